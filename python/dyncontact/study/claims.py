"""The seed's claims, each given a verdict computed from the stability sweep's runs.

Nothing here is hard-coded but the thresholds that turn numbers into words, stated in
each claim's row:

- an impact is a contact that starts after >= 0.5 time units without contact
  (:func:`.analyses.impacts`); "after about 4-5 impacts" accepts 3 to 6;
- the energy change per impact is the geometric mean over the flight phases,
  (E_n / E_1)^(1/(n-1)) - 1 with E_k = e_total just before impact k (in flight the
  scheme's energy is constant up to the small theta = 1 effect noted in numerics.md);
  "significant" means more than +1 % of the energy per impact;
- "robust" means stable at every dt/h of the grid, and "small γ0" below the element bound
  of θ = 1 (the sweep's smallest γ0 is tested only when the core refuses θ = 1 there;
  above the bound the claim is not tested). A setting the core refuses as bad input
  (theta = 1 with gamma0 below its bound) is counted apart, as refused: it is neither
  stable nor unstable, and a theta is compared with another only on the settings it
  accepts.
"""

from __future__ import annotations

import math
from typing import Any, Mapping, Sequence

import numpy as np

from .common import SCHEMES, fmt
from .sweep import REFUSED

__all__ = ["claims_table", "gain_per_impact"]

SEED_RATIO = 1 / 20       # the seed's HHT step, dt = h/20
SIGNIFICANT_GAIN = 0.01   # +1 % of the energy per impact


def gain_per_impact(e_before: Sequence[float]) -> float:
    """(E_n/E_1)^(1/(n-1)) - 1 from the energies just before each impact (NaN if n < 2)."""
    e = [x for x in e_before if x is not None and math.isfinite(x) and x > 0]
    if len(e) < 2:
        return float("nan")
    return (e[-1] / e[0]) ** (1.0 / (len(e) - 1)) - 1.0


def _sel(recs, **want):
    out = []
    for r in recs:
        tg = dict(r["task"].tags)
        if all((math.isclose(tg.get(k), v, rel_tol=1e-9) if isinstance(v, float)
                else tg.get(k) == v) for k, v in want.items()):
            out.append(r)
    return out


def _n_impacts(r) -> int:
    return len(r.get("metrics", {}).get("impact_times", []) or [])


def _outcome(r) -> str:
    if r["status"] == "ok":
        return "stable to T"
    return f"{r['status']} at t={fmt(r.get('t_end_reached'), '.3g')} after {_n_impacts(r)} impacts"


def _setting(tg: Mapping[str, Any], with_scheme=False) -> str:
    s = f"h={tg['h']:g} γ0={tg['gamma0']:g} θ={tg['theta']:+d}"
    return (f"{tg['scheme']} " + s) if with_scheme else s


def claims_table(recs: Sequence[Mapping[str, Any]], grid: Mapping[str, Any]) -> list[dict]:
    """Rows {claim, setting, verdict, evidence} from the grid runs of the sweep."""
    recs = [r for r in recs if r["task"].tag("phase") == "grid"]
    return [_claim_pc(recs, grid), _claim_cn(recs, grid), _claim_alpha(recs, grid),
            _claim_skew(recs, grid), *_claim_seed_coeffs(recs, grid)]


def _not_tested(claim, why) -> dict:
    return {"claim": claim, "setting": "-", "verdict": "not tested", "evidence": why}


