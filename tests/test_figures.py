"""scripts/figures --quick end to end (every figure file, index.md, the runs' outputs,
a second run from the cache), and the pieces of dyncontact.study.figures and
dyncontact.study.bench that scripts/figures and scripts/bench use."""

from __future__ import annotations

import json
import os
import subprocess

import numpy as np
import pytest

from conftest import ROOT

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
#: scripts/figures --quick takes ~10 s on 2 idle cores; leave room for a busy machine.
FIGURES_TIMEOUT = 600


@pytest.fixture(scope="module")
def quick_figures(tmp_path_factory):
    """Run `scripts/figures --quick --out DIR` once for the module."""
    out = tmp_path_factory.mktemp("figures")
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    res = subprocess.run([str(ROOT / "scripts" / "figures"), "--quick", "--out", str(out)],
                         cwd=out, env=env, capture_output=True, text=True,
                         timeout=FIGURES_TIMEOUT)
    return out, res


@pytest.mark.slow
def test_quick_figures_exit_and_every_file(quick_figures):
    from dyncontact.study.figures import figure_plan

    out, res = quick_figures
    assert res.returncode == 0, (res.stdout[-3000:], res.stderr[-3000:])
    plan = figure_plan(quick=True)
    assert [f.key for f in plan] == [f"fig{k}" for k in range(1, 10)]
    for fig in plan:
        png = out / fig.png
        assert png.is_file(), fig.png
        assert png.read_bytes()[:8] == PNG_MAGIC
        assert png.stat().st_size > 10_000, fig.png
    assert (out / "index.md").is_file()
    assert (out / "index.json").is_file()


@pytest.mark.slow
def test_quick_index_lists_every_run_with_its_status(quick_figures):
    from dyncontact.core import read_summary
    from dyncontact.study.figures import figure_plan

    out, res = quick_figures
    index = (out / "index.md").read_text(encoding="utf-8")
    assert "Total wall time:" in index
    report = json.loads((out / "index.json").read_text(encoding="utf-8"))
    assert report["quick"] is True and report["wall_s"] > 0
    rows = {}
    for line in index.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 10 and cells[0] not in ("run", "---"):
            rows.setdefault(cells[0], cells)
    for fig in figure_plan(quick=True):
        assert fig.title in index
        assert f"]({fig.png})" in index
        for run in fig.runs:
            assert run.name in rows, run.name
            summary = read_summary(out / "runs" / run.name)
            status, steps = rows[run.name][3], int(rows[run.name][4])
            assert status == summary["status"]
            # the scheme column names the scheme the run ran (Fig. 9's ball: its scene's)
            assert rows[run.name][1].split()[0].rstrip(",") == summary["scheme"], run.name
            assert steps == summary["steps"]
            assert (out / "runs" / run.name / "trace.csv").is_file()
    for fig in report["figures"]:
        assert fig["plot"]["ok"], fig


@pytest.mark.slow
def test_quick_traces_are_short_and_fig1_has_fields(quick_figures):
    from dyncontact.core import read_trace
    from dyncontact.plotting import read_pvd
    from dyncontact.study.figures import MAX_ROWS, figure_plan

    out, _ = quick_figures
    plan = figure_plan(quick=True)
    for fig in plan:
        for run in fig.runs:
            t = read_trace(out / "runs" / run.name)["t"]
            assert 1 < len(t) <= MAX_ROWS + 2
    fig1 = plan[0]
    pvd = out / "runs" / fig1.runs[0].name / "fields.pvd"
    sets = read_pvd(pvd)
    assert 8 <= len(sets) <= 12
    assert all(os.path.isfile(p) for _, p in sets)
    assert sets[0][0] == 0.0 and sets[-1][0] == pytest.approx(3.0)
    assert f"runs/{fig1.runs[0].name}/fields.pvd" in (out / "index.md").read_text("utf-8")


