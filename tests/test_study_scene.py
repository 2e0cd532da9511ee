"""``study work-precision --scene`` and ``study stability --scene``: the studies on a
scene file of one's own.

What is checked against what:
- work-precision: on the 1D bar before its first impact (t < 1: the semi-discrete
  problem is a linear ODE there, smooth in time) the error against the scene's own
  fine-Δt reference falls at order 2 for the second-order schemes; the run of a scheme at
  the scene's Δt is the very run of the built-in study on the same scene (one cache key);
  the summary holds the reference table; a scheme the core refuses on the scene is left
  out with its reason; a second call takes every run from the cache;
- stability: the bisection brackets the CFL limits of pc (√2/ω_max) and central
  differences (2/ω_max) with lumped mass on a contact-free 1D bar, ω_max computed here;
- bad input: one line, exit status 2, nothing written.
"""

from __future__ import annotations

import math
import os

import pytest
from conftest import stable_grid
from test_studies import _cfl_lumped_1d

from dyncontact import BadInputError, Scene
from dyncontact.study.common import EXACT_1D, SCHEMES
from dyncontact.study.sweep import sweep, task_key

# The 1D bar of the closed form, h = 1/20, Δt = h/20, to T = 1: the bar leaves the
# obstacle at once and comes back at t = 1 (exact1d), so the window holds no impact.
H_1D = 0.05
T_SMOOTH = 1.0
LADDER = (1.0, 0.5, 0.25)
#: The second-order schemes whose observed order is checked (the series' keys).
SECOND_ORDER = ("newmark", "hht-0.1", "theta0.5", "galpha0.5", "pc", "pc@20",
                "central_lumped")
#: e(2Δt)/e(Δt) = 4 (1 + O(Δt)) for a second-order scheme: the band allows a correction
#: of 2^0.2 - 1 = 15 % between successive halvings; the reference moves the ratio by at
#: most (1 + r)/(1 - r) with r = its estimated error / the run's error, checked below
#: 1 %, i.e. 0.03 in the order.
ORDER_BAND = (1.8, 2.2)


def _scene_1d(path, t_end=T_SMOOTH, **replace):
    text = (EXACT_1D.replace("h = 0.04", f"h = {H_1D}").replace("t_end = 3.0",
                                                                 f"t_end = {t_end}")
            .replace("dt = 0.002", f"dt = {H_1D / 20}"))
    for a, b in replace.items():
        text = text.replace(a, b)
    path.write_text(text)
    return str(path)


@pytest.fixture(scope="module")
def wp(tmp_path_factory):
    from dyncontact.study.workprecision import run_work_precision_scene

    d = tmp_path_factory.mktemp("wp_scene")
    scene = _scene_1d(d / "bar.nml")
    series = tuple((k, None) for k in ("newmark", "hht-0.1", "theta0.5", "theta1",
                                       "galpha0.5", "pc", "central_lumped")) + (("pc", 20.0),)
    rep = run_work_precision_scene(str(d / "out"), scene, quick=True, ladder=LADDER,
                                   series=series, workers=2, progress=False, log=None)
    rep["series_asked"] = series
    return rep, scene, d


def _by_series(rows):
    out = {}
    for r in rows:
        out.setdefault(r["series"].split("@")[0] if r["series"] != "pc@20" else "pc@20",
                       []).append(r)
    return {k: sorted(v, key=lambda r: -r["dt"]) for k, v in out.items()}


def test_scene_errors_fall_at_the_schemes_order(wp):
    rep, _scene, _d = wp
    series = _by_series(rep["rows"])
    assert set(SECOND_ORDER) <= set(series)
    for key, rows in series.items():
        assert [r["status"] for r in rows] == ["ok"] * len(LADDER), key
        for q in ("u_n", "v_n", "e_total"):
            errs = [r[f"err_{q}"] for r in rows]
            assert all(a > b > 0 for a, b in zip(errs, errs[1:])), (key, q, errs)
            if key in SECOND_ORDER and q != "e_total":
                est = rep["ref"]["quantities"][q]["est"]
                assert est < 0.01 * min(errs), (key, q, est, errs)
                orders = [math.log2(a / b) for a, b in zip(errs, errs[1:])]
                assert all(ORDER_BAND[0] <= p <= ORDER_BAND[1] for p in orders), \
                    (key, q, orders)


def test_scene_runs_are_the_builtin_runs(wp):
    """At the scene's Δt a scheme's run is the built-in 1D study's run of the same
    scene (same h, Δt, T, output): the same cache key, so the same trace and cost."""
    from dyncontact.study.common import write_base_scenes
    from dyncontact.study.workprecision import _trace_task

    rep, _scene, d = wp
    row = next(r for r in rep["rows"] if r["series"] == "newmark@20" and r["dt"] == H_1D / 20)
    # the built-in study's 1D task (run_work_precision), at this h and T
    base = write_base_scenes(str(d / "scenes"))["exact1d"]
    builtin = _trace_task(base, SCHEMES["newmark"], H_1D / 20, T_SMOOTH, {}, h=H_1D)
    rec = sweep([builtin], str(d / "out" / "cache"), workers=1, progress=False)[0]
    assert rec["cached"] and rec["status"] == "ok" and rec["key"] == task_key(builtin)
    assert rec["cpu_s"] == row["cpu_s"]


def test_scene_summary_has_the_reference_table_and_says_what_is_measured(wp):
    rep, _scene, _d = wp
    text = open(rep["summary"], encoding="utf-8").read()
    assert "## Is the reference converged enough?" in text
    assert "time-discretization errors on this mesh" in text
    # the explicit schemes' steps as run (c_explicit = 100: pc at 20/100; central, c = 4)
    assert "here pc at 0.2×; central at 5×" in text
    for q in ("u_n", "v_n", "p_n", "e_total"):
        assert f"| {q} |" in text
    # T = 1 holds no impact for the reference: p_n = 0 at every level, which is not a
    # reference that fails to converge (the table said "the levels do not converge")
    p_n_row = next(line for line in text.splitlines() if line.startswith("| p_n | mean"))
    assert "p_n = 0 at every level: no contact before T" in p_n_row, p_n_row
    assert "do not converge" not in p_n_row, p_n_row
    assert os.path.getsize(rep["png"]) > 0 and os.path.getsize(rep["csv"]) > 0
    assert rep["ref"]["ok"] and len(rep["ref_levels"]) == 3


