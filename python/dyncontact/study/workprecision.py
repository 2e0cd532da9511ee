"""``study work-precision``: error against CPU time, one curve per scheme over its
(h, dt) ladder, on the 1D exact case and on the seed's 2D bar.

Errors at the probe, as RMS in time over [0, T]:
``(1/T int_0^T (q - q_ref)^2 dt)^(1/2)`` for q = u_n, v_n, p_n, and the same for
(e_total - e_ref) / e_ref(0). The 1D reference is the closed form
(:mod:`dyncontact.exact1d`); the 2D reference is a run of the code itself, newmark
(1/4, 1/2) on a mesh ``REF_FACTOR`` times finer than the finest of the ladder with
dt = h/20 (its trace is interpolated linearly to each run's times). Its own error is
estimated from a second reference on the mesh twice coarser: the difference d of the two
references, with the observed order p of the ladder, gives err(ref) ~ d / (2^p - 1);
points whose error is less than RESOLVED_MARGIN (3) x that estimate are flagged as not
resolved, per quantity.

CPU time: process CPU time of the worker around :func:`dyncontact.run` (set-up and trace
reading included), robust to other load on the machine. Every run writes its trace
rows OUTPUT_DT apart in time (not every step), so that output costs the same for all. Unstable runs are drawn as
crosses at the top of each panel, never dropped.
"""

from __future__ import annotations

import math
import os
import time
from typing import Any

import numpy as np

from . import analyses  # noqa: F401 - registers the analyses
from .analyses import rms_in_time
from .common import (SCHEMES, fmt, md_table, new_figure, step_ratio, write_base_scenes,
                     write_csv, write_markdown)
from .sweep import make_task, sweep

__all__ = ["run_work_precision", "QUANTITIES", "DEFAULT_SERIES"]

QUANTITIES = ("u_n", "v_n", "p_n", "e_total")
#: (scheme key, dt = h/c; None = the family's default c).
DEFAULT_SERIES = (("newmark", None), ("hht-0.05", None), ("hht-0.1", None),
                  ("theta0.5", None), ("theta1", None), ("pc", None), ("pc_hht-0.1", None),
                  ("pc", 20.0),
                  # beyond the seed: generalized-alpha, central differences (lumped, its own
                  # dt = h/4), penalty (gamma0 = 10), the redistributed mass
                  ("galpha1", None), ("galpha0.8", None), ("galpha0.5", None),
                  ("central_lumped", None), ("newmark_penalty", None),
                  ("newmark_redist", None), ("hht-0.1_redist", None),
                  # the augmented Lagrangian, integral and nodal, consistent and
                  # redistributed mass
                  ("newmark_alm", None), ("newmark_alm_nodal", None),
                  ("newmark_alm_redist", None), ("newmark_alm_nodal_redist", None))
LADDER_1D = {"full": (25, 50, 100, 200, 400), "quick": (25, 50)}
LADDER_2D = {"full": (0.1, 0.05, 0.025), "quick": (0.1, 0.05)}
REF_FACTOR = {"full": 8, "quick": 2}
T_END = {"full": 3.0, "quick": 1.5}
#: A 2D run's error counts as measured when it is at least this many times the
#: estimated error of the reference.
RESOLVED_MARGIN = 3.0
COLUMNS = "t,u_n,v_n,p_n,e_total"
#: Trace rows about this far apart in time, for every run: writing a row costs about as
#: much as a step on the small meshes, so a row per step would charge the small-step
#: schemes for output rather than for computing. The RMS-in-time errors are taken over
#: these rows (trapezoidal rule).
OUTPUT_DT = 0.0025


def _every(dt: float) -> int:
    return max(1, int(round(OUTPUT_DT / dt)))


def _series(c_implicit, c_explicit, series=DEFAULT_SERIES):
    out = []
    for key, c in series:
        s = SCHEMES[key]
        default = step_ratio(s, c_implicit, c_explicit)
        cc = c if c is not None else default
        family = c_explicit if s.explicit else c_implicit
        label = s.label + ("" if cc == family else f", Δt=h/{cc:g}")
        out.append((s, cc, label, f"{key}@{cc:g}"))
    return out


def _errors(tr: dict, ref: dict) -> dict[str, float]:
    t = tr["t"]
    e0 = float(ref["e_total"][0])
    out = {}
    for q in QUANTITIES:
        r = np.interp(t, ref["t"], ref[q])
        d = tr[q] - r
        out[f"err_{q}"] = rms_in_time(t, d / e0 if q == "e_total" else d)
    return out


