"""``study methods``: contact method x mass x scheme on the seed's 2D bar.

Methods: Nitsche theta = -1, 0, 1, penalty (eps_N = gamma0/h_T) and the augmented
Lagrangian with integral and nodal multipliers (r = gamma0/h_T), all at gamma0 = 10 with
the exact contact quadrature; masses consistent, lumped, redistributed; schemes newmark
1/4 1/2 (trapezoidal) and hht alpha = -0.1. Seed bar, h = 0.05, dt = h/20, T = 15 (quick:
h = 0.1, T = 3). Per run (from its trace):

- energy drift: E(T)/E(0) - 1 with E = e_total + e_contact (Nitsche's discrete energy; ALM
  stores none), and the largest E(t)/E(0);
- p_n over t in [1.2, 1.8] (the interior of the first contact phase at the probe, which
  runs from about 1.14 to 2.27 at h = 0.1) against the thin-bar value PN_BAR = -3/8: mean
  error and standard deviation (the chatter). The 1D closed form's contact stress is
  -amplitude x the bar's modulus, -1/2 for E = 1; the seed's strip has free lateral
  sides in plane strain, so its bar modulus is E/(1 - nu^2) = 0.75 (as docs/numerics.md
  says of Fig. 8; its waves and its contact phase run at c = 0.87), and its stress -3/8;
- penetration max u_n (g = 0 at the probe), Newton iterations a step, and the core's
  verdict (stable or unstable).

Writes methods.csv, methods.png and summary.md into --out.
"""

from __future__ import annotations

import os
import time
from typing import Any

import numpy as np

from .common import fmt, md_table, new_figure, save_figure, write_base_scenes, write_csv, \
    write_markdown
from .sweep import ERROR, make_task, register_analysis, sweep

__all__ = ["run_methods", "METHODS", "MASSES", "SCHEMES", "PN_BAR"]

#: Contact methods: label -> scene keys.
METHODS = {
    "nitsche -1": {"contact.method": "nitsche", "contact.theta": -1},
    "nitsche 0": {"contact.method": "nitsche", "contact.theta": 0},
    "nitsche 1": {"contact.method": "nitsche", "contact.theta": 1},
    "penalty": {"contact.method": "penalty"},
    "alm integral": {"contact.method": "alm", "contact.multiplier": "integral"},
    "alm nodal": {"contact.method": "alm", "contact.multiplier": "nodal"},
}
MASSES = ("consistent", "lumped", "redistributed")
#: Schemes: label -> scene keys.
SCHEMES = {
    "newmark": {"scheme.name": "newmark", "scheme.beta": 0.25, "scheme.gamma": 0.5},
    "hht -0.1": {"scheme.name": "hht", "scheme.alpha": -0.1},
}
#: The window of p_n: the interior of the first contact phase at the probe.
PN_WINDOW = (1.2, 1.8)
#: The seed's material and lift (docs/numerics.md, "The seed's test case").
SEED_YOUNG, SEED_POISSON, SEED_AMPLITUDE = 2.0 / 3.0, 1.0 / 3.0, 0.5
#: The contact stress of the seed's strip in that phase, in the thin-bar limit: the 1D
#: closed form's -amplitude x modulus with the plane-strain strip's bar modulus
#: E/(1 - nu^2) = 0.75 (free lateral sides): -3/8. The 1D bar's -1/2 is that of
#: modulus 1 (the strip with sliding sides, lambda + 2 mu = 1).
PN_BAR = -SEED_AMPLITUDE * SEED_YOUNG / (1.0 - SEED_POISSON ** 2)

COLUMNS = ("method", "mass", "scheme", "status", "t_last", "e_drift", "e_max_ratio",
           "pn_mean_err", "pn_std", "max_un", "its_per_step")


