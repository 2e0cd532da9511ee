"""Stop signals in both entry points, beyond tests/test_signals_mesh_file.py:

- a SIGINT or SIGTERM ignored when the program starts (`nohup`, a background job of a
  shell without job control) stays ignored, in the executable and in `python -m
  dyncontact run` alike, while the other one still stops the run;
- `python -m dyncontact run --set ...` ends at once on a signal while gmsh meshes its
  .geo, as without --set, and leaves no temporary file;
- `python -m dyncontact mesh --geo` ends at once on a signal while gmsh meshes, writes
  or reads back the mesh, and leaves no file, not even a part of one, and an existing
  file of that name as it was;
- a signal that reaches Python while the core opens a run closes the run it opened,
  in run() as in a Model, a Stepper and bench_floors, and one while the core reads a
  mesh for load_mesh frees the mesh it read;
- `dyncontact study` leaves a SIGTERM ignored at start ignored, as `run` does.

Every child starts with SIGINT at its default (as Ctrl-C finds it in a terminal), since
pytest's own children may have inherited it ignored."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from conftest import ROOT, signal_after
from test_reliability import child_env, entry, write_scene
from test_signals_mesh_file import CUBE_GEO, _cube_scene, _start, _wait_for_gmsh

EXIT_SIGNAL = 130
#: A bound far above what the stop takes (0.01-0.1 s) and far below the 20 s or more
#: that gmsh goes on meshing the cube at h = 0.03 without it.
PROMPT_S = 8.0
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
    for several chunks of steps of the Python command line); the other stop signal still
    stops it, exit 130 with the trace and summary of an interrupted run. A handler
    installed over an ignored signal would stop the run on it."""
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


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["int", "term"])
def test_run_with_set_ends_at_once_while_gmsh_meshes(sig, tmp_path):
    """`run --set` writes the changed scene to a temporary file, which the stop removes:
    a signal while gmsh meshes the .geo ends it at once, exit 130 and the one line naming
    the file (the absolute path the Scene gives it), no output folder, an empty $TMPDIR.
    Without the stop it would wait for the meshing and the set-up (28 s measured), then
    stop before the first step, after making the output folder."""
    _cube_scene(tmp_path, 0.03)
    args = entry("cli") + ["s.nml", "--set", "scheme.dt=0.002", "--out", "o", "--quiet"]
    proc = _start(args, tmp_path)
    with signal_after(proc, sig) as ended:
        _wait_for_gmsh(proc)
    assert ended.returncode == EXIT_SIGNAL, (ended.returncode, ended.stdout, ended.stderr)
    geo = (tmp_path / "cube.geo").resolve()
    assert ended.stderr == (f"dyncontact: {geo}: interrupted by signal {int(sig)} while "
                            "gmsh read it; nothing was written\n"), ended.stderr
    assert ended.waited < PROMPT_S, ended.waited
    assert not (tmp_path / "o").exists()
    assert list((tmp_path / "tmp").iterdir()) == []


def _mesh_args(h: float) -> list[str]:
    return [sys.executable, "-m", "dyncontact", "mesh", "--geo", "cube.geo", "--h", str(h),
            "--out", "m.msh"]


def _meshes(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.endswith(".msh"))


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["int", "term"])
def test_mesh_command_ends_at_once_while_gmsh_meshes(sig, tmp_path):
    """`dyncontact mesh --geo` stopped while gmsh meshes: exit 130 at once, one line
    naming the .geo, no mesh file. Without the guard SIGINT would wait for the meshing
    (6 s measured at this size), and SIGTERM would kill the process without a word
    (status -15: gmsh's initialization resets SIGTERM to its default)."""
    _cube_scene(tmp_path, 0.03)
    proc = _start(_mesh_args(0.03), tmp_path)
    with signal_after(proc, sig) as ended:
        _wait_for_gmsh(proc)
    assert ended.returncode == EXIT_SIGNAL, (ended.returncode, ended.stdout, ended.stderr)
    assert ended.stderr == (f"dyncontact: cube.geo: interrupted by signal {int(sig)} while "
                            "gmsh meshed it; nothing was written\n"), ended.stderr
    assert ended.waited < PROMPT_S, ended.waited
    assert _meshes(tmp_path) == []


