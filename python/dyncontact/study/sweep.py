"""Sweeps of independent runs: a per-run cache, a local process pool or a Dask cluster.

The one runner of the package: the studies, the seed's figures (:mod:`.figures`) and the
benchmark (:mod:`.bench`) all run their scenes through it.

A :class:`Task` is one run: a base scene file (or the built-in default scene), the keys
it changes (``Scene.set``) and the *analysis* that turns the run's outputs into a record
(numbers, optionally small arrays). :func:`sweep` executes a list of tasks and returns
their records in order. :func:`run_uncached` runs one task into a given folder without
the cache, for measurements that must be taken afresh (the benchmark's timings).

Cache
-----
Each run is stored under ``CACHE/<k[:2]>/<k>/`` where ``k`` is the SHA-256 of

- the full parsed scene as the Fortran core reads it (:func:`dyncontact.core.scene_dump`:
  every key, defaults filled in), without ``output.dir`` (where the run goes is not
  what it is), plus the content hash of the mesh file when there is one;
- the code version: ``dyncontact.__version__``, the Fortran core's version string and
  the SHA-256 of the compiled extension (any rebuild that changes the code changes it);
- the analysis name, its parameters and the SHA-256 of the module that implements it
  (:mod:`.analyses`, which holds nothing else: editing a report or a plot does not
  invalidate the runs).

An entry is written in a temporary folder next to it and renamed into place when
complete (``record.json`` last, holding the SHA-256 of every file it lists, those in the
sub-folders the analysis keeps included), so an
interrupted sweep leaves no entry that looks finished. On a lookup the record is parsed
and each listed file's hash checked; anything missing, unreadable or different is a
*corrupt* entry: it is removed and the run is done again. A re-run of a sweep therefore
resumes where it stopped.

Executors
---------
``workers`` processes of a local :class:`concurrent.futures.ProcessPoolExecutor` by
default; with ``scheduler`` (an address such as ``tcp://host:8786``, or a
``distributed.Client``) the tasks go to a ``dask.distributed`` cluster (the workers must
see the cache folder: a shared file system, or the same machine); an address where no
scheduler answers within ``scheduler_timeout`` seconds (default :data:`SCHEDULER_TIMEOUT_S`,
5 s, as the command lines' ``--scheduler-timeout``; not dask's 30 s) raises
:class:`SchedulerUnreachable`. A run that fails
(bad input, an exception in the analysis, a worker that died) becomes a record with
``status = 'error'`` and its message; the sweep goes on. A sweep stopped by Ctrl-C (or
by SIGTERM inside :func:`sigterm_as_interrupt`, as the command lines run) terminates the
pool's workers before the ``KeyboardInterrupt`` goes on (by SIGTERM in a process that
left it at its default action, likewise, and then the process ends by SIGTERM:
:func:`_sigterm_ends_after_cleaning`), and a worker whose parent dies
(even by ``kill -9``) ends too: no worker outlives the sweep. Runs that share a machine
with other runs (the pool's workers, and every Dask task) run their solves on one thread
(``&solver threads = 1``, :data:`PARALLEL_THREADS`, unless the task sets the key; the
environment's ``DYNCONTACT_THREADS`` still overrides it): two threads for each of several
runs at once would be slower than one (docs/performance.md, "Two threads in the
triangular solve"). The key is applied after the cache key is computed, so it does not
change the key. Likewise a run writes no checkpoint (``&output checkpoint_every = 0``
unless the task sets the key): nothing would use it, and the fsync of each would cost
more than the steps between them in a run of a small scene at a fine Δt. A scene the core refuses as bad
input *at run time* (for example Nitsche θ = 1 with γ0 below the element bound, which
only the assembled mesh can tell) is a grid point outside the method's domain: status
``'refused'``, not cached, counted once per sweep on the log. The core's warnings are
kept in the record (``warnings``), not printed by the workers.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import contextvars
import ctypes
import dataclasses
import functools
import hashlib
import json
import numbers
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import traceback
import uuid
import warnings
from typing import Any, Callable, Iterable, Iterator, Mapping, Sequence

import numpy as np

__all__ = ["Task", "make_task", "sweep", "task_key", "code_version", "lookup", "execute",
           "run_uncached", "register_analysis", "sigterm_as_interrupt", "child_group",
           "ERROR", "REFUSED", "PARALLEL_THREADS"]

#: Status of a record whose run could not be done (not a numerical verdict).
ERROR = "error"
#: ``&solver threads`` of the runs that share the machine with other runs (workers of a
#: pool, Dask tasks): one thread each, as MUMPS or PARDISO run under a sweep of one
#: process per core.
PARALLEL_THREADS = 1
#: Bump when the layout of a cache entry changes.
CACHE_LAYOUT = 1
#: A temporary entry folder older than this (s) is left over from an interrupted sweep.
STALE_S = 6 * 3600
#: Seconds the workers of a stopped pool get to end after SIGTERM before SIGKILL.
WORKER_TERM_S = 5.0
#: Linux prctl option: the signal a process gets when its parent ends (linux/prctl.h).
PR_SET_PDEATHSIG = 1

_ANALYSES: dict[str, Callable[..., dict[str, Any]]] = {}


def register_analysis(name: str, runner: Callable[..., Any] | None = None):
    """Decorator: ``fn(run_dir, result, **params) -> {'metrics': {...}, 'arrays': {...}}``
    names an analysis that tasks can ask for. ``result`` is the :class:`RunResult`.

    ``runner(scene, run_dir, **params) -> RunResult``, when given, runs the scene instead
    of :func:`dyncontact.run` (same outputs in run_dir), for an analysis that must see
    the state at every step (stepping a :class:`dyncontact.core.Stepper`) without
    writing every field to disk; what it measures rides on the result it returns."""

    def deco(fn):
        fn.runner = runner
        _ANALYSES[name] = fn
        return fn

    return deco


@dataclasses.dataclass(frozen=True)
class Task:
    """One run of a sweep.

    ``base``: scene file ('' for the built-in default scene, the seed's test case);
    ``settings``: ((group.key, value), ...) applied with
    ``Scene.set``; ``analysis``: a registered analysis name with ``params``
    (((name, value), ...)); ``tags``: labels carried into the record (scheme label,
    grid coordinates), not part of the cache key. The analysis may name more files of
    the run folder (files or sub-folders) to keep in the cache (``keep``) besides
    trace.csv and summary.json.
    """

    base: str
    settings: tuple[tuple[str, Any], ...]
    analysis: str = "trace"
    params: tuple[tuple[str, Any], ...] = ()
    tags: tuple[tuple[str, Any], ...] = ()

    def setting(self, key: str, default: Any = None) -> Any:
        return dict(self.settings).get(key, default)

    def tag(self, key: str, default: Any = None) -> Any:
        return dict(self.tags).get(key, default)


#: The run's fields that :func:`by_tags` puts beside a task's tags: a tag may not be
#: named as one of them (its value would be replaced by the run's without a word).
RUN_FIELDS = ("status", "message", "t_end_reached", "steps", "wall_s")


def make_task(base: str | None, settings: Mapping[str, Any], analysis: str = "trace",
              params: Mapping[str, Any] | None = None,
              tags: Mapping[str, Any] | None = None) -> Task:
    """A :class:`Task` from plain dicts (values must be plain numbers / strings);
    ``base`` None or '': the built-in default scene. A tag named as one of
    :data:`RUN_FIELDS` is a ValueError."""
    clash = [k for k in (tags or {}) if k in RUN_FIELDS]
    if clash:
        raise ValueError(f"tag(s) {', '.join(map(repr, clash))}: the names of the run's own "
                         f"fields in by_tags ({', '.join(RUN_FIELDS)}); name the tag "
                         "otherwise")
    return Task(base=os.path.abspath(base) if base else "", settings=tuple(settings.items()),
                analysis=analysis, params=tuple(sorted((params or {}).items())),
                tags=tuple((tags or {}).items()))


# --------------------------------------------------------------------------- keys

def _sha256_file(path: str) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


@functools.lru_cache(maxsize=1)
def code_version() -> dict[str, str]:
    """The code's identity for the cache: package version, Fortran version string and
    the hash of the compiled extension."""
    import importlib.util

    from .. import __version__
    from .. import core

    fortran = core.fortran_version()       # loads the extension (or raises, clearly)
    ext = importlib.util.find_spec("dyncontact._core").origin   # its shared library
    return {"package": __version__, "fortran": fortran, "extension_sha256": _sha256_file(ext)}


#: Modules that register the analyses the studies use (imported on first need, so that
#: a worker process that only imported this module finds them).
_ANALYSIS_MODULES = ("dyncontact.study.analyses",)


def _analysis(name: str) -> Callable[..., dict[str, Any]]:
    if name not in _ANALYSES:
        import importlib

        for mod in _ANALYSIS_MODULES:
            importlib.import_module(mod)
    if name not in _ANALYSES:
        raise ValueError(f"unknown analysis {name!r} (known: {', '.join(sorted(_ANALYSES))})")
    return _ANALYSES[name]


@functools.lru_cache(maxsize=None)
def _analysis_version(name: str) -> str:
    fn = _analysis(name)
    mod = sys.modules[fn.__module__]
    return _sha256_file(mod.__file__)


def _scene(task: Task):
    from ..scene import Scene

    scn = Scene.read(task.base) if task.base else Scene()
    for key, value in task.settings:
        scn.set(key, value)
    return scn


def _parsed(task: Task, folder: str) -> dict[str, Any]:
    """The scene as the core parses it (output.dir removed, mesh content hashed)."""
    from .. import core

    path = os.path.join(folder, "scene.nml")
    _scene(task).write(path)
    dump_fn = getattr(core, "scene_dump", None)
    if dump_fn is None:   # no parsed dump: the canonical text Scene.write produced
        with open(path, encoding="utf-8") as f:
            return {"scene_nml": f.read()}
    dump = dump_fn(path)
    out = dump.get("output")
    if isinstance(out, dict):
        out.pop("dir", None)
    mesh = dump.get("mesh")
    if isinstance(mesh, dict) and mesh.get("file"):
        mesh["file_sha256"] = _sha256_file(str(mesh["file"]))
        mesh.pop("file")
    return dump


def task_key(task: Task) -> str:
    """The cache key of a task (see the module docstring)."""
    with tempfile.TemporaryDirectory(prefix="dyncontact-key-") as tmp:
        dump = _parsed(task, tmp)
    doc = {"layout": CACHE_LAYOUT, "scene": dump, "code": code_version(),
           "analysis": task.analysis, "params": [list(p) for p in task.params],
           "analysis_sha256": _analysis_version(task.analysis)}
    text = json.dumps(doc, sort_keys=True, default=str, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


#: Status of a record whose scene the core refused as bad input at run time (for example
#: Nitsche θ = 1 with γ0 below the element bound): a point outside the method's domain,
#: not a failure of the sweep (not cached; counted, not reported one by one).
REFUSED = "refused"


#: What marks a cache entry being written: ``<entry>.tmp-<pid>-<random>`` (:func:`_tmp_mark`).
TMP_MARK = ".tmp-"


def _tmp_mark(pid: int) -> str:
    """The part of a temporary entry's name that names the process writing it."""
    return f"{TMP_MARK}{pid}-"


def _entry(cache: str, key: str) -> str:
    return os.path.join(cache, key[:2], key)


# --------------------------------------------------------------------------- entries

def lookup(cache: str, key: str) -> dict[str, Any] | None:
    """The record of a finished cache entry, or None (missing). A corrupt entry (record
    unreadable, a listed file missing or changed) is removed and None returned."""
    folder = _entry(cache, key)
    if not os.path.isdir(folder):
        return None
    try:
        with open(os.path.join(folder, "record.json"), encoding="utf-8") as f:
            rec = json.load(f)
        if rec.get("key") != key:
            raise ValueError("key mismatch")
        for name, digest in rec["files"].items():
            if _sha256_file(os.path.join(folder, name)) != digest:
                raise ValueError(f"{name} changed")
        arrays = {}
        if "arrays.npz" in rec["files"]:
            with np.load(os.path.join(folder, "arrays.npz")) as z:
                arrays = {k: z[k] for k in z.files}
    except Exception:  # noqa: BLE001 - any defect means: redo the run
        shutil.rmtree(folder, ignore_errors=True)
        return None
    rec["arrays"] = arrays
    rec["cached"] = True
    rec["run_dir"] = folder
    return rec


def _said_of_setting(message: str, task: Task) -> str:
    """A refusal of the core said of the task's setting that gave the key it names: the
    core names the base scene (``BadInputError: base.nml: &scheme dt: must be > 0 ...``),
    which holds another value or none, so the scene's name gives way to the setting
    (``BadInputError: setting scheme.dt=-1.0 of the task on base.nml: &scheme dt: ...``),
    as ``--set`` does on the command line. Other messages are returned as they are."""
    kind, sep, text = message.partition(": ")
    prefix = f"{task.base or '<scene>'}: "
    if not sep or not text.startswith(prefix):
        return message
    rest = text[len(prefix):]
    for name, value in reversed(task.settings):     # the last setting of a key is used
        group, _, key = str(name).strip().lower().partition(".")
        if rest.startswith((f"&{group} {key}:", f"&{group} {key} ")):
            base = os.path.basename(task.base) if task.base else "the default scene"
            return f"{kind}: setting {name}={value!r} of the task on {base}: {rest}"
    return message


def _error_record(task: Task, key: str | None, message: str) -> dict[str, Any]:
    message = _said_of_setting(message, task)
    return {"key": key, "status": ERROR, "message": message, "t_end_reached": None,
            "steps": None, "wall_s": None, "cpu_s": None, "newton_its_total": None,
            "metrics": {}, "arrays": {}, "cached": False, "run_dir": None}


def _files(folder: str) -> list[str]:
    """Every file below folder, as sorted relative paths."""
    return sorted(os.path.relpath(os.path.join(d, name), folder)
                  for d, _, names in os.walk(folder) for name in names)


def _run(task: Task, run_dir: str, key: str | None,
         threads: int | None = None) -> tuple[dict[str, Any], dict[str, Any]]:
    """Run the task's scene into run_dir and its analysis on the outputs: the record
    (without files and cache fields) and the analysis' output. ``threads``: the
    ``&solver threads`` to run with when the task does not set it (None: the scene's).
    Raises what the run or the analysis raises."""
    from .. import core

    scene = _scene(task)
    if threads is not None and task.setting("solver.threads") is None:
        scene.set("solver.threads", threads)
    if task.setting("output.checkpoint_every") is None:
        # a checkpoint costs an fsync and nothing keeps it (an interrupted run is run
        # again whole): the base scene's checkpoint_every, set for its own long runs,
        # would make each run of a sweep at a fine Δt pay one every few steps
        scene.set("output.checkpoint_every", 0)
    analysis = _analysis(task.analysis)
    runner = getattr(analysis, "runner", None)
    cpu0, wall0 = time.process_time(), time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:   # kept in the record,
        warnings.simplefilter("always")                    # not printed by workers
        if runner is None:
            res = core.run(scene, out=run_dir, progress=False)
        else:
            res = runner(scene, run_dir, **dict(task.params))
    cpu_s, wall_measured_s = time.process_time() - cpu0, time.perf_counter() - wall0
    out = analysis(run_dir, res, **dict(task.params)) or {}
    s = res.summary
    rec = {"key": key, "status": res.status, "message": res.message,
           "t_end_reached": s.get("t_end_reached"), "steps": s.get("steps"),
           "wall_s": s.get("wall_s"), "cpu_s": cpu_s, "wall_measured_s": wall_measured_s,
           "newton_its_total": s.get("newton_its_total"),
           "metrics": out.get("metrics", {}), "code": code_version(),
           "warnings": sorted({str(w.message) for w in caught})}
    return rec, out


def _guarded(task: Task, key: str | None, body: Callable[[], dict[str, Any]]) -> dict[str, Any]:
    """body() or, when it raises, the record that says why: 'refused' for bad input the
    core refuses at run time, 'error' for anything else."""
    from .. import core

    try:
        return body()
    except core.BadInputError as exc:   # refused by the core: outside the method's domain
        rec = _error_record(task, key, f"{type(exc).__name__}: {exc}")
        rec["status"] = REFUSED
        return rec
    except Exception as exc:  # noqa: BLE001 - one failing run never kills a sweep
        msg = f"{type(exc).__name__}: {exc}"
        if os.environ.get("DYNCONTACT_STUDY_DEBUG"):
            msg += "\n" + traceback.format_exc()
        return _error_record(task, key, msg)


def run_uncached(task: Task, run_dir: str) -> dict[str, Any]:
    """Run one task into run_dir (emptied first), never through the cache: what it
    measures (wall_s, cpu_s, wall_measured_s around :func:`dyncontact.run`) is of this
    run. Never raises; the record is :func:`execute`'s, with run_dir = run_dir and all
    of the run's outputs left there."""

    def body() -> dict[str, Any]:
        folder = os.path.abspath(run_dir)
        if os.path.isdir(folder):
            shutil.rmtree(folder)
        rec, out = _run(task, folder, None)
        rec["arrays"] = {k: np.asarray(v) for k, v in out.get("arrays", {}).items()}
        rec["cached"] = False
        rec["run_dir"] = folder
        return rec

    return _guarded(task, None, body)


def execute(task: Task, cache: str, key: str | None = None,
            threads: int | None = None) -> dict[str, Any]:
    """Run one task (or take it from the cache) and return its record; never raises.
    ``threads``: the ``&solver threads`` of the run when the task does not set it (None:
    the scene's; the sweep's workers pass :data:`PARALLEL_THREADS`).

    The record: key, status ('ok' | 'unstable' | 'newton_failed' | 'refused' | 'error'),
    message, t_end_reached, steps, wall_s (the core's time loop), cpu_s (process CPU time
    around :func:`dyncontact.run`, set-up and trace reading included), wall_measured_s
    (the wall time of the same), newton_its_total, metrics (numbers from the analysis),
    arrays (numpy arrays from the analysis), cached, run_dir (the cache entry, holding
    the files the analysis keeps).
    """

    def body() -> dict[str, Any]:
        k = key or task_key(task)
        hit = lookup(cache, k)
        if hit is not None:
            return hit
        final = _entry(cache, k)
        os.makedirs(os.path.dirname(final), exist_ok=True)
        tmp = f"{final}{_tmp_mark(os.getpid())}{uuid.uuid4().hex[:8]}"
        os.makedirs(tmp)
        try:
            run_dir = os.path.join(tmp, "run")
            rec, out = _run(task, run_dir, k, threads)
            keep = set(out.get("keep", ())) | {"trace.csv", "summary.json"}
            for name in os.listdir(run_dir):
                if name in keep:
                    os.replace(os.path.join(run_dir, name), os.path.join(tmp, name))
            shutil.rmtree(run_dir, ignore_errors=True)
            arrays = out.get("arrays", {})
            if arrays:
                np.savez(os.path.join(tmp, "arrays.npz"),
                         **{n: np.asarray(v) for n, v in arrays.items()})
            rec["files"] = {name: _sha256_file(os.path.join(tmp, name))
                            for name in _files(tmp)}
            with open(os.path.join(tmp, "record.json"), "w", encoding="utf-8") as f:
                json.dump(rec, f, indent=1, default=_json_default)
            try:
                os.rename(tmp, final)
            except OSError:   # another worker finished the same run first
                shutil.rmtree(tmp, ignore_errors=True)
            rec["arrays"] = {n: np.asarray(v) for n, v in arrays.items()}
            rec["cached"] = False
            rec["run_dir"] = final
            return rec
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise

    return _guarded(task, key, body)


def _json_default(x):
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    return str(x)


def _last_change(folder: str) -> float:
    """The newest modification time of folder and of everything below it (0 if it is
    gone meanwhile)."""
    newest = 0.0
    for d, _, names in os.walk(folder):
        for p in (d, *(os.path.join(d, n) for n in names)):
            try:
                newest = max(newest, os.path.getmtime(p))
            except OSError:   # removed meanwhile
                pass
    return newest


def _clean_stale(cache: str) -> None:
    """Remove the temporary folders that an interrupted sweep left behind: those in
    which nothing has changed for :data:`STALE_S`. The age is that of the newest file
    inside, not of the folder itself, whose time stops changing once its ``run``
    sub-folder exists: a run of another sweep on the same cache that lasts longer than
    :data:`STALE_S` writes its trace at least every second and is left alone."""
    if not os.path.isdir(cache):
        return
    now = time.time()
    for sub in os.listdir(cache):
        d = os.path.join(cache, sub)
        if not os.path.isdir(d):
            continue
        for name in os.listdir(d):
            p = os.path.join(d, name)
            if TMP_MARK in name and now - _last_change(p) > STALE_S:
                shutil.rmtree(p, ignore_errors=True)


# --------------------------------------------------------------------------- sweeps

def _bar(total: int, desc: str, progress: bool | None):
    if progress is None:
        progress = hasattr(sys.stderr, "isatty") and sys.stderr.isatty()
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit="run", file=sys.stderr, disable=not progress,
                dynamic_ncols=True, mininterval=0.5)


