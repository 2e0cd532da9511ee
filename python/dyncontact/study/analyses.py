"""What a sweep keeps of each run (registered analyses of :mod:`.sweep`).

- ``trace``: energy ratios and, optionally, trace columns (every ``stride``-th row).
- ``stability``: energy ratios, impact times, the energy before each impact and,
  optionally, t, u_n, e_total (the stability study and the claims).
- ``contact``: energy ratios and the p_n oscillation during contact
  (:func:`pn_oscillation`), for the "which scheme" table.
- ``outputs``: every output of the run kept as it is (trace, summary, field snapshots)
  and the summary's sizes and counters, for runs whose outputs are the result (the
  seed's figures) or whose timings are (the benchmark).
- ``exact1d``: errors of a run of the 1D exact case (SPEC section 2) against the closed
  form :mod:`dyncontact.exact1d`. Its runner (:func:`run_exact1d`) steps the run through a
  :class:`dyncontact.core.Stepper` and evaluates the fields in memory: the relative norms
  at every step, the absolute field norms at every ``snap_every``-th step; no field is
  written to disk. The probe errors come from the trace.
- ``hertz``: the contact time, largest force, centre-of-mass approach, impulse and energy
  drift of a ball's impact (:mod:`.hertz`, the 3D ball against Hertz's theory).

Field norms (1D)
----------------
At each sampled time t_k the space norms of e = u_h - u are integrated exactly: the
interval [0, 1] is cut at the mesh nodes *and* at the kinks of the exact solution
(x = tau, tau - 1, 2 - tau, 3 - tau with tau = t mod 3, where u is not smooth), so that
on every piece both u_h and u are linear and a 3-point Gauss rule is exact for e^2 and
(e')^2. ``H1`` is the full norm (L2 of e plus L2 of e'). These absolute norms are
sampled every ``snap_every`` steps (the study's uniform grid t_0 = 0 < ... < t_K = T,
the same for every h): L-infinity = max over k, L2 = trapezoidal rule.
The contact stress error is integrated in time over every trace row (``every`` = 1).

Relative norms (the literature's)
---------------------------------
GetFEM's 1D dynamic-contact demo and the papers it comes from report relative errors,
``REL_NORMS`` (suffix ``_rel``). At *every step* t_k = k dt, k = 0 (the initial state),
1, ..., N, the error is taken against the nodal interpolant I_h u of the exact solution
(e_h = u_h - I_h u, a P1 function, and v_h - I_h u_t), its L2 and full H1 norms
integrated exactly on the P1 space (:func:`p1_norms`), and the exact solution's norm of
the same kind is that of I_h u (resp. I_h u_t). In time (:func:`relative_in_time`):
L-infinity = max_k ||e_h(t_k)|| / max_k ||I_h u(t_k)||; L2 = (sum_k dt ||e_h(t_k)||^2)^(1/2)
/ (sum_k dt ||I_h u(t_k)||^2)^(1/2), the rectangle rule (dt cancels). The contact stress
likewise over every trace row: p_L2_rel = (sum_k (p_n - sigma_n)^2)^(1/2) /
(sum_k sigma_n^2)^(1/2).
"""

from __future__ import annotations

import dataclasses
import math
import os
import xml.etree.ElementTree as ET
from typing import Any

import numpy as np

from .. import exact1d as ex
from .. import core
from .sweep import register_analysis

__all__ = ["read_pvd", "read_vtu_1d", "field_errors_1d", "probe_errors_1d", "rms_in_time",
           "impacts", "contact_phases", "pn_oscillation", "FIELD_NORMS", "IMPACT_GAP",
           "PHASE_TRIM", "REL_NORMS", "p1_norms", "relative_in_time",
           "interpolant_errors_1d", "interpolant_errors_steps", "run_exact1d", "SteppedRun",
           "contact_time", "centre_approach", "analyse_hertz"]

