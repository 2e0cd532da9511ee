"""The benchmark (``scripts/bench``): the seed scene and the predictor-corrector, timed
against the floors of their own matrices.

``scripts/bench`` is a thin wrapper of :func:`bench_main`. The rows run one after another
in this process (a timing shares the machine with nothing of its own), each through
:func:`.sweep.run_uncached`: the sweep runner's run of one scene, never its cache, so that
every time in the table was measured by this benchmark.
"""

from __future__ import annotations

import dataclasses
import datetime
import json
import os
import platform
import shutil
import sys
import time
from typing import Any, Iterable, Mapping, Sequence

from .common import (OneLineParser, RunSpec, contact_free_by_design, fmt, loadavg, num,
                     package_version, scheme_text, seed_spec)
from .sweep import ERROR, REFUSED, run_uncached, sigterm_as_interrupt

__all__ = ["bench_specs", "bench_row", "interleaved_run", "bench_table", "bench_main",
           "step_floor", "floor_api_available", "FLOOR_API", "contact_steps",
           "split_flight_contact"]


#: The core's timing helper of the floors (bench prints 'n/a' when it is missing; it is
#: reached through :func:`dyncontact.core.bench_floors`).
FLOOR_API = "dc_bench_floor"


def floor_api_available() -> bool:
    """Whether the core has the timing helper of the floors."""
    from ..core import bench_floors_available

    return bench_floors_available()


def bench_specs(quick: bool = False, only: Iterable[str] | None = None) -> list[RunSpec]:
    """The benchmark's rows: the seed scene (hht α = 0, Δt = h/20, T = 15) at h = 0.05,
    0.02, 0.01, pc (Δt = h/100, consistent and lumped mass) at the same meshes and the 3D
    box (hht α = 0, Δt = h/20) at h = 0.05 and 0.025, each also without its contact
    boundary (``box3d_free_h*``), with
    the scene's default output (every = 1). ``only``: row names to keep (fnmatch
    patterns allowed)."""
    import fnmatch

    meshes = (0.05,) if quick else (0.05, 0.02, 0.01)
    specs = []
    for h in meshes:
        s = seed_spec("hht", h, h / 20, 15.0, max_rows=None, alpha=0.0)
        s.name = f"seed_h{num(h)}"
        specs.append(s)
    # the same bar with no contact boundary: every step contact-free (one solve each)
    s = seed_spec("hht", meshes[-1], meshes[-1] / 20, 15.0, max_rows=None, alpha=0.0)
    s.settings["boundary.contact"] = ""
    s.name = f"seed_free_h{num(meshes[-1])}"
    specs.append(s)
    for h in meshes:
        for mass in ("consistent", "lumped"):
            s = seed_spec("pc", h, h / 100, 15.0, max_rows=None, mass=mass, beta=0.25,
                          gamma=0.5)
            s.name = f"pc_h{num(h)}_{mass}"
            specs.append(s)
    # the 3D box (P1 tetrahedra, GetFEM's 3D settings: hht alpha = 0, dt = h/20), T = 15 at
    # h = 0.05 and the first contact (T = 3) at h = 0.025; each followed by the same box with
    # no contact boundary (every step in flight: the 3D step against its floor)
    for h, t_end in ((0.05, 15.0),) if quick else ((0.05, 15.0), (0.025, 3.0)):
        for free in (False, True):
            s = seed_spec("hht", h, h / 20, t_end, max_rows=None, alpha=0.0)
            s.settings = {"mesh.dim": 3, **s.settings}     # first: the vectors become 3D
            if free:
                s.settings["boundary.contact"] = ""
            s.name = f"box3d_free_h{num(h)}" if free else f"box3d_h{num(h)}"
            specs.append(s)
    if only:
        pats = only_patterns(only)
        specs = [s for s in specs if any(fnmatch.fnmatchcase(s.name, p) for p in pats)]
    return specs


