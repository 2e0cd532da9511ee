"""The only module that calls the Fortran extension ``dyncontact._core``.

Everything that crosses the f2py boundary goes through here: dtype/order
conversion (done once, so f2py never copies), 0-based (Python) to 1-based
(Fortran) indices, ``bytes`` -> ``str`` for fixed-length Fortran strings, and
the Fortran ``stat`` codes to exceptions:

====  =====================  ==========================================
stat  meaning                Python
====  =====================  ==========================================
0     ok                     --
2     bad input              :class:`BadInputError`
3     numerical failure      :func:`run`: a :class:`RunResult` whose
                             ``status`` is 'unstable' / 'newton_failed';
                             elsewhere :class:`NumericalError`
4     internal error         :class:`DyncontactError`
====  =====================  ==========================================

>>> import dyncontact
>>> res = dyncontact.run("scripts/scenes/bar2d_hht.nml", out="out/bar2d_hht")  # doctest: +SKIP
>>> res.status, res.trace["u_n"][-1]                                           # doctest: +SKIP
"""

from __future__ import annotations

import contextlib
import dataclasses
import errno
import json
import operator
import os
import shutil
import signal
import sys
import tempfile
import threading
import time
import warnings
from typing import Any, Callable, Mapping

import numpy as np

__all__ = [
    "DyncontactError", "BadInputError", "RunNotFoundError", "NumericalError", "RunResult",
    "run", "run_file",
    "TRACE_COLUMNS", "read_trace", "read_summary", "fortran_version", "scene_dump", "scene_parse",
    "load_mesh", "estimate_geo", "unmeshed_text", "p1_element",
    "umf_solve", "linear_solve", "Model", "bench_floors_available",
    "bench_floors", "cpu_lacks", "V3_FEATURES",
]

#: Header of trace.csv (SPEC section 4).
TRACE_COLUMNS = ("t", "u_n", "v_n", "p_n", "e_kin", "e_el", "e_contact", "e_total",
                 "newton_its", "active", "e_load", "f_n")

STAT_OK, STAT_BAD_INPUT, STAT_NUMERIC, STAT_INTERNAL, STAT_INTERRUPTED = 0, 2, 3, 4, 5

#: The name of the file a :class:`dyncontact.Scene` is written to, in a temporary folder,
#: for the core to read (:func:`run`, :class:`Model`).
SCENE_FILE = "scene.nml"

#: Longest path the Fortran core accepts, in bytes of the file-system encoding.
PATH_MAX_BYTES = 1024

#: run() advances the run in chunks of steps that take about this long (wall seconds):
#: Ctrl-C, SIGTERM, the progress bar and the callback act between two chunks. A fixed
#: chunk of 100 steps took 10-100 s on meshes of 10^5 dofs, where Ctrl-C waited that long.
CHUNK_S = 0.5
#: The largest step budget the core's dc_sim_advance takes (a C int).
C_INT_MAX = 2**31 - 1


class DyncontactError(RuntimeError):
    """A failure of the dyncontact core (Fortran stat 4, or anything unexpected)."""


class BadInputError(DyncontactError, ValueError):
    """Bad scene, mesh or argument (Fortran stat 2; exit status 2)."""


class RunNotFoundError(BadInputError, FileNotFoundError):
    """A run folder (or the file of it a reader needs: trace.csv, fields.pvd) that is not
    there: bad input, one line naming the path. Also a :class:`FileNotFoundError`
    (``errno`` ENOENT, ``filename`` the path), which the readers raised before."""

    def __init__(self, path: str | os.PathLike, what: str) -> None:
        path = os.fspath(path)
        FileNotFoundError.__init__(self, errno.ENOENT, what, path)
        self.path, self.what = path, what

    def __str__(self) -> str:
        return f"{self.path}: {self.what}"

    def __reduce__(self):      # pickled as made (a sweep's worker process to the caller)
        return type(self), (self.path, self.what)


def run_file(out_dir: str | os.PathLike, name: str, what: str | None = None) -> str:
    """The path of file ``name`` of the run folder ``out_dir`` (the readers' one check):
    :class:`RunNotFoundError` naming the folder when it is not there (or is a file), and
    when ``what`` is given (said after ``no NAME``: why it is needed, or '') and the
    folder has no such file."""
    folder = os.fspath(out_dir)
    if not os.path.isdir(folder):
        raise RunNotFoundError(folder, "no such run folder" if not os.path.exists(folder)
                               else "not a folder (a run folder holds trace.csv)")
    path = os.path.join(folder, name)
    if what is not None and not os.path.isfile(path):
        raise RunNotFoundError(folder, f"no {name}{what}")
    return path


class DyncontactWarning(UserWarning):
    """A warning or note of the core about a scene that runs (the CLI prints it as
    ``dyncontact: warning: ...``)."""


class NumericalError(DyncontactError):
    """Numerical failure outside a time loop (Fortran stat 3: singular matrix, ...)."""


#: The features of x86-64-v3 that the core compiled with -march=x86-64-v3 -mno-fma may use
#: (the x86-64 psABI's levels v2 and v3 but FMA), as (name, flag of /proc/cpuinfo);
#: fortran/app/cpu_check.c, the executable's check, has the same list.
V3_FEATURES = (("cmpxchg16b", "cx16"), ("lahf_lm", "lahf_lm"), ("popcnt", "popcnt"),
               ("sse3", "pni"), ("sse4.1", "sse4_1"), ("sse4.2", "sse4_2"), ("ssse3", "ssse3"),
               ("avx", "avx"), ("avx2", "avx2"), ("bmi", "bmi1"), ("bmi2", "bmi2"),
               ("f16c", "f16c"), ("lzcnt", "abm"), ("movbe", "movbe"), ("osxsave", "xsave"))


def cpu_lacks(isa: str, flags: set[str] | None) -> str | None:
    """The one-line error for a CPU whose /proc/cpuinfo ``flags`` lack features that the
    instruction set ``isa`` of the build uses, else None (also when the flags are unknown:
    None, another system than Linux). Pure, so that a test can give it an older CPU."""
    if isa != "x86-64-v3" or flags is None:
        return None
    lacking = [name for name, flag in V3_FEATURES if flag not in flags]
    if not lacking:
        return None
    return ("this build of the core uses x86-64-v3 instructions (AVX2; -Dsimd=auto on a "
            f"machine that has them) and this CPU lacks {', '.join(lacking)}; rebuild with "
            "`meson setup build -Dsimd=portable` (or `pip install . "
            "-Csetup-args=-Dsimd=portable`)")


def _cpu_flags() -> set[str] | None:
    """The CPU's feature flags from /proc/cpuinfo (its first processor), None if unknown."""
    try:
        with open("/proc/cpuinfo", encoding="ascii", errors="replace") as f:
            for line in f:
                key, _, value = line.partition(":")
                if key.strip() == "flags":
                    return set(value.split())
    except OSError:
        pass
    return None


def _check_cpu() -> None:
    """Raise DyncontactError (exit 4 from the CLI, as the executable's check) when the CPU
    lacks what the extension was compiled for. Importing the extension on such a CPU may
    kill the process with SIGILL ("Illegal instruction"), which no Python code can catch,
    so the check reads /proc/cpuinfo and the build's recorded level (``_version.__isa__``)
    and runs before the import."""
    try:
        from ._version import __isa__
    except ImportError:  # pragma: no cover - source tree without a build
        return
    said = cpu_lacks(__isa__, _cpu_flags())
    if said:
        raise DyncontactError(said)


def _core():
    """The extension module, imported on first use with a readable error; the CPU is
    checked first (_check_cpu)."""
    if __package__ + "._core" not in sys.modules:
        _check_cpu()
    try:
        from . import _core as core
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise DyncontactError(
            f"the Fortran extension dyncontact._core cannot be imported ({exc}); "
            "run scripts/setup (or `pip install .`)") from exc
    return core


