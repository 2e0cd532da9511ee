"""dyncontact driven from one Python process (a notebook's kernel): the values a Python
user passes (paths, fractions, numpy numbers, lists of group names) are taken or refused
as the docs say; bad input is a BadInputError naming the file (a Scene's, never its
temporary copy) and the key, also from the studies on a scene of one's own; a Stepper
refuses a wrong argument with a TypeError as run() does; an interrupt from run()'s
callback keeps the run and says what was kept. Small scenes only: the 1D bar at h = 0.05
over a short t_end."""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest

from conftest import ROOT

import dyncontact
from dyncontact import BadInputError, Scene, Stepper
from dyncontact.study.sweep import by_tags, make_task, sweep

BAR1D = ROOT / "scripts" / "scenes" / "bar1d.nml"
GEO = ROOT / "meshes" / "bar2d.geo"


def small_bar() -> Scene:
    scene = Scene.read(BAR1D)
    scene.set("mesh.h", 0.05)
    scene.set("scheme.dt", 0.0025)
    scene.set("scheme.t_end", 0.05)
    return scene


@pytest.mark.parametrize("key, value", [("mesh.file", GEO), ("output.dir", Path("out/x"))])
def test_scene_set_takes_a_path_for_a_string_key(key, value):
    scene = small_bar()
    scene.set(key, value)
    assert scene.get(key) == str(value)


def test_run_of_a_scene_whose_mesh_file_was_set_as_a_path(tmp_path):
    scene = small_bar()
    scene.set("mesh.dim", 0)
    scene.set("mesh.file", GEO)
    scene.set("mesh.h", 0.1)
    scene.unset("contact.obstacle_normal", "contact.probe", "contact.obstacle_point",
                "material.gravity")
    res = dyncontact.run(scene, out=tmp_path / "run", progress=False)
    assert res.status == "ok"
    assert res.summary["scene"]["mesh"]["file"] == str(GEO)


def test_scene_set_takes_a_fraction_as_its_value():
    scene = small_bar()
    scene.set("scheme.dt", Fraction(1, 400))
    assert scene.get("scheme.dt") == 0.0025


@pytest.mark.parametrize("text", ["1/400", "0.1 /", "0.1, t_end = 3"])
def test_scene_set_of_a_value_that_ends_the_group_names_the_key(text):
    scene = small_bar()
    with pytest.raises(BadInputError) as info:
        scene.set("scheme.dt", text)
    msg = str(info.value)
    assert msg.startswith(f"{BAR1D}: &scheme dt: ")
    assert f"(got '{text}')" in msg
    assert "line " not in msg
    assert scene.get("scheme.dt") == 0.0025     # the scene is left as it was


@pytest.mark.parametrize("bad", [3, {"scheme.dt": 0.001}, None])
def test_stepper_of_something_not_a_scene_is_a_type_error(bad, tmp_path):
    with pytest.raises(TypeError, match=r"Stepper\(\): scene must be a path"):
        Stepper(bad, tmp_path / "out")
    with pytest.raises(TypeError, match=r"run\(\): scene must be a path"):
        dyncontact.run(bad, out=tmp_path / "out")


def test_sweep_takes_numpy_values_and_a_numpy_worker_count(tmp_path):
    dts = np.array([0.005, 0.0025])
    tasks = [make_task(str(BAR1D), {"mesh.h": 0.05, "scheme.dt": dt,
                                    "scheme.t_end": np.float32(0.05)}, tags={"dt": dt})
             for dt in dts]
    rows = by_tags(sweep(tasks, str(tmp_path / "cache"), workers=np.int64(1),
                         progress=False))
    assert [(r["dt"], r["status"], r["steps"]) for r in rows] == [(0.005, "ok", 10),
                                                                   (0.0025, "ok", 20)]


def test_stepper_advance_takes_a_numpy_integer_or_a_0d_integer_array(tmp_path):
    with Stepper(small_bar(), tmp_path / "out") as st:
        assert st.advance(np.int64(2)) == 2
        assert st.advance(np.array(3)) == 3
        assert st.state()["t"] == pytest.approx(5 * 0.0025, rel=1e-12)
        for bad in (2.0, np.array(2.0), True, np.array(True), [2]):
            with pytest.raises(TypeError, match="steps must be an int"):
                st.advance(bad)


