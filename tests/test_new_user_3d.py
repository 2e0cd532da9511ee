"""What a researcher bringing a 3D problem of their own meets, through the executable, the
Python CLI and the API: each bad input ends as exit 2 (BadInputError) with one line naming
the file and the key, each numerical failure as exit 3 with the trace kept and a message
that says what to change. The 2D cases are in test_new_user.py."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

from test_reliability import ENTRIES, EXIT_BAD_INPUT, EXIT_OK, one_line, run

EXIT_NUMERIC = 3

#: The built-in 3D box, 0.3 high (h = 0.05: 144 tetrahedra), lifted by 0.05 at its
#: bottom; central differences with the step of each test.
BOX = ("&mesh dim = 3, length = 0.3, h = 0.05 /\n"
       "&initial kind = 'compressed_bar', amplitude = 0.05 /\n"
       "&scheme name = '{scheme}', dt = {dt!r}, t_end = 1.0 /\n")


def box_scene(path: Path, scheme: str, dt: float) -> Path:
    path.write_text(BOX.format(scheme=scheme, dt=dt))
    return path


@pytest.fixture(scope="module")
def box_dt_crit(tmp_path_factory) -> float:
    """central's own estimate of its critical step on the box (summary.json's
    dt_crit_estimate of a run with dt = 0, which runs at 0.9 x it)."""
    import dyncontact
    folder = tmp_path_factory.mktemp("dtcrit")
    res = dyncontact.run(box_scene(folder / "s.nml", "central", 0.0), out=folder / "o",
                         progress=False)
    assert res.status == "ok"
    return float(res.summary["dt_crit_estimate"])


@pytest.mark.parametrize("kind", ENTRIES)
def test_central_above_its_critical_step_warns_and_says_why_it_blew_up(kind, box_dt_crit,
                                                                      tmp_path):
    """central at 3 x its critical step estimate: a warning before the run names
    &scheme dt, the ratio and the estimate; the run stops as unstable (exit 3, the trace
    kept) and its message says that the step is above the estimate and what to give.
    Without both, a newcomer saw only 'e_total exceeds blowup x e_total(0)'."""
    dt = 3.0 * box_dt_crit
    scene = box_scene(tmp_path / "s.nml", "central", dt)
    res = run(kind, scene, "--out", tmp_path / "o", cwd=tmp_path)
    assert res.returncode == EXIT_NUMERIC, res.stderr
    lines = [ln for ln in res.stderr.splitlines() if ln.startswith("dyncontact: ")]
    warn = [ln for ln in lines if "warning:" in ln]
    assert len(warn) == 1 and "&scheme dt = " in warn[0], res.stderr
    assert " is 3.00 x the critical step of central differences, estimated " \
        f"{box_dt_crit:.3E}" .replace("E-0", "E-00") in warn[0], warn[0]
    stop = [ln for ln in lines if "unstable at t = " in ln]
    assert len(stop) == 1, res.stderr
    assert stop[0].endswith(" (run stopped, trace kept); central is explicit, stable only "
                            f"below a critical step, estimated {box_dt_crit:.3E} at full "
                            f"contact (&scheme dt = {dt:.3E}): try a smaller &scheme dt, "
                            "or dt = 0".replace("E-0", "E-00")), stop[0]
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summary["status"] == "unstable"
    assert summary["message"] in stop[0]          # the same line in summary.json
    assert len((tmp_path / "o" / "trace.csv").read_text().splitlines()) > 2   # kept


def test_central_below_its_critical_step_says_nothing(box_dt_crit, tmp_path):
    """At 0.8 x the estimate the box runs to its end without a word about the step."""
    import dyncontact
    scene = box_scene(tmp_path / "s.nml", "central", 0.8 * box_dt_crit)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        res = dyncontact.run(scene, out=tmp_path / "o", progress=False)
    assert res.status == "ok"


def test_pc_unstable_says_it_is_explicit(box_dt_crit, tmp_path):
    """pc at 3 x central's estimate, 4.24 x its own (sqrt(2) / omega_max, the same
    omega_max): a warning before the run, and the unstable message says that pc is
    explicit and gives its estimate; through the API the run returns with status
    'unstable' and that message."""
    import dyncontact
    from dyncontact.core import DyncontactWarning
    dt = 3.0 * box_dt_crit
    with pytest.warns(DyncontactWarning, match=" is 4.24 x the critical step of pc, "):
        res = dyncontact.run(box_scene(tmp_path / "s.nml", "pc", dt), out=tmp_path / "o",
                             progress=False)
    assert res.status == "unstable"
    est = res.summary["dt_crit_estimate"]
    assert est == pytest.approx(box_dt_crit / 2 ** 0.5, rel=1e-12)
    assert res.summary["message"].endswith(
        f"; pc is explicit, stable only below a critical step, estimated {est:.3E} at full "
        f"contact (&scheme dt = {dt:.3E}): try a smaller &scheme dt".replace("E-0", "E-00"))


def test_implicit_runs_get_no_explicit_hint(tmp_path):
    """An implicit run that exits 0 says nothing about steps; a scene's exit codes are
    unchanged (the hint is in the message only)."""
    scene = box_scene(tmp_path / "s.nml", "newmark", 0.02)
    res = run("exe", scene, "--out", tmp_path / "o", cwd=tmp_path)
    assert res.returncode == EXIT_OK, res.stderr
    assert "critical step" not in res.stderr


GETFEM_BOX = Path(__file__).resolve().parents[1] / "meshes" / "bar3d_getfem_h0.05.msh"


@pytest.mark.parametrize("key, value, message", [
    ("initial.velocity", [0.0, -0.1],
     "&initial velocity: expected 3 values in 3D (got '0.0, -0.1')"),
    ("contact.quad_points", 5,
     "&contact quad_points: must be 1, 3, 6 or 7 in 3D"),
])
def test_validate_checks_a_mesh_files_dimension_as_the_run_does(key, value, message,
                                                                tmp_path):
    """A scene for a 3D mesh file that leaves &mesh dim to the file (dim = 0), given a
    2-component vector (the 2D habit) or a 2D Gauss rule: Scene.validate() passed it and
    only the run refused it. validate now reads the file's dimension and refuses it with
    the run's own message."""
    import dyncontact
    pytest.importorskip("gmsh")
    (tmp_path / "s.nml").write_text(
        f"&mesh file = '{GETFEM_BOX}' /\n&initial kind = 'velocity', velocity = 0, 0, -0.1 /\n"
        "&contact quadrature = 'gauss' /\n&scheme t_end = 0.01 /\n")
    scene = dyncontact.Scene.read(tmp_path / "s.nml")
    scene.validate()                                   # as written: 3D vectors
    scene.set(key, value)
    with pytest.raises(dyncontact.BadInputError) as validated:
        scene.validate()
    with pytest.raises(dyncontact.BadInputError) as ran:
        dyncontact.run(scene, out=tmp_path / "o", progress=False)
    assert message in str(validated.value)
    assert str(validated.value).split(": ", 1)[1] == str(ran.value).split(": ", 1)[1]