def test_scene_where_no_cap_binds_runs_the_ladder_as_before(wp):
    """Δt = h/20: every explicit scheme's largest step is below 0.9 × its estimate
    (central's h/4 is 0.53 × it), so no step is lowered and every run is at the step the
    study gave it before it knew the estimates, the float of the same expression (the
    same tasks: the cache keys of earlier runs stay valid)."""
    rep, _scene, _d = wp
    assert rep["capped"] == []
    assert {x["series"] for x in rep["explicit"]} == {"pc@100", "pc@20", "central_lumped@4"}
    assert all(0 < x["dt_max"] <= 0.9 * x["estimate"] for x in rep["explicit"])
    dt, c0 = H_1D / 20, 20.0
    for r in rep["rows"]:
        assert r["dt"] in [dt * c0 / r["c"] * f for f in LADDER], r
        assert "(capped)" not in r["label"]
    text = open(rep["summary"], encoding="utf-8").read()
    assert "None lowered: every explicit scheme's largest step is at most 0.9 × its " \
           "estimate." in text


def test_scene_second_call_takes_every_run_from_the_cache(wp):
    from dyncontact.study.workprecision import run_work_precision_scene

    rep, scene, d = wp
    again = run_work_precision_scene(str(d / "out"), scene, quick=True, ladder=LADDER,
                                     series=rep["series_asked"],
                                     workers=2, progress=False, log=None)
    assert again["n_runs"] == rep["n_runs"] and again["n_cached"] == again["n_runs"]


def test_scene_whose_dt_does_not_divide_t_end_is_compared_up_to_the_reference_end(tmp_path):
    """T = 0.999, Δt = h/20 = 0.0025: each run and reference level stops at its first
    step past T (1.0, 0.999375, 0.9990625, ...). The rows past the reference's end are
    not compared (against its last row held constant they would add an error of about
    the time past it times |u'|, the same at every level): the reference levels converge
    at order 2 as for a T that every Δt divides, and the runs' errors fall at order 2."""
    from dyncontact.study.workprecision import run_work_precision_scene

    scene = _scene_1d(tmp_path / "bar.nml", t_end=0.999)
    rep = run_work_precision_scene(str(tmp_path / "out"), scene, quick=True,
                                   ladder=(1.0, 0.5), series=(("newmark", None),),
                                   workers=1, progress=False, log=None)
    rows = sorted(rep["rows"], key=lambda r: -r["dt"])
    assert [r["t_end_reached"] > 0.999 for r in rows] == [True, True]
    for q in ("u_n", "v_n"):
        ref = rep["ref"]["references"]["scene"][q]
        assert ORDER_BAND[0] <= ref["p"] <= ORDER_BAND[1], (q, ref)
        errs = [r[f"err_{q}"] for r in rows]
        assert all(r[f"resolved_{q}"] for r in rows), (q, ref, errs)
        assert ORDER_BAND[0] <= math.log2(errs[0] / errs[1]) <= ORDER_BAND[1], (q, errs)


def test_scene_summary_gives_the_explicit_steps_of_its_c_explicit(tmp_path):
    """--c-explicit 50: pc runs at 20/50 = 0.4 × the implicit step, and the summary says
    so (it said "a fifth of it", the default's, whatever c_explicit was)."""
    from dyncontact.study.workprecision import run_work_precision_scene

    rep = run_work_precision_scene(str(tmp_path / "out"), _scene_1d(tmp_path / "bar.nml"),
                                   quick=True, c_explicit=50.0, ladder=(1.0,),
                                   series=(("newmark", None), ("pc", None)),
                                   workers=1, progress=False, log=None)
    assert sorted(r["dt"] for r in rep["rows"]) == pytest.approx([0.4 * H_1D / 20, H_1D / 20])
    text = open(rep["summary"], encoding="utf-8").read()
    assert "here pc at 0.4×)" in text and "a fifth" not in text


@pytest.mark.parametrize("scheme, c0, k", [("central", 4.0, 1), ("pc", 100.0, 5),
                                           ("newmark", 20.0, 1)])
def test_scene_dt_is_the_step_of_the_scenes_own_scheme(tmp_path, scheme, c0, k):
    """The scene's Δt is its own scheme's step: a scene written for central at Δt runs
    central at that Δt (the scene's own run is among the study's) and newmark at
    Δt × 4/20; on a pc scene newmark runs at 5 × its Δt; on an implicit scene central
    runs at 5 × (20/4) and pc at a fifth, as in the built-in study. Read as the implicit
    step whatever the scene's scheme, the scene's Δt would run central at 5 × the step
    the scene gives it, past its stability limit. On the pc scene central's Δt × 25 =
    0.0625 is itself 2.65 × its critical step (0.0236): it runs at a k-th of it, 0.0125
    (test_scene_explicit_schemes_run_below_their_critical_step)."""
    from dyncontact.study.workprecision import run_work_precision_scene

    dt = H_1D / 20
    scene = _scene_1d(tmp_path / "bar.nml", t_end=0.2,
                      **{"name = 'newmark'": f"name = '{scheme}'",
                         "mass = 'consistent'": "mass = 'lumped'"})
    rep = run_work_precision_scene(str(tmp_path / "out"), scene, quick=True, ladder=(1.0,),
                                   series=(("newmark", None), ("pc", None),
                                           ("central_lumped", None)),
                                   workers=1, progress=False, log=None)
    assert rep["n_errors"] == 0
    got = {r["series"]: r["dt"] for r in rep["rows"]}
    assert got == pytest.approx({"newmark@20": dt * c0 / 20, "pc@100": dt * c0 / 100,
                                 "central_lumped@4": dt * c0 / 4 / k})
    assert {x["series"]: x["divisor"] for x in rep["capped"]} == (
        {"central_lumped@4": k} if k > 1 else {})
    assert all(r["status"] == "ok" for r in rep["rows"])
    text = open(rep["summary"], encoding="utf-8").read()
    assert f"({scheme}: c₀ = {c0:g}," in text


