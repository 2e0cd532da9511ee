"""Batches of runs and their reports: the seed's figures and the benchmark.

``scripts/figures`` and ``scripts/bench`` are thin wrappers of :func:`figures_main` and
:func:`bench_main`; everything they do is here, reusable from Python:

>>> from dyncontact import studies
>>> plan = studies.figure_plan(quick=True)                      # what scripts/figures runs
>>> report = studies.make_figures("out/figures", quick=True)   # doctest: +SKIP
>>> report["figures"][0]["png"], report["wall_s"]               # doctest: +SKIP

A run is described by a :class:`RunSpec`: a name (its folder) and the scene keys it
changes from the seed's default scene (SPEC section 2: the built-in 2D bar, hht α = 0).
:func:`run_spec` runs one spec in the current process and returns a plain record (status,
steps, wall times, Newton iterations, ...); :func:`run_many` runs many of them over a
process pool, longest first.
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import dataclasses
import datetime
import json
import math
import os
import platform
import shutil
import sys
import time
from typing import Any, Callable, Iterable, Mapping, Sequence

__all__ = [
    "RunSpec", "seed_spec", "every_for", "run_spec", "run_many",
    "FigureSpec", "figure_plan", "make_figures", "write_index", "figures_main",
    "bench_specs", "bench_row", "interleaved_run", "bench_table", "bench_main",
    "floor_api_available",
    "MAX_ROWS",
]

#: Trace rows a figure run keeps at most (output.every is chosen for it).
MAX_ROWS = 3000


# --------------------------------------------------------------------------- run specs

def _g(x: float) -> str:
    """A number as it appears in run names and labels: 0.05, 0.0025, -0.1, 1e-05."""
    return f"{float(x):.6g}"


@dataclasses.dataclass
class RunSpec:
    """One run: a name (its output folder) and the scene keys it sets.

    ``settings`` maps 'group.key' to a value (``Scene.set``), applied to the scene file
    ``base`` or, when ``base`` is None, to the built-in default scene (the seed's test
    case). ``label`` (optional) is the legend text; by default the figures use
    :func:`dyncontact.plotting.run_label` of the run's summary.
    """

    name: str
    settings: dict[str, Any]
    base: str | None = None
    label: str | None = None

    def scene(self):
        """The :class:`dyncontact.Scene` of this run."""
        from .scene import Scene

        scn = Scene.read(self.base) if self.base else Scene()
        for key, value in self.settings.items():
            scn.set(key, value)
        return scn

    def get(self, key: str, default: Any = None) -> Any:
        """A scene key of this run (the setting, or the default scene's value)."""
        if key in self.settings:
            return self.settings[key]
        try:
            return self.scene().get(key)
        except Exception:  # noqa: BLE001 - only for estimates and reports
            return default

    def estimated_steps(self) -> int:
        dt = float(self.get("scheme.dt", 0.0025))
        t_end = float(self.get("scheme.t_end", 15.0))
        return max(0, math.ceil(t_end / dt - 1e-9))

    def estimated_dofs(self) -> int:
        """Free dofs of the built-in bar (clamped top row removed); a guess otherwise."""
        if self.get("mesh.file", ""):
            return 1000
        h = float(self.get("mesh.h", 0.05))
        length = float(self.get("mesh.length", 1.0))
        dim = int(self.get("mesh.dim", 2))
        ny = round(length / h)
        if dim == 1:
            return ny
        nx = max(1, round(float(self.get("mesh.width", 0.1)) / h))
        return 2 * (nx + 1) * ny

    def estimated_cost(self) -> float:
        """Relative cost (steps x dofs) used to start the longest runs first."""
        return float(self.estimated_steps()) * float(self.estimated_dofs())


def every_for(t_end: float, dt: float, max_rows: int = MAX_ROWS) -> int:
    """The smallest output.every that keeps a trace to at most ~max_rows rows."""
    steps = max(1, math.ceil(float(t_end) / float(dt) - 1e-9))
    return max(1, math.ceil(steps / max_rows))


_SCHEME_KEYS = {"alpha": "a", "beta": "b", "gamma": "g", "theta": "th"}


def seed_spec(scheme: str, h: float, dt: float, t_end: float, *, mass: str = "consistent",
              every: int | None = None, max_rows: int | None = MAX_ROWS,
              fields_every: int = 0, prefix: str = "", **params: float) -> RunSpec:
    """A run of the seed's 2D bar with one scheme.

    ``params`` are scheme keys (alpha, beta, gamma, theta). ``every`` = output.every;
    None: :func:`every_for` (max_rows), or 1 when max_rows is None. The name says all:
    ``hht_a-0.05_h0.02_dt0.001_T15`` (+ ``_lumped``).
    """
    dt = round(float(dt), 15)
    if every is None:
        every = 1 if max_rows is None else every_for(t_end, dt, max_rows)
    settings: dict[str, Any] = {"mesh.h": float(h), "scheme.name": scheme,
                                "scheme.dt": dt, "scheme.t_end": float(t_end),
                                "scheme.mass": mass, "output.every": int(every),
                                "output.fields_every": int(fields_every)}
    tag = [scheme]
    for key, value in params.items():
        if key not in _SCHEME_KEYS:
            raise ValueError(f"unknown scheme parameter {key!r}")
        settings[f"scheme.{key}"] = float(value)
        tag.append(f"{_SCHEME_KEYS[key]}{_g(value)}")
    name = "_".join(tag) + f"_h{_g(h)}_dt{_g(dt)}_T{_g(t_end)}"
    if mass != "consistent":
        name += f"_{mass}"
    return RunSpec(name=prefix + name, settings=settings)


# --------------------------------------------------------------------------- running

def _load_core() -> None:
    """Load the extension once in this process (before forking workers)."""
    from .core import fortran_version

    fortran_version()


def run_spec(spec: RunSpec, out_dir: str, clean: bool = True) -> dict[str, Any]:
    """Run one spec into out_dir (emptied first when ``clean``); never raises.

    Returns a record: name, out_dir, status ('ok' | 'unstable' | 'newton_failed' |
    'error'), message, steps, t_end_reached, wall_s (summary.json: the core's time loop),
    wall_measured_s (around :func:`dyncontact.run`, Python and trace reading included),
    newton_its_total, factorizations, dofs, elements, rows (trace rows).
    """
    from .core import run

    out_dir = os.path.abspath(out_dir)
    rec: dict[str, Any] = {"name": spec.name, "out_dir": out_dir, "status": "error",
                           "message": "", "steps": None, "t_end_reached": None,
                           "wall_s": None, "wall_measured_s": None,
                           "newton_its_total": None, "factorizations": None, "dofs": None,
                           "elements": None, "rows": 0, "settings": dict(spec.settings)}
    t0 = time.perf_counter()
    try:
        if clean and os.path.isdir(out_dir):
            shutil.rmtree(out_dir)
        scene = spec.scene()
        res = run(scene, out=out_dir, progress=False)
    except Exception as exc:  # noqa: BLE001 - a report never crashes on one run
        rec["message"] = f"{type(exc).__name__}: {exc}"
        rec["wall_measured_s"] = time.perf_counter() - t0
        return rec
    rec["wall_measured_s"] = time.perf_counter() - t0
    s = res.summary
    rec.update(status=res.status, message=res.message or str(s.get("message", "") or ""),
               steps=s.get("steps"), t_end_reached=s.get("t_end_reached"),
               wall_s=s.get("wall_s"), newton_its_total=s.get("newton_its_total"),
               factorizations=s.get("factorizations"), dofs=s.get("dofs"),
               elements=s.get("elements"), rows=int(len(res.trace.get("t", ()))),
               isa=s.get("isa"), solve_kernel=s.get("solve_kernel"))
    return rec


def _default_jobs() -> int:
    return max(1, os.cpu_count() or 1)


def run_many(specs: Sequence[RunSpec], runs_root: str, jobs: int | None = None,
             on_done: Callable[[dict[str, Any]], None] | None = None) -> list[dict[str, Any]]:
    """Run specs in parallel (a process pool of ``jobs`` workers, default: all cores),
    each into runs_root/<name>/, longest first. Returns the records in spec order."""
    names = [s.name for s in specs]
    if len(set(names)) != len(names):
        raise ValueError("run names must be unique")
    _load_core()
    order = sorted(range(len(specs)), key=lambda i: -specs[i].estimated_cost())
    records: list[dict[str, Any] | None] = [None] * len(specs)
    with cf.ProcessPoolExecutor(max_workers=jobs or _default_jobs()) as pool:
        futs = {pool.submit(run_spec, specs[i], os.path.join(runs_root, specs[i].name)): i
                for i in order}
        for fut in cf.as_completed(futs):
            rec = fut.result()
            records[futs[fut]] = rec
            if on_done is not None:
                on_done(rec)
    return [r for r in records if r is not None]


# --------------------------------------------------------------------------- figures

@dataclasses.dataclass
class FigureSpec:
    """One figure: its file, title, kind ('traces': the four panels, one curve per run;
    'snapshots': the deformed meshes of one run with fields) and its runs."""

    key: str
    png: str
    title: str
    kind: str
    runs: list[RunSpec]
    note: str = ""


HHT_FAMILY = (  # (scheme, params) of Figs. 2-4
    ("newmark", {"beta": 0.25, "gamma": 0.5}),
    ("hht", {"alpha": 0.0}),
    ("hht", {"alpha": -0.05}),
    ("hht", {"alpha": -0.1}),
    ("newmark", {"beta": 0.3025, "gamma": 0.6}),
)
PC_FAMILY = (  # (scheme, params) of Figs. 5-7
    ("pc", {"beta": 0.25, "gamma": 0.5}),
    ("pc_hht", {"alpha": -0.1}),
    # The seed's literal coefficients (γ = ½ + α < ½): the runs that go unstable after a
    # few impacts, as the seed reports; they stop early, so they cost little.
    ("pc_hht_seed", {"alpha": -0.1}),
)


def figure_plan(quick: bool = False) -> list[FigureSpec]:
    """The seed's Figures 1-7 (SPEC section 2, issue 4).

    Full: Fig. 1 trapezoidal rule (newmark ¼ ½), h = 0.02, Δt = 0.001, T = 3 with 11
    snapshots; Figs. 2-4 the HHT family at h = 0.05, 0.02, 0.01 (Δt = h/20, T = 15);
    Figs. 5-7 pc, pc_hht (α = -0.1) and pc_hht_seed (α = -0.1, the seed's literal
    coefficients) at the same meshes with Δt = h/100 and h/20.
    Quick (for the test suite): the same figures with h = 0.1 and 0.05 only (Figs. 4
    and 7 repeat h = 0.05), T = 3, Fig. 1 at h = 0.05, Δt = h/20.
    """
    if quick:
        meshes, t_end = (0.1, 0.05, 0.05), 3.0
        f1_h, f1_dt = 0.05, 0.0025
    else:
        meshes, t_end = (0.05, 0.02, 0.01), 15.0
        f1_h, f1_dt = 0.02, 0.001
    f1_t = 3.0
    f1_steps = math.ceil(f1_t / f1_dt - 1e-9)
    figs = [FigureSpec(
        key="fig1", png="fig1_field.png", kind="snapshots",
        title=f"Fig. 1: displacement over the first period, trapezoidal rule "
              f"(newmark β=0.25, γ=0.5), h={_g(f1_h)}, Δt={_g(f1_dt)}",
        runs=[seed_spec("newmark", f1_h, f1_dt, f1_t, beta=0.25, gamma=0.5,
                        fields_every=max(1, round(f1_steps / 10)), prefix="fields_")],
        note="VTU snapshots and the ParaView index: runs/{run}/fields.pvd")]
    for k, h in enumerate(meshes):
        dt = h / 20
        repeat = quick and k > 0 and h == meshes[k - 1]
        figs.append(FigureSpec(
            key=f"fig{2 + k}", png=f"fig{2 + k}_hht_family.png", kind="traces",
            title=f"Fig. {2 + k}: HHT family, h={_g(h)}, Δt=h/20={_g(dt)}, T={_g(t_end)}",
            runs=[seed_spec(s, h, dt, t_end, **p) for s, p in HHT_FAMILY],
            note="quick mode: the same mesh as the previous figure" if repeat else ""))
    for k, h in enumerate(meshes):
        repeat = quick and k > 0 and h == meshes[k - 1]
        runs = [seed_spec(s, h, h / div, t_end, **p)
                for div in (100, 20) for s, p in PC_FAMILY]
        figs.append(FigureSpec(
            key=f"fig{5 + k}", png=f"fig{5 + k}_predictor_corrector.png", kind="traces",
            title=f"Fig. {5 + k}: predictor-corrector, h={_g(h)}, Δt=h/100 and h/20, "
                  f"T={_g(t_end)}",
            runs=runs,
            note="quick mode: the same mesh as the previous figure" if repeat else ""))
    return figs


def plot_figure(fig: FigureSpec, runs_root: str, out_png: str) -> dict[str, Any]:
    """Draw one figure from its runs' folders (those that left a trace); never raises."""
    t0 = time.perf_counter()
    dirs = [os.path.join(runs_root, r.name) for r in fig.runs]
    dirs = [d for d in dirs if os.path.isfile(os.path.join(d, "trace.csv"))]
    try:
        if not dirs:
            raise RuntimeError("no run of this figure left a trace")
        from . import plotting

        if fig.kind == "snapshots":
            plotting.plot_field_snapshots(dirs[0], out_png, title=fig.title)
        else:
            plotting.plot_traces(dirs, out_png, title=fig.title)
    except Exception as exc:  # noqa: BLE001
        return {"key": fig.key, "ok": False, "message": f"{type(exc).__name__}: {exc}",
                "wall_s": time.perf_counter() - t0}
    return {"key": fig.key, "ok": True, "message": "", "wall_s": time.perf_counter() - t0}


def _fmt(x: Any, spec: str = ".3f", missing: str = "-") -> str:
    if x is None:
        return missing
    try:
        return format(float(x), spec)
    except (TypeError, ValueError):
        return str(x)


def _run_line(rec: Mapping[str, Any], k: int, n: int) -> str:
    t = rec.get("t_end_reached")
    extra = f" at t={_fmt(t, '.4g')}" if rec["status"] != "ok" and t is not None else ""
    msg = f" ({rec['message']})" if rec["status"] == "error" else ""
    return (f"[{k:>{len(str(n))}}/{n}] {rec['name']}: {rec['status']}{extra}, "
            f"{rec.get('steps') or 0} steps, {_fmt(rec.get('wall_s'), '.2f')} s{msg}")


def make_figures(out_root: str, quick: bool = False, jobs: int | None = None,
                 log: Callable[[str], None] | None = print) -> dict[str, Any]:
    """Run every figure's runs in parallel (runs into out_root/runs/<name>/), draw each
    figure as soon as its runs are done, and write out_root/index.md and index.json.

    Returns the report (also index.json): figures (key, png, title, runs' records, plot
    status), total wall_s, jobs, and the sum of the runs' wall times.
    """
    t_start = time.perf_counter()
    started = datetime.datetime.now().astimezone()
    load0 = _loadavg()
    out_root = os.path.abspath(out_root)
    runs_root = os.path.join(out_root, "runs")
    os.makedirs(runs_root, exist_ok=True)
    plan = figure_plan(quick)
    unique: dict[str, RunSpec] = {}
    for fig in plan:
        for r in fig.runs:
            if r.name in unique and unique[r.name].settings != r.settings:
                raise ValueError(f"two different runs named {r.name}")
            unique.setdefault(r.name, r)
    specs = sorted(unique.values(), key=lambda s: -s.estimated_cost())
    jobs = jobs or _default_jobs()
    _load_core()
    records: dict[str, dict[str, Any]] = {}
    plots: dict[str, dict[str, Any]] = {}
    waiting = {fig.key: {r.name for r in fig.runs} for fig in plan}
    by_key = {fig.key: fig for fig in plan}
    if log:
        log(f"figures: {len(specs)} runs for {len(plan)} figures on {jobs} worker(s) "
            f"-> {out_root}")
    # The workers run; this process draws each figure as soon as its runs are done
    # (matplotlib is imported once, here, and the drawing overlaps the longer runs).
    with cf.ProcessPoolExecutor(max_workers=jobs) as pool:
        pending = {pool.submit(run_spec, s, os.path.join(runs_root, s.name)): s.name
                   for s in specs}
        try:
            for fut in cf.as_completed(pending):
                name = pending[fut]
                try:
                    rec = fut.result()
                except Exception as exc:  # noqa: BLE001 - e.g. a worker that crashed
                    rec = {"name": name, "out_dir": os.path.join(runs_root, name),
                           "status": "error", "message": f"{type(exc).__name__}: {exc}",
                           "steps": None, "t_end_reached": None, "wall_s": None,
                           "wall_measured_s": None, "newton_its_total": None,
                           "factorizations": None, "dofs": None, "elements": None,
                           "rows": 0, "settings": dict(unique[name].settings)}
                records[name] = rec
                if log:
                    log(_run_line(rec, len(records), len(specs)))
                for key, names in waiting.items():
                    if name in names:
                        names.discard(name)
                        if not names:
                            fig = by_key[key]
                            plots[key] = plot_figure(fig, runs_root,
                                                     os.path.join(out_root, fig.png))
                            if log:
                                state = "written" if plots[key]["ok"] else \
                                    f"FAILED: {plots[key]['message']}"
                                log(f"figures: {fig.png} {state} "
                                    f"({plots[key]['wall_s']:.1f} s)")
        except BaseException:
            pool.shutdown(wait=False, cancel_futures=True)
            raise
    wall = time.perf_counter() - t_start
    report = {
        "quick": bool(quick),
        "started": started.isoformat(timespec="seconds"),
        "wall_s": wall,
        "jobs": jobs,
        "cpu_count": os.cpu_count(),
        "loadavg_start": load0,
        "loadavg_end": _loadavg(),
        "version": _version(),
        "runs_wall_sum_s": sum(float(r.get("wall_measured_s") or 0) for r in records.values()),
        "plots_wall_sum_s": sum(float(p.get("wall_s") or 0) for p in plots.values()),
        "figures": [],
        "runs": [records[s.name] for s in specs if s.name in records],
    }
    for fig in plan:
        report["figures"].append({
            "key": fig.key, "png": fig.png, "title": fig.title, "kind": fig.kind,
            "note": fig.note.format(run=fig.runs[0].name) if fig.note else "",
            "runs": [r.name for r in fig.runs],
            "plot": plots.get(fig.key, {"ok": False, "message": "not drawn"}),
        })
    write_index(out_root, report)
    if log:
        n_bad = sum(1 for f in report["figures"] if not f["plot"]["ok"])
        log(f"figures: {len(plan) - n_bad}/{len(plan)} figures, {len(specs)} runs in "
            f"{wall:.1f} s wall (runs: {report['runs_wall_sum_s']:.1f} s summed over "
            f"{jobs} worker(s)) -> {os.path.join(out_root, 'index.md')}")
    return report


def _loadavg() -> list[float] | None:
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except (AttributeError, OSError):
        return None


def _version() -> str:
    try:
        from . import __version__
    except ImportError:  # pragma: no cover
        return "unknown"
    return __version__


def _scheme_text(settings: Mapping[str, Any]) -> str:
    name = settings.get("scheme.name", "hht")
    params = [f"{sym}={_g(settings[f'scheme.{k}'])}"
              for k, sym in (("alpha", "α"), ("beta", "β"), ("gamma", "γ"), ("theta", "θ"))
              if f"scheme.{k}" in settings]
    text = name + (" " + ", ".join(params) if params else "")
    if settings.get("scheme.mass", "consistent") != "consistent":
        text += f", {settings['scheme.mass']} mass"
    return text


def write_index(out_root: str, report: Mapping[str, Any]) -> str:
    """out_root/index.md (figures, each run's status, steps and wall time, the total
    wall time and where it went) and out_root/index.json (the report). Returns the
    path of index.md."""
    recs = {r["name"]: r for r in report["runs"]}
    lines = [
        "# dyncontact: the seed's figures",
        "",
        f"Generated by `scripts/figures{' --quick' if report.get('quick') else ''}` on "
        f"{report.get('started', '?')} (dyncontact {report.get('version', '?')}).",
        "",
        f"**Total wall time: {report['wall_s']:.1f} s** for {len(recs)} runs and "
        f"{len(report['figures'])} figures on {report['jobs']} worker process(es) "
        f"({report.get('cpu_count')} cores; load average at start "
        f"{report.get('loadavg_start')}, at the end {report.get('loadavg_end')}). "
        f"Runs: {report['runs_wall_sum_s']:.1f} s summed over the runs "
        f"(each measured around `dyncontact.run`); plots: "
        f"{report.get('plots_wall_sum_s', 0.0):.1f} s summed.",
        "",
        "Status `unstable`: the run tripped `&scheme blowup` and stopped (SPEC §4); its "
        "curve ends there, marked with an x and a dotted vertical line.",
        "",
    ]
    for fig in report["figures"]:
        lines += [f"## {fig['title']}", ""]
        if fig["plot"]["ok"]:
            lines += [f"![{fig['key']}]({fig['png']})", ""]
        else:
            lines += [f"**Figure not drawn:** {fig['plot'].get('message', '')}", ""]
        if fig.get("note"):
            lines += [fig["note"], ""]
        lines += ["| run | scheme | Δt | status | steps | t reached | wall s (core) | "
                  "wall s (total) | Newton its | folder |",
                  "|---|---|---|---|---:|---:|---:|---:|---:|---|"]
        for name in fig["runs"]:
            r = recs.get(name)
            if r is None:
                lines.append(f"| {name} | | | not run | | | | | | |")
                continue
            st = r["status"] if r["status"] != "error" else f"error: {r['message']}"
            lines.append(
                f"| {name} | {_scheme_text(r['settings'])} | "
                f"{_g(r['settings'].get('scheme.dt', 0))} | {st} | {r.get('steps') or 0} | "
                f"{_fmt(r.get('t_end_reached'), '.4g')} | {_fmt(r.get('wall_s'), '.2f')} | "
                f"{_fmt(r.get('wall_measured_s'), '.2f')} | "
                f"{r.get('newton_its_total') if r.get('newton_its_total') is not None else '-'}"
                f" | [runs/{name}](runs/{name}) |")
        lines.append("")
    lines += ["## Where the time goes", "",
              "Runs by wall time (core time loop from summary.json; total = around "
              "`dyncontact.run`, model set-up and trace reading included):", "",
              "| run | dofs | steps | wall s (core) | wall s (total) | µs/step |",
              "|---|---:|---:|---:|---:|---:|"]
    for r in sorted(report["runs"], key=lambda r: -(r.get("wall_measured_s") or 0)):
        us = (1e6 * float(r["wall_s"]) / r["steps"]) if r.get("wall_s") and r.get("steps") \
            else None
        lines.append(f"| {r['name']} | {r.get('dofs') or '-'} | {r.get('steps') or 0} | "
                     f"{_fmt(r.get('wall_s'), '.2f')} | {_fmt(r.get('wall_measured_s'), '.2f')}"
                     f" | {_fmt(us, '.1f')} |")
    lines.append("")
    path = os.path.join(out_root, "index.md")
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(lines))
    with open(os.path.join(out_root, "index.json"), "w", encoding="utf-8") as f:
        json.dump(report, f, indent=1, default=str)
    return path