def only_patterns(only: Iterable[str]) -> list[str]:
    """The fnmatch patterns of repeated, comma-separated ``--only`` values."""
    return [p.strip() for item in only for p in item.split(",") if p.strip()]


def unmatched_only(quick: bool, only: Iterable[str]) -> str | None:
    """The message refusing ``--only`` when one of its patterns matches no row of the
    mode (a typo would otherwise drop a row silently), or None when each matches."""
    import fnmatch

    pats = only_patterns(only)
    names = [s.name for s in bench_specs(quick=quick)]
    bad = [p for p in pats if not any(fnmatch.fnmatchcase(n, p) for n in names)]
    if pats and not bad:
        return None
    what = ", ".join(bad) if bad else "(empty)"
    msg = (f"--only {what}: no such row{' with --quick' if quick else ''} "
           f"(rows{' of --quick' if quick else ''}: {', '.join(names)})")
    full = [p for p in bad if any(fnmatch.fnmatchcase(s.name, p) for s in bench_specs())]
    if quick and full:
        msg += f"; {', '.join(full)}: row(s) of the full bench, run without --quick"
    return msg


def interleaved_run(spec: RunSpec, out_dir: str, chunks: int = 16, n_rep: int = 400,
                    batches: int = 4) -> dict[str, Any]:
    """One run of ``spec`` in ``chunks`` stretches of steps, with the floors measured on
    its own matrices before the first stretch and after each one
    (:meth:`dyncontact.core.Stepper.floors`, ``n_rep`` calls in ``batches``: the best
    batch). Each stretch is timed around its steps and compared with the mean of the
    floors measured right before and right after it, so that a ratio compares times
    taken seconds apart (these machines' speed drifts by tens of percent within a
    minute). Returns us_per_step (all stretches), the floors (step-weighted means of
    the stretches' floors), floor_us, floor_ratio = Σ time / Σ steps × floor (=
    us_per_step / floor_us; each stretch's floor is the faster of its two solves, so
    floor_us can lie below step_floor() of the mean floors), chunk_ratios, chunk_steps,
    chunk_floors_us, steps and status, and from the run's trace the
    share of contact steps and the cost of a step in flight and of a contact step in
    floors (contact_share, flight_ratio, contact_ratio: :func:`split_flight_contact`).
    Never raises."""
    from ..core import NumericalError, Stepper

    rec: dict[str, Any] = {"scene": spec.name, "status": "error", "message": "",
                           "steps": 0, "us_per_step": None, "floor_us": None,
                           "floor_ratio": None, "floor_cholmod_ratio": None,
                           "chunk_ratios": [], "contact_share": None,
                           "flight_ratio": None, "contact_ratio": None}
    keys = ("floor_solve_us", "floor_spmv_us", "floor_mass_solve_us",
            "floor_cholmod_solve_us")
    names = ("solve_us", "spmv_us", "mass_solve_us", "cholmod_solve_us")
    try:
        if os.path.isdir(out_dir):
            shutil.rmtree(out_dir)
        with contact_free_by_design(spec.settings.get("boundary.contact") == ""):
            run = Stepper(spec.scene(), out_dir)
        with run:
            size = max(1, -(-int(run.n_steps) // max(1, int(chunks))))
            floors = [run.floors(n_rep, batches)]
            stretches = []   # (steps, seconds)
            rec["status"] = "ok"
            while not run.finished:
                t0 = time.perf_counter()
                try:
                    done = run.advance(size)
                except NumericalError as exc:
                    rec.update(status="unstable", message=str(exc))
                    break
                seconds = time.perf_counter() - t0
                if done == 0:
                    break
                stretches.append((done, seconds))
                floors.append(run.floors(n_rep, batches))
    except Exception as exc:  # noqa: BLE001 - a benchmark reports, it does not fail
        rec.update(status="error", message=f"{type(exc).__name__}: {exc}")
        return rec
    steps = sum(d for d, _ in stretches)
    rec["steps"] = steps
    if not steps:
        return rec
    seconds = sum(t for _, t in stretches)
    rec["us_per_step"] = 1e6 * seconds / steps
    if any(f is None for f in floors):
        return rec
    per = []   # each stretch's floors: the mean of those before and after it
    for k in range(len(stretches)):
        per.append({key: (None if floors[k][n] is None or floors[k + 1][n] is None
                          else 0.5 * (floors[k][n] + floors[k + 1][n]))
                    for key, n in zip(keys, names)})
    for key in keys:
        vals = [p[key] for p in per]
        rec[key] = (None if any(v is None for v in vals)
                    else sum(d * v for (d, _), v in zip(stretches, vals)) / steps)
    chol_floors = [step_floor(dict(p, scene=spec.name), cholmod=True) for p in per]
    if all(f is not None for f in chol_floors):
        rec["floor_cholmod_ratio"] = 1e6 * seconds / sum(
            d * f for (d, _), f in zip(stretches, chol_floors))
    step_floors = [step_floor(dict(p, scene=spec.name)) for p in per]
    if any(f is None for f in step_floors):
        return rec
    spent = sum(d * f for (d, _), f in zip(stretches, step_floors))   # µs
    rec["floor_us"] = spent / steps
    rec["floor_ratio"] = 1e6 * seconds / spent
    rec["chunk_ratios"] = [1e6 * t / (d * f) for (d, t), f in zip(stretches, step_floors)]
    rec["chunk_steps"] = [d for d, _ in stretches]
    rec["chunk_floors_us"] = step_floors
    rec.update(_split(out_dir, [d for d, _ in stretches], rec["chunk_ratios"]))
    return rec


def _split(out_dir: str, steps: Sequence[int], ratios: Sequence[float]) -> dict[str, Any]:
    """contact_share (the run's contact steps ÷ its steps), flight_ratio and
    contact_ratio (:func:`split_flight_contact`) from the run's trace; None where the
    trace has no row every step."""
    from ..core import read_trace

    out: dict[str, Any] = {"contact_share": None, "flight_ratio": None,
                           "contact_ratio": None}
    try:
        flags = contact_steps(read_trace(out_dir))
    except (OSError, KeyError, ValueError):
        return out
    if len(flags) != sum(steps):
        return out
    contact, start = [], 0
    for d in steps:
        contact.append(sum(flags[start:start + d]))
        start += d
    out["contact_share"] = sum(contact) / len(flags) if flags else None
    out["flight_ratio"], out["contact_ratio"] = split_flight_contact(steps, contact, ratios)
    return out


def contact_steps(trace: Mapping[str, Any]) -> list[bool]:
    """For a trace with a row every step (row 0 the initial state, row k the end of step
    k), whether each step k = 1, 2, ... did contact work: its Newton took more than one
    iteration, or contact was active at its start or at its end. A step in flight (one
    iteration, no active point before or after) is False."""
    its = [float(x) for x in trace["newton_its"]]
    act = [float(x) for x in trace["active"]]
    return [its[k] > 1 or act[k] > 0 or act[k - 1] > 0 for k in range(1, len(its))]


#: The least spread of the stretches' contact-step fractions for which
#: :func:`split_flight_contact` separates the two costs.
SPLIT_MIN_SPREAD = 0.25


def split_flight_contact(steps: Sequence[int], contact: Sequence[int],
                         ratios: Sequence[float]) -> tuple[float | None, float | None]:
    """The cost of a step in flight and of a contact step, each in floors, from stretches
    of steps: stretch k has steps[k] steps, contact[k] of them contact steps, and took
    ratios[k] × steps[k] floors. Least squares of ratios[k] steps[k] = a (steps[k] −
    contact[k]) + b contact[k] over the stretches; returns (a, b). With no contact step
    (every step in flight) a is the stretches' ratio and b None, and the other way round;
    (None, None) when the stretches' contact fractions spread by less than
    SPLIT_MIN_SPREAD (the two costs cannot be told apart)."""
    d = [float(x) for x in steps]
    c = [float(x) for x in contact]
    y = [r * n for r, n in zip(ratios, d)]
    if not d or sum(d) <= 0:
        return None, None
    if sum(c) == 0:
        return sum(y) / sum(d), None
    if sum(c) == sum(d):
        return None, sum(y) / sum(d)
    frac = [ck / dk for ck, dk in zip(c, d) if dk > 0]
    if max(frac) - min(frac) < SPLIT_MIN_SPREAD:
        return None, None
    f = [dk - ck for dk, ck in zip(d, c)]      # steps in flight
    sff = sum(x * x for x in f)
    sfc = sum(x * z for x, z in zip(f, c))
    scc = sum(z * z for z in c)
    sfy = sum(x * v for x, v in zip(f, y))
    scy = sum(z * v for z, v in zip(c, y))
    det = sff * scc - sfc * sfc
    return (scc * sfy - sfc * scy) / det, (sff * scy - sfc * sfy) / det


def _timed_run(spec: RunSpec, out_dir: str) -> dict[str, Any]:
    """One run of spec into out_dir, measured afresh (:func:`.sweep.run_uncached`): its
    record with the summary's counters (dofs, factorizations, isa, ...) at the top."""
    rec = run_uncached(spec.task("outputs"), out_dir)
    rec.update(rec.pop("metrics", None) or {})
    return rec


def bench_row(spec: RunSpec, out_root: str, sparse_every: int = 100,
              repeat: int = 3) -> dict[str, Any]:
    """One benchmark row: the run as a user runs it (trace every step; wall s, status,
    Newton iterations), the same run with every = ``sparse_every`` (the cost of the
    trace), and ``repeat`` interleaved runs (:func:`interleaved_run`: floors measured
    between stretches of steps) for the ratio µs/step ÷ floor; the row reports the
    interleaved run of the median ratio (its µs/step, floors and ratio) and the range of
    the ratios."""
    repeat = max(1, int(repeat))
    full = _timed_run(spec, os.path.join(out_root, spec.name))
    sparse = dataclasses.replace(spec, settings=dict(spec.settings,
                                                     **{"output.every": sparse_every}))
    light = _timed_run(sparse, os.path.join(out_root, f"{spec.name}_every{sparse_every}"))
    runs = [interleaved_run(spec, os.path.join(out_root, f"{spec.name}_interleaved"))
            for _ in range(repeat)]
    rated = sorted(range(len(runs)), key=lambda k: (runs[k]["floor_ratio"] is None,
                                                    runs[k]["floor_ratio"] or 0.0))
    pick = rated[(len([k for k in rated if runs[k]["floor_ratio"] is not None]) - 1) // 2] \
        if any(r["floor_ratio"] is not None for r in runs) else 0
    steps = full.get("steps") or 0
    its = full.get("newton_its_total")
    ratios = [r["floor_ratio"] for r in runs if r["floor_ratio"] is not None]
    row = {
        "scene": spec.name,
        "scheme": scheme_text(spec.settings, spec.base),
        "h": spec.settings.get("mesh.h"),
        "dt": spec.settings.get("scheme.dt"),
        "status": full["status"],
        "message": full["message"],
        "dofs": full.get("dofs"),
        "steps": steps,
        "wall_s": full.get("wall_s"),
        "wall_measured_s": full.get("wall_measured_s"),
        "us_per_step_run": 1e6 * full["wall_s"] / steps if steps and full.get("wall_s")
        else None,
        "sparse_every": sparse_every,
        "wall_s_sparse": light.get("wall_s"),
        "wall_measured_s_sparse": light.get("wall_measured_s"),
        "us_per_step_sparse": (1e6 * light["wall_s"] / light["steps"]
                               if light.get("steps") and light.get("wall_s") else None),
        "newton_its_total": its,
        "newton_its_per_step": its / steps if its is not None and steps else None,
        "factorizations": full.get("factorizations"),
        "setup_factorizations": full.get("setup_factorizations"),
        "isa": full.get("isa"),
        "blas": full.get("blas"),
        "solve_kernel": full.get("solve_kernel"),
        "loadavg": loadavg(),
        "repeat": repeat,
        "runs": runs,
        "floor_ratio_min": min(ratios) if ratios else None,
        "floor_ratio_max": max(ratios) if ratios else None,
    }
    row.update({k: v for k, v in runs[pick].items()
                if k not in ("scene", "status", "message", "steps", "chunk_ratios")})
    row["chunk_ratios"] = runs[pick]["chunk_ratios"]
    return row


def step_floor(row: Mapping[str, Any], cholmod: bool = False) -> float | None:
    """The floor of one step: one solve + one SpMV with K_θ for the implicit scheme, two
    M⁻¹ applications + two SpMVs for the predictor-corrector. The implicit scheme's solve
    is the faster of the run's own triangular solve and cholmod_solve2 on the same factor
    (the best solve of that factor; in 2D and 3D the run's node-block solve). ``cholmod``:
    the implicit scheme's floor with cholmod_solve2 (CHOLMOD's own solve, the reference
    for the run's solve kernel); None for the predictor-corrector."""
    spmv = row.get("floor_spmv_us")
    if row.get("floor_mass_solve_us") is None:     # an implicit scheme: no M^-1 solve
        chol = row.get("floor_cholmod_solve_us")
        solve = chol if cholmod else row.get("floor_solve_us")
        if not cholmod and solve is not None and chol is not None:
            solve = min(solve, chol)
        return solve + spmv if solve is not None and spmv is not None else None
    if cholmod:
        return None
    mass = row.get("floor_mass_solve_us")
    return 2 * (mass + spmv) if mass is not None and spmv is not None else None


_BENCH_COLUMNS = (  # (header, key, format)
    ("scene", "scene", "s"),
    ("dofs", "dofs", "d"),
    ("steps", "steps", "d"),
    ("wall s", "wall_s", ".3f"),
    ("meas. s", "wall_measured_s", ".3f"),
    ("s e=100", "wall_s_sparse", ".3f"),
    ("µs/step", "us_per_step", ".1f"),
    ("µs/st e=100", "us_per_step_sparse", ".1f"),
    ("Newton", "newton_its_total", "d"),
    ("its/step", "newton_its_per_step", ".3f"),
    ("fact.", "factorizations", "d"),
    ("solve µs", "floor_solve_us", ".2f"),
    ("CHOLMOD µs", "floor_cholmod_solve_us", ".2f"),
    ("M solve µs", "floor_mass_solve_us", ".2f"),
    ("SpMV µs", "floor_spmv_us", ".2f"),
    ("floor µs", "floor_us", ".1f"),
    ("µs/floor", "floor_ratio", ".2f"),
    ("range", "floor_ratio_range", "s"),
    ("µs/CHOLMOD floor", "floor_cholmod_ratio", ".2f"),
    ("contact steps", "contact_share", ".2f"),
    ("in flight /floor", "flight_ratio", ".2f"),
    ("contact step /floor", "contact_ratio", ".2f"),
    ("status", "status", "s"),
)


def _cell(row: Mapping[str, Any], key: str, fmt: str) -> str:
    if key == "floor_ratio_range":
        lo, hi = row.get("floor_ratio_min"), row.get("floor_ratio_max")
        return f"{lo:.2f}-{hi:.2f}" if lo is not None and hi is not None else "-"
    v = row.get(key)
    if key.startswith("floor_"):
        # an implicit scheme's row (the seed's and the 3D box's): no M^-1 floor
        implicit = not str(row.get("scene", "")).startswith("pc")
        applies = {"floor_solve_us": implicit, "floor_cholmod_solve_us": implicit,
                   "floor_cholmod_ratio": implicit,
                   "floor_mass_solve_us": not implicit}.get(key, True)
        if not applies:
            return "-"
        if v is None:
            return "n/a"
    if v is None:
        return "-"
    if fmt == "d":
        return str(int(v))
    if fmt == "s":
        return str(v)
    return format(float(v), fmt)


def bench_table(rows: Sequence[Mapping[str, Any]]) -> str:
    """The rows as a fixed-width text table (floors 'n/a' when not measured, '-' when
    they do not apply to the row's scheme)."""
    cells = [[h for h, _, _ in _BENCH_COLUMNS]]
    cells += [[_cell(r, k, f) for _, k, f in _BENCH_COLUMNS] for r in rows]
    widths = [max(len(c[j]) for c in cells) for j in range(len(_BENCH_COLUMNS))]

    def line(c):
        return "  ".join(x.ljust(w) if j == 0 else x.rjust(w)
                         for j, (x, w) in enumerate(zip(c, widths))).rstrip()

    out = [line(cells[0]), "  ".join("-" * w for w in widths)]
    out += [line(c) for c in cells[1:]]
    return "\n".join(out)


def _bad_out_file(path: str) -> str | None:
    """Why ``path`` cannot be the file a command writes (None when it can): empty, a
    folder, or in a folder that does not exist (a command that writes one file does not
    create folders a typo named)."""
    if not path.strip():
        return "empty file name"
    if path.endswith(("/", os.sep)) or os.path.isdir(path):
        return "is a folder (give a file name)"
    folder = os.path.dirname(path) or "."
    if not os.path.isdir(folder):
        return f"no folder {folder} (create it first)"
    return None


def bench_main(argv: Sequence[str] | None = None, root: str | None = None) -> int:
    """``scripts/bench [--quick] [--only NAME[,NAME]] [--out FILE.json]``: runs one after
    another, prints the table, writes the JSON. Exit 0 unless a run could not run at all
    (a benchmark never fails on time), 2 on a bad command line, 130 on Ctrl-C or SIGTERM
    (after the table and the JSON of the rows done)."""
    root = root or os.getcwd()
    p = OneLineParser(prog="scripts/bench", label="bench", description="Benchmark the seed "
                                "scene and the predictor-corrector runs; prints a table "
                                "and writes it as JSON.",
                                epilog="scripts/bench --scaling runs the scaling sweep "
                                "instead, scripts/bench --getfem the comparison with the "
                                "GetFEM script; each has its own --help.")
    p.add_argument("--quick", action="store_true", help="only the h = 0.05 rows")
    p.add_argument("--only", action="append", metavar="NAME",
                   help="rows to run (names as in the table; fnmatch patterns, "
                   "comma-separated; repeatable); a pattern that matches no row of the "
                   "mode (--quick has only the h = 0.05 rows) is refused, exit 2")
    p.add_argument("--out", default=None, help="JSON file, in an existing folder "
                   "(default: ROOT/out/bench.json)")
    p.add_argument("--runs", default=None,
                   help="folder of the runs' outputs (default: ROOT/out/bench)")
    p.add_argument("--repeat", type=int, default=3, metavar="N",
                   help="interleaved runs of each row (floors measured between "
                   "stretches of its steps); the table shows the median ratio (>= 1, "
                   "default 3)")
    args = p.parse_args(argv)

    def refuse(message: str) -> int:
        print(f"bench: {message}", file=sys.stderr)
        return 2

    if args.repeat < 1:
        return refuse(f"--repeat must be >= 1, got {args.repeat}")
    if args.only is not None:
        bad = unmatched_only(args.quick, args.only)
        if bad:
            return refuse(bad)
    if args.out is not None:
        bad = _bad_out_file(args.out)
        if bad:
            return refuse(f"--out {args.out}: {bad}")
    specs = bench_specs(quick=args.quick, only=args.only)
    out_json = args.out or os.path.join(root, "out", "bench.json")
    runs_root = args.runs or os.path.join(root, "out", "bench")
    from ..core import fortran_version

    fortran_version()   # load the extension before the first timing
    load = loadavg()
    print(f"bench: {len(specs)} rows, one run after another (load average {load}, "
          f"{os.cpu_count()} cores); floors: "
          f"{'measured' if floor_api_available() else 'n/a (the core has no ' + FLOOR_API + ')'}",
          flush=True)
    if load and load[0] > 0.5 * (os.cpu_count() or 1):
        print("bench: warning: the machine is busy, timings are inflated", flush=True)
    rows = []
    t0 = time.perf_counter()
    interrupted = False
    try:
        with sigterm_as_interrupt():
            for spec in specs:
                row = bench_row(spec, runs_root, repeat=args.repeat)
                rows.append(row)
                print(f"bench: {row['scene']}: {row['status']}, {row['steps']} steps, "
                      f"{fmt(row['wall_s'], '.3f')} s ({fmt(row['wall_s_sparse'], '.3f')} "
                      "s with every=100)", flush=True)
    except KeyboardInterrupt:
        interrupted = True
        print("bench: interrupted; partial results follow", file=sys.stderr)
    print()
    print(bench_table(rows))
    print()
    print("wall s = summary.json wall_s (core time loop, trace every step); meas. s = "
          "around dyncontact.run (set-up and reading the trace back included); s e=100 = "
          "the same run with output.every = 100; solve µs = the triangular solve the run "
          "uses, CHOLMOD µs = the same solve through cholmod_solve2 on the same factor; "
          f"µs/step, the floors and µs/floor: each row ran {args.repeat} more times in 16 "
          "stretches of steps with the floors measured between them, each stretch "
          "compared with the floors measured next to it (µs/floor = time of the steps ÷ "
          "Σ steps × floor); the table shows the run of the median ratio, range = the "
          "ratios of all those runs; µs/CHOLMOD floor = the same run's ratio with "
          "CHOLMOD µs in place of solve µs in the floor; contact steps = the share of "
          "steps that did contact work (more than one Newton iteration, or contact "
          "active at the step's start or end); in flight /floor and contact step /floor "
          "= the cost of one such step in floors, least squares over the same run's "
          "stretches (- where the stretches' contact shares do not differ enough to "
          "tell them apart).")
    isas = sorted({str(r.get("isa")) for r in rows if r.get("isa")})
    if isas:
        print(f"core built for: {', '.join(isas)} (meson option simd; see meson.options)")
    blas = sorted({str(r.get("blas")) for r in rows if r.get("blas")})
    if blas:
        print(f"BLAS (CHOLMOD's supernodal factorization, UMFPACK): {', '.join(blas)}")
    doc = {
        "generated": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
        "version": package_version(),
        "machine": {"cpu_count": os.cpu_count(), "platform": platform.platform(),
                    "python": platform.python_version(), "loadavg_start": load,
                    "loadavg_end": loadavg()},
        "floor_api": FLOOR_API if floor_api_available() else None,
        "isa": isas,
        "blas": blas,
        "total_wall_s": time.perf_counter() - t0,
        "columns": {k: h for h, k, _ in _BENCH_COLUMNS},
        "rows": rows,
    }
    folder = os.path.dirname(os.path.abspath(out_json))
    os.makedirs(folder, exist_ok=True)
    with open(out_json, "w", encoding="utf-8") as f:
        json.dump(doc, f, indent=1)
    print(f"bench: wrote {out_json}")
    if interrupted:
        return 130
    return 0 if all(r["status"] not in (ERROR, REFUSED) for r in rows) else 1
