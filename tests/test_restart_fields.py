"""A run continued from a checkpoint leaves in fields/ only the snapshots of its own steps:
those a stopped run wrote after its last checkpoint are removed with the trace's rows
after it, so that a restart to an earlier t_end (or a Stepper gone back to a saved state)
holds the files of the run made straight, no snapshot at a time the trace never reached.

The folder of a run killed after its last checkpoint is made without a kill: a run to
step 100 whose checkpoint is then replaced by the one it wrote at step 50 (the trace and
the snapshots run on past it, as a kill -9 leaves them)."""

from __future__ import annotations

import shutil
import warnings
from pathlib import Path

import pytest

from conftest import ROOT
from dyncontact import Scene, Stepper
from dyncontact.core import DyncontactWarning
from dyncontact.plotting import read_pvd

#: The seed's 2D bar, Δt = 0.0025: 50 steps to t = 0.125, 100 to 0.25, 80 to 0.2.
SCENE = ROOT / "scripts" / "scenes" / "bar2d_hht.nml"
FIELDS_EVERY = 7


def scene(tmp_path: Path, t_end: float, name: str) -> Path:
    s = Scene.read(SCENE)
    s.set("scheme.t_end", t_end)
    s.set("output.every", 3)
    s.set("output.fields_every", FIELDS_EVERY)
    s.set("output.checkpoint_every", 50)
    path = tmp_path / name
    s.write(path)
    return path


def snapshot_steps(folder: Path) -> list[int]:
    return sorted(int(p.name[5:-4]) for p in (folder / "fields").glob("step_*.vtu"))


def listed_steps(folder: Path) -> list[int]:
    return [int(Path(f).name[5:-4]) for _, f in read_pvd(folder / "fields.pvd")]


def test_a_restart_to_an_earlier_end_leaves_no_later_snapshot(run_exe, tmp_path):
    s50, s100, s80 = (scene(tmp_path, t, f"s{t}.nml") for t in (0.125, 0.25, 0.2))
    res = run_exe(s50, "--out", "k")
    assert res.returncode == 0, res.stderr
    shutil.copy(tmp_path / "k" / "checkpoint.bin", tmp_path / "ckpt50.bin")
    res = run_exe(s100, "--restart", "k")          # on to step 100 ...
    assert res.returncode == 0, res.stderr
    assert snapshot_steps(tmp_path / "k")[-3:] == [91, 98, 100]
    shutil.copy(tmp_path / "ckpt50.bin", tmp_path / "k" / "checkpoint.bin")   # ... killed
    res = run_exe(s80, "--restart", "k")           # continued from step 50 to step 80
    assert res.returncode == 0, res.stderr
    res = run_exe(s80, "--out", "straight")
    assert res.returncode == 0, res.stderr

    expected = list(range(0, 81, FIELDS_EVERY)) + [80]      # and the last step's
    assert snapshot_steps(tmp_path / "straight") == expected
    assert snapshot_steps(tmp_path / "k") == expected, "snapshots of steps 84 to 100 left"
    assert listed_steps(tmp_path / "k") == expected
    assert (tmp_path / "k" / "trace.csv").read_bytes() == \
        (tmp_path / "straight" / "trace.csv").read_bytes()


def test_a_stepper_gone_back_to_a_saved_state_leaves_no_later_snapshot(tmp_path):
    path = scene(tmp_path, 0.25, "s.nml")
    out = tmp_path / "out"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DyncontactWarning)
        with Stepper(path, out) as st:
            st.advance(30)
            st.save(tmp_path / "at30.bin")
            st.advance(40)
            assert max(snapshot_steps(out)) == 70
            assert st.load(tmp_path / "at30.bin") == 30
            assert snapshot_steps(out) == list(range(0, 31, FIELDS_EVERY))
            assert listed_steps(out) == snapshot_steps(out)
            st.advance(70)
    assert snapshot_steps(out) == list(range(0, 101, FIELDS_EVERY)) + [100]


@pytest.mark.parametrize("name, kept", [("step_0000084.vtu", False),
                                        ("step_0000049.vtu", True),
                                        ("step_00000x84.vtu", True),     # not a number
                                        ("notes.vtu", True),
                                        ("step_0000091.vtu.tmp", False)])
def test_only_numbered_snapshots_after_the_checkpoint_are_removed(run_exe, tmp_path, name,
                                                                   kept):
    s50, s80 = scene(tmp_path, 0.125, "s50.nml"), scene(tmp_path, 0.2, "s80.nml")
    assert run_exe(s50, "--out", "k").returncode == 0
    (tmp_path / "k" / "fields" / name).write_text("x")
    res = run_exe(s80, "--restart", "k")
    assert res.returncode == 0, res.stderr
    assert (tmp_path / "k" / "fields" / name).exists() == kept


def test_a_restart_to_a_later_end_keeps_no_snapshot_of_the_shorter_runs_end(run_exe,
                                                                           tmp_path):
    """The run to step 50 ends with a snapshot of its last step, off the grid of 7; the run
    continued from its checkpoint to step 100 (a later t_end) holds the fields of the run
    made straight to step 100: no snapshot at step 50, one at step 100, the same files and
    fields.pvd. Continued to step 50 again, the last step's snapshot is written again."""
    s50, s100 = scene(tmp_path, 0.125, "s50.nml"), scene(tmp_path, 0.25, "s100.nml")
    assert run_exe(s50, "--out", "k").returncode == 0
    expected50 = list(range(0, 50, FIELDS_EVERY)) + [50]
    assert snapshot_steps(tmp_path / "k") == listed_steps(tmp_path / "k") == expected50
    last50 = (tmp_path / "k" / "fields" / "step_0000050.vtu").read_bytes()
    shutil.copy(tmp_path / "k" / "checkpoint.bin", tmp_path / "ckpt50.bin")
    res = run_exe(s50, "--restart", "k")        # to the same end: its last snapshot again
    assert res.returncode == 0, res.stderr
    assert snapshot_steps(tmp_path / "k") == listed_steps(tmp_path / "k") == expected50
    assert (tmp_path / "k" / "fields" / "step_0000050.vtu").read_bytes() == last50
    res = run_exe(s100, "--restart", "k")
    assert res.returncode == 0, res.stderr
    assert run_exe(s100, "--out", "straight").returncode == 0
    expected = list(range(0, 100, FIELDS_EVERY)) + [100]
    assert snapshot_steps(tmp_path / "straight") == expected
    for folder in ("k", "straight"):
        assert snapshot_steps(tmp_path / folder) == listed_steps(tmp_path / folder) == expected
    assert (tmp_path / "k" / "fields.pvd").read_bytes() == \
        (tmp_path / "straight" / "fields.pvd").read_bytes()
    for step in expected:
        name = f"fields/step_{step:07d}.vtu"
        assert (tmp_path / "k" / name).read_bytes() == \
            (tmp_path / "straight" / name).read_bytes(), name