def _cost(task: Task) -> float:
    """Relative cost used to start the longest runs first: steps x (1/h)^dim."""
    dt = float(task.setting("scheme.dt", 0.0025))
    t_end = float(task.setting("scheme.t_end", 15.0))
    h = float(task.setting("mesh.h", 0.05))
    return (t_end / dt) / h


#: Seconds :func:`sweep` waits for the Dask scheduler at an address to answer (the
#: command lines' --scheduler-timeout default): dask's own connect timeout is 30 s, which
#: an address where nothing listens (a typo, a scheduler not started) took before it
#: failed. A scheduler that runs answers in well under a second on a local network.
SCHEDULER_TIMEOUT_S = 5.0

_default_scheduler_timeout: contextvars.ContextVar[float] = contextvars.ContextVar(
    "dyncontact_scheduler_timeout", default=SCHEDULER_TIMEOUT_S)


@contextlib.contextmanager
def default_scheduler_timeout(seconds: float) -> Iterator[None]:
    """Within the block, :func:`sweep` calls that give no ``scheduler_timeout`` wait
    ``seconds`` for their scheduler: how a command line's --scheduler-timeout reaches the
    sweeps of the study it runs, however deep they are called."""
    token = _default_scheduler_timeout.set(_positive_seconds(seconds))
    try:
        yield
    finally:
        _default_scheduler_timeout.reset(token)


