"""plot_traces' fixed layout on the magnitudes of the shipped scenes: nothing drawn
outside the figure and no panel's text over another panel.

The ball (scripts/scenes/ball3d_newmark.nml: u_n from -0.0075 to 0.0125, tick labels of
six characters) pushed the u_n panel's label past the figure's left edge, and the steel
bar in SI units (scripts/scenes/bar2d_steel_si.nml: p_n near -9e8 Pa, f_n near -6e7
N/m) put the scale factors of the lower panels ('1e8', '1e7') under the upper panel,
where they read as its tick labels.
"""

from __future__ import annotations

import numpy as np
import pytest

from test_plotting import HEADER, _write_run

#: Pixels of clearance between a panel's text and the figure's edge or the title...
PAD_PX = 1.0
#: ... and between a lower panel's scale factor and the upper panel, which it would
#: otherwise read as a tick label of.
ROW_PAD_PX = 10.0


def _scaled(folder, u=1.0, v=1.0, p=1.0, e=1.0, f=None, u_shift=0.0):
    """Scale the synthetic run's columns (u_n, v_n, p_n, the energies; u_n from -0.5 u
    to 0.5 u, then shifted by u_shift); f: append e_load = 0 and f_n = f * p_n."""
    rows = np.loadtxt(folder / "trace.csv", delimiter=",", skiprows=1)
    rows[:, 1] = u * rows[:, 1] + u_shift
    rows[:, 2] *= v
    rows[:, 3] *= p
    rows[:, 4:8] *= e
    header = HEADER
    if f is not None:
        rows = np.column_stack([rows, np.zeros(len(rows)), f * rows[:, 3]])
        header += ",e_load,f_n"
    np.savetxt(folder / "trace.csv", rows, delimiter=",", header=header, comments="",
               fmt="%.12e")
    return folder


CASES = {
    # u_n from -0.0075 to 0.0125 as the ball's: wide tick labels on the left
    "ball": dict(u=0.02, u_shift=0.002, v=0.2, p=1.0, e=1.3e-3, f=0.02),
    # the steel bar in SI: scale factors 1e8 (p_n) and 1e7 (f_n) on the lower row
    "steel_si": dict(u=2e-3, v=30.0, p=1.8e9, e=1.1e5, f=0.07),
    # tiny values: a scale factor on the upper row, under a title
    "tiny": dict(u=1e-9, v=1e-8, p=1e-7, e=1e-12, f=0.1),
}


def _boxes(fig):
    fig.draw_without_rendering()
    return [ax.get_tightbbox() for ax in fig.axes]


@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.parametrize("title", [None, "a title"])
def test_panels_stay_inside_the_figure_and_apart(tmp_path, case, title):
    from dyncontact.plotting import plot_traces

    run = _scaled(_write_run(tmp_path / "r"), **CASES[case])
    fig = plot_traces([run], None, title=title)
    boxes = _boxes(fig)
    width, height = fig.bbox.width, fig.bbox.height
    for k, box in enumerate(boxes):
        assert box.x0 >= 0 and box.x1 <= width, (case, k, box)
        assert box.y0 >= 0 and box.y1 <= height, (case, k, box)
    u_n, v_n, p_n, energy = boxes[:4]
    lower = [p_n, energy] + boxes[4:]        # the f_n scale is the p_n panel's twin
    for low in lower:
        for up in (u_n, v_n):
            overlaps_x = low.x0 < up.x1 and up.x0 < low.x1
            assert not overlaps_x or low.y1 + ROW_PAD_PX <= up.y0, (case, low, up)
    if title:
        top = fig._suptitle.get_window_extent()
        for up in (u_n, v_n):
            overlaps_x = top.x0 < up.x1 and up.x0 < top.x1
            assert not overlaps_x or up.y1 + PAD_PX <= top.y0, (case, up, top)


def test_scale_factor_still_shown(tmp_path):
    """The layout makes room for the scale factors; it does not drop them."""
    from dyncontact.plotting import plot_traces

    run = _scaled(_write_run(tmp_path / "r"), **CASES["steel_si"])
    fig = plot_traces([run], None)
    fig.draw_without_rendering()
    assert fig.axes[2].yaxis.get_offset_text().get_text() != ""
    assert fig.axes[2].yaxis.get_offset_text().get_visible()