def _claim_pc(recs, grid) -> dict:
    claim = ("pc at the HHT step (h/20) converges for a short time but becomes unstable "
             "after about 4–5 impacts")
    runs = [r for r in recs if r["task"].tag("scheme") in ("pc", "pc_lumped")
            and math.isclose(r["task"].tag("dt_over_h"), SEED_RATIO, rel_tol=1e-9)]
    if not runs:
        return _not_tested(claim, "no pc run at Δt = h/20 in the sweep")

    def label(r):
        tg = dict(r["task"].tags)
        return f"{tg['mass'][0]}/h{tg['h']:g}/γ0 {tg['gamma0']:g}/θ{tg['theta']:+d}"

    # a setting the core refuses (θ = 1 below the γ0 bound) is counted apart
    refused = [label(r) for r in runs if r["status"] == REFUSED]
    runs = [r for r in runs if r["status"] != REFUSED]
    if not runs:
        return _not_tested(claim, "the core refused every pc run at Δt = h/20 of the sweep")
    cats: dict[str, list[str]] = {"holds": [], "stable to T": [], "unstable before 3 impacts":
                                  [], "unstable after more than 6 impacts": [], "other": []}
    diffs = []
    for r in runs:
        tg = dict(r["task"].tags)
        n = _n_impacts(r)
        label_r = label(r)
        # short-time agreement with hht α=-0.1 at the same setting (first period)
        ref = _sel(recs, scheme="hht-0.1", h=tg["h"], gamma0=tg["gamma0"], theta=tg["theta"],
                   dt_over_h=SEED_RATIO)
        if ref and r.get("arrays") and ref[0].get("arrays") and ref[0]["status"] == "ok":
            a, b = r["arrays"], ref[0]["arrays"]
            w = a["t"] <= 3.0
            if w.any():
                diffs.append(float(np.max(np.abs(a["u_n"][w] - np.interp(a["t"][w], b["t"],
                                                                         b["u_n"])))))
        if r["status"] == "ok":
            cats["stable to T"].append(label_r)
        elif r["status"] == "unstable" and 3 <= n <= 6:
            cats["holds"].append(f"{label_r} (t={fmt(r.get('t_end_reached'), '.3g')}, {n})")
        elif r["status"] == "unstable" and n < 3:
            cats["unstable before 3 impacts"].append(
                f"{label_r} (t={fmt(r.get('t_end_reached'), '.3g')})")
        elif r["status"] == "unstable":
            cats["unstable after more than 6 impacts"].append(
                f"{label_r} (t={fmt(r.get('t_end_reached'), '.3g')}, {n})")
        else:
            cats["other"].append(f"{label_r} ({r['status']})")
    n_hold = len(cats["holds"])
    verdict = ("holds" if n_hold == len(runs) else "does not hold" if not n_hold
               else f"holds in {n_hold} of {len(runs)} settings")
    parts = [f"{k}: {len(v)} ({', '.join(v)})" for k, v in cats.items() if v]
    ev = "Settings as mass/h/γ0/θ (stop time, impacts before it). " + "; ".join(parts) + "."
    if refused:
        ev += (f" Refused by the core (θ = 1 below the γ0 bound), counted apart: "
               f"{len(refused)} ({', '.join(refused)}).")
    if diffs:
        ev += (f" Over the first period (t ≤ 3) max |u_n − u_n(hht α=-0.1)| is "
               f"{min(diffs):.2g} to {max(diffs):.2g}.")
    return {"claim": claim, "setting": f"pc β=¼ γ=½, Δt = h/20, consistent and lumped mass, "
            f"T = {grid['t_end']:g}, every h, γ0, θ of the sweep the core accepts; 'about "
            f"4–5' = 3 to 6 impacts before the stop", "verdict": verdict, "evidence": ev}


def _claim_cn(recs, grid) -> dict:
    claim = "Crank–Nicolson (newmark ¼ ½) adds a significant amount of energy at impacts"
    runs = _sel(recs, scheme="newmark", dt_over_h=SEED_RATIO)
    if not runs:
        return _not_tested(claim, "no newmark ¼ ½ run at Δt = h/20 in the sweep")
    parts, seed = [], []
    for r in runs:
        tg = dict(r["task"].tags)
        gpi = gain_per_impact(r.get("metrics", {}).get("e_before_impacts", []))
        parts.append((tg, gpi, r))
        if tg["gamma0"] == 10.0 and tg["theta"] == 1:
            seed.append((tg, gpi, r))
    base = seed or parts
    gains = [g for _, g, _ in base if math.isfinite(g)]
    if not gains:
        return _not_tested(claim, "fewer than two impacts in every run")
    sig = [g for g in gains if g > SIGNIFICANT_GAIN]
    verdict = ("holds" if len(sig) == len(gains) else "does not hold" if not sig
               else f"holds in {len(sig)} of {len(gains)} settings")
    ev = "; ".join(f"{_setting(tg)}: {100 * g:+.2f} %/impact, e(T)/e(0) = "
                   f"{fmt(r.get('metrics', {}).get('e_end_ratio'), '.3g')} ({_outcome(r)})"
                   for tg, g, r in base)
    finite = [g for _, g, _ in parts if math.isfinite(g)]
    if finite and seed:
        ev += (f". Over all {len(parts)} (h, γ0, θ) settings: from {100 * min(finite):+.2f} "
               f"to {100 * max(finite):+.2f} %/impact")
        big = [(tg, g) for tg, g, _ in parts if math.isfinite(g) and g > SIGNIFICANT_GAIN]
        if big:
            ev += "; more than +1 %/impact at " + ", ".join(
                f"{_setting(tg)} ({100 * g:+.1f} %)" for tg, g in big)
        n_unstable = sum(1 for _, _, r in parts if r["status"] != "ok")
        if n_unstable:
            ev += f"; {n_unstable} of {len(parts)} settings stopped before T"
    return {"claim": claim, "setting": f"newmark ¼ ½, Δt = h/20, γ0 = 10, θ = 1, "
            f"T = {grid['t_end']:g}; energy just before each impact; significant = "
            f"> {100 * SIGNIFICANT_GAIN:g} %/impact", "verdict": verdict, "evidence": ev}


