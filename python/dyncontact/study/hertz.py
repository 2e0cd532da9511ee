"""``study hertz``: the 3D ball against Hertz's impact theory, where Hertz holds.

Hertz's quasi-static impact of an elastic sphere (radius R, mass m, E* = E/(1 - ν²)) on a
rigid plane at speed v (Johnson, *Contact Mechanics*, §11.4): the force law
F = 4/3 E* R^(1/2) δ^(3/2) in m δ'' = -F gives the largest approach
δ_max = (15 m v² / (16 E* R^(1/2)))^(2/5) (energy: ½ m v² = 8/15 E* R^(1/2) δ_max^(5/2)),
the largest force F_max = 4/3 E* R^(1/2) δ_max^(3/2), the contact time
t_c = 2 I δ_max / v with I = ∫_0^1 dx / (1 - x^(5/2))^(1/2) = 1.4716 (:func:`hertz_time_factor`),
that is 2.943 δ_max / v = 2.868 (m² / (R E*² v))^(1/5), and the patch radius
a = (R δ)^(1/2). Every impulse of an elastic impact is ∫ F dt = 2 m v.

Hertz holds for a patch small against the ball (a ≪ R: the bodies are half-spaces near the
contact), a speed small against the waves' (v ≪ c: quasi-static) and, for the numerics, a
mesh fine under the patch. The study drops the ball of ``meshes/ball_pole.geo`` (R = 0.2,
E = 1, ν = 0.3, ρ = 1; tetrahedra of size h_c within 3a of the south pole, width/4 = 0.05
far from it) on the plane z = 0 at the speed that gives a/R = 0.1 (v = 1.67e-3, v/c =
1.4e-3 with c = ((λ + 2μ)/ρ)^(1/2) = 1.16) and, as a second series, a/R = 0.05
(v = 2.95e-4): each series at h_c = a/2, a/2.83, a/4, a/5.66, so that equal h_c/a
compare the two a/R. Newmark ¼ ½ (energy-conserving), consistent mass, Nitsche θ = 1 with
γ0 = 50 (10 is below the element bound of these meshes, about 11.5), Δt = t_c/140,
T = 1.15 t_c.

Per run, from the trace (f_n: the total normal contact force, ≤ 0):

- t_c: the contact starts and ends where |f_n|^(2/3), linear in t near both ends (δ is
  linear in t there and F ∝ δ^(3/2)), extrapolated from the first (last) two rows with
  f_n < 0, reaches 0; the bracket (first and last row with f_n < 0, widened by Δt at each
  end) is in the CSV too;
- F_max = max |f_n|;
- δ_max: the largest approach of the centre of mass, z_c(t) - z_c(0) from m z_c'' = -f_n
  integrated twice by the trapezoidal rule, which is how Newmark ¼ ½ integrates it (the
  total momentum changes by Δt/2 (f_n^n + f_n^(n+1)) a step: the stiffness does not act on
  a rigid translation), from z_c'(0) = -v;
- the impulse -∫ f_n dt / (2 m v) (trapezoidal rule), 1 for an elastic bounce: (1 + e)/2
  with e the restitution; the energy left in vibrations lowers it;
- the energy drift E(T)/E(0) - 1, E = e_total + e_contact.

Hertz is evaluated with the mesh's mass m = 2 e_kin(0) / v² (every node starts at -v, so
the kinetic energy is ½ ρ |Ω_h| v²; the faceted ball is about 1.3 % lighter than the
sphere) and the sphere's R (the mesh is fine where the curvature acts).

Writes hertz.csv, hertz.png and summary.md into --out.
"""

from __future__ import annotations

import math
import os
import time
from pathlib import Path
from typing import Any

import numpy as np

from .common import fmt, md_table, new_figure, save_figure, slope, write_csv, write_markdown
from .sweep import ERROR, make_task, register_analysis, sweep

__all__ = ["run_hertz", "hertz_impact", "hertz_time_factor", "hertz_speed", "contact_time",
           "centre_approach", "hertz_spec", "BALL_POLE_GEO", "BALL_SCENE", "RADIUS", "YOUNG",
           "POISSON", "DENSITY", "GAMMA0", "STEPS_PER_CONTACT", "T_OVER_TC", "SERIES",
           "QUICK_SERIES", "ZONE_PATCHES"]

#: The pole-refined ball (its &mesh length: the radius of the zone of size h).
BALL_POLE_GEO = str(Path(__file__).resolve().parents[3] / "meshes" / "ball_pole.geo")
#: The ball scene whose material, contact and scheme the study starts from.
BALL_SCENE = str(Path(__file__).resolve().parents[3] / "scripts" / "scenes"
                 / "ball3d_newmark.nml")
