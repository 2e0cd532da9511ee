"""The comparison with GetFEM (``scripts/bench --getfem``, dyncontact.study.getfem_compare).

- The driver's own logic, without GetFEM: the ratio and the table on canned numbers, the
  peak read from ``/usr/bin/time -v``, the step counts, the scene it gives dyncontact
  (the GetFEM script's problem), interleaved rounds with the best kept, and a clean exit 0
  with a message when no Python has GetFEM.
- Skipped without GetFEM's Python interface (Debian python3-getfem): the GetFEM script
  (scripts/getfem_bar.py) gives the reference trace
  tests/data/reference/bar2d_h0.05_hht_a0.csv (copied from ../shared/reference, computed
  with GetFEM 5.4.2), its timed loop to T = 15 and GetFEM's Model.solve to t = 3: it is
  the reference problem, so its times are for the same problem.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from conftest import ROOT

from dyncontact import Scene
from dyncontact.study import getfem_compare as gc

REFERENCE = ROOT / "tests" / "data" / "reference" / "bar2d_h0.05_hht_a0.csv"
SCRIPT = ROOT / "scripts" / "getfem_bar.py"

#: The reference file prints 10 significant digits: |u_n| <= 0.5 is rounded to 2.5e-11,
#: the energies (<= 0.0125) to 6.3e-13. On top of that, two codes that solve the same
#: steps with other sparse factorizations and other Newton stopping tests (each at the
#: 1e-10 relative tolerance) part by round-off over the 6000 steps: at h = 0.05 the GetFEM
#: script's two loops differ by 3.8e-12 in u_n and 9e-14 in e_total, the GetFEM script
#: and dyncontact (gauss 3) by 1.7e-11 and 3.9e-13. The sums (4.2e-11, 1.0e-12) are within:
TOL_U = 5e-11
TOL_E = 1.3e-12
#: v_n and p_n amplify u's differences: v^{n+1} carries (gamma/(beta dt)) (u^{n+1} - u^n)
#: = 800 (u^{n+1} - u^n) at dt = 0.0025, p_n carries gamma_N u_n = 141 u_n. Measured: the
#: two loops differ by 3e-10, the GetFEM script and dyncontact by 1.5e-9, the reference
#: and the GetFEM script by 1.05e-9: 1e-8 is about 7 times the largest.
TOL_VP = 1e-8


def _getfem_python():
    py, _ = gc.find_getfem_python()
    return py


needs_getfem = pytest.mark.skipif(_getfem_python() is None,
                                  reason="GetFEM's Python interface is not installed")


# ----------------------------------------------------------------- the driver's logic

def test_ratio_is_getfem_over_ours():
    assert gc.ratio(20.0, 0.5) == pytest.approx(40.0)
    assert gc.ratio(None, 0.5) is None
    assert gc.ratio(20.0, None) is None
    assert gc.ratio(20.0, 0.0) is None


def test_table_on_canned_rows():
    rows = [{"h": 0.0025, "dofs": 32800, "steps": 400, "getfem_ms": 21.0, "ours_ms": 1.5,
             "ratio": gc.ratio(21.0, 1.5), "getfem_peak_mb": 150.0, "ours_peak_mb": 120.0,
             "getfem_wall_ms": 22.0, "ours_wall_ms": 1.0, "wall_ratio": gc.ratio(22.0, 1.0),
             "ours_threads": 2},
            {"h": 0.00125, "dofs": 129600, "steps": 200, "getfem_ms": 114.0,
             "ours_ms": None, "ratio": None, "getfem_peak_mb": 780.0, "ours_peak_mb": None}]
    lines = gc.rows_table(rows)
    assert lines[0].startswith("| h | dofs | steps | GetFEM script ms/step")
    assert "Model.solve" not in lines[0]           # not measured: no such columns
    assert lines[2] == ("| 0.0025 | 32800 | 400 | 21 | 1.5 | 14 | 150 | 120 | 22 | 1 | 22 | 2 "
                        "| auto |")
    assert lines[3] == ("| 0.00125 | 129600 | 200 | 114 | – | – | 780 | – | – | – | – | – "
                        "| auto |")
    rows[0].update(model_steps=6, model_ms=700.0, model_ratio=gc.ratio(700.0, 1.5))
    lines = gc.rows_table(rows)
    assert lines[0].endswith("| Model.solve steps | Model.solve ms/step | ratio |")
    assert lines[2].endswith("| 6 | 700 | 467 |")
    assert lines[3].endswith("| – | – | – |")


def test_peak_from_time_v():
    text = ("\tCommand being timed: \"python3 getfem_bar.py\"\n"
            "\tUser time (seconds): 1.20\n"
            "\tMaximum resident set size (kbytes): 778572\n"
            "\tExit status: 0\n")
    assert gc.parse_time_v(text) == pytest.approx(778572 / 1024)
    assert gc.parse_time_v("no report") is None


def test_steps_stay_before_the_first_impact():
    for h in gc.SIZES:
        assert gc.steps_for(h) == gc.STEPS[h]
    assert gc.steps_for(0.000625) == round(gc.STEPS[0.00125] / 4)
    assert gc.steps_for(0.1) == gc.MAX_STEPS
    # contact at the probe starts at t = 1.15 (reference README): every step is flight
    assert max(gc.STEPS.values()) <= gc.MAX_STEPS
    assert gc.MAX_STEPS * gc.DT < 1.15


def test_scene_is_the_getfem_scripts_problem(tmp_path):
    path = tmp_path / "s.nml"
    path.write_text(gc.scene_text(0.01, 40, str(tmp_path / "out")))
    s = Scene.read(path)
    expected = {"mesh.h": 0.01, "mesh.dim": 2, "mesh.width": 0.1, "mesh.length": 1.0,
                "contact.theta": 1, "contact.gamma0": 10.0, "contact.quadrature": "gauss",
                "contact.quad_points": 3, "scheme.name": "hht", "scheme.alpha": 0.0,
                "scheme.dt": gc.DT, "scheme.mass": "consistent",
                "initial.kind": "compressed_bar", "initial.amplitude": 0.5,
                "boundary.clamped": "top", "boundary.contact": "bottom"}
    for key, value in expected.items():
        assert s.get(key) == value, key
    assert s.get("scheme.t_end") == pytest.approx(40 * gc.DT)
    assert s.get("material.young") == pytest.approx(2 / 3)
    assert s.get("material.poisson") == pytest.approx(1 / 3)


def test_rounds_interleave_and_keep_the_best(monkeypatch):
    calls = []
    getfem_ms = iter([3.0, 2.0])
    getfem_wall = iter([3.5, 3.1])
    ours_ms = iter([0.05, 0.07])
    ours_wall = iter([0.06, 0.04])

    def fake_getfem(py, h, steps, loop="scipy", env=None, script=None):
        calls.append(("getfem", loop, steps, env))
        return {"ms_per_step": next(getfem_ms), "peak_mb": 60.0 + len(calls),
                "dofs": 2200, "setup_cpu_s": 0.1, "factorizations": 0,
                "ms_per_step_wall": next(getfem_wall)}

    def fake_ours(exe, h, steps, work, env=None):
        calls.append(("ours", steps, env))
        return {"ms_per_step": next(ours_ms), "peak_mb": 9.0, "dofs": 2200,
                "wall_ms_per_step": next(ours_wall), "threads": 2}

    monkeypatch.setattr(gc, "measure_getfem", fake_getfem)
    monkeypatch.setattr(gc, "measure_ours", fake_ours)
    rows = gc.compare("py", "exe", [0.01], steps=50, repeats=2, log=lambda *_: None,
                      env={"G": "1"}, ours_env={"O": "1"})
    assert calls == [("getfem", "scipy", 50, {"G": "1"}), ("ours", 50, {"O": "1"})] * 2
    (r,) = rows
    assert r["getfem_ms"] == 2.0 and r["ours_ms"] == 0.05
    assert r["ratio"] == pytest.approx(40.0)
    # the wall times: the smallest of the rounds, each side on its own
    assert r["getfem_wall_ms"] == 3.1 and r["ours_wall_ms"] == 0.04
    assert r["wall_ratio"] == pytest.approx(3.1 / 0.04) and r["ours_threads"] == 2
    assert r["getfem_peak_mb"] == 63.0        # the largest of the rounds' peaks
    assert r["dofs"] == 2200 and r["steps"] == 50


def test_settings_share_the_getfem_runs(monkeypatch):
    """--threads auto,1: each round runs GetFEM once, then dyncontact with each setting;
    a row for each setting, against the same GetFEM numbers."""
    calls = []

    def fake_getfem(py, h, steps, loop="scipy", env=None, script=None):
        calls.append("getfem")
        return {"ms_per_step": 2.0, "peak_mb": 60.0, "dofs": 2200, "ms_per_step_wall": 2.5}

    def fake_ours(exe, h, steps, work, env=None):
        calls.append(env["T"])
        wall = {"auto": 0.02, "1": 0.04}[env["T"]]
        return {"ms_per_step": 0.05, "peak_mb": 9.0, "dofs": 2200, "wall_ms_per_step": wall,
                "threads": 2 if env["T"] == "auto" else 1}

    monkeypatch.setattr(gc, "measure_getfem", fake_getfem)
    monkeypatch.setattr(gc, "measure_ours", fake_ours)
    rows = gc.compare("py", "exe", [0.01], steps=50, repeats=2, log=lambda *_: None,
                      settings=[("auto", {"T": "auto"}), ("1", {"T": "1"})])
    assert calls == ["getfem", "auto", "1"] * 2
    assert [r["threads_setting"] for r in rows] == ["auto", "1"]
    assert [r["ours_threads"] for r in rows] == [2, 1]
    assert [r["wall_ratio"] for r in rows] == [pytest.approx(125.0), pytest.approx(62.5)]


def test_without_getfem_exits_0_with_a_message(capsys, tmp_path):
    # the project's venv has no GetFEM (dyncontact must not depend on it)
    rc = gc.main(["--getfem-python", sys.executable, "--out", str(tmp_path)])
    assert rc == 0
    out = capsys.readouterr().out
    assert "GetFEM's Python interface is not available" in out
    assert not list(tmp_path.iterdir())       # nothing measured, nothing written


def test_bench_dispatches_getfem_option(tmp_path):
    r = subprocess.run([str(ROOT / "scripts" / "bench"), "--getfem", "--getfem-python",
                        sys.executable, "--out", str(tmp_path)],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "nothing to compare" in r.stdout


# ------------------------------------------- the GetFEM script is the reference problem

@needs_getfem
@pytest.mark.parametrize("loop, t_end", [("scipy", 15.0), ("model", 3.0)])
def test_getfem_script_gives_the_reference_trace(loop, t_end, tmp_path):
    """The timed loop (scipy) over the whole reference; GetFEM's Model.solve through the
    first impact and rebound (t = 1.15 to about 1.9) only, to keep the test short."""
    out = tmp_path / "trace.csv"
    r = subprocess.run([_getfem_python(), str(SCRIPT), "--h", "0.05", "--dt", "0.0025",
                        "--t-end", repr(t_end), "--every", "5", "--loop", loop, "--trace",
                        str(out)], capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr
    got = np.genfromtxt(out, delimiter=",", names=True)
    ref = np.genfromtxt(REFERENCE, delimiter=",", names=True)
    assert len(ref) == 1201
    ref = ref[:len(got)]
    assert len(got) == round(t_end / 0.0025 / 5) + 1
    np.testing.assert_allclose(got["t"], ref["t"], rtol=0, atol=1e-12)
    tols = {"u_n": TOL_U, "e_kin": TOL_E, "e_el": TOL_E, "e_contact": TOL_E,
            "e_total": TOL_E, "v_n": TOL_VP, "p_n": TOL_VP, "sigma_n": TOL_VP}
    for col, tol in tols.items():
        np.testing.assert_allclose(got[col], ref[col], rtol=0, atol=tol, err_msg=col)
    # the comparison is meaningful: the trace goes through contact
    assert (ref["p_n"] < 0).sum() > 40     # 55 rows in contact by t = 3, 235 by 15
