"""Signals in runs on a mesh file: reading a .msh or .geo through gmsh leaves the
process's signal dispositions as they were (gmsh's initialization and finalization reset
some, SIGTERM among them), so SIGTERM stops such a run as documented (docs/scenes.md, exit
codes): exit 130, summary status "interrupted", the trace kept, a checkpoint written at the
signal's step and the lock released, in the executable and in `python -m dyncontact run`;
a signal while gmsh meshes a .geo ends the executable and `python -m dyncontact run` at
once, with nothing written, and reaches a library caller's own handling once the read is
over."""

from __future__ import annotations

import json
import signal
import struct
import subprocess
import sys
import time
from pathlib import Path

import pytest

from conftest import ROOT, signal_after
from test_reliability import child_env, entry, wait_for_rows

EXIT_SIGNAL = 130
#: The checkpoint's step: the 7th 8-byte field of its header (docs/scenes.md).
CKPT_STEP_OFFSET = 6 * 8

MSH = ROOT / "meshes" / "bar2d_getfem_h0.05.msh"
GEO = ROOT / "meshes" / "bar2d.geo"

#: Signals whose handlers a caller may have installed; all of them must survive a read.
WATCHED = ("SIGINT", "SIGTERM", "SIGHUP", "SIGQUIT", "SIGUSR1", "SIGFPE", "SIGSEGV",
           "SIGBUS", "SIGPIPE", "SIGALRM", "SIGCHLD")

PROBE = """
import signal, sys
import dyncontact.core as core

def caught():
    for line in open('/proc/self/status'):
        if line.startswith(('SigCgt', 'SigIgn')):
            print(line.strip())

for name in sys.argv[2].split(','):
    signal.signal(getattr(signal, name), lambda *a: None)
caught()
core.load_mesh(sys.argv[1])
caught()
"""