def _positive_seconds(seconds: Any) -> float:
    value = float(seconds)
    if not value > 0 or value == float("inf"):
        raise ValueError(f"scheduler_timeout must be a finite number of seconds > 0, "
                         f"got {seconds!r}")
    return value


def sweep(tasks: Sequence[Task], cache: str, *, workers: int | None = None,
          scheduler: Any = None, scheduler_timeout: float | None = None,
          progress: bool | None = None, desc: str = "runs",
          log: Callable[[str], None] | None = None,
          on_done: Callable[[int, dict[str, Any]], None] | None = None
          ) -> list[dict[str, Any]]:
    """Execute tasks (cached ones are taken from ``cache``) and return their records in
    the order of ``tasks``. Each record gets ``task`` (the Task) added. Tasks of one
    cache key (the same scene and analysis, whatever their tags: a grid that names one
    case twice) are one run, done once; each of them gets a copy of its record.

    ``workers``: processes of the local pool (>= 1, default: all cores; ValueError
    otherwise); ``scheduler``: a
    dask.distributed scheduler address or Client, whose cluster runs the tasks on its own
    workers (ValueError with ``workers`` too: it would size nothing).
    ``scheduler_timeout``: seconds to wait for the scheduler at that address to answer
    (default :data:`SCHEDULER_TIMEOUT_S`, or the one of an enclosing
    :func:`default_scheduler_timeout`); :class:`SchedulerUnreachable` after it, raised
    before any run is done.
    ``on_done(i, record)`` is called in this process as soon as task i's record is
    known (from the cache or a finished run), for work that need not wait for the rest.
    """
    timeout = (_default_scheduler_timeout.get() if scheduler_timeout is None
               else _positive_seconds(scheduler_timeout))
    if workers is not None and (isinstance(workers, bool)
                                or not isinstance(workers, numbers.Integral) or workers < 1):
        # 0 ran on every core and a negative number on one, both without a word
        raise ValueError(f"workers must be a whole number >= 1 (or None: every core), "
                         f"got {workers!r}")
    if workers is not None:
        workers = int(workers)            # a numpy integer: the pool takes an int
    if workers is not None and scheduler is not None:
        raise ValueError(f"workers = {workers} with a scheduler: the Dask cluster runs the "
                         "tasks on its own workers; give one of them")
    cache = os.path.abspath(cache)
    os.makedirs(cache, exist_ok=True)
    _clean_stale(cache)
    from .. import core

    core.fortran_version()   # load the extension before forking
    records: list[dict[str, Any] | None] = [None] * len(tasks)
    keys: list[str | None] = [None] * len(tasks)
    todo: list[int] = []
    say = log or (lambda s: print(s, file=sys.stderr, flush=True))
    with _bar(len(tasks), desc, progress) as bar:

        refused: list[str] = []

        def done(i: int, rec: dict[str, Any]) -> None:
            records[i] = rec
            if rec["status"] == REFUSED:
                refused.append(rec["message"].splitlines()[0] if rec["message"] else "")
            if rec["status"] == ERROR:
                msg = rec["message"].splitlines()[0] if rec["message"] else ""
                say(f"{desc}: run failed ({_describe(tasks[i])}): {msg}")
            bar.update(1)
            if on_done is not None:
                on_done(i, rec)

        hits = 0
        # tasks of one key are one run (the same scene and analysis, other tags): it is
        # done once and its record given to each of them
        same: dict[str, list[int]] = {}
        for i, task in enumerate(tasks):
            try:
                keys[i] = task_key(task)
            except Exception as exc:  # noqa: BLE001 - e.g. a bad key: an error record
                done(i, _error_record(task, None, f"{type(exc).__name__}: {exc}"))
                continue
            if keys[i] in same:
                same[keys[i]].append(i)
                continue
            same[keys[i]] = [i]
            hit = lookup(cache, keys[i])
            if hit is not None:
                hits += 1
                done(i, hit)
            else:
                todo.append(i)
        repeats = {}
        for first, *more in same.values():
            if more:
                repeats[first] = more
                if records[first] is not None:   # from the cache
                    hits += len(more)
                    for j in more:
                        done(j, _copy_record(records[first]))
        todo.sort(key=lambda i: -_cost(tasks[i]))
        if log:
            dup = sum(len(repeats.get(i, ())) for i in todo)
            unkeyed = len(tasks) - hits - len(todo) - dup   # no scene: an error record each
            log(f"{desc}: {len(tasks)} runs, {hits} from the cache, {len(todo)} to do"
                + (f" ({dup} more the same run as another)" if dup else "")
                + (f", {unkeyed} whose scene could not be built" if unkeyed else ""))

        def done_all(i: int, rec: dict[str, Any]) -> None:
            done(i, rec)
            for j in repeats.get(i, ()):
                done(j, _copy_record(rec))

        with _sigterm_ends_after_cleaning():
            if todo and scheduler is not None:
                _sweep_dask(tasks, keys, todo, cache, scheduler, timeout, done_all)
            elif todo and (workers or os.cpu_count() or 1) > 1 and len(todo) > 1:
                _sweep_pool(tasks, keys, todo, cache, workers or os.cpu_count() or 1,
                            done_all)
            else:
                for i in todo:
                    done_all(i, execute(tasks[i], cache, keys[i]))
        if refused:
            say(f"{desc}: {len(refused)} run(s) refused by the core as bad input "
                f"(first: {refused[0]})")
    out = []
    for task, rec in zip(tasks, records):
        rec = dict(rec or _error_record(task, None, "not run"))
        rec["task"] = task
        out.append(rec)
    return out