#: The ball: radius (&mesh width), Young's modulus, Poisson's ratio, density.
RADIUS, YOUNG, POISSON, DENSITY = 0.2, 1.0, 0.3, 1.0
#: Nitsche's γ0: the element bound of the pole meshes is about 11.5 (θ = 1), the core's
#: advice 50; at h_c = a/2 the results with γ0 = 10 and 50 differ by 0.3 % in F_max.
GAMMA0 = 50.0
#: Δt = t_c / STEPS_PER_CONTACT (Hertz's t_c); halving it moves F_max by 0.07 %.
STEPS_PER_CONTACT = 140
#: T = T_OVER_TC t_c: the whole contact and a few steps of flight after it.
T_OVER_TC = 1.15
#: The zone of size h_c around the pole: this many patch radii (&mesh length = 3 a).
ZONE_PATCHES = 3.0
#: (a/R, the values of a/h_c) of each series: equal a/h_c compare the two a/R.
SERIES = ((0.1, (2.0, 2.0 ** 1.5, 4.0, 2.0 ** 2.5)),
          (0.05, (2.0, 2.0 ** 1.5, 4.0, 2.0 ** 2.5)))
QUICK_SERIES = ((0.1, (2.0, 2.0 ** 1.5)),)

COLUMNS = ("a_over_R", "h_c", "a_over_h", "speed", "dt", "status", "dofs", "elements",
           "steps", "cpu_s", "mass", "tc_hertz", "fmax_hertz", "delta_hertz", "tc",
           "tc_lo", "tc_hi", "fmax", "delta_max", "err_tc", "err_fmax", "err_delta",
           "impulse", "energy_drift")


def hertz_time_factor(n: int = 200_000) -> float:
    """I = ∫_0^1 dx / (1 - x^(5/2))^(1/2) (t_c = 2 I δ_max / v), by the midpoint rule after
    the substitution x = 1 - s², which removes the end singularity: 1.47160..."""
    s = (np.arange(n) + 0.5) / n
    x = 1.0 - s * s
    return float(np.sum(2.0 * s / np.sqrt(1.0 - x ** 2.5)) / n)


def hertz_impact(radius: float, young: float, poisson: float, mass: float,
                 speed: float) -> dict[str, float]:
    """Hertz's impact of an elastic sphere (radius, mass, E, ν) on a rigid plane at speed:
    t_contact, delta_max, f_max, patch_radius (module docstring)."""
    e_star = young / (1.0 - poisson ** 2)
    delta = (15.0 * mass * speed ** 2 / (16.0 * e_star * math.sqrt(radius))) ** 0.4
    return {"t_contact": 2.0 * hertz_time_factor() * delta / speed, "delta_max": delta,
            "f_max": 4.0 / 3.0 * e_star * math.sqrt(radius) * delta ** 1.5,
            "patch_radius": math.sqrt(radius * delta)}


def hertz_speed(a_over_r: float, radius: float = RADIUS, young: float = YOUNG,
                poisson: float = POISSON, density: float = DENSITY) -> float:
    """The impact speed of the sphere whose largest patch radius is a_over_r x radius."""
    mass = density * 4.0 / 3.0 * math.pi * radius ** 3
    e_star = young / (1.0 - poisson ** 2)
    delta = radius * a_over_r ** 2
    return math.sqrt(delta ** 2.5 * 16.0 * e_star * math.sqrt(radius) / (15.0 * mass))


def contact_time(t: np.ndarray, f_n: np.ndarray) -> tuple[float, float, float]:
    """(t_c, lower, upper) of the first contact phase: t_c from |f_n|^(2/3) extrapolated
    linearly to 0 at both ends (module docstring); lower/upper from the first and last rows
    with f_n < 0 (the bracket). NaN when there is no contact or it has not ended."""
    on = np.nonzero(f_n < 0)[0]
    if len(on) < 2:
        return (math.nan,) * 3
    first = on[0]
    gaps = np.nonzero(np.diff(on) > 1)[0]
    last = on[gaps[0]] if len(gaps) else on[-1]
    if last + 1 >= len(t) or first == 0:
        return (math.nan,) * 3
    g = np.abs(f_n) ** (2.0 / 3.0)

    def zero(i: int, j: int) -> float:   # the line through rows i, j at g = 0
        return float(t[i] - g[i] * (t[j] - t[i]) / (g[j] - g[i]))

    start = zero(first, first + 1) if last > first else float(t[first - 1])
    end = zero(last, last - 1) if last > first else float(t[last + 1])
    start = min(max(start, float(t[first - 1])), float(t[first]))
    end = min(max(end, float(t[last])), float(t[last + 1]))
    return end - start, float(t[last] - t[first]), float(t[last + 1] - t[first - 1])