@pytest.mark.parametrize("geo_tail, what", [
    ("Mesh.ElementOrder = 2;\n", "is not a linear simplex"),
    ("Physical Surface(\"sole\") = {5\n", "gmsh cannot read it"),
])
def test_validate_names_the_scene_and_key_of_a_mesh_it_cannot_read(geo_tail, what,
                                                                   tmp_path):
    """Scene.validate (and Scene.get of a vector left to the file's dimension) of a scene
    whose .geo is meshed at second order or has a syntax error: one line naming the
    scene and &mesh file, as the run's message does; it said only 'block.geo: ...'."""
    import dyncontact
    pytest.importorskip("gmsh")
    scene = block_scene(tmp_path, "block.geo", geo=BLOCK_GEO + geo_tail)
    scn = dyncontact.Scene.read(scene)
    with pytest.raises(dyncontact.BadInputError) as validated:
        scn.validate()
    with pytest.raises(dyncontact.BadInputError) as ran:
        dyncontact.run(scn, out=tmp_path / "o", progress=False)
    message = str(validated.value)
    assert "\n" not in message and what in message, message
    assert message.startswith(f"{scn._name()}: &mesh file: "), message
    assert str(ran.value).startswith(f"{scn._name()}: &mesh file: "), ran.value
    with pytest.raises(dyncontact.BadInputError, match=r": &mesh file: "):
        dyncontact.Scene.read(scene).get("material.gravity")   # left out: the file's dim


