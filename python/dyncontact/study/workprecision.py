"""``study work-precision``: error against CPU time, one curve per scheme over its
(h, dt) ladder, on the 1D exact case and on the seed's 2D bar.

Errors at the probe, in a norm in time over [0, T] chosen by the quantity's regularity
(``NORMS``): RMS, ``(1/T int_0^T (q - q_ref)^2 dt)^(1/2)``, for u_n and for
(e_total - e_ref) / e_ref(0), which are continuous in time; the mean absolute error
``1/T int_0^T |q - q_ref| dt`` (L1 in time over T) for v_n and p_n, which jump at impact
and release. A discrete solution smears a jump J over a time of order h; there the error
is O(J), so the jump costs O(J h) in L1, O(J h^(1/2)) in RMS and O(J) in the maximum: in
RMS the error of v_n converges at most at order 1/2 and the jumps dominate it (the RMS
of v_n and p_n is kept in the CSV, err_<q>_rms, and in the reference table, not used).
The 1D reference is the closed form
(:mod:`dyncontact.exact1d`). The 2D references are runs of the code itself
(``REFERENCES``), each at a sequence of mesh sizes halving to the finest, which is the
reference; its trace is interpolated linearly to each run's times:

- e_total against newmark (1/4, 1/2) with the consistent mass, dt = h/20, the finest
  h = 0.003125: the trapezoidal rule conserves the energy, as the exact solution does,
  and its time error at dt = h/20 is small against its space error (checked by the
  study: the coarsest level against the same run at dt/2);
- u_n, v_n and p_n against generalized-alpha (rho_inf = 0.5) with the consistent mass at
  dt = h, the finest h = 0.000390625 (shipped with the package: SHIPPED). With small
  steps the contact nodes chatter during contact (the active set of the contact
  quadrature points switches from step to step)
  and pointwise v_n and p_n at the probe do not converge, neither as h -> 0 nor as
  dt -> 0 (the study shows it: the consistent reference's level differences barely
  decrease in v_n and grow in p_n). At dt = h the scheme damps that mesh-scale oscillation
  (omega dt >~ 1) and stays second order below it; its time error is then of the size
  of its space error, and the estimate below is that of the joint refinement
  (dt = h halving with h). The study also reports how far the two references' finest
  levels are apart in each quantity.

The error of a reference comes from its own levels: with d_1, d_2 the RMS differences
between its last three levels and p = log2(d_1/d_2) (floored at MIN_ORDER), err(ref) ~
d_2 / (2^p - 1) (:func:`richardson`); unknown when d_2 >= d_1. Points whose error is less
than RESOLVED_MARGIN (3) x the estimate are flagged as not resolved, per quantity.

On a scene of one's own (``--scene``, :func:`run_work_precision_scene`): each scheme on
the scene as given (mesh, material, mass, contact, probe, T) at a ladder of Δt derived
from the scene's (SCENE_LADDER), against the same scene run with SCENE_REFERENCE at
SCENE_REF_FRACTIONS of the smallest of those Δt, in the same measures, reference table
(its three Δt levels in place of mesh sizes, no separate Δt check) and plot: errors of the
time discretization on the scene's mesh. An explicit scheme whose ladder would go above
EXPLICIT_SAFETY × its critical step, as the core estimates it on the scene, runs at its
step divided by an integer that brings its largest step to at most that
(:func:`_explicit_divisors`), so that its points are runs, not crosses.

CPU time: process CPU time of the worker around :func:`dyncontact.run` (set-up and trace
reading included), robust to other load on the machine. Every run writes its trace
rows OUTPUT_DT apart in time (not every step), so that output costs the same for all. Unstable runs are drawn as
crosses at the top of each panel, never dropped.
"""

from __future__ import annotations

import gzip
import json
import math
import os
import time
from typing import Any

import numpy as np

from . import analyses  # noqa: F401 - registers the analyses
from .analyses import rms_in_time
from .common import (SCHEMES, UserScene, fmt, md_table, new_figure, save_figure, step_ratio,
                     study_folder, wrapped_suptitle, write_base_scenes, write_csv,
                     write_markdown)
from .sweep import Task, make_task, sweep

__all__ = ["run_work_precision", "QUANTITIES", "DEFAULT_SERIES", "REFERENCES",
           "NORMS", "RMS_TOO", "richardson", "mean_abs_in_time", "is_resolved",
           "resolution", "run_work_precision_scene", "SCENE_LADDER", "SCENE_REFERENCE",
           "SCENE_REF_FRACTIONS", "EXPLICIT_SAFETY"]

QUANTITIES = ("u_n", "v_n", "p_n", "e_total")
#: The norm in time of each quantity's error (module docstring; docs/numerics.md,
#: "Work–precision"): 'rms' = (1/T int e^2 dt)^(1/2) for the quantities that are
#: continuous in time (u_n, e_total); 'mean' = 1/T int |e| dt (L1 in time / T) for those
#: that jump at impact and release (v_n, p_n): a jump smeared over a time of order h
#: costs O(h) in L1 but O(h^(1/2)) in RMS and O(1) in the maximum, so in RMS their error
#: converges at most at order 1/2, the jumps dominate it, and no affordable 2D reference
#: resolves it.
NORMS = {"u_n": "rms", "v_n": "mean", "p_n": "mean", "e_total": "rms"}
#: Quantities measured in RMS too (err_<q>_rms), for the comparison of the norms in the
#: reference table.
RMS_TOO = ("v_n", "p_n")
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
T_END = {"full": 3.0, "quick": 1.5}
#: The cases of the built-in study: (case, title of its panels).
CASES = (("1d", "1D exact case"), ("2d", "2D seed bar"))
#: ``--scene``: the time steps of each scheme, as factors on its step (the scene's Δt for
#: the scene's own scheme's family, scaled by c₀/c for a scheme of another c, as the
#: built-in study's Δt = h/c: :func:`.common.scene_step_ratio`), coarse to fine.
SCENE_LADDER = {"full": (2.0, 1.0, 0.5, 0.25), "quick": (1.0, 0.5)}
#: ``--scene``: the reference is the trapezoidal rule (second order, energy-conserving)
#: on the scene's own mesh, mass and contact, at these fractions of the smallest Δt of
#: the study's runs, coarse to fine: the finest is the reference, the two differences
#: between the three give its error estimate (:func:`richardson`).
SCENE_REFERENCE = "newmark"
SCENE_REF_FRACTIONS = {"full": (1 / 4, 1 / 8, 1 / 16), "quick": (1 / 2, 1 / 4, 1 / 8)}
#: ``--scene``: an explicit scheme's largest step is kept at or below this fraction of
#: its critical step as the core estimates it on the scene (the core's CRITICAL_SAFETY,
#: the fraction central's dt = 0 takes: the estimate is the linear limit at full contact,
#: approached from above); where its ladder would go above, its step is divided by an
#: integer (:func:`_explicit_divisors`).
EXPLICIT_SAFETY = 0.9
#: The 2D references (module docstring): name -> (scheme key, c in dt = h/c, the
#: quantities it is the reference for, the mesh sizes per study size, coarse to fine:
#: the finest is the reference, the two before it give its error estimate).
REFERENCES = {
    # energy-conserving: the trapezoidal rule with the consistent mass, small steps
    "consistent": ("newmark", 20.0, ("e_total",),
                   {"full": (0.0125, 0.00625, 0.003125),
                    "quick": (0.025, 0.0125, 0.00625)}),
    # generalized-alpha (rho_inf = 0.5) at dt = h: damps the contact chatter of the
    # consistent mass (a mesh-scale oscillation, omega dt >~ 1), second order below it
    "filtered": ("galpha0.5", 1.0, ("u_n", "v_n", "p_n"),
                 {"full": (0.00625, 0.003125, 0.0015625, 0.00078125, 0.000390625),
                  "quick": (0.025, 0.0125, 0.00625)}),
}
#: Reference levels too costly to run inside the study (about 19 minutes of two cores
#: and 2 GB for the finest filtered level: 1.3 million dofs, 7 680 steps), shipped with
#: the package instead: (reference name, h) -> file in SHIPPED_DIR. Each file holds the
#: trace and, on its first line, the scene the core parsed, the code version and the
#: cost; the study uses it only when that scene is the one it would run (else the level
#: is an error naming the file and how to write it again: write_shipped_reference).
SHIPPED = {("filtered", 0.000390625): "ref_filtered_h0.000390625.csv.gz"}
SHIPPED_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data")
#: Scene keys a shipped level may differ in: they change neither the numbers (the
#: solve's threads give the same bits) nor the trace's rows.
SHIPPED_FREE_KEYS = (("solver", "threads"), ("mesh", "max_elements"))
#: The time-step check: each reference is run again at its coarsest level with dt
#: halved; the difference is its time error at dt, reported beside its space error. At
#: a fixed dt/h the time error shrinks at least as fast as the space error, so the
#: coarsest level bounds the ratio of the two.
DT_CHECK_LEVEL = 0
#: A 2D run's error counts as measured when it is at least this many times the
#: estimated error of the reference.
RESOLVED_MARGIN = 3.0
#: The floor on the order observed between the reference levels (a pessimistic estimate
#: when the differences barely decrease).
MIN_ORDER = 0.2
COLUMNS = "t,u_n,v_n,p_n,e_total"
#: Trace rows about this far apart in time, for every run: writing a row costs about as
#: much as a step on the small meshes, so a row per step would charge the small-step
#: schemes for output rather than for computing. The RMS-in-time errors are taken over
#: these rows (trapezoidal rule).
OUTPUT_DT = 0.0025
#: Runs shorter than this (CPU seconds) are timed to within their noise: a summary whose
#: cheapest runs are that short says their ranking is not reliable (six repeats of one
#: run of the 1D bar at h = 0.05 to T = 1 took 1.3-2.5 ms, the first the longest: more
#: than newmark and hht differ there).
SHORT_CPU_S = 0.02


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


