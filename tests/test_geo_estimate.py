"""A .geo too large for &mesh max_elements is refused before gmsh meshes it
(fortran/io/gmsh_shim.c, geo_estimate; docs/scenes.md, "How large a .geo will be"): a
cylinder drawn in mm meshed at an h meant in m asked gmsh for some 1e11 tetrahedra, 10 GB
after 8 minutes, with Ctrl-C held until gmsh returned. The estimate (the measure of the
cells' entities over the cell size of the mesh size) is checked against gmsh's own meshes
here on a few shapes, within the band docs/scenes.md gives; a mesh that fits is never
refused by it."""

from __future__ import annotations

import time

import pytest

import dyncontact
from dyncontact import core
from conftest import ROOT, stderr_line

GEO = ROOT / "tests" / "data" / "geo"
CYL_MM = GEO / "cylinder_mm.geo"

#: The band of cells / estimate that docs/scenes.md gives for meshes of 1 000 cells and
#: more (measured with scripts/geo_estimate: 0.96 to 1.10 on boxes, cylinders, balls,
#: rectangles, disks and annuli of 1 000 to 340 000 cells).
BAND = (0.9, 1.2)
#: Seconds a refusal may take: it parses the file and measures it, no mesh (measured
#: 0.03 s for the executable, and 0.3 s for `python -m dyncontact run`, imports included;
#: the bound leaves room for a loaded machine).
FAST = 1.0


def scene_text(geo, extra: str = "") -> str:
    """A scene on the .geo `geo` (3D: the mm cylinder; `extra`: more &mesh keys)."""
    return (f"&mesh file = '{geo}'{extra} /\n"
            "&boundary clamped = '', contact = 'surface' /\n"
            "&contact obstacle_point = 0.0, 0.0, 0.0, obstacle_normal = 0.0, 0.0, -1.0 /\n"
            "&initial kind = 'rest' /\n"
            "&scheme dt = 0.01, t_end = 0.02 /\n")


@pytest.mark.parametrize("entry", ["exe", "cli"])
def test_tiny_h_refused_before_meshing(entry, tmp_path, run_exe, run_cli):
    """h = 0.05 on the cylinder in mm (radius 100): about 6e10 elements estimated, refused
    in well under a second with one line naming the file, &mesh max_elements and
    &mesh h, exit 2, from the executable and from `python -m dyncontact run`."""
    (tmp_path / "s.nml").write_text(scene_text(CYL_MM, ", h = 0.05"))
    run = run_exe if entry == "exe" else run_cli
    args = ("s.nml", "--out", "o") if entry == "exe" else ("run", "s.nml", "--out", "o")
    t0 = time.perf_counter()
    r = run(*args)
    elapsed = time.perf_counter() - t0
    line = stderr_line(r, 2)
    assert "cylinder_mm.geo: about 5.9" in line and "elements estimated before meshing" in line
    assert "&mesh max_elements = 2000000" in line and "&mesh h" in line, line
    assert elapsed < FAST * (1 if entry == "exe" else 3), elapsed
    assert not (tmp_path / "o").exists() or not any((tmp_path / "o").iterdir())


def test_tiny_h_refused_by_the_api(tmp_path):
    """dyncontact.run and Scene.dimension() (which reads the file for its dimension)
    raise BadInputError with the same line, without meshing."""
    (tmp_path / "s.nml").write_text(scene_text(CYL_MM, ", h = 0.05"))
    scene = dyncontact.Scene.read(tmp_path / "s.nml")
    for call in (lambda: dyncontact.run(scene, out=tmp_path / "o"), scene.dimension):
        t0 = time.perf_counter()
        with pytest.raises(dyncontact.BadInputError) as exc:
            call()
        assert time.perf_counter() - t0 < FAST
        msg = str(exc.value)
        assert "\n" not in msg and "&mesh max_elements = 2000000" in msg, msg
        assert "cylinder_mm.geo: about 5.9" in msg and "&mesh h" in msg, msg


def test_own_sizes_name_no_h(tmp_path, run_exe):
    """A scene that gives no h leaves the file its sizes: here a point size of 0.05 in a
    copy of the mm cylinder; the refusal names &mesh max_elements, not &mesh h."""
    geo = tmp_path / "cyl.geo"
    geo.write_text(CYL_MM.read_text() + "MeshSize{ PointsOf{ Volume{1}; } } = 0.05;\n")
    (tmp_path / "s.nml").write_text(scene_text("cyl.geo"))
    r = run_exe("s.nml", "--out", "o")
    line = stderr_line(r, 2)
    assert "&mesh max_elements" in line and "&mesh h" not in line, line
    assert "larger mesh sizes in the file" in line, line


def test_mesh_command_refuses(run_cli, tmp_path):
    """`dyncontact mesh --geo` refuses it too, naming --max-elements and --h; a larger
    --max-elements would let it through (checked on the estimate, not by meshing)."""
    t0 = time.perf_counter()
    r = run_cli("mesh", "--geo", CYL_MM, "--h", "0.05", "--out", "c.msh")
    assert r.returncode == 2, r.stderr
    assert time.perf_counter() - t0 < 3 * FAST
    line = stderr_line(r, 2)
    # worded by the core, as a run's refusal (one text for both)
    assert line.startswith("dyncontact mesh: ") and "cylinder_mm.geo: about 5.9E+010" in line
    assert "--max-elements = 2000000" in line and "--h" in line, line
    assert not (tmp_path / "c.msh").exists()


