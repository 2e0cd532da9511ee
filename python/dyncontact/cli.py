"""Command line: ``python -m dyncontact {run,plot,mesh,study} ...``.

Exit status: 0 ok, 2 bad input (one line ``dyncontact: MESSAGE`` on stderr, no
traceback), 3 numerical failure (unstable / newton_failed; the trace is kept),
4 write failure, out of memory or internal error, 130 interrupted (Ctrl-C or SIGTERM).
"""

from __future__ import annotations

import argparse
import errno
import os
import shlex
import signal
import sys
import threading
import time
import warnings
from pathlib import Path
from typing import Sequence

from . import core

PROG = "dyncontact"
#: The command as a user types it, in usage lines and in "see ... --help": the program
#: `dyncontact` on a PATH (pip install, build/) is the executable, which runs a scene
#: file and has no subcommands.
COMMAND = "python -m dyncontact"
#: Part of the core's message when another live run holds the output folder's lock.
LOCK_HELD = "is writing into this output folder"
#: Seconds between two attempts of `run --wait`.
WAIT_POLL_S = 0.5
EXIT_OK, EXIT_BAD_INPUT, EXIT_NUMERIC, EXIT_INTERNAL, EXIT_INTERRUPTED = 0, 2, 3, 4, 130
#: errno values of a write that failed for want of room or of a writable file system.
WRITE_ERRNOS = frozenset({errno.ENOSPC, errno.EFBIG, errno.EDQUOT, errno.EROFS})


