"""The factorization choices made for large meshes, and the scaling sweep.

- Every fill-reducing ordering of the node pairs (AMD, METIS, CHOLMOD's nested
  dissection; forced with the test-only environment variable DYNCONTACT_ORDERING) gives
  the example traces to round-off (1e-12), and the run's own choice is the ordering with
  the fewest factor entries among those it tries (AMD and nested dissection for node
  pairs; summary.json's ordering and factor_nnz).
- Both numerical factorizations (CHOLMOD's simplicial LDL^T and supernodal LL^T, forced
  with DYNCONTACT_FACTORIZATION) give the example traces to round-off (1e-12), in 2D and
  3D, through contact (the contact correction's column solves), with node blocks and
  without; summary.json's factorization says which ran, and factor_nnz is the same
  (the supernodes are not relaxed: the same entries).
- The contact correction's Z = J0^{-1} P^T solved by chunks of columns gives the trace
  of the code that held it as one dense block, on a mesh with three chunks
  (tests/data/contact_h0.01/README.md).
- summary.json's matrix_nnz is the stored entries of the assembled matrices, and
  factor_nnz at least those of their upper triangle.
- study.scaling writes its table on a small size, for every geometry and both solvers,
  and a row for each threads setting of the direct solver.
"""

from __future__ import annotations

import csv
import warnings

import numpy as np
import pytest

from conftest import ROOT
from test_traces_unchanged import BEFORE, run_case

import dyncontact
from dyncontact import Scene
from dyncontact.study import scaling

ORDERINGS = ("amd", "metis", "nesdis")
#: The orderings the run tries for node pairs (2D), in the order ties are broken.
PAIR_ORDERINGS = ("amd", "nesdis")
FACTORIZATIONS = ("simplicial", "supernodal")
#: Another ordering sums the same products in another order: round-off, not more.
RTOL = ATOL = 1e-12
#: The implicit 2D cases (J0 factorized) and one pc case (M factorized).
CASES = ("bar2d_hht", "bar2d_newmark", "bar2d_theta", "bar2d_hht_mshfile", "bar2d_pc")
CONTACT = ROOT / "tests" / "data" / "contact_h0.01"


