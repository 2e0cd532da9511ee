"""Every quantity a run carries from step to step instead of recomputing it, checked at
EVERY step of a short run against its definition, recomputed here in numpy from the
fields (dyncontact.core.Stepper's state), the assembled matrices and the mesh:

- M v (state mv; e_kin uses it) against M @ v;
- B(u) as the scheme carries it into the next step (state bu: K_theta u by a product, and
  the contact part, which the implicit schemes keep from the step's last Newton iterate)
  against B evaluated afresh at u, and against K_theta @ u off the contact cells;
- M (u - u~) (+ k a) of the next step's predictor, which the implicit schemes carry: it
  enters the balance equation of the step, recomputed here from u, v, a, M and B;
- the trace row's e_kin = 1/2 v.M v, e_el = 1/2 u.K u, e_total = e_kin + e_el,
  e_load = -u.L, and e_contact = e_pen - e_theta (e_pen = int [P]_-^2 / (2 gamma_N) over
  the contact facets, integrated in closed form from the nodal values of the linear P,
  e_theta = sum theta |F| sigma_n^2 / (2 gamma_N) from the P1 gradients of each facet's
  owner cell: the mesh, not the core's kernels), which the schemes carry from the
  contact evaluation of the step's last iterate;
- f_n, the total normal contact force (state and trace, carried from the same
  evaluation), against int [P]_- over the contact facets in closed form (the Gauss
  rule's sum where the scene uses one), and with the augmented Lagrangian against
  -t.(B(u) - K_theta u), t the rigid translation along n;
- the trace's active count (carried from the same evaluation) against a fresh evaluation
  at u, and the flag clear (no contact point possible at u) against contact_clear at u;
- with the augmented Lagrangian, the multipliers the carried contact force stands for
  (f = -N lambda, recovered from B(u) - K_theta u) against the complementarity at u;
- the time t (a running sum of dt) against n dt;
- a restart from a checkpoint in the middle of each run: the same states after it, bit
  for bit;
- summary.json's counters: newton_its_total against the sum of the trace's per-step
  newton_its, factorizations against the factorizations each scheme makes (J0 once, M
  once when not lumped, the θ-scheme's definiteness check of a redistributed mass once;
  tests/test_factorization_count.py counts the calls to CHOLMOD and UMFPACK), steps and
  t_end_reached against the run.

The runs: a short bar (1D, 2D, 3D) thrown with velocity 1 and gravity onto a plane
obstacle, tilted in 2D and 3D so the contact starts at a corner, spreads, cuts facets
(the 'exact' quadrature splits them) and is released within t = 0.3; for every scheme of
tests/test_invariants.py's list, every mass, and the contact variants Nitsche theta = 1,
0, -1 (and theta = 1 with Gauss rules: 3 points a segment in 2D, the 3- and 7-point
triangle rules in 3D), penalty and the augmented Lagrangian (integral and nodal
multipliers). CASES lists which combinations run in each dimension.
The implicit schemes' kept Woodbury factors and cache of columns of J0^{-1} are checked
against their references (the environment variables that form them afresh) in 1D, 2D
and 3D, for each implicit family and Nitsche theta = 1, 0, -1 and penalty.
tests/test_invariants.py checks the same kind of identities at sampled steps of long
runs of the seed's scenes; here every step is checked, on every dimension and contact
method.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import dyncontact
from dyncontact.core import Stepper, load_mesh, read_trace

from conftest import ROOT, drop_unused, lame, warns_as_designed
from test_invariants import SCHEMES, coefficients

EPS = np.finfo(float).eps
#: Relative round-off bound for an identity evaluated in double precision: each side is
#: a sum of O(10-100) terms (products with M, K, a P1 gradient, a closed-form integral),
#: whose round-off is a few hundred eps at most relative to the sum of the terms'
#: magnitudes (the scale each check names); 1e-12 is ~4500 eps, with room for the
#: carried contact part being evaluated at the Newton iterate x, which differs from u'
#: by round-off of u' (see the module header of fortran/schemes/implicit_schemes.f90).
THR = 1e-12
#: The Newton tolerance of the runs: below round-off of the residual's scale, so a
#: converged step is exact and the balance equation holds to round-off.
NEWTON_TOL = 1e-14
T_END = 0.3
#: time steps other than test_invariants.py's: the predictor-correctors at twice theirs
#: (300 steps; stable on these meshes, whose smallest cells are the 2D ones at h = 0.025),
#: central at the step it chooses (0.9 of its estimate of the critical step)
DT = {"pc": 0.001, "pc_hht": 0.001, "pc_hht_seed": 0.001, "central": 0.0}

#: (scene file, mesh keys, obstacle normal (into the obstacle), obstacle point, velocity)
GEOMETRY = {
    1: ("bar1d.nml", {"length": 0.2, "h": 0.02}, [-1.0, 0.0], [-0.004, 0.0], [-1.0, 0.0]),
    2: ("bar2d_hht.nml", {"length": 0.2, "width": 0.1, "h": 0.025}, [0.3, -1.0],
        [0.1, -0.004], [0.0, -1.0]),
    3: ("bar3d_hht.nml", {"length": 0.2, "width": 0.1, "h": 0.05}, [0.3, 0.2, -1.0],
        [0.1, 0.1, -0.004], [0.0, 0.0, -1.0]),
}
#: contact variants: (&contact keys)
CONTACT = {
    "nitsche1": {"method": "nitsche", "theta": 1},
    "nitsche0": {"method": "nitsche", "theta": 0},
    "nitsche-1": {"method": "nitsche", "theta": -1},
    "penalty": {"method": "penalty"},
    "alm_integral": {"method": "alm", "multiplier": "integral"},
    "alm_nodal": {"method": "alm", "multiplier": "nodal"},
    # a fixed 3-point Gauss rule on each segment (GetFEM's 2D runs; in 3D the symmetric
    # 3-point rule of degree 2 on each triangle), which does not resolve the kink: e_pen
    # is that rule's sum
    "nitsche1_gauss3": {"method": "nitsche", "theta": 1, "quadrature": "gauss",
                        "quad_points": 3},
    # 3D only: Radon's 7-point rule of degree 5 (GetFEM's face rule of the 3D reference)
    "nitsche1_gauss7": {"method": "nitsche", "theta": 1, "quadrature": "gauss",
                        "quad_points": 7},
}
#: the contact variants of 2D segments only (1D: a point; 3D: triangles)
ONLY_3D = ("nitsche1_gauss7",)
IMPLICIT = ("newmark", "hht", "hht_seed", "theta", "galpha")
MASSES = ("consistent", "lumped", "redistributed")


def takes(label, mass, contact):
    """Whether the scheme takes that mass and contact method (redistributed mass and the
    augmented Lagrangian: implicit schemes only)."""
    implicit = SCHEMES[label][0]["name"] in IMPLICIT
    return implicit or (mass != "redistributed" and not contact.startswith("alm"))


CASES = (
    # 2D: every scheme, every mass, every contact variant
    [(2, label, mass, contact, "direct") for label in SCHEMES for mass in MASSES
     for contact in CONTACT if takes(label, mass, contact) and contact not in ONLY_3D
     and (mass == "consistent" or contact in ("nitsche1", "penalty", "alm_integral"))]
    # 1D: every scheme, Nitsche theta = 1, 0, -1 and penalty (every mass with theta = 1),
    # the augmented Lagrangian (one contact node: 'nodal' is 'integral') with the
    # consistent mass
    + [(1, label, mass, contact, "direct") for label in SCHEMES for mass in MASSES
       for contact in ("nitsche1", "nitsche0", "nitsche-1", "penalty", "alm_nodal")
       if takes(label, mass, contact) and (mass == "consistent" or contact == "nitsche1")]
    # 3D: every scheme, Nitsche theta = 1, 0, -1, the 3- and 7-point Gauss rules,
    # penalty and both multipliers, with the consistent mass; theta = 1 and penalty with
    # every mass
    + [(3, label, mass, contact, "direct") for label in SCHEMES for mass in MASSES
       for contact in ("nitsche1", "nitsche0", "nitsche-1", "nitsche1_gauss3",
                       "nitsche1_gauss7", "penalty", "alm_integral", "alm_nodal")
       if takes(label, mass, contact)
       and (mass == "consistent" or contact in ("nitsche1", "penalty"))]
    # conjugate gradients for J0 (its solves and the contact correction's columns): the
    # implicit schemes in 2D and 3D (1D stays direct)
    + [(dim, label, "consistent", "nitsche1", "cg") for dim in (2, 3) for label in SCHEMES
       if SCHEMES[label][0]["name"] in IMPLICIT]
)
#: CG's relative residual: at most the Newton tolerance (docs/scenes.md, &solver
#: cg_rtol), which the balance check then meets to round-off as with the direct solver
#: (these matrices have ~100 rows: CG reaches round-off in fewer iterations than that).
CG_RTOL = NEWTON_TOL


def case_id(case):
    return "-".join(str(c) for c in case)


# ------------------------------------------------------------------ the reference

class ContactReference:
    """The contact facets of a built-in bar and what the carried contact quantities
    stand for, from the mesh alone: sigma_n(u) = s_f . u on facet f's owner cell (P1
    gradients, plane strain in 2D, sigma = E u' in 1D), u_n at its nodes, the gap,
    gamma_N = gamma0 / h_T (h_T: the owner cell's longest edge), |F|."""

    def __init__(self, dim, mesh_keys, young, poisson, gamma0, normal, point, dof_map,
                 n_dofs):
        m = load_mesh(dim=dim, **mesh_keys)
        x, cells = m["x"], m["cells"]
        bottom = m["group_names"].index("bottom")
        facets = m["facets"][m["facet_group"] == bottom]
        normal = np.asarray(normal[:dim], dtype=float)
        normal = normal / np.linalg.norm(normal)
        point = np.asarray(point[:dim], dtype=float)
        lam, mu = lame(young, poisson)
        free = {(int(nd), int(c)): k for k, (nd, c) in enumerate(zip(*dof_map))}
        cell_sets = [set(c.tolist()) for c in cells]
        nf = len(facets)
        self.dim = dim
        self.s = np.zeros((nf, n_dofs))             # sigma_n(u) = s[f] . u
        self.un = np.zeros((nf, dim, n_dofs))       # u_n at facet node j = un[f, j] . u
        self.gap = np.zeros((nf, dim))
        self.gamma = np.zeros(nf)
        self.measure = np.zeros(nf)
        self.cells = np.zeros(nf, dtype=int)
        self.facets = facets
        self.normal = normal
        self.gamma0 = gamma0
        self.free = free
        for f, fac in enumerate(facets):
            owner = [c for c, cs in enumerate(cell_sets) if set(fac.tolist()) <= cs]
            assert len(owner) == 1, "a contact facet with no single owner cell"
            cell = cells[owner[0]]
            self.cells[f] = owner[0]
            xc = x[cell]
            grads = np.linalg.inv(np.column_stack([np.ones(dim + 1), xc]))[1:, :]  # (dim, dim+1)
            h_t = max(np.linalg.norm(xc[i] - xc[j]) for i in range(dim + 1) for j in range(i))
            self.gamma[f] = gamma0 / h_t
            # d sigma_n / d u(node i, comp a): strain of that unit field, then n.sigma.n
            for i, node in enumerate(cell):
                for a in range(dim):
                    k = free.get((int(node), a))
                    if k is None:
                        continue
                    g = np.zeros((dim, dim))
                    g[a, :] = grads[:, i]
                    eps_ = 0.5 * (g + g.T)
                    if dim == 1:
                        sig = young * eps_
                    else:
                        sig = lam * np.trace(eps_) * np.eye(dim) + 2 * mu * eps_
                    self.s[f, k] = normal @ sig @ normal
            for j, node in enumerate(fac):
                for a in range(dim):
                    k = free.get((int(node), a))
                    if k is not None:
                        self.un[f, j, k] = normal[a]
                self.gap[f, j] = (point - x[node]) @ normal
            xf = x[fac]
            if dim == 1:
                self.measure[f] = 1.0
            elif dim == 2:
                self.measure[f] = np.linalg.norm(xf[1] - xf[0])
            else:
                self.measure[f] = 0.5 * np.linalg.norm(np.cross(xf[1] - xf[0], xf[2] - xf[0]))
        # the dofs of the owner cells (where the contact part of B lives)
        self.cell_dofs = np.zeros(n_dofs, dtype=bool)
        for c in self.cells:
            for node in cells[c]:
                for a in range(dim):
                    k = free.get((int(node), a))
                    if k is not None:
                        self.cell_dofs[k] = True

    def energies(self, u, theta, penalty, gauss=0):
        """(e_pen, e_theta, e_scale, b_scale): e_pen = sum_f int_F [P]_-^2 / (2 gamma_f),
        exact for the linear P; e_theta = sum_f theta |F| sigma_n^2 / (2 gamma_f).
        P = sigma_n - gamma (u_n - g) is formed from terms of magnitude pmag =
        |s| |u| + gamma (|u_n| + |g|), so its round-off is a few eps pmag (and the
        carried value, taken at the Newton iterate, differs by the round-off of u, which
        pmag covers too). e_scale bounds the round-off of the energies:
        |F| / gamma (pmag max|[P]_-| + |theta| (|s| |u|)^2) summed over the facets;
        b_scale that of the contact residual's entries, |F| / gamma pmag (|s| + gamma)
        summed over the facets (a dof is on a few of them)."""
        sn = self.s @ u
        un = self.un @ u
        ws = 0.0 if penalty else 1.0
        p = ws * sn[:, None] - self.gamma[:, None] * (un - self.gap)
        smag = np.abs(self.s) @ np.abs(u)
        pmag = ws * smag + self.gamma * (np.max(np.abs(self.un) @ np.abs(u), axis=1)
                                         + np.max(np.abs(self.gap), axis=1))
        pneg = np.max(np.maximum(-p, 0.0), axis=1)
        if gauss:
            pq, wq = self.gauss_values(p, gauss)
            e_pen = float(np.sum(self.measure / (2 * self.gamma)
                                 * (np.minimum(pq, 0.0) ** 2 @ wq)))
        else:
            e_pen = sum(self.integral(p[f], self.measure[f]) / (2 * self.gamma[f])
                        for f in np.flatnonzero(np.any(p < 0, axis=1)))
        e_theta = 0.0 if penalty else float(np.sum(theta * self.measure * sn**2
                                                   / (2 * self.gamma)))
        w = self.measure / self.gamma
        e_scale = float(np.sum(w * (pmag * pneg + abs(theta) * smag**2)))
        b_scale = float(np.sum(w * pmag * (ws * np.max(np.abs(self.s), axis=1) + self.gamma)))
        return e_pen, e_theta, e_scale, b_scale

    def force(self, u, penalty, gauss=0):
        """(f_n, scale): f_n = sum_f int_F [P]_- (<= 0), exact for the linear P (the part
        where P < 0 in closed form, as :meth:`integral`), or the Gauss rule's sum; scale
        bounds its round-off, |F| pmag summed over the facets (pmag as in
        :meth:`energies`)."""
        ws = 0.0 if penalty else 1.0
        p = ws * (self.s @ u)[:, None] - self.gamma[:, None] * (self.un @ u - self.gap)
        pmag = ws * (np.abs(self.s) @ np.abs(u)) + self.gamma * (
            np.max(np.abs(self.un) @ np.abs(u), axis=1) + np.max(np.abs(self.gap), axis=1))
        if gauss:
            pq, wq = self.gauss_values(p, gauss)
            f_n = float(np.sum(self.measure * (np.minimum(pq, 0.0) @ wq)))
        else:
            f_n = sum(self.integral(p[f], self.measure[f], power=1)
                      for f in np.flatnonzero(np.any(p < 0, axis=1)))
        return f_n, float(np.sum(self.measure * pmag))

    def alm(self, u, f, kind, kmag):
        """The multipliers lambda the carried contact force f = B(u) - K_theta u stands
        for, and the complementarity G(u, lambda) = 0 they must meet (fem/alm_contact.f90's
        header): returns (errors, active) with errors a list of (name, |error| / scale)
        and active the points where lambda - r (u_n - g) < 0. 'nodal': f = -lambda_i n at
        contact node i, zero elsewhere; G_i = u_n - g if active, lambda_i / r_i if not
        (r_i: mean gamma0 / h_T of its facets). 'integral' (a segment or a point):
        f = -N lambda, N(dof (K, a), J) = sum_F n_a int_F psi_K psi_J (lambda found by
        least squares, f must lie in N's range), G_J = int psi_J (u_n - g) where P < 0,
        int psi_J lambda / r where not, P = lambda - r (u_n - g) linear on each facet
        (2 Gauss points on each side of its zero: exact for these quadratics). Scales:
        kmag + |f| for f (the products K_theta u and N lambda it is formed from),
        |u| + |g| + |lambda| / r for G."""
        kmag = max(kmag + np.max(np.abs(f)), np.finfo(float).tiny)
        nodes = sorted({int(k) for k in self.facets.ravel()})
        where = {k: i for i, k in enumerate(nodes)}
        dofs = [[self.free[(k, a)] for a in range(self.dim)] for k in nodes]
        gap = np.zeros(len(nodes))
        rsum, nfac = np.zeros(len(nodes)), np.zeros(len(nodes))
        for fi, fac in enumerate(self.facets):
            for j, k in enumerate(fac):
                gap[where[int(k)]] = self.gap[fi, j]
                rsum[where[int(k)]] += self.gamma[fi]
                nfac[where[int(k)]] += 1
        un = np.array([self.normal @ u[d] for d in dofs]) - gap
        umag = np.max(np.abs(u)) + np.abs(gap)
        on = np.zeros(len(u), dtype=bool)
        on[np.ravel(dofs)] = True
        errors = [("f off the contact nodes", np.max(np.abs(f[~on]), initial=0.0) / kmag)]
        if kind == "nodal" or self.dim == 1:
            lam = np.array([-(self.normal @ f[d]) for d in dofs])
            tang = np.array([f[d] + lam[i] * self.normal for i, d in enumerate(dofs)])
            errors.append(("f along the normal", np.max(np.abs(tang)) / kmag))
            r = rsum / nfac
            act = lam - r * un < 0
            g = np.where(act, un, lam / r)
            scale = np.where(act, umag, (umag * r + kmag) / r)
            errors.append(("G", np.max(np.abs(g) / scale)))
            return errors, int(np.count_nonzero(act))
        n_mat = np.zeros((len(u), len(nodes)))
        nfn = self.dim      # facet nodes: int psi_K psi_J = |F| (1 + delta_KJ) / 6 or / 12
        for fi, fac in enumerate(self.facets):
            mf = self.measure[fi] / (nfn * (nfn + 1)) * (np.ones((nfn, nfn)) + np.eye(nfn))
            for j, kj in enumerate(fac):
                for k, kk in enumerate(fac):
                    n_mat[dofs[where[int(kk)]], where[int(kj)]] += self.normal * mf[k, j]
        lam = np.linalg.lstsq(n_mat[on], -f[on], rcond=None)[0]
        errors.append(("f in the range of N", np.max(np.abs(f + n_mat @ lam)) / kmag))
        g = np.zeros(len(nodes))
        gscale = np.zeros(len(nodes))
        active = 0
        gauss = 0.5 + np.array([-0.5, 0.5]) / np.sqrt(3.0)
        for fi, fac in enumerate(self.facets):
            idx = [where[int(k)] for k in fac]
            r, meas = self.gamma[fi], self.measure[fi]
            p = lam[idx] - r * un[idx]
            if self.dim == 3:   # the pieces where P < 0 and where not, 3 points a triangle
                for piece, negative in triangle_pieces(p):
                    frac = abs(np.linalg.det(piece))     # |piece| / |F|
                    active += 3 * negative
                    for c in np.full((3, 3), 1 / 6) + np.eye(3) / 2:   # (2/3, 1/6, 1/6) ...
                        psi = c @ piece
                        value = un[idx] @ psi if negative else (lam[idx] @ psi) / r
                        g[idx] += meas * frac / 3 * psi * value
                gscale[idx] += meas * (np.max(umag[idx]) + np.max(np.abs(lam[idx])) / r)
                continue
            cut = [0.0, 1.0] if (p[0] < 0) == (p[1] < 0) else [0.0, p[0] / (p[0] - p[1]), 1.0]
            active += 2 * bool(np.any(p < 0))
            for a, b in zip(cut[:-1], cut[1:]):
                for xi in a + (b - a) * gauss:
                    psi = np.array([1.0 - xi, xi])
                    w = 0.5 * (b - a) * meas
                    value = un[idx] @ psi if psi @ p < 0 else (lam[idx] @ psi) / r
                    g[idx] += w * psi * value
            gscale[idx] += meas * (np.max(umag[idx]) + np.max(np.abs(lam[idx])) / r)
        errors.append(("G", np.max(np.abs(g) / gscale)))
        return errors, active

    def gauss_values(self, p, n):
        """(P at the points of an n-point rule on each facet, (facets, n); the weights,
        summing to 1). A segment: Gauss-Legendre. A triangle: the symmetric rules of
        degree 2 (3 points: Strang-Fix, barycentric (2/3, 1/6, 1/6) and its rotations,
        weights 1/3) and 5 (7 points: Radon), :func:`triangle_rule`."""
        if self.dim == 2:
            xi, wq = np.polynomial.legendre.leggauss(n)
            return p @ np.array([(1 - xi) / 2, (1 + xi) / 2]), wq / 2
        bary, wq = triangle_rule(n)
        return p @ bary.T, wq

    def integral(self, p, measure, power=2):
        """int_F min(P, 0)^power (power 2 or 1) for P linear on the facet with nodal
        values p (a point, a segment or a triangle of measure `measure`), in closed form:
        the part where P < 0 is the facet, a sub-segment / sub-triangle at a negative
        node, or the facet less the sub-triangle at its one node where P >= 0. On a
        facet simplex (of dimension dim - 1) where P vanishes at all nodes but the one
        with value q, int P^2 is |part| q^2 2 / (dim (dim + 1)) and int P is
        |part| q / dim: 1/3 and 1/2 on a segment, 1/6 and 1/3 on a triangle."""
        p = np.asarray(p, dtype=float)
        neg = p < 0
        if not neg.any():
            return 0.0
        if self.dim == 1:
            return float(p[0] ** power)
        if power == 1:
            full = measure * np.mean(p)
            corner = 1.0 / self.dim
        else:
            full = measure / (self.dim * (self.dim + 1) / 2) * (
                np.sum(p**2) + sum(p[i] * p[j] for i in range(len(p)) for j in range(i)))
            corner = 2.0 / (self.dim * (self.dim + 1))
        if neg.all():
            return float(full)
        if self.dim == 2:   # one node negative: the sub-segment from it to the zero
            i = int(np.flatnonzero(neg)[0])
            t = p[i] / (p[i] - p[1 - i])
            return float(t * measure * corner * p[i] ** power)
        if neg.sum() == 1:  # the sub-triangle at the negative node
            i = int(np.flatnonzero(neg)[0])
            t = [p[i] / (p[i] - p[k]) for k in range(3) if k != i]
            return float(measure * t[0] * t[1] * corner * p[i] ** power)
        i = int(np.flatnonzero(~neg)[0])   # the facet less the sub-triangle where P >= 0
        t = [p[i] / (p[i] - p[k]) for k in range(3) if k != i]
        return float(full - measure * t[0] * t[1] * corner * p[i] ** power)


def triangle_rule(n):
    """(barycentric points (n, 3), weights summing to 1) of the symmetric triangle rules
    of degree 2 (n = 3: Strang-Fix, (2/3, 1/6, 1/6) and its rotations, weights 1/3) and
    5 (n = 7: Radon; the centroid, weight 9/40, and the orbits of (1 - 2a, a, a),
    a = (6 -+ sqrt 15)/21, weights (155 -+ sqrt 15)/1200)."""
    def orbit(a):
        return [[1 - 2 * a, a, a], [a, 1 - 2 * a, a], [a, a, 1 - 2 * a]]
    if n == 3:
        return np.array(orbit(1 / 6)), np.full(3, 1 / 3)
    if n == 7:
        r = np.sqrt(15.0)
        return (np.array([[1 / 3] * 3] + orbit((6 - r) / 21) + orbit((6 + r) / 21)),
                np.array([9 / 40] + [(155 - r) / 1200] * 3 + [(155 + r) / 1200] * 3))
    raise ValueError(f"no {n}-point triangle rule here")


def triangle_pieces(p):
    """The triangles, in barycentric coordinates of a facet (rows: a piece's vertices),
    that make up its parts where the linear P (nodal values p) is negative and where it
    is not, each with whether it is the negative part: the whole facet, or a corner
    triangle cut off by the zero line and the quadrilateral left, split along a diagonal
    into two triangles."""
    eye = np.eye(3)
    neg = p < 0
    if neg.all() or not neg.any():
        return [(eye, bool(neg.all()))]
    lone = int(np.flatnonzero(neg if neg.sum() == 1 else ~neg)[0])
    j, k = [m for m in range(3) if m != lone]

    def zero(a, b):     # the zero of P on the edge a-b
        t = p[a] / (p[a] - p[b])
        return (1 - t) * eye[a] + t * eye[b]
    corner = np.array([eye[lone], zero(lone, j), zero(lone, k)])
    quad = [np.array([zero(lone, j), eye[j], eye[k]]), np.array([zero(lone, j), eye[k],
                                                                  zero(lone, k)])]
    corner_negative = bool(neg[lone])
    return [(corner, corner_negative)] + [(q, not corner_negative) for q in quad]


def scene_for(dim, label, mass, contact, solver="direct"):
    f, mesh_keys, normal, point, velocity = GEOMETRY[dim]
    keys, dt = SCHEMES[label]
    dt = DT.get(keys["name"], dt)
    scene = dyncontact.Scene.read(ROOT / "scripts" / "scenes" / f)
    for k, v in mesh_keys.items():
        scene.set(f"mesh.{k}", v)
    for k, v in keys.items():
        scene.set(f"scheme.{k}", v)
    scene.set("scheme.dt", dt)
    scene.set("scheme.t_end", T_END)
    scene.set("scheme.mass", mass)
    scene.set("scheme.newton_tol", NEWTON_TOL)
    scene.set("scheme.blowup", 1e6)
    scene.set("contact.quadrature", "exact")
    for k, v in CONTACT[contact].items():
        scene.set(f"contact.{k}", v)
    scene.set("contact.obstacle_normal", normal)
    scene.set("contact.obstacle_point", point)
    scene.set("contact.probe", [0.0, 0.0] if dim == 1 else [0.1, *([0.05] * (dim - 2)), 0.0])
    scene.set("initial.kind", "velocity")
    scene.set("initial.velocity", velocity)
    scene.set("material.gravity", [0.5 * c for c in velocity])
    scene.set("solver.kind", solver)
    if solver == "cg":
        scene.set("solver.cg_rtol", CG_RTOL)
    return drop_unused(scene), mesh_keys, normal, point


def rel(x, scale):
    return float(np.max(np.abs(x)) / max(scale, np.finfo(float).tiny))


@pytest.mark.parametrize("case", CASES, ids=case_id)
def test_carried_quantities_every_step(case, tmp_path):
    dim, label, mass, contact, solver = case
    keys = SCHEMES[label][0]
    family, am, af, beta, _, theta_s = coefficients(keys)
    alm = contact.startswith("alm")
    penalty = contact == "penalty"
    theta = CONTACT[contact].get("theta", 0)
    scene, mesh_keys, normal, point = scene_for(dim, label, mass, contact, solver)
    out = tmp_path / "run"
    states, fresh = [], []
    with warns_as_designed(scene):
        run = Stepper(scene, out)
    with run:
        M, K, Kt = run.matrix("M"), run.matrix("K"), run.matrix("K_theta")
        ref = ContactReference(dim, mesh_keys, scene.get("material.young"),
                               scene.get("material.poisson"), scene.get("contact.gamma0"),
                               normal, point, run.dof_map(), run.dofs)
        n_steps = run.n_steps
        states.append(run.state())
        fresh.append(run.eval_b(states[0]["u"]))
        clear = [run.contact_clear(states[0]["u"])]
        saved = n_steps // 2
        for step in range(n_steps):
            if step == saved:
                run.save(tmp_path / "state.bin")
            assert run.advance(1) == 1
            states.append(run.state())
            fresh.append(run.eval_b(states[-1]["u"]))
            clear.append(run.contact_clear(states[-1]["u"]))
        # a restart from the checkpoint in the middle of the run (in contact) carries
        # what the step after it needs: every state after it the same, bit for bit (so
        # the checks below hold for the restarted run too)
        run.save(tmp_path / "end.bin")
        assert run.load(tmp_path / "state.bin") == saved
        for step in range(saved, n_steps):
            assert run.advance(1) == 1
            again = run.state()
            for key in ("t", "u", "v", "a", "mv", "bu"):
                assert np.array_equal(again[key], states[step + 1][key]), \
                    (case_id(case), "restarted at", saved, "step", step + 1, key)
        # and the same counters and column cache at the end: a checkpoint of the
        # restarted run's end is that of the run's end, byte for byte (the CG solves
        # among its counters: the columns the cache held are solved again at the restart,
        # uncounted, and the run then solves what the run never stopped solves)
        run.save(tmp_path / "end_again.bin")
        assert (tmp_path / "end_again.bin").read_bytes() == (tmp_path / "end.bin").read_bytes()
    trace = read_trace(out)
    summary = json.loads((out / "summary.json").read_text())
    assert len(trace["t"]) == n_steps + 1
    assert np.any(trace["active"] > 0), "the run never reached contact"
    if not alm:
        assert np.any(trace["active"][1:] < np.maximum.accumulate(trace["active"])[1:]), \
            "the contact was never (partly) released"

    inert = np.any(M != 0.0, axis=0)
    absM, absK, absKt = np.abs(M), np.abs(K), np.abs(Kt)
    dt = states[1]["t"]
    for n, (s, (b, active)) in enumerate(zip(states, fresh)):
        u, v, mv, bu, load = s["u"], s["v"], s["mv"], s["bu"], s["load"]
        where = f"{case_id(case)} step {n} (t = {s['t']:.4f})"
        # t: a running sum of dt, each addition rounded by at most eps/2 of the sum
        assert abs(s["t"] - n * dt) <= n * EPS * s["t"], (where, "t")
        assert trace["t"][n] == s["t"], (where, "trace t")
        assert trace["f_n"][n] == s["f_n"], (where, "trace f_n")
        # M v, carried for e_kin: each entry a sum of products, scaled by |M| |v|
        assert rel(mv - M @ v, np.max(absM @ np.abs(v))) <= THR, (where, "M v")
        # B(u): the linear part is K_theta u everywhere; the contact part (Nitsche and
        # penalty) against the core's evaluation afresh at u
        kmag = np.max(absKt @ np.abs(u))
        e_pen, e_theta, cscale, bterm = ref.energies(u, theta, penalty,
                                                     CONTACT[contact].get("quad_points", 0))
        off = ~ref.cell_dofs
        assert rel((bu - Kt @ u)[off], kmag) <= THR, (where, "B(u) off the contact cells")
        if not alm:
            bscale = kmag + bterm
            assert rel(bu - b, bscale) <= THR, (where, "B(u)", rel(bu - b, bscale))
        # the flag clear (the step found no contact point possible at u, so the probe
        # skips [P]_- there): set only where it holds; never by the explicit schemes
        assert clear[n] or not s["clear"], (where, "clear")
        assert not (s["clear"] and keys["name"] not in IMPLICIT), (where, "clear (explicit)")
        # the trace row: energies of this state, from their definitions
        e_kin = 0.5 * v @ M @ v
        e_el = 0.5 * u @ K @ u
        escale = 0.5 * np.abs(v) @ absM @ np.abs(v) + 0.5 * np.abs(u) @ absK @ np.abs(u)
        assert abs(trace["e_kin"][n] - e_kin) <= THR * escale, (where, "e_kin")
        assert abs(trace["e_el"][n] - e_el) <= THR * (escale + cscale), (where, "e_el")
        assert abs(trace["e_total"][n] - (e_kin + e_el)) <= THR * (escale + cscale), \
            (where, "e_total")
        assert abs(trace["e_load"][n] + u @ load) <= THR * (np.abs(u) @ np.abs(load)), \
            (where, "e_load")
        if alm:
            assert trace["e_contact"][n] == 0.0, (where, "e_contact (alm)")
            # the multipliers the carried contact force stands for meet the complementarity
            # at u, and the trace's active count is theirs
            errors, act = ref.alm(u, bu - Kt @ u, CONTACT[contact]["multiplier"], kmag)
            for name, err in errors:
                assert err <= THR, (where, name, err)
            if n > 0:
                assert trace["active"][n] == act, (where, "active (alm)", act)
            # f_n, the multipliers' resultant: against the rigid translation t along n
            # (every contact node's dofs free) the contact part of B gives -f_n; the
            # round-off of B(u) - K_theta u entries is bounded by kmag + |f| each
            t_n = np.zeros(len(u))
            for (_node, a), k in ref.free.items():
                t_n[k] = ref.normal[a]
            fc = bu - Kt @ u
            assert abs(s["f_n"] + t_n @ fc) <= THR * (kmag + np.max(np.abs(fc))) \
                * np.count_nonzero(ref.cell_dofs), (where, "f_n (alm)", s["f_n"], -t_n @ fc)
        else:
            # the reference's sigma_n rows against the matrices: e_theta = 1/2 u.(K - K_theta) u
            assert abs(e_theta - 0.5 * u @ (K - Kt) @ u) <= THR * (escale + cscale), \
                (where, "reference e_theta")
            assert abs(trace["e_contact"][n] - (e_pen - e_theta)) <= THR * (escale + cscale), \
                (where, "e_contact", trace["e_contact"][n], e_pen - e_theta)
            # f_n, carried from the step's contact evaluation: int [P]_- at u
            f_n, fscale = ref.force(u, penalty, CONTACT[contact].get("quad_points", 0))
            assert abs(s["f_n"] - f_n) <= THR * fscale, (where, "f_n", s["f_n"], f_n)
            assert trace["active"][n] == active, (where, "active")
        if n == 0:
            assert trace["newton_its"][0] == 0
            continue
        # the step's balance equation, from the state before and after it: it holds to
        # round-off only if what the step carried (M (u - u~) + k a of its predictor,
        # B(u^n)) is what it stands for. B is the fresh one (the carried one with the
        # augmented Lagrangian, whose multipliers are the scheme's).
        s0 = states[n - 1]
        b0, b1 = (s0["bu"], bu) if alm else (fresh[n - 1][0], b)
        u0, v0, a0, a1 = s0["u"], s0["v"], s0["a"], s["a"]
        if family in ("newmark", "hht", "galpha"):
            bal = (1 - am) * M @ a1 + am * M @ a0 + (1 - af) * b1 + af * b0 - load
            bal_scale = (np.max(absM @ np.abs(a1)) + np.max(absM @ np.abs(a0))
                         + np.max(np.abs(b1)) + np.max(np.abs(b0)) + np.max(np.abs(load))
                         + (1 - am) * np.max(absM @ np.abs(u)) / (beta * dt * dt))
        elif family == "theta":
            bal = M @ (v - v0) - dt * (load - theta_s * b1 - (1 - theta_s) * b0)
            bal_scale = (np.max(absM @ np.abs(v - v0)) + np.max(absM @ np.abs(u)) / theta_s
                         + dt * (np.max(np.abs(b1)) + np.max(np.abs(b0))
                                 + np.max(np.abs(load))))
        elif family == "central":
            bal = M @ a1 - (load - b1)
            bal_scale = np.max(absM @ np.abs(a1)) + np.max(np.abs(b1)) + np.max(np.abs(load))
        else:   # predictor-correctors: the acceleration of the written state
            bal = M @ a1 - (load - af * b0 - (1 - af) * b1)
            bal_scale = (np.max(absM @ np.abs(a1)) + (1 + abs(af)) * np.max(np.abs(b1))
                         + abs(af) * np.max(np.abs(b0)) + np.max(np.abs(load)))
        bal_scale += bterm
        assert rel(bal, bal_scale) <= THR, (where, "balance", rel(bal, bal_scale))
        if not inert.all():   # dofs without inertia: v = (u' - u)/dt, a = 0
            assert rel((v - (u - u0) / dt)[~inert], np.max(np.abs(v)) + 1e-300) <= THR
            assert np.all(a1[~inert] == 0.0)

    # the run's counters
    explicit = keys["name"] not in IMPLICIT
    assert summary["steps"] == n_steps and summary["t_end_reached"] == states[-1]["t"]
    assert summary["newton_its_total"] == int(np.sum(trace["newton_its"][1:]))
    if explicit:
        assert np.all(trace["newton_its"] == 0)
    else:
        assert np.all(trace["newton_its"][1:] >= 1)
    # factorizations: J0 once (implicit, direct solver), M once unless lumped (explicit
    # schemes, and the Newmark family's initial acceleration: L - B(u0) is not zero
    # here, gravity; tests/test_initial_acceleration.py for a zero one), the θ-scheme's check that
    # a redistributed M is definite once (of S or M, direct whatever the solver); a CG
    # that fell back to a direct factorization would add it (implicit_schemes' count_lu0; the factors' count
    # of it: test_solver_cg), which J0, positive definite in every accepted scene, never
    # makes here (no note says so)
    if solver == "cg":
        assert summary["solver_note"] == "", summary["solver_note"]
    expected = (0 if explicit or solver == "cg" else 1) + (
        0 if mass == "lumped" or family == "theta" else 1) + (
        1 if family == "theta" and mass == "redistributed" else 0)
    assert summary["factorizations"] == expected, (summary["factorizations"], expected)
    if solver == "cg":
        # one J0 solve a step at least (y0), each of at least one iteration
        assert summary["solver"] == "pcg" and summary["cg_solves"] >= n_steps
        assert summary["cg_iterations"] >= summary["cg_solves"]
        assert (summary["cg_iterations"] / summary["cg_solves"] <= summary["cg_max_iterations"]
                <= scene.get("solver.cg_max_iter"))
    else:
        assert summary["cg_solves"] == summary["cg_iterations"] == 0


# ------------------------------------------------- the kept factors and columns

#: The implicit schemes' caches of the contact correction and the environment variables
#: that replace each by its reference (fortran/schemes/implicit_schemes.f90's header):
#: the Woodbury factors reused while the tangent is the same (fresh: formed and
#: factorized at every iteration), the lazily solved, bounded cache of the columns of
#: Z = J0^{-1} P^T (all: every column at set-up; 0 MB: every column not needed at the
#: current step dropped and solved again when needed). Both give the same numbers by
#: the same operations: the traces equal to the bit.
SAME_BITS = {"DYNCONTACT_WOODBURY_FRESH": "1", "DYNCONTACT_CONTACT_COLUMNS": "all"}
EVICTING = {"DYNCONTACT_CONTACT_COLUMNS": "0"}
#: The Woodbury system on the node basis and Z T on the node basis, against the system
#: on the terms and Z T on the dofs: equal in exact arithmetic, so the runs differ by
#: round-off (each step's THR, over the 120 steps of a run, within what the Newton test
#: at NEWTON_TOL leaves free: TOL, as in tests/test_zt_basis.py), with the same active
#: counts and Newton iterations at every row.
ON_TERMS = {"DYNCONTACT_WOODBURY_BASIS": "terms", "DYNCONTACT_ZT_BASIS": "dofs"}
TOL = 1e-10
#: one scheme of each implicit family
REF_LABELS = [next(lb for lb in SCHEMES if SCHEMES[lb][0]["name"] == name) for name in IMPLICIT]
REF_CASES = [(dim, label, contact) for dim in (1, 2, 3) for label in REF_LABELS
             for contact in ("nitsche1", "nitsche0", "nitsche-1", "penalty")]


def run_env(monkeypatch, env, scene, out):
    for var in (*SAME_BITS, *ON_TERMS):
        monkeypatch.delenv(var, raising=False)
    for var, value in env.items():
        monkeypatch.setenv(var, value)
    with warns_as_designed(scene):
        res = dyncontact.run(scene, out=out, progress=False)
    assert res.ok, res.message
    return res.trace


@pytest.mark.parametrize("case", REF_CASES, ids=case_id)
def test_kept_factors_and_columns_equal_their_references(case, monkeypatch, tmp_path):
    dim, label, contact = case
    scene = scene_for(dim, label, "consistent", contact)[0]
    kept = run_env(monkeypatch, {}, scene, tmp_path / "kept")
    assert kept["active"].max() > 0 and kept["newton_its"].max() >= 2
    for name, env in (("fresh, all columns", SAME_BITS), ("evicting", EVICTING)):
        ref = run_env(monkeypatch, env, scene, tmp_path / name.replace(" ", "_"))
        for col in kept:
            np.testing.assert_array_equal(kept[col], ref[col], err_msg=f"{name}: {col}")
    ref = run_env(monkeypatch, {**SAME_BITS, **ON_TERMS}, scene, tmp_path / "terms")
    np.testing.assert_array_equal(kept["active"], ref["active"])
    np.testing.assert_array_equal(kept["newton_its"], ref["newton_its"])
    for col in kept:
        scale = np.max(np.abs(ref[col]))
        np.testing.assert_allclose(kept[col], ref[col], rtol=0, atol=TOL * scale, err_msg=col)