#: Columns of the field/stress norms: L∞(0,T) then L²(0,T) of ‖u‖_L², ‖u‖_H¹ and ‖u̇‖_L²,
#: then ‖p_n − σ_n‖ in L²(0,T).
FIELD_NORMS = ("u_Linf_L2", "u_Linf_H1", "v_Linf_L2", "u_L2_L2", "u_L2_H1", "v_L2_L2",
               "p_L2")

#: The relative norms beside them (module docstring, "Relative norms").
REL_NORMS = tuple(f"{n}_rel" for n in FIELD_NORMS)

#: A new impact is a contact that starts after at least this long without contact.
IMPACT_GAP = 0.5

_GAUSS3_X, _GAUSS3_W = np.polynomial.legendre.leggauss(3)


def read_pvd(path: str) -> list[tuple[float, str]]:
    """(time, absolute .vtu path) of the data sets of a .pvd index."""
    root = ET.parse(path).getroot()
    folder = os.path.dirname(os.path.abspath(path))
    return [(float(d.get("timestep")), os.path.join(folder, d.get("file")))
            for d in root.iter("DataSet")]


def read_vtu_1d(path: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x, u, v) of an ASCII .vtu of a 1D mesh, sorted by x (first components)."""
    root = ET.parse(path).getroot()
    arrays = {}
    for da in root.iter("DataArray"):
        arrays.setdefault(da.get("Name") or "points", da.text)
    pts = np.array(arrays["points"].split(), dtype=float).reshape(-1, 3)[:, 0]
    u = np.array(arrays["displacement"].split(), dtype=float).reshape(-1, 3)[:, 0]
    v = np.array(arrays["velocity"].split(), dtype=float).reshape(-1, 3)[:, 0]
    order = np.argsort(pts)
    return pts[order], u[order], v[order]


def _pieces(x: np.ndarray, t: float) -> np.ndarray:
    """Break points in [0, 1]: the mesh nodes and the exact solution's kinks at t."""
    tau = float(np.mod(t, ex.PERIOD))
    kinks = np.array([tau, tau - 1.0, 2.0 - tau, 3.0 - tau])
    kinks = kinks[(kinks > x[0]) & (kinks < x[-1])]
    return np.unique(np.concatenate([x, kinks]))


def field_errors_1d(x, u_h, v_h, t) -> dict[str, float]:
    """||u_h - u||_L2, ||u_h - u||_H1 and ||v_h - u_t||_L2 over the bar at time t."""
    b = _pieces(np.asarray(x), t)
    a, c = b[:-1], b[1:]
    mid, half = 0.5 * (a + c), 0.5 * (c - a)
    keep = half > 1e-14
    mid, half = mid[keep], half[keep]
    xq = (mid[:, None] + half[:, None] * _GAUSS3_X[None, :]).ravel()
    wq = (half[:, None] * _GAUSS3_W[None, :]).ravel()
    # P1 fields: values by interpolation, slope of the element that holds the point
    uq = np.interp(xq, x, u_h)
    vq = np.interp(xq, x, v_h)
    k = np.clip(np.searchsorted(x, xq) - 1, 0, len(x) - 2)
    duq = (u_h[k + 1] - u_h[k]) / (x[k + 1] - x[k])
    eu = uq - ex.u(xq, t)
    ed = duq - ex.u_x(xq, t)
    ev = vq - ex.u_t(xq, t)
    l2 = float(np.sqrt(np.sum(wq * eu ** 2)))
    semi = float(np.sqrt(np.sum(wq * ed ** 2)))
    return {"u_L2": l2, "u_H1": float(np.hypot(l2, semi)),
            "v_L2": float(np.sqrt(np.sum(wq * ev ** 2)))}


def p1_norms(x, w) -> tuple[float, float]:
    """(L2, full H1) norms of the P1 function with nodal values w on the 1D mesh x,
    exact: on [a, b], int w^2 = (b - a)/3 (w_a^2 + w_a w_b + w_b^2) and
    int w'^2 = (w_b - w_a)^2 / (b - a)."""
    x, w = np.asarray(x, dtype=float), np.asarray(w, dtype=float)
    le = np.diff(x)
    wa, wb = w[:-1], w[1:]
    l2sq = float(np.sum(le / 3.0 * (wa * wa + wa * wb + wb * wb)))
    semi_sq = float(np.sum((wb - wa) ** 2 / le))
    return float(np.sqrt(l2sq)), float(np.sqrt(l2sq + semi_sq))


