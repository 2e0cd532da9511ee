"""The scaling chart (scripts/bench --scaling, docs/scaling/*.png) redrawn from the
committed sweeps' CSVs: every panel says on its y axis what it measures and in which
units: the time panels (steps and solves in ms, the set-up in s) and the memory panels
(MB), whose 5-point legends are too small to carry them."""

from __future__ import annotations

import pytest

from conftest import ROOT

CSVS = [ROOT / "docs" / "scaling" / "scaling.csv",
        ROOT / "docs" / "scaling" / "solvers" / "scaling.csv"]


@pytest.mark.parametrize("csv", CSVS, ids=lambda p: str(p.relative_to(ROOT / "docs")))
def test_every_panel_has_a_y_label_with_units(tmp_path, monkeypatch, csv):
    import matplotlib
    matplotlib.use("Agg")

    import dyncontact.study.scaling as scaling

    figs = []
    monkeypatch.setattr(scaling, "save_figure", lambda fig, path, **kw: figs.append(fig))
    scaling.replot(str(tmp_path), [str(csv)])
    axes = [ax for ax in figs[0].axes if ax.has_data()]
    assert axes
    for ax in axes:
        label = ax.get_ylabel()
        if ax.get_title().endswith(": time"):
            assert "ms" in label and "set-up" in label and " s" in label, label
        else:
            assert ax.get_title().endswith(": memory"), ax.get_title()
            assert "MB" in label, label
