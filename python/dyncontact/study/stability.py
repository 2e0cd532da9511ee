"""``study stability``: where each scheme fails on the seed's 2D bar, and the seed's
claims settled in numbers.

Sweep: scheme (x mass for pc) x h x gamma0 x Nitsche theta in {-1, 0, 1} x dt/h, to
T = 30 (about 10 impacts). The dt/h grid is per family (implicit schemes at and above
the seed's h/20, predictor-corrector schemes from h/100 up), since an implicit scheme at
h/100 says nothing a run at h/20 does not.

The options beyond the seed are rows: galpha, central differences (lumped and consistent mass,
on the explicit dt/h grid; their own critical-step estimate is compared with the
bisection), the redistributed mass, penalty contact and the augmented Lagrangian (integral
and nodal multipliers, consistent and redistributed mass; r = gamma0/h_T). Penalty and ALM
have no Nitsche theta: one run per (h, gamma0, dt), listed as theta = +1.

The 3D rows (:data:`BOX3D_GRIDS`, :func:`run_box3d`): the box [0, 0.1]^2 x [0, 1] of P1
tetrahedra (&mesh dim = 3) with the seed's material, initial state and contact, for the
main schemes at h = 0.05 on the same dt/h grid, T and bisection; their critical dt is set
beside the 2D bar's (OUT/box3d/, a section of summary.md).

On a scene of one's own (``--scene``, :func:`run_stability_scene`): the schemes of
SCENE_GRIDS on the scene's mesh, mass, contact and T, a Δt grid of multiples of the
scene's Δt, then the same bisection (:func:`critical_dt`); no h, γ0 or θ grid.

Classification (from summary.json, i.e. the core's own verdict, SPEC section 4):
``stable`` (ran to T), ``unstable`` (energy of the written state over ``blowup`` x
e_total(0), or not finite: stop time and the core's message), ``newton_failed``,
``refused`` (the core refused the scene as bad input at run time: theta = 1 below the
gamma0 bound), ``error`` (the run could not be done).

Critical dt per (scheme, mass, h, gamma0, theta): the grid gives a bracket (the largest
stable dt below the smallest one that is not stable); it is narrowed by bisection in
log(dt) (``rounds`` halvings of the log-width, all groups at once per round). Reported
as [lo, hi] and their geometric mean. When a stable dt lies above an unstable one the
group is flagged ``non_monotone`` (the bisection brackets the first loss of stability).
"""

from __future__ import annotations

import math
import os
import textwrap
import time
from typing import Any, Callable, Hashable, Mapping

import numpy as np

from . import analyses  # noqa: F401 - registers the analyses
from .common import (STATUS_COLORS, fmt, md_table, new_figure, save_figure,
                     scheme_list, study_folder, wrapped_suptitle, write_csv, write_markdown)
from .analyses import impacts  # noqa: F401 - part of this module's API
from .sweep import ERROR, REFUSED, Task, make_task, sweep

__all__ = ["run_stability", "bisect_critical", "classify", "GRIDS", "impacts",
           "BOX3D_GRIDS", "run_box3d", "critical_groups", "critical_rows", "critical_dt",
           "RUN_COLUMNS", "CRITICAL_COLUMNS", "run_stability_scene", "SCENE_GRIDS",
           "mesh_file_h"]

#: Sweep sizes. 'dt_over_h': {'implicit': (...), 'explicit': (...)}.
GRIDS = {
    "full": {"schemes": ("newmark", "newmark_diss", "newmark_g0.6", "hht-0.1", "hht_seed-0.1",
                         "theta1",
                         "pc", "pc_lumped", "pc_hht-0.1", "pc_hht_seed-0.1",
                         # beyond the seed
                         "galpha1", "galpha0.5", "central_lumped", "central",
                         "newmark_redist", "hht-0.1_redist", "newmark_penalty",
                         "hht-0.1_penalty", "newmark_alm", "newmark_alm_nodal",
                         "newmark_alm_redist", "newmark_alm_nodal_redist",
                         "hht-0.1_alm_redist", "hht-0.1_alm_nodal_redist"),
             "h": (0.1, 0.05), "gamma0": (0.01, 1.0, 10.0, 100.0),
             "theta": (-1, 0, 1),
             "dt_over_h": {"implicit": (1 / 80, 1 / 20, 1 / 5, 1.0),
                           "explicit": (1 / 100, 1 / 20, 1 / 10, 1 / 5, 1 / 2, 1.0)},
             "t_end": 30.0, "rounds": 4},
    "quick": {"schemes": ("hht-0.1", "pc", "pc_lumped", "central_lumped", "hht-0.1_redist",
                          "newmark_penalty", "newmark_alm", "newmark_alm_nodal_redist"),
              "h": (0.1,), "gamma0": (10.0,), "theta": (-1, 1),
              "dt_over_h": {"implicit": (1 / 20, 1 / 2), "explicit": (1 / 20, 1 / 10, 1 / 2)},
              "t_end": 30.0, "rounds": 3},
}
#: The 3D box rows (&mesh dim = 3: [0, 0.1]^2 x [0, 1] of P1 tetrahedra, the seed's
#: material and initial state): the main schemes at h = 0.05 with the 2D grid's dt/h,
#: T and bisection rounds, beside the 2D rows of the same (scheme, h, gamma0, theta).
BOX3D_GRIDS = {
    "full": {"schemes": ("newmark", "hht-0.1", "pc", "pc_lumped", "central_lumped"),
             "h": (0.05,), "gamma0": (10.0,), "theta": (-1, 1)},
    # quick: two schemes over the first two impacts (T = 6)
    "quick": {"schemes": ("hht-0.1", "pc_lumped"), "h": (0.05,), "gamma0": (10.0,),
              "theta": (1,), "t_end": 6.0},
}
#: ``--scene``: the main schemes (each on the scene's mass and contact,
#: :func:`.common.on_scene`), the Δt grid as multiples of the scene's Δt (a factor 4
#: apart: the bisection narrows a bracket [lo, 4 lo] to a ratio 4^(1/2^rounds), 1.09
#: after 4 rounds), and the rounds. No h, γ0 or θ grid: the scene's own values.
SCENE_GRIDS = {
    "full": {"schemes": ("newmark", "hht-0.1", "theta1", "galpha0.5", "pc", "pc_hht-0.1",
                         "central"),
             "dt_factors": {"implicit": (1, 4, 16, 64),
                            "explicit": (1 / 16, 1 / 4, 1, 4, 16)},
             "rounds": 4},
    "quick": {"schemes": ("hht-0.1", "pc", "central"),
              "dt_factors": {"implicit": (1, 8), "explicit": (1 / 8, 1, 8)}, "rounds": 3},
}
#: Trace rows kept per grid run for the claims (u_n over the first period, energies).
KEEP_ROWS = 1500
#: Trace rows about this far apart in time (output.every = round(OUTPUT_DT / dt)): the
#: verdict does not depend on it (the core checks the energy of every step, and the stop
#: time is summary.json's), impacts are found to within OUTPUT_DT, and writing a row per
#: step would cost more than the step itself on these small meshes.
OUTPUT_DT = 0.01
#: central differences with dt = 0 run at this fraction of their own estimate (scenes.md)
AUTO_FACTOR = 0.9


