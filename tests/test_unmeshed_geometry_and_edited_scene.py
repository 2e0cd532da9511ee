"""What a researcher meets when a geometry of their own does not mesh, or a restart meets a
scene that was changed: bad input ends as exit 2 (BadInputError) with one line that names
the file and says what is wrong, never as a run of another body."""

from __future__ import annotations

import pytest

from test_reliability import ENTRIES, EXIT_BAD_INPUT, one_line, run

#: A quadrilateral whose boundary crosses itself (the edge 3-4 cuts the edge 1-2): gmsh
#: cannot mesh the surface. It would retry for minutes with its default Mesh.MaxRetries;
#: 0 makes it give up at once, leaving the surface without triangles.
CROSSED_GEO = """\
Point(1) = {0, 0, 0, 0.1}; Point(2) = {1, 0, 0, 0.1};
Point(3) = {1, 1, 0, 0.1}; Point(4) = {0.5, -1, 0, 0.1};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4}; Plane Surface(1) = {1};
Physical Surface("body") = {1}; Physical Curve("bottom") = {1};
Mesh.MaxRetries = 0;
"""

SCENE = ("&mesh file = '{mesh}' /\n&boundary clamped = '' /\n"
         "&initial kind = 'rest' /\n&scheme t_end = 0.01 /\n")


@pytest.mark.parametrize("kind", ENTRIES)
def test_a_surface_gmsh_cannot_mesh_is_refused_naming_it(tmp_path, kind):
    """The surface left without triangles was taken for a 1D mesh of its curves, and the
    run said that the contact group 'bottom' has no facets, 'the facets of a 1D mesh are
    points': nothing about the surface that failed."""
    (tmp_path / "crossed.geo").write_text(CROSSED_GEO)
    (tmp_path / "s.nml").write_text(SCENE.format(mesh="crossed.geo"))
    res = run(kind, "s.nml", "--out", "o", cwd=tmp_path)
    line = one_line(res, EXIT_BAD_INPUT)
    assert "s.nml: &mesh file: crossed.geo: surface 1 of physical group 'body' has no " \
           "3-node triangles: gmsh could not mesh it" in line, line
    assert "Mesh.MaxRetries" in line
    assert not (tmp_path / "o").exists()


def test_a_msh_saved_below_its_groups_dimension_is_refused(tmp_path):
    """A .msh of a 2D geometry saved with its curves only (gmsh -1): a Physical Surface
    without triangles, refused naming it, not run as a 1D bar."""
    import dyncontact
    import gmsh

    (tmp_path / "quad.geo").write_text(
        CROSSED_GEO.replace("{0.5, -1, 0, 0.1}", "{0, 1, 0, 0.1}"))
    gmsh.initialize(["-v", "0"])
    try:
        gmsh.open(str(tmp_path / "quad.geo"))
        gmsh.model.mesh.generate(1)
        gmsh.write(str(tmp_path / "quad.msh"))
    finally:
        gmsh.finalize()
    scene = dyncontact.Scene()
    scene.set("mesh.file", str(tmp_path / "quad.msh"))
    with pytest.raises(dyncontact.BadInputError) as err:
        scene.dimension()
    assert "quad.msh: surface 1 of physical group 'body' has no 3-node triangles in the " \
           "file (saved with gmsh -1 instead of -2" in str(err.value)


def test_mesh_command_refuses_a_surface_it_cannot_mesh_and_writes_nothing(tmp_path,
                                                                           run_cli):
    """`dyncontact mesh --geo` wrote the curves as a 1D mesh and reported success."""
    (tmp_path / "crossed.geo").write_text(CROSSED_GEO)
    res = run_cli("mesh", "--geo", "crossed.geo", "--out", "crossed.msh", cwd=tmp_path)
    assert res.returncode == EXIT_BAD_INPUT, res.stderr
    assert res.stderr.strip().startswith(
        "dyncontact mesh: crossed.geo: surface 1 of physical group 'body' has no 3-node "
        "triangles: gmsh could not mesh it"), res.stderr
    assert not (tmp_path / "crossed.msh").exists()


