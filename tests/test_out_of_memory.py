"""A run that runs out of memory ends with one line on stderr that names the stage (the
assembly, the factorization, the contact columns), what it was to hold and what to do,
exit status 4, and the trace written so far (docs/scenes.md, *Exit codes*).

The memory is limited as a batch system or `ulimit -v` limits it: RLIMIT_AS on the child
process. The limits are not tuned numbers: each is placed relative to the peak address
space of the same scene measured first without a limit (VmPeak, read from /proc while the
child runs), by the sizes the run itself reports (summary.json's factor_nnz and
matrix_nnz). Before these checks the factorization of the 3D box hung under such limits
(OpenBLAS retrying its buffer's allocation for ever) or ended in libgomp's 'Thread
creation failed' (exit 1), whatever OMP_NUM_THREADS said; the other stages ended in
gfortran's 'Error allocating' (exit 1) or a segmentation fault."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import EXE, peak_run

resource = pytest.importorskip("resource")
if not hasattr(resource, "RLIMIT_AS") or not Path("/proc/self/status").is_file():
    pytest.skip("needs RLIMIT_AS and /proc (Linux)", allow_module_level=True)

EXIT_INTERNAL = 4
#: Seconds a limited run may take: a hang (OpenBLAS's retry loop) fails the test.
TIMEOUT = 60
MB = 2 ** 20

#: The 3D box of 19 440 dofs: CHOLMOD's supernodal factorization (BLAS, OpenMP), whose
#: factor and work (about 230 MB with OpenBLAS's buffer) dwarf the set-up (about 90 MB).
BOX = """&mesh dim = 3, length = 1.0, width = 0.1, h = {h} /
&contact obstacle_point = 0.0, 0.0, 0.0, obstacle_normal = 0.0, 0.0, -1.0,
         probe = 0.05, 0.05, 0.0 /
