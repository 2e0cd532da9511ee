"""The critical step of the predictor-corrector family (pc, pc_hht, pc_hht_seed):
dt_crit = Omega_c / omega_max, Omega_c the stability limit of the scheme's amplification
matrix on one mode (explicit_schemes.f90), omega_max the one central differences
estimates (critical_step.f90). Checked against something independent: the spectral
radius of the amplification matrix written here from the scheme's equations (numpy
eigenvalues), the closed forms of the limit, the closed-form omega_max of a lumped chain,
and runs just below and above the estimate."""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pytest

from dyncontact import Scene
from dyncontact.core import DyncontactWarning, pc_stability

from conftest import ROOT, run_as_designed, stderr_line

SCENE_1D = ROOT / "scripts" / "scenes" / "bar1d.nml"
SCENE_2D = ROOT / "scripts" / "scenes" / "bar2d_pc.nml"

#: (name, &scheme alpha) of the variants run below; the seed's alpha > 0 has a limit,
#: its alpha < 0 has none (test_pc_hht_seed_with_negative_alpha_has_no_stable_step)
VARIANTS = [("pc", 0.0), ("pc_hht", -0.1), ("pc_hht", -1.0 / 3.0), ("pc_hht_seed", 0.1)]

#: numpy's eigenvalues of a 3 x 3 matrix with O(1) entries: backward stable, so a simple
#: root is off by a few eps times the entries; 1e-12 leaves a factor 10^3 to that
EIG_TOL = 1e-12
#: the code's bisection stops at the last bit, its stability test within 16 eps of
#: conditions whose slope in Omega is O(1): Omega_c is off by O(1e-15), so 1e-12
#: relative
LIMIT_TOL = 1e-12
#: power iteration approaches omega_max^2 from below (central's test: within 1 %)
POWER_TOL = 0.01


def coefficients(name: str, alpha: float, beta: float = 0.25, gamma: float = 0.5):
    """(alpha, beta, gamma) of the recurrence (docs/scenes.md, &scheme)."""
    if name == "pc":
        return 0.0, beta, gamma
    if name == "pc_hht":
        return alpha, (1 - alpha) ** 2 / 4, 0.5 - alpha
    return alpha, (1 + alpha) ** 2 / 4, 0.5 + alpha


def amplification(om: float, alpha: float, beta: float, gamma: float) -> np.ndarray:
    """The step of explicit_schemes.f90 on m a + k u = 0 (m = 1, k = om^2, dt = 1):
    u~ = u + v + a, a~ = alpha k u - (1 + alpha) k u~, u' = u + v + ((1 - 2 beta) a +
    2 beta a~)/2, v' = v + (1 - gamma) a + gamma a~, a' = alpha k u - (1 + alpha) k u';
    column j is the step of the j-th unit vector of (u, v, a)."""
    k = om * om
    cols = []
    for e in np.eye(3):
        u, v, a = e
        ut = u + v + a
        at = alpha * k * u - (1 + alpha) * k * ut
        u1 = u + v + 0.5 * ((1 - 2 * beta) * a + 2 * beta * at)
        v1 = v + (1 - gamma) * a + gamma * at
        cols.append([u1, v1, alpha * k * u - (1 + alpha) * k * u1])
    return np.array(cols).T


def radius(om: float, *coef) -> float:
    return float(max(abs(np.linalg.eigvals(amplification(om, *coef)))))


@pytest.mark.parametrize("name, alpha", VARIANTS + [("pc_hht", -0.05), ("pc_hht_seed", 0.5)])
def test_pc_limit_is_where_the_spectral_radius_leaves_one(name, alpha):
    """The code's Omega_c against numpy's spectral radius of the matrix written above:
    at most 1 on a fine grid up to 0.999 Omega_c (the stable side, the whole interval),
    above 1 + 1e-6 at 1.001 Omega_c; and the code's matrix is this one."""
    coef = coefficients(name, alpha)
    oc, amp = pc_stability(*coef, omega_dt=0.7)
    np.testing.assert_allclose(amp, amplification(0.7, *coef), rtol=0, atol=EIG_TOL)
    assert 0.1 < oc < 2
    assert all(radius(om, *coef) <= 1 + EIG_TOL for om in np.linspace(1e-3, 0.999 * oc, 400))
    assert radius(1.001 * oc, *coef) > 1 + 1e-6


