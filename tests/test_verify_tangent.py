"""The generalized derivative B'(u) against central differences of B at states where
contact facets are cut: the active set ends inside a facet, so the 'exact' quadrature
splits it at the zero of P and a fixed Gauss rule has active and inactive points on one
facet. (tests/test_schemes.py and tests/test_3d.py check states pushed into the obstacle
as a whole, whose facets are all fully active or all free: 6 of 6 points of the 3-point
rule in 2D.)

The state: u_n = s (x - x0) along the contact boundary (the bar tilted about the line
x = x0, which lies inside a bottom facet in 2D and crosses the bottom triangles in 3D),
plus noise of 1e-4. That the facets are cut is asserted, not assumed: a Gauss rule with
q points a facet has an active count that is not a multiple of q. B is piecewise linear,
so central differences have no truncation error where no point switches, and their error
is round-off, eps |B| / step: measured 5e-10 to 7e-10 relative, every theta, penalty,
'exact' and every Gauss rule, 2D and 3D. FD_TOL is sqrt(eps)-scaled (tblite's thr2, as in
test_schemes.py); every direction must keep the active count (none is skipped here).

What only a cut facet shows: the tangent leaves out the derivative of the split point,
which is right because [P]_- vanishes there. A split placed 1 % off the zero of P (in
the 2D 'exact' rule) gives an FD error of 1.3e-3 here, while the whole-facet checks of
test_schemes.py still pass.
"""

from __future__ import annotations

import numpy as np
import pytest

import dyncontact
from dyncontact.core import Model, load_mesh

from conftest import ROOT, fd_jacobian_errors

FD_TOL = 1e-6
TRIES = 4
SCENES = {2: "bar2d_hht.nml", 3: "bar3d_hht.nml"}
H = 0.05
X0, SLOPE = 0.037, 0.05      # tilt line inside the first/second bottom facet (h = 0.05)
#: Gauss rules whose counts prove a cut (points a facet)
PROOF_RULE = {2: 5, 3: 3}
CONTACT = [("nitsche", -1), ("nitsche", 0), ("nitsche", 1), ("penalty", 0)]
#: (quadrature, quad_points) by dimension: 'exact' and every Gauss rule the scene takes
#: (1..6 points a segment; the symmetric triangle rules of 1, 3, 6, 7 points)
QUADRATURE = {2: [("exact", 0)] + [("gauss", n) for n in range(1, 7)],
              3: [("exact", 0)] + [("gauss", n) for n in (1, 3, 6, 7)]}
CASES = [(dim, method, theta, quadrature, points) for dim in (2, 3)
         for method, theta in CONTACT for quadrature, points in QUADRATURE[dim]]


def model_scene(dim, method, theta, quadrature, points):
    s = dyncontact.Scene.read(ROOT / "scripts" / "scenes" / SCENES[dim])
    s.set("mesh.h", H)
    s.set("contact.method", method)
    if method == "nitsche":
        s.set("contact.theta", theta)
    s.set("contact.quadrature", quadrature)
    if quadrature == "gauss":
        s.set("contact.quad_points", points)
    return s


def tilted_state(m, dim, rng):
    node, comp = m.dof_map()
    x = load_mesh("", dim=dim, h=H)["x"][node]
    u_n = SLOPE * (x[:, 0] - X0)
    # n = -e_y (2D), -e_z (3D): u_n = -u along that axis
    return np.where(comp == dim - 1, -u_n, 0.0) + 1e-4 * rng.standard_normal(comp.shape)


@pytest.mark.parametrize("dim, method, theta, quadrature, points", CASES)
def test_tangent_matches_finite_differences_on_cut_facets(dim, method, theta, quadrature,
                                                         points):
    rng = np.random.default_rng(5)
    proof = PROOF_RULE[dim]
    with Model(model_scene(dim, method, theta, "gauss", proof)) as m:
        _, active = m.eval_b(tilted_state(m, dim, np.random.default_rng(5)))
        assert 0 < active and active % proof != 0, f"no cut facet: {active} active points"
    with Model(model_scene(dim, method, theta, quadrature, points)) as m:
        u = tilted_state(m, dim, rng)
        b, active = m.eval_b(u)
        assert active > 0
        errs = fd_jacobian_errors(m, u, active, rng, TRIES, switch="fail")
        print(f"{dim}D {method} theta={theta} {quadrature} {points}: active {active}, "
              f"max FD error {max(errs):.1e}")
        assert max(errs) < FD_TOL, errs


@pytest.mark.parametrize("depth", [-0.05, 0.05], ids=["free", "in_contact"])
@pytest.mark.parametrize("method, theta", CONTACT)
def test_1d_tangent_matches_finite_differences(method, theta, depth):
    """The 1D contact point (a facet of one node, no quadrature): B'(u) against central
    differences of B in and out of contact, every theta and penalty (measured: 2e-10 to
    1.9e-9 relative; no other test checks the 1D tangent)."""
    s = dyncontact.Scene.read(ROOT / "scripts" / "scenes" / "bar1d.nml")
    s.set("mesh.h", 0.05)
    s.set("contact.method", method)
    if method == "nitsche":
        s.set("contact.theta", theta)
    rng = np.random.default_rng(9)
    with Model(s) as m:
        node, _ = m.dof_map()
        x = load_mesh("", dim=1, h=0.05)["x"][node, 0]
        # u_n = -u (n = -1): the bar pushed into the obstacle by depth, clamped end fixed
        u = -depth * (1 - x) + 1e-4 * rng.standard_normal(x.shape)
        _, active = m.eval_b(u)
        assert active == (1 if depth > 0 else 0)
        errs = fd_jacobian_errors(m, u, active, rng, TRIES, switch="fail")
        print(f"1D {method} theta={theta} depth={depth}: max FD error {max(errs):.1e}")
        assert max(errs) < FD_TOL, errs


#: symmetry of a dense Jacobian: |J - J^T| against |J| (round-off of the sums forming it)
SYM_TOL = 1e-13


@pytest.mark.parametrize("dim, method, theta",
                         [(dim, m, t) for dim in (2, 3) for m, t in CONTACT])
def test_tangent_is_symmetric_exactly_for_the_gradient_methods(dim, method, theta):
    """At the cut state: theta = 1 and penalty, where B is the gradient of e_el + e_contact
    (tests/test_verify_energy.py), have a symmetric generalized derivative (measured
    |J - J^T| <= 4.1e-17 of |J|); theta = 0 and -1 do not (measured 0.09 to 0.28 of |J|)."""
    rng = np.random.default_rng(5)
    with Model(model_scene(dim, method, theta, "exact", 0)) as m:
        u = tilted_state(m, dim, rng)
        _, active = m.eval_b(u)
        assert active > 0
        jac = np.column_stack([m.jacobian_apply(u, e) for e in np.eye(m.dofs)])
    asym = float(np.max(np.abs(jac - jac.T)) / np.max(np.abs(jac)))
    print(f"{dim}D {method} theta={theta}: |J - J^T| / |J| = {asym:.1e}")
    if method == "penalty" or theta == 1:
        assert asym <= SYM_TOL
    else:
        assert asym > 1e-3