def thetas(s, g) -> tuple[int, ...]:
    """The Nitsche θ of the sweep for scheme s: penalty and the augmented Lagrangian have
    no θ (one run, θ = 1 in the tables)."""
    return tuple(g["theta"]) if s.method == "nitsche" else (1,)


def classify(status: str) -> str:
    return {"ok": "stable"}.get(status, status)


# --------------------------------------------------------------------------- bisection

def bisect_critical(groups: Mapping[Hashable, tuple[float, float]],
                    task_for: Callable[[Hashable, float], Task], rounds: int, cache: str,
                    *, workers=None, scheduler=None, progress=None, log=None,
                    desc: str = "bisection") -> dict[Hashable, dict[str, Any]]:
    """Narrow each group's bracket [lo, hi] (lo stable, hi not) by ``rounds`` bisections
    in log(dt); the midpoints of all groups run together in each round.

    Returns {group: {'lo', 'hi', 'runs': [records]}}.
    """
    state = {g: {"lo": float(lo), "hi": float(hi), "runs": []} for g, (lo, hi) in
             groups.items()}
    for k in range(rounds):
        order = list(state)
        if not order:
            break
        mids = {g: math.sqrt(state[g]["lo"] * state[g]["hi"]) for g in order}
        recs = sweep([task_for(g, mids[g]) for g in order], cache, workers=workers,
                     scheduler=scheduler, progress=progress,
                     desc=f"{desc} {k + 1}/{rounds}", log=log)
        for g, r in zip(order, recs):
            st = state[g]
            st["runs"].append(r)
            if r["status"] == "ok":
                st["lo"] = mids[g]
            elif r["status"] not in (ERROR, REFUSED):
                st["hi"] = mids[g]
            # an 'error' or 'refused' run leaves the bracket as it is
    return state


# --------------------------------------------------------------------------- study

#: The bracket of a group with no run that finished or was refused only (every run an
#: 'error', the run could not be done): no critical Δt, stable or unstable.
NO_VERDICT = "no verdict"


def critical_groups(recs) -> tuple[dict[tuple, dict[str, Any]], dict[tuple, tuple]]:
    """Group the grid runs by (scheme, h, gamma0, theta) and bracket each group's
    critical dt on the grid: ({group: info}, {group: (lo, hi)} of the groups to bisect).
    info: grid_stable ('k/n'), bracket ('bisection', 'above grid', 'below grid',
    'refused', NO_VERDICT), lo (the largest Δt that ran to T below the first unstable
    one; a run that could not be done is no stable end), hi, non_monotone,
    dt_crit_estimate, and the first unstable run's status, stop time and reason."""
    groups: dict[tuple, list[dict]] = {}
    for r in recs:
        tg = r["task"].tag
        groups.setdefault((tg("scheme"), tg("h"), tg("gamma0"), tg("theta")), []).append(r)
    brackets, crit = {}, {}
    for key, rs in groups.items():
        rs.sort(key=lambda r: r["task"].tag("dt"))
        dts = [r["task"].tag("dt") for r in rs]
        ok = [r["status"] == "ok" for r in rs]
        first_bad = next((i for i, o in enumerate(ok) if not o
                          and rs[i]["status"] not in (ERROR, REFUSED)), None)
        est = [r.get("metrics", {}).get("dt_crit_estimate") for r in rs]
        est = [x for x in est if x]
        info = {"grid_stable": f"{sum(ok)}/{len(ok)}", "non_monotone": False,
                "lo": None, "hi": None, "bracket": "",
                "dt_crit_estimate": est[0] if est else None}
        # the bracket's stable end is a run that finished, never one that could not be
        # done (an 'error' says nothing about stability)
        stable = [i for i in range(len(rs) if first_bad is None else first_bad) if ok[i]]
        if all(r["status"] == REFUSED for r in rs):
            info.update(bracket="refused")
        elif first_bad is None and not stable:
            info.update(bracket=NO_VERDICT)
        elif first_bad is None:
            info.update(bracket="above grid", lo=dts[stable[-1]])
        elif not stable:
            info.update(bracket="below grid", hi=dts[first_bad])
        else:
            info.update(bracket="bisection", lo=dts[stable[-1]], hi=dts[first_bad])
            brackets[key] = (dts[stable[-1]], dts[first_bad])
        if first_bad is not None:
            info["non_monotone"] = any(ok[first_bad + 1:])
            info["first_unstable_status"] = rs[first_bad]["status"]
            info["first_unstable_stop"] = rs[first_bad].get("t_end_reached")
            info["first_unstable_reason"] = _first(rs[first_bad].get("message"))
        crit[key] = info
    return crit, brackets


def _grid_tasks(base, schemes, grid, t_end, **task_kw):
    """The grid's runs: every scheme x h x gamma0 x theta x dt/h of ``grid`` (the ratios
    of the scheme's kind), in that order; ``task_kw`` goes to :func:`_task`, and so does
    the grid's ``set_h`` (default True)."""
    task_kw.setdefault("set_h", grid.get("set_h", True))
    tasks = []
    for s in schemes:
        ratios = grid["dt_over_h"]["explicit" if s.explicit else "implicit"]
        for h in grid["h"]:
            for g0 in grid["gamma0"]:
                for th in thetas(s, grid):
                    for r in ratios:
                        tasks.append(_task(base, s, h, g0, th, h * r, t_end, "grid",
                                           **task_kw))
    return tasks