def figures_main(argv: Sequence[str] | None = None, root: str | None = None) -> int:
    """``scripts/figures [--quick] [--jobs N] [--out DIR]``: 0 when every figure was
    drawn (unstable runs are results, not failures), 1 otherwise, 130 on Ctrl-C."""
    root = root or os.getcwd()
    p = argparse.ArgumentParser(prog="scripts/figures", description="Regenerate the "
                                "seed's Figures 1-7 (runs in parallel) and index.md.")
    p.add_argument("--quick", action="store_true", help="h = 0.1 and 0.05, T = 3 (tests)")
    p.add_argument("--jobs", "-j", type=int, default=None,
                   help=f"worker processes (default: all cores, {_default_jobs()})")
    p.add_argument("--out", default=None, help="output folder (default: ROOT/out/figures)")
    args = p.parse_args(argv)
    if args.jobs is not None and args.jobs < 1:
        p.error("--jobs must be >= 1")
    out = args.out or os.path.join(root, "out", "figures")
    try:
        report = make_figures(out, quick=args.quick, jobs=args.jobs,
                              log=lambda s: print(s, flush=True))
    except KeyboardInterrupt:
        print("figures: interrupted", file=sys.stderr)
        return 130
    bad = [f["key"] for f in report["figures"] if not f["plot"]["ok"]]
    errors = [r["name"] for r in report["runs"] if r["status"] == "error"]
    if bad or errors:
        print(f"figures: not drawn: {', '.join(bad) or '-'}; runs that failed to run: "
              f"{', '.join(errors) or '-'}", file=sys.stderr)
        return 1
    return 0


