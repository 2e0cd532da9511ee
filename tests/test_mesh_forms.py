"""Mesh files through gmsh's API: one mesh in every form gmsh writes (msh 2.2 ASCII,
4.1 ASCII, 4.1 binary) and named as its .geo gives the same mesh, and in 2D the same
trace; bad mesh files stop with exit 2 naming the file; gmsh is loaded only when a mesh
file is named, and leaves no state behind in the Python process.

Meshes: the 2D bar of meshes/bar2d.geo, the 2D disk of meshes/disk.geo, the 3D box of
GetFEM (meshes/bar3d_getfem_h0.05.msh) and a small 3D box .geo
(tests/data/meshes/box3d.geo); 3D is checked at the reader level (check=False), since
the model takes 2D meshes.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import callers_gmsh_session, stderr_line
from dyncontact import Scene, core, mesh_io
from dyncontact.core import BadInputError

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data" / "meshes"
ROOT_MESHES = ROOT / "meshes"

#: msh forms gmsh writes: name -> (version, binary)
FORMS = {"msh22": (2.2, False), "msh41": (4.1, False), "msh41bin": (4.1, True)}

#: .geo sources: name -> (file, parameters)
GEOS = {
    "bar": (ROOT / "meshes" / "bar2d.geo", dict(h=0.05, length=1.0, width=0.1)),
    "disk": (ROOT / "meshes" / "disk.geo", dict(h=0.02, length=1.0, width=0.1)),
    "box3d": (DATA / "box3d.geo", dict(h=0.05, length=0.3, width=0.1)),
}


def rewrite(src: Path, out: Path, version: float, binary: bool) -> Path:
    """The mesh file `src` written by gmsh in another form."""
    with mesh_io._gmsh_session("rewrite") as gmsh:
        gmsh.merge(str(src))
        gmsh.option.setNumber("Mesh.MshFileVersion", version)
        gmsh.option.setNumber("Mesh.Binary", int(binary))
        gmsh.write(str(out))
    return out


def same_mesh(a: mesh_io.MeshData, b: mesh_io.MeshData, what: str) -> None:
    """Same numbering, cells, facets and groups; coordinates to one rounding (an ASCII
    file holds 16 significant digits of the in-process mesh's doubles)."""
    assert (a.dim, a.group_names) == (b.dim, b.group_names), what
    np.testing.assert_array_equal(a.group_dim, b.group_dim, err_msg=what)
    scale = np.abs(a.x).max()
    np.testing.assert_allclose(a.x, b.x, rtol=0, atol=4 * np.finfo(float).eps * scale,
                               err_msg=what)
    for k in ("cells", "cell_group", "facets", "facet_group"):
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k), err_msg=f"{what}: {k}")


@pytest.fixture(scope="module")
def forms(tmp_path_factory):
    """name -> {form: path}: every .geo written by gmsh in each form, plus the .geo."""
    d = tmp_path_factory.mktemp("forms")
    out = {}
    for name, (geo, par) in GEOS.items():
        out[name] = {"geo": geo}
        for form, (version, binary) in FORMS.items():
            out[name][form] = mesh_io.generate(geo, d / f"{name}_{form}.msh", binary=binary,
                                               version=version, **par)
    ref3d = ROOT_MESHES / "bar3d_getfem_h0.05.msh"
    out["getfem3d"] = {"orig": ref3d}
    for form, (version, binary) in FORMS.items():
        out["getfem3d"][form] = rewrite(ref3d, d / f"getfem3d_{form}.msh", version, binary)
    return out


@pytest.mark.parametrize("name", ["bar", "disk", "box3d", "getfem3d"])
def test_every_form_same_mesh(core_ext, forms, name):
    par = GEOS.get(name, (None, {}))[1]
    meshes = {f: mesh_io.read_mesh(p, check=False, **par) for f, p in forms[name].items()}
    first = next(iter(meshes))
    for f, m in meshes.items():
        same_mesh(m, meshes[first], f"{name}: {f} vs {first}")
    m = meshes[first]
    assert m.dim == (3 if "3d" in name else 2)
    assert len(m.cells) > 0 and len(m.facets) > 0
    if m.dim == 3:
        assert m.cells.shape[1] == 4 and m.facets.shape[1] == 3
        assert m.group_names == ["bottom", "top", "sides", "body"]
        # the facets of `bottom` lie on z = 0
        bottom = m.facets[m.facet_group == m.group("bottom")]
        assert np.all(m.x[bottom, 2] == 0.0)


def test_getfem3d_read_as_file(core_ext):
    """The GetFEM box (documented sizes: 2 x 2 x 20 cubes of 6 tetrahedra, 3 x 3 x 21
    nodes) with its groups; the tetrahedra have both orientations and none is flat."""
    m = mesh_io.read_mesh(ROOT_MESHES / "bar3d_getfem_h0.05.msh", check=False)
    assert (m.dim, len(m.x), len(m.cells)) == (3, 3 * 3 * 21, 2 * 2 * 20 * 6)
    # facets: bottom and top 2 x 2 x 2 triangles, sides 4 x 2 x 20 x 2
    counts = np.bincount(m.facet_group, minlength=4)
    assert list(counts[:3]) == [8, 8, 320]
    e = m.x[m.cells[:, 1:]] - m.x[m.cells[:, :1]]
    vol = np.linalg.det(e) / 6
    assert np.all(np.abs(vol) > 0)
    assert np.any(vol > 0) and np.any(vol < 0)     # kept in GetFEM's node order
    np.testing.assert_allclose(np.abs(vol).sum(), 0.1 * 0.1 * 1.0, rtol=1e-12)


def test_geo_parameters_and_default_size(core_ext, tmp_path):
    """h, length, width reach the .geo's variables of those names; a .geo that uses no h
    is meshed with h as the largest mesh size."""
    bar = mesh_io.read_mesh(ROOT / "meshes" / "bar2d.geo", h=0.1, length=2.0, width=0.2)
    assert len(bar.cells) == 2 * 2 * 20
    np.testing.assert_allclose(bar.x.max(axis=0), [0.2, 2.0])
    geo = tmp_path / "square.geo"
    geo.write_text('Point(1) = {0, 0, 0}; Point(2) = {1, 0, 0}; Point(3) = {1, 1, 0};\n'
                   'Point(4) = {0, 1, 0}; Line(1) = {1, 2}; Line(2) = {2, 3};\n'
                   'Line(3) = {3, 4}; Line(4) = {4, 1}; Curve Loop(1) = {1, 2, 3, 4};\n'
                   'Plane Surface(1) = {1};\n')
    for h in (0.1, 0.05):       # both below gmsh's default size (1/10 of the diagonal)
        m = mesh_io.read_mesh(geo, h=h)
        edges = np.concatenate([m.cells[:, [0, 1]], m.cells[:, [1, 2]], m.cells[:, [2, 0]]])
        longest = np.linalg.norm(m.x[edges[:, 0]] - m.x[edges[:, 1]], axis=1).max()
        assert longest <= 1.5 * h, (h, longest)
        assert m.group_names == [] and np.all(m.cell_group == -1)
    assert len(mesh_io.read_mesh(geo, h=0.05).cells) > 3 * len(mesh_io.read_mesh(geo, h=0.1).cells)


