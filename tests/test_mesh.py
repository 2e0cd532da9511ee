"""Meshes: the core's reader (gmsh's API) against meshio, the built-in bar
against GetFEM's structured meshes (meshes/bar2d_getfem_h*.msh, copies of
shared/reference/meshes), the generated bar of meshes/bar2d.geo, and clean errors
on bad files (stat 2, message starting with the path).

The Fortran side is reached through dyncontact._core.dc_mesh_sizes /
dc_mesh_arrays (via dyncontact.core.load_mesh and mesh_io.read_msh_fortran /
builtin_bar).
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pytest

from conftest import callers_gmsh_session, gmsh_session, write_msh41
from dyncontact import mesh_io
from dyncontact.core import BadInputError, DyncontactError

ROOT = Path(__file__).resolve().parents[1]
MESHES = ROOT / "meshes"
REFERENCE_H = (0.05, 0.02, 0.01)

#: GetFEM writes coordinates with 16 significant digits: the built-in bar (computed
#: as i*(width/nx), like GetFEM) agrees with the files to one rounding of ~1 m
ATOL_COORD = 1e-15
#: coordinates are matched to nodes on this grid when comparing up to numbering
KEY_GRID = 1e-9

STAT_OK, STAT_BAD_INPUT = 0, 2


def reference(h: float) -> Path:
    return MESHES / f"bar2d_getfem_h{h}.msh"


def _msg(errmsg) -> str:
    if isinstance(errmsg, bytes):
        errmsg = errmsg.decode("utf-8", "replace")
    return str(errmsg).strip().strip("\x00").strip()


def fortran_sizes(core_ext, path) -> tuple[int, str]:
    """stat and message of the Fortran reader on `path`."""
    handle, *_, stat, errmsg = core_ext.dc_mesh_sizes(str(path), 2, 1.0, 0.1, 0.05, 1, 7, 0)
    core_ext.dc_mesh_free(handle)
    return int(stat), _msg(errmsg)


# --------------------------------------------------------------------------- comparisons

def assert_same_mesh(a: mesh_io.MeshData, b: mesh_io.MeshData, atol: float = 0.0) -> None:
    """Same arrays (same numbering)."""
    assert a.dim == b.dim
    assert a.group_names == b.group_names
    np.testing.assert_array_equal(a.group_dim, b.group_dim)
    np.testing.assert_allclose(a.x, b.x, rtol=0, atol=atol, err_msg="coordinates")
    np.testing.assert_array_equal(a.cells, b.cells, err_msg="cells")
    np.testing.assert_array_equal(a.cell_group, b.cell_group, err_msg="cell groups")
    np.testing.assert_array_equal(a.facets, b.facets, err_msg="facets")
    np.testing.assert_array_equal(a.facet_group, b.facet_group, err_msg="facet groups")


class Form(NamedTuple):
    """A mesh as the readers are compared: coordinates and cells in their numbering,
    groups and facets by name (facets sorted, so independent of their order)."""

    dim: int
    groups: list          # (name, dim) of the groups compared, in the reader's order
    x: np.ndarray
    cells: np.ndarray
    cell_groups: list     # name of the group of each cell ("" if none)
    facets: list          # sorted (group name, node, ...) of each facet of those groups
    unnamed: list = []    # (meshio) facets of unnamed groups that are their entity's first


def form(m: mesh_io.MeshData, names=None) -> Form:
    """The Form of `m`, keeping the facets of the groups in `names` (default: all)."""
    keep = list(m.group_names) if names is None else list(names)
    return Form(
        dim=m.dim,
        groups=[(n, int(d)) for n, d in zip(m.group_names, m.group_dim) if n in keep],
        x=m.x,
        cells=m.cells,
        cell_groups=[m.group_names[g] if g >= 0 else "" for g in m.cell_group],
        facets=sorted((m.group_names[g],) + tuple(int(i) for i in f)
                      for f, g in zip(m.facets, m.facet_group) if m.group_names[g] in keep),
    )


#: meshio cell types -> dimension (first-order simplices only)
MESHIO_DIM = {"vertex": 0, "line": 1, "triangle": 2}


def meshio_form(path) -> Form:
    """The Form of a .msh file read by meshio, independently of dyncontact.

    meshio numbers nodes in file order (the Fortran reader in tag order: the same for
    the files gmsh writes) and keeps the blocks of elements in file order. It names the
    groups of $PhysicalNames (``field_data``: name -> (tag, dim)) and lists the
    elements of each (``cell_sets``, all groups of an entity); ``cell_data
    ['gmsh:physical']`` holds the first group of each element's entity. Unnamed groups
    are known only through that first group: their facets are not in ``facets``, and
    those meshio sees are in ``unnamed``. Cells take the first group, named or not
    (then by its tag).
    """
    import meshio

    m = meshio.read(path, file_format="gmsh")
    named = list(m.field_data)
    name_of = {(int(t), int(d)): n for n, (t, d) in m.field_data.items()}
    dims = [MESHIO_DIM[b.type] for b in m.cells]
    dim = max(d for d, b in zip(dims, m.cells) if len(b.data))
    first = m.cell_data["gmsh:physical"]
    cells = [b.data for d, b in zip(dims, m.cells) if d == dim]
    cell_groups = [name_of.get((int(t), dim), str(t))
                   for d, tags in zip(dims, first) if d == dim for t in tags]
    facets = sorted((n,) + tuple(int(i) for i in m.cells[k].data[e])
                    for n in named for k, elems in enumerate(m.cell_sets[n])
                    if dims[k] == dim - 1 for e in elems)
    unnamed = sorted((str(t),) + tuple(int(i) for i in f)
                     for d, b, tags in zip(dims, m.cells, first) if d == dim - 1
                     for f, t in zip(b.data, tags) if (int(t), d) not in name_of)
    return Form(dim=dim, groups=[(n, int(m.field_data[n][1])) for n in named],
                x=m.points[:, :dim], cells=np.concatenate(cells).astype(np.int64),
                cell_groups=cell_groups, facets=facets, unnamed=unnamed)


def assert_same_form(a: Form, b: Form, atol: float = 0.0) -> None:
    """Same numbering, groups, cells and facets."""
    assert a.dim == b.dim
    assert a.groups == b.groups
    np.testing.assert_allclose(a.x, b.x, rtol=0, atol=atol, err_msg="coordinates")
    np.testing.assert_array_equal(a.cells, b.cells, err_msg="cells")
    assert a.cell_groups == b.cell_groups, "cell groups"
    assert a.facets == b.facets, "facets (with their groups)"


def assert_matches_meshio(m: mesh_io.MeshData, path, atol: float = 0.0) -> None:
    """`m` is the mesh meshio reads from `path` (groups beyond meshio's named ones are
    unnamed: named by their tag)."""
    ref = meshio_form(path)
    named = [n for n, _ in ref.groups]
    assert all(n.isdigit() for n in m.group_names if n not in named), m.group_names
    assert_same_form(form(m, named), ref, atol)
    others = Counter(form(m).facets) - Counter(form(m, named).facets)
    assert not Counter(ref.unnamed) - others, "facets of unnamed groups"


def canonical(f: Form):
    """Nodes, cells and facets as sets of coordinate keys: independent of numbering
    and of the vertex order in each simplex."""
    keys = [tuple(k) for k in np.round(f.x / KEY_GRID).astype(np.int64)]
    assert len(set(keys)) == len(keys), "two nodes at the same place"
    nodes = sorted(keys)
    cells = sorted(tuple(sorted(keys[i] for i in c)) + (g,)
                   for c, g in zip(f.cells, f.cell_groups))
    facets = sorted((fa[0],) + tuple(sorted(keys[i] for i in fa[1:])) for fa in f.facets)
    return nodes, cells, facets


def assert_same_up_to_numbering(a: Form, b: Form) -> None:
    assert a.dim == b.dim
    assert a.groups == b.groups
    na, ca, fa = canonical(a)
    nb, cb, fb = canonical(b)
    assert na == nb, "nodes differ"
    assert ca == cb, "cells (as node sets, with groups) differ"
    assert fa == fb, "facets (as node sets, with groups) differ"


# --------------------------------------------------------------------------- generated files

def write_line_mesh(path: Path, n: int, split: bool, extra_groups: bool) -> Path:
    """A 1D gmsh mesh of [0, 1] (n segments per line), points bottom/top, line body."""
    with gmsh_session("line") as gmsh:
        geo = gmsh.model.geo
        p1 = geo.addPoint(0, 0, 0, 1 / n)
        p2 = geo.addPoint(1, 0, 0, 1 / n)
        if split:
            pm = geo.addPoint(0.4, 0, 0, 1 / n)
            lines = [geo.addLine(p1, pm), geo.addLine(pm, p2)]
        else:
            lines = [geo.addLine(p1, p2)]
        geo.synchronize()
        gmsh.model.addPhysicalGroup(0, [p1], 1, "bottom")
        gmsh.model.addPhysicalGroup(0, [p2], 2, "top")
        gmsh.model.addPhysicalGroup(1, lines, 3, "body")
        if extra_groups:
            gmsh.model.addPhysicalGroup(0, [p1], 4, "contact")   # p1 in two groups
            gmsh.model.addPhysicalGroup(0, [p1, p2], 7)          # unnamed
            gmsh.model.addPhysicalGroup(1, lines[:1], 8, "left_part")
        gmsh.model.mesh.generate(1)
        write_msh41(gmsh, path)
    return path


def write_multi_group_mesh(path: Path) -> Path:
    """An unstructured 2D rectangle whose boundary curves are in several groups
    (named and unnamed), with a corner point group and two cell groups."""
    with gmsh_session("multi") as gmsh:
        r = gmsh.model.occ.addRectangle(0, 0, 0, 1, 0.5)
        gmsh.model.occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.2)
        curves = [c[1] for c in gmsh.model.getBoundary([(2, r)], oriented=False)]
        gmsh.model.addPhysicalGroup(1, curves[:1], 11, "contact")
        gmsh.model.addPhysicalGroup(1, curves[:2], 12, "bottom")
        gmsh.model.addPhysicalGroup(1, curves[2:3], 13)
        gmsh.model.addPhysicalGroup(0, [1], 14, "corner")
        gmsh.model.addPhysicalGroup(2, [r], 15, "body")
        gmsh.model.addPhysicalGroup(2, [r], 16, "body2")
        gmsh.model.mesh.generate(2)
        write_msh41(gmsh, path)
    return path


@pytest.fixture(scope="module")
def generated(tmp_path_factory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("meshes")
    return {
        "bar2d_h0.05": mesh_io.generate_bar(0.05, d / "bar2d_h0.05.msh"),
        "bar2d_h0.02": mesh_io.generate_bar(0.02, d / "bar2d_h0.02.msh"),
        "bar2d_wide": mesh_io.generate_bar(0.1, d / "bar2d_wide.msh", length=2.0, width=0.7),
        "line": write_line_mesh(d / "line.msh", 10, split=False, extra_groups=False),
        "line_multi": write_line_mesh(d / "line_multi.msh", 7, split=True, extra_groups=True),
        "multi2d": write_multi_group_mesh(d / "multi2d.msh"),
    }


# --------------------------------------------------------------------------- Fortran vs meshio

@pytest.mark.parametrize("h", REFERENCE_H)
def test_fortran_reader_matches_meshio_reference(core_ext, h):
    f = mesh_io.read_msh_fortran(reference(h))
    assert_matches_meshio(f, reference(h))
    assert f.group_names == ["bottom", "top", "left", "right", "body"]
    np.testing.assert_array_equal(f.group_dim, [1, 1, 1, 1, 2])


@pytest.mark.parametrize("name", ["bar2d_h0.05", "bar2d_h0.02", "bar2d_wide", "line",
                                  "line_multi", "multi2d"])
def test_fortran_reader_matches_meshio_generated(core_ext, generated, name):
    f = mesh_io.read_msh_fortran(generated[name])
    assert_matches_meshio(f, generated[name])


def test_multi_group_conventions(core_ext, generated):
    m = mesh_io.read_msh_fortran(generated["multi2d"])
    # $PhysicalNames order (gmsh writes it by dimension, then tag), unnamed ones last
    assert m.group_names == ["corner", "contact", "bottom", "body", "body2", "13"]
    np.testing.assert_array_equal(m.group_dim, [0, 1, 1, 2, 2, 1])
    # cells take the first group of their entity; the corner point is dropped in 2D
    assert set(m.cell_group) == {m.group("body")}
    counts = np.bincount(m.facet_group, minlength=len(m.group_names))
    assert counts[m.group("corner")] == 0
    # the 'contact' curve's segments are stored again for 'bottom'
    contact = {frozenset(f) for f in m.facets[m.facet_group == m.group("contact")]}
    bottom = {frozenset(f) for f in m.facets[m.facet_group == m.group("bottom")]}
    assert contact and contact < bottom


def test_line_mesh_conventions(core_ext, generated):
    m = mesh_io.read_msh_fortran(generated["line_multi"])
    assert m.dim == 1 and m.x.shape[1] == 1
    # $PhysicalNames order (by dimension, then tag, as gmsh writes it), unnamed last
    assert m.group_names == ["bottom", "top", "contact", "body", "left_part", "7"]
    np.testing.assert_array_equal(m.group_dim, [0, 0, 0, 1, 1, 0])
    node0 = int(np.argmin(m.x[:, 0]))
    node1 = int(np.argmax(m.x[:, 0]))
    facets = sorted((m.group_names[g], int(f[0])) for f, g in zip(m.facets, m.facet_group))
    assert facets == sorted([("bottom", node0), ("contact", node0), ("7", node0),
                             ("top", node1), ("7", node1)])
    # the first line is in body and left_part: its cells get the first, body
    assert set(m.cell_group) == {m.group("body")}
    assert np.isclose(np.abs(np.diff(m.x[m.cells][:, :, 0], axis=1)).sum(), 1.0)


# --------------------------------------------------------------------------- built-in bar

@pytest.mark.parametrize("h", REFERENCE_H)
def test_builtin_bar_equals_getfem_mesh(core_ext, h):
    bar = mesh_io.builtin_bar(2, 1.0, 0.1, h)
    assert_same_up_to_numbering(form(bar), meshio_form(reference(h)))
    # stronger: GetFEM's numbering and vertex order too (facet order: Fortran reader)
    assert_matches_meshio(bar, reference(h), atol=ATOL_COORD)
    assert_same_mesh(bar, mesh_io.read_msh_fortran(reference(h)), atol=ATOL_COORD)


@pytest.mark.parametrize("h", [0.05, 0.02])
def test_generated_bar_equals_builtin(core_ext, generated, h):
    bar = mesh_io.builtin_bar(2, 1.0, 0.1, h)
    assert_same_up_to_numbering(form(bar), meshio_form(generated[f"bar2d_h{h}"]))


def test_generated_wide_bar_equals_builtin(core_ext, generated):
    bar = mesh_io.builtin_bar(2, 2.0, 0.7, 0.1)
    assert_same_up_to_numbering(form(bar), meshio_form(generated["bar2d_wide"]))


def test_builtin_bar_2d_structure(core_ext):
    m = mesh_io.builtin_bar(2, 1.0, 0.1, 0.05)
    nx, ny = 2, 20
    assert m.x.shape == ((nx + 1) * (ny + 1), 2)
    assert m.cells.shape == (2 * nx * ny, 3)
    x, y = m.x[:, 0], m.x[:, 1]
    sides = {"bottom": (y, 0.0), "top": (y, 1.0), "left": (x, 0.0), "right": (x, 0.1)}
    for name, (coord, value) in sides.items():
        f = m.facets[m.facet_group == m.group(name)]
        assert len(f) == (nx if name in ("bottom", "top") else ny)
        assert np.all(coord[f] == value), name
    assert np.all(m.cell_group == m.group("body"))
    # all cells have area h^2/2, whatever their orientation
    p = m.x[m.cells]
    a, b = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    area = 0.5 * np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
    np.testing.assert_allclose(area, 0.05 ** 2 / 2, rtol=1e-12)


# n = nint(length/h) (half away from zero), at least 1
@pytest.mark.parametrize("length,h,n", [(1.0, 0.1, 10), (1.0, 0.03, 33), (2.5, 1.0, 3),
                                        (1.0, 5.0, 1)])
def test_builtin_bar_1d(core_ext, length, h, n):
    m = mesh_io.builtin_bar(1, length, 0.1, h)
    assert m.dim == 1
    np.testing.assert_allclose(m.x[:, 0], np.arange(n + 1) * (length / n), rtol=0,
                               atol=4 * np.finfo(float).eps * length)
    assert m.x[-1, 0] == length
    np.testing.assert_array_equal(m.cells, np.stack([np.arange(n), np.arange(1, n + 1)], 1))
    assert m.group_names == ["bottom", "top", "body"]
    np.testing.assert_array_equal(m.group_dim, [0, 0, 1])
    np.testing.assert_array_equal(m.facets[:, 0], [0, n])
    np.testing.assert_array_equal(m.facet_group, [0, 1])
    np.testing.assert_array_equal(m.cell_group, 2)


def test_builtin_bar_1d_equals_gmsh_line(core_ext, generated):
    bar = mesh_io.builtin_bar(1, 1.0, 0.1, 0.1)
    assert_same_up_to_numbering(form(bar), meshio_form(generated["line"]))


@pytest.mark.parametrize("args,fragment", [
    ((2, 1.0, 0.1, 0.0), "h = "),
    ((2, 1.0, 0.1, -0.1), "h = "),
    ((1, 1.0, 0.1, float("nan")), "h = "),
    ((4, 1.0, 0.1, 0.1), "dim = 4"),
    ((3, 1.0, 0.0, 0.1), "width = "),
    ((0, 1.0, 0.1, 0.1), "dim = 0"),
    ((2, 1.0, 0.0, 0.1), "width = "),
    ((2, -1.0, 0.1, 0.1), "length = "),
    ((1, 1.0, 0.1, 1e-12), "cells"),
])
def test_builtin_bar_errors(core_ext, args, fragment):
    dim, length, width, h = args
    handle, *_, stat, errmsg = core_ext.dc_mesh_sizes("", dim, length, width, h, 1, 1, 0)
    core_ext.dc_mesh_free(handle)
    assert int(stat) == STAT_BAD_INPUT
    assert fragment in _msg(errmsg)
    with pytest.raises(BadInputError, match="built-in bar"):
        mesh_io.builtin_bar(dim, length, width, h)


def test_builtin_bar_1d_ignores_width(core_ext):
    assert_same_mesh(mesh_io.builtin_bar(1, 1.0, 0.0, 0.1), mesh_io.builtin_bar(1, 1.0, 5.0, 0.1))


# --------------------------------------------------------------------------- bad files

def _ref_text() -> str:
    return reference(0.05).read_text()


def _cut(text: str, start: str, end: str) -> str:
    i, j = text.index(start), text.index(end) + len(end) + 1
    return text[:i] + text[j:]


BAD_FILES = {
    # name: (contents from the h = 0.05 reference file, expected message fragment).
    # gmsh reads the file: its own message is quoted after "gmsh cannot read it: ".
    # Defects gmsh tolerates (a missing $EndElements, a missing $Entities, a node count
    # larger than the nodes listed, unquoted names) are not errors; a node count smaller
    # than the nodes listed makes gmsh 4.15 itself abort, so it is not tried here.
    "empty": (lambda t: "", "file is empty"),
    # gmsh 4.15 answers a blank file with a syntax error or with an empty mesh
    "blank": (lambda t: "\n  \n\n", ""),
    "garbage": (lambda t: "hello\nworld 1 2 3\n", "gmsh cannot read it: "),
    "binary_junk": (lambda t: "".join(map(chr, range(1, 256))) * 4, "gmsh cannot read it: "),
    "binary_header": (lambda t: t.replace("4.1 0 8", "4.1 1 8"),
                      "no segments, triangles or tetrahedra"),
    "version22": (lambda t: t.replace("4.1 0 8", "2.2 0 8"), "gmsh cannot read it: "),
    "version40": (lambda t: t.replace("4.1 0 8", "4 0 8"), "gmsh cannot read it: "),
    "truncated_nodes": (lambda t: t[:t.index("0.05 0.45 0")],
                        "gmsh cannot read it: Could not read nodes"),
    "truncated_elements": (lambda t: t[:t.index("57 47 43 46")],
                           "gmsh cannot read it: Could not read elements"),
    "missing_nodes": (lambda t: _cut(t, "$Nodes", "$EndNodes"), "Unknown node 1 in element"),
    "missing_elements": (lambda t: _cut(t, "$Elements", "$EndElements"),
                         "no segments, triangles or tetrahedra"),
    "missing_format": (lambda t: _cut(t, "$MeshFormat", "$EndMeshFormat"),
                       "gmsh cannot read it: "),
    "too_few_elements": (lambda t: t.replace("2 1 2 80", "2 1 2 79"),
                         "its $Elements section header gives 124, its blocks hold 123"),
    "too_many_elements": (lambda t: t.replace("2 1 2 80", "2 1 2 81"),
                          "gmsh cannot read it: Could not read elements"),
    "unknown_node": (lambda t: t.replace("\n80 63 59 60", "\n80 63 59 99"),
                     "Unknown node 99 in element 80"),
    "duplicate_node": (lambda t: t.replace("\n63\n0 0 0", "\n62\n0 0 0"), "Unknown node 63"),
    "not_a_number": (lambda t: t.replace("\n0.05 0.45 0\n", "\n0.05 abc 0\n"),
                     "Could not read nodes"),
    "nan": (lambda t: t.replace("\n0.05 0.45 0\n", "\n0.05 nan 0\n"), "non-finite"),
    "quadrangles": (lambda t: t.replace("2 1 2 80", "2 1 3 80"), "Could not read elements"),
    "unknown_entity": (lambda t: t.replace("1 4 1 20\n105", "1 9 1 20\n105"),
                       "Unknown entity 9 of dimension 1"),
    "not_planar": (lambda t: t.replace("\n0.05 0.45 0\n", "\n0.05 0.45 0.01\n"),
                   "the mesh is 2D but its z coordinates are not constant"),
    "comma_in_name": (lambda t: t.replace('"body"', '"bo,dy"'), "comma"),
    "degenerate_cell": (lambda t: t.replace("\n80 63 59 60", "\n80 63 59 63"), "degenerate"),
    "flat_cell": (lambda t: t.replace("\n80 63 59 60", "\n80 57 60 63"), "degenerate"),
    "orphan_facet": (lambda t: t.replace("\n82 2 5", "\n82 2 63"), "not a face of any cell"),
    "free_node": (lambda t: t.replace("5 63 1 63", "5 64 1 64").replace("2 1 0 63", "2 1 0 64")
                  .replace("\n63\n0 0 0\n", "\n63\n64\n0 0 0\n")
                  .replace("\n0.1 1 0\n$EndNodes", "\n0.1 1 0\n0.05 2 0\n$EndNodes"),
                  "node 64 (and 0 more) belongs to no cell"),
}


@pytest.mark.parametrize("name", sorted(BAD_FILES))
def test_bad_file_clean_error(core_ext, tmp_path, name):
    make, fragment = BAD_FILES[name]
    path = tmp_path / f"{name}.msh"
    path.write_text(make(_ref_text()))
    stat, msg = fortran_sizes(core_ext, path)
    assert stat == STAT_BAD_INPUT, msg
    assert msg.startswith(str(path) + ": "), msg
    assert fragment in msg, msg
    assert "\n" not in msg
    with pytest.raises(BadInputError) as exc:
        mesh_io.read_msh_fortran(path)
    assert str(path) in str(exc.value)


def test_missing_file(core_ext, tmp_path):
    path = tmp_path / "nope.msh"
    stat, msg = fortran_sizes(core_ext, path)
    assert stat == STAT_BAD_INPUT
    assert msg == f"{path}: no such file"
    with pytest.raises(BadInputError, match="no such file"):
        mesh_io.read_msh_fortran(path)


def test_directory_is_not_a_mesh(core_ext, tmp_path):
    stat, msg = fortran_sizes(core_ext, tmp_path)
    assert stat == STAT_BAD_INPUT and msg.startswith(str(tmp_path))


def test_gmsh_binary_and_v22_files_read(core_ext, tmp_path):
    """The reference mesh as gmsh writes it in the other formats reads as the original,
    and as meshio reads those files (independently of gmsh)."""
    import gmsh
    import meshio

    gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.merge(str(reference(0.05)))
        for name, binary, version in [("bin41", 1, 4.1), ("ascii22", 0, 2.2), ("bin22", 1, 2.2)]:
            gmsh.option.setNumber("Mesh.Binary", binary)
            gmsh.option.setNumber("Mesh.MshFileVersion", version)
            gmsh.write(str(tmp_path / f"{name}.msh"))
    finally:
        gmsh.finalize()
    ref = mesh_io.read_msh_fortran(reference(0.05))
    ref_meshio = meshio.read(reference(0.05))
    for name in ("bin41", "ascii22", "bin22"):
        path = tmp_path / f"{name}.msh"
        assert_same_mesh(mesh_io.read_msh_fortran(path), ref)
        m = meshio.read(path, file_format="gmsh")
        np.testing.assert_array_equal(m.points, ref_meshio.points, err_msg=name)
        np.testing.assert_array_equal(m.get_cells_type("triangle"),
                                      ref_meshio.get_cells_type("triangle"), err_msg=name)


def test_tolerated_variants(core_ext, tmp_path):
    """CRLF line ends, no final newline, unknown sections, parametric nodes and
    non-contiguous node tags read as the original."""
    text = _ref_text()
    ref = mesh_io.read_msh_fortran(reference(0.05))
    variants = {
        "crlf": text.replace("\n", "\r\n"),
        "no_final_newline": text.rstrip("\n"),
        "comments": text.replace("$Nodes", "$Comments\n$Nodes in a comment\n$EndComments\n$Nodes"),
        "shifted_tags": _shift_node_tags(text, 1000, 3),
        "shuffled_nodes": _shuffle_nodes(text, np.random.default_rng(1)),
    }
    for name, contents in variants.items():
        path = tmp_path / f"{name}.msh"
        path.write_bytes(contents.encode())
        assert_same_mesh(mesh_io.read_msh_fortran(path), ref)
    assert_matches_meshio(ref, tmp_path / "shifted_tags.msh")


def _shuffle_nodes(text: str, rng) -> str:
    """The same mesh with the nodes of each $Nodes block listed in random order."""
    lines = text.split("\n")
    i = lines.index("$Nodes") + 1
    nblocks = int(lines[i].split()[0])
    i += 1
    for _ in range(nblocks):
        c = int(lines[i].split()[3])
        p = rng.permutation(c)
        tags, xyz = lines[i + 1:i + 1 + c], lines[i + 1 + c:i + 1 + 2 * c]
        lines[i + 1:i + 1 + c] = [tags[k] for k in p]
        lines[i + 1 + c:i + 1 + 2 * c] = [xyz[k] for k in p]
        i += 1 + 2 * c
    return "\n".join(lines)


def _shift_node_tags(text: str, offset: int, stride: int) -> str:
    """The same mesh with node tag t renamed offset + stride*t (non-contiguous)."""
    def rename(t: str) -> str:
        return str(offset + stride * int(t))

    lines = text.split("\n")
    out, i = [], 0
    while i < len(lines):
        line = lines[i]
        out.append(line)
        i += 1
        if line == "$Nodes":
            nblocks, nnodes, _, _ = map(int, lines[i].split())
            out.append(f"{nblocks} {nnodes} {rename('1')} {rename(str(nnodes))}")
            i += 1
            for _ in range(nblocks):
                d, t, p, c = map(int, lines[i].split())
                out.append(lines[i])
                out += [rename(s) for s in lines[i + 1:i + 1 + c]]
                out += lines[i + 1 + c:i + 1 + 2 * c]
                i += 1 + 2 * c
        elif line == "$Elements":
            out.append(lines[i])
            nblocks = int(lines[i].split()[0])
            i += 1
            for _ in range(nblocks):
                c = int(lines[i].split()[3])
                out.append(lines[i])
                for s in lines[i + 1:i + 1 + c]:
                    w = s.split()
                    out.append(" ".join([w[0]] + [rename(v) for v in w[1:]]))
                i += 1 + c
    return "\n".join(out)


def test_degenerate_1d_segment(core_ext, tmp_path, generated):
    """A segment whose two nodes are the same node."""
    lines = generated["line"].read_text().split("\n")
    i = lines.index("$Elements") + 2
    while lines[i].split()[2] != "1":       # the block of line elements (type 1)
        i += 1 + int(lines[i].split()[3])
    tag, n1, _ = lines[i + 1].split()
    lines[i + 1] = f"{tag} {n1} {n1}"
    path = tmp_path / "degenerate1d.msh"
    path.write_text("\n".join(lines))
    stat, msg = fortran_sizes(core_ext, path)
    assert stat == STAT_BAD_INPUT and "degenerate" in msg and msg.startswith(str(path)), msg


# --------------------------------------------------------------------------- gmsh hygiene, CLI

def test_gmsh_left_finalized(tmp_path):
    import gmsh

    mesh_io.generate_bar(0.1, tmp_path / "b.msh")
    assert not gmsh.isInitialized()


def test_gmsh_session_of_caller_kept(core_ext, tmp_path):
    """Inside a caller's gmsh session: its model, options and variables survive."""
    with callers_gmsh_session() as gmsh:
        binary = gmsh.option.getNumber("Mesh.Binary")
        mesh_io.generate_bar(0.1, tmp_path / "b.msh")
        m = mesh_io.read_msh_fortran(tmp_path / "b.msh")
        assert gmsh.model.getCurrent() == "mine"
        assert gmsh.model.getEntities() == [(0, 1)]
        assert gmsh.model.list() == ["", "mine"]
        assert gmsh.option.getNumber("Mesh.Binary") == binary
        assert "h" not in gmsh.parser.getNames()
    assert len(m.cells) == 2 * 1 * 10