def mean_abs_in_time(t: np.ndarray, e: np.ndarray) -> float:
    """(1/T) int_0^T |e| dt, T = t[-1] - t[0] (trapezoidal rule): the L1 norm in time
    divided by T."""
    span = float(t[-1] - t[0]) if len(t) > 1 else 0.0
    return float(np.trapezoid(np.abs(e), t)) / span if span > 0 else float("nan")


_NORM_FN = {"rms": rms_in_time, "mean": mean_abs_in_time}
NORM_NAME = {"rms": "RMS", "mean": "mean |·|"}


def _measures():
    """[(column suffix, quantity, norm)]: every quantity in its norm (NORMS), then those
    of RMS_TOO in RMS (suffix '<q>_rms')."""
    return ([(q, q, NORMS[q]) for q in QUANTITIES]
            + [(f"{q}_rms", q, "rms") for q in RMS_TOO if NORMS[q] != "rms"])


def _errors(tr: dict, ref: dict) -> dict[str, float]:
    """err_<q> (q in its norm in time, NORMS) and err_<q>_rms (RMS_TOO) of the trace tr
    against ref, whose rows are interpolated linearly to tr's times; e_total relative to
    ref's e_total(0). Only tr's rows up to ref's last time are compared: where Δt does
    not divide T, each run stops at its first step past T, and a row after ref's end
    would be compared with ref's last row held constant (np.interp), an error of about
    the time past it times the rate of change that no Δt makes smaller."""
    t_ref = ref["t"]
    keep = tr["t"] <= t_ref[-1] + 1e-9 * (t_ref[-1] - t_ref[0])
    t = tr["t"][keep]
    e0 = float(ref["e_total"][0])
    out = {}
    for key, q, norm in _measures():
        r = np.interp(t, t_ref, ref[q])
        d = tr[q][keep] - r
        out[f"err_{key}"] = _NORM_FN[norm](t, d / e0 if q == "e_total" else d)
    return out


def _exact_trace(t: np.ndarray) -> dict[str, np.ndarray]:
    from .. import exact1d as ex

    return {"t": t, "u_n": ex.u_n(t), "v_n": ex.v_n(t), "p_n": ex.sigma_n(t),
            "e_total": np.full_like(t, ex.ENERGY)}


def richardson(d1: float, d2: float) -> tuple[float, float]:
    """(p, error of the finest level) from the differences d1 = |r(4h) - r(2h)| and
    d2 = |r(2h) - r(h)| of three levels: if |r(h) - r| = C h^p, then d1/d2 = 2^p and
    |r(h) - r| = d2 / (2^p - 1). p is floored at MIN_ORDER in the estimate; (nan, inf)
    when d2 >= d1 (the levels do not converge)."""
    if not (d2 < d1) or not d1 > 0:
        return float("nan"), float("inf")
    p = math.log2(d1 / d2)
    return p, d2 / (2 ** max(p, MIN_ORDER) - 1)


def _reference_tasks(base: str, size: str, t_end: float):
    """[(task, (reference name, level index or 'dt', h, dt))]: every reference at every
    level, and each at level DT_CHECK_LEVEL with dt halved."""
    out = []
    for name, (key, c, _qs, by_size) in REFERENCES.items():
        levels = by_size[size]
        runs = [(i, h, h / c) for i, h in enumerate(levels)]
        runs.append(("dt", levels[DT_CHECK_LEVEL], levels[DT_CHECK_LEVEL] / (2 * c)))
        for i, h, dt in runs:
            out.append((_trace_task(base, SCHEMES[key], dt, t_end,
                                    {"case": "2d-ref", "ref": name, "level": i, "h": h,
                                     "dt": dt}, h=h, every=_level_every(dt)),
                        (name, i, h, dt)))
    return out


def _level_every(dt: float) -> int:
    """output.every of a reference level: steps longer than OUTPUT_DT / 4 write a row per
    step, so that the levels' rows nest (dt halving) and no level is compared through an
    interpolation of a coarser sampling than its own step; shorter ones
    :func:`_nested_every`."""
    return 1 if dt > OUTPUT_DT / 4 else _nested_every(dt)


def _trace_task(base: str, s, dt: float, t_end: float, tags, h: float | None = None,
                every: int | None = None) -> Task:
    """A run of scheme ``s`` (a SchemeSpec) on the scene file ``base`` at step dt to
    t_end (with mesh size h, else the scene's mesh), writing the trace COLUMNS every
    ``every`` steps (default: :func:`_every`) and no fields."""
    settings = dict(s.settings)
    if h is not None:
        settings["mesh.h"] = h
    settings.update({"scheme.dt": dt, "scheme.t_end": t_end,
                     "output.every": every or _every(dt), "output.fields_every": 0})
    return make_task(base, settings, "trace", {"columns": COLUMNS}, tags=tags)


def _nested_every(dt: float) -> int:
    """Rows every 2^k steps, the fewest k with rows at least OUTPUT_DT / 4 apart: the
    rows of a level at dt fall on those of the level at 2 dt (whose every is 1 or half
    this one), so successive levels are compared at common times."""
    k = max(0, math.ceil(math.log2(OUTPUT_DT / 4 / dt) - 1e-12))
    return 2 ** k


def _shipped_dump(task) -> dict[str, Any]:
    """The scene of a task as the core parses it, without SHIPPED_FREE_KEYS."""
    import tempfile

    from .sweep import _parsed

    with tempfile.TemporaryDirectory(prefix="dyncontact-ref-") as tmp:
        dump = _parsed(task, tmp)
    for group, key in SHIPPED_FREE_KEYS:
        if isinstance(dump.get(group), dict):
            dump[group].pop(key, None)
    return json.loads(json.dumps(dump, sort_keys=True, default=str))


def read_shipped(path: str) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """(header, arrays) of a shipped reference level (write_shipped_reference)."""
    with gzip.open(path, "rt", encoding="utf-8") as f:
        header = json.loads(f.readline()[1:])
        names = f.readline().strip().split(",")
        data = np.loadtxt(f, delimiter=",", ndmin=2)
    return header, {n: data[:, i] for i, n in enumerate(names)}