def _claim_alpha(recs, grid) -> dict:
    claim = ("α slightly improves the dissipation behaviour compared with the θ-scheme and "
             "Newmark")
    keys = ("hht-0.1", "theta1", "newmark_diss")
    rows = []
    for h in grid["h"]:
        got = {}
        for k in keys:
            rs = _sel(recs, scheme=k, h=h, gamma0=10.0, theta=1, dt_over_h=SEED_RATIO)
            if rs:
                got[k] = rs[0]
        if len(got) == 3:
            rows.append((h, got))
    if not rows:
        return _not_tested(claim, "needs hht α=-0.1, theta θ=1 and newmark 0.3025/0.6 at "
                           "Δt = h/20, γ0 = 10, θ = 1")
    ev, better = [], 0
    for h, got in rows:
        g = {k: gain_per_impact(r.get("metrics", {}).get("e_before_impacts", []))
             for k, r in got.items()}
        ok = {k: r["status"] == "ok" for k, r in got.items()}
        # "better dissipation behaviour": loses less of the physical energy per impact
        hht_better = ok["hht-0.1"] and all(
            (not ok[k]) or (math.isfinite(g["hht-0.1"]) and g["hht-0.1"] > g[k])
            for k in ("theta1", "newmark_diss"))
        better += hht_better
        ev.append(f"h={h:g}: energy change per impact hht α=-0.1 {100 * g['hht-0.1']:+.2f} %, "
                  f"theta θ=1 {100 * g['theta1']:+.2f} %, newmark 0.3025/0.6 "
                  f"{100 * g['newmark_diss']:+.2f} % "
                  f"(e(T)/e(0) = {fmt(got['hht-0.1']['metrics'].get('e_end_ratio'), '.3g')}, "
                  f"{fmt(got['theta1']['metrics'].get('e_end_ratio'), '.3g')}, "
                  f"{fmt(got['newmark_diss']['metrics'].get('e_end_ratio'), '.3g')}"
                  + "".join(f"; {k}: {_outcome(r)}" for k, r in got.items() if not ok[k])
                  + ")")
    verdict = ("holds" if better == len(rows) else "does not hold" if better == 0
               else f"holds for {better} of {len(rows)} meshes")
    return {"claim": claim, "setting": "Δt = h/20, γ0 = 10, θ = 1, T = "
            f"{grid['t_end']:g}; hht α=-0.1 against theta θ=1 and newmark β=0.3025 γ=0.6 "
            "(the same γ = ½ − α); better = loses less energy per impact",
            "verdict": verdict, "evidence": "; ".join(ev)}


