"""The Hertz study's chart (hertz.png) from made-up rows: its title names the scene (the
ball, its material, the speeds, the mesh sizes, scheme and contact), as the other
studies' charts do, its axes say what they show, and the legends stay
clear of the x labels."""

from __future__ import annotations

import pytest

from conftest import saved_figures

#: The quick study's series (a/R = 0.1 at h_c = a/2 and a/2.83) and a second one.
SERIES = ((0.1, (2.0, 2.0 ** 1.5)), (0.05, (2.0, 2.0 ** 1.5)))


def _rows():
    from dyncontact.study.hertz import RADIUS, hertz_speed

    rows = []
    for a_over_r, ratios in SERIES:
        for k, a_over_h in enumerate(ratios):
            err = 0.06 / (k + 1)
            rows.append({"a_over_R": a_over_r, "a_over_h": a_over_h,
                         "h_c": a_over_r * RADIUS / a_over_h, "speed": hertz_speed(a_over_r),
                         "status": "ok", "err_tc": err, "err_fmax": -err, "err_delta": err})
    return rows


@pytest.fixture
def fig(monkeypatch):
    import matplotlib
    matplotlib.use("Agg")

    import dyncontact.study.hertz as hertz

    figs = saved_figures(monkeypatch, hertz)
    hertz._chart(_rows(), "hertz.png")
    return figs[0]


def test_title_names_the_scene(fig):
    title = fig._suptitle.get_text()
    for part in ("ball_pole.geo", "R = 0.2", "E = 1", "ν = 0.3", "ρ = 1",
                 "0.00167 (a/R = 0.1)", "0.000296 (a/R = 0.05)", "h_c = a/2, a/2.83",
                 "newmark", "γ0 = 50", "Δt = t_c/140"):
        assert part in title, (part, title)


def test_axes_say_what_they_show(fig):
    for ax in fig.axes:
        assert ax.get_ylabel().startswith("relative error of "), ax.get_ylabel()
        assert ax.get_xlabel().startswith("h_c / a")
        # the values of h_c/a run, as numbers (not 4×10^-1)
        fig.canvas.draw()
        assert [t.get_text() for t in ax.get_xticklabels()] == ["0.354", "0.5"]


def test_legends_clear_of_the_x_labels_and_title_above_the_panels(fig):
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    title_bottom = fig._suptitle.get_window_extent(renderer).y0
    for ax in fig.axes:
        label = ax.xaxis.label.get_window_extent(renderer)
        legend = ax.get_legend().get_window_extent(renderer)
        assert legend.y1 <= label.y0, (legend, label)
        assert ax.get_tightbbox(renderer).y1 <= title_bottom
