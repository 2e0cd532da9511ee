"""Each time scheme's order of accuracy in dt, measured against the exact solution of
the semi-discrete system: a contact-free run (no contact boundary) of a short clamped
bar released from its compressed state solves M u'' + K u = 0, whose solution is
u(t) = Phi (cos(w t) Phi^T M u0 + sin(w t)/w Phi^T M v0) with K Phi = M Phi diag(w^2),
Phi^T M Phi = I (numpy's eigh on L^{-1} K L^{-T}, M = L L^T; M and K are the core's
assembled matrices, checked against independent element formulas in test_fe.py and
test_tet.py). The error at t = T is then the time discretization's alone.

Nominal orders (Hughes, "The finite element method", ch. 9; Chung-Hulbert 1993): Newmark
is second order iff gamma = 1/2, any beta; HHT (gamma = 1/2 - alpha with the alpha-shifted
balance) and generalized-alpha (gamma = 1/2 - alpha_m + alpha_f) are second order; the
theta scheme on (u, u') is second order at theta = 1/2 only; central differences second
order. The seed's literal hht_seed (gamma = 1/2 + alpha with the standard alpha-shifted
balance line) matches neither and is first order for alpha != 0. The predictor-corrector
pc (beta, 1/2) is second order (its predicted acceleration is a(t + dt) + O(dt^2), enough
for O(dt^3) local errors in u and v); pc_hht with gamma = 1/2 - alpha keeps HHT's
second order, pc_hht_seed (gamma = 1/2 + alpha~) does not.

The observed order is log2(e(dt) / e(dt/2)) for the relative errors of u and of v at T,
with dt = T/200 and T/400 (w_max dt <= 0.12 on these meshes: the asymptotic range).
Measured in 1D, 2D and 3D, consistent and lumped mass: the second-order schemes 1.98-2.08
(u) and 1.93-2.04 (v); the first-order ones 0.87-1.16 (u) and 0.85-1.21 (v): their O(dt^2)
term is still of a size with the O(dt) one at these steps (over dt = T/50 ... T/400 the
estimate approaches 1 from either side). The bounds are 2 +- 0.1 (the style guide's
polyfit bound; the largest deviation measured is 0.075) and 1 +- 0.3 (the largest
deviation 0.21, and under half the distance between the orders 1 and 2), so a scheme of
the wrong order cannot pass.
"""

from __future__ import annotations

import numpy as np
import pytest

import dyncontact

from conftest import ROOT, stepper_as_designed

T = 0.5
N_STEPS = (200, 400)
#: allowed |observed - nominal| order (module docstring: measured spread, and half the
#: distance between the orders 1 and 2 at most)
ORDER_TOL = {2: 0.1, 1: 0.3}

SCENES = {1: "bar1d.nml", 2: "bar2d_hht.nml", 3: "bar3d_hht.nml"}
#: short bars (45, 60 and 180 free dofs), so that w_max dt stays small at dt = T/200
MESH = {1: {"h": 0.1}, 2: {"h": 0.05, "width": 0.1, "length": 0.5},
        3: {"h": 0.1, "width": 0.1, "length": 0.5}}

#: (scheme keys, nominal order)
SCHEMES = {
    "newmark_0.25_0.5": ({"name": "newmark", "beta": 0.25, "gamma": 0.5}, 2),
    "newmark_0.2_0.5": ({"name": "newmark", "beta": 0.2, "gamma": 0.5}, 2),
    "newmark_0.3025_0.6": ({"name": "newmark", "beta": 0.3025, "gamma": 0.6}, 1),
    "hht_-0.1": ({"name": "hht", "alpha": -0.1}, 2),
    "hht_seed_-0.1": ({"name": "hht_seed", "alpha": -0.1}, 1),
    "hht_seed_0.1": ({"name": "hht_seed", "alpha": 0.1}, 1),
    "theta_0.5": ({"name": "theta", "theta": 0.5}, 2),
    "theta_0.6": ({"name": "theta", "theta": 0.6}, 1),
    "galpha_0.8": ({"name": "galpha", "rho_inf": 0.8}, 2),
    "galpha_0.5": ({"name": "galpha", "rho_inf": 0.5}, 2),
    "pc_0.25_0.5": ({"name": "pc", "beta": 0.25, "gamma": 0.5}, 2),
    "pc_0.1_0.5": ({"name": "pc", "beta": 0.1, "gamma": 0.5}, 2),
    "pc_hht_-0.1": ({"name": "pc_hht", "alpha": -0.1}, 2),
    "pc_hht_seed_0.1": ({"name": "pc_hht_seed", "alpha": 0.1}, 1),
    "central": ({"name": "central"}, 2),
}
CASES = ([(dim, label, "consistent") for dim in (1, 2, 3) for label in SCHEMES]
         + [(2, label, "lumped") for label in SCHEMES])