def _shipped_record(task, name: str, h: float) -> dict[str, Any]:
    """The record of a shipped level: its arrays when the file's scene is the task's,
    else status 'error' with the reason."""
    path = os.path.join(SHIPPED_DIR, SHIPPED[(name, h)])
    rec: dict[str, Any] = {"task": task, "cached": True, "shipped": path}
    try:
        header, arrays = read_shipped(path)
    except (OSError, ValueError) as exc:
        return {**rec, "status": "error", "message": f"{path}: cannot be read ({exc})"}
    if header.get("scene") != _shipped_dump(task):
        return {**rec, "status": "error",
                "message": f"{path}: computed for another scene than the study's level "
                           f"h = {h:g}; write it again with "
                           f"dyncontact.study.workprecision.write_shipped_reference()"}
    return {**rec, "status": "ok", "arrays": arrays, "cpu_s": header.get("cpu_s"),
            "wall_s": header.get("wall_s")}


def write_shipped_reference(cache: str | None = None, log=print) -> list[str]:
    """Run every SHIPPED level (two threads, its own cache folder) and write its file
    into SHIPPED_DIR: the header line (the parsed scene, the code version, CPU and wall
    seconds), then the trace's columns COLUMNS. Returns the paths written."""
    import tempfile

    from .sweep import code_version

    bases = write_base_scenes(tempfile.mkdtemp(prefix="dyncontact-ref-scenes-"))
    written = []
    for task, (name, _i, h, _dt) in _reference_tasks(bases["seed2d"], "full", T_END["full"]):
        if (name, h) not in SHIPPED or _i == "dt":
            continue
        run = Task(task.base, task.settings + (("solver.threads", 2),), task.analysis,
                   task.params, task.tags)
        rec = sweep([run], cache or tempfile.mkdtemp(prefix="dyncontact-ref-cache-"),
                    workers=1, progress=False, desc="shipped reference", log=log)[0]
        if rec["status"] != "ok":
            raise RuntimeError(f"shipped reference h = {h:g}: {rec['status']}: "
                               f"{rec.get('message')}")
        header = {"reference": name, "h": h, "scene": _shipped_dump(task),
                  "code": code_version(), "cpu_s": rec.get("cpu_s"),
                  "wall_s": rec.get("wall_s")}
        path = os.path.join(SHIPPED_DIR, SHIPPED[(name, h)])
        os.makedirs(SHIPPED_DIR, exist_ok=True)
        cols = COLUMNS.split(",")
        with gzip.open(path, "wt", encoding="utf-8") as f:
            f.write("#" + json.dumps(header, sort_keys=True, default=str) + "\n")
            f.write(",".join(cols) + "\n")
            for row in zip(*(rec["arrays"][c] for c in cols)):
                f.write(",".join(repr(float(v)) for v in row) + "\n")
        written.append(path)
        log(f"shipped reference: wrote {path}")
    return written


def _reference_estimates(recs, keys, size: str, references=None) -> dict[str, Any]:
    """The error of each reference from its levels: the differences d between successive
    levels (each quantity in its norm in time, NORMS; RMS_TOO also in RMS), the observed
    order p = log2(d_1/d_2) of the last two (floored at MIN_ORDER), and the error of the
    finest level d_2 / (2^p - 1); when d_2 >= d_1 the levels do not converge and the
    error is unknown (inf). The time error: level DT_CHECK_LEVEL against the same run at
    dt/2. 'truth': quantity -> the trace of the finest level of its reference.
    ``references``: REFERENCES by default; ``recs`` the records of
    :func:`_reference_tasks`' tasks, ``keys`` their (name, level, h, dt)."""
    references = REFERENCES if references is None else references
    by = {k[:2]: r for r, k in zip(recs, keys)}
    info: dict[str, Any] = {"references": {}, "quantities": {}, "truth": {}}
    for name, (key, c, qs, by_size) in references.items():
        n = len(by_size[size])
        lv = [by[(name, i)] for i in range(n)]
        chk = by.get((name, "dt"))   # None: no time-step check (the levels are Δt's)
        checks = [chk] if chk is not None else []
        ok = all(r["status"] == "ok" and r.get("arrays") for r in lv + checks)
        ref: dict[str, Any] = {
            "scheme": key, "label": SCHEMES[key].label, "c": c, "ok": ok,
            "status": [r["status"] for r in lv + checks],
            "cpu_s": [r.get("cpu_s") for r in lv + checks],
            "h": [dict(r["task"].tags)["h"] for r in lv],
            "dt": [dict(r["task"].tags)["dt"] for r in lv], "for": list(qs)}
        if ok:
            arr = [r["arrays"] for r in lv]
            diffs = [_errors(arr[i], arr[i + 1]) for i in range(n - 1)]
            dt_errs = (_errors(by[(name, DT_CHECK_LEVEL)]["arrays"], chk["arrays"])
                       if chk is not None else {})
            for m, q, _norm in _measures():
                d = [x[f"err_{m}"] for x in diffs]
                p, est = richardson(d[-2], d[-1])
                ref[m] = {"d": d, "p": p, "est": est,
                          "dt_err": dt_errs.get(f"err_{m}", float("nan")),
                          "zero": not np.any(arr[-1][q])}
            for q in qs:
                info["truth"][q] = arr[-1]
        info["references"][name] = ref
    finest = {name: by[(name, len(spec[3][size]) - 1)] for name, spec in references.items()}
    both_ok = all(info["references"][nm]["ok"] for nm in finest)
    for m, q, _norm in _measures():
        name = next(nm for nm, spec in references.items() if q in spec[2])
        ref = info["references"][name]
        est = ref[m]["est"] if ref["ok"] else float("inf")
        info["quantities"][m] = {"ref": name, "est": est}
        if both_ok and len(finest) == 2:   # two discretizations of the same solution
            a, b = (finest[nm]["arrays"] for nm in references)
            info["quantities"][m]["between"] = _errors(a, b)[f"err_{m}"]
    info["ok"] = all(r["ok"] for r in info["references"].values())
    return info


def is_resolved(err: float, est: float) -> bool:
    """A 2D run's error err is measured, not the reference's, when it is at least
    RESOLVED_MARGIN times the reference's estimated error est (never when est is
    unknown): the reference then moves it by at most a third."""
    return math.isfinite(est) and err >= RESOLVED_MARGIN * est


def resolution(est: float, errors) -> dict[str, Any]:
    """The verdict of the "converged enough" table for one quantity: the smallest error
    of the runs, how many of them are not resolved (:func:`is_resolved`), and 'yes' when
    none is ('unknown' when est is: the levels do not converge)."""
    errs = [e for e in errors if e is not None and math.isfinite(e)]
    n_unres = sum(1 for e in errs if not is_resolved(e, est))
    verdict = ("unknown" if not math.isfinite(est)
               else "yes" if errs and n_unres == 0 else "no")
    return {"verdict": verdict, "n_unresolved": n_unres, "n_all": len(errs),
            "smallest": min(errs) if errs else float("nan")}


def run_work_precision(out: str, *, quick: bool = False, c_implicit: float = 20.0,
                       c_explicit: float = 100.0, cache: str | None = None,
                       workers: int | None = None, scheduler: Any = None,
                       progress: bool | None = None, log=print) -> dict[str, Any]:
    """Run the study; writes work_precision.csv, work_precision.png, summary.md."""
    t0 = time.perf_counter()
    size = "quick" if quick else "full"
    out, cache, bases = study_folder(out, cache)
    t_end = T_END[size]
    series = _series(c_implicit, c_explicit)
    tasks = []
    for case, base, ladder in (("1d", bases["exact1d"], [1.0 / n for n in LADDER_1D[size]]),
                               ("2d", bases["seed2d"], list(LADDER_2D[size]))):
        for s, c, label, skey in series:
            for h in ladder:
                tasks.append(_trace_task(base, s, h / c, t_end,
                                         {"case": case, "series": skey, "label": label,
                                          "scheme": s.key, "h": h, "dt": h / c, "c": c},
                                         h=h))
    refs = _reference_tasks(bases["seed2d"], size, t_end)
    shipped = [(k[0], k[2]) in SHIPPED and k[1] != "dt" for _t, k in refs]
    recs = sweep(tasks + [t for (t, _), sh in zip(refs, shipped) if not sh], cache,
                 workers=workers, scheduler=scheduler, progress=progress,
                 desc="work-precision", log=log)
    run_recs, ran = recs[:len(tasks)], iter(recs[len(tasks):])
    ref_recs = [_shipped_record(t, k[0], k[2]) if sh else next(ran)
                for (t, k), sh in zip(refs, shipped)]
    for r in ref_recs:
        if r.get("shipped") and r["status"] != "ok":
            log(f"work-precision: {r['message']}")
    ref_info = _reference_estimates(ref_recs, [k for _, k in refs], size)
    title = (f"Error against CPU time to T = {t_end:g}: the 1D exact case (bar [0, 1], "
             f"E = ρ = 1) at h = {', '.join(f'1/{n}' for n in LADDER_1D[size])}, the seed "
             f"2D bar [0, 0.1] × [0, 1] at h = {', '.join(f'{h:g}' for h in LADDER_2D[size])}"
             f"; Δt = h/{c_implicit:g} implicit, h/{c_explicit:g} explicit unless labelled")
    report = _report(run_recs, recs, series, ref_info, out, CASES, title=title)
    report.update(t_end=t_end, quick=quick, wall_s=time.perf_counter() - t0, size=size)
    report["summary"] = _summary(report, os.path.join(out, "summary.md"))
    return report