#: A triangle whose point sizes use h without defining it (no DefineConstant), as a .geo
#: written for `gmsh -setnumber h 0.02` does; two statements on the first line, so that
#: the rest of the line follows the first use of h.
BARE_H_GEO = ("Point(1) = {-0.1, 0, 0, 2 * h}; Point(2) = {0.1, 0, 0, h};\n"
              "Point(3) = {0, 0.1, 0, h}; Line(1) = {1, 2}; Line(2) = {2, 3};\n"
              "Line(3) = {3, 1}; Curve Loop(1) = {1, 2, 3}; Plane Surface(1) = {1};\n"
              'Physical Curve("outline") = {1, 2, 3}; Physical Surface("body") = {1};\n')


def test_geo_using_h_without_defining_it(core_ext, run_cli, tmp_path):
    """A .geo that uses h as gmsh -setnumber sets it, without DefineConstant: the run's
    reader, read_mesh and `dyncontact mesh` mesh it with the scene's h, as the same file
    with h defined in it (DefineConstant, the form of meshes/*.geo). With gmsh's
    default, a first parse without h stops at its first 'Unknown variable' and leaves the rest of the file in
    gmsh's lexer, so a later parse with h would fail ("line 0: syntax error (;)"): the
    reader's first parse runs to the end of the file (AbortOnError 0)."""
    bare = tmp_path / "bare.geo"
    bare.write_text(BARE_H_GEO)
    defined = tmp_path / "defined.geo"
    defined.write_text('DefineConstant[ h = {0.5, Name "Parameters/h"} ];\n' + BARE_H_GEO)
    ref = mesh_io.read_mesh(defined, h=0.02)
    assert len(ref.cells) > 20              # h = 0.02 reached the file, not 0.5
    same_mesh(mesh_io.read_mesh(bare, h=0.02), ref, "read_mesh")
    r = run_cli("mesh", "--geo", bare, "--h", "0.02", "--out", "bare.msh", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    same_mesh(mesh_io.read_mesh(tmp_path / "bare.msh"), ref, "mesh command")
    scene = tmp_path / "bare.nml"
    scene.write_text("&mesh file = 'bare.geo', h = 0.02 /\n"
                     "&boundary clamped = '', contact = 'outline' /\n"
                     "&contact probe = 0.0, 0.0 /\n&initial kind = 'rest' /\n"
                     "&scheme t_end = 0.01 /\n")
    res = core.run(scene, out=tmp_path / "out", progress=False)
    assert res.status == "ok" and res.summary["elements"] == len(ref.cells)


def test_geo_defining_h_keeps_its_own_h_unless_the_scene_gives_one(core_ext, run_cli,
                                                                  tmp_path):
    """A .geo that defines h (DefineConstant[h = {0.02, ...}]) is meshed with its own
    h where the scene gives no &mesh h, as gmsh without -setnumber h meshes it (not with
    the built-in bar's default 0.05), and with the scene's h where it gives one: in a
    run, Scene.dimension()/validate(), the size estimate before meshing,
    `dyncontact mesh --geo` without --h and mesh_io.read_mesh without h. A .geo that uses h without defining it gets the
    default 0.05."""
    geo = tmp_path / "tri.geo"
    geo.write_text('DefineConstant[ h = {0.02, Name "Parameters/h"} ];\n' + BARE_H_GEO)
    bare = tmp_path / "bare.geo"
    bare.write_text(BARE_H_GEO)
    own = mesh_io.read_mesh(geo, h=0.02)
    other = mesh_io.read_mesh(geo, h=0.05)
    assert len(own.cells) > 2 * len(other.cells)
    same_mesh(mesh_io.read_mesh(geo), own, "read_mesh without h")
    same_mesh(mesh_io.read_mesh(bare), other, "read_mesh without h, h not defined")
    no_h = ("length", "width")
    assert core.estimate_geo(geo, h=0.05, given=no_h) == core.estimate_geo(geo, h=0.02)
    assert core.estimate_geo(bare, h=0.05, given=no_h) == core.estimate_geo(bare, h=0.05)
    r = run_cli("mesh", "--geo", geo, "--out", "own.msh", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    same_mesh(mesh_io.read_mesh(tmp_path / "own.msh"), own, "mesh command without --h")
    r = run_cli("mesh", "--geo", bare, "--out", "bare.msh", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    same_mesh(mesh_io.read_mesh(tmp_path / "bare.msh"), mesh_io.read_mesh(bare, h=0.05),
              "mesh command without --h, h not defined")
    text = ("&mesh file = '{geo}'{h}, max_elements = {limit} /\n"
            "&boundary clamped = '', contact = 'outline' /\n"
            "&contact probe = 0.0, 0.0 /\n&initial kind = 'rest' /\n"
            "&scheme t_end = 0.01 /\n")
    for name, h, want in (("tri.geo", "", own), ("tri.geo", ", h = 0.05", other),
                          ("bare.geo", "", other)):
        scene = tmp_path / "s.nml"
        scene.write_text(text.format(geo=name, h=h, limit=2000000))
        Scene.read(scene).validate()
        res = core.run(scene, out=tmp_path / "out", progress=False)
        assert res.status == "ok" and res.summary["elements"] == len(want.cells), (name, h)
    # the refusal of a too-large .geo estimates it at its own h too
    est = core.estimate_geo(geo, h=0.02)["estimate"]
    limit = int(est / core.estimate_geo(geo, h=0.02)["margin"]) - 1
    scene.write_text(text.format(geo="tri.geo", h="", limit=limit))
    with pytest.raises(BadInputError, match="max_elements"):
        Scene.read(scene).validate()
    scene.write_text(text.format(geo="tri.geo", h=", h = 0.05", limit=limit))
    Scene.read(scene).validate()


#: A rectangle [0, width] x [0, length] of size h (used, not defined: 0.05 by default).
RECT_GEO = ("Point(1) = {0, 0, 0, h}; Point(2) = {width, 0, 0, h};\n"
            "Point(3) = {width, length, 0, h}; Point(4) = {0, length, 0, h};\n"
            "Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};\n"
            "Curve Loop(1) = {1, 2, 3, 4}; Plane Surface(1) = {1};\n"
            'Physical Curve("bottom") = {1}; Physical Surface("body") = {1};\n')


def test_geo_defining_length_and_width_keeps_its_own_unless_the_scene_gives_them(
        core_ext, run_cli, tmp_path):
    """A .geo that defines length and width (DefineConstant, as meshes/ball.geo's width
    = 0.2 and meshes/ball_pole.geo's length = 0.06) keeps its own values where the scene
    gives no &mesh length and width, as h does, and takes the scene's where it gives
    them; one that uses them without defining them gets the defaults 1.0 and 0.1: in a
    run, Scene.dimension()/validate() and the refusal of a too-large .geo, the size
    estimate, `dyncontact mesh --geo` without --length/--width, mesh_io.read_mesh without
    length/width, and the studies' reading of a scene. Setting them always would override
    the file's own values with the defaults."""
    from dyncontact.study.common import read_user_scene

    geo = tmp_path / "rect.geo"
    geo.write_text('DefineConstant[ length = {0.3, Name "Parameters/length"},\n'
                   '                width = {0.2, Name "Parameters/width"} ];\n' + RECT_GEO)
    bare = tmp_path / "bare.geo"
    bare.write_text(RECT_GEO)
    own = mesh_io.read_mesh(geo)
    np.testing.assert_allclose(own.x.max(axis=0), [0.2, 0.3], rtol=1e-12)
    given = mesh_io.read_mesh(geo, length=1.0, width=0.1)
    np.testing.assert_allclose(given.x.max(axis=0), [0.1, 1.0], rtol=1e-12)
    np.testing.assert_allclose(mesh_io.read_mesh(geo, width=0.1).x.max(axis=0), [0.1, 0.3],
                               rtol=1e-12)
    same_mesh(mesh_io.read_mesh(bare), given, "read_mesh, length and width not defined")
    assert len(own.cells) != len(given.cells)
    # the estimate: the rectangle's area
    assert core.estimate_geo(geo, given=("h",))["measure"] == pytest.approx(0.06, rel=1e-12)
    assert core.estimate_geo(geo)["measure"] == pytest.approx(0.1, rel=1e-12)
    assert core.estimate_geo(bare, given=())["measure"] == pytest.approx(0.1, rel=1e-12)
    # `dyncontact mesh --geo`
    r = run_cli("mesh", "--geo", geo, "--out", "own.msh", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    same_mesh(mesh_io.read_mesh(tmp_path / "own.msh"), own, "mesh without --length/--width")
    r = run_cli("mesh", "--geo", geo, "--length", "1", "--width", "0.1", "--out", "g.msh",
                cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    same_mesh(mesh_io.read_mesh(tmp_path / "g.msh"), given, "mesh --length 1 --width 0.1")
    r = run_cli("mesh", "--geo", bare, "--out", "bare.msh", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    same_mesh(mesh_io.read_mesh(tmp_path / "bare.msh"), given, "mesh, not defined")
    # a run, Scene.validate() and the studies' reading of the scene
    text = ("&mesh file = '{geo}'{lw}, max_elements = {limit} /\n"
            "&boundary clamped = '', contact = 'bottom' /\n"
            "&contact probe = 0.0, 0.0 /\n&initial kind = 'rest' /\n"
            "&scheme dt = 0.001, t_end = 0.002 /\n")
    scene = tmp_path / "s.nml"
    lw = ", length = 1.0, width = 0.1"
    for name, keys, want, user in (("rect.geo", "", own, (None, None)),
                                   ("rect.geo", lw, given, (1.0, 0.1)),
                                   ("bare.geo", "", given, (None, None))):
        scene.write_text(text.format(geo=name, lw=keys, limit=2000000))
        Scene.read(scene).validate()
        res = core.run(scene, out=tmp_path / "out", progress=False)
        assert res.status == "ok" and res.summary["elements"] == len(want.cells), (name, keys)
        us = read_user_scene(str(scene))
        assert (us.length, us.width) == user, (name, keys)
    # the refusal of a too-large .geo estimates it at the file's own length and width
    est = core.estimate_geo(geo)
    limit = int(est["estimate"] / est["margin"]) - 1
    assert core.estimate_geo(geo, given=("h",))["estimate"] < est["margin"] * limit
    scene.write_text(text.format(geo="rect.geo", lw="", limit=limit))
    Scene.read(scene).validate()
    scene.write_text(text.format(geo="rect.geo", lw=lw, limit=limit))
    with pytest.raises(BadInputError, match="max_elements"):
        Scene.read(scene).validate()


def test_own_length_and_width_in_a_callers_gmsh_session(core_ext, tmp_path):
    """Two .geo files defining their own length and width (DefineConstant with the Names
    "Parameters/length", "Parameters/width") read one after the other in a caller's gmsh
    session, by the core and by generate, each keep their own: a DefineConstant takes an
    existing ONELAB value over its own, so values the first read left behind would be
    taken for the second file's."""
    first, second = tmp_path / "first.geo", tmp_path / "second.geo"
    for path, length, width in ((first, 0.3, 0.2), (second, 0.4, 0.1)):
        path.write_text(f'DefineConstant[ length = {{{length}, Name "Parameters/length"}},\n'
                        f'  width = {{{width}, Name "Parameters/width"}} ];\n' + RECT_GEO)
    with callers_gmsh_session():
        for path, top in ((first, [0.2, 0.3]), (second, [0.1, 0.4]), (first, [0.2, 0.3])):
            np.testing.assert_allclose(mesh_io.read_mesh(path).x.max(axis=0), top,
                                       rtol=1e-12, err_msg=path.name)
            out = mesh_io.generate(path, tmp_path / "g.msh", length=None, width=None)
            np.testing.assert_allclose(mesh_io.read_mesh(out).x.max(axis=0), top,
                                       rtol=1e-12, err_msg=f"generate {path.name}")


def _named_size_geo(path: Path, size: float) -> Path:
    """A unit square whose mesh size is a DefineConstant named "Mesh/size", a Name
    outside "Parameters/": one the reader knows nothing of."""
    path.write_text(f'DefineConstant[ size = {{{size}, Name "Mesh/size"}} ];\n'
                    + RECT_GEO.replace("width", "1").replace("length", "1")
                    .replace(", h}", ", size}"))
    return path


#: The mesh sizes of the two files of test_a_read_leaves_the_onelab_database_as_it_found_it.
COARSE, FINE = 0.25, 0.1


def test_a_read_leaves_the_onelab_database_as_it_found_it(core_ext, tmp_path):
    """Two .geo files whose DefineConstant share a Name outside "Parameters/" ("Mesh/size",
    0.25 and 0.1), read one after the other in a caller's gmsh session by the core
    (read_mesh), by generate and by a run, each mesh at their own size: a DefineConstant
    takes the value of an existing ONELAB parameter of its Name over its own, so a
    read that left "Mesh/size" behind would mesh the second file at the first's 0.25. The
    caller's own ONELAB parameters are as
    they were after each read, and no parameter of the files is left behind."""
    coarse = _named_size_geo(tmp_path / "coarse.geo", COARSE)
    fine = _named_size_geo(tmp_path / "fine.geo", FINE)
    alone = {p: len(mesh_io.read_mesh(p).cells) for p in (coarse, fine)}
    assert alone[coarse] < alone[fine]
    scene = tmp_path / "s.nml"
    with callers_gmsh_session() as gmsh:
        gmsh.onelab.setNumber("Mine/x", [3.0])
        mine = sorted(gmsh.onelab.getNames())
        for path in (coarse, fine, coarse, fine):
            assert len(mesh_io.read_mesh(path).cells) == alone[path], path.name
            out = mesh_io.generate(path, tmp_path / "g.msh", h=None, length=None, width=None)
            assert len(mesh_io.read_mesh(out).cells) == alone[path], f"generate {path.name}"
            scene.write_text(f"&mesh file = '{path}' /\n&boundary clamped = '', contact = 'bottom' /\n"
                             "&contact probe = 0.5, 0.0 /\n&initial kind = 'rest' /\n"
                             "&scheme dt = 0.01, t_end = 0.01 /\n")
            r = core.run(scene, out=tmp_path / "out", progress=False)
            assert r.summary["elements"] == alone[path], f"run {path.name}"
            assert sorted(gmsh.onelab.getNames()) == mine
            assert gmsh.onelab.getNumber("Mine/x") == [3.0]


SCENE = """&mesh file = '{file}'{h} /
&boundary clamped = 'top', contact = 'bottom' /
&contact probe = {probe} /
&initial kind = 'compressed_bar', amplitude = {amp} /
&scheme name = 'hht', dt = 0.0025, t_end = 0.05 /
&output dir = 'out' /
"""


@pytest.mark.parametrize("name,probe,amp", [("bar", "0.05, 0.0", 0.5),
                                            ("disk", "0.0, 0.01", 0.05)])
def test_every_form_same_trace(core_ext, forms, tmp_path, name, probe, amp):
    traces = {}
    for form, path in forms[name].items():
        scene = tmp_path / f"{form}.nml"
        # h sizes the .geo forms; a .msh is meshed already (h given, a note says so)
        h = f", h = {GEOS[name][1]['h']}" if str(path).endswith(".geo") else ""
        scene.write_text(SCENE.format(file=path, h=h, probe=probe, amp=amp))
        r = core.run(scene, out=tmp_path / f"out_{form}", progress=False)
        assert r.summary["status"] == "ok", r.message
        traces[form] = r.trace
    first = traces["msh41"]
    assert len(first["t"]) == 21 and np.any(first["e_el"] > 0)
    for form, tr in traces.items():
        for k in first:
            np.testing.assert_allclose(tr[k], first[k], rtol=1e-10, atol=1e-13,
                                       err_msg=f"{name} {form}: {k}")


def test_mesh_command_any_geo(run_cli, tmp_path):
    """`python -m dyncontact mesh --geo` meshes any .geo, in the form asked for."""
    r = run_cli("mesh", "--geo", ROOT / "meshes" / "disk.geo", "--h", "0.02", "--out", "d.msh",
                "--binary", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "triangles; groups bottom" in r.stdout
    head = (tmp_path / "d.msh").read_bytes()[:40]
    assert head.startswith(b"$MeshFormat\n4.1 1 8\n")
    same_mesh(mesh_io.read_mesh(tmp_path / "d.msh"),
              mesh_io.read_mesh(ROOT / "meshes" / "disk.geo", h=0.02), "mesh command")
    r = run_cli("mesh", "--geo", tmp_path / "none.geo", "--out", "x.msh", cwd=tmp_path)
    assert r.returncode == 2 and "none.geo: no such file" in r.stderr


# --------------------------------------------------------------------------- bad input

def _exe_error(run_exe, tmp_path, mesh_file, **keys):
    extra = "".join(f"&{g} {v} /\n" for g, v in keys.items())
    scene = tmp_path / "s.nml"
    scene.write_text(f"&mesh file = '{mesh_file}' /\n{extra}&scheme t_end = 0.01 /\n")
    r = run_exe(scene)
    assert r.returncode == 2, (r.returncode, r.stdout, r.stderr)
    lines = r.stderr.strip().split("\n")
    assert len(lines) == 1, r.stderr
    return lines[0]


#: Mesh files a run refuses: id -> (file name, its text, what the message says after
#: 'PATH: ').
REFUSED_FILES = {
    "unknown_extension": ("mesh.vtk", "# vtk DataFile Version 2.0\n",
                          "unknown mesh file extension '.vtk'"),
    "geo_without_cells": ("points.geo", "Point(1) = {0, 0, 0};\nPoint(2) = {1, 0, 0};\n",
                          "no segments, triangles or tetrahedra"),
    "quadrangles": ("quads.geo", (ROOT / "meshes" / "bar2d.geo").read_text()
                            + "\nRecombine Surface{1};\n",
                            "element type 3 (a 4-node quadrangle, dimension 2) is not a "
                            "linear simplex; only 3-node triangles are supported in "
                            "dimension 2 (quadrangles, hexahedra, "
                            "prisms or pyramids: mesh without Recombine)"),
    # a second-order mesh: its 3-node segments come first; the message says what to change
    "second_order": ("p2.geo", (ROOT / "meshes" / "disk.geo").read_text()
                     + "\nMesh.ElementOrder = 2;\n",
                     "element type 8 (a 3-node segment, dimension 1) is not a linear "
                     "simplex; only 2-node segments are supported in dimension 1 (a "
                     "higher-order element: mesh with "
                     "Mesh.ElementOrder = 1)"),
    # triangles off the z = 0 plane with no tetrahedra: a 3D geometry saved as 2D
    "mixed_dimensions": ("tilted.geo",
                         "Point(1) = {0, 0, 0}; Point(2) = {1, 0, 0}; Point(3) = {0, 1, 1};\n"
                         "Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 1};\n"
                         "Curve Loop(1) = {1, 2, 3}; Plane Surface(1) = {1};\n",
                         "the mesh is 2D but its z coordinates are not constant"),
}


@pytest.mark.parametrize("name, text, what", REFUSED_FILES.values(), ids=list(REFUSED_FILES))
def test_mesh_file_refused(run_exe, tmp_path, name, text, what):
    p = tmp_path / name
    p.write_text(text)
    msg = _exe_error(run_exe, tmp_path, p)
    assert f"{p}: {what}" in msg


def _swap_counts(data: bytes, section: bytes, binary: bool) -> bytes:
    """data with the first two numbers of `section`'s header (its block count and its
    node or element count) swapped."""
    start = data.index(b"\n" + section + b"\n") + len(section) + 2
    if binary:
        a, b = data[start:start + 8], data[start + 8:start + 16]
        return data[:start] + b + a + data[start + 16:]
    end = data.index(b"\n", start)
    head = data[start:end].split()
    return data[:start] + b" ".join([head[1], head[0], *head[2:]]) + data[end:]


def _fewer_nodes(data: bytes, section: bytes, binary: bool) -> bytes:
    """data with `section`'s header count 5 less than its blocks hold."""
    start = data.index(b"\n" + section + b"\n") + len(section) + 2
    if binary:
        n = int.from_bytes(data[start + 8:start + 16], "little")
        return data[:start + 8] + (n - 5).to_bytes(8, "little") + data[start + 16:]
    end = data.index(b"\n", start)
    head = data[start:end].split()
    return data[:start] + b" ".join([head[0], b"%d" % (int(head[1]) - 5), *head[2:]]) \
        + data[end:]


@pytest.mark.parametrize("version, binary", [(4.1, False), (4.1, True), (4.0, False)],
                         ids=["4.1-ascii", "4.1-binary", "4.0-ascii"])
@pytest.mark.parametrize("section", [b"$Nodes", b"$Elements"])
@pytest.mark.parametrize("edit", [_swap_counts, _fewer_nodes], ids=["swapped", "fewer"])
def test_msh4_header_counts_that_differ_from_the_blocks_refused(run_exe, tmp_path, version,
                                                                 binary, section, edit):
    """gmsh sizes its arrays from a msh 4 section's header and fills them from its blocks:
    a header count below the blocks' sum writes past them (4.1: abort, "corrupted size vs.
    prev_size"; 4.0 ASCII, a node a line and two-number headers: "double free or
    corruption"); such a file is refused naming the file and the section, exit 2, while
    the file as gmsh wrote it reads."""
    src = rewrite(ROOT / "meshes" / "bar2d_getfem_h0.05.msh", tmp_path / "src.msh", version,
                  binary)
    assert mesh_io.read_mesh(src).dim == 2
    p = tmp_path / "bad.msh"
    p.write_bytes(edit(src.read_bytes(), section, binary))
    msg = _exe_error(run_exe, tmp_path, p)
    assert f"{p}: its {section.decode()} section" in msg
    with pytest.raises(BadInputError, match=f"its \\{section.decode()} section"):
        mesh_io.read_mesh(p)


@pytest.mark.parametrize("label", [b"4 1 8", b"4.0 1 8"], ids=["4", "4.0"])
def test_msh40_binary_is_refused_by_gmsh_before_its_sections(run_exe, run_cli, tmp_path,
                                                              label):
    """gmsh 4.15 neither writes nor reads binary MSH 4.0: it refuses the file on its
    $MeshFormat line, before it sizes any array from a section's header. So a binary
    4.0 file whose $Nodes header count is 5 below its blocks' (a binary 4.1 file so
    edited and relabelled, as gmsh labels 4.0) needs no count check of its own: both
    entry points refuse it with gmsh's reason, the same line, exit 2 (valgrind: no
    invalid access), and so does the reader. Were a gmsh to write binary 4.0 again,
    the first check here fails, and msh_sections.f90 would need its layout."""
    bar = ROOT / "meshes" / "bar2d_getfem_h0.05.msh"
    with pytest.raises(Exception, match="Can only write MSH 4.0 format in ASCII mode"):
        rewrite(bar, tmp_path / "bin40.msh", 4.0, True)
    src = rewrite(bar, tmp_path / "src.msh", 4.1, True)
    data = _fewer_nodes(src.read_bytes(), b"$Nodes", True)
    assert data.startswith(b"$MeshFormat\n4.1 1 8\n")
    p = tmp_path / "bad40.msh"
    p.write_bytes(data.replace(b"4.1 1 8", label, 1))
    scene = tmp_path / "s.nml"
    scene.write_text(f"&mesh file = '{p}' /\n&scheme t_end = 0 /\n")
    lines = [stderr_line(res, 2) for res in (run_exe(scene), run_cli("run", scene))]
    assert lines[0] == lines[1], lines
    why = "gmsh cannot read it: Can only read MSH 4.0 format in ASCII mode"
    assert f"{p}: {why}" in lines[0]
    with pytest.raises(BadInputError, match=why):
        mesh_io.read_mesh(p)


def _tag_range(data: bytes, low: bytes, high: bytes) -> bytes:
    """data with its $Nodes header's minTag and maxTag replaced."""
    start = data.index(b"\n$Nodes\n") + 8
    end = data.index(b"\n", start)
    head = data[start:end].split()
    return data[:start] + b" ".join([head[0], head[1], low, high]) + data[end:]


#: Fields of an ASCII 4.1 file that disagree with its content, which gmsh reads to the
#: same mesh with no invalid access under valgrind (fortran/io/msh_sections.f90): left
#: to gmsh, accepted.
HARMLESS_EDITS = {
    "tags_above_range": lambda d: _tag_range(d, b"1", b"2"),
    "tags_below_range": lambda d: _tag_range(d, b"62", b"63"),
    "range_far_too_wide": lambda d: _tag_range(d, b"1", b"100000000"),
    "data_size_4": lambda d: d.replace(b"4.1 0 8", b"4.1 0 4", 1),
    "unterminated_name": lambda d: d.replace(b'"bottom"', b'"bottom', 1),
}


@pytest.mark.parametrize("edit", HARMLESS_EDITS, ids=list(HARMLESS_EDITS))
def test_msh41_fields_gmsh_reads_alike_are_accepted(tmp_path, edit):
    src = rewrite(ROOT / "meshes" / "bar2d_getfem_h0.05.msh", tmp_path / "src.msh", 4.1,
                  False)
    p = tmp_path / "edited.msh"
    data = HARMLESS_EDITS[edit](src.read_bytes())
    assert data != src.read_bytes()
    p.write_bytes(data)
    same_mesh(mesh_io.read_mesh(src), mesh_io.read_mesh(p), edit)


#: A .geo with gmsh's Exit command: gmsh ends the process there (status 1, no word).
_EXIT_GEO = (ROOT / "meshes" / "disk.geo").read_text() + "\nExit ;\n"


def test_geo_with_exit_refused(run_exe, tmp_path):
    """The run, the reader and the estimate (Scene.validate) refuse it naming the file;
    the Python process that asked lives on. Exit in a comment or a string is no command."""
    p = tmp_path / "exits.geo"
    p.write_text(_EXIT_GEO)
    what = "has gmsh's 'Exit' command"
    assert f"{p}: {what}" in _exe_error(run_exe, tmp_path, p)
    with pytest.raises(BadInputError, match=what):
        mesh_io.read_mesh(p)
    with pytest.raises(BadInputError, match=what):
        core.estimate_geo(p)
    quiet = tmp_path / "quiet.geo"
    quiet.write_text((ROOT / "meshes" / "disk.geo").read_text()
                     + '\n// Exit;\n/* Exit; */\nPrintf("Exit;");\nExits = 1;\n'
                     + "Printf('Sleep 1;');\nSystem = 2;\nSleep[0] = 1;\nSleep += 1;\n"
                     + "SystemCalls = 1;\n")
    assert mesh_io.read_mesh(quiet).dim == 2


#: gmsh's .geo commands that end the process, stall it, run other programs or write
#: to disk outside the run's output folder (each appended to a .geo that meshes; MARK
#: is a file the command would create): the command, and what the refusal says it
#: would do.
GEO_COMMANDS = {
    "exit_status": ("Exit 3;", "Exit", "end the run without a word"),
    "sleep": ("Sleep 30;", "Sleep", "stall the run"),
    "sleep_parenthesis": ("Sleep(30);", "Sleep", "stall the run"),
    "system_call": ('SystemCall "touch MARK";', "SystemCall", "run a shell command"),
    "system": ('System "touch MARK";', "System", "run a shell command"),
    "non_blocking": ('NonBlockingSystemCall "touch MARK";', "NonBlockingSystemCall",
                     "run a shell command"),
    "onelab_run": ('OnelabRun("touch MARK");', "OnelabRun", "run another program"),
    "print": ('Print "MARK.png";', "Print", "write a file"),
    "save": ('Save "MARK.msh";', "Save", "write a file"),
    "save_view": ('Save View[0] "MARK.pos";', "Save", "write a file"),
    "create_dir": ('CreateDir "MARK";', "CreateDir", "create a folder"),
    "printf_to_file": ('Printf("x") > "MARK";', "Printf(...) >", "write a file"),
    "printf_values_to_file": ('Printf("x %g", 1) /* to */ > "MARK";', "Printf(...) >",
                              "write a file"),
    "printf_append": ('Printf("x") >> "MARK";', "Printf(...) >>",
                      "append to a file at each of gmsh's parses of the .geo"),
    "plugin_that_writes": ('Plugin(Bubbles).OutputFile = "MARK";\nPlugin (Bubbles) . Run;',
                           "Plugin(Bubbles).Run", "write a file"),
}


@pytest.mark.parametrize("case", GEO_COMMANDS, ids=list(GEO_COMMANDS))
def test_geo_command_that_escapes_the_process_refused(run_exe, run_cli, tmp_path, case):
    """Both entry points refuse the .geo with the same line naming the file and the
    command, exit 2, before gmsh reads it (the shell command does not run, nothing
    stalls, no file is written); so do mesh_io.generate, without a limit, and the
    reader."""
    command, name, effect = GEO_COMMANDS[case]
    mark = tmp_path / "ran"
    p = tmp_path / "escapes.geo"
    p.write_text((ROOT / "meshes" / "disk.geo").read_text() + "\n"
                 + command.replace("MARK", str(mark)) + "\n")
    scene = tmp_path / "s.nml"
    scene.write_text(f"&mesh file = '{p}' /\n&scheme t_end = 0 /\n")
    lines = [stderr_line(res, 2) for res in (run_exe(scene), run_cli("run", scene))]
    assert lines[0] == lines[1], lines
    assert f"{p}: has gmsh's '{name}' command, which would {effect}" in lines[0]
    with pytest.raises(BadInputError, match=re.escape(f"'{name}' command")):
        mesh_io.generate(p, tmp_path / "out.msh", max_elements=0)
    with pytest.raises(BadInputError, match=re.escape(f"'{name}' command")):
        mesh_io.read_mesh(p)
    assert not any(tmp_path.glob("ran*"))


def test_geo_printf_to_the_terminal_and_print_options_pass(tmp_path):
    """Printf without '>' prints to the terminal, '>' inside its arguments or a string
    is no redirection, Print.Width is an option, Saved a variable, Plugin(Bubbles)
    without Run sets an option and writes nothing: the .geo meshes as disk.geo gives
    it, and no file appears beside it."""
    disk = (ROOT_MESHES / "disk.geo").read_text()
    p = _write(tmp_path / "quiet.geo", disk + '\nPrintf("x");\nPrintf("a > b");\n'
               'Printf("%g", 2 > 1);\nPrintf("%g", (1 > 0)) ;\nPrint.Width = 100;\n'
               'Printf("Save >> f");\nSaved = 1;\n// Save "f";\n'
               'Plugin(Bubbles).OutputFile = "f";\n')
    same_mesh(mesh_io.read_mesh(ROOT_MESHES / "disk.geo", h=0.05),
              mesh_io.read_mesh(p, h=0.05), "quiet")
    assert sorted(f.name for f in tmp_path.iterdir()) == ["quiet.geo"]



def _write(path: Path, text: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def _disk_with(tmp_path: Path, line: str) -> Path:
    """meshes/disk.geo with `line` after it, as tmp_path/top.geo."""
    return _write(tmp_path / "top.geo", (ROOT_MESHES / "disk.geo").read_text() + "\n"
                  + line + "\n")


def test_geo_exit_in_included_file_refused(run_exe, tmp_path):
    """An Exit in a file the .geo includes (named relative to the .geo's folder) is
    refused by the run, the reader and the estimate, naming the included file and the
    .geo that reads it."""
    inc = _write(tmp_path / "parts" / "ends.geo", "Exit;\n")
    top = _disk_with(tmp_path, 'Include "parts/ends.geo";')
    line = _exe_error(run_exe, tmp_path, top)
    assert f"{inc}: has gmsh's 'Exit' command" in line and f"from {top})" in line, line
    with pytest.raises(BadInputError, match=f"{inc}: has gmsh's 'Exit' command"):
        mesh_io.read_mesh(top)
    with pytest.raises(BadInputError, match="'Exit' command"):
        core.estimate_geo(top)


def test_geo_system_call_two_includes_deep_refused(run_exe, run_cli, tmp_path):
    """A SystemCall in a file included from an included file, each named relative to
    the folder of the file that names it (as gmsh resolves it): both entry points
    refuse with the same line naming that file, so do mesh_io.generate and the reader,
    and the shell command does not run."""
    mark = tmp_path / "ran"
    deep = _write(tmp_path / "sub" / "deeper" / "call.geo", f'SystemCall "touch {mark}";\n')
    _write(tmp_path / "sub" / "one.geo", 'Include "deeper/call.geo";\n')
    top = _disk_with(tmp_path, 'Include "sub/one.geo";')
    scene = tmp_path / "s.nml"
    scene.write_text(f"&mesh file = '{top}' /\n&scheme t_end = 0 /\n")
    lines = [stderr_line(res, 2) for res in (run_exe(scene), run_cli("run", scene))]
    assert lines[0] == lines[1], lines
    assert f"{deep}: has gmsh's 'SystemCall' command, which would run a shell command" \
        in lines[0]
    with pytest.raises(BadInputError, match="'SystemCall' command"):
        mesh_io.generate(top, tmp_path / "out.msh", max_elements=0)
    with pytest.raises(BadInputError, match="'SystemCall' command"):
        mesh_io.read_mesh(top)
    assert not mark.exists()


def test_geo_include_cycle(tmp_path):
    """a.geo includes b.geo, which includes a.geo (a.geo guards itself, as gmsh needs):
    the check ends, the disk reads as disk.geo gives it; a command in a file b.geo
    includes after the cycle is still found."""
    disk = (ROOT_MESHES / "disk.geo").read_text()
    a = _write(tmp_path / "a.geo", "If (!Exists(a_read))\na_read = 1;\n"
               + 'Include "b.geo";\n' + disk + "\nEndIf\n")
    b = _write(tmp_path / "b.geo", 'Include "a.geo";\n')
    same_mesh(mesh_io.read_mesh(ROOT_MESHES / "disk.geo", h=0.05),
              mesh_io.read_mesh(a, h=0.05), "cycle")
    mark = tmp_path / "ran"
    _write(tmp_path / "c.geo", f'SystemCall "touch {mark}";\n')
    b.write_text('Include "a.geo";\nInclude "c.geo";\n')
    with pytest.raises(BadInputError, match=f"{tmp_path / 'c.geo'}: has gmsh's 'SystemCall'"):
        mesh_io.read_mesh(a, h=0.05)
    assert not mark.exists()



def test_geo_includes_nested_too_deep_refused(tmp_path):
    """Files nested more than 20 deep are refused (no .geo needs so deep a nesting; a
    cycle ends at the first file seen again, however its name is written), naming the
    file past the limit; 20 deep pass."""
    for k in range(21):
        _write(tmp_path / f"n{k}.geo", f'Include "n{k + 1}.geo";\n')
    _write(tmp_path / "n21.geo", "// clean\n")
    with pytest.raises(BadInputError, match=f"{tmp_path / 'n21.geo'}: files included or "
                       "merged more than 20 deep"):
        core.estimate_geo(tmp_path / "n0.geo")
    (tmp_path / "n20.geo").write_text((ROOT_MESHES / "disk.geo").read_text())
    assert mesh_io.read_mesh(tmp_path / "n0.geo", h=0.05).dim == 2


#: How a.geo names b.geo and b.geo names a.geo again in an include cycle gmsh reads
#: (a.geo guards itself): b.geo's name in a.geo, b.geo's text. "link": link.geo is a
#: link to a.geo (a cycle a scan by names as text ended too, after one more round);
#: "folder_link": sub is a link to the folder itself, so that each round names the
#: files one 'sub/' deeper.
CYCLE_SPELLINGS = {
    "dot": ("b.geo", 'Include "./a.geo";\n'),
    "dot_dot": ("sub/b.geo", 'Include "../sub/../a.geo";\n'),
    "link": ("b.geo", 'Include "link.geo";\n'),
    "folder_link": ("sub/b.geo", 'Include "sub/a.geo";\n'),
}


@pytest.mark.parametrize("case", CYCLE_SPELLINGS, ids=list(CYCLE_SPELLINGS))
def test_geo_include_cycle_through_names_written_differently(run_exe, run_cli, tmp_path,
                                                              case):
    """gmsh reads a.geo as one file however it is named; so does the scan, by canonical
    paths (comparing names as text, it went round the cycle to the nesting limit and
    refused the file, 'more than 20 deep'): the reader gives the bar as bar2d.geo gives
    it, and a run through each entry point succeeds."""
    where, text = CYCLE_SPELLINGS[case]
    bar = ROOT_MESHES / "bar2d.geo"
    if case == "folder_link":
        (tmp_path / "sub").symlink_to(tmp_path, target_is_directory=True)
    a = _write(tmp_path / "a.geo", "If (!Exists(a_read))\na_read = 1;\n"
               f'Include "{where}";\nInclude "{bar}";\nEndIf\n')
    _write(tmp_path / where, text)
    if case == "link":
        (tmp_path / "link.geo").symlink_to(a)
    same_mesh(mesh_io.read_mesh(bar, h=0.05), mesh_io.read_mesh(a, h=0.05), case)
    for run, out in ((run_exe, "out_exe"), (run_cli, "out_cli")):
        scene = tmp_path / f"{out}.nml"
        scene.write_text(f"&mesh file = '{a}' /\n&scheme t_end = 0.01 /\n"
                         f"&output dir = '{out}' /\n")
        res = run(scene) if run is run_exe else run("run", scene)
        assert res.returncode == 0, res.stderr[-2000:]
        assert (tmp_path / out).is_dir()


#: Files gmsh parses as .geo when the .geo merges them (a .geo, a .msh without a mesh
#: header) or after it (the options file name.opt gmsh merges after each file): the
#: line that pulls the file in, the file, its text.
MERGED_GEO = {
    "merge_geo": ('Merge "more.geo";', "more.geo", "Exit;\n"),
    "merge_msh_without_header": ('Merge "more.msh";', "more.msh", "Exit 3;\n"),
    "options_file": ("", "top.geo.opt", "Exit;\n"),
}


@pytest.mark.parametrize("case", MERGED_GEO, ids=list(MERGED_GEO))
def test_geo_exit_in_merged_file_refused(tmp_path, case):
    line, name, text = MERGED_GEO[case]
    f = _write(tmp_path / name, text)
    top = _disk_with(tmp_path, line)
    with pytest.raises(BadInputError, match=f"{f}: has gmsh's 'Exit' command"):
        mesh_io.read_mesh(top)


def test_geo_merge_of_a_mesh_not_scanned(tmp_path):
    """A merged file gmsh reads as a mesh (a mesh header on its first line) is not
    scanned: a name 'Exit' in it is no command."""
    _write(tmp_path / "more.msh", "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n"
           "$Comments\nExit;\n$EndComments\n")
    assert mesh_io.read_mesh(_disk_with(tmp_path, 'Merge "more.msh";'), h=0.05).dim == 2


def test_geo_include_of_expression_refused(tmp_path):
    """A file named by an expression cannot be followed without gmsh's parser: refused,
    naming the file that holds the Include."""
    _write(tmp_path / "parts" / "body.geo", (ROOT_MESHES / "disk.geo").read_text())
    top = _write(tmp_path / "top.geo", 'Include StrCat("parts/", "body.geo");\n')
    with pytest.raises(BadInputError, match=f"{top}: has gmsh's 'Include' of a file not "
                       "named by a string"):
        mesh_io.read_mesh(top)


def test_geo_clean_include_meshes_as_inlined(run_exe, tmp_path):
    """A clean file included (with the command names in its comments and strings, and
    included twice) meshes as the same text inlined, and a run on it succeeds."""
    body = (ROOT_MESHES / "disk.geo").read_text()
    _write(tmp_path / "parts" / "body.geo", body + '\n// Exit;\nPrintf("SystemCall");\n')
    _write(tmp_path / "parts" / "none.geo", "// nothing\n")
    top = _write(tmp_path / "top.geo", 'Include "parts/body.geo";\n'
                 'Include "parts/none.geo";\nInclude "parts/none.geo";\n')
    for h in (0.05, 0.03):
        same_mesh(mesh_io.read_mesh(ROOT_MESHES / "disk.geo", h=h),
                  mesh_io.read_mesh(top, h=h), f"include h={h}")


def test_missing_file(run_exe, tmp_path):
    msg = _exe_error(run_exe, tmp_path, tmp_path / "none.msh")
    assert "none.msh" in msg and "cannot read mesh file" in msg


def test_geo_gmsh_cannot_read(run_exe, tmp_path):
    p = tmp_path / "bad.geo"
    p.write_text("Point(1) = {0, 0, 0};\nLine(1) = {1, 7};\n")
    msg = _exe_error(run_exe, tmp_path, p)
    assert f"{p}: gmsh cannot" in msg
    with pytest.raises(BadInputError, match="gmsh cannot"):
        mesh_io.read_mesh(p)


def test_named_group_missing(run_exe, tmp_path):
    msg = _exe_error(run_exe, tmp_path, ROOT / "meshes" / "disk.geo",
                     boundary="clamped = 'top', contact = 'left'")
    assert "&boundary contact: group 'left' not in mesh" in msg and "disk.geo" in msg


def test_no_gmsh(exe, tmp_path):
    """Without libgmsh: built-in meshes run, a mesh file gets exit 2 saying how to get
    gmsh (DYNCONTACT_GMSH_LIB set to a missing file stands for a machine without it)."""
    env = dict(os.environ, DYNCONTACT_GMSH_LIB=str(tmp_path / "libgmsh.so"))
    env.pop("PYTHONPATH", None)
    scene = tmp_path / "s.nml"
    scene.write_text("&scheme t_end = 0.01 /\n&output dir = 'out' /\n")
    r = subprocess.run([exe, scene], env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    scene.write_text(f"&mesh file = '{ROOT / 'meshes' / 'disk.geo'}' /\n"
                     "&scheme t_end = 0.01 /\n&output dir = 'out' /\n")
    r = subprocess.run([exe, scene], env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == 2
    assert "disk.geo: mesh files need gmsh" in r.stderr and "pip install gmsh" in r.stderr


# --------------------------------------------------------------------------- loading, state

def _loaded_libraries(exe, scene: Path) -> str:
    """What the dynamic loader opens during a run (LD_DEBUG=files)."""
    env = dict(os.environ, LD_DEBUG="files")
    env.pop("PYTHONPATH", None)
    env.pop("DYNCONTACT_GMSH_LIB", None)
    r = subprocess.run([exe, scene], env=env, capture_output=True, text=True, timeout=120,
                       cwd=scene.parent)
    assert r.returncode == 0, r.stderr[-2000:]
    return r.stderr


def test_builtin_mesh_does_not_load_gmsh(exe, tmp_path):
    """No libgmsh among the executable's needed libraries, none opened by a run on the
    built-in bar; the same run on a mesh file opens it (the check sees a load)."""
    ldd = subprocess.run(["ldd", exe], capture_output=True, text=True).stdout
    assert "libgmsh" not in ldd and "libumfpack" in ldd
    scene = tmp_path / "builtin.nml"
    scene.write_text("&scheme t_end = 0.01 /\n&output dir = 'out1' /\n")
    log = _loaded_libraries(exe, scene)
    assert "libumfpack" in log and "libgmsh" not in log
    scene = tmp_path / "file.nml"
    scene.write_text(f"&mesh file = '{ROOT / 'meshes' / 'bar2d_getfem_h0.05.msh'}' /\n"
                     "&initial kind = 'compressed_bar' /\n"
                     "&scheme t_end = 0.01 /\n&output dir = 'out2' /\n")
    assert "libgmsh" in _loaded_libraries(exe, scene)


def test_reading_leaves_gmsh_finalized(core_ext):
    import gmsh

    mesh_io.read_mesh(ROOT / "meshes" / "disk.geo", h=0.05)
    assert not gmsh.isInitialized()


def test_reading_keeps_callers_gmsh_session(core_ext):
    """Inside a caller's gmsh session: its model, options and variables survive a read of
    a .geo and of a .msh by the core, and nothing is printed."""
    with callers_gmsh_session() as gmsh:
        gmsh.parser.setNumber("mine", [3.0])
        size_max = gmsh.option.getNumber("Mesh.MeshSizeMax")
        m = mesh_io.read_mesh(ROOT / "meshes" / "disk.geo", h=0.05)
        mesh_io.read_mesh(ROOT / "meshes" / "bar2d_getfem_h0.05.msh")
        assert gmsh.model.getCurrent() == "mine"
        assert gmsh.model.getEntities() == [(0, 1)]
        assert gmsh.model.list() == ["", "mine"]
        assert gmsh.option.getNumber("Mesh.MeshSizeMax") == size_max
        assert gmsh.option.getNumber("General.Terminal") == 0
        assert set(gmsh.parser.getNames()) == {"mine"}
    assert m.dim == 2 and len(m.cells) > 0


def test_gmsh_prints_nothing(run_exe, tmp_path, capfd, core_ext):
    """A run on a .geo prints only its own lines; a read from Python prints nothing."""
    scene = tmp_path / "s.nml"
    scene.write_text(f"&mesh file = '{ROOT / 'meshes' / 'disk.geo'}' /\n"
                     "&boundary clamped = 'top', contact = 'bottom' /\n"
                     "&contact probe = 0.0, 0.01 /\n"
                     "&initial kind = 'compressed_bar', amplitude = 0.05 /\n"
                     "&scheme t_end = 0.01 /\n&output dir = 'out' /\n")
    r = run_exe(scene)
    assert r.returncode == 0, r.stderr
    lines = (r.stdout + r.stderr).strip().split("\n")
    assert len(lines) == 2 and all(s.startswith("dyncontact: ") for s in lines), lines
    capfd.readouterr()
    mesh_io.read_mesh(ROOT / "meshes" / "disk.geo", h=0.05)
    bad = tmp_path / "bad.geo"
    bad.write_text("Point(1) = {0, 0, 0};\nLine(1) = {1, 7};\n")
    with pytest.raises(BadInputError):
        mesh_io.read_mesh(bad)
    out, err = capfd.readouterr()
    assert out == "" and err == ""


def test_degenerate_cell_sizes_written_with_their_exponent(run_exe, tmp_path):
    """A degenerate cell's measure below 1e-99 is written with its E (2.470E-322, not
    the 2.470-322 of a 2-digit exponent format), and both entry points give one text."""
    scene = tmp_path / "s.nml"
    scene.write_text("&mesh length = 1e-320 /\n&scheme t_end = 0.01 /\n")
    exe_line = stderr_line(run_exe(scene), 2, "dyncontact: ")
    assert re.search(r"is degenerate \(measure \d\.\d{3}E-3\d\d, longest edge 5\.000E-002\)$",
                     exe_line), exe_line
    py = subprocess.run([sys.executable, "-m", "dyncontact", "run", str(scene), "--out",
                         str(tmp_path / "p")], capture_output=True, text=True, cwd=tmp_path)
    assert stderr_line(py, 2, "dyncontact: ") == exe_line
