"""The "which scheme should I use" table: picks computed from runs,
never written by hand, for the 1D exact case and the seed's 2D bar.

- **Cheapest for a given error** in u_n, p_n and e_total: from the work-precision runs
  (:mod:`.workprecision`). Two levels: the smallest 1 or 3 x 10^k that at least half of
  the curves reach (so that most options compete), and ("a small error") the smallest
  that at least two curves reach; the pick is the run of least CPU time
  with an error at most that level (ok runs; on the 2D bar only runs the reference
  resolves), the runner-up the cheapest run of another curve. A pick that ran for less
  than the work-precision study's SHORT_CPU_S says so: its ranking is not reliable.
- **Least p_n oscillation**: an own sweep, every scheme on one mesh (1D h = 0.01,
  T = 3; 2D h = 0.05, T = 15) with its work-precision step Δt = h/c and the trace written
  every step. Measure (:func:`.analyses.pn_oscillation`): the standard deviation of p_n
  over the interior of the contact phases (each phase without its first and last 20 %)
  divided by |mean p_n| there; the total variation per unit contact time is reported
  beside it. The energy E = e_total + e_contact is reported over the first step, the
  first contact phase and the whole run, since a remedy that kills the oscillation may
  cost energy. Two picks: the least oscillation of all, and the least among the schemes
  that neither lose nor gain a significant amount of energy at impact: |E change across
  the first contact phase| ≤ 1 % of E(0) (the claims table's "significant",
  :mod:`.claims`).
- **Most robust in γ0 and Δt**: an option is a scheme with a Nitsche θ (θ is the user's
  choice too; penalty and ALM contact have none). Its runs over γ0 x Δt/h (Δt/h from the
  values every scheme was swept at) are counted as stable, not stable (unstable, Newton failed,
  failed to run) and refused (the core refuses the setting as bad input: θ = 1 with γ0
  below its bound). Its score is the fraction of stable runs among the settings it
  accepts (stable + not stable): a refused setting is the user being told no, not a run
  that went wrong, so it neither counts against an option nor for it. 2D: the stability
  study's grid runs (every h). 1D: an own sweep of the same grid (h = 0.02, T = 15, five
  impacts). Ties are broken by the smallest, over the accepted γ0, largest stable Δt/h
  below the first one that is not stable (the top of the grid when all are stable), and
  listed when they remain.
"""

from __future__ import annotations

import math
import os
import time
from typing import Any, Mapping

import numpy as np

from . import analyses  # noqa: F401 - registers the analyses
from .common import (SCHEMES, fmt, md_table, scheme_list, step_ratio, study_folder,
                     write_csv, write_markdown)
from .stability import thetas
from .claims import SIGNIFICANT_GAIN
from .sweep import REFUSED, make_task, sweep
from .workprecision import SHORT_CPU_S

__all__ = ["run_which", "OSC_SCHEMES", "OSC_SIZES", "ROBUST_1D", "cheapest",
           "cheapest_evidence"]

#: Schemes of the oscillation sweep: the work-precision set (with the augmented
#: Lagrangian's rows) plus implicit lumped mass and stiffer penalties (γ0 = 100, 1000).
OSC_SCHEMES = ("newmark", "newmark_lumped", "hht-0.05", "hht-0.1", "theta0.5", "theta1",
               "galpha1", "galpha0.8", "galpha0.5", "pc", "pc_hht-0.1", "central_lumped",
               "newmark_penalty", "newmark_penalty100", "newmark_penalty1000",
               "newmark_redist", "hht-0.1_redist", "newmark_alm", "newmark_alm_nodal",
               "newmark_alm_redist", "newmark_alm_nodal_redist")
#: (case, h, T) of the oscillation sweep; the 1D case also at h/2 and 2h for the energy
#: of the redistributed mass (first order in h).
OSC_SIZES = {"full": (("1d", 0.02, 3.0), ("1d", 0.01, 3.0), ("1d", 0.005, 3.0),
                      ("2d", 0.05, 15.0)),
             "quick": (("1d", 0.02, 3.0), ("2d", 0.1, 8.0))}
