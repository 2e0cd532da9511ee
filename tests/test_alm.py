"""The augmented Lagrangian (`&contact method = 'alm'`, fem/alm_contact.f90 and
schemes/alm_newton.f90) against truth: GetFEM's own ALM run of the seed's bar, the Nitsche
run before the first contact, the 1D closed form with the redistributed mass, the nodal
complementarity at the probe, and every implicit scheme with every mass.

The finite-difference check of the (u, lambda) derivative is the Fortran unit program
tests/fortran/test_alm_contact.f90 (test_fortran_units.py runs it).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import dyncontact
from conftest import run_as_designed, sampled_steps, stepper_as_designed
from dyncontact import Scene
from dyncontact import exact1d as ex

ROOT = Path(__file__).resolve().parents[1]
REF = Path(__file__).parent / "data" / "reference" / "alm" / "bar2d_h0.05_alm_integral_newmark.csv"
#: GetFEM's same model with u0 x (1 + 1e-14), t <= 4.5 (tests/data/reference/README.md).
GETFEM_PERTURBED = REF.with_name("bar2d_h0.05_alm_integral_newmark_u0p1e-14.csv")
SCENE_1D = ROOT / "scripts" / "scenes" / "bar1d.nml"

#: Agreement with GetFEM's ALM trace: u_n, v_n, and p_n (relative where |p_n| > 1).
GETFEM_TOL = 1e-8
#: The window of that agreement: the first contact phase at the probe (contact at
#: t = 1.185, release at 1.205, contact again at 1.215). Past it no second implementation
#: can agree to 1e-8, GetFEM included: from the first contact step on Gamma_C (t = 1.15)
#: the consistent-mass multipliers turn a 1e-13 difference of state into 1e-10 in p_n,
#: and the chattering amplifies it about 10^4-fold every 0.2 time units. GetFEM's own model
#: with u0 changed by 1e-14 parts from the reference trace as our run does
#: (test_getfem_parts_from_its_own_trace_as_we_part_from_it), while one step of GetFEM's
#: from our state equals our step to 4e-16 (docs/numerics.md, "Augmented Lagrangian").
T_AGREE = 1.28
#: Before the first contact ALM is plain elastodynamics: the Nitsche theta = 0 run (whose
#: K_theta is K) does the same operations.
SAME_FLIGHT_TOL = 1e-13


def seed_alm(**keys) -> Scene:
    """The seed scene with the ALM settings of GetFEM's run (newmark 1/4 1/2, dt = h/20,
    3-point face rule, integral multipliers, consistent mass), keys as group__key."""
    s = Scene()
    base = {"contact.method": "alm", "contact.multiplier": "integral",
            "contact.quadrature": "gauss", "contact.quad_points": 3,
            "scheme.name": "newmark", "scheme.beta": 0.25, "scheme.gamma": 0.5}
    base.update({k.replace("__", "."): v for k, v in keys.items()})
    for k, v in base.items():
        s.set(k, v)
    return s


def run(s: Scene, tmp_path: Path, name: str):
    return run_as_designed(s, tmp_path / name)


def deviation(ours: np.ndarray, ref: np.ndarray, relative_above: float | None = None) -> float:
    d = np.abs(ours - ref)
    if relative_above is not None:
        big = np.abs(ref) > relative_above
        d[big] = d[big] / np.abs(ref[big])
    return float(d.max())


def test_alm_matches_getfem_over_the_first_contact(tmp_path):
    ref = np.genfromtxt(REF, delimiter=",", names=True)
    res = run(seed_alm(scheme__t_end=1.5), tmp_path, "alm")
    assert res.status == "ok"
    tr = res.trace
    m = ref["t"] <= T_AGREE + 1e-9
    n = int(m.sum())
    assert np.allclose(tr["t"][:n], ref["t"][:n], atol=1e-12)
    # the window holds the first contact, a release and a second contact at the probe
    assert (ref["p_n"][:n] < -1).sum() > 3 and ref["t"][:n][ref["p_n"][:n] < -0.1][0] < 1.19
    assert deviation(tr["u_n"][:n], ref["u_n"][:n]) <= GETFEM_TOL
    assert deviation(tr["v_n"][:n], ref["v_n"][:n]) <= GETFEM_TOL
    assert deviation(tr["p_n"][:n], ref["p_n"][:n], relative_above=1.0) <= GETFEM_TOL
    assert deviation(tr["e_total"][:n], ref["e_total"][:n]) <= GETFEM_TOL * ref["e_total"][0]
    # the same Newton iterations a step as GetFEM's Newton
    assert np.array_equal(tr["newton_its"][1:n], ref["newton_its"][1:n])


def parting_times(tr: dict, other: np.ndarray, levels=(1e-10, 1e-8, 1e-6)) -> list[float]:
    """The first time at which u_n, v_n or p_n (relative where |p_n| > 1) of the traces
    tr and other differ by more than each level (inf: never), over tr's rows."""
    n = len(tr["t"])
    d = np.maximum(np.abs(tr["u_n"] - other["u_n"][:n]), np.abs(tr["v_n"] - other["v_n"][:n]))
    dp = np.abs(tr["p_n"] - other["p_n"][:n])
    big = np.abs(other["p_n"][:n]) > 1
    dp[big] /= np.abs(other["p_n"][:n][big])
    d = np.maximum(d, dp)
    return [float(tr["t"][np.argmax(d > lv)]) if (d > lv).any() else np.inf for lv in levels]


