"""`dyncontact plot` without --title: a title saying the scene the runs share (from their
summary.json), what differs between them being in the legend; --title overrides it and
--title '' draws none."""

from __future__ import annotations

import json

import pytest

from test_plotting import _write_run

SCENE = {"mesh": {"file": "", "dim": 2, "length": 1.0, "width": 0.1, "h": 0.05},
         "material": {"young": 2.0, "poisson": 0.25, "density": 1.0, "gravity": [0.0, 0.0]},
         "contact": {"method": "nitsche", "theta": 1, "gamma0": 10.0,
                     "obstacle_point": [0.0, 0.0], "obstacle_normal": [0.0, -1.0]},
         "initial": {"kind": "compressed_bar", "amplitude": 0.5}}


def _run(folder, scheme="hht", mesh=None, **params):
    run = _write_run(folder, scheme=scheme, **params)
    summary = json.loads((run / "summary.json").read_text())
    summary["scene"] = {**SCENE, "scheme": summary["scene"]["scheme"]}
    if mesh is not None:
        summary["scene"]["mesh"] = mesh
    (run / "summary.json").write_text(json.dumps(summary))
    return run


@pytest.fixture
def plotted(monkeypatch):
    """Run `dyncontact plot ARGS` in this process; the Figure it drew."""
    from dyncontact import cli, plotting

    figs = []

    def keep(*args, **kwargs):
        figs.append(draw(*args, **kwargs))
        return figs[-1]

    draw = plotting.plot_traces
    monkeypatch.setattr(plotting, "plot_traces", keep)

    def plot(*args):
        assert cli.main(["plot", *map(str, args), "--quiet"]) == 0
        return figs[-1]
    return plot


def _title(fig):
    return fig._suptitle.get_text() if fig._suptitle is not None else None


def test_default_title_says_the_shared_scene(tmp_path, plotted):
    a = _run(tmp_path / "a", alpha=0.0)
    b = _run(tmp_path / "b", alpha=-0.1)
    title = _title(plotted(a, b, "--out", tmp_path / "ab.png"))
    assert title is not None
    for part in ("2D bar 0.1 × 1", "h = 0.05", "E = 2", "ν = 0.25", "ρ = 1",
                 "compressed bar (lift 0.5)", "Nitsche θ = 1, γ0 = 10", "hht, Δt = 0.0025"):
        assert part in title, (part, title)
    # lines short enough for the figure's width
    assert max(len(line) for line in title.splitlines()) <= 100


def test_default_title_leaves_out_what_differs(tmp_path, plotted):
    a = _run(tmp_path / "a", scheme="hht", alpha=0.0)
    b = _run(tmp_path / "b", scheme="newmark", beta=0.25, gamma=0.5)
    title = _title(plotted(a, b, "--out", tmp_path / "ab.png"))
    assert "hht" not in title and "newmark" not in title
    assert "Δt = 0.0025" in title and "2D bar" in title


def test_default_title_names_the_mesh_file(tmp_path, plotted):
    mesh = {"file": "/somewhere/meshes/ball_pole.geo", "dim": 3, "length": 0.06,
            "width": 0.2, "h": 0.01}
    run = _run(tmp_path / "a", mesh=mesh)
    title = _title(plotted(run, "--out", tmp_path / "a.png"))
    assert "ball_pole.geo, h = 0.01" in title and "/somewhere" not in title
    assert "bar" not in title.split(";")[0]


def test_title_given_or_none(tmp_path, plotted):
    a = _run(tmp_path / "a")
    assert _title(plotted(a, "--out", tmp_path / "a.png", "--title", "mine")) == "mine"
    assert _title(plotted(a, "--out", tmp_path / "b.png", "--title", "")) is None


def test_plot_help_documents_the_default_title(capsys):
    from dyncontact import cli

    with pytest.raises(SystemExit):
        cli.main(["plot", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "default: the scene the runs share" in text and "--title '' for none" in text
