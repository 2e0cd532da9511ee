"""The 2x2 block triangular solves on two threads (fortran/linalg/ldl_solves.f90,
pair_sweeps_two) equal the serial ones (pair_sweeps) to round-off, are the same run to
run, and a scene's trace does not depend on them (DYNCONTACT_THREADS, docs/scenes.md);
the same for the 3x3 block solves of node triples (triple_sweeps_two, 3D).

The two-thread solve does the serial solve's operations but for the forward updates of
the top separator's rows: the updates from the two subtrees are summed in two buffers
and added to b, instead of one after the other. That reorders sums of at most k terms,
k the entries of a row of L: a relative change of at most about k eps of the sum of
their magnitudes (Wilkinson), which the rest of the solve carries into x amplified at
most by kappa(A). On the test's grid (a fill-reducing ordering of a square grid: rows of
L hold O(sqrt(n_dofs)) entries; a shifted Laplacian with kappa <= KAPPA) that gives RTOL
below. On the 3D grid of the triples the rows of L hold O(n_dofs^(2/3)) entries (the
top separator, a plane of the cube): RTOL3 = 4 kappa n^(2/3) eps.
"""
from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from dyncontact import _core

#: Nodes per side of the test grid: 2 * 60^2 = 7200 dofs, under the size from which the
#: solves use two threads (20 000), hence the threshold lowered in the comparison.
SIDE = 60
#: kappa(A) of the grid matrix: kron(L + I, B), L's eigenvalues in [0, 8], B = [2 1; 1 2]
#: with eigenvalues 1 and 3: A's eigenvalues in [1, 27].
KAPPA = 27.0
#: 4 kappa sqrt(n) eps with n = 2 SIDE^2 (the row lengths of L, see the docstring).
RTOL = 4.0 * KAPPA * np.sqrt(2 * SIDE**2) * np.finfo(float).eps


def grid_blocks(side, dim, blk):
    """kron(L + I, blk) with L the (2 dim + 1)-point Laplacian of a side^dim grid
    (Dirichlet-like diagonal 2 dim): blk.shape[0] dofs a node, numbered by nodes,
    1-based COO (rows, cols, vals) and the size."""
    n = side**dim
    idx = np.arange(n).reshape((side,) * dim)
    r = [idx.ravel()]
    c = [idx.ravel()]
    v = [np.full(n, 2.0 * dim + 1.0)]
    for ax in range(dim):
        lo = tuple(slice(None, -1) if a == ax else slice(None) for a in range(dim))
        hi = tuple(slice(1, None) if a == ax else slice(None) for a in range(dim))
        a, b = idx[lo], idx[hi]
        r += [a.ravel(), b.ravel()]
        c += [b.ravel(), a.ravel()]
        v += [np.full(a.size, -1.0)] * 2
    r, c, v = np.concatenate(r), np.concatenate(c), np.concatenate(v)
    k = blk.shape[0]
    rows, cols, vals = [], [], []
    for i in range(k):
        for j in range(k):
            rows.append(k * r + i)
            cols.append(k * c + j)
            vals.append(v * blk[i, j])
    return (np.concatenate(rows) + 1, np.concatenate(cols) + 1, np.concatenate(vals), k * n)


def grid_pairs(side):
    """kron(L + I, B) with L the 5-point Laplacian of a side x side grid and B = [2 1;
    1 2]: two dofs a node (grid_blocks)."""
    return grid_blocks(side, 2, np.array([[2.0, 1.0], [1.0, 2.0]]))


#: Nodes per side of the 3D test grid: 3 * 16^3 = 12 288 dofs.
SIDE3 = 16
#: kappa(A) of the 3D grid matrix: kron(L + I, B3), L's eigenvalues in [0, 12], B3 =
#: [3 1 1; 1 3 1; 1 1 3] with eigenvalues 2, 2, 5: A's eigenvalues in [2, 65].
KAPPA3 = 32.5
#: 4 kappa n^(2/3) eps with n = 3 SIDE3^3 (the row lengths of L, see the docstring).
RTOL3 = 4.0 * KAPPA3 * (3 * SIDE3**3) ** (2.0 / 3.0) * np.finfo(float).eps


def grid_triples(side):
    """kron(L + I, B3) with L the 7-point Laplacian of a side^3 grid and B3 = [3 1 1;
    1 3 1; 1 1 3]: three dofs a node (grid_blocks)."""
    return grid_blocks(side, 3, np.ones((3, 3)) + 2.0 * np.eye(3))


def compare(b, grid=None):
    rows, cols, vals, n = grid or grid_pairs(SIDE)
    b = np.asfortranarray(b, dtype=np.float64)
    assert b.shape[0] == n
    xs, xt, split, kernel, stat, msg = _core.dc_ldl_threads_compare(
        rows.astype(np.int32), cols.astype(np.int32), vals, b)
    assert stat == 0, msg
    kernel = kernel.decode() if isinstance(kernel, bytes) else kernel
    return xs, xt, split, kernel.strip()


