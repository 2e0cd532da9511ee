#!/usr/bin/env python3
"""The seed scene (SPEC §2) in GetFEM, for the speed comparison of docs/performance.md
("Against the GetFEM script") and as an independent check of the reference traces.

Not part of dyncontact and never imported by it: it needs GetFEM's Python interface
(Debian `python3-getfem` 5.4.2) and runs under the system Python, not the project's venv:

    /usr/bin/python3 scripts/getfem_bar.py --h 0.05 --dt 0.0025 --t-end 15 --trace OUT.csv
    /usr/bin/python3 scripts/getfem_bar.py --h 0.0025 --dt 0.0005 --steps 50      # timing

The problem is the reference's (tests/data/reference/README.md): the strip [0, 0.1] x [0, 1]
as GetFEM's "regular simplices" mesh (two right triangles a square, diagonals alternating),
P1, plane strain, E = 2/3, nu = 1/3 (lambda = 1/2, mu = 1/4), rho = 1, clamped at y = 1,
Nitsche contact (SPEC §1) on y = 0 with the plane y = 0 (n = (0, -1), g = y, 0 on Gamma_C),
theta = 1, gamma0 = 10, gamma_N = gamma0 / h_T with h_T = sqrt(2) h, IM_TRIANGLE(4) (degree
4 on the triangles, 3 Gauss points a contact facet), u0 = (0, 1/2 - y/2), v0 = 0,
a0 from M a0 + B(u0) = 0, Newmark beta = 1/4, gamma = 1/2 (= hht alpha = 0).

GetFEM makes the mesh, the P1 space, the integration and every matrix and vector (its
elasticity and mass assemblies and, for the contact, a term in its weak-form language).
Two time loops (`--loop`):

- `scipy` (the default; "the GetFEM script" of docs/performance.md): the reference's
  layout (tests/data/reference/README.md): numpy and scipy run Newmark and the semi-smooth
  Newton on what GetFEM assembles (the contact term's residual and tangent at every
  iterate, on Gamma_C only), with sparse LU (scipy's splu), the factor reused while the
  Jacobian does not change (see `ScipyLoop`).
- `model`: everything in GetFEM's model: its elasticity and mass bricks, its Newmark scheme
  (the time dispatcher: the balance at t_{n+1}), the contact as a nonlinear term and its
  Newton (`Model.solve`, full steps), which assembles the tangent and factorizes it at
  every iteration with `--lsolver mumps` (sequential MUMPS, LU since the model is not
  flagged symmetric; what GetFEM picks by itself when it has MUMPS). `--lsolver superlu`
  is GetFEM's other direct solver, but in Debian's 5.4.2 build it crashes (segmentation
  fault in the first solve).

Both reproduce the reference trace bar2d_h0.05_hht_a0.csv (h = 0.05, dt = 0.0025, T = 15)
to its printed digits in u_n (1.4e-11) and the energies (6e-13), and to 1e-9 in v_n and
p_n (tests/test_getfem_compare.py checks the scipy loop to T = 15 and the model loop to
t = 3). The contact term (`--contact spec`, the default) is SPEC §1's frictionless one:

    -(theta/gamma_N) sigma_n(u) sigma_n(v) + (1/gamma_N) [P_1(u) + gamma_N g]_- P_theta(v).

`--contact brick` (with `--loop model`) uses GetFEM's Nitsche brick instead
(`add_Nitsche_contact_with_rigid_obstacle_brick`, friction coefficient 0, gamma0 scaled so
that its gamma0 / element_size is the same gamma_N). That brick's symmetric term is
-(theta/gamma) (sigma(u) n).(sigma(v) n), the whole traction and not only its normal part,
so its problem differs from SPEC's by the consistent term (theta/gamma_N) sigma_t(u)
sigma_t(v), present in flight too: at h = 0.05 its u_n differs from the reference by 1.4e-3
before the first impact and by 4e-2 over T = 15 (a different discretization, not round-off;
the same cost a step).

Output: one JSON line on stdout with dofs (free dofs, the count dyncontact reports), steps,
setup_s, loop_s and loop_cpu_s (the time loop only: wall and CPU time of the process),
ms_per_step (CPU), newton_its, factorizations (in the loop); `--trace FILE` also writes the reference's columns
(t,u_n,v_n,p_n,sigma_n,e_kin,e_el,e_contact,e_total,newton_its) every `--every` steps (the
trace's own cost is inside the loop then: time without `--trace`). Peak memory: run it under
`/usr/bin/time -v`.
"""

