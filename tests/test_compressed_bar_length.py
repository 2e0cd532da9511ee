"""&initial kind = 'compressed_bar' on a mesh file's body (docs/scenes.md, &initial): the lift
-amplitude (1 - d/length) n falls to 0 over the body's own extent along n, not over
&mesh length's default 1.0, when the scene does not give &mesh length (a .geo that defines
its own length keeps it). The initial state is then the seed bar's, scaled to the body:
a uniform strain amplitude/L along n, whose elastic energy is exact for P1 elements."""

from __future__ import annotations

import pytest

from conftest import ROOT, lame, stderr_line

from dyncontact import Scene
from dyncontact.core import read_trace

#: The compressed bar's lift, and the length of the .geo below (its own, not 1.0).
AMPLITUDE, GEO_LENGTH = 0.5, 2.0
#: A sum over the elements of the same exact value per element: round-off only.
RTOL = 1e-12


def _bar_geo(folder, length: float):
    """meshes/bar2d.geo with its own length `length` (a scene that gives no &mesh length
    keeps it)."""
    text = (ROOT / "meshes" / "bar2d.geo").read_text()
    assert text.count("length = {1.0,") == 1
    path = folder / "bar.geo"
    path.write_text(text.replace("length = {1.0,", f"length = {{{length!r},"))
    return path


def _scene(folder, name: str, mesh: str, initial: str):
    path = folder / f"{name}.nml"
    path.write_text(f"&mesh {mesh} /\n&initial {initial} /\n"
                    "&scheme dt = 0.01, t_end = 0.01 /\n"
                    f"&output dir = '{name}' /\n")
    return path.name


def _elastic_energy_at_rest(length: float) -> float:
    """E_el of u0 = -A (1 - d/L) n on the bar width x L (plane strain): the uniform strain
    A/L along n, ½ (λ + 2μ) (A/L)² over the area."""
    scn = Scene()
    lam, mu = lame(scn.get("material.young"), scn.get("material.poisson"))
    return 0.5 * (lam + 2 * mu) * (AMPLITUDE / length) ** 2 * scn.get("mesh.width") * length


def test_lift_falls_over_the_geo_bodys_own_length(run_exe, tmp_path):
    """A .geo bar of its own length 2.0 (the scene gives no &mesh length) starts strained
    by A/2.0, as the built-in bar of length 2.0 does: E_el(0) is the closed form's (with
    &mesh length's 1.0 it is 4 times that, and the far end is lifted)."""
    _bar_geo(tmp_path, GEO_LENGTH)
    kind = f"kind = 'compressed_bar', amplitude = {AMPLITUDE}"
    runs = {"geo": "file = 'bar.geo', h = 0.1",
            "given": f"file = 'bar.geo', h = 0.1, length = {GEO_LENGTH}",
            "builtin": f"length = {GEO_LENGTH}, h = 0.1"}
    expected = _elastic_energy_at_rest(GEO_LENGTH)
    for name, mesh in runs.items():
        res = run_exe(_scene(tmp_path, name, mesh, kind))
        assert res.returncode == 0 and res.stderr == "", (name, res.stderr)
        trace = read_trace(tmp_path / name)
        assert trace["u_n"][0] == -AMPLITUDE, name
        assert trace["e_el"][0] == pytest.approx(expected, rel=RTOL), name


def test_default_kind_warning_gives_the_bodys_strain(run_exe, tmp_path):
    """The warning of a mesh file's scene without &initial kind gives the strain the run
    starts from: amplitude over the body's length (0.5 / 2.0)."""
    _bar_geo(tmp_path, GEO_LENGTH)
    res = run_exe(_scene(tmp_path, "nokind", "file = 'bar.geo', h = 0.1",
                         f"amplitude = {AMPLITUDE}"))
    assert res.returncode == 0, res.stderr
    assert "(compressed by amplitude/length = 2.5E-001 along n)" in res.stderr, res.stderr


def test_default_kind_warning_gives_the_strain_to_3_digits(run_exe, tmp_path):
    """A strain that is no short decimal (0.5 / 3.0) is given to 3 digits, not 16."""
    _bar_geo(tmp_path, 3.0)
    res = run_exe(_scene(tmp_path, "nokind", "file = 'bar.geo', h = 0.1",
                         f"amplitude = {AMPLITUDE}"))
    assert res.returncode == 0, res.stderr
    assert "(compressed by amplitude/length = 1.67E-001 along n)" in res.stderr, res.stderr


def test_body_beyond_the_obstacle_plane_is_refused(run_exe, tmp_path):
    """With no node of the body on its side of the obstacle plane the lift has no length
    to fall over: one line naming the scene and &initial kind, exit 2."""
    _bar_geo(tmp_path, GEO_LENGTH)
    name = _scene(tmp_path, "beyond", "file = 'bar.geo', h = 0.1",
                  f"kind = 'compressed_bar', amplitude = {AMPLITUDE}")
    text = (tmp_path / name).read_text()
    (tmp_path / name).write_text(text + "&contact obstacle_point = 0.0, 3.0 /\n")
    line = stderr_line(run_exe(name), 2, f"dyncontact: {name}: &initial kind: ")
    assert "&mesh length" in line
    assert not (tmp_path / "beyond").exists()