def test_getfem_parts_from_its_own_trace_as_we_part_from_it(tmp_path):
    """Why the GetFEM comparison has a window. GetFEM's own model run again with u0 changed
    by 1e-14 (relative; made by tests/data/reference/alm/getfem_alm_bar2d.py) parts from the
    reference trace at the times our run parts from it, and our run parts from itself
    under the same change in the same way: past 1e-10 in the first contact steps (the
    first on Gamma_C is t = 1.15; observed 1.15-1.22), past 1e-8 at t = 1.29-1.35,
    past 1e-6 by t = 1.7, and at t = 2 apart by 5e-5 to 6e-4 in u_n. The sensitivity is the
    model's, not an implementation's; a 1e-8 agreement to t = 4.5 needs the same
    floating-point operations."""
    ref = np.genfromtxt(REF, delimiter=",", names=True)
    gf_perturbed = np.genfromtxt(GETFEM_PERTURBED, delimiter=",", names=True)
    a = run(seed_alm(scheme__t_end=2.0), tmp_path, "a").trace
    b = run(seed_alm(scheme__t_end=2.0, initial__amplitude=0.5 * (1 + 1e-14)), tmp_path, "b").trace
    n = len(a["t"])
    gf = {c: gf_perturbed[c][:n] for c in ("t", "u_n", "v_n", "p_n")}
    assert np.allclose(gf["t"], a["t"], atol=1e-12)
    pairs = {"GetFEM perturbed vs GetFEM": (gf, ref), "ours vs GetFEM": (a, ref),
             "ours perturbed vs ours": (b, a)}
    for name, (x, y) in pairs.items():
        t10, t8, t6 = parting_times(x, y)
        assert 1.149 < t10 < 1.23, (name, t10)
        assert 1.28 < t8 < 1.36, (name, t8)
        assert 1.3 < t6 < 1.7, (name, t6)
        late = x["t"] > 1.95
        assert np.abs(x["u_n"][late] - y["u_n"][:n][late]).max() > 1e-5, name
        assert np.abs(x["v_n"][late] - y["v_n"][:n][late]).max() > 1e-4, name


