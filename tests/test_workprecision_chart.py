"""The work-precision chart's series (work_precision.png, 20 series on the built-in
study): one colour per scheme family, its variants told apart by marker and line style
('tab20' gave light/dark pairs of one hue, hard to tell apart), the legend grouped by
family, beside the panels and inside the figure. Drawn from made-up rows."""

from __future__ import annotations

import pytest

from conftest import saved_figures


def _series():
    from dyncontact.study.workprecision import _series
    return _series(20.0, 100.0)


def _family(s):
    return dict(s.settings)["scheme.name"]


def test_one_colour_per_family_and_every_series_its_own_look():
    from matplotlib import colors

    from dyncontact.study.workprecision import series_styles

    series = _series()
    styles = series_styles(series)
    by_family = {}
    for (s, *_rest), (col, _marker, _line) in zip(series, styles):
        by_family.setdefault(_family(s), set()).add(colors.to_hex(col))
    assert len(by_family) >= 7
    assert all(len(c) == 1 for c in by_family.values()), by_family
    family_colours = [next(iter(c)) for c in by_family.values()]
    assert len(set(family_colours)) == len(family_colours), by_family
    looks = [(colors.to_hex(c), m, ls) for c, m, ls in styles]
    assert len(set(looks)) == len(looks)
    # within a family the marker alone tells the variants apart too
    for family in by_family:
        markers = [m for (s, *_r), (_c, m, _l) in zip(series, styles) if _family(s) == family]
        assert len(set(markers)) == len(markers), (family, markers)


@pytest.fixture
def fig(monkeypatch):
    import matplotlib
    matplotlib.use("Agg")

    import dyncontact.study.workprecision as wp

    rows = []
    for case, _title in wp.CASES:
        for k, (_s, c, label, skey) in enumerate(_series()):
            for j, h in enumerate((0.1, 0.05)):
                row = {"case": case, "series": skey, "label": label, "h": h, "dt": h / c,
                       "status": "ok", "cpu_s": 0.01 * (1 + k / 10) * (1 + j)}
                row.update({f"err_{q}": 1e-2 * (1 + k) / (1 + j) for q in wp.QUANTITIES})
                rows.append(row)
    figs = saved_figures(monkeypatch, wp)
    ref = {"quantities": {q: {"est": 1e-4} for q in wp.QUANTITIES}}
    wp._plot(rows, _series(), ref, "work_precision.png")
    return figs[0]


def test_lines_drawn_in_their_styles(fig):
    from matplotlib import colors

    from dyncontact.study.workprecision import series_styles

    series = _series()
    for ax in fig.axes:
        lines = {ln.get_gid(): ln for ln in ax.get_lines() if ln.get_gid()}
        assert len(lines) == len(series)
        for (_s, _c, _label, skey), (col, marker, line) in zip(series, series_styles(series)):
            ln = lines[skey]
            assert colors.to_hex(ln.get_color()) == colors.to_hex(col)
            assert (ln.get_marker(), ln.get_linestyle()) == (marker, line)


def test_legend_grouped_by_family_beside_the_panels(fig):
    series = _series()
    family = {label: _family(s) for s, _c, label, _k in series}
    legend = fig.legends[0]
    labels = [t.get_text() for t in legend.get_texts()]
    assert set(family) <= set(labels)
    order = [family[lab] for lab in labels if lab in family]
    runs = [f for i, f in enumerate(order) if i == 0 or order[i - 1] != f]
    assert len(runs) == len(set(runs)), order      # each family's entries together
    fig.canvas.draw()
    box = legend.get_window_extent()
    assert box.x1 <= fig.bbox.width and box.y0 >= 0 and box.y1 <= fig.bbox.height
    assert all(ax.get_tightbbox().x1 <= box.x0 for ax in fig.axes)


def test_title_says_the_cases_and_steps(monkeypatch):
    """The chart's title says which bodies, T and Δt, which the summary says too."""
    import matplotlib
    matplotlib.use("Agg")

    import dyncontact.study.workprecision as wp

    titles = []

    def plot(rows, series, ref_info, path, cases=wp.CASES, title=""):
        titles.append(title)
        return path
    monkeypatch.setattr(wp, "_plot", plot)
    monkeypatch.setattr(wp, "write_csv", lambda path, rows, cols: path)
    wp._report([], [], _series(), {"truth": {}, "quantities": {}}, "unused", wp.CASES,
               title="the title")
    assert titles == ["the title"]


def test_title_drawn_above_the_panels(monkeypatch):
    import matplotlib
    matplotlib.use("Agg")

    import dyncontact.study.workprecision as wp

    figs = saved_figures(monkeypatch, wp)
    title = ("Error against CPU time to T = 1.5: the 1D exact case (bar [0, 1], E = ρ = 1) "
             "at h = 1/25, 1/50, the seed 2D bar [0, 0.1] × [0, 1] at h = 0.1, 0.05; "
             "Δt = h/20 implicit, h/100 explicit unless labelled")
    wp._plot([], _series(), {}, "work_precision.png", title=title)
    fig = figs[0]
    assert " ".join(fig._suptitle.get_text().split()) == title
    fig.canvas.draw()
    box = fig._suptitle.get_window_extent()
    assert box.x0 >= 0 and box.x1 <= fig.bbox.width and box.y1 <= fig.bbox.height
    assert all(ax.get_tightbbox().y1 <= box.y0 for ax in fig.axes)
    assert all(ax.get_xlabel() == "CPU time (s)" for ax in fig.axes)

