"""&solver kind = 'auto': the cost model of linear_solver's ls_auto_kind (docs/numerics.md,
"The 'auto' rule"). After the symbolic analysis (the factor's entries F, no numerical
factorization) CG runs when AUTO_CG_ITS(dim) nnz(J0) < AUTO_CG_MARGIN F, in 2D and 3D; 1D,
a non-symmetric matrix or an unknown dimension stay direct.

- The rule on synthetic numbers: the boundary, the dimensions, 'direct'/'cg' unchanged.
- The rule on the measured sweep (docs/scaling/solvers/scaling.csv): it picks the solver
  whose step was faster wherever the two differ by more than the sweep's noise.
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


def auto_kind(kind, dim, matrix_nnz, factor_nnz):
    """dc_ls_auto_kind: the kind that runs, AUTO_CG_ITS and AUTO_CG_MARGIN."""
    res, its, margin = _core.dc_ls_auto_kind(kind, dim, matrix_nnz, factor_nnz)
    return dec(res), [int(i) for i in its], float(margin)


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
    assert its == [0, 8, 10] and margin == 1.9
    for dim in (2, 3):
        nnz = 10**6
        edge = its[dim - 1] * nnz / margin          # the factor size where the costs meet
        assert auto_kind("auto", dim, nnz, int(edge * 1.01))[0] == "cg"
        assert auto_kind("auto", dim, nnz, int(edge * 0.99))[0] == "direct"
        assert auto_kind("auto", dim, nnz, 0)[0] == "direct"       # no analysis
        for fnnz in (1, 10**9):
            assert auto_kind("direct", dim, nnz, fnnz)[0] == "direct"
            assert auto_kind("cg", dim, nnz, fnnz)[0] == "cg"
    for dim in (0, 1):                                             # unknown, 1D
        assert auto_kind("auto", dim, 10, 10**12)[0] == "direct"


def sweep_rows():
    """(geometry, dofs, matrix_nnz, factor_nnz, CG step / direct step) of the sweep."""
    rows = list(csv.DictReader(open(ROOT / "docs" / "scaling" / "solvers" / "scaling.csv")))
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
    only such point and the rule keeps the direct solver there)."""
    rows = sweep_rows()
    assert len(rows) == 13
    dims = {"strip": 2, "disk": 2, "box": 3}
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
        ["direct", "direct", "direct", "cg", "cg"]


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


def test_auto_on_the_disk_above_its_crossover_is_cg(tmp_path):
    """h = 0.00125: 47 392 dofs, where CG's step was 2.7x faster (docs/performance.md)."""
    a = _scene(tmp_path, "disk", 0.00125, "auto")
    c = _scene(tmp_path, "disk", 0.00125, "cg")
    s = a.summary
    assert s["solver_kind"] == "auto" and s["solver"] == "pcg" and s["cg_solves"] > 0
    kind, its, nnz, fnnz = _reason_numbers(s["auto_reason"])
    assert kind == "cg" and its == 8 and its * nnz < 1.9 * fnnz
    # the sweep's mesh and J0 (its factor may differ: the orderings have changed since)
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
