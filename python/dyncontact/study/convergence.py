"""``study convergence``: errors of every scheme against the 1D closed form.

Case: the 1D exact case (SPEC section 2), h in {1/25, ..., 1/400}, dt = h/c with c = 20
(implicit) and 100 (predictor-corrector) by default, and central differences at its own
c = 4 (about half its critical step), T = 3 (one period: flight, impact,
contact, release). Norms (see :mod:`.analyses`): L-infinity(0,T; L2) and
L-infinity(0,T; H1) of u, L-infinity(0,T; L2) of u_t, their L2(0,T) counterparts, and
L2(0,T) of the contact stress at x = 0: absolute norms of u_h - u, and beside them
(suffix ``_rel``) the relative norms the literature reports (GetFEM's 1D demo): the
error against the nodal interpolant of u at every step divided by the interpolant's
norm of the same kind, L2 in time by the rectangle rule.

Each run is stepped in memory (:func:`.analyses.run_exact1d`; no field is written to
disk). The absolute field norms are sampled every k steps with k = round(SNAP_DT / dt):
the same time grid (spacing SNAP_DT = 1/50, 151 samples over T = 3) for every h, so the
time norms of all runs are computed on the same points. The relative norms and the
stress norms use every step.

The 3D rows (:func:`box3d_rows`): the box [0, 0.1]^2 x [0, 1] of P1 tetrahedra
(&mesh dim = 3) with E = 1, nu = 0, whose exact solution is the 1D bar's (the lateral
faces carry no traction): its probe (the centre of the bottom face) against the closed
form, u_n, v_n, p_n and the energy per unit cross-section, beside the 1D bar at the same
h, dt and scheme, both measured by the same code (:func:`probe_errors`).
"""

from __future__ import annotations

import os
import time
from typing import Any

import numpy as np

from . import analyses  # noqa: F401 - registers the analyses
from .common import (fmt, md_table, new_figure, save_figure, scheme_list, slope,
                     step_ratio, study_folder, ticks_at, write_csv, write_markdown,
                     PENALTY_GAMMA0)
from .analyses import FIELD_NORMS, REL_NORMS
from .sweep import make_task, sweep

__all__ = ["run_convergence", "DEFAULT_SCHEMES", "FULL_NS", "QUICK_NS", "box3d_rows",
           "probe_errors", "BOX3D_SCHEMES", "BOX3D_NS", "BOX3D_QUICK_NS", "BOX3D_COLUMNS"]

DEFAULT_SCHEMES = ("newmark", "hht-0.05", "hht-0.1", "theta0.5", "theta1", "pc",
                   "pc_hht-0.1",
                   # beyond the seed: generalized-alpha, central differences (lumped, dt = h/4),
                   # penalty (gamma0 = 10), the redistributed mass
                   "galpha1", "galpha0.8", "galpha0.5", "central_lumped", "newmark_penalty",
                   "newmark_redist", "hht-0.1_redist")
FULL_NS = (25, 50, 100, 200, 400)
QUICK_NS = (25, 50, 100)
SNAP_DT = 1.0 / 50.0
#: The 3D rows: schemes and 1/h (h must divide the box's width 0.1 and length 1).
BOX3D_SCHEMES = ("newmark", "hht-0.1")
BOX3D_NS = (20, 40)
BOX3D_QUICK_NS = (20,)
#: The box's cross-section: the 1D closed form's energy 1/8 is per unit cross-section.
BOX3D_WIDTH = 0.1
#: Columns of the 3D rows (convergence_3d.csv).
BOX3D_COLUMNS = ("err_u_n", "err_v_n", "err_p_n", "p_L2", "p_L2_rel", "err_e_total",
                 "max_err_u_n", "e_end_ratio")
NORM_LABELS = {
    "u_Linf_L2": "L∞(0,T; L²) of u", "u_Linf_H1": "L∞(0,T; H¹) of u",
    "v_Linf_L2": "L∞(0,T; L²) of u̇", "u_L2_L2": "L²(0,T; L²) of u",
    "u_L2_H1": "L²(0,T; H¹) of u", "v_L2_L2": "L²(0,T; L²) of u̇",
    "p_L2": "L²(0,T) of the contact stress at x=0",
}