import argparse
import json
import math
import sys
import time

import numpy as np

LAM, MU, RHO = 0.5, 0.25, 1.0
WIDTH, LENGTH = 0.1, 1.0
THETA, GAMMA0 = 1.0, 10.0
PROBE = (0.05, 0.0)
GC, TOP = 101, 102


def _sigma(grad):
    """sigma(w) in GetFEM's weak-form language for a gradient expression of w."""
    return f"({LAM}*Trace({grad})*Id(2) + {MU}*({grad} + ({grad})'))"


def _scipy(a):
    """A GetFEM sparse matrix as scipy CSC."""
    import scipy.sparse as sp

    a.to_csc()
    (jc, ir), val = a.csc_ind(), a.csc_val()
    return sp.csc_matrix((val, ir, jc), shape=tuple(a.size()))


def build(h, dt, contact="spec", lsolver="mumps"):
    """The mesh, FEM, model (with the initial state in its Newmark variables) and what the
    trace needs."""
    import getfem as gf
    import scipy.sparse.linalg as spl

    gf.util_trace_level(0)
    nx, ny = round(WIDTH / h), round(LENGTH / h)
    mesh = gf.Mesh("regular simplices", np.linspace(0.0, WIDTH, nx + 1),
                   np.linspace(0.0, LENGTH, ny + 1))
    mesh.set_region(GC, mesh.outer_faces_with_direction([0.0, -1.0], 0.01))
    mesh.set_region(TOP, mesh.outer_faces_with_direction([0.0, 1.0], 0.01))
    mfu = gf.MeshFem(mesh, 2)
    mfu.set_classical_fem(1)
    mim = gf.MeshIm(mesh, gf.Integ("IM_TRIANGLE(4)"))
    gamma_n = GAMMA0 / (math.sqrt(2.0) * h)

    sn_u = f"(({_sigma('Grad_u')}*Normal).Normal)"
    sn_v = f"(({_sigma('Grad_Test_u')}*Normal).Normal)"
    # Normal is Gamma_C's outward normal, (0, -1): the obstacle's n, so u.Normal = u_n
    gap = "X(2)"            # g = (obstacle_point - x).n with n = (0, -1): y
    p1 = f"({THETA}*{sn_u} - {gamma_n!r}*u.Normal + {gamma_n!r}*{gap})"
    contact_expr = (f"-({THETA}/{gamma_n!r})*{sn_u}*{sn_v} - (1/{gamma_n!r})"
                    f"*neg_part({p1})*({THETA}*{sn_v} - {gamma_n!r}*Test_u.Normal)")
    if contact == "brick":
        # GetFEM's brick takes gamma = gamma0 / element_size: give it the gamma0 that makes
        # this gamma_N (element_size is the same on every contact element of this mesh)
        sizes = gf.asm("generic", mim, 0, "element_size", GC)
        length = gf.asm("generic", mim, 0, "1", GC)
        brick_gamma0 = gamma_n * float(sizes) / float(length)
        mfo = gf.MeshFem(mesh, 1)
        mfo.set_classical_fem(1)
    elif contact != "spec":
        raise ValueError(f"unknown --contact {contact!r}")

    def static_part(md):
        """Elasticity, the clamped top and the contact term: B(u) of SPEC §1."""
        md.add_fem_variable("u", mfu)
        md.add_initialized_data("lambda", [LAM])
        md.add_initialized_data("mu", [MU])
        md.add_isotropic_linearized_elasticity_brick(mim, "u", "lambda", "mu")
        md.add_Dirichlet_condition_with_simplification("u", TOP)
        if contact == "spec":
            md.add_nonlinear_term(mim, contact_expr, GC)
        else:
            md.add_initialized_data("gamma0", [brick_gamma0])
            md.add_initialized_fem_data("obstacle", mfo, mfo.eval("y"))
            md.add_Nitsche_contact_with_rigid_obstacle_brick(
                mim, "u", md.Neumann_term("u", GC), "obstacle", "gamma0", GC, THETA)

    nd = mfu.nbdof()
    m = _scipy(gf.asm_mass_matrix(mim, mfu)) * RHO
    mfd = gf.MeshFem(mesh, 1)
    mfd.set_classical_fem(0)
    k = _scipy(gf.asm_linear_elasticity(mim, mfu, mfd, np.full(mfd.nbdof(), LAM),
                                        np.full(mfd.nbdof(), MU)))
    u0 = mfu.eval("[0, 0.5 - y/2]").T.ravel()
    top = mfu.basic_dof_on_region(TOP)
    free = np.setdiff1d(np.arange(nd), top)
    # a0 from M a0 + B(u0) = 0 on the free dofs, B(u0) the residual of the static model
    ms = gf.Model("real")
    static_part(ms)
    ms.set_variable("u", u0)
    ms.assembly("build_rhs")
    b_u0 = -np.asarray(ms.rhs())[:nd]
    a0 = np.zeros(nd)
    a0[free] = spl.splu(m[free][:, free].tocsc(), permc_spec="MMD_AT_PLUS_A").solve(
        -b_u0[free])
    del ms

    # the time model: the static part, Newmark (1/4, 1/2) on u and the mass on Dot2_u
    md = gf.Model("real")
    static_part(md)
    md.add_Newmark_scheme("u", 0.25, 0.5)
    md.add_initialized_data("rho", [RHO])
    md.add_mass_brick(mim, "Dot2_u", "rho")
    md.set_time_step(dt)
    md.set_variable("Previous_u", u0)
    md.set_variable("u", u0)
    md.set_variable("Previous_Dot_u", np.zeros(nd))
    md.set_variable("Previous_Dot2_u", a0)

    probe = _probe(mesh, mfu, h)
    return {"gf": gf, "md": md, "mfu": mfu, "mim": mim, "m": m, "k": k, "free": free,
            "gamma_n": gamma_n, "probe": probe, "sn_u": sn_u, "p1": p1,
            "lsolver": lsolver, "contact_expr": contact_expr, "u0": u0, "a0": a0}


