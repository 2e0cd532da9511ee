"""``python -m dyncontact study {convergence,work-precision,stability,methods,hertz,all} ...``.

Exit status: 0 when every run could be done (unstable runs are results, not failures),
1 when some runs failed to run (each is reported, the study still completes), 2 bad
command line, 4 an output file that cannot be written (full disk, file-size limit: one
line naming it), 130 interrupted (Ctrl-C or SIGTERM: the pool's workers are stopped, the
finished runs stay cached and the same command resumes).
"""

from __future__ import annotations

import argparse
import datetime
import os
import sys
import time
from typing import Any, Sequence

from .common import (OneLineParser, UserSceneError, add_runner_options, positive,
                     scheduler_timeout, scheduler_unreachable_line, scheme_list)
from .sweep import SchedulerUnreachable, sigterm_as_interrupt

__all__ = ["main", "write_index"]

STUDIES = ("convergence", "work-precision", "stability")
#: --scene of the studies that take it: a scene file of one's own instead of the seed's.
SCENE_HELP = {
    "work-precision": "a scene file of one's own: each scheme on it as given (mesh, "
                      "material, contact, probe, T) at Δt = 2, 1, 1/2, 1/4 × its step "
                      "(quick: 1, 1/2; the scene's Δt for its own scheme, of step h/c0, "
                      "x c0/c for a scheme of step h/c; an explicit scheme's steps divided "
                      "by an integer where they would be above 0.9 x its critical step "
                      "as the core estimates it), errors against the same scene at a "
                      "much finer Δt (time-discretization errors on that mesh)",
    "stability": "a scene file of one's own: the critical Δt of the main schemes on it "
                 "as given (its h, γ0, θ, T), Δt grid in multiples of its Δt, then "
                 "bisection"}
#: Why the other studies refuse --scene (one line each).
SCENE_REFUSED = {
    "convergence": "it measures errors against the 1D closed form, which a scene of one's "
                   "own does not have; use `study work-precision --scene FILE` (errors "
                   "against the scene run at a much finer Δt)",
    "methods": "it compares contact methods and masses on the seed bar, which a scene "
               "study keeps at the scene's own; set `&contact method` or `&scheme mass` "
               "in the scene and run `study work-precision --scene` or `study stability "
               "--scene` on each",
    "hertz": "it drops the pole-refined ball of meshes/ball_pole.geo at the speeds where "
             "Hertz's impact theory holds; run `study work-precision --scene FILE` on a "
             "ball scene of one's own",
    "all": "its which-scheme table is built from the seed bar's studies; run `study "
           "work-precision --scene FILE` and `study stability --scene FILE`"}