def exit_on_signal_during_mesh_read() -> None:
    """For a program only (``python -m dyncontact run``), never for a library caller:
    from this call on, SIGINT or SIGTERM while gmsh reads or meshes a mesh file ends the
    whole process at once with exit status 130 and the executable's line on stderr
    (``dyncontact: FILE: interrupted by signal N while gmsh read it; nothing was
    written``), instead of the signal waiting until gmsh returns (minutes on a large
    .geo) and coming back as a KeyboardInterrupt.

    A switch of the process, set once and never cleared, as the executable's signal
    handlers are: ending the process is the decision of the program that owns it, not
    of a run, so it is no argument of :func:`run` and no state of a library object. A
    script, a notebook or a :class:`Stepper` that imports dyncontact keeps Python's
    handling of the signals (a KeyboardInterrupt once the read is over). It is safe only
    where nothing the exit would leave behind has been written before the read: the core
    reads the mesh before it makes the output folder or takes its lock; :func:`run` of a
    :class:`dyncontact.Scene` writes it to a temporary file first, and
    :func:`dyncontact.mesh_io.generate` its mesh file under a temporary name until it is
    whole, and both name them to :func:`removed_if_stopped`, so that the exit removes
    them. A SIGINT or SIGTERM that the process ignores (``nohup``, a background job of a
    shell without job control) stays ignored."""
    _core().dc_exit_on_read_signal()


@contextlib.contextmanager
def removed_if_stopped(*paths: str | os.PathLike):
    """Within the block, a stop signal that ends the process during a gmsh read
    (:func:`exit_on_signal_during_mesh_read`) first removes each of ``paths``: files,
    then folders (removed when the files have emptied them). For the temporary files a
    caller writes before a read and removes itself afterwards. Nothing changes in a
    process that has not asked for that exit. The core holds a few such names at a time
    (8): a path it cannot hold (too many named at once, a path over 4095 bytes) would be
    left behind by such an exit, and is not an error of the block."""
    named = _stop_removes(paths)
    try:
        yield
    finally:
        _stop_keeps(named)


def _stop_removes(paths) -> list[bytes]:
    """Name ``paths`` to the core for removal by a stop (:func:`removed_if_stopped`);
    those it holds, for :func:`_stop_keeps`."""
    lib = _core()
    named = []
    for path in paths:
        b = os.fsencode(path)
        if lib.dc_stop_removes(b) == 0:
            named.append(b)
    return named


def _stop_keeps(named: list[bytes]) -> None:
    """Take back the names of :func:`_stop_removes`."""
    lib = _core()
    for b in reversed(named):
        lib.dc_stop_keeps(b)


@contextlib.contextmanager
def gmsh_guard(path: str | os.PathLike, doing: str = "meshed"):
    """Guard the caller's own calls into gmsh (the gmsh Python module) as the core
    guards its reads: within the block, the stop signals (SIGINT, SIGTERM, SIGHUP,
    SIGQUIT) are held in the calling thread, and every signal's disposition is put back
    at its end, undoing what gmsh's initialization changes (it resets SIGTERM to its
    default, which would kill the process without a word, even where SIGTERM was
    ignored). Call :func:`gmsh_guard_after_init` right after ``gmsh.initialize()``.

    In a program that asked for it (:func:`exit_on_signal_during_mesh_read`), SIGINT or
    SIGTERM inside the block ends the process at once, exit status 130, after removing
    what :func:`removed_if_stopped` names, with one line on stderr:
    ``dyncontact: PATH: interrupted by signal N while gmsh DOING it; nothing was
    written``. Elsewhere (a library caller) the signal reaches the caller's handler once
    the block ends (a KeyboardInterrupt for Ctrl-C). One guard at a time in the process:
    a block inside another one, or in another thread meanwhile, guards nothing more."""
    lib = _core()
    start = b"dyncontact: " + os.fsencode(path) + b": interrupted by signal "
    held = lib.dc_gmsh_guard_begin(start, f" while gmsh {doing} it; nothing was written")
    try:
        yield
    finally:
        if held:
            lib.dc_gmsh_guard_end()


def gmsh_guard_after_init() -> None:
    """Inside :func:`gmsh_guard`, right after ``gmsh.initialize()``: the stop signals'
    dispositions put back at once (gmsh's initialization resets SIGTERM's, so that a
    SIGTERM during the meshing would kill the process without a word)."""
    _core().dc_gmsh_guard_after_init()


def _str(b: bytes | str) -> str:
    """A fixed-length Fortran string returned by f2py, as str."""
    if isinstance(b, bytes):
        b = b.decode("utf-8", "surrogateescape")
    return b.strip().strip("\x00").strip()


def _check(stat: int, errmsg: bytes | str, what: str) -> None:
    """Raise the exception that belongs to a Fortran stat."""
    stat = int(stat)
    if stat == STAT_OK:
        return
    msg = _str(errmsg) or f"{what} failed (stat {stat})"
    if stat == STAT_BAD_INPUT:
        raise BadInputError(msg)
    if stat == STAT_NUMERIC:
        raise NumericalError(msg)
    if stat == STAT_INTERRUPTED:
        raise KeyboardInterrupt(msg)
    raise DyncontactError(msg)


def _fpath(path, what: str) -> bytes:
    """A path as the bytes the Fortran core gets (file-system encoding, so that
    non-ASCII names work), refused when longer than the core's limit."""
    b = os.fsencode(path)
    if len(b) > PATH_MAX_BYTES:
        raise BadInputError(f"{what}: the path is {len(b)} bytes long, over the limit of "
                            f"{PATH_MAX_BYTES} ({os.fsdecode(b)[:60]}...)")
    return b


def _notes(text) -> list[str]:
    """The core's notes (one per line) as a list."""
    return [line.strip() for line in _str(text).splitlines() if line.strip()]


def _warn_notes(handle) -> int:
    """Give an opened run's warnings and notes (the core's, one a line) as
    DyncontactWarning warnings at the line that called run() or Stepper(); returns the
    run's steps."""
    n_steps, _bytes, notes = _core().dc_sim_info(handle)
    for note in _notes(notes):
        warnings.warn(note, DyncontactWarning, stacklevel=3)
    return int(n_steps)


def _f64(a, shape=None) -> np.ndarray:
    a = np.asfortranarray(a, dtype=np.float64)
    if shape is not None and a.shape != shape:
        raise ValueError(f"expected an array of shape {shape}, got {a.shape}")
    return a


def _i32(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.int32)


# --------------------------------------------------------------------------- outputs

def read_trace(out_dir: str | os.PathLike) -> dict[str, np.ndarray]:
    """trace.csv of a run folder as {column: float64 array} (empty arrays if no rows).

    A run killed halfway may leave a partial last line: it is dropped. The rows are
    parsed by numpy's C reader in one call (about twice as fast as a Python loop, which
    matters for the 150 000-row runs of a study); a file it does not read whole (a
    malformed line) is read line by line, up to the first bad line.
    A folder that is not there, or has no trace.csv: :class:`RunNotFoundError` (a
    BadInputError and a FileNotFoundError) naming it.
    """
    path = run_file(out_dir, "trace.csv", "")
    with open(path, encoding="utf-8") as f:
        text = f.read()
    if not text:
        raise DyncontactError(f"{path}: empty file")
    head, _, body = text.partition("\n")
    names = [c.strip() for c in head.split(",")]
    body = body[:body.rfind("\n") + 1]      # complete lines only
    n_rows = body.count("\n")
    data = None
    if n_rows:
        try:
            with warnings.catch_warnings():   # numpy < 2 warned where 2 raises
                warnings.simplefilter("error", DeprecationWarning)
                flat = np.fromstring(body[:-1].replace("\n", ","), dtype=np.float64, sep=",")
        except (ValueError, DeprecationWarning):
            flat = np.empty(0)
        if flat.size == n_rows * len(names):
            data = flat.reshape(n_rows, len(names))
    if data is None:
        rows = []
        for line in body.splitlines():
            parts = line.split(",")
            if len(parts) != len(names):
                break  # partial line at the end of a killed run
            try:
                rows.append([float(p) for p in parts])
            except ValueError:
                break
        data = np.array(rows, dtype=np.float64).reshape(len(rows), len(names))
    return {name: np.ascontiguousarray(data[:, j]) for j, name in enumerate(names)}


def read_summary(out_dir: str | os.PathLike) -> dict[str, Any]:
    """summary.json of a run folder ({} if the folder has none);
    :class:`RunNotFoundError` naming the folder when it is not there."""
    path = run_file(out_dir, "summary.json")
    if not os.path.exists(path):
        return {}
    with open(path, encoding="utf-8") as f:
        return json.load(f)


