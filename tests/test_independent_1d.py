"""An independent implementation of the 1D problem, to cross-check the core.

`Bar1D` and the two time loops below were written from SPEC section 1 alone (not from
fortran/): the P1 bar of SPEC section 2 with dense numpy matrices, Nitsche's contact at
the node x = 0 and HHT / Newmark (semi-smooth Newton) or the predictor-corrector of
eq. (10). dyncontact's 1D trace must be the same sequence of numbers up to round-off.

Discrete 1D contact term (the "facet" is the point x = 0, of measure 1): with n = -1,
u_n = -u_0, sigma_n(u) = sigma n.n = E (u_1 - u_0)/h = s.u on the first element,
gamma_N = gamma0/h, P_1(u) = s.u - gamma_N u_n = dP.u and
    B(u) = K u - (theta/gamma_N) s (s.u) + (1/gamma_N) [P_1(u)]_- (theta s - gamma_N e_n).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import dyncontact
from conftest import run_as_designed
from dyncontact import Scene

ROOT = Path(__file__).resolve().parents[1]
SCENE_1D = ROOT / "scripts" / "scenes" / "bar1d.nml"
H = 1.0 / 50.0
T_END = 6.0

#: Both codes solve the same piecewise-linear equations exactly (semi-smooth Newton
#: ends on the right active set), so they differ by round-off only, which accumulates
#: over the steps but does not grow from one period to the next.
#: u_n and the energies: observed <= 7e-12 over 6000 steps.
TOL_U = 1e-10
#: v_n and p_n amplify displacement round-off: v through a = (u - u_pred)/(beta dt^2)
#: (eps |u| / (beta dt^2) * dt ~ 2e-13 per step at dt = 1e-3), p_n through
#: gamma_N = 500 (7e-12 in u_0 -> 3.5e-9). Observed <= 1.9e-9 (theta = 0, alpha = -0.1).
TOL_VP = 1e-8

TRACE = ("u_n", "v_n", "p_n", "e_kin", "e_el", "e_contact")


# ----------------------------------------------------------------- the reference code

class Bar1D:
    """P1 bar [0, 1] clamped at x = 1, Nitsche contact at x = 0 (n = -1, no gap)."""

    def __init__(self, h, young=1.0, rho=1.0, theta=1, gamma0=10.0, mass="consistent"):
        n = int(round(1.0 / h))               # elements; free dofs = nodes 0 .. n-1
        self.x = np.linspace(0.0, 1.0, n + 1)[:n]
        K, M = np.zeros((n + 1, n + 1)), np.zeros((n + 1, n + 1))
        for e in range(n):
            i = np.ix_([e, e + 1], [e, e + 1])
            K[i] += young / h * np.array([[1.0, -1.0], [-1.0, 1.0]])
            M[i] += rho * h * (np.array([[2.0, 1.0], [1.0, 2.0]]) / 6.0
                               if mass == "consistent" else np.eye(2) / 2.0)
        self.K, self.M = K[:n, :n], M[:n, :n]
        self.s = np.zeros(n)
        self.s[:2] = [-young / h, young / h]      # sigma_n(u) = s.u
        self.en = np.zeros(n)
        self.en[0] = -1.0                         # u_n = en.u
        self.theta, self.gam = theta, gamma0 / h
        self.Kt = self.K - theta / self.gam * np.outer(self.s, self.s)
        self.dP = self.s - self.gam * self.en     # P_1(u) = dP.u
        self.dPt = theta * self.s - self.gam * self.en   # P_theta(v) = dPt.v

    def B(self, u):
        return self.Kt @ u + min(self.dP @ u, 0.0) / self.gam * self.dPt

    def active(self, u):
        """Is the contact point active (P_1(u) < 0)? The argument of dB."""
        return self.dP @ u < 0

    def dB(self, active):
        return self.Kt + (np.outer(self.dPt, self.dP) / self.gam if active else 0.0)

    def u0(self):
        return 0.5 - self.x / 2.0

    def row(self, u, v):
        """u_n, v_n, p_n, e_kin, e_el, e_contact (SPEC sections 1 and 4)."""
        pm, sn = min(self.dP @ u, 0.0), self.s @ u
        return (-u[0], -v[0], pm, 0.5 * v @ self.M @ v, 0.5 * u @ self.K @ u,
                (pm * pm - self.theta * sn * sn) / (2.0 * self.gam))


def semismooth_newton(bar, w, residual, jacobian):
    """The root of residual from w by semi-smooth Newton, jacobian(bar.active(w)) its
    Jacobian: exact once the active set repeats (at most 50 iterations)."""
    for _ in range(50):
        act = bar.active(w)
        w = w - np.linalg.solve(jacobian(act), residual(w))
        if bar.active(w) == act:
            return w
    raise RuntimeError("reference Newton did not converge")


def run_implicit(bar, dt, t_end, alpha=0.0, beta=None, gamma=None):
    """HHT (alpha; beta, gamma default to (1-alpha)^2/4, 1/2-alpha) or Newmark (alpha=0),
    for any bar with u0, row, M, B, active and dB (the 2D one of test_slip_bar.py too)."""
    beta = (1 - alpha) ** 2 / 4 if beta is None else beta
    gamma = 0.5 - alpha if gamma is None else gamma
    u = bar.u0()
    v = np.zeros_like(u)
    a = np.linalg.solve(bar.M, -bar.B(u))
    rows = [bar.row(u, v)]
    c = 1.0 / (beta * dt * dt)
    for _ in range(int(round(t_end / dt))):
        u_pred = u + dt * v + dt * dt / 2 * (1 - 2 * beta) * a
        b_old = bar.B(u)
        w = semismooth_newton(
            bar, u.copy(),
            lambda w: c * bar.M @ (w - u_pred) + (1 + alpha) * bar.B(w) - alpha * b_old,
            lambda act: c * bar.M + (1 + alpha) * bar.dB(act))
        a_new = c * (w - u_pred)
        v = v + dt * ((1 - gamma) * a + gamma * a_new)
        u, a = w, a_new
        rows.append(bar.row(u, v))
    return np.array(rows)


def run_pc(bar, dt, t_end, beta=0.25, gamma=0.5):
    """SPEC eq. (10) as read in section 1: explicit predictor-corrector."""
    u = bar.u0()
    v = np.zeros_like(u)
    acc = lambda w: np.linalg.solve(bar.M, -bar.B(w))   # noqa: E731
    a = acc(u)
    rows = [bar.row(u, v)]
    for _ in range(int(round(t_end / dt))):
        a_pred = acc(u + dt * (v + dt * a))
        u_new = u + dt * v + dt * dt / 2 * ((1 - 2 * beta) * a + 2 * beta * a_pred)
        v = v + dt * ((1 - gamma) * a + gamma * a_pred)
        u = u_new
        a = acc(u)
        rows.append(bar.row(u, v))
    return np.array(rows)


# ----------------------------------------------------------------- the comparisons

def core_run(tmp_path, name, **keys) -> dyncontact.RunResult:
    s = Scene.read(SCENE_1D)
    s.set("mesh.h", H)
    s.set("scheme.dt", H / 20)
    s.set("scheme.t_end", T_END)
    for key, value in keys.items():
        s.set(key.replace("__", "."), value)
    return run_as_designed(s, out=tmp_path / name, progress=False)


def differences(trace, ref) -> dict[str, float]:
    n = len(trace["t"])
    assert n <= len(ref)
    return {c: float(np.max(np.abs(trace[c] - ref[:n, j]))) for j, c in enumerate(TRACE)}


def assert_same(trace, ref, what):
    d = differences(trace, ref)
    print(what, " ".join(f"{c}={v:.1e}" for c, v in d.items()))
    for c, v in d.items():
        assert v <= (TOL_VP if c in ("v_n", "p_n") else TOL_U), (what, c, v)


@pytest.mark.slow
@pytest.mark.parametrize("alpha", [0.0, -0.1])
@pytest.mark.parametrize("gamma0", [10.0, 1.0])
@pytest.mark.parametrize("theta", [-1, 0, 1])
def test_hht_matches_independent_reference(theta, gamma0, alpha, tmp_path):
    ref = run_implicit(Bar1D(H, theta=theta, gamma0=gamma0), H / 20, T_END, alpha=alpha)
    if theta == 1 and gamma0 == 1.0:
        # gamma0 = E kills the first element's stiffness in K_theta = K - (1/gamma_N) s s^T:
        # the contact node drifts and e_kin + e_el grows past 10 e(0) in the independent
        # run. The core refuses the scene before it runs (gamma0 at the element bound).
        e_ref = ref[:, 3] + ref[:, 4]
        assert np.any(e_ref > 10.0 * e_ref[0])
        with pytest.raises(dyncontact.BadInputError, match="&contact gamma0.*singular at it"):
            core_run(tmp_path, "hht", scheme__name="hht", scheme__alpha=alpha,
                     contact__theta=theta, contact__gamma0=gamma0)
        return
    res = core_run(tmp_path, "hht", scheme__name="hht", scheme__alpha=alpha,
                   contact__theta=theta, contact__gamma0=gamma0)
    assert_same(res.trace, ref, f"theta={theta} gamma0={gamma0} alpha={alpha}")
    assert res.status == "ok" and len(res.trace["t"]) == len(ref)
    assert np.any(res.trace["p_n"] < 0)      # there was contact


def test_dissipative_newmark_lumped_mass_matches_reference(tmp_path):
    res = core_run(tmp_path, "nm", scheme__name="newmark", scheme__beta=0.3025,
                   scheme__gamma=0.6, scheme__mass="lumped")
    ref = run_implicit(Bar1D(H, mass="lumped"), H / 20, T_END, beta=0.3025, gamma=0.6)
    assert res.status == "ok"
    assert_same(res.trace, ref, "newmark 0.3025/0.6 lumped")


def test_predictor_corrector_matches_reference(tmp_path):
    """pc at the seed's dt = h/100 over T = 3 (one period: flight, contact, release; the
    numpy loop needs two dense solves per step)."""
    t_end = 3.0
    res = core_run(tmp_path, "pc", scheme__name="pc", scheme__dt=H / 100,
                   scheme__t_end=t_end)
    ref = run_pc(Bar1D(H), H / 100, t_end)
    assert res.status == "ok" and len(res.trace["t"]) == len(ref)
    assert res.summary["newton_its_total"] == 0
    assert_same(res.trace, ref, "pc")


def test_reference_is_not_trivially_equal(tmp_path):
    """The comparison can fail: a different gamma0 (or theta) in the reference shows up
    far above the tolerances."""
    res = core_run(tmp_path, "hht", scheme__t_end=2.0)
    ref = run_implicit(Bar1D(H, gamma0=11.0), H / 20, 2.0)
    assert differences(res.trace, ref)["u_n"] > 1e3 * TOL_U
    ref = run_implicit(Bar1D(H, theta=0), H / 20, 2.0)
    assert differences(res.trace, ref)["p_n"] > 1e3 * TOL_VP


# ------------------------ every Newmark-family variant, stable or not, and theta

def run_theta(bar, dt, t_end, theta):
    """The theta scheme on (u, v) (SPEC section 1): u' = u + dt (theta v' + (1-theta) v),
    M (v' - v) = dt (L - theta B(u') - (1-theta) B(u)); eliminating v' gives
    M (u' - u - dt v) + theta^2 dt^2 B(u') + theta (1-theta) dt^2 B(u) = 0."""
    u = bar.u0()
    v = np.zeros_like(u)
    rows = [bar.row(u, v)]
    c = 1.0 / (theta * theta * dt * dt)
    for _ in range(int(round(t_end / dt))):
        b_old = bar.B(u)
        w = semismooth_newton(
            bar, u.copy(),
            lambda w: c * bar.M @ (w - u - dt * v) + bar.B(w) + (1 - theta) / theta * b_old,
            lambda act: c * bar.M + bar.dB(act))
        v = (w - u - dt * (1 - theta) * v) / (theta * dt)
        u = w
        rows.append(bar.row(u, v))
    return np.array(rows)


T_LONG = 15.0
BLOWUP = 10.0   # the scene's &scheme blowup

#: label -> (scene keys, reference run). hht_seed uses the seed's printed coefficients
#: beta = (1+alpha)^2/4, gamma = 1/2 + alpha with the balance (1+alpha) B(u') - alpha B(u).
VARIANTS = {
    "newmark_0.15_0.5": ({"scheme__name": "newmark", "scheme__beta": 0.15, "scheme__gamma": 0.5},
                         lambda bar, dt: run_implicit(bar, dt, T_LONG, beta=0.15, gamma=0.5)),
    "newmark_0.2_0.5": ({"scheme__name": "newmark", "scheme__beta": 0.2, "scheme__gamma": 0.5},
                        lambda bar, dt: run_implicit(bar, dt, T_LONG, beta=0.2, gamma=0.5)),
    "newmark_0.25_0.5": ({"scheme__name": "newmark", "scheme__beta": 0.25, "scheme__gamma": 0.5},
                         lambda bar, dt: run_implicit(bar, dt, T_LONG, beta=0.25, gamma=0.5)),
    "newmark_0.25_0.6": ({"scheme__name": "newmark", "scheme__beta": 0.25, "scheme__gamma": 0.6},
                         lambda bar, dt: run_implicit(bar, dt, T_LONG, beta=0.25, gamma=0.6)),
    "hht_0": ({"scheme__name": "hht", "scheme__alpha": 0.0},
              lambda bar, dt: run_implicit(bar, dt, T_LONG, alpha=0.0)),
    "hht_-0.1": ({"scheme__name": "hht", "scheme__alpha": -0.1},
                 lambda bar, dt: run_implicit(bar, dt, T_LONG, alpha=-0.1)),
    "hht_seed_-0.05": ({"scheme__name": "hht_seed", "scheme__alpha": -0.05},
                       lambda bar, dt: run_implicit(bar, dt, T_LONG, alpha=-0.05,
                                                    beta=0.95 ** 2 / 4, gamma=0.45)),
    "hht_seed_-0.1": ({"scheme__name": "hht_seed", "scheme__alpha": -0.1},
                      lambda bar, dt: run_implicit(bar, dt, T_LONG, alpha=-0.1,
                                                   beta=0.9 ** 2 / 4, gamma=0.4)),
    "theta_0.5": ({"scheme__name": "theta", "scheme__theta": 0.5},
                  lambda bar, dt: run_theta(bar, dt, T_LONG, 0.5)),
    "theta_1": ({"scheme__name": "theta", "scheme__theta": 1.0},
                lambda bar, dt: run_theta(bar, dt, T_LONG, 1.0)),
}


@pytest.mark.parametrize("label", list(VARIANTS))
def test_scheme_variants_match_independent_reference(label, tmp_path):
    """u_n, v_n and e_total agree with the independent loop while both are stable; a
    scheme whose reference stays below blowup x e_total(0) runs to T = 15; one whose
    reference energy crosses it is stopped on exactly that row (no round-off growth:
    v and a are formed from vectors, docs/numerics.md)."""
    keys, reference = VARIANTS[label]
    res = core_run(tmp_path, label, scheme__t_end=T_LONG, **keys)
    ref = reference(Bar1D(H), H / 20)
    n = len(res.trace["t"])
    e_core = res.trace["e_total"]
    e_ref = ref[:, 3] + ref[:, 4]
    d = differences(res.trace, ref)
    # relative to the energy level reached (a growing scheme reaches 10 e_total(0))
    d_e = float(np.max(np.abs(e_core - e_ref[:n])) / np.max(e_ref[:n]))
    print(label, res.status, f"t_end={res.trace['t'][-1]}", f"max e/e0={e_ref.max() / e_ref[0]:.3f}",
          " ".join(f"{c}={v:.1e}" for c, v in d.items()), f"e_total={d_e:.1e}")
    assert d["u_n"] <= TOL_U and d["v_n"] <= TOL_VP and d_e <= TOL_U, (label, d, d_e)
    over = np.nonzero(e_ref > BLOWUP * e_ref[0])[0]
    if len(over) == 0:
        assert res.status == "ok" and n == len(ref), (label, res.status, n)
    else:
        assert res.status == "unstable" and n == over[0] + 1, (label, res.status, n, over[0])
    assert np.all(res.trace["e_kin"] >= 0.0)


def test_hht_seed_gains_energy_like_the_reference(tmp_path):
    """The seed's printed HHT coefficients with alpha = -0.1 (gamma = 0.4 < 1/2) gain
    energy at every impact in both codes: e_total(T) / e_total(0) agree to round-off."""
    keys, reference = VARIANTS["hht_seed_-0.1"]
    res = core_run(tmp_path, "seed", scheme__t_end=3.0, **keys)
    ref = reference(Bar1D(H), H / 20)[: len(res.trace["t"])]
    growth_core = res.trace["e_total"][-1] / res.trace["e_total"][0]
    growth_ref = (ref[-1, 3] + ref[-1, 4]) / (ref[0, 3] + ref[0, 4])
    assert growth_ref > 1.5                       # the growth is real, not round-off
    assert abs(growth_core - growth_ref) <= TOL_U * growth_ref
