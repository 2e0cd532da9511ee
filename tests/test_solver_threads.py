"""&solver threads (docs/scenes.md): the scene key, the automatic choice of the threads of
the triangular solves (ldl_solves' ldl_threads_choice, a pure decision function), what
summary.json reports (solve_threads), and that sweeps run their parallel workers on one
thread. The solves' results on one and two threads are compared in
tests/test_parallel_solve.py; speed is measured by scripts/bench, never here.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from conftest import EXE, SUBPROCESS_TIMEOUT
from dyncontact import _core
from dyncontact.core import BadInputError
from dyncontact.scene import Scene

#: The size from which two threads are used (ldl_solves' PAR_MIN_DOFS).
MIN_DOFS = 20000


def choice(asked, env, cpus, n):
    threads, _cpus_here, min_dofs = _core.dc_threads_choice(asked, env, cpus, n)
    assert min_dofs == MIN_DOFS
    return int(threads)


# ------------------------------------------------------------------ the decision function

@pytest.mark.parametrize("asked, env, cpus, n, expected", [
    # automatic: two with two CPUs or more and a large factor, else one
    (0, 0, 2, 129600, 2),
    (0, 0, 8, MIN_DOFS, 2),
    (0, 0, 1, 129600, 1),          # one CPU (an affinity mask of one, OMP_NUM_THREADS=1)
    (0, 0, 2, MIN_DOFS - 1, 1),    # too small: forking costs more than it saves
    # the scene's 1 and 2
    (1, 0, 2, 129600, 1),
    (2, 0, 2, 129600, 2),
    (2, 0, 1, 129600, 2),          # asked for: two even on one CPU
    (2, 0, 2, 8400, 1),            # but not below the size
    # DYNCONTACT_THREADS overrides the scene
    (2, 1, 2, 129600, 1),
    (0, 1, 2, 129600, 1),
    (1, 2, 1, 129600, 2),
    (0, 2, 2, 100, 1),             # the size still counts
])
def test_threads_choice(asked, env, cpus, n, expected):
    assert choice(asked, env, cpus, n) == expected


CPUS_SCRIPT = """
import os, sys
if sys.argv[1] == 'one':
    os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})