def centre_approach(t: np.ndarray, f_n: np.ndarray, mass: float, speed: float) -> np.ndarray:
    """-(z_c(t) - z_c(0)): m z_c'' = -f_n, z_c'(0) = -speed, by the trapezoidal rule twice
    (Newmark ¼ ½'s own integration of the total momentum; module docstring)."""
    dt = np.diff(t)
    vz = -speed - np.concatenate([[0.0], np.cumsum(0.5 * (f_n[1:] + f_n[:-1]) * dt)]) / mass
    return -np.concatenate([[0.0], np.cumsum(0.5 * (vz[1:] + vz[:-1]) * dt)])


@register_analysis("hertz")
def analyse_hertz(run_dir: str, result, speed: float) -> dict[str, Any]:  # noqa: ARG001
    """The run's contact time, F_max, δ_max, impulse and energy drift (module docstring)."""
    tr = result.trace
    t = np.asarray(tr["t"], dtype=float)
    f_n = np.asarray(tr["f_n"], dtype=float)
    mass = 2.0 * float(tr["e_kin"][0]) / speed ** 2
    tc, lo, hi = contact_time(t, f_n)
    e = np.asarray(tr["e_total"], dtype=float) + np.asarray(tr["e_contact"], dtype=float)
    return {"metrics": {
        "mass": mass, "tc": tc, "tc_lo": lo, "tc_hi": hi, "fmax": float(-np.min(f_n)),
        "delta_max": float(np.max(centre_approach(t, f_n, mass, speed))),
        "impulse": float(-np.trapezoid(f_n, t) / (2.0 * mass * speed)),
        "energy_drift": float(e[-1] / e[0] - 1.0)}}


def hertz_spec(a_over_r: float, a_over_h: float) -> tuple[dict[str, Any], float]:
    """The scene keys (on :data:`BALL_SCENE`) of the run at a/R = a_over_r and
    h_c = a / a_over_h, and its speed."""
    speed = hertz_speed(a_over_r)
    sphere_mass = DENSITY * 4.0 / 3.0 * math.pi * RADIUS ** 3
    hz = hertz_impact(RADIUS, YOUNG, POISSON, sphere_mass, speed)
    a = a_over_r * RADIUS
    dt = hz["t_contact"] / STEPS_PER_CONTACT
    settings = {"mesh.file": BALL_POLE_GEO, "mesh.h": a / a_over_h, "mesh.width": RADIUS,
                "mesh.length": ZONE_PATCHES * a,
                "material.young": YOUNG, "material.poisson": POISSON,
                "material.density": DENSITY, "contact.gamma0": GAMMA0,
                "contact.probe": "0.0, 0.0, 0.0",
                "initial.velocity": f"0.0, 0.0, {-speed!r}",
                "scheme.name": "newmark", "scheme.beta": 0.25, "scheme.gamma": 0.5,
                "scheme.dt": dt, "scheme.t_end": T_OVER_TC * hz["t_contact"],
                "output.every": 1, "output.fields_every": 0}
    return settings, speed


def run_hertz(out: str, quick: bool = False, workers: int | None = None,
              scheduler: Any = None, cache: str | None = None,
              progress: bool | None = None, log=None) -> dict[str, Any]:
    """Run the series, write hertz.csv, hertz.png and summary.md into out."""
    t0 = time.perf_counter()
    os.makedirs(out, exist_ok=True)
    cache = cache or os.path.join(out, "cache")
    tasks = []
    for a_over_r, ratios in (QUICK_SERIES if quick else SERIES):
        for a_over_h in ratios:
            settings, speed = hertz_spec(a_over_r, a_over_h)
            tasks.append(make_task(BALL_SCENE, settings, analysis="hertz",
                                   params={"speed": speed},
                                   tags={"a_over_R": a_over_r, "a_over_h": a_over_h,
                                         "speed": speed}))
    recs = sweep(tasks, cache, workers=workers, scheduler=scheduler, progress=progress,
                 desc="hertz", log=log)
    rows = [_row(rec) for rec in recs]
    csv = write_csv(os.path.join(out, "hertz.csv"), rows, COLUMNS)
    png = _chart(rows, os.path.join(out, "hertz.png"))
    summary = write_markdown(os.path.join(out, "summary.md"), _summary(rows, quick))
    return {"n_runs": len(recs), "n_cached": sum(1 for r in recs if r.get("cached")),
            "n_errors": sum(1 for r in recs if r["status"] == ERROR),
            "wall_s": time.perf_counter() - t0, "summary": summary, "csv": csv, "png": png,
            "rows": rows}