def _row(r, truth) -> dict[str, Any]:
    """The CSV row of a run's record: its tags, status and cost, and its errors (case
    '1d' against the closed form, any other case against ``truth``: quantity -> the
    trace of its reference)."""
    tg = dict(r["task"].tags)
    row = {k: tg[k] for k in ("case", "series", "label", "scheme", "h", "dt", "c")}
    row.update(status=r["status"], t_end_reached=r.get("t_end_reached"),
               steps=r.get("steps"), cpu_s=r.get("cpu_s"), wall_s=r.get("wall_s"),
               newton_its_total=r.get("newton_its_total"),
               message=(r.get("message") or "").splitlines()[0] if r.get("message")
               else "")
    tr = r.get("arrays") or {}
    if tr and len(tr.get("t", ())) > 1:
        if tg["case"] == "1d":
            row.update(_errors(tr, _exact_trace(tr["t"])))
        else:
            for m, q, _norm in _measures():
                if truth.get(q):
                    row[f"err_{m}"] = _errors(tr, truth[q])[f"err_{m}"]
    return row


def _report(run_recs, recs, series, ref_info, out: str, cases,
            title: str = "") -> dict[str, Any]:
    """Rows (with the resolved flags of the cases measured against a reference run),
    work_precision.csv, work_precision.png (``title``: its title) and the cheapest-scheme
    table; the report without its summary. ``recs``: every record of the sweep (for the
    counts)."""
    truth = ref_info.pop("truth")
    rows = [_row(r, truth) for r in run_recs]
    for x in rows:
        if x["case"] != "1d":
            for m, _q, _norm in _measures():
                err = x.get(f"err_{m}")
                x[f"resolved_{m}"] = err is None or is_resolved(
                    err, ref_info["quantities"][m]["est"])
    measures = [m for m, _q, _norm in _measures()]
    cols = ["case", "series", "scheme", "h", "dt", "c", "status", "t_end_reached", "steps",
            "cpu_s", "wall_s", "newton_its_total", *(f"err_{m}" for m in measures),
            *(f"resolved_{m}" for m in measures), "message"]
    csv_path = write_csv(os.path.join(out, "work_precision.csv"), rows, cols)
    png = _plot(rows, series, ref_info, os.path.join(out, "work_precision.png"), cases,
                title=title)
    return {"rows": rows, "ref": ref_info, "cheapest": _cheapest(rows, cases),
            "csv": csv_path, "png": png, "n_runs": len(recs),
            "n_cached": sum(r["cached"] for r in recs),
            "n_errors": sum(r["status"] == "error" for r in recs)}


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


def _cheapest(rows, cases=CASES) -> list[dict[str, Any]]:
    """For each case, quantity and error level: the cheapest ok run reaching it."""
    out = []
    for case, _title in cases:
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


#: Markers and line styles of the variants of one scheme family, in the series' order
#: (:func:`series_styles`).
VARIANT_MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*", "<", ">")
VARIANT_LINES = ("-", "--", ":", "-.")


def series_styles(series) -> list[tuple[Any, str, str]]:
    """(colour, marker, line style) of each series: one colour per scheme family (the
    core's scheme name: newmark, hht, theta, pc, pc_hht, galpha, central; matplotlib's
    ten distinct colours), the family's variants (parameters, mass, contact method,
    step) told apart by marker and line style: with 'tab20' the series would come in
    light/dark pairs of one hue, hard to tell apart on 20 series."""
    from matplotlib import colormaps

    colours = colormaps["tab10"].colors
    families: dict[str, int] = {}
    seen: dict[str, int] = {}
    out = []
    for s, _c, _label, skey in series:
        # a series without a SchemeSpec (made-up rows) is a family of its own
        family = (dict(s.settings).get("scheme.name", s.key) if s is not None
                  else f"series {skey}")
        f = families.setdefault(family, len(families))
        k = seen[family] = seen.get(family, -1) + 1
        out.append((colours[f % len(colours)], VARIANT_MARKERS[k % len(VARIANT_MARKERS)],
                    VARIANT_LINES[k % len(VARIANT_LINES)]))
    return out


def _plot(rows, series, ref_info, path, cases=CASES, title: str = ""):
    """One row of panels per case (its quantities' errors against CPU time); each series
    in its family's colour, with its own marker and line style (:func:`series_styles`);
    ``title`` (what the cases are, T, Δt) above them."""
    heading = title       # the loop below names each case's title `title`
    fig, axes = new_figure(len(cases), 4, 3.9, 3.3)
    styles = series_styles(series)
    for i, (case, title) in enumerate(cases):
        for j, q in enumerate(QUANTITIES):
            ax = axes[i, j]
            key = f"err_{q}"
            finite = [r[key] for r in rows if r["case"] == case and r.get(key)
                      and r["status"] == "ok" and math.isfinite(r[key])]
            top = 2.0 * max(finite) if finite else 1.0
            for (s, c, label, skey), (col, marker, line) in zip(series, styles):
                mine = [r for r in rows if r["case"] == case and r["series"] == skey]
                ok = [r for r in mine if r["status"] == "ok" and r.get(key) and r.get("cpu_s")]
                if ok:
                    ax.loglog([r["cpu_s"] for r in ok], [r[key] for r in ok], marker=marker,
                              ls=line, ms=4, lw=1.1, color=col, label=label, gid=skey)
                    unres = [r for r in ok if r.get(f"resolved_{q}") is False]
                    if unres:
                        ax.loglog([r["cpu_s"] for r in unres], [r[key] for r in unres], "o",
                                  mfc="none", mec="k", ms=7)
                bad = [r for r in mine if r["status"] != "ok" and r.get("cpu_s")]
                if bad:
                    ax.loglog([r["cpu_s"] for r in bad], [top] * len(bad), "x", color=col,
                              ms=8, mew=2, label=f"{label}: {bad[0]['status']}")
            est = (ref_info.get("quantities", {}).get(q, {}).get("est")
                   if case != "1d" else None)
            if est and math.isfinite(est):
                ax.axhline(est, color="k", ls=":", lw=0.8,
                           label="reference error (est.)" if j == 0 else None)
            ax.set_title(f"{title}: {q}", fontsize=9)
            ax.set_xlabel("CPU time (s)")
            ax.set_ylabel(f"{NORM_NAME[NORMS[q]]} error in time"
                          + (" / e(0)" if q == "e_total" else ""))
            ax.grid(True, which="both", alpha=0.3)
    for ax in axes.flat:
        _minor_labels_only_within_a_decade(ax)
    seen: dict[str, Any] = {}
    for ax in axes[:, 0]:
        h, lab = ax.get_legend_handles_labels()
        seen.update({a: b for a, b in zip(lab, h) if a not in seen})
    # grouped by family (the order of the colours), each family's variants in the
    # series' order; entries not of a series (the reference's line) last
    colour_rank = {c: i for i, c in enumerate(dict.fromkeys(c for c, _m, _l in styles))}
    rank = {label: (colour_rank[col], k) for k, ((_s, _c, label, _skey), (col, _m, _l))
            in enumerate(zip(series, styles))}
    order = sorted(seen, key=lambda lab: rank.get(lab.split(": ")[0], (len(colour_rank), 0))
                   + (lab != lab.split(": ")[0],))
    fig.legend([seen[lab] for lab in order], order, loc="center right", fontsize=7,
               title="open circle: not resolved by the reference", title_fontsize=7)
    top = 1.0
    if heading:
        top = 1 - (0.1 + 0.17 * wrapped_suptitle(fig, heading)) / fig.get_figheight()
    return save_figure(fig, path, rect=(0, 0, 0.82, top))


