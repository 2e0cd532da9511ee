"""Field snapshots on disk (docs/scenes.md, outputs): each VTU is written under a temporary
name and renamed, and fields.pvd is rewritten (atomically) at most a second after a
snapshot and at every checkpoint and close, so that after a kill -9 the folder holds a
fields.pvd listing the snapshots written up to a second before, and never part of a VTU
file (a disk that fills up: test_reliability.py); a new run into a folder that holds an
earlier run's snapshots removes them (a restart keeps them, see test_restart.py)."""

from __future__ import annotations

import signal
import subprocess
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from dyncontact.core import read_trace
from dyncontact.plotting import read_pvd
from test_reliability import child_env, entry

EXIT_OK, EXIT_WRITE = 0, 4
#: Seconds to wait for a run to write its first snapshots.
START_TIMEOUT = 60


def scene(path: Path, t_end: str, fields_every: int, dt: str = "0.0025") -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("&mesh file = '', dim = 2, length = 1.0, width = 0.1, h = 0.05 /\n"
                    "&boundary clamped = 'top', contact = 'bottom' /\n"
                    "&contact theta = 1, gamma0 = 10.0, probe = 0.05, 0.0 /\n"
                    "&initial kind = 'compressed_bar', amplitude = 0.5 /\n"
                    f"&scheme name = 'hht', dt = {dt}, t_end = {t_end} /\n"
                    f"&output dir = 'out', every = 100, fields_every = {fields_every} /\n",
                    encoding="utf-8")
    return path


def command(kind: str, scene_path: Path, out: Path) -> list[str]:
    args = entry(kind) + [str(scene_path), "--out", str(out)]
    return args + ["--quiet"] if kind == "cli" else args


def listed(out: Path) -> list[str]:
    """The files fields.pvd lists, in its order."""
    return [ds.get("file") for ds in ET.parse(out / "fields.pvd").getroot().iter("DataSet")]


def on_disk(out: Path) -> list[str]:
    return sorted(f"fields/{p.name}" for p in (out / "fields").glob("step_*.vtu"))


def assert_whole_snapshots(out: Path, every: bool = True) -> list[str]:
    """fields.pvd lists every VTU on disk (every=False: the first ones, in order), each
    a whole XML file; returns the list."""
    files = listed(out)
    assert files == (on_disk(out) if every else on_disk(out)[:len(files)])
    for f in on_disk(out):
        assert ET.parse(out / f).getroot().tag == "VTKFile", f
    return files


def test_kill_9_leaves_a_pvd_listing_the_snapshots(tmp_path):
    """A run killed with SIGKILL (no close) still has fields.pvd listing its first VTUs,
    every one written more than a second (FLUSH_S) before the kill, and only whole VTUs."""
    out = tmp_path / "o"
    s = scene(tmp_path / "s.nml", t_end="400.0", fields_every=4000, dt="1e-4")
    proc = subprocess.Popen(command("exe", s, out), cwd=tmp_path, env=child_env(),
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        t0 = time.time()
        while not (out / "fields").exists() or len(on_disk(out)) < 4:
            assert time.time() - t0 < START_TIMEOUT and proc.poll() is None, "did not start"
            time.sleep(0.01)
        before = on_disk(out)
        time.sleep(2.0)
        assert proc.poll() is None, "the run ended before the kill"
        proc.send_signal(signal.SIGSTOP)     # a state between two snapshots, or within one
        proc.kill()
    finally:
        proc.wait()
    files = assert_whole_snapshots(out, every=False)
    assert files[:len(before)] == before
    assert files[0] == "fields/step_0000000.vtu"


@pytest.mark.parametrize("kind", ["exe", "cli"])
@pytest.mark.parametrize("fields_every, steps", [(50, [0, 50, 100, 150, 200]),
                                                 (60, [0, 60, 120, 180, 200])])
def test_snapshots_every_k_steps_and_at_the_last_step(kind, tmp_path, fields_every, steps):
    """200 steps: a snapshot at step 0 and every fields_every steps, and one at the last
    step when fields_every does not divide the step count (as the trace's last row), so
    that fields.pvd ends with the final state, at the trace's last t."""
    out = tmp_path / "o"
    s = scene(tmp_path / "s.nml", t_end="0.5", fields_every=fields_every)
    res = subprocess.run(command(kind, s, out), cwd=tmp_path, env=child_env(),
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == EXIT_OK, res.stderr
    assert assert_whole_snapshots(out) == [f"fields/step_{k:07d}.vtu" for k in steps]
    times = [t for t, _ in read_pvd(out / "fields.pvd")]
    assert times == pytest.approx([0.0025 * k for k in steps], rel=1e-12, abs=0)
    assert times[-1] == pytest.approx(float(read_trace(out)["t"][-1]), rel=1e-12)


@pytest.mark.parametrize("kind", ["exe", "cli"])
def test_new_run_removes_the_previous_runs_snapshots(kind, tmp_path):
    out = tmp_path / "o"
    s1 = scene(tmp_path / "s1.nml", t_end="1.0", fields_every=100)
    res = subprocess.run(command(kind, s1, out), cwd=tmp_path, env=child_env(), capture_output=True,
                         text=True, timeout=120)
    assert res.returncode == EXIT_OK, res.stderr
    assert len(assert_whole_snapshots(out)) == 5           # steps 0, 100, ..., 400
    (out / "fields" / "notes.txt").write_text("mine")      # not a snapshot: kept

    s2 = scene(tmp_path / "s2.nml", t_end="0.5", fields_every=150)
    res = subprocess.run(command(kind, s2, out), cwd=tmp_path, env=child_env(), capture_output=True,
                         text=True, timeout=120)
    assert res.returncode == EXIT_OK, res.stderr
    assert assert_whole_snapshots(out) == ["fields/step_0000000.vtu", "fields/step_0000150.vtu",
                                           "fields/step_0000200.vtu"]     # the last step

    s3 = scene(tmp_path / "s3.nml", t_end="0.5", fields_every=0)
    res = subprocess.run(command(kind, s3, out), cwd=tmp_path, env=child_env(), capture_output=True,
                         text=True, timeout=120)
    assert res.returncode == EXIT_OK, res.stderr
    assert not (out / "fields.pvd").exists()
    assert on_disk(out) == []
    assert (out / "fields" / "notes.txt").read_text() == "mine"