def _probe(mesh, mfu, h):
    """The probe's data: the y dofs of the contact facet(s) holding it with their weights
    (u_n = -u_y is linear on a facet), and for each of those facets its element's nodes and
    shape-function gradients (sigma_n is constant on a P1 element)."""
    dn = mfu.basic_dof_nodes()
    x0 = PROBE[0]
    k = math.floor(x0 / h + 1e-9)
    xs = [k * h] if abs(x0 - k * h) < 1e-9 * h else [k * h, (k + 1) * h]
    facets = [(k - 1, k), (k, k + 1)] if len(xs) == 1 else [(k, k + 1)]
    nx = round(WIDTH / h)
    facets = [f for f in facets if 0 <= f[0] and f[1] <= nx]

    def ydof(x):
        return int([i for i in range(1, mfu.nbdof(), 2)
                    if abs(dn[0, i] - x) < 1e-12 and abs(dn[1, i]) < 1e-12][0])

    if len(xs) == 1:
        weights = [(ydof(xs[0]), 1.0)]
    else:
        s = (x0 - xs[0]) / h
        weights = [(ydof(xs[0]), 1.0 - s), (ydof(xs[1]), s)]
    elems = []
    pts = mesh.pts()
    for a, b in facets:
        ia = int(np.argmin(np.hypot(pts[0] - a * h, pts[1])))
        ib = int(np.argmin(np.hypot(pts[0] - b * h, pts[1])))
        # the one triangle holding both ends of the facet (cvid_from_pid lists the
        # triangles that hold a given point)
        both = (set(np.atleast_1d(mesh.cvid_from_pid([ia], True)).tolist())
                & set(np.atleast_1d(mesh.cvid_from_pid([ib], True)).tolist()))
        c = int(min(both))
        pid = mesh.pid_from_cvid(c)[0]
        xy = pts[:, pid].T                        # 3 x 2
        grads = np.linalg.inv(np.c_[np.ones(3), xy])[1:, :]   # 2 x 3: d phi_j / d x_i
        dofs = []
        for p in pid:
            j = [i for i in range(0, mfu.nbdof(), 2)
                 if abs(dn[0, i] - pts[0, p]) < 1e-12 and abs(dn[1, i] - pts[1, p]) < 1e-12][0]
            dofs.append((j, j + 1))
        elems.append((np.array(dofs), grads, [ia, ib]))
    return {"weights": weights, "elems": elems}