def interpolant_errors_1d(x, u_h, v_h, t) -> dict[str, float]:
    """At time t: the norms of u_h - I_h u (L2, H1) and v_h - I_h u_t (L2), and those of
    I_h u and I_h u_t (keys ``ex_*``), I_h the nodal interpolant on the mesh x."""
    x = np.asarray(x, dtype=float)
    iu, iv = ex.u(x, t), ex.u_t(x, t)
    eu_l2, eu_h1 = p1_norms(x, np.asarray(u_h) - iu)
    ev_l2, _ = p1_norms(x, np.asarray(v_h) - iv)
    xu_l2, xu_h1 = p1_norms(x, iu)
    xv_l2, _ = p1_norms(x, iv)
    return {"u_L2": eu_l2, "u_H1": eu_h1, "v_L2": ev_l2,
            "ex_u_L2": xu_l2, "ex_u_H1": xu_h1, "ex_v_L2": xv_l2}


def interpolant_errors_steps(x, t, u_h, v_h) -> dict[str, np.ndarray]:
    """:func:`interpolant_errors_1d` at many times at once: ``t`` (K,), ``u_h`` and ``v_h``
    (K, n) nodal values on the mesh x (n,); each key holds a (K,) array."""
    x = np.asarray(x, dtype=float)
    t = np.asarray(t, dtype=float)[:, None]
    iu, iv = ex.u(x[None, :], t), ex.u_t(x[None, :], t)
    w = np.stack([np.asarray(u_h, dtype=float) - iu, np.asarray(v_h, dtype=float) - iv,
                  iu, iv])                                       # (4, K, n)
    le = np.diff(x)
    wa, wb = w[..., :-1], w[..., 1:]
    # the element sums as products with the element lengths (no (4, K, n) temporaries
    # beyond the three products)
    l2sq = (wa * wa + wa * wb + wb * wb) @ (le / 3.0)
    dw = wb - wa
    semi_sq = (dw * dw) @ (1.0 / le)
    l2 = np.sqrt(l2sq)
    h1 = np.sqrt(l2sq + semi_sq)
    return {"u_L2": l2[0], "u_H1": h1[0], "v_L2": l2[1],
            "ex_u_L2": l2[2], "ex_u_H1": h1[2], "ex_v_L2": l2[3]}


@dataclasses.dataclass
class SteppedRun(core.RunResult):
    """A :class:`dyncontact.core.RunResult` and what :func:`run_exact1d` evaluated in
    memory: ``x`` the mesh nodes, ``steps`` the space norms of
    :func:`interpolant_errors_steps` at every step (key ``t`` their times, from 0), and
    ``snapshots`` [(t, u_h, v_h)] every ``snap_every``-th step (nodal values on x)."""

    x: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0))
    steps: dict = dataclasses.field(default_factory=dict)
    snapshots: list = dataclasses.field(default_factory=list)


#: Steps gathered before their norms are evaluated together (a bound on the memory).
STEP_BATCH = 512


