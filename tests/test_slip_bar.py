"""The 2D bar with sliding sides (boundary.slip_x = 'left,right') against the 1D bar
(SPEC section 2: lambda + 2 mu = 1 with E = 2/3, nu = 1/3, so the continuum problems
are the same; 1D gamma0 = 10/sqrt(2) gives the same gamma_N since h_T = sqrt(2) h in 2D).

Finding: the two DISCRETE systems are not the same, so their traces agree only up to
discretization error (max |du_n| 2.1e-2 at h = 0.05, 1.2e-2 at 0.025, 6.6e-3 at
0.0125, over T = 6), not to round-off. The 2D system restricted to x-independent
fields (0, w(y)) is the 1D one only "on average over each row of nodes":

* against an x-independent test function psi_k(y) (the sum of a row's hats with the
  trapezoidal weights tau_i = h/2 at the ends, h inside; sum = W) every term is W times
  the 1D one: the sliding sides kill int lambda w' d(v_x)/dx, and K, M, the contact
  term integrate exactly;
* against a single node's hat they are not proportional to tau_i: on the built-in
  criss-cross mesh the consistent (and the lumped) mass of an x-independent
  acceleration is not (nodes with 8 triangles carry 4/3 h^2 of lumped mass, those with
  4 carry 2/3 h^2, the bottom row's three nodes h^2/3 each), and for Nitsche theta != 0
  sigma_n(v) of a hat depends on which triangle owns the facet (it is 0 for a facet
  node opposite the triangle's vertical edge).

So M a = -B(u0) already gives an x-dependent initial acceleration and the 2D motion
leaves the x-independent fields at once (for theta = 0 too, through the mass). The
tests below check exactly these statements with the core's own operators (B
node-wise = tau_i B_1D for theta = 0 to 1e-15, off by 8e-3 of max|B_1D| for theta = 1;
M a / tau_i spreads by 50 % along a row), that the 2D slip trace equals an independent
2D numpy computation to round-off (observed 1e-13 in u_n: the difference from 1D is not
a bug in the sliding boundary), and that the 2D-1D difference shrinks with h.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from dyncontact import Scene
from dyncontact.core import Model, load_mesh, p1_element
from conftest import run_as_designed
from test_independent_1d import run_implicit

ROOT = Path(__file__).resolve().parents[1]
SCENE_1D = ROOT / "scripts" / "scenes" / "bar1d.nml"
W = 0.1                       # bar width: 2D energies are per W of cross-section
GAMMA0_1D = 10.0 / math.sqrt(2.0)
T_END = 6.0

#: Identities between exactly assembled operators: round-off relative to their size.
OPERATOR_TOL = 1e-12
#: Same discrete equations solved by two codes (see test_independent_1d.py): u_n and
#: energies (observed <= 2e-13), v_n and p_n (amplified by 1/dt and gamma_N;
#: observed <= 2e-11).
SAME_TOL_U = 1e-10
SAME_TOL_VP = 1e-8
#: 2D - 1D difference at h = 0.05 over T = 6 (observed: u_n 2.1e-2, energy/width
#: 6.8e-3 for theta = 1; 1.9e-2 and 5.4e-3 for theta = 0): discretization-sized, the
#: same size as either code's error against the exact solution (4.3e-2 in u_n).
DIFF_U_BOUND = 0.03
DIFF_E_BOUND = 0.01


def scene_2d(h=0.05, **keys) -> Scene:
    s = Scene()
    values = {"mesh.h": h, "boundary.slip_x": "left,right", "scheme.dt": h / 20,
              "scheme.t_end": T_END}
    values.update({k.replace("__", "."): v for k, v in keys.items()})
    for key, value in values.items():
        s.set(key, value)
    return s


def scene_1d(h=0.05, **keys) -> Scene:
    s = Scene.read(SCENE_1D)
    values = {"mesh.h": h, "material.young": 1.0, "contact.gamma0": GAMMA0_1D,
              "scheme.name": "hht", "scheme.dt": h / 20, "scheme.t_end": T_END}
    values.update({k.replace("__", "."): v for k, v in keys.items()})
    for key, value in values.items():
        s.set(key, value)
    return s


def trace_differences(a, b) -> dict[str, float]:
    """max |2D - 1D| of the probe values and of the energies per unit cross-section."""
    d = {c: float(np.max(np.abs(a[c] - b[c]))) for c in ("u_n", "v_n", "p_n")}
    for c in ("e_kin", "e_el", "e_contact", "e_total"):
        d[c] = float(np.max(np.abs(a[c] / W - b[c])))
    return d


# ----------------------------------------------------------------- 2D against 1D traces

@pytest.mark.parametrize("theta", [1, 0])
def test_slip_bar_starts_like_the_1d_bar(theta, tmp_path):
    """t = 0: the same u_n, and the same energies per unit cross-section (u0 is
    x-independent and linear, so every energy is integrated exactly in both)."""
    a = run_as_designed(scene_2d(contact__theta=theta, scheme__t_end=0.0025), out=tmp_path / "2d",
                       progress=False).trace
    b = run_as_designed(scene_1d(contact__theta=theta, scheme__t_end=0.0025), out=tmp_path / "1d",
                       progress=False).trace
    assert a["u_n"][0] == pytest.approx(b["u_n"][0], abs=1e-15)
    for c in ("e_kin", "e_el", "e_contact", "e_total"):
        assert a[c][0] / W == pytest.approx(b[c][0], rel=OPERATOR_TOL, abs=1e-16), c
    # ... but the first step already differs: the initial accelerations differ
    assert abs(a["u_n"][1] - b["u_n"][1]) > 1e-6


@pytest.mark.parametrize("theta", [1, 0])
def test_slip_bar_close_to_1d_bar_but_not_to_round_off(theta, tmp_path):
    """hht alpha = 0 over T = 6 at h = 0.05."""
    a = run_as_designed(scene_2d(contact__theta=theta), out=tmp_path / "2d", progress=False)
    b = run_as_designed(scene_1d(contact__theta=theta), out=tmp_path / "1d", progress=False)
    assert a.status == b.status == "ok"
    d = trace_differences(a.trace, b.trace)
    print(f"theta = {theta}: " + " ".join(f"{k}={v:.2e}" for k, v in d.items()))
    assert d["u_n"] <= DIFF_U_BOUND and d["e_total"] <= DIFF_E_BOUND
    assert d["u_n"] > 1e3 * SAME_TOL_U           # a real difference, explained above


@pytest.mark.slow
def test_slip_bar_difference_from_1d_shrinks_with_h(tmp_path):
    """Both discretize the same continuum problem: the 2D-1D difference of u_n and of
    the energy per width decreases with h (observed u_n 2.1e-2, 1.2e-2, 6.6e-3, order
    0.8; energy 6.8e-3, 3.0e-3, 1.3e-3, order 1.2). v_n and p_n do not converge
    pointwise (velocity jumps, oscillations) and are not compared."""
    hs = (0.05, 0.025, 0.0125)
    du, de = [], []
    for h in hs:
        a = run_as_designed(scene_2d(h), out=tmp_path / f"2d{h}", progress=False)
        b = run_as_designed(scene_1d(h), out=tmp_path / f"1d{h}", progress=False)
        d = trace_differences(a.trace, b.trace)
        du.append(d["u_n"])
        de.append(d["e_total"])
    order_u = np.polyfit(np.log(hs), np.log(du), 1)[0]
    order_e = np.polyfit(np.log(hs), np.log(de), 1)[0]
    print(f"2D-1D: u_n {du} (order {order_u:.2f}); energy/width {de} (order {order_e:.2f})")
    assert du[0] > du[1] > du[2] and de[0] > de[1] > de[2]
    assert order_u > 0.5 and order_e > 0.5


# ----------------------------------------------------------------- why: the operators

def _rows(x):
    """Node indices of each row y = const, sorted in x, with their trapezoidal weights."""
    out = []
    for y in np.unique(np.round(x[:, 1], 12)):
        row = np.flatnonzero(np.isclose(x[:, 1], y))
        row = row[np.argsort(x[row, 0])]
        dx = np.diff(x[row, 0])
        tau = (np.r_[dx, 0.0] + np.r_[0.0, dx]) / 2
        out.append((y, row, tau))
    return out


def _assemble_mass(mesh, lumped):
    x = mesh["x"]
    M = np.zeros((len(x), len(x)))           # one component (the y one)
    for cell in mesh["cells"]:
        _, me, ml = p1_element(2, x[cell].T, 2 / 3, 1 / 3, 1.0)
        m = (ml if lumped else me)[1::2, 1::2]
        M[np.ix_(cell, cell)] += m
    return M


@pytest.mark.parametrize("lumped", [False, True], ids=["consistent", "lumped"])
def test_mass_of_x_independent_field_is_1d_only_per_row(lumped):
    h = 0.05
    mesh = load_mesh("", dim=2, h=h)
    x = mesh["x"]
    M2 = _assemble_mass(mesh, lumped)
    a = 1.0 - x[:, 1] + 0.3 * x[:, 1] ** 2    # any x-independent nodal field
    f = M2 @ a
    # the 1D mass (unit cross-section) on the row coordinates
    ys = np.unique(np.round(x[:, 1], 12))
    n = len(ys)
    M1 = np.zeros((n, n))
    for e in range(n - 1):
        i = np.ix_([e, e + 1], [e, e + 1])
        M1[i] += h * (np.eye(2) / 2 if lumped else np.array([[2, 1], [1, 2]]) / 6)
    f1 = M1 @ (1.0 - ys + 0.3 * ys ** 2)
    spread = []
    for k, (y, row, tau) in enumerate(_rows(x)):
        assert np.sum(tau) == pytest.approx(W)
        assert np.sum(f[row]) == pytest.approx(W * f1[k], rel=OPERATOR_TOL)   # row: exact
        per_weight = f[row] / tau
        spread.append(np.ptp(per_weight) / np.max(np.abs(per_weight)))
    # node by node it is not W-proportional: the spread is O(1), not round-off
    print(f"max spread of M a / tau over a row: {max(spread):.2f}")
    assert max(spread) > 0.3


@pytest.mark.parametrize("theta", [0, 1])
def test_b_of_x_independent_field_is_1d_per_node_only_for_theta_0(theta):
    """B_2D((0, w(y))) against tau_i B_1D(w): node by node for theta = 0 (and no force in
    x), only per row for theta = 1. Checked in and out of contact."""
    h = 0.05
    mesh = load_mesh("", dim=2, h=h)
    x = mesh["x"]
    x1 = load_mesh("", dim=1, h=h)["x"][:, 0]
    for depth in (-0.3, 0.01):                # lifted (flight) and pressed (contact)
        # u_y = w(y), w(1) = 0 (clamped), u_n = -w(0) = depth; 1D: u(x) = w(x)
        w = lambda y: -depth * (1 - y) + 0.4 * y * (1 - y)   # noqa: E731
        with Model(scene_2d(contact__theta=theta)) as m2, \
                Model(scene_1d(contact__theta=theta)) as m1:
            node2, comp2 = m2.dof_map()
            u2 = np.where(comp2 == 1, w(x[node2, 1]), 0.0)
            b2, act2 = m2.eval_b(u2)
            node1, _ = m1.dof_map()
            b1, act1 = m1.eval_b(w(x1[node1]))
        assert (act1 > 0) == (depth > 0) and (act2 > 0) == (depth > 0)
        full2 = np.zeros((len(x), 2))
        full2[node2, comp2] = b2
        full1 = np.zeros(len(x1))
        full1[node1] = b1
        scale = np.max(np.abs(full1))
        per_node = 0.0
        for y, row, tau in _rows(x):
            k = int(np.argmin(np.abs(x1 - y)))
            if np.isclose(y, 1.0):
                continue                      # clamped row: no free dofs
            # per row (x-independent test function): always W times the 1D force
            assert np.sum(full2[row, 1]) == pytest.approx(W * full1[k], abs=OPERATOR_TOL * scale)
            per_node = max(per_node, np.max(np.abs(full2[row, 1] - tau * full1[k])),
                           np.max(np.abs(full2[row, 0])))
        print(f"theta = {theta}, u_n = {depth}: max node-wise |B_2D - tau B_1D| = "
              f"{per_node / scale:.2e} x max|B_1D|")
        if theta == 0:
            assert per_node <= OPERATOR_TOL * scale
        else:
            assert per_node > 1e-3 * scale


# ----------------------------------------------------------------- independent 2D code

class SlipBar2D:
    """Independent dense P1 plane-strain slip bar (SPEC section 1 only): u_x = 0 on
    x = 0, W; u = 0 on y = 1; Nitsche on y = 0 (n = (0, -1), g = 0, gamma_N = gamma0 /
    longest edge) with `nq` Gauss points per facet (the core's quadrature = 'gauss')."""

    def __init__(self, h, theta=1, gamma0=10.0, nq=3, young=2 / 3, poisson=1 / 3):
        mesh = load_mesh("", dim=2, h=h)
        x = mesh["x"]
        lam = young * poisson / ((1 + poisson) * (1 - 2 * poisson))
        mu = young / (2 * (1 + poisson))
        D = np.array([[lam + 2 * mu, lam, 0], [lam, lam + 2 * mu, 0], [0, 0, mu]])
        n = 2 * len(x)
        K, M = np.zeros((n, n)), np.zeros((n, n))
        fixed = {2 * i + c for i in np.flatnonzero(np.isclose(x[:, 1], 1.0)) for c in (0, 1)}
        fixed |= {2 * i for i in np.flatnonzero(np.isclose(x[:, 0], 0) | np.isclose(x[:, 0], W))}
        self.free = np.array(sorted(set(range(n)) - fixed))
        restrict = np.zeros((n, len(self.free)))
        restrict[self.free, np.arange(len(self.free))] = 1.0
        self.probe = int(np.flatnonzero(np.isclose(x[:, 0], 0.05) & np.isclose(x[:, 1], 0))[0])
        gp, gw = np.polynomial.legendre.leggauss(nq)
        self.quad, self.probe_rows = [], []   # (s, e_n, gamma_N, weight); (s, e_n at probe)
        for c in mesh["cells"]:
            T = np.vstack([np.ones(3), x[c].T])
            g = np.linalg.inv(T)[:, 1:]
            area = 0.5 * abs(np.linalg.det(T))
            Bm = np.zeros((3, 6))
            for a in range(3):
                Bm[:, 2 * a:2 * a + 2] = [[g[a, 0], 0], [0, g[a, 1]], [g[a, 1], g[a, 0]]]
            dofs = np.ravel([[2 * a, 2 * a + 1] for a in c])
            K[np.ix_(dofs, dofs)] += area * Bm.T @ D @ Bm
            mm = area * (np.ones((3, 3)) + np.eye(3)) / 12
            M[np.ix_(dofs[0::2], dofs[0::2])] += mm
            M[np.ix_(dofs[1::2], dofs[1::2])] += mm
            bottom = [a for a in c if np.isclose(x[a, 1], 0.0)]
            if len(bottom) == 2:              # the triangle owns a contact facet
                s = np.zeros(n)
                s[dofs] = (D @ Bm)[1]         # sigma_n(u) = n.sigma(u) n = sigma_yy
                s = s @ restrict
                gam = gamma0 / max(np.linalg.norm(x[c[i]] - x[c[i - 1]]) for i in range(3))
                p, q = bottom
                length = abs(x[q, 0] - x[p, 0])
                for xi, wq in zip(gp, gw):
                    en = np.zeros(n)          # u_n = -u_y at the Gauss point
                    en[[2 * p + 1, 2 * q + 1]] = [-(1 - xi) / 2, -(1 + xi) / 2]
                    self.quad.append((s, en @ restrict, gam, wq * length / 2))
                if self.probe in bottom:
                    en = np.zeros(n)
                    en[2 * self.probe + 1] = -1.0
                    self.probe_rows.append((s, en @ restrict, gam))
        self.K = restrict.T @ K @ restrict
        self.M = restrict.T @ M @ restrict
        self.Kt = self.K - sum(w * theta / gam * np.outer(s, s) for s, _, gam, w in self.quad)
        self.theta = theta
        self.uy0 = np.where(self.free % 2 == 1, 0.5 - x[self.free // 2, 1] / 2, 0.0)
        self.i_probe = int(np.flatnonzero(self.free == 2 * self.probe + 1)[0])

    def B(self, u):
        b = self.Kt @ u
        for s, en, gam, w in self.quad:
            P = s @ u - gam * (en @ u)
            b += w / gam * min(P, 0.0) * (self.theta * s - gam * en)
        return b

    def active(self, u):
        """Which Gauss points are in contact (P(u) < 0): the argument of dB."""
        return [s @ u - gam * (en @ u) < 0 for s, en, gam, _ in self.quad]

    def dB(self, active):
        J = self.Kt.copy()
        for (s, en, gam, w), on in zip(self.quad, active):
            if on:
                J += w / gam * np.outer(self.theta * s - gam * en, s - gam * en)
        return J

    def u0(self):
        return self.uy0.copy()

    def row(self, u, v):
        p_n = np.mean([min(s @ u - gam * (en @ u), 0.0) for s, en, gam in self.probe_rows])
        e_c = sum(w / (2 * gam) * (min(s @ u - gam * (en @ u), 0.0) ** 2
                                   - self.theta * (s @ u) ** 2) for s, en, gam, w in self.quad)
        return (-u[self.i_probe], -v[self.i_probe], p_n, 0.5 * v @ self.M @ v,
                0.5 * u @ self.K @ u, e_c)


@pytest.mark.parametrize("theta", [1, 0])
def test_slip_bar_matches_independent_2d_computation(theta, tmp_path):
    """The core's 2D slip trace is the discrete 2D system it should be (so the 2D-1D
    difference above is the discretization's, not a bug in the sliding boundary)."""
    t_end = 3.0       # one period: flight, contact, release
    res = run_as_designed(scene_2d(contact__theta=theta, contact__quadrature="gauss",
                                  contact__quad_points=3, scheme__name="newmark",
                                  scheme__t_end=t_end),
                         out=tmp_path / "2d", progress=False)
    assert res.status == "ok"
    # Newmark (1/4, 1/2): the independent 1D reference's stepper on the 2D bar
    ref = run_implicit(SlipBar2D(0.05, theta=theta), 0.05 / 20, t_end, beta=0.25, gamma=0.5)
    tr = res.trace
    assert len(tr["t"]) == len(ref)
    diffs = {}
    for j, c in enumerate(("u_n", "v_n", "p_n", "e_kin", "e_el", "e_contact")):
        diffs[c] = float(np.max(np.abs(tr[c] - ref[:, j])))
    print(f"theta = {theta}: " + " ".join(f"{k}={v:.1e}" for k, v in diffs.items()))
    assert np.any(tr["p_n"] < 0)
    for c, d in diffs.items():
        assert d <= (SAME_TOL_VP if c in ("v_n", "p_n") else SAME_TOL_U), (c, d)
