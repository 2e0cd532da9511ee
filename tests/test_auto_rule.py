"""&solver kind = 'auto': the cost model of linear_solver's ls_auto_kind (docs/numerics.md,
"The 'auto' rule"). After the symbolic analysis (the factor's entries F, no numerical
factorization) CG runs when AUTO_CG_ITS(dim) nnz(J0) < AUTO_CG_MARGIN(dim) F, in 2D and 3D; 1D,
a non-symmetric matrix or an unknown dimension stay direct. When the direct solve will run
on two threads (ldl_threads_choice for the matrix's size) its estimate is divided by
AUTO_PAR_SPEEDUP.

- The rule on synthetic numbers: the boundary, the dimensions, 'direct'/'cg' unchanged.
- The rule on the measured sweep (docs/scaling/solvers/scaling.csv; the box's rows from its
  newer sweep, scaling_box.csv, each of its two runs): it picks the solver whose step was
  faster wherever the two differ by more than the sweep's noise.
- The rule on the two-thread pairs (docs/scaling/solvers/scaling_threads.csv: CG against
  the direct solver on the threads the default gives, wall time a step): the same.
- The analysis' entry count equals the entries the direct factorization then stores.
- Real scenes: the strip at h = 0.01, 0.005, 0.0025 runs the direct solver, the disk at
  h = 0.00125 (47 392 dofs, above its crossover) CG; 'auto''s results equal the chosen
  solver's bit for bit, and summary.json's auto_reason gives the decision's inputs.
"""

from __future__ import annotations

import csv
import re

import numpy as np
import pytest

from conftest import ROOT
from test_linalg import symmetric_coo

import dyncontact
from dyncontact import Scene, _core
from dyncontact.study.scaling import scene_text

STAT_OK = 0


def dec(s) -> str:
    return (s.tobytes() if hasattr(s, "tobytes") else bytes(s)).decode().strip()


def auto_kind(kind, dim, matrix_nnz, factor_nnz, threads=1):
    """dc_ls_auto_kind for a direct solve on `threads` threads: the kind that runs,
    AUTO_CG_ITS and AUTO_CG_MARGIN, by dimension."""
    res, its, margin, _ = _core.dc_ls_auto_kind(kind, dim, matrix_nnz, factor_nnz, threads)
    return dec(res), [int(i) for i in its], [float(m) for m in margin]


def par_speedup():
    """AUTO_PAR_SPEEDUP."""
    return float(_core.dc_ls_auto_kind("auto", 2, 1, 1, 2)[3])


def auto_decide(rows, cols, vals, n, dim):
    """dc_ls_auto_decide on 1-based COO."""
    out = _core.dc_ls_auto_decide(
        n, np.ascontiguousarray(rows, dtype=np.int32), np.ascontiguousarray(cols, dtype=np.int32),
        np.ascontiguousarray(vals, dtype=np.float64), dim)
    resolved, backend, mnnz, annz, dnnz, reason, stat, msg = out
    assert stat == STAT_OK, dec(msg)
    return dec(resolved), dec(backend), int(mnnz), int(annz), int(dnnz), dec(reason)


def test_rule_on_synthetic_numbers():
    _, its, margin = auto_kind("auto", 2, 1, 1)
    assert its == [0, 8, 10] and margin[1:] == [1.9, 1.4]
    for dim in (2, 3):
        nnz = 10**6
        edge = its[dim - 1] * nnz / margin[dim - 1]  # the factor size where the costs meet
        assert auto_kind("auto", dim, nnz, int(edge * 1.01))[0] == "cg"
        assert auto_kind("auto", dim, nnz, int(edge * 0.99))[0] == "direct"
        assert auto_kind("auto", dim, nnz, 0)[0] == "direct"       # no analysis
        for fnnz in (1, 10**9):
            assert auto_kind("direct", dim, nnz, fnnz)[0] == "direct"
            assert auto_kind("cg", dim, nnz, fnnz)[0] == "cg"
    for dim in (0, 1):                                             # unknown, 1D
        assert auto_kind("auto", dim, 10, 10**12)[0] == "direct"