def _nonempty(text: str) -> str:
    """argparse type: a non-blank string (`--out ""` would name the current folder)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("must not be empty")
    return text


def _subparser(parser: argparse.ArgumentParser, name: str) -> argparse.ArgumentParser:
    """The parser of subcommand `name` of `parser`."""
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return action.choices[name]


#: The exit statuses, at the end of every study's --help (a run of a study that fails is
#: reported and the study completes, so a batch script needs to know what 1 means).
EXIT_HELP = ("Exit status: 0 every run done (unstable runs are results), 1 some runs failed "
             "to run (each named in the log, counted in summary.md; the study completes), 2 bad "
             "input (one line), 4 an output that cannot be written, 130 interrupted "
             "(Ctrl-C, SIGTERM: the finished runs are cached and the same command resumes).")


def _parser() -> argparse.ArgumentParser:
    p = OneLineParser(epilog=EXIT_HELP,
        prog="python -m dyncontact study", label="dyncontact study",
        description="The studies: convergence, work-precision, stability, contact methods "
        "and Hertz's impact ('all': the first three and the which-scheme table); each "
        "writes CSV, PNG and summary.md into --out.")
    sub = p.add_subparsers(dest="study", metavar="STUDY", required=True)
    helps = {"convergence": "errors against the 1D closed form, observed orders",
             "work-precision": "error against CPU time per scheme (1D exact, 2D seed bar; "
                               "--scene FILE: on a scene of one's own)",
             "stability": "stability maps and critical dt on the 2D seed bar, with the "
                          "seed's claims (--scene FILE: critical dt on a scene of one's "
                          "own)",
             "all": "the three studies into OUT/<study>/, the 'which scheme should I use' "
                    "table into OUT/which/ (from their runs and two sweeps of its own) and "
                    "OUT/index.md",
             "methods": "contact method (Nitsche, penalty, augmented Lagrangian) x mass x "
                        "scheme on the 2D seed bar: energy drift, p_n, penetration, Newton "
                        "iterations, stability",
             "hertz": "the 3D ball refined under its pole against Hertz's impact (a/R = "
                      "0.2, 0.1, 0.05; v << c): contact time, F_max, approach, impulse"}
    for name in (*STUDIES, "methods", "hertz", "all"):
        s = sub.add_parser(name, help=helps[name], description=helps[name], epilog=EXIT_HELP)
        s.add_argument("--quick", action="store_true", help="small sizes (seconds)")
        s.add_argument("--out", required=True, metavar="DIR", type=_nonempty,
                       help="output folder")
        add_runner_options(s)
        s.add_argument("--no-progress", action="store_true", help="no progress bar")
        s.add_argument("--scene", metavar="FILE.nml", default=None, type=_nonempty,
                       help=SCENE_HELP.get(name, "not for this study: "
                                           + SCENE_REFUSED.get(name, "")))
        if name in ("convergence", "work-precision", "all"):
            s.add_argument("--c-implicit", type=positive(float), default=20.0,
                           help="dt = h/c for implicit schemes (> 0, default 20)")
            s.add_argument("--c-explicit", type=positive(float), default=100.0,
                           help="dt = h/c for predictor-corrector schemes (> 0, "
                           "default 100)")
        if name == "convergence":
            s.add_argument("--schemes", default=None, type=_nonempty,
                           help="comma-separated scheme keys (default: the study's list)")
            s.add_argument("--t-end", type=positive(float), default=3.0,
                           help="T (> 0, default 3)")
    return p


def _common(args) -> dict[str, Any]:
    return {"workers": args.workers, "scheduler": args.scheduler, "cache": args.cache,
            "progress": False if args.no_progress else None,
            "log": lambda s: print(s, file=sys.stderr, flush=True)}


def run_one(name: str, out: str, args) -> dict[str, Any]:
    kw = _common(args)
    if name == "convergence":
        from .convergence import run_convergence

        return run_convergence(out, quick=args.quick, c_implicit=args.c_implicit,
                               c_explicit=args.c_explicit,
                               schemes=getattr(args, "schemes", None),
                               t_end=getattr(args, "t_end", 3.0), **kw)
    scene = getattr(args, "scene", None)
    if name == "work-precision" and scene is not None:
        from .workprecision import run_work_precision_scene

        return run_work_precision_scene(out, scene, quick=args.quick,
                                        c_implicit=args.c_implicit,
                                        c_explicit=args.c_explicit,
                                        desc="work-precision --scene", **kw)
    if name == "stability" and scene is not None:
        from .stability import run_stability_scene

        return run_stability_scene(out, scene, quick=args.quick, desc="stability --scene",
                                   **kw)
    if name == "work-precision":
        from .workprecision import run_work_precision

        return run_work_precision(out, quick=args.quick, c_implicit=args.c_implicit,
                                  c_explicit=args.c_explicit, **kw)
    if name == "methods":
        from .methods import run_methods

        return run_methods(out, quick=args.quick, **kw)
    if name == "hertz":
        from .hertz import run_hertz

        return run_hertz(out, quick=args.quick, **kw)
    from .stability import run_stability

    return run_stability(out, quick=args.quick, **kw)


def write_index(out: str, reports: dict[str, dict[str, Any]], wall_s: float,
                quick: bool) -> str:
    """OUT/index.md: the three studies' charts and findings, with wall time and runs."""
    from .. import __version__

    n_runs = sum(r["n_runs"] for r in reports.values())
    n_cached = sum(r["n_cached"] for r in reports.values())
    lines = [f"# dyncontact studies{' (quick)' if quick else ''}", "",
             f"Generated {datetime.datetime.now().astimezone().isoformat(timespec='seconds')}"
             f" by dyncontact {__version__}, {os.cpu_count()} cores. "
             f"**Wall time {wall_s:.1f} s, {n_runs} runs** ({n_cached} from the cache).", ""]
    which = reports.get("which")
    if which is not None:   # the answer first, the studies behind it after
        reports = {"which": which, **{k: v for k, v in reports.items() if k != "which"}}
    for name, rep in reports.items():
        folder = name
        lines += [f"## {name}", "",
                  f"{rep['n_runs']} runs, {rep['n_errors']} failed to run, "
                  f"{rep['wall_s']:.1f} s. Details: [{folder}/summary.md]({folder}/summary.md)",
                  ""]
        with open(rep["summary"], encoding="utf-8") as f:
            body = f.read().splitlines()
        # the study's own summary without its title, images re-rooted
        for line in body[1:]:
            if line.startswith("!["):
                a, b = line.split("](", 1)
                line = f"{a}]({folder}/{b}"
            if line.startswith("#"):
                line = "#" + line
            lines.append(line)
        lines.append("")
    path = os.path.join(out, "index.md")
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(lines) + "\n")
    return path


