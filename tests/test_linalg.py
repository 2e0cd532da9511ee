"""UMFPACK through the f2py boundary: dyncontact._core.dc_umf_solve (1-based COO in)
against dense numpy solves, and its error reporting (singular, bad indices); the solver
choice of linear_solver (CHOLMOD LDLᵀ or UMFPACK LU) through dc_ls_solve.

The Fortran-level unit tests of the same modules are tests/fortran/test_sparse.f90,
test_umfpack.f90, test_cholmod.f90 and test_vtk_output.f90 (meson test()).
"""

from __future__ import annotations

import contextlib

import numpy as np
import pytest

from dyncontact import _core, core

#: relative accuracy of a UMFPACK solve (no iterative refinement) of the well-conditioned
#: systems below, against numpy's dense LU
RTOL_SOLVE = 1e-12

STAT_OK, STAT_BAD_INPUT, STAT_NUMERIC = 0, 2, 3


def _msg(errmsg) -> str:
    if isinstance(errmsg, bytes):
        errmsg = errmsg.decode("utf-8", "replace")
    return str(errmsg).strip().strip("\x00").strip()


def umf_solve_1based(rows, cols, vals, b):
    """Call dc_umf_solve with 1-based COO, arrays cast once (f2py must not copy)."""
    rows = np.ascontiguousarray(rows, dtype=np.int32)
    cols = np.ascontiguousarray(cols, dtype=np.int32)
    vals = np.ascontiguousarray(vals, dtype=np.float64)
    b = np.ascontiguousarray(b, dtype=np.float64)
    x, stat, errmsg = _core.dc_umf_solve(rows, cols, vals, b, b.shape[0], rows.shape[0])
    return x, int(stat), _msg(errmsg)


def assert_matches_dense(x, dense, b, rtol=RTOL_SOLVE, err_msg=""):
    """x agrees with numpy's dense solve of dense x = b to rtol times its largest entry
    (an absolute bound, the same for every entry)."""
    x_ref = np.linalg.solve(dense, b)
    np.testing.assert_allclose(x, x_ref, rtol=0, atol=rtol * np.abs(x_ref).max(),
                               err_msg=err_msg)


def assert_umf_solves(rows, cols, vals, b, dense, err_msg=""):
    """dc_umf_solve of the 1-based COO system succeeds and matches the dense solve."""
    x, stat, msg = umf_solve_1based(rows, cols, vals, b)
    assert stat == STAT_OK, msg
    assert_matches_dense(x, dense, b, err_msg=err_msg)


def every_size_and_density(test):
    """Parametrize test over n in (1, 2, 17, 100, 400) and density in (0.01, 0.05, 0.3),
    every pair (ids 'density-n')."""
    test = pytest.mark.parametrize("density", [0.01, 0.05, 0.3])(test)
    return pytest.mark.parametrize("n", [1, 2, 17, 100, 400])(test)


def random_coo(rng, n, density, dominance=1.0):
    """Non-symmetric sparse n x n system as shuffled 1-based COO with duplicates.

    Off-diagonal pattern at the given density, every diagonal entry present, values
    split into several duplicate triplets (and a few entries that cancel to exact 0),
    diagonal shifted to make the matrix diagonally dominant (well conditioned).
    Returns (rows, cols, vals, dense).
    """
    nnz_off = max(1, int(density * n * n))
    r = rng.integers(0, n, nnz_off)
    c = rng.integers(0, n, nnz_off)
    v = rng.uniform(-1.0, 1.0, nnz_off)
    dense = np.zeros((n, n))
    np.add.at(dense, (r, c), v)
    diag = np.abs(dense).sum(axis=1) + dominance
    r = np.concatenate([r, np.arange(n)])
    c = np.concatenate([c, np.arange(n)])
    v = np.concatenate([v, diag - np.diag(dense)])
    dense[np.arange(n), np.arange(n)] = diag
    # split every value into 1..3 duplicates
    reps = rng.integers(1, 4, r.size)
    r = np.repeat(r, reps)
    c = np.repeat(c, reps)
    v = np.repeat(v / reps, reps)
    # explicit entries that cancel (kept as stored zeros by csc_from_coo)
    k = rng.integers(0, n, 3)
    l = rng.integers(0, n, 3)
    r = np.concatenate([r, k, k])
    c = np.concatenate([c, l, l])
    v = np.concatenate([v, np.full(3, 0.5), np.full(3, -0.5)])
    perm = rng.permutation(r.size)
    return r[perm] + 1, c[perm] + 1, v[perm], dense