def test_two_threads_divide_the_direct_estimate():
    """With a two-thread direct solve the boundary moves by AUTO_PAR_SPEEDUP: the factor
    size where the costs meet is AUTO_PAR_SPEEDUP times the one-thread one; one thread
    (or 0, 'not known') keeps the one-thread rule; 'direct' and 'cg' are unchanged."""
    s = par_speedup()
    assert 1.0 <= s <= 2.0                      # two threads: at most twice as fast
    _, its, margin = auto_kind("auto", 2, 1, 1)
    for dim in (2, 3):
        nnz = 10**6
        edge = its[dim - 1] * nnz / margin[dim - 1]  # one thread: where the costs meet
        for t, e in ((2, edge * s), (1, edge), (0, edge)):
            assert auto_kind("auto", dim, nnz, int(e * 1.01), t)[0] == "cg"
            assert auto_kind("auto", dim, nnz, int(e * 0.99), t)[0] == "direct"
        for fnnz in (1, 10**9):
            assert auto_kind("direct", dim, nnz, fnnz, 2)[0] == "direct"
            assert auto_kind("cg", dim, nnz, fnnz, 2)[0] == "cg"


def sweep_rows(name="scaling.csv", run=None):
    """(geometry, dofs, matrix_nnz, factor_nnz, CG step / direct step) of a sweep's CSV
    (CPU time a step: one thread), the rows of one run when `run` is given."""
    rows = list(csv.DictReader(open(ROOT / "docs" / "scaling" / "solvers" / name)))
    if run is not None:
        rows = [r for r in rows if r["run"] == str(run)]
    step = {(r["geometry"], r["dofs"], r["solver_kind"]): r for r in rows}
    out = []
    for (g, dofs, kind), r in step.items():
        if kind == "direct" and (g, dofs, "cg") in step:
            cg = step[(g, dofs, "cg")]
            out.append((g, int(dofs), int(r["matrix_nnz"]), int(r["factor_nnz"]),
                        float(cg["loop_ms_per_step"]) / float(r["loop_ms_per_step"])))
    return out


def test_rule_picks_the_faster_solver_of_the_sweep():
    """Every (geometry, size) of the sweep with both solvers: 'auto' picks the one whose
    step was faster, except where they are within 10 % (one repeat on a loaded machine:
    the sweep's run-to-run spread is of that order; the disk at 12 036 dofs, 0.91, is the
    only such point and the rule keeps the direct solver there). The box: its newer
    sweep's two runs, each (scaling.csv's box rows predate the direct step's speed-ups)."""
    first = [r for r in sweep_rows() if r[0] != "box"]
    assert len(first) == 8
    dims = {"strip": 2, "disk": 2, "box": 3}
    for rows in (first + sweep_rows("scaling_box.csv", 1), first + sweep_rows("scaling_box.csv", 2)):
        assert len(rows) == 13
        picked = {}
        for g, dofs, nnz, fnnz, ratio in rows:
            k = auto_kind("auto", dims[g], nnz, fnnz)[0]
            picked[(g, dofs)] = k
            if abs(ratio - 1) > 0.1:
                assert k == ("cg" if ratio < 1 else "direct"), (g, dofs, ratio, k)
        assert all(picked[("strip", d)] == "direct" for d in (8400, 32800, 129600, 515200))
        assert [picked[("disk", d)] for d in (3188, 12036, 47392, 188116)] == \
            ["direct", "direct", "cg", "cg"]
        assert [picked[("box", d)] for d in (3000, 5400, 8820, 19440, 36300)] == \
            ["direct", "direct", "direct", "direct", "cg"]


