"""The contact methods study's chart (methods.png) from made-up rows: its title says
which scene and settings the runs are (without it: three panels of numbers without the
bar, h or T), and its legend explains the crosses of the runs that did not finish."""

from __future__ import annotations

import math

from conftest import saved_figures


def _rows(unstable: bool):
    from dyncontact.study.methods import MASSES, METHODS, SCHEMES

    rows = []
    for i, method in enumerate(METHODS):
        for mass in MASSES:
            for scheme in SCHEMES:
                bad = unstable and i == 0 and mass == "lumped"
                rows.append({"method": method, "mass": mass, "scheme": scheme,
                             "status": "unstable" if bad else "ok",
                             "e_drift": 1e-3 * (i + 1), "pn_std": 0.1 * (i + 1),
                             "max_un": 1e-4 if i < 4 else 0.0})
    return rows


def _drawn(monkeypatch, rows, **kw):
    import matplotlib
    matplotlib.use("Agg")

    import dyncontact.study.methods as methods

    figs = []
    monkeypatch.setattr(methods, "save_figure", lambda fig, path, **k: figs.append(fig))
    methods._chart(rows, "methods.png", **kw)
    return figs[0]


def test_title_names_the_scene_and_its_settings(monkeypatch):
    fig = _drawn(monkeypatch, _rows(False), h=0.1, t_end=3.0)
    title = fig._suptitle.get_text()
    assert "seed 2D bar" in title and "h = 0.1" in title and "T = 3" in title, title
    assert "Δt = h/20" in title and "γ0 = 10" in title, title


def test_legend_explains_the_crosses_of_unfinished_runs(monkeypatch):
    fig = _drawn(monkeypatch, _rows(True), h=0.05, t_end=15.0)
    crosses = [ln for ax in fig.axes for ln in ax.get_lines() if ln.get_marker() == "x"
               and len(ln.get_xdata()) and not math.isnan(ln.get_xdata()[0])]
    assert crosses
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert any("not finished" in label for label in labels), labels


def test_legend_covers_no_point(monkeypatch):
    """Beside the panels: inside the first ('best' place) it would cover the ALM runs'
    points."""
    import numpy as np

    import matplotlib
    matplotlib.use("Agg")

    import dyncontact.study.methods as methods

    rows = _rows(True)
    for k, r in enumerate(rows):          # points spread over the panels' whole height
        r["e_drift"] = 10.0 ** (-4 + 4 * (k % 7) / 6)
    figs = saved_figures(monkeypatch, methods)
    methods._chart(rows, "methods.png", h=0.1, t_end=3.0)
    fig = figs[0]
    fig.canvas.draw()
    legends = fig.legends + [ax.get_legend() for ax in fig.axes if ax.get_legend()]
    assert len(legends) == 1
    box = legends[0].get_window_extent()
    for ax in fig.axes:
        for ln in ax.get_lines():
            if not len(ln.get_xdata()):
                continue                  # the legend's own entries
            xy = ln.get_transform().transform(np.column_stack([ln.get_xdata(),
                                                               ln.get_ydata()]))
            inside = ((xy[:, 0] > box.x0) & (xy[:, 0] < box.x1)
                      & (xy[:, 1] > box.y0) & (xy[:, 1] < box.y1))
            assert not inside.any(), ax.get_title()
    assert box.x1 <= fig.bbox.width


def _points(ax):
    """(x, y) of the runs' markers in a panel (not the floor's line)."""
    return [(float(ln.get_xdata()[0]), float(ln.get_ydata()[0])) for ln in ax.get_lines()
            if ln.get_gid() is None and len(ln.get_xdata()) == 1]


def test_penetration_panel_says_where_zero_and_gaps_are_drawn(monkeypatch):
    """The max u_n panel drew exact zeros (and the ALM's round-off) at 1e-16 without
    saying so, and a gap (max u_n < 0: the probe stayed off the plane) as a penetration
    of its size, |max u_n|."""
    from dyncontact.study.methods import ZERO_FLOOR

    rows = _rows(False)
    values = {"nitsche 1": 2e-3, "penalty": 3e-18, "alm integral": 0.0, "alm nodal": -1e-3}
    for r in rows:
        r["max_un"] = values.get(r["method"], 1e-4)
    fig = _drawn(monkeypatch, rows, h=0.1, t_end=3.0)
    ax = fig.axes[2]
    assert "penetration" in ax.get_title()
    ys = sorted({y for _x, y in _points(ax)})
    assert ys == [ZERO_FLOOR, 1e-4, 2e-3], ys      # the gap -1e-3 not drawn as 1e-3
    floor = [ln for ln in ax.get_lines() if ln.get_gid() == "zero-floor"]
    assert len(floor) == 1 and floor[0].get_ydata()[0] == ZERO_FLOOR
    notes = [t.get_text() for t in ax.texts if t.get_gid() == "zero-floor-note"]
    assert len(notes) == 1 and "none" in notes[0] and f"{ZERO_FLOOR:g}" in notes[0], notes


def test_no_floor_line_without_values_under_it(monkeypatch):
    rows = _rows(False)
    for r in rows:
        r["max_un"] = 1e-4
    fig = _drawn(monkeypatch, rows, h=0.1, t_end=3.0)
    for ax in fig.axes:
        assert not [ln for ln in ax.get_lines() if ln.get_gid() == "zero-floor"]
        assert not [t for t in ax.texts if t.get_gid() == "zero-floor-note"]