def test_mesh_command(tmp_path, capsys):
    out = tmp_path / "bar2d_h0.05.msh"   # in an existing folder (tests/test_cli_options.py)
    assert mesh_io.main(["--h", "0.05", "--out", str(out)]) == 0
    assert out.read_text().startswith("$MeshFormat\n4.1 0 8\n")
    assert "63 nodes, 80 triangles" in capsys.readouterr().out
    assert mesh_io.main(["mesh", "--h", "-1", "--out", str(out)]) == 2
    assert "h = -1" in capsys.readouterr().err


def test_mesh_command_via_cli(run_cli, tmp_path):
    r = run_cli("mesh", "--h", "0.1", "--out", "m.msh", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "m.msh").is_file()


def test_mesh_command_writes_through_a_symbolic_link(run_cli, tmp_path):
    """`--out LINK.msh`, a symbolic link (relative, to an existing file or to one not yet
    there), writes the file it points to and stays a link, as a write into it would: the
    mesh is written under a temporary name beside the link's target and renamed to it."""
    meshes = tmp_path / "meshes"
    meshes.mkdir()
    (meshes / "old.msh").write_text("old\n")
    (tmp_path / "LINK.msh").symlink_to(Path("meshes") / "old.msh")
    (tmp_path / "NEW.msh").symlink_to(Path("meshes") / "new.msh")    # dangling
    for link, target in (("LINK.msh", "old.msh"), ("NEW.msh", "new.msh")):
        r = run_cli("mesh", "--h", "0.1", "--out", link, cwd=tmp_path)
        assert r.returncode == 0, r.stderr
        assert r.stdout.startswith(f"dyncontact mesh: wrote {link}: "), r.stdout
        assert (tmp_path / link).is_symlink()
        assert (tmp_path / link).readlink() == Path("meshes") / target
        assert (meshes / target).read_text().startswith("$MeshFormat\n4.1 0 8\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["LINK.msh", "NEW.msh", "meshes"]
    assert sorted(p.name for p in meshes.iterdir()) == ["new.msh", "old.msh"]
    (tmp_path / "loop1.msh").symlink_to("loop2.msh")
    (tmp_path / "loop2.msh").symlink_to("loop1.msh")
    with pytest.raises(DyncontactError, match="loop1.msh: cannot write it: Too many levels"):
        mesh_io.generate_bar(0.1, tmp_path / "loop1.msh")
    assert (tmp_path / "loop1.msh").readlink() == Path("loop2.msh")


def test_generate_through_a_link_creates_its_targets_folders(tmp_path):
    """generate_bar's `out_path` folders are created, through a symbolic link too: a link
    to a file in folders not yet there gets them, and the mesh, and stays a link."""
    (tmp_path / "LINK.msh").symlink_to(Path("new") / "sub" / "m.msh")
    mesh_io.generate_bar(0.1, tmp_path / "LINK.msh")
    assert (tmp_path / "LINK.msh").is_symlink()
    assert (tmp_path / "new" / "sub" / "m.msh").read_text().startswith("$MeshFormat\n")
    assert sorted(p.name for p in (tmp_path / "new" / "sub").iterdir()) == ["m.msh"]


def test_mesh_command_help(run_cli, tmp_path):
    r = run_cli("mesh", "--help", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("usage: python -m dyncontact mesh") and "--out FILE.msh" in r.stdout
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("args, words", [
    (("--out", "x.msh", "--bogus"), "unrecognized arguments: --bogus"),
    (("--out", "x.msh", "--h", "abc"), "argument --h: invalid float value: 'abc'"),
    ((), "the following arguments are required: --out"),
])
def test_mesh_command_line_errors_are_one_line(capsys, tmp_path, monkeypatch, args, words):
    """argparse's errors of `mesh` were its usage and the message, while the command's
    other errors and the other commands' are one line: one line naming the mesh
    command's help, exit 2, nothing written."""
    from dyncontact.cli import main

    monkeypatch.chdir(tmp_path)
    assert main(["mesh", *args]) == 2
    err = capsys.readouterr().err
    assert err == f"dyncontact mesh: {words} (see `python -m dyncontact mesh --help`)\n", err
    assert list(tmp_path.iterdir()) == []


#: Two squares' four triangles on [0, 1]^2 (MSH 2.2): 'bottom' and 'top' on the boundary,
#: 'mid' the edge y = 0.5 between the two squares, a face of two triangles.
TWO_SQUARES_MSH = """$MeshFormat
2.2 0 8
$EndMeshFormat
$PhysicalNames
4
1 1 "bottom"
1 2 "mid"
1 3 "top"
2 4 "body"
$EndPhysicalNames
$Nodes
6
1 0 0 0
2 1 0 0
3 0 0.5 0
4 1 0.5 0
5 0 1 0
6 1 1 0
$EndNodes
$Elements
7
1 1 2 1 1 1 2
2 1 2 2 2 3 4
3 1 2 3 3 5 6
4 2 2 4 1 1 2 4
5 2 2 4 1 1 4 3
6 2 2 4 1 3 4 6
7 2 2 4 1 3 6 5
$EndElements
"""


def test_a_contact_group_inside_the_body_is_refused(tmp_path):
    """A contact facet that is a face of two cells lies inside the body and cannot touch
    the obstacle: the scene is refused naming &boundary contact (the same mesh's boundary
    group runs)."""
    import dyncontact
    from dyncontact import Scene

    (tmp_path / "m.msh").write_text(TWO_SQUARES_MSH)
    (tmp_path / "s.nml").write_text(
        "&mesh file = 'm.msh' /\n&boundary clamped = 'top', contact = 'mid' /\n"
        "&contact obstacle_point = 0.0, 0.4, probe = 0.5, 0.5 /\n"
        "&initial kind = 'compressed_bar' /\n"
        "&scheme t_end = 0.01, dt = 0.005 /\n")
    with pytest.raises(dyncontact.BadInputError,
                       match=r"&boundary contact: a contact facet lies inside the body"):
        dyncontact.run(tmp_path / "s.nml", out=tmp_path / "o", progress=False)
    s = Scene.read(tmp_path / "s.nml")
    s.set("boundary.contact", "bottom")
    s.set("contact.probe", [0.5, 0.0])
    s.set("contact.obstacle_point", [0.0, 0.0])
    assert dyncontact.run(s, out=tmp_path / "o2", progress=False).status == "ok"


def test_a_mesh_in_parts_that_share_no_node_is_warned_about(tmp_path):
    """The two squares with the upper one's lower nodes duplicated (coincident, not
    merged: what a mesh of two volumes not made conforming gives) are two parts, each
    moving on its own: the run says so. The merged mesh runs without the warning."""
    import warnings

    import dyncontact

    split = (TWO_SQUARES_MSH.replace("$Nodes\n6\n", "$Nodes\n8\n")
             .replace("6 1 1 0\n$EndNodes", "6 1 1 0\n7 0 0.5 0\n8 1 0.5 0\n$EndNodes")
             .replace("6 2 2 4 1 3 4 6", "6 2 2 4 1 7 8 6")
             .replace("7 2 2 4 1 3 6 5", "7 2 2 4 1 7 6 5"))
    for name, text, parts in (("merged", TWO_SQUARES_MSH, 1), ("split", split, 2)):
        (tmp_path / f"{name}.msh").write_text(text)
        (tmp_path / f"{name}.nml").write_text(
            f"&mesh file = '{name}.msh' /\n&boundary clamped = 'top', contact = 'bottom' /\n"
            "&contact probe = 0.5, 0.0 /\n&initial kind = 'compressed_bar' /\n"
            "&scheme t_end = 0.01, dt = 0.005 /\n")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            res = dyncontact.run(tmp_path / f"{name}.nml", out=tmp_path / name, progress=False)
        assert res.status == "ok"
        said = [str(w.message) for w in caught if "share no node" in str(w.message)]
        assert len(said) == (parts > 1)
        if said:
            assert f"has {parts} parts that share no node" in said[0]