@pytest.mark.slow
def test_quick_fig8_draws_the_box_and_strip_traces(quick_figures):
    """Fig. 8's values (index.json) are those of the two runs' traces: the 2D strip and
    the 3D box of the same scheme, written at the same times."""
    from dyncontact.core import read_summary, read_trace
    from dyncontact.study.figures import figure_plan

    out, _ = quick_figures
    report = json.loads((out / "index.json").read_text(encoding="utf-8"))
    fig = next(f for f in report["figures"] if f["key"] == "fig8")
    assert fig["plot"]["ok"], fig
    data = fig["plot"]["data"]
    strip, box = next(f for f in figure_plan(quick=True) if f.key == "fig8").runs
    assert box.settings["mesh.dim"] == 3
    assert {k: v for k, v in box.settings.items() if k != "mesh.dim"} == strip.settings
    a, b = read_trace(out / "runs" / strip.name), read_trace(out / "runs" / box.name)
    assert read_summary(out / "runs" / box.name)["dofs"] == data["box"]["dofs"] == 540
    assert read_summary(out / "runs" / strip.name)["dofs"] == data["strip"]["dofs"] == 120
    assert np.array_equal(a["t"], b["t"]) and data["common_rows"] == len(a["t"])
    assert data["max_abs_du_n"] == np.max(np.abs(a["u_n"] - b["u_n"]))
    assert data["max_abs_dp_n"] == np.max(np.abs(a["p_n"] - b["p_n"]))
    for key, tr in (("strip", a), ("box", b)):
        assert data[key]["e0"] == tr["e_total"][0]
        assert data[key]["p_n_min"] == tr["p_n"].min() < 0
        assert data[key]["e_end_ratio"] == tr["e_total"][-1] / tr["e_total"][0]
    # the same 1D-like motion: the compressed bar starts at u_n = -1/2 in both
    assert a["u_n"][0] == b["u_n"][0] == -0.5


def _von_mises_loop(x, tets, u, young, poisson):
    """Von Mises stress per tetrahedron, written out element by element (P1 gradients
    from the barycentric coordinates), to check the figure's vectorized one."""
    lam = young * poisson / ((1 + poisson) * (1 - 2 * poisson))
    mu = young / (2 * (1 + poisson))
    out = []
    for t in tets:
        a = np.hstack([np.ones((4, 1)), x[t]])        # rows: 1, x, y, z of each node
        grads = np.linalg.inv(a)[1:, :]               # (3, 4): gradients of the 4 shape fns
        g = u[t].T @ grads.T                          # (3, 3): du_i/dx_j
        eps = 0.5 * (g + g.T)
        sig = lam * np.trace(eps) * np.eye(3) + 2 * mu * eps
        s = sig - np.trace(sig) / 3 * np.eye(3)
        out.append(np.sqrt(1.5 * np.sum(s * s)))
    return np.array(out)


@pytest.mark.slow
def test_quick_fig9_snapshot_is_the_ball_at_its_maximum_compression(quick_figures):
    """Fig. 9: the snapshot run stops at the trace run's largest elastic energy and is
    the same state (same steps, same e_el); the drawn stress and patch are those of its
    VTU; the impact is Hertz's to the accuracy of this coarse ball."""
    meshio = pytest.importorskip("meshio")
    from dyncontact.core import read_trace
    from dyncontact.plotting import read_pvd
    from dyncontact.study.figures import figure_plan

    out, _ = quick_figures
    report = json.loads((out / "index.json").read_text(encoding="utf-8"))
    fig = next(f for f in report["figures"] if f["key"] == "fig9")
    assert fig["plot"]["ok"], fig
    data = fig["plot"]["data"]
    trace_run = next(f for f in figure_plan(quick=True) if f.key == "fig9").runs[0]
    assert fig["runs"][0] == trace_run.name and len(fig["runs"]) == 2
    tr = read_trace(out / "runs" / trace_run.name)
    k = int(np.argmax(tr["e_el"]))
    assert 0 < k < len(tr["t"]) - 1                   # a maximum inside the run
    assert data["t_star"] == tr["t"][k] and data["e_el_max"] == tr["e_el"][k]
    assert tr["active"][0] == 0 and tr["active"][k] > 0 and tr["active"][-1] == 0
    snap_dir = out / "runs" / fig["runs"][1]
    snap = read_trace(snap_dir)
    assert snap["t"][-1] == pytest.approx(tr["t"][k], abs=1e-12)
    assert snap["e_el"][-1] == pytest.approx(tr["e_el"][k], rel=1e-12)
    sets = read_pvd(snap_dir / "fields.pvd")
    assert [t for t, _ in sets] == pytest.approx([0.0, tr["t"][k]], abs=1e-12)
    m = meshio.read(sets[-1][1])
    x, u = m.points, m.point_data["displacement"]
    tets = m.cells_dict["tetra"]
    vm = _von_mises_loop(x, tets, u, data["young"], data["poisson"])
    assert data["von_mises_max"] == pytest.approx(vm.max(), rel=1e-10)
    assert data["tets"] == len(tets) and data["contact_nodes"] >= 1
    assert data["min_gap"] == pytest.approx(float(np.min(x[:, 2] + u[:, 2])), abs=1e-15)
    # Hertz's quasi-static impact (R = 0.2, E* = 1/0.91, v = 0.1): contact time 1.55,
    # approach 0.053; this ball of 257 tetrahedra: 1.37 and 0.046 (the coarse sphere is
    # stiffer, and the impact not quite quasi-static); within 25 %
    hz = data["hertz"]
    assert data["contact_end"] - data["contact_start"] == pytest.approx(hz["t_contact"],
                                                                         rel=0.25)
    assert data["approach"] == pytest.approx(hz["delta_max"], rel=0.25)