#: A block of one's own (OpenCASCADE), 0.01 above the plane z = 0, with groups of every
#: dimension under names of one's own: the sole (the contact boundary), an edge and a
#: corner of it, the brick.
BLOCK_GEO = ('SetFactory("OpenCASCADE");\n'
             "Box(1) = {0, 0, 0.01, 0.2, 0.1, 0.1};\n"
             "Mesh.MeshSizeMax = 0.05;\n"
             'Physical Surface("sole") = {5};\nPhysical Curve("edge") = {1};\n'
             'Physical Point("corner") = {1};\nPhysical Volume("brick") = {1};\n')

BLOCK_SCENE = ("&mesh file = '{mesh}' /\n&boundary clamped = {clamped}, contact = 'sole' /\n"
               "&material young = 1.0, poisson = 0.3 /\n"
               "&contact obstacle_point = 0, 0, 0, obstacle_normal = 0, 0, -1,\n"
               "         probe = 0.1, 0.05, 0.01 /\n"
               "&initial kind = 'velocity', velocity = 0, 0, -0.1 /\n"
               "&scheme name = 'newmark', dt = 0.01, t_end = 0.05 /\n")


def block_scene(folder: Path, mesh: str, clamped: str = "''", geo: str = BLOCK_GEO) -> Path:
    (folder / "block.geo").write_text(geo)
    scene = folder / "s.nml"
    scene.write_text(BLOCK_SCENE.format(mesh=mesh, clamped=clamped))
    return scene


def test_the_block_of_ones_own_runs(tmp_path):
    """The block as written runs (its point and curve groups are read and left alone)."""
    pytest.importorskip("gmsh")
    res = run("exe", block_scene(tmp_path, "block.geo"), "--out", tmp_path / "o",
              cwd=tmp_path)
    assert res.returncode == EXIT_OK, res.stderr


@pytest.mark.parametrize("kind", ENTRIES)
@pytest.mark.parametrize("group", ["edge", "corner"])
def test_clamped_group_of_a_lower_dimension_clamps_its_nodes(kind, group, tmp_path):
    """clamped = a curve or a point group of the 3D block: runs (exit 0) and holds
    exactly the group's nodes (curve 1: the nodes on x = y = 0; point 1: the node at
    (0, 0, 0.11), OpenCASCADE's first corner of the box), every other node keeping its three dofs. It was refused ('has no
    facets or cells in the mesh'); more in test_lower_groups.py."""
    pytest.importorskip("gmsh")
    from dyncontact import mesh_io
    from dyncontact.core import Model

    scene = block_scene(tmp_path, "block.geo", f"'{group}'")
    res = run(kind, scene.name, "--out", "o", cwd=tmp_path)
    assert res.returncode == EXIT_OK, res.stderr
    x = mesh_io.read_mesh(tmp_path / "block.geo").x
    on_edge = (np.abs(x[:, 0]) < 1e-12) & (np.abs(x[:, 1]) < 1e-12)
    held = on_edge & (np.abs(x[:, 2] - 0.11) < 1e-12) if group == "corner" else on_edge
    assert held.sum() == 1 if group == "corner" else held.sum() >= 2
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with Model(scene) as m:
            node, _ = m.dof_map()
    assert np.array_equal(np.unique(node), np.flatnonzero(~held))
    assert len(node) == 3 * (~held).sum()


def test_second_order_3d_mesh_names_its_elements(tmp_path):
    """A 3D .geo meshed at second order: refused (exit 2, one line naming the file and
    &mesh file) with the element's name (a 6-node triangle is a triangle: 'only triangles
    are supported' did not say what was wrong; here the curve group's 3-node segments come
    first) and what to change."""
    pytest.importorskip("gmsh")
    scene = block_scene(tmp_path, "block.geo", geo=BLOCK_GEO + "Mesh.ElementOrder = 2;\n")
    line = one_line(run("exe", scene.name, "--out", "o", cwd=tmp_path), EXIT_BAD_INPUT)
    assert line.startswith("dyncontact: s.nml: &mesh file: block.geo: element type ")
    # the first second-order element met: the curve group's, a facet's or a cell's
    assert any(f"(a {p2}, dimension {d}) is not a linear simplex; only {p1} are supported "
               f"in dimension {d}" in line
               for p2, p1, d in (("3-node segment", "2-node segments", 1),
                                 ("6-node triangle", "3-node triangles", 2),
                                 ("10-node tetrahedron", "4-node tetrahedra", 3))), line
    assert line.endswith("(a higher-order element: mesh with Mesh.ElementOrder = 1)")