def _exact_trace(t: np.ndarray) -> dict[str, np.ndarray]:
    from .. import exact1d as ex

    return {"t": t, "u_n": ex.u_n(t), "v_n": ex.v_n(t), "p_n": ex.sigma_n(t),
            "e_total": np.full_like(t, ex.ENERGY)}


def run_work_precision(out: str, *, quick: bool = False, c_implicit: float = 20.0,
                       c_explicit: float = 100.0, cache: str | None = None,
                       workers: int | None = None, scheduler: Any = None,
                       progress: bool | None = None, log=print) -> dict[str, Any]:
    """Run the study; writes work_precision.csv, work_precision.png, summary.md."""
    t0 = time.perf_counter()
    size = "quick" if quick else "full"
    out = os.path.abspath(out)
    os.makedirs(out, exist_ok=True)
    cache = cache or os.path.join(out, "cache")
    bases = write_base_scenes(os.path.join(out, "scenes"))
    t_end = T_END[size]
    series = _series(c_implicit, c_explicit)
    tasks = []
    for case, base, ladder in (("1d", bases["exact1d"], [1.0 / n for n in LADDER_1D[size]]),
                               ("2d", bases["seed2d"], list(LADDER_2D[size]))):
        for s, c, label, skey in series:
            for h in ladder:
                settings = dict(s.settings)
                settings.update({"mesh.h": h, "scheme.dt": h / c, "scheme.t_end": t_end,
                                 "output.every": _every(h / c),
                                 "output.fields_every": 0})
                tasks.append(make_task(base, settings, "trace", {"columns": COLUMNS},
                                       tags={"case": case, "series": skey, "label": label,
                                             "scheme": s.key, "h": h, "dt": h / c,
                                             "c": c}))
    h_ref = LADDER_2D[size][-1] / REF_FACTOR[size]
    refs = []
    for h in (h_ref, 2 * h_ref):
        settings = dict(SCHEMES["newmark"].settings)
        settings.update({"mesh.h": h, "scheme.dt": h / 20.0, "scheme.t_end": t_end,
                         "output.every": _every(h / 20.0), "output.fields_every": 0})
        refs.append(make_task(bases["seed2d"], settings, "trace", {"columns": COLUMNS},
                              tags={"case": "2d-ref", "h": h, "dt": h / 20.0}))
    recs = sweep(tasks + refs, cache, workers=workers, scheduler=scheduler,
                 progress=progress, desc="work-precision", log=log)
    run_recs, ref_recs = recs[:len(tasks)], recs[len(tasks):]
    ref_ok = all(r["status"] == "ok" for r in ref_recs)
    ref, ref2 = (r["arrays"] for r in ref_recs) if ref_ok else ({}, {})
    rows = []
    for r in run_recs:
        tg = dict(r["task"].tags)
        row = {k: tg[k] for k in ("case", "series", "label", "scheme", "h", "dt", "c")}
        row.update(status=r["status"], t_end_reached=r.get("t_end_reached"),
                   steps=r.get("steps"), cpu_s=r.get("cpu_s"), wall_s=r.get("wall_s"),
                   newton_its_total=r.get("newton_its_total"),
                   message=(r.get("message") or "").splitlines()[0] if r.get("message")
                   else "")
        tr = r.get("arrays") or {}
        if tr and len(tr.get("t", ())) > 1:
            truth = _exact_trace(tr["t"]) if tg["case"] == "1d" else ref
            if truth:
                row.update(_errors(tr, truth))
        rows.append(row)
    # the 2D reference's own error
    ref_info: dict[str, Any] = {"h_ref": h_ref, "dt_ref": h_ref / 20.0, "ok": ref_ok,
                                "status": [r["status"] for r in ref_recs],
                                "cpu_s": [r.get("cpu_s") for r in ref_recs]}
    if ref_ok:
        diff = _errors(ref2, ref)
        for q in QUANTITIES:
            p = _observed_order([x for x in rows if x["case"] == "2d"], q)
            ref_info[f"diff_{q}"] = diff[f"err_{q}"]
            ref_info[f"order_{q}"] = p
            pe = p if (p == p and p > 0.2) else 0.2   # a pessimistic floor on the order
            ref_info[f"est_{q}"] = diff[f"err_{q}"] / (2 ** pe - 1)
        for x in rows:
            if x["case"] == "2d":
                for q in QUANTITIES:
                    x[f"resolved_{q}"] = bool(
                        x.get(f"err_{q}") is None
                        or x[f"err_{q}"] >= RESOLVED_MARGIN * ref_info[f"est_{q}"])
    cols = ["case", "series", "scheme", "h", "dt", "c", "status", "t_end_reached", "steps",
            "cpu_s", "wall_s", "newton_its_total", *(f"err_{q}" for q in QUANTITIES),
            *(f"resolved_{q}" for q in QUANTITIES), "message"]
    csv_path = write_csv(os.path.join(out, "work_precision.csv"), rows, cols)
    png = _plot(rows, series, ref_info, os.path.join(out, "work_precision.png"))
    cheapest = _cheapest(rows)
    report = {"rows": rows, "ref": ref_info, "cheapest": cheapest, "csv": csv_path,
              "png": png, "n_runs": len(recs), "n_cached": sum(r["cached"] for r in recs),
              "n_errors": sum(r["status"] == "error" for r in recs), "t_end": t_end,
              "quick": quick, "wall_s": time.perf_counter() - t0, "size": size}
    report["summary"] = _summary(report, os.path.join(out, "summary.md"))
    return report