def _claim_skew(recs, grid) -> dict:
    claim = "Skew-symmetric Nitsche (θ = −1) is robust for small γ0"
    g0 = min(grid["gamma0"])
    if -1 not in grid["theta"] or len(grid["theta"]) < 2:
        return _not_tested(claim, "θ = −1 and another θ are needed")
    ev, robust, better = [], 0, 0
    # Nitsche schemes only (penalty rows have no θ)
    schemes = sorted({r["task"].tag("scheme") for r in recs
                      if r["task"].tag("theta") == -1},
                     key=lambda k: list(SCHEMES).index(k))
    # "small" is below the element bound, where the core refuses θ = 1: a γ0 it accepts
    # θ = 1 at is above the bound, and no run there can decide the claim
    th1 = [r for r in _sel(recs, gamma0=g0, theta=1) if r["task"].tag("scheme") in schemes]
    if th1 and not any(r["status"] == REFUSED for r in th1):
        return _not_tested(claim, f"γ0 = {g0:g}, the smallest of the sweep, is not small: "
                           "the core accepts θ = 1 there (γ0 above its bound); the claim "
                           "needs a γ0 below the bound")
    for k in schemes:
        counts = {}   # θ: (stable, accepted, refused)
        for th in grid["theta"]:
            rs = _sel(recs, scheme=k, gamma0=g0, theta=th)
            n_ref = sum(r["status"] == REFUSED for r in rs)
            counts[th] = (sum(r["status"] == "ok" for r in rs), len(rs) - n_ref, n_ref)
        s_m1 = counts[-1]
        robust += s_m1[1] > 0 and s_m1[0] == s_m1[1]
        # compared on the fraction of accepted settings; a θ refused everywhere is no rival
        better += s_m1[1] > 0 and all(s_m1[0] * b >= a * s_m1[1]
                                      for a, b, _ in counts.values() if b > 0)
        ev.append(f"{k}: stable " + ", ".join(
            f"θ={th:+d} {a}/{b}" + (f" ({r} refused)" if r else "")
            for th, (a, b, r) in counts.items()))
    n = len(schemes)
    verdict = ("holds" if robust == n else
               f"partly: θ = −1 is stable on the whole grid for {robust} of {n} schemes and "
               f"at least as often stable as the other θ for {better} of {n}, counted "
               "among the settings each θ accepts")
    return {"claim": claim, "setting": f"γ0 = {g0:g} (the smallest of the sweep), every "
            f"scheme, h and Δt/h of the grid, T = {grid['t_end']:g}; robust = stable at every "
            "Δt/h; stable counts are of the settings the core accepts (refused ones "
            "apart)", "verdict": verdict, "evidence": "; ".join(ev)}


def _claim_seed_coeffs(recs, grid) -> list[dict]:
    out = []
    for seed_key, std_key in (("hht_seed-0.1", "hht-0.1"), ("pc_hht_seed-0.1", "pc_hht-0.1")):
        claim = (f"The seed's printed coefficients ({SCHEMES[seed_key].label}) against the "
                 f"standard ones ({SCHEMES[std_key].label})")
        a = _sel(recs, scheme=seed_key)
        b = _sel(recs, scheme=std_key)
        if not a or not b:
            out.append(_not_tested(claim, "both schemes must be in the sweep"))
            continue
        # stable among the settings the core accepts (the refused ones apart): a
        # fraction, so that two schemes the core refuses at different settings compare
        sa, sb = (sum(r["status"] == "ok" for r in rs) for rs in (a, b))
        acc_a, acc_b = (sum(r["status"] != REFUSED for r in rs) for rs in (a, b))
        if not acc_a or not acc_b:
            out.append(_not_tested(claim, "the core refuses every setting of one of them"))
            continue

        def count(rs, n_ok):
            n_ref = sum(r["status"] == REFUSED for r in rs)
            return f"{n_ok}/{len(rs) - n_ref}" + (f" ({n_ref} refused)" if n_ref else "")

        seed_runs = []
        for k, rs in ((seed_key, a), (std_key, b)):
            for r in rs:
                tg = dict(r["task"].tags)
                if tg["gamma0"] == 10.0 and tg["theta"] == 1 and math.isclose(
                        tg["dt_over_h"], SEED_RATIO, rel_tol=1e-9):
                    seed_runs.append(f"{k} h={tg['h']:g}: {_outcome(r)}, e_max/e(0) = "
                                     f"{fmt(r.get('metrics', {}).get('e_max_ratio'), '.3g')}")
        verdict = ("the seed's coefficients are less stable" if sa * acc_b < sb * acc_a else
                   "no difference in stability" if sa * acc_b == sb * acc_a else
                   "the seed's coefficients are more stable")
        out.append({"claim": claim, "setting": f"every grid setting (α = −0.1), T = "
                    f"{grid['t_end']:g}; stable runs counted among the settings the core "
                    "accepts", "verdict": verdict,
                    "evidence": f"stable runs: {seed_key} {count(a, sa)}, {std_key} "
                                f"{count(b, sb)}. At Δt = h/20, γ0 = 10, θ = 1: "
                                + "; ".join(seed_runs)})
    return out
