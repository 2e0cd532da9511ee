"""critical_dt.png (study/stability.py, _heatmaps) colours a cell only where a bisection
measured Δt_crit: its key says what the uncoloured cells are (no Δt_crit in the grid's
range, refused, not run), and a map with a single measured value still has a colour bar
with a range (the decade around the value, a tick at it), not one of zero width."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from conftest import saved_figures, stable_grid

H = 0.1
RATIOS = [0.05, 0.5]


def _critical_figure(monkeypatch, crit, schemes, rows, grid):
    import matplotlib
    matplotlib.use("Agg")

    import dyncontact.study.stability as st

    figs = saved_figures(monkeypatch, st)
    st._heatmaps(rows, crit, schemes, grid, "unused")
    return figs[-1]


def _nitsche_and_penalty():
    """A Nitsche scheme on theta = -1 and 1, a penalty scheme on theta = 1 only (it has
    no Nitsche theta): the penalty's theta = -1 cell is not run."""
    schemes = [SimpleNamespace(key="hht-0.1", label="hht", explicit=False),
               SimpleNamespace(key="newmark_penalty", label="penalty", explicit=False)]
    rows, grid = stable_grid(schemes, H, RATIOS)
    grid["theta"] = [-1, 1]
    return schemes, rows, grid


def test_one_value_has_a_colour_bar_around_it(monkeypatch):
    schemes, rows, grid = _nitsche_and_penalty()
    value = 0.25
    crit = [{"scheme": "hht-0.1", "h": H, "gamma0": 10.0, "theta": 1,
             "bracket": "bisection", "dt_crit_lo": 0.02, "dt_crit_hi": 0.03,
             "dt_crit_over_h": value},
            {"scheme": "hht-0.1", "h": H, "gamma0": 10.0, "theta": -1,
             "bracket": "above grid", "dt_crit_lo": 0.05, "dt_crit_over_h": None},
            {"scheme": "newmark_penalty", "h": H, "gamma0": 10.0, "theta": 1,
             "bracket": "refused", "dt_crit_over_h": None}]
    fig = _critical_figure(monkeypatch, crit, schemes, rows, grid)
    panel = fig.axes[0]
    (im,) = panel.get_images()
    z = np.asarray(im.get_array(), dtype=float)
    assert np.isfinite(z).sum() == 1                   # the one bisection cell
    lo, hi = im.norm.vmin, im.norm.vmax
    assert hi > lo, (lo, hi)
    assert lo < math.log10(value) < hi
    assert math.isclose(im.norm(math.log10(value)), 0.5)   # mid-map, not an end
    assert im.colorbar is not None
    ticks = list(im.colorbar.get_ticks())
    assert any(math.isclose(t, math.log10(value)) for t in ticks), ticks
    # the cells without a colour: written '>', 'refused', or nothing (not run)
    texts = {t.get_text() for t in panel.texts}
    assert {">0.5", "refused"} <= texts, texts
    key = panel.get_title().replace("\n", " ")
    for said in ("uncoloured: no Δt_crit measured", "stable / unstable on the whole grid",
                 "'refused': refused by the core", "no text: not run"):
        assert said in key, key


def test_no_value_draws_no_empty_colour_bar(monkeypatch):
    schemes, rows, grid = _nitsche_and_penalty()
    crit = [{"scheme": "hht-0.1", "h": H, "gamma0": 10.0, "theta": th,
             "bracket": "above grid", "dt_crit_lo": 0.05, "dt_crit_over_h": None}
            for th in (-1, 1)]
    fig = _critical_figure(monkeypatch, crit, schemes, rows, grid)
    (im,) = fig.axes[0].get_images()
    assert im.colorbar is None
    assert len(fig.axes) == 1                          # the panel, no colour bar axes
    assert "not run" in fig.axes[0].get_title().replace("\n", " ")


def test_several_values_keep_their_own_range(monkeypatch):
    schemes, rows, grid = _nitsche_and_penalty()
    crit = [{"scheme": "hht-0.1", "h": H, "gamma0": 10.0, "theta": th,
             "bracket": "bisection", "dt_crit_lo": 0.02, "dt_crit_hi": 0.03,
             "dt_crit_over_h": v} for th, v in ((-1, 0.1), (1, 1.0))]
    fig = _critical_figure(monkeypatch, crit, schemes, rows, grid)
    (im,) = fig.axes[0].get_images()
    assert (im.norm.vmin, im.norm.vmax) == (-1.0, 0.0)