def _copy_record(rec: Mapping[str, Any]) -> dict[str, Any]:
    """A record of its own for another task of the same run: its dicts copied (the
    arrays themselves are shared, as a record's arrays from the cache are read once)."""
    return {k: dict(v) if isinstance(v, dict) else v for k, v in rec.items()}


def _describe(task: Task) -> str:
    tags = ", ".join(f"{k}={v}" for k, v in task.tags)
    return tags or ", ".join(f"{k}={v}" for k, v in task.settings)


def _sigterm_raises(signum, frame):  # noqa: ARG001 - signal handler signature
    raise KeyboardInterrupt(f"signal {signum}")


_sigterm_raises.raises_keyboard_interrupt = True   # a run's set-up reads it (core)


@contextlib.contextmanager
def _sigterm_ends_after_cleaning():
    """Within the block, a SIGTERM that would end the process outright (its default
    action: a script of one's own that calls :func:`sweep`, ended by ``kill PID`` or a
    batch system's time limit) first unwinds the sweep as Ctrl-C does: the pool's workers
    are ended and the temporary entries of the runs they were doing removed (in the
    serial case, the one of the run in progress). Then the process ends by SIGTERM, as
    it would have (exit status 143 from a shell). A handler already set (the command
    lines' :func:`sigterm_as_interrupt`, the caller's own) is left alone, and so is a
    thread other than the main one, where Python cannot set handlers."""
    if threading.current_thread() is not threading.main_thread() \
            or signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL:
        yield
        return
    received = []

    def terminates(signum, frame):
        received.append(signum)
        _sigterm_raises(signum, frame)

    signal.signal(signal.SIGTERM, terminates)
    try:
        yield
    except KeyboardInterrupt:
        # the interrupt may come out of dyncontact.run as its own (the serial case)
        if received:
            signal.signal(signal.SIGTERM, signal.SIG_DFL)
            os.kill(os.getpid(), signal.SIGTERM)   # ends the process here
        raise
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)


