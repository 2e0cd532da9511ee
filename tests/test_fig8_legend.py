"""Fig. 8 (the 3D box against the 2D strip, study/figures.py): its legend covers no
curve. A legend in each panel ('best' place) would lie over the u_n dips and the energy's
spikes, which fill the panels; one legend under the panels says the runs, their dofs
and e_total(0) (the strip's per unit thickness)."""

from __future__ import annotations

import json

import numpy as np

from conftest import saved_figures
from test_plotting import _write_run


def test_one_legend_under_the_panels(tmp_path, monkeypatch):
    import matplotlib
    matplotlib.use("Agg")

    import dyncontact.study.figures as figures

    strip = _write_run(tmp_path / "strip")
    box = _write_run(tmp_path / "box")
    for run, dofs in ((strip, 120), (box, 540)):
        summary = json.loads((run / "summary.json").read_text())
        summary["dofs"] = dofs
        (run / "summary.json").write_text(json.dumps(summary))
    figs = saved_figures(monkeypatch, figures)
    figures.plot_box_vs_strip(str(strip), str(box), str(tmp_path / "fig8.png"), title="t")
    fig = figs[0]
    assert all(ax.get_legend() is None for ax in fig.axes)
    assert len(fig.legends) == 1
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert labels[0].startswith("2D strip") and "120 dofs" in labels[0]
    assert "per unit thickness" in labels[0]
    assert labels[1].startswith("3D box") and "540 dofs" in labels[1]
    fig.canvas.draw()
    legend = fig.legends[0].get_window_extent()
    assert legend.y0 >= 0
    for ax in fig.axes:
        assert ax.get_tightbbox().y0 >= legend.y1, ax.get_title()
        for ln in ax.get_lines():
            xy = ln.get_transform().transform(np.column_stack([ln.get_xdata(),
                                                               ln.get_ydata()]))
            assert not ((xy[:, 1] < legend.y1) & (xy[:, 1] > legend.y0)).any()