def test_interrupt_in_the_callback_of_the_last_chunk_says_the_run_ended(tmp_path):
    """A KeyboardInterrupt raised by the callback after the last step keeps the complete
    run, and its text says so (it was empty: the run had written no message)."""
    def stop_at_end(step, n_steps):
        if step == n_steps:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt) as info:
        dyncontact.run(small_bar(), out=tmp_path / "out", progress=False,
                       callback=stop_at_end)
    assert str(info.value) == ("interrupted after the run ended at t = 0.05 "
                               "(trace and summary complete)")
    summary = dyncontact.core.read_summary(tmp_path / "out")
    assert (summary["status"], summary["steps"]) == ("ok", 20)
    assert len(dyncontact.core.read_trace(tmp_path / "out")["t"]) == 21
    # the folder's lock is released: the next run writes there
    assert dyncontact.run(small_bar(), out=tmp_path / "out", progress=False).status == "ok"


@pytest.mark.parametrize("study", ["stability", "work_precision"])
def test_study_on_a_bad_scene_raises_bad_input_naming_it(study, tmp_path):
    """README: bad input raises dyncontact.BadInputError; the studies on a scene of
    one's own raised a plain ValueError, which `except BadInputError` missed."""
    if study == "stability":
        from dyncontact.study.stability import run_stability_scene as run_study
    else:
        from dyncontact.study.workprecision import run_work_precision_scene as run_study
    missing = tmp_path / "missing.nml"
    with pytest.raises(BadInputError, match=f"{missing}: no such file"):
        run_study(str(tmp_path / "study"), missing, quick=True, workers=1, progress=False)
    no_step = tmp_path / "central.nml"
    no_step.write_text("&scheme name = 'central', dt = 0 /\n")
    with pytest.raises(BadInputError, match=r"central.nml: &scheme dt = 0: the study"):
        run_study(str(tmp_path / "study"), no_step, quick=True, workers=1, progress=False)
    scene = small_bar()
    scene.set("scheme.dt", -1.0)                 # refused when the Scene is written
    with pytest.raises(BadInputError, match=rf"{BAR1D}: &scheme dt: "):
        run_study(str(tmp_path / "study"), scene, quick=True, workers=1, progress=False)


def test_scene_set_takes_a_list_of_group_names(tmp_path):
    scene = small_bar()
    scene.set("boundary.slip_x", ["left", "right"])
    assert scene.get("boundary.slip_x") == "left,right"
    scene.set("boundary.slip_x", [])
    assert scene.get("boundary.slip_x") == ""


def test_scene_refused_once_its_mesh_is_read_is_named_by_stepper_and_model(tmp_path):
    """A Scene that only the mesh shows wrong (a 2-component probe for a 3D mesh file
    with &mesh dim = 0) is refused naming the Scene's file, not the temporary file it
    was written to, by Stepper, Model and bench_floors as by run()."""
    scene = Scene()
    scene.set("mesh.file", ROOT / "meshes" / "bar3d_getfem_h0.05.msh")
    scene.set("initial.kind", "compressed_bar")
    scene.set("scheme.t_end", 0.01)
    scene.set("contact.probe", [0.05, 0.0])
    scene.path = str(tmp_path / "mine.nml")
    want = f"{tmp_path / 'mine.nml'}: &contact probe: expected 3 values in 3D (got '0.05, 0.0')"
    calls = [lambda: dyncontact.run(scene, out=tmp_path / "a", progress=False),
             lambda: Stepper(scene, tmp_path / "b"),
             lambda: dyncontact.core.Model(scene)]
    if dyncontact.core.bench_floors_available():
        calls.append(lambda: dyncontact.core.bench_floors(scene, n_rep=1))
    for call in calls:
        with pytest.raises(BadInputError) as info:
            call()
        assert str(info.value) == want


def test_runs_leave_the_callers_scene_as_it_was(tmp_path):
    """run(), Stepper, Model, bench_floors and the studies on a Scene leave it as the
    caller left it: the obstacle normal as given (not normalized: the run's copy is),
    the keys given, the path. The run itself uses the unit normal, as the executable
    does: the same trace as the scene given the unit normal."""
    from dyncontact.core import Model
    from dyncontact.study.common import read_user_scene

    def state(scene):
        return scene.to_dict(), scene.given("contact.obstacle_normal"), scene.path

    scene = small_bar()
    scene.set("contact.obstacle_normal", -2.0)
    before = state(scene)
    res = dyncontact.run(scene, out=tmp_path / "run", progress=False)
    assert state(scene) == before and scene.get("contact.obstacle_normal") == [-2.0, 0.0]
    with Stepper(scene, tmp_path / "stepped") as st:
        st.advance(1)
    with Model(scene):
        pass
    if dyncontact.core.bench_floors_available():
        dyncontact.core.bench_floors(scene, n_rep=1)
    read_user_scene(scene, str(tmp_path / "study"))
    assert state(scene) == before
    unit = small_bar()
    unit.set("contact.obstacle_normal", -1.0)
    same = dyncontact.run(unit, out=tmp_path / "unit", progress=False)
    for column in ("u_n", "p_n", "e_total"):
        np.testing.assert_array_equal(res.trace[column], same.trace[column])