@contextlib.contextmanager
def sigterm_as_interrupt():
    """Within the block, SIGTERM raises ``KeyboardInterrupt`` in the main thread as
    Ctrl-C does, so that ``kill PID`` of a study, the figures or the bench stops its
    pool and its workers and exits 130, as ``python -m dyncontact run`` does
    (docs/scenes.md, *Exit codes*). The previous handler is restored at the end. Outside
    the main thread (where Python cannot set handlers) it does nothing, and so it does
    where SIGTERM is ignored (``nohup``, a background job of a shell without job
    control): a signal ignored from the program's start stays ignored, as the executable
    and ``python -m dyncontact run`` leave it."""
    if threading.current_thread() is not threading.main_thread() \
            or signal.getsignal(signal.SIGTERM) is signal.SIG_IGN:
        yield
        return
    previous = signal.signal(signal.SIGTERM, _sigterm_raises)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


@contextlib.contextmanager
def child_group(proc: subprocess.Popen):
    """Within the block, ``proc`` is a child started with ``start_new_session=True``
    (the leader of its own process group, with whatever it starts itself, such as the
    program under ``/usr/bin/time``). Any exception out of the block, a
    ``KeyboardInterrupt`` from Ctrl-C or from SIGTERM under :func:`sigterm_as_interrupt`
    included, first ends that whole group: SIGTERM (a dyncontact run stops at the end of
    its step, exit 130), then SIGKILL after :data:`WORKER_TERM_S`. Without it, a program
    under ``/usr/bin/time`` outlives a parent stopped by SIGTERM: time dies, the run goes
    on as an orphan."""
    try:
        yield proc
    except BaseException:
        _end_group(proc)
        raise