def test_scene_left_out_schemes_are_said_not_crashed_on(tmp_path):
    """The redistributed mass needs an implicit scheme: pc is refused on such a scene,
    left out with the core's reason; newmark_redist is newmark on it."""
    from dyncontact.study.workprecision import run_work_precision_scene

    scene = _scene_1d(tmp_path / "redist.nml", t_end=0.2,
                      **{"mass = 'consistent'": "mass = 'redistributed'"})
    rep = run_work_precision_scene(str(tmp_path / "out"), scene, quick=True,
                                   series=(("newmark", None), ("pc", None),
                                           ("newmark_redist", None)),
                                   workers=1, progress=False, log=None)
    assert rep["n_errors"] == 0
    assert {r["series"] for r in rep["rows"]} == {"newmark@20"}
    why = dict(rep["left_out"])
    assert "refused by the core" in why["pc@100"] and "implicit" in why["pc@100"]
    assert "same run" in why["newmark_redist@20"]
    text = open(rep["summary"], encoding="utf-8").read()
    assert "- pc@100: refused by the core" in text


# ------------------------------------------------------- explicit schemes, critical step

#: A scene whose Δt is already near the explicit limit: the 1D bar, lumped mass, Δt =
#: h/2.5 to T = 1.5 (one impact, at t = 1). central's ladder (Δt × c₀/c = 5 Δt) would be
#: 0.1 and 0.05, 4.24 and 2.12 × its critical step estimate 0.0236 (√2 h/3): both stop as
#: unstable (0.1 at t = 0.2, 0.05 at the impact); pc@20's largest, 0.02, is 1.2 × its
#: estimate 0.0167 (= central's / √2).
DT_NEAR = H_1D / 2.5
T_NEAR = 1.5


def _near_scene(path):
    return _scene_1d(path, t_end=T_NEAR, **{f"dt = {H_1D / 20}": f"dt = {DT_NEAR}",
                                            "mass = 'consistent'": "mass = 'lumped'"})


def test_scene_explicit_schemes_run_below_their_critical_step(tmp_path):
    """On a scene whose Δt would put central and pc@20 above their critical steps, both
    run at their step divided by an integer (central by 5, pc@20 by 2), every point
    below 0.9 × the estimate and finished (status ok); the estimate the study used is
    the dt_crit_estimate of a run of the scheme on the scene; newmark's and pc@100's
    steps are those of the ladder; the summary and the log say which scheme was
    lowered, to what step and why, and the note on the steps gives the factors run."""
    from conftest import run_as_designed

    import dyncontact
    from dyncontact.study.workprecision import EXPLICIT_SAFETY, run_work_precision_scene

    scene = _near_scene(tmp_path / "near.nml")
    logged = []
    rep = run_work_precision_scene(str(tmp_path / "out"), scene, quick=True,
                                   series=(("newmark", None), ("pc", None), ("pc", 20.0),
                                           ("central_lumped", None)),
                                   workers=1, progress=False, log=logged.append)
    assert rep["n_errors"] == 0
    est = {x["series"]: x["estimate"] for x in rep["explicit"]}
    # the estimates are those of the core's own runs of the schemes on the scene
    for skey, name in (("central_lumped@4", "central"), ("pc@20", "pc")):
        run = dyncontact.Scene.read(scene)
        run.set("scheme.name", name)
        run.set("scheme.dt", 0.5 * est[skey])
        run.set("scheme.t_end", 0.05)
        res = run_as_designed(run, out=tmp_path / name)
        assert res.summary["dt_crit_estimate"] == est[skey], skey
    assert est["pc@100"] == est["pc@20"]     # one scheme and mass: one estimate
    rows = {}
    for r in rep["rows"]:
        rows.setdefault(r["series"], []).append(r)
    want = {"newmark@20": [DT_NEAR, DT_NEAR / 2], "pc@100": [DT_NEAR / 5, DT_NEAR / 10],
            "pc@20": [DT_NEAR / 2, DT_NEAR / 4], "central_lumped@4": [DT_NEAR, DT_NEAR / 2]}
    assert set(rows) == set(want)
    for skey, dts in want.items():
        assert [r["dt"] for r in rows[skey]] == pytest.approx(dts, rel=1e-12), skey
    assert [r["dt"] for r in rows["newmark@20"]] == [DT_NEAR * 1.0, DT_NEAR * 0.5]
    for skey in ("pc@20", "central_lumped@4"):
        for r in rows[skey]:
            assert r["status"] == "ok" and r["dt"] <= EXPLICIT_SAFETY * est[skey], (skey, r)
            assert r["label"].endswith("(capped)"), r["label"]
    assert {x["series"]: x["divisor"] for x in rep["capped"]} == {"pc@20": 2,
                                                                  "central_lumped@4": 5}
    text = open(rep["summary"], encoding="utf-8").read()
    assert "## Explicit schemes below their critical step" in text
    line = ("- central_lumped@4 (central lumped): its ladder's largest step 0.1 is 4.24 × "
            "its critical step, estimated 0.02357 on this scene; run at its step / 5 "
            "(1 × the scene's Δt), the largest 0.02 = 0.849 × the estimate (at most 0.9 ×).")
    assert line in text.splitlines()
    assert any(x.startswith("- pc@20 (pc β=0.25, γ=0.5, lumped mass): its ladder's largest "
                            "step 0.02 is 1.2 × ") for x in text.splitlines()), text
    assert ("here pc at 0.2×; pc@20 at 0.5×, central_lumped@4 at 1× (lowered below their "
            "critical step: see below)") in text
    assert "Not lowered: pc@100: largest step 0.004, 0.24 × its estimate 0.01667." in text
    said = [x for x in logged if "critical step" in x]
    assert len(said) == 2 and f"work-precision (near.nml): {line[2:-1]}" in said, logged


def test_scene_explicit_divisor_keeps_the_ladder_points_below_the_cap():
    """A scheme whose ladder (2, 1, ½, ¼) × 0.01 crosses its cap 0.0075 (0.9 × 1/120):
    its points 0.005 and 0.0025 are below the cap and run as they are; the ladder is
    divided by 4, not by 3 (the smallest that brings 0.02 under the cap, whose steps
    0.0067, 0.0033, ... left both out): 0.005, 0.0025, 0.00125, 0.000625. Central's
    0.05 × (2, 1, ½, ¼) under a cap of 0.0212 keeps its 0.0125 with 8 (5, the smallest
    under the cap, ran 0.02, 0.01, 0.005, 0.0025 and left 0.0125 out)."""
    from dyncontact.study.workprecision import (EXPLICIT_SAFETY, _explicit_divisors,
                                                _scene_steps)

    factors, dt = (2.0, 1.0, 0.5, 0.25), 0.01
    kept = [(SCHEMES["pc"], 20.0, "p", "pc@20"),
            (SCHEMES["central_lumped"], 4.0, "c", "central_lumped@4")]
    base = {"pc@20": dt, "central_lumped@4": 5 * dt}
    est = {"pc@20": 0.0075 / EXPLICIT_SAFETY, "central_lumped@4": 0.023570226039551584}
    got = _explicit_divisors(kept, base, factors, "full", dt, est)
    assert got == {"pc@20": 4, "central_lumped@4": 8}
    runs, _levels = _scene_steps(kept, base, got, factors, "full")
    steps = {k: [x for *_, skey, _f, x in runs if skey == k] for k in base}
    assert steps["pc@20"] == pytest.approx([0.005, 0.0025, 0.00125, 0.000625], rel=1e-12)
    for skey, b in base.items():
        cap = EXPLICIT_SAFETY * est[skey]
        assert max(steps[skey]) <= cap
        for f in factors:
            if b * f <= cap:
                assert any(math.isclose(b * f, x, rel_tol=1e-12) for x in steps[skey]), f