DISK_SCENE = ("&mesh file = '{geo}', h = 0.02, max_elements = {limit} /\n"
              "&boundary clamped = '', contact = 'bottom' /\n"
              "&contact probe = 0.0, 0.01 /\n"
              "&initial kind = 'velocity', velocity = 0.0, -0.1 /\n"
              "&scheme dt = 0.001, t_end = 0.005 /\n")


def test_just_under_the_limit_runs(tmp_path, run_exe):
    """meshes/disk.geo at h = 0.02 has 212 triangles (estimate 181): max_elements = 212
    runs; 211 is refused after meshing, by the count, as before (the estimate is below
    2 x 211, so it does not refuse a mesh that may fit)."""
    geo = ROOT / "meshes" / "disk.geo"
    est = core.estimate_geo(geo, h=0.02)
    assert est is not None and est["estimate"] < 212
    (tmp_path / "ok.nml").write_text(DISK_SCENE.format(geo=geo, limit=212))
    r = run_exe("ok.nml", "--out", "o")
    assert r.returncode == 0, r.stderr
    (tmp_path / "no.nml").write_text(DISK_SCENE.format(geo=geo, limit=211))
    r = run_exe("no.nml", "--out", "o2")
    assert "212 elements exceed the limit of 211 (&mesh max_elements)" in stderr_line(r, 2)


CASES = [(GEO / "box.geo", 0.05), (GEO / "box_builtin.geo", 0.05), (GEO / "cylinder.geo", 0.02),
         (ROOT / "meshes" / "ball.geo", 0.02), (GEO / "rect.geo", 0.01),
         (ROOT / "meshes" / "disk.geo", 0.005), (GEO / "annulus.geo", 0.003)]


@pytest.mark.parametrize("geo,h", CASES, ids=[f"{g.stem}-{h}" for g, h in CASES])
def test_estimate_within_band(geo, h):
    """cells / estimate within BAND (docs/scenes.md) on meshes of 2 000 to 7 000 cells;
    a limit at the exact count is not refused (no estimate exceeds 2 x the count)."""
    est = core.estimate_geo(geo, h=h, width=0.1)
    m = core.load_mesh(geo, h=h, width=0.1, check=False)
    cells = len(m["cells"])
    assert BAND[0] <= cells / est["estimate"] <= BAND[1], (cells, est)
    assert est["estimate"] <= est["margin"] * cells
    assert len(core.load_mesh(geo, h=h, width=0.1, check=False,
                              max_elements=cells)["cells"]) == cells


def test_measure_is_the_geometry():
    """The measure the estimate stands on: the box's volume 0.15, from OCC and from the
    plane faces of the built-in kernel's box (exact but for round-off), the annulus's
    area pi (0.1^2 - 0.05^2) of the built-in kernel (its boundary sampled: the polygons
    of 256 chords on each quarter arc, of angle pi / 512, miss (pi / 512)^2 / 6 = 6.3e-6 of
    each circle's area, so of the annulus's), and the size h."""
    for name in ("box.geo", "box_builtin.geo"):
        box = core.estimate_geo(GEO / name, h=0.1)
        assert box["measure"] == pytest.approx(0.15, rel=1e-12) and box["size"] == 0.1
    ann = core.estimate_geo(GEO / "annulus.geo", h=0.01)
    assert ann["measure"] == pytest.approx(3.141592653589793 * (0.01 - 0.0025) * (1 - 6.3e-6),
                                         rel=1e-7)
    assert ann["measure"] < 3.141592653589793 * (0.01 - 0.0025)


def test_no_estimate_where_counts_are_fixed():
    """Transfinite meshes (meshes/bar2d.geo) have counts the sizes do not set: no
    estimate, the file is meshed and counted as before. A size field (meshes/
    ball_pole.geo) only makes cells smaller: the estimate is then below the count."""
    assert core.estimate_geo(ROOT / "meshes" / "bar2d.geo", h=0.05) is None
    pole = ROOT / "meshes" / "ball_pole.geo"
    est = core.estimate_geo(pole, h=0.02, length=0.06, width=0.2)
    cells = len(core.load_mesh(pole, h=0.02, length=0.06, width=0.2, check=False)["cells"])
    assert est["estimate"] < cells


def test_sizes_kept_on_the_boundary():
    """With Mesh.MeshSizeExtendFromBoundary = 0 the points' size stays on the boundary and
    the interior is coarse (506 tetrahedra where the box of the same size h has 27 050):
    the points' size is not the cells' size, and with no Mesh.MeshSizeMax there is no
    estimate; a limit at the count is not refused."""
    geo = GEO / "box_inner_coarse.geo"
    assert core.estimate_geo(geo, h=0.03) is None
    cells = len(core.load_mesh(geo, h=0.03, check=False)["cells"])
    assert len(core.load_mesh(geo, h=0.03, check=False, max_elements=cells)["cells"]) == cells
