"""The stability map's title explains every colour its panels show, white included:
the penalty and ALM rows of the Nitsche theta = -1 line are not run (the methods have
no Nitsche theta), and the key says what their white cells are."""

from __future__ import annotations

import warnings
from types import SimpleNamespace

import numpy as np

from conftest import stable_grid


def test_white_cells_not_run_are_explained(tmp_path, monkeypatch):
    import matplotlib
    matplotlib.use("Agg")

    import dyncontact.study.stability as st

    h, ratios = 0.1, [0.05, 0.5]
    schemes = [SimpleNamespace(key="hht-0.1", label="hht α=-0.1", explicit=False),
               SimpleNamespace(key="newmark_penalty", label="newmark penalty",
                               explicit=False)]
    rows = [{"phase": "grid", "scheme": s.key, "h": h, "gamma0": 10.0, "theta": th,
             "dt_over_h": r, "classification": "stable", "stop_time": None}
            for s in schemes for th in (-1, 1) for r in ratios
            if not (s.key == "newmark_penalty" and th == -1)]
    crit = [{"scheme": s.key, "h": h, "gamma0": 10.0, "theta": 1, "bracket": "above grid",
             "dt_crit_lo": 0.05, "dt_crit_over_h": None} for s in schemes]
    grid = {"h": [h], "gamma0": [10.0], "theta": [-1, 1], "t_end": 1.0,
            "dt_over_h": {"implicit": ratios, "explicit": ratios}}
    figs = []
    monkeypatch.setattr(st, "save_figure", lambda fig, path, **kw: figs.append(fig) or path)
    st._heatmaps(rows, crit, schemes, grid, str(tmp_path))
    fig = figs[0]
    cells = [np.asarray(im.get_array(), dtype=float) for ax in fig.axes
             for im in ax.get_images()]
    assert any(np.isnan(z).any() for z in cells)          # the penalty's theta = -1 row
    assert "white not run" in fig._suptitle.get_text()


def test_title_fits_a_map_of_one_scheme(tmp_path, monkeypatch):
    """A map of one or two schemes (a study on a scene of one's own may run so few) is
    one or two panels wide: the colour key must stay inside the figure."""
    import matplotlib
    matplotlib.use("Agg")

    import dyncontact.study.stability as st

    h, ratios = 0.1, [0.05, 0.5]
    scheme = SimpleNamespace(key="hht-0.1", label="hht α=-0.1", explicit=False)
    rows, grid = stable_grid([scheme], h, ratios)
    crit = [{"scheme": "hht-0.1", "h": h, "gamma0": 10.0, "theta": 1,
             "bracket": "above grid", "dt_crit_lo": 0.05, "dt_crit_over_h": None}]
    figs = []

    def keep(fig, path, **kw):
        with warnings.catch_warnings():     # "Tight layout not applied": no room left
            warnings.simplefilter("error")
            fig.tight_layout(rect=kw.get("rect") or (0, 0, 1, kw.get("top", 1.0)))
        figs.append(fig)
        return path

    monkeypatch.setattr(st, "save_figure", keep)
    st._heatmaps(rows, crit, [scheme], grid, str(tmp_path))
    fig = figs[0]
    fig.canvas.draw()
    title = fig._suptitle.get_window_extent()
    assert title.x0 >= 0 and title.x1 <= fig.bbox.width, (title, fig.bbox)
    assert title.y1 <= fig.bbox.height