def _task(base, s, h, g0, th, dt, t_end, phase, keep_rows=0, first=None, set_h=True):
    """One run of the grid or of a bisection. ``set_h``: the run sets &mesh h = h (the
    built-in bar, a .geo the scene gives &mesh h for); False for a .msh file, which is
    meshed already, and a .geo the scene gives no &mesh h for, which is meshed with its
    own sizes: h is then the mesh's own size (:func:`mesh_file_h`), reported, not set."""
    settings = dict(first or {})        # first: keys that must come first (mesh.dim)
    settings.update(s.settings)
    if s.method == "nitsche":           # penalty and ALM have no theta (th = 1, the default)
        settings["contact.theta"] = int(th)
    if set_h:
        settings["mesh.h"] = h
    settings.update({"contact.gamma0": g0,
                     "scheme.dt": dt, "scheme.t_end": t_end,
                     "output.every": max(1, int(round(OUTPUT_DT / dt))),
                     "output.fields_every": 0})
    return make_task(base, settings, "stability", {"keep_rows": keep_rows},
                     tags={"scheme": s.key, "label": s.label, "mass": s.mass, "h": h,
                           "method": s.method, "gamma0": g0, "theta": int(th), "dt": dt,
                           "dt_over_h": dt / h,
                           "phase": phase})


#: Columns of runs.csv and stability.csv (2D and 3D alike).
RUN_COLUMNS = ["scheme", "mass", "method", "h", "gamma0", "theta", "dt", "dt_over_h",
               "phase", "status", "classification", "stop_time", "reason", "impacts",
               "e_max_ratio", "e_end_ratio", "ec_end_ratio", "steps"]
CRITICAL_COLUMNS = ["scheme", "mass", "method", "h", "gamma0", "theta", "dt_crit_lo",
                    "dt_crit_hi", "dt_crit", "dt_crit_over_h", "dt_crit_estimate",
                    "estimate_over_measured", "bracket", "grid_stable", "non_monotone",
                    "first_unstable_status", "first_unstable_stop", "first_unstable_reason"]


def critical_rows(crit: Mapping[tuple, Mapping[str, Any]], schemes) -> list[dict[str, Any]]:
    """The rows of stability.csv (:data:`CRITICAL_COLUMNS`) from :func:`critical_groups`'
    groups, with the bisection's [lo, hi] filled in, in the order of ``schemes`` then
    (h, gamma0, theta): the bracket, its geometric mean (and / h), the first unstable grid
    run's status, stop time and reason, and the explicit schemes' own estimate (central,
    pc, pc_hht, pc_hht_seed: summary.json's dt_crit_estimate) beside the measured value."""
    by_key = {s.key: s for s in schemes}
    order = [s.key for s in schemes]
    rows = []
    for key in sorted(crit, key=lambda k: (order.index(k[0]),) + tuple(k[1:])):
        c = crit[key]
        lo, hi = c["lo"], c["hi"]
        mid = math.sqrt(lo * hi) if lo and hi else None
        est = c["dt_crit_estimate"]
        rows.append({"scheme": key[0], "mass": by_key[key[0]].mass,
                     "method": by_key[key[0]].method, "h": key[1], "gamma0": key[2],
                     "theta": key[3], "dt_crit_lo": lo, "dt_crit_hi": hi, "dt_crit": mid,
                     "dt_crit_over_h": mid / key[1] if mid else None,
                     "dt_crit_estimate": est,
                     "estimate_over_measured": est / mid if est and mid else None,
                     "bracket": c["bracket"], "grid_stable": c["grid_stable"],
                     "non_monotone": c["non_monotone"],
                     "first_unstable_status": c.get("first_unstable_status", ""),
                     "first_unstable_stop": c.get("first_unstable_stop"),
                     "first_unstable_reason": c.get("first_unstable_reason", "")})
    return rows


def critical_dt(base: str, schemes, grid: Mapping[str, Any], folder: str, cache: str, *,
                keep_rows: int = 0, first: Mapping[str, Any] | None = None,
                workers=None, scheduler=None, progress=None, log=print,
                desc: str = "stability") -> dict[str, Any]:
    """The one path from a grid to its critical Δt, for the 2D bar and the 3D box alike:
    the grid's runs (:func:`_grid_tasks`), the brackets (:func:`critical_groups`), the
    bisections (:func:`bisect_critical`), then runs.csv and stability.csv in ``folder``.
    ``first``: scene keys set before the scheme's (``mesh.dim``). Returns {'grid_records',
    'records' (grid then bisection), 'runs', 'critical', 'runs_csv', 'csv'}."""
    t_end = float(grid["t_end"])
    tasks = _grid_tasks(base, schemes, grid, t_end, keep_rows=keep_rows, first=first)
    recs = sweep(tasks, cache, workers=workers, scheduler=scheduler, progress=progress,
                 desc=f"{desc} grid", log=log)
    crit, brackets = critical_groups(recs)
    by_key = {s.key: s for s in schemes}
    bis = bisect_critical(
        brackets, lambda key, dt: _task(base, by_key[key[0]], key[1], key[2], key[3], dt,
                                        t_end, "bisect", first=first,
                                        set_h=grid.get("set_h", True)),
        int(grid["rounds"]), cache, workers=workers, scheduler=scheduler,
        progress=progress, log=log, desc=f"{desc} bisection")
    for key, st in bis.items():
        crit[key].update(lo=st["lo"], hi=st["hi"])
    all_recs = list(recs) + [r for st in bis.values() for r in st["runs"]]
    run_rows = [_run_row(r) for r in all_recs]
    crit_rows = critical_rows(crit, schemes)
    return {"grid_records": recs, "records": all_recs, "runs": run_rows,
            "critical": crit_rows,
            "runs_csv": write_csv(os.path.join(folder, "runs.csv"), run_rows, RUN_COLUMNS),
            "csv": write_csv(os.path.join(folder, "stability.csv"), crit_rows,
                             CRITICAL_COLUMNS)}


