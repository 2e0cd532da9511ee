"""The built-in 3D box (&mesh dim = 3): the same nodes and tetrahedra as GetFEM's
"regular simplices" mesh of the reference runs (shared/reference/meshes/
bar3d_getfem_h{0.05,0.025}.msh, copied unchanged to meshes/, read here with
gmsh's own Python API), compared as sets of node coordinates and of cells given as
node-coordinate tuples; its boundary groups; refused inputs."""

from __future__ import annotations

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