@register_analysis("methods")
def analyse_methods(run_dir: str, result) -> dict[str, Any]:
    """The metrics of the module header from the run's trace."""
    tr = result.trace
    t = np.asarray(tr["t"])
    e = np.asarray(tr["e_total"]) + np.asarray(tr["e_contact"])
    m = (t > PN_WINDOW[0]) & (t < PN_WINDOW[1])
    fin = np.isfinite(e)
    return {"metrics": {
        "t_last": float(t[-1]),
        "e_drift": float(e[-1] / e[0] - 1.0),
        "e_max_ratio": float(np.max(e[fin]) / e[0]),
        "pn_mean_err": float(np.mean(tr["p_n"][m]) - PN_BAR) if m.any() else float("nan"),
        "pn_std": float(np.std(tr["p_n"][m])) if m.any() else float("nan"),
        "max_un": float(np.max(tr["u_n"])),
        "its_per_step": float(np.mean(tr["newton_its"][1:])) if len(t) > 1 else 0.0,
    }}


def run_methods(out: str, quick: bool = False, workers: int | None = None,
                scheduler: Any = None, cache: str | None = None,
                progress: bool | None = None, log=None) -> dict[str, Any]:
    """Run the sweep, write methods.csv, methods.png and summary.md into out."""
    t0 = time.perf_counter()
    os.makedirs(out, exist_ok=True)
    cache = cache or os.path.join(out, "cache")
    base = write_base_scenes(os.path.join(out, "scenes"))["seed2d"]
    h, t_end = (0.1, 3.0) if quick else (0.05, 15.0)
    tasks = []
    for method, mkeys in METHODS.items():
        for mass in MASSES:
            for scheme, skeys in SCHEMES.items():
                settings = {"mesh.h": h, "scheme.dt": h / 20, "scheme.t_end": t_end,
                            "scheme.mass": mass, "contact.gamma0": 10.0,
                            "contact.quadrature": "exact", **mkeys, **skeys}
                tasks.append(make_task(base, settings, analysis="methods",
                                       tags={"method": method, "mass": mass,
                                             "scheme": scheme}))
    recs = sweep(tasks, cache, workers=workers, scheduler=scheduler, progress=progress,
                 desc="methods", log=log)
    rows = []
    for rec in recs:
        task = rec["task"]
        row = {"method": task.tag("method"), "mass": task.tag("mass"),
               "scheme": task.tag("scheme"), "status": rec["status"]}
        row.update({k: rec.get("metrics", {}).get(k, float("nan")) for k in COLUMNS[4:]})
        rows.append(row)
    csv = write_csv(os.path.join(out, "methods.csv"), rows, COLUMNS)
    png = _chart(rows, os.path.join(out, "methods.png"), h=h, t_end=t_end)
    lines = [f"# Contact methods x mass x scheme{' (quick)' if quick else ''}", "",
             f"Seed 2D bar, h = {h}, dt = h/20, T = {t_end}, gamma0 = 10, exact contact "
             f"quadrature. E = e_total + e_contact; p_n over t in {PN_WINDOW} against "
             f"{PN_BAR:g}, the thin-bar value: the 1D closed form's -{SEED_AMPLITUDE:g} × the "
             f"strip's bar modulus E/(1 − ν²) = {-PN_BAR / SEED_AMPLITUDE:g} (plane strain, "
             "free sides; -1/2 is the modulus-1 bar's).", "", "![methods](methods.png)", ""]
    lines += md_table(["method", "mass", "scheme", "status", "E(T)/E(0) - 1", "max E/E(0)",
                       f"p_n mean - ({PN_BAR:g})", "p_n std", "max u_n", "Newton its/step"],
                      [[r["method"], r["mass"], r["scheme"], r["status"],
                        fmt(r["e_drift"], ".2e"), fmt(r["e_max_ratio"], ".3g"),
                        fmt(r["pn_mean_err"], ".2e"), fmt(r["pn_std"], ".2e"),
                        fmt(r["max_un"], ".2e"), fmt(r["its_per_step"], ".3g")] for r in rows])
    summary = write_markdown(os.path.join(out, "summary.md"), lines)
    return {"n_runs": len(recs), "n_cached": sum(1 for r in recs if r.get("cached")),
            "n_errors": sum(1 for r in recs if r["status"] == ERROR),
            "wall_s": time.perf_counter() - t0, "summary": summary, "csv": csv, "png": png,
            "rows": rows}