def _same(trace, before, what, rtol=RTOL, atol=ATOL):
    names = before.dtype.names if hasattr(before, "dtype") else list(before)
    for col in names:
        np.testing.assert_allclose(trace[col], before[col], rtol=rtol, atol=atol,
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


#: Through contact, the contact point's velocity and pressure and the contact energy
#: (v_n, p_n, e_contact) amplify the factor's round-off: on the contact scene below,
#: forcing nested dissection instead of the run's AMD moves them by 1.2e-11 of their
#: largest value (u_n and the other energies by 1e-13, the Newton iterations and active
#: sets not at all). The contact force f_n, the integral of p_n over Γ_C, is as
#: sensitive: on the 3D bar below, the supernodal factor made with OpenBLAS's kernels
#: instead of the reference BLAS's moves it by 1.9e-12 of its largest value. Another
#: numerical factorization is the same kind of change (the same products in another
#: order): those four columns are compared to 1e-10 of their largest value, the others
#: to RTOL of theirs, the counts exactly.
CONTACT_SENSITIVE = ("v_n", "p_n", "f_n", "e_contact")
CONTACT_RTOL = 1e-10


def _same_through_contact(trace, ref, what):
    for col in ref.dtype.names if hasattr(ref, "dtype") else list(ref):
        a, b = np.asarray(trace[col]), np.asarray(ref[col])
        if col in ("newton_its", "active"):
            np.testing.assert_array_equal(a, b, err_msg=f"{what}: column {col}")
            continue
        scale = max(np.max(np.abs(b)), 1e-300)
        tol = CONTACT_RTOL if col in CONTACT_SENSITIVE else RTOL
        assert np.max(np.abs(a - b)) <= tol * scale, f"{what}: column {col}"


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
    tried = {o: got[o] for o in PAIR_ORDERINGS}
    assert s["factor_nnz"] == min(tried.values())
    assert got[s["ordering"]] == s["factor_nnz"]
    # ties go to the first of amd, nesdis
    assert s["ordering"] == next(o for o in PAIR_ORDERINGS if got[o] == s["factor_nnz"])
    # a small mesh's factor has short columns: simplicial (docs/performance.md)
    assert s["factorization"] == "simplicial"


@pytest.mark.parametrize("factorization", FACTORIZATIONS)
@pytest.mark.parametrize("name", CASES)
def test_every_factorization_gives_the_same_traces(name, factorization, tmp_path,
                                                   monkeypatch):
    monkeypatch.setenv("DYNCONTACT_FACTORIZATION", factorization)
    res = run_case(name, tmp_path / name)
    before = np.genfromtxt(BEFORE / f"{name}.csv", delimiter=",", names=True)
    _same(res.trace, before, f"{name}, {factorization}")
    if res.summary["solver"] == "cholmod_ldlt":
        assert res.summary["factorization"] == factorization
        # node pairs (J0) by their kernel; pc's scalar mass S (one dof a node) by CHOLMOD's
        own = "cholmod_supernodal" if factorization == "supernodal" else "cholmod_solve2"
        assert res.summary["solve_kernel"] == ("ldl_node_pairs" if name != "bar2d_pc" else own)


@pytest.mark.parametrize("factorization", FACTORIZATIONS)
def test_contact_columns_with_every_factorization(factorization, tmp_path, monkeypatch):
    """Through contact: the columns of Z = J0^-1 P^T are solved with the factor of each
    numerical factorization (16 at a time), and the trace is the one of the dense block."""
    monkeypatch.setenv("DYNCONTACT_FACTORIZATION", factorization)
    res = _contact_run(tmp_path / "out")
    before = np.genfromtxt(CONTACT / "bar2d_hht_h0.01.csv", delimiter=",", names=True)
    assert before["active"].max() > 0
    _same_through_contact(res.trace, before, f"Z by chunks, {factorization}")
    assert res.summary["factorization"] == factorization


@pytest.mark.parametrize("keys, kernel", [
    ({}, "ldl_node_triples"),
    ({"boundary.slip_z": "sides"}, None),   # nodes with two free dofs: CHOLMOD's solves
])
def test_3d_factorizations_agree_through_contact(keys, kernel, tmp_path, monkeypatch):
    """The 3D bar to t = 1.3 (it lands near t = 1.1): the supernodal factorization's
    trace equals the simplicial one's to round-off; with node triples both are solved by
    the triples' kernel, without them by CHOLMOD's solve of each factor."""
    traces, sums = {}, {}
    for f in FACTORIZATIONS:
        monkeypatch.setenv("DYNCONTACT_FACTORIZATION", f)
        scn = Scene.read(ROOT / "scripts" / "scenes" / "bar3d_hht.nml")
        scn.set("scheme.t_end", 1.3)
        for key, value in keys.items():
            scn.set(key, value)
        res = dyncontact.run(scn, out=tmp_path / f, progress=False)
        traces[f], sums[f] = res.trace, res.summary
    assert traces["simplicial"]["active"].max() > 0
    _same_through_contact(traces["supernodal"], traces["simplicial"],
                          "3D, supernodal against simplicial")
    for f in FACTORIZATIONS:
        assert sums[f]["factorization"] == f
    assert sums["supernodal"]["factor_nnz"] == sums["simplicial"]["factor_nnz"]
    if kernel is None:
        assert sums["simplicial"]["solve_kernel"] == "cholmod_solve2"
        assert sums["supernodal"]["solve_kernel"] == "cholmod_supernodal"
    else:
        assert sums["simplicial"]["solve_kernel"] == kernel
        assert sums["supernodal"]["solve_kernel"] == kernel


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
    # the row without contact (contact 0) has no contact boundary by design: the core's
    # warning that its probe reports nothing is kept out of the sweep's output, and no
    # other is given
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rows = scaling.run_scaling(str(tmp_path), sizes=[0.05], steps=5, repeats=1,
                                   log=lambda *_: None)
    assert not caught, [str(w.message) for w in caught]
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
            assert r["solver"] == "pcg" and r["cg_its_per_solve"] > 1
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


def test_scaling_sweep_with_thread_settings(tmp_path, monkeypatch):
    """--threads 1,2: the direct solver's row for each setting at each size (CG's once,
    with the last), each with the threads its solves used (summary.json solve_threads;
    two from 0 dofs with the test-only DYNCONTACT_THREADS_MIN_DOFS) and its wall time a
    step; the table names the setting."""
    monkeypatch.setenv("DYNCONTACT_THREADS_MIN_DOFS", "0")
    rows = scaling.run_scaling(str(tmp_path), sizes=[0.05], steps=2, repeats=1,
                               log=lambda *_: None, geometries=("box",),
                               solvers=("direct", "cg"), floors=False, threads=("1", "2"))
    assert [(r["solver_kind"], r["threads"], r["solve_threads"]) for r in rows] == [
        ("direct", "1", 1), ("direct", "2", 2), ("cg", "2", 1)]
    assert all(r["wall_ms_per_step"] > 0 for r in rows)
    assert rows[0]["dofs"] == rows[1]["dofs"] == rows[2]["dofs"]
    with open(tmp_path / "scaling.csv", encoding="utf-8") as f:
        table = list(csv.DictReader(f))
    assert [t["threads"] for t in table] == ["1", "2", "2"]
    md = (tmp_path / "scaling.md").read_text()
    assert "| box | direct 1t |" in md and "| box | direct 2t |" in md


def test_long_factor_columns_choose_the_supernodal_factorization(tmp_path, monkeypatch):
    """The 3D box at 19 440 dofs (249 factor entries a column, where the supernodal
    factorization was measured 1.5x faster): the run picks it, solves by node triples,
    and its factor has the simplicial one's entries (summary.json)."""
    sums = {}
    for f in ("", "simplicial"):
        if f:
            monkeypatch.setenv("DYNCONTACT_FACTORIZATION", f)
        out = tmp_path / (f or "auto")
        path = tmp_path / f"box_{f or 'auto'}.nml"
        path.write_text(scaling.scene_text("box", 0.0125, 0, True, str(out), "direct"))
        sums[f or "auto"] = dyncontact.run(Scene.read(path), out=out, progress=False).summary
    assert sums["auto"]["factorization"] == "supernodal"
    assert sums["simplicial"]["factorization"] == "simplicial"
    assert sums["auto"]["solve_kernel"] == sums["simplicial"]["solve_kernel"] == "ldl_node_triples"
    assert sums["auto"]["factor_nnz"] == sums["simplicial"]["factor_nnz"]
    assert sums["auto"]["ordering"] == sums["simplicial"]["ordering"]
