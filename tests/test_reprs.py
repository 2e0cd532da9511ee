"""The reprs of what a run returns and of a Stepper: one short line that says where the
run is, never the trace's arrays nor the summary (a printed RunResult of a long run was
megabytes of numbers)."""

from __future__ import annotations

import re

import pytest

import dyncontact
from dyncontact import core

#: A 1D bar dropped on the plane: 50 steps, a trace row every 10 (6 rows with t = 0).
SCENE = """&mesh dim = 1, h = 0.05 /
&contact obstacle_point = 0.0, obstacle_normal = -1.0, probe = 0.0 /
&initial kind = 'compressed_bar', amplitude = 0.5 /
&scheme dt = 1e-3, t_end = 0.05 /
&output dir = 'o', every = 10 /
"""


@pytest.fixture
def scene(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "s.nml").write_text(SCENE, encoding="utf-8")
    return "s.nml"


def test_a_run_results_repr_is_one_short_line(scene, tmp_path):
    res = dyncontact.run(scene, out="o", progress=False)
    rows = len(res.trace["t"])
    assert rows == 6
    columns = ", ".join(core.TRACE_COLUMNS)
    assert repr(res) == (f"<RunResult status='ok' steps=50 "
                         f"t={res.summary['t_end_reached']} out_dir={str(tmp_path / 'o')!r} "
                         f"trace=6 rows x ({columns})>")
    assert str(res) == repr(res)


def test_a_run_results_repr_without_a_summary():
    res = core.RunResult(trace={}, summary={}, out_dir="o", message="stopped")
    assert repr(res) == "<RunResult status='failed' steps=? t=? out_dir='o' trace=0 rows x ()>"


def test_a_steppers_repr_says_where_it_is(scene):
    with core.Stepper(scene, "o") as s:
        assert repr(s) == "<Stepper scene='s.nml' t=0.0 step=0 out='o' open>"
        s.advance(3)
        t = s.state()["t"]
        assert t == pytest.approx(3e-3, rel=1e-12)
        assert repr(s) == f"<Stepper scene='s.nml' t={t!r} step=3 out='o' open>"
        s.advance(100)
        t = s.state()["t"]
        assert repr(s) == f"<Stepper scene='s.nml' t={t!r} step=50 out='o' open, finished>"
    assert repr(s) == f"<Stepper scene='s.nml' t={t!r} step=50 out='o' closed, finished>"


def _no_state(self):
    raise AssertionError("repr copied the state (state())")


@pytest.mark.filterwarnings("ignore:.*&scheme dt = 0 picks")
@pytest.mark.parametrize("dt", ["1e-3", "0"], ids=["given_dt", "central_auto_dt"])
def test_a_steppers_repr_keeps_t_without_copying_the_state(scene, tmp_path, monkeypatch,
                                                           dt):
    """The repr's t is the core's (state()'s t), after an advance, a load and a close,
    without state(), which copies every state array; the central scheme's automatic step
    (dt = 0), which the scene does not give, and a loaded state's t are the core's own
    too. A repr through state() would copy the state, and a closed Stepper's would
    show no t."""
    if dt == "0":
        (tmp_path / "s.nml").write_text(
            SCENE.replace("&scheme dt = 1e-3, t_end = 0.05",
                          "&scheme name = 'central', dt = 0, t_end = 1.0"),
            encoding="utf-8")
    state = core.Stepper.state
    with core.Stepper(scene, "o") as s:
        seen = []
        for act in ("open", "advance", "save", "advance", "load"):
            if act == "advance":
                s.advance(4)
            elif act == "save":
                s.save(tmp_path / "state.bin")
            elif act == "load":
                s.load(tmp_path / "state.bin")
            t = state(s)["t"]
            seen.append(t)
            with monkeypatch.context() as m:
                m.setattr(core.Stepper, "state", _no_state)
                assert repr(s) == (f"<Stepper scene='s.nml' t={t!r} step={s.step} "
                                   "out='o' open>"), act
                assert s.t == t, act
        assert seen[0] == 0.0 < seen[1] < seen[3]
        assert seen[4] == seen[2] == seen[1]
    monkeypatch.setattr(core.Stepper, "state", _no_state)
    assert repr(s) == f"<Stepper scene='s.nml' t={seen[4]!r} step=4 out='o' closed>"


def test_a_steppers_step_follows_a_load(scene, tmp_path):
    with core.Stepper(scene, "o") as s:
        s.advance(5)
        s.save(tmp_path / "state.bin")
        s.advance(7)
        assert s.step == 12
        assert s.load(tmp_path / "state.bin") == 5
        assert s.step == 5
        assert "step=5 " in repr(s)


def test_a_stepper_of_a_scene_object_names_its_file(scene, tmp_path):
    sc = dyncontact.Scene.read(scene)
    with core.Stepper(sc, tmp_path / "o2") as s:
        assert re.fullmatch(r"<Stepper scene='s\.nml' t=0\.0 step=0 out='.*/o2' open>",
                            repr(s)), repr(s)


def test_the_state_docstring_names_every_key(scene):
    """Each key of state() is documented in its docstring (``key``: what it is)."""
    with core.Stepper(scene, "o") as s:
        keys = set(s.state())
    doc = core.Stepper.state.__doc__
    assert keys == {"t", "u", "v", "a", "mv", "load", "bu", "clear", "f_n"}
    for key in keys:
        assert re.search(rf"- ``{key}``( \(\w+\))?: \w", doc), key
