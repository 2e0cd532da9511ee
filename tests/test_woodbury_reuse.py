"""The implicit schemes keep the LU factors of the Woodbury system I + c VᵀWU of the
contact correction with a copy of what they are formed from (the terms' facets and their
coefficients in the facets' M_θ and M), and solve with them again, across Newton
iterations and steps, while these are that copy bit for bit, and forms the system from X = MᵀW M_θ over the facets with active points,
kept while those facets are the same (fortran/schemes/implicit_schemes.f90). On the
node basis (3D) the factors carry the terms' coefficients α_t, β_t (`halpha`, `hbeta`),
which `node_solve` reads instead of forming them again: reused factors bring their
kept coefficients, fresh ones new coefficients, so this comparison checks them too.
DYNCONTACT_WOODBURY_FRESH=1 forms X and the system and factorizes it at every Newton
iteration: the reference. The traces with and
without reuse must be equal on 2D and 3D scenes, with 'exact' quadrature (cut facets move
the tangent: few reuses) and 'gauss' (the same active points give the same tangent: many),
including one whose active set changes at nearly every step (the ball).

Equal to the bit, which is stronger than the 1e-12 relative round-off bound: the factors
are reused only for a system formed from the same numbers, and X only for the same facets
(X and the system depend on W, which depends on J0 alone, and its columns do not depend
on the cache's history, tests/test_contact_columns.py), so the factors and every Newton
step are the ones a fresh formation and factorization give."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from conftest import run_as_designed
from dyncontact import Scene

ROOT = Path(__file__).resolve().parents[1]
ENV = "DYNCONTACT_WOODBURY_FRESH"


def ball() -> Scene:
    """The coarse ball dropped at speed 1 ('exact' quadrature): its patch grows by some
    points at nearly every step of the window."""
    s = Scene.read(ROOT / "scripts" / "scenes" / "ball3d_newmark.nml")
    s.set("mesh.h", 0.1)
    s.set("initial.velocity", "0.0, 0.0, -1.0")
    s.set("scheme.dt", 0.005)
    s.set("scheme.t_end", 0.075)
    s.set("output.fields_every", 0)
    return s


def bar3d(quadrature: str) -> Scene:
    """The 3D bar (GetFEM's 3D settings: 7-point 'gauss' face rule) through its first
    contact (it lands at t = 1.21)."""
    s = Scene.read(ROOT / "scripts" / "scenes" / "bar3d_hht.nml")
    s.set("contact.quadrature", quadrature)
    s.set("scheme.t_end", 1.45)
    s.set("output.fields_every", 0)
    return s


def box(theta: int | None = None) -> Scene:
    """The built-in 3D box at h = 0.05 (GetFEM's settings: hht α = 0, Δt = h/20)
    through its first contact, whole facets active and sharing nodes."""
    s = Scene()
    s.set("mesh.dim", 3)
    s.set("scheme.t_end", 3.0)
    if theta is not None:
        s.set("contact.theta", theta)
    return s


def bar2d(quadrature: str) -> Scene:
    """The 2D bar (HHT) through its first contact (it lands at t = 1.13)."""
    s = Scene.read(ROOT / "scripts" / "scenes" / "bar2d_hht.nml")
    s.set("contact.quadrature", quadrature)
    if quadrature == "gauss":
        s.set("contact.quad_points", 3)
    s.set("scheme.t_end", 1.6)
    s.set("output.fields_every", 0)
    return s


SCENES = {
    "ball3d_exact": ball,
    "bar3d_gauss": lambda: bar3d("gauss"),
    "bar3d_exact": lambda: bar3d("exact"),
    "bar2d_gauss": lambda: bar2d("gauss"),
    "bar2d_exact": lambda: bar2d("exact"),
}


def run_with_env(monkeypatch, var: str, value: str | None, s: Scene, out: Path):
    """The run of s with the environment variable var set to value (None: unset)."""
    if value is None:
        monkeypatch.delenv(var, raising=False)
    else:
        monkeypatch.setenv(var, value)
    return run_as_designed(s, out)


def assert_traces_agree(name: str, new, ref, tol: float, used: bool = True) -> None:
    """Two runs of one scene by two paths of the same Newton step: the same active counts
    and iterations at every row, every column within tol of its largest value, and not
    bit for bit the same (the path under test was used) or, used False, bit for bit the same."""
    assert ref.trace["active"].max() > 0 and ref.trace["newton_its"].max() >= 2, name
    np.testing.assert_array_equal(new.trace["active"], ref.trace["active"])
    np.testing.assert_array_equal(new.trace["newton_its"], ref.trace["newton_its"])
    differ = False
    for col in ref.trace:
        a, b = np.asarray(new.trace[col]), np.asarray(ref.trace[col])
        scale = np.max(np.abs(b)) if b.size else 0.0
        np.testing.assert_allclose(a, b, rtol=0, atol=tol * scale, err_msg=f"{name}: {col}")
        differ = differ or not np.array_equal(a, b)
    assert differ == used, f"{name}: the path under test changed the trace: {differ}"


@pytest.mark.parametrize("name", sorted(SCENES))
def test_reused_woodbury_factors_give_the_fresh_traces(monkeypatch, tmp_path, name):
    s = SCENES[name]()
    reuse = run_with_env(monkeypatch, ENV, None, s, tmp_path / "reuse")
    fresh = run_with_env(monkeypatch, ENV, "1", s, tmp_path / "fresh")
    active = reuse.trace["active"]
    inside = active[np.argmax(active > 0):]
    # the window is one of contact, with Newton iterations beyond the first
    assert inside.size >= 10 and np.count_nonzero(inside) >= 0.5 * inside.size, name
    assert reuse.trace["newton_its"].max() >= 2, name
    if name == "ball3d_exact":
        # the patch grows: its active points change at most steps of the window
        assert np.count_nonzero(np.diff(inside)) >= 0.6 * (inside.size - 1)
    for col in reuse.trace:
        np.testing.assert_array_equal(reuse.trace[col], fresh.trace[col],
                                      err_msg=f"{name}: {col}")


#: the schemes whose Newton steps go through the contact correction
IMPLICIT = ("newmark", "hht", "hht_seed", "theta", "galpha")


@pytest.mark.parametrize("mass", ["consistent", "lumped", "redistributed"])
@pytest.mark.parametrize("scheme", IMPLICIT)
def test_reuse_gives_the_fresh_traces_for_every_implicit_scheme_and_mass(
        monkeypatch, tmp_path, scheme, mass):
    """The reused factors and the kept X (and, on the 3D box, the node basis's Y) equal
    what a fresh formation gives at every step: the 3D box through its first contact,
    for every implicit scheme and mass, bit for bit."""
    s = box()
    s.set("scheme.name", scheme)
    s.set("scheme.mass", mass)
    s.set("scheme.t_end", 1.6)
    reuse = run_with_env(monkeypatch, ENV, None, s, tmp_path / "reuse")
    fresh = run_with_env(monkeypatch, ENV, "1", s, tmp_path / "fresh")
    assert reuse.trace["active"].max() > 0 and reuse.trace["newton_its"].max() >= 2
    for col in reuse.trace:
        np.testing.assert_array_equal(reuse.trace[col], fresh.trace[col],
                                      err_msg=f"{scheme} {mass}: {col}")