def test_alm_newton_tolerance_leaves_the_trace_unchanged(tmp_path):
    """The semi-smooth Newton's last iterate solves its active set's linear equations to
    round-off, whatever the tolerance that stopped it: newton_tol 1e-8 and 1e-12 give the
    same trace through the whole first contact phase (observed: bit for bit, and the same
    iterations, to t = 4.5). So two runs with different tolerances agreeing says nothing
    of how the trajectory amplifies round-off: GetFEM's two tolerances agree the same way
    to t = 4.5 (tested above: a 1e-14 change parts it by t = 1.3)."""
    tr = {tol: run(seed_alm(scheme__t_end=2.3, scheme__newton_tol=tol), tmp_path,
                   f"tol{tol:g}").trace for tol in (1e-8, 1e-12)}
    assert tr[1e-8]["active"].max() > 0
    for col in ("u_n", "v_n", "p_n", "e_total"):
        scale = max(1.0, np.abs(tr[1e-12][col]).max())
        assert deviation(tr[1e-8][col], tr[1e-12][col]) <= 1e-14 * scale


def test_alm_before_contact_equals_nitsche_theta0(tmp_path):
    t_end = 1.1    # contact at the probe starts at t = 1.185, nowhere before 1.15
    alm = run(seed_alm(scheme__t_end=t_end), tmp_path, "alm").trace
    nit = run(seed_alm(scheme__t_end=t_end, contact__method="nitsche", contact__theta=0),
              tmp_path, "nitsche").trace
    assert alm["active"].max() == 0 and nit["active"].max() == 0
    for col in ("u_n", "v_n", "e_kin", "e_el", "e_total"):
        assert deviation(alm[col], nit[col]) <= SAME_FLIGHT_TOL * max(1.0, np.abs(nit[col]).max())
    assert np.all(alm["p_n"] == 0.0) and np.all(alm["e_contact"] == 0.0)


@pytest.mark.parametrize("multiplier", ["integral", "nodal"])
def test_alm_1d_redistributed_mass_against_the_closed_form(multiplier, tmp_path):
    h = 0.01
    s = Scene.read(SCENE_1D)
    for k, v in {"mesh.h": h, "scheme.name": "newmark", "scheme.beta": 0.25,
                 "scheme.gamma": 0.5, "scheme.dt": h / 20, "scheme.t_end": 6.0,
                 "scheme.mass": "redistributed", "contact.method": "alm",
                 "contact.multiplier": multiplier}.items():
        s.set(k, v)
    res = run(s, tmp_path, "run")
    assert res.status == "ok"
    tr = res.trace
    t = tr["t"]
    # observed 0.0165 (the Nitsche runs' 0.017)
    assert np.abs(tr["u_n"] - ex.u_n(t)).max() < 0.03
    # the first contact phase: observed mean -0.5003, std 0.029 (consistent mass: std 3.3);
    # the second, after the velocity jumps have crossed the bar twice, is rougher
    m = (t > 1.2) & (t < 1.8)
    assert abs(tr["p_n"][m].mean() + 0.5) < 0.01
    assert tr["p_n"][m].std() < 0.05
    m = (t > 4.2) & (t < 4.8)
    assert abs(tr["p_n"][m].mean() + 0.5) < 0.05
    # the contact node never enters the obstacle, and pushes only
    assert tr["u_n"].max() <= 1e-14 and tr["p_n"].max() <= 1e-14
    # energy: the massless contact node snaps to its quasi-static position in the first
    # step (1.0 % of e(0) at h = 0.01, as with Nitsche); after that it changes by less than
    # 1e-5 over two periods (observed 8e-6): no energy goes into the multiplier
    e = tr["e_total"] / 0.125
    assert abs(e[0] - 1) < 1e-12 and 0.985 < e[1] < 1.0
    assert np.abs(e[1:] - e[1]).max() < 1e-5


def test_alm_nodal_complementarity_at_the_probe_node(tmp_path):
    """h = 0.05: the probe (0.05, 0) is a contact node, where 'nodal' holds u_n <= 0,
    p_n <= 0 and p_n u_n = 0 exactly (to round-off), through the chattering."""
    for mass in ("consistent", "redistributed"):
        tr = run(seed_alm(contact__multiplier="nodal", scheme__mass=mass, scheme__t_end=3.0),
                 tmp_path, mass).trace
        assert (tr["p_n"] < -0.1).sum() > 10    # contact rows (chattering with consistent mass)
        assert tr["u_n"].max() <= 1e-14
        assert tr["p_n"].max() <= 1e-14
        assert np.abs(tr["p_n"] * tr["u_n"]).max() <= 1e-14


