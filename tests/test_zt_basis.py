"""Z T of the contact correction applied on the node basis against Z T on the contact-cell
dofs (fortran/schemes/implicit_schemes.f90, apply_zt_basis; contact_columns' basis
columns).

A Newton step's correction T (on the contact-cell dofs) is a sum of contact residuals
C(x') − C(x), tangent terms D dx and Woodbury corrections, each a combination of the
vectors s_f (a facet's σ_n row) and n_j (the obstacle's normal on the dofs of a facet
node): C = Σ_f M_θ,f g_f with M_θ,f(:, j) = θ s_f − γ_f n_j (contact_eval's rg), a term's
U column is M_θ,f ca (its tca), the node basis' correction is B qs. The schemes carry T's
coefficients τ on [s_f, n_j] beside T and apply Z T = Σ_k τ_k Z b_k with the kept columns
Z s_f and Z n_j (one a vector instead of one a dof); the rows of dx on the contact-cell
dofs are the Newton's own P dx. DYNCONTACT_ZT_BASIS=dofs applies Z T on the dofs: the
reference.

The two forms of Z T are equal in exact arithmetic (B τ = T), so the states after a step
differ by round-off, and after the next step's Newton by at most what its test leaves
free: the relative residual 1e-10 of the step's scale. So every trace column must agree
within 1e-10 of its largest magnitude (observed: at most 5.8e-13 on these windows; the
seed at h = 0.01 to T = 15, 30 000 steps and five impacts, 5.7e-10 in v_n, growing at each
impact), and the active
counts and the Newton iterations must be the same at every row, for every implicit scheme
and mass (each forms T through the same Newton, with its own c and right-hand side; the
redistributed mass makes the contact dofs massless), in 3D (the
Woodbury system on the node basis) and 2D (on the terms), Nitsche with θ = 1, 0, −1 and
penalty contact (s_f = 0), with a normal off the axes, and the ball (its patch grows at
nearly every step: new basis vectors at most steps). The traces must not be equal bit
for bit: the basis was used; but where T lies on the n_j alone (θ = 0, penalty) and each
n_j is one dof (a normal along an axis) the basis is no smaller than T's dofs and is not
taken: there they must be equal bit for bit."""

from __future__ import annotations

import contextlib

import numpy as np
import pytest

from dyncontact.core import DyncontactWarning

from test_woodbury_reuse import (IMPLICIT, assert_traces_agree, ball, bar2d, bar3d, box,
                                 run_with_env)

ENV = "DYNCONTACT_ZT_BASIS"
#: the Newton test's relative tolerance (see the module docstring)
TOL = 1e-10


def bar2d_method(theta: int | None = None, method: str | None = None):
    s = bar2d("exact")
    if theta is not None:
        s.set("contact.theta", theta)
    if method is not None:
        s.set("contact.method", method)
    return s


@pytest.mark.parametrize("mass", ["consistent", "lumped", "redistributed"])
@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("scheme", IMPLICIT)
def test_zt_on_the_basis_gives_the_dofs_traces_for_every_implicit_scheme(
        monkeypatch, tmp_path, scheme, dim, mass):
    s = box() if dim == 3 else bar2d("exact")
    s.set("scheme.name", scheme)
    s.set("scheme.mass", mass)
    s.set("scheme.t_end", 1.6)
    basis = run_with_env(monkeypatch, ENV, None, s, tmp_path / "basis")
    dofs = run_with_env(monkeypatch, ENV, "dofs", s, tmp_path / "dofs")
    assert_traces_agree(f"{scheme} {dim}D {mass}", basis, dofs, TOL)


def tilted(s, dim: int = 3):
    """s with the obstacle's normal off the axes: n_j has an entry on each dof of node j."""
    s.set("contact.obstacle_normal", "0.1, 0.2, -1.0" if dim == 3 else "0.2, -1.0")
    return s


SCENES = {
    "box3d_theta0_tilted": lambda: tilted(box(0)),
    "box3d_tilted": lambda: tilted(box()),
    "bar2d_penalty_tilted": lambda: tilted(bar2d_method(method="penalty"), 2),
    "box3d_theta-1": lambda: box(-1),
    "bar2d_theta-1": lambda: bar2d_method(theta=-1),
    "bar2d_gauss": lambda: bar2d("gauss"),
    "ball3d_exact": ball,
    "bar3d_gauss": lambda: bar3d("gauss"),
}
#: With theta = 0 and penalty contact T lies on the n_j alone (M_theta has no s_f part),
#: one dof a node for a normal along an axis: the basis has no fewer columns than T has
#: dofs, so Z T stays on the dofs, bit for bit.
UNUSED = {
    "box3d_theta0": lambda: box(0),
    "bar2d_theta0": lambda: bar2d_method(theta=0),
    "bar2d_penalty": lambda: bar2d_method(method="penalty"),
}


@pytest.mark.parametrize("name", sorted(SCENES) + sorted(UNUSED))
def test_zt_on_the_basis_gives_the_dofs_traces(monkeypatch, tmp_path, name):
    s = SCENES[name]() if name in SCENES else UNUSED[name]()
    s.set("scheme.t_end", min(float(s.get("scheme.t_end")), 1.6))
    # the tilted plane cuts a corner of the contact boundary: it starts inside (and warns)
    inside = name.endswith("_tilted")
    with (pytest.warns(DyncontactWarning, match="contact boundary starts inside the obstacle")
          if inside else contextlib.nullcontext()):
        basis = run_with_env(monkeypatch, ENV, None, s, tmp_path / "basis")
        dofs = run_with_env(monkeypatch, ENV, "dofs", s, tmp_path / "dofs")
    assert_traces_agree(name, basis, dofs, TOL, used=name in SCENES)


@pytest.mark.parametrize("dim", [2, 3])
def test_basis_columns_dropped_and_formed_again_give_the_same_traces(monkeypatch, tmp_path,
                                                                       dim):
    """The basis columns Z b_k are held in the column cache within its budget: with a
    budget of 0 MB every one not used at the current step is dropped and formed again
    when needed, from the same columns of Z by the same sums, so the traces are those of
    the default budget bit for bit."""
    s = box() if dim == 3 else bar2d("exact")
    s.set("scheme.t_end", 1.6)
    monkeypatch.delenv(ENV, raising=False)
    kept = run_with_env(monkeypatch, "DYNCONTACT_CONTACT_COLUMNS", None, s, tmp_path / "kept")
    dropped = run_with_env(monkeypatch, "DYNCONTACT_CONTACT_COLUMNS", "0", s, tmp_path / "zero")
    assert kept.trace["active"].max() > 0
    for col in kept.trace:
        np.testing.assert_array_equal(kept.trace[col], dropped.trace[col], err_msg=col)