def test_von_mises_and_mid_plane_cut_on_known_states():
    """Uniaxial stress gives σ_vm = |σ_xx|, pure shear √3 |σ_xy|; the mid-plane section of
    the unit cube (6 tetrahedra, at rest) has area 1."""
    from dyncontact.study.figures import mid_plane_cut, von_mises

    x = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0, 0, 1], [1, 0, 1],
                  [0, 1, 1], [1, 1, 1]], dtype=float)
    tets = np.array([[0, 1, 3, 7], [0, 1, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 5, 7],
                     [0, 4, 6, 7]])
    young, nu, e = 2.0, 0.25, 1e-3
    u = x @ np.diag([e, -nu * e, -nu * e]).T
    assert von_mises(x, tets, u, young, nu) == pytest.approx(young * e, rel=1e-12)
    g = 1e-3
    u = np.column_stack([g * x[:, 1], g * x[:, 0], 0 * x[:, 0]])     # ε_xy = g
    assert von_mises(x, tets, u, young, nu) == pytest.approx(
        np.sqrt(3) * young / (1 + nu) * g, rel=1e-12)
    polys, cut = mid_plane_cut(x, tets, 0 * x, axis=1, value=0.5)
    area = sum(0.5 * abs(np.dot(p[:, 0], np.roll(p[:, 1], 1))
                         - np.dot(p[:, 1], np.roll(p[:, 0], 1))) for p in polys)
    assert len(cut) == 6 and area == pytest.approx(1.0, rel=1e-12)


def test_figures_run_on_the_pool_on_dask_and_from_the_cache(tmp_path, monkeypatch):
    """The figures' runs go through the sweep runner: the local pool and a Dask cluster
    write the same traces, and a second make_figures takes every run from the cache and
    writes them again, byte for byte, with summary.json naming the folder it is in."""
    distributed = pytest.importorskip("distributed")
    from dyncontact.core import read_summary
    from dyncontact.study import figures
    from dyncontact.study.common import seed_spec

    fig = figures.FigureSpec(
        key="fig2", png="fig2.png", title="two short runs", kind="traces",
        runs=[seed_spec("hht", 0.1, 0.005, 0.5, alpha=0.0),
              seed_spec("pc", 0.1, 0.001, 0.5, beta=0.25, gamma=0.5)])
    monkeypatch.setattr(figures, "figure_plan", lambda quick=False: [fig])
    pool = figures.make_figures(str(tmp_path / "pool"), workers=2, log=None)
    with distributed.LocalCluster(processes=False, n_workers=1, threads_per_worker=1,
                                  dashboard_address=":0") as cluster:
        dask = figures.make_figures(str(tmp_path / "dask"), scheduler=cluster.scheduler_address,
                                    log=None)
    again = figures.make_figures(str(tmp_path / "pool"), workers=2, log=None)
    assert [r["cached"] for r in pool["runs"] + dask["runs"]] == [False] * 4
    assert [r["cached"] for r in again["runs"]] == [True] * 2
    assert dask["jobs"] is None and "Dask" in (tmp_path / "dask" / "index.md").read_text()
    for rep in (pool, dask, again):
        assert rep["figures"][0]["plot"]["ok"], rep["figures"][0]
    for run in fig.runs:
        folder = tmp_path / "pool" / "runs" / run.name
        trace = (folder / "trace.csv").read_bytes()
        assert (tmp_path / "dask" / "runs" / run.name / "trace.csv").read_bytes() == trace
        assert read_summary(folder)["scene"]["output"]["dir"] == str(folder)
    rec = {r["name"]: r for r in again["runs"]}[fig.runs[0].name]
    assert rec["status"] == "ok" and rec["steps"] == 100 and rec["rows"] == 101