def test_pc_limits_have_their_closed_forms():
    """pc (1/4, 1/2): sqrt(2); pc_hht, alpha in [-1/3, 0]: the root z = 1 crossing,
    p(1) = 0 of det(z - P), Omega^2 = 4 / (2 - 2 alpha - 3 alpha^2 + alpha^3);
    pc_hht_seed, alpha >= 0: Omega^2 = 4 / ((1 + alpha)(alpha^2 + 4 alpha + 2)); pc with
    another (beta, gamma) where p(-1) = 0 binds first: 4 - 2 gamma W + (beta - gamma/2) W^2
    = 0."""
    assert pc_stability(0.0, 0.25, 0.5)[0] == pytest.approx(math.sqrt(2), rel=LIMIT_TOL)
    for a in np.linspace(-1 / 3, 0, 7):
        w = 4 / (2 - 2 * a - 3 * a * a + a ** 3)
        assert pc_stability(*coefficients("pc_hht", a))[0] == pytest.approx(
            math.sqrt(w), rel=LIMIT_TOL), a
    for a in (0.0, 0.1, 0.5, 1.0, 3.0):
        w = 4 / ((1 + a) * (a * a + 4 * a + 2))
        assert pc_stability(*coefficients("pc_hht_seed", a))[0] == pytest.approx(
            math.sqrt(w), rel=LIMIT_TOL), a
    beta, gamma = 0.1, 0.5
    w = (2 * gamma - math.sqrt(4 * gamma ** 2 - 4 * 4 * (beta - gamma / 2))) \
        / (2 * (beta - gamma / 2))
    assert pc_stability(0.0, beta, gamma)[0] == pytest.approx(math.sqrt(w), rel=LIMIT_TOL)


@pytest.mark.parametrize("alpha", [-1 / 3, -0.1, -0.01])
def test_pc_hht_seed_with_negative_alpha_has_no_stable_step(alpha):
    """gamma = 1/2 + alpha < 1/2: the pair of roots near 1 has modulus
    1 - alpha Omega^2 + O(Omega^4) > 1 at every small Omega (numpy: above 1 - 0.9 alpha
    Omega^2 at Omega = 0.01, 0.03), so the limit is 0, although the radius may come back
    under 1 at a larger Omega (alpha = -0.01: 0.995 at 0.5): the low modes of a mesh
    have a small Omega at any step."""
    coef = coefficients("pc_hht_seed", alpha)
    assert pc_stability(*coef)[0] == 0.0
    for om in (1e-2, 3e-2):
        assert radius(om, *coef) > 1 - 0.9 * alpha * om * om


# ------------------------------------------------------------------ runs on a lumped chain

def chain_omega_max(n: int) -> float:
    """Lumped P1 chain of n elements (h = 1/n, E = rho = 1), fixed at x = 1, free at
    x = 0: omega_max = (2/h) sin((2n - 1) pi / (4n)) (test_beyond_seed.chain_dt_crit)."""
    return 2 * n * math.sin((2 * n - 1) * math.pi / (4 * n))


def free_bar(name: str, alpha: float, n: int, dt: float, t_end: float) -> Scene:
    """The 1D bar without a contact boundary (linear), lumped mass."""
    s = Scene.read(SCENE_1D)
    s.set("mesh.h", 1.0 / n)
    s.set("boundary.contact", "")
    s.set("scheme.name", name)
    if name != "pc":
        s.set("scheme.alpha", alpha)
    s.set("scheme.mass", "lumped")
    s.set("scheme.dt", dt)
    s.set("scheme.t_end", t_end)
    return s


CHAIN_N = 20


