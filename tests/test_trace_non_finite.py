"""A trace's values that are not finite (the last row of a run stopped as unstable with a
blow-up limit too high to catch the growth before it overflows) are written nan, inf and
-inf without blanks, as Python and numpy write them: pandas.read_csv reads those as
numbers, but a right-aligned "                Infinity" as text, and with it the whole
column (e_total, ...) of the trace, which then cannot be divided by e_total[0]."""

from __future__ import annotations

import math

import numpy as np

from conftest import ROOT
from dyncontact.core import read_trace

SCENE = ROOT / "scripts" / "scenes" / "bar2d_hht.nml"
#: Central differences at twice their critical step on the seed's bar, with a blow-up
#: limit that lets the energy overflow: the run stops at t = 11.76 (196 steps) on a row
#: with e_el = e_total = inf and e_contact = nan.
ARGS = ["--set", "scheme.name=central", "--set", "scheme.dt=0.06", "--set", "scheme.mass=lumped",
        "--set", "scheme.t_end=200", "--set", "scheme.blowup=1e308"]


def test_non_finite_values_are_written_as_python_writes_them(run_cli, tmp_path):
    res = run_cli("run", SCENE, "--out", "out", "-q", *ARGS)
    assert res.returncode == 3, res.stderr
    lines = (tmp_path / "out" / "trace.csv").read_text().splitlines()
    header = lines[0].split(",")
    non_finite = []
    for line in lines[1:]:
        for name, field in zip(header, line.split(",")):
            value = float(field)
            if not math.isfinite(value):
                non_finite.append((name, field))
                assert field in ("nan", "inf", "-inf"), f"{name}: {field!r}"
    last = dict(zip(header, lines[-1].split(",")))
    assert last["e_total"] == "inf" and last["e_contact"] == "nan", last
    assert non_finite                       # the run did reach the overflow
    tr = read_trace(tmp_path / "out")
    assert tr["e_total"][-1] == np.inf and np.isnan(tr["e_contact"][-1])
    assert np.all(np.isfinite(tr["e_total"][:-1]))