def run_exact1d(scene, run_dir: str, snap_every: int = 0, **_params) -> SteppedRun:
    """Run a 1D exact-case scene into run_dir (as :func:`dyncontact.run`: trace.csv and
    summary.json) through a Stepper, and evaluate the fields at every step in memory:
    the norms of :func:`interpolant_errors_steps` at steps 0 (the initial state), 1, ...,
    N, and the nodal fields at every ``snap_every``-th step (0: none). The mesh nodes are
    those of the built-in bar of the scene's ``&mesh``; the clamped node x = 1 holds 0."""
    h = float(scene.get("mesh.h"))
    length = float(scene.get("mesh.length"))
    x = np.asarray(core.load_mesh(dim=1, length=length, h=h)["x"])[:, 0]
    snap = int(snap_every)
    steps: dict[str, list] = {}
    snapshots: list = []
    message = ""
    ts: list[float] = []
    us: list[np.ndarray] = []
    vs: list[np.ndarray] = []

    def flush() -> None:
        if ts:
            for k, val in interpolant_errors_steps(x, ts, us, vs).items():
                steps.setdefault(k, []).append(val)
            steps.setdefault("t", []).append(np.array(ts))
            ts.clear(), us.clear(), vs.clear()

    with core.Stepper(scene, run_dir) as s:
        node, _comp = s.dof_map()
        n_done = 0
        while True:
            st = s.state()
            u = np.zeros(len(x))
            v = np.zeros(len(x))
            u[node], v[node] = st["u"], st["v"]
            ts.append(st["t"])
            us.append(u)
            vs.append(v)
            if snap and n_done % snap == 0:
                snapshots.append((st["t"], u, v))
            if len(ts) >= STEP_BATCH:
                flush()
            if s.finished:
                break
            try:
                if s.advance(1) == 0:
                    break
            except core.NumericalError as exc:   # unstable: the trace is kept
                message = str(exc) or "numerical failure"
                break
            n_done += 1
    flush()
    summary = core.read_summary(run_dir)
    if message and summary.get("status", "ok") == "ok":
        summary = dict(summary, status="unstable")
    return SteppedRun(trace=core.read_trace(run_dir), summary=summary, out_dir=run_dir,
                      message=message, x=x,
                      steps={k: np.concatenate(v) for k, v in steps.items()},
                      snapshots=snapshots)


def relative_in_time(err, exact) -> tuple[float, float]:
    """(L-infinity, L2) in time of the relative error, from space norms at equally
    spaced times: max(err)/max(exact), and (sum err^2)^(1/2) / (sum exact^2)^(1/2)
    (the rectangle rule; the common step cancels). nan when the exact norms are all 0."""
    err, exact = np.asarray(err, dtype=float), np.asarray(exact, dtype=float)
    if len(err) == 0 or not np.max(np.abs(exact)) > 0:
        return float("nan"), float("nan")
    return (float(np.max(err) / np.max(exact)),
            float(np.sqrt(np.sum(err ** 2)) / np.sqrt(np.sum(exact ** 2))))


def _time_l2(t: np.ndarray, e: np.ndarray) -> float:
    """(int_0^T e(t)^2 dt)^(1/2) by the trapezoidal rule."""
    if len(t) < 2:
        return float("nan")
    return float(np.sqrt(np.trapezoid(np.asarray(e) ** 2, t)))


def rms_in_time(t: np.ndarray, e: np.ndarray) -> float:
    """(1/T int_0^T e^2 dt)^(1/2), T = t[-1] - t[0] (trapezoidal rule)."""
    span = float(t[-1] - t[0]) if len(t) > 1 else 0.0
    return _time_l2(t, e) / np.sqrt(span) if span > 0 else float("nan")


def probe_errors_1d(trace: dict[str, np.ndarray]) -> dict[str, float]:
    """RMS-in-time errors of u_n, v_n, p_n and e_total (relative to 1/8) at x = 0."""
    t = trace["t"]
    return {"err_u_n": rms_in_time(t, trace["u_n"] - ex.u_n(t)),
            "err_v_n": rms_in_time(t, trace["v_n"] - ex.v_n(t)),
            "err_p_n": rms_in_time(t, trace["p_n"] - ex.sigma_n(t)),
            "err_e_total": rms_in_time(t, (trace["e_total"] - ex.ENERGY) / ex.ENERGY)}


def _energy_metrics(trace: dict[str, np.ndarray]) -> dict[str, float]:
    e = trace["e_total"]
    ec = e + trace["e_contact"]
    if len(e) == 0:
        return {}
    e0 = float(e[0]) if e[0] != 0 else float("nan")
    fin = np.isfinite(e)
    # E = e_total + e_contact against its own initial value (Nitsche's e_contact is not
    # zero out of contact: -theta/(2 gamma) |sigma_n|^2 terms)
    return {"e0": e0, "e_end_ratio": float(e[-1] / e0),
            "e_max_ratio": float(np.max(e[fin]) / e0) if fin.any() else float("nan"),
            "ec_end_ratio": float(ec[-1] / ec[0]) if ec[0] else float("nan"),
            "t_last": float(trace["t"][-1])}


