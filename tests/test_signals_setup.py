"""A stop signal during a run's set-up (after the mesh read: the assembly, the mass
factorization of the initial acceleration, the critical step's power iterations) stops
the run within a fraction of a second, in the executable, `python -m dyncontact run`,
dyncontact.run() and a Stepper alike: exit 130 (KeyboardInterrupt in Python) with the
line `interrupted by signal N during the set-up at t = 0.00000E+000 (trace kept)`, and
the output folder as that of a run stopped before its first step: summary.json saying
"interrupted" with that line, trace.csv with its header alone, the lock released. A
restart stopped in its set-up leaves its folder as it was.

The scenes are the built-in 3D bar at h = 0.015 (68 000 tetrahedra) under central
differences (the assembly, the mass factorization, the critical step's power
iterations) and the 2D strip at h = 0.0035 under HHT (the factorizations of M and J0,
the orderings tried): each set-up takes 4-6 s on the test machine, each of its pieces a
small part of a second. The signal is sent once the process has spent SETTLE_CPU_S of
CPU time in the run's code (for Python, counted from the moment the core's extension is
loaded), well inside the set-up; without the set-up reading the stop flag the process
would go on for the rest of it (seconds) before it stops."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from conftest import SUBPROCESS_TIMEOUT, signal_after
from test_reliability import child_env, entry, write_scene

EXIT_SIGNAL = 130
#: CPU seconds of the run's own work before the signal is sent: past the scene's read
#: and the mesh, within a set-up of 4-6 s.
SETTLE_CPU_S = 1.0
#: The bound on the time from the signal to the process's end: the set-up's longest
#: piece between two reads of the flag is about 0.1 s here (a chunk of cells, a range of
#: rows, a power iteration), against the 3-5 s of set-up left without them.
PROMPT_S = 1.5
#: The trace's header (trace_output.f90), the whole of trace.csv of a run stopped in its
#: set-up.
TRACE_HEADER = "t,u_n,v_n,p_n,e_kin,e_el,e_contact,e_total,newton_its,active,e_load,f_n\n"


#: The scene of a slow set-up: the built-in 3D bar (1 x 0.2 x 0.2) at h = 0.015 under
#: central differences, one step, into the folder o.
SLOW_SETUP_SCENE = """&mesh dim = 3, length = 1.0, width = 0.2, h = 0.015 /
&boundary clamped = 'top', contact = 'bottom' /
&contact obstacle_point = 0.0, 0.0, 0.0, obstacle_normal = 0.0, 0.0, -1.0,
         probe = 0.1, 0.1, 0.0 /
&initial kind = 'rest' /
&scheme name = 'central', dt = 1e-6, t_end = 1e-6 /
&output dir = 'o' /
"""


#: An implicit scheme's slow set-up: the built-in 2D strip 1 x 1 at h = 0.0035 (some
#: 160 000 dofs; simplicial factors, made by ranges of rows) under HHT: the mass factorization of
#: the initial acceleration, the orderings tried and the factorization of J0.
SLOW_IMPLICIT_SETUP_SCENE = """&mesh dim = 2, length = 1.0, width = 1.0, h = 0.0035 /
&boundary clamped = 'top', contact = 'bottom' /
&contact obstacle_point = 0.0, 0.0, obstacle_normal = 0.0, -1.0, probe = 0.5, 0.0 /
&initial kind = 'rest' /
&scheme name = 'hht', dt = 1e-3, t_end = 1e-3 /
&output dir = 'o' /
"""


def _slow_setup_scene(folder: Path, text: str = SLOW_SETUP_SCENE) -> Path:
    """folder/s.nml: SLOW_SETUP_SCENE, or the scene `text`."""
    path = folder / "s.nml"
    path.write_text(text, encoding="utf-8")
    return path


def _said(sig: int) -> str:
    return f"interrupted by signal {int(sig)} during the set-up at t = 0.00000E+000 (trace kept)"


def _cpu_s(pid: int) -> float:
    """User and system CPU seconds of process pid (/proc/PID/stat)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _core_loaded(pid: int) -> bool:
    """Whether process pid has loaded the core (the executable has it from its start)."""
    maps = Path(f"/proc/{pid}/maps").read_text()
    return "/build/dyncontact\n" in maps or "_core." in maps


def _wait_into_setup(proc: subprocess.Popen, timeout: float = 60.0) -> None:
    """Wait until the process has spent SETTLE_CPU_S of CPU since it loaded the core."""
    if not Path("/proc/self/stat").exists():
        pytest.skip("needs /proc to see the process's CPU time")
    t_end = time.monotonic() + timeout
    start = None
    while time.monotonic() < t_end:
        assert proc.poll() is None, ("ended before the signal", proc.communicate())
        if start is None and _core_loaded(proc.pid):
            start = _cpu_s(proc.pid)
        if start is not None and _cpu_s(proc.pid) - start >= SETTLE_CPU_S:
            return
        time.sleep(0.01)
    pytest.fail("the run did not get into its set-up")