@dataclasses.dataclass(repr=False)
class RunResult:
    """What :func:`run` returns.

    Attributes
    ----------
    trace : dict of numpy arrays keyed by the trace.csv columns (``TRACE_COLUMNS``)
    summary : the parsed summary.json (``status``, ``steps``, ``scheme``, ``scene``, ...)
    out_dir : the folder that holds trace.csv and summary.json
    message : the core's message when the run stopped early ('' otherwise)

    Its repr is one line, without the arrays and the summary::

        <RunResult status='ok' steps=1500 t=3.0 out_dir='/home/me/out'
         trace=301 rows x (t, u_n, v_n, ...)>
    """

    trace: dict[str, np.ndarray]
    summary: dict[str, Any]
    out_dir: str
    message: str = ""

    def __repr__(self) -> str:
        rows = len(next(iter(self.trace.values()), ()))
        return (f"<RunResult status={self.status!r} steps={self.summary.get('steps', '?')} "
                f"t={self.summary.get('t_end_reached', '?')} out_dir={self.out_dir!r} "
                f"trace={rows} rows x ({', '.join(self.trace)})>")

    @property
    def status(self) -> str:
        """'ok', 'unstable' or 'newton_failed' (summary.json's status)."""
        return str(self.summary.get("status", "ok" if not self.message else "failed"))

    @property
    def ok(self) -> bool:
        return self.status == "ok"


# --------------------------------------------------------------------------- run

def fortran_version() -> str:
    """The version string compiled into the Fortran core (dc_version)."""
    return _str(_core().dc_version())


#: The defaults of the vector keys by mesh dimension, as the core's (scene_keys in
#: fortran/io/scene.f90; tests/test_scene_vectors.py checks them against summary.json).
#: Vectors have 2 components in 1D and 2D (the second one 0 in 1D), 3 in 3D.
VECTOR_DEFAULTS: dict[int, dict[tuple[str, str], list[float]]] = {
    1: {("material", "gravity"): [0.0, 0.0], ("contact", "obstacle_point"): [0.0, 0.0],
        ("contact", "obstacle_normal"): [-1.0, 0.0], ("contact", "probe"): [0.0, 0.0],
        ("initial", "velocity"): [0.0, 0.0]},
    2: {("material", "gravity"): [0.0, 0.0], ("contact", "obstacle_point"): [0.0, 0.0],
        ("contact", "obstacle_normal"): [0.0, -1.0], ("contact", "probe"): [0.05, 0.0],
        ("initial", "velocity"): [0.0, 0.0]},
    3: {("material", "gravity"): [0.0, 0.0, 0.0],
        ("contact", "obstacle_point"): [0.0, 0.0, 0.0],
        ("contact", "obstacle_normal"): [0.0, 0.0, -1.0],
        ("contact", "probe"): [0.05, 0.05, 0.0], ("initial", "velocity"): [0.0, 0.0, 0.0]},
}


def _fill_vectors(scene: dict[str, Any]) -> dict[str, Any]:
    """The core's JSON with each vector key not given (null) filled with the default of
    the dimension known before the mesh is read: the built-in bar's (dim 0: 2), or the
    &mesh dim given with a mesh file. With a mesh file and dim = 0 it stays None."""
    mesh = scene.get("mesh", {})
    dim = mesh.get("dim")
    if mesh.get("file"):
        dim = dim or None
    else:
        dim = dim or 2
    if dim in VECTOR_DEFAULTS:
        for (group, key), value in VECTOR_DEFAULTS[dim].items():
            if group in scene and scene[group].get(key, 0) is None:
                scene[group][key] = list(value)
    return scene


def _given_names(given: bytes | str) -> frozenset[str]:
    """The core's list of the keys a scene gives ('group.key' separated by blanks)."""
    return frozenset(_str(given).split())


def scene_dump(path: str | os.PathLike, keep_omitted: bool = False,
               with_given: bool = False):
    """The scene file as the Fortran core reads it (all keys, defaults filled in).

    A vector key the file does not give takes the default of the mesh's dimension
    (docs/scenes.md, "Vector keys"); with ``keep_omitted`` it is None (as in the core's
    JSON), and it is None anyway for a mesh file with ``&mesh dim = 0``, whose dimension is
    known once the file is read. ``with_given``: return ``(scene, given)``, ``given`` the
    frozenset of the keys the file writes, as ``'group.key'`` (whatever their values: the
    run's warnings about keys that change nothing are about those).

    Raises :class:`BadInputError` with the core's one-line message on a bad scene.
    """
    with tempfile.TemporaryDirectory(prefix="dyncontact-") as tmp:
        json_path = os.path.join(tmp, "scene.json")
        given, stat, errmsg = _core().dc_scene_dump(_fpath(path, "scene file"),
                                                    _fpath(json_path, "temporary file"))
        _check(stat, errmsg, "reading the scene")
        with open(json_path, encoding="utf-8", errors="surrogateescape") as f:
            scene = json.load(f)
    scene = scene if keep_omitted else _fill_vectors(scene)
    return (scene, _given_names(given)) if with_given else scene


def scene_parse(text: str, name: str, full: bool = False, keep_omitted: bool = False,
                with_given: bool = False):
    """A scene given as namelist text, as the Fortran core reads it (all keys, defaults
    filled in; ``keep_omitted`` and ``with_given``: as in :func:`scene_dump`).
    ``full=False`` checks only the syntax and the types of the values; ``full=True`` also
    the ranges and the cross-checks, as for a file. ``name`` stands for the scene in
    messages; a relative mesh file counts from the current folder.

    Raises :class:`BadInputError` with the core's one-line message on a bad scene.
    """
    enc = ("utf-8", "surrogateescape")
    js, given, stat, errmsg = _core().dc_scene_text(text.encode(*enc), name.encode(*enc),
                                                    int(full))
    _check(stat, errmsg, "reading the scene")
    if isinstance(js, bytes):
        js = js.decode(*enc)
    scene = json.loads(js.rstrip(" \x00"))
    scene = scene if keep_omitted else _fill_vectors(scene)
    return (scene, _given_names(given)) if with_given else scene


def scene_check_dim(text: str, name: str, dim: int) -> None:
    """Check a scene given as namelist text against its mesh's dimension ``dim``, as the
    run does once the mesh is read: the vector keys' counts (3 in 3D), ``&contact
    quad_points``, ``&mesh dim`` against a mesh file's. ``name`` stands for the scene in
    messages. Raises :class:`BadInputError` with the core's one-line message.
    """
    enc = ("utf-8", "surrogateescape")
    stat, errmsg = _core().dc_scene_check_dim(text.encode(*enc), name.encode(*enc), int(dim))
    _check(stat, errmsg, "reading the scene")


def _scene_output_dir(scene_json: Mapping[str, Any]) -> str | None:
    out = scene_json.get("output", {})
    d = out.get("dir") if isinstance(out, Mapping) else None
    return str(d) if d else None


def _write_scene(scene, folder: str) -> str:
    """Write a Scene as folder/scene.nml with an absolute mesh file (``write``
    validates it, leaving what needs the mesh to the run, which reads it). A copy is
    written: the validation normalizes ``contact.obstacle_normal`` in the Scene it
    checks, and a run leaves the caller's Scene as the caller left it."""
    path = os.path.join(folder, SCENE_FILE)
    scene.copy().write(path)
    return path


def _need_scene(scene, who: str) -> None:
    """TypeError naming ``who`` (``run()``, ``Stepper()``) unless ``scene`` is a path or
    a :class:`dyncontact.Scene`."""
    from .scene import Scene

    if not isinstance(scene, (str, bytes, os.PathLike, Scene)):
        raise TypeError(f"{who}: scene must be a path (str, bytes or os.PathLike) or a "
                        f"dyncontact.Scene, not {type(scene).__name__}")


def _is_path(scene) -> bool:
    """True for a scene given as a path (a file the core reads), False for a Scene."""
    return isinstance(scene, (str, bytes, os.PathLike))


def _scene_file(scene, folder: str | None) -> tuple[str, str | None]:
    """(the scene file the core reads, the temporary file written for it or None): a
    path as it is; a Scene written into ``folder`` (:func:`_write_scene`), whose file
    the core's messages name until :func:`_raise_for_scene` names the Scene instead."""
    if _is_path(scene):
        return os.fsdecode(scene), None
    written = _write_scene(scene, folder)
    return written, written