def test_scene_explicit_divisor_keeps_the_rows_on_the_reference():
    """central's step 5 × 0.01 with the ladder (1, ½) against a cap of 0.9 × 0.02357: the
    smallest divisor is 3 (0.0167), whose steps are not multiples of the finest
    reference step; with 4 (0.0125) they are, but its rows, 0.0125 apart, share with
    newmark's (0.01 apart) no multiple of the coarsest reference step: in both cases
    the runs' rows would not all fall on the reference's. The study takes 5 (0.01, the
    scene's Δt). A scheme without an estimate, one of estimate 0 (no step is stable)
    and one whose ladder stays below its cap are left as they are."""
    from dyncontact.study.workprecision import _explicit_divisors, _nested_rows, _scene_steps

    dt, est = 0.01, 0.023570226039551584
    kept = [(SCHEMES["newmark"], 20.0, "n", "newmark@20"),
            (SCHEMES["central_lumped"], 4.0, "c", "central_lumped@4"),
            (SCHEMES["pc"], 100.0, "p", "pc@100"),
            (SCHEMES["pc_hht_seed-0.1"], 100.0, "s", "pc_hht_seed-0.1@100")]
    base = {"newmark@20": dt, "central_lumped@4": 5 * dt, "pc@100": dt / 5,
            "pc_hht_seed-0.1@100": dt / 5}
    factors, spacing = (1.0, 0.5), dt

    def rows(k):
        runs, levels = _scene_steps(kept, base, {"central_lumped@4": k}, factors, "quick")
        return _nested_rows([x[-1] for x in runs], levels, spacing)

    assert rows(3) is None and rows(4) is None and rows(5) is not None
    got = _explicit_divisors(kept, base, factors, "quick", spacing,
                             {"central_lumped@4": est, "pc@100": est / 2 ** 0.5,
                              "pc_hht_seed-0.1@100": 0.0})
    assert got == {"central_lumped@4": 5}
    assert _explicit_divisors(kept, base, factors, "quick", spacing, {}) == {}


# --------------------------------------------------------------------------- stability

CFL_N = 20
#: a run just above the limit grows slowly: the bracket must hold the limit within this
#: margin at T = 20 (as tests/test_studies.py's CFL_MARGIN, there 2 % above the limit
#: blows up at t = 1.7)
CFL_MARGIN = 0.03


def test_scene_stability_brackets_the_cfl_limits(tmp_path, monkeypatch):
    import dyncontact.study.stability as stability
    from dyncontact.study.stability import run_stability_scene

    figs = []
    real_save = stability.save_figure
    monkeypatch.setattr(stability, "save_figure",
                        lambda fig, path, **kw: figs.append(fig) or real_save(fig, path, **kw))

    h = 1.0 / CFL_N
    # contact-free: the obstacle far below, the bar moving up; lumped mass
    scene = tmp_path / "free.nml"
    scene.write_text(
        f"&mesh dim = 1, length = 1.0, h = {h} /\n&boundary clamped = 'top', "
        "contact = 'bottom' /\n&material young = 1.0, poisson = 0.0, density = 1.0 /\n"
        "&contact obstacle_point = -1.0, obstacle_normal = -1.0, probe = 0.0 /\n"
        "&initial kind = 'velocity', velocity = 0.1 /\n"
        f"&scheme name = 'pc', dt = {h / 2}, t_end = 20.0, mass = 'lumped' /\n")
    # the CFL limit of pc, √2/ω_max (ω_max of M_lumped⁻¹ K, node CFL_N clamped), and
    # that of central differences, 2/ω_max
    pc_limit = _cfl_lumped_1d(CFL_N)
    w_max = math.sqrt(2.0) / pc_limit
    limits = {"pc": math.sqrt(2.0) / w_max, "central": 2.0 / w_max}
    rounds = 5
    rep = run_stability_scene(str(tmp_path / "out"), str(scene),
                              grid={"schemes": ("pc", "central"),
                                    "dt_factors": {"implicit": (1,),
                                                   "explicit": (0.5, 1, 2, 4)},
                                    "rounds": rounds},
                              workers=2, progress=False, log=None)
    crit = {c["scheme"]: c for c in rep["critical"]}
    for key, dtc in limits.items():
        c = crit[key]
        assert c["bracket"] == "bisection" and c["mass"] == "lumped", c
        assert c["dt_crit_hi"] >= dtc                      # unstable runs are above it
        assert c["dt_crit_lo"] <= dtc * (1 + CFL_MARGIN)   # and the bracket holds it
        # the bisection's resolution: a grid bracket a factor 2 wide, `rounds` halvings
        assert c["dt_crit_hi"] / c["dt_crit_lo"] <= 2 ** (1 / 2 ** rounds) * (1 + 1e-12)
    text = open(rep["summary"], encoding="utf-8").read()
    assert "## Critical Δt" in text and "| pc | lumped |" in text
    # critical_dt.png: central's Δt_crit/h, the largest, is the dark end of the colour
    # map, written in white; pc's, the light end, in black
    colour = {t.get_text(): t.get_color() for t in figs[-1].axes[0].texts}
    assert colour == {f"{crit['central']['dt_crit_over_h']:.3g}": "w",
                      f"{crit['pc']['dt_crit_over_h']:.3g}": "k"}, colour