def test_mesh_command_stopped_while_writing_leaves_the_old_file(tmp_path):
    """A stop while gmsh writes the mesh (signalled as soon as a file is written: another
    .msh appears, or m.msh changes) removes what was written, and an existing file of
    that name stays as it was: the mesh is written under a temporary name and renamed
    once whole. gmsh writing m.msh itself would leave it cut where the signal found
    it."""
    _cube_scene(tmp_path, 0.03)
    old = tmp_path / "m.msh"
    old.write_text("the previous mesh\n", encoding="utf-8")
    before = old.stat().st_mtime_ns
    proc = _start(_mesh_args(0.03), tmp_path)
    with signal_after(proc, signal.SIGINT) as ended:
        t_end = time.monotonic() + 120
        while _meshes(tmp_path) == ["m.msh"] and old.stat().st_mtime_ns == before:
            assert proc.poll() is None, ("ended before the signal", proc.communicate())
            assert time.monotonic() < t_end, "the mesh was not written"
            time.sleep(0.01)
    assert ended.returncode == EXIT_SIGNAL, (ended.returncode, ended.stdout, ended.stderr)
    assert ended.stderr == ("dyncontact: cube.geo: interrupted by signal 2 while gmsh "
                            "meshed it; nothing was written\n"), ended.stderr
    assert _meshes(tmp_path) == ["m.msh"]
    assert old.read_text(encoding="utf-8") == "the previous mesh\n"


def test_mesh_generate_keeps_the_ignored_sigterm(tmp_path):
    """A SIGTERM ignored by the process stays ignored through mesh_io.generate, whose
    gmsh initialization resets it to its default: after the call the disposition is
    SIG_IGN again, in the library and in the command line alike."""
    (tmp_path / "cube.geo").write_text(CUBE_GEO, encoding="utf-8")
    code = ("import signal, sys\n"
            "from dyncontact import mesh_io\n"
            "signal.signal(signal.SIGTERM, signal.SIG_IGN)\n"
            "mesh_io.generate('cube.geo', 'm.msh', h=0.5)\n"
            "print([l.split()[1] for l in open('/proc/self/status')"
            " if l.startswith('SigIgn')][0])\n")
    res = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=child_env(),
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    ignored = int(res.stdout.strip(), 16)
    assert ignored >> (int(signal.SIGTERM) - 1) & 1, res.stdout
    assert _meshes(tmp_path) == ["m.msh"]


#: A library caller whose Ctrl-C comes while the core opens the run: the signal is sent
#: by the core call itself, right before it returns (as one sent during a long set-up
#: reaches Python once the call returns).
SIGNAL_IN_OPEN = """
import os, signal, sys
import dyncontact
from dyncontact import core

real = core._core()

class Core:
    def __getattr__(self, name):
        return getattr(real, name)

    def dc_sim_open(self, *args):
        result = real.dc_sim_open(*args)
        os.kill(os.getpid(), signal.SIGINT)
        return result

core._core = lambda: Core()
try:
    dyncontact.run(sys.argv[1], out="o", progress=False)
except KeyboardInterrupt as exc:
    print(f"KeyboardInterrupt: {exc}")
"""