def contact_free_scene(dim: int, keys: dict, n_steps: int, mass: str) -> dyncontact.Scene:
    s = dyncontact.Scene.read(ROOT / "scripts" / "scenes" / SCENES[dim])
    for key, value in MESH[dim].items():
        s.set(f"mesh.{key}", value)
    s.set("boundary.contact", "")
    s.set("initial.kind", "compressed_bar")
    for key, value in keys.items():
        s.set(f"scheme.{key}", value)
    s.set("scheme.dt", T / n_steps)
    s.set("scheme.t_end", T)
    s.set("scheme.mass", mass)
    s.set("scheme.newton_tol", 1e-13)
    return s


def modal_solution(m, k, u0, v0, t):
    """(u(t), v(t)) of M u'' + K u = 0 from (u0, v0), by the M-orthonormal modes."""
    lower_inv = np.linalg.inv(np.linalg.cholesky(m))
    w2, q = np.linalg.eigh(lower_inv @ k @ lower_inv.T)
    phi = lower_inv.T @ q
    w = np.sqrt(w2)
    q0, p0 = phi.T @ m @ u0, phi.T @ m @ v0
    return (phi @ (q0 * np.cos(w * t) + p0 / w * np.sin(w * t)),
            phi @ (-q0 * w * np.sin(w * t) + p0 * np.cos(w * t)))


def errors_at_t_end(dim, keys, n_steps, mass, out):
    """Relative errors of u and v at T against the modal solution."""
    with stepper_as_designed(contact_free_scene(dim, keys, n_steps, mass), out) as run:
        s0 = run.state()
        m, k = run.matrix("M"), run.matrix("K")
        done = 0
        while done < n_steps:
            done += run.advance(n_steps - done)
        s1 = run.state()
    assert s1["t"] == pytest.approx(T, rel=1e-12)
    u, v = modal_solution(m, k, s0["u"], s0["v"], s1["t"])
    return (np.linalg.norm(s1["u"] - u) / np.linalg.norm(u),
            np.linalg.norm(s1["v"] - v) / np.linalg.norm(v))


@pytest.mark.parametrize("dim, label, mass", CASES)
def test_observed_order_in_dt_is_the_nominal_one(dim, label, mass, tmp_path):
    keys, nominal = SCHEMES[label]
    (eu1, ev1), (eu2, ev2) = (errors_at_t_end(dim, keys, n, mass, tmp_path / f"n{n}")
                              for n in N_STEPS)
    # the errors are discretization errors, far above round-off, and the initial state
    # moves (the run is not trivially at rest)
    assert min(eu2, ev2) > 1e-8, (eu2, ev2)
    order_u, order_v = np.log2(eu1 / eu2), np.log2(ev1 / ev2)
    print(f"{dim}D {mass} {label}: e_u {eu1:.3e} -> {eu2:.3e} (order {order_u:.3f}), "
          f"e_v {ev1:.3e} -> {ev2:.3e} (order {order_v:.3f})")
    assert abs(order_u - nominal) <= ORDER_TOL[nominal], (order_u, nominal)
    assert abs(order_v - nominal) <= ORDER_TOL[nominal], (order_v, nominal)