#: The 1D mesh on which the oscillation is ranked (the 2D one is the only one).
OSC_RANK_H = {"full": {"1d": 0.01, "2d": 0.05}, "quick": {"1d": 0.02, "2d": 0.1}}
#: The 1D robustness sweep: h, T (five periods) and the grid of the stability study.
ROBUST_1D = {"h": 0.02, "t_end": 15.0}
#: trace rows this far apart in time in the robustness sweep (the verdict is the core's)
ROBUST_OUTPUT_DT = 0.01
QUANTITIES = ("u_n", "p_n", "e_total")
CASE_NAME = {"1d": "1D exact case", "2d": "2D seed bar"}


def _osc_tasks(bases, size, c_implicit, c_explicit):
    tasks = []
    for case, h, t_end in OSC_SIZES[size]:
        base = bases["exact1d" if case == "1d" else "seed2d"]
        for s in scheme_list(OSC_SCHEMES):
            c = step_ratio(s, c_implicit, c_explicit)
            settings = dict(s.settings)
            settings.update({"mesh.h": h, "scheme.dt": h / c, "scheme.t_end": t_end,
                             "output.every": 1, "output.fields_every": 0})
            tasks.append(make_task(base, settings, "contact",
                                   tags={"case": case, "scheme": s.key, "label": s.label,
                                         "h": h, "dt": h / c, "t_end": t_end}))
    return tasks


def _robust_tasks(base, grid, ratios):
    tasks = []
    h = ROBUST_1D["h"]
    for s in scheme_list(grid["schemes"]):
        for g0, th, r in ((g0, th, r) for g0 in grid["gamma0"] for th in thetas(s, grid)
                          for r in ratios):
            dt = h * r
            settings = dict(s.settings)
            if s.method == "nitsche":   # penalty and ALM have no theta (th = 1, the default)
                settings["contact.theta"] = th
            settings.update({"mesh.h": h, "contact.gamma0": g0,
                             "scheme.dt": dt, "scheme.t_end": ROBUST_1D["t_end"],
                             "output.every": max(1, int(round(ROBUST_OUTPUT_DT / dt))),
                             "output.fields_every": 0})
            tasks.append(make_task(base, settings, "trace",
                                   tags={"scheme": s.key, "gamma0": g0, "theta": th,
                                         "dt_over_h": r, "h": h}))
    return tasks


def common_ratios(grid: Mapping[str, Any]) -> list[float]:
    """Δt/h values that both the implicit and the explicit grids of the sweep hold."""
    imp = grid["dt_over_h"]["implicit"]
    exp = grid["dt_over_h"]["explicit"]
    return sorted(r for r in imp if any(math.isclose(r, x, rel_tol=1e-9) for x in exp))


def robustness(rows, options, gammas, ratios) -> list[dict[str, Any]]:
    """Per option (scheme, θ) over the grid points γ0 x Δt/h: ``stable`` (status ok),
    ``refused`` (the core refused the setting as bad input), ``unstable`` (any other
    status, or no run), ``total`` = their sum, ``accepted`` = total − refused and
    ``score`` = stable / accepted (nan when every setting is refused); and
    ``min_stable_dt_over_h``, the smallest over γ0 of the largest stable Δt/h below the
    first accepted one that is not stable (the top of the grid when all are stable;
    refused settings are skipped, a γ0 with every setting refused is left out; inf when
    no setting is accepted)."""
    out = []
    for s, th in options:
        stable, unstable, refused, worst = 0, 0, 0, math.inf
        for g0 in gammas:
            first_bad, seen = None, []
            for r in ratios:
                row = next((x for x in rows if x["scheme"] == s and x["gamma0"] == g0
                            and x["theta"] == th
                            and math.isclose(x["dt_over_h"], r, rel_tol=1e-9)), None)
                if row is not None and row["status"] == REFUSED:
                    refused += 1
                    continue
                seen.append(r)
                ok = row is not None and row["status"] == "ok"
                stable += ok
                unstable += not ok
                if not ok and first_bad is None:
                    first_bad = r
            if seen:
                below = [r for r in seen if first_bad is None or r < first_bad]
                worst = min(worst, max(below) if below else 0.0)
        out.append(_scored({"scheme": s, "theta": th, "stable": stable,
                            "unstable": unstable, "refused": refused,
                            "min_stable_dt_over_h": worst}))
    return out