def probe_values(st, u):
    """(u_n, p_n, sigma_n) at the probe: u_n = -u_y interpolated on the facet, sigma_n and
    p_n = [P_1(u)]_- of each facet holding it, their mean where the probe is a node."""
    pr = st["probe"]
    un = -sum(w * u[d] for d, w in pr["weights"])
    sig, pn = [], []
    for dofs, grads, _ in pr["elems"]:
        uu = u[dofs]                              # 3 x 2 nodal values
        g = uu.T @ grads.T                        # grad u: g[i, j] = d u_i / d x_j
        eps = 0.5 * (g + g.T)
        s = LAM * np.trace(eps) * np.eye(2) + 2 * MU * eps
        n = np.array([0.0, -1.0])
        sn = n @ s @ n
        sig.append(sn)
        pn.append(min(THETA * sn - st["gamma_n"] * un, 0.0))   # g = 0 on Gamma_C
    return un, float(np.mean(pn)), float(np.mean(sig))


def energies(st, u, v):
    """(e_kin, e_el, e_contact) of SPEC §1."""
    gf, gn = st["gf"], st["gamma_n"]
    e_kin = 0.5 * v @ (st["m"] @ v)
    e_el = 0.5 * u @ (st["k"] @ u)
    e_c = gf.asm("generic", st["mim"], 0,
                 f"(1/(2*{gn!r}))*(sqr(neg_part({st['p1']})) - {THETA}*sqr({st['sn_u']}))",
                 GC, "u", 0, st["mfu"], u)
    return e_kin, e_el, float(e_c)


class ScipyLoop:
    """The reference's layout of the time loop: GetFEM assembles (M, K once; the contact
    term's residual and tangent at every Newton iterate, on Gamma_C only), numpy and scipy
    do the rest: Newmark (1/4, 1/2), semi-smooth Newton on the free dofs from u^n, stopped
    at ||R|| <= tol x (||M a|| + ||K u|| + ||r_c||). The Jacobian is factorized by sparse
    LU (scipy's splu, SuperLU with the minimum-degree ordering of A^T + A: the fastest of
    its orderings on this matrix) only when it changes: the factors are kept by the bytes
    of the assembled contact tangent, which depends on u only through the active
    quadrature points (at most ``keep`` factors, the oldest dropped). Contact-free steps
    therefore reuse one factor and cost one solve. The first factor (at u0) is made with
    the set-up."""

    keep = 4

    def __init__(self, st, dt, beta=0.25, gamma=0.5):
        self.st, self.dt, self.beta, self.gamma = st, dt, beta, gamma
        f = st["free"]
        self.f = f
        self.m, self.k = st["m"], st["k"]
        self.mff = st["m"][f][:, f].tocsc()
        self.kff = st["k"][f][:, f].tocsc()
        self.u, self.v, self.a = st["u0"].copy(), np.zeros_like(st["u0"]), st["a0"].copy()
        self.factors = {}           # bytes of the contact tangent -> splu factor
        self.factorizations = 0
        # the Jacobian at u0 factorized with the set-up, as dyncontact factorizes J0
        # before its first step
        self._u = self.u
        self._solver(1.0 / (beta * dt * dt))

    def _solver(self, c):
        """The factor of the Jacobian at the current iterate (J_c assembled here)."""
        import scipy.sparse.linalg as spl

        jc = self._contact(self._u, 2)[self.f][:, self.f].tocsr()
        jc.sum_duplicates()
        jc.sort_indices()
        key = jc.indptr.tobytes() + jc.indices.tobytes() + jc.data.tobytes()
        lu = self.factors.pop(key, None)
        if lu is None:
            jac = (c * self.mff + self.kff + jc).tocsc()
            lu = spl.splu(jac, permc_spec="MMD_AT_PLUS_A")
            self.factorizations += 1
            while len(self.factors) >= self.keep:
                self.factors.pop(next(iter(self.factors)))
        self.factors[key] = lu      # most recently used last
        return lu

    def _contact(self, u, order):
        gf, st = self.st["gf"], self.st
        out = gf.asm("generic", st["mim"], order, st["contact_expr"], GC, "u", 1,
                     st["mfu"], u)
        return np.asarray(out) if order == 1 else _scipy(out)

    def step(self, tol=1e-10, maxit=50):
        """One step; returns the Newton iterations."""
        dt, b, g, f = self.dt, self.beta, self.gamma, self.f
        c = 1.0 / (b * dt * dt)
        pred = self.u + dt * self.v + dt * dt * (0.5 - b) * self.a
        u = self.u.copy()
        for it in range(1, maxit + 1):
            a = c * (u - pred)
            ma, ku, rc = self.m @ a, self.k @ u, self._contact(u, 1)
            r = (ma + ku + rc)[f]
            scale = (np.linalg.norm(ma[f]) + np.linalg.norm(ku[f]) + np.linalg.norm(rc[f]))
            if it > 1 and np.linalg.norm(r) <= tol * scale:
                it -= 1
                break
            self._u = u
            u[f] -= self._solver(c).solve(r)
        else:
            raise RuntimeError("Newton did not converge")
        a = c * (u - pred)
        self.v = self.v + dt * ((1 - g) * self.a + g * a)
        self.u, self.a = u, a
        return it