def run_stability(out: str, *, quick: bool = False, grid: Mapping[str, Any] | None = None,
                  cache: str | None = None, workers: int | None = None,
                  scheduler: Any = None, progress: bool | None = None,
                  log=print) -> dict[str, Any]:
    """Run the sweep and the bisections; writes runs.csv, stability.csv, heat maps
    (stability_h*.png, critical_dt.png) and summary.md (with the claims table)."""
    t0 = time.perf_counter()
    g = dict(GRIDS["quick" if quick else "full"])
    g.update(grid or {})
    out, cache, bases = study_folder(out, cache)
    base = bases["seed2d"]
    schemes = scheme_list(g["schemes"])
    crit = critical_dt(base, schemes, g, out, cache, keep_rows=KEEP_ROWS,
                       workers=workers, scheduler=scheduler, progress=progress, log=log,
                       desc="stability")
    recs, all_recs = crit["grid_records"], crit["records"]
    run_rows, crit_rows = crit["runs"], crit["critical"]
    crit_csv, runs_csv = crit["csv"], crit["runs_csv"]
    pngs = _heatmaps(run_rows, crit_rows, schemes, g, out, scene=SEED_SCENE)
    from .claims import claims_table

    claims = claims_table(recs, g)
    # the 3D rows: BOX3D_GRIDS, or grid['box3d'] (None: none)
    g3 = (grid or {}).get("box3d", BOX3D_GRIDS["quick" if quick else "full"])
    box = run_box3d(out, base, g, g3, cache, workers=workers, scheduler=scheduler,
                    progress=progress, log=log) if g3 else None
    all_recs = all_recs + (box["records"] if box else [])
    report = {"runs": run_rows, "critical": crit_rows, "claims": claims,
              "csv": crit_csv, "runs_csv": runs_csv, "pngs": pngs, "grid": g, "box3d": box,
              "n_runs": len(all_recs), "n_cached": sum(r["cached"] for r in all_recs),
              "n_errors": sum(r["status"] == ERROR for r in all_recs),
              "n_refused": sum(r["status"] == REFUSED for r in all_recs),
              "wall_s": time.perf_counter() - t0, "quick": quick}
    report["summary"] = _summary(report, schemes, os.path.join(out, "summary.md"))
    return report


def _first(msg) -> str:
    return msg.splitlines()[0] if msg else ""


def run_box3d(out: str, base: str, g: Mapping[str, Any], g3: Mapping[str, Any], cache: str,
              *, workers=None, scheduler=None, progress=None, log=print) -> dict[str, Any]:
    """The 3D box rows: the grid of ``g3`` (schemes, h, gamma0, theta) with the dt/h,
    T and bisection rounds of the 2D grid ``g``, then the bisections; writes
    OUT/box3d/runs.csv, stability.csv and the heat maps there. Returns {'critical',
    'runs', 'records', 'grid', 'csv', 'pngs'}."""
    folder = os.path.join(out, "box3d")
    os.makedirs(folder, exist_ok=True)
    grid = dict(g)
    grid.update(g3)
    schemes = scheme_list(grid["schemes"])
    crit = critical_dt(base, schemes, grid, folder, cache,
                       first={"mesh.dim": 3},   # the vector keys become 3D before the others
                       workers=workers, scheduler=scheduler, progress=progress, log=log,
                       desc="stability 3D")
    run_rows, crit_rows, all_recs = crit["runs"], crit["critical"], crit["records"]
    crit_csv, runs_csv = crit["csv"], crit["runs_csv"]
    pngs = _heatmaps(run_rows, crit_rows, schemes, grid, folder, scene=BOX3D_SCENE)
    return {"critical": crit_rows, "runs": run_rows, "records": all_recs, "grid": grid,
            "csv": crit_csv, "runs_csv": runs_csv, "pngs": pngs}


def _crit_text(c) -> str:
    if c is None:
        return "-"
    if c["bracket"] == "bisection":
        return f"{fmt(c['dt_crit_lo'], '.4g')} – {fmt(c['dt_crit_hi'], '.4g')}"
    if c["bracket"] == "above grid":
        return f"> {fmt(c['dt_crit_lo'], '.4g')}"
    if c["bracket"] in ("refused", NO_VERDICT):
        return c["bracket"]
    return f"< {fmt(c['dt_crit_hi'], '.4g')}"


def dt_over_h_text(r: float) -> str:
    """A grid's Δt/h as a tick label: 1/20, 1/100 for the nondimensional scenes' ratios (Δt
    = h/c, c a multiple of the wave speed 1), the number itself beyond 1/1000 or from 1
    on: in SI Δt/h is in s/m (8e-06 on the steel strip), which 1/1.25e+05 hides."""
    if 1e-3 <= r < 1:
        return f"1/{1 / r:.3g}"
    return f"{r:.3g}"


def _ratio_text(c, dt: float) -> str:
    """The critical Δt of :func:`_crit_text` as a multiple of the scene's Δt: the
    bracket's geometric mean, or the bound of a critical Δt outside the grid ("> 8", "< 0.5");
    "-" for a refused row."""
    if c["bracket"] == "bisection":
        return fmt(c["dt_crit"] / dt if c.get("dt_crit") else None, ".3g")
    if c["bracket"] == "above grid":
        return f"> {fmt(c['dt_crit_lo'] / dt, '.3g')}"
    if c["bracket"] in ("refused", NO_VERDICT):
        return "-"
    return f"< {fmt(c['dt_crit_hi'] / dt, '.3g')}"


def _box3d_summary(report) -> list[str]:
    box = report["box3d"]
    g3 = box["grid"]
    lines = ["", "## 3D box (P1 tetrahedra) beside the 2D bar", "",
             "The box [0, 0.1]² × [0, 1] (`&mesh dim = 3`) with the seed's material, "
             f"initial state and contact; h ∈ {{{', '.join(f'{h:g}' for h in g3['h'])}}}, "
             f"γ0 ∈ {{{', '.join(f'{x:g}' for x in g3['gamma0'])}}}, θ ∈ "
             f"{{{', '.join(str(x) for x in g3['theta'])}}}, the 2D grid's Δt/h, T and "
             "bisection. Critical Δt beside the 2D bar's at the same (scheme, h, γ0, θ); "
             "heat maps and CSV in box3d/.", ""]
    for p in box["pngs"]:
        lines += [f"![{os.path.basename(p)}](box3d/{os.path.basename(p)})", ""]
    crit2 = {(c["scheme"], c["h"], c["gamma0"], c["theta"]): c for c in report["critical"]}
    table = []
    for c in box["critical"]:
        c2 = crit2.get((c["scheme"], c["h"], c["gamma0"], c["theta"]))
        ratio = c["dt_crit"] / c2["dt_crit"] if c.get("dt_crit") and c2 and \
            c2.get("dt_crit") else None
        stop = f"{c['first_unstable_status']} at t={fmt(c['first_unstable_stop'], '.4g')}" \
            if c["first_unstable_status"] else ""
        table.append([c["scheme"], fmt(c["h"], "g"), fmt(c["gamma0"], "g"), c["theta"],
                      _crit_text(c), _crit_text(c2), fmt(ratio, ".3f"), c["grid_stable"],
                      fmt(c.get("dt_crit_estimate"), ".4g"),
                      fmt(c.get("estimate_over_measured"), ".3f"), stop])
    lines += md_table(["scheme", "h", "γ0", "θ", "critical Δt 3D", "critical Δt 2D",
                       "3D / 2D", "3D grid stable", "3D estimate (explicit)",
                       "estimate / measured", "first unstable 3D grid run"], table)
    return lines