def _mesh_of_its_own_h(tmp_path, form: str) -> str:
    """A mesh file of h = 0.1 in tmp_path that a scene need not give &mesh h for: a .msh
    (meshed already), or a .geo that defines its own h (the seed's bar with its
    DefineConstant h = 0.1)."""
    import subprocess
    import sys

    from conftest import ROOT

    if form == "msh":
        made = subprocess.run([sys.executable, "-m", "dyncontact", "mesh", "--h", "0.1",
                               "--out", str(tmp_path / "m.msh")], capture_output=True,
                              text=True)
        assert made.returncode == 0, made.stderr
        return "m.msh"
    geo = (ROOT / "meshes" / "bar2d.geo").read_text()
    assert "h = {0.05," in geo
    (tmp_path / "bar.geo").write_text(geo.replace("h = {0.05,", "h = {0.1,"))
    return "bar.geo"


@pytest.mark.parametrize("form", ["msh", "geo"])
def test_scene_stability_on_a_mesh_of_its_own_h_reports_that_h(tmp_path, form):
    """A .msh file is meshed already, and a .geo that defines its own h, in a scene that
    gives no &mesh h, is meshed at that h by the scene's own run. The study's runs do not
    set &mesh h (for a .msh it only drew the note that it is not used; for the .geo,
    setting the scene's default, 0.05, ran them on another mesh than the scene's), and
    the tables and heat maps give the mesh's own h, its shortest edge (h on the built-in
    mesh the file was written from), not the unused default 0.05."""
    import csv
    import json

    from dyncontact.study.stability import run_stability_scene

    scene = tmp_path / "s.nml"
    scene.write_text(f"&mesh file = '{_mesh_of_its_own_h(tmp_path, form)}' /\n"
                     "&initial kind = 'compressed_bar' /\n&scheme dt = 0.005, t_end = 0.5 /\n")
    rep = run_stability_scene(str(tmp_path / "out"), str(scene), quick=True,
                              grid={"schemes": ("hht-0.1",), "rounds": 1},
                              workers=1, progress=False, log=None)
    records = [json.loads(p.read_text()) for p in (tmp_path / "out").rglob("record.json")]
    assert len(records) == rep["n_runs"] > 0
    assert all(r["status"] != "error" for r in records)
    assert not [w for r in records for w in r["warnings"] if "&mesh h" in w]
    assert rep["grid"]["set_h"] is False
    assert rep["grid"]["h"] == (pytest.approx(0.1, rel=1e-12),)
    rows = list(csv.DictReader(open(rep["csv"], encoding="utf-8")))
    assert rows and all(float(r["h"]) == pytest.approx(0.1, rel=1e-12) for r in rows)
    assert "stability_h0.1.png" in [os.path.basename(p) for p in rep["pngs"]]
    summary = open(rep["summary"], encoding="utf-8").read()
    assert "(h = its shortest edge, 0.1)" in summary
    # the summary says what its charts show, not only their file names
    assert "`stability_h*.png` has one panel per scheme" in summary
    assert "`critical_dt.png` gives each scheme's critical Δt/h" in summary


@pytest.mark.parametrize("contact, said", [
    ("method = 'nitsche', theta = -1,", "nitsche contact (γ0 = 10, θ = -1)"),
    ("method = 'penalty',", "penalty contact (γ0 = 10)")])
def test_scene_stability_summary_gives_theta_only_for_nitsche(tmp_path, contact, said):
    """The scene line of the summary gives the scene's θ for Nitsche; penalty has none
    (it said θ = +1, the default the core ignores)."""
    from dyncontact.study.stability import run_stability_scene

    scene = tmp_path / "bar.nml"
    scene.write_text(
        "&mesh dim = 1, length = 1.0, h = 0.1 /\n&boundary clamped = 'top', "
        "contact = 'bottom' /\n&material young = 1.0, poisson = 0.0, density = 1.0 /\n"
        f"&contact {contact} gamma0 = 10.0, obstacle_point = -1.0, obstacle_normal = -1.0,"
        " probe = 0.0 /\n&initial kind = 'velocity', velocity = 0.1 /\n"
        "&scheme name = 'newmark', dt = 0.01, t_end = 0.1 /\n")
    rep = run_stability_scene(str(tmp_path / "out"), str(scene),
                              grid={"schemes": ("newmark",),
                                    "dt_factors": {"implicit": (1,), "explicit": (1,)},
                                    "rounds": 1},
                              workers=1, progress=False, log=None)
    text = open(rep["summary"], encoding="utf-8").read()
    assert said + ", T = 0.1" in text


@pytest.mark.parametrize("mesh, dim", [("dim = 0, h = 0.05", 2), ("dim = 1, h = 0.05", 1),
                                       ("file = 'MESH3D'", 3)])
def test_scene_dimension_is_the_meshs_when_dim_is_left_at_0(tmp_path, mesh, dim):
    """The summaries' scene line gives the mesh's dimension (UserScene.dim): with
    ``&mesh dim`` left at 0 (the default) that is the file's, or 2 for the built-in bar;
    the line said "0D"."""
    from dyncontact.study.common import read_user_scene

    mesh3d = os.path.join(os.path.dirname(__file__), "..", "meshes", "bar3d_getfem_h0.05.msh")
    scene = tmp_path / "s.nml"
    scene.write_text(f"&mesh {mesh.replace('MESH3D', os.path.abspath(mesh3d))} /\n"
                     "&scheme name = 'newmark', dt = 0.01, t_end = 0.1 /\n")
    assert read_user_scene(str(scene)).dim == dim


def test_sweep_runs_write_no_checkpoint_of_the_base_scenes(tmp_path):
    """A scene of one's own may keep &output checkpoint_every for its long runs; the
    sweep's runs of it (the studies' --scene, the reference at Δt/16) write none: nothing
    keeps or uses them, and the fsync of each made a quick work-precision study on a scene
    with checkpoint_every = 5 take 67 s instead of 5 s. A task that sets the key keeps it."""
    from dyncontact.study.sweep import make_task, run_uncached

    scene = _scene_1d(tmp_path / "bar.nml", t_end=0.1,
                      **{"&output": "&output checkpoint_every = 2,"})
    assert "checkpoint_every = 2" in open(scene).read()
    rec = run_uncached(make_task(scene, {}), str(tmp_path / "plain"))
    assert rec["status"] == "ok" and not (tmp_path / "plain" / "checkpoint.bin").exists()
    rec = run_uncached(make_task(scene, {"output.checkpoint_every": 3}), str(tmp_path / "set"))
    assert rec["status"] == "ok" and (tmp_path / "set" / "checkpoint.bin").exists()


# --------------------------------------------------------------------------- bad input