from dyncontact import _core
print(_core.dc_threads_choice(0, 0, 1, 1)[1])
"""


def cpus_in_child(mode, **env):
    e = dict(os.environ)
    e.pop("PYTHONPATH", None)
    e.pop("OMP_NUM_THREADS", None)
    e.update(env)
    r = subprocess.run([sys.executable, "-c", CPUS_SCRIPT, mode], env=e, capture_output=True,
                       text=True, timeout=SUBPROCESS_TIMEOUT)
    assert r.returncode == 0, r.stderr
    return int(r.stdout.split()[-1])


@pytest.mark.skipif(not hasattr(os, "sched_getaffinity"), reason="no sched_getaffinity")
def test_cpus_are_the_affinity_mask_and_omp_num_threads():
    """The CPUs the automatic choice counts are the process's affinity mask (as
    sched_getaffinity gives it), limited by OMP_NUM_THREADS."""
    mask = len(os.sched_getaffinity(0))
    assert cpus_in_child("all") == mask
    assert cpus_in_child("one") == 1
    assert cpus_in_child("all", OMP_NUM_THREADS="1") == 1
    if mask >= 2:
        assert cpus_in_child("all", OMP_NUM_THREADS="2") == 2


# ------------------------------------------------------------------ the scene key

@pytest.mark.parametrize("value", [0, 1, 2])
def test_threads_key_values(value):
    scn = Scene()
    assert scn.get("solver.threads") == 0        # the default: automatic
    scn.set("solver.threads", value)
    scn.validate()
    assert scn.get("solver.threads") == value


@pytest.mark.parametrize("text, what", [
    ("3", "must be 0, 1 or 2 (got '3')"),
    ("-1", "must be 0, 1 or 2 (got '-1')"),
    ("'auto'", "expected an integer, not a string"),
    ("1.5", "expected an integer"),
])
def test_threads_key_bad_value_exits_2(tmp_path, text, what):
    if not EXE.is_file():
        pytest.skip(f"{EXE} is not built")
    path = tmp_path / "s.nml"
    path.write_text(f"&solver threads = {text} /\n")
    r = subprocess.run([str(EXE), str(path)], capture_output=True, text=True,
                       timeout=SUBPROCESS_TIMEOUT, cwd=tmp_path)
    assert r.returncode == 2, (r.returncode, r.stderr)
    line = r.stderr.strip()
    assert "\n" not in line
    assert f"{path}: &solver threads: " in line and what in line, line
    with pytest.raises(BadInputError, match="&solver threads"):
        Scene.read(path)


# ------------------------------------------------------------------ summary.json

#: The bar at h = 0.0125: 1 440 dofs, J0 solved by 2x2 node blocks, its elimination tree
#: split (the size threshold lowered to 0 by DYNCONTACT_THREADS_MIN_DOFS).
BAR = "&mesh h = 0.0125 /\n&scheme t_end = 0.01 /\n"


def solve_threads(tmp_path, threads, **env):
    if not EXE.is_file():
        pytest.skip(f"{EXE} is not built")
    out = tmp_path / f"o{threads}_{len(env)}"
    path = tmp_path / "s.nml"
    path.write_text(BAR + f"&solver threads = {threads} /\n&output dir = '{out}' /\n")
    e = dict(os.environ, DYNCONTACT_THREADS_MIN_DOFS="0")
    for k in ("DYNCONTACT_THREADS", "OMP_NUM_THREADS"):
        e.pop(k, None)
    e.update(env)
    r = subprocess.run([str(EXE), str(path)], capture_output=True, text=True, env=e,
                       timeout=SUBPROCESS_TIMEOUT)
    assert r.returncode == 0, r.stderr
    s = json.loads((out / "summary.json").read_text())
    assert s["solve_kernel"] == "ldl_node_pairs"
    assert s["scene"]["solver"]["threads"] == threads
    return s["solve_threads"]


def test_summary_solve_threads(tmp_path):
    assert solve_threads(tmp_path, 1) == 1
    assert solve_threads(tmp_path, 2) == 2
    assert solve_threads(tmp_path, 2, DYNCONTACT_THREADS="1") == 1
    assert solve_threads(tmp_path, 1, DYNCONTACT_THREADS="2") == 2
    assert solve_threads(tmp_path, 0, OMP_NUM_THREADS="1") == 1
    if len(os.sched_getaffinity(0)) >= 2:
        assert solve_threads(tmp_path, 0) == 2


def test_summary_solve_threads_one_below_the_size(tmp_path):
    """Without the lowered threshold the 1 440-dof bar is solved on one thread."""
    if not EXE.is_file():
        pytest.skip(f"{EXE} is not built")
    path = tmp_path / "s.nml"
    path.write_text(BAR + f"&solver threads = 2 /\n&output dir = '{tmp_path / 'o'}' /\n")
    e = dict(os.environ)
    e.pop("DYNCONTACT_THREADS", None)
    e.pop("DYNCONTACT_THREADS_MIN_DOFS", None)
    r = subprocess.run([str(EXE), str(path)], capture_output=True, text=True, env=e,
                       timeout=SUBPROCESS_TIMEOUT)
    assert r.returncode == 0, r.stderr
    assert json.loads((tmp_path / "o" / "summary.json").read_text())["solve_threads"] == 1


# ------------------------------------------------------------------ sweeps

def sweep_summaries(tmp_path, monkeypatch, workers, settings=()):
    from dyncontact.study.sweep import make_task, sweep
    monkeypatch.delenv("DYNCONTACT_THREADS", raising=False)
    monkeypatch.setenv("DYNCONTACT_THREADS_MIN_DOFS", "0")
    base = tmp_path / "bar.nml"
    base.write_text(BAR)
    tasks = [make_task(str(base), {"scheme.t_end": t, **dict(settings)}) for t in (0.005, 0.01)]
    recs = sweep(tasks, str(tmp_path / f"cache{workers}"), workers=workers, progress=False)
    out = []
    for rec in recs:
        assert rec["status"] == "ok", rec["message"]
        with open(os.path.join(rec["run_dir"], "summary.json"), encoding="utf-8") as f:
            out.append(json.load(f))
    return out


@pytest.mark.skipif(len(os.sched_getaffinity(0)) < 2, reason="one CPU: automatic is one")
def test_sweep_workers_run_on_one_thread(tmp_path, monkeypatch):
    """Two workers at once: each run's solves on one thread, where the same scene run
    alone (automatic, two CPUs, threshold 0) uses two; a task that sets the key keeps it.
    The cache key does not depend on it."""
    from dyncontact.study.sweep import PARALLEL_THREADS, make_task, task_key
    assert PARALLEL_THREADS == 1
    for s in sweep_summaries(tmp_path, monkeypatch, workers=2):
        assert s["scene"]["solver"]["threads"] == 1 and s["solve_threads"] == 1
    for s in sweep_summaries(tmp_path, monkeypatch, workers=1):
        assert s["scene"]["solver"]["threads"] == 0 and s["solve_threads"] == 2
    # (the workers, forks of this process, which may have started OpenMP threads in an
    # earlier test, then solve on one thread anyway: test_fork_after_two_threads)
    for s in sweep_summaries(tmp_path, monkeypatch, workers=2,
                             settings={"solver.threads": 2}):
        assert s["scene"]["solver"]["threads"] == 2
    task = make_task("", {"scheme.t_end": 0.01})
    assert task_key(task) == task_key(make_task("", {"scheme.t_end": 0.01}))


FORK_SCRIPT = """
import json, multiprocessing, sys
import dyncontact
from dyncontact.scene import Scene