def _observed_order(rows, q) -> float:
    """Median over the series of the slope of log err against log h (ok runs)."""
    from .common import slope

    slopes = []
    for key in sorted({r["series"] for r in rows}):
        mine = [r for r in rows if r["series"] == key and r["status"] == "ok"
                and r.get(f"err_{q}")]
        if len(mine) >= 2:
            slopes.append(slope([r["h"] for r in mine], [r[f"err_{q}"] for r in mine]))
    return float(np.median(slopes)) if slopes else float("nan")


def _levels(values) -> list[float]:
    """Error levels 1 and 3 x 10^k from the smallest one reached up to the first one that
    every run reaches."""
    v = [x for x in values if x and math.isfinite(x) and x > 0]
    if not v:
        return []
    lo, hi = math.floor(math.log10(min(v))), math.ceil(math.log10(max(v)))
    cand = sorted(m * 10.0 ** k for k in range(lo, hi + 1) for m in (1.0, 3.0))
    top = next(c for c in cand if c >= max(v))
    return [c for c in cand if min(v) <= c <= top]


def _cheapest(rows) -> list[dict[str, Any]]:
    """For each case, quantity and error level: the cheapest ok run reaching it."""
    out = []
    for case in ("1d", "2d"):
        for q in QUANTITIES:
            key = f"err_{q}"
            mine = [r for r in rows if r["case"] == case and r["status"] == "ok"
                    and r.get(f"resolved_{q}", True)]
            vals = [r[key] for r in mine if r.get(key) is not None]
            for level in sorted(_levels(vals), reverse=True):
                ok = [r for r in mine if r.get(key) is not None and r[key] <= level
                      and r.get("cpu_s")]
                if not ok:
                    continue
                best = min(ok, key=lambda r: r["cpu_s"])
                out.append({"case": case, "quantity": q, "level": level,
                            "label": best["label"], "h": best["h"], "dt": best["dt"],
                            "cpu_s": best["cpu_s"], "err": best[key]})
    return out


