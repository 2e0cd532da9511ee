"""GetFEM's own ALM model of the seed's bar: how bar2d_h0.05_alm_integral_newmark_u0p1e-14.csv
was made, and the one-step cross-check of docs/numerics.md ("Augmented Lagrangian").

Not part of the test suite and not a dependency of dyncontact: it needs GetFEM's Python
interface (Debian `python3-getfem` 5.4.2) and runs under the system Python:

    /usr/bin/python3 getfem_alm_bar2d.py trace OUT.csv [--t-end 4.5] [--perturb 1e-14]
    /usr/bin/python3 getfem_alm_bar2d.py one-step STATES.npz

The model is the reference's (the "alm/" section of tests/data/reference/README.md): P1 on
the h = 0.05 "regular simplices" mesh, plane strain (lambda = 1/2, mu = 1/4), rho = 1,
clamped at y = 1; GetFEM's integral contact brick with a rigid obstacle (option 1, non-
symmetric Alart-Curnier; option 2, the symmetric one, gives the same trace), lambda P1 on
Gamma_C, r = gamma0 / (h sqrt 2), gamma0 = 10, the obstacle the signed distance y;
IM_TRIANGLE(4) (3 Gauss points a contact facet); GetFEM's Newmark dispatcher (1/4, 1/2), dt
= h/20, a0 from M a0 + K u0 = 0; Newton to the absolute residual 1e-10. `--perturb e`
multiplies u0 by 1 + e.

`one-step` reads states of our run (keys x, node, comp: our mesh's node coordinates and each
free dof's node and component; U, V, A: u, v, a at step n in rows 2k and at step n + 1 in
rows 2k + 1; T: their times), loads each step-n state into GetFEM's Newmark variables, makes
one GetFEM step and prints max |u_GetFEM - u_ours| / max |u_ours| at step n + 1.
"""

import argparse

import numpy as np
import getfem as gf
import scipy.sparse as sp
import scipy.sparse.linalg as spl

H, GAMMA0 = 0.05, 10.0
DT = H / 20
MESH = "/work/shared/reference/meshes/bar2d_getfem_h0.05.msh"
GC, TOP = 101, 102


def build(perturb=0.0):
    """The model, its FEMs and the initial state set in GetFEM's Newmark variables."""
    gf.util_trace_level(0)
    mesh = gf.Mesh("import", "gmsh", MESH)
    pts, fb = mesh.pts(), mesh.outer_faces()

    def faces(y0):
        keep = [k for k in range(fb.shape[1])
                if np.all(np.abs(pts[1, mesh.pid_in_faces(fb[:, k:k + 1])] - y0) < 1e-12)]
        return fb[:, keep]

    mesh.set_region(GC, faces(0.0))
    mesh.set_region(TOP, faces(1.0))
    mfu = gf.MeshFem(mesh, 2)
    mfu.set_classical_fem(1)
    mfl = gf.MeshFem(mesh, 1)
    mfl.set_classical_fem(1)
    mim = gf.MeshIm(mesh, gf.Integ("IM_TRIANGLE(4)"))
    md = gf.Model("real")
    md.add_fem_variable("u", mfu)
    md.add_filtered_fem_variable("lambda", mfl, GC)
    md.add_initialized_data("lam", [0.5])
    md.add_initialized_data("mu", [0.25])
    md.add_isotropic_linearized_elasticity_brick(mim, "u", "lam", "mu")
    md.add_Dirichlet_condition_with_simplification("u", TOP)
    md.add_initialized_data("r", [GAMMA0 / (H * np.sqrt(2))])
    md.add_initialized_fem_data("obstacle", mfl, mfl.eval("y"))
    md.add_integral_contact_with_rigid_obstacle_brick(mim, "u", "lambda", "obstacle", "r", GC, 1)
    md.add_Newmark_scheme("u", 0.25, 0.5)
    md.add_mass_brick(mim, "Dot2_u")
    md.set_time_step(DT)

    def scipy_matrix(a):
        a.to_csc()
        (jc, ir), val = a.csc_ind(), a.csc_val()
        return sp.csc_matrix((val, ir, jc), shape=tuple(a.size()))

    m = scipy_matrix(gf.asm_mass_matrix(mim, mfu))
    mfd = gf.MeshFem(mesh, 1)
    mfd.set_classical_fem(0)
    k = scipy_matrix(gf.asm_linear_elasticity(mim, mfu, mfd, np.full(mfd.nbdof(), 0.5),
                                              np.full(mfd.nbdof(), 0.25)))
    u0 = mfu.eval("[0, 0.5 - y/2]").T.ravel() * (1 + perturb)
    free = np.setdiff1d(np.arange(mfu.nbdof()), mfu.basic_dof_on_region(TOP))
    a0 = np.zeros(mfu.nbdof())
    a0[free] = spl.spsolve(m[free][:, free].tocsc(), -(k @ u0)[free])
    md.set_variable("Previous_u", u0)
    md.set_variable("u", u0)
    md.set_variable("Previous_Dot_u", np.zeros(mfu.nbdof()))
    md.set_variable("Previous_Dot2_u", a0)
    return md, mfu, mfl, m, k