def _progress_bar(progress, total: int, desc: str):
    """A tqdm bar on stderr (progress=None: only when stderr is a terminal)."""
    if progress is None:
        progress = hasattr(sys.stderr, "isatty") and sys.stderr.isatty()
    if not progress or total <= 0:
        return contextlib.nullcontext(None)
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover
        return contextlib.nullcontext(None)
    return tqdm(total=total, desc=desc, unit="step", file=sys.stderr, leave=False,
                dynamic_ncols=True)


def run(scene, out: str | os.PathLike | None = None, progress: bool | None = None,
        callback: Callable[[int, int], None] | None = None,
        restart: str | os.PathLike | None = None,
        opened: Callable[[list[str]], None] | None = None) -> RunResult:
    """Run one scene to its end (or until it becomes unstable) and read its outputs.

    Parameters
    ----------
    scene : path of a scene file (.nml), or a :class:`dyncontact.Scene`. A path is given
        to the Fortran core as is; a Scene is validated and written to a temporary file
        (mesh file made absolute) first, through a copy: the caller's Scene is left as
        it was (``contact.obstacle_normal`` as given; the run normalizes it).
    out : output folder; None = the scene's ``&output dir``.
    progress : None (default) shows a progress bar on stderr when it is a terminal;
        True / False force it on / off.
    callback : optional ``callback(step, n_steps)`` called after each chunk of steps
        (about ``CHUNK_S`` seconds of steps). A ``KeyboardInterrupt`` it raises stops the
        run as Ctrl-C does: the trace is kept, the folder's lock released, and the
        interrupt raised again with the run's line (``interrupted at t = ...``; after the
        last chunk, ``interrupted after the run ended at t = ...``). Any other exception
        it raises stops the run the same way (trace kept, lock released, summary.json's
        status 'interrupted') with the message ``callback raised TYPE: TEXT; stopped at
        t = ... (trace kept)``, and goes on to the caller as it was raised.
    restart : output folder of a stopped run of the same scene, holding the checkpoint.bin
        its ``&output checkpoint_every`` wrote: the run continues from it in that folder
        (trace.csv continued, summary.json counting the whole run; the result is the one
        of the run never stopped, bit for bit). ``out`` must then be None or that folder.
        The scene may differ in the keys that say when to stop (``scheme.t_end``,
        ``max_steps``, ``blowup``) and in ``output.checkpoint_every``: a later t_end
        extends a run that ended, a raised blowup continues one stopped as unstable
        (docs/scenes.md, "Checkpoint and restart").
    opened : optional ``opened(lines)`` called once the run is open, before its first
        step, with the lines the executable prints on stdout at that moment, without its
        ``dyncontact: `` prefix: ``restart at step N, t=T`` for a restart, then ``SCENE: N
        dofs, M elements, F contact facets; SCHEME, K steps -> DIR`` (the scene file, or
        a Scene's path, and the output folder as given). An exception it raises stops
        the run before its first step (the folder's lock released) and goes on to the
        caller.

    Returns
    -------
    RunResult
        ``status`` is 'ok', or 'unstable' / 'newton_failed' when the run stopped early
        (Fortran stat 3; the CLI turns that into exit status 3).

    Raises
    ------
    BadInputError
        bad scene, mesh or argument (Fortran stat 2); with ``restart``, a missing,
        foreign (another scene, build or step dt), truncated or corrupt checkpoint, or one
        past the scene's t_end.
    DyncontactError
        internal failure (stat 4).
    """
    _need_scene(scene, "run()")
    core = _core()
    explicit_out = out is not None
    if restart is not None and out is None:
        out = restart
    # a folder for the file a Scene is written to, none for a scene file; a program that
    # ends itself on a signal while gmsh reads the mesh (exit_on_signal_during_mesh_read)
    # removes the file and the folder first (removed_if_stopped): nothing is left behind
    tmp = None if _is_path(scene) else tempfile.mkdtemp(prefix="dyncontact-")
    written = None    # the temporary file a Scene is written to (its messages name the Scene)
    named = [] if tmp is None else _stop_removes([tmp, os.path.join(tmp, SCENE_FILE)])
    try:
        path, written = _scene_file(scene, tmp)
        if out is None:   # the folder the core will use (a bad scene file raises here)
            out = (_scene_output_dir(scene_dump(path)) if written is None
                   else _scene_attr_output_dir(scene)) or "out"
        # Relative output folders count from the current folder, for both entry points;
        # the core gets the folder as given, so that summary.json records it as the
        # executable does.
        given = _folder_arg(out, "out" if explicit_out else "restart")
        out_dir = os.path.abspath(given)
        start = 0
        if restart is not None:
            given = _folder_arg(restart, "restart")
            restart_dir = os.path.abspath(given)
            if explicit_out and not _same_folder(restart_dir, out_dir):
                raise BadInputError(f"restart={os.fspath(restart)!r} continues the run in that "
                                    "folder: out must be the same folder or None")
            out_dir = restart_dir
        if restart is not None:
            def open_run():
                return core.dc_sim_open_restart(_fpath(path, "scene file"),
                                                _fpath(given, "restart folder"))
        else:
            def open_run():
                return core.dc_sim_open(_fpath(path, "scene file"),
                                        _fpath(given, "output folder"), 0,
                                        _out_said("out", given) if explicit_out else b"")
        handle = 0

        def keep(opened_handle: int) -> None:
            nonlocal handle
            handle = opened_handle

        message = ""
        stopped = None
        try:
            # a signal during the open (the set-up after the mesh is read: seconds to
            # minutes on a large mesh) stops the run before its first step as any other:
            # the run closed as interrupted, its lock released (_open_held)
            got = _open_held(open_run, keep)
            _check(got[-2], got[-1], "opening the run")
            if restart is not None:
                start = got[2]
            n_steps = _warn_notes(handle)
            if opened is not None:
                said = os.fsdecode(scene) if written is None else scene._name()
                lines = [_str(x) for x in core.dc_sim_lines(
                    handle, said.encode("utf-8", "surrogateescape"),
                    _fpath(given, "output folder"))]
                opened([line for line in lines if line])
            # the first chunk is one step; then as many as take about CHUNK_S, at most
            # max(100, n_steps // 200) (fewer calls on small fast runs)
            max_chunk = max(100, n_steps // 200)
            chunk = 1
            with _progress_bar(progress, n_steps, os.path.basename(out_dir)) as bar:
                if bar is not None and start:
                    bar.update(int(start))
                finished = 0
                while not finished:
                    clock = time.perf_counter()
                    done, step, finished, stat, errmsg = core.dc_sim_advance(handle, chunk)
                    if done:
                        per_step = max(time.perf_counter() - clock, 1e-9) / int(done)
                        chunk = min(max_chunk, max(1, int(CHUNK_S / per_step)))
                    if bar is not None and done:
                        bar.update(int(done))
                    if callback is not None:
                        _call_back(callback, int(step), int(n_steps), handle)
                    if stat == STAT_NUMERIC:
                        message = _str(errmsg) or "numerical failure"
                        break
                    _check(stat, errmsg, "advancing the run")
                    if not finished and done == 0:
                        raise DyncontactError(
                            f"the run made no progress at step {int(step)} of {int(n_steps)}")
        except KeyboardInterrupt as exc:   # Ctrl-C, SIGTERM, or the core's signal stop
            if not handle:                 # during an open that failed: nothing to close
                raise
            stopped = exc
        finally:
            if handle:
                stat, errmsg = core.dc_sim_close(handle)
        _check(stat, errmsg, "closing the run")
        if stopped is not None:
            # with the message the run wrote on closing: t, and what was kept; a run that
            # had ended (the callback of its last chunk stopped it) wrote none
            try:
                summary = read_summary(out_dir)
            except (OSError, ValueError):
                summary = {}
            said = summary.get("message")
            if not said and summary.get("status") == "ok":
                said = (f"interrupted after the run ended at t = "
                        f"{summary.get('t_end_reached')} (trace and summary complete)")
            raise KeyboardInterrupt(said or str(stopped)) from None
        trace = read_trace(out_dir)
        summary = read_summary(out_dir)
        if message and summary.get("status", "ok") == "ok":
            summary = dict(summary, status="unstable")
        return RunResult(trace=trace, summary=summary, out_dir=out_dir, message=message)
    except BadInputError as exc:
        _raise_for_scene(exc, written, scene)
    finally:
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)
        _stop_keeps(named)