def _scene_line(exc: UserSceneError) -> str:
    """A study's refusal of the scene, said of the option that gave it: ``--scene SCENE:
    WHY``, the file named once (the core's refusals start with it)."""
    why = exc.why.removeprefix(f"{exc.scene}: ")
    return f"--scene {exc.scene}: {why}"


def main(argv: Sequence[str] | None = None) -> int:
    parser = _parser()
    try:
        args, extras = parser.parse_known_args(argv)
        if extras:
            # argparse would report them from the top-level parser, pointing to `dyncontact
            # study --help`, which does not list the study's options: the study's own
            # parser reports them, pointing to its help
            _subparser(parser, args.study).error(f"unrecognized arguments: {' '.join(extras)}")
    except SystemExit as exc:   # --help (0) or a bad command line (2, reported)
        return int(exc.code or 0)
    if args.workers is not None and args.workers < 1:
        print("dyncontact study: --workers must be >= 1", file=sys.stderr)
        return 2
    if args.cache is not None and not args.cache.strip():
        print("dyncontact study: --cache: must not be empty", file=sys.stderr)
        return 2
    folders = (("--out", args.out), ("--cache", args.cache))
    for option, folder in folders:
        if folder is not None and os.path.exists(folder) and not os.path.isdir(folder):
            print(f"dyncontact study: {option} {folder}: a file, not a folder", file=sys.stderr)
            return 2
    if args.scene is not None and args.study in SCENE_REFUSED:
        print(f"dyncontact study {args.study}: --scene: not for this study: "
              f"{SCENE_REFUSED[args.study]}", file=sys.stderr)
        return 2
    if args.scene is not None:
        from .common import read_user_scene

        try:
            read_user_scene(args.scene)   # before anything is written
        except UserSceneError as exc:
            print(f"dyncontact study: {_scene_line(exc)}", file=sys.stderr)
            return 2
        except ValueError as exc:
            print(f"dyncontact study: {exc}", file=sys.stderr)
            return 2
    if getattr(args, "schemes", None) is not None:
        try:
            scheme_list(args.schemes)   # before anything is written
        except ValueError as exc:
            print(f"dyncontact study: --schemes: {exc}", file=sys.stderr)
            return 2
    for option, folder in folders:      # made once the arguments are known to be good
        if folder is None:
            continue
        try:
            os.makedirs(folder, exist_ok=True)
        except OSError as exc:
            from ..cli import WRITE_ERRNOS

            # as a run's output folder: no room or a read-only file system is exit 4
            print(f"dyncontact study {args.study}: {option} {folder}: cannot create the "
                  f"folder ({exc.strerror or exc})", file=sys.stderr)
            return 4 if exc.errno in WRITE_ERRNOS else 2
    t0 = time.perf_counter()
    out = os.path.abspath(args.out)
    try:
        with sigterm_as_interrupt(), scheduler_timeout(args):
            reports = _run_study(args, out, t0)
    except SchedulerUnreachable as exc:
        print(scheduler_unreachable_line("dyncontact study", args, exc), file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("dyncontact study: interrupted (finished runs are cached; run the same "
              "command again to resume)", file=sys.stderr)
        return 130
    except UserSceneError as exc:
        print(f"dyncontact study: {_scene_line(exc)}", file=sys.stderr)
        return 2
    except ValueError as exc:
        print(f"dyncontact study: {exc}", file=sys.stderr)
        return 2
    errors = sum(r["n_errors"] for r in reports.values())
    if errors:
        print(f"dyncontact study: {errors} run(s) failed to run (see the summaries)",
              file=sys.stderr)
        return 1
    return 0


def _run_study(args, out: str, t0: float) -> dict[str, dict[str, Any]]:
    """Run the study (or all of them) the command line asks for; the reports by name."""
    if args.study != "all":
        reports = {args.study: run_one(args.study, out, args)}
        rep = reports[args.study]
        print(f"dyncontact study {args.study}: {rep['n_runs']} runs in "
              f"{time.perf_counter() - t0:.1f} s -> {rep['summary']}")
        return reports
    if args.cache is None:
        args.cache = os.path.join(out, "cache")
    reports = {name: run_one(name, os.path.join(out, name), args) for name in STUDIES}
    from .which import run_which

    reports["which"] = run_which(os.path.join(out, "which"), reports["work-precision"],
                                 reports["stability"], quick=args.quick,
                                 c_implicit=args.c_implicit,
                                 c_explicit=args.c_explicit, **_common(args))
    wall = time.perf_counter() - t0
    index = write_index(out, reports, wall, args.quick)
    n = sum(r["n_runs"] for r in reports.values())
    print(f"dyncontact study: {n} runs in {wall:.1f} s -> {index}")
    return reports
