"""The factorization choices made for large meshes, and the scaling sweep.

- Every fill-reducing ordering of the node pairs (AMD, METIS, CHOLMOD's nested
  dissection; forced with the test-only environment variable DYNCONTACT_ORDERING) gives
  the example traces to round-off (1e-12), and the run's own choice is the ordering with
  the fewest factor entries (summary.json's ordering and factor_nnz).
- The contact correction's Z = J0^{-1} P^T solved by chunks of columns gives the trace
  of the code that held it as one dense block, on a mesh with three chunks
  (tests/data/contact_h0.01/README.md).
- summary.json's matrix_nnz is the stored entries of the assembled matrices, and
  factor_nnz at least those of their upper triangle.
- study.scaling writes its table on a small size, for every geometry and both solvers.
"""

from __future__ import annotations

import csv

import numpy as np
import pytest

from conftest import ROOT
from test_traces_unchanged import BEFORE, run_case

import dyncontact
from dyncontact import Scene
from dyncontact.study import scaling

ORDERINGS = ("amd", "metis", "nesdis")
#: Another ordering sums the same products in another order: round-off, not more.
RTOL = ATOL = 1e-12
#: The implicit 2D cases (J0 factorized) and one pc case (M factorized).
CASES = ("bar2d_hht", "bar2d_newmark", "bar2d_theta", "bar2d_hht_mshfile", "bar2d_pc")
CONTACT = ROOT / "tests" / "data" / "contact_h0.01"


def _same(trace, before, what):
    for col in before.dtype.names:
        np.testing.assert_allclose(trace[col], before[col], rtol=RTOL, atol=ATOL,
                                   err_msg=f"{what}: column {col}")


@pytest.mark.parametrize("ordering", ORDERINGS)
@pytest.mark.parametrize("name", CASES)
def test_every_ordering_gives_the_same_traces(name, ordering, tmp_path, monkeypatch):
    monkeypatch.setenv("DYNCONTACT_ORDERING", ordering)
    res = run_case(name, tmp_path / name)
    before = np.genfromtxt(BEFORE / f"{name}.csv", delimiter=",", names=True)
    _same(res.trace, before, f"{name}, {ordering}")
    if res.summary["solver"] == "cholmod_ldlt" and res.summary["solve_kernel"] == "ldl_node_pairs":
        assert res.summary["ordering"] == ordering


def _contact_run(out):
    scn = Scene.read(CONTACT / "bar2d_hht_h0.01.nml")
    return dyncontact.run(scn, out=out, progress=False)


def test_the_run_picks_the_ordering_with_the_fewest_factor_entries(tmp_path, monkeypatch):
    got = {}
    for ordering in ORDERINGS:
        monkeypatch.setenv("DYNCONTACT_ORDERING", ordering)
        scn = Scene.read(CONTACT / "bar2d_hht_h0.01.nml")
        scn.set("scheme.t_end", 0.0)
        s = dyncontact.run(scn, out=tmp_path / ordering, progress=False).summary
        got[ordering] = s["factor_nnz"]
    monkeypatch.delenv("DYNCONTACT_ORDERING")
    scn = Scene.read(CONTACT / "bar2d_hht_h0.01.nml")
    scn.set("scheme.t_end", 0.0)
    s = dyncontact.run(scn, out=tmp_path / "auto", progress=False).summary
    assert s["factor_nnz"] == min(got.values())
    assert got[s["ordering"]] == s["factor_nnz"]
    # ties go to the first of amd, metis, nesdis
    assert s["ordering"] == next(o for o in ORDERINGS if got[o] == s["factor_nnz"])


def test_contact_correction_by_chunks_equals_the_dense_block(tmp_path):
    res = _contact_run(tmp_path / "out")
    before = np.genfromtxt(CONTACT / "bar2d_hht_h0.01.csv", delimiter=",", names=True)
    assert before["active"].max() > 0
    _same(res.trace, before, "Z by chunks")