def test_figures_take_the_studies_options(tmp_path, monkeypatch, capsys):
    """scripts/figures passes the runner's options (as `dyncontact study` takes them, and
    --jobs, -j for --workers) to make_figures, and refuses a pool of no process, and a
    pool size with a scheduler (whose cluster has its own workers) naming both."""
    from dyncontact.study import figures

    seen = []
    monkeypatch.setattr(figures, "make_figures", lambda out, **kw: seen.append((out, kw))
                        or {"figures": [], "runs": []})
    assert figures.figures_main(["--workers", "3", "--cache", "C", "--out", "O"]) == 0
    assert figures.figures_main(["-j", "2"], root=str(tmp_path)) == 0
    assert figures.figures_main(["--scheduler", "tcp://h:8786"], root=str(tmp_path)) == 0
    assert [(kw["workers"], kw["scheduler"], kw["cache"]) for _, kw in seen] == [
        (3, None, "C"), (2, None, None), (None, "tcp://h:8786", None)]
    assert seen[0][0] == "O" and seen[1][0] == str(tmp_path / "out" / "figures")
    with pytest.raises(SystemExit) as exc:
        figures.figures_main(["--workers", "0"])
    assert exc.value.code == 2 and "--workers must be >= 1" in capsys.readouterr().err
    for workers in (["-j", "2"], ["--workers", "2"]):
        with pytest.raises(SystemExit) as exc:
            figures.figures_main([*workers, "--scheduler", "tcp://h:8786"])
        err = capsys.readouterr().err.strip().splitlines()
        assert exc.value.code == 2 and len(err) == 1, err
        assert err[0].startswith("figures: ") and "--workers" in err[0] \
            and "--scheduler" in err[0], err
    assert len(seen) == 3


# --------------------------------------------------------------------------- plan, runs, index

def test_full_plan_matches_the_seed():
    from dyncontact.study.figures import figure_plan

    plan = figure_plan()
    assert len(plan) == 9
    f1 = plan[0].runs[0].settings
    assert (f1["scheme.name"], f1["scheme.beta"], f1["scheme.gamma"]) == ("newmark", 0.25, 0.5)
    assert (f1["mesh.h"], f1["scheme.dt"], f1["scheme.t_end"]) == (0.02, 0.001, 3.0)
    assert 8 <= 3000 // f1["output.fields_every"] + 1 <= 12
    for k, h in enumerate((0.05, 0.02, 0.01)):
        hht = plan[1 + k].runs
        assert len(hht) == 5
        assert {r.settings["mesh.h"] for r in hht} == {h}
        assert all(r.settings["scheme.dt"] == pytest.approx(h / 20) for r in hht)
        assert {r.settings["scheme.t_end"] for r in hht} == {15.0}
        assert sorted(r.settings.get("scheme.alpha", 1) for r in hht
                      if r.settings["scheme.name"] == "hht") == [-0.1, -0.05, 0.0]
        assert sorted((r.settings.get("scheme.beta"), r.settings.get("scheme.gamma"))
                      for r in hht if r.settings["scheme.name"] == "newmark") == [
            (0.25, 0.5), (0.3025, 0.6)]
        pc = plan[4 + k].runs
        assert sorted((r.settings["scheme.name"], round(h / r.settings["scheme.dt"]))
                      for r in pc) == [("pc", 20), ("pc", 100), ("pc_hht", 20),
                                       ("pc_hht", 100), ("pc_hht_seed", 20),
                                       ("pc_hht_seed", 100)]
        assert all(r.settings.get("scheme.alpha", -0.1) == -0.1 for r in pc)
        for r in hht + pc:
            steps = r.estimated_steps()
            assert steps / r.settings["output.every"] <= 3000


def test_seed_spec_and_every():
    from dyncontact.study.common import every_for, seed_spec

    assert every_for(15.0, 0.0001) == 50
    assert every_for(3.0, 0.001) == 1
    s = seed_spec("hht", 0.02, 0.02 / 20, 15.0, alpha=-0.05)
    assert s.name == "hht_a-0.05_h0.02_dt0.001_T15"
    assert s.settings["output.every"] == 5
    scene = s.scene()
    assert scene.get("scheme.alpha") == -0.05 and scene.get("mesh.h") == 0.02
    lumped = seed_spec("pc", 0.05, 0.0005, 15.0, mass="lumped", max_rows=None)
    assert lumped.name.endswith("_lumped") and lumped.settings["output.every"] == 1
    assert lumped.estimated_steps() == 30000
    with pytest.raises(ValueError):
        seed_spec("hht", 0.05, 0.0025, 1.0, alfa=0.1)