SCHEMES = {"newmark": {"scheme.name": "newmark"},
           "hht-0.1": {"scheme.name": "hht", "scheme.alpha": -0.1},
           "theta": {"scheme.name": "theta", "scheme.theta": 0.5},
           "galpha0.8": {"scheme.name": "galpha", "scheme.rho_inf": 0.8}}


@pytest.mark.parametrize("mass", ["consistent", "lumped", "redistributed"])
@pytest.mark.parametrize("scheme", list(SCHEMES))
@pytest.mark.parametrize("multiplier", ["integral", "nodal"])
def test_alm_every_implicit_scheme_and_mass_runs_through_an_impact(multiplier, scheme, mass,
                                                                    tmp_path):
    s = seed_alm(contact__multiplier=multiplier, contact__quadrature="exact",
                 scheme__mass=mass, scheme__t_end=2.5, mesh__h=0.1, scheme__dt=0.005)
    for k, v in SCHEMES[scheme].items():
        s.set(k, v)
    res = run(s, tmp_path, "run")
    assert res.status == "ok"
    tr = res.trace
    assert tr["active"].max() > 0 and tr["p_n"].min() < -0.1
    assert np.all(tr["e_contact"] == 0.0)
    # the penetration stays small: below 2 % of the initial lift
    assert tr["u_n"].max() < 0.01
    assert res.summary["factorizations"] <= 2


@pytest.mark.parametrize("scheme", ["newmark", "hht-0.1"])
def test_alm_carried_b_is_k_u_minus_n_lambda_and_balances(scheme, tmp_path):
    """The B(u) a step carries into the next is K u - N lambda: its contact part lives on
    the contact nodes' normal dofs ('nodal': -N lambda = lambda_i there, n = (0, -1)), is 0
    out of contact, equals the trace's p_n times the probe node's share of Gamma_C (h) at
    the probe node, and closes the scheme's balance equation with the state."""
    from dyncontact.core import read_trace
    h, dt = 0.05, 0.0025
    s = seed_alm(contact__multiplier="nodal", scheme__t_end=1.5, material__gravity=[0.0, -0.2])
    for k, v in SCHEMES[scheme].items():
        s.set(k, v)
    am = 0.0
    af = 0.1 if scheme == "hht-0.1" else 0.0
    beta = (1 + af) ** 2 / 4
    n_steps = int(round(1.5 / dt))
    samples = set(range(455, n_steps)) | {10, 200}
    with stepper_as_designed(s, tmp_path / "run") as run:
        M, K = run.matrix("M"), run.matrix("K")
        states = sampled_steps(run, n_steps, samples)
    trace = read_trace(tmp_path / "run")
    seen_contact = 0
    for step, (s0, s1) in states.items():
        row = step + 1
        ku = K @ s1["u"]
        c = s1["bu"] - ku
        c[np.abs(c) <= 1e-12 * np.abs(ku).max()] = 0.0     # round-off of the product
        nz = np.flatnonzero(c)
        assert len(nz) <= 3 and np.all(c <= 0.0), step
        if trace["active"][row] == 0:
            assert len(nz) == 0, step
        if trace["p_n"][row] < -1e-6:
            seen_contact += 1
            assert np.abs(c[nz] - trace["p_n"][row] * h).min() <= 1e-12 * abs(trace["p_n"][row]), step
        bal = ((1 - am) * M @ s1["a"] + am * M @ s0["a"] + (1 - af) * s1["bu"] + af * s0["bu"]
               - s1["load"])
        scale = (np.abs(M @ s1["a"]).max() + np.abs(s1["bu"]).max() + np.abs(s0["bu"]).max()
                 + np.abs(M @ s1["u"]).max() / (beta * dt * dt))
        assert np.abs(bal).max() <= 1e-12 * scale, (step, np.abs(bal).max() / scale)
    assert seen_contact >= 3


