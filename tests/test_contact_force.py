"""The trace's f_n column: the total normal contact force.

Its definition, sign and units: (docs/scenes.md, "Outputs (in `&output dir`)").

f_n = int_GammaC [P]_- ds for Nitsche and penalty (<= 0, p_n's sign), the multipliers'
resultant for the augmented Lagrangian. Against the rigid translation t along the obstacle
normal n (sigma_n(t) = 0, t_n = 1) the contact part of B gives -f_n for any theta, and the
elastic part K_theta t is 0 on a body with nothing clamped, so t . M a = t . (L - B(u)) = f_n
at every state the scheme balances (no load). That is the identity tested here.

The discrete impulse identity (P = t . M v, the momentum along n). Newmark, HHT and the
central difference update v^{k+1} = v^k + dt ((1 - gamma) a^k
+ gamma a^{k+1}), so P^{k+1} - P^k = dt ((1 - gamma) g^k + gamma g^{k+1}) with g^k = t . M a^k:
  - Newmark and central (gamma = 1/2): M a^k = L - B(u^k), g^k = f_n^k;
  - HHT: M a^{k+1} = L + alpha B(u^k) - (1 + alpha) B(u^{k+1}),
    g^{k+1} = (1 + alpha) f_n^{k+1} - alpha f_n^k, and g^0 = f_n^0 (a^0 from M a^0 = L - B(u^0)).
  - generalized-alpha (galpha, rho_inf; docs/numerics.md, fortran/schemes/implicit_schemes.f90)
    balances (1 - am) M a^{k+1} + am M a^k + (1 - af) B(u^{k+1}) + af B(u^k) = L with
    am = (2 rho_inf - 1) / (rho_inf + 1), af = rho_inf / (rho_inf + 1), gamma = 1/2 - am + af,
    so (1 - am) g^{k+1} + am g^k = (1 - af) f_n^{k+1} + af f_n^k, g^0 = f_n^0 (a^0 from
    M a^0 = L - B(u^0), as HHT, which is am = 0, af = -alpha). With am != 0 g^{k+1} depends
    on g^k: the force history, not the step's two f_n alone. The test runs this recurrence
    on the trace's f_n from row 0 (no acceleration is read: g^k is t . M a^k, which a
    Stepper's state gives too, measured equal to 7.5e-13 of the peak force, a formed as
    (u' - u~) / (beta dt^2) with the cancellation that brings). rho_inf = 1 (am = af = 1/2,
    gamma = 1/2): g^{k+1} + g^k = f_n^{k+1} + f_n^k, so each step's impulse is
    dt (f_n^k + f_n^{k+1}) / 2, the trapezoid, with no history; rho_inf = 1/2 is am = 0,
    af = 1/3, HHT with alpha = -1/3.
Summed between two rows, P^j - P^i = sum_{k=i}^{j-1} dt ((1 - gamma) g^k + gamma g^{k+1}),
to the Newton tolerance (1e-14 here, below round-off) and round-off.

The theta-scheme (&scheme name = 'theta', theta in [1/2, 1]) has no acceleration: its step
is u' = u + dt (theta v' + (1 - theta) v), M (v' - v) = dt (L - theta B(u')
- (1 - theta) B(u)) (docs/numerics.md; the residual M (u' - u~) + theta^2 dt^2 B(u') - b
with u~ = u + dt v, b = theta dt^2 (L - (1 - theta) B(u)) is theta dt times it), so
P^{k+1} - P^k = dt ((1 - theta) f_n^k + theta f_n^{k+1}): the Newmark form with
gamma = theta and g^k = f_n^k (theta = 1/2: the trapezoid).

The pc schemes update v with the predictor's acceleration instead (see the pc test below).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import dyncontact
from dyncontact.core import Stepper, load_mesh, read_trace

#: obstacle normal (pointing into the obstacle) and point, by dimension
NORMAL = {1: "-1.0", 2: "0.0, -1.0", 3: "0.0, 0.0, -1.0"}
POINT = {1: "-0.01", 2: "0.0, -0.01", 3: "0.0, 0.0, -0.01"}
VELOCITY = {1: "-0.5", 2: "0.0, -0.5", 3: "0.0, 0.0, -0.5"}
PROBE = {1: "0.0", 2: "0.05, 0.0", 3: "0.05, 0.05, 0.0"}
SLIP = {1: "", 2: "slip_x = '', slip_y = '',", 3: "slip_x = '', slip_y = '', slip_z = '',"}


def free_bar(path, dim, method="nitsche", theta=1, scheme="name = 'newmark', beta = 0.25, "
             "gamma = 0.5", mass="consistent", dt=0.0025, t_end=0.2, extra="", every=1):
    """A short built-in bar (length 0.2), nothing clamped, thrown at the plane 0.01 below
    its bottom with v = 0.5 along n, no load: it hits, bounces and leaves within t_end.
    theta is written for Nitsche only (the other methods do not use it)."""
    variant = f"theta = {theta}, " if method == "nitsche" else ""
    path.write_text(
        f"&mesh file = '', dim = {dim}, length = 0.2, width = 0.1, h = 0.05 /\n"
        f"&boundary clamped = '', {SLIP[dim]} contact = 'bottom' /\n"
        "&material young = 1.0, poisson = 0.3, density = 1.0 /\n"
        f"&contact method = '{method}', {variant}gamma0 = 10.0, {extra}\n"
        f"         obstacle_point = {POINT[dim]}, obstacle_normal = {NORMAL[dim]},\n"
        f"         probe = {PROBE[dim]} /\n"
        f"&initial kind = 'velocity', velocity = {VELOCITY[dim]} /\n"
        f"&scheme {scheme}, dt = {dt}, t_end = {t_end}, mass = '{mass}',\n"
        "        newton_tol = 1e-14, newton_maxit = 50 /\n"
        f"&output every = {every} /\n")
    return path


def stepped(scene, out):
    """(t, momentum along n, states) at every step of a Stepper run, and its trace."""
    times, mom, states = [], [], []
    with Stepper(dyncontact.Scene.read(scene), out) as st:
        node, comp = st.dof_map()
        dim = int(comp.max()) + 1
        n = np.zeros(dim)
        n[-1] = -1.0            # NORMAL: the last axis, pointing down
        tvec = n[comp]          # the rigid translation along n on the free dofs
        while True:
            x = st.state()
            times.append(x["t"])
            mom.append(float(tvec @ x["mv"]))
            states.append(x)
            if st.finished:
                break
            st.advance(1)
    return np.array(times), np.array(mom), states, read_trace(out), (node, comp, tvec)


def impulse(f_n, dt, gamma, alpha=0.0, alpha_m=0.0):
    """sum dt ((1 - gamma) g^k + gamma g^{k+1}) from row 0 to each row (module docstring),
    with g^0 = f_n^0 and (1 - alpha_m) g^{k+1} + alpha_m g^k = (1 + alpha) f_n^{k+1}
    - alpha f_n^k (alpha = -af: HHT's alpha; alpha_m = am: generalized-alpha's)."""
    f_n = np.asarray(f_n, dtype=float)
    g = np.array(f_n)
    for k in range(len(f_n) - 1):
        g[k + 1] = ((1.0 + alpha) * f_n[k + 1] - alpha * f_n[k] - alpha_m * g[k]) \
            / (1.0 - alpha_m)
    steps = dt * ((1.0 - gamma) * g[:-1] + gamma * g[1:])
    return np.concatenate([[0.0], np.cumsum(steps)])


def check_impulse(times, mom, tr, dt, gamma, alpha=0.0, sign_tol=0.0, alpha_m=0.0):
    assert np.array_equal(tr["t"], times)
    f = tr["f_n"]
    assert f.min() < 0 and f[0] == 0.0       # from flight into contact
    assert np.all(f <= sign_tol * abs(f.min()))
    dp = mom - mom[0]
    imp = impulse(f, dt, gamma, alpha, alpha_m)
    # each step balances to newton_tol = 1e-14 (relative, below round-off), the sums run
    # over up to a few hundred dofs and 80-400 steps: measured at most 7.1e-14 of the
    # momentum change (ALM integral; 1e-15 to 6.4e-14 for the others); 1e-12 leaves a
    # factor 14, and HHT's run with Newmark's weights instead misses by 1.7e-4
    scale = np.abs(dp).max()
    assert scale > 0.5 * abs(mom[0])           # the impact took half the momentum or more
    np.testing.assert_allclose(imp, dp, rtol=0, atol=1e-12 * scale)
    assert dp.min() < 0


@pytest.mark.parametrize("dim", [1, 2, 3])
@pytest.mark.parametrize("contact", ["theta1", "theta0", "theta-1", "penalty"])
def test_impulse_identity_newmark(dim, contact, tmp_path):
    """Newmark (1/4, 1/2), consistent mass: P^j - P^0 = sum dt (f_n^k + f_n^{k+1}) / 2."""
    if contact == "penalty":
        scene = free_bar(tmp_path / "s.nml", dim, method="penalty", theta=1)
    else:
        scene = free_bar(tmp_path / "s.nml", dim, theta=int(contact[5:]))
    times, mom, _, tr, _ = stepped(scene, tmp_path / "o")
    check_impulse(times, mom, tr, 0.0025, 0.5)


@pytest.mark.parametrize("case", ["newmark_lumped", "hht", "central", "alm_integral",
                                  "alm_nodal"])
def test_impulse_identity_other_schemes_2d(case, tmp_path):
    """The same identity in 2D with a lumped mass, HHT (alpha shifts the weights), the
    central difference and the augmented Lagrangian (integral and nodal multipliers, with
    the redistributed mass it is meant for). The multipliers leave Newton at its
    tolerance: in flight lambda, and so f_n, can be a round-off away from 0 (seen: 6e-18
    of the peak force, of either sign), hence sign_tol there."""
    alpha, gamma, kw, sign_tol = 0.0, 0.5, {}, 0.0
    if case == "newmark_lumped":
        kw = {"mass": "lumped"}
    elif case == "hht":
        alpha = -0.1
        gamma = 0.5 - alpha       # HHT's gamma = 1/2 - alpha, beta = (1 - alpha)^2 / 4
        kw = {"scheme": "name = 'hht', alpha = -0.1"}
    elif case == "central":
        kw = {"scheme": "name = 'central'", "dt": 0.0005, "mass": "lumped"}
    else:
        kw = {"method": "alm", "extra": f"multiplier = '{case[4:]}',",
              "mass": "redistributed"}
        sign_tol = 1e-14
    scene = free_bar(tmp_path / "s.nml", 2, **kw)
    times, mom, _, tr, _ = stepped(scene, tmp_path / "o")
    check_impulse(times, mom, tr, kw.get("dt", 0.0025), gamma, alpha, sign_tol)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("mass", ["consistent", "lumped"])
@pytest.mark.parametrize("scheme", ["theta 0.5", "theta 0.6", "galpha 1.0", "galpha 0.5"])
def test_impulse_identity_theta_and_galpha(dim, mass, scheme, tmp_path):
    """The theta-scheme: P^j - P^0 = sum dt ((1 - theta) f_n^k + theta f_n^{k+1}); galpha:
    the Newmark form with its gamma and g^k from the recurrence on f_n (module docstring).
    With the trapezoid's weights theta = 0.6 misses by 2.3e-3 to 3.3e-3 of the momentum
    change and rho_inf = 0.5 by 2.2e-4 to 2.9e-4 (measured, 2D and 3D, either mass), far
    above check_impulse's tolerance (measured here with the right weights: at most
    2.1e-14); theta = 0.5 and rho_inf = 1 are the trapezoid."""
    name, value = scheme.split()
    par = float(value)
    if name == "theta":
        kw = {"gamma": par}
        text = f"name = 'theta', theta = {value}"
    else:
        am = (2.0 * par - 1.0) / (par + 1.0)
        af = par / (par + 1.0)
        kw = {"gamma": 0.5 - am + af, "alpha": -af, "alpha_m": am}
        text = f"name = 'galpha', rho_inf = {value}"
    scene = free_bar(tmp_path / "s.nml", dim, scheme=text, mass=mass)
    times, mom, _, tr, _ = stepped(scene, tmp_path / "o")
    check_impulse(times, mom, tr, 0.0025, **kw)
    if scheme in ("theta 0.6", "galpha 0.5"):
        # the trapezoid's weights (right for the other two) miss by far more than round-off
        dp = mom - mom[0]
        miss = np.abs(impulse(tr["f_n"], 0.0025, 0.5) - dp).max()
        assert miss > 1e-5 * np.abs(dp).max()


@pytest.mark.parametrize("scheme", ["name = 'newmark', beta = 0.25, gamma = 0.5",
                                    "name = 'theta', theta = 0.6",
                                    "name = 'galpha', rho_inf = 0.5",
                                    "name = 'pc', beta = 0.25, gamma = 0.5",
                                    "name = 'central'", "alm"])
def test_stepper_state_f_n_is_the_trace_f_n(scheme, tmp_path):
    """Stepper.state()["f_n"] is the f_n the trace writes for the same step, at every row
    (bit for bit: both are state_t's f_n, and the trace's 17 significant digits read back
    to the same double), implicit, explicit and augmented-Lagrangian runs."""
    kw = {"scheme": scheme}
    if scheme == "alm":
        kw = {"method": "alm", "extra": "multiplier = 'integral',", "mass": "redistributed"}
    elif scheme.startswith(("name = 'pc'", "name = 'central'")):
        kw.update(dt=0.0005, mass="lumped")
    scene = free_bar(tmp_path / "s.nml", 2, **kw)
    times, _, states, tr, _ = stepped(scene, tmp_path / "o")
    assert np.array_equal(tr["t"], times)
    f = np.array([x["f_n"] for x in states])
    assert f.min() < 0
    np.testing.assert_array_equal(f, tr["f_n"])


@pytest.mark.parametrize("scheme,alpha", [("name = 'pc', beta = 0.25, gamma = 0.5", 0.0),
                                          ("name = 'pc_hht', alpha = -0.1", -0.1)])
def test_f_n_is_the_force_of_the_predictor_corrector_balance(scheme, alpha, tmp_path):
    """pc and pc_hht update v with the predictor's acceleration (at u~, which the trace
    does not see), so the impulse identity above does not hold for them with f_n; the
    balance of the corrected state does: M a' = L + alpha B(u) - (1 + alpha) B(u'), so
    t . M a^{k+1} = (1 + alpha) f_n^{k+1} - alpha f_n^k at every row (t . M a^0 = f_n^0)."""
    scene = free_bar(tmp_path / "s.nml", 2, scheme=scheme, dt=0.0005)
    with Stepper(dyncontact.Scene.read(scene), tmp_path / "o") as st:
        _node, comp = st.dof_map()
        tvec = np.where(comp == 1, -1.0, 0.0)
        mass = st.matrix("M")
        g = []
        while True:
            g.append(float(tvec @ (mass @ st.state()["a"])))
            if st.finished:
                break
            st.advance(1)
    f = read_trace(tmp_path / "o")["f_n"]
    assert f.min() < 0
    want = np.array(f)
    want[1:] = (1.0 + alpha) * f[1:] - alpha * f[:-1]
    # one mass solve and a product with M a step: round-off of the largest force
    np.testing.assert_allclose(g, want, rtol=0, atol=1e-12 * abs(f.min()))


def test_f_n_is_the_integral_of_the_pressure_2d(tmp_path):
    """f_n against an independent numpy integral of [P]_- over the contact facets:
    P = sigma_n(u) - gamma_N (u_n - g) is linear on a segment, so the integral of its
    negative part is closed-form (the trapezoid, or the triangle cut at its zero)."""
    scene = free_bar(tmp_path / "s.nml", 2, theta=0)
    times, _, states, tr, (node, comp, _t) = stepped(scene, tmp_path / "o")
    mesh = load_mesh("", dim=2, length=0.2, width=0.1, h=0.05)
    x, cells = mesh["x"], mesh["cells"]
    bottom = mesh["group_names"].index("bottom")
    facets = mesh["facets"][mesh["facet_group"] == bottom]
    young, nu, gamma0 = 1.0, 0.3, 10.0
    lam = young * nu / ((1 + nu) * (1 - 2 * nu))     # plane strain
    mu = young / (2 * (1 + nu))
    n = np.array([0.0, -1.0])
    owner = [next(c for c in cells if set(f) <= set(c)) for f in facets]
    checked = 0
    for k in np.flatnonzero(tr["active"] > 0)[::7]:
        u = np.zeros((len(x), 2))
        u[node, comp] = states[k]["u"]
        total = 0.0
        for f, c in zip(facets, owner):
            xc = x[c]
            grad = np.linalg.solve(np.c_[np.ones(3), xc], np.eye(3))[1:]  # (2, 3) dphi/dx
            du = u[c].T @ grad.T                                             # du_i/dx_j
            eps = 0.5 * (du + du.T)
            sigma = lam * np.trace(eps) * np.eye(2) + 2 * mu * eps
            h_t = max(np.linalg.norm(xc[i] - xc[j]) for i in range(3) for j in range(i))
            gap = (np.array([0.0, -0.01]) - x[f]) @ n
            p = n @ sigma @ n - (gamma0 / h_t) * (u[f] @ n - gap)
            length = np.linalg.norm(x[f[1]] - x[f[0]])
            if p.max() <= 0:
                total += length * p.mean()
            elif p.min() < 0:
                total += 0.5 * length * p.min() ** 2 / (p.min() - p.max())
        # the two sums (numpy's closed form, the kernel's Gauss points on the cut segment)
        # differ by round-off: measured <= 6.7e-16 relative; at the first contact row
        # f_n = -2.0e-16 (P of order 1 just below 0 on a sliver) and they differ by 2e-18,
        # hence abs = 1e-15, round-off of P ~ 1 integrated over the 0.1 wide bottom
        assert tr["f_n"][k] == pytest.approx(total, rel=1e-12, abs=1e-15)
        assert tr["f_n"][k] < 0
        checked += 1
    assert checked >= 3


def test_f_n_is_zero_in_flight(tmp_path):
    """Before the impact and after the bounce no contact point is active: f_n = +0
    exactly (not -0, not round-off), as p_n; the implicit flight test (contact_clear)
    forms no facet term there. Checked for an implicit and an explicit scheme."""
    for name, scheme, dt in (("imp", "name = 'newmark', beta = 0.25, gamma = 0.5", 0.0025),
                             ("exp", "name = 'central'", 0.0005)):
        scene = free_bar(tmp_path / f"{name}.nml", 2, scheme=scheme, dt=dt,
                         mass="lumped" if name == "exp" else "consistent", t_end=0.5)
        res = dyncontact.run(dyncontact.Scene.read(scene), out=tmp_path / name,
                             progress=False)
        tr = res.trace
        fly = tr["active"] == 0
        assert fly[0] and fly[-1] and not fly.all()
        assert np.all(tr["f_n"][fly] == 0.0)
        assert not np.any(np.signbit(tr["f_n"][fly]))
        assert np.all(tr["f_n"][~fly] < 0.0)
        # the written text of a zero row is the format's +0
        lines = (tmp_path / name / "trace.csv").read_text().splitlines()
        assert lines[1].rsplit(",", 1)[1].strip() == "0.0000000000000000E+000"


def test_f_n_per_unit_thickness_matches_p_n_on_a_uniform_contact_1d(tmp_path):
    """In 1D the contact 'facet' is the end node (measure 1): f_n is the force there, which
    is P at the node, the probe's p_n (the probe sits on the end node)."""
    scene = free_bar(tmp_path / "s.nml", 1)
    _, _, _, tr, _ = stepped(scene, tmp_path / "o")
    np.testing.assert_array_equal(tr["f_n"], tr["p_n"])
    assert math.isfinite(tr["f_n"].min()) and tr["f_n"].min() < 0