@every_size_and_density
def test_umf_solve_matches_dense(n, density):
    rng = np.random.default_rng(1000 * n + int(100 * density))
    rows, cols, vals, dense = random_coo(rng, n, density)
    for _ in range(2):                     # two right-hand sides
        b = rng.standard_normal(n)
        assert_umf_solves(rows, cols, vals, b, dense, err_msg=f"n={n} density={density}")


def test_umf_solve_weak_diagonal():
    """Not diagonally dominant (pivoting matters), still well conditioned."""
    rng = np.random.default_rng(7)
    n = 200
    rows, cols, vals, dense = random_coo(rng, n, 0.05, dominance=1.0)
    # permute the rows of the system: the large entries leave the diagonal
    p = rng.permutation(n)
    inv = np.empty(n, dtype=int)
    inv[p] = np.arange(n)
    rows = inv[rows - 1] + 1
    dense = dense[p]
    b = rng.standard_normal(n)
    assert_umf_solves(rows, cols, vals, b, dense)


def test_grid_operator_2d():
    """5-point Laplacian with a drift term (non-symmetric) on a 30 x 30 grid."""
    m = 30
    n = m * m
    weights = {(0, 0): 4.5, (1, 0): -1.2, (-1, 0): -0.8, (0, 1): -1.0, (0, -1): -1.0}
    r, c, v = [], [], []
    for i in range(m):
        for j in range(m):
            for (di, dj), w in weights.items():
                if 0 <= i + di < m and 0 <= j + dj < m:
                    r.append(i * m + j)
                    c.append((i + di) * m + j + dj)
                    v.append(w)
    r, c, v = np.array(r), np.array(c), np.array(v)
    dense = np.zeros((n, n))
    np.add.at(dense, (r, c), v)
    b = np.random.default_rng(3).standard_normal(n)
    assert_umf_solves(r + 1, c + 1, v, b, dense)


def test_singular_matrix_reported():
    # rank 2: column 3 = column 1 + column 2
    rows = np.array([1, 2, 2, 3, 1, 2, 3])
    cols = np.array([1, 1, 2, 2, 3, 3, 3])
    vals = np.array([1.0, 1.0, 1.0, 1.0, 1.0, 2.0, 1.0])
    _, stat, msg = umf_solve_1based(rows, cols, vals, np.ones(3))
    assert stat == STAT_NUMERIC
    assert "singular" in msg.lower(), msg


def test_structurally_singular_matrix_reported():
    # column 3 empty
    _, stat, msg = umf_solve_1based([1, 2, 1], [1, 2, 2], [1.0, 1.0, 3.0], np.ones(3))
    assert stat == STAT_NUMERIC
    assert "singular" in msg.lower(), msg


@pytest.mark.parametrize("rows, cols", [([1, 4], [1, 2]), ([1, 2], [0, 2]),
                                        ([-1, 2], [1, 2]), ([1, 2], [1, 5])])
def test_index_out_of_range_reported(rows, cols):
    _, stat, msg = umf_solve_1based(rows, cols, [1.0, 1.0], np.ones(3))
    assert stat == STAT_BAD_INPUT
    assert "out of range" in msg, msg


def test_python_wrapper_0based_and_exceptions():
    """dyncontact.core.umf_solve: 0-based COO, stat mapped to exceptions."""
    rng = np.random.default_rng(11)
    rows, cols, vals, dense = random_coo(rng, 50, 0.1)
    b = rng.standard_normal(50)
    assert_matches_dense(core.umf_solve(rows - 1, cols - 1, vals, b), dense, b)
    with pytest.raises(core.NumericalError, match="singular"):
        core.umf_solve([0, 1], [0, 0], [1.0, 1.0], np.ones(2))
    with pytest.raises(core.BadInputError, match="out of range"):
        core.umf_solve([0, 2], [0, 1], [1.0, 1.0], np.ones(2))


# ---------------------------------------------------------------------------------------
# linear_solver: CHOLMOD LDLᵀ for symmetric positive definite matrices,
# UMFPACK LU for the rest, through dyncontact._core.dc_ls_solve.

def ls_solve_1based(rows, cols, vals, b):
    """Call dc_ls_solve with 1-based COO; returns (x, backend, stat, message)."""
    rows = np.ascontiguousarray(rows, dtype=np.int32)
    cols = np.ascontiguousarray(cols, dtype=np.int32)
    vals = np.ascontiguousarray(vals, dtype=np.float64)
    b = np.ascontiguousarray(b, dtype=np.float64)
    x, backend, stat, errmsg = _core.dc_ls_solve(rows, cols, vals, b, b.shape[0], rows.shape[0])
    return x, _msg(backend), int(stat), _msg(errmsg)


