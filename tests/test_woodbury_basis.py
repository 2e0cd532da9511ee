"""The Woodbury system of the contact correction on the node basis against the same
system on the terms (fortran/schemes/implicit_schemes.f90, node_basis).

Every term of the contact tangent D = U Vᵀ lies on its facet's columns s_f − γ_f n_j
(θ s_f − γ_f n_j for U), with s_f the facet's σ_n row and n_j the obstacle's normal on the
dofs of facet node j, one vector a node whatever facet it is seen from: so D = B H Bᵀ with
B = [s_f of each facet, n_j of each facet node], and the Woodbury identity with U = B H,
V = B gives J⁻¹ through a system of order facets + nodes instead of the rank. The schemes
take it when that order is smaller than the rank (3D facets that share nodes; never in 1D
and 2D, where a facet adds at least as many basis vectors as terms).
DYNCONTACT_WOODBURY_BASIS=terms keeps the system on the terms: the reference.

Both runs solve each Newton step's same linear system (the two forms of J⁻¹ are equal in
exact arithmetic), so their Newton iterates differ by round-off, and the steps' states
by at most what the Newton test leaves free: the relative residual 1e-10 of the step's
scale. So every trace column must agree within 1e-10 of its largest magnitude (observed:
at most 5e-12, v_n and p_n on the box at h = 0.05 to T = 15), and the active counts and
the Newton iterations must be the same at every row. The traces must not be equal bit
for bit: the node basis was used (its round-off differs)."""

from __future__ import annotations

import pytest

from test_woodbury_reuse import assert_traces_agree, ball, bar3d, box, run_with_env

ENV = "DYNCONTACT_WOODBURY_BASIS"
#: the Newton test's relative tolerance (see the module docstring)
TOL = 1e-10


SCENES = {
    "box3d": box,
    "box3d_theta0": lambda: box(0),
    "box3d_theta-1": lambda: box(-1),
    "ball3d_exact": ball,
    "bar3d_gauss": lambda: bar3d("gauss"),
}


@pytest.mark.parametrize("name", sorted(SCENES))
def test_node_basis_gives_the_terms_traces(monkeypatch, tmp_path, name):
    s = SCENES[name]()
    nodes = run_with_env(monkeypatch, ENV, None, s, tmp_path / "nodes")
    terms = run_with_env(monkeypatch, ENV, "terms", s, tmp_path / "terms")
    assert_traces_agree(name, nodes, terms, TOL)