def convergence_tasks(base: str, schemes, ns, c_implicit: float, c_explicit: float,
                      t_end: float, snap_dt: float = SNAP_DT):
    tasks = []
    for s in schemes:
        c = step_ratio(s, c_implicit, c_explicit)
        for n in ns:
            h = 1.0 / n
            dt = h / c
            k = max(1, int(round(snap_dt / dt)))
            settings = dict(s.settings)
            settings.update({"mesh.h": h, "scheme.dt": dt, "scheme.t_end": t_end,
                             "output.every": 1, "output.fields_every": 0})
            tasks.append(make_task(base, settings, "exact1d", {"snap_every": k},
                                   tags={"scheme": s.key, "label": s.label, "n": n, "h": h,
                                         "dt": dt, "c": c, "k": k}))
    return tasks


def run_convergence(out: str, *, quick: bool = False, schemes: str | None = None,
                    c_implicit: float = 20.0, c_explicit: float = 100.0,
                    t_end: float = 3.0, ns=None, cache: str | None = None,
                    workers: int | None = None, scheduler: Any = None,
                    progress: bool | None = None, log=print) -> dict[str, Any]:
    """Run the study, write convergence.csv, orders.csv, convergence.png and summary.md
    into ``out``; returns the report (rows, orders, paths, n_runs, wall_s)."""
    t0 = time.perf_counter()
    out, cache, bases = study_folder(out, cache)
    base = bases["exact1d"]
    sch = scheme_list(DEFAULT_SCHEMES if schemes is None else schemes)
    ns = tuple(ns or (QUICK_NS if quick else FULL_NS))
    tasks = convergence_tasks(base, sch, ns, c_implicit, c_explicit, t_end)
    recs = sweep(tasks, cache, workers=workers, scheduler=scheduler, progress=progress,
                 desc="convergence", log=log)
    rows = []
    for r in recs:
        tg = dict(r["task"].tags)
        row = {k: tg[k] for k in ("scheme", "n", "h", "dt", "c", "k")}
        m = r.get("metrics", {})
        row.update(status=r["status"], t_end_reached=r.get("t_end_reached"),
                   steps=r.get("steps"), snapshots=m.get("snapshots"),
                   rel_steps=m.get("rel_steps"))
        for norm in FIELD_NORMS + REL_NORMS:
            row[norm] = m.get(norm)
        row.update(err_u_n=m.get("err_u_n"), err_v_n=m.get("err_v_n"),
                   e_end_ratio=m.get("e_end_ratio"), message=_first(r.get("message")))
        rows.append(row)
    cols = ["scheme", "n", "h", "dt", "c", "k", "status", "t_end_reached", "steps",
            "snapshots", "rel_steps", *FIELD_NORMS, *REL_NORMS, "err_u_n", "err_v_n", "e_end_ratio",
            "message"]
    csv_path = write_csv(os.path.join(out, "convergence.csv"), rows, cols)
    orders = []
    for s in sch:
        mine = [r for r in rows if r["scheme"] == s.key and r["status"] == "ok"]
        hs = [r["h"] for r in mine]
        for norm in FIELD_NORMS:
            ys = [r[norm] if r[norm] is not None else float("nan") for r in mine]
            last = slope(hs[-2:], ys[-2:]) if len(hs) >= 2 else float("nan")
            orders.append({"scheme": s.key, "norm": norm, "order_fit": slope(hs, ys),
                           "order_last": last, "runs_ok": len(mine),
                           "runs": sum(1 for r in rows if r["scheme"] == s.key)})
    ord_path = write_csv(os.path.join(out, "orders.csv"), orders,
                         ["scheme", "norm", "order_fit", "order_last", "runs_ok", "runs"])
    png = _plot(rows, sch, os.path.join(out, "convergence.png"), t_end=t_end,
                c_implicit=c_implicit, c_explicit=c_explicit)
    # the 3D rows for the study's schemes among BOX3D_SCHEMES
    box_schemes = [k for k in BOX3D_SCHEMES if k in {s.key for s in sch}]
    box = box3d_rows(out, base, c_implicit=c_implicit, t_end=t_end,
                     ns=BOX3D_QUICK_NS if quick else BOX3D_NS, schemes=box_schemes,
                     cache=cache, workers=workers, scheduler=scheduler, progress=progress,
                     log=log) if box_schemes else None
    recs = list(recs) + (box["records"] if box else [])
    report = {"rows": rows, "orders": orders, "csv": csv_path, "orders_csv": ord_path,
              "png": png, "n_runs": len(recs),
              "n_cached": sum(r["cached"] for r in recs), "box3d": box,
              "n_errors": sum(r["status"] == "error" for r in recs),
              "wall_s": time.perf_counter() - t0, "ns": ns, "t_end": t_end,
              "c_implicit": c_implicit, "c_explicit": c_explicit, "quick": quick}
    report["summary"] = _summary(report, sch, os.path.join(out, "summary.md"))
    return report


