"""What a new user tries, through the executable, the Python CLI and the API: each case
ends either as a correct run or as exit 2 (BadInputError) with one line naming the file
and the key. Cases already covered by test_reliability.py and test_bad_input_cli.py are
not repeated here."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from test_reliability import (ENTRIES, EXIT_BAD_INPUT, EXIT_OK, one_line, run,
                              write_scene)

#: Radius and centre height of the disk; the obstacle is the plane y = 0.
RADIUS = 0.1


def disk_mesh(path: Path, h: float = 0.02, invert_every: int = 0) -> Path:
    """A disk of radius RADIUS centred at (0, RADIUS), meshed by gmsh's Python API, with
    its whole outline as the physical group 'outline' and the surface as 'body'. With
    invert_every = k, every k-th triangle is written with its nodes in clockwise order
    (negative Jacobian), as some mesh tools write them."""
    gmsh = pytest.importorskip("gmsh")
    gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("disk")
        occ = gmsh.model.occ
        c = occ.addPoint(0, RADIUS, 0)
        p = [occ.addPoint(RADIUS * np.cos(a), RADIUS + RADIUS * np.sin(a), 0)
             for a in (0.0, np.pi / 2, np.pi, 1.5 * np.pi)]
        arcs = [occ.addCircleArc(p[i], c, p[(i + 1) % 4]) for i in range(4)]
        s = occ.addPlaneSurface([occ.addCurveLoop(arcs)])
        occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", h)
        gmsh.model.addPhysicalGroup(1, arcs, 1, "outline")
        gmsh.model.addPhysicalGroup(2, [s], 2, "body")
        gmsh.model.mesh.generate(2)
        if invert_every:
            types, tags, nodes = gmsh.model.mesh.getElements(2, s)
            tri = np.asarray(nodes[0]).reshape(-1, 3)
            tri[::invert_every] = tri[::invert_every, ::-1]
            gmsh.model.mesh.removeElements(2, s)
            gmsh.model.mesh.addElements(2, s, [types[0]], [tags[0]], [tri.ravel()])
        gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    return path


def disk_scene(path: Path, mesh: Path, **over) -> Path:
    """The disk falling onto y = 0 at speed 0.1, nothing clamped, whole outline in contact."""
    settings = dict(mesh__file=f"'{mesh.name}'", boundary__clamped="''",
                    boundary__contact="'outline'", initial__kind="'velocity'",
                    initial__velocity="0.0, -0.1", scheme__name="'newmark'",
                    scheme__dt="0.001", scheme__t_end="0.1", contact__probe="0.0, 0.0")
    settings.update(over)
    return write_scene(path, **settings)


# ------------------------------------------------------------------ 2D disk, closed contact

@pytest.mark.parametrize("kind", ENTRIES)
def test_disk_with_closed_contact_boundary_says_nothing_false(kind, tmp_path):
    """A probe at a negative x is snapped and the note prints its coordinates (a format
    too narrow for a sign printed asterisks); the closed outline gives no warning about
    obstacle_normal, with either sign of it (every closed boundary has facets that face
    the obstacle)."""
    mesh = disk_mesh(tmp_path / "disk.msh")
    a = -2.0   # a point of the true circle with x < 0, below the centre
    probe = np.array([RADIUS * np.cos(a), RADIUS + RADIUS * np.sin(a)])
    # down: the plane y = 0 below; up: the plane y = 1 above (never reached)
    for name, normal, point in (("down", "0.0, -1.0", "0.0, 0.0"), ("up", "0.0, 1.0", "0.0, 1.0")):
        scene = disk_scene(tmp_path / f"{name}.nml", mesh,
                           contact__probe=f"{float(probe[0])!r}, {float(probe[1])!r}",
                           contact__obstacle_normal=normal, contact__obstacle_point=point)
        res = run(kind, scene, "--out", tmp_path / name, cwd=tmp_path)
        assert res.returncode == EXIT_OK, res.stderr
        assert "*" not in res.stderr and "obstacle_normal" not in res.stderr, res.stderr
        note = [ln for ln in res.stderr.splitlines() if "probe snapped to" in ln]
        assert len(note) == 1, res.stderr
        words = note[0].split("snapped to ")[1].replace("(distance ", "").rstrip(")").split()
        x, y, dist = (float(w) for w in words)
        # the nearest point of a chord: inside the circle, within a facet of the probe
        assert x < 0 and math.hypot(x, y - RADIUS) < RADIUS
        assert dist == pytest.approx(math.hypot(x - probe[0], y - probe[1]), rel=1e-3)
        assert 0 < dist < 0.02


@pytest.mark.parametrize("kind", ENTRIES)
def test_open_contact_boundary_facing_away_still_warns(kind, tmp_path):
    """The bar's bottom with obstacle_normal along +y: no facet faces the obstacle; the
    warning says so (the default normal gives none, test_reliability)."""
    scene = write_scene(tmp_path / "s.nml", contact__obstacle_normal="0.0, 1.0",
                        contact__obstacle_point="0.0, -1.0", scheme__t_end="0.05")
    res = run(kind, scene, "--out", tmp_path / "o", cwd=tmp_path)
    assert res.returncode == EXIT_OK, res.stderr
    warn = [ln for ln in res.stderr.splitlines() if "obstacle_normal" in ln]
    assert len(warn) == 1 and "no contact facet faces the obstacle" in warn[0], res.stderr
    assert "-1.000" in warn[0]    # every bottom facet's outward normal is -y
