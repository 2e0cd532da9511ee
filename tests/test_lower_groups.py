"""&boundary clamped and slip_* naming a group of a lower dimension than the facets: a
Physical Point of a 2D mesh, a Physical Point or Curve of a 3D one. The Dirichlet dofs
are the group's nodes' dofs, as a facet group's are its facets' nodes' dofs; `contact`
stays a facet group. From the executable, the Python CLI and the API; from a .geo and
from .msh 4.1 (ASCII, binary) and 2.2 written by gmsh from it."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from test_reliability import ENERGY_TOL, ENTRIES, EXIT_BAD_INPUT, EXIT_OK, one_line, run

pytest.importorskip("gmsh")

#: A 1 x 0.2 plate whose top edge is a chain of 6 lines of one segment each, so that its
#: Physical Point 'top_points' holds every node of the facet group 'top'; 'pin' is the
#: corner (0, 0).
PLATE_GEO = """\
n = 6;
Point(1) = {0, 0, 0};
Point(2) = {1, 0, 0};
For i In {0:n}
  Point(10 + i) = {1 - i / n, 0.2, 0};
EndFor
Line(1) = {1, 2};
Line(2) = {2, 10};
For i In {0:n-1}
  Line(10 + i) = {10 + i, 11 + i};
EndFor
Line(3) = {10 + n, 1};
Curve Loop(1) = {1, 2, 10:10+n-1, 3};
Plane Surface(1) = {1};
Transfinite Curve{10:10+n-1} = 2;
Mesh.MeshSizeMax = 0.1;
Physical Curve("bottom") = {1};
Physical Curve("top") = {10:10+n-1};
Physical Point("top_points") = {10:10+n};
Physical Point("pin") = {1};
Physical Surface("body") = {1};
"""

#: The plate, clamped at `clamped`, hitting the obstacle y = 0 under its bottom.
PLATE_SCENE = """\
&mesh file = '{mesh}', h = {h} /
&boundary clamped = '{clamped}', contact = 'bottom' /
&initial kind = 'velocity', velocity = 0.0, -0.1 /
&scheme name = 'newmark', dt = 0.01, t_end = 0.3 /
"""

#: A 0.2 x 0.1 x 0.1 block whose top face (surface 6) is two triangles: its four
#: corners are all its nodes, held by the Physical Point 'lid_corners' and by the
#: Physical Curve 'lid_edges' (its four edges, one segment each). 'edge' is the curve
#: x = y = 0 (along z), 'corner' the point (0, 0, 0.11).
BLOCK_GEO = """\
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0.01, 0.2, 0.1, 0.1};
Mesh.MeshSizeMax = 0.05;
Transfinite Curve{Boundary{Surface{6};}} = 2;
Transfinite Surface{6};
Physical Surface("sole") = {5};
Physical Surface("lid") = {6};
Physical Curve("lid_edges") = Boundary{Surface{6};};
Physical Point("lid_corners") = PointsOf{Surface{6};};
Physical Curve("edge") = {1};
Physical Point("corner") = {1};
Physical Volume("brick") = {1};
"""

BLOCK_SCENE = """\
&mesh file = '{mesh}', h = {h} /
&boundary clamped = '{clamped}', contact = '{contact}' /
&material young = 1.0, poisson = 0.3 /
&contact obstacle_point = 0, 0, 0, obstacle_normal = 0, 0, -1, probe = 0.1, 0.05, 0.01 /
&initial kind = 'velocity', velocity = {velocity} /
&scheme name = 'newmark', dt = 0.01, t_end = {t_end} /
"""

#: gmsh's file formats the core reads: (suffix, Mesh.MshFileVersion, Mesh.Binary).
MSH_FORMATS = [("41.msh", 4.1, 0), ("41b.msh", 4.1, 1), ("22.msh", 2.2, 0)]


def write_msh(geo: Path, dim: int, out: Path, version: float, binary: int) -> None:
    """The .geo meshed by gmsh in `dim` and written as `out` in that format."""
    from conftest import gmsh_session

    with gmsh_session("lowgroups") as gmsh:
        gmsh.open(str(geo))
        gmsh.model.mesh.generate(dim)
        gmsh.option.setNumber("Mesh.MshFileVersion", version)
        gmsh.option.setNumber("Mesh.Binary", binary)
        gmsh.write(str(out))


def run_ok(kind: str, folder: Path, scene: str, out: str) -> bytes:
    """Run the scene text `scene` (written in `folder`) with the entry `kind`; the bytes
    of its trace.csv."""
    path = folder / f"{out}.nml"
    path.write_text(scene)
    res = run(kind, path.name, "--out", out, cwd=folder)
    assert res.returncode == EXIT_OK, res.stderr
    return (folder / out / "trace.csv").read_bytes()


@pytest.mark.parametrize("kind", ENTRIES)
@pytest.mark.parametrize("fmt", ["geo"] + [f[0] for f in MSH_FORMATS])
def test_point_group_clamps_as_the_facet_group_of_its_nodes(kind, fmt, tmp_path):
    """clamped = the Physical Point holding every node of the top edge gives the trace of
    clamped = 'top' (the facet group) bit for bit: the same Dirichlet dofs, so the same
    numbering and the same arithmetic. Refused before ('has no facets or cells')."""
    (tmp_path / "plate.geo").write_text(PLATE_GEO)
    mesh = "plate.geo"
    if fmt != "geo":
        _, version, binary = next(f for f in MSH_FORMATS if f[0] == fmt)
        mesh = f"plate{fmt}"
        write_msh(tmp_path / "plate.geo", 2, tmp_path / mesh, version, binary)
    scene = dict(h=0.1, mesh=mesh)
    facet = run_ok(kind, tmp_path, PLATE_SCENE.format(clamped="top", **scene), "facet")
    point = run_ok(kind, tmp_path, PLATE_SCENE.format(clamped="top_points", **scene), "point")
    assert facet.count(b"\n") == 32   # header and steps 0..30
    assert point == facet


@pytest.mark.parametrize("fmt", ["geo", "41.msh"])
@pytest.mark.parametrize("group", ["lid_edges", "lid_corners"])
def test_curve_and_point_groups_of_a_3d_mesh_clamp_as_its_face(group, fmt, tmp_path):
    """3D: clamped = the top face's edges (a Physical Curve) or its corners (a Physical
    Point), which hold all its nodes, gives the trace of clamped = 'lid' bit for bit."""
    (tmp_path / "block.geo").write_text(BLOCK_GEO)
    mesh = "block.geo"
    if fmt != "geo":
        mesh = "block.msh"
        write_msh(tmp_path / "block.geo", 3, tmp_path / mesh, 4.1, 0)
    scene = dict(h=0.05, mesh=mesh, contact="sole", velocity="0, 0, -0.1", t_end="0.3")
    face = run_ok("exe", tmp_path, BLOCK_SCENE.format(clamped="lid", **scene), "face")
    lower = run_ok("exe", tmp_path, BLOCK_SCENE.format(clamped=group, **scene), "lower")
    assert lower == face


def model_nodes(scene: Path):
    """(x, free dofs' (node, component)) of the model of `scene`, both 0-based."""
    from dyncontact import mesh_io
    from dyncontact.core import Model

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with Model(scene) as m:
            node, comp = m.dof_map()
    geo, h = ("block.geo", 0.05) if "block" in scene.read_text() else ("plate.geo", 0.1)
    return mesh_io.read_mesh(scene.parent / geo, h=h).x, node, comp


def test_clamped_edge_of_a_3d_body_stays_put_and_keeps_its_energy(tmp_path):
    """3D block clamped along one edge (a Physical Curve), no contact, set moving
    across it (velocity along x and y, the edge held): the edge's nodes have no dof
    (u = 0 there at every step), every other node keeps its three, and the total
    energy of the trapezoidal rule (newmark's default 1/4, 1/2, exactly conservative for
    a linear problem) stays e_total(0) to round-off (ENERGY_TOL, as in
    test_reliability) while the body moves."""
    from dyncontact import run as run_api
    from dyncontact.core import Stepper

    (tmp_path / "block.geo").write_text(BLOCK_GEO)
    scene = tmp_path / "s.nml"
    scene.write_text(BLOCK_SCENE.format(h=0.05, mesh="block.geo", clamped="edge", contact="",
                                        velocity="0.1, 0.1, 0", t_end="0.5"))
    x, node, comp = model_nodes(scene)
    on_edge = np.flatnonzero((np.abs(x[:, 0]) < 1e-12) & (np.abs(x[:, 1]) < 1e-12))
    assert len(on_edge) >= 2
    assert not np.isin(node, on_edge).any()
    assert len(node) == 3 * (len(x) - len(on_edge))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with Stepper(scene, tmp_path / "o") as s:
            moved = 0.0
            while not s.finished:
                s.advance(1)
                moved = max(moved, float(np.abs(s.state()["u"]).max()))
        res = run_api(scene, out=tmp_path / "o2", progress=False)
    assert moved > 1e-3
    e = res.trace["e_total"]
    assert e[0] > 0 and np.abs(e - e[0]).max() <= ENERGY_TOL * e[0]
    assert res.trace["e_el"].max() > 1e-3 * e[0]   # the body deforms: the edge holds it


def test_slip_x_on_one_point_removes_that_nodes_x_motion_only(tmp_path):
    """slip_x = 'pin' (the corner (0, 0)) on the free plate pushed along x: the pinned
    node has no x dof (u_x = 0 there at every step), keeps its y dof, and every other
    dof is free; the rest of the plate moves along x."""
    from dyncontact.core import Stepper

    (tmp_path / "plate.geo").write_text(PLATE_GEO)
    scene = tmp_path / "s.nml"
    scene.write_text("&mesh file = 'plate.geo', h = 0.1 /\n"
                     "&boundary clamped = '', slip_x = 'pin', contact = '' /\n"
                     "&initial kind = 'velocity', velocity = 0.1, 0.0 /\n"
                     "&scheme name = 'newmark', dt = 0.01, t_end = 0.2 /\n")
    x, node, comp = model_nodes(scene)
    pin = int(np.flatnonzero(np.hypot(x[:, 0], x[:, 1]) < 1e-12)[0])
    assert len(node) == 2 * len(x) - 1
    assert not ((node == pin) & (comp == 0)).any()
    assert ((node == pin) & (comp == 1)).sum() == 1
    far = np.flatnonzero((node == int(np.argmax(x[:, 0] + x[:, 1]))) & (comp == 0))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with Stepper(scene, tmp_path / "o") as s:
            s.advance(20)
            u = s.state()["u"]
    assert u[far[0]] > 1e-3       # the far corner moved along x (about 0.1 t)


@pytest.mark.parametrize("kind", ENTRIES)
def test_contact_on_a_point_group_is_refused(kind, tmp_path):
    """contact = a Physical Point: refused in one line naming the key, the group and what
    it is made of (exit 2); contact needs facets."""
    (tmp_path / "plate.geo").write_text(PLATE_GEO)
    scene = tmp_path / "s.nml"
    scene.write_text(PLATE_SCENE.format(h=0.1, mesh="plate.geo", clamped="top")
                     .replace("contact = 'bottom'", "contact = 'pin'"))
    line = one_line(run(kind, "s.nml", "--out", "o", cwd=tmp_path), EXIT_BAD_INPUT)
    assert line == ("dyncontact: s.nml: &boundary contact: group 'pin' has no facets in "
                    "the mesh (its elements are points; the facets of a 2D mesh are "
                    "segments) (mesh 'plate.geo')")


@pytest.mark.parametrize("fmt", ["geo"] + [f[0] for f in MSH_FORMATS])
def test_the_mesh_keeps_the_nodes_of_point_and_curve_groups(fmt, tmp_path):
    """MeshData.lower_nodes / lower_group (the core's mesh_t%lower_nodes, lower_group)
    hold, for each point or curve group, exactly its nodes, once each: the plate's
    'top_points' the nodes of the facet group 'top', 'pin' the node at (0, 0); the
    block's 'lid_corners' and 'lid_edges' the nodes of the face 'lid', 'edge' those on
    x = y = 0. Groups of facets or cells have none."""
    from dyncontact import mesh_io

    def nodes(m, name):
        got = m.lower_nodes[m.lower_group == m.group(name)]
        assert np.all(np.diff(got) > 0)        # sorted, each node once
        return got

    def facet_nodes(m, name):
        return np.unique(m.facets[m.facet_group == m.group(name)])

    for geo, text, dim, h in (("plate.geo", PLATE_GEO, 2, 0.1),
                              ("block.geo", BLOCK_GEO, 3, 0.05)):
        (tmp_path / geo).write_text(text)
        mesh = tmp_path / geo
        if fmt != "geo":
            _, version, binary = next(f for f in MSH_FORMATS if f[0] == fmt)
            mesh = tmp_path / (geo[:-4] + fmt)
            write_msh(tmp_path / geo, dim, mesh, version, binary)
        m = mesh_io.read_mesh(mesh, h=h)
        lower = {m.group_names[g] for g in m.lower_group}
        if dim == 2:
            assert lower == {"top_points", "pin"}
            assert np.array_equal(nodes(m, "top_points"), facet_nodes(m, "top"))
            assert len(nodes(m, "top_points")) == 7
            assert np.array_equal(nodes(m, "pin"),
                                  np.flatnonzero(np.hypot(*m.x.T) < 1e-12))
        else:
            assert lower == {"lid_corners", "lid_edges", "edge", "corner"}
            for name in ("lid_corners", "lid_edges"):
                assert np.array_equal(nodes(m, name), facet_nodes(m, "lid"))
            on_edge = np.flatnonzero(np.hypot(m.x[:, 0], m.x[:, 1]) < 1e-12)
            assert np.array_equal(nodes(m, "edge"), on_edge)


def test_a_point_group_off_the_body_is_refused(tmp_path):
    """A .geo's Physical Point at a geometry point outside the meshed surface: refused
    when the mesh is read (exit 2, naming the file and the group), as a .msh's node in no
    cell is; it would otherwise hold nothing where the scene meant to hold a node."""
    (tmp_path / "plate.geo").write_text(PLATE_GEO + "Point(99) = {0.5, 0.5, 0};\n"
                                        'Physical Point("off") = {99};\n')
    scene = tmp_path / "s.nml"
    scene.write_text(PLATE_SCENE.format(h=0.1, mesh="plate.geo", clamped="top"))
    line = one_line(run("exe", "s.nml", "--out", "o", cwd=tmp_path), EXIT_BAD_INPUT)
    assert line == ("dyncontact: s.nml: &mesh file: plate.geo: physical group 'off' has a "
                    "node in no cell (the cells are the 3-node triangles)")