def _plot(rows, series, ref_info, path):
    import matplotlib.pyplot as plt

    fig, axes = new_figure(2, 4, 3.9, 3.3)
    colors = plt.get_cmap("tab20").colors
    for i, case in enumerate(("1d", "2d")):
        for j, q in enumerate(QUANTITIES):
            ax = axes[i, j]
            key = f"err_{q}"
            finite = [r[key] for r in rows if r["case"] == case and r.get(key)
                      and r["status"] == "ok" and math.isfinite(r[key])]
            top = 2.0 * max(finite) if finite else 1.0
            for k, (s, c, label, skey) in enumerate(series):
                col = colors[k % len(colors)]
                mine = [r for r in rows if r["case"] == case and r["series"] == skey]
                ok = [r for r in mine if r["status"] == "ok" and r.get(key) and r.get("cpu_s")]
                if ok:
                    ax.loglog([r["cpu_s"] for r in ok], [r[key] for r in ok], "o-", ms=3,
                              color=col, label=label)
                    unres = [r for r in ok if r.get(f"resolved_{q}") is False]
                    if unres:
                        ax.loglog([r["cpu_s"] for r in unres], [r[key] for r in unres], "o",
                                  mfc="none", mec="k", ms=7)
                bad = [r for r in mine if r["status"] != "ok" and r.get("cpu_s")]
                if bad:
                    ax.loglog([r["cpu_s"] for r in bad], [top] * len(bad), "x", color=col,
                              ms=8, mew=2, label=f"{label}: {bad[0]['status']}")
            if case == "2d" and ref_info.get(f"est_{q}"):
                ax.axhline(ref_info[f"est_{q}"], color="k", ls=":", lw=0.8,
                           label="reference error (est.)" if j == 0 else None)
            ax.set_title(f"{'1D exact case' if case == '1d' else '2D seed bar'}: "
                         f"{q}", fontsize=9)
            ax.set_xlabel("CPU s")
            ax.set_ylabel("RMS error" + (" / e(0)" if q == "e_total" else ""))
            ax.grid(True, which="both", alpha=0.3)
    from matplotlib.ticker import NullFormatter

    for ax in axes.flat:
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.yaxis.set_minor_formatter(NullFormatter())
    h, lab = axes[0, 0].get_legend_handles_labels()
    h2, lab2 = axes[1, 0].get_legend_handles_labels()
    seen = dict(zip(lab, h))
    seen.update({a: b for a, b in zip(lab2, h2) if a not in seen})
    fig.legend(list(seen.values()), list(seen.keys()), loc="center right", fontsize=7,
               title="open circle: not resolved by the reference", title_fontsize=7)
    fig.tight_layout(rect=(0, 0, 0.82, 1))
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _summary(report, path) -> str:
    rows, ref = report["rows"], report["ref"]
    lad1 = LADDER_1D[report["size"]]
    lad2 = LADDER_2D[report["size"]]
    lines = [
        "# Work–precision", "",
        f"T = {report['t_end']:g}. 1D exact case: h = {', '.join('1/' + str(n) for n in lad1)}"
        f" against the closed form. 2D seed bar (θ = 1, γ0 = 10): h = "
        f"{', '.join(f'{h:g}' for h in lad2)} against a reference computed by the code "
        f"(newmark ¼ ½, h = {ref['h_ref']:g}, Δt = {ref['dt_ref']:g}). Each curve runs over "
        f"h with Δt = h/c. Errors: RMS in time of the probe quantity minus the reference "
        f"(e_total relative to e(0)); x axis: CPU seconds of the run. Unstable runs: "
        f"crosses at the top of the panel.", "",
        f"{report['n_runs']} runs ({report['n_cached']} from the cache, "
        f"{report['n_errors']} failed to run), {report['wall_s']:.1f} s.", "",
        "![work-precision](work_precision.png)", "",
        "## Is the 2D reference converged enough?", ""]
    if ref["ok"]:
        lines += [
            f"Difference between the reference and the same run on the mesh twice coarser "
            f"(h = {2 * ref['h_ref']:g}), the observed order p of the ladder, and the "
            f"estimated error of the reference d/(2^p − 1) (p floored at 0.2), against the "
            f"smallest error plotted:", ""]
        table = []
        for q in QUANTITIES:
            errs = [r[f"err_{q}"] for r in rows if r["case"] == "2d" and r["status"] == "ok"
                    and r.get(f"err_{q}")]
            smallest = min(errs) if errs else float("nan")
            est = ref[f"est_{q}"]
            n_unres = sum(1 for r in rows if r["case"] == "2d" and r.get(f"resolved_{q}") is False)
            n_all = sum(1 for r in rows if r["case"] == "2d" and r.get(f"err_{q}") is not None)
            verdict = "yes" if est * RESOLVED_MARGIN <= smallest else \
                f"no for {n_unres} of {n_all} runs: flagged (open circles), left out of the " \
                "cheapest-scheme table"
            table.append([q, fmt(ref[f"diff_{q}"]), fmt(ref[f"order_{q}"], ".2f"),
                          fmt(est), fmt(smallest), verdict])
        lines += md_table(["quantity", "d", "p", "est. error of ref", "smallest error",
                           f"converged enough ({RESOLVED_MARGIN:g}× margin)"], table)
    else:
        lines += [f"The reference runs did not finish: {ref['status']}."]
    lines += ["", "## Cheapest scheme per error level", "",
              "For each error level, the run of least CPU time whose error is at most the "
              "level (ok runs only; 2D runs not resolved by the reference are left out).", ""]
    table = [[c["case"], c["quantity"], fmt(c["level"], ".0e"), c["label"], fmt(c["h"], ".4g"),
              fmt(c["dt"], ".3g"), fmt(c["cpu_s"], ".3f"), fmt(c["err"])]
             for c in report["cheapest"]]
    lines += md_table(["case", "quantity", "error ≤", "cheapest scheme", "h", "Δt", "CPU s",
                       "its error"], table)
    bad = [r for r in rows if r["status"] != "ok"]
    lines += ["", "## Runs that did not finish", ""]
    if bad:
        lines += md_table(["case", "scheme", "h", "Δt", "status", "stopped at t", "message"],
                          [[r["case"], r["label"], fmt(r["h"], ".4g"), fmt(r["dt"], ".3g"),
                            r["status"], fmt(r.get("t_end_reached"), ".4g"), r["message"]]
                           for r in bad])
    else:
        lines.append("None.")
    return write_markdown(path, lines)