def test_alm_energy_change_is_the_work_of_the_multipliers(tmp_path):
    """Where the energy goes: with the trapezoidal rule (newmark 1/4 1/2, no load),
    E = 1/2 v.M v + 1/2 u.K u changes over a step by exactly -1/2 (C + C').(u' - u), the work
    of the mean contact force C = -N lambda (the contact part of the carried B). Summed over
    the steps through the first impact it is the whole change of E (consistent mass: the
    chattering multipliers feed energy in)."""
    s = seed_alm(scheme__t_end=1.6)
    first, last = 440, 640
    work = 0.0
    with stepper_as_designed(s, tmp_path / "run") as run:
        M, K = run.matrix("M"), run.matrix("K")
        run.advance(first)
        s0 = run.state()
        e_first = 0.5 * s0["v"] @ M @ s0["v"] + 0.5 * s0["u"] @ K @ s0["u"]
        for _ in range(last - first):
            run.advance(1)
            s1 = run.state()
            e0 = 0.5 * s0["v"] @ M @ s0["v"] + 0.5 * s0["u"] @ K @ s0["u"]
            e1 = 0.5 * s1["v"] @ M @ s1["v"] + 0.5 * s1["u"] @ K @ s1["u"]
            c0 = s0["bu"] - K @ s0["u"]
            c1 = s1["bu"] - K @ s1["u"]
            w = -0.5 * (c0 + c1) @ (s1["u"] - s0["u"])
            assert abs((e1 - e0) - w) <= 1e-12 * e0, (s1["t"], e1 - e0, w)
            work += w
            s0 = s1
        e_last = e1
    assert abs(e_last - e_first) > 1e-4 * e_first       # the impact changed E ...
    assert abs((e_last - e_first) - work) <= 1e-11 * e_first   # ... by the multipliers' work


# ------------------------------------------------------------------ 3D (triangle facets)

def box_alm(**keys) -> Scene:
    """The 3D box (&mesh dim = 3: [0, 0.1]^2 x [0, 1], h = 0.05, P1 tetrahedra, contact on
    the bottom triangles, probe the centre node of the bottom face) with ALM and Newmark
    1/4 1/2, keys as group__key."""
    s = Scene()
    s.set("mesh.dim", 3)
    base = {"contact.method": "alm", "contact.multiplier": "integral",
            "scheme.name": "newmark", "scheme.beta": 0.25, "scheme.gamma": 0.5}
    base.update({k.replace("__", "."): v for k, v in keys.items()})
    for k, v in base.items():
        s.set(k, v)
    return s


@pytest.mark.parametrize("quadrature", ["exact", "gauss"])
def test_alm_3d_before_contact_equals_nitsche_theta0(quadrature, tmp_path):
    t_end = 1.1    # the bottom face reaches the obstacle at t = 1.15
    alm = run(box_alm(scheme__t_end=t_end, contact__quadrature=quadrature), tmp_path,
              "alm").trace
    nit = run(box_alm(scheme__t_end=t_end, contact__quadrature=quadrature,
                      contact__method="nitsche", contact__theta=0), tmp_path, "nitsche").trace
    assert alm["active"].max() == 0 and nit["active"].max() == 0
    for col in ("u_n", "v_n", "e_kin", "e_el", "e_total"):
        assert deviation(alm[col], nit[col]) <= SAME_FLIGHT_TOL * max(1.0, np.abs(nit[col]).max())
    assert np.all(alm["p_n"] == 0.0) and np.all(alm["e_contact"] == 0.0)


def test_alm_3d_nodal_complementarity_at_the_probe_node(tmp_path):
    """The probe (0.05, 0.05, 0) is a contact node of the triangles, where 'nodal' holds
    u_n <= 0, p_n <= 0 and p_n u_n = 0 to round-off, through the impact."""
    for mass in ("consistent", "redistributed"):
        tr = run(box_alm(contact__multiplier="nodal", scheme__mass=mass, scheme__t_end=2.5),
                 tmp_path, mass).trace
        assert (tr["p_n"] < -0.1).sum() > 10
        # an inactive lambda_i is zero up to the round-off of the Schur solve, relative to
        # the largest multipliers (p_n up to 38 with consistent mass): observed 3 eps of
        # max |p_n|, allowed 45 eps
        p_round = 1e-14 * np.abs(tr["p_n"]).max()
        assert tr["u_n"].max() <= 1e-14
        assert tr["p_n"].max() <= p_round
        assert np.abs(tr["p_n"] * tr["u_n"]).max() <= 1e-14


