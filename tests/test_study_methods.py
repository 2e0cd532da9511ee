"""``study methods`` (python/dyncontact/study/methods.py): the table of contact method x
mass x scheme is built from runs, one row each, and its metrics are those of the traces."""

from __future__ import annotations

import csv

import numpy as np

import dyncontact
from dyncontact.study.methods import (MASSES, METHODS, PN_BAR, SCHEMES, analyse_methods,
                                      run_methods)


def test_methods_table_is_built_from_runs(tmp_path):
    rep = run_methods(str(tmp_path / "m"), quick=True, workers=1, progress=False)
    assert rep["n_errors"] == 0
    with open(rep["csv"], newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == len(METHODS) * len(MASSES) * len(SCHEMES) == rep["n_runs"]
    assert {(r["method"], r["mass"], r["scheme"]) for r in rows} == \
        {(m, k, s) for m in METHODS for k in MASSES for s in SCHEMES}
    assert (tmp_path / "m" / "methods.png").stat().st_size > 0
    text = (tmp_path / "m" / "summary.md").read_text()
    assert "| alm nodal | redistributed | newmark |" in text
    by = {(r["method"], r["mass"], r["scheme"]): r for r in rows}
    # facts of the quick table that do not depend on tuning: the multipliers with the
    # redistributed mass never let the probe node penetrate; Newton iterates at least once
    for m in ("alm integral", "alm nodal"):
        for s in SCHEMES:
            assert float(by[(m, "redistributed", s)]["max_un"]) <= 1e-14
    assert all(float(r["its_per_step"]) >= 1.0 for r in rows)


def test_methods_metrics_are_those_of_the_trace(tmp_path):
    s = dyncontact.Scene()
    for k, v in {"mesh.h": 0.1, "scheme.dt": 0.005, "scheme.t_end": 2.0,
                 "contact.method": "nitsche", "contact.theta": 1}.items():
        s.set(k, v)
    res = dyncontact.run(s, out=tmp_path / "run", progress=False)
    m = analyse_methods(str(tmp_path / "run"), res)["metrics"]
    tr = res.trace
    e = tr["e_total"] + tr["e_contact"]
    w = (tr["t"] > 1.2) & (tr["t"] < 1.8)
    assert m["e_drift"] == e[-1] / e[0] - 1
    assert m["max_un"] == tr["u_n"].max()
    assert np.isclose(m["pn_mean_err"], tr["p_n"][w].mean() - PN_BAR, rtol=0, atol=1e-15)
    assert np.isclose(m["its_per_step"], res.summary["newton_its_total"] / (len(tr["t"]) - 1))


def test_methods_pn_reference_is_the_strips_bar_value(tmp_path):
    """The p_n error is taken against the seed strip's own thin-bar stress: the 1D closed
    form's -amplitude x modulus with the plane-strain bar modulus E/(1 - ν²) of the
    default scene's material (-3/8), not the modulus-1 bar's -1/2. A run of that strip
    shows it: its contact phase lasts about 1/c = 1/√0.75 = 1.15 (not 1), and its mean
    p_n over the window lies far closer to -3/8 than to -1/2."""
    s = dyncontact.Scene()
    young, nu = s.get("material.young"), s.get("material.poisson")
    assert np.isclose(PN_BAR, -s.get("initial.amplitude") * young / (1 - nu ** 2),
                      rtol=0, atol=1e-15)
    assert np.isclose(PN_BAR, -3 / 8, rtol=0, atol=1e-15)
    for k, v in {"mesh.h": 0.1, "scheme.dt": 0.005, "scheme.t_end": 2.5}.items():
        s.set(k, v)
    tr = dyncontact.run(s, out=tmp_path / "run", progress=False).trace
    on = tr["t"][tr["active"] > 0]
    assert abs((on.max() - on.min()) - 1 / np.sqrt(0.75)) < 0.05
    w = (tr["t"] > 1.2) & (tr["t"] < 1.8)
    mean = tr["p_n"][w].mean()
    assert abs(mean - PN_BAR) < abs(mean + 0.5) / 4
