"""Invariants of the state a run writes out: for every scheme and both masses,
at sampled steps through an impact, recompute from the state (u, v, a through
dyncontact.core.Stepper) and the assembled matrices:

- the product M v that e_kin uses equals M v formed from v (no carried copy drifts);
- the flag `clear` an implicit step carries (no contact point possible at u, so the
  trace's p_n skips the probe's facets at a node) holds wherever it is set;
- B(u) as the scheme carries it into the next step (K_theta u formed by a product, and
  the contact part, which the implicit schemes keep from the step's last Newton
  iterate) equals B(u) evaluated afresh from u;
- the trace's e_kin = 1/2 v.M v and e_el = 1/2 u.K u;
- the scheme's update relations and its balance equation, to round-off (the Newton
  tolerance is set below round-off of the residual, so a converged step is exact);
- e_kin >= 0 in every trace row.

The scene is the seed bar at h = 0.05 (120 dofs) with gravity on (so the load L enters
the balance), run past the first impact (contact starts at t ~ 1.15); and, for every
scheme with the consistent mass, the 3D box at h = 0.05 (540 dofs; contact from t ~ 0.98),
whose products pass (K_theta u', M v', M (u' - u~') by node triples, M one scalar a block)
is a kernel of its own (block3_matvec_ks3 in fortran/linalg/sparse.f90).
"""

from __future__ import annotations

import numpy as np
import pytest

import dyncontact
from dyncontact.core import read_trace

from conftest import ROOT, sampled_steps, stepper_as_designed

SCENE = ROOT / "scripts" / "scenes" / "bar2d_hht.nml"
SCENE_3D = ROOT / "scripts" / "scenes" / "bar3d_hht.nml"

#: Relative round-off bound for identities evaluated in double precision over
#: O(100) terms (products with M, K, the update formulas).
THR = 1e-12
#: The balance equation is met to the Newton tolerance: NEWTON_TOL relative to the
#: residual's scale, which is below THR. Its scale includes the terms the step cancels:
#: a' = (u' - u~) / (beta dt^2) carries the round-off of u' divided by beta dt^2, so
#: M a' is exact only relative to |M u'| / (beta dt^2) (likewise v' in the theta scheme,
#: relative to |M u'| / (theta dt)).
NEWTON_TOL = 1e-14
T_END = 1.4      # past the start of the first impact
T_CONTACT = 1.15  # about where it starts
T_END_3D = 1.25   # the same for the 3D box (gravity -0.2 along the normal)
T_CONTACT_3D = 0.98
N_SAMPLES = 12   # sampled steps per run (each: the state before and after one step),
                 # as many again in contact

# (scheme keys, dt): implicit at the seed's h/20, predictor-correctors at h/100.
SCHEMES = {
    "newmark_0.25_0.5": ({"name": "newmark", "beta": 0.25, "gamma": 0.5}, 0.0025),
    "newmark_0.2_0.5": ({"name": "newmark", "beta": 0.2, "gamma": 0.5}, 0.0025),
    "newmark_0.25_0.6": ({"name": "newmark", "beta": 0.25, "gamma": 0.6}, 0.0025),
    "hht_-0.1": ({"name": "hht", "alpha": -0.1}, 0.0025),
    "hht_seed_-0.05": ({"name": "hht_seed", "alpha": -0.05}, 0.0025),
    "theta_0.5": ({"name": "theta", "theta": 0.5}, 0.0025),
    "theta_1": ({"name": "theta", "theta": 1.0}, 0.0025),
    "pc": ({"name": "pc", "beta": 0.25, "gamma": 0.5}, 0.0005),
    "pc_hht_-0.1": ({"name": "pc_hht", "alpha": -0.1}, 0.0005),
    "pc_hht_seed_-0.05": ({"name": "pc_hht_seed", "alpha": -0.05}, 0.0005),
    "galpha_0.8": ({"name": "galpha", "rho_inf": 0.8}, 0.0025),
    "central": ({"name": "central"}, 0.0005),
}
#: the mass kinds each family takes (the redistributed mass: implicit schemes only)
MASSES = ["consistent", "lumped", "redistributed"]
CASES = [(label, mass) for label in SCHEMES for mass in MASSES
         if mass != "redistributed" or SCHEMES[label][0]["name"] in (
             "newmark", "hht", "hht_seed", "theta", "galpha")]