def test_uncached_run_reports_instead_of_raising(tmp_path):
    """The bench's runs: the sweep runner's run of one scene into a folder of its own
    (emptied first), never through a cache, never raising."""
    from dyncontact.study.common import RunSpec
    from dyncontact.study.sweep import run_uncached

    rec = run_uncached(RunSpec("bad", {"scheme.dt": -1.0}).task(), str(tmp_path / "bad"))
    assert rec["status"] == "refused" and "dt" in rec["message"]
    spec = RunSpec("ok", {"scheme.t_end": 0.05})
    ok = run_uncached(spec.task(), str(tmp_path / "ok"))
    assert ok["status"] == "ok" and ok["steps"] == 20 and ok["metrics"]["rows"] == 21
    assert ok["metrics"]["dofs"] == 120 and not ok["cached"]
    assert ok["wall_measured_s"] >= ok["wall_s"] > 0
    (tmp_path / "ok" / "marker").write_text("from the first run")
    again = run_uncached(spec.task(), str(tmp_path / "ok"))
    assert again["status"] == "ok" and not again["cached"]
    assert sorted(p.name for p in (tmp_path / "ok").iterdir()) == ["summary.json",
                                                                    "trace.csv"]


def test_write_index_shows_unstable_runs(tmp_path):
    from dyncontact.study.common import seed_spec
    from dyncontact.study.figures import write_index

    a = seed_spec("pc", 0.05, 0.0025, 15.0, beta=0.25, gamma=0.5)
    b = seed_spec("pc_hht", 0.05, 0.0025, 15.0, alpha=-0.1)
    recs = [dict(name=a.name, settings=a.settings, status="unstable", message="", steps=812,
                 t_end_reached=2.03, wall_s=0.05, wall_measured_s=0.1, newton_its_total=0,
                 dofs=120),
            dict(name=b.name, settings=b.settings, status="error", message="boom",
                 steps=None, t_end_reached=None, wall_s=None, wall_measured_s=0.01,
                 newton_its_total=None, dofs=None)]
    report = {"quick": False, "started": "now", "wall_s": 1.0, "jobs": 2, "cpu_count": 2,
              "runs_wall_sum_s": 0.11, "plots_wall_sum_s": 0.5, "version": "x",
              "runs": recs,
              "figures": [{"key": "fig5", "png": "fig5.png", "title": "Fig. 5: pc",
                           "kind": "traces", "note": "", "runs": [a.name, b.name],
                           "plot": {"ok": True, "wall_s": 0.5}}]}
    text = open(write_index(str(tmp_path), report), encoding="utf-8").read()
    assert f"| {a.name} | pc β=0.25, γ=0.5 | 0.0025 | unstable | 812 | 2.03 |" in text
    assert "error: boom" in text
    assert json.loads((tmp_path / "index.json").read_text())["runs"][0]["status"] == \
        "unstable"


def test_write_index_gives_the_scheme_of_the_base_scene(tmp_path):
    """Fig. 9's ball runs set no scheme key: their scheme is their scene file's
    (newmark), not the built-in default scene's (hht)."""
    from dyncontact.study.figures import BALL_SCENE, ball_trace_spec, write_index

    ball = ball_trace_spec(0.1, 0.01, 1.6)
    assert "scheme.name" not in ball.settings
    recs = [dict(name=ball.name, settings=ball.settings, base=ball.base, status="ok",
                 message="", steps=160, t_end_reached=1.6, wall_s=0.05, wall_measured_s=0.1,
                 newton_its_total=160, dofs=99)]
    report = {"quick": True, "started": "now", "wall_s": 1.0, "jobs": 2, "cpu_count": 2,
              "runs_wall_sum_s": 0.1, "plots_wall_sum_s": 0.5, "version": "x",
              "runs": recs,
              "figures": [{"key": "fig9", "png": "fig9.png", "title": "Fig. 9: ball",
                           "kind": "traces", "note": "", "runs": [ball.name],
                           "plot": {"ok": True, "wall_s": 0.5}}]}
    text = open(write_index(str(tmp_path), report), encoding="utf-8").read()
    assert ball.base == BALL_SCENE
    assert f"| {ball.name} | newmark | 0.01 | ok | 160 |" in text


def test_scheme_text_takes_what_settings_leave_from_the_base_scene(tmp_path):
    from dyncontact.study.common import scheme_text

    base = tmp_path / "b.nml"
    base.write_text("&scheme name = 'pc', mass = 'lumped', dt = 0.001 /\n")
    assert scheme_text({}, str(base)) == "pc, lumped mass"
    assert scheme_text({"scheme.name": "newmark", "scheme.mass": "consistent"},
                       str(base)) == "newmark"
    assert scheme_text({"scheme.beta": 0.3}, str(base)) == "pc β=0.3, lumped mass"
    assert scheme_text({}) == "hht"                 # the built-in default scene's


