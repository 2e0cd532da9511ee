"""The residual B(u) the core evaluates against SPEC's formula written out here, on states
where the contact facets are cut (the active set ends inside them), in 1D, 2D and 3D:

    B(u).v = a(u, v) - int_GC (theta/gamma_N) sigma_n(u) sigma_n(v)
             + int_GC (1/gamma_N) [P_1(u) + gamma_N g]_- P_theta(v),
    P_theta(v) = theta sigma_n(v) - gamma_N v_n   (penalty: sigma_n dropped, theta = 0).

a(u, v) is the core's assembled K (tests/test_verify_assembly.py and test_fe.py check it
against the continuum); everything else comes from the mesh: sigma_n(v) = s_f . v from the
P1 gradients of facet f's owner cell, u_n and g at the facet's nodes, gamma_N = gamma0 /
h_T with h_T the owner cell's longest edge (tests/test_carried_quantities.py's
ContactReference). The contact integral is taken in closed form where the core's rule is
'exact': P is linear on a facet, so the part where P < 0 is the facet, a sub-segment, or
one or two sub-triangles (triangle_pieces), and on each the integrand [P]_- P_theta(v) is
a polynomial of degree 2 in the facet's coordinates, which 2 Gauss points (a segment) or
the 3-point degree-2 rule (a triangle) integrate exactly. Where the scene takes a Gauss
rule, the rule's own points (Gauss-Legendre; the symmetric triangle rules).

The obstacle is tilted and off the body (tests/test_carried_quantities.py's GEOMETRY), so
g varies along Gamma_C; the body is translated into the obstacle by DEPTH, which leaves
some facets fully active and some cut (asserted; in 2D some free too). B(u) - K u (the
contact integral and the theta-term, K u being K's product whatever the contact) is
compared with the formula relative to the largest of those terms' magnitudes at a dof
(|F| / gamma_N |P| (|s| + gamma_N |u_n rows|) and |F| / gamma_N |theta sigma_n| |s|,
summed over the facets): measured 1e-17 to 5e-17, held to 1e-12 (about 4500 eps, as the
carried quantities). The contact part is 0.96 to 1.01 of |B| at these states. What the
finite-difference checks cannot see, as a residual and its tangent can be wrong
together: gamma_N 0.1 % off fails every case here, and passes tests/test_verify_tangent.py.
"""

from __future__ import annotations

import numpy as np
import pytest

from dyncontact.core import Stepper, load_mesh

from conftest import warns_as_designed
from test_carried_quantities import (CONTACT, GEOMETRY, ContactReference, scene_for,
                                     triangle_pieces, triangle_rule)

THR = 1e-12
#: translation into the obstacle along n (the gap runs from 0.004 to about 0.035 across
#: the bottom of the tilted 2D and 3D bars; 1D: a point, in contact)
DEPTH = {1: 0.01, 2: 0.015, 3: 0.03}
VARIANTS = {1: ["nitsche1", "nitsche0", "nitsche-1", "penalty"],
            2: ["nitsche1", "nitsche0", "nitsche-1", "penalty", "nitsche1_gauss3"],
            3: ["nitsche1", "nitsche0", "nitsche-1", "penalty", "nitsche1_gauss3",
                "nitsche1_gauss7"]}
GAUSS_2D = {n: np.polynomial.legendre.leggauss(n) for n in range(1, 7)}


def facet_points(dim, p, gauss):
    """(shape values at the points, (n, nfn); weights as fractions of |F|) of the points
    where [P]_- is integrated on a facet with nodal P values p: the pieces where P < 0
    ('exact', gauss = 0) or the Gauss rule's points."""
    if dim == 1:
        return np.ones((1, 1)), np.ones(1)
    if dim == 2:
        if gauss:
            xi, w = GAUSS_2D[gauss]
            t = (1 + xi) / 2
            return np.column_stack([1 - t, t]), w / 2
        if not np.any(p < 0):
            return np.zeros((0, 2)), np.zeros(0)
        if np.all(p < 0):
            a, b = 0.0, 1.0
        else:
            z = p[0] / (p[0] - p[1])
            a, b = (0.0, z) if p[0] < 0 else (z, 1.0)
        t = a + (b - a) * (0.5 + np.array([-0.5, 0.5]) / np.sqrt(3.0))
        return np.column_stack([1 - t, t]), np.full(2, (b - a) / 2)
    if gauss:
        bary, w = triangle_rule(gauss)
        return bary, w
    shapes, weights = [], []
    bary, w = triangle_rule(3)
    for piece, negative in triangle_pieces(p):
        if negative:
            shapes.append(bary @ piece)
            weights.append(w * abs(np.linalg.det(piece)))
    if not shapes:
        return np.zeros((0, 3)), np.zeros(0)
    return np.vstack(shapes), np.concatenate(weights)