def _first(msg):
    return msg.splitlines()[0] if msg else ""


# --------------------------------------------------------------------------- 3D rows

def probe_errors(trace: dict[str, np.ndarray], area: float = 1.0) -> dict[str, float]:
    """Errors of a run's probe trace against the 1D closed form: RMS in time of u_n, v_n,
    p_n and of the energy per unit cross-section (e_total / ``area``) relative to 1/8;
    p_L2 and p_L2_rel as the 1D rows (:mod:`.analyses`); max |u_n - exact|; and
    e_total(T) / e_total(0)."""
    from .. import exact1d as ex
    from .analyses import relative_in_time, rms_in_time

    t = np.asarray(trace["t"], dtype=float)
    sigma = ex.sigma_n(t)
    e = np.asarray(trace["e_total"], dtype=float) / area
    dp = np.asarray(trace["p_n"]) - sigma
    return {"err_u_n": rms_in_time(t, trace["u_n"] - ex.u_n(t)),
            "err_v_n": rms_in_time(t, trace["v_n"] - ex.v_n(t)),
            "err_p_n": rms_in_time(t, dp),
            "p_L2": float(np.sqrt(np.trapezoid(dp ** 2, t))) if len(t) > 1 else float("nan"),
            "p_L2_rel": relative_in_time(np.abs(dp), np.abs(sigma))[1],
            "err_e_total": rms_in_time(t, (e - ex.ENERGY) / ex.ENERGY),
            "max_err_u_n": float(np.max(np.abs(trace["u_n"] - ex.u_n(t)))),
            "e_end_ratio": float(e[-1] / e[0])}


def box3d_tasks(base_1d: str, schemes, ns, c_implicit: float, t_end: float):
    """Per scheme and n: the nu = 0, E = 1 box at h = 1/n (&mesh dim = 3 first, so that the
    vector keys are 3D; the probe at the centre of the bottom face) and the 1D bar of
    ``base_1d`` at the same h, dt and scheme; each keeps its whole probe trace."""
    cols = {"columns": "t,u_n,v_n,p_n,e_total", "stride": 1}
    tasks = []
    for s in schemes:
        c = step_ratio(s, c_implicit, c_implicit)
        for n in ns:
            h = 1.0 / n
            common = dict(s.settings)
            common.update({"mesh.h": h, "scheme.dt": h / c, "scheme.t_end": t_end,
                           "output.every": 1, "output.fields_every": 0})
            box = {"mesh.dim": 3, "mesh.length": 1.0, "mesh.width": BOX3D_WIDTH,
                   "material.young": 1.0, "material.poisson": 0.0, "material.density": 1.0,
                   "contact.gamma0": 10.0,
                   "contact.probe": f"{BOX3D_WIDTH / 2!r}, {BOX3D_WIDTH / 2!r}, 0.0",
                   "initial.kind": "compressed_bar", "initial.amplitude": 0.5, **common}
            for model, base, settings in (("3d", None, box), ("1d", base_1d, common)):
                tasks.append(make_task(base, settings, "trace", cols,
                                       tags={"scheme": s.key, "label": s.label, "model": model,
                                             "n": n, "h": h, "dt": h / c}))
    return tasks