def thread_rows():
    """(geometry, dofs, matrix_nnz, factor_nnz, threads of the direct solve, CG's wall
    time a step / the direct solver's) of scaling_threads.csv: the direct rows with the
    setting '2' (DYNCONTACT_THREADS=2: two threads from PAR_MIN_DOFS, as the automatic
    setting gives on two CPUs), the fastest of the runs of each (the sweep's own rule for
    its repeats: a slowed-down run is dropped), against CG's fastest."""
    rows = list(csv.DictReader(open(ROOT / "docs" / "scaling" / "solvers" /
                                    "scaling_threads.csv")))
    best: dict = {}
    for r in rows:
        if r["solver_kind"] == "direct" and r["threads"] != "2":
            continue
        key = (r["geometry"], int(r["dofs"]), r["solver_kind"])
        if key not in best or float(r["wall_ms_per_step"]) < float(best[key]["wall_ms_per_step"]):
            best[key] = r
    out = []
    for (g, dofs, kind), r in sorted(best.items()):
        if kind == "direct" and (g, dofs, "cg") in best:
            cg = best[(g, dofs, "cg")]
            out.append((g, dofs, int(r["matrix_nnz"]), int(r["factor_nnz"]),
                        int(r["solve_threads"]),
                        float(cg["wall_ms_per_step"]) / float(r["wall_ms_per_step"])))
    return out


def test_rule_picks_the_faster_solver_with_two_threads():
    """The measured pairs where the direct solve ran on two threads (the disk at 47 392
    dofs, the box at 36 300; below PAR_MIN_DOFS it runs on one, and the pair is a
    one-thread one): 'auto', told the threads, picks the solver whose step was faster
    in wall time, beyond the 10 % of the one-thread sweep's noise."""
    rows = [r for r in thread_rows() if r[4] == 2]
    assert sorted((g, d) for g, d, *_ in rows) == [("box", 36300), ("disk", 47392)]
    dims = {"strip": 2, "disk": 2, "box": 3}
    for g, dofs, nnz, fnnz, threads, ratio in rows:
        assert abs(ratio - 1) > 0.1, (g, dofs, ratio)
        k = auto_kind("auto", dims[g], nnz, fnnz, threads)[0]
        assert k == ("cg" if ratio < 1 else "direct"), (g, dofs, ratio, k)


@pytest.mark.parametrize("factorization", ["", "simplicial", "supernodal"])
def test_analysis_entries_are_the_factors(factorization, monkeypatch):
    """The analysis' entry count (what 'auto' decides on) equals the entries the direct
    factorization of the same matrix stores (D and L), simplicial or supernodal."""
    if factorization:
        monkeypatch.setenv("DYNCONTACT_FACTORIZATION", factorization)
    rng = np.random.default_rng(5)
    for n, density in ((40, 0.1), (300, 0.02)):
        rows, cols, vals, _ = symmetric_coo(rng, n, density, 2.0 * n)   # SPD
        kind, backend, mnnz, annz, dnnz, reason = auto_decide(rows, cols, vals, n, 2)
        assert annz > 0 and annz == dnnz, (n, annz, dnnz)
        assert kind == auto_kind("auto", 2, mnnz, annz)[0]
        assert backend == ("pcg" if kind == "cg" else "cholmod_ldlt")
        assert reason.startswith(kind + ": 8 x nnz(J0) %d " % mnnz) and str(annz) in reason


def _scene(tmp_path, geometry, h, kind, steps=2):
    out = tmp_path / f"{geometry}_{kind}"
    path = tmp_path / f"{geometry}_{kind}.nml"
    path.write_text(scene_text(geometry, h, steps, True, str(out), solver=kind))
    return dyncontact.run(Scene.read(path), out=out, progress=False)


def _reason_numbers(reason):
    m = re.match(r"(\w+): (\d+) x nnz\(J0\) (\d+) (<|>=) 1\.9 x factor entries (\d+)", reason)
    assert m, reason
    return m.group(1), int(m.group(2)), int(m.group(3)), int(m.group(5))


@pytest.mark.parametrize("h", [0.01, 0.005, 0.0025])
def test_auto_on_the_strip_is_the_direct_solver(h, tmp_path):
    a = _scene(tmp_path, "strip", h, "auto")
    d = _scene(tmp_path, "strip", h, "direct")
    s = a.summary
    assert s["solver_kind"] == "auto" and s["solver"] == "cholmod_ldlt"
    kind, its, nnz, fnnz = _reason_numbers(s["auto_reason"])
    assert kind == "direct" and its == 8 and fnnz == d.summary["factor_nnz"] == s["factor_nnz"]
    assert d.summary["auto_reason"] == ""
    for col in d.trace:
        np.testing.assert_array_equal(d.trace[col], a.trace[col])