def _run_row(r) -> dict[str, Any]:
    tg = dict(r["task"].tags)
    m = r.get("metrics", {})
    stop = r.get("t_end_reached") if r["status"] != "ok" else None
    n_imp = None
    if m.get("impact_times") is not None:
        n_imp = len(m["impact_times"])
    return {"scheme": tg["scheme"], "mass": tg["mass"], "method": tg.get("method", "nitsche"),
            "h": tg["h"], "gamma0": tg["gamma0"],
            "theta": tg["theta"], "dt": tg["dt"], "dt_over_h": tg["dt_over_h"],
            "phase": tg["phase"], "status": r["status"],
            "classification": classify(r["status"]), "stop_time": stop,
            "reason": _first(r.get("message")) if r["status"] != "ok" else "",
            "impacts": n_imp, "e_max_ratio": m.get("e_max_ratio"),
            "e_end_ratio": m.get("e_end_ratio"), "ec_end_ratio": m.get("ec_end_ratio"),
            "steps": r.get("steps")}


#: The scenes of the built-in study's charts (their titles).
SEED_SCENE = ("seed 2D bar [0, 0.1] × [0, 1] (E = 2/3, ν = 1/3, ρ = 1; compressed bar, "
              "lift 0.5)")
BOX3D_SCENE = "3D box [0, 0.1]² × [0, 1] (the seed 2D bar's material, lift and contact)"


def _heatmaps(run_rows, crit_rows, schemes, g, out, scene: str = "") -> list[str]:
    """One PNG per h: a panel per scheme, rows (gamma0, theta), columns dt/h, colour =
    classification, text = stop time; and critical_dt.png (dt_crit/h per scheme). Their
    titles begin with ``scene``, what the runs are of (SEED_SCENE, BOX3D_SCENE, a scene
    file's name)."""
    on = f"{scene}: " if scene else ""
    from matplotlib.colors import ListedColormap

    names = ["stable", "unstable", "newton_failed", "error", "refused"]
    cmap = ListedColormap([STATUS_COLORS[n] for n in names])
    pngs = []
    combos = [(g0, th) for g0 in g["gamma0"] for th in g["theta"]]
    for h in g["h"]:
        ncols = min(3, len(schemes))
        nrows = math.ceil(len(schemes) / ncols)
        fig, axes = new_figure(nrows, ncols, 4.6, 0.45 * len(combos) + 1.6)
        for ax, s in zip(axes.flat, schemes):
            ratios = g["dt_over_h"]["explicit" if s.explicit else "implicit"]
            z = np.full((len(combos), len(ratios)), np.nan)
            for i, (g0, th) in enumerate(combos):
                for j, rr in enumerate(ratios):
                    row = next((x for x in run_rows if x["phase"] == "grid"
                                and x["scheme"] == s.key and x["h"] == h
                                and x["gamma0"] == g0 and x["theta"] == th
                                and math.isclose(x["dt_over_h"], rr, rel_tol=1e-9)), None)
                    if row is None:
                        continue
                    z[i, j] = names.index(row["classification"]) \
                        if row["classification"] in names else 3
                    if row["stop_time"] is not None:
                        ax.text(j, i, f"{row['stop_time']:.3g}", ha="center", va="center",
                                fontsize=6, color="w")
            ax.imshow(z, cmap=cmap, vmin=-0.5, vmax=4.5, aspect="auto")
            ax.set_xticks(range(len(ratios)))
            ax.set_xticklabels([dt_over_h_text(r) for r in ratios], fontsize=7)
            ax.set_yticks(range(len(combos)))
            ax.set_yticklabels([f"γ0={g0:g} θ={th:+d}" for g0, th in combos], fontsize=6)
            ax.set_xlabel("Δt/h", fontsize=8)
            ax.set_title(s.label, fontsize=9)
        for ax in list(axes.flat)[len(schemes):]:
            ax.axis("off")
        # white: a cell with no run (penalty and ALM have no Nitsche theta to vary); the
        # key wrapped to the figure's width (about 14 characters an inch at 9 points), which
        # is one panel wide for a study of one scheme
        n_lines = wrapped_suptitle(fig, f"{on}h = {h:g}, T = {g['t_end']:g}: green stable, "
                                   "red unstable (stop time written), orange Newton failed, "
                                   "grey error, light grey refused by the core, white not run")
        fig.set_figheight(fig.get_figheight() + 0.15 * (n_lines - 1))
        path = os.path.join(out, f"stability_h{h:g}.png")
        pngs.append(save_figure(fig, path, top=1 - (0.2 + 0.15 * n_lines)
                                / fig.get_figheight()))
    # critical dt / h
    fig, axes = new_figure(len(g["h"]), 1, 0.9 * len(schemes) + 3, 0.3 * len(combos) + 2.2)
    finite = [c["dt_crit_over_h"] for c in crit_rows if c.get("dt_crit_over_h")]
    lims = (math.log10(min(finite)), math.log10(max(finite))) if finite else (None, None)
    single = bool(finite) and lims[0] == lims[1]
    if single:
        # one value (or all equal): a range of zero width maps nothing; the decade
        # centred on it, which colours its cells mid-map, and a tick at it
        lims = (lims[0] - 0.5, lims[1] + 0.5)
    for ax, h in zip(axes.flat, g["h"]):
        z = np.full((len(combos), len(schemes)), np.nan)
        for i, (g0, th) in enumerate(combos):
            for j, s in enumerate(schemes):
                c = next((c for c in crit_rows if c["scheme"] == s.key and c["h"] == h
                          and c["gamma0"] == g0 and c["theta"] == th), None)
                if c is None:
                    continue
                if c["bracket"] == "bisection":
                    z[i, j] = c["dt_crit_over_h"]
                    txt = f"{c['dt_crit_over_h']:.3g}"
                elif c["bracket"] == "above grid":
                    txt = f">{c['dt_crit_lo'] / h:.3g}"
                elif c["bracket"] in ("refused", NO_VERDICT):
                    txt = c["bracket"]
                else:
                    txt = f"<{c['dt_crit_hi'] / h:.3g}"
                # white on the dark end of the colour map (black was unreadable there)
                dark = (lims[1] is not None and lims[1] > lims[0] and math.isfinite(z[i, j])
                        and (math.log10(z[i, j]) - lims[0]) / (lims[1] - lims[0]) > 0.6)
                ax.text(j, i, txt, ha="center", va="center", fontsize=6,
                        color="w" if dark else "k")
        im = ax.imshow(np.log10(z), aspect="auto", cmap="YlGnBu", vmin=lims[0],
                       vmax=lims[1])
        ax.set_xticks(range(len(schemes)))
        ax.set_xticklabels([s.key for s in schemes], rotation=45, ha="right", fontsize=7)
        ax.set_yticks(range(len(combos)))
        ax.set_yticklabels([f"γ0={g0:g} θ={th:+d}" for g0, th in combos], fontsize=6)
        # a cell is coloured only where a bisection measured Δt_crit; the key says what
        # the others are: no Δt_crit in the grid's range (> / <), a scene the core
        # refused, or no run at all (penalty and ALM have no Nitsche theta to vary);
        # wrapped to the panel's width (about 14 characters an inch at 9 points; the
        # colour bar takes a quarter of the figure's)
        ax.set_title("\n".join(textwrap.wrap(
            f"critical Δt/h, h = {h:g}, T = {g['t_end']:g} (bisection); uncoloured: no "
            "Δt_crit measured, > / <: stable / unstable on the whole grid, 'refused': "
            "refused by the core, no text: not run", width=int(10 * fig.get_figwidth()))),
            fontsize=9)
        if not finite:       # no value to scale: the bar would be an empty range
            continue
        bar = fig.colorbar(im, ax=ax, label="log10(Δt_crit/h)")
        if single:
            bar.set_ticks([lims[0], math.log10(finite[0]), lims[1]])
    top = 1.0
    if scene:
        n_lines = wrapped_suptitle(fig, scene)
        fig.set_figheight(fig.get_figheight() + 0.15 * n_lines)
        top = 1 - (0.1 + 0.15 * n_lines) / fig.get_figheight()
    pngs.append(save_figure(fig, os.path.join(out, "critical_dt.png"), top=top))
    return pngs