def run(out):
    return dyncontact.run(Scene.read(sys.argv[1]), out=out, progress=False).summary

if __name__ == "__main__":
    parent = run(sys.argv[2] + "/parent")
    with multiprocessing.get_context("fork").Pool(1) as pool:
        child = pool.apply(run, (sys.argv[2] + "/child",))
    print(json.dumps([parent["solve_threads"], child["solve_threads"], child["steps"]]))
"""


def test_fork_after_two_threads(tmp_path):
    """A process that solved on two threads, then forks (a fork-context pool): the child
    solves on one thread and finishes (the helper thread does not survive fork();
    two_threads.c. With an OpenMP team, GNU libgomp's, the child hung for ever)."""
    path = tmp_path / "s.nml"
    path.write_text(BAR + "&solver threads = 2 /\n")
    e = dict(os.environ, DYNCONTACT_THREADS_MIN_DOFS="0")
    e.pop("DYNCONTACT_THREADS", None)
    e.pop("PYTHONPATH", None)
    r = subprocess.run([sys.executable, "-c", FORK_SCRIPT, str(path), str(tmp_path)], env=e,
                       capture_output=True, text=True, timeout=SUBPROCESS_TIMEOUT)
    assert r.returncode == 0, r.stderr
    parent, child, steps = json.loads(r.stdout.split("\n")[-2])
    assert (parent, child) == (2, 1) and steps > 0


def test_parallel_test_workers_use_one_thread():
    """Under pytest-xdist every worker's runs use one thread (conftest.py)."""
    if os.environ.get("PYTEST_XDIST_WORKER"):
        assert os.environ.get("DYNCONTACT_THREADS") in ("1", "2")   # 1, unless set before
    src = open(os.path.join(os.path.dirname(__file__), "conftest.py"), encoding="utf-8").read()
    assert 'os.environ.setdefault("DYNCONTACT_THREADS", "1")' in src