def test_3d_geometry_meshed_in_2d_says_so(tmp_path):
    """The block meshed with gmsh -2 (its surfaces only) and saved: refused (exit 2)
    naming its Physical Volume, which has no tetrahedra, and the likely cause, a 2D
    meshing."""
    pytest.importorskip("gmsh")
    from conftest import gmsh_session, write_msh41

    (tmp_path / "block.geo").write_text(BLOCK_GEO)
    with gmsh_session("block") as gmsh:
        gmsh.open(str(tmp_path / "block.geo"))
        gmsh.model.mesh.generate(2)
        write_msh41(gmsh, tmp_path / "surface.msh")
    scene = block_scene(tmp_path, "surface.msh")
    line = one_line(run("exe", scene.name, "--out", "o", cwd=tmp_path), EXIT_BAD_INPUT)
    assert line == ("dyncontact: s.nml: &mesh file: surface.msh: volume 1 of physical "
                    "group 'brick' has no 4-node tetrahedra in the file (saved with gmsh -2 "
                    "instead of -3, or a volume gmsh could not mesh)")


#: A cube of side 1 whose .geo sizes its own mesh (Mesh.MeshSizeMax = 0.5) and uses no h:
#: what a CAD export in its own units looks like.
OWN_SIZE_GEO = ('SetFactory("OpenCASCADE");\nBox(1) = {0, 0, 0.01, 1, 1, 1};\n'
                "Mesh.MeshSizeMax = 0.5;\n"
                'Physical Surface("sole") = {5};\nPhysical Volume("cube") = {1};\n')


def own_size_cells(geo: Path, size_max: float | None = None) -> int:
    """Tetrahedra of gmsh's own meshing of the file (with size_max imposed after the
    file is read, as `-clmax` would)."""
    from conftest import gmsh_session

    with gmsh_session("own") as gmsh:
        gmsh.open(str(geo))
        if size_max is not None:
            gmsh.option.setNumber("Mesh.MeshSizeMax", size_max)
        gmsh.model.mesh.generate(3)
        return sum(len(t) for t in gmsh.model.mesh.getElements(3)[1])


@pytest.mark.parametrize("given_h", [None, 0.25])
def test_geo_without_h_keeps_its_own_sizes_unless_the_scene_gives_h(given_h, tmp_path):
    """A .geo that sizes its own mesh and uses no h, run by a scene that gives no &mesh h:
    the run, Scene.dimension/validate and `dyncontact mesh` (no --h) mesh it with the
    file's own sizes. They imposed the built-in bar's default h = 0.05 as the largest
    size: a body drawn in mm (a cylinder of radius 100) got some 10^11 tetrahedra and the
    run never came back from gmsh. A scene that gives h still sizes it (0.25 here)."""
    import subprocess
    import sys

    import dyncontact
    pytest.importorskip("gmsh")
    geo = tmp_path / "cube.geo"
    geo.write_text(OWN_SIZE_GEO)
    cells = own_size_cells(geo, given_h)
    assert cells < 3000                      # 0.05 gives about 50 000
    h_line = "" if given_h is None else f"&mesh h = {given_h} /\n"
    scene = tmp_path / "s.nml"
    scene.write_text(f"&mesh file = 'cube.geo' /\n{h_line}"
                     "&boundary clamped = '', contact = 'sole' /\n"
                     "&contact obstacle_point = 0, 0, 0, obstacle_normal = 0, 0, -1,\n"
                     "         probe = 0.5, 0.5, 0.01 /\n"
                     "&initial kind = 'velocity', velocity = 0, 0, -0.1 /\n"
                     "&scheme name = 'newmark', dt = 0.01, t_end = 0.02 /\n"
                     .replace(f"&mesh file = 'cube.geo' /\n&mesh h = {given_h} /",
                              f"&mesh file = 'cube.geo', h = {given_h} /"))
    res = dyncontact.run(scene, out=tmp_path / "o", progress=False)
    assert res.status == "ok" and res.summary["elements"] == cells
    scn = dyncontact.Scene.read(scene)
    scn.validate()
    assert scn.dimension() == 3
    if given_h is None:
        out = tmp_path / "cube.msh"
        cli = subprocess.run([sys.executable, "-m", "dyncontact", "mesh", "--geo", str(geo),
                              "--out", str(out)], capture_output=True, text=True, timeout=60)
        assert cli.returncode == 0, cli.stderr
        assert f" {cells} tetrahedra;" in cli.stdout + cli.stderr
