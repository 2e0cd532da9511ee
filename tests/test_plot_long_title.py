"""A long title given to plot_traces (`dyncontact plot --title`) is wrapped to the
figure's width: drawn, it lies inside the figure, above the panels, every word kept
(unwrapped, a title of 200 characters would run off both edges)."""

from __future__ import annotations

import pytest

from test_plotting import _write_run

#: Pixels of clearance between the title and the figure's edges or the panels.
PAD_PX = 1.0

TITLES = {
    "words": "Nitsche contact of the compressed 2D bar with HHT alpha = -0.1 against the "
             "lumped-mass central difference scheme at the same time step, one panel per "
             "quantity at the probe and the energy, every run in its own colour",
    "capitals": "WIDE CAPITAL LETTERS MAKE A LINE LONGER THAN ITS COUNT OF CHARACTERS SAYS "
                * 3,
    "one_word": "/a/very/long/run/folder/" * 12,
    "own_lines": "first line, short\n" + "a second line of many words " * 8,
}


@pytest.mark.parametrize("name", sorted(TITLES))
def test_long_title_lies_inside_the_figure(tmp_path, name):
    from dyncontact.plotting import plot_traces

    title = TITLES[name]
    fig = plot_traces([_write_run(tmp_path / "r")], None, title=title)
    fig.draw_without_rendering()
    text = fig._suptitle
    box = text.get_window_extent()
    width, height = fig.bbox.width, fig.bbox.height
    assert PAD_PX <= box.x0 and box.x1 <= width - PAD_PX, (name, box, width)
    assert box.y1 <= height, (name, box, height)
    for ax in fig.axes[:2]:          # the upper panels start under it
        assert ax.get_tightbbox().y1 + PAD_PX <= box.y0, (name, ax.get_tightbbox(), box)
    drawn = text.get_text()
    assert drawn.count("\n") >= 1
    assert "".join(drawn.split()) == "".join(title.split())     # nothing lost
    if name == "own_lines":
        assert drawn.startswith("first line, short\n")


def test_short_title_is_one_line(tmp_path):
    from dyncontact.plotting import plot_traces

    fig = plot_traces([_write_run(tmp_path / "r")], None, title="two runs")
    assert fig._suptitle.get_text() == "two runs"


def test_plot_command_wraps_its_title(tmp_path):
    """`dyncontact plot --title LONG`: the image written has the title's ink inside its
    edges (run off, the glyphs fill the first and last columns)."""
    from matplotlib.image import imread

    from dyncontact.cli import main

    png = tmp_path / "t.png"
    assert main(["plot", str(_write_run(tmp_path / "r")), "--title", TITLES["words"],
                 "--out", str(png)]) == 0
    img = imread(png)
    band = img[: img.shape[0] // 12, :, :3].min(axis=2)     # the title's rows
    ink = band < 0.5
    assert ink.any()
    assert not ink[:, :2].any() and not ink[:, -2:].any()