def formula_contact(ref, u, theta, penalty, gauss):
    """(B(u) - K u by SPEC's formula: the theta-term and the contact integral; P at the
    facets' nodes; the scale of those terms at each dof)."""
    b = np.zeros_like(u)
    scale = np.zeros_like(u)
    ws = 0.0 if penalty else 1.0
    sn = ref.s @ u
    p = ws * sn[:, None] - ref.gamma[:, None] * (ref.un @ u - ref.gap)
    for f in range(len(ref.gamma)):
        gam, meas, s = ref.gamma[f], ref.measure[f], ref.s[f]
        b -= theta * meas / gam * sn[f] * s
        scale += abs(theta) * meas / gam * abs(sn[f]) * np.abs(s)
        shapes, w = facet_points(ref.dim, p[f], gauss)
        pmag = ws * np.abs(s) @ np.abs(u) + gam * np.max(np.abs(ref.un[f] @ u)
                                                          + np.abs(ref.gap[f]))
        for phi, wq in zip(shapes, w):
            pq = phi @ p[f]
            if pq < 0:
                p_theta = theta * ws * s - gam * (phi @ ref.un[f])
                b += meas * wq / gam * pq * p_theta
        scale += meas / gam * pmag * (ws * np.abs(s) + gam * np.abs(ref.un[f]).sum(axis=0))
    return b, p, scale


CASES = [(dim, variant) for dim in (1, 2, 3) for variant in VARIANTS[dim]]


@pytest.mark.parametrize("dim, variant", CASES)
def test_residual_is_the_formula_on_cut_facets(dim, variant, tmp_path):
    scene, mesh_keys, normal, point = scene_for(dim, "newmark_0.25_0.5", "consistent",
                                                variant)
    keys = CONTACT[variant]
    theta = keys.get("theta", 0)
    penalty = keys["method"] == "penalty"
    gauss = keys.get("quad_points", 0)
    with warns_as_designed(scene):
        run = Stepper(scene, tmp_path / "run")
    with run:
        k = run.matrix("K")
        node, comp = run.dof_map()
        ref = ContactReference(dim, mesh_keys, scene.get("material.young"),
                               scene.get("material.poisson"), scene.get("contact.gamma0"),
                               normal, point, (node, comp), run.dofs)
        n = np.asarray(normal[:dim], dtype=float)
        n /= np.linalg.norm(n)
        rng = np.random.default_rng(2)
        x = load_mesh(dim=dim, **mesh_keys)["x"][node, :dim]
        # a translation into the obstacle, a small strain (so sigma_n is not zero) and noise
        u = ((DEPTH[dim] + 0.01 * x[:, -1]) * n[comp]
             + 1e-4 * rng.standard_normal(comp.shape))
        b, active = run.eval_b(u)
    expected, p, scale = formula_contact(ref, u, theta, penalty, gauss)
    if dim > 1:
        negative = np.sum(p < 0, axis=1)
        cut = (negative > 0) & (negative < dim)
        assert np.any(cut) and not np.all(cut), negative
        assert np.any(negative == dim), negative       # fully active facets too
    else:
        assert active == 1
    contact = b - k @ u
    err = float(np.max(np.abs(contact - expected)) / np.max(scale))
    share = float(np.max(np.abs(contact)) / np.max(np.abs(b)))
    print(f"{dim}D {variant}: active {active}, contact part {share:.2f} of |B|, "
          f"max |(B - K u) - formula| / scale = {err:.1e}")
    assert share > 0.1        # the contact part is not lost beside K u
    assert err <= THR


@pytest.mark.parametrize("dim, variant", [(dim, v) for dim in (1, 2, 3)
                                          for v in ("nitsche1", "nitsche0", "nitsche-1",
                                                    "penalty")])
def test_k_theta_is_k_less_the_theta_term(dim, variant, tmp_path):
    """The linear part the schemes factorize and carry, K_theta = K - theta sum_f |F| /
    gamma_N s_f s_f^T (the theta-term of a_theta; penalty: K), against that sum written
    from the mesh, to round-off (measured <= 1.9e-16 of |K_theta|): symmetric for every
    theta."""
    scene, mesh_keys, normal, point = scene_for(dim, "newmark_0.25_0.5", "consistent",
                                                variant)
    theta = 0 if variant == "penalty" else CONTACT[variant]["theta"]
    with warns_as_designed(scene):
        run = Stepper(scene, tmp_path / "run")
    with run:
        k, k_theta = run.matrix("K"), run.matrix("K_theta")
        ref = ContactReference(dim, mesh_keys, scene.get("material.young"),
                               scene.get("material.poisson"), scene.get("contact.gamma0"),
                               normal, point, run.dof_map(), run.dofs)
    expected = k - theta * np.einsum("f,fi,fj->ij", ref.measure / ref.gamma, ref.s, ref.s)
    err = float(np.max(np.abs(k_theta - expected)) / np.max(np.abs(k_theta)))
    print(f"{dim}D {variant}: |K_theta - formula| / |K_theta| = {err:.1e}")
    assert err <= THR
    assert np.max(np.abs(k_theta - k_theta.T)) <= THR * np.max(np.abs(k_theta))
    if theta:
        assert np.max(np.abs(k_theta - k)) > 1e-3 * np.max(np.abs(k))   # the term is there