&initial velocity = 0.0, 0.0, 0.0 /
&scheme name = 'hht', dt = 0.0025, t_end = 0.0 /
&solver kind = '{kind}' /
"""
#: A 2D strip of 51 000 dofs that flies for two steps and then hits the obstacle: the
#: contact correction's columns of J0^-1 come on top of the set-up's peak.
STRIP = """&mesh length = 1.0, width = 0.1, h = 0.002 /
&contact obstacle_point = 0.0, -0.0025 /
&initial kind = 'velocity', velocity = 0.0, -1.0 /
&scheme name = 'hht', dt = 0.001, t_end = {t_end} /
"""


def write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def env_with(**extra) -> dict:
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    env.update(extra)
    return env


def limited_run(cmd, cwd, limit: int, env=None) -> subprocess.CompletedProcess:
    """Run cmd with its address space limited to `limit` bytes (RLIMIT_AS)."""

    def set_limit():
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))

    return subprocess.run([str(c) for c in cmd], cwd=cwd, env=env or env_with(),
                          capture_output=True, text=True, timeout=TIMEOUT,
                          preexec_fn=set_limit)


def oom_line(res, stage: str) -> str:
    """The one line of a run that ran out of memory in `stage`."""
    lines = res.stderr.strip().splitlines()
    assert res.returncode == EXIT_INTERNAL, (res.returncode, res.stderr[-2000:])
    assert len(lines) == 1, res.stderr[-2000:]
    assert lines[0].startswith("dyncontact: out of memory in " + stage), lines[0]
    return lines[0]


def summary(out: Path) -> dict:
    return json.loads((out / "summary.json").read_text())


@pytest.fixture(scope="module")
def box_peak(tmp_path_factory):
    """The box's scene, its peak address space without a limit and its factor's
    entries."""
    if not EXE.is_file():
        pytest.skip(f"{EXE} is not built; run scripts/setup")
    d = tmp_path_factory.mktemp("box")
    scene = write(d / "box.nml", BOX.format(h=0.0125, kind="direct"))
    peak, _ = peak_run([EXE, scene, "--out", d / "free"], d)
    factor_nnz = summary(d / "free")["factor_nnz"]
    assert summary(d / "free")["factorization"] == "supernodal"
    return d, scene, peak, factor_nnz


@pytest.mark.parametrize("threads", [None, "1", "2"])
def test_factorization_out_of_memory_is_one_line(box_peak, threads):
    """Half the factor's values below the run's peak: the set-up fits, the factorization
    does not. Exit 4 in a second with the line that names the factorization, the
    factor's entries and the hints, with any OMP_NUM_THREADS and OpenBLAS on one
    thread (before: a hang or libgomp's exit 1)."""
    d, scene, peak, factor_nnz = box_peak
    env = env_with()
    if threads is not None:
        env.update(OMP_NUM_THREADS=threads, OPENBLAS_NUM_THREADS="1")
    limit = peak - 4 * factor_nnz
    res = limited_run([EXE, scene, "--out", d / f"lim{threads}"], d, limit, env)
    line = oom_line(res, "the factorization")
    assert f"the factor has {factor_nnz} entries" in line, line
    assert "&solver kind = 'cg'" in line and "coarser mesh" in line, line


def test_cg_runs_where_the_factor_does_not_fit(box_peak):
    """The hint holds: under the same limit, &solver kind = 'cg' (no factor) runs."""
    d, _scene, peak, factor_nnz = box_peak
    scene = write(d / "box_cg.nml", BOX.format(h=0.0125, kind="cg"))
    res = limited_run([EXE, scene, "--out", d / "cg"], d, peak - 4 * factor_nnz)
    assert res.returncode == 0, res.stderr[-2000:]


def test_assembly_out_of_memory_is_one_line(box_peak, tmp_path):
    """A limit above what the program holds before the assembly (the peak of the same
    box at h = 0.05, whose matrices are small) by 24 bytes an entry of the matrices,
    where they need 36 (K, M, K_theta, the pattern) and more for their block copies:
    the assembly's line, not gfortran's 'Error allocating' or a segmentation fault."""
    d, scene, _peak, _f = box_peak
    small = write(tmp_path / "small.nml", BOX.format(h=0.05, kind="direct"))
    base, _ = peak_run([EXE, small, "--out", tmp_path / "small"], tmp_path)
    nnz = summary(d / "free")["matrix_nnz"]
    res = limited_run([EXE, scene, "--out", tmp_path / "o"], tmp_path, base + 24 * nnz)
    line = oom_line(res, "the assembly")
    assert "coarser mesh" in line and f"{nnz} entries" in line, line


@pytest.fixture(scope="module")
def strip_peaks(tmp_path_factory):
    """The strip's scene, and the peaks of its set-up (no step) and of its run (five
    steps, three in contact)."""
    if not EXE.is_file():
        pytest.skip(f"{EXE} is not built; run scripts/setup")
    d = tmp_path_factory.mktemp("strip")
    setup = write(d / "setup.nml", STRIP.format(t_end=0.0))
    scene = write(d / "strip.nml", STRIP.format(t_end=0.005))
    p0, _ = peak_run([EXE, setup, "--out", d / "setup"], d)
    p1, _ = peak_run([EXE, scene, "--out", d / "free"], d)
    assert p1 > p0 + 8 * MB, (p0, p1)    # the contact columns' part, some 30 MB
    return d, scene, p0, p1


def test_contact_columns_out_of_memory_keeps_the_trace(strip_peaks):
    """Between the set-up's peak and the run's: the steps in flight are done and
    written, the first contact step runs out of memory in the contact columns. Exit 4,
    the columns' line with t, trace.csv with the rows before it (those of the run
    without a limit, bit for bit), summary status out_of_memory."""
    d, scene, p0, p1 = strip_peaks
    out = d / "lim"
    res = limited_run([EXE, scene, "--out", out], d, (p0 + p1) // 2)
    line = oom_line(res, "the contact columns")
    assert "coarser mesh" in line and "trace kept" in line, line
    rows = (out / "trace.csv").read_text().splitlines()
    free = (d / "free" / "trace.csv").read_text().splitlines()
    assert 2 <= len(rows) - 1 < len(free) - 1, (len(rows), len(free))
    assert rows == free[:len(rows)]
    s = summary(out)
    assert s["status"] == "out_of_memory"
    assert s["message"] == line.removeprefix("dyncontact: ")


def test_python_shows_the_same_line(strip_peaks):
    """The Python command line (through dyncontact.run, whose DyncontactError it
    prints) gives the executable's line. The limit is set in the child after its
    imports (the interpreter and numpy take their own address space), between the
    set-up's peak and the run's as measured in the same child without a limit."""
    d, scene, _p0, _p1 = strip_peaks
    code = ("import resource, sys\nfrom dyncontact.cli import main\n"
            "limit = int(sys.argv[1])\n"
            "if limit: resource.setrlimit(resource.RLIMIT_AS, (limit, limit))\n"
            "sys.exit(main(['run', sys.argv[2], '--out', sys.argv[3], '--quiet']))\n")
    q0, _ = peak_run([sys.executable, "-c", code, "0", d / "setup.nml", d / "py_setup"], d)
    q1, _ = peak_run([sys.executable, "-c", code, "0", scene, d / "py_free"], d)
    res = subprocess.run([sys.executable, "-c", code, str((q0 + q1) // 2), str(scene),
                          str(d / "py_lim")], cwd=d, env=env_with(), capture_output=True,
                         text=True, timeout=TIMEOUT)
    line = oom_line(res, "the contact columns")
    assert summary(d / "py_lim")["message"] == line.removeprefix("dyncontact: ")
    # the executable's line for the same step, but for the bytes asked for
    exe = subprocess.run([str(EXE), str(scene), "--out", str(d / "exe_lim")], cwd=d,
                         capture_output=True, text=True, timeout=TIMEOUT,
                         preexec_fn=lambda: resource.setrlimit(
                             resource.RLIMIT_AS, ((_p0 + _p1) // 2, (_p0 + _p1) // 2)))
    exe_line = oom_line(exe, "the contact columns")

    def words(s):
        return [w for w in s.split() if not w.isdigit()]

    assert words(line) == words(exe_line), (line, exe_line)
