"""The stability study's charts name the scene their runs are of (the heat maps and
critical_dt.png said h and T but not which body: the seed 2D bar, the 3D box or a scene
file), and critical_dt.png's titles stay inside the figure, however few schemes wide."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from conftest import saved_figures, stable_grid


def _draw(monkeypatch, schemes, scene):
    import matplotlib
    matplotlib.use("Agg")

    import dyncontact.study.stability as st

    h, ratios = 0.1, [0.05, 0.5]
    rows, grid = stable_grid(schemes, h, ratios, t_end=30.0)
    crit = [{"scheme": s.key, "h": h, "gamma0": 10.0, "theta": 1, "bracket": "bisection",
             "dt_crit_lo": 0.02, "dt_crit_hi": 0.03, "dt_crit_over_h": 0.25 + 0.01 * k}
            for k, s in enumerate(schemes)]
    figs = saved_figures(monkeypatch, st)
    st._heatmaps(rows, crit, schemes, grid, "unused", scene=scene)
    return figs


@pytest.mark.parametrize("n_schemes", [1, 8])
def test_titles_name_the_scene_and_stay_inside(monkeypatch, n_schemes):
    from dyncontact.study.stability import SEED_SCENE

    schemes = [SimpleNamespace(key=f"s{k}", label=f"scheme {k}", explicit=False)
               for k in range(n_schemes)]
    heat, critical = _draw(monkeypatch, schemes, SEED_SCENE)
    assert SEED_SCENE in heat._suptitle.get_text().replace("\n", " ")
    assert SEED_SCENE == critical._suptitle.get_text().replace("\n", " ")
    critical.canvas.draw()
    width, height = critical.bbox.width, critical.bbox.height
    for text in [critical._suptitle] + [ax.title for ax in critical.axes]:
        box = text.get_window_extent()
        assert box.x0 >= 0 and box.x1 <= width and box.y1 <= height, (text.get_text(), box)


def test_built_in_scenes_say_what_body():
    from dyncontact.study.stability import BOX3D_SCENE, SEED_SCENE

    assert "seed 2D bar" in SEED_SCENE and "E = 2/3" in SEED_SCENE
    assert "3D box" in BOX3D_SCENE