def box3d_rows(out: str, base_1d: str, *, c_implicit: float = 20.0, t_end: float = 3.0,
               ns=BOX3D_NS, schemes=BOX3D_SCHEMES, cache: str | None = None,
               workers: int | None = None, scheduler: Any = None,
               progress: bool | None = None, log=print) -> dict[str, Any]:
    """The 3D rows (module docstring): run the box and the 1D bar, write
    convergence_3d.csv; returns {'rows', 'orders', 'csv', 'records'}."""
    sch = scheme_list(schemes)
    tasks = box3d_tasks(base_1d, sch, ns, c_implicit, t_end)
    recs = sweep(tasks, cache or os.path.join(out, "cache"), workers=workers,
                 scheduler=scheduler, progress=progress, desc="convergence 3D", log=log)
    rows = []
    for r in recs:
        tg = dict(r["task"].tags)
        row = {k: tg[k] for k in ("scheme", "model", "n", "h", "dt")}
        row.update(status=r["status"], steps=r.get("steps"), message=_first(r.get("message")))
        arr = r.get("arrays") or {}
        if r["status"] == "ok" and len(arr.get("t", ())):
            area = BOX3D_WIDTH ** 2 if tg["model"] == "3d" else 1.0
            row.update(probe_errors(arr, area))
        rows.append(row)
    cols = ["scheme", "model", "n", "h", "dt", "status", "steps", *BOX3D_COLUMNS, "message"]
    csv_path = write_csv(os.path.join(out, "convergence_3d.csv"), rows, cols)
    orders = []
    for s in sch:
        for model in ("3d", "1d"):
            mine = [r for r in rows if r["scheme"] == s.key and r["model"] == model
                    and r["status"] == "ok"]
            for col in ("err_u_n", "err_p_n", "err_e_total"):
                orders.append({"scheme": s.key, "model": model, "norm": col,
                               "order": slope([r["h"] for r in mine],
                                              [abs(r.get(col) or float("nan"))
                                               for r in mine])})
    return {"rows": rows, "orders": orders, "csv": csv_path, "records": list(recs),
            "ns": tuple(ns), "schemes": [s.key for s in sch]}


def _box3d_summary(box) -> list[str]:
    rows = box["rows"]
    lines = ["", "## 3D: the ν = 0 box against the 1D closed form", "",
             f"The box [0, {BOX3D_WIDTH:g}]² × [0, 1] of P1 tetrahedra (`&mesh dim = 3`), "
             "E = 1, ν = 0, θ = 1, γ0 = 10: its exact solution is the 1D bar's (the lateral "
             "faces carry no traction). Probe at the centre of the bottom face; energy per "
             f"unit cross-section (e_total / {BOX3D_WIDTH:g}²). Beside each 3D row the 1D bar "
             "at the same h, Δt and scheme, measured by the same code. RMS in time over "
             "every step: u_n, u̇_n, p_n against −½ in contact, and (e − 1/8)/(1/8); "
             "p_L2_rel as the 1D rows. convergence_3d.csv has every column.", ""]
    table = []
    for r in rows:
        table.append([r["scheme"], r["model"], f"1/{r['n']}", fmt(r["dt"], ".4g"),
                      r["status"]] + [fmt(r.get(c)) for c in BOX3D_COLUMNS])
    lines += md_table(["scheme", "model", "h", "Δt", "status", *BOX3D_COLUMNS], table)
    if len(box["ns"]) > 1:
        lines += ["", "Observed orders (slope over h = "
                  + ", ".join(f"1/{n}" for n in box["ns"]) + "):", ""]
        table = []
        for s in box["schemes"]:
            for model in ("3d", "1d"):
                cells = [s, model]
                for col in ("err_u_n", "err_p_n", "err_e_total"):
                    o = next(o for o in box["orders"] if o["scheme"] == s
                             and o["model"] == model and o["norm"] == col)
                    cells.append(fmt(o["order"], ".2f"))
                table.append(cells)
        lines += md_table(["scheme", "model", "err_u_n", "err_p_n", "err_e_total"], table)
    return lines