@pytest.mark.parametrize("mass", ["consistent", "lumped", "redistributed"])
@pytest.mark.parametrize("quadrature", ["exact", "gauss"])
@pytest.mark.parametrize("multiplier", ["integral", "nodal"])
def test_alm_3d_every_mass_runs_through_an_impact(multiplier, quadrature, mass, tmp_path):
    """Both multipliers, both quadratures, the three masses: ok through the first impact,
    in contact, the penetration small (observed: 'nodal' 0 to round-off; 'integral' at
    most 1.5e-2 with consistent mass, 2e-4 with redistributed); redistributed keeps its
    energy after the first step's snap of the massless contact nodes (observed 2e-5)."""
    res = run(box_alm(contact__multiplier=multiplier, contact__quadrature=quadrature,
                      scheme__mass=mass, scheme__t_end=2.5), tmp_path, "run")
    assert res.status == "ok", res.message
    tr = res.trace
    assert tr["active"].max() > 0 and tr["p_n"].min() < -0.1
    assert np.all(tr["e_contact"] == 0.0)
    assert tr["u_n"].max() < (1e-14 if multiplier == "nodal" else 0.02)
    if mass == "redistributed":
        assert tr["u_n"].max() < (1e-14 if multiplier == "nodal" else 1e-3)
        assert np.abs(tr["e_total"][1:] / tr["e_total"][1] - 1).max() < 1e-4


def test_alm_integral_with_one_point_a_facet_is_refused(tmp_path):
    """With one Gauss point a facet the integral multipliers' mass matrix
    sum_f |F| psi(x_f) psi(x_f)^T has rank at most one a facet, fewer than the multipliers (the
    nodes of Gamma_C): the multiplier system is singular (checked on the seed's bottom,
    2 segments and 3 nodes, and on the box's, 8 triangles and 9 nodes). The scene is
    refused naming &contact quad_points in 2D and 3D; the smallest rule that is not
    singular (2 points a segment, 3 a triangle) runs."""
    seg = np.array([[psi, 1 - psi] for psi in (0.5,)])                 # midpoint of a segment
    m2 = np.zeros((3, 3))
    for f in range(2):
        for row in seg:
            m2[f:f + 2, f:f + 2] += np.outer(row, row)
    assert np.linalg.matrix_rank(m2) <= 2 < 3
    centroid = np.full(3, 1.0 / 3.0)
    m3 = np.zeros((9, 9))
    tris = [(0, 1, 4), (0, 3, 4), (1, 2, 5), (1, 4, 5), (3, 4, 7), (3, 6, 7), (4, 5, 8),
            (4, 7, 8)]                                                   # a 3 x 3 node grid
    for t in tris:
        m3[np.ix_(t, t)] += np.outer(centroid, centroid)
    assert np.linalg.matrix_rank(m3) <= 8 < 9
    seed = Scene.read(ROOT / "scripts" / "scenes" / "bar2d_alm_consistent.nml")
    seed.set("scheme.t_end", 0.05)
    seed.set("contact.quadrature", "gauss")
    for scene, points, enough in ((seed, 1, 2), (box_alm(scheme__t_end=0.05,
                                                         contact__quadrature="gauss"), 1, 3)):
        scene.set("contact.quad_points", points)
        with pytest.raises(dyncontact.BadInputError,
                           match=r"&contact quad_points: must be at least \d with &contact "
                                 r"method = 'alm' and multiplier = 'integral'"):
            dyncontact.run(scene, out=tmp_path / "refused", progress=False)
        scene.set("contact.quad_points", enough)
        assert run_as_designed(scene, tmp_path / f"ok{enough}").status == "ok"