def _open_held(open_call: Callable[[], tuple], keep: Callable[[int], None]) -> tuple:
    """``open_call()``, a core call that opens a run, a model or a mesh and returns its
    handle first (0 when it failed) and its stat and message last, made with SIGINT and
    SIGTERM held (:class:`_SignalsHeld`); ``keep(handle)`` stores a handle it opened where
    the caller's clean-up closes or frees it, and only then are the signals held handled
    (Ctrl-C's KeyboardInterrupt raised here). Returns the call's result.

    The one way :func:`run`, :class:`Model`, :class:`Stepper`, :func:`bench_floors` and
    :func:`load_mesh` open the core's objects: a signal during the open (a run's set-up
    after the mesh read, a .geo's meshing: seconds to minutes on a large mesh) reached
    Python as the call returned, before the handle was stored, and the object was never
    freed (a run's folder left locked, its summary.json saying "running"; a mesh's
    memory kept to the end of the process). A signal during an open that failed is
    raised before the failure (the caller asked to stop; nothing is left open).

    A SIGINT or SIGTERM whose handler raises KeyboardInterrupt (:func:`_stops_runs`)
    reaches the core itself meanwhile (:class:`_SignalsHeld` ``core_reads``): a run's
    set-up (25 s on a cube of 94 000 dofs) reads it between its phases and in its long
    loops, and stops within a fraction of a second (stat STAT_INTERRUPTED, the run closed
    as interrupted before its first step)."""
    with _SignalsHeld(core_reads=True) as held:
        got = open_call()
    try:
        if got[0]:
            keep(got[0])
    finally:
        if int(got[-2]) == STAT_INTERRUPTED:
            # the core stopped on the signal it read: the caller raises the
            # KeyboardInterrupt with the run's line (_check)
            held.drop_read()
        held.deliver()
    return got


def _stops_runs(handler) -> bool:
    """Whether a Python signal handler stops a run as Ctrl-C does, by raising
    KeyboardInterrupt: Python's own of SIGINT, or one marked
    ``handler.raises_keyboard_interrupt = True`` (the command lines' SIGTERM handlers).
    Only such a signal may stop a run's set-up in the core; any other handler is called
    once the core returns, as it was."""
    return handler is signal.default_int_handler \
        or getattr(handler, "raises_keyboard_interrupt", False) is True


class _SignalsHeld:
    """``with _SignalsHeld() as held:`` around a core call whose result must be stored
    before anything may interrupt (:func:`_open_held`): a SIGINT
    or SIGTERM whose handler is Python code (Ctrl-C's KeyboardInterrupt, the command
    line's SIGTERM) is recorded instead of handled during the block, and handled, by the
    handler that was set, at ``held.deliver()``. Python handles a signal that came during
    a call as soon as the call returns, before its result is stored: the run the core
    had opened meanwhile was then never closed (its folder left locked, summary.json
    saying "running"). Only in the main thread, where Python runs its handlers; a block
    left by an exception delivers at once.

    With ``core_reads``, a signal whose handler raises KeyboardInterrupt
    (:func:`_stops_runs`) sets the core's stop flag instead during the block
    (``dc_stop_signals_catch``), which a run's set-up reads; at the block's end the
    handler is put back, the flag taken (cleared: the process's later runs are not
    stopped by it) and the signal held as one recorded. ``drop_read()`` forgets it
    when the core stopped on it."""

    SIGNALS = ("SIGINT", "SIGTERM")

    def __init__(self, core_reads: bool = False) -> None:
        self._previous: dict[int, Any] = {}
        self._held: list[tuple[int, Any]] = []
        self._core_reads = core_reads
        self._read: list[int] = []        # the signals pointed at the core's flag
        self._taken = 0                   # the signal the core's flag held at the end

    def __enter__(self) -> "_SignalsHeld":
        if threading.current_thread() is threading.main_thread():
            for name in self.SIGNALS:
                sig = getattr(signal, name)
                handler = signal.getsignal(sig)
                if callable(handler):
                    self._previous[sig] = handler
                    signal.signal(sig, self._record)
                    if self._core_reads and _stops_runs(handler) \
                            and _core().dc_stop_signals_catch(int(sig)) == 0:
                        self._read.append(sig)
        return self

    def _record(self, signum, frame) -> None:
        self._held.append((signum, frame))

    def __exit__(self, exc_type, exc, tb) -> None:
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)
        if self._read:
            self._taken = int(_core().dc_stop_signal_take())
            if self._taken in self._previous:
                self._held.append((self._taken, None))
        if exc_type is not None:
            self.deliver()

    def drop_read(self) -> None:
        """Forget the signal the core's flag held (the core stopped on it)."""
        self._held = [(s, f) for s, f in self._held if not (s == self._taken and f is None)]

    def deliver(self) -> None:
        """Handle the signals held, once each, as their handlers would have (Ctrl-C's
        raises KeyboardInterrupt here)."""
        held, self._held = self._held, []
        for signum, frame in held:
            self._previous[signum](signum, frame)


#: The longest text of a callback's exception that summary.json's message repeats.
CALLBACK_TEXT_MAX = 200


def _call_back(callback, step: int, n_steps: int, handle) -> None:
    """``callback(step, n_steps)`` of run(). An exception other than KeyboardInterrupt
    it raises is told to the core first, so that the run it stops says so in
    summary.json (``callback raised ValueError: ...; stopped at t = ... (trace
    kept)``, status 'interrupted'), then goes on to the caller; a KeyboardInterrupt
    stops the run as Ctrl-C does."""
    try:
        callback(step, n_steps)
    except KeyboardInterrupt:
        raise
    except Exception as exc:
        text = " ".join(str(exc).split())
        if len(text) > CALLBACK_TEXT_MAX:
            text = text[:CALLBACK_TEXT_MAX - 3] + "..."
        said = type(exc).__name__ + (f": {text}" if text else "")
        _core().dc_sim_stopped_by(handle, f"callback raised {said}; stopped".encode(
            "utf-8", "surrogateescape"))
        raise


def _raise_for_scene(exc: BadInputError, written: str | None, scene) -> None:
    """Raise ``exc``; where it names the temporary file ``written`` that a Scene was
    written to (the core names the file it read), name the Scene (its file) instead."""
    if written is not None and written in str(exc):
        raise BadInputError(str(exc).replace(written, scene._name())) from None
    raise exc


def _out_said(name: str, given: str) -> bytes:
    """How the core's message names an output folder given as argument ``name`` of
    run() or Stepper() when it cannot be made: ``out='DIR'`` (the command line says
    ``--out DIR`` instead, :func:`dyncontact.cli.main`)."""
    return os.fsencode(f"{name}={given!r}")


def _folder_arg(path, what: str) -> str:
    """A folder argument (str, bytes or path) as text, as the core gets it; an empty one
    is refused (BadInputError naming ``what``), as the command line refuses --out ''."""
    text = os.fsdecode(path)
    if not text.strip():
        raise BadInputError(f"{what}: empty folder name")
    return text


def _same_folder(a: str, b: str) -> bool:
    """Whether two paths name the same folder (a link to it included, as the executable
    compares them); by name where either does not exist."""
    try:
        return os.path.samefile(a, b)
    except OSError:
        return os.path.abspath(a) == os.path.abspath(b)


def _scene_attr_output_dir(scene) -> str | None:
    """&output dir of a Scene object."""
    try:
        d = scene.get("output.dir")
    except Exception:  # noqa: BLE001 - not a Scene: the caller falls back to 'out'
        return None
    return os.fspath(d) if d else None


# --------------------------------------------------------------------------- helpers

#: The bits of the core's ``given``: the .geo parameters a scene gives (gmsh_mesh's
#: GEO_GIVEN_H, GEO_GIVEN_LENGTH, GEO_GIVEN_WIDTH).
_GEO_GIVEN_BITS = {"h": 1, "length": 2, "width": 4}


def _given_bits(given) -> int:
    """The core's bits of ``given``, a collection of .geo parameter names ("h",
    "length", "width"); ValueError naming any other."""
    if isinstance(given, str):
        given = (given,)
    bits = 0
    for name in given:
        if name not in _GEO_GIVEN_BITS:
            raise ValueError(f"given: {name!r} is not a .geo parameter "
                             f"({', '.join(_GEO_GIVEN_BITS)})")
        bits |= _GEO_GIVEN_BITS[name]
    return bits


