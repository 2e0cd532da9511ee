"""The core's assembled matrices (the ones a run uses, dyncontact.core.Stepper.matrix, with
its own dof numbering) against the continuum, on a free body (no clamped boundary, no
contact) in 1D, 2D and 3D. tests/test_fe.py and tests/test_tet.py check the element
kernels and a numpy assembly of them; these check the global assembly and dof map.

- K's null space is exactly the rigid motions: 1 in 1D, 3 in 2D, 6 in 3D eigenvalues are
  round-off (observed |lambda| <= 9e-17 of the largest), the next is a real mode (observed
  >= 3e-3 of the largest: the bars are 0.3 long, the rigid modes and the lowest bending
  one are well apart), and K r = 0 for each rigid motion r written from the nodes
  (observed <= 6e-17 of |K| |r|).
- The patch test: a linear field u = A x + c gives zero force at the interior nodes
  (observed <= 4.4e-14 of the largest nodal force) and the energy 1/2 u.K u =
  |Omega| sigma : eps / 2 of its constant strain (plane strain in 2D, sigma = E u' in 1D
  with a unit cross-section), observed to 9.4e-15 relative.
- The consistent and the lumped mass both carry rho |Omega| per component, and the first
  moments rho int x (observed to 2.2e-16 relative), with no coupling between components.
THR = 1e-12 (about 4500 eps) bounds round-off of sums over a few hundred entries; the
gap to the first elastic mode is asserted at 1e-4, 30 times below the observed one.
"""

from __future__ import annotations

import numpy as np
import pytest

import dyncontact
from dyncontact.core import DyncontactWarning, Stepper, load_mesh

from conftest import lame

THR = 1e-12
FIRST_MODE_GAP = 1e-4
LENGTH, WIDTH, H = 0.3, 0.1, 0.05
YOUNG, POISSON, RHO = 0.7, 0.3, 1.3
RIGID_MODES = {1: 1, 2: 3, 3: 6}


def free_body(dim, mass):
    s = dyncontact.Scene()
    s.set("mesh.dim", dim)
    s.set("mesh.h", H)
    s.set("mesh.length", LENGTH)
    if dim > 1:
        s.set("mesh.width", WIDTH)
    s.set("boundary.clamped", "")
    s.set("boundary.contact", "")
    s.set("material.young", YOUNG)
    s.set("material.poisson", POISSON)
    s.set("material.density", RHO)
    s.set("initial.kind", "rest")
    s.set("scheme.name", "newmark")
    s.set("scheme.mass", mass)
    s.set("scheme.t_end", 0.0)
    return s


def matrices(dim, mass, out):
    """(K, M, x) with x the coordinates of each dof's node, (dofs, dim), and comp."""
    with pytest.warns(DyncontactWarning, match="no contact boundary"):
        run = Stepper(free_body(dim, mass), out)
    with run:
        k, m = run.matrix("K"), run.matrix("M")
        node, comp = run.dof_map()
    x = load_mesh("", dim=dim, length=LENGTH, width=WIDTH, h=H)["x"][:, :dim]
    return k, m, x[node], comp


def rigid_motions(dim, xd, comp):
    """The rigid motions as dof vectors: translations, then rotations e_a x - e_b y."""
    modes = [(comp == k).astype(float) for k in range(dim)]
    for a, b in ((0, 1), (1, 2), (0, 2))[: RIGID_MODES[dim] - dim]:
        modes.append(np.where(comp == a, -xd[:, b], 0.0) + np.where(comp == b, xd[:, a], 0.0))
    return modes


@pytest.mark.parametrize("dim", [1, 2, 3])
def test_stiffness_null_space_is_the_rigid_motions(dim, tmp_path):
    k, _, xd, comp = matrices(dim, "consistent", tmp_path / "r")
    assert len(comp) == k.shape[0] and np.array_equal(np.unique(comp), np.arange(dim))
    eig = np.linalg.eigvalsh(k)
    top = eig[-1]
    n0 = RIGID_MODES[dim]
    assert np.max(np.abs(eig[:n0])) <= THR * top, eig[:n0 + 1] / top
    assert eig[n0] >= FIRST_MODE_GAP * top, eig[n0] / top
    for r in rigid_motions(dim, xd, comp):
        assert np.linalg.norm(k @ r) <= THR * top * np.linalg.norm(r)


@pytest.mark.parametrize("dim", [1, 2, 3])
def test_patch_test_through_the_assembled_stiffness(dim, tmp_path):
    k, _, xd, comp = matrices(dim, "consistent", tmp_path / "p")
    lam, mu = lame(YOUNG, POISSON)
    lo, hi = xd.min(axis=0), xd.max(axis=0)
    interior = np.all((xd > lo + 1e-9) & (xd < hi - 1e-9), axis=1)
    assert interior.sum() >= dim      # interior dofs exist (1D: the inner nodes)
    volume = np.prod(hi - lo)
    rng = np.random.default_rng(4)
    for _ in range(3):
        a, c = rng.normal(size=(dim, dim)), rng.normal(size=dim)
        u = np.einsum("ij,ij->i", xd @ a.T + c, np.eye(dim)[comp])
        f = k @ u
        assert np.max(np.abs(f[interior])) <= THR * np.max(np.abs(f))
        eps = 0.5 * (a + a.T)
        if dim == 1:
            energy = 0.5 * YOUNG * eps[0, 0] ** 2 * volume
        else:     # plane strain in 2D: the same law on the in-plane strains
            sig = lam * np.trace(eps) * np.eye(dim) + 2 * mu * eps
            energy = 0.5 * np.sum(sig * eps) * volume
        assert 0.5 * u @ k @ u == pytest.approx(energy, rel=THR)


@pytest.mark.parametrize("mass", ["consistent", "lumped"])
@pytest.mark.parametrize("dim", [1, 2, 3])
def test_mass_carries_the_mass_and_first_moments(dim, mass, tmp_path):
    _, m, xd, comp = matrices(dim, mass, tmp_path / "m")
    lo, hi = xd.min(axis=0), xd.max(axis=0)
    volume = np.prod(hi - lo)
    for a in range(dim):
        one = (comp == a).astype(float)
        assert one @ m @ one == pytest.approx(RHO * volume, rel=THR)
        for b in range(dim):   # rho int x_b = rho |Omega| (centre)_b over the box
            moment = one @ m @ np.where(comp == a, xd[:, b], 0.0)
            assert moment == pytest.approx(RHO * volume * 0.5 * (lo[b] + hi[b]), rel=THR,
                                           abs=THR * RHO * volume)
        for b in range(dim):
            if b != a:     # no coupling between components
                assert np.all(m[np.ix_(comp == a, comp == b)] == 0.0)
