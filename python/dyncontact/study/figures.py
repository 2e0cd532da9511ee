"""The seed's Figures 1-7 (``scripts/figures``), run on the studies' sweep runner.

``scripts/figures`` is a thin wrapper of :func:`figures_main`; everything it does is
here, reusable from Python:

>>> from dyncontact.study import figures
>>> plan = figures.figure_plan(quick=True)                      # what scripts/figures runs
>>> report = figures.make_figures("out/figures", quick=True)   # doctest: +SKIP
>>> report["figures"][0]["png"], report["wall_s"]               # doctest: +SKIP

Each run is a :class:`.common.RunSpec` (a name and the keys it changes in the seed's
default scene). The runs go through :func:`.sweep.sweep` with the ``outputs`` analysis:
the local process pool (``--workers``) or a Dask cluster (``--scheduler``), and the
per-run cache (``--cache``, default OUT/cache), so that a second ``scripts/figures``
redraws from the cache what has not changed. Each run's outputs are copied from its cache
entry into OUT/runs/<name>/, where the figures and index.md take them from; each figure
is drawn as soon as its runs are done.
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import json
import math
import os
import shutil
import sys
import time
from typing import Any, Callable, Mapping, Sequence

from .common import (MAX_ROWS, RunSpec, add_runner_options, fmt, loadavg, num,
                     package_version, scheme_text, seed_spec)
from .sweep import ERROR, REFUSED, sweep

__all__ = ["FigureSpec", "figure_plan", "make_figures", "plot_figure", "write_index",
           "figures_main", "MAX_ROWS", "HHT_FAMILY", "PC_FAMILY"]


# --------------------------------------------------------------------------- the plan

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
    """The seed's Figures 1-7 (SPEC section 2).

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
              f"(newmark β=0.25, γ=0.5), h={num(f1_h)}, Δt={num(f1_dt)}",
        runs=[seed_spec("newmark", f1_h, f1_dt, f1_t, beta=0.25, gamma=0.5,
                        fields_every=max(1, round(f1_steps / 10)), prefix="fields_")],
        note="VTU snapshots and the ParaView index: runs/{run}/fields.pvd")]
    for k, h in enumerate(meshes):
        dt = h / 20
        repeat = quick and k > 0 and h == meshes[k - 1]
        figs.append(FigureSpec(
            key=f"fig{2 + k}", png=f"fig{2 + k}_hht_family.png", kind="traces",
            title=f"Fig. {2 + k}: HHT family, h={num(h)}, Δt=h/20={num(dt)}, T={num(t_end)}",
            runs=[seed_spec(s, h, dt, t_end, **p) for s, p in HHT_FAMILY],
            note="quick mode: the same mesh as the previous figure" if repeat else ""))
    for k, h in enumerate(meshes):
        repeat = quick and k > 0 and h == meshes[k - 1]
        runs = [seed_spec(s, h, h / div, t_end, **p)
                for div in (100, 20) for s, p in PC_FAMILY]
        figs.append(FigureSpec(
            key=f"fig{5 + k}", png=f"fig{5 + k}_predictor_corrector.png", kind="traces",
            title=f"Fig. {5 + k}: predictor-corrector, h={num(h)}, Δt=h/100 and h/20, "
                  f"T={num(t_end)}",
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
        from .. import plotting

        if fig.kind == "snapshots":
            plotting.plot_field_snapshots(dirs[0], out_png, title=fig.title)
        else:
            plotting.plot_traces(dirs, out_png, title=fig.title)
    except Exception as exc:  # noqa: BLE001
        return {"key": fig.key, "ok": False, "message": f"{type(exc).__name__}: {exc}",
                "wall_s": time.perf_counter() - t0}
    return {"key": fig.key, "ok": True, "message": "", "wall_s": time.perf_counter() - t0}


# --------------------------------------------------------------------------- the runs

def _run_line(rec: Mapping[str, Any], k: int, n: int) -> str:
    t = rec.get("t_end_reached")
    extra = f" at t={fmt(t, '.4g')}" if rec["status"] != "ok" and t is not None else ""
    msg = f" ({rec['message']})" if rec["status"] in (ERROR, REFUSED) else ""
    cached = " (cache)" if rec.get("cached") else ""
    return (f"[{k:>{len(str(n))}}/{n}] {rec['name']}: {rec['status']}{extra}, "
            f"{rec.get('steps') or 0} steps, {fmt(rec.get('wall_s'), '.2f')} s{cached}{msg}")


def _relocate(entry: str, folder: str) -> None:
    """Copy a cache entry's run outputs into folder (emptied first); the copy's
    summary.json names folder as its output.dir, where the run's outputs now are."""
    if os.path.isdir(folder):
        shutil.rmtree(folder)
    shutil.copytree(entry, folder, ignore=shutil.ignore_patterns("record.json",
                                                                  "arrays.npz"))
    path = os.path.join(folder, "summary.json")
    if not os.path.isfile(path):
        return
    with open(path, encoding="utf-8") as f:
        text = f.read()
    try:
        old = json.loads(text)["scene"]["output"]["dir"]
    except (ValueError, KeyError, TypeError):
        return
    new = text.replace(json.dumps(old), json.dumps(folder))
    if new != text:
        with open(path, "w", encoding="utf-8") as f:
            f.write(new)


def _figure_record(spec: RunSpec, rec: Mapping[str, Any], out_dir: str) -> dict[str, Any]:
    """The index's record of a figure run, from the sweep's record."""
    m = rec.get("metrics") or {}
    out = {"name": spec.name, "out_dir": out_dir, "status": rec["status"],
           "message": rec.get("message") or "", "steps": rec.get("steps"),
           "t_end_reached": rec.get("t_end_reached"), "wall_s": rec.get("wall_s"),
           "wall_measured_s": rec.get("wall_measured_s"),
           "newton_its_total": rec.get("newton_its_total"),
           "factorizations": m.get("factorizations"), "dofs": m.get("dofs"),
           "elements": m.get("elements"), "rows": m.get("rows", 0),
           "settings": dict(spec.settings)}
    if m:
        out.update(isa=m.get("isa"), solve_kernel=m.get("solve_kernel"))
    out["cached"] = bool(rec.get("cached"))
    return out


def make_figures(out_root: str, quick: bool = False, workers: int | None = None,
                 scheduler: Any = None, cache: str | None = None,
                 log: Callable[[str], None] | None = print) -> dict[str, Any]:
    """Run every figure's runs on the sweep runner (``workers`` processes, default all
    cores, or the Dask ``scheduler``; cached in ``cache``, default out_root/cache), copy
    each run's outputs into out_root/runs/<name>/, draw each figure as soon as its runs
    are done, and write out_root/index.md and index.json.

    Returns the report (also index.json): figures (key, png, title, runs' records, plot
    status), total wall_s, jobs (the local pool's processes; None on Dask), and the sum
    of the runs' wall times.
    """
    t_start = time.perf_counter()
    started = datetime.datetime.now().astimezone()
    load0 = loadavg()
    out_root = os.path.abspath(out_root)
    runs_root = os.path.join(out_root, "runs")
    os.makedirs(runs_root, exist_ok=True)
    cache = os.path.abspath(cache or os.path.join(out_root, "cache"))
    plan = figure_plan(quick)
    unique: dict[str, RunSpec] = {}
    for fig in plan:
        for r in fig.runs:
            if r.name in unique and unique[r.name].settings != r.settings:
                raise ValueError(f"two different runs named {r.name}")
            unique.setdefault(r.name, r)
    specs = list(unique.values())
    jobs = None if scheduler is not None else (workers or os.cpu_count() or 1)
    records: dict[str, dict[str, Any]] = {}
    plots: dict[str, dict[str, Any]] = {}
    waiting = {fig.key: {r.name for r in fig.runs} for fig in plan}
    by_key = {fig.key: fig for fig in plan}
    if log:
        where = f"the Dask scheduler {scheduler}" if jobs is None else f"{jobs} worker(s)"
        log(f"figures: {len(specs)} runs for {len(plan)} figures on {where} -> {out_root}")

    # This process copies each run out of the cache and draws each figure as soon as its
    # runs are done (matplotlib is imported once, here; the drawing overlaps the runs).
    def done(i: int, rec: dict[str, Any]) -> None:
        spec = specs[i]
        out_dir = os.path.join(runs_root, spec.name)
        if rec.get("run_dir"):
            _relocate(rec["run_dir"], out_dir)
        records[spec.name] = _figure_record(spec, rec, out_dir)
        if log:
            log(_run_line(records[spec.name], len(records), len(specs)))
        for key, names in waiting.items():
            if spec.name in names:
                names.discard(spec.name)
                if not names:
                    fig = by_key[key]
                    plots[key] = plot_figure(fig, runs_root, os.path.join(out_root, fig.png))
                    if log:
                        state = "written" if plots[key]["ok"] else \
                            f"FAILED: {plots[key]['message']}"
                        log(f"figures: {fig.png} {state} ({plots[key]['wall_s']:.1f} s)")

    sweep([s.task() for s in specs], cache, workers=workers, scheduler=scheduler,
          progress=False, desc="figures", log=log, on_done=done)
    wall = time.perf_counter() - t_start
    report = {
        "quick": bool(quick),
        "started": started.isoformat(timespec="seconds"),
        "wall_s": wall,
        "jobs": jobs,
        "cpu_count": os.cpu_count(),
        "loadavg_start": load0,
        "loadavg_end": loadavg(),
        "version": package_version(),
        "runs_wall_sum_s": sum(float(r.get("wall_measured_s") or 0) for r in records.values()),
        "plots_wall_sum_s": sum(float(p.get("wall_s") or 0) for p in plots.values()),
        "figures": [],
        "runs": [records[s.name] for s in sorted(specs, key=lambda s: s.name)
                 if s.name in records],
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
        n_cached = sum(1 for r in records.values() if r["cached"])
        log(f"figures: {len(plan) - n_bad}/{len(plan)} figures, {len(specs)} runs "
            f"({n_cached} from the cache) in {wall:.1f} s wall (runs: "
            f"{report['runs_wall_sum_s']:.1f} s summed) -> "
            f"{os.path.join(out_root, 'index.md')}")
    return report


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
        f"{len(report['figures'])} figures on "
        f"{_where(report)} "
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
            st = f"{r['status']}: {r['message']}" if r["status"] in (ERROR, REFUSED) \
                else r["status"]
            lines.append(
                f"| {name} | {scheme_text(r['settings'])} | "
                f"{num(r['settings'].get('scheme.dt', 0))} | {st} | {r.get('steps') or 0} | "
                f"{fmt(r.get('t_end_reached'), '.4g')} | {fmt(r.get('wall_s'), '.2f')} | "
                f"{fmt(r.get('wall_measured_s'), '.2f')} | "
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
                     f"{fmt(r.get('wall_s'), '.2f')} | {fmt(r.get('wall_measured_s'), '.2f')}"
                     f" | {fmt(us, '.1f')} |")
    lines.append("")
    path = os.path.join(out_root, "index.md")
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(lines))
    with open(os.path.join(out_root, "index.json"), "w", encoding="utf-8") as f:
        json.dump(report, f, indent=1, default=str)
    return path


def _where(report: Mapping[str, Any]) -> str:
    jobs = report.get("jobs")
    return "a Dask cluster" if jobs is None else f"{jobs} worker process(es)"


def figures_main(argv: Sequence[str] | None = None, root: str | None = None) -> int:
    """``scripts/figures [--quick] [--workers N] [--scheduler ADDRESS] [--cache DIR]
    [--out DIR]`` (the runner's options as ``dyncontact study`` takes them): 0 when every figure was drawn (unstable runs are results, not
    failures), 1 otherwise, 2 on a bad command line, 130 on Ctrl-C."""
    root = root or os.getcwd()
    p = argparse.ArgumentParser(prog="scripts/figures", description="Regenerate the "
                                "seed's Figures 1-7 (runs in parallel) and index.md.")
    p.add_argument("--quick", action="store_true", help="h = 0.1 and 0.05, T = 3 (tests)")
    add_runner_options(p, "--jobs", "-j")
    p.add_argument("--out", default=None, help="output folder (default: ROOT/out/figures)")
    args = p.parse_args(argv)
    if args.workers is not None and args.workers < 1:
        p.error("--workers must be >= 1")
    out = args.out or os.path.join(root, "out", "figures")
    try:
        report = make_figures(out, quick=args.quick, workers=args.workers,
                              scheduler=args.scheduler, cache=args.cache,
                              log=lambda s: print(s, flush=True))
    except KeyboardInterrupt:
        print("figures: interrupted (finished runs are cached; run the same command "
              "again to resume)", file=sys.stderr)
        return 130
    bad = [f["key"] for f in report["figures"] if not f["plot"]["ok"]]
    errors = [r["name"] for r in report["runs"] if r["status"] in (ERROR, REFUSED)]
    if bad or errors:
        print(f"figures: not drawn: {', '.join(bad) or '-'}; runs that failed to run: "
              f"{', '.join(errors) or '-'}", file=sys.stderr)
        return 1
    return 0
