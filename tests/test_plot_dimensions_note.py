"""plot_traces on runs of models of several dimensions: their energies and f_n are per
unit cross-section (1D), per unit thickness (2D) or of the whole body (3D), so one axis
holds curves in different units. The energy panel says so in a note; runs of one
dimension get no note."""

from __future__ import annotations

from conftest import ROOT, drop_unused

import dyncontact
from dyncontact.plotting import plot_traces

SCENES = ROOT / "scripts" / "scenes"


def _run(out, name, **keys):
    scene = dyncontact.Scene.read(SCENES / f"{name}.nml")
    for key, value in {"scheme.t_end": 0.05, **keys}.items():
        scene.set(key, value)
    return dyncontact.run(drop_unused(scene), out=out, progress=False)


def _notes(fig):
    return [t.get_text() for ax in fig.axes for t in ax.texts if t.get_gid() == "dims-note"]


def test_runs_of_1d_2d_and_3d_get_the_note_naming_each(tmp_path):
    one = _run(tmp_path / "bar1d", "bar1d")
    two = _run(tmp_path / "bar2d", "bar2d_hht")
    three = _run(tmp_path / "bar3d", "bar3d_hht")
    assert {r.summary["dim"] for r in (one, two, three)} == {1, 2, 3}
    notes = _notes(plot_traces([one, two, three], None))
    assert len(notes) == 1
    for said in ("1D per unit cross-section", "2D per unit thickness", "3D whole body"):
        assert said in notes[0]
    # two of the three: only theirs named
    (note,) = _notes(plot_traces([one, two], None))
    assert "1D" in note and "2D" in note and "3D" not in note


def test_runs_of_one_dimension_get_no_note(tmp_path):
    a = _run(tmp_path / "a", "bar2d_hht")
    b = _run(tmp_path / "b", "bar2d_newmark")
    assert _notes(plot_traces([a, b], None)) == []