def _end_group(proc: subprocess.Popen) -> None:
    """SIGTERM to the process group led by ``proc``, SIGKILL to what is left of it after
    :data:`WORKER_TERM_S`; ``proc`` is reaped."""
    pgid = proc.pid

    def signal_group(sig: int) -> bool:
        try:
            os.killpg(pgid, sig)
            return True
        except ProcessLookupError:   # the group has ended
            return False

    signal_group(signal.SIGTERM)
    deadline = time.monotonic() + WORKER_TERM_S
    while time.monotonic() < deadline:
        proc.poll()   # reap the leader, so that it does not keep the group alive
        if not signal_group(0):
            break
        time.sleep(0.02)
    else:
        signal_group(signal.SIGKILL)
    try:
        proc.wait(WORKER_TERM_S)
    except subprocess.TimeoutExpired:   # pragma: no cover - stuck in uninterruptible I/O
        pass


def _end_with_parent(parent: int) -> None:
    """In a pool worker: end when the parent process ends, and take SIGINT and SIGTERM
    as the default process does.

    A forked worker inherits the parent's Python handlers (SIGTERM raising
    KeyboardInterrupt inside :func:`sigterm_as_interrupt`), under which the parent's
    ``terminate()`` would only interrupt the run in progress and leave the worker waiting
    for work: SIGTERM gets its default action back. The pool forks its workers with
    SIGINT and SIGTERM blocked (:func:`_sweep_pool`) and they are unblocked only here,
    after that: a signal that reaches a worker still starting waits for it instead of
    raising in the middle of its start-up. SIGINT is ignored: Ctrl-C in a
    terminal reaches the whole process group, and the parent stops the workers itself.
    A worker whose parent was killed outright would wait forever on the task queue (it
    holds both ends of the pipe, so it never sees an end of file): on Linux the kernel
    sends it SIGKILL when the parent ends (``prctl(PR_SET_PDEATHSIG)``), and a parent
    already gone when that is set (the race of a kill during the start) ends it here."""
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, _STOP_SIGNALS)   # blocked by the fork
    if sys.platform.startswith("linux"):
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
        except (OSError, AttributeError):  # pragma: no cover - no prctl: no guard
            pass
    if os.getppid() != parent:
        os._exit(1)