# --------------------------------------------------------------------------- bench

#: The core's timing helper of the floors (bench prints 'n/a' when it is missing; it is
#: reached through :func:`dyncontact.core.bench_floors`).
FLOOR_API = "dc_bench_floor"


def floor_api_available() -> bool:
    """Whether the core has the timing helper of the floors."""
    from .core import bench_floors_available

    return bench_floors_available()


def bench_specs(quick: bool = False, only: Iterable[str] | None = None) -> list[RunSpec]:
    """The benchmark's rows: the seed scene (hht α = 0, Δt = h/20, T = 15) at h = 0.05,
    0.02, 0.01 and pc (Δt = h/100, consistent and lumped mass) at the same meshes, with
    the scene's default output (every = 1). ``only``: row names to keep (fnmatch
    patterns allowed)."""
    import fnmatch

    meshes = (0.05,) if quick else (0.05, 0.02, 0.01)
    specs = []
    for h in meshes:
        s = seed_spec("hht", h, h / 20, 15.0, max_rows=None, alpha=0.0)
        s.name = f"seed_h{_g(h)}"
        specs.append(s)
    # the same bar with no contact boundary: every step contact-free (one solve each)
    s = seed_spec("hht", meshes[-1], meshes[-1] / 20, 15.0, max_rows=None, alpha=0.0)
    s.settings["boundary.contact"] = ""
    s.name = f"seed_free_h{_g(meshes[-1])}"
    specs.append(s)
    for h in meshes:
        for mass in ("consistent", "lumped"):
            s = seed_spec("pc", h, h / 100, 15.0, max_rows=None, mass=mass, beta=0.25,
                          gamma=0.5)
            s.name = f"pc_h{_g(h)}_{mass}"
            specs.append(s)
    if only:
        pats = [p for item in only for p in item.split(",") if p]
        specs = [s for s in specs if any(fnmatch.fnmatchcase(s.name, p) for p in pats)]
    return specs


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
    us_per_step / floor_us), chunk_ratios, steps and status. Never raises."""
    from .core import NumericalError, Stepper

    rec: dict[str, Any] = {"scene": spec.name, "status": "error", "message": "",
                           "steps": 0, "us_per_step": None, "floor_us": None,
                           "floor_ratio": None, "floor_cholmod_ratio": None,
                           "chunk_ratios": []}
    keys = ("floor_solve_us", "floor_spmv_us", "floor_mass_solve_us",
            "floor_cholmod_solve_us")
    names = ("solve_us", "spmv_us", "mass_solve_us", "cholmod_solve_us")
    try:
        if os.path.isdir(out_dir):
            shutil.rmtree(out_dir)
        with Stepper(spec.scene(), out_dir) as run:
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
    chol_floors = [_step_floor(dict(p, scene=spec.name), cholmod=True) for p in per]
    if all(f is not None for f in chol_floors):
        rec["floor_cholmod_ratio"] = 1e6 * seconds / sum(
            d * f for (d, _), f in zip(stretches, chol_floors))
    step_floors = [_step_floor(dict(p, scene=spec.name)) for p in per]
    if any(f is None for f in step_floors):
        return rec
    spent = sum(d * f for (d, _), f in zip(stretches, step_floors))   # µs
    rec["floor_us"] = spent / steps
    rec["floor_ratio"] = 1e6 * seconds / spent
    rec["chunk_ratios"] = [1e6 * t / (d * f) for (d, t), f in zip(stretches, step_floors)]
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
    full = run_spec(spec, os.path.join(out_root, spec.name))
    sparse = dataclasses.replace(spec, settings=dict(spec.settings,
                                                     **{"output.every": sparse_every}))
    light = run_spec(sparse, os.path.join(out_root, f"{spec.name}_every{sparse_every}"))
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
        "scheme": _scheme_text(spec.settings),
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
        "isa": full.get("isa"),
        "solve_kernel": full.get("solve_kernel"),
        "loadavg": _loadavg(),
        "repeat": repeat,
        "runs": runs,
        "floor_ratio_min": min(ratios) if ratios else None,
        "floor_ratio_max": max(ratios) if ratios else None,
    }
    row.update({k: v for k, v in runs[pick].items()
                if k not in ("scene", "status", "message", "steps", "chunk_ratios")})
    row["chunk_ratios"] = runs[pick]["chunk_ratios"]
    return row


def _step_floor(row: Mapping[str, Any], cholmod: bool = False) -> float | None:
    """The floor of one step (issue 10): one solve + one SpMV with K_θ for the implicit
    scheme, two M⁻¹ applications + two SpMVs for the predictor-corrector. ``cholmod``:
    the implicit scheme's floor with cholmod_solve2 on the same factor as its solve (the
    floor the issue's budget was first measured with); None for the predictor-corrector."""
    spmv = row.get("floor_spmv_us")
    if str(row.get("scene", "")).startswith("seed"):
        solve = row.get("floor_cholmod_solve_us" if cholmod else "floor_solve_us")
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
    ("status", "status", "s"),
)