def _minor_labels_only_within_a_decade(ax) -> None:
    """Leave the minor ticks of a log axis unlabelled when its range holds two powers of
    10 or more (which are labelled), label those at 2 and 5 x a power of 10 when it holds
    one (5-50 ms of CPU, a quick study's: 10⁻² would be the axis's one number), and label
    them as matplotlib chooses when it holds none (a scene study's quick runs can all take
    5-6 ms of CPU, an axis with no power of 10 in range). Those are the minor ticks
    matplotlib labels by default, written as plain numbers (0.03): as 3×10⁻² they
    overlapped their neighbours on a panel's width."""
    from matplotlib.ticker import LogFormatter, NullFormatter

    class PlainLogFormatter(LogFormatter):
        """matplotlib's choice of the minor ticks to label, each as a plain number."""

        def __call__(self, x, pos=None):
            return f"{x:g}".replace("-", "\N{MINUS SIGN}") if super().__call__(x, pos) \
                else ""

    class TwoAndFiveFormatter(LogFormatter):
        """The minor ticks 2 and 5 x a power of 10, as plain numbers: beside the one
        labelled power of 10, matplotlib's choice (2, 3, 4, 6 x) overlapped (0.03 0.04)."""

        def __call__(self, x, pos=None):
            lead = round(x / 10.0 ** math.floor(math.log10(x) + 1e-9))
            return f"{x:g}".replace("-", "\N{MINUS SIGN}") if lead in (2, 5) else ""

    for axis, (lo, hi) in ((ax.xaxis, ax.get_xlim()), (ax.yaxis, ax.get_ylim())):
        lo, hi = min(lo, hi), max(lo, hi)
        powers = math.floor(math.log10(hi)) - math.ceil(math.log10(lo)) + 1 if lo > 0 else 0
        if powers >= 2:
            axis.set_minor_formatter(NullFormatter())
        elif powers == 1:     # one number alone on the axis: 2 and 5 x its decades too
            axis.set_minor_formatter(TwoAndFiveFormatter(labelOnlyBase=False))
        else:
            axis.set_minor_formatter(PlainLogFormatter(labelOnlyBase=False))


def _pn_note(ref) -> str:
    """Why v_n and p_n have their own reference, and how far it resolves them (from the
    numbers of the study)."""
    cons, filt = ref["references"].get("consistent"), ref["references"].get("filtered")
    if not cons or not cons["ok"] or not filt or not filt["ok"]:
        return ""

    def seq(r, m):
        return " → ".join(fmt(x) for x in r[m]["d"])

    def decreasing(r, m):
        d = r[m]["d"]
        return all(b < a for a, b in zip(d, d[1:]))

    def trend(r, m):
        d, p = r[m]["d"], f"p = {fmt(r[m]['p'], '.2f')}"
        if decreasing(r, m):
            return p
        if d[-1] < d[-2]:
            return p + " from the last two, not decreasing before"
        return "not decreasing at the last level"

    qs = [(q, f"{q}_rms") for q in RMS_TOO]

    def seqs(r):
        # what a reference's own levels say, sequence by sequence: the chatter's
        # differences may shrink slowly on coarse levels and stall or grow on fine ones
        return "; ".join(
            f"{q} " + ", ".join(
                f"{seq(r, k)} ({name}, " + trend(r, k) + ")"
                for k, name in ((q, NORM_NAME[NORMS[q]]), (m, "RMS")))
            for q, m in qs)

    cons_seq = seqs(cons)
    # the verdict from the last two levels, as the error estimate (richardson) takes it
    n_dec = sum(cons[k]["d"][-1] < cons[k]["d"][-2] for q, m in qs for k in (q, m))
    cons_verdict = ("does not converge" if n_dec == 0 else
                    "converges slowly if at all" if n_dec == 2 * len(qs) else
                    "does not converge in every measure")
    dts = "; ".join(f"{q} {fmt(cons[q]['dt_err'])}" for q in RMS_TOO)
    conv = seqs(filt)
    return ("With Δt = h/20 the contact nodes chatter during contact: the active set of "
            "the contact quadrature points switches from step to step, and v_n and p_n at "
            "the probe oscillate by O(1) around their mean. Pointwise in time this "
            f"oscillation {cons_verdict}: the consistent reference's differences between "
            f"successive levels are {cons_seq}, and at a fixed h halving Δt "
            f"changes them by {dts} (mean |·|). The filtered reference (generalized-α, "
            "ρ∞ = ½, "
            "Δt = h) damps the chatter, a mesh-scale oscillation; its levels' differences "
            f"are {conv}. In RMS the jumps of v_n at impact and release cap the order at ½; "
            "in mean |·| (L¹ in time) they cost O(h), and what remains is the slower "
            "convergence of the waves after impact and release. Its Δt error is of the size "
            "of its space error, so its estimate is that of h and Δt refined together; "
            "u_n is measured against it too (its levels converge at a higher order than the "
            "consistent reference's). It is not used for e_total (it dissipates).")


def _reference_table(ref, rows, case: str) -> list[str]:
    """The "converged enough" table: per quantity and norm, each reference's level
    differences d, observed order p, estimated error (and its Δt error when it was
    checked), and for the reference in bold the smallest error of the ``case`` runs and
    whether the reference resolves them all: the runs that finished (an unstable run's
    error, such as p_n = 0 against a run stopped before the first contact, measures
    nothing, and the plot and the cheapest-scheme table leave it out too)."""
    with_dt = any(math.isfinite(r[m]["dt_err"]) for r in ref["references"].values()
                  if r["ok"] for m, _q, _n in _measures())
    table = []
    for m, q, norm in _measures():
        chosen = ref["quantities"][m]["ref"]
        res = resolution(ref["quantities"][m]["est"],
                         [r.get(f"err_{m}") for r in rows
                          if r["case"] == case and r["status"] == "ok"])
        used = norm == NORMS[q]
        for name, r in ref["references"].items():
            if not used and name != chosen:
                continue
            x = r[m]
            est = x["est"]
            cells = [q, NORM_NAME[norm] + ("" if used else " (not used)"),
                     f"**{r['label']}**" if name == chosen else r["label"],
                     ", ".join(fmt(d) for d in x["d"]), fmt(x["p"], ".2f"),
                     fmt(est) if math.isfinite(est) else "unknown"]
            cells += [fmt(x["dt_err"])] if with_dt else []
            if name == chosen:
                if res["verdict"] == "yes":
                    verdict = f"yes, all {res['n_all']} finished runs"
                elif all(d == 0 for d in x["d"]):
                    # not a reference that fails to converge: one that does not move
                    # (p_n = 0 when the reference has no contact before T)
                    zero = x.get("zero", False)
                    verdict = ("no error estimate: the levels agree exactly"
                               + ((f" ({q} = 0 at every level"
                                   + (": no contact before T)" if q == "p_n" else ")"))
                                  if zero else "")
                               + f"; all {res['n_all']} finished runs flagged")
                elif res["verdict"] == "unknown":
                    verdict = (f"no: the levels do not converge (d₂ ≥ d₁); all "
                               f"{res['n_all']} finished runs flagged")
                else:
                    verdict = (f"no for {res['n_unresolved']} of {res['n_all']} finished runs: "
                               "flagged")
                if used and res["verdict"] != "yes":
                    verdict += (" (open circles), left out of the cheapest-scheme "
                                "table")
                cells += [fmt(res["smallest"]), verdict]
            else:
                cells += ["", ""]
            table.append(cells)
    return md_table(["quantity", "norm in time", "reference", "d (coarse → fine)", "p",
                     "est. error of ref", *(["Δt error"] if with_dt else []),
                     "smallest error", f"converged enough ({RESOLVED_MARGIN:g}× margin)"],
                    table)