def test_bench_rows_and_table():
    from dyncontact.study.bench import bench_specs, bench_table

    names = [s.name for s in bench_specs()]
    assert names == ["seed_h0.05", "seed_h0.02", "seed_h0.01", "seed_free_h0.01",
                     "pc_h0.05_consistent", "pc_h0.05_lumped", "pc_h0.02_consistent",
                     "pc_h0.02_lumped", "pc_h0.01_consistent", "pc_h0.01_lumped",
                     "box3d_h0.05", "box3d_free_h0.05", "box3d_h0.025", "box3d_free_h0.025"]
    assert [s.name for s in bench_specs(quick=True)] == [
        "seed_h0.05", "seed_free_h0.05", "pc_h0.05_consistent", "pc_h0.05_lumped",
        "box3d_h0.05", "box3d_free_h0.05"]
    box = bench_specs(only=["box3d_h0.025"])[0].settings
    assert list(box)[0] == "mesh.dim" and box["mesh.dim"] == 3   # first: 3D vectors
    assert box["scheme.dt"] == pytest.approx(0.00125) and box["scheme.t_end"] == 3.0
    free = bench_specs(only=["seed_free_h0.01"])[0].settings
    assert free["boundary.contact"] == "" and free["scheme.dt"] == pytest.approx(0.0005)
    free3 = bench_specs(only=["box3d_free_h0.025"])[0].settings
    assert list(free3)[0] == "mesh.dim" and free3["boundary.contact"] == ""
    assert {k: v for k, v in free3.items() if k != "boundary.contact"} == \
        {k: v for k, v in box.items() if k != "boundary.contact"}
    assert [s.name for s in bench_specs(only=["pc_h0.02*"])] == [
        "pc_h0.02_consistent", "pc_h0.02_lumped"]
    seed = bench_specs(only=["seed_h0.01"])[0].settings
    assert (seed["scheme.name"], seed["scheme.alpha"], seed["output.every"]) == ("hht", 0.0, 1)
    assert seed["scheme.dt"] == pytest.approx(0.0005) and seed["scheme.t_end"] == 15.0
    pc = bench_specs(only=["pc_h0.01_lumped"])[0].settings
    assert pc["scheme.dt"] == pytest.approx(0.0001) and pc["scheme.mass"] == "lumped"
    rows = [{"scene": "seed_h0.05", "dofs": 120, "steps": 6000, "wall_s": 0.2,
             "status": "ok", "floor_solve_us": None, "floor_spmv_us": 2.0},
            {"scene": "pc_h0.05_lumped", "dofs": 120, "steps": 30000, "wall_s": 0.5,
             "status": "ok", "floor_mass_solve_us": None, "floor_spmv_us": None}]
    table = bench_table(rows).splitlines()
    assert table[0].split()[:3] == ["scene", "dofs", "steps"]
    seed_cells, pc_cells = table[2].split(), table[3].split()
    # floors: n/a when not measured, '-' where they do not apply to the scheme
    # (the last three columns before the status: the flight / contact split, '-' unless
    # measured)
    assert seed_cells[-11:] == ["n/a", "-", "2.00", "n/a", "n/a", "-", "n/a",
                                "-", "-", "-", "ok"]
    assert pc_cells[-11:] == ["-", "n/a", "n/a", "n/a", "n/a", "-", "-", "-", "-", "-", "ok"]
    ranged = bench_table([dict(rows[0], floor_ratio=1.2, floor_ratio_min=1.1,
                               floor_ratio_max=1.5, contact_share=0.25,
                               flight_ratio=1.437, contact_ratio=2.442)]
                         ).splitlines()[2].split()
    assert ranged[-7:] == ["1.20", "1.10-1.50", "n/a", "0.25", "1.44", "2.44", "ok"]
    # the floor of a step (one solve + one SpMV for the implicit rows) and the ratio to it
    from dyncontact.study.bench import step_floor
    assert step_floor({"scene": "seed_h0.01", "floor_solve_us": 50.0,
                        "floor_spmv_us": 10.0}) == 60.0
    assert step_floor({"scene": "pc_h0.01_consistent", "floor_mass_solve_us": 30.0,
                        "floor_spmv_us": 10.0}) == 80.0
    assert step_floor({"scene": "seed_h0.01", "floor_solve_us": None,
                        "floor_spmv_us": 10.0}) is None
    # the same floor with CHOLMOD's solve in place of the run's (implicit rows only)
    assert step_floor({"scene": "seed_h0.01", "floor_solve_us": 50.0,
                        "floor_cholmod_solve_us": 70.0, "floor_spmv_us": 10.0},
                       cholmod=True) == 80.0
    assert step_floor({"scene": "pc_h0.01_consistent", "floor_mass_solve_us": 30.0,
                        "floor_spmv_us": 10.0}, cholmod=True) is None
    # the implicit floor's solve is the best of the two on the same factor
    assert step_floor({"scene": "box3d_h0.05", "floor_solve_us": 50.0,
                        "floor_cholmod_solve_us": 40.0, "floor_spmv_us": 10.0}) == 50.0
    # the 3D box rows are implicit: their solve floors are shown, the M^-1 floor is not
    box_cells = bench_table([{"scene": "box3d_h0.05", "dofs": 540, "steps": 6000,
                              "wall_s": 0.2, "status": "ok", "floor_solve_us": 11.0,
                              "floor_cholmod_solve_us": 13.0, "floor_spmv_us": 4.0}]
                            ).splitlines()[2].split()
    assert box_cells[-12:-8] == ["11.00", "13.00", "-", "4.00"]