def _start(args: list[str], cwd: Path) -> subprocess.Popen:
    """A child with SIGINT at its default, as Ctrl-C finds it in a terminal."""
    return subprocess.Popen(args, cwd=cwd, env=child_env(), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))


def _assert_stopped_in_setup(folder: Path, sig: int) -> None:
    """The output folder of a run stopped in its set-up by sig."""
    out = folder / "o"
    assert sorted(os.listdir(out)) == ["summary.json", "trace.csv"]
    summary = json.loads((out / "summary.json").read_text())
    assert (summary["status"], summary["message"]) == ("interrupted", _said(sig)), summary
    assert (out / "trace.csv").read_text() == TRACE_HEADER


@pytest.mark.parametrize("kind, sig, scene", [
    ("exe", signal.SIGINT, SLOW_SETUP_SCENE), ("exe", signal.SIGTERM, SLOW_SETUP_SCENE),
    ("cli", signal.SIGINT, SLOW_SETUP_SCENE), ("cli", signal.SIGTERM, SLOW_SETUP_SCENE),
    ("exe", signal.SIGINT, SLOW_IMPLICIT_SETUP_SCENE),
    ("cli", signal.SIGINT, SLOW_IMPLICIT_SETUP_SCENE),
], ids=["exe-int", "exe-term", "cli-int", "cli-term", "exe-int-implicit", "cli-int-implicit"])
def test_a_signal_during_the_setup_stops_the_program_promptly(kind, sig, scene, tmp_path):
    """Exit 130 within PROMPT_S of the signal, the one line of the run stopped in its
    set-up, and its folder: summary.json "interrupted", trace.csv's header, no lock."""
    _slow_setup_scene(tmp_path, scene)
    args = entry(kind) + ["s.nml"] + (["--quiet"] if kind == "cli" else [])
    proc = _start(args, tmp_path)
    with signal_after(proc, sig) as ended:
        _wait_into_setup(proc)
    assert ended.returncode == EXIT_SIGNAL, (ended.returncode, ended.stdout, ended.stderr)
    assert ended.stderr == f"dyncontact: {_said(sig)}\n", ended.stderr
    assert ended.waited < PROMPT_S, ended.waited
    _assert_stopped_in_setup(tmp_path, sig)


#: A library caller: a run (dyncontact.run, or a Stepper) stopped in its set-up by
#: Ctrl-C, then a small run of the same process to its end (the stop flag is cleared
#: after the open: it does not stop the process's later runs). Prints the interrupt's
#: text and the small run's status.
LIBRARY_CALLER = """
import sys
import dyncontact
from dyncontact import core

try:
    if sys.argv[1] == "run":
        dyncontact.run("s.nml", progress=False)
    else:
        core.Stepper("s.nml", "o")
    print("no interrupt", flush=True)
except KeyboardInterrupt as exc:
    print(f"KeyboardInterrupt: {exc}", flush=True)
print(dyncontact.run("small.nml", progress=False).summary["status"])
"""


@pytest.mark.parametrize("caller", ["run", "stepper"])
def test_ctrl_c_during_the_setup_stops_a_library_run_promptly(caller, tmp_path):
    """dyncontact.run() and a Stepper being made raise the KeyboardInterrupt with the
    line of the run stopped in its set-up within PROMPT_S of Ctrl-C, its folder as the
    programs leave it; a later run in the same process goes to its end."""
    _slow_setup_scene(tmp_path)
    write_scene(tmp_path / "small.nml", scheme__t_end="0.01", output__dir="'small'")
    proc = _start([sys.executable, "-c", LIBRARY_CALLER, caller], tmp_path)
    try:
        _wait_into_setup(proc)
        t0 = time.monotonic()
        proc.send_signal(signal.SIGINT)
        # the KeyboardInterrupt's line comes out before the small run: the time to it
        line = proc.stdout.readline()
        waited = time.monotonic() - t0
        rest, err = proc.communicate(timeout=SUBPROCESS_TIMEOUT)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, (proc.returncode, line, rest, err)
    assert line == f"KeyboardInterrupt: {_said(signal.SIGINT)}\n", (line, err)
    assert rest == "ok\n", (rest, err)
    assert waited < PROMPT_S, waited
    _assert_stopped_in_setup(tmp_path, signal.SIGINT)