def _summary(report, path) -> str:
    rows, ref = report["rows"], report["ref"]
    lad1 = LADDER_1D[report["size"]]
    lad2 = LADDER_2D[report["size"]]
    refs_text = "; ".join(
        f"{r['label']} with Δt = h/{r['c']:g} at h = {r['h'][-1]:g} for {', '.join(r['for'])}"
        for r in ref["references"].values())
    lines = [
        "# Work–precision", "",
        f"T = {report['t_end']:g}. 1D exact case: h = {', '.join('1/' + str(n) for n in lad1)}"
        f" against the closed form. 2D seed bar (θ = 1, γ0 = 10): h = "
        f"{', '.join(f'{h:g}' for h in lad2)} against references computed by the code "
        f"({refs_text}). Each curve runs over "
        f"h with Δt = h/c. Errors: the probe quantity minus the reference, in time RMS "
        f"for u_n and e_total (e_total relative to e(0)) and mean |·| (L¹ in time / T) "
        f"for v_n and p_n (err_v_n_rms, err_p_n_rms in the CSV: their RMS); x axis: CPU "
        f"seconds of the run. Unstable runs: "
        f"crosses at the top of the panel.", "",
        f"{report['n_runs']} runs ({report['n_cached']} from the cache, "
        f"{report['n_errors']} failed to run), {report['wall_s']:.1f} s.", "",
        "![work-precision](work_precision.png)", "",
        "## Is the 2D reference converged enough?", ""]
    if ref["ok"]:
        lines += [
            "Each reference is run at the levels " + "; ".join(
                f"{r['label']}: h = {', '.join(f'{h:g}' for h in r['h'])}"
                for r in ref["references"].values()) + " (Δt = h/c). "
            "d: the differences between successive levels, coarse to fine, in each "
            "quantity's norm in time (RMS for u_n and e_total, continuous in time; mean "
            "|·| = L¹ in time / T for v_n and p_n, which jump at impact and release); "
            "p = log₂(d₁/d₂) from the last two; the error of the finest level "
            f"d₂/(2^p − 1) (p floored at {MIN_ORDER:g}; unknown when d₂ ≥ d₁: the levels "
            "do not converge). Δt error: the coarsest level against the same run at Δt/2. "
            "Each quantity is measured against the reference in bold; its estimated error "
            f"is compared with every 2D run's error ({RESOLVED_MARGIN:g}× margin). The "
            "rows 'RMS (not used)' measure v_n and p_n in RMS as well, to show why they "
            "are not measured so.", ""]
        lines += _reference_table(ref, rows, "2d")
        between = [(q, NORMS[q], ref["quantities"][q].get("between")) for q in QUANTITIES]
        if all(b is not None for _, _, b in between):
            names = list(ref["references"])
            lines += ["", f"Cross-check: the finest levels of the two references "
                      f"({', '.join(ref['references'][n]['label'] for n in names)}) differ by "
                      + ", ".join(f"{fmt(b)} in {q} ({NORM_NAME[nm]})" for q, nm, b in between)
                      + "."]
        lines += ["", _pn_note(ref)]
    else:
        lines += ["The reference runs did not finish: " + "; ".join(
            f"{r['label']}: {r['status']}" for r in ref["references"].values()) + "."]
    return write_markdown(path, lines + _cheapest_and_failures(report))


def _cheapest_and_failures(report) -> list[str]:
    """The summary's last sections: the cheapest run per error level, and the runs that
    did not finish."""
    lines = ["", "## Cheapest scheme per error level", "",
             "For each error level, the run of least CPU time whose error is at most the "
             "level (ok runs only; runs not resolved by their reference are left out).", ""]
    table = [[c["case"], c["quantity"], fmt(c["level"], ".0e"), c["label"], fmt(c["h"], ".4g"),
              fmt(c["dt"], ".3g"), fmt(c["cpu_s"], ".3f"), fmt(c["err"])]
             for c in report["cheapest"]]
    lines += md_table(["case", "quantity", "error ≤", "cheapest scheme", "h", "Δt", "CPU s",
                       "its error"], table)
    short = sorted({c["label"] for c in report["cheapest"] if c["cpu_s"] < SHORT_CPU_S})
    if short:
        lines += ["", f"Some of these runs took less than {SHORT_CPU_S * 1e3:g} ms of CPU "
                  f"({', '.join(short)}): at that length the time of a run varies by "
                  "about as much as the runs differ (the machine's load, caches, the "
                  "start of the run), so the ranking between runs of similar cost is not "
                  "reliable; a longer T or a finer mesh makes the runs long enough to rank."]
    bad = [r for r in report["rows"] if r["status"] != "ok"]
    lines += ["", "## Runs that did not finish", ""]
    if bad:
        lines += md_table(["case", "scheme", "h", "Δt", "status", "stopped at t", "message"],
                          [[r["case"], r["label"], fmt(r["h"], ".4g"), fmt(r["dt"], ".3g"),
                            r["status"], fmt(r.get("t_end_reached"), ".4g"), r["message"]]
                           for r in bad])
    else:
        lines.append("None.")
    return lines


# --------------------------------------------------------------------------- --scene

def _scene_rows(run_dts, ref_dts, spacing: float):
    """output.every of each run and of each reference level of a scene study, so that
    every run's rows fall on rows of every reference level: the errors are taken at
    common times, not through the linear interpolation of the reference between two of
    its rows (which errs by about (row spacing)^2 |u''| / 8: near 4e-6 in u_n on the 1D
    bar with rows 1e-3 apart, far above the time errors it is meant to measure). Each
    run writes rows at most ``spacing`` apart (the scene's coarsest implicit step), or
    one a step where its step is longer; the references write a row at every multiple of
    g, the greatest common divisor of the runs' row spacings. In units of the finest
    reference step, every step is an integer when the schemes' steps are in integer
    ratios to the smallest, as the ladders and c values make them; where one is not (or
    g is not a multiple of a level's step), the rows of the built-in study are taken:
    runs about every OUTPUT_DT, references nested, compared through the interpolation.
    Returns (the runs' every, the references' every)."""
    nested = _nested_rows(run_dts, ref_dts, spacing)
    if nested is None:
        return [_every(dt) for dt in run_dts], [_level_every(dt) for dt in ref_dts]
    return nested