def trace(out, t_end, perturb):
    """Every step's probe values (u_n, v_n, p_n at (0.05, 0)), e_total and iterations."""
    md, mfu, mfl, m, k = build(perturb)
    dn = mfu.basic_dof_nodes()
    iy = [i for i in range(mfu.nbdof()) if i % 2 == 1 and abs(dn[0, i] - 0.05) < 1e-12
          and abs(dn[1, i]) < 1e-12][0]
    ln = mfl.basic_dof_nodes()
    lp = [i for i in range(mfl.nbdof())
          if abs(ln[0, i] - 0.05) < 1e-12 and abs(ln[1, i]) < 1e-12][0]
    ilp = list(np.sort(mfl.basic_dof_on_region(GC))).index(lp)
    rows = []

    def record(t, its):
        u, v = md.variable("Previous_u"), md.variable("Previous_Dot_u")
        rows.append((t, -u[iy], -v[iy], md.variable("lambda")[ilp],
                     0.5 * v @ (m @ v) + 0.5 * u @ (k @ u), its))

    record(0.0, 0)
    for n in range(int(round(t_end / DT))):
        its, _ = md.solve("max_res", 1e-10, "max_iter", 100)
        md.shift_variables_for_time_integration()
        record((n + 1) * DT, its)
    with open(out, "w") as f:
        f.write("t,u_n,v_n,p_n,e_total,newton_its\n")
        for t, un, vn, pn, e, its in rows:
            f.write(f"{t:.12e},{un:.12e},{vn:.12e},{pn:.12e},{e:.12e},{its}\n")


def one_step(states):
    """One GetFEM step from each of our step-n states, against our step n + 1."""
    md, mfu, mfl, _, _ = build()
    d = np.load(states)
    dn = mfu.basic_dof_nodes()
    x, node, comp = d["x"], d["node"], d["comp"]
    idx = np.array([[j for j in range(mfu.nbdof()) if abs(dn[0, j] - x[nd][0]) < 1e-12
                     and abs(dn[1, j] - x[nd][1]) < 1e-12][c] for nd, c in zip(node, comp)])

    def full(w):
        f = np.zeros(mfu.nbdof())
        f[idx] = w
        return f

    for k in range(len(d["T"]) // 2):
        md.set_variable("Previous_u", full(d["U"][2 * k]))
        md.set_variable("u", full(d["U"][2 * k]))
        md.set_variable("Previous_Dot_u", full(d["V"][2 * k]))
        md.set_variable("Previous_Dot2_u", full(d["A"][2 * k]))
        md.set_variable("lambda", np.zeros(len(mfl.basic_dof_on_region(GC))))
        md.solve("max_res", 1e-10, "max_iter", 100)
        u1 = d["U"][2 * k + 1]
        dev = np.abs(md.variable("u")[idx] - u1).max() / np.abs(u1).max()
        print(f"t = {d['T'][2 * k + 1]:.4f}: {dev:.1e}  lambda = {md.variable('lambda')}")


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("mode", choices=["trace", "one-step"])
    ap.add_argument("path")
    ap.add_argument("--t-end", type=float, default=4.5)
    ap.add_argument("--perturb", type=float, default=0.0)
    a = ap.parse_args()
    if a.mode == "trace":
        trace(a.path, a.t_end, a.perturb)
    else:
        one_step(a.path)