def test_the_mesh_command_says_the_cores_words_for_a_surface_it_cannot_mesh(tmp_path,
                                                                          monkeypatch):
    """mesh_io meshes a .geo with gmsh's Python module and finds the surface left without
    triangles itself, but its line is the core's (the reader's, gmsh_shim.c), not a copy
    of it in Python: the same line as a run's refusal of the same .geo."""
    import types

    import dyncontact.core as core
    from dyncontact import BadInputError
    from dyncontact.mesh_io import generate

    geo = tmp_path / "crossed.geo"
    geo.write_text(CROSSED_GEO)
    with pytest.raises(BadInputError) as read:
        core.load_mesh(geo)
    with pytest.raises(BadInputError) as meshed:
        generate(geo, tmp_path / "crossed.msh")
    assert str(meshed.value) == str(read.value)
    assert str(meshed.value).startswith(f"{geo}: surface 1 of physical group 'body' has no "
                                        "3-node triangles: gmsh could not mesh it")
    # the words come from the core: a core that says others is followed
    real = core._core()
    fake = types.SimpleNamespace(
        dc_unmeshed_text=lambda d, tag, group: f"entity {d} {tag} of {group.decode()}: core",
        **{k: getattr(real, k) for k in dir(real) if k.startswith("dc_")
           and k != "dc_unmeshed_text"})
    monkeypatch.setattr(core, "_core", lambda: fake)
    with pytest.raises(BadInputError) as meshed:
        generate(geo, tmp_path / "crossed.msh")
    assert str(meshed.value) == f"{geo}: entity 2 1 of body: core"
    assert not (tmp_path / "crossed.msh").exists()


RESTART = ("&scheme t_end = 0.05 /\n&output checkpoint_every = 10 /\n"
           "&contact theta = {theta}, obstacle_point = 0.0, {gap} /\n")


@pytest.mark.parametrize("kind", ENTRIES)
def test_a_restart_after_the_scene_was_edited_names_the_keys_that_changed(tmp_path, kind):
    """A restart with an edited scene was refused as 'written by another scene or mesh',
    which named no key: the user had to find by hand what they had changed."""
    (tmp_path / "s.nml").write_text(RESTART.format(theta=1, gap=0.0))
    assert run(kind, "s.nml", "--out", "o", cwd=tmp_path).returncode == 0
    # t_end may change at a restart (not named); theta and the obstacle may not
    (tmp_path / "s.nml").write_text(RESTART.format(theta=0, gap=-0.01).replace(
        "0.05", "0.1"))
    line = one_line(run(kind, "s.nml", "--restart", "o", cwd=tmp_path), EXIT_BAD_INPUT)
    assert line.startswith("dyncontact: o/checkpoint.bin: written by another scene: "
                           "&contact theta: 0 here, 1 there; &contact obstacle_point: "
                           "[0.0E+000, -1.0E-002] here, [0.0E+000, 0.0E+000] there "
                           "(in o/summary.json, the scene of the run that wrote it;"), line
    assert "t_end" not in line


def test_a_restart_after_the_mesh_file_was_edited_keeps_the_general_refusal(tmp_path):
    """Where no key differs (the mesh file's nodes moved), the refusal says the scene or
    the mesh differs, as before, and names no key."""
    import dyncontact
    from dyncontact.mesh_io import generate_bar

    generate_bar(0.05, tmp_path / "m.msh")
    text = ("&mesh file = 'm.msh' /\n&initial kind = 'compressed_bar' /\n"
            "&scheme t_end = 0.05 /\n&output checkpoint_every = 10 /\n")
    (tmp_path / "s.nml").write_text(text)
    assert dyncontact.run(tmp_path / "s.nml", out=tmp_path / "o",
                          progress=False).status == "ok"
    msh = (tmp_path / "m.msh").read_text()
    (tmp_path / "m.msh").write_text(msh.replace("\n0.1 1 0\n", "\n0.1 1.001 0\n", 1))
    assert (tmp_path / "m.msh").read_text() != msh
    with pytest.raises(dyncontact.BadInputError) as err:
        dyncontact.run(tmp_path / "s.nml", restart=tmp_path / "o", progress=False)
    assert "written by another scene or mesh (the parsed scene or the mesh differs" \
        in str(err.value)
