"""Implicit schemes and Nitsche contact: tangent by finite differences,
GetFEM reference traces, energy behaviour of each scheme, Newton failure, the
executable and Python giving the same trace.

Runs use the seed scene (SPEC section 2) unless a test says otherwise.
"""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import dyncontact
from dyncontact import Scene
from dyncontact.core import Model
from conftest import fd_jacobian_errors, run_as_designed

REF = Path(__file__).parent / "data" / "reference"
ROOT = Path(__file__).resolve().parents[1]

#: Agreement required with the GetFEM traces (same mesh, scheme, dt and
#: contact quadrature): max |du_n| and max |de_total| / e_total(0).
REF_TOL_U = 1e-3
REF_TOL_E = 1e-3
#: Both codes solve the same discrete equations; a semi-smooth Newton's last iterate
#: solves its active set's linear equations to round-off, so they agree to the reference
#: files' rounding (11 significant digits: 5e-12 in u_n, 5e-13 in e_total, which is
#: 4e-11 of e_total(0) = 0.0125). Observed, the four runs: u_n 5.1e-12 to 1.3e-11,
#: e_total 4.0e-11 to 4.2e-11 of e_total(0) (tests/test_3d.py holds the 3D run to 1e-10).
SAME_EQUATIONS_TOL = 1e-10
#: Energy conservation of energy-conserving schemes in flight: a step in flight is one
#: direct linear solve (Newton's first iteration solves the linear step exactly), so what
#: is left is round-off over a few hundred steps. Observed: at most 2.5e-13 (newmark
#: theta = 0 and 1 over t <= 6, lumped mass and theta 1/2 over t <= 1, the bar without
#: contact boundary over t <= 2); 1e-11 leaves 40 times that.
CONSERVATION_TOL = 1e-11
#: theta = 1/2 on (u, v) and newmark 1/4 1/2 in flight: the same trapezoidal rule by other
#: formulas, so u_n (of order 0.5) agrees to round-off. Observed: 2.3e-14.
SAME_RULE_TOL = 1e-12
#: Finite differences of B (central, step 1e-7 relative): sqrt(eps)-scaled.
FD_TOL = 1e-6


def scene(**keys) -> Scene:
    """The seed scene with keys given as group__key=value."""
    s = Scene()
    for name, value in keys.items():
        s.set(name.replace("__", "."), value)
    return s


def run(s: Scene, tmp_path: Path, name: str) -> dyncontact.RunResult:
    return run_as_designed(s, tmp_path / name)


def load_reference(name: str) -> dict[str, np.ndarray]:
    d = np.genfromtxt(REF / name, delimiter=",", names=True)
    return {k: d[k] for k in d.dtype.names}


def max_diff(res: dyncontact.RunResult, ref: dict[str, np.ndarray], col: str) -> float:
    """max |ours - reference| at the reference's times (ours has every step)."""
    t = res.trace["t"]
    idx = np.searchsorted(t, ref["t"] - 1e-12)
    assert np.allclose(t[idx], ref["t"], atol=1e-9), "reference times missing from trace"
    return float(np.max(np.abs(res.trace[col][idx] - ref[col])))


# ----------------------------------------------------------------- tangent (FD)

def _contact_state(m: Model, depth: float, rng) -> np.ndarray:
    """Free-dof displacement: uniform lift/penetration along n = (0, -1) plus noise."""
    node, comp = m.dof_map()
    u = np.where(comp == 1, -depth, 0.0)          # u_y = -depth: u_n = depth
    return u + 1e-3 * rng.standard_normal(u.shape)


@pytest.mark.parametrize("quadrature", ["exact", "gauss"])
@pytest.mark.parametrize("theta", [-1, 0, 1])
# "shallow" is 0.002 deep with 1e-3 of noise: every contact point active, as "deep"; the
# facets the active set cuts are tests/test_verify_tangent.py's
@pytest.mark.parametrize("depth", [-0.05, 0.002, 0.05], ids=["free", "shallow", "deep"])
def test_generalized_derivative_matches_finite_differences(theta, quadrature, depth):
    rng = np.random.default_rng(7)
    s = scene(contact__theta=theta, contact__quadrature=quadrature)
    with Model(s) as m:
        u = _contact_state(m, depth, rng)
        b, active = m.eval_b(u)
        if depth < 0:
            assert active == 0
        else:
            assert active > 0
        errs = fd_jacobian_errors(m, u, active, rng, 3)
        assert errs, "every direction switched a quadrature point"
        for err in errs:
            assert err < FD_TOL, f"theta={theta} {quadrature}: relative FD error {err:.2e}"