def _summary(report, schemes, path) -> str:
    g = report["grid"]
    lines = [
        "# Stability on the seed's 2D bar", "",
        f"T = {g['t_end']:g}; h ∈ {{{', '.join(f'{h:g}' for h in g['h'])}}}; "
        f"γ0 ∈ {{{', '.join(f'{x:g}' for x in g['gamma0'])}}}; Nitsche θ ∈ "
        f"{{{', '.join(str(x) for x in g['theta'])}}}; Δt/h ∈ "
        f"{{{', '.join(f'{x:.4g}' for x in g['dt_over_h']['implicit'])}}} (implicit), "
        f"{{{', '.join(f'{x:.4g}' for x in g['dt_over_h']['explicit'])}}} "
        f"(predictor-corrector); then {g['rounds']} rounds of bisection in log Δt on each "
        f"bracket.", "",
        f"{report['n_runs']} runs ({report['n_cached']} from the cache, "
        f"{report['n_errors']} failed to run, {report['n_refused']} refused by the core as "
        f"bad input), {report['wall_s']:.1f} s.", "",
        "Verdicts are the core's (summary.json status): `unstable` = the energy of the "
        "written state exceeded blowup × e_total(0) (or was not finite). Penalty rows "
        "(ε_N = γ0/h) and augmented Lagrangian rows (r = γ0/h) have no Nitsche θ: one run "
        "per (γ0, Δt), listed as θ = +1. "
        "θ = 1 with γ0 below the element bound is refused by the core (`refused`).", ""]
    lines += ["## The seed's claims", ""]
    lines += md_table(["claim", "setting tested", "verdict", "evidence"],
                      [[c["claim"], c["setting"], c["verdict"], c["evidence"]]
                       for c in report["claims"]])
    lines += ["", "## Critical Δt (stability.csv)", ""]
    for p in report["pngs"]:
        lines += [f"![{os.path.basename(p)}]({os.path.basename(p)})", ""]
    table = []
    for c in report["critical"]:
        if c["bracket"] == "bisection":
            val = f"{fmt(c['dt_crit_lo'], '.4g')} – {fmt(c['dt_crit_hi'], '.4g')} " \
                  f"(h/{1 / c['dt_crit_over_h']:.3g})"
        elif c["bracket"] == "above grid":
            val = f"> {fmt(c['dt_crit_lo'], '.4g')} ({_grid_words(c)})"
        elif c["bracket"] == "refused":
            val = "refused by the core (γ0 below the bound for θ = 1)"
        elif c["bracket"] == NO_VERDICT:
            val = "no verdict (no run finished: every one failed to run)"
        else:
            val = f"< {fmt(c['dt_crit_hi'], '.4g')} ({_grid_words(c)})"
        stop = f"{c['first_unstable_status']} at t={fmt(c['first_unstable_stop'], '.4g')}" \
            if c["first_unstable_status"] else ""
        table.append([c["scheme"], c["mass"], fmt(c["h"], "g"), fmt(c["gamma0"], "g"),
                      c["theta"], val, c["grid_stable"],
                      "yes" if c["non_monotone"] else "", stop])
    lines += md_table(["scheme", "mass", "h", "γ0", "θ", "critical Δt", "grid stable",
                       "non-monotone", "first unstable grid run"], table)
    lines += ["", "## Explicit schemes: the run's own critical-step estimate against the "
              "measured one", "",
              "`dt_crit_estimate` (summary.json): Ω_c/√λ_max, λ_max the largest eigenvalue of "
              "M⁻¹(K_θ + contact tangent with every contact point active) by power "
              "iterations, Ω_c the limit of the scheme's amplification matrix (2 for central, "
              "√2 for pc; docs/numerics.md, \"Explicit schemes\"); the measured critical Δt "
              "is the bisection's bracket above, the ratio is to its geometric mean. The "
              "estimate is on the safe side when it is at most the bracket's stable end, on "
              "the unsafe side when at least its unstable end; inside the bracket the runs "
              "cannot tell, whatever the ratio (central's dt = 0 runs at 0.9 × the "
              "estimate).", ""]
    table = [[c["scheme"], c["mass"], fmt(c["h"], "g"), fmt(c["gamma0"], "g"), c["theta"],
              fmt(c["dt_crit_estimate"], ".4g"),
              (f"{fmt(c['dt_crit_lo'], '.4g')} – {fmt(c['dt_crit_hi'], '.4g')}"
               if c["bracket"] == "bisection" else c["bracket"]),
              fmt(c["estimate_over_measured"], ".3f") + _undecided(c)]
             for c in report["critical"] if c.get("dt_crit_estimate")]
    if table:
        lines += md_table(["scheme", "mass", "h", "γ0", "θ", "estimate", "measured",
                           "estimate / measured"], table)
        for key in dict.fromkeys(c["scheme"] for c in report["critical"]):
            ratios = [c["estimate_over_measured"] for c in report["critical"]
                      if c["scheme"] == key and c.get("estimate_over_measured")]
            if ratios:
                lines += ["", f"{key}: estimate / measured over {len(ratios)} settings: "
                          f"{min(ratios):.3f} to {max(ratios):.3f} "
                          f"(median {float(np.median(ratios)):.3f})."]
        # dt = 0 is central's only
        auto = [c for c in report["critical"] if c.get("dt_crit_estimate")
                and c["scheme"].startswith("central")]
        sides = {k: [c for c in auto if _side(c, AUTO_FACTOR * c["dt_crit_estimate"]) == k]
                 for k in ("unsafe", "safe", "in")}

        def which(cs):
            return (": " + ", ".join(f"{c['scheme']} h={c['h']:g} γ0={c['gamma0']:g} "
                                     f"θ={c['theta']:+d}" for c in cs)) if cs else ""

        lines += ["", f"Central's Δt = 0 (auto: {AUTO_FACTOR:g} × the estimate) is at or "
                  f"above the measured unstable bound in {len(sides['unsafe'])} of "
                  f"{len(auto)} settings{which(sides['unsafe'])}; at or below the measured "
                  f"stable bound in {len(sides['safe'])}; where the runs cannot tell "
                  f"(inside the bracket, or beyond the grid's end) in "
                  f"{len(sides['in'])}{which(sides['in'])}."]
    else:
        lines.append("No explicit run in the sweep.")
    if report.get("box3d"):
        lines += _box3d_summary(report)
    return write_markdown(path, lines)


