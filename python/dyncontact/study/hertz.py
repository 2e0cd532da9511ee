"""``study hertz``: the 3D ball against Hertz's impact theory, where Hertz holds.

Hertz's quasi-static impact of an elastic sphere (radius R, mass m, E* = E/(1 - ν²)) on a
rigid plane at speed v (Johnson, *Contact Mechanics*, §11.4): the force law
F = 4/3 E* R^(1/2) δ^(3/2) in m δ'' = -F gives the largest approach
δ_max = (15 m v² / (16 E* R^(1/2)))^(2/5) (energy: ½ m v² = 8/15 E* R^(1/2) δ_max^(5/2)),
the largest force F_max = 4/3 E* R^(1/2) δ_max^(3/2), the contact time
t_c = 2 I δ_max / v with I = ∫_0^1 dx / (1 - x^(5/2))^(1/2) = 1.4716
(:func:`hertz_time_factor`), that is 2.943 δ_max / v = 2.868 (m² / (R E*² v))^(1/5),
and the patch radius a = (R δ)^(1/2). Every impulse of an elastic impact is ∫ F dt = 2 m v.

Hertz holds for a patch small against the ball (a ≪ R: the bodies are half-spaces near the
contact), a speed small against the waves' (v ≪ c: quasi-static) and, for the numerics, a
mesh fine under the patch. The study drops the ball of ``meshes/ball_pole.geo`` (R = 0.2,
E = 1, ν = 0.3, ρ = 1; tetrahedra of size h_c within 3a of the south pole, width/4 = 0.05
far from it) on the plane z = 0 at the speed that gives a/R = 0.1 (v = 1.67e-3, v/c =
1.4e-3 with c = ((λ + 2μ)/ρ)^(1/2) = 1.16) and, as further series, a/R = 0.05
(v = 2.96e-4) and 0.2 (v = 9.46e-3): each series at h_c = a/2, a/2.83, a/4, a/5.66, so
that equal h_c/a compare the a/R (:func:`extrapolated`). Newmark ¼ ½ (energy-conserving), consistent mass, Nitsche θ = 1 with
γ0 = 50 (10 is below the element bound of these meshes, about 11.5), Δt = t_c/140,
T = 1.15 t_c.

Per run, from the trace (f_n: the total normal contact force, ≤ 0), by the ``hertz``
analysis of :mod:`.analyses` (there so that editing this report keeps the cached runs):

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
from typing import Any

import numpy as np

from ..mesh_io import find_geo
from ..scene import find_scene
from .common import (fmt, md_table, new_figure, save_figure, slope, ticks_at, write_csv,
                     write_markdown)
from .sweep import ERROR, make_task, sweep

__all__ = ["run_hertz", "hertz_impact", "hertz_time_factor", "hertz_speed", "hertz_spec",
           "sphere_mass",
           "extrapolated", "BALL_POLE_GEO", "BALL_SCENE", "RADIUS", "YOUNG", "POISSON",
           "DENSITY", "GAMMA0", "STEPS_PER_CONTACT", "T_OVER_TC", "SERIES", "QUICK_SERIES",
           "ZONE_PATCHES"]

#: The pole-refined ball (its &mesh length: the radius of the zone of size h).
BALL_POLE_GEO = str(find_geo("ball_pole.geo"))
#: The ball scene whose material, contact and scheme the study starts from.
BALL_SCENE = str(find_scene("ball3d_newmark.nml"))
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
SERIES = ((0.2, (2.0, 2.0 ** 1.5, 4.0, 2.0 ** 2.5)),
          (0.1, (2.0, 2.0 ** 1.5, 4.0, 2.0 ** 2.5)),
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


def sphere_mass(radius: float = RADIUS, density: float = DENSITY) -> float:
    """ρ 4/3 π R³: the mass of the sphere (the faceted ball's is about 1.3 % less)."""
    return density * 4.0 / 3.0 * math.pi * radius ** 3


def hertz_speed(a_over_r: float, radius: float = RADIUS, young: float = YOUNG,
                poisson: float = POISSON, density: float = DENSITY) -> float:
    """The impact speed of the sphere whose largest patch radius is a_over_r x radius."""
    mass = sphere_mass(radius, density)
    e_star = young / (1.0 - poisson ** 2)
    delta = radius * a_over_r ** 2
    return math.sqrt(delta ** 2.5 * 16.0 * e_star * math.sqrt(radius) / (15.0 * mass))


def hertz_spec(a_over_r: float, a_over_h: float) -> tuple[dict[str, Any], float]:
    """The scene keys (on :data:`BALL_SCENE`) of the run at a/R = a_over_r and
    h_c = a / a_over_h, and its speed."""
    speed = hertz_speed(a_over_r)
    hz = hertz_impact(RADIUS, YOUNG, POISSON, sphere_mass(), speed)
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
    row.update(dofs=m.get("dofs"), elements=m.get("elements"))
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
    ext = extrapolated(rows)
    if ext:
        r2, r1 = sorted(_series(rows))[:2]
        lines += ["", f"At equal a/h_c, the part first order in a/R (the finite ball: "
                  f"docs/numerics.md) removed: e_0 = (r e({r2:g}) - e({r1:g}))/(r - 1), "
                  f"r = {r1 / r2:g}; what is left is the mesh's error at that a/h_c. "
                  "With a third a/R, e_0 of the parabola through the three (quadratic), "
                  "and how the error grows with a/R: (e(a_3) - e(a_1))/(e(a_1) - e(a_2)), "
                  "which is (a_3 - a_1)/(a_1 - a_2) if it is linear in a/R:", ""]
        lines += md_table(["a/h_c", "t_c e_0", "F_max e_0", "δ_max e_0",
                           "t_c e_0 (quadratic)", "F_max e_0 (quadratic)",
                           f"t_c: e({r1:g}) - e({r2:g})", f"F_max: e({r1:g}) - e({r2:g})",
                           "t_c growth", "F_max growth"],
                          [[fmt(e["a_over_h"], ".3g"), fmt(e["err_tc"], "+.2%"),
                            fmt(e["err_fmax"], "+.2%"), fmt(e["err_delta"], "+.2%"),
                            fmt(e.get("quad_tc"), "+.2%"), fmt(e.get("quad_fmax"), "+.2%"),
                            fmt(e["diff_tc"], "+.2%"), fmt(e["diff_fmax"], "+.2%"),
                            fmt(e.get("growth_tc"), ".2f"), fmt(e.get("growth_fmax"), ".2f")]
                           for e in ext])
        xs = [1.0 / e["a_over_h"] for e in ext]
        lines += ["", "Fitted slopes of |e_0| against h_c/a: " + ", ".join(
            f"{label} {fmt(slope(xs, [abs(e[key]) for e in ext]), '.2f')}"
            for key, label in ERRORS)]
    return lines


def extrapolated(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The errors at each a/h_c common to the two smallest a/R (a_2 < a_1), with their
    part first order in a/R removed (Richardson in a/R): e_0 = (r e_2 - e_1)/(r - 1),
    r = a_1/a_2, and the differences e_1 - e_2; with a third a/R (a_3, the next larger)
    at that a/h_c, the value at a/R = 0 of the parabola through the three (quad_*) and
    the growth (e_3 - e_1)/(e_1 - e_2) (growth_*). [] with fewer than two series."""
    series = _series(rows)
    if len(series) < 2:
        return []
    sizes = sorted(series)
    by_h = {a: {round(r["a_over_h"], 9): r for r in series[a]} for a in sizes}
    a2, a1 = sizes[:2]
    a3 = sizes[2] if len(sizes) > 2 else None
    ratio = a1 / a2
    out = []
    for row1 in series[a1]:
        key_h = round(row1["a_over_h"], 9)
        row2 = by_h[a2].get(key_h)
        if row2 is None:
            continue
        row3 = by_h[a3].get(key_h) if a3 is not None else None
        e = {"a_over_h": row1["a_over_h"]}
        for key, _ in ERRORS:
            e1, e2 = row1.get(key, math.nan), row2.get(key, math.nan)
            e[key] = (ratio * e2 - e1) / (ratio - 1.0)
        for key, short in (("err_tc", "tc"), ("err_fmax", "fmax")):
            e1, e2 = row1.get(key, math.nan), row2.get(key, math.nan)
            e[f"diff_{short}"] = e1 - e2
            if row3 is not None:
                e3 = row3.get(key, math.nan)
                xs, ys = (a2, a1, a3), (e2, e1, e3)
                e[f"quad_{short}"] = sum(
                    y * math.prod(-xj / (xi - xj) for xj in xs if xj != xi)
                    for xi, y in zip(xs, ys))
                e[f"growth_{short}"] = (e3 - e1) / (e1 - e2)
        out.append(e)
    return out


def _title(rows: list[dict[str, Any]]) -> str:
    """The scene of the runs: the ball (mesh, R, E, ν, ρ), the speed of each series, the
    mesh sizes at the pole, the scheme and contact, Δt and T."""
    series = sorted(_series(rows), reverse=True)
    speeds = ", ".join(f"{_speed(rows, a):.3g} (a/R = {a:g})" for a in series)
    ratios = sorted({r["a_over_h"] for r in rows})
    sizes = ", ".join(f"a/{x:.3g}" for x in ratios)
    return (f"3D ball against Hertz's impact: meshes/ball_pole.geo, R = {RADIUS:g}, "
            f"E = {YOUNG:g}, ν = {POISSON:g}, ρ = {DENSITY:g}; speed v = {speeds}\n"
            f"mesh size h_c = {sizes} within {ZONE_PATCHES:g} a of the pole (a: Hertz's "
            f"patch radius); newmark ¼ ½, consistent mass, Nitsche θ = 1, "
            f"γ0 = {GAMMA0:g}; Δt = t_c/{STEPS_PER_CONTACT}, T = {T_OVER_TC:g} t_c")


def _speed(rows: list[dict[str, Any]], a_over_r: float) -> float:
    return next(r["speed"] for r in rows if r["a_over_R"] == a_over_r)


def _chart(rows: list[dict[str, Any]], path: str) -> str:
    """|error| of t_c, F_max and δ_max against h_c/a, log-log, one line per a/R and one
    extrapolated to a/R -> 0 (:func:`extrapolated`), each with its fitted slope (the
    same against h_c/a as against h_c within a series); the title names the scene
    (:func:`_title`), the x axis the values of h_c/a run."""
    fig, axes = new_figure(1, 3, width=4.2, height=4.6)
    ticks = sorted({1.0 / r["a_over_h"] for r in rows})
    ext = extrapolated(rows)
    for ax, (key, label) in zip(axes.flat, ERRORS):
        for i, (a_over_r, rs) in enumerate(_series(rows).items()):
            hs = np.array([r["h_c"] for r in rs], dtype=float)
            err = np.array([abs(r.get(key, math.nan)) for r in rs], dtype=float)
            p = slope(hs, err)
            ax.loglog(hs / (a_over_r * RADIUS), err, "o-", color=f"C{i}",
                      label=f"a/R = {a_over_r:g} (slope {fmt(p, '.2f')})")
        if ext:
            xs = np.array([1.0 / e["a_over_h"] for e in ext])
            err = np.array([abs(e[key]) for e in ext])
            ax.loglog(xs, err, "k^--", label=f"a/R -> 0, extrapolated (slope "
                      f"{fmt(slope(xs, err), '.2f')})")
        ax.set_xlabel("h_c / a (mesh size at the pole / patch radius)")
        ax.set_ylabel(f"relative error of {label}")
        ax.set_title(f"|{label} / Hertz - 1|")
        # the values of h_c/a the study ran, as numbers (the log axis' own ticks would give
        # 4×10^-1 and 5×10^-1 for the quick study's 0.354 and 0.5)
        if ticks:
            ticks_at(ax, ticks, ".3g")
        ax.legend(fontsize="x-small", loc="upper center", bbox_to_anchor=(0.5, -0.22))
    if rows:
        fig.suptitle(_title(rows), fontsize=9)
    return save_figure(fig, path, top=1 - 0.4 / fig.get_figheight())