def assert_ls_solves(rows, cols, vals, b, dense, backend, rtol=RTOL_SOLVE):
    """dc_ls_solve of the 1-based COO system succeeds on `backend` and matches the dense
    solve to rtol (see assert_matches_dense)."""
    x, got, stat, msg = ls_solve_1based(rows, cols, vals, b)
    assert stat == STAT_OK, msg
    assert got == backend
    assert_matches_dense(x, dense, b, rtol)


def symmetric_coo(rng, n, density, shift):
    """Symmetric sparse n x n matrix S + Sᵀ + shift I (diagonal always stored) as shuffled
    1-based COO with duplicates; shift > Gershgorin radius: positive definite, shift <
    -radius: negative definite, shift = 0: in general indefinite. Returns (rows, cols,
    vals, dense)."""
    nnz_off = max(1, int(density * n * n / 2))
    r = rng.integers(0, n, nnz_off)
    c = rng.integers(0, n, nnz_off)
    v = rng.uniform(-1.0, 1.0, nnz_off)
    r, c, v = np.concatenate([r, c, np.arange(n)]), np.concatenate([c, r, np.arange(n)]), \
        np.concatenate([v, v, np.full(n, shift)])
    dense = np.zeros((n, n))
    np.add.at(dense, (r, c), v)
    perm = rng.permutation(r.size)
    return r[perm] + 1, c[perm] + 1, v[perm], dense


@every_size_and_density
def test_ls_solve_spd_uses_cholmod(n, density):
    rng = np.random.default_rng(2000 * n + int(100 * density))
    rows, cols, vals, dense = symmetric_coo(rng, n, density, shift=0.0)
    shift = np.abs(dense).sum(axis=1).max() + 1.0      # above the Gershgorin radius: SPD
    rows = np.concatenate([rows, np.arange(1, n + 1)])  # as duplicate diagonal triplets
    cols = np.concatenate([cols, np.arange(1, n + 1)])
    vals = np.concatenate([vals, np.full(n, shift)])
    dense = dense + shift * np.eye(n)
    b = rng.standard_normal(n)
    assert_ls_solves(rows, cols, vals, b, dense, "cholmod_ldlt")


def test_ls_solve_indefinite_symmetric_falls_back_exactly():
    """Symmetric but indefinite (LDLᵀ meets a negative pivot): UMFPACK solves it, to the
    same accuracy as a dense solve."""
    rng = np.random.default_rng(21)
    n = 300
    rows, cols, vals, dense = symmetric_coo(rng, n, 0.05, shift=0.0)
    eig = np.linalg.eigvalsh(dense)
    assert eig.min() < 0 < eig.max()                   # really indefinite
    cond = np.linalg.cond(dense)
    assert cond < 1e6
    b = rng.standard_normal(n)
    assert_ls_solves(rows, cols, vals, b, dense, "umfpack_lu",
                     rtol=cond * np.finfo(float).eps * 10)


def test_ls_solve_negative_definite_falls_back():
    # the first pivot is already negative
    rng = np.random.default_rng(22)
    rows, cols, vals, dense = symmetric_coo(rng, 60, 0.1, shift=-30.0)
    assert np.linalg.eigvalsh(dense).max() < 0
    b = rng.standard_normal(60)
    assert_ls_solves(rows, cols, vals, b, dense, "umfpack_lu")


def test_ls_solve_nonsymmetric_uses_umfpack():
    rng = np.random.default_rng(23)
    rows, cols, vals, dense = random_coo(rng, 200, 0.05)
    assert not np.allclose(dense, dense.T)
    b = rng.standard_normal(200)
    assert_ls_solves(rows, cols, vals, b, dense, "umfpack_lu")


def test_ls_solve_slightly_nonsymmetric_uses_umfpack():
    """An SPD matrix with one off-diagonal pair differing in the 10th digit is not
    symmetric for the solver (far above assembly round-off): LU, exact solve."""
    rows = np.array([1, 2, 3, 1, 2, 2, 3])
    cols = np.array([1, 2, 3, 2, 1, 3, 2])
    vals = np.array([4.0, 4.0, 4.0, 1.0, 1.0 + 1e-10, 1.0, 1.0])
    dense = np.zeros((3, 3))
    np.add.at(dense, (rows - 1, cols - 1), vals)
    x, backend, stat, msg = ls_solve_1based(rows, cols, vals, np.ones(3))
    assert stat == STAT_OK, msg
    assert backend == "umfpack_lu"
    np.testing.assert_allclose(x, np.linalg.solve(dense, np.ones(3)), rtol=RTOL_SOLVE)


def test_ls_solve_singular_symmetric_reported():
    # symmetric, rank 2: row 3 = row 1 + row 2
    dense = np.array([[2.0, 1.0, 3.0], [1.0, 2.0, 3.0], [3.0, 3.0, 6.0]])
    r, c = np.nonzero(dense)
    _, backend, stat, msg = ls_solve_1based(r + 1, c + 1, dense[r, c], np.ones(3))
    assert stat == STAT_NUMERIC
    assert "singular" in msg.lower(), msg
    assert backend == ""