@register_analysis("exact1d", runner=run_exact1d)
def analyse_exact1d(run_dir: str, result, snap_every: int = 0) -> dict[str, Any]:
    """Probe errors and stress norms from the trace; the absolute field norms from the
    snapshots and the relative ones from every step, when the result holds them (a
    :class:`SteppedRun` of :func:`run_exact1d`)."""
    trace = result.trace
    metrics: dict[str, Any] = dict(_energy_metrics(trace))
    metrics.update(probe_errors_1d(trace))
    t = trace["t"]
    sigma = ex.sigma_n(t)
    metrics["p_L2"] = _time_l2(t, trace["p_n"] - sigma)
    metrics["p_L2_rel"] = relative_in_time(np.abs(trace["p_n"] - sigma), np.abs(sigma))[1]
    x = getattr(result, "x", None)
    snaps = getattr(result, "snapshots", None) or []
    if snaps:
        errs = [field_errors_1d(x, u_h, v_h, tk) for tk, u_h, v_h in snaps]
        ts = np.array([tk for tk, _, _ in snaps])
        eu, eh, ev = (np.array([e[k] for e in errs]) for k in ("u_L2", "u_H1", "v_L2"))
        metrics.update(
            u_Linf_L2=float(np.max(eu)), u_Linf_H1=float(np.max(eh)),
            v_Linf_L2=float(np.max(ev)), u_L2_L2=_time_l2(ts, eu),
            u_L2_H1=_time_l2(ts, eh), v_L2_L2=_time_l2(ts, ev), snapshots=len(ts))
    steps = getattr(result, "steps", None) or {}
    if steps and len(steps.get("t", ())):
        for space, key in (("L2", "u_L2"), ("H1", "u_H1")):
            lin, l2 = relative_in_time(steps[key], steps["ex_" + key])
            metrics[f"u_Linf_{space}_rel"], metrics[f"u_L2_{space}_rel"] = lin, l2
        metrics["v_Linf_L2_rel"], metrics["v_L2_L2_rel"] = \
            relative_in_time(steps["v_L2"], steps["ex_v_L2"])
        metrics["rel_steps"] = int(len(steps["t"]))
    return {"metrics": metrics}


#: The summary.json fields that the ``outputs`` analysis copies into its metrics.
OUTPUT_COUNTERS = ("factorizations", "setup_factorizations", "dofs", "elements", "isa",
                   "blas", "solve_kernel")


@register_analysis("outputs")
def analyse_outputs(run_dir: str, result) -> dict[str, Any]:
    """Keep every output of the run; metrics: the summary's :data:`OUTPUT_COUNTERS` and
    rows (the trace's rows)."""
    s = result.summary
    metrics = {k: s.get(k) for k in OUTPUT_COUNTERS}
    metrics["rows"] = int(len(result.trace.get("t", ())))
    return {"metrics": metrics, "keep": sorted(os.listdir(run_dir))}


@register_analysis("trace")
def analyse_trace(run_dir: str, result, columns: str = "", stride: int = 1) -> dict[str, Any]:
    """Energy ratios; with ``columns`` ('t,u_n,...') those trace columns, every
    ``stride``-th row (the last row always kept)."""
    trace = result.trace
    arrays = {}
    if columns and len(trace["t"]):
        idx = np.arange(0, len(trace["t"]), max(1, int(stride)))
        if idx[-1] != len(trace["t"]) - 1:
            idx = np.append(idx, len(trace["t"]) - 1)
        arrays = {c: np.asarray(trace[c])[idx] for c in columns.split(",")}
    return {"metrics": _energy_metrics(trace), "arrays": arrays}