def _warm_worker(parent: int | None = None) -> None:
    """Pool initializer: tie the worker to its parent (:func:`_end_with_parent`), then
    import what a run needs and run a tiny scene once, so that the first run of each
    worker is not charged for lazy imports and first calls (the CPU time of a run is a
    result of the work-precision study)."""
    if parent is not None:
        _end_with_parent(parent)
    try:
        from .. import core
        from ..scene import Scene
        from . import analyses  # noqa: F401

        with tempfile.TemporaryDirectory(prefix="dyncontact-warm-") as tmp:
            path = os.path.join(tmp, "warm.nml")
            with open(path, "w", encoding="utf-8") as f:
                f.write("&mesh dim = 1, h = 0.5 /\n&material young = 1.0, poisson = 0.0 /\n"
                        "&contact obstacle_point = 0.0, obstacle_normal = -1.0, "
                        "probe = 0.0 /\n&scheme dt = 0.1, t_end = 0.2 /\n")
            scn = Scene.read(path)
            core.run(scn, out=os.path.join(tmp, "out"), progress=False)
    except Exception:  # noqa: BLE001 - only a warm-up
        pass


def _stop_pool(pool: cf.ProcessPoolExecutor) -> list[int]:
    """Cancel the pool's pending tasks and end its workers now (SIGTERM, then SIGKILL
    after :data:`WORKER_TERM_S`): ``shutdown`` alone would wait for the runs in progress,
    however long. A run cut short leaves only a temporary entry, never a finished one
    (:func:`_remove_entries_of` removes it). Returns the ended workers' pids."""
    procs = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for p in procs:
        if p.is_alive():
            p.terminate()
    deadline = time.monotonic() + WORKER_TERM_S
    for p in procs:
        p.join(max(0.0, deadline - time.monotonic()))
        if p.is_alive():  # pragma: no cover - a worker stuck in uninterruptible I/O
            p.kill()
            p.join()
    return [p.pid for p in procs if p.pid is not None]