def assert_solves_agree(b, xs, xt, grid, rtol, kappa):
    """Every column of the two-thread solution xt equals the serial xs to rtol of its
    largest entry, and xt solves the grid's system (A x = b for the first column) to the
    serial solve's own accuracy, rtol times the condition bound kappa."""
    for j in range(b.shape[1]):
        diff = np.abs(xt[:, j] - xs[:, j]).max() / np.abs(xs[:, j]).max()
        assert diff <= rtol, (j, diff, rtol)
    rows, cols, vals, n = grid
    ax = np.zeros(n)
    np.add.at(ax, rows - 1, vals * xt[cols - 1, 0])
    assert np.abs(ax - b[:, 0]).max() <= rtol * np.abs(b[:, 0]).max() * kappa


def test_two_threads_equal_serial_to_round_off():
    rng = np.random.default_rng(7)
    n = 2 * SIDE**2
    b = rng.standard_normal((n, 5))
    xs, xt, split, kernel = compare(b)
    assert kernel == "ldl_node_pairs"
    nn, sa, ss = split
    # the two-thread path ran: two ranges of block columns and the separator after them
    assert nn == SIDE**2 and 0 < sa < ss - 1 and ss <= nn + 1, split
    assert_solves_agree(b, xs, xt, grid_pairs(SIDE), RTOL, KAPPA)


def test_two_threads_same_run_to_run():
    rng = np.random.default_rng(8)
    b = rng.standard_normal((2 * SIDE**2, 3))
    _, x1, _, _ = compare(b)
    _, x2, _, _ = compare(b)
    assert np.array_equal(x1, x2)


def assert_traces_agree(a, b):
    """Traces a and b of one run on one and on two threads: the same times (more than
    one), every column equal to 1e-12 of max(1, its largest magnitude)."""
    assert a["t"].shape == b["t"].shape and a["t"].size > 1
    for col in a:
        scale = max(1.0, np.abs(a[col]).max())
        assert np.abs(a[col] - b[col]).max() <= 1e-12 * scale, col


TRACE_SCRIPT = """
import sys
from pathlib import Path
import dyncontact
from dyncontact.scene import Scene
scn = Scene.read(Path(sys.argv[1]))
scn.set("scheme.t_end", 0.2)
dyncontact.run(scn, out=sys.argv[2], progress=False)
"""


def test_scene_trace_does_not_depend_on_threads(tmp_path):
    """bar2d_hht (J0 solved by 2x2 blocks each step) with every factor solved on two
    threads (threshold 0) and on one: the traces agree to 1e-12."""
    from conftest import ROOT
    import dyncontact
    traces = {}
    for threads in ("1", "2"):
        env = dict(os.environ, DYNCONTACT_THREADS=threads, DYNCONTACT_THREADS_MIN_DOFS="0")
        env.pop("PYTHONPATH", None)
        out = tmp_path / f"t{threads}"
        res = subprocess.run([sys.executable, "-c", TRACE_SCRIPT,
                              str(ROOT / "scripts" / "scenes" / "bar2d_hht.nml"), str(out)],
                             env=env, capture_output=True, text=True, timeout=600)
        assert res.returncode == 0, res.stderr
        traces[threads] = dyncontact.core.read_trace(out)
    assert_traces_agree(traces["1"], traces["2"])


def test_two_threads_equal_serial_to_round_off_3d():
    """The 3x3 node-block solve (ldl_node_triples) on two threads."""
    grid = grid_triples(SIDE3)
    n = grid[3]
    rng = np.random.default_rng(9)
    b = rng.standard_normal((n, 3))
    xs, xt, split, kernel = compare(b, grid)
    assert kernel == "ldl_node_triples"
    nt, sa, ss = split
    assert nt == SIDE3**3 and 0 < sa < ss - 1 and ss <= nt + 1, split
    assert_solves_agree(b, xs, xt, grid, RTOL3, KAPPA3)
    # run to run: the same bits
    _, xt2, _, _ = compare(b, grid)
    assert np.array_equal(xt, xt2)


def test_scene_trace_does_not_depend_on_threads_3d(tmp_path):
    """The 3D box (J0 solved by 3x3 blocks each step) on two threads (threshold 0) and on
    one: the traces agree to 1e-12, and summary.json says which."""
    import json
    import dyncontact
    text = ("&mesh dim = 3, h = 0.025 /\n&scheme dt = 0.0025, t_end = 0.05 /\n")
    traces = {}
    for threads in ("1", "2"):
        out = tmp_path / f"t{threads}"
        path = tmp_path / f"s{threads}.nml"
        path.write_text(text + f"&solver threads = {threads} /\n&output dir = '{out}' /\n")
        env = dict(os.environ, DYNCONTACT_THREADS_MIN_DOFS="0")
        env.pop("DYNCONTACT_THREADS", None)
        env.pop("PYTHONPATH", None)
        res = subprocess.run([sys.executable, "-m", "dyncontact", "run", str(path)], env=env,
                             capture_output=True, text=True, timeout=600)
        assert res.returncode == 0, res.stderr
        summary = json.loads((out / "summary.json").read_text())
        assert summary["solve_kernel"] == "ldl_node_triples"
        assert summary["solve_threads"] == int(threads)
        traces[threads] = dyncontact.core.read_trace(out)
    assert_traces_agree(traces["1"], traces["2"])
