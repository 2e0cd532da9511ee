"""The convergence study's chart (convergence.png), drawn from made-up rows: one colour
per scheme, the mesh sizes the study ran readable on the h axis, and a title that says
what was run.

With matplotlib's default cycle of ten colours the study's fourteen schemes would share
colours (newmark and central lumped both blue, theta 1/2 and hht -0.1 redistributed both
red), and the log h axis of 0.04 ... 0.0025 (1.2 decades) would show one number, 10^-2.
"""

from __future__ import annotations

import pytest


def _drawn(tmp_path, monkeypatch, ns):
    import matplotlib
    matplotlib.use("Agg")
    import dyncontact.study.convergence as conv
    from dyncontact.study.analyses import FIELD_NORMS
    from dyncontact.study.common import scheme_list

    schemes = scheme_list(conv.DEFAULT_SCHEMES)
    rows = [{"scheme": s.key, "status": "ok", "h": 1.0 / n,
             **{norm: (1.0 + 0.1 * i) / n ** 0.7 for norm in FIELD_NORMS}}
            for i, s in enumerate(schemes) for n in ns]
    figs = []
    monkeypatch.setattr(conv, "save_figure", lambda fig, path, **kw: figs.append(fig) or path)
    conv._plot(rows, schemes, str(tmp_path / "convergence.png"), t_end=3.0,
               c_implicit=20.0, c_explicit=100.0)
    fig = figs[0]
    fig.canvas.draw()
    return fig, schemes


@pytest.mark.parametrize("ns", [(25, 50, 100), (25, 50, 100, 200, 400)])
def test_each_scheme_has_a_colour_of_its_own(tmp_path, monkeypatch, ns):
    from matplotlib.colors import to_rgba

    fig, schemes = _drawn(tmp_path, monkeypatch, ns)
    labels = {s.label for s in schemes}
    ax = fig.axes[0]
    colours = {ln.get_label(): to_rgba(ln.get_color()) for ln in ax.get_lines()
               if ln.get_label() in labels}
    assert set(colours) == labels
    assert len(set(colours.values())) == len(labels), colours


@pytest.mark.parametrize("ns", [(25, 50, 100), (25, 50, 100, 200, 400)])
def test_every_mesh_size_is_a_number_on_the_h_axis(tmp_path, monkeypatch, ns):
    fig, _ = _drawn(tmp_path, monkeypatch, ns)
    renderer = fig.canvas.get_renderer()
    hs = sorted(1.0 / n for n in ns)
    for ax in fig.axes:
        if not ax.axison:
            continue                     # the legend's panel
        lo, hi = sorted(ax.get_xlim())
        shown = [t for t in ax.xaxis.get_majorticklabels() + ax.xaxis.get_minorticklabels()
                 if t.get_text() and lo <= t.get_position()[0] <= hi]
        values = sorted(t.get_position()[0] for t in shown)
        assert values == pytest.approx(hs), (ax.get_title(), [t.get_text() for t in shown])
        boxes = sorted((t.get_window_extent(renderer) for t in shown), key=lambda b: b.x0)
        for left, right in zip(boxes, boxes[1:]):
            assert left.x1 <= right.x0, (ax.get_title(), [t.get_text() for t in shown])


def test_title_says_the_case_and_the_steps(tmp_path, monkeypatch):
    fig, _ = _drawn(tmp_path, monkeypatch, (25, 50, 100))
    title = fig._suptitle.get_text()
    assert "1D closed form" in title and "T = 3" in title, title
    assert "Δt = h/20 implicit, h/100 explicit" in title, title
    assert "central lumped h/4" in title, title      # a scheme with its own step