def test_a_signal_during_a_restarts_setup_leaves_its_folder_as_it_was(exe, tmp_path):
    """`--restart o` stopped in its set-up: exit 130 within PROMPT_S, one line saying
    nothing was written, and the folder byte for byte as the stopped run left it (its
    checkpoint still continues it), no lock."""
    scene = _slow_setup_scene(tmp_path)
    text = SLOW_SETUP_SCENE.replace("t_end = 1e-6", "t_end = 2e-6").replace(
        "dir = 'o'", "dir = 'o', checkpoint_every = 1")
    scene.write_text(text, encoding="utf-8")
    first = subprocess.run([str(exe), "s.nml"], cwd=tmp_path, env=child_env(),
                           capture_output=True, text=True, timeout=SUBPROCESS_TIMEOUT)
    assert first.returncode == 0, first.stderr
    scene.write_text(text.replace("t_end = 2e-6", "t_end = 4e-6"), encoding="utf-8")
    out = tmp_path / "o"
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    assert sorted(before) == ["checkpoint.bin", "summary.json", "trace.csv"], sorted(before)
    proc = _start([str(exe), "s.nml", "--restart", "o"], tmp_path)
    with signal_after(proc, signal.SIGINT) as ended:
        _wait_into_setup(proc)
    assert ended.returncode == EXIT_SIGNAL, (ended.returncode, ended.stdout, ended.stderr)
    assert ended.stderr == ("dyncontact: interrupted by signal 2 during the set-up "
                            "(nothing written)\n"), ended.stderr
    assert ended.waited < PROMPT_S, ended.waited
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before


#: A restart whose contact columns take seconds to solve again: the built-in 2D strip
#: 1 x 1 at h = 0.005 (some 80 000 dofs) under HHT, thrown onto the plane it touches, so
#: that after its first step the whole bottom is in contact and the checkpoint's cache
#: holds every group of columns (some 50 groups of 16 solves with J0). The first run
#: makes that one step (its checkpoint at its end); the restart continues to 2 steps.
COLUMNS_RESTART_SCENE = """&mesh dim = 2, length = 1.0, width = 1.0, h = 0.005 /
&boundary clamped = 'top', contact = 'bottom' /
&contact obstacle_point = 0.0, 0.0, obstacle_normal = 0.0, -1.0, probe = 0.5, 0.0 /
&initial kind = 'velocity', velocity = 0.0, -1.0 /
&scheme name = 'hht', dt = 1e-3, t_end = 1e-3 /
&output dir = 'o', checkpoint_every = 1 /
"""


@pytest.fixture(scope="module")
def stopped_after_contact(tmp_path_factory, exe) -> Path:
    """A folder holding COLUMNS_RESTART_SCENE's run of one step (o/, its checkpoint at
    the step) and the scene continued to 2 steps (s.nml)."""
    folder = tmp_path_factory.mktemp("columns")
    scene = _slow_setup_scene(folder, COLUMNS_RESTART_SCENE)
    first = subprocess.run([str(exe), "s.nml"], cwd=folder, env=child_env(),
                           capture_output=True, text=True, timeout=SUBPROCESS_TIMEOUT)
    assert first.returncode == 0, first.stderr
    scene.write_text(COLUMNS_RESTART_SCENE.replace("t_end = 1e-3", "t_end = 2e-3"),
                     encoding="utf-8")
    return folder


def _wait_for_lock(proc: subprocess.Popen, out: Path, timeout: float = 60.0) -> None:
    """Wait until the restart has taken its folder's lock: its set-up is over, and it
    loads the checkpoint and then solves the checkpoint's contact columns again (seconds
    here) before it writes anything."""
    t_end = time.monotonic() + timeout
    while time.monotonic() < t_end:
        assert proc.poll() is None, ("ended before the signal", proc.communicate())
        if (out / ".dyncontact.lock").exists():
            time.sleep(0.05)       # past the checkpoint's read, into the columns
            return
        time.sleep(0.002)
    pytest.fail("the restart did not take its folder's lock")


@pytest.mark.parametrize("kind", ["exe", "cli"])
def test_a_signal_while_a_restart_solves_its_columns_leaves_its_folder(
        kind, stopped_after_contact, tmp_path):
    """`--restart o` stopped while it solves the checkpoint's contact columns again (the
    stop flag read before each group of columns, as a new run's set-up reads it): exit
    130 within PROMPT_S, the line of a restart stopped in its set-up, and the folder byte
    for byte as the stopped run left it, no lock. Unread there, the signal would wait
    for the columns and the step after them, and the run would stop with that step
    written (its rows, its checkpoint, its summary.json)."""
    for name in ("s.nml", "o"):
        src = stopped_after_contact / name
        (shutil.copytree if src.is_dir() else shutil.copy)(src, tmp_path / name)
    out = tmp_path / "o"
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    assert sorted(before) == ["checkpoint.bin", "summary.json", "trace.csv"], sorted(before)
    args = entry(kind) + ["s.nml", "--restart", "o"] + (["--quiet"] if kind == "cli" else [])
    proc = _start(args, tmp_path)
    with signal_after(proc, signal.SIGINT) as ended:
        _wait_for_lock(proc, out)
    assert ended.returncode == EXIT_SIGNAL, (ended.returncode, ended.stdout, ended.stderr)
    assert ended.stderr == ("dyncontact: interrupted by signal 2 during the set-up "
                            "(nothing written)\n"), ended.stderr
    assert ended.waited < PROMPT_S, ended.waited
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
