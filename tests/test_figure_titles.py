"""The titles of Figs. 1-7 (scripts/figures, study/figures.py) name the body their runs
are of, as those of Figs. 8 and 9 do."""

from __future__ import annotations


def test_titles_of_figs_1_to_7_name_the_body():
    """Figs. 1-7 said the scheme, h and Δt but not the body (the seed's 2D bar), which
    Figs. 8 and 9 name (the box and strip, the ball)."""
    from dyncontact.study.figures import SEED_BAR, figure_plan

    for quick in (False, True):
        for fig in figure_plan(quick):
            if fig.key in {f"fig{k}" for k in range(1, 8)}:
                assert SEED_BAR in fig.title, fig.title
    assert "2D bar" in SEED_BAR


def test_a_long_snapshot_title_stays_inside_the_figure(tmp_path):
    """Fig. 1's title (110 characters) stays within the snapshots' figure."""
    from dyncontact.plotting import plot_field_snapshots
    from dyncontact.study.figures import figure_plan
    from test_plotting import _write_snapshots

    title = next(f.title for f in figure_plan(False) if f.key == "fig1")
    fig = plot_field_snapshots(_write_snapshots(tmp_path / "run", n=5), None, title=title)
    fig.canvas.draw()
    box = fig._suptitle.get_window_extent()
    assert box.x0 >= 0 and box.x1 <= fig.bbox.width and box.y1 <= fig.bbox.height, box
    assert " ".join(fig._suptitle.get_text().split()) == title