def test_floors_between_steps_leave_the_run_unchanged(tmp_path):
    """Stepper.floors (the bench's floors, measured between stretches of a run's steps)
    solves and multiplies vectors of its own: the trace is the plain run's, byte for
    byte, for an implicit contact run and a predictor-corrector."""
    import dyncontact
    from dyncontact import Scene
    from dyncontact.core import Stepper, bench_floors

    for name in ("bar2d_hht", "bar2d_pc"):
        scn = Scene.read(ROOT / "scripts" / "scenes" / f"{name}.nml")
        scn.set("scheme.t_end", 1.0)
        dyncontact.run(scn, out=tmp_path / f"{name}_plain", progress=False)
        with Stepper(scn, tmp_path / f"{name}_floors") as run:
            measured = [run.floors(20, 2)]
            while not run.finished:
                run.advance(37)
                measured.append(run.floors(20, 2))
        plain = (tmp_path / f"{name}_plain" / "trace.csv").read_bytes()
        assert (tmp_path / f"{name}_floors" / "trace.csv").read_bytes() == plain, name
        key = "solve_us" if name == "bar2d_hht" else "mass_solve_us"
        assert all(f[key] > 0 and f["spmv_us"] > 0 for f in measured), name
        alone = bench_floors(scn, 20, 2)   # the same helper on a run of its own
        assert alone[key] > 0 and alone["spmv_us"] > 0, name


def test_interleaved_run_ratio_is_time_over_floors(tmp_path):
    """interleaved_run: every step is timed in some stretch, each stretch's ratio uses
    the floors next to it, and the run's ratio is Σ time / Σ steps × floor (so it
    equals µs/step ÷ the step-weighted floor, and lies within the stretches' ratios)."""
    from dyncontact.study.bench import bench_specs, interleaved_run, step_floor

    spec = bench_specs(quick=True, only=["seed_h0.05"])[0]
    spec.settings["scheme.t_end"] = 1.0
    rec = interleaved_run(spec, str(tmp_path / "run"), chunks=5, n_rep=20, batches=2)
    assert rec["status"] == "ok" and rec["steps"] == 400
    assert len(rec["chunk_ratios"]) == 5
    steps, floors = rec["chunk_steps"], rec["chunk_floors_us"]
    assert sum(steps) == rec["steps"] and len(floors) == 5
    assert rec["floor_us"] == pytest.approx(
        sum(d * f for d, f in zip(steps, floors)) / sum(steps), rel=1e-12)
    # each stretch takes the faster of its solves (the run's or cholmod_solve2's): the sum
    # of those minima is at most the minimum of the sums, which step_floor(rec) takes
    assert rec["floor_us"] <= step_floor(rec) * (1 + 1e-12)
    assert rec["floor_ratio"] == pytest.approx(rec["us_per_step"] / rec["floor_us"],
                                               rel=1e-12)
    assert min(rec["chunk_ratios"]) <= rec["floor_ratio"] <= max(rec["chunk_ratios"])
    assert rec["floor_cholmod_ratio"] == pytest.approx(
        rec["us_per_step"] / step_floor(rec, cholmod=True), rel=1e-12)
    assert (tmp_path / "run" / "summary.json").is_file()