def _scored(x: dict[str, Any]) -> dict[str, Any]:
    """x with total, accepted and score from its stable, unstable and refused counts."""
    x["total"] = x["stable"] + x["unstable"] + x["refused"]
    x["accepted"] = x["stable"] + x["unstable"]
    x["score"] = x["stable"] / x["accepted"] if x["accepted"] else float("nan")
    return x


def _best(items, key, reverse=False):
    """The items with the best key (ties kept)."""
    vals = [key(x) for x in items if key(x) == key(x)]
    if not vals:
        return []
    b = max(vals) if reverse else min(vals)
    return [x for x in items if key(x) == b]


def _level(rows, q, tight=False) -> float | None:
    """The smallest 1 or 3 x 10^k that at least half of the curves reach, or with
    ``tight`` that at least two curves reach."""
    best = {}
    for r in rows:
        v = r.get(f"err_{q}")
        if v is not None and math.isfinite(v) and v > 0:
            best[r["series"]] = min(best.get(r["series"], math.inf), v)
    if not best:
        return None
    vals = sorted(best.values())
    need = vals[min(1, len(vals) - 1)] if tight else vals[(len(vals) + 1) // 2 - 1]
    k = math.floor(math.log10(need))
    for m in (1.0, 3.0, 10.0):
        if m * 10.0 ** k >= need * (1 - 1e-12):
            return m * 10.0 ** k
    return 10.0 ** (k + 1)


def cheapest(wp_rows, case, q, tight=False) -> dict[str, Any] | None:
    ok = [r for r in wp_rows if r["case"] == case and r["status"] == "ok"
          and r.get(f"resolved_{q}", True) and r.get(f"err_{q}") is not None
          and r.get("cpu_s")]
    level = _level(ok, q, tight)
    if level is None:
        return None
    reach = sorted((r for r in ok if r[f"err_{q}"] <= level), key=lambda r: r["cpu_s"])
    if not reach:
        return None
    pick = reach[0]
    other = next((r for r in reach if r["series"] != pick["series"]), None)
    n_curves = len({r["series"] for r in reach})
    return {"level": level, "pick": pick, "runner_up": other, "n_curves": n_curves,
            "n_all": len({r["series"] for r in ok})}


def cheapest_evidence(c: Mapping[str, Any], q: str, tight: bool = False) -> str:
    """The evidence of a :func:`cheapest` pick: the level, the pick and the runner-up
    with their CPU times; and, when the pick ran for less than SHORT_CPU_S, that its
    ranking is not reliable (the work-precision summary's caveat: at that length a run's
    time varies by about as much as the runs differ)."""
    p, o = c["pick"], c["runner_up"]
    which_lvl = "the level at least two" if tight else "the level half"
    ev = (f"error ≤ {c['level']:.0e} ({which_lvl} of the {c['n_all']} curves "
          f"reach; {c['n_curves']} reach it): {p['label']} at h = {p['h']:.4g}, "
          f"Δt = {p['dt']:.3g}, {p['cpu_s']:.3f} CPU s, error {p[f'err_{q}']:.3g}")
    if o is not None:
        ev += (f"; runner-up {o['label']} at h = {o['h']:.4g}, {o['cpu_s']:.3f} CPU s "
               f"({o['cpu_s'] / p['cpu_s']:.2g}×)")
    if p["cpu_s"] < SHORT_CPU_S:
        ev += (f"; the pick ran for less than {SHORT_CPU_S * 1e3:g} ms of CPU, where a "
               "run's time varies by about as much as the runs differ: the ranking is not "
               "reliable (a longer T or a finer mesh makes the runs long enough to rank)")
    return ev


def run_which(out: str, wp: Mapping[str, Any], stab: Mapping[str, Any], *,
              quick: bool = False, c_implicit: float = 20.0, c_explicit: float = 100.0,
              cache: str | None = None, workers: int | None = None, scheduler: Any = None,
              progress: bool | None = None, log=print) -> dict[str, Any]:
    """Build the table from the work-precision report ``wp``, the stability report
    ``stab`` and two sweeps of its own; writes oscillation.csv, robustness.csv,
    which.csv and summary.md into ``out``."""
    t0 = time.perf_counter()
    size = "quick" if quick else "full"
    out, cache, bases = study_folder(out, cache)
    grid = stab["grid"]
    ratios = common_ratios(grid)
    osc_tasks = _osc_tasks(bases, size, c_implicit, c_explicit)
    rob_tasks = _robust_tasks(bases["exact1d"], grid, ratios)
    recs = sweep(osc_tasks + rob_tasks, cache, workers=workers, scheduler=scheduler,
                 progress=progress, desc="which-scheme", log=log)
    osc_recs, rob_recs = recs[:len(osc_tasks)], recs[len(osc_tasks):]
    osc = []
    for r in osc_recs:
        row = dict(r["task"].tags)
        row.update(status=r["status"], cpu_s=r.get("cpu_s"))
        row.update({k: v for k, v in r.get("metrics", {}).items()})
        osc.append(row)
    osc_cols = ["case", "scheme", "h", "dt", "t_end", "status", "cpu_s", "contact_phases",
                "contact_time", "pn_mean", "pn_rel_std", "pn_tv_rate", "e_first_row",
                "e_first_contact", "ec_end_ratio"]
    osc_csv = write_csv(os.path.join(out, "oscillation.csv"), osc, osc_cols)
    # robustness: 2D from the stability grid runs, 1D from the own sweep
    rob_rows_1d = []
    for r in rob_recs:
        tg = dict(r["task"].tags)
        rob_rows_1d.append({"scheme": tg["scheme"], "gamma0": tg["gamma0"],
                            "theta": tg["theta"], "dt_over_h": tg["dt_over_h"],
                            "status": r["status"]})
    rob_rows_2d = [x for x in stab["runs"] if x["phase"] == "grid"]
    hs2 = sorted({x["h"] for x in rob_rows_2d})
    options = [(s.key, th) for s in scheme_list(grid["schemes"]) for th in thetas(s, grid)]
    robust = []
    for case, rows_c in (("1d", [rob_rows_1d]),
                         ("2d", [[x for x in rob_rows_2d if x["h"] == h] for h in hs2])):
        per = {}
        for rows in rows_c:   # 2D: every h of the sweep; the counts add up
            for x in robustness(rows, options, grid["gamma0"], ratios):
                p = per.setdefault((x["scheme"], x["theta"]),
                                   {"scheme": x["scheme"], "theta": x["theta"], "stable": 0,
                                    "unstable": 0, "refused": 0,
                                    "min_stable_dt_over_h": math.inf})
                for k in ("stable", "unstable", "refused"):
                    p[k] += x[k]
                p["min_stable_dt_over_h"] = min(p["min_stable_dt_over_h"],
                                                x["min_stable_dt_over_h"])
        for p in per.values():
            p["case"] = case
            robust.append(_scored(p))
    rob_csv = write_csv(os.path.join(out, "robustness.csv"), robust,
                        ["case", "scheme", "theta", "stable", "unstable", "refused",
                         "accepted", "total", "score", "min_stable_dt_over_h"])
    # the picks
    picks = []
    for case in ("1d", "2d"):
        for q, tight in ((q, t) for q in QUANTITIES for t in (False, True)):
            c = cheapest(wp["rows"], case, q, tight)
            question = f"cheapest for {'a small' if tight else 'a given'} error in {q}"
            if c is None:
                if not tight:
                    picks.append({"case": case, "question": question, "pick": "-",
                                  "evidence": "no run reached any level (in 2D: none "
                                              "resolved by the reference)"})
                continue
            if tight and c["level"] == cheapest(wp["rows"], case, q)["level"]:
                continue
            picks.append({"case": case, "question": question, "pick": c["pick"]["label"],
                          "evidence": cheapest_evidence(c, q, tight)})
        h_rank = OSC_RANK_H[size][case]
        mine = [x for x in osc if x["case"] == case and math.isclose(x["h"], h_rank)
                and x["status"] == "ok" and x.get("pn_rel_std") == x.get("pn_rel_std")
                and x.get("pn_rel_std") is not None]
        mine.sort(key=lambda x: x["pn_rel_std"])
        keep = [x for x in mine if x.get("e_first_contact") is not None
                and abs(x["e_first_contact"]) <= SIGNIFICANT_GAIN]
        for question, cands in (
                ("least p_n oscillation", mine),
                (f"least p_n oscillation with the energy kept within "
                 f"{100 * SIGNIFICANT_GAIN:g} % across the first impact", keep)):
            if cands:
                picks.append({"case": case, "question": question,
                              "pick": cands[0]["label"],
                              "evidence": _osc_evidence(cands, mine, h_rank)})
        rob = [x for x in robust if x["case"] == case]
        top = _best(rob, lambda x: x["score"], reverse=True)
        top = _best(top, lambda x: x["min_stable_dt_over_h"], reverse=True)
        if top:
            labels = ", ".join(_option(x) for x in top)
            x = top[0]
            ev = (f"stable in {x['stable']}/{x['accepted']} accepted settings "
                  f"({x['refused']} refused) of γ0 ∈ "
                  f"{{{', '.join(f'{g:g}' for g in grid['gamma0'])}}} × Δt/h ∈ "
                  f"{{{', '.join(f'{r:.3g}' for r in ratios)}}}"
                  + (" (every h of the stability sweep)" if case == "2d" else
                     f" (h = {ROBUST_1D['h']:g}, T = {ROBUST_1D['t_end']:g})")
                  + f"; {len(top)} tied" + (f": {labels}" if len(top) > 1 else ""))
            others = sorted((y for y in rob if y not in top and y["accepted"]),
                            key=lambda y: -y["score"])
            if others:
                ev += "; then " + ", ".join(f"{_option(y)} {y['stable']}/{y['accepted']}"
                                            for y in others[:4])
            ev += "; scores count only the settings each option accepts"
            picks.append({"case": case, "question": "most robust in γ0 and Δt",
                          "pick": labels if len(top) <= 3 else
                          f"{len(top)} options tie (listed in the evidence)",
                          "evidence": ev})
    which_csv = write_csv(os.path.join(out, "which.csv"), picks,
                          ["case", "question", "pick", "evidence"])
    report = {"picks": picks, "oscillation": osc, "robustness": robust, "csv": which_csv,
              "osc_csv": osc_csv, "rob_csv": rob_csv, "n_runs": len(recs),
              "n_cached": sum(r["cached"] for r in recs),
              "n_errors": sum(r["status"] == "error" for r in recs),
              "wall_s": time.perf_counter() - t0, "size": size, "ratios": ratios}
    report["summary"] = _summary(report, os.path.join(out, "summary.md"))
    return report


def _option(x) -> str:
    """'label θ=±1', or the label alone for penalty and ALM contact (no θ)."""
    s = SCHEMES[x["scheme"]]
    return s.label if s.method != "nitsche" else f"{s.label}, Nitsche θ={x['theta']}"


def _osc_evidence(cands, mine, h_rank) -> str:
    best = cands[0]
    ev = (f"std(p_n)/|mean p_n| over the contact phases' interior at h = {h_rank:g}: "
          f"{best['pn_rel_std']:.3g} (TV {best['pn_tv_rate']:.3g} per unit contact time)")
    if len(cands) > 1:
        ev += f"; next {cands[1]['label']} {cands[1]['pn_rel_std']:.3g}"
    base = next((x for x in mine if x["scheme"] == "newmark"), None)
    if base is not None and base is not best:
        ev += f"; newmark ¼ ½ consistent {base['pn_rel_std']:.3g} (TV {base['pn_tv_rate']:.3g})"
    ev += (f". Energy E = e_total + e_contact: {100 * best['e_first_row']:+.2f} % in the "
           f"first step, {100 * best['e_first_contact']:+.2f} % across the first contact, "
           f"{100 * (best['ec_end_ratio'] - 1):+.2f} % by T = {best['t_end']:g}")
    return ev


def _summary(report, path) -> str:
    lines = ["# Which scheme should I use?", "",
             "Every pick below is computed from runs (work-precision, stability and the two "
             "sweeps of this table); see `python/dyncontact/study/which.py` for the rules.", "",
             f"{report['n_runs']} runs of its own ({report['n_cached']} from the cache, "
             f"{report['n_errors']} failed to run), {report['wall_s']:.1f} s.", ""]
    lines += md_table(["case", "question", "pick", "evidence"],
                      [[CASE_NAME[p["case"]], p["question"], p["pick"], p["evidence"]]
                       for p in report["picks"]])
    lines += ["", "## p_n oscillation and energy (oscillation.csv)", "",
              "rel. std = std(p_n)/|mean p_n| over the contact phases without their first and "
              "last 20 %; TV = total variation of p_n per unit contact time (trace written "
              "every step); energy changes of E = e_total + e_contact relative to E(0): over "
              "the first step, across the first contact phase (from the row before the "
              "impact to the row after the release), and from 0 to T.", ""]
    table = []
    for x in sorted(report["oscillation"], key=lambda x: (x["case"], x["h"],
                                                          x.get("pn_rel_std") or math.inf)):
        table.append([CASE_NAME[x["case"]], fmt(x["h"], "g"), SCHEMES[x["scheme"]].label,
                      x["status"], fmt(x.get("pn_mean"), ".3f"), fmt(x.get("pn_rel_std")),
                      fmt(x.get("pn_tv_rate")),
                      fmt(_pct(x.get("e_first_row")), "+.3f"),
                      fmt(_pct(x.get("e_first_contact")), "+.3f"),
                      fmt(_pct((x.get("ec_end_ratio") or float("nan")) - 1), "+.3f")])
    lines += md_table(["case", "h", "scheme", "status", "mean p_n", "rel. std", "TV",
                       "E first step %", "E first contact %", "E(T)−E(0) %"], table)
    lines += ["", "## Robustness (robustness.csv)", "",
              "Each option's settings γ0 × Δt/h are counted as stable, not stable (unstable, "
              "Newton failed or failed to run) and refused (bad input for the core: θ = 1 "
              "with γ0 below its bound). The score is stable / (stable + not stable): "
              "options are ranked only among the settings each one accepts, so a refused "
              "setting counts neither for nor against an option.", ""]
    table = [[CASE_NAME[x["case"]], _option(x), str(x["stable"]), str(x["unstable"]),
              str(x["refused"]), fmt(x["score"], ".3f"),
              fmt(x["min_stable_dt_over_h"], ".3g")]
             for x in sorted(report["robustness"],
                             key=lambda x: (x["case"], -_num(x["score"])))]
    lines += md_table(["case", "option", "stable", "not stable", "refused",
                       "score (of accepted)", "smallest stable Δt/h over γ0"], table)
    return write_markdown(path, lines)


def _num(x) -> float:
    """x, or -inf for nan (sorts last when negated)."""
    return x if x == x else -math.inf


def _pct(x):
    return 100 * x if x is not None and x == x else None