def _side(c: Mapping[str, Any], dt: float) -> str:
    """Where the step dt lies against the critical row c's measured bounds: 'safe' (at
    or below a stable Δt), 'unsafe' (at or above an unstable one) or 'in' (the runs
    cannot tell: inside the bisection's bracket, or beyond the end of the grid whose
    runs all had the one verdict)."""
    lo = c.get("dt_crit_lo") if c["bracket"] in ("bisection", "above grid") else None
    hi = c.get("dt_crit_hi") if c["bracket"] in ("bisection", "below grid") else None
    if lo is not None and dt <= lo:
        return "safe"
    if hi is not None and dt >= hi:
        return "unsafe"
    return "in"


def _grid_words(c: Mapping[str, Any]) -> str:
    """What the grid's runs say about a critical Δt outside the grid's range, from the
    row's grid_stable 'k/n': stable (unstable) on the whole grid only when every run was;
    a row below the grid with a stable run above its first unstable one is
    non-monotone; runs that could not be done are neither."""
    k, n = (int(x) for x in c["grid_stable"].split("/"))
    if c["bracket"] == "above grid":
        return "stable on the whole grid" if k == n else "stable at every Δt that ran"
    if k == 0:
        return "unstable on the whole grid"
    return "unstable at the grid's smallest Δt, stable at a larger one: non-monotone"


def _undecided(c: Mapping[str, Any]) -> str:
    """' (undecided: ...)' when the row's estimate lies where its runs cannot tell
    (:func:`_side`), naming where; '' otherwise."""
    if _side(c, c["dt_crit_estimate"]) != "in":
        return ""
    where = {"bisection": "inside the bracket", "above grid": "above the grid's runs",
             "below grid": "below the grid's runs"}.get(c["bracket"], "no bracket")
    return f" (undecided: {where})"


def run_stability_scene(out: str, scene: Any, *, quick: bool = False,
                        grid: Mapping[str, Any] | None = None, cache: str | None = None,
                        workers: int | None = None, scheduler: Any = None,
                        progress: bool | None = None, log=print,
                        desc: str | None = None) -> dict[str, Any]:
    """``study stability --scene``: the critical Δt of each scheme of SCENE_GRIDS (or
    ``grid``: schemes, dt_factors, rounds) on a scene file of one's own, its mesh, mass,
    contact (h, γ0, θ) and T as given, by :func:`critical_dt` (the grid, then the
    bisection). Writes runs.csv, stability.csv, the heat maps and summary.md into
    ``out``; BadInputError (a ValueError, one line) for a missing or bad scene.
    ``scene``: a scene file's path, or a :class:`dyncontact.Scene`, written as
    ``out/scene.nml`` for the runs to read. ``desc``: the study's name in the lines of
    ``log`` and on the progress bars; by default it names the scene file (``stability
    (bar.nml) grid``); the command line gives ``stability --scene``."""
    from .common import UserSceneError, on_scene, read_user_scene, refusal_on_scene

    t0 = time.perf_counter()
    scn = read_user_scene(scene, out)
    desc = desc or f"stability ({os.path.basename(scn.path)})"
    g = dict(SCENE_GRIDS["quick" if quick else "full"])
    g.update(grid or {})
    out = os.path.abspath(out)
    os.makedirs(out, exist_ok=True)
    cache = cache or os.path.join(out, "cache")
    schemes, left_out = [], []
    for s in scheme_list(g["schemes"]):
        t = on_scene(s, scn)
        why = refusal_on_scene(t, scn)
        if why is None:
            schemes.append(t)
        else:
            left_out.append((s.key, why))
    if not schemes:
        raise UserSceneError(scn.path, "the core refuses every scheme of the study on "
                             f"it (first: {left_out[0][1]})")
    largest = scn.dt * max(f for fs in g["dt_factors"].values() for f in fs)
    if largest > scn.t_end:
        # a run whose one step passes T is refused by the core (0 < t_end < dt): said
        # once, here, rather than as runs that failed to run
        raise UserSceneError(scn.path, f"&scheme t_end = {scn.t_end:g} is shorter than the "
                             f"study's largest step, {largest:.4g} (the grid's "
                             f"{largest / scn.dt:g} × the scene's Δt): give a t_end of a few "
                             "of them at least")
    # critical_dt's grid is in Δt/h: the scene's Δt multiples over its own h, γ0, θ. A
    # .msh file's h is its own (&mesh h, which it does not use, would name every row
    # 0.05), and so is that of a .geo the scene gives no &mesh h for: it is meshed with
    # its own sizes (or its own DefineConstant h), which setting h would change
    own = os.path.splitext(scn.mesh_file)[1].lower() == ".msh" or (
        bool(scn.mesh_file) and not scn.h_given)
    h = mesh_file_h(scn.mesh_file, length=scn.length, width=scn.width) if own else scn.h
    g.update(h=(h,), gamma0=(scn.gamma0,), theta=(scn.theta,), t_end=scn.t_end,
             set_h=not own, dt_over_h={kind: tuple(f * scn.dt / h for f in fs)
                                       for kind, fs in g["dt_factors"].items()})
    crit = critical_dt(scn.path, schemes, g, out, cache, workers=workers,
                       scheduler=scheduler, progress=progress, log=log,
                       desc=desc)
    all_recs = crit["records"]
    report = {"runs": crit["runs"], "critical": crit["critical"], "csv": crit["csv"],
              "runs_csv": crit["runs_csv"],
              "pngs": _heatmaps(crit["runs"], crit["critical"], schemes, g, out,
                                scene=os.path.basename(scn.path)),
              "grid": g, "scene": scn, "schemes": schemes, "left_out": left_out,
              "n_runs": len(all_recs),
              "n_cached": sum(r["cached"] for r in all_recs),
              "n_errors": sum(r["status"] == ERROR for r in all_recs),
              "n_refused": sum(r["status"] == REFUSED for r in all_recs),
              "wall_s": time.perf_counter() - t0, "quick": quick}
    report["summary"] = _scene_summary(report, os.path.join(out, "summary.md"))
    return report