def test_auto_reason_with_a_two_thread_direct_solve(tmp_path, monkeypatch):
    """DYNCONTACT_THREADS=2 (from 0 dofs: the test-only DYNCONTACT_THREADS_MIN_DOFS):
    'auto' on the strip at h = 0.005 assumes the two-thread solve that then runs
    (summary.json solve_threads), auto_reason says so with AUTO_PAR_SPEEDUP, the
    decision is ls_auto_kind's for two threads, and the traces are the direct run's."""
    monkeypatch.setenv("DYNCONTACT_THREADS", "2")
    monkeypatch.setenv("DYNCONTACT_THREADS_MIN_DOFS", "0")
    a = _scene(tmp_path, "strip", 0.005, "auto")
    d = _scene(tmp_path, "strip", 0.005, "direct")
    s = a.summary
    assert s["solver"] == "cholmod_ldlt" and s["solve_threads"] == d.summary["solve_threads"] == 2
    kind, its, nnz, fnnz = _reason_numbers(s["auto_reason"])
    assert f"x factor entries {fnnz} / {par_speedup():.2f}, the direct solve on 2 threads (ratio" \
        in s["auto_reason"]
    assert kind == auto_kind("auto", 2, nnz, fnnz, 2)[0] == "direct"
    for col in d.trace:
        np.testing.assert_array_equal(d.trace[col], a.trace[col])
    monkeypatch.setenv("DYNCONTACT_THREADS", "1")                  # one thread: no divisor
    (tmp_path / "one").mkdir()
    one = _scene(tmp_path / "one", "strip", 0.005, "auto").summary
    assert one["solve_threads"] == 1 and "threads" not in one["auto_reason"]


def test_auto_on_the_disk_above_its_crossover_is_cg(tmp_path):
    """h = 0.00125: 47 392 dofs, where CG's step was 2.7x faster (docs/performance.md)."""
    a = _scene(tmp_path, "disk", 0.00125, "auto")
    c = _scene(tmp_path, "disk", 0.00125, "cg")
    s = a.summary
    assert s["solver_kind"] == "auto" and s["solver"] == "pcg" and s["cg_solves"] > 0
    kind, its, nnz, fnnz = _reason_numbers(s["auto_reason"])
    assert kind == "cg" and its == 8 and its * nnz < 1.9 * fnnz
    # the sweep's mesh and J0 (not its factor: the fill depends on the ordering used)
    sweep = {(g, d): m for g, d, m, f, _ in sweep_rows()}
    assert nnz == sweep[("disk", s["dofs"])]
    assert s["dofs"] == c.summary["dofs"] and s["cg_iterations"] == c.summary["cg_iterations"]
    for col in c.trace:
        np.testing.assert_array_equal(c.trace[col], a.trace[col])


def test_no_analysis_where_cg_does_not_apply():
    """1D (or an unknown dimension) and a non-symmetric matrix: the direct solver, without
    an analysis (the decision's factor entries are 0), and auto_reason says why."""
    rng = np.random.default_rng(9)
    n = 60
    rows, cols, vals, _ = symmetric_coo(rng, n, 0.1, 2.0 * n)
    for dim in (0, 1):
        kind, backend, _, annz, _, reason = auto_decide(rows, cols, vals, n, dim)
        assert (kind, backend, annz) == ("direct", "cholmod_ldlt", 0)
        assert reason == "direct: 1D or dimension unknown"
    vals = vals.copy()
    off = np.flatnonzero(rows != cols)[0]
    vals[off] += 1.0                                        # one entry: not symmetric
    kind, backend, _, annz, _, reason = auto_decide(rows, cols, vals, n, 2)
    assert (kind, backend, annz) == ("direct", "umfpack_lu", 0)
    assert reason == "direct: the matrix is not symmetric"
