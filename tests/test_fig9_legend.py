"""Fig. 9 (the ball at its maximum compression, study/figures.py): the legend of its
energy panel covers no curve (at the panel's centre right it would lie over e_kin, e_el
and the count of active contact points)."""

from __future__ import annotations

import numpy as np

from conftest import ROOT

import dyncontact

BALL = ROOT / "scripts" / "scenes" / "ball3d_newmark.nml"


def _run(out, **keys):
    scene = dyncontact.Scene.read(BALL)
    for key, value in {"mesh.h": 0.1, "output.fields_every": 0, **keys}.items():
        scene.set(key, value)
    return dyncontact.run(scene, out=out, progress=False)


def test_energy_panel_legend_covers_no_curve(tmp_path, monkeypatch):
    import matplotlib
    matplotlib.use("Agg")

    import dyncontact.study.figures as figures

    trace = _run(tmp_path / "trace")
    k = figures.max_compression(trace.trace)
    # the snapshot run: stopped at the maximum compression, its last snapshot there
    _run(tmp_path / "snap", **{"scheme.t_end": float(trace.trace["t"][k]),
                               "output.fields_every": 10 ** 6})
    figs = []
    monkeypatch.setattr(figures, "save_figure", lambda fig, path, **kw: figs.append(fig))
    figures.plot_ball_snapshot(str(tmp_path / "trace"), str(tmp_path / "snap"),
                               str(tmp_path / "fig9.png"))
    fig = figs[0]
    fig.canvas.draw()
    ax_t = fig.axes[0]
    legend = ax_t.get_legend()
    assert legend is not None
    box = legend.get_window_extent()
    twins = [ax for ax in fig.axes if ax is not ax_t and ax.bbox.bounds == ax_t.bbox.bounds]
    curves = [ln for ax in [ax_t, *twins] for ln in ax.get_lines()
              if len(ln.get_xdata()) > 2]          # not the vertical line at t*
    assert len(curves) == 4                        # e_kin, e_el, e_total, active
    for ln in curves:
        xy = ln.get_transform().transform(np.column_stack([ln.get_xdata(),
                                                           ln.get_ydata()]))
        inside = ((xy[:, 0] > box.x0) & (xy[:, 0] < box.x1)
                  & (xy[:, 1] > box.y0) & (xy[:, 1] < box.y1))
        assert not inside.any(), (ln.get_label(), int(inside.sum()))