def coefficients(keys):
    """(family, alpha_m, alpha_f, beta, gamma, theta) of a scheme as docs/scenes.md defines
    them (HHT's alpha is alpha_f = -alpha; the predictor-correctors' alpha is kept as
    alpha_f = -alpha too)."""
    name, a = keys["name"], keys.get("alpha", 0.0)
    if name == "galpha":
        rho = keys["rho_inf"]
        am, af = (2 * rho - 1) / (rho + 1), rho / (rho + 1)
        return "galpha", am, af, 0.25 * (1 - am + af) ** 2, 0.5 - am + af, None
    if name == "central":
        return "central", 0.0, 0.0, 0.0, 0.5, None
    if name in ("newmark", "pc"):
        return name, 0.0, 0.0, keys["beta"], keys["gamma"], None
    if name in ("hht", "pc_hht"):
        return name.replace("_hht", ""), 0.0, -a, (1 - a) ** 2 / 4, 0.5 - a, None
    if name in ("hht_seed", "pc_hht_seed"):
        return name.split("_")[0], 0.0, -a, (1 + a) ** 2 / 4, 0.5 + a, None
    return "theta", 0.0, 0.0, None, None, keys["theta"]


def rel(x, scale):
    return float(np.max(np.abs(x)) / max(scale, np.finfo(float).tiny))


@pytest.mark.parametrize("label, mass", CASES)
def test_state_invariants(label, mass, tmp_path):
    check_invariants(label, mass, SCENE, [0.0, -0.2], T_END, T_CONTACT, tmp_path)


@pytest.mark.parametrize("label", list(SCHEMES))
def test_state_invariants_3d(label, tmp_path):
    check_invariants(label, "consistent", SCENE_3D, [0.0, 0.0, -0.2], T_END_3D, T_CONTACT_3D,
                     tmp_path)