def _plot(rows, schemes, path, t_end: float, c_implicit: float, c_explicit: float):
    from ..plotting import run_colours

    fig, axes = new_figure(2, 4, 3.8, 3.2)
    # one colour per scheme (the default cycle repeats after ten; the study has 14)
    colours = run_colours(len(schemes))
    hs = np.array(sorted({r["h"] for r in rows}))
    for j, norm in enumerate(FIELD_NORMS):
        ax = axes.flat[j]
        for s, colour in zip(schemes, colours):
            mine = [r for r in rows if r["scheme"] == s.key and r["status"] == "ok"
                    and r[norm]]
            if mine:
                ax.loglog([r["h"] for r in mine], [r[norm] for r in mine], "o-",
                          ms=3, label=s.label, color=colour)
        if len(hs):
            ys = [r[norm] for r in rows if r[norm]]
            if ys:
                y0 = float(np.median(ys))
                for p, ls in ((0.5, ":"), (1.0, "--")):
                    ax.loglog(hs, y0 * (hs / hs[len(hs) // 2]) ** p, "k" + ls, lw=0.8,
                              label=f"h^{p:g}" if j == 0 else None)
        ax.set_title(NORM_LABELS[norm], fontsize=9)
        ax.set_xlabel("h")
        ax.grid(True, which="both", alpha=0.3)
        # the mesh sizes the study ran, as numbers: 0.04 ... 0.0025 spans 1.2 decades,
        # where the log axis's own ticks would give one number (10^-2)
        if len(hs):
            ticks_at(ax, hs)
    ax = axes.flat[7]
    handles, labels = axes.flat[0].get_legend_handles_labels()
    ax.legend(handles, labels, loc="center", fontsize=6)
    ax.axis("off")
    own = "".join(f", {s.label} h/{s.c:g}" for s in schemes if s.c is not None)
    fig.suptitle(f"Errors against the 1D closed form (bar [0, 1], E = ρ = 1, "
                 f"T = {t_end:g}); Δt = h/{c_implicit:g} implicit, h/{c_explicit:g} "
                 f"explicit{own}", fontsize=10)
    return save_figure(fig, path, top=1 - 0.3 / fig.get_figheight())


def _finest_table(rows, schemes, n, norms) -> list[str]:
    """Markdown table of the given norms of each scheme's run on the mesh h = 1/n
    (schemes without that run left out)."""
    table = []
    for s in schemes:
        r = next((r for r in rows if r["scheme"] == s.key and r["n"] == n), None)
        if r is not None:
            table.append([s.label, r["status"]] + [fmt(r[k]) for k in norms])
    return md_table(["scheme", "status", *norms], table)


def _summary(report, schemes, path) -> str:
    rows, orders = report["rows"], report["orders"]
    ns = report["ns"]
    lines = [
        "# Convergence against the 1D closed form", "",
        f"1D exact case (docs/numerics.md, *The seed's test case*), θ = 1, γ0 = 10, "
        f"T = {report['t_end']:g}; "
        f"h = {', '.join('1/' + str(n) for n in ns)}; Δt = h/c with c = "
        f"{report['c_implicit']:g} (implicit) and {report['c_explicit']:g} "
        f"(predictor-corrector)"
        + "".join(f", {s.c:g} for {s.label}" for s in schemes if s.c is not None)
        + f". Penalty rows: ε_N = γ0/h with γ0 = {PENALTY_GAMMA0:g}. Absolute field norms on one time grid "
        f"(spacing {SNAP_DT:g}) for every h; the relative norms and the stress norms "
        f"from every step.", "",
        f"{report['n_runs']} runs ({report['n_cached']} from the cache, "
        f"{report['n_errors']} failed to run), {report['wall_s']:.1f} s.", "",
        "![convergence](convergence.png)", "",
        "## Observed orders (least-squares slope over all h; last pair in brackets)", ""]
    header = ["scheme"] + [n for n in FIELD_NORMS]
    table = []
    for s in schemes:
        cells = [s.label]
        for norm in FIELD_NORMS:
            o = next(o for o in orders if o["scheme"] == s.key and o["norm"] == norm)
            cells.append(f"{fmt(o['order_fit'], '.2f')} ({fmt(o['order_last'], '.2f')})")
        bad = [r for r in rows if r["scheme"] == s.key and r["status"] != "ok"]
        if bad:
            cells[0] += " (" + ", ".join(f"1/{r['n']}: {r['status']}" for r in bad) + ")"
        table.append(cells)
    lines += md_table(header, table)
    lines += ["", f"## Errors at the finest mesh (h = 1/{ns[-1]})", ""]
    lines += _finest_table(rows, schemes, ns[-1], FIELD_NORMS)
    lines += ["", f"## Relative errors at the finest mesh (h = 1/{ns[-1]}), as the literature "
              "reports them", "",
              "GetFEM's 1D dynamic-contact demo and the papers it comes from: the error "
              "against the nodal interpolant I_h u of the exact solution, divided by the "
              "norm of the same kind of I_h u (of I_h u̇ for u̇, of σ_n for the stress); "
              "L∞ in time = max of the errors / max of the norms, L² in time by the "
              "rectangle rule (Σ_k Δt ‖·‖², Δt cancels), every step t_k = kΔt from "
              "k = 0 (the initial state) to N, fields and stress alike. docs/numerics.md "
              "gives both definitions.", ""]
    lines += _finest_table(rows, schemes, ns[-1], REL_NORMS)
    if report.get("box3d"):
        lines += _box3d_summary(report["box3d"])
    return write_markdown(path, lines)
