"""The built-in 3D box (&mesh dim = 3): the same nodes and tetrahedra as GetFEM's
"regular simplices" mesh of the reference runs (shared/reference/meshes/
bar3d_getfem_h{0.05,0.025}.msh, copied unchanged to meshes/, read here with
gmsh's own Python API), compared as sets of node coordinates and of cells given as
node-coordinate tuples; its boundary groups; refused inputs."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest

from dyncontact.core import load_mesh

REF = Path(__file__).resolve().parents[1] / "meshes"


def read_gmsh(path):
    """Nodes (n, 3) and the elements of every physical group (1-based node tags)."""
    gmsh = pytest.importorskip("gmsh")
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.open(str(path))
        tags, coords, _ = gmsh.model.mesh.getNodes()
        x = np.zeros((int(tags.max()), 3))
        x[tags.astype(int) - 1] = coords.reshape(-1, 3)
        groups = {}
        for dim, tag in gmsh.model.getPhysicalGroups():
            name = gmsh.model.getPhysicalName(dim, tag)
            els = []
            for ent in gmsh.model.getEntitiesForPhysicalGroup(dim, tag):
                types, _, enodes = gmsh.model.mesh.getElements(dim, ent)
                for t, en in zip(types, enodes):
                    nn = gmsh.model.mesh.getElementProperties(t)[3]
                    els.append(en.reshape(-1, nn).astype(int))
            groups[name] = np.vstack(els)
    finally:
        gmsh.finalize()
    return x, groups


def as_sets(x, elements):
    """Elements as frozensets of coordinate tuples (exact floats)."""
    return {frozenset(tuple(x[i]) for i in e) for e in elements}


def box(h, length=1.0, width=0.1):
    m = load_mesh("", dim=3, length=length, width=width, h=h)
    groups = {name: m["facets"][m["facet_group"] == g]
              for g, name in enumerate(m["group_names"]) if m["group_dim"][g] == 2}
    return m, groups


@pytest.mark.parametrize("h", ["0.05", "0.025"])
def test_builtin_box_equals_getfem_mesh(h):
    x_ref, g_ref = read_gmsh(REF / f"bar3d_getfem_h{h}.msh")
    m, groups = box(float(h))
    x = m["x"]
    assert m["dim"] == 3
    assert {tuple(p) for p in x} == {tuple(p) for p in x_ref}
    assert len(m["cells"]) == len(g_ref["body"])
    # the same nodes in the same order, the same tetrahedra in the same vertex order
    np.testing.assert_array_equal(x, x_ref)
    np.testing.assert_array_equal(m["cells"] + 1, g_ref["body"])
    assert as_sets(x, m["cells"]) == as_sets(x_ref, g_ref["body"] - 1)
    for name in ("bottom", "top", "sides"):
        assert as_sets(x, groups[name]) == as_sets(x_ref, g_ref[name] - 1), name


def test_builtin_box_groups():
    length, width, h = 1.0, 0.1, 0.05
    m, groups = box(h)
    x = m["x"]
    faces = {"bottom": (2, 0.0), "top": (2, length), "left": (0, 0.0), "right": (0, width),
             "front": (1, 0.0), "back": (1, width)}
    for name, (axis, value) in faces.items():
        tri = groups[name]
        assert np.all(x[tri][..., axis] == value), name
        # two right triangles per square, covering the face once
        side = (width, width) if axis == 2 else (width, length)
        area = sum(0.5 * np.linalg.norm(np.cross(x[t[1]] - x[t[0]], x[t[2]] - x[t[0]]))
                   for t in tri)
        assert area == pytest.approx(side[0] * side[1], rel=1e-13), name
    lateral = np.vstack([groups[n] for n in ("left", "right", "front", "back")])
    assert as_sets(x, groups["sides"]) == as_sets(x, lateral)
    # every tetrahedron has volume h^3 / 6
    e = x[m["cells"][:, 1:]] - x[m["cells"][:, :1]]
    vol = np.abs(np.linalg.det(e)) / 6
    np.testing.assert_allclose(vol, h**3 / 6, rtol=1e-12)
    assert vol.sum() == pytest.approx(width * width * length, rel=1e-13)


def test_builtin_box_uneven_sizes():
    """h that does not divide the sides: n = nint(side / h) cuboids, ends exactly on the box."""
    m, _ = box(0.03, length=0.2, width=0.07)
    x = m["x"]
    assert x[:, 0].max() == 0.07 and x[:, 1].max() == 0.07 and x[:, 2].max() == 0.2
    assert len(m["cells"]) == 6 * 2 * 2 * 7


# --------------------------------------------------------------------------- bad 3D mesh files

#: The unit cube cut into 6 tetrahedra around its diagonal from node 0 to node 7 (node i at
#: (i & 1, i >> 1 & 1, i >> 2 & 1)), its bottom and top faces as the triangles of those
#: tetrahedra on z = 0 and z = 1.
CUBE_X = [[i & 1, i >> 1 & 1, i >> 2 & 1] for i in range(8)]
CUBE_TETS = [[0, 1, 3, 7], [0, 1, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 5, 7], [0, 4, 6, 7]]
CUBE_BOTTOM = [[0, 1, 3], [0, 2, 3]]
CUBE_TOP = [[4, 5, 7], [4, 6, 7]]


def cube_msh(path, *, tets=CUBE_TETS, bottom="triangles", plate=None):
    """Write the cube as a gmsh 4.1 ASCII file through gmsh's API: physical groups 'body'
    (the tetrahedra), 'top' (triangles) and 'bottom', made of the bottom face's
    'triangles', of its four edges ('segments') or of its four corners ('points').
    plate = 'grouped' / 'ungrouped': a square of two triangles beside the cube (at x = 2),
    in a physical group 'plate' or in none: a mesh with 2D and 3D cells."""
    gmsh = pytest.importorskip("gmsh")
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("cube")
        vol = gmsh.model.addDiscreteEntity(3)
        x = [c for p in CUBE_X for c in p]
        gmsh.model.mesh.addNodes(3, vol, list(range(1, 9)), x)
        gmsh.model.mesh.addElementsByType(vol, 4, [], [n + 1 for t in tets for n in t])
        top = gmsh.model.addDiscreteEntity(2)
        gmsh.model.mesh.addElementsByType(top, 2, [], [n + 1 for t in CUBE_TOP for n in t])
        dim, etype, elems = {"triangles": (2, 2, CUBE_BOTTOM),
                             "segments": (1, 1, [[0, 1], [1, 3], [3, 2], [2, 0]]),
                             "points": (0, 15, [[0], [1], [2], [3]])}[bottom]
        bot = gmsh.model.addDiscreteEntity(dim)
        gmsh.model.mesh.addElementsByType(bot, etype, [], [n + 1 for e in elems for n in e])
        gmsh.model.addPhysicalGroup(3, [vol], name="body")
        gmsh.model.addPhysicalGroup(2, [top], name="top")
        gmsh.model.addPhysicalGroup(dim, [bot], name="bottom")
        if plate:
            sq = gmsh.model.addDiscreteEntity(2)
            gmsh.model.mesh.addNodes(2, sq, [9, 10, 11, 12],
                                     [2, 0, 0, 3, 0, 0, 2, 1, 0, 3, 1, 0])
            gmsh.model.mesh.addElementsByType(sq, 2, [], [9, 10, 12, 9, 12, 11])
            if plate == "grouped":
                gmsh.model.addPhysicalGroup(2, [sq], name="plate")
        gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
        gmsh.option.setNumber("Mesh.Binary", 0)
        gmsh.option.setNumber("Mesh.SaveAll", 1 if plate == "ungrouped" else 0)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    return path


def run_scene(exe, tmp_path, mesh, mesh_keys="", contact="bottom"):
    """build/dyncontact on a 3D scene of the mesh file (the cube dropped at speed 1)."""
    scene = tmp_path / "s.nml"
    scene.write_text(
        f"&mesh file = '{mesh}' {mesh_keys} /\n"
        f"&boundary clamped = '', contact = '{contact}' /\n"
        "&contact obstacle_point = 0.0, 0.0, 0.0, obstacle_normal = 0.0, 0.0, -1.0,\n"
        "         probe = 0.5, 0.5, 0.0 /\n"
        "&initial kind = 'velocity', velocity = 0.0, 0.0, -1.0 /\n"
        "&scheme name = 'newmark', dt = 0.005, t_end = 0.01 /\n")
    r = subprocess.run([str(exe), str(scene), "--out", str(tmp_path / "o")],
                       capture_output=True, text=True, timeout=120)
    return scene, r


def test_cube_mesh_file_runs(exe, tmp_path):
    """The hand-made cube is a valid 3D mesh file: the bad files below each break one thing."""
    scene, r = run_scene(exe, tmp_path, cube_msh(tmp_path / "cube.msh"))
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "o" / "trace.csv").is_file()


def assert_refused(r, tmp_path, scene, *fragments):
    """Exit 2, one line on stderr naming the scene and each fragment, nothing written."""
    assert r.returncode == 2, (r.returncode, r.stdout, r.stderr)
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, r.stderr
    assert str(scene) in lines[0], lines[0]
    for f in fragments:
        assert f in lines[0], (f, lines[0])
    assert "Traceback" not in r.stderr
    assert not (tmp_path / "o" / "trace.csv").exists()


def test_zero_volume_tetrahedron_is_refused(exe, tmp_path):
    """A seventh tetrahedron on the four bottom corners (coplanar: volume 0)."""
    mesh = cube_msh(tmp_path / "flat.msh", tets=CUBE_TETS + [[0, 1, 2, 3]])
    scene, r = run_scene(exe, tmp_path, mesh)
    assert_refused(r, tmp_path, scene, "&mesh file:", str(mesh),
                   "cell 7 is degenerate (volume 0.000E+000")


@pytest.mark.parametrize("bottom", ["segments", "points"])
def test_contact_group_without_triangles_is_refused(exe, tmp_path, bottom):
    """The contact group of a 3D mesh file made of its bottom edges or corners."""
    mesh = cube_msh(tmp_path / f"{bottom}.msh", bottom=bottom)
    scene, r = run_scene(exe, tmp_path, mesh)
    assert_refused(r, tmp_path, scene, "&boundary contact:", str(mesh),
                   f"group 'bottom' has no facets in the mesh (its elements are {bottom}; "
                   "the facets of a 3D mesh are triangles)")


def test_volume_group_as_contact_is_refused(exe, tmp_path):
    mesh = cube_msh(tmp_path / "cube.msh")
    scene, r = run_scene(exe, tmp_path, mesh, contact="body")
    assert_refused(r, tmp_path, scene, "&boundary contact:", str(mesh),
                   "group 'body' has no facets in the mesh (its elements are tetrahedra")


@pytest.mark.parametrize("dim", [1, 2])
def test_3d_mesh_file_with_another_dim_given_is_refused(exe, tmp_path, dim):
    """&mesh dim is for the built-in bar; given with a 3D file it must be 3 (or left out)."""
    mesh = cube_msh(tmp_path / "cube.msh")
    scene, r = run_scene(exe, tmp_path, mesh, mesh_keys=f", dim = {dim}")
    assert_refused(r, tmp_path, scene, f"&mesh dim: {dim} given, but the mesh file",
                   str(mesh), "is 3D")
    scene, r = run_scene(exe, tmp_path, mesh, mesh_keys=", dim = 3")
    assert r.returncode == 0, r.stderr


@pytest.mark.parametrize("plate", ["grouped", "ungrouped"])
def test_mixed_2d_and_3d_cells_are_refused(exe, tmp_path, plate):
    """Two triangles beside the tetrahedra: in a physical group they are facets of no
    tetrahedron; in none they are dropped and their nodes belong to no cell."""
    mesh = cube_msh(tmp_path / "mixed.msh", plate=plate)
    scene, r = run_scene(exe, tmp_path, mesh)
    what = ("is not a face of any cell (group 'plate')" if plate == "grouped"
            else "node 9 (and 3 more) belongs to no cell")
    assert_refused(r, tmp_path, scene, "&mesh file:", str(mesh), what,
                   "the cells are the tetrahedra")