def test_linear_solve_python_wrapper():
    rng = np.random.default_rng(24)
    rows, cols, vals, dense = symmetric_coo(rng, 40, 0.1, shift=50.0)
    b = rng.standard_normal(40)
    x, backend = core.linear_solve(rows - 1, cols - 1, vals, b)
    assert backend == "cholmod_ldlt"
    assert_matches_dense(x, dense, b)
    with pytest.raises(core.NumericalError, match="singular"):
        core.linear_solve([0, 1, 0, 1], [0, 1, 1, 0], [1.0, 1.0, 1.0, 1.0], np.ones(2))


# Which solver a run used: summary.json "solver" (SPEC section 4, docs/scenes.md).

def _short_run(tmp_path, scene_file, **keys):
    from dyncontact.scene import Scene
    from conftest import ROOT
    scn = Scene.read(str(ROOT / "scripts" / "scenes" / scene_file))
    for k, v in keys.items():
        scn.set(k.replace("__", "."), v)
    return core.run(scn, out=tmp_path, progress=False).summary


@pytest.mark.parametrize("scene_file, keys, solver", [
    ("bar2d_hht.nml", {}, "cholmod_ldlt"),                       # J0 = M + c K_θ, SPD
    ("bar2d_theta.nml", {}, "cholmod_ldlt"),
    ("bar2d_pc.nml", {}, "cholmod_ldlt"),                        # consistent M
    ("bar2d_pc.nml", {"scheme__mass": "lumped"}, "diagonal"),
    # (Nitsche θ = 1 with a small γ0, where K_θ and J0 turn indefinite, is refused when
    # the model is built (test below), so a run never reaches the UMFPACK fallback through
    # a scene; the fallback is tested on matrices: test_ls_solve_indefinite_... above)
    # θ = 0: K_θ = K, SPD
    ("bar2d_hht.nml", {"contact__gamma0": 0.01, "contact__theta": 0}, "cholmod_ldlt"),
    # θ = -1: K_θ stays symmetric (θ only scales the s sᵀ term), the non-symmetric
    # part of the tangent is in the Woodbury correction
    ("bar2d_hht.nml", {"contact__theta": -1}, "cholmod_ldlt"),
])
def test_summary_reports_solver(tmp_path, scene_file, keys, solver):
    # a gamma0 of 0.01 is small for the material: the run warns so (the case chosen here)
    small = keys.get("contact__gamma0") == 0.01
    with (pytest.warns(core.DyncontactWarning, match="gamma0 = 1.000E-002 is small")
          if small else contextlib.nullcontext()):
        s = _short_run(tmp_path, scene_file, scheme__t_end=0.01, **keys)
    assert s["solver"] == solver
    assert s["steps"] >= 1


def test_indefinite_k_theta_is_refused_before_any_solve(tmp_path):
    with pytest.raises(core.BadInputError, match="&contact gamma0"):
        _short_run(tmp_path, "bar2d_hht.nml", scheme__t_end=0.01, contact__gamma0=0.01)


# Which triangular solve ran with the factors: summary.json "solve_kernel" (docs/scenes.md).
# The 2D bars' J0 is made of 2x2 node blocks (every free node has two dofs), the 3D box's
# of 3x3 blocks: solved by blocks (ldl_solves); a 1D bar, or sliding sides (nodes with
# some dofs fixed), are not: cholmod_solve2. The numbers of both are checked against the GetFEM traces elsewhere.
@pytest.mark.parametrize("scene_file, keys, kernel", [
    ("bar2d_hht.nml", {}, "ldl_node_pairs"),
    ("bar2d_theta.nml", {}, "ldl_node_pairs"),
    ("bar2d_hht.nml", {"boundary__slip_x": "left,right"}, "cholmod_solve2"),
    ("bar1d.nml", {}, "cholmod_solve2"),
    ("bar2d_pc.nml", {}, "cholmod_solve2"),        # M's nodal scalar S, two right-hand sides
    ("bar2d_pc.nml", {"scheme__mass": "lumped"}, "diagonal"),
    ("bar3d_hht.nml", {}, "ldl_node_triples"),                          # 3x3 node blocks
    ("bar3d_hht.nml", {"boundary__slip_z": "sides"}, "cholmod_solve2"),  # nodes with two free dofs
])
def test_summary_reports_solve_kernel(tmp_path, scene_file, keys, kernel):
    s = _short_run(tmp_path, scene_file, scheme__t_end=0.01, **keys)
    assert s["solve_kernel"] == kernel
    assert s["steps"] >= 1