def impacts(t: np.ndarray, active: np.ndarray, gap: float = IMPACT_GAP) -> np.ndarray:
    """Start times of the impacts: rows where contact starts after at least ``gap`` time
    units without any active contact point (chattering within a contact phase is one
    impact)."""
    starts = []
    last_contact = -np.inf
    was = False
    for ti, a in zip(t, active):
        on = a > 0
        if on and not was and ti - last_contact >= gap:
            starts.append(ti)
        if on:
            last_contact = ti
        was = on
    return np.array(starts)


#: Fraction of each contact phase left out at either end when measuring the p_n
#: oscillation (the impact and release transients are not oscillations).
PHASE_TRIM = 0.2
#: Contact phases shorter than this many trace rows are skipped by the oscillation measure.
MIN_PHASE_ROWS = 10


def contact_phases(t: np.ndarray, active: np.ndarray,
                   gap: float = IMPACT_GAP) -> list[tuple[float, float]]:
    """(start, end) of each contact phase: from an impact (as :func:`impacts`) to the last
    row in contact before the next gap of at least ``gap`` without contact (or the last
    row). Chattering inside a phase does not end it."""
    phases: list[list[float]] = []
    last_on = -np.inf
    for ti, a in zip(t, active):
        if a > 0:
            if not phases or ti - last_on >= gap:
                phases.append([float(ti), float(ti)])
            phases[-1][1] = float(ti)
            last_on = ti
    return [(a, b) for a, b in phases]


def pn_oscillation(trace: dict[str, np.ndarray], trim: float = PHASE_TRIM) -> dict[str, Any]:
    """How much p_n oscillates during contact, and the energy across the first contact.

    - ``pn_rel_std``: the standard deviation of p_n over the interior of the contact phases
      (each phase without its first and last ``trim`` fraction), over |mean of p_n| there;
      rows pooled over the phases (the trace must be written at a fixed step).
    - ``pn_tv_rate``: total variation of p_n over the whole contact phases per unit contact
      time (depends on the output spacing: compare runs written every step).
    - ``e_first_contact``: (E_after − E_before)/E(0) with E = e_total + e_contact, from the
      row before the first impact to the first row after the first phase ends (NaN if the
      run ends in contact).
    - ``e_first_row``: (E(t_1) − E(0))/E(0) over the first trace row (the first step when
      the trace is written every step): where an initial state that the scheme cannot
      hold (a massless contact node out of equilibrium) loses its energy.
    """
    t, p, act = trace["t"], trace["p_n"], trace["active"]
    out: dict[str, Any] = {"contact_phases": 0, "contact_time": 0.0,
                           "pn_rel_std": float("nan"), "pn_tv_rate": float("nan"),
                           "pn_mean": float("nan"), "e_first_contact": float("nan"),
                           "e_first_row": float("nan")}
    if len(t) < 2:
        return out
    e = trace["e_total"] + trace["e_contact"]
    e0 = float(e[0])
    if e0:
        out["e_first_row"] = float((e[1] - e[0]) / e0)
    phases = contact_phases(t, act)
    inner, tv, ct = [], 0.0, 0.0
    for a, b in phases:
        w = (t >= a) & (t <= b)
        if w.sum() < MIN_PHASE_ROWS:
            continue
        tv += float(np.sum(np.abs(np.diff(p[w]))))
        ct += b - a
        lo, hi = a + trim * (b - a), b - trim * (b - a)
        inner.append(p[(t >= lo) & (t <= hi)])
    out["contact_phases"] = len(phases)
    out["contact_time"] = ct
    if inner and sum(len(x) for x in inner) > 1:
        allp = np.concatenate(inner)
        mean = float(np.mean(allp))
        out["pn_mean"] = mean
        out["pn_rel_std"] = float(np.std(allp) / abs(mean)) if mean else float("nan")
    if ct > 0:
        out["pn_tv_rate"] = tv / ct
    if phases:
        i0 = int(np.searchsorted(t, phases[0][0])) - 1
        i1 = int(np.searchsorted(t, phases[0][1], side="right"))
        if i0 >= 0 and i1 < len(t) and e0:
            out["e_first_contact"] = float((e[i1] - e[i0]) / e0)
    return out