def _tangent_both_ways(theta):
    """(d2 . J d1, d1 . J d2) for the tangent J of a state in contact (depth 0.01) and
    two random directions d1, d2 (seed 3): equal when J is symmetric."""
    rng = np.random.default_rng(3)
    with Model(scene(contact__theta=theta)) as m:
        u = _contact_state(m, 0.01, rng)
        d1, d2 = rng.standard_normal((2, m.dofs))
        return d2 @ m.jacobian_apply(u, d1), d1 @ m.jacobian_apply(u, d2)


def test_theta1_tangent_is_symmetric():
    a, b = _tangent_both_ways(1)
    assert a == pytest.approx(b, rel=1e-12)


def test_theta0_tangent_is_not_symmetric_in_contact():
    a, b = _tangent_both_ways(0)
    assert abs(a - b) > 1e-6 * abs(a)


# ----------------------------------------------------------------- GetFEM references

REFERENCE_CASES = {
    "bar2d_h0.05_hht_a0.csv": dict(scheme__name="hht", scheme__alpha=0.0),
    "bar2d_h0.05_hht_a-0.1.csv": dict(scheme__name="hht", scheme__alpha=-0.1),
    "bar2d_h0.05_newmark_b0.3025_g0.6.csv": dict(scheme__name="newmark", scheme__beta=0.3025,
                                                 scheme__gamma=0.6),
    "bar2d_h0.02_hht_a0.csv": dict(mesh__h=0.02, scheme__name="hht", scheme__dt=0.001),
}


@pytest.mark.parametrize("ref_name", list(REFERENCE_CASES))
def test_matches_getfem_reference(ref_name, tmp_path):
    s = scene(contact__quadrature="gauss", contact__quad_points=3,
              **REFERENCE_CASES[ref_name])
    res = run(s, tmp_path, "run")
    assert res.status == "ok"
    ref = load_reference(ref_name)
    du = max_diff(res, ref, "u_n")
    de = max_diff(res, ref, "e_total") / ref["e_total"][0]
    assert du <= REF_TOL_U and de <= REF_TOL_E
    assert du <= SAME_EQUATIONS_TOL and de <= SAME_EQUATIONS_TOL, (du, de)


def test_exact_quadrature_differs_from_gauss_less_on_finer_meshes(tmp_path):
    """Effect of the contact quadrature: 'exact' (facet split at the kink) against
    GetFEM's 3-point rule; the difference is O(h^p) with p > 1 (observed: 1.1e-2 at
    h = 0.05, 5.7e-4 at h = 0.02, p ~ 3)."""
    diffs = []
    for h, ref_name in [(0.05, "bar2d_h0.05_hht_a0.csv"), (0.02, "bar2d_h0.02_hht_a0.csv")]:
        res = run(scene(mesh__h=h, scheme__dt=h / 20), tmp_path, f"h{h}")
        diffs.append(max_diff(res, load_reference(ref_name), "u_n"))
    rate = math.log(diffs[0] / diffs[1]) / math.log(0.05 / 0.02)
    print(f"max |u_n exact - u_n gauss3|: {diffs}, observed order {rate:.2f}")
    assert diffs[1] <= REF_TOL_U
    assert rate > 1.0


# ----------------------------------------------------------------- energy behaviour

def _flight_windows(tr, min_len=20):
    """Index ranges of consecutive rows with no active contact point."""
    idle = np.flatnonzero(tr["active"] == 0)
    windows = np.split(idle, np.flatnonzero(np.diff(idle) > 1) + 1)
    return [w for w in windows if len(w) >= min_len]


