"""Stop signals in both entry points, beyond tests/test_signals_mesh_file.py:

- a SIGINT or SIGTERM ignored when the program starts (`nohup`, a background job of a
  shell without job control) stays ignored, in the executable and in `python -m
  dyncontact run` alike, while the other one still stops the run.

Every child starts with SIGINT at its default (as Ctrl-C finds it in a terminal), since
pytest's own children may have inherited it ignored."""

from __future__ import annotations

import json
import signal
import subprocess
import time
from pathlib import Path

import pytest

from conftest import signal_after
from test_reliability import child_env, entry, write_scene

EXIT_SIGNAL = 130
#: Seconds a run goes on after an ignored signal before it is stopped: several chunks of
#: steps of the Python command line (about 0.5 s each), at the end of the first of which a
#: signal it caught would have stopped it (the executable: at the end of the step).
GOES_ON_S = 3.0


def _long_scene(folder: Path) -> Path:
    """A 1D run of 10^7 steps, a trace row every 1000 steps, into folder/o (stopped long
    before its end)."""
    return write_scene(folder / "long.nml", mesh__dim="1", mesh__h="0.05",
                       contact__obstacle_point="0.0", contact__obstacle_normal="-1.0",
                       contact__probe="0.0", scheme__dt="1e-4", scheme__t_end="1000.0",
                       output__every="1000", output__dir="'o'")


def _trace_size(folder: Path) -> int:
    p = folder / "o" / "trace.csv"
    return p.stat().st_size if p.exists() else 0


def _goes_on(proc: subprocess.Popen, folder: Path, seconds: float,
             timeout: float = 120.0) -> bool:
    """Whether the run goes on for `seconds` from now, its trace growing meanwhile: True
    once both are seen; False if the process ends first."""
    size = _trace_size(folder)
    t_min = time.monotonic() + seconds
    t_end = time.monotonic() + timeout
    while time.monotonic() < t_end:
        if proc.poll() is not None:
            return False
        if time.monotonic() >= t_min and _trace_size(folder) > size:
            return True
        time.sleep(0.05)
    pytest.fail("the run did not write its trace")


@pytest.mark.parametrize("ignored", [signal.SIGINT, signal.SIGTERM], ids=["int", "term"])
@pytest.mark.parametrize("kind", ["exe", "cli"])
def test_a_signal_ignored_at_start_stays_ignored(kind, ignored, tmp_path):
    """Started with `ignored` ignored, the run goes on after it (its trace keeps growing,
    for several chunks of steps of the Python command line); the other stop signal still stops it, exit 130 with
    the trace and summary of an interrupted run. Without the fix the executable installs
    its handler over an ignored SIGINT or SIGTERM and stops, and the Python command line
    does so for SIGTERM."""
    other = signal.SIGTERM if ignored == signal.SIGINT else signal.SIGINT

    def dispositions():
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        signal.signal(ignored, signal.SIG_IGN)

    args = entry(kind) + [str(_long_scene(tmp_path))] + (["--quiet"] if kind == "cli" else [])
    proc = subprocess.Popen(args, cwd=tmp_path, env=child_env(), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, preexec_fn=dispositions)
    with signal_after(proc, other) as ended:
        assert _goes_on(proc, tmp_path, 0.0), proc.communicate()     # rows written
        proc.send_signal(ignored)
        assert _goes_on(proc, tmp_path, GOES_ON_S), \
            (f"stopped by the ignored signal {ignored!r}", proc.communicate())
    assert ended.returncode == EXIT_SIGNAL, (ended.returncode, ended.stdout, ended.stderr)
    if kind == "exe":    # the executable's line names the signal that stopped it
        assert f"interrupted by signal {int(other)} at t = " in ended.stderr, ended.stderr
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summary["status"] == "interrupted"
    assert not (tmp_path / "o" / ".dyncontact.lock").exists()