class UsageError(Exception):
    """A bad command line (exit 2)."""


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors: 'dyncontact: MESSAGE (see --help)', exit 2."""

    def error(self, message):  # noqa: D102 - argparse API
        raise UsageError(f"{message} (see `{self.prog} --help`)")


def _fail(message: str, code: int) -> int:
    first = " ".join(str(message).split())   # always exactly one line
    print(f"{PROG}: {first}", file=sys.stderr, flush=True)
    return code


def parse_set(item: str) -> tuple[str, str, str]:
    """'group.key=value' -> ('group', 'key', 'value').

    Only the syntax is checked here; the value stays a string that
    :meth:`dyncontact.Scene.set` converts to the key's type (numbers, 'quoted' or bare
    strings, comma-separated vectors) and checks, naming the key when it is wrong.
    """
    if "=" not in item:
        raise UsageError(f"--set {item!r}: expected group.key=value, one word (e.g. "
                         "--set scheme.dt=0.001)")
    lhs, raw = item.split("=", 1)
    lhs = lhs.strip()
    if lhs.count(".") != 1:
        raise UsageError(f"--set {item!r}: expected group.key=value (e.g. scheme.dt=0.001)")
    group, key = (s.strip().lower() for s in lhs.split("."))
    if not (group.isidentifier() and key.isidentifier()):
        raise UsageError(f"--set {item!r}: group and key must be names")
    raw = raw.strip()
    if raw == "":
        raise UsageError(f"--set {item!r}: empty value (write '' for an empty string)")
    return group, key, raw


def _said_of_set(message: str, scene_path, group: str, key: str, value: str) -> str:
    """The core's refusal of a value that ``--set group.key=value`` gave, said of the item:
    the core names the scene file (``s.nml: &scheme dt: must be > 0 ...``), which holds
    another value or none, so the line begins with the item instead (``--set
    scheme.dt=-1: &scheme dt: must be > 0 ...``)."""
    prefix = f"{scene_path}: "
    rest = message[len(prefix):] if message.startswith(prefix) else message
    return f"--set {group}.{key}={value}: {rest}"


def _blame_set(message: str, scene_path, sets) -> str | None:
    """The run's refusal (it checks ranges, and keys against each other, on the whole
    scene) said of the ``--set`` item that gave the key it names (:func:`_said_of_set`);
    ``None`` when the message is not about a key set on the command line."""
    prefix = f"{scene_path}: "
    if not sets or not message.startswith(prefix):
        return None
    rest = message[len(prefix):]
    for group, key, value in reversed(sets):      # the last item of a key is the one used
        if rest.startswith(f"&{group} {key}:") or rest.startswith(f"&{group} {key} "):
            return _said_of_set(message, scene_path, group, key, value)
    return None


# --------------------------------------------------------------------------- commands

def _sigterm_as_interrupt(signum, frame):  # noqa: ARG001 - signal handler signature
    """SIGTERM stops a run like Ctrl-C: at the end of the current chunk of steps, with
    summary.json saying 'interrupted' (exit 130), as the executable does."""
    raise KeyboardInterrupt(f"signal {signum}")


_sigterm_as_interrupt.raises_keyboard_interrupt = True   # a run's set-up reads it (core)


def _catch_sigterm() -> None:
    """Make SIGTERM stop the command as Ctrl-C does (:func:`_sigterm_as_interrupt`), in
    the main thread (Python sets handlers there only), unless the process ignores
    SIGTERM: a signal ignored from the program's start stays ignored, as the executable
    leaves it (run_guard.c) and as Python leaves an ignored SIGINT (no
    KeyboardInterrupt)."""
    if threading.current_thread() is not threading.main_thread():
        return
    if signal.getsignal(signal.SIGTERM) is signal.SIG_IGN:
        return
    signal.signal(signal.SIGTERM, _sigterm_as_interrupt)


def _said_of_option(exc: Exception, out: str | None, restart: str | None = None) -> Exception:
    """``exc``, a run's error, with the folders that run() names as its arguments said as
    this command's options, as the executable and ``study`` say them: the output folder
    (``out='DIR': cannot create the folder (...)`` becomes ``--out DIR: ...``), and the
    refusal of an output folder other than the restart folder (``restart='B' continues
    the run in that folder: out must be the same folder or None`` becomes ``--restart B
    continues the run in that folder: --out must be the same folder or left out``)."""
    text = str(exc)
    prefix = f"out={out!r}: "
    if out is not None and text.startswith(prefix):
        return type(exc)(f"--out {out}: {text[len(prefix):]}")
    if restart is not None and text == (f"restart={restart!r} continues the run in that "
                                        "folder: out must be the same folder or None"):
        return type(exc)(f"--restart {restart} continues the run in that folder: "
                         "--out must be the same folder or left out")
    return exc


def cmd_run(args) -> int:
    for option, folder in (("--out", args.out), ("--restart", args.restart)):
        if folder == "":     # `--out=` or `--out ''`: the option named, as the executable
            raise UsageError(f"{option}: empty folder name")
    sets = [parse_set(s) for s in (args.set or [])]
    scene_path = args.scene
    if sets:
        from .scene import Scene

        scene = Scene.read(scene_path)
        for group, key, value in sets:
            try:
                scene.set(f"{group}.{key}", value)   # the core converts and checks the value
            except core.BadInputError as exc:
                raise core.BadInputError(_said_of_set(str(exc), scene_path, group, key,
                                                      value)) from None
    else:
        scene = scene_path
    progress = False if args.quiet else None
    waited = False
    if getattr(args, "program", False):
        # as the executable: Ctrl-C or SIGTERM while gmsh reads or meshes the mesh file
        # ends the program at once (exit 130, one line naming the file) instead of after
        # the meshing; nothing is left behind: the core makes the output folder and takes
        # its lock after the read, and the temporary file that run() writes a Scene to
        # (--set) is removed by the exit (core.removed_if_stopped)
        core.exit_on_signal_during_mesh_read()
    _catch_sigterm()
    with warnings.catch_warnings():
        warnings.simplefilter("always", core.DyncontactWarning)
        previous = warnings.showwarning

        def show(message, category, *rest, **kw):
            if issubclass(category, core.DyncontactWarning):
                print(f"{PROG}: {' '.join(str(message).split())}", file=sys.stderr, flush=True)
            else:  # pragma: no cover - other libraries' warnings
                previous(message, category, *rest, **kw)

        warnings.showwarning = show
        while True:
            try:
                result = core.run(scene, out=args.out, progress=progress, restart=args.restart,
                                  opened=None if args.quiet else _print_opened)
                break
            except core.BadInputError as exc:
                if not (args.wait and LOCK_HELD in str(exc)):
                    blamed = _blame_set(str(exc), scene_path, sets)
                    if blamed is None:
                        raise _said_of_option(exc, args.out, args.restart) from None
                    raise core.BadInputError(blamed) from None
                if not waited:
                    print(f"{PROG}: {' '.join(str(exc).split())}; waiting (--wait)",
                          file=sys.stderr, flush=True)
                waited = True
                time.sleep(WAIT_POLL_S)
            except core.DyncontactError as exc:     # an --out on a full or read-only disk
                raise _said_of_option(exc, args.out, args.restart) from None
    s = result.summary
    if result.status != "ok":
        # the core's message, as the executable prints it (it gives t and what to check)
        msg = result.message
        if not msg:
            t_stop = result.trace["t"][-1] if result.trace.get("t") is not None and \
                len(result.trace["t"]) else float("nan")
            msg = f"{result.status} at t = {t_stop:.6g} (trace kept)"
        return _fail(msg, EXIT_NUMERIC)
    if not args.quiet:
        # the output folder as given, as the executable prints it (summary.json records it)
        folder = ((s.get("scene") or {}).get("output") or {}).get("dir") or result.out_dir
        wall = s.get("wall_s")
        wall_txt = f", {float(wall):.2f} s" if isinstance(wall, (int, float)) else ""
        _say(f"{PROG}: ok, {_counted(s.get('steps'), 'step')} to "
             f"t={_full_exponent(s.get('t_end_reached'))}{wall_txt} -> {folder}")
    return EXIT_OK


def _print_opened(lines: list[str]) -> None:
    """The lines the executable prints once the run is open, before its steps (restart,
    then the run's sizes, scheme and output folder), flushed so that a job's log has them
    even when the run is stopped by a signal or fails."""
    for line in lines:
        _say(f"{PROG}: {line}")


def _say(line: str) -> None:
    """Print one line on stdout, flushed. A stdout whose reader has gone (``| head -1``)
    does not stop the run: the line and the ones after it are dropped (stdout is pointed
    at /dev/null, so that Python's flush at exit does not complain either), and the exit
    status stays the run's, as the executable's."""
    try:
        print(line, flush=True)
    except BrokenPipeError:
        _drop_stdout()


def _drop_stdout() -> None:
    """Point stdout at /dev/null (its reader closed the pipe): later prints and the
    interpreter's last flush then go nowhere, without a traceback."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, sys.stdout.fileno())
    finally:
        os.close(devnull)


def cmd_plot(args) -> int:
    from .plotting import plot_traces, scene_title

    labels = args.labels.split(",") if args.labels is not None else None
    for i, label in enumerate(labels or [], 1):
        # `--labels ""` and `a,,b` would draw the default or a blank legend entry
        if not label.strip():
            raise UsageError(f"--labels: label {i} of {len(labels)} is empty; give one "
                             "per folder, comma-separated")
    if labels is not None and len(labels) != len(args.dirs):
        raise UsageError(f"--labels: {_counted(len(labels), 'label')} for "
                         f"{_counted(len(args.dirs), 'folder')}; give one per folder, "
                         "comma-separated")
    for d in args.dirs:
        # the readers' own check, so that a folder is refused in the API's words
        # ('no such run folder', 'not a folder ...', 'no trace.csv'), before any drawing
        core.run_file(d, "trace.csv", "")
    out = _png_path(args.out)
    title = args.title
    if title is None:   # the scene the runs share, from their summary.json
        title = scene_title([core.read_summary(d) for d in args.dirs])
    plot_traces(args.dirs, out, labels=labels, title=title or None)
    if not args.quiet:
        print(f"{PROG}: wrote {out}")
    return EXIT_OK


#: The image formats `plot --out` writes (matplotlib's back-ends for them are always there).
PLOT_FORMATS = (".png", ".pdf", ".svg")


def _png_path(out: str) -> str:
    """The file `plot --out OUT` really writes (docs/scenes.md): OUT/traces.png when OUT
    is an existing folder or ends with a slash (a folder, created if needed); OUT itself
    when it ends with one of :data:`PLOT_FORMATS` (any case); OUT.png otherwise, so that a
    dotted name (`cmp_dt0.001`) keeps its dots. A suffix of letters only that is not a
    format (`x.xyz`, `x.jpg`) is taken for a mistyped format and refused (UsageError)."""
    if not out:
        raise UsageError("--out: empty file name")
    if out.endswith(("/", os.sep)) or os.path.isdir(out):
        return os.path.join(out, "traces.png")
    ext = os.path.splitext(out)[1]
    if ext.lower() in PLOT_FORMATS:
        return out
    if ext[1:].isalpha() and ext[1:].isascii():
        raise UsageError(f"--out {out}: unsupported format {ext!r} (use "
                         f"{', '.join(PLOT_FORMATS)}, or no extension for .png)")
    return out + ".png"


def cmd_study(argv: Sequence[str]) -> int:
    from .study import cli as study_cli

    return int(study_cli.main(list(argv)) or 0)


def cmd_mesh(argv: Sequence[str], program: bool = False) -> int:
    from . import mesh_io

    if program:
        # as `run`: Ctrl-C or SIGTERM while gmsh meshes, writes or reads back the mesh
        # ends the program at once (exit 130, one line naming the .geo), the mesh file
        # written so far removed (mesh_io.generate writes it under a temporary name that
        # the exit removes, and gives it its name once gmsh wrote it whole)
        core.exit_on_signal_during_mesh_read()
    rc = mesh_io.main(list(argv))
    return int(rc or 0)


class _Once(argparse.Action):
    """An option that may be given once: a second one is a usage error naming both values
    (the executable refuses it too), not a silent choice of the last."""

    def __call__(self, parser, namespace, values, option_string=None):
        given = getattr(namespace, self.dest, None)
        if given is not None:
            parser.error(f"{option_string} given twice ({given}, {values})")
        setattr(namespace, self.dest, values)


def run_help_text() -> str:
    """What a scene file is, where its documentation is (by title: an installed package
    has no docs/) and the exit statuses: run_help.txt beside this module, which the
    executable's --help prints too (meson.build makes it part of the program), so that
    both say the same lines."""
    return (Path(__file__).resolve().parent / "run_help.txt").read_text(encoding="utf-8")


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog=COMMAND, description="Elastic bodies hitting a rigid obstacle "
                "(Nitsche contact, P1 elements, implicit and explicit time schemes).")
    p.add_argument("--version", action="version",
                   version=f"{PROG} {_version()}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)

    r = sub.add_parser("run", help="run a scene file", description="Run a scene file; "
                       "writes trace.csv and summary.json into the output folder\n"
                       "(&output dir, or --out DIR).", epilog=run_help_text(),
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    r.add_argument("scene", metavar="SCENE.nml")
    r.add_argument("--set", action="append", metavar="GROUP.KEY=VALUE",
                   help="override one scene key, e.g. --set scheme.dt=0.001 (repeatable)")
    r.add_argument("--restart", action=_Once, metavar="DIR", help="continue the stopped run whose output "
                   "folder DIR holds a checkpoint (&output checkpoint_every); the run continues "
                   "in DIR (a later &scheme t_end or a raised blowup extends it)")
    r.add_argument("--out", action=_Once, metavar="DIR", help="output folder (default: the scene's "
                   "&output dir)")
    r.add_argument("--quiet", "-q", action="store_true", help="no progress bar, no summary")
    r.add_argument("--wait", action="store_true", help="when another run holds the output "
                   "folder's lock, wait for it to end instead of stopping (exit 2)")
    r.set_defaults(func=cmd_run)

    pl = sub.add_parser("plot", help="overlay the traces of runs in one image (.png, .pdf "
                        "or .svg)",
                        description="Draw u_n, v_n, p_n and the energy of one or more "
                        "runs (folders holding trace.csv and summary.json).")
    pl.add_argument("dirs", nargs="+", metavar="DIR")
    pl.add_argument("--out", required=True, action=_Once, metavar="FILE.png",
                    help="image to write: FILE.png, .pdf or .svg; a name without one of "
                    "these extensions gets .png added (cmp_dt0.001 -> cmp_dt0.001.png); "
                    "an existing folder or a name ending with '/': FOLDER/traces.png")
    pl.add_argument("--title", metavar="T", help="figure title (default: the scene the "
                    "runs share, from their summary.json: the mesh file's name or the "
                    "built-in bar, h, material, initial state, contact method, and the "
                    "scheme and dt when they share them; --title '' for none)")
    pl.add_argument("--labels", metavar="L1,L2,...", help="legend labels (default: scheme "
                    "and parameters from summary.json)")
    pl.add_argument("--quiet", "-q", action="store_true")
    pl.set_defaults(func=cmd_plot)

    sub.add_parser("mesh", help="mesh a .geo with gmsh into a .msh file (see "
                   f"`{COMMAND} mesh --help`)", add_help=False)
    sub.add_parser("study", help="convergence, work-precision, stability, contact methods and "
                   f"Hertz's impact studies (see `{COMMAND} study --help`)", add_help=False)
    return p


def _version() -> str:
    from . import __version__

    return __version__


def _full_exponent(x) -> str:
    """x as the executable writes numbers in messages: 1.00000E-002 (docs/scenes.md)."""
    if not isinstance(x, (int, float)):
        return "?"
    mant, exp = f"{float(x):.5E}".split("E")
    return f"{mant}E{int(exp):+04d}"


def _counted(n, noun: str) -> str:
    """'n noun' with the noun in the plural unless n = 1 (as the executable's lines)."""
    if n is None:
        return f"? {noun}s"
    return f"{n} {noun}" if n == 1 else f"{n} {noun}s"


#: The subcommands, which an argument of the same name is taken for.
COMMANDS = ("run", "plot", "mesh", "study")


def _scene_for_command(first: str) -> bool:
    """Whether the first argument, given where the command goes, is a scene file: an
    existing file, or a name ending in .nml (the command `run` forgotten)."""
    if first in COMMANDS or first.startswith("-"):
        return False
    return first.lower().endswith(".nml") or os.path.isfile(first)


def main(argv: Sequence[str] | None = None, *, program: bool = False) -> int:
    """Entry point; returns the exit status. ``program``: the process is this command
    (``python -m dyncontact``), which may then end itself on a signal while gmsh reads a
    run's mesh file, as the executable does (:func:`dyncontact.core.
    exit_on_signal_during_mesh_read`); False (a caller that runs the command inside its
    own process) keeps Python's handling of the signals."""
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        if argv and argv[0] == "mesh":
            return cmd_mesh(argv[1:], program)
        if argv and argv[0] == "study":
            return cmd_study(argv[1:])
        if argv and _scene_for_command(argv[0]):
            # `python -m dyncontact scene.nml`: argparse would say "invalid choice"
            raise UsageError(f"{argv[0]} is not a command; to run a scene file: "
                             f"`python -m dyncontact {shlex.join(['run', *argv])}`")
        parser = build_parser()
        args, extras = parser.parse_known_args(argv)
        if extras:
            # `--set scheme.dt 0.001` leaves the value over: the item is said as wrong
            for item in getattr(args, "set", None) or ():
                parse_set(item)
            # the subcommand's parser leaves them to this one, whose error would point
            # to the top-level help, which does not list the subcommand's options
            command = f"{COMMAND} {args.command}" if args.command else COMMAND
            raise UsageError(f"unrecognized arguments: {' '.join(extras)} "
                             f"(see `{command} --help`)")
        if not getattr(args, "func", None):
            parser.print_help(sys.stderr)
            return EXIT_BAD_INPUT
        args.program = program
        return args.func(args)
    except KeyboardInterrupt as exc:
        # a run's own line (t, what was kept), as the executable prints it
        said = " ".join(str(exc).split())
        return _fail(said if said.startswith("interrupted") else "interrupted",
                     EXIT_INTERRUPTED)
    except (core.BadInputError, UsageError) as exc:
        return _fail(str(exc), EXIT_BAD_INPUT)
    except core.NumericalError as exc:
        return _fail(str(exc), EXIT_NUMERIC)
    except core.DyncontactError as exc:
        return _fail(str(exc), EXIT_INTERNAL)
    except BrokenPipeError:  # e.g. `plot` or `--help` piped into head: its work is done
        _drop_stdout()
        return EXIT_OK
    except OSError as exc:
        name = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
        # a file that cannot be written for want of room (full disk, quota, file-size
        # limit) or a read-only file system is exit 4 as in a run (docs/scenes.md, *Exit
        # codes*); an unreadable or missing input stays bad input
        code = EXIT_INTERNAL if exc.errno in WRITE_ERRNOS else EXIT_BAD_INPUT
        return _fail(f"{name}{exc.strerror or exc}", code)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