def check_invariants(label, mass, scene_path, gravity, t_end, t_contact, tmp_path):
    """The invariants of the module's docstring for one scheme and mass on one scene."""
    keys, dt = SCHEMES[label]
    family, am, af, beta, gamma, theta = coefficients(keys)
    scene = dyncontact.Scene.read(scene_path)
    for k, v in keys.items():
        scene.set(f"scheme.{k}", v)
    scene.set("scheme.dt", dt)
    scene.set("scheme.t_end", t_end)
    scene.set("scheme.mass", mass)
    scene.set("scheme.newton_tol", NEWTON_TOL)
    scene.set("material.gravity", gravity)
    out = tmp_path / "run"
    n_steps = int(round(t_end / dt))
    samples = set(np.linspace(0, n_steps - 1, N_SAMPLES).astype(int).tolist())
    samples |= set(np.linspace(int(t_contact / dt), n_steps - 1, N_SAMPLES).astype(int).tolist())
    with stepper_as_designed(scene, out) as run:
        M, K = run.matrix("M"), run.matrix("K")
        states = sampled_steps(run, n_steps, samples,
                               lambda s0, s1: (run.eval_b(s0["u"])[0], run.eval_b(s1["u"])[0],
                                               run.contact_clear(s1["u"])))
    trace = read_trace(out)
    assert len(trace["t"]) == n_steps + 1
    assert np.all(trace["e_kin"] >= 0.0), "e_kin < 0 in the trace"
    assert np.any(trace["active"] > 0), "the run never reached contact"
    in_contact = sum(1 for step in states if trace["active"][step + 1] > 0)
    assert in_contact >= 3, f"only {in_contact} sampled steps in contact"

    # the carried flag clear (the step ended with no contact point possible at u', so the
    # trace's p_n skips the probe's facets at a node) is never set where it does not hold;
    # the implicit schemes set it in flight, the explicit ones never
    clears = [s1["clear"] for s0, s1, b0, b1, fresh in states.values()]
    for step, (s0, s1, b0, b1, fresh) in states.items():
        assert fresh or not s1["clear"], f"{label} {mass} step {step + 1}: clear, P < 0"
    if family in ("central",) or keys["name"].startswith("pc"):
        assert not any(clears), f"{label}: an explicit scheme set clear"
    else:
        assert any(clears) and not all(clears), f"{label} {mass}: clear {sum(clears)}"

    for step, (s0, s1, b0, b1, fresh) in states.items():
        u0, v0, a0, u1, v1, a1 = s0["u"], s0["v"], s0["a"], s1["u"], s1["v"], s1["a"]
        load = s1["load"]
        where = f"{label} {mass} step {step + 1} (t = {s1['t']:.4f})"
        # the product the energies use is M v, formed from v
        mv = M @ v1
        assert rel(s1["mv"] - mv, np.max(np.abs(mv)) + 1e-300) <= THR, where
        # the carried B(u) is B(u) (the scheme's next residual starts from it)
        for s, b in ((s0, b0), (s1, b1)):
            assert rel(s["bu"] - b, np.max(np.abs(b)) + 1e-300) <= THR, (where, "B(u)")
        # the trace row of that step holds the energies of this state
        row = step + 1
        e_kin = 0.5 * v1 @ mv
        e_el = 0.5 * u1 @ K @ u1
        scale_e = abs(e_kin) + abs(e_el)
        assert abs(trace["e_kin"][row] - e_kin) <= THR * scale_e, (where, "e_kin")
        assert abs(trace["e_el"][row] - e_el) <= THR * scale_e, (where, "e_el")
        assert abs(trace["t"][row] - s1["t"]) <= THR, where
        # the scheme's relations. With the redistributed mass the contact dofs carry no
        # inertia: their v is reported as (u' - u)/dt and a as 0, and the update relations
        # are checked on the other dofs (the balance, with M's zero rows, on all).
        inert = np.any(M != 0.0, axis=0)
        if not inert.all():
            assert rel((v1 - (u1 - u0) / dt)[~inert], np.max(np.abs(v1)) + 1e-300) <= THR
            assert np.all(a1[~inert] == 0.0)
        if family in ("newmark", "hht", "galpha"):
            u_rel = u1 - (u0 + dt * v0 + dt * dt * ((0.5 - beta) * a0 + beta * a1))
            v_rel = v1 - (v0 + dt * ((1 - gamma) * a0 + gamma * a1))
            bal = (1 - am) * M @ a1 + am * M @ a0 + (1 - af) * b1 + af * b0 - load
            bal_scale = (np.max(np.abs(M @ a1)) + np.max(np.abs(M @ a0)) + np.max(np.abs(b1))
                         + np.max(np.abs(b0)) + np.max(np.abs(load))
                         + (1 - am) * np.max(np.abs(M @ u1)) / (beta * dt * dt))
        elif family == "theta":
            u_rel = u1 - (u0 + dt * (theta * v1 + (1 - theta) * v0))
            v_rel = np.zeros(1)
            bal = M @ (v1 - v0) - dt * (load - theta * b1 - (1 - theta) * b0)
            bal_scale = (np.max(np.abs(M @ (v1 - v0))) + np.max(np.abs(M @ u1)) / theta
                         + dt * (np.max(np.abs(b1)) + np.max(np.abs(b0))
                                 + np.max(np.abs(load))))
        elif family == "central":
            u_rel = u1 - (u0 + dt * v0 + 0.5 * dt * dt * a0)
            v_rel = v1 - (v0 + 0.5 * dt * (a0 + a1))
            bal = M @ a1 - (load - b1)
            bal_scale = np.max(np.abs(M @ a1)) + np.max(np.abs(b1)) + np.max(np.abs(load))
        else:  # predictor-correctors: the acceleration of the written state
            u_rel = np.zeros(1)
            v_rel = np.zeros(1)
            bal = M @ a1 - (load - af * b0 - (1 - af) * b1)
            bal_scale = (np.max(np.abs(M @ a1)) + (1 + abs(af)) * np.max(np.abs(b1))
                         + abs(af) * np.max(np.abs(b0)) + np.max(np.abs(load)))
        u_rel, v_rel = u_rel[inert] if u_rel.size > 1 else u_rel, \
            v_rel[inert] if v_rel.size > 1 else v_rel
        u_scale = np.max(np.abs(u1)) + np.max(np.abs(u0))
        v_scale = np.max(np.abs(v1)) + np.max(np.abs(v0)) + dt * np.max(np.abs(a0))
        assert rel(u_rel, u_scale) <= THR, (where, "u update", rel(u_rel, u_scale))
        assert rel(v_rel, v_scale) <= THR, (where, "v update", rel(v_rel, v_scale))
        assert rel(bal, bal_scale) <= THR, (where, "balance", rel(bal, bal_scale))