def test_summary_sizes_are_those_of_the_matrices_and_the_factor(tmp_path):
    scn = Scene.read(ROOT / "scripts" / "scenes" / "bar2d_hht.nml")
    scn.set("scheme.t_end", 0.0)
    with dyncontact.core.Stepper(scn, tmp_path / "out") as st:
        dense = [st.matrix(w) for w in ("M", "K", "K_theta")]
    s = dyncontact.core.read_summary(tmp_path / "out")
    pattern = np.zeros_like(dense[0], dtype=bool)
    for d in dense:
        pattern |= d != 0
    # the shared pattern stores every entry any of the matrices has (and maybe zeros)
    assert s["matrix_nnz"] >= int(pattern.sum())
    assert s["matrix_nnz"] <= dense[0].size
    upper = int(np.triu(pattern).sum())
    assert upper <= s["factor_nnz"] <= dense[0].shape[0] * (dense[0].shape[0] + 1) // 2
    assert s["ordering"] in ORDERINGS


def test_scaling_sweep_writes_its_table(tmp_path):
    rows = scaling.run_scaling(str(tmp_path), sizes=[0.05], steps=5, repeats=1,
                               log=lambda *_: None)
    assert [r["contact"] for r in rows] == [1, 0]
    for r in rows:
        assert r["dofs"] > 0 and r["peak_mb"] > 0 and r["setup_s"] >= 0
        assert r["factor_nnz"] > 0 and r["matrix_nnz"] > 0 and r["model_mb"] > 0
        assert r["ordering"] in ORDERINGS
    with open(tmp_path / "scaling.csv", encoding="utf-8") as f:
        table = list(csv.DictReader(f))
    assert len(table) == 2 and list(table[0]) == scaling.COLUMNS
    assert (tmp_path / "scaling.png").stat().st_size > 0
    assert (tmp_path / "scaling.md").read_text().startswith("| geometry | solver | h |")


def test_scaling_sweep_of_every_geometry_and_solver(tmp_path):
    """The disk (gmsh) and the 3D box with both solvers at one small size: the rows name
    their geometry and solver, CG's rows count iterations, and the dofs estimate that
    --max-dofs uses is the run's count for the built-in meshes (within 10 % for gmsh's
    disk at h = 0.02)."""
    rows = scaling.run_scaling(str(tmp_path), sizes=[0.05], steps=2, repeats=1,
                               log=lambda *_: None, geometries=("disk", "box"),
                               solvers=("direct", "cg"), floors=False, no_contact=False)
    assert [(r["geometry"], r["solver_kind"]) for r in rows] == [
        ("disk", "direct"), ("disk", "cg"), ("box", "direct"), ("box", "cg")]
    for r in rows:
        assert r["dofs"] > 0 and r["peak_mb"] > 0
        if r["solver_kind"] == "cg":
            assert r["solver"] == "pcg_jacobi" and r["cg_its_per_solve"] > 1
        else:
            assert r["solver"] == "cholmod_ldlt" and r["cg_its_per_solve"] is None
    assert scaling.estimate_dofs("box", 0.05) == rows[2]["dofs"]
    (tmp_path / "disk.nml").write_text(scaling.scene_text("disk", 0.02, 0, True,
                                                          str(tmp_path / "d")))
    disk = Scene.read(tmp_path / "disk.nml")
    dofs = dyncontact.run(disk, out=tmp_path / "d", progress=False).summary["dofs"]
    assert abs(scaling.estimate_dofs("disk", 0.02) / dofs - 1) < 0.1
    for h, dofs in ((0.01, 2200), (0.00125, 129600)):
        assert scaling.estimate_dofs("strip", h) == dofs
    assert (tmp_path / "scaling.png").stat().st_size > 0
    # a size above --max-dofs is skipped, and the table says so
    scaling.run_scaling(str(tmp_path / "cap"), sizes=[0.05], steps=2, repeats=1,
                        log=lambda *_: None, geometries=("box",), max_dofs=100, floors=False)
    assert "Skipped: box h = 0.05" in (tmp_path / "cap" / "scaling.md").read_text()