@pytest.mark.parametrize("theta", [0, 1])
def test_trapezoidal_rule_conserves_energy_in_flight(theta, tmp_path):
    """newmark 1/4, 1/2 conserves 1/2 v.Mv + 1/2 u.K_theta u exactly in flight, i.e.
    e_kin + e_el + e_contact; for theta = 0 that is e_kin + e_el."""
    res = run(scene(scheme__name="newmark", contact__theta=theta, scheme__t_end=6.0),
              tmp_path, "nm")
    tr = res.trace
    windows = _flight_windows(tr)
    assert len(windows) >= 3
    conserved = tr["e_total"] + tr["e_contact"]
    for w in windows:
        spread = np.ptp(conserved[w]) / conserved[w][0]
        assert spread < CONSERVATION_TOL, (theta, tr["t"][w[0]], spread)
    if theta == 0:
        assert np.allclose(tr["e_contact"][windows[0]], 0.0, atol=1e-300)


def test_theta1_e_kin_plus_e_el_alone_is_not_conserved_in_flight(tmp_path):
    """With theta = 1 the flight energy includes -1/(2 gamma) sigma_n^2: e_kin + e_el
    alone varies (by ~1e-2 at h = 0.05) — the conserved quantity is the one above."""
    tr = run(scene(scheme__name="newmark", scheme__t_end=1.0), tmp_path, "nm").trace
    w = _flight_windows(tr)[0]
    assert np.ptp(tr["e_total"][w]) / tr["e_total"][0] > 1e-3


def test_hht_alpha0_equals_newmark(tmp_path):
    a = run(scene(scheme__name="hht", scheme__alpha=0.0, scheme__t_end=3.0), tmp_path, "h")
    b = run(scene(scheme__name="newmark", scheme__t_end=3.0), tmp_path, "n")
    for col in ("u_n", "v_n", "p_n", "e_total"):
        assert np.max(np.abs(a.trace[col] - b.trace[col])) <= 1e-13 * max(
            1.0, np.max(np.abs(b.trace[col])))


@pytest.mark.parametrize("alpha", [-0.05, -0.1, -1 / 3])
def test_hht_negative_alpha_dissipates(alpha, tmp_path):
    tr = run(scene(scheme__alpha=alpha), tmp_path, "hht").trace
    assert tr["e_total"][-1] < tr["e_total"][0]
    # more dissipation than the trapezoidal rule's
    ref = load_reference("bar2d_h0.05_hht_a0.csv")
    assert tr["e_total"][-1] < ref["e_total"][-1]


def test_hht_seed_with_negative_alpha_gains_energy(tmp_path):
    """The seed's printed coefficients with alpha < 0 give gamma < 1/2: energy grows
    in flight (anti-dissipative), where hht dissipates. The growth is physical, not
    round-off: +38 % over the first flight (t < 1) with the state formed from vectors
    (docs/numerics.md, "The state and the products"), against -0.03 % for hht; 10 % is
    asserted."""
    seed = run(scene(scheme__name="hht_seed", scheme__alpha=-0.1, scheme__t_end=1.0),
               tmp_path, "seed").trace
    w = _flight_windows(seed)[0]
    conserved = seed["e_total"] + seed["e_contact"]
    assert conserved[w[-1]] > conserved[w[0]] * 1.1


@pytest.mark.parametrize("time_theta, conserving", [(0.5, True), (1.0, False)])
def test_theta_scheme_energy(time_theta, conserving, tmp_path):
    tr = run(scene(scheme__name="theta", scheme__theta=time_theta, scheme__t_end=1.0),
             tmp_path, "theta").trace
    w = _flight_windows(tr)[0]
    conserved = tr["e_total"] + tr["e_contact"]
    spread = np.ptp(conserved[w]) / conserved[w][0]
    if conserving:
        assert spread < CONSERVATION_TOL
    else:
        assert conserved[w[-1]] < conserved[w[0]] * (1 - 1e-3)


def test_theta_half_matches_newmark_trapezoidal_in_flight(tmp_path):
    """theta = 1/2 on (u, v) and newmark 1/4, 1/2 are both the trapezoidal rule for a
    linear flight phase: same displacements before the first contact."""
    a = run(scene(scheme__name="theta", scheme__theta=0.5, scheme__t_end=1.0), tmp_path, "a")
    b = run(scene(scheme__name="newmark", scheme__t_end=1.0), tmp_path, "b")
    w = _flight_windows(a.trace)[0]
    assert np.max(np.abs(a.trace["u_n"][w] - b.trace["u_n"][w])) < SAME_RULE_TOL


# ----------------------------------------------------------------- small gamma0