def load_mesh(path: str | os.PathLike = "", *, dim: int = 2, length: float = 1.0,
              width: float = 0.1, h: float = 0.05, check: bool = True,
              given=("h", "length", "width"), max_elements: int = 0) -> dict[str, Any]:
    """A mesh as the Fortran core reads it: a mesh file (.msh in any version gmsh reads,
    or .geo meshed with the parameters h, length, width), or the built-in bar (path '').
    ``check=False`` skips the core's mesh checks of a file's mesh (reader level: meshes
    the model does not take, such as tetrahedra). ``given``: the names of the .geo's
    parameters the scene gives (default all three), set as the file's; one left out is
    as for a scene that does not give it: a .geo that defines it
    (``DefineConstant[width = {0.2, ...}]``) keeps its own value, one that uses it
    without defining it gets the value passed (the scene's default), and without
    ``"h"`` a .geo that uses no h keeps its own mesh sizes (with ``"h"``, h is its
    largest mesh size). ``max_elements > 0``: a .geo whose element
    count, estimated before meshing (:func:`estimate_geo`), exceeds the refusal's margin
    times it is refused without meshing (:class:`BadInputError` naming
    ``&mesh max_elements``).

    Returns a dict with 0-based indices: ``x`` (n_nodes, dim), ``cells`` (n_cells, dim+1),
    ``cell_group`` (n_cells; -1 = none), ``facets`` (n_facets, dim), ``facet_group``
    (n_facets), ``group_dim`` and ``group_names`` (lists), ``lower_nodes`` and
    ``lower_group`` (the nodes of the groups of a lower dimension, Physical Points and
    Curves of a 3D mesh: once per group, sorted by group then node).
    """
    core = _core()
    p = _fpath(path, "mesh file")
    handle = 0

    def keep(opened: int) -> None:
        nonlocal handle
        handle = opened

    try:
        # the mesh the core read is freed whatever stops load_mesh, a signal as the read
        # returns included (_open_held)
        _, dim_, nn, nc, nf, ng, stat, errmsg = _open_held(
            lambda: core.dc_mesh_sizes(p, int(dim), float(length), float(width), float(h),
                                       int(bool(check)), _given_bits(given),
                                       int(max_elements)),
            keep)
        _check(stat, errmsg, "reading the mesh")
        nl = core.dc_mesh_lower_size(handle)
        lower_nodes, lower_group, stat, errmsg = core.dc_mesh_lower_arrays(handle, nl)
        _check(stat, errmsg, "reading the mesh")
        # dc_mesh_arrays releases the mesh (whatever its stat): the handle is forgotten
        # with signals held, so that a signal as it returns frees nothing twice
        with _SignalsHeld() as held:
            (x, cells, cell_group, facets, facet_group, group_dim, names, stat,
             errmsg) = core.dc_mesh_arrays(handle, dim_, nn, nc, nf, ng)
            handle = 0
    finally:
        core.dc_mesh_free(handle)          # 0 (released or never read) is ignored
    held.deliver()
    _check(stat, errmsg, "reading the mesh")
    group_names = [s for s in _str(names).split(",")] if ng else []
    return {
        "dim": int(dim_),
        "x": np.ascontiguousarray(np.asarray(x).T),
        "cells": np.ascontiguousarray(np.asarray(cells).T) - 1,
        "cell_group": np.asarray(cell_group) - 1,
        "facets": np.ascontiguousarray(np.asarray(facets).T) - 1,
        "facet_group": np.asarray(facet_group) - 1,
        "group_dim": [int(g) for g in group_dim],
        "group_names": group_names,
        "lower_nodes": np.asarray(lower_nodes, dtype=np.int64) - 1,
        "lower_group": np.asarray(lower_group, dtype=np.int64) - 1,
    }


def estimate_geo(path: str | os.PathLike, *, length: float = 1.0, width: float = 0.1,
                 h: float = 0.05,
                 given=("h", "length", "width")) -> dict[str, float] | None:
    """The element count of a .geo estimated before meshing, as :func:`load_mesh` would
    mesh it with these parameters and ``given`` (nothing is meshed; docs/scenes.md, "How
    large a .geo will be"): a dict with ``estimate``, ``measure`` (volume, area or length of the cells'
    entities), ``size`` (the mesh size it assumes) and ``margin`` (a .geo is refused when
    the estimate exceeds margin x the limit), or None where no estimate can be made.
    :class:`BadInputError` if gmsh cannot read the file."""
    est, _, stat, errmsg = _core().dc_geo_estimate(
        _fpath(path, "mesh file"), float(length), float(width), float(h), _given_bits(given),
        0, "", "")
    _check(stat, errmsg, "estimating the mesh")
    if est[0] < 0:
        return None
    return {"estimate": float(est[0]), "measure": float(est[1]), "size": float(est[2]),
            "margin": float(est[3])}


def geo_check(path: str | os.PathLike) -> None:
    """:class:`BadInputError` naming the file and the command if the .geo (or a file it
    includes or merges) holds one of gmsh's commands that end, stall or escape the
    process (docs/scenes.md): the text scan that the core's reader and :func:`estimate_geo`
    make before gmsh parses the file, without starting gmsh."""
    stat, errmsg = _core().dc_geo_check(_fpath(path, "mesh file"))
    _check(stat, errmsg, "checking the .geo")


def geo_refusal(path: str | os.PathLike, limit: int, limit_key: str, h_key: str, *,
                length: float = 1.0, width: float = 0.1, h: float = 0.05,
                given=("h", "length", "width")) -> str | None:
    """The core's one-line refusal of a .geo whose element count, estimated before meshing
    (:func:`estimate_geo`, with ``given`` as there), exceeds the margin times ``limit``,
    naming the file and the keys that change it (``h_key`` "" where h is not given); None
    where it is within the limit
    or no estimate can be made. :class:`BadInputError` if gmsh cannot read the file."""
    _, text, stat, errmsg = _core().dc_geo_estimate(
        _fpath(path, "mesh file"), float(length), float(width), float(h), _given_bits(given),
        int(limit), limit_key, h_key)
    _check(stat, errmsg, "estimating the mesh")
    return _str(text) or None


def unmeshed_text(dim: int, tag: int, group: str) -> str:
    """The core's refusal of a .geo meshed in-process in which gmsh left entity ``dim``
    (1 curve, 2 surface, 3 volume) ``tag`` of physical group ``group`` without elements
    (a surface whose boundary crosses itself), without the path in front: the words the
    core's reader says of such a .geo, for a mesh that Python meshes with gmsh."""
    text = _core().dc_unmeshed_text(int(dim), int(tag),
                                    str(group).encode("utf-8", "surrogateescape"))
    return _str(text)


def pc_stability(alpha: float, beta: float, gamma: float,
                 omega_dt: float = 0.0) -> tuple[float, np.ndarray]:
    """The predictor-corrector family's stability limit Omega_c of omega dt, and its
    amplification matrix on one mode at ``omega_dt`` (on (u, dt v, dt^2 a)), for the
    recurrence's (alpha, beta, gamma) (pc: alpha = 0; pc_hht: beta = (1 - alpha)^2/4,
    gamma = 1/2 - alpha; pc_hht_seed: beta = (1 + alpha)^2/4, gamma = 1/2 + alpha).
    A run's critical step estimate is Omega_c / omega_max.

    >>> round(pc_stability(0.0, 0.25, 0.5)[0] ** 2, 12)
    2.0
    """
    omega_c, amp = _core().dc_pc_stability(float(alpha), float(beta), float(gamma),
                                           float(omega_dt))
    return float(omega_c), np.array(amp)


def p1_element(dim: int, x, young: float, poisson: float, density: float):
    """P1 element matrices of one cell: (stiffness, consistent mass, lumped mass).

    ``x`` is (dim, dim+1) node coordinates (columns = nodes); the matrices are
    (dim*(dim+1))-square with dofs ordered (x1, y1, x2, y2, ...).
    """
    x = np.asarray(x, dtype=np.float64)
    if x.shape != (dim, dim + 1):
        raise ValueError(f"x must have shape ({dim}, {dim + 1}), got {x.shape}")
    xf = np.zeros((3, 4), dtype=np.float64, order="F")
    xf[:dim, :dim + 1] = x
    ke, me, ml = _core().dc_p1_element(int(dim), xf, float(young), float(poisson),
                                       float(density))
    n = dim * (dim + 1)
    return ke[:n, :n].copy(), me[:n, :n].copy(), ml[:n, :n].copy()