#: Where the chart's log scales draw a value exactly 0.
ZERO_FLOOR = 1e-16


def _chart(rows: list[dict[str, Any]], path: str, h: float, t_end: float) -> str:
    """Three panels over the runs: |energy drift|, p_n std and max u_n, by method (x),
    one marker per mass and scheme; unstable runs as crosses; the title names the scene
    (the seed's 2D bar at mesh size h, up to t_end). The penetration panel draws
    max(max u_n, 0): a run whose probe stays off the plane (max u_n < 0, a gap) has none,
    not the gap's size. Values under ZERO_FLOOR (0, or round-off: the ALM's penetration),
    which a log scale cannot show, are drawn at ZERO_FLOOR on a dotted line that says
    so."""
    fig, axes = new_figure(1, 3, width=4.6)
    methods = list(METHODS)
    markers = {"consistent": "o", "lumped": "s", "redistributed": "^"}
    for ax, key, title, floor_note in zip(
            axes.flat, ("e_drift", "pn_std", "max_un"),
            ("|E(T)/E(0) - 1|", "std p_n on [1.2, 1.8]",
             "penetration max(max u_n, 0) at the probe"),
            (f"< {ZERO_FLOOR:g} (0 drawn here)", f"< {ZERO_FLOOR:g} (0 drawn here)",
             f"< {ZERO_FLOOR:g}: none (max u_n ≤ 0) or round-off")):
        floored = False
        for r in rows:
            x = methods.index(r["method"]) + (0.15 if r["scheme"] != "newmark" else -0.15)
            if not np.isfinite(r[key]):
                y = np.nan
            elif key == "max_un":
                y = max(r[key], 0.0)
            else:
                y = abs(r[key])
            floored = floored or y < ZERO_FLOOR
            stable = r["status"] == "ok"
            ax.plot(x, max(y, ZERO_FLOOR), marker=markers[r["mass"]] if stable else "x",
                    color="C0" if r["scheme"] == "newmark" else "C1", linestyle="none",
                    fillstyle="full" if stable else "none")
        ax.set_yscale("log")
        if floored:
            ax.axhline(ZERO_FLOOR, color="0.5", lw=0.8, ls=":", gid="zero-floor")
            ax.text(0.02, ZERO_FLOOR, floor_note, transform=ax.get_yaxis_transform(),
                    fontsize=7, color="0.3", va="bottom", ha="left", gid="zero-floor-note")
        ax.set_xticks(range(len(methods)))
        ax.set_xticklabels(methods, rotation=45, ha="right")
        ax.set_title(title)
    from matplotlib.lines import Line2D

    keys = [Line2D([], [], color="k", marker=m, ls="none", label=mass)
            for mass, m in markers.items()]
    keys += [Line2D([], [], color=c, marker=".", ls="none", label=scheme)
             for scheme, c in (("newmark ¼ ½", "C0"), ("hht α = -0.1", "C1"))]
    if any(r["status"] != "ok" for r in rows):
        keys.append(Line2D([], [], color="k", marker="x", ls="none", label="run not finished"))
    # beside the panels: inside one ('best' place) it would cover the ALM runs' points
    legend = fig.legend(handles=keys, loc="center right", fontsize="small")
    fig.suptitle(f"Contact methods on the seed 2D bar: h = {h:g}, Δt = h/20, T = {t_end:g}, "
                 "γ0 = 10, exact contact quadrature", fontsize=10)
    fig.canvas.draw()
    right = 1 - (legend.get_window_extent().width + 10) / fig.bbox.width
    return save_figure(fig, path, rect=(0, 0, right, 1 - 0.3 / fig.get_figheight()))
