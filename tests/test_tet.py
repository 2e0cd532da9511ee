"""P1 tetrahedron checks (3D isotropic elasticity): the element matrices against an
independent numpy formula, the six rigid-body modes as K's null space, the mass sums
and the patch test on a small assembled cube of tetrahedra.

3D: lambda = E nu / ((1 + nu)(1 - 2 nu)), mu = E / (2 (1 + nu)); dofs ordered
(x1, y1, z1, x2, ...)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from dyncontact.core import p1_element
from conftest import lame

#: Element matrices are a few flops from their entries: round-off relative to the
#: largest entry.
ELEMENT_TOL = 1e-13
#: A zero eigenvalue of K_e is zero up to round-off: relative to the largest one.
ZERO_EIG_TOL = 1e-12
#: Patch test: interior forces of an assembled linear field vanish to round-off,
#: relative to the largest nodal force.
PATCH_TOL = 1e-12

RNG = np.random.default_rng(2024)


def reference_tet(x, young, poisson, rho):
    """Independent P1 tetrahedron: K from the bilinear form
    a(u, v) = int lambda div u div v + 2 mu eps(u) : eps(v), consistent M, volume."""
    lam, mu = lame(young, poisson)
    T = np.vstack([np.ones(4), x])                  # rows: 1, x, y, z
    grads = np.linalg.inv(T)[:, 1:]                 # row a = grad phi_a
    vol = abs(np.linalg.det(T)) / 6
    K = np.zeros((12, 12))
    for a in range(4):
        for b in range(4):
            ga, gb = grads[a], grads[b]
            blk = lam * np.outer(ga, gb) + mu * np.outer(gb, ga) + mu * (ga @ gb) * np.eye(3)
            K[3 * a:3 * a + 3, 3 * b:3 * b + 3] = vol * blk
    Ms = rho * vol / 20 * (np.ones((4, 4)) + np.eye(4))
    M = np.kron(Ms, np.eye(3))
    return K, M, vol


def random_tet(orientation):
    while True:
        x = RNG.uniform(-1, 1, (3, 4))
        vol = np.linalg.det(np.vstack([np.ones(4), x])) / 6
        if abs(vol) > 0.05:
            break
    if np.sign(vol) != orientation:
        x[:, [1, 2]] = x[:, [2, 1]]
    return x


def rigid_modes(x):
    """The six rigid-body modes: three translations, three rotations."""
    modes = []
    for k in range(3):
        t = np.zeros((3, 4))
        t[k] = 1
        modes.append(t.T.ravel())
    for axis in np.eye(3):
        modes.append(np.cross(axis, x.T).ravel())
    return np.array(modes).T


@pytest.mark.parametrize("orientation", [1, -1])
@pytest.mark.parametrize("young,poisson,rho", [(2 / 3, 1 / 3, 1.0), (210e9, 0.3, 7850.0),
                                              (1.0, 0.0, 2.5)])
def test_tet_matrices_match_independent_formula(orientation, young, poisson, rho):
    x = random_tet(orientation)
    ke, me, ml = p1_element(3, x, young, poisson, rho)
    K, M, vol = reference_tet(x, young, poisson, rho)
    np.testing.assert_allclose(ke, K, rtol=0, atol=ELEMENT_TOL * abs(K).max())
    np.testing.assert_allclose(me, M, rtol=0, atol=ELEMENT_TOL * abs(M).max())
    np.testing.assert_allclose(ml, np.diag(M.sum(axis=1)), rtol=0,
                               atol=ELEMENT_TOL * abs(M).max())


@pytest.mark.parametrize("orientation", [1, -1])
def test_tet_stiffness_null_space_is_the_six_rigid_modes(orientation):
    x = random_tet(orientation)
    ke, _, _ = p1_element(3, x, 2 / 3, 1 / 3, 1.0)
    np.testing.assert_allclose(ke, ke.T, rtol=0, atol=ELEMENT_TOL * abs(ke).max())
    eig = np.linalg.eigvalsh(ke)
    assert np.all(abs(eig[:6]) <= ZERO_EIG_TOL * eig[-1])
    assert np.all(eig[6:] > 1e-6 * eig[-1])
    R = rigid_modes(x)
    assert np.linalg.matrix_rank(R) == 6
    assert abs(ke @ R).max() <= ZERO_EIG_TOL * eig[-1] * abs(R).max()


@pytest.mark.parametrize("orientation", [1, -1])
def test_tet_mass_sums_to_rho_volume_per_component(orientation):
    x = random_tet(orientation)
    rho = 2.5
    _, me, ml = p1_element(3, x, 2 / 3, 1 / 3, rho)
    vol = abs(np.linalg.det(np.vstack([np.ones(4), x]))) / 6
    for m in (me, ml):
        for k in range(3):
            idx = np.arange(k, 12, 3)
            assert m[np.ix_(idx, idx)].sum() == pytest.approx(rho * vol, rel=1e-14)
        # no coupling between components
        assert m[0::3, 1::3].max() == 0 and m[0::3, 2::3].max() == 0


def cube_mesh(n):
    """[0,1]^3 in n^3 cubes, each split into the 6 tetrahedra around its main diagonal
    (nodes (0,0,0) and (1,1,1) of the cube) - an independent mesh for the patch test."""
    g = np.linspace(0, 1, n + 1)
    nodes = np.array([[x, y, z] for z in g for y in g for x in g])
    idx = lambda i, j, k: i + (n + 1) * (j + (n + 1) * k)
    tets = []
    for i, j, k in itertools.product(range(n), repeat=3):
        c = [idx(i + a, j + b, k + d) for d in (0, 1) for b in (0, 1) for a in (0, 1)]
        # vertices by bits (a, b, d): paths 0 -> 7 along the three axes in every order
        for perm in itertools.permutations((1, 2, 4)):
            p = [0]
            for s in perm:
                p.append(p[-1] + s)
            tets.append([c[q] for q in p])
    return nodes, np.array(tets)


def test_patch_test_3d_linear_fields():
    """Any linear field u = A x + c: the assembled forces K u vanish at interior nodes and
    the energy is |Omega| sigma : eps / 2 with the constant strain of A."""
    young, poisson = 2 / 3, 1 / 3
    lam, mu = lame(young, poisson)
    nodes, tets = cube_mesh(3)
    nn = len(nodes)
    K = np.zeros((3 * nn, 3 * nn))
    for t in tets:
        ke, _, _ = p1_element(3, nodes[t].T, young, poisson, 1.0)
        dofs = (3 * t[:, None] + np.arange(3)).ravel()
        K[np.ix_(dofs, dofs)] += ke
    interior = np.all((nodes > 1e-12) & (nodes < 1 - 1e-12), axis=1)
    assert interior.sum() == 8
    for _ in range(3):
        A = RNG.normal(size=(3, 3))
        c = RNG.normal(size=3)
        u = (nodes @ A.T + c).ravel()
        f = (K @ u).reshape(nn, 3)
        assert abs(f[interior]).max() <= PATCH_TOL * abs(f).max()
        eps = 0.5 * (A + A.T)
        sig = lam * np.trace(eps) * np.eye(3) + 2 * mu * eps
        assert 0.5 * u @ K @ u == pytest.approx(0.5 * np.sum(sig * eps), rel=1e-12)


def test_tet_degenerate_is_reported_by_zero_volume():
    """A flat tetrahedron has zero volume: its mass is zero (the mesh check refuses it)."""
    x = np.array([[0, 1, 0, 1], [0, 0, 1, 1], [0, 0, 0, 0]], dtype=float)
    _, me, _ = p1_element(3, x, 1.0, 0.0, 1.0)
    assert abs(me).max() == 0