@pytest.mark.parametrize("name, alpha", VARIANTS)
def test_pc_runs_are_stable_below_the_estimate_and_not_above(name, alpha, tmp_path):
    """Measured on the chain out of contact (linear): the run at 0.98 x the closed-form
    critical step Omega_c / omega_max runs 3000 steps without a warning, at 1.02 x it
    warns before the run (ratio 1.02 to the estimate, within the power iteration's 1 %)
    and stops as unstable; summary.json's dt_crit_estimate is within 1 % of it."""
    dtc = pc_stability(*coefficients(name, alpha))[0] / chain_omega_max(CHAIN_N)
    with warnings.catch_warnings():
        warnings.simplefilter("error")      # no warning but the designed one
        below = run_as_designed(free_bar(name, alpha, CHAIN_N, 0.98 * dtc, 3000 * dtc),
                                out=tmp_path / "b")
    with pytest.warns(DyncontactWarning, match=f"x the critical step of {name}, estimated "):
        above = run_as_designed(free_bar(name, alpha, CHAIN_N, 1.02 * dtc, 3000 * dtc),
                                out=tmp_path / "a")
    assert below.status == "ok"
    assert above.status == "unstable"
    est = below.summary["dt_crit_estimate"]
    assert abs(est - dtc) <= POWER_TOL * dtc
    assert above.summary["dt_crit_estimate"] == est
    assert f"is explicit, stable only below a critical step, estimated {est:.3E} " \
        .replace("E-0", "E-00") in above.summary["message"]


def test_pc_estimate_is_omega_c_over_centrals_omega_max(tmp_path):
    """The same omega_max as central (one power iteration, critical_step.f90): pc's
    estimate x 2 / sqrt(2) is central's, to round-off, on the 2D bar with contact (full
    contact stiffness included) and consistent mass (set-up only: t_end = 0)."""
    est = {}
    for name in ("pc", "central"):
        s = Scene.read(SCENE_2D)
        s.set("scheme.name", name)
        s.set("scheme.t_end", 0.0)
        est[name] = run_as_designed(s, out=tmp_path / name).summary["dt_crit_estimate"]
    assert est["pc"] * 2 / math.sqrt(2) == pytest.approx(est["central"], rel=1e-13)


# ------------------------------------------------------------------ messages

def test_pc_warning_above_the_estimate_only(run_exe, tmp_path):
    """The executable: one warning line above the estimate (ratio, estimate, a step to
    use: 0.9 x it), none just below; exit 0 both (the 2D seed scene, t_end = 0)."""
    s = Scene.read(SCENE_2D)
    s.set("scheme.t_end", 0.0)
    s.write(tmp_path / "probe.nml")
    assert run_exe(tmp_path / "probe.nml", "--out", tmp_path / "p").returncode == 0
    dtc = json.loads((tmp_path / "p" / "summary.json").read_text())["dt_crit_estimate"]
    for factor, warned in ((0.99, False), (1.01, True)):
        s.set("scheme.dt", factor * dtc)
        s.write(tmp_path / f"s{factor}.nml")
        res = run_exe(tmp_path / f"s{factor}.nml", "--out", tmp_path / f"o{factor}")
        if not warned:
            assert res.returncode == 0 and "warning" not in res.stderr, res.stderr
            continue
        line = stderr_line(res, 0, "dyncontact: warning: &scheme dt = ")
        assert line.endswith(
            f" is 1.01 x the critical step of pc, estimated {dtc:.3E} at full contact: the "
            "run is likely to go unstable once the contact is active; give dt <= "
            f"{0.9 * dtc:.3E} (0.9 x it) (docs/scenes.md, &scheme)".replace("E-0", "E-00")), \
            line


def test_pc_hht_seed_negative_alpha_says_no_step_is_stable(tmp_path):
    """Estimate 0 (no stable step), no warning before the run, and the blow-up message
    says why instead of asking for a smaller step."""
    s = free_bar("pc_hht_seed", -0.3, CHAIN_N, 0.01, 300.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")      # no warning but the designed one
        res = run_as_designed(s, out=tmp_path / "o")
    assert res.summary["dt_crit_estimate"] == 0.0
    assert res.status == "unstable"
    assert res.summary["message"].endswith(
        "; pc_hht_seed is unstable at every step: gamma = 2.000E-001 < 1/2 - alpha = "
        "8.000E-001 (docs/numerics.md, \"Explicit schemes\")"), res.summary["message"]