class CallbackBroke(ValueError):
    """An error of the caller's callback (not an interrupt)."""


def test_an_error_in_the_callback_is_said_as_the_callbacks_not_as_an_interrupt(tmp_path):
    """An exception other than KeyboardInterrupt raised by run()'s callback stops the
    run with the trace kept and the folder's lock released; summary.json says the
    callback raised it (its type and text), not 'interrupted' as for Ctrl-C, and the
    exception itself goes on to the caller. Raised after the last chunk, the complete
    run keeps its own summary."""
    def broke_at_first(step, n_steps):
        raise CallbackBroke('no "probe" here\nsecond line')

    scene = small_bar()
    scene.set("output.checkpoint_every", 5)
    with pytest.raises(CallbackBroke) as info:
        dyncontact.run(scene, out=tmp_path / "out", progress=False, callback=broke_at_first)
    assert str(info.value) == 'no "probe" here\nsecond line'
    summary = dyncontact.core.read_summary(tmp_path / "out")
    assert summary["status"] == "interrupted" and 0 < summary["steps"] < 20
    head, _, rest = summary["message"].partition(" at t = ")
    t, _, kept = rest.partition(" ")
    assert head == 'callback raised CallbackBroke: no "probe" here second line; stopped'
    assert float(t) == pytest.approx(summary["t_end_reached"], rel=1e-5)
    assert kept == f"(trace and checkpoint kept: --restart {tmp_path / 'out'} continues)"
    assert len(dyncontact.core.read_trace(tmp_path / "out")["t"]) == summary["steps"] + 1
    # the lock is released and the checkpoint continues the run
    res = dyncontact.run(scene, restart=tmp_path / "out", progress=False)
    assert (res.status, res.summary["steps"]) == ("ok", 20)

    def broke_at_end(step, n_steps):
        if step == n_steps:
            raise CallbackBroke("after the end")

    with pytest.raises(CallbackBroke):
        dyncontact.run(small_bar(), out=tmp_path / "end", progress=False,
                       callback=broke_at_end)
    summary = dyncontact.core.read_summary(tmp_path / "end")
    assert (summary["status"], summary["steps"], summary.get("message", "")) == ("ok", 20, "")


def test_readers_of_a_run_folder_that_is_not_there_raise_bad_input_naming_it(tmp_path):
    """read_trace, read_summary, plot_traces and plot_field_snapshots on a folder that is
    not there (a typo in a notebook) raise the project's bad-input error naming the
    folder, which is still the FileNotFoundError they raised before."""
    import pickle

    from dyncontact.core import RunNotFoundError, read_summary, read_trace
    from dyncontact.plotting import plot_field_snapshots, plot_traces

    missing = tmp_path / "no_such_run"
    a_file = tmp_path / "file.txt"
    a_file.write_text("x\n")
    empty = tmp_path / "empty"
    empty.mkdir()
    cases = [(read_trace, missing, "no such run folder"),
             (read_summary, missing, "no such run folder"),
             (lambda d: plot_traces([d]), missing, "no such run folder"),
             (plot_field_snapshots, missing, "no such run folder"),
             (read_trace, a_file, "not a folder (a run folder holds trace.csv)"),
             (read_trace, empty, "no trace.csv"),
             (lambda d: plot_traces([d]), empty, "no trace.csv"),
             (plot_field_snapshots, empty,
              "no fields.pvd (run with &output fields_every > 0)")]
    for read, folder, what in cases:
        with pytest.raises(BadInputError) as info:
            read(folder)
        exc = info.value
        assert isinstance(exc, FileNotFoundError) and isinstance(exc, RunNotFoundError)
        assert str(exc) == f"{folder}: {what}"
        assert exc.filename == str(folder)
        again = pickle.loads(pickle.dumps(exc))     # as a sweep's worker sends it
        assert type(again) is RunNotFoundError and str(again) == str(exc)
    assert read_summary(empty) == {}                 # a folder without one: as documented