def _cell(row: Mapping[str, Any], key: str, fmt: str) -> str:
    if key == "floor_ratio_range":
        lo, hi = row.get("floor_ratio_min"), row.get("floor_ratio_max")
        return f"{lo:.2f}-{hi:.2f}" if lo is not None and hi is not None else "-"
    v = row.get(key)
    if key.startswith("floor_"):
        implicit = str(row.get("scene", "")).startswith("seed")
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


def bench_main(argv: Sequence[str] | None = None, root: str | None = None) -> int:
    """``scripts/bench [--quick] [--only NAME[,NAME]] [--out FILE.json]``: runs one after
    another, prints the table, writes the JSON. Exit 0 unless a run could not run at all
    (a benchmark never fails on time)."""
    root = root or os.getcwd()
    p = argparse.ArgumentParser(prog="scripts/bench", description="Benchmark the seed "
                                "scene and the predictor-corrector runs; prints a table "
                                "and writes it as JSON.")
    p.add_argument("--quick", action="store_true", help="only the h = 0.05 rows")
    p.add_argument("--only", action="append", metavar="NAME",
                   help="rows to run (names as in the table; fnmatch patterns, "
                   "comma-separated; repeatable)")
    p.add_argument("--out", default=None, help="JSON file (default: ROOT/out/bench.json)")
    p.add_argument("--runs", default=None,
                   help="folder of the runs' outputs (default: ROOT/out/bench)")
    p.add_argument("--repeat", type=int, default=3, metavar="N",
                   help="interleaved runs of each row (floors measured between "
                   "stretches of its steps); the table shows the median ratio (default 3)")
    args = p.parse_args(argv)
    specs = bench_specs(quick=args.quick, only=args.only)
    if not specs:
        names = ", ".join(s.name for s in bench_specs())
        print(f"bench: no row matches --only {args.only} (rows: {names})", file=sys.stderr)
        return 2
    out_json = args.out or os.path.join(root, "out", "bench.json")
    runs_root = args.runs or os.path.join(root, "out", "bench")
    _load_core()
    load = _loadavg()
    print(f"bench: {len(specs)} rows, one run after another (load average {load}, "
          f"{os.cpu_count()} cores); floors: "
          f"{'measured' if floor_api_available() else 'n/a (the core has no ' + FLOOR_API + ')'}",
          flush=True)
    if load and load[0] > 0.5 * (os.cpu_count() or 1):
        print("bench: warning: the machine is busy, timings are inflated", flush=True)
    rows = []
    t0 = time.perf_counter()
    try:
        for spec in specs:
            row = bench_row(spec, runs_root, repeat=args.repeat)
            rows.append(row)
            print(f"bench: {row['scene']}: {row['status']}, {row['steps']} steps, "
                  f"{_fmt(row['wall_s'], '.3f')} s ({_fmt(row['wall_s_sparse'], '.3f')} s "
                  f"with every=100)", flush=True)
    except KeyboardInterrupt:
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
          "CHOLMOD µs in place of solve µs in the floor.")
    isas = sorted({str(r.get("isa")) for r in rows if r.get("isa")})
    if isas:
        print(f"core built for: {', '.join(isas)} (meson option simd; see meson.options)")
    doc = {
        "generated": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
        "version": _version(),
        "machine": {"cpu_count": os.cpu_count(), "platform": platform.platform(),
                    "python": platform.python_version(), "loadavg_start": load,
                    "loadavg_end": _loadavg()},
        "floor_api": FLOOR_API if floor_api_available() else None,
        "isa": isas,
        "total_wall_s": time.perf_counter() - t0,
        "columns": {k: h for h, k, _ in _BENCH_COLUMNS},
        "rows": rows,
    }
    folder = os.path.dirname(os.path.abspath(out_json))
    os.makedirs(folder, exist_ok=True)
    with open(out_json, "w", encoding="utf-8") as f:
        json.dump(doc, f, indent=1)
    print(f"bench: wrote {out_json}")
    return 0 if all(r["status"] != "error" for r in rows) else 1