def _coo(rows, cols, vals, b):
    """0-based COO triplets and a right-hand side as the core takes them (1-based)."""
    rows = _i32(np.asarray(rows) + 1)
    cols = _i32(np.asarray(cols) + 1)
    vals = _f64(vals)
    b = _f64(b)
    if not (rows.shape == cols.shape == vals.shape) or rows.ndim != 1:
        raise ValueError("rows, cols and vals must be 1-D arrays of the same length")
    return rows, cols, vals, b


def umf_solve(rows, cols, vals, b) -> np.ndarray:
    """Solve A x = b with UMFPACK; A as 0-based COO triplets (duplicates summed)."""
    rows, cols, vals, b = _coo(rows, cols, vals, b)
    x, stat, errmsg = _core().dc_umf_solve(rows, cols, vals, b, b.shape[0], rows.shape[0])
    _check(stat, errmsg, "umfpack solve")
    return x


def linear_solve(rows, cols, vals, b) -> tuple[np.ndarray, str]:
    """Solve A x = b with the core's solver choice (CHOLMOD LDLᵀ when A is symmetric
    positive definite, UMFPACK LU otherwise); A as 0-based COO triplets (duplicates
    summed). Returns (x, backend) with backend 'cholmod_ldlt' or 'umfpack_lu'."""
    rows, cols, vals, b = _coo(rows, cols, vals, b)
    x, backend, stat, errmsg = _core().dc_ls_solve(rows, cols, vals, b, b.shape[0],
                                                   rows.shape[0])
    _check(stat, errmsg, "linear solve")
    if isinstance(backend, bytes):
        backend = backend.decode("ascii", "replace")
    return x, str(backend).strip().strip("\x00").strip()


class Model:
    """The discrete model of a scene (no outputs written), for tests and scripts.

    Use as a context manager so that the Fortran object is always freed::

        with Model("scene.nml") as m:
            b, active = m.eval_b(np.zeros(m.dofs))

    Attributes: ``dofs`` (free dofs), ``elements``, ``contact_facets`` and ``n_steps``
    (steps to t_end). A model alone starts no scheme, so ``n_steps`` is 0 where the scheme
    chooses the step (``central`` with ``dt = 0``); a :class:`Stepper` has the count.
    ``scene``: the scene file, or a :class:`dyncontact.Scene`'s name (its file, or
    ``<scene>``).
    """

    def __init__(self, scene, _out: str | os.PathLike | None = None):
        # _out: the output folder of a run (Stepper); None builds the model only
        self.handle = 0
        _need_scene(scene, f"{type(self).__name__}()")
        self.scene = os.fsdecode(scene) if _is_path(scene) else scene._name()
        self._tmp = tempfile.mkdtemp(prefix="dyncontact-")
        try:
            path, written = _scene_file(scene, self._tmp)
            out, said = b"", b""
            if _out is not None:   # as given, as the executable records it in summary.json
                given = _folder_arg(_out, "out")
                out, said = _fpath(given, "output folder"), _out_said("out", given)
            scene_path = _fpath(path, "scene file")
            (_handle, self.n_steps, self.dofs, self.elements, self.contact_facets, stat,
             errmsg) = _open_held(
                lambda: _core().dc_sim_open(scene_path, out, 1 if _out is None else 0, said),
                self._keep)
            try:
                _check(stat, errmsg,
                       "building the model" if _out is None else "opening the run")
            except BadInputError as exc:
                _raise_for_scene(exc, written, scene)
        except BaseException:
            # a model opened before a signal held over its open (_open_held) is freed; a
            # Stepper's run is closed as interrupted, its lock released
            try:
                self.close()
            finally:
                shutil.rmtree(self._tmp, ignore_errors=True)
            raise

    def _keep(self, handle: int) -> None:
        self.handle = handle

    def _need(self):
        if not self.handle:
            raise DyncontactError("the model is closed")

    def eval_b(self, u) -> tuple[np.ndarray, int]:
        """(B(u), active contact quadrature points) on the free dofs."""
        self._need()
        b, active = _core().dc_sim_eval_b(self.handle, _f64(u, (self.dofs,)), self.dofs)
        return b, int(active)

    def contact_clear(self, u) -> bool:
        """Whether no contact point can be active at u: P finite and >= 0 at the nodes of
        every contact facet (what an implicit step carries as the state's ``clear``)."""
        self._need()
        return bool(_core().dc_sim_contact_clear(self.handle, _f64(u, (self.dofs,)), self.dofs))

    def jacobian_apply(self, u, du) -> np.ndarray:
        """B'(u) du (generalized derivative) on the free dofs."""
        self._need()
        return _core().dc_sim_jacobian_apply(self.handle, _f64(u, (self.dofs,)),
                                             _f64(du, (self.dofs,)), self.dofs)

    def static(self) -> np.ndarray:
        """Solution of K u = L (contact ignored) on the free dofs."""
        self._need()
        u, stat, errmsg = _core().dc_sim_static(self.handle, self.dofs)
        _check(stat, errmsg, "static solve")
        return u

    def dof_map(self) -> tuple[np.ndarray, np.ndarray]:
        """(node, component) of each free dof, both 0-based."""
        self._need()
        node, comp = _core().dc_sim_dof_map(self.handle, self.dofs)
        return np.asarray(node) - 1, np.asarray(comp) - 1

    def close(self) -> None:
        if self.handle:
            handle, self.handle = self.handle, 0
            stat, errmsg = _core().dc_sim_close(handle)
            shutil.rmtree(self._tmp, ignore_errors=True)
            _check(stat, errmsg, "closing the model")

    def __enter__(self) -> "Model":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __del__(self):  # last resort; prefer close() / with
        try:
            self.close()
        except Exception:  # noqa: BLE001
            pass


