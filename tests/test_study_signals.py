"""Signals to the command lines that run a pool of workers (`dyncontact study`,
scripts/figures): SIGTERM stops them as Ctrl-C does (exit 130, docs/scenes.md *Exit
codes*) and no worker outlives its parent, even one killed with SIGKILL.

Each command is started with setsid (start_new_session), so that every process it starts
is in one process group: the test finds them in /proc by that group (psutil is not a
dependency) and kills what is left when it ends, whatever happened.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import pytest

from conftest import ROOT

#: Workers of the pool the commands are started with.
WORKERS = 2
#: Seconds to wait for the pool's workers to appear (the quick runs take seconds; a busy
#: machine is slower to fork and import).
START_TIMEOUT_S = 60.0
#: Seconds a stopped command and its workers may take to end: the parent terminates the
#: workers and waits for them (SIGKILL after 5 s, sweep.WORKER_TERM_S), plus room for a
#: busy machine. Before the fix the workers never ended.
END_TIMEOUT_S = 20.0
POLL_S = 0.05


def _group_members(pgid: int) -> list[int]:
    """Live (not zombie) processes of the process group pgid, from /proc/PID/stat."""
    pids = []
    for name in os.listdir("/proc"):
        if not name.isdigit():
            continue
        try:
            with open(f"/proc/{name}/stat", encoding="ascii", errors="replace") as f:
                stat = f.read()
        except OSError:   # ended in between
            continue
        # pid (comm) state ppid pgrp ...; comm may hold blanks: split after its ')'
        fields = stat[stat.rindex(")") + 2:].split()
        if fields[0] != "Z" and int(fields[2]) == pgid:
            pids.append(int(name))
    return pids


def _children(pid: int) -> list[int]:
    try:
        with open(f"/proc/{pid}/task/{pid}/children", encoding="ascii") as f:
            return [int(x) for x in f.read().split()]
    except OSError:
        return []


def _start(cmd: list[str], cwd) -> subprocess.Popen:
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    return subprocess.Popen(cmd, cwd=cwd, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)


def _wait_for_workers(proc: subprocess.Popen) -> list[int]:
    deadline = time.monotonic() + START_TIMEOUT_S
    while time.monotonic() < deadline:
        kids = _children(proc.pid)
        if len(kids) >= WORKERS:
            return kids
        if proc.poll() is not None:
            break
        time.sleep(POLL_S)
    out, err = proc.communicate(timeout=END_TIMEOUT_S)
    pytest.fail(f"no pool of {WORKERS} workers appeared (exit {proc.returncode}): "
                f"{out[-1000:]} {err[-1000:]}")


def _wait_group_gone(pgid: int) -> list[int]:
    deadline = time.monotonic() + END_TIMEOUT_S
    left = _group_members(pgid)
    while left and time.monotonic() < deadline:
        time.sleep(POLL_S)
        left = _group_members(pgid)
    return left


def _commands(tmp_path):
    study = [sys.executable, "-m", "dyncontact", "study", "convergence", "--quick",
             "--out", str(tmp_path / "study"), "--workers", str(WORKERS), "--no-progress"]
    figures = [str(ROOT / "scripts" / "figures"), "--quick", "--out",
               str(tmp_path / "figures"), "--workers", str(WORKERS)]
    return {"study": study, "figures": figures}


@pytest.fixture
def started(tmp_path):
    """started(name) -> Popen of that command; its process group is killed at the end."""
    procs = []

    def start(name: str) -> subprocess.Popen:
        proc = _start(_commands(tmp_path)[name], tmp_path)
        procs.append(proc)
        return proc

    yield start
    for proc in procs:
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        try:
            proc.communicate(timeout=END_TIMEOUT_S)
        except subprocess.TimeoutExpired:  # pragma: no cover - cannot happen after SIGKILL
            pass


@pytest.mark.parametrize("name", ["study", "figures"])
def test_sigterm_stops_the_pool_like_ctrl_c(started, name):
    proc = started(name)
    workers = _wait_for_workers(proc)
    t0 = time.monotonic()
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=END_TIMEOUT_S)
    assert proc.returncode == 130, (proc.returncode, err[-2000:])
    assert time.monotonic() - t0 < END_TIMEOUT_S
    assert "interrupted" in err and "Traceback" not in err, err[-2000:]
    left = _wait_group_gone(proc.pid)
    assert not left, f"processes left after SIGTERM: {left} (workers were {workers})"


def test_workers_end_when_their_parent_is_killed(started):
    """SIGKILL leaves the parent no chance to stop its pool: the workers must notice the
    parent's end themselves (instead of waiting on the task queue forever)."""
    proc = started("study")
    workers = _wait_for_workers(proc)
    proc.send_signal(signal.SIGKILL)
    proc.communicate(timeout=END_TIMEOUT_S)
    left = _wait_group_gone(proc.pid)
    assert not left, f"workers left after the parent's SIGKILL: {left} (were {workers})"


def test_the_study_resumes_after_sigterm(started, run_cli, tmp_path):
    """The runs finished before SIGTERM are cached; the same command completes (exit 0)."""
    proc = started("study")
    _wait_for_workers(proc)
    proc.send_signal(signal.SIGTERM)
    proc.communicate(timeout=END_TIMEOUT_S)
    assert proc.returncode == 130
    r = run_cli(*_commands(tmp_path)["study"][3:])
    assert r.returncode == 0, r.stderr[-2000:]


def _temporary_entries(cache) -> list[str]:
    return [str(p) for p in cache.glob("*/*.tmp-*")] if cache.is_dir() else []