def test_small_gamma0_theta1_is_refused_before_the_run(tmp_path):
    """theta = 1 needs gamma0 large enough: with gamma0 = 0.01 K_theta is indefinite and
    a run would blow up within its first steps, so the scene is refused before the run,
    naming &contact gamma0 (element bound, docs/scenes.md)."""
    with pytest.raises(dyncontact.BadInputError, match="&contact gamma0"):
        run(scene(contact__gamma0=0.01, contact__theta=1), tmp_path, "t1")


#: The warning of a gamma0 below the material's bound (docs/scenes.md, &contact gamma0).
SMALL_GAMMA0 = r"&contact gamma0 = 1\.000E-002 is small for the material"


@pytest.mark.slow
def test_small_gamma0_skew_symmetric_is_stable_with_smaller_step(tmp_path):
    """theta = -1, gamma0 = 0.01 stays bounded over T = 15 at dt = h/200 (observed: max
    e_total 4.3 to 4.7 e_total(0) for newton_tol 1e-8 to 1e-12) and with a dissipative
    Newmark at dt = h/20. dt = h/100 is marginal: its outcome depends on round-off (max
    e_total 2.9, 10.0 and 7.3 e_total(0) for newton_tol 1e-8, 1e-10, 1e-12; the middle one
    trips blowup at t = 13.1); h/40 and h/80 are stopped at t = 5.5 and 14.7. With the
    trapezoidal rule at the seed's dt = h/20 it gains energy at once (next test). Both runs
    warn that gamma0 is small for the material (the case chosen here)."""
    with pytest.warns(dyncontact.core.DyncontactWarning, match=SMALL_GAMMA0):
        res = run(scene(contact__gamma0=0.01, contact__theta=-1, scheme__dt=0.05 / 200),
                  tmp_path, "skew")
    assert res.status == "ok"
    assert np.max(res.trace["e_total"]) < 10 * res.trace["e_total"][0]
    with pytest.warns(dyncontact.core.DyncontactWarning, match=SMALL_GAMMA0):
        res = run(scene(contact__gamma0=0.01, contact__theta=-1, scheme__name="newmark",
                        scheme__beta=0.3025, scheme__gamma=0.6), tmp_path, "skew_diss")
    assert res.status == "ok"



def test_small_gamma0_skew_symmetric_trapezoidal_at_seed_step_is_unstable(tmp_path):
    with pytest.warns(dyncontact.core.DyncontactWarning, match=SMALL_GAMMA0):
        res = run(scene(contact__gamma0=0.01, contact__theta=-1), tmp_path, "skew")
    assert res.status == "unstable"
    assert 0.0 < res.summary["t_end_reached"] < 15.0
    # the trace is kept and ends where the run stopped
    assert res.trace["t"][-1] == pytest.approx(res.summary["t_end_reached"])


# ----------------------------------------------------------------- failures, counters

def test_newton_failure_stops_cleanly_with_trace(tmp_path):
    s = scene(scheme__newton_maxit=1, scheme__t_end=3.0)
    res = run(s, tmp_path, "nf")
    assert res.status == "newton_failed"
    t_stop = res.summary["t_end_reached"]
    assert 1.0 < t_stop < 3.0          # contact starts at t ~ 1.15
    assert res.trace["t"][-1] <= t_stop
    assert "Newton" in res.message
    # numbers with a full 3-digit exponent (never Fortran's E-less '2.225-307')
    assert re.search(r"Newton did not converge at t = \d\.\d{5}E[+-]\d{3} after 1 iteration "
                     r"\(relative residual \d\.\d{3}E[+-]\d{3}\)", res.message), res.message
    # t once (the scheme gives it), and the advice of a Newton failure, not of &solver
    assert res.message.count("at t = ") == 1, res.message
    assert "check &scheme dt (smaller)" in res.message and "&solver" not in res.message
    # the limit the step ran into is named with its value in the advice
    assert res.message.endswith("&scheme newton_tol and newton_maxit (= 1)"), res.message


def test_factorizations_do_not_depend_on_contact(tmp_path):
    """The contact-free iteration matrix is factorized once (plus M for a0); active-set
    changes use a low-rank correction, never a refactorization."""
    res = run(scene(scheme__t_end=3.0), tmp_path, "f")
    assert res.summary["factorizations"] == 2
    assert np.any(res.trace["active"] > 0)
    res = run(scene(scheme__name="theta", scheme__t_end=3.0), tmp_path, "g")
    assert res.summary["factorizations"] == 1