@pytest.mark.parametrize("mesh", [MSH, GEO], ids=["msh", "geo"])
def test_reading_a_mesh_file_keeps_the_signal_dispositions(mesh):
    res = subprocess.run([sys.executable, "-c", PROBE, str(mesh), ",".join(WATCHED)],
                         env=child_env(), capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    lines = res.stdout.split("\n")
    before, after = lines[0:2], lines[2:4]
    assert before == after, (before, after)


def _scene(folder: Path) -> Path:
    """A 2D run on a .msh file long enough to be stopped (500 000 steps)."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "s.nml"
    path.write_text(f"&mesh file = '{MSH}' /\n"
                    "&boundary clamped = 'top', contact = 'bottom' /\n"
                    "&contact theta = 1, gamma0 = 10.0, probe = 0.05, 0.0 /\n"
                    "&initial kind = 'compressed_bar', amplitude = 0.5 /\n"
                    "&scheme name = 'hht', dt = 1e-4, t_end = 50.0 /\n"
                    "&output dir = 'out', every = 10, checkpoint_every = 997 /\n",
                    encoding="utf-8")
    return path


@pytest.mark.parametrize("kind", ["exe", "cli"])
def test_sigterm_stops_a_run_on_a_mesh_file(kind, tmp_path):
    out = tmp_path / "o"
    args = entry(kind) + [str(_scene(tmp_path)), "--out", str(out)]
    if kind == "cli":
        args.append("--quiet")
    proc = subprocess.Popen(args, cwd=tmp_path, env=child_env(), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    with signal_after(proc, signal.SIGTERM, timeout=120) as ended:
        wait_for_rows(out, 300)
    stdout, stderr = ended.stdout, ended.stderr
    assert proc.returncode == EXIT_SIGNAL, (proc.returncode, stdout, stderr)
    assert "interrupted" in stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "interrupted"
    steps = summary["steps"]
    assert steps > 0
    # the trace is kept, up to the step the run stopped on (a row every 10 steps)
    rows = (out / "trace.csv").read_text().splitlines()[1:]
    assert steps * 1e-4 - 10e-4 < float(rows[-1].split(",")[0]) <= steps * 1e-4 * (1 + 1e-12)
    # the checkpoint was written at that step (not only at the last multiple of 997)
    header = (out / "checkpoint.bin").read_bytes()[:7 * 8]
    (ckpt_step,) = struct.unpack_from("<q", header, CKPT_STEP_OFFSET)
    assert ckpt_step == steps
    assert not (out / ".dyncontact.lock").exists()


#: A unit cube meshed at h = 0.03: about 20 s of gmsh meshing (docs/scenes.md, "Signals
#: while gmsh works"), long enough to signal the executable in the middle of it.
CUBE_GEO = """SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 1, 1, 1};
Mesh.MeshSizeMax = h;
Physical Surface("bottom") = {5};
Physical Surface("top") = {6};
Physical Volume("body") = {1};
"""


def _wait_for_gmsh(proc: subprocess.Popen, timeout: float = 60.0) -> None:
    """Wait until the process has loaded libgmsh (it is then reading the file: the
    library is loaded by the read itself), then a little more, into the meshing."""
    t_end = time.monotonic() + timeout
    maps = Path(f"/proc/{proc.pid}/maps")
    while time.monotonic() < t_end and proc.poll() is None:
        if "libgmsh" in maps.read_text():
            time.sleep(0.3)
            return
        time.sleep(0.05)
    pytest.fail("the run did not start reading its .geo with gmsh")


def _cube_scene(folder: Path, h: float) -> None:
    """folder/s.nml, a run on folder/cube.geo (CUBE_GEO) meshed at h."""
    if not Path("/proc/self/maps").exists():
        pytest.skip("needs /proc to see when gmsh is loaded")
    (folder / "cube.geo").write_text(CUBE_GEO, encoding="utf-8")
    (folder / "s.nml").write_text(
        f"&mesh file = 'cube.geo', h = {h}, max_elements = 100000000 /\n"
        "&boundary clamped = 'top', contact = 'bottom' /\n"
        "&contact probe = 0.5, 0.5, 0.0, obstacle_point = 0.0, 0.0, 0.0,\n"
        "         obstacle_normal = 0.0, 0.0, -1.0 /\n"
        "&scheme name = 'hht', dt = 1e-3, t_end = 0.01 /\n", encoding="utf-8")


def _sigint_default() -> None:
    """In the child before it starts: SIGINT as the terminal's Ctrl-C finds it. A child
    of a shell's background job inherits SIGINT ignored, and Python then leaves it
    ignored (no KeyboardInterrupt, and an ignored signal is not even queued)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _sigint_ignored() -> None:
    """In the child before it starts: SIGINT ignored, as `nohup` or a shell's background
    job starts it."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _start(args: list[str], folder: Path, before=_sigint_default) -> subprocess.Popen:
    """A child in folder with SIGINT at its default (or as `before` sets it) and its own
    temporary folder (folder/tmp, $TMPDIR), so that a test sees what it leaves there."""
    (folder / "tmp").mkdir()
    env = dict(child_env(), TMPDIR=str(folder / "tmp"))
    return subprocess.Popen(args, cwd=folder, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, preexec_fn=before)


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["int", "term"])
@pytest.mark.parametrize("kind", ["exe", "cli"])
def test_a_signal_while_gmsh_meshes_ends_the_program_at_once(kind, sig, tmp_path):
    """The executable and `python -m dyncontact run` do not wait for gmsh to finish
    meshing: SIGINT or SIGTERM during the read ends them at once with exit 130 and the
    same line naming the file, and nothing is written: no output folder (it is made after
    the mesh is read), no temporary file. Without the stop the command line would hold
    the signal until gmsh returns, 20 s later, and then stop before the first step
    (SIGINT), or be killed by SIGTERM without a line (gmsh's initialization resets its disposition,
    and numpy's OpenBLAS threads, which do not block it, take it)."""
    _cube_scene(tmp_path, 0.03)
    args = entry(kind) + ["s.nml", "--out", "o"] + (["--quiet"] if kind == "cli" else [])
    proc = _start(args, tmp_path)
    with signal_after(proc, sig, timeout=120) as ended:
        _wait_for_gmsh(proc)
    stdout, stderr = ended.stdout, ended.stderr
    assert proc.returncode == EXIT_SIGNAL, (proc.returncode, stdout, stderr)
    assert stderr == (f"dyncontact: cube.geo: interrupted by signal {int(sig)} while gmsh "
                      "read it; nothing was written\n"), stderr
    assert ended.waited < 5.0, ended.waited          # a fraction of the meshing's 20 s
    assert not (tmp_path / "o").exists()
    assert list((tmp_path / "tmp").iterdir()) == []


def test_an_ignored_sigint_stays_ignored_while_gmsh_meshes(tmp_path):
    """`python -m dyncontact run` started with SIGINT ignored (`nohup`, a background job)
    goes on reading after a SIGINT, as it goes on running after one; SIGTERM still ends it
    at once."""
    _cube_scene(tmp_path, 0.03)
    proc = _start(entry("cli") + ["s.nml", "--out", "o", "--quiet"], tmp_path,
                  before=_sigint_ignored)
    with signal_after(proc, signal.SIGTERM, timeout=120) as ended:
        _wait_for_gmsh(proc)
        proc.send_signal(signal.SIGINT)
        time.sleep(1.0)
        assert proc.poll() is None, proc.communicate()
        assert _reading(proc), "the read ended before the signals: mesh a larger .geo"
    assert proc.returncode == EXIT_SIGNAL, (proc.returncode, ended.stdout, ended.stderr)
    assert ended.stderr == ("dyncontact: cube.geo: interrupted by signal 15 while gmsh read "
                            "it; nothing was written\n"), ended.stderr
    assert not (tmp_path / "o").exists()


def _reading(proc: subprocess.Popen) -> bool:
    """Whether the process's main thread is inside a gmsh read: it blocks SIGINT there
    (and nowhere else in these runs)."""
    for line in Path(f"/proc/{proc.pid}/status").read_text().splitlines():
        if line.startswith("SigBlk:"):
            return bool(int(line.split()[1], 16) >> (int(signal.SIGINT) - 1) & 1)
    return False


#: A library caller: dyncontact.run(), or the command line's main() called inside the
#: caller's process, with SIGTERM raising KeyboardInterrupt as the command line's does.
LIBRARY_CALLER = """
import signal, sys
import dyncontact
from dyncontact import cli

def term(signum, frame):
    raise KeyboardInterrupt(f"signal {signum}")

signal.signal(signal.SIGTERM, term)
if sys.argv[1] == "run":
    try:
        dyncontact.run("s.nml", out="o", progress=False)
    except KeyboardInterrupt as exc:
        print(f"KeyboardInterrupt: {exc}")
else:
    print(f"main returned {cli.main(['run', 's.nml', '--out', 'o', '--quiet'])}")
"""


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["int", "term"])
@pytest.mark.parametrize("caller", ["run", "cli_main"])
def test_a_signal_while_gmsh_meshes_reaches_a_library_caller_after_the_read(
        caller, sig, tmp_path):
    """A library caller's process is not ended by a signal during the read: the signal
    waits for gmsh and reaches the caller's handling (KeyboardInterrupt) once the read is
    over. Ctrl-C's (Python's own handler), and SIGTERM under the command line's main()
    (its handler), reach the core first, whose set-up stops right after the read; the
    caller's own SIGTERM handler (not marked as raising KeyboardInterrupt) is called once
    the open returns, the run then stopping before its first step, as before a signal is
    sent. Only
    `python -m dyncontact` ends itself, not the command line's main() inside another
    program. Without the caller's dispositions put back after gmsh's initialization, a
    SIGTERM during the first read kills the process (status -15, nothing said)."""
    _cube_scene(tmp_path, 0.05)           # about 2 s of meshing: all of it is waited for
    proc = _start([sys.executable, "-c", LIBRARY_CALLER, caller], tmp_path)
    with signal_after(proc, sig, timeout=120) as ended:
        _wait_for_gmsh(proc)
        assert _reading(proc), "the read ended before the signal: mesh a larger .geo"
    stdout, stderr = ended.stdout, ended.stderr
    assert proc.returncode == 0, (proc.returncode, stdout, stderr)
    assert "while gmsh read it" not in stderr, stderr
    # stopped by the signal in the set-up, or once the run is open, before its first
    # step (SIGTERM to the caller's own handler)
    if sig == signal.SIGINT or caller == "cli_main":
        said = (f"interrupted by signal {int(sig)} during the set-up at t = 0.00000E+000 "
                "(trace kept)")
    else:
        said = "interrupted at t = 0.00000E+000 (trace kept)"
    if caller == "run":
        assert stdout == f"KeyboardInterrupt: {said}\n", (stdout, stderr)
    else:
        assert stdout == f"main returned {EXIT_SIGNAL}\n", (stdout, stderr)
        assert stderr == f"dyncontact: {said}\n", stderr
    assert json.loads((tmp_path / "o" / "summary.json").read_text())["status"] == \
        "interrupted"