def _nested_rows(run_dts, ref_dts, spacing: float):
    """The rows of :func:`_scene_rows` that fall on rows of every reference level, or None
    where the steps do not allow them (a step not an integer multiple of the finest
    reference step, or g not a multiple of a level's step)."""
    unit = min(ref_dts)
    steps = [dt / unit for dt in list(run_dts) + list(ref_dts)]
    if any(abs(k - round(k)) > 1e-6 * k for k in steps):
        return None
    n_run = [round(dt / unit) for dt in run_dts]
    n_ref = [round(dt / unit) for dt in ref_dts]
    every = [max(1, int(spacing / dt * (1 + 1e-9))) for dt in run_dts]
    g = 0
    for e, n in zip(every, n_run):
        g = math.gcd(g, e * n)
    if any(g % n for n in n_ref):
        return None
    return every, [g // n for n in n_ref]


def _scene_series(scene: UserScene, c_implicit: float, c_explicit: float, series):
    """The series of a scene study: each scheme of ``series`` on the scene's mass and
    contact (:func:`.common.on_scene`), as :func:`_series` gives them; a second scheme
    that becomes the same run as an earlier one is left out. Returns (series,
    [(key, why left out)])."""
    from .common import on_scene, refusal_on_scene, scene_step_ratio

    c0 = scene_step_ratio(scene, c_implicit, c_explicit)
    kept, left_out, seen = [], [], {}
    for s, c, _label, skey in _series(c_implicit, c_explicit, series):
        t = on_scene(s, scene)
        why = refusal_on_scene(t, scene)
        if why is not None:
            left_out.append((skey, f"refused by the core on this scene: {why}"))
            continue
        same = seen.get((t.settings, c))
        if same is not None:
            left_out.append((skey, f"differs from {same} only in its mass or contact, "
                                   f"which the study keeps at the scene's ({scene.mass} "
                                   f"mass, {scene.method} contact): the same run"))
            continue
        seen[(t.settings, c)] = skey
        family = c_explicit if t.explicit else c_implicit
        ratio = c0 / c
        kept.append((t, c, t.label + ("" if c == family else ", the scene's Δt" if ratio == 1
                                      else f", Δt×{ratio:g}"), skey))
    return kept, left_out


def _explicit_estimates(scn: UserScene, kept) -> dict[str, float | None]:
    """Series key -> the core's critical step estimate of each explicit scheme of
    ``kept`` on the scene (:func:`.common.critical_step_estimate`): one 0-step run per
    distinct scheme on the scene's mass and contact (pc at two c values is one)."""
    from .common import critical_step_estimate

    by_settings: dict[Any, float | None] = {}
    out = {}
    for s, _c, _label, skey in kept:
        if s.explicit:
            if s.settings not in by_settings:
                by_settings[s.settings] = critical_step_estimate(s, scn)
            out[skey] = by_settings[s.settings]
    return out


def _scene_steps(kept, base, divisors, factors, size: str):
    """(runs, reference levels) of a scene study: each scheme of ``kept`` at its step
    base[series key], divided by divisors.get(series key) where there is one, times each
    of ``factors``; the reference levels at SCENE_REF_FRACTIONS of the smallest step."""
    runs = []
    for s, c, label, skey in kept:
        step = base[skey] / divisors[skey] if skey in divisors else base[skey]
        runs += [(s, c, label, skey, f, step * f) for f in factors]
    dt_min = min(dt for *_, dt in runs)
    return runs, tuple(dt_min * x for x in SCENE_REF_FRACTIONS[size])


def _explicit_divisors(kept, base, factors, size: str, spacing: float,
                       estimates) -> dict[str, int]:
    """Series key -> the integer k by which an explicit scheme's step base[key] is
    divided so that its largest step, base × max(factors) / k, is at most
    EXPLICIT_SAFETY × its critical step estimate (``estimates``: key -> the core's
    estimate; None or 0, where no step is known to be stable, leaves the scheme as it
    is). k is the smallest integer that does it and keeps the ladder's points already
    at or below the cap (:func:`_keeps_stable_points`: on the halving ladders, a power of
    two, the ladder shifted down by whole halvings; where no integer keeps them, the
    smallest that brings the largest step under the cap), or the first of the next ones
    up to 2k that also keeps them and with which every run's rows fall on the
    reference's (:func:`_nested_rows`: errors at common times, not through an
    interpolation of the reference), tried in the series' order. An integer divisor
    keeps the ladder's factors, and T a whole number of steps wherever the undivided
    step made it one. Only the schemes whose ladder goes above the cap are in the
    result: where none does, the study runs exactly the runs (the same tasks, the same
    cache keys) it ran without the cap."""
    fmax = max(factors)
    need, keeps = {}, {}
    for _s, _c, _label, skey in kept:
        est = estimates.get(skey)
        if not est or not est > 0 or base[skey] * fmax <= EXPLICIT_SAFETY * est:
            continue
        cap = EXPLICIT_SAFETY * est
        k = max(2, math.ceil(base[skey] * fmax / cap))
        while base[skey] / k * fmax > cap:
            k += 1
        stable = [f for f in factors if base[skey] * f <= cap]
        keeps[skey] = lambda k, stable=stable: _keeps_stable_points(k, stable, factors)
        first = k
        while not keeps[skey](k) and k < fmax / min(factors):   # f × k <= fmax
            k += 1
        if not keeps[skey](k):        # no integer keeps them: the smallest under the cap
            k = first
            keeps[skey] = lambda k: True
        need[skey] = k
    chosen = dict(need)
    for skey, k0 in need.items():
        for k in range(k0, 2 * k0 + 1):
            if not keeps[skey](k):
                continue
            runs, levels = _scene_steps(kept, base, {**chosen, skey: k}, factors, size)
            if _nested_rows([dt for *_, dt in runs], levels, spacing) is not None:
                chosen[skey] = k
                break
    return chosen


def _keeps_stable_points(k: int, stable, factors) -> bool:
    """Whether the ladder ``factors`` divided by k still holds each point of ``stable``
    (the factors whose step is at or below the cap): each f × k is a factor of the
    ladder, so that the step f × base is run as base / k × (f × k)."""
    return all(any(math.isclose(f * k, g, rel_tol=1e-9) for g in factors) for f in stable)


def _capped_line(x) -> str:
    """One line on a scheme whose step was lowered below its critical step."""
    return (f"{x['series']} ({x['label']}): its ladder's largest step "
            f"{fmt(x['dt_ladder_max'], '.4g')} is {x['dt_ladder_max'] / x['estimate']:.3g} × "
            f"its critical step, estimated {fmt(x['estimate'], '.4g')} on this scene; run "
            f"at its step / {x['divisor']} ({x['ratio']:.3g} × the scene's Δt), the largest "
            f"{fmt(x['dt_max'], '.4g')} = {x['dt_max'] / x['estimate']:.3g} × the estimate "
            f"(at most {EXPLICIT_SAFETY:g} ×)")


def run_work_precision_scene(out: str, scene: Any, *, quick: bool = False,
                             c_implicit: float = 20.0, c_explicit: float = 100.0,
                             cache: str | None = None, workers: int | None = None,
                             scheduler: Any = None, progress: bool | None = None, log=print,
                             ladder=None, series=DEFAULT_SERIES,
                             desc: str | None = None) -> dict[str, Any]:
    """The work-precision study on a scene file of one's own (``study work-precision
    --scene``): every scheme of ``series`` on the scene's mesh, mass, contact, probe and
    T at the Δt of ``ladder`` (factors on its step, default SCENE_LADDER; its step is
    the scene's Δt × c₀/c, c₀ the ratio of the scene's own scheme,
    :func:`.common.scene_step_ratio`), against SCENE_REFERENCE at SCENE_REF_FRACTIONS of
    the smallest of those Δt: time-discretization errors on that mesh. An explicit
    scheme whose largest step would be above EXPLICIT_SAFETY × its critical step, as the
    core estimates it on the scene, runs at its step divided by an integer
    (:func:`_explicit_divisors`; the report's 'capped', its summary's "Explicit schemes
    below their critical step", one line each in ``log``). A scheme the core
    refuses on the scene (an explicit one with the ALM or the redistributed mass) is left
    out with the core's reason. Writes work_precision.csv, work_precision.png and
    summary.md into ``out``; BadInputError (a ValueError, one line) for a missing or bad
    scene.
    ``scene``: a scene file's path, or a :class:`dyncontact.Scene`, written as
    ``out/scene.nml`` for the runs to read. ``desc``: the study's name in the lines of
    ``log`` and on the progress bar; by default it names the scene file
    (``work-precision (bar.nml)``); the command line gives ``work-precision --scene``."""
    from .common import UserSceneError, on_scene, read_user_scene, scene_step_ratio

    t0 = time.perf_counter()
    size = "quick" if quick else "full"
    scn = read_user_scene(scene, out)
    desc = desc or f"work-precision ({os.path.basename(scn.path)})"
    c0 = scene_step_ratio(scn, c_implicit, c_explicit)
    out = os.path.abspath(out)
    os.makedirs(out, exist_ok=True)
    cache = cache or os.path.join(out, "cache")
    factors = tuple(ladder or SCENE_LADDER[size])
    kept, left_out = _scene_series(scn, c_implicit, c_explicit, series)
    if not kept:
        raise UserSceneError(scn.path, "the core refuses every scheme of the study on "
                             f"it (first: {left_out[-1][1]})")
    h = None if scn.mesh_file else scn.h
    base = {skey: scn.dt * c0 / c for _s, c, _label, skey in kept}
    spacing = scn.dt * c0 / c_implicit * max(factors)
    estimates = _explicit_estimates(scn, kept)
    divisors = _explicit_divisors(kept, base, factors, size, spacing, estimates)
    explicit = [{"series": skey, "label": s.label, "estimate": estimates[skey],
                 "divisor": divisors.get(skey, 1), "ratio": c0 / c / divisors.get(skey, 1),
                 "dt_ladder_max": base[skey] * max(factors),
                 "dt_max": base[skey] / divisors.get(skey, 1) * max(factors)}
                for s, c, _label, skey in kept if skey in estimates]
    capped = [x for x in explicit if x["divisor"] > 1]
    for x in capped:
        if log:
            log(f"{desc}: {_capped_line(x)}")
    kept = [(s, c, label if skey not in divisors
             else f"{s.label}, Δt×{c0 / c / divisors[skey]:.3g} (capped)", skey)
            for s, c, label, skey in kept]
    runs, levels = _scene_steps(kept, base, divisors, factors, size)
    longest = max(runs, key=lambda run: run[-1])
    if longest[-1] > scn.t_end:
        # a run whose one step passes T is refused by the core (0 < t_end < dt): said
        # once, here, rather than as a run that failed to run
        raise UserSceneError(scn.path, f"&scheme t_end = {scn.t_end:g} is shorter than the "
                             f"study's largest step, {longest[-1]:.4g} ({longest[2]}): give a "
                             "t_end of a few of them at least")
    run_every, ref_every = _scene_rows([dt for *_, dt in runs], levels, spacing)
    tasks = [_trace_task(scn.path, s, dt, scn.t_end,
                         {"case": "scene", "series": skey, "label": label, "scheme": s.key,
                          "h": h, "dt": dt, "c": c, "factor": f}, every=e)
             for (s, c, label, skey, f, dt), e in zip(runs, run_every)]
    ref_spec = on_scene(SCHEMES[SCENE_REFERENCE], scn)
    refs = [(_trace_task(scn.path, ref_spec, dt, scn.t_end,
                         {"case": "scene-ref", "ref": "scene", "level": i, "h": h, "dt": dt},
                         every=e), ("scene", i, h, dt))
            for i, (dt, e) in enumerate(zip(levels, ref_every))]
    recs = sweep(tasks + [t for t, _ in refs], cache, workers=workers,
                 scheduler=scheduler, progress=progress, desc=desc,
                 log=log)
    run_recs, ref_recs = recs[:len(tasks)], recs[len(tasks):]
    ref_info = _reference_estimates(
        ref_recs, [k for _, k in refs], size,
        {"scene": (SCENE_REFERENCE, None, QUANTITIES, {size: levels})})
    cases = (("scene", os.path.basename(scn.path)),)
    report = _report(run_recs, recs, kept, ref_info, out, cases)
    # the schemes of another step than the scene's Δt, by their factor on it (the
    # factors of the c values run, whatever --c-explicit was); those whose step was
    # lowered below their critical step by their series key, with the factor they ran at
    other: dict[float, list[str]] = {}
    for s, c, _label, skey in kept:
        name = dict(s.settings)["scheme.name"]
        if skey not in divisors and c != c0 and name not in other.setdefault(c0 / c, []):
            other[c0 / c].append(name)
    step_note = "; ".join(f"{', '.join(keys)} at {ratio:.3g}×"
                          for ratio, keys in sorted(other.items()))
    if capped:
        step_note += (("; " if step_note else "")
                      + ", ".join(f"{x['series']} at {x['ratio']:.3g}×" for x in capped)
                      + " (lowered below " + ("its" if len(capped) == 1 else "their")
                      + " critical step: see below)")
    step_note = step_note or "every scheme at the scene's Δt"
    report.update(t_end=scn.t_end, quick=quick, wall_s=time.perf_counter() - t0, size=size,
                  scene=scn, factors=factors, left_out=left_out, ref_levels=levels,
                  ref_label=ref_spec.label, c0=c0, step_note=step_note,
                  explicit=explicit, capped=capped)
    report["summary"] = _scene_summary(report, os.path.join(out, "summary.md"))
    return report


def _explicit_section(report) -> list[str]:
    """The summary's lines on the explicit schemes' steps: their critical step
    estimates, and one line per scheme whose step was lowered below it."""
    explicit = report["explicit"]
    if not explicit:
        return ["No explicit scheme in the series."]
    lines = [
        "An explicit scheme is stable only below a critical step. The core estimates it "
        "on this scene for each explicit scheme (summary.json's `dt_crit_estimate`: "
        "Ω_c/ω_max at full contact, from above; docs/numerics.md, \"Explicit schemes\"), "
        "from a run opened without a step. Where the ladder would put a scheme's largest "
        f"step above {EXPLICIT_SAFETY:g} × its estimate (the fraction central's dt = 0 "
        "takes), its step is divided by the smallest integer that brings it there (or "
        "the next one, up to twice it, whose steps fall on the reference's rows), the "
        "factors of the ladder kept: a point above it would only be a cross at the top "
        "of the panels.", ""]
    capped = report["capped"]
    lines += ([f"- {_capped_line(x)}." for x in capped]
              or [f"None lowered: every explicit scheme's largest step is at most "
                  f"{EXPLICIT_SAFETY:g} × its estimate."])
    rest = [x for x in explicit if x["divisor"] == 1]
    if rest:
        lines += ["", "Not lowered: " + "; ".join(
            f"{x['series']}: largest step {fmt(x['dt_max'], '.4g')}, "
            + (f"{x['dt_max'] / x['estimate']:.3g} × its estimate "
               f"{fmt(x['estimate'], '.4g')}" if x["estimate"]
               else "no step is stable (estimate 0)" if x["estimate"] == 0
               else "no estimate")
            for x in rest) + "."]
    return lines


def _scene_summary(report, path) -> str:
    scn, ref = report["scene"], report["ref"]
    mesh = f"mesh file {scn.mesh_file}" if scn.mesh_file else f"built-in mesh, h = {scn.h:g}"
    lines = [
        f"# Work–precision on {os.path.basename(scn.path)}", "",
        f"Scene {scn.path}: {scn.dim}D, {mesh}, {scn.mass} mass, {scn.method} contact "
        f"(γ0 = {scn.gamma0:g}), T = {scn.t_end:g}, Δt = {scn.dt:g}. Each scheme runs on "
        f"the scene as given (its mesh, material, mass, contact, probe and T; only the "
        f"time scheme and Δt change) at Δt = "
        f"{', '.join(f'{f:g}' for f in report['factors'])} × its step: the scene's Δt for "
        f"the schemes of the scene's own scheme's step h/c₀ ({scn.scheme}: c₀ = "
        f"{report['c0']:g}, as in the built-in study's Δt = h/c), × c₀/c for a scheme of "
        f"step h/c (here {report['step_note']}). "
        f"The reference is the same scene with {report['ref_label']} at the much finer "
        f"Δt = {fmt(report['ref_levels'][-1], '.4g')}. **These are time-discretization "
        "errors on this mesh**: the reference has the same mesh and contact, so the space "
        "error (of the mesh against the continuous body) is in neither and is not "
        "measured. Errors: the probe quantity minus the reference, in time RMS for u_n "
        "and e_total (e_total relative to e(0)) and mean |·| (L¹ in time / T) for v_n and "
        "p_n; x axis: CPU seconds of the run. Unstable runs: crosses at the top of the "
        "panel.", "",
        f"{report['n_runs']} runs ({report['n_cached']} from the cache, "
        f"{report['n_errors']} failed to run), {report['wall_s']:.1f} s.", "",
        "![work-precision](work_precision.png)", "", "## Schemes left out", ""]
    lines += ([f"- {k}: {why}." for k, why in report["left_out"]]
              or ["None: every scheme of the series applies to this scene."])
    lines += ["", "## Explicit schemes below their critical step", ""]
    lines += _explicit_section(report)
    lines += ["", "## Is the reference converged enough?", ""]
    if ref["ok"]:
        lines += [
            f"The reference is run at Δt = "
            f"{', '.join(fmt(d, '.4g') for d in report['ref_levels'])} (the finest is the "
            "reference). d: the differences between successive levels, coarse to fine, in "
            "each quantity's norm in time; p = log₂(d₁/d₂); the error of the finest level "
            f"d₂/(2^p − 1) (p floored at {MIN_ORDER:g}; unknown when d₂ ≥ d₁: the levels do "
            "not converge). A run whose error is less than "
            f"{RESOLVED_MARGIN:g}× that estimate is flagged as not resolved.", ""]
        lines += _reference_table(ref, report["rows"], "scene")
    else:
        r = ref["references"]["scene"]
        lines += [f"The reference runs did not finish ({', '.join(r['status'])}): no "
                  "errors are measured."]
    return write_markdown(path, lines + _cheapest_and_failures(report))