def mesh_file_h(path: str, length: float | None = None,
                width: float | None = None) -> float:
    """The size h of the mesh file ``path`` for the stability tables (Δt_crit/h, the
    heat maps): its shortest edge, which is h on every built-in mesh (the squares' and
    cubes' sides; the diagonals are longer) and bounds the explicit schemes' steps. A
    .geo is meshed as for a scene that gives no ``&mesh h`` (with ``length`` and
    ``width`` as its parameters of those names; None: as for a scene that does not give
    them, :func:`dyncontact.mesh_io.read_mesh`)."""
    from ..mesh_io import read_mesh

    m = read_mesh(path, check=False, length=length, width=width)
    k = m.cells.shape[1]
    pairs = [(i, j) for i in range(k) for j in range(i + 1, k)]
    edges = np.concatenate([m.x[m.cells[:, i]] - m.x[m.cells[:, j]] for i, j in pairs])
    return float(np.sqrt((edges ** 2).sum(axis=1)).min())


def _scene_summary(report, path) -> str:
    scn, g = report["scene"], report["grid"]
    if not scn.mesh_file:
        mesh = f"built-in mesh, h = {scn.h:g}"
    elif g.get("set_h", True):
        mesh = f"mesh file {scn.mesh_file} meshed with h = {scn.h:g}"
    else:
        mesh = f"mesh file {scn.mesh_file} (h = its shortest edge, {g['h'][0]:.4g})"
    fac = g["dt_factors"]
    # penalty and the augmented Lagrangian have no θ (their tables list θ = +1)
    theta = f", θ = {scn.theta:+d}" if scn.method == "nitsche" else ""
    lines = [
        f"# Stability on {os.path.basename(scn.path)}", "",
        f"Scene {scn.path}: {scn.dim}D, {mesh}, {scn.mass} mass, {scn.method} contact "
        f"(γ0 = {scn.gamma0:g}{theta}), T = {scn.t_end:g}, Δt = {scn.dt:g}. "
        "Each scheme runs on the scene as given (only the time scheme and Δt change) at "
        f"Δt = {{{', '.join(f'{x:.4g}' for x in fac['implicit'])}}} × the scene's Δt "
        f"(implicit), {{{', '.join(f'{x:.4g}' for x in fac['explicit'])}}} × (explicit), "
        f"then {g['rounds']} rounds of bisection in log Δt on each bracket. Verdicts are "
        "the core's: `unstable` = the energy exceeded blowup × its scale at t = 0 "
        "(e_total(0); under gravity e_total + e_load against the scale of docs/scenes.md, "
        "\"The blow-up test\") before T; a "
        "run just above the critical Δt may grow too slowly to be caught before T, so "
        "the bracket is that of this T.", "",
        f"{report['n_runs']} runs ({report['n_cached']} from the cache, "
        f"{report['n_errors']} failed to run, {report['n_refused']} refused by the core as "
        f"bad input), {report['wall_s']:.1f} s.", "",
        "## Critical Δt (stability.csv)", ""]
    table = []
    for c in report["critical"]:
        stop = f"{c['first_unstable_status']} at t={fmt(c['first_unstable_stop'], '.4g')}" \
            if c["first_unstable_status"] else ""
        table.append([c["scheme"], c["mass"], c["method"], _crit_text(c),
                      _ratio_text(c, scn.dt), c["grid_stable"],
                      "yes" if c["non_monotone"] else "",
                      fmt(c.get("dt_crit_estimate"), ".4g"), stop,
                      c["first_unstable_reason"] if c["bracket"] == "refused" else ""])
    refused = [c for c in report["critical"] if c["bracket"] == "refused"]
    left = [f"- {k}: refused by the core on this scene: {why}." for k, why in
            report["left_out"]]
    lines += md_table(["scheme", "mass", "contact", "critical Δt", "/ scene's Δt",
                       "grid stable", "non-monotone", "own estimate (explicit)",
                       "first unstable grid run", "why refused"], table)
    if refused:
        lines += ["", "Refused rows: the core does not run that scheme on this scene "
                  "(its reason in the last column)."]
    if left:
        lines += ["", "Schemes left out:", ""] + left
    lines += ["", "The charts: `stability_h*.png` has one panel per scheme, its grid runs "
              "by Δt/h (columns; h as above) coloured by verdict (the colours in its "
              "title; an unstable run's stop time written in its cell); `critical_dt.png` "
              "gives each scheme's critical Δt/h, the geometric middle of its bisection's "
              "bracket (> or < where the whole grid was stable or unstable)."]
    lines += [""] + [f"![{os.path.basename(p)}]({os.path.basename(p)})" for p in
                     report["pngs"]]
    return write_markdown(path, lines)
