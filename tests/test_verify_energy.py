"""The energy the trace reports is the one the semi-discrete system conserves, checked
through an impact by its convergence as dt -> 0.

With Nitsche theta = 1, B is a gradient: B(u).v = a(u, v) - int (1/gamma_N) sigma_n(u)
sigma_n(v) + int (1/gamma_N) [P_1(u) + gamma_N g]_- P_1(v), and P_1(v) is the derivative
of P_1(u) along v, so B = grad Psi with Psi = 1/2 a(u, u) - int (1/(2 gamma_N)) sigma_n^2 +
int (1/(2 gamma_N)) [P_1 + gamma_N g]_-^2 = e_el + e_contact (SPEC, "Energies"). With the
penalty, B = grad(e_el + int (eps_N / 2) [u_n - g]_+^2) = grad(e_el + e_contact). So
M u'' + B(u) = 0 conserves E = e_kin + e_el + e_contact = e_total + e_contact exactly,
through the impact as in flight, and every consistent scheme's max |E(t) - E(0)| over
[0, T] tends to zero with dt (B is only Lipschitz at the contact switches, so no scheme
conserves E exactly there, and dissipative ones lose O(dt^p) of it).

With theta = -1, B is not a gradient (its linear part's theta-term is symmetric but the
contact term is not the derivative of anything), so the same E changes by an O(1) amount
through the impact whatever dt: the contrast that shows the check can fail. So does the
wrong energy e_total + 2 e_contact with theta = 1.

The runs: the 1D bar (h = 0.02), the seed's 2D bar (h = 0.05) and the 3D box (h = 0.1) from
the compressed state through the first impact and release (T = 2.5); dt = h/10 and h/80
for the implicit schemes, a fifth of that for the predictor-corrector and central (lumped
mass). Measured, the ratio of max |E - E(0)| / E(0) at the two steps (theta = 1 with
'exact' and the 3-point rule, and penalty, every scheme and dimension): 36 to 470,
orders 1.7 to 3 (e.g. 2D newmark 1/4 1/2, theta = 1: 1.2e-3 -> 2.6e-5; hht -0.1: 1.1e-2
-> 5.6e-5). Asserted: at least 8, first order. With
theta = -1 the drift tends to 1.4e-2 (1D), 0.47 (2D) and 0.27 (3D) of E(0), ratios 0.6 to
1.0 (and 0.7 to 1.0 for e_total + 2 e_contact with theta = 1); asserted below 2.
"""

from __future__ import annotations

import numpy as np
import pytest

import dyncontact

from conftest import ROOT, run_as_designed

T_END = 2.5
SCENES = {1: "bar1d.nml", 2: "bar2d_hht.nml", 3: "bar3d_hht.nml"}
H = {1: 0.02, 2: 0.05, 3: 0.1}
#: (scheme keys, mass, dt as a fraction of h at the coarse step; the fine step is 1/8 of it)
SCHEMES = {
    "newmark_0.25_0.5": ({"name": "newmark", "beta": 0.25, "gamma": 0.5}, "consistent", 10),
    "hht_-0.1": ({"name": "hht", "alpha": -0.1}, "consistent", 10),
    "galpha_0.8": ({"name": "galpha", "rho_inf": 0.8}, "consistent", 10),
    "theta_0.5": ({"name": "theta", "theta": 0.5}, "consistent", 10),
    "pc_0.25_0.5": ({"name": "pc", "beta": 0.25, "gamma": 0.5}, "consistent", 50),
    "central": ({"name": "central"}, "lumped", 50),
}
CONTACT = {
    "nitsche1": {"method": "nitsche", "theta": 1},
    "penalty": {"method": "penalty"},
    "nitsche-1": {"method": "nitsche", "theta": -1},
    # a fixed 3-point rule (2D segments, 3D triangles): B is the gradient of the rule's
    # sum, which e_contact then reports
    "nitsche1_gauss3": {"method": "nitsche", "theta": 1, "quadrature": "gauss",
                        "quad_points": 3},
}
CASES = [(dim, scheme, contact) for dim in (1, 2, 3) for scheme in SCHEMES
         for contact in CONTACT if dim > 1 or "gauss" not in contact]
REFINE = 8
#: max drift at dt must exceed REFINE^1 times the drift at dt / REFINE (first order):
#: measured 36-470 for the conserving cases (module docstring)
MIN_RATIO = REFINE
#: theta = -1 and the wrong energy: the drift does not fall (measured 0.6-1.0)
NO_CONVERGENCE_RATIO = 2.0


def energy_drifts(dim, scheme, contact, dt, out):
    keys, mass, _ = SCHEMES[scheme]
    s = dyncontact.Scene.read(ROOT / "scripts" / "scenes" / SCENES[dim])
    s.set("mesh.h", H[dim])
    for key, value in keys.items():
        s.set(f"scheme.{key}", value)
    for key, value in CONTACT[contact].items():
        s.set(f"contact.{key}", value)
    s.set("scheme.mass", mass)
    s.set("scheme.dt", dt)
    s.set("scheme.t_end", T_END)
    s.set("output.every", 1)
    res = run_as_designed(s, out)
    assert res.status == "ok"
    tr = res.trace
    touched = np.flatnonzero(tr["active"] > 0)
    assert touched.size and np.any(tr["active"][touched[0]:] == 0), "an impact and a release"
    e = tr["e_total"] + tr["e_contact"]
    wrong = tr["e_total"] + 2 * tr["e_contact"]
    return (float(np.max(np.abs(e - e[0])) / e[0]),
            float(np.max(np.abs(wrong - wrong[0])) / wrong[0]))


@pytest.mark.parametrize("dim, scheme, contact", CASES)
def test_energy_drift_through_an_impact_vanishes_as_dt_falls(dim, scheme, contact, tmp_path):
    dt = H[dim] / SCHEMES[scheme][2]
    (coarse, wrong_coarse), (fine, wrong_fine) = (
        energy_drifts(dim, scheme, contact, step, tmp_path / f"dt{i}")
        for i, step in enumerate((dt, dt / REFINE)))
    ratio = coarse / fine
    print(f"{dim}D {scheme} {contact}: max |E - E0|/E0 {coarse:.2e} -> {fine:.2e} "
          f"(ratio {ratio:.1f}); e_total + 2 e_contact: {wrong_coarse:.2e} -> "
          f"{wrong_fine:.2e}")
    if contact == "nitsche-1":
        assert ratio < NO_CONVERGENCE_RATIO and fine > 1e-3, (coarse, fine)
    else:
        assert ratio >= MIN_RATIO, (coarse, fine)
        if contact.startswith("nitsche1"):
            assert wrong_coarse / wrong_fine < NO_CONVERGENCE_RATIO, (wrong_coarse, wrong_fine)
