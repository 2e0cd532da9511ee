"""Signals in runs on a mesh file: reading a .msh or .geo through gmsh leaves the
process's signal dispositions as they were (gmsh's initialization and finalization reset
some, SIGTERM among them), so SIGTERM stops such a run as documented (docs/scenes.md, exit
codes): exit 130, summary status "interrupted", the trace kept, a checkpoint written at the
signal's step and the lock released, in the executable and in `python -m dyncontact run`;
a signal while gmsh meshes a .geo ends the executable at once, with nothing written."""

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


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["int", "term"])
def test_a_signal_while_gmsh_meshes_ends_the_executable_at_once(sig, tmp_path):
    """The executable does not wait for gmsh to finish meshing: SIGINT or SIGTERM during
    the read ends it at once with exit 130 and one line naming the file, and nothing is
    written (the output folder is made after the mesh is read). Without this the signal
    was held until gmsh returned, 20 s later, and the run then stopped before its first
    step."""
    (tmp_path / "cube.geo").write_text(CUBE_GEO, encoding="utf-8")
    (tmp_path / "s.nml").write_text(
        "&mesh file = 'cube.geo', h = 0.03, max_elements = 100000000 /\n"
        "&boundary clamped = 'top', contact = 'bottom' /\n"
        "&contact probe = 0.5, 0.5, 0.0, obstacle_point = 0.0, 0.0, 0.0,\n"
        "         obstacle_normal = 0.0, 0.0, -1.0 /\n"
        "&scheme name = 'hht', dt = 1e-3, t_end = 0.01 /\n", encoding="utf-8")
    if not Path("/proc/self/maps").exists():
        pytest.skip("needs /proc to see when gmsh is loaded")
    proc = subprocess.Popen(entry("exe") + ["s.nml", "--out", "o"], cwd=tmp_path,
                            env=child_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    with signal_after(proc, sig, timeout=120) as ended:
        _wait_for_gmsh(proc)
        t0 = time.monotonic()
    waited = time.monotonic() - t0
    stdout, stderr = ended.stdout, ended.stderr
    assert proc.returncode == EXIT_SIGNAL, (proc.returncode, stdout, stderr)
    assert stderr == (f"dyncontact: cube.geo: interrupted by signal {int(sig)} while gmsh "
                      "read it; nothing was written\n"), stderr
    assert waited < 5.0, waited          # a fraction of the meshing's 20 s
    assert not (tmp_path / "o").exists()