def test_interleaved_run_of_a_contact_free_row_gives_no_probe_warning(tmp_path):
    """The contact-free rows have no contact boundary by design: the core's warning that
    the probe then reports nothing is kept out of the bench's output (it came once a
    repeat of each such row); a row with a contact boundary still gives the run's
    other warnings."""
    import warnings

    from dyncontact.core import DyncontactWarning
    from dyncontact.study.bench import bench_specs, interleaved_run

    spec = bench_specs(quick=True, only=["seed_free_h0.05"])[0]
    spec.settings["scheme.t_end"] = 0.1
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rec = interleaved_run(spec, str(tmp_path / "free"), chunks=2, n_rep=5, batches=1)
    assert rec["status"] == "ok"
    assert [str(w.message) for w in caught if w.category is DyncontactWarning] == []
    spec.settings["scheme.beta"] = 0.25       # unused by hht: warned, as by any run
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        interleaved_run(spec, str(tmp_path / "beta"), chunks=2, n_rep=5, batches=1)
    said = [str(w.message) for w in caught if w.category is DyncontactWarning]
    assert len(said) == 1 and "beta" in said[0], said


def test_contact_steps_flags_each_step_from_its_trace_rows():
    """A step did contact work when its Newton took more than one iteration or contact
    was active at its start (the row before) or at its end (its row); row 0 is the
    initial state, not a step."""
    from dyncontact.study.bench import contact_steps

    trace = {"newton_its": [0, 1, 1, 2, 1, 1, 1, 3],
             "active": [0, 0, 0, 0, 4, 0, 0, 0]}
    assert contact_steps(trace) == [False, False, True, True, True, False, True]


def test_split_flight_contact_is_the_least_squares_fit():
    """split_flight_contact recovers a flight and a contact cost that make the stretches'
    times exactly; on noisy times its residual is orthogonal to both regressors (the
    normal equations of least squares); one kind of step alone gives that kind's ratio;
    contact fractions that hardly differ give no split."""
    import random

    from dyncontact.study.bench import SPLIT_MIN_SPREAD, split_flight_contact

    steps = [100, 100, 100, 100, 80]
    contact = [0, 40, 100, 10, 80]
    a, b = 1.27, 2.9
    ratios = [(a * (d - c) + b * c) / d for d, c in zip(steps, contact)]
    fa, fb = split_flight_contact(steps, contact, ratios)
    assert fa == pytest.approx(a, rel=1e-12) and fb == pytest.approx(b, rel=1e-12)

    rng = random.Random(7)
    noisy = [r * (1 + 0.05 * rng.uniform(-1, 1)) for r in ratios]
    fa, fb = split_flight_contact(steps, contact, noisy)
    res = [r * d - fa * (d - c) - fb * c for r, d, c in zip(noisy, steps, contact)]
    assert abs(sum(x * (d - c) for x, d, c in zip(res, steps, contact))) < 1e-9
    assert abs(sum(x * c for x, c in zip(res, contact))) < 1e-9

    assert split_flight_contact([10, 20], [0, 0], [1.2, 1.5]) == (
        pytest.approx((12 + 30) / 30, rel=1e-14), None)
    assert split_flight_contact([10, 20], [10, 20], [2.0, 2.6]) == (
        None, pytest.approx((20 + 52) / 30, rel=1e-14))
    close = [40, 40 + int(100 * SPLIT_MIN_SPREAD) - 1]
    assert split_flight_contact([100, 100], close, [1.5, 1.6]) == (None, None)


def test_interleaved_run_splits_flight_and_contact_steps(tmp_path):
    """On a run through an impact, interleaved_run's contact share is the trace's
    contact steps over its steps, and its two costs are split_flight_contact of its
    stretches (the stretches' contact counts read back from the trace)."""
    from dyncontact.core import read_trace
    from dyncontact.study.bench import (bench_specs, contact_steps, interleaved_run,
                                        split_flight_contact)

    spec = bench_specs(quick=True, only=["seed_h0.05"])[0]
    spec.settings["scheme.t_end"] = 3.0
    rec = interleaved_run(spec, str(tmp_path / "run"), chunks=6, n_rep=20, batches=2)
    assert rec["status"] == "ok" and rec["steps"] == 1200
    flags = contact_steps(read_trace(tmp_path / "run"))
    assert len(flags) == 1200 and 0 < sum(flags) < 1200
    assert rec["contact_share"] == pytest.approx(sum(flags) / 1200, rel=1e-14)
    contact = [sum(flags[k * 200:(k + 1) * 200]) for k in range(6)]
    fa, fb = split_flight_contact([200] * 6, contact, rec["chunk_ratios"])
    assert fa is not None and fb is not None
    assert rec["flight_ratio"] == pytest.approx(fa, rel=1e-14)
    assert rec["contact_ratio"] == pytest.approx(fb, rel=1e-14)