def _row(rec: dict[str, Any]) -> dict[str, Any]:
    task = rec["task"]
    m = rec.get("metrics", {})
    speed = task.tag("speed")
    row = {"a_over_R": task.tag("a_over_R"), "a_over_h": task.tag("a_over_h"),
           "h_c": task.setting("mesh.h"), "speed": speed, "dt": task.setting("scheme.dt"),
           "status": rec["status"], "steps": rec.get("steps"), "cpu_s": rec.get("cpu_s")}
    run_summary = os.path.join(rec.get("run_dir") or "", "summary.json")
    if os.path.isfile(run_summary):
        from ..core import read_summary

        s = read_summary(os.path.dirname(run_summary))
        row.update(dofs=s.get("dofs"), elements=s.get("elements"))
    row.update({k: m.get(k, math.nan) for k in ("mass", "tc", "tc_lo", "tc_hi", "fmax",
                                                 "delta_max", "impulse", "energy_drift")})
    if math.isfinite(row["mass"]):
        hz = hertz_impact(RADIUS, YOUNG, POISSON, row["mass"], speed)
        row.update(tc_hertz=hz["t_contact"], fmax_hertz=hz["f_max"],
                   delta_hertz=hz["delta_max"],
                   err_tc=row["tc"] / hz["t_contact"] - 1.0,
                   err_fmax=row["fmax"] / hz["f_max"] - 1.0,
                   err_delta=row["delta_max"] / hz["delta_max"] - 1.0)
    return row


def _series(rows: list[dict[str, Any]]) -> dict[float, list[dict[str, Any]]]:
    out: dict[float, list[dict[str, Any]]] = {}
    for r in rows:
        out.setdefault(r["a_over_R"], []).append(r)
    return out


ERRORS = (("err_tc", "t_c"), ("err_fmax", "F_max"), ("err_delta", "δ_max"))


def _summary(rows: list[dict[str, Any]], quick: bool) -> list[str]:
    lines = [f"# The 3D ball against Hertz's impact{' (quick)' if quick else ''}", "",
             f"meshes/ball_pole.geo (R = {RADIUS}, E = {YOUNG}, ν = {POISSON}, ρ = {DENSITY}): "
             f"size h_c within {ZONE_PATCHES:g} a of the south pole, 0.05 far from it; "
             f"newmark ¼ ½, consistent mass, Nitsche θ = 1, γ0 = {GAMMA0:g}, "
             f"Δt = t_c/{STEPS_PER_CONTACT}, T = {T_OVER_TC} t_c. Errors relative to Hertz "
             "with the mesh's mass; impulse = -∫ f_n dt / (2 m v) (1: elastic); slopes: "
             "least-squares of log |error| against log h_c.", "", "![hertz](hertz.png)", ""]
    lines += md_table(
        ["a/R", "v", "h_c", "a/h_c", "dofs", "steps", "CPU s", "t_c", "t_c err",
         "F_max err", "δ_max err", "impulse", "E(T)/E(0) - 1"],
        [[fmt(r["a_over_R"], "g"), fmt(r["speed"], ".3g"), fmt(r["h_c"], ".3g"),
          fmt(r["a_over_h"], ".3g"), fmt(r.get("dofs"), ".0f"), fmt(r.get("steps"), ".0f"),
          fmt(r.get("cpu_s"), ".3g"), fmt(r.get("tc"), ".4g"), fmt(r.get("err_tc"), "+.2%"),
          fmt(r.get("err_fmax"), "+.2%"), fmt(r.get("err_delta"), "+.2%"),
          fmt(r.get("impulse"), ".5f"), fmt(r.get("energy_drift"), ".1e")] for r in rows])
    lines += ["", "Fitted slopes of |error| against h_c:", ""]
    for a_over_r, rs in _series(rows).items():
        hs = [r["h_c"] for r in rs]
        parts = [f"{label} {fmt(slope(hs, [abs(r.get(key, math.nan)) for r in rs]), '.2f')}"
                 for key, label in ERRORS]
        lines.append(f"- a/R = {a_over_r:g}: " + ", ".join(parts))
    return lines


def _chart(rows: list[dict[str, Any]], path: str) -> str:
    """|error| of t_c, F_max and δ_max against h_c, log-log, one line per a/R with its
    fitted slope in the legend."""
    fig, axes = new_figure(1, 3, width=4.2)
    for ax, (key, label) in zip(axes.flat, ERRORS):
        for i, (a_over_r, rs) in enumerate(_series(rows).items()):
            hs = np.array([r["h_c"] for r in rs], dtype=float)
            err = np.array([abs(r.get(key, math.nan)) for r in rs], dtype=float)
            p = slope(hs, err)
            ax.loglog(hs, err, "o-", color=f"C{i}",
                      label=f"a/R = {a_over_r:g} (slope {fmt(p, '.2f')})")
        ax.set_xlabel("h_c (mesh size at the pole)")
        ax.set_title(f"|{label} / Hertz - 1|")
        ax.legend(fontsize="small")
    return save_figure(fig, path)