def test_lumped_mass_runs_and_conserves_in_flight(tmp_path):
    tr = run(scene(scheme__name="newmark", scheme__mass="lumped", scheme__t_end=1.0),
             tmp_path, "l").trace
    w = _flight_windows(tr)[0]
    conserved = tr["e_total"] + tr["e_contact"]
    assert np.ptp(conserved[w]) / conserved[w][0] < CONSERVATION_TOL


def test_scene_without_contact_boundary(tmp_path):
    """contact = '': no contact machinery; the bar oscillates freely (energy conserved)."""
    res = run(scene(boundary__contact="", scheme__name="newmark", scheme__t_end=2.0),
              tmp_path, "free")
    assert res.status == "ok"
    assert res.summary["contact_facets"] == 0
    tr = res.trace
    assert np.all(tr["active"] == 0)
    assert np.ptp(tr["e_total"]) / tr["e_total"][0] < CONSERVATION_TOL


@pytest.mark.parametrize("name", ["newmark", "hht", "hht_seed", "theta", "galpha"])
def test_body_at_rest_takes_one_newton_iteration_a_step(tmp_path, name):
    """The first Newton iteration always solves (numerics.md, Semi-smooth Newton): a bar
    at rest with no load, off the obstacle, has R(u^n) = 0, its solve gives dx = 0 exactly,
    and R after it is zero (no contact point active), so every step takes exactly one
    iteration and the bar stays at rest, bit for bit."""
    res = run(scene(initial__kind="rest", scheme__name=name, scheme__t_end=0.05),
              tmp_path, name)
    assert res.status == "ok" and res.summary["steps"] == 20
    tr = res.trace
    assert np.all(tr["newton_its"][1:] == 1) and res.summary["newton_its_total"] == 20
    for col in ("u_n", "v_n", "p_n", "e_kin", "e_el", "e_total"):
        assert np.all(tr[col] == 0.0), col


@pytest.mark.parametrize("dim", [1, 2, 3])
def test_summary_names_the_dimension(tmp_path, dim):
    """summary.json's dim is the body's: the built-in bar's &mesh dim, and a mesh file's
    own, which the scene's mesh.dim (0: from the file) does not say."""
    s = scene(scheme__t_end=0.01, mesh__dim=dim, initial__kind="rest")
    if dim == 3:
        s.set("mesh.dim", 0)
        s.set("mesh.file", str(Path(__file__).parent / "data" / "meshes" / "box3d.geo"))
    res = run(s, tmp_path, "s")
    assert res.status == "ok"
    assert res.summary["dim"] == dim
    assert res.summary["scene"]["mesh"]["dim"] == (0 if dim == 3 else dim)


def test_summary_fields(tmp_path):
    res = run(scene(scheme__t_end=0.1), tmp_path, "s")
    s = res.summary
    for key in ("status", "steps", "t_end_reached", "wall_s", "newton_its_total",
                "factorizations", "dofs", "elements", "contact_facets", "scheme", "scene",
                "version"):
        assert key in s
    assert s["steps"] == 40 and s["dofs"] == 120 and s["elements"] == 80
    assert s["contact_facets"] == 2 and s["scheme"] == "hht"
    assert s["version"] == dyncontact.__version__
    assert s["scene"]["scheme"]["dt"] == 0.0025
    assert len(res.trace["t"]) == 41


def test_executable_and_python_give_the_same_trace(tmp_path):
    exe = ROOT / "build" / "dyncontact"
    if not exe.exists():
        pytest.skip("build/dyncontact not built (scripts/setup builds it)")
    s = scene(scheme__t_end=2.0, output__every=7)
    path = tmp_path / "scene.nml"
    s.write(path)
    subprocess.run([str(exe), str(path), "--out", str(tmp_path / "exe")], check=True)
    subprocess.run([sys.executable, "-m", "dyncontact", "run", str(path), "--out",
                    str(tmp_path / "py"), "--quiet"], check=True)
    a = (tmp_path / "exe" / "trace.csv").read_text()
    b = (tmp_path / "py" / "trace.csv").read_text()
    assert a == b
    assert len(a.splitlines()) == 1 + 1 + 800 // 7 + 1
