"""The simplicial factorization by ranges of rows (fortran/linalg/cholmod_shim.c,
factor_by_ranges) gives the factor cholmod_factorize gives, bit for bit.

cholmod_factorize hands cholmod_rowfac the whole of triu(P A P') (two transposes of A's
upper triangle, alive next to the factor while it is made: the set-up's peak); the shim
builds the columns of one range of rows at a time (16 ranges by default). The test-only
switch DYNCONTACT_FACTOR_RANGES sets the number of ranges, 0 giving cholmod_factorize
whole (the reference). The traces must be equal exactly (not to round-off: the same
products in the same order), through contact (the contact correction's column solves),
for M's factor (pc: one dof a node, solved by CHOLMOD) and in 3D without node triples
(CHOLMOD's solves of its own factor); one range, and a thousand (a row or two each on these meshes), are the
extreme cases. The Fortran unit program of the CHOLMOD layer (refactorization in place,
the upper triangle alone, a matrix that is not positive definite) passes with them too.
"""

from __future__ import annotations

import subprocess

import numpy as np
import pytest

from conftest import ROOT
from test_traces_unchanged import run_case

import dyncontact
from dyncontact import Scene

CONTACT = ROOT / "tests" / "data" / "contact_h0.01"
VAR = "DYNCONTACT_FACTOR_RANGES"
#: cholmod_factorize whole (the reference), one range, ranges of a row or two
RANGES = ("0", "1", "1000")


def _exactly_equal(trace, ref, what):
    names = ref.dtype.names if hasattr(ref, "dtype") else list(ref)
    for col in names:
        np.testing.assert_array_equal(np.asarray(trace[col]), np.asarray(ref[col]),
                                      err_msg=f"{what}: column {col}")


def _runs(monkeypatch, run):
    """The run with the default ranges, then with each of RANGES: their traces."""
    monkeypatch.delenv(VAR, raising=False)
    base = run("default")
    out = {}
    for r in RANGES:
        monkeypatch.setenv(VAR, r)
        out[r] = run(r)
    monkeypatch.delenv(VAR, raising=False)
    return base, out


def test_ranges_give_the_same_trace_through_contact(tmp_path, monkeypatch):
    def run(tag):
        scn = Scene.read(CONTACT / "bar2d_hht_h0.01.nml")
        return dyncontact.run(scn, out=tmp_path / tag, progress=False)

    base, out = _runs(monkeypatch, run)
    assert base.trace["active"].max() > 0
    assert base.summary["factorization"] == "simplicial"
    for r, res in out.items():
        _exactly_equal(res.trace, base.trace, f"contact, ranges {r}")
        assert res.summary["factor_nnz"] == base.summary["factor_nnz"]


def test_ranges_give_the_same_trace_for_the_mass_factor(tmp_path, monkeypatch):
    base, out = _runs(monkeypatch, lambda tag: run_case("bar2d_pc", tmp_path / tag))
    assert base.summary["solve_kernel"] == "cholmod_solve2"
    for r, res in out.items():
        _exactly_equal(res.trace, base.trace, f"bar2d_pc, ranges {r}")


def test_ranges_give_the_same_trace_in_3d_without_node_triples(tmp_path, monkeypatch):
    monkeypatch.setenv("DYNCONTACT_FACTORIZATION", "simplicial")

    def run(tag):
        scn = Scene.read(ROOT / "scripts" / "scenes" / "bar3d_hht.nml")
        scn.set("scheme.t_end", 1.3)
        scn.set("boundary.slip_z", "sides")
        return dyncontact.run(scn, out=tmp_path / tag, progress=False)

    base, out = _runs(monkeypatch, run)
    assert base.trace["active"].max() > 0
    for r, res in out.items():
        _exactly_equal(res.trace, base.trace, f"3D, slip_z sides, ranges {r}")


@pytest.mark.parametrize("ranges", RANGES)
def test_cholmod_unit_program_with_ranges(ranges, tmp_path, monkeypatch):
    exe = ROOT / "build" / "tests" / "test_cholmod"
    if not exe.exists():
        pytest.skip(f"{exe} not built (scripts/setup builds it)")
    monkeypatch.setenv(VAR, ranges)
    proc = subprocess.run([str(exe)], capture_output=True, text=True, timeout=300,
                          cwd=tmp_path)
    assert proc.returncode == 0, proc.stdout + proc.stderr