def run(h, dt, steps, trace=None, every=1, contact="spec", lsolver="mumps",
        max_res=1e-10, loop="scipy"):
    """Set up, then ``steps`` steps; returns the timing record (and writes the trace).
    ``loop``: 'model' (GetFEM's Model.solve) or 'scipy' (:class:`ScipyLoop`)."""
    if loop == "scipy" and contact != "spec":
        raise ValueError("--loop scipy assembles the contact term of --contact spec")
    t0w, t0c = time.perf_counter(), time.process_time()
    st = build(h, dt, contact, lsolver)
    md = st["md"]
    sl = ScipyLoop(st, dt) if loop == "scipy" else None
    setup_s = time.perf_counter() - t0w
    rows = []

    def record(n, its):
        if sl is None:
            u, v = md.variable("Previous_u"), md.variable("Previous_Dot_u")
        else:
            u, v = sl.u, sl.v
        un, pn, sn = probe_values(st, u)
        vn = -sum(w * v[d] for d, w in st["probe"]["weights"])
        ek, ee, ec = energies(st, u, v)
        rows.append((n * dt, un, vn, pn, sn, ek, ee, ec, ek + ee, its))

    if trace:
        record(0, 0)
    its_total = 0
    t1w, t1c = time.perf_counter(), time.process_time()
    for n in range(1, steps + 1):
        if sl is None:
            its = md.solve("max_res", max_res, "max_iter", 50, "lsolver", lsolver,
                           "lsearch", "simplest")[0]
            md.shift_variables_for_time_integration()
        else:
            its = sl.step(max_res)
        its_total += its
        if trace and n % every == 0:
            record(n, its)
    loop_s, loop_cpu = time.perf_counter() - t1w, time.process_time() - t1c
    if trace:
        with open(trace, "w", encoding="utf-8") as f:
            f.write("t,u_n,v_n,p_n,sigma_n,e_kin,e_el,e_contact,e_total,newton_its\n")
            for r in rows:
                f.write(",".join(f"{x:.12e}" for x in r[:-1]) + f",{r[-1]}\n")
    return {"h": h, "dt": dt, "dofs": int(len(st["free"])), "steps": steps,
            "loop": loop, "contact": contact,
            "lsolver": lsolver if loop == "model" else "scipy splu",
            "setup_s": setup_s, "setup_cpu_s": t1c - t0c, "loop_s": loop_s,
            "loop_cpu_s": loop_cpu, "ms_per_step": 1e3 * loop_cpu / max(1, steps),
            "ms_per_step_wall": 1e3 * loop_s / max(1, steps), "newton_its": its_total,
            "factorizations": (sl.factorizations - 1) if sl is not None else its_total}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--h", type=float, default=0.05, help="mesh size (default 0.05)")
    ap.add_argument("--dt", type=float, default=None, help="time step (default h/20)")
    ap.add_argument("--steps", type=int, default=None, help="number of steps")
    ap.add_argument("--t-end", type=float, default=None, help="or the final time")
    ap.add_argument("--trace", default=None, help="write the trace to this CSV")
    ap.add_argument("--every", type=int, default=1, help="trace every k-th step")
    ap.add_argument("--contact", choices=("spec", "brick"), default="spec")
    ap.add_argument("--loop", choices=("scipy", "model"), default="scipy",
                    help="scipy: the reference's loop (default); model: GetFEM's "
                    "Model.solve")
    ap.add_argument("--lsolver", choices=("mumps", "superlu"), default="mumps",
                    help="GetFEM's sparse direct solver (default mumps, GetFEM's own "
                    "choice; superlu crashes in Debian's 5.4.2 build)")
    a = ap.parse_args(argv)
    dt = a.dt if a.dt is not None else a.h / 20
    if a.steps is None:
        steps = round((a.t_end if a.t_end is not None else 15.0) / dt)
    else:
        steps = a.steps
    rec = run(a.h, dt, steps, a.trace, a.every, a.contact, a.lsolver, loop=a.loop)
    print(json.dumps(rec), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