@pytest.mark.parametrize("study,scene_text,message", [
    ("work-precision", None, "no such file"),
    ("stability", "&mesh dim = 7 /\n", "&mesh dim"),
    ("work-precision", "&scheme name = 'central', dt = 0.0 /\n", "dt = 0"),
    ("stability", "&scheme name = 'central', dt = 0.0 /\n", "scene.scheme.dt"),
    ("stability", "&scheme name = 'central', dt = 0.0 /\n", "`python -m dyncontact run` it"),
    # refused once the mesh is there: every run of the study would be refused
    ("stability", "&contact probe = 0.05, 0.3 /\n", "&contact probe: the point is not on"),
    ("work-precision", "&boundary clamped = 'lid' /\n", "&boundary clamped: group 'lid'"),
    ("work-precision", "&contact gamma0 = 0.01 /\n", "&contact gamma0"),
    ("convergence", "", "1D closed form"),
    ("methods", "", "not for this study"),
    ("all", "", "not for this study"),
])
def test_scene_bad_input_is_one_line_exit_2(tmp_path, capsys, study, scene_text, message):
    from dyncontact.study.cli import main

    scene = tmp_path / "scene.nml"
    if scene_text is not None:
        scene.write_text(scene_text)
    out = tmp_path / "out"
    assert main([study, "--out", str(out), "--scene", str(scene), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err, err
    assert not out.exists()


@pytest.mark.parametrize("study, step", [
    ("work-precision", "0.0125 (central, Δt×5)"),
    ("stability", "0.02 (the grid's 8 × the scene's Δt)"),
])
def test_scene_shorter_than_the_studys_largest_step_is_one_line_exit_2(tmp_path, capsys,
                                                                       study, step):
    """A scene whose T is a few of its own steps (T = 4 Δt) would run the study and end
    with exit 1, runs failing to run: work-precision's central step (5 × the scene's) and
    the stability grid's largest (8 ×) pass T, which the core refuses. The study says so in
    one line naming the scene, T and that step, exit 2, before any run."""
    from dyncontact.study.cli import main

    scene = tmp_path / "short.nml"
    scene.write_text("&scheme dt = 0.0025, t_end = 0.01 /\n")
    out = tmp_path / "out"
    assert main([study, "--quick", "--out", str(out), "--scene", str(scene),
                 "--no-progress"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert err == (f"dyncontact study: --scene {scene}: &scheme t_end = 0.01 is shorter than "
                   f"the study's largest step, {step}: give a t_end of a few of them at "
                   "least"), err
    assert not (out / "cache").exists()


@pytest.mark.parametrize("factors, ratios", [((2.0, 1.0, 0.5, 0.25), (1.0, 0.2, 5.0)),
                                             ((1.0, 0.5), (1.0, 0.2, 5.0)),
                                             ((1.0, 0.5, 0.25), (1.0, 0.2, 5.0, 0.25))])
def test_scene_rows_fall_on_every_reference_level(factors, ratios):
    """The runs' rows are at times the reference levels write (to the step), so no error
    goes through an interpolation of the reference; each run writes at least a row per
    coarsest implicit step, and a run with steps no longer than that one writes rows
    that far apart (not a row per step)."""
    from dyncontact.study.workprecision import _scene_rows

    dt = 0.0025
    run_dts = [dt * r * f for r in ratios for f in factors]
    levels = [min(run_dts) * x for x in (1 / 4, 1 / 8, 1 / 16)]
    every, ref_every = _scene_rows(run_dts, levels, dt * max(factors))
    for d, e in zip(run_dts, every):
        row = d * e
        assert row <= dt * max(factors) * (1 + 1e-12) or e == 1
        for lv, le in zip(levels, ref_every):
            k = row / (lv * le)
            assert abs(k - round(k)) < 1e-9 and round(k) >= 1, (d, e, lv, le)


def test_scene_rows_fall_back_to_the_builtin_rows_for_steps_out_of_ratio():
    from dyncontact.study.workprecision import _every, _level_every, _scene_rows

    run_dts, levels = [0.003, 0.003 / 3 ** 0.5], [1e-4, 5e-5]
    every, ref_every = _scene_rows(run_dts, levels, 0.003)
    assert every == [_every(d) for d in run_dts]
    assert ref_every == [_level_every(d) for d in levels]


def _scene_chart_of_two_runs(tmp_path, monkeypatch, cpu_s):
    """The work-precision chart of a scene study whose two runs took `cpu_s` seconds of
    CPU (errors 2e-4 and 5e-5), drawn."""
    import matplotlib
    matplotlib.use("Agg")
    import dyncontact.study.workprecision as wp

    rows = [{"case": "scene", "series": "newmark@20", "status": "ok", "cpu_s": cpu,
             **{f"err_{q}": err for q in ("u_n", "v_n", "p_n", "e_total")}}
            for cpu, err in zip(cpu_s, (2e-4, 5e-5))]
    series = [(SCHEMES["newmark"], 20.0, "newmark", "newmark@20")]
    figs = []
    monkeypatch.setattr(wp, "save_figure", lambda fig, path, **kw: figs.append(fig) or path)
    wp._plot(rows, series, {}, str(tmp_path / "wp.png"), cases=(("scene", "s.nml"),))
    fig = figs[0]
    fig.canvas.draw()
    return fig


def test_scene_plot_x_axis_has_numbers_when_every_run_takes_the_same_decade(tmp_path,
                                                                           monkeypatch):
    """A quick scene study's runs can all take 5-6 ms of CPU: the log x axis then holds
    no power of 10, and its minor ticks must carry the numbers (they had none)."""
    fig = _scene_chart_of_two_runs(tmp_path, monkeypatch, (0.0052, 0.0061))
    for ax in fig.axes[:4]:
        lo, hi = ax.get_xlim()
        shown = [t.get_text() for t in ax.xaxis.get_majorticklabels()
                 + ax.xaxis.get_minorticklabels()
                 if t.get_text() and lo <= t.get_position()[0] <= hi]
        assert shown, ax.get_title()


def test_scene_plot_x_numbers_within_a_decade_do_not_overlap(tmp_path, monkeypatch):
    """Runs of 12-45 ms of CPU: the x axis's minor ticks carry the numbers, as plain
    numbers (0.03) side by side; as 3×10⁻² and 4×10⁻² they overlapped on a panel."""
    fig = _scene_chart_of_two_runs(tmp_path, monkeypatch, (0.0125, 0.045))
    renderer = fig.canvas.get_renderer()
    for ax in fig.axes[:4]:
        lo, hi = ax.get_xlim()
        labels = [t for t in ax.xaxis.get_majorticklabels() + ax.xaxis.get_minorticklabels()
                  if t.get_text() and lo <= t.get_position()[0] <= hi]
        assert len(labels) >= 2, ax.get_title()
        boxes = sorted((t.get_window_extent(renderer) for t in labels), key=lambda b: b.x0)
        for left, right in zip(boxes, boxes[1:]):
            assert left.x1 <= right.x0, (ax.get_title(), [t.get_text() for t in labels])


def test_scene_stability_map_gives_its_dt_over_h_to_3_digits_either_side_of_1(
        tmp_path, monkeypatch):
    """On a mesh of its own, the scene's Δt multiples over its h are no round numbers:
    the map's columns read 1/2.64 and 3.03 alike, not 1/2.64 and 3.02601."""
    import matplotlib
    matplotlib.use("Agg")
    from types import SimpleNamespace

    import dyncontact.study.stability as st

    h, ratios = 0.0132187, [0.005 / 0.0132187, 0.04 / 0.0132187]
    scheme = SimpleNamespace(key="hht-0.1", label="hht α=-0.1", explicit=False)
    rows, grid = stable_grid([scheme], h, ratios)
    crit = [{"scheme": "hht-0.1", "h": h, "gamma0": 10.0, "theta": 1,
             "bracket": "above grid", "dt_crit_lo": 0.04, "dt_crit_over_h": None}]
    figs = []
    monkeypatch.setattr(st, "save_figure", lambda fig, path, **kw: figs.append(fig) or path)
    st._heatmaps(rows, crit, [scheme], grid, str(tmp_path))
    labels = [t.get_text() for t in figs[0].axes[0].get_xticklabels()]
    assert labels == ["1/2.64", "3.03"], labels


def test_stability_analysis_of_a_body_that_starts_with_no_energy():
    """A scene at rest under gravity starts with e_total = 0: its energy ratios are
    undefined (NaN), not inf with numpy's divide-by-zero warning on the study's stderr."""
    import warnings
    from types import SimpleNamespace

    import numpy as np

    from dyncontact.study.analyses import analyse_stability

    t = np.linspace(0.0, 1.0, 5)
    trace = {"t": t, "e_total": np.array([0.0, 1e-3, 2e-3, 1e-3, 0.0]),
             "e_contact": np.zeros(5), "active": np.zeros(5), "u_n": np.zeros(5)}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m = analyse_stability("run", SimpleNamespace(trace=trace, summary={}))["metrics"]
    assert m["e0"] == 0.0
    for key in ("e_end_ratio", "e_max_ratio", "ec_end_ratio"):
        assert math.isnan(m[key]), (key, m[key])


def test_scene_studies_take_a_scene_object(tmp_path):
    """From Python, ``run_stability_scene`` and ``run_work_precision_scene`` take a
    dyncontact.Scene as well as a file (a notebook's scene built or edited in Python):
    it is written as OUT/scene.nml and studied as that file would be, the same runs (the
    second study on the same cache takes every run from it) and the same brackets;
    anything else is a TypeError that says what is expected."""
    import dyncontact
    from dyncontact.study.stability import run_stability_scene
    from dyncontact.study.workprecision import run_work_precision_scene

    path = _scene_1d(tmp_path / "bar.nml", t_end=0.2)
    grid = {"schemes": ("pc",), "dt_factors": {"implicit": (1,), "explicit": (1, 8)},
            "rounds": 1}
    cache = str(tmp_path / "cache")
    kw = dict(grid=grid, cache=cache, workers=1, progress=False, log=None)
    by_file = run_stability_scene(str(tmp_path / "file"), path, **kw)
    scene = dyncontact.Scene.read(path)
    by_object = run_stability_scene(str(tmp_path / "object"), scene, **kw)
    assert (tmp_path / "object" / "scene.nml").is_file()
    assert dyncontact.Scene.read(tmp_path / "object" / "scene.nml") == scene
    assert by_object["n_cached"] == by_object["n_runs"] == by_file["n_runs"] > 0
    pick = ("scheme", "dt_crit_lo", "dt_crit_hi", "bracket")
    assert [{k: c[k] for k in pick} for c in by_object["critical"]] == \
        [{k: c[k] for k in pick} for c in by_file["critical"]]
    scene.set("scheme.dt", 0.0)   # refused as the file would be: one line naming it
    with pytest.raises(ValueError, match=r"bar\.nml: &scheme dt: must be > 0"):
        run_work_precision_scene(str(tmp_path / "wp"), scene, quick=True, cache=cache,
                                 progress=False, log=None)
    with pytest.raises(TypeError, match="a scene file's path or a dyncontact.Scene"):
        run_stability_scene(str(tmp_path / "x"), 3, **kw)


@pytest.mark.parametrize("study", ["stability", "work-precision"])
def test_scene_studies_from_python_log_the_file_not_the_option(tmp_path, capsys, study):
    """Called from Python, a study's log lines and progress bars name the scene file
    (``stability (bar.nml) grid``), not `--scene`, the command line's option, which the
    caller did not use; the command line's wording is the one it passes as ``desc``."""
    from dyncontact.study.stability import run_stability_scene
    from dyncontact.study.workprecision import run_work_precision_scene

    path = _scene_1d(tmp_path / "bar.nml", t_end=0.1)
    logged = []
    kw = dict(cache=str(tmp_path / "cache"), workers=1, progress=True, log=logged.append)
    if study == "stability":
        grid = {"schemes": ("pc",), "dt_factors": {"implicit": (1,), "explicit": (1, 8)},
                "rounds": 1}
        run_stability_scene(str(tmp_path / "out"), path, grid=grid, **kw)
    else:
        run_work_precision_scene(str(tmp_path / "out"), path, quick=True, ladder=(1.0,),
                                 series=(("pc", None),), **kw)
    bars = capsys.readouterr().err
    assert logged and all(x.startswith(f"{study} (bar.nml)") for x in logged), logged
    assert f"{study} (bar.nml)" in bars, bars
    assert not [x for x in logged if "--scene" in x] and "--scene" not in bars
    kw.update(log=None, desc=f"{study} --scene")   # the command line's (cached runs)
    if study == "stability":
        run_stability_scene(str(tmp_path / "out"), path, grid=grid, **kw)
    else:
        run_work_precision_scene(str(tmp_path / "out"), path, quick=True, ladder=(1.0,),
                                 series=(("pc", None),), **kw)
    assert f"{study} --scene" in capsys.readouterr().err


def test_stability_summary_gives_bounds_outside_the_grid_in_scene_steps_too():
    """The summary's "/ scene's Δt" column says what its "critical Δt" column does: the
    bracket's geometric mean within the grid, and the bound where the critical Δt is
    outside it ("> 8" beside "> 0.08" at a scene's Δt of 0.01), not "-"."""
    from dyncontact.study.stability import _crit_text, _ratio_text

    rows = [({"bracket": "bisection", "dt_crit_lo": 0.02, "dt_crit_hi": 0.08,
              "dt_crit": 0.04}, "0.02 – 0.08", "4"),
            ({"bracket": "above grid", "dt_crit_lo": 0.08, "dt_crit_hi": None,
              "dt_crit": None}, "> 0.08", "> 8"),
            ({"bracket": "below grid", "dt_crit_lo": None, "dt_crit_hi": 0.005,
              "dt_crit": None}, "< 0.005", "< 0.5"),
            ({"bracket": "refused", "dt_crit_lo": None, "dt_crit_hi": None,
              "dt_crit": None}, "refused", "-")]
    for c, crit, ratio in rows:
        assert (_crit_text(c), _ratio_text(c, 0.01)) == (crit, ratio), c


def _refused_by_every_scheme(path):
    """A scene on which the core refuses each explicit scheme (the augmented Lagrangian)."""
    return _scene_1d(path, t_end=0.1, **{"method = 'nitsche'": "method = 'alm'"})


@pytest.mark.parametrize("study", ["stability", "work-precision"])
def test_scene_refusals_from_python_name_the_file_not_the_option(tmp_path, study):
    """Called from Python, a study names the scene file it refuses as the caller gave it
    (no `--scene`, the command line's option, which the caller did not use); the core's
    refusal, which names the file already, is its one line as the core says it."""
    from dyncontact.study.stability import run_stability_scene
    from dyncontact.study.workprecision import run_work_precision_scene

    def study_on(scene, **kw):
        if study == "stability":
            return run_stability_scene(str(tmp_path / "out"), scene, quick=True,
                                       progress=False, log=None, **kw)
        return run_work_precision_scene(str(tmp_path / "out"), scene, quick=True,
                                        progress=False, log=None, **kw)

    missing = str(tmp_path / "none.nml")
    with pytest.raises(BadInputError) as exc:
        study_on(missing)
    assert str(exc.value) == f"{missing}: no such file"
    bad = tmp_path / "bad.nml"
    bad.write_text("&mesh dim = 7 /\n")
    with pytest.raises(BadInputError) as exc:
        study_on(str(bad))
    assert str(exc.value).startswith(f"{bad}: &mesh dim:"), exc.value
    zero = tmp_path / "zero.nml"
    zero.write_text("&scheme name = 'central', dt = 0.0 /\n")
    with pytest.raises(BadInputError) as exc:
        study_on(str(zero))
    assert str(exc.value).startswith(f"{zero}: &scheme dt = 0: "), exc.value
    alm = _refused_by_every_scheme(tmp_path / "alm.nml")
    kw = ({"grid": {"schemes": ("pc", "central")}} if study == "stability"
          else {"series": (("pc", None), ("central_lumped", None))})
    with pytest.raises(BadInputError) as exc:
        study_on(alm, **kw)
    assert str(exc.value).startswith(f"{alm}: the core refuses every scheme of the study "
                                     "on it (first: "), exc.value
    # a Scene: named by the file the study writes it as, which its runs read
    scn = Scene.read(str(zero))
    with pytest.raises(BadInputError) as exc:
        study_on(scn)
    written = os.path.join(str(tmp_path / "out"), "scene.nml")
    assert str(exc.value).startswith(f"{written}: &scheme dt = 0: "), exc.value


@pytest.mark.parametrize("study", ["stability", "work-precision"])
def test_scene_refusals_on_the_command_line_name_the_option(tmp_path, capsys, monkeypatch,
                                                           study):
    """The command line says the same refusals of the option that gave the scene."""
    from dyncontact.study import stability
    from dyncontact.study.cli import main

    bad = tmp_path / "bad.nml"
    bad.write_text("&mesh dim = 7 /\n")
    assert main([study, "--out", str(tmp_path / "o"), "--scene", str(bad),
                 "--no-progress"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"dyncontact study: --scene {bad}: &mesh dim:"), err   # named once
    if study == "stability":    # its schemes are the grid's: explicit ones only
        monkeypatch.setitem(stability.SCENE_GRIDS, "quick",
                            {**stability.SCENE_GRIDS["quick"], "schemes": ("pc", "central")})
        alm = _refused_by_every_scheme(tmp_path / "alm.nml")
        assert main([study, "--out", str(tmp_path / "o2"), "--scene", alm, "--quick",
                     "--no-progress"]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1, err
        assert err.startswith(f"dyncontact study: --scene {os.path.abspath(alm)}: the core "
                              "refuses every scheme of the study on it (first: "), err


@pytest.mark.parametrize("cpu_s", [(0.0055, 0.045), (0.0052, 0.047), (0.0021, 0.0092)])
def test_scene_plot_axes_give_two_numbers_when_one_power_of_ten_is_in_range(tmp_path,
                                                                           monkeypatch,
                                                                           cpu_s):
    """Runs of 5-50 ms of CPU, a quick study's: the range holds one power of 10 (0.01),
    which alone would be labelled, one number on the axis; the minor ticks carry numbers too
    (plain, side by side without overlapping)."""
    fig = _scene_chart_of_two_runs(tmp_path, monkeypatch, cpu_s)
    renderer = fig.canvas.get_renderer()
    for ax in fig.axes[:4]:
        lo, hi = ax.get_xlim()
        labels = [t for t in ax.xaxis.get_majorticklabels() + ax.xaxis.get_minorticklabels()
                  if t.get_text() and lo <= t.get_position()[0] <= hi]
        assert len(labels) >= 2, (ax.get_title(), [t.get_text() for t in labels])
        boxes = sorted((t.get_window_extent(renderer) for t in labels), key=lambda b: b.x0)
        for left, right in zip(boxes, boxes[1:]):
            assert left.x1 <= right.x0, (ax.get_title(), [t.get_text() for t in labels])
