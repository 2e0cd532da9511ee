"""The scaling sweep's memory columns are what docs/performance.md says they are.

- ``base_mb`` is the smallest peak RSS of the executable on the geometry's trivial scene:
  its scene with contact, 0 steps, on the coarsest mesh (``scaling.BASE_H``), the same
  solver kind, run once per geometry and solver in the sweep.
- ``model_mb`` = (4 x 12 x matrix_nnz + 12 x factor_nnz) / 1e6 (unchanged), ``peak_over_model``
  = peak_mb / model_mb (unchanged), and ``peak_over_model_above_base`` =
  (peak_mb - base_mb) / model_mb, on the row's own peak.

The runs are real (a small strip), the peaks read through the sweep's own ``_run_child``,
which the test wraps to see every run the sweep makes and the peak it read.
"""

from __future__ import annotations

import csv
import warnings

import pytest

from dyncontact.study import scaling


def test_memory_columns_are_computed_as_documented(tmp_path, monkeypatch):
    seen = []
    real = scaling._run_child

    def spy(exe, scene, env):
        got = real(exe, scene, env)
        with open(scene, encoding="utf-8") as f:
            seen.append((f.read(), got[1]))
        return got

    monkeypatch.setattr(scaling, "_run_child", spy)
    # the row without contact (contact 0) has no contact boundary by design: the core's
    # warning that its probe reports nothing is kept out of the sweep's output, and no
    # other is given
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rows = scaling.run_scaling(str(tmp_path), sizes=[0.01], steps=2, repeats=2,
                                   log=lambda *_: None, floors=False)
    assert not caught, [str(w.message) for w in caught]
    assert [r["contact"] for r in rows] == [1, 0]
    # the trivial scene: the strip with contact at BASE_H, 0 steps, run `repeats` times,
    # once for the sweep (not once a row)
    base_runs = [peak for text, peak in seen
                 if f"h = {scaling.BASE_H['strip']!r} /" in text]
    assert len(base_runs) == 2
    assert all("t_end = 0.0," in text and "contact = 'bottom'" in text
               for text, _ in seen if f"h = {scaling.BASE_H['strip']!r} /" in text)
    base = min(base_runs)
    for r in rows:
        assert r["base_mb"] == base
        model = (4 * 12.0 * r["matrix_nnz"] + 12.0 * r["factor_nnz"]) / 1.0e6
        assert r["model_mb"] == pytest.approx(model, rel=1e-15)
        assert r["peak_over_model"] == pytest.approx(r["peak_mb"] / r["model_mb"], rel=1e-15)
        assert r["peak_over_model_above_base"] == pytest.approx(
            (r["peak_mb"] - r["base_mb"]) / r["model_mb"], rel=1e-15)
        # the trivial scene (the strip with contact, coarsest mesh, 0 steps; the smallest
        # of its runs) is below a run on a finer mesh (the largest of its runs). The rows
        # are at h = 0.01, whose matrices and factor (model_mb 1.8 MB) put their peaks
        # ~2 MB above it: at h = 0.05 the difference (tens of kB) is below the peaks'
        # run-to-run spread (0.35 MB measured), where the comparison would fail by chance
        assert 0.0 < r["base_mb"]
        assert r["base_mb"] <= r["peak_mb"]
    with open(tmp_path / "scaling.csv", encoding="utf-8") as f:
        table = list(csv.DictReader(f))
    assert list(table[0]) == scaling.COLUMNS
    for t, r in zip(table, rows):
        assert float(t["base_mb"]) == r["base_mb"]
        assert float(t["peak_over_model_above_base"]) == r["peak_over_model_above_base"]
    assert "(peak − base)/model" in (tmp_path / "scaling.md").read_text()


def test_rows_without_a_base_leave_the_column_empty(tmp_path, exe):
    """measure_one without base_mb (a caller that did not measure it): no made-up value."""
    r = scaling.measure_one(str(exe), 0.05, True, 2, str(tmp_path), floors=False, repeats=1)
    assert r["base_mb"] is None and r["peak_over_model_above_base"] is None
    assert r["peak_over_model"] == pytest.approx(r["peak_mb"] / r["model_mb"], rel=1e-15)