def test_a_stopped_sweep_leaves_no_temporary_entry(started, tmp_path):
    """The runs in progress when SIGTERM (or Ctrl-C) stops the pool are cut short: their
    temporary cache entries (`<key>.tmp-<pid>-...`, whose workers are gone) are removed
    with them, not left on disk for the 6 h of sweep.STALE_S. The signal is sent once a
    worker has made one, so that there is one to remove."""
    proc = started("study")
    cache = tmp_path / "study" / "cache"
    deadline = time.monotonic() + START_TIMEOUT_S
    while not _temporary_entries(cache) and proc.poll() is None \
            and time.monotonic() < deadline:
        time.sleep(0.01)
    if not _temporary_entries(cache):
        pytest.fail(f"no run started in {cache} (exit {proc.poll()})")
    proc.send_signal(signal.SIGTERM)
    proc.communicate(timeout=END_TIMEOUT_S)
    assert proc.returncode == 130
    assert _wait_group_gone(proc.pid) == []
    assert _temporary_entries(cache) == []


# ------------------------------------------------------------- programs run as children

def _descendants(pid: int) -> list[int]:
    """Every live descendant of pid (children first), from /proc/PID/task/PID/children."""
    out, todo = [], [pid]
    while todo:
        for kid in _children(todo.pop()):
            out.append(kid)
            todo.append(kid)
    return out


def _cmdline(pid: int) -> str:
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as f:
            return f.read().replace(b"\0", b" ").decode("utf-8", "replace")
    except OSError:
        return ""


def _alive(pid: int) -> bool:
    """pid exists and is not a zombie."""
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii", errors="replace") as f:
            stat = f.read()
    except OSError:
        return False
    return stat[stat.rindex(")") + 2:].split()[0] != "Z"


def _wait_pids_gone(pids: list[int]) -> list[int]:
    deadline = time.monotonic() + END_TIMEOUT_S
    left = [p for p in pids if _alive(p)]
    while left and time.monotonic() < deadline:
        time.sleep(POLL_S)
        left = [p for p in left if _alive(p)]
    return left


def _kill_all(proc: subprocess.Popen) -> None:
    """SIGKILL to proc's descendants (in their own process groups or not) and its group,
    whatever the test saw; proc is reaped."""
    for pid in _descendants(proc.pid):
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    proc.wait()


@pytest.mark.skipif(not os.access("/usr/bin/time", os.X_OK), reason="no /usr/bin/time")
def test_child_group_ends_the_program_under_time():
    """The benchmarks run the executable under /usr/bin/time for its peak memory; time
    does not pass SIGTERM on, so stopping time alone left the run going as an orphan.
    child_group ends the child's whole process group."""
    from dyncontact.study.sweep import child_group

    proc = subprocess.Popen(["/usr/bin/time", "-f", "%M", "sleep", "60"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    try:
        deadline = time.monotonic() + START_TIMEOUT_S
        while not _children(proc.pid) and time.monotonic() < deadline:
            time.sleep(POLL_S)
        sleeper = _children(proc.pid)
        assert sleeper, "time started no child"
        with pytest.raises(KeyboardInterrupt):
            with child_group(proc):
                raise KeyboardInterrupt
        assert proc.returncode is not None            # reaped
        assert not _wait_pids_gone(sleeper), "the program under time outlived the group"
    finally:
        _kill_all(proc)


def test_sigterm_to_the_scaling_sweep_ends_its_run(tmp_path):
    """`scripts/bench --scaling` runs each size as a child (the executable under
    /usr/bin/time). SIGTERM to the sweep stops it with exit 130 and the run in progress
    with it; before, that run went on alone after the sweep had died (exit 143)."""
    cmd = [str(ROOT / "scripts" / "bench"), "--scaling", "--sizes", "0.0025",
           "--steps", "20000", "--repeats", "1", "--no-floors", "--contact-only",
           "--out", str(tmp_path / "sc")]
    proc = _start(cmd, tmp_path)
    try:
        runs: list[int] = []
        deadline = time.monotonic() + START_TIMEOUT_S
        while not runs and time.monotonic() < deadline and proc.poll() is None:
            runs = [p for p in _descendants(proc.pid) if "_c_direct_" in _cmdline(p)]
            time.sleep(POLL_S)
        assert runs, f"no timed run appeared (exit {proc.poll()})"
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=END_TIMEOUT_S)
        assert proc.returncode == 130, (proc.returncode, err[-2000:])
        assert "interrupted" in err and "Traceback" not in err, err[-2000:]
        assert not _wait_pids_gone(runs), "the run outlived the sweep"
    finally:
        _kill_all(proc)


def test_sigterm_to_the_bench_writes_what_it_has_and_exits_130(tmp_path):
    """SIGTERM to scripts/bench ends it as Ctrl-C does: the table and the JSON of the
    rows done, exit 130 (before: killed at once, exit 143, nothing written)."""
    out_json = tmp_path / "bench.json"
    cmd = [str(ROOT / "scripts" / "bench"), "--only", "seed_h0.01", "--repeat", "5",
           "--out", str(out_json), "--runs", str(tmp_path / "runs")]
    proc = _start(cmd, tmp_path)
    try:
        deadline = time.monotonic() + START_TIMEOUT_S
        while time.monotonic() < deadline and proc.poll() is None:
            if (tmp_path / "runs").is_dir():     # the first run has started
                break
            time.sleep(POLL_S)
        time.sleep(1.0)
        assert proc.poll() is None, "the bench ended before the signal"
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=END_TIMEOUT_S)
        assert proc.returncode == 130, (proc.returncode, err[-2000:])
        assert "interrupted" in err and "Traceback" not in err, err[-2000:]
        doc = json.loads(out_json.read_text(encoding="utf-8"))
        assert isinstance(doc["rows"], list)
    finally:
        _kill_all(proc)