@register_analysis("contact")
def analyse_contact(run_dir: str, result) -> dict[str, Any]:
    """Energy ratios and the p_n oscillation measures of :func:`pn_oscillation`."""
    m = dict(_energy_metrics(result.trace))
    m.update(pn_oscillation(result.trace))
    return {"metrics": m}


@register_analysis("stability")
def analyse_stability(run_dir: str, result, keep_rows: int = 0) -> dict[str, Any]:
    """Energy ratios, impact times, the energy just before each impact (the flight
    energy left by the previous contact), and optionally t, u_n, e_total."""
    tr = result.trace
    t, e = tr["t"], tr["e_total"]
    m: dict[str, Any] = {}
    if len(t):
        # a body at rest (under gravity) starts with no energy: no ratio to it, as in
        # _energy_metrics (not e/0 = inf, with numpy's divide-by-zero warning on stderr)
        e0 = float(e[0])
        scale = e0 if e0 != 0 else float("nan")
        ec0 = float(e[0] + tr["e_contact"][0])
        fin = np.isfinite(e)
        starts = impacts(t, tr["active"])
        idx = np.searchsorted(t, starts) - 1
        before = [float(e[i] / scale) for i in idx if i >= 0]
        m = {"e0": e0, "e_end_ratio": float(e[-1] / scale),
             "e_max_ratio": float(np.max(e[fin]) / scale) if fin.any() else float("nan"),
             "ec_end_ratio": float((e[-1] + tr["e_contact"][-1]) / ec0) if ec0
             else float("nan"),
             "impact_times": [float(x) for x in starts],
             "e_before_impacts": before, "t_last": float(t[-1])}
    # the explicit schemes (central, the pc family) estimate their own critical step
    # (summary.json)
    m["dt_crit_estimate"] = result.summary.get("dt_crit_estimate")
    arrays = {}
    if keep_rows and len(t):
        stride = max(1, len(t) // int(keep_rows))
        idx = np.arange(0, len(t), stride)
        arrays = {"t": t[idx], "u_n": tr["u_n"][idx], "e_total": e[idx]}
    return {"metrics": m, "arrays": arrays}


def contact_time(t: np.ndarray, f_n: np.ndarray) -> tuple[float, float, float]:
    """(t_c, lower, upper) of the first contact phase: t_c from |f_n|^(2/3) extrapolated
    linearly to 0 at both ends (:mod:`.hertz`'s docstring); lower/upper from the first and
    last rows with f_n < 0 (the bracket). NaN when there is no contact or it has not
    ended."""
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
    (Newmark ¼ ½'s own integration of the total momentum; :mod:`.hertz`'s docstring)."""
    def integral(y: np.ndarray) -> np.ndarray:    # ∫_0^t y by the trapezoidal rule
        return np.concatenate([[0.0], np.cumsum(0.5 * (y[1:] + y[:-1]) * np.diff(t))])

    vz = -speed - integral(f_n) / mass
    return -integral(vz)


@register_analysis("hertz")
def analyse_hertz(run_dir: str, result, speed: float) -> dict[str, Any]:  # noqa: ARG001
    """The run's contact time, F_max, δ_max, impulse and energy drift
    (:mod:`.hertz`'s docstring), its dofs and elements."""
    tr = result.trace
    t = np.asarray(tr["t"], dtype=float)
    f_n = np.asarray(tr["f_n"], dtype=float)
    mass = 2.0 * float(tr["e_kin"][0]) / speed ** 2
    tc, lo, hi = contact_time(t, f_n)
    e = np.asarray(tr["e_total"], dtype=float) + np.asarray(tr["e_contact"], dtype=float)
    return {"metrics": {
        "dofs": result.summary.get("dofs"), "elements": result.summary.get("elements"),
        "mass": mass, "tc": tc, "tc_lo": lo, "tc_hi": hi, "fmax": float(-np.min(f_n)),
        "delta_max": float(np.max(centre_approach(t, f_n, mass, speed))),
        "impulse": float(-np.trapezoid(f_n, t) / (2.0 * mass * speed)),
        "energy_drift": float(e[-1] / e[0] - 1.0)}}