def _remove_entries_of(cache: str, keys: Iterable[str], pids: Iterable[int]) -> None:
    """Remove the temporary entries (``<key>.tmp-<pid>-...``) that the ended workers
    ``pids`` left for ``keys``, the runs they were doing when the sweep was stopped:
    their writers are gone, so nothing will finish them (:func:`_clean_stale` would
    remove them only hours later, and a run's folder can be large)."""
    prefixes = tuple(_tmp_mark(pid) for pid in pids)
    for key in set(keys):
        final = _entry(cache, key)
        folder, name = os.path.split(final)
        try:
            names = os.listdir(folder)
        except OSError:   # no entry of this prefix was ever made
            continue
        for n in names:
            if n.startswith(name) and n[len(name):].startswith(prefixes):
                shutil.rmtree(os.path.join(folder, n), ignore_errors=True)


#: The signals a worker is started with blocked (:func:`_end_with_parent`).
_STOP_SIGNALS = {signal.SIGINT, signal.SIGTERM}


def _sweep_pool(tasks, keys, todo, cache, workers, done) -> None:
    pool = cf.ProcessPoolExecutor(max_workers=workers, initializer=_warm_worker,
                                  initargs=(os.getpid(),))
    try:
        # the pool forks all its workers at the first submit (fork start method), which
        # inherit this mask; a SIGTERM to this process meanwhile waits until the end of
        # the block and then raises here, where the pool is stopped
        mask = signal.pthread_sigmask(signal.SIG_BLOCK, _STOP_SIGNALS)
        try:
            futs = {pool.submit(execute, tasks[i], cache, keys[i], PARALLEL_THREADS): i
                    for i in todo}
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        for fut in cf.as_completed(futs):
            i = futs[fut]
            try:
                rec = fut.result()
            except Exception as exc:  # noqa: BLE001 - e.g. a worker that died
                rec = _error_record(tasks[i], keys[i], f"{type(exc).__name__}: {exc}")
            done(i, rec)
    except BaseException:
        _remove_entries_of(cache, (keys[i] for i in todo), _stop_pool(pool))
        raise
    pool.shutdown(wait=True)


class SchedulerUnreachable(ConnectionError):
    """No dask.distributed scheduler answered at the address given to :func:`sweep`
    within its ``scheduler_timeout`` (the command lines' ``--scheduler-timeout``).
    ``address`` is the address given, ``timeout`` the seconds waited."""

    def __init__(self, address: str, reason: str, timeout: float | None = None):
        within = f" within {timeout:g} s" if timeout is not None else ""
        super().__init__(f"no Dask scheduler answers at {address}{within} ({reason})")
        self.address = address
        self.timeout = timeout


def _sweep_dask(tasks, keys, todo, cache, scheduler, timeout, done) -> None:
    from distributed import Client, as_completed

    own = not isinstance(scheduler, Client)
    if own:
        try:
            client = Client(scheduler, timeout=timeout)
        except OSError as exc:   # refused or timed out: dask retries until the timeout
            raise SchedulerUnreachable(str(scheduler), str(exc), timeout) from exc
    else:
        client = scheduler
    try:
        futs = [client.submit(execute, tasks[i], cache, keys[i], PARALLEL_THREADS, pure=False,
                              key=f"dyncontact-{keys[i]}-{uuid.uuid4().hex[:6]}")
                for i in todo]
        index = {f.key: i for f, i in zip(futs, todo)}
        for fut in as_completed(futs):
            i = index[fut.key]
            try:
                rec = fut.result()
            except Exception as exc:  # noqa: BLE001 - a lost worker, ...
                rec = _error_record(tasks[i], keys[i], f"{type(exc).__name__}: {exc}")
            done(i, rec)
            fut.release()
    finally:
        if own:
            client.close()


def by_tags(records: Iterable[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Flat rows: each record's tags, then its status fields (:data:`RUN_FIELDS`) and
    metrics. A tag named as a status field or a metric is a ValueError naming it: the
    row would hold the run's value under the tag's name."""
    rows = []
    for r in records:
        tags = dict(r["task"].tags)
        row = {field: r.get(field) for field in RUN_FIELDS}
        row["status"] = r["status"]
        row["message"] = r["message"].splitlines()[0] if r.get("message") else ""
        row.update(r.get("metrics", {}))
        clash = [k for k in tags if k in row]
        if clash:
            raise ValueError(f"tag(s) {', '.join(map(repr, clash))} of task "
                             f"{_describe(r['task'])!r}: the names of the run's own fields "
                             "or metrics; name the tag otherwise")
        rows.append({**tags, **row})
    return rows