class Stepper(Model):
    """A run advanced step by step, whose state can be read between steps (tests,
    invariant checks, scripts that need the fields). Outputs go to ``out`` as for
    :func:`run`, and the run's warnings and notes are :class:`DyncontactWarning` warnings
    as there; use it as a context manager so that summary.json is written::

        with Stepper(scene, out) as s:
            s.advance(10)
            st = s.state()          # u, v, a, mv, load, bu on the free dofs; t, f_n, clear
            M = s.matrix("M")       # the assembled matrix, dense
            s.save("state.bin")     # a checkpoint; s.load("state.bin") goes back to it

    Beyond :class:`Model`'s attributes: ``out`` (the output folder as given), ``step``
    (the steps done so far, or the step loaded), ``t`` (the time reached, the core's
    own: ``state()['t']`` without copying the state; kept when closed) and ``finished``
    (the run reached its end). Its repr says where it is::

        <Stepper scene='bar.nml' t=0.01 step=10 out='out/bar' open>
    """

    _WHICH = {"M": 1, "K": 2, "K_theta": 3}

    def __init__(self, scene, out: str | os.PathLike):
        if not isinstance(out, (str, bytes, os.PathLike)):
            raise TypeError("Stepper(): out must be the output folder (a path), not "
                            f"{type(out).__name__}")
        self.out = os.fsdecode(out)
        self.step = 0
        self.t = 0.0
        self.finished = False
        super().__init__(scene, _out=out)
        # the warnings and notes a run gives before it starts (docs/scenes.md); warnings
        # turned into errors leave no run open
        try:
            self._at()
            _warn_notes(self.handle)
        except BaseException:
            self.close()
            raise

    def _at(self) -> None:
        """Keep ``t`` as the core has it (not step x dt: a loaded state's t, or the central
        scheme's automatic step, would differ)."""
        self.t = float(_core().dc_sim_time(self.handle))

    def advance(self, steps: int = 1) -> int:
        """Advance by at most ``steps`` steps (an int >= 0: a Python or numpy integer, or a
        0-d integer array); returns the steps done. A numerical failure (unstable,
        Newton) raises :class:`NumericalError`, with the snapshot of the state it stopped
        at written as the executable writes it (docs/scenes.md, *Outputs*); a closed
        Stepper, :class:`DyncontactError`."""
        if isinstance(steps, (bool, np.bool_)):
            raise TypeError(f"advance(): steps must be an int, not {type(steps).__name__}")
        try:                  # an int, a numpy integer or a 0-d integer array
            steps = operator.index(steps)
        except TypeError:
            raise TypeError(f"advance(): steps must be an int, not {type(steps).__name__}"
                            ) from None
        if steps < 0:
            raise ValueError(f"advance(): steps must be >= 0 (got {steps})")
        self._need()
        # the core takes a C int: a larger budget advances to the end as well, since no run
        # has more steps (&scheme max_steps is a C int too)
        budget = min(steps, C_INT_MAX)
        done, step, finished, stat, errmsg = _core().dc_sim_advance(self.handle, budget)
        self.step = int(step)
        self._at()
        self.finished = bool(finished)
        if stat == STAT_NUMERIC:
            raise NumericalError(_str(errmsg))
        _check(stat, errmsg, "advancing the run")
        return int(done)

    def floors(self, n_rep: int = 1000, batches: int = 10) -> dict[str, float | None] | None:
        """The cost floors of :func:`bench_floors`, measured now on this run's matrices and
        factors (between steps: a benchmark compares each stretch of steps with floors
        measured next to it). The run's state is not touched. None when the extension
        has no timing helper."""
        self._need()
        if not bench_floors_available():
            return None
        return _handle_floors(self.handle, n_rep, batches)

    def save(self, path: str | os.PathLike) -> None:
        """Save the run's state and counters to the checkpoint file ``path`` (the format
        of ``&output checkpoint_every``; written atomically)."""
        self._need()
        stat, errmsg = _core().dc_sim_save(self.handle, _fpath(path, "checkpoint file"))
        _check(stat, errmsg, "saving the state")

    def load(self, path: str | os.PathLike) -> int:
        """Load a state saved by :meth:`save` (or a run's checkpoint.bin) of the same scene
        and build; the next :meth:`advance` continues from it, bit for bit as the run that
        saved it. Returns the step loaded. A missing, foreign, truncated or corrupt file
        raises :class:`BadInputError` naming it (the Stepper is then finished: it advances
        no further). The snapshots of steps after the state's are removed, and fields.pvd
        is rewritten to list the state's snapshots that are still in the folder; a
        :class:`DyncontactWarning` names a missing one."""
        self._need()
        before = len(_notes(_core().dc_sim_info(self.handle)[2]))
        step, stat, errmsg = _core().dc_sim_load(self.handle, _fpath(path, "checkpoint file"))
        self._at()
        if int(stat) != STAT_OK:
            self.finished = True
        _check(stat, errmsg, "loading the state")
        self.finished = False
        self.step = int(step)
        # the notes the load added (a snapshot it lists that is no longer there)
        for note in _notes(_core().dc_sim_info(self.handle)[2])[before:]:
            warnings.warn(note, DyncontactWarning, stacklevel=2)
        return int(step)

    def __repr__(self) -> str:
        said = "open" if self.handle else "closed"
        if self.finished:
            said += ", finished"
        return (f"<Stepper scene={self.scene!r} t={self.t!r} step={self.step} "
                f"out={self.out!r} {said}>")

    def state(self) -> dict[str, Any]:
        """The run's state now (after the last :meth:`advance` or :meth:`load`; before
        them, the initial state), as a dict of new arrays. The vectors are float64 arrays
        on the free dofs (length ``dofs``; :meth:`dof_map` gives the node and component of
        each):

        - ``t`` (float): the time reached;
        - ``u``: the displacement;
        - ``v``: the velocity;
        - ``a``: the acceleration (zeros for the theta scheme, which carries none);
        - ``mv``: the product M v of the mass matrix and the velocity, from which the
          trace's e_kin = ½ v·M v is computed;
        - ``load``: the load vector L = ∫ ρ g·v of ``&material gravity`` (zeros without
          gravity), whose potential is the trace's e_load = −u·L;
        - ``bu``: B(u), the internal force, elastic and contact (M u'' + B(u) = L,
          docs/numerics.md), as the scheme carries it into the next step
          (:meth:`eval_b` evaluates it anew at any u);
        - ``clear`` (bool): the last step found no contact point possible at u
          (:meth:`contact_clear`), so the trace's p_n skips the probe's facets at a node;
          False: not known;
        - ``f_n`` (float): the total normal contact force at u, the trace's f_n
          (docs/scenes.md).
        """
        self._need()
        t, u, v, a, mv, load, bu, clear, f_n = _core().dc_sim_state(self.handle, self.dofs)
        return {"t": float(t), "u": u, "v": v, "a": a, "mv": mv, "load": load, "bu": bu,
                "clear": bool(clear), "f_n": float(f_n)}

    def matrix(self, which: str) -> np.ndarray:
        """The assembled 'M', 'K' or 'K_theta' on the free dofs, as a dense array."""
        if which not in self._WHICH:
            raise ValueError(f"matrix(): which must be one of {', '.join(self._WHICH)} "
                             f"(got {which!r})")
        self._need()
        nnz = int(_core().dc_sim_matrix_nnz(self.handle))
        colptr, rowind, val, stat, errmsg = _core().dc_sim_matrix(
            self.handle, self._WHICH[which], self.dofs, nnz)
        _check(stat, errmsg, "reading a matrix")
        dense = np.zeros((self.dofs, self.dofs))
        for j in range(self.dofs):
            rows = rowind[colptr[j]:colptr[j + 1]]
            dense[rows, j] += val[colptr[j]:colptr[j + 1]]
        return dense


__all__ += ["Stepper"]


# --------------------------------------------------------------------------- timing

#: The core's timing helper of the benchmark floors (optional in the extension).
_FLOOR_API = "dc_bench_floor"


def bench_floors_available() -> bool:
    """Whether the extension has the timing helper of :func:`bench_floors`."""
    try:
        return hasattr(_core(), _FLOOR_API)
    except DyncontactError:
        return False


def bench_floors(scene, n_rep: int = 1000, batches: int = 1) -> dict[str, float | None] | None:
    """Cost floors of one step of a scene's scheme, in µs: one triangular solve with the
    cached iteration-matrix factors (``solve_us``, implicit schemes), one SpMV with K_θ
    (``spmv_us``) and one M^{-1} application (``mass_solve_us``, explicit schemes), and
    for comparison the iteration matrix's solve through cholmod_solve2 on the same factor
    (``cholmod_solve_us``); None for a floor that does not apply. Each is the best of
    ``batches`` batches of the mean over n_rep // batches calls (the best batch: a floor).
    Returns None when the extension has no timing helper. (Between the steps of a run:
    :meth:`Stepper.floors`.)
    """
    if not bench_floors_available():
        return None
    core = _core()
    tmp = tempfile.mkdtemp(prefix="dyncontact-bench-")
    try:
        path, written = _scene_file(scene, tmp)
        scene_path = _fpath(path, "scene file")
        out_path = _fpath(os.path.join(tmp, "out"), "output folder")
        kept: list[int] = []
        try:
            _h, *_, stat, errmsg = _open_held(
                lambda: core.dc_sim_open(scene_path, out_path, 0, b""), kept.append)
            try:
                _check(stat, errmsg, "opening the run")
            except BadInputError as exc:
                _raise_for_scene(exc, written, scene)
            return _handle_floors(kept[0], n_rep, batches)
        finally:
            for handle in kept:
                core.dc_sim_close(handle)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _handle_floors(handle, n_rep: int, batches: int) -> dict[str, float | None]:
    """The floors of :func:`bench_floors` on an open run (its state is not touched: the
    helper solves and multiplies vectors of its own)."""
    core = _core()
    best = [np.inf, np.inf, np.inf, np.inf]
    for _ in range(max(1, int(batches))):
        got = getattr(core, _FLOOR_API)(handle, max(1, int(n_rep) // max(1, int(batches))))
        best = [min(b, float(x)) for b, x in zip(best, got[:4])]
    t_solve, t_spmv, t_mass, t_cholmod = best

    def pos(x: float) -> float | None:
        return x if x > 0 and np.isfinite(x) else None

    return {"solve_us": pos(t_solve), "spmv_us": pos(t_spmv), "mass_solve_us": pos(t_mass),
            "cholmod_solve_us": pos(t_cholmod)}