def test_a_signal_during_the_open_closes_the_run(tmp_path):
    """The run the core opened is closed as interrupted (summary.json says so, its lock
    is released) and the interrupt goes on to the caller with the run's line. Without
    the fix the KeyboardInterrupt came out of the open's return before the run was
    stored: its folder stayed locked, with summary.json's status "running"."""
    scene = _long_scene(tmp_path)
    res = subprocess.run([sys.executable, "-c", SIGNAL_IN_OPEN, str(scene)], cwd=tmp_path,
                         env=child_env(), capture_output=True, text=True, timeout=120,
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    assert res.returncode == 0, res.stderr
    assert res.stdout == "KeyboardInterrupt: interrupted at t = 0.00000E+000 (trace kept)\n", \
        (res.stdout, res.stderr)
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summary["status"] == "interrupted"
    assert not (tmp_path / "o" / ".dyncontact.lock").exists()
    assert sorted(os.listdir(tmp_path / "o")) == ["summary.json", "trace.csv"]


#: As SIGNAL_IN_OPEN, for the other callers of the core's open: a Model (no outputs), a
#: Stepper (its run in folder o) and bench_floors (a run in a temporary folder). Prints
#: whether the interrupt came out, the handles the open returned and those closed, and
#: what is left in the temporary folder.
SIGNAL_IN_OBJECT_OPEN = """
import json, os, signal, sys, tempfile
from dyncontact import core

real = core._core()
opened, closed = [], []

class Core:
    def __getattr__(self, name):
        return getattr(real, name)

    def dc_sim_open(self, *args):
        result = real.dc_sim_open(*args)
        opened.append(int(result[0]))
        os.kill(os.getpid(), signal.SIGINT)
        return result

    def dc_sim_close(self, handle):
        closed.append(int(handle))
        return real.dc_sim_close(handle)

core._core = lambda: Core()
what = sys.argv[2]
try:
    if what == "model":
        obj = core.Model(sys.argv[1])
    elif what == "stepper":
        obj = core.Stepper(sys.argv[1], "o")
    else:
        obj = core.bench_floors(sys.argv[1], n_rep=10)
    said = "no interrupt"
except KeyboardInterrupt:
    said = "KeyboardInterrupt"
print(json.dumps({"said": said, "opened": opened, "closed": closed,
                  "tmp": sorted(os.listdir(tempfile.gettempdir()))}))
"""


@pytest.mark.parametrize("what", ["model", "stepper", "bench_floors"])
def test_a_signal_during_an_objects_open_frees_it(what, tmp_path):
    """Ctrl-C while the core opens a Model, a Stepper or bench_floors' run: the
    interrupt goes on to the caller and the handle the open returned is closed, with the
    temporary folder removed; the Stepper's run is closed as interrupted (summary.json
    says so, its lock released). Unheld, the KeyboardInterrupt would come out of the
    open's return before the handle is stored: it would never be closed, and the
    Stepper's folder would stay locked with summary.json's status "running"."""
    if what == "bench_floors":
        from dyncontact import core
        if not core.bench_floors_available():
            pytest.skip("the extension has no timing helper")
    scene = _long_scene(tmp_path)
    (tmp_path / "tmp").mkdir()
    env = dict(child_env(), TMPDIR=str(tmp_path / "tmp"))
    res = subprocess.run([sys.executable, "-c", SIGNAL_IN_OBJECT_OPEN, str(scene), what],
                         cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120,
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    assert res.returncode == 0, res.stderr
    got = json.loads(res.stdout)
    assert got["said"] == "KeyboardInterrupt", got
    assert len(got["opened"]) == 1 and got["opened"][0] != 0, got
    assert got["closed"] == got["opened"], got
    assert got["tmp"] == [], got
    if what == "stepper":
        summary = json.loads((tmp_path / "o" / "summary.json").read_text())
        assert summary["status"] == "interrupted", summary
        assert summary["message"].startswith("interrupted at t = 0"), summary
        assert not (tmp_path / "o" / ".dyncontact.lock").exists()
        assert sorted(os.listdir(tmp_path / "o")) == ["summary.json", "trace.csv"]
    else:
        assert not (tmp_path / "o").exists()


#: load_mesh with a SIGINT sent as the core call named in argv[2] returns: the mesh read
#: (argv[1]: a file, or '' for the built-in bar). Prints whether the interrupt came out,
#: the handles dc_mesh_sizes returned, those dc_mesh_arrays copied and released, and
#: those dc_mesh_free released (0 ignored, not listed).
SIGNAL_IN_MESH_READ = """
import json, os, signal, sys
from dyncontact import core

real = core._core()
opened, copied, freed = [], [], []
when = sys.argv[2]

class Core:
    def __getattr__(self, name):
        return getattr(real, name)

    def dc_mesh_sizes(self, *args):
        result = real.dc_mesh_sizes(*args)
        opened.append(int(result[0]))
        if when == "dc_mesh_sizes":
            os.kill(os.getpid(), signal.SIGINT)
        return result

    def dc_mesh_arrays(self, handle, *args):
        copied.append(int(handle))
        result = real.dc_mesh_arrays(handle, *args)
        if when == "dc_mesh_arrays":
            os.kill(os.getpid(), signal.SIGINT)
        return result

    def dc_mesh_free(self, handle):
        if handle:
            freed.append(int(handle))
        return real.dc_mesh_free(handle)

core._core = lambda: Core()
try:
    core.load_mesh(sys.argv[1])
    said = "no interrupt"
except KeyboardInterrupt:
    said = "KeyboardInterrupt"
print(json.dumps({"said": said, "opened": opened, "copied": copied, "freed": freed}))
"""


@pytest.mark.parametrize("mesh", ["", str(ROOT / "meshes" / "bar2d_getfem_h0.05.msh")],
                         ids=["bar", "msh"])
@pytest.mark.parametrize("when", ["dc_mesh_sizes", "dc_mesh_arrays"])
def test_a_signal_during_load_mesh_frees_the_mesh_once(when, mesh, tmp_path):
    """Ctrl-C as the core's read of a mesh for load_mesh returns: the interrupt goes on
    to the caller and the mesh read is freed (dc_mesh_free); Ctrl-C as the copy that
    releases it returns: it is not freed a second time. Unheld, the KeyboardInterrupt
    would come out of the read's return before the handle is stored: the mesh would
    never be freed (its memory kept to the end of the process)."""
    res = subprocess.run([sys.executable, "-c", SIGNAL_IN_MESH_READ, mesh, when],
                         cwd=tmp_path, env=child_env(), capture_output=True, text=True,
                         timeout=120,
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    assert res.returncode == 0, res.stderr
    got = json.loads(res.stdout)
    assert got["said"] == "KeyboardInterrupt", got
    assert len(got["opened"]) == 1 and got["opened"][0] != 0, got
    if when == "dc_mesh_sizes":
        assert got["freed"] == got["opened"] and got["copied"] == [], got
    else:
        assert got["copied"] == got["opened"] and got["freed"] == [], got


def test_the_study_leaves_an_ignored_sigterm_ignored(tmp_path):
    """`dyncontact study` started with SIGTERM ignored (`nohup`) goes on after a SIGTERM,
    its pool's workers too; Ctrl-C still stops it, exit 130, and no worker is left.
    A handler installed over the ignored SIGTERM would raise KeyboardInterrupt on it:
    the study would stop at once with exit 130."""
    from test_study_signals import END_TIMEOUT_S, _children, _wait_group_gone

    def dispositions():
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        signal.signal(signal.SIGTERM, signal.SIG_IGN)

    args = [sys.executable, "-m", "dyncontact", "study", "convergence", "--quick", "--out",
            str(tmp_path / "study"), "--workers", "2", "--no-progress"]
    proc = subprocess.Popen(args, cwd=tmp_path, env=child_env(), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True,
                            preexec_fn=dispositions)
    try:
        deadline = time.monotonic() + 60.0
        while len(_children(proc.pid)) < 2:
            assert proc.poll() is None and time.monotonic() < deadline, \
                ("no pool of 2 workers appeared", proc.communicate())
            time.sleep(0.05)
        workers = _children(proc.pid)
        proc.send_signal(signal.SIGTERM)
        time.sleep(GOES_ON_S)
        assert proc.poll() is None, ("stopped by the ignored SIGTERM", proc.communicate())
        assert set(workers) <= set(_children(proc.pid)), "a worker ended on the SIGTERM"
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=END_TIMEOUT_S)
        assert proc.returncode == EXIT_SIGNAL, (proc.returncode, err[-2000:])
        assert "interrupted" in err and "Traceback" not in err, err[-2000:]
        assert not _wait_group_gone(proc.pid)
    finally:
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        proc.communicate()
