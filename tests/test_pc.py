"""Predictor-corrector schemes pc, pc_hht, pc_hht_seed: GetFEM reference,
lumped mass, instability reported (not hidden), cost structure."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import dyncontact
from dyncontact import Scene

from test_schemes import REF_TOL_E, REF_TOL_U, SAME_EQUATIONS_TOL, load_reference, max_diff

#: pc is explicit: no Newton iteration, no tolerance; agreement with GetFEM's pc
#: is at the reference file's rounding (test_schemes.SAME_EQUATIONS_TOL) after 30000
#: steps. Observed: 5.1e-12 in u_n, 4.0e-11 of e_total(0) in e_total.
ROUNDOFF_TOL = 1e-10


def scene(**keys) -> Scene:
    s = Scene()
    s.set("scheme.name", "pc")
    s.set("scheme.dt", 0.0005)
    for name, value in keys.items():
        s.set(name.replace("__", "."), value)
    return s


def run(s, tmp_path, name):
    return dyncontact.run(s, out=tmp_path / name, progress=False)


def test_pc_matches_getfem_reference(tmp_path):
    res = run(scene(contact__quadrature="gauss", contact__quad_points=3), tmp_path, "pc")
    assert res.status == "ok"
    ref = load_reference("bar2d_h0.05_pc_dt0.0005.csv")
    du = max_diff(res, ref, "u_n")
    de = max_diff(res, ref, "e_total") / ref["e_total"][0]
    assert du <= REF_TOL_U and de <= REF_TOL_E
    assert du <= ROUNDOFF_TOL and de <= ROUNDOFF_TOL, (du, de)


def test_pc_is_explicit(tmp_path):
    """No Newton iterations; M factorized once (consistent) or never (lumped)."""
    res = run(scene(scheme__t_end=2.0), tmp_path, "c")
    assert res.summary["newton_its_total"] == 0
    assert np.all(res.trace["newton_its"] == 0)
    assert res.summary["factorizations"] == 1
    res = run(scene(scheme__t_end=2.0, scheme__mass="lumped"), tmp_path, "l")
    assert res.summary["factorizations"] == 0


def test_pc_lumped_runs_the_seed_scene(tmp_path):
    res = run(scene(scheme__mass="lumped", output__every=20), tmp_path, "lumped")
    assert res.status == "ok"
    tr = res.trace
    assert tr["t"][-1] == pytest.approx(15.0)
    assert np.all(np.isfinite(tr["e_total"]))
    # it bounces: several contact phases, energy of the order of the initial one
    contact = tr["active"] > 0
    assert np.count_nonzero(np.diff(contact.astype(int)) == 1) >= 4
    assert np.max(tr["e_total"]) < 2 * tr["e_total"][0]


@pytest.mark.parametrize("name", ["pc_hht", "pc_hht_seed"])
def test_pc_hht_variants_run(name, tmp_path):
    res = run(scene(scheme__name=name, scheme__alpha=-0.1, scheme__t_end=3.0), tmp_path, name)
    assert res.status == "ok"
    assert res.trace["t"][-1] == pytest.approx(3.0)


def test_pc_hht_alpha0_equals_pc(tmp_path):
    a = run(scene(scheme__name="pc_hht", scheme__alpha=0.0, scheme__t_end=2.0), tmp_path, "a")
    b = run(scene(scheme__t_end=2.0), tmp_path, "b")
    assert np.array_equal(a.trace["u_n"], b.trace["u_n"])


def test_pc_hht_dissipates_more_than_pc(tmp_path):
    a = run(scene(scheme__name="pc_hht", scheme__alpha=-0.1, output__every=50), tmp_path, "a")
    b = run(scene(output__every=50), tmp_path, "b")
    assert a.trace["e_total"][-1] < b.trace["e_total"][-1]


def test_unstable_pc_stops_with_status_and_trace(tmp_path):
    """dt far above the explicit stability limit (~h / (c sqrt(3)) for P1): the run is
    stopped as 'unstable', keeps its trace up to the stop, and the CLI exits 3, after
    one warning line before the run (dt is 1.57 x pc's own estimate)."""
    s = scene(scheme__dt=0.02)
    path = tmp_path / "unstable.nml"
    s.write(path)
    out = tmp_path / "out"
    proc = subprocess.run([sys.executable, "-m", "dyncontact", "run", str(path), "--out",
                           str(out), "--quiet"], capture_output=True, text=True)
    assert proc.returncode == 3
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 2, proc.stderr
    assert " is 1.57 x the critical step of pc, estimated " in lines[0], lines[0]
    assert "unstable" in lines[1]
    summary = dyncontact.core.read_summary(out)
    trace = dyncontact.core.read_trace(out)
    assert summary["status"] == "unstable"
    assert 0 < summary["t_end_reached"] < 15.0
    assert trace["t"][-1] == pytest.approx(summary["t_end_reached"])
    e = trace["e_total"]
    assert not np.isfinite(e[-1]) or e[-1] > 10 * e[0]
    assert np.all(e[:-1] <= 10 * e[0])
