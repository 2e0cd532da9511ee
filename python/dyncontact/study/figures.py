"""The seed's Figures 1-7 and the 3D figures 8-9 (``scripts/figures``), run on the
studies' sweep runner.

``scripts/figures`` is a thin wrapper of :func:`figures_main`; everything it does is
here, reusable from Python:

>>> from dyncontact.study import figures
>>> plan = figures.figure_plan(quick=True)                      # what scripts/figures runs
>>> report = figures.make_figures("out/figures", quick=True)   # doctest: +SKIP
>>> report["figures"][0]["png"], report["wall_s"]               # doctest: +SKIP

Each run is a :class:`.common.RunSpec` (a name and the keys it changes in the seed's
default scene). The runs go through :func:`.sweep.sweep` with the ``outputs`` analysis:
the local process pool (``--workers``) or a Dask cluster (``--scheduler``), and the
per-run cache (``--cache``, default OUT/cache), so that a second ``scripts/figures``
redraws from the cache what has not changed. Each run's outputs are copied from its cache
entry into OUT/runs/<name>/, where the figures and index.md take them from; each figure
is drawn as soon as its runs are done.

Figure 8 sets the 3D box (&mesh dim = 3) beside the 2D strip of the same material, h and
scheme: u_n, p_n and the energy. Figure 9 is the ball of ``scripts/scenes/ball3d_newmark.nml``
(coarse: a few hundred tetrahedra) dropped onto the plane: its trace run finds the time of
maximum compression (the largest elastic energy, where the kinetic energy is smallest);
a second run, to that time, writes the fields there only; the figure cuts the deformed
ball by its vertical mid-plane, coloured by the von Mises stress, and shows the contact
patch from below. The values each figure draws are kept in index.json (``plot.data``).
"""

from __future__ import annotations

import dataclasses
import datetime
import json
import math
import os
import shutil
import sys
import time
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ..scene import find_scene
from .common import (MAX_ROWS, OneLineParser, RunSpec, add_runner_options, fmt, loadavg,
                     new_figure, num, package_version, save_figure, scheduler_timeout,
                     scheduler_unreachable_line, scheme_text, seed_spec)
from .sweep import ERROR, REFUSED, SchedulerUnreachable, sigterm_as_interrupt, sweep

__all__ = ["FigureSpec", "figure_plan", "make_figures", "plot_figure", "write_index",
           "figures_main", "MAX_ROWS", "HHT_FAMILY", "PC_FAMILY", "BALL_SCENE",
           "box3d_spec", "ball_trace_spec", "BALL_SPEED", "BALL_QUICK", "BALL_FULL", "ball_snapshot_spec", "max_compression",
           "plot_box_vs_strip", "plot_ball_snapshot", "von_mises", "mid_plane_cut"]


# --------------------------------------------------------------------------- the plan

@dataclasses.dataclass
class FigureSpec:
    """One figure: its file, title, kind ('traces': the four panels, one curve per run;
    'snapshots': the deformed meshes of one run with fields; 'box3d': the 3D box against
    the 2D strip, runs [strip, box]; 'ball': the ball's trace run, then the snapshot run
    ``derive`` makes from its folder) and its runs."""

    key: str
    png: str
    title: str
    kind: str
    runs: list[RunSpec]
    note: str = ""
    #: for 'ball': the run made from the first run's outputs (its folder), run after it
    derive: Callable[[str], RunSpec] | None = None


HHT_FAMILY = (  # (scheme, params) of Figs. 2-4
    ("newmark", {"beta": 0.25, "gamma": 0.5}),
    ("hht", {"alpha": 0.0}),
    ("hht", {"alpha": -0.05}),
    ("hht", {"alpha": -0.1}),
    ("newmark", {"beta": 0.3025, "gamma": 0.6}),
)
PC_FAMILY = (  # (scheme, params) of Figs. 5-7
    ("pc", {"beta": 0.25, "gamma": 0.5}),
    ("pc_hht", {"alpha": -0.1}),
    # The seed's literal coefficients (γ = ½ + α < ½): the runs that go unstable after a
    # few impacts, as the seed reports; they stop early, so they cost little.
    ("pc_hht_seed", {"alpha": -0.1}),
)


#: The ball scene of Fig. 9 (its mesh: meshes/ball.geo, meshed in-process at &mesh h).
BALL_SCENE = str(find_scene("ball3d_newmark.nml"))
#: Fig. 9's ball: (mesh size, dt, t_end) of the trace run, quick and full, dropped at
#: BALL_SPEED, the scene's own speed. A faster drop squashes this soft ball (E = 1,
#: ρ = 1, units in which the wave speed is 1: at speed 1 the kinetic energy per volume is
#: half of E) to strains of order 1, where the linear model inverts tetrahedra; at speed
#: 0.1 the compression is a quarter of the radius
#: (Hertz: 0.053) and the contact lasts about 1.3 (Hertz: 1.55), with its largest elastic
#: energy near t = 0.75. T = 1.6 holds the whole contact: the patch grows and shrinks.
#: h = 0.1: 257 tetrahedra, ~3 ms a step; h = 0.05 (the scene's): ~50 ms a step.
BALL_SPEED = 0.1
BALL_QUICK = (0.1, 0.01, 1.6)
BALL_FULL = (0.05, 0.01, 1.6)


def box3d_spec(strip: RunSpec) -> RunSpec:
    """The 3D box (&mesh dim = 3: [0, width]^2 x [0, length] of tetrahedra) with every
    setting of the 2D strip run ``strip`` (same material, h, scheme, Δt, T, outputs)."""
    settings = {"mesh.dim": 3}          # first: the vector keys become 3D
    settings.update(strip.settings)
    return RunSpec(name="box3d_" + strip.name, settings=settings)


def ball_trace_spec(h: float, dt: float, t_end: float, speed: float = BALL_SPEED) -> RunSpec:
    """The ball of :data:`BALL_SCENE` at mesh size h dropped at ``speed``, every step in
    the trace, no fields."""
    return RunSpec(name=f"ball3d_newmark_v{num(speed)}_h{num(h)}_dt{num(dt)}_T{num(t_end)}",
                   base=BALL_SCENE,
                   settings={"mesh.h": float(h), "initial.velocity": f"0.0, 0.0, {-speed!r}",
                             "scheme.dt": float(dt), "scheme.t_end": float(t_end),
                             "output.every": 1, "output.fields_every": 0})


def max_compression(trace: Mapping[str, np.ndarray]) -> int:
    """Row of the ball's maximum compression: the largest elastic energy (the kinetic
    energy is then at its smallest: the ball has stopped and is squeezed the most)."""
    e_el = np.asarray(trace["e_el"], dtype=float)
    if not len(e_el) or not np.isfinite(e_el).any():
        raise ValueError("no elastic energy in the trace")
    return int(np.nanargmax(e_el))


def ball_snapshot_spec(trace_run: RunSpec, run_dir: str) -> RunSpec:
    """The run of ``trace_run`` stopped at its maximum compression (from its trace in
    ``run_dir``), writing the fields there (and at t = 0) only."""
    from ..core import read_trace

    trace = read_trace(run_dir)
    k = max_compression(trace)
    every = int(trace_run.settings.get("output.every", 1))
    steps = k * every                   # the trace has every step (output.every = 1)
    if steps < 1:
        raise ValueError(f"{run_dir}: the elastic energy is largest at t = 0")
    dt = float(trace_run.settings["scheme.dt"])
    settings = dict(trace_run.settings)
    settings.update({"scheme.t_end": round(steps * dt, 12), "output.fields_every": steps})
    return RunSpec(name=f"{trace_run.name}_snapshot_step{steps}", base=trace_run.base,
                   settings=settings)


#: The body of Figs. 1-7, as their titles name it.
SEED_BAR = "seed 2D bar [0, 0.1] × [0, 1]"


def figure_plan(quick: bool = False) -> list[FigureSpec]:
    """The seed's Figures 1-7 (SPEC section 2) and the 3D Figures 8-9.

    Full: Fig. 1 trapezoidal rule (newmark ¼ ½), h = 0.02, Δt = 0.001, T = 3 with 11
    snapshots; Figs. 2-4 the HHT family at h = 0.05, 0.02, 0.01 (Δt = h/20, T = 15);
    Figs. 5-7 pc, pc_hht (α = -0.1) and pc_hht_seed (α = -0.1, the seed's literal
    coefficients) at the same meshes with Δt = h/100 and h/20.
    Fig. 8: the 3D box against the 2D strip, HHT α = 0 (the trapezoidal rule), h = 0.05,
    Δt = h/20, T as Figs. 2-7 (the strip is Fig. 2's run). Fig. 9: the ball
    (:data:`BALL_FULL`, quick :data:`BALL_QUICK`) at its maximum compression.
    Quick (for the test suite): the same figures with h = 0.1 and 0.05 only (Figs. 4
    and 7 repeat h = 0.05), T = 3, Fig. 1 at h = 0.05, Δt = h/20.
    """
    if quick:
        meshes, t_end = (0.1, 0.05, 0.05), 3.0
        f1_h, f1_dt = 0.05, 0.0025
    else:
        meshes, t_end = (0.05, 0.02, 0.01), 15.0
        f1_h, f1_dt = 0.02, 0.001
    f1_t = 3.0
    f1_steps = math.ceil(f1_t / f1_dt - 1e-9)
    figs = [FigureSpec(
        key="fig1", png="fig1_field.png", kind="snapshots",
        title=f"Fig. 1: displacement of the {SEED_BAR} over the first period, trapezoidal "
              f"rule (newmark β=0.25, γ=0.5), h={num(f1_h)}, Δt={num(f1_dt)}",
        runs=[seed_spec("newmark", f1_h, f1_dt, f1_t, beta=0.25, gamma=0.5,
                        fields_every=max(1, round(f1_steps / 10)), prefix="fields_")],
        note="VTU snapshots and the ParaView index: runs/{run}/fields.pvd")]
    for k, h in enumerate(meshes):
        dt = h / 20
        repeat = quick and k > 0 and h == meshes[k - 1]
        figs.append(FigureSpec(
            key=f"fig{2 + k}", png=f"fig{2 + k}_hht_family.png", kind="traces",
            title=f"Fig. {2 + k}: HHT family on the {SEED_BAR}, h={num(h)}, "
                  f"Δt=h/20={num(dt)}, T={num(t_end)}",
            runs=[seed_spec(s, h, dt, t_end, **p) for s, p in HHT_FAMILY],
            note="quick mode: the same mesh as the previous figure" if repeat else ""))
    for k, h in enumerate(meshes):
        repeat = quick and k > 0 and h == meshes[k - 1]
        runs = [seed_spec(s, h, h / div, t_end, **p)
                for div in (100, 20) for s, p in PC_FAMILY]
        figs.append(FigureSpec(
            key=f"fig{5 + k}", png=f"fig{5 + k}_predictor_corrector.png", kind="traces",
            title=f"Fig. {5 + k}: predictor-corrector on the {SEED_BAR}, h={num(h)}, "
                  f"Δt=h/100 and h/20, T={num(t_end)}",
            runs=runs,
            note="quick mode: the same mesh as the previous figure" if repeat else ""))
    h3 = 0.05
    strip = seed_spec("hht", h3, h3 / 20, t_end, alpha=0.0)
    figs.append(FigureSpec(
        key="fig8", png="fig8_box3d_vs_strip2d.png", kind="box3d",
        title=f"Fig. 8: 3D box (P1 tetrahedra) against the 2D plane-strain strip, same "
              f"material, h={num(h3)}, hht α=0, Δt={num(h3 / 20)}, T={num(t_end)}",
        runs=[strip, box3d_spec(strip)]))
    bh, bdt, bt = BALL_QUICK if quick else BALL_FULL
    ball = ball_trace_spec(bh, bdt, bt)
    figs.append(FigureSpec(
        key="fig9", png="fig9_ball_snapshot.png", kind="ball",
        title=f"Fig. 9: elastic ball (meshes/ball.geo, h={num(bh)}) dropped at "
              f"speed {num(BALL_SPEED)}, "
              f"newmark β=¼ γ=½, Δt={num(bdt)}: maximum compression",
        runs=[ball], derive=lambda d, run=ball: ball_snapshot_spec(run, d),
        note="the snapshot run stops at the trace run's maximum compression (largest "
             "e_el) and writes the fields there: runs/{run}_snapshot*/fields.pvd"))
    return figs


def plot_figure(fig: FigureSpec, runs_root: str, out_png: str) -> dict[str, Any]:
    """Draw one figure from its runs' folders (those that left a trace); never raises."""
    t0 = time.perf_counter()
    dirs = [os.path.join(runs_root, r.name) for r in fig.runs]
    dirs = [d for d in dirs if os.path.isfile(os.path.join(d, "trace.csv"))]
    try:
        if not dirs:
            raise RuntimeError("no run of this figure left a trace")
        from .. import plotting

        data = None
        if fig.kind == "snapshots":
            plotting.plot_field_snapshots(dirs[0], out_png, title=fig.title)
        elif fig.kind in ("box3d", "ball"):
            if len(dirs) != len(fig.runs):
                raise RuntimeError("not every run of this figure left a trace")
            draw = plot_box_vs_strip if fig.kind == "box3d" else plot_ball_snapshot
            data = draw(dirs[0], dirs[1], out_png, title=fig.title)
        else:
            plotting.plot_traces(dirs, out_png, title=fig.title)
    except Exception as exc:  # noqa: BLE001
        return {"key": fig.key, "ok": False, "message": f"{type(exc).__name__}: {exc}",
                "wall_s": time.perf_counter() - t0}
    out = {"key": fig.key, "ok": True, "message": "", "wall_s": time.perf_counter() - t0}
    if data is not None:
        out["data"] = data
    return out


# --------------------------------------------------------------------------- 3D figures

def _first_contact(trace: Mapping[str, np.ndarray]) -> float | None:
    """Time of the first row with a contact stress at the probe (p_n < 0)."""
    hit = np.nonzero(np.asarray(trace["p_n"]) < 0.0)[0]
    return float(trace["t"][hit[0]]) if len(hit) else None


def plot_box_vs_strip(strip_dir: str, box_dir: str, out_png: str | None,
                      title: str = "") -> dict[str, Any]:
    """Fig. 8: u_n, p_n and e_total/e_total(0) at the probe of the 2D strip run and of the
    3D box run (same scheme, Δt and output rows), one panel each, one legend under them
    (the runs, their dofs and e_total(0)). Returns what is drawn:
    per run its run folder name, dofs, e_total(0), min u_n, min p_n, the first contact and
    e_total(T)/e_total(0); and the largest |box - strip| of u_n and p_n over their common
    rows."""
    from ..core import read_summary, read_trace

    runs = []
    for d, label in ((strip_dir, "2D strip (plane strain)"), (box_dir, "3D box")):
        tr, sm = read_trace(d), read_summary(d)
        if not len(tr.get("t", ())):
            raise ValueError(f"{d}: empty trace")
        runs.append((tr, sm, f"{label}, {sm.get('dofs', '?')} dofs", os.path.basename(d)))
    fig, axes = new_figure(1, 3, 4.6, 3.6)
    ax_u, ax_p, ax_e = axes[0]
    data: dict[str, Any] = {}
    # the strip's energy is per unit thickness, the box's of the whole body (width 0.1)
    per = {"strip": " per unit thickness", "box": ""}
    for (tr, sm, label, name), key, style in zip(runs, ("strip", "box"), ("-", "--")):
        t, e = tr["t"], tr["e_total"]
        ax_u.plot(t, tr["u_n"], style, lw=1.0, label=label)
        ax_p.plot(t, tr["p_n"], style, lw=1.0, label=label)
        ax_e.plot(t, e / e[0], style, lw=1.0,
                  label=f"{label}, e_total(0) = {e[0]:.4g}{per[key]}")
        data[key] = {"run": name, "dofs": sm.get("dofs"), "status": sm.get("status"),
                     "rows": int(len(t)), "e0": float(e[0]),
                     "u_n_min": float(np.min(tr["u_n"])), "u_n_max": float(np.max(tr["u_n"])),
                     "p_n_min": float(np.min(tr["p_n"])),
                     "first_contact": _first_contact(tr),
                     "e_end_ratio": float(e[-1] / e[0])}
    (a, *_), (b, *_) = runs
    n = min(len(a["t"]), len(b["t"]))
    if n and not np.allclose(a["t"][:n], b["t"][:n], rtol=0, atol=1e-12):
        raise ValueError("the strip and the box were written at different times")
    data["common_rows"] = int(n)
    data["max_abs_du_n"] = float(np.max(np.abs(a["u_n"][:n] - b["u_n"][:n])))
    data["max_abs_dp_n"] = float(np.max(np.abs(a["p_n"][:n] - b["p_n"][:n])))
    for ax, ylabel in ((ax_u, "u_n at the probe"), (ax_p, "p_n at the probe"),
                       (ax_e, "e_total / e_total(0)")):
        ax.set_xlabel("t")
        ax.set_ylabel(ylabel)
        ax.grid(True, alpha=0.3)
    # one legend under the panels: in each panel ('best' place) it would cover the curves,
    # which fill the panels (u_n's dips, the energy's spikes)
    fig.legend(*ax_e.get_legend_handles_labels(), loc="lower center", ncols=2,
               fontsize=8, frameon=False)
    ax_u.set_title(f"max |Δu_n| = {data['max_abs_du_n']:.3g}", fontsize=9)
    ax_p.set_title(f"max |Δp_n| = {data['max_abs_dp_n']:.3g}", fontsize=9)
    ax_e.set_title("energy relative to its start", fontsize=9)
    fig.suptitle(title, fontsize=9)
    if out_png:
        save_figure(fig, out_png, rect=(0, 0.35 / fig.get_figheight(), 1,
                                        1 - 0.3 / fig.get_figheight()))
    else:
        import matplotlib.pyplot as plt

        plt.close(fig)
    return data


def von_mises(x: np.ndarray, tets: np.ndarray, u: np.ndarray, young: float,
              poisson: float) -> np.ndarray:
    """Von Mises stress of each P1 tetrahedron (constant on it): grad u from its four
    nodes, ε its symmetric part, σ = λ tr(ε) I + 2μ ε, σ_vm = (3/2 s:s)^(1/2) with s the
    deviator of σ. x, u: (n, 3); tets: (m, 4) 0-based."""
    x, u = np.asarray(x, dtype=float), np.asarray(u, dtype=float)
    tets = np.asarray(tets, dtype=np.int64)
    dx = x[tets[:, 1:]] - x[tets[:, :1]]            # (m, 3 edges, 3 coords)
    du = u[tets[:, 1:]] - u[tets[:, :1]]
    # rows of dx are the edges: du = dx grad(u)^T, so grad(u)^T = dx^-1 du
    grad_t = np.linalg.solve(dx, du)                # (m, 3, 3): [j, i] = d u_i / d x_j
    eps = 0.5 * (grad_t + np.swapaxes(grad_t, 1, 2))
    lam = young * poisson / ((1 + poisson) * (1 - 2 * poisson))
    mu = young / (2 * (1 + poisson))
    tr = np.trace(eps, axis1=1, axis2=2)
    sig = 2 * mu * eps + (lam * tr)[:, None, None] * np.eye(3)
    dev = sig - (np.trace(sig, axis1=1, axis2=2) / 3.0)[:, None, None] * np.eye(3)
    return np.sqrt(1.5 * np.sum(dev * dev, axis=(1, 2)))


def mid_plane_cut(x: np.ndarray, tets: np.ndarray, u: np.ndarray, axis: int = 1,
                  value: float = 0.0) -> tuple[list[np.ndarray], np.ndarray]:
    """The tetrahedra cut by the plane x[axis] = value (in the reference configuration):
    for each cut tetrahedron its section, a triangle or a quadrangle, as the deformed
    positions (x + u, the two other coordinates in order) of the points where its edges
    cross the plane, ordered around their centre. Returns (polygons, indices of the cut
    tetrahedra)."""
    x, u = np.asarray(x, dtype=float), np.asarray(u, dtype=float)
    keep = [c for c in range(3) if c != axis]
    d = x[:, axis] - value
    polys, which = [], []
    edges = ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))
    side = d[tets] >= 0.0
    cut = np.nonzero(side.any(axis=1) & ~side.all(axis=1))[0]
    for c in cut:
        nodes = tets[c]
        pts = []
        for i, j in edges:
            a, b = nodes[i], nodes[j]
            if (d[a] >= 0.0) == (d[b] >= 0.0):
                continue
            s = d[a] / (d[a] - d[b])
            p = (x[a] + u[a]) + s * ((x[b] + u[b]) - (x[a] + u[a]))
            pts.append(p[keep])
        pts = np.array(pts)
        centre = pts.mean(axis=0)
        pts = pts[np.argsort(np.arctan2(pts[:, 1] - centre[1], pts[:, 0] - centre[0]))]
        polys.append(pts)
        which.append(c)
    return polys, np.array(which, dtype=np.int64)


def hertz(radius: float, young: float, poisson: float, density: float,
          speed: float) -> dict[str, float]:
    """Hertz's quasi-static impact of an elastic sphere on a rigid plane: the contact time
    2.868 (m^2 / (R E*^2 v))^(1/5), the largest approach (15 m v^2 / (16 E* R^(1/2)))^(2/5)
    and the patch radius (R δ)^(1/2) then, with m the sphere's mass and
    E* = E / (1 - ν^2)."""
    mass = density * 4.0 / 3.0 * np.pi * radius ** 3
    e_star = young / (1.0 - poisson ** 2)
    delta = (15.0 * mass * speed ** 2 / (16.0 * e_star * np.sqrt(radius))) ** 0.4
    return {"t_contact": float(2.868 * (mass ** 2 / (radius * e_star ** 2 * speed)) ** 0.2),
            "delta_max": float(delta), "patch_radius": float(np.sqrt(radius * delta))}


def _boundary_faces(tets: np.ndarray) -> np.ndarray:
    """Faces (triangles) of exactly one tetrahedron: the mesh's surface."""
    faces = np.concatenate([tets[:, [0, 1, 2]], tets[:, [0, 1, 3]], tets[:, [0, 2, 3]],
                            tets[:, [1, 2, 3]]])
    key = np.sort(faces, axis=1)
    _, idx, count = np.unique(key, axis=0, return_index=True, return_counts=True)
    return faces[idx[count == 1]]


def plot_ball_snapshot(trace_dir: str, snap_dir: str, out_png: str | None,
                       title: str = "") -> dict[str, Any]:
    """Fig. 9 from the ball's trace run and its snapshot run (stopped at the trace's
    maximum compression, :func:`max_compression`): the energies and the contact points
    over time with that instant marked; the deformed ball cut by its vertical mid-plane
    y = y_centre, coloured by the von Mises stress; the contact patch seen from below
    (the deformed lower surface coloured by its height z above the plane, the line
    z = 0, the surface nodes at or below it). Returns what is drawn (times, energies,
    stresses, patch)."""
    import meshio
    from matplotlib.collections import PolyCollection
    from matplotlib.tri import Triangulation

    from ..core import read_summary, read_trace
    from ..plotting import read_pvd

    tr = read_trace(trace_dir)
    k = max_compression(tr)
    t_star = float(tr["t"][k])
    sets = read_pvd(os.path.join(snap_dir, "fields.pvd"))
    if not sets:
        raise ValueError(f"{snap_dir}: no field snapshot")
    t_snap, vtu = sets[-1]
    dt = float(tr["t"][1] - tr["t"][0]) if len(tr["t"]) > 1 else 1.0
    if abs(t_snap - t_star) > 1e-6 * dt:
        raise ValueError(f"{vtu}: snapshot at t={t_snap:.6g}, not at the maximum "
                         f"compression t={t_star:.6g}")
    snap_tr = read_trace(snap_dir)
    scene = read_summary(snap_dir).get("scene") or {}
    mat = scene.get("material", {})
    young, poisson = float(mat.get("young", 1.0)), float(mat.get("poisson", 0.3))
    contact = scene.get("contact", {})
    plane_z = float((contact.get("obstacle_point") or [0.0, 0.0, 0.0])[2])

    m = meshio.read(vtu)
    tets = np.asarray(m.cells_dict.get("tetra", np.zeros((0, 4))), dtype=np.int64)
    if not len(tets):
        raise ValueError(f"{vtu}: no tetrahedra")
    x = np.asarray(m.points, dtype=float)
    u = np.asarray(m.point_data["displacement"], dtype=float)
    vm = von_mises(x, tets, u, young, poisson)
    y_mid = 0.5 * float(x[:, 1].min() + x[:, 1].max())
    z_mid = 0.5 * float(x[:, 2].min() + x[:, 2].max())
    polys, cut = mid_plane_cut(x, tets, u, axis=1, value=y_mid)
    surf = _boundary_faces(tets)
    lower = surf[np.all(x[surf, 2] < z_mid, axis=1)]
    xd = x + u
    gap = xd[:, 2] - plane_z
    low_nodes = np.unique(lower)
    touching = low_nodes[gap[low_nodes] <= 0.0]
    centre_xy = xd[low_nodes][:, :2].mean(axis=0) if len(low_nodes) else np.zeros(2)
    radius = float(np.max(np.hypot(*(xd[touching][:, :2] - centre_xy).T)))         if len(touching) else 0.0

    # the approach of the centre of mass towards the plane since the first touch
    vol = np.abs(np.linalg.det(x[tets[:, 1:]] - x[tets[:, :1]])) / 6.0
    uz_mean = float(np.sum(vol * u[tets, 2].mean(axis=1)) / np.sum(vol))
    gap0 = float(x[:, 2].min() - plane_z)
    radius0 = 0.5 * float(x[:, 2].max() - x[:, 2].min())
    speed = float(np.linalg.norm((scene.get("initial") or {}).get("velocity") or [0.0]))
    on = np.nonzero(np.asarray(tr["active"]) > 0)[0]
    fig, axes = new_figure(1, 3, 4.6, 4.0)
    ax_t, ax_c, ax_p = axes[0]
    t = tr["t"]
    for col, style in (("e_kin", "-"), ("e_el", "-"), ("e_total", "k--")):
        ax_t.plot(t, tr[col], style, lw=1.0, label=col)
    ax_t.axvline(t_star, color="r", lw=0.8, ls=":")
    ax_t.set_xlabel("t")
    ax_t.set_ylabel("energy")
    ax_a = ax_t.twinx()
    ax_a.plot(t, tr["active"], color="0.6", lw=0.8, label="active contact points")
    ax_a.set_ylabel("active contact points", color="0.4")
    h1, l1 = ax_t.get_legend_handles_labels()
    h2, l2 = ax_a.get_legend_handles_labels()
    # the legend in a band kept free above the curves (each scale's top raised by 45 % of
    # its range): anywhere inside the curves' range it would cover e_kin, e_el or the active
    # points
    for ax in (ax_t, ax_a):
        lo, hi = ax.get_ylim()
        ax.set_ylim(lo, hi + 0.45 * (hi - lo))
    ax_t.legend(h1 + h2, l1 + l2, fontsize=6, loc="upper center", ncols=2, framealpha=0.6)
    ax_t.set_title(f"maximum compression at t={t_star:.3g} (largest e_el)", fontsize=9)

    vm_cut = vm[cut]
    pc = PolyCollection(polys, array=vm_cut, cmap="viridis", edgecolors="k",
                        linewidths=0.2)
    ax_c.add_collection(pc)
    xs = np.concatenate([p[:, 0] for p in polys]) if polys else np.zeros(1)
    zs = np.concatenate([p[:, 1] for p in polys]) if polys else np.zeros(1)
    pad = 0.05 * float(max(np.ptp(xs), np.ptp(zs), 1e-9))
    ax_c.set_xlim(xs.min() - pad, xs.max() + pad)
    ax_c.set_ylim(min(zs.min(), plane_z) - pad, zs.max() + pad)
    ax_c.axhline(plane_z, color="k", lw=1.2)
    ax_c.set_aspect("equal")
    ax_c.set_xlabel("x")
    ax_c.set_ylabel("z")
    fig.colorbar(pc, ax=ax_c, label="von Mises stress", shrink=0.8)
    ax_c.set_title(f"deformed section y={y_mid:.3g}, t={t_snap:.3g}", fontsize=9)

    if len(lower):
        tri = Triangulation(xd[:, 0], xd[:, 1], lower)
        im = ax_p.tripcolor(tri, gap, shading="gouraud", cmap="magma",
                            vmin=float(min(gap[low_nodes].min(), 0.0)),
                            vmax=float(np.percentile(gap[low_nodes], 60)))
        ax_p.triplot(tri, color="w", lw=0.2, alpha=0.5)
        if gap[low_nodes].min() < 0.0 < gap[low_nodes].max():
            ax_p.tricontour(tri, gap, levels=[0.0], colors="c", linewidths=1.0)
        ax_p.plot(xd[touching, 0], xd[touching, 1], "c.", ms=4)
        fig.colorbar(im, ax=ax_p, label="height above the plane", shrink=0.8)
    ax_p.set_aspect("equal")
    ax_p.set_xlabel("x")
    ax_p.set_ylabel("y")
    ax_p.set_title(f"contact patch from below: {len(touching)} nodes on the plane, "
                   f"radius {radius:.3g}", fontsize=9)
    fig.suptitle(title, fontsize=9)
    if out_png:
        save_figure(fig, out_png, top=1 - 0.3 / fig.get_figheight())
    else:
        import matplotlib.pyplot as plt

        plt.close(fig)
    return {"t_star": t_star, "row": k, "e_el_max": float(tr["e_el"][k]),
            "e_kin_at_max": float(tr["e_kin"][k]), "active_at_max": int(tr["active"][k]),
            "snapshot_t": float(t_snap), "snapshot_vtu": os.path.relpath(vtu, snap_dir),
            "snapshot_e_el": float(snap_tr["e_el"][-1]) if len(snap_tr["t"]) else None,
            "tets": int(len(tets)), "cut_tets": int(len(cut)),
            "von_mises_max": float(vm.max()), "von_mises_cut_max": float(vm_cut.max())
            if len(vm_cut) else None,
            "contact_nodes": int(len(touching)), "patch_radius": radius,
            "min_gap": float(gap[low_nodes].min()) if len(low_nodes) else None,
            "young": young, "poisson": poisson, "radius": radius0, "speed": speed,
            "approach": -uz_mean - gap0,
            "contact_start": float(tr["t"][on[0]]) if len(on) else None,
            "contact_end": float(tr["t"][on[-1]]) if len(on) else None,
            "hertz": hertz(radius0, young, poisson, float(mat.get("density", 1.0)), speed)
            if speed > 0 else None}


# --------------------------------------------------------------------------- the runs

def _run_line(rec: Mapping[str, Any], k: int, n: int) -> str:
    t = rec.get("t_end_reached")
    extra = f" at t={fmt(t, '.4g')}" if rec["status"] != "ok" and t is not None else ""
    msg = f" ({rec['message']})" if rec["status"] in (ERROR, REFUSED) else ""
    cached = " (cache)" if rec.get("cached") else ""
    return (f"[{k:>{len(str(n))}}/{n}] {rec['name']}: {rec['status']}{extra}, "
            f"{rec.get('steps') or 0} steps, {fmt(rec.get('wall_s'), '.2f')} s{cached}{msg}")


def _relocate(entry: str, folder: str) -> None:
    """Copy a cache entry's run outputs into folder (emptied first); the copy's
    summary.json names folder as its output.dir, where the run's outputs now are."""
    if os.path.isdir(folder):
        shutil.rmtree(folder)
    shutil.copytree(entry, folder, ignore=shutil.ignore_patterns("record.json",
                                                                  "arrays.npz"))
    path = os.path.join(folder, "summary.json")
    if not os.path.isfile(path):
        return
    with open(path, encoding="utf-8") as f:
        text = f.read()
    try:
        old = json.loads(text)["scene"]["output"]["dir"]
    except (ValueError, KeyError, TypeError):
        return
    new = text.replace(json.dumps(old), json.dumps(folder))
    if new != text:
        with open(path, "w", encoding="utf-8") as f:
            f.write(new)


def _figure_record(spec: RunSpec, rec: Mapping[str, Any], out_dir: str) -> dict[str, Any]:
    """The index's record of a figure run, from the sweep's record."""
    m = rec.get("metrics") or {}
    out = {"name": spec.name, "out_dir": out_dir, "status": rec["status"],
           "message": rec.get("message") or "", "steps": rec.get("steps"),
           "t_end_reached": rec.get("t_end_reached"), "wall_s": rec.get("wall_s"),
           "wall_measured_s": rec.get("wall_measured_s"),
           "newton_its_total": rec.get("newton_its_total"),
           "factorizations": m.get("factorizations"), "dofs": m.get("dofs"),
           "elements": m.get("elements"), "rows": m.get("rows", 0),
           "settings": dict(spec.settings), "base": spec.base}
    if m:
        out.update(isa=m.get("isa"), solve_kernel=m.get("solve_kernel"))
    out["cached"] = bool(rec.get("cached"))
    return out


def make_figures(out_root: str, quick: bool = False, workers: int | None = None,
                 scheduler: Any = None, cache: str | None = None,
                 log: Callable[[str], None] | None = print) -> dict[str, Any]:
    """Run every figure's runs on the sweep runner (``workers`` processes, default all
    cores, or the Dask ``scheduler``; cached in ``cache``, default out_root/cache), copy
    each run's outputs into out_root/runs/<name>/, draw each figure as soon as its runs
    are done, and write out_root/index.md and index.json.

    Returns the report (also index.json): figures (key, png, title, runs' records, plot
    status), total wall_s, jobs (the local pool's processes; None on Dask), and the sum
    of the runs' wall times.
    """
    t_start = time.perf_counter()
    started = datetime.datetime.now().astimezone()
    load0 = loadavg()
    out_root = os.path.abspath(out_root)
    runs_root = os.path.join(out_root, "runs")
    os.makedirs(runs_root, exist_ok=True)
    cache = os.path.abspath(cache or os.path.join(out_root, "cache"))
    plan = figure_plan(quick)
    unique: dict[str, RunSpec] = {}
    for fig in plan:
        for r in fig.runs:
            if r.name in unique and unique[r.name].settings != r.settings:
                raise ValueError(f"two different runs named {r.name}")
            unique.setdefault(r.name, r)
    specs = list(unique.values())
    jobs = None if scheduler is not None else (workers or os.cpu_count() or 1)
    records: dict[str, dict[str, Any]] = {}
    plots: dict[str, dict[str, Any]] = {}
    waiting = {fig.key: {r.name for r in fig.runs} for fig in plan}
    by_key = {fig.key: fig for fig in plan}
    if log:
        where = f"the Dask scheduler {scheduler}" if jobs is None else f"{jobs} worker(s)"
        log(f"figures: {len(specs)} runs for {len(plan)} figures on {where} -> {out_root}")

    def draw(fig: FigureSpec) -> None:
        plots[fig.key] = plot_figure(fig, runs_root, os.path.join(out_root, fig.png))
        if log:
            state = "written" if plots[fig.key]["ok"] else \
                f"FAILED: {plots[fig.key]['message']}"
            log(f"figures: {fig.png} {state} ({plots[fig.key]['wall_s']:.1f} s)")

    # This process copies each run out of the cache and draws each figure as soon as its
    # runs are done (matplotlib is imported once, here; the drawing overlaps the runs).
    # A figure with a derived run (the ball's snapshot) waits for the second sweep.
    derived: list[FigureSpec] = []

    def finish(spec: RunSpec, rec: dict[str, Any]) -> None:
        out_dir = os.path.join(runs_root, spec.name)
        if rec.get("run_dir"):
            _relocate(rec["run_dir"], out_dir)
        records[spec.name] = _figure_record(spec, rec, out_dir)
        if log:
            log(_run_line(records[spec.name], len(records), len(specs)))
        for key, names in waiting.items():
            if spec.name in names:
                names.discard(spec.name)
                if not names:
                    fig = by_key[key]
                    if fig.derive is not None and len(fig.runs) == len(plan_runs[key]):
                        derived.append(fig)
                    else:
                        draw(fig)

    plan_runs = {fig.key: list(fig.runs) for fig in plan}
    sweep([s.task() for s in specs], cache, workers=workers, scheduler=scheduler,
          progress=False, desc="figures", log=log, on_done=lambda i, rec: finish(specs[i], rec))
    more: list[RunSpec] = []
    for fig in derived:
        try:
            spec = fig.derive(os.path.join(runs_root, fig.runs[0].name))
        except Exception as exc:  # noqa: BLE001 - the figure is reported as not drawn
            plots[fig.key] = {"key": fig.key, "ok": False, "wall_s": 0.0,
                              "message": f"{type(exc).__name__}: {exc}"}
            continue
        fig.runs.append(spec)
        waiting[fig.key] = {spec.name}
        specs.append(spec)
        more.append(spec)
    if more:
        sweep([s.task() for s in more], cache, workers=workers, scheduler=scheduler,
              progress=False, desc="figures (derived runs)", log=log,
              on_done=lambda i, rec: finish(more[i], rec))
    wall = time.perf_counter() - t_start
    report = {
        "quick": bool(quick),
        "started": started.isoformat(timespec="seconds"),
        "wall_s": wall,
        "jobs": jobs,
        "cpu_count": os.cpu_count(),
        "loadavg_start": load0,
        "loadavg_end": loadavg(),
        "version": package_version(),
        "runs_wall_sum_s": sum(float(r.get("wall_measured_s") or 0) for r in records.values()),
        "plots_wall_sum_s": sum(float(p.get("wall_s") or 0) for p in plots.values()),
        "figures": [],
        "runs": [records[s.name] for s in sorted(specs, key=lambda s: s.name)
                 if s.name in records],
    }
    for fig in plan:
        report["figures"].append({
            "key": fig.key, "png": fig.png, "title": fig.title, "kind": fig.kind,
            "note": fig.note.format(run=fig.runs[0].name) if fig.note else "",
            "runs": [r.name for r in fig.runs],
            "plot": plots.get(fig.key, {"ok": False, "message": "not drawn"}),
        })
    write_index(out_root, report)
    if log:
        n_bad = sum(1 for f in report["figures"] if not f["plot"]["ok"])
        n_cached = sum(1 for r in records.values() if r["cached"])
        log(f"figures: {len(plan) - n_bad}/{len(plan)} figures, {len(specs)} runs "
            f"({n_cached} from the cache) in {wall:.1f} s wall (runs: "
            f"{report['runs_wall_sum_s']:.1f} s summed) -> "
            f"{os.path.join(out_root, 'index.md')}")
    return report


def write_index(out_root: str, report: Mapping[str, Any]) -> str:
    """out_root/index.md (figures, each run's status, steps and wall time, the total
    wall time and where it went) and out_root/index.json (the report). Returns the
    path of index.md."""
    recs = {r["name"]: r for r in report["runs"]}
    lines = [
        "# dyncontact: the seed's figures and the 3D figures",
        "",
        f"Generated by `scripts/figures{' --quick' if report.get('quick') else ''}` on "
        f"{report.get('started', '?')} (dyncontact {report.get('version', '?')}).",
        "",
        f"**Total wall time: {report['wall_s']:.1f} s** for {len(recs)} runs and "
        f"{len(report['figures'])} figures on "
        f"{_where(report)} "
        f"({report.get('cpu_count')} cores; load average at start "
        f"{report.get('loadavg_start')}, at the end {report.get('loadavg_end')}). "
        f"Runs: {report['runs_wall_sum_s']:.1f} s summed over the runs "
        f"(each measured around `dyncontact.run`); plots: "
        f"{report.get('plots_wall_sum_s', 0.0):.1f} s summed.",
        "",
        "Status `unstable`: the run tripped `&scheme blowup` and stopped (docs/scenes.md, "
        "*The blow-up test*); its "
        "curve ends there, marked with an x and a dotted vertical line.",
        "",
    ]
    for fig in report["figures"]:
        lines += [f"## {fig['title']}", ""]
        if fig["plot"]["ok"]:
            lines += [f"![{fig['key']}]({fig['png']})", ""]
        else:
            lines += [f"**Figure not drawn:** {fig['plot'].get('message', '')}", ""]
        if fig.get("note"):
            lines += [fig["note"], ""]
        data = fig["plot"].get("data") if fig["plot"].get("ok") else None
        if data:
            lines += ["Values drawn (index.json, plot.data): " + _data_text(data), ""]
        lines += ["| run | scheme | Δt | status | steps | t reached | wall s (core) | "
                  "wall s (total) | Newton its | folder |",
                  "|---|---|---|---|---:|---:|---:|---:|---:|---|"]
        for name in fig["runs"]:
            r = recs.get(name)
            if r is None:
                lines.append(f"| {name} | | | not run | | | | | | |")
                continue
            st = f"{r['status']}: {r['message']}" if r["status"] in (ERROR, REFUSED) \
                else r["status"]
            lines.append(
                f"| {name} | {scheme_text(r['settings'], r.get('base'))} | "
                f"{num(r['settings'].get('scheme.dt', 0))} | {st} | {r.get('steps') or 0} | "
                f"{fmt(r.get('t_end_reached'), '.4g')} | {fmt(r.get('wall_s'), '.2f')} | "
                f"{fmt(r.get('wall_measured_s'), '.2f')} | "
                f"{r.get('newton_its_total') if r.get('newton_its_total') is not None else '-'}"
                f" | [runs/{name}](runs/{name}) |")
        lines.append("")
    lines += ["## Where the time goes", "",
              "Runs by wall time (core time loop from summary.json; total = around "
              "`dyncontact.run`, model set-up and trace reading included):", "",
              "| run | dofs | steps | wall s (core) | wall s (total) | µs/step |",
              "|---|---:|---:|---:|---:|---:|"]
    for r in sorted(report["runs"], key=lambda r: -(r.get("wall_measured_s") or 0)):
        us = (1e6 * float(r["wall_s"]) / r["steps"]) if r.get("wall_s") and r.get("steps") \
            else None
        lines.append(f"| {r['name']} | {r.get('dofs') or '-'} | {r.get('steps') or 0} | "
                     f"{fmt(r.get('wall_s'), '.2f')} | {fmt(r.get('wall_measured_s'), '.2f')}"
                     f" | {fmt(us, '.1f')} |")
    lines.append("")
    path = os.path.join(out_root, "index.md")
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(lines))
    with open(os.path.join(out_root, "index.json"), "w", encoding="utf-8") as f:
        json.dump(report, f, indent=1, default=str)
    return path


def _data_text(data: Mapping[str, Any], prefix: str = "") -> str:
    """A figure's drawn values as 'key=value' text (nested dicts flattened)."""
    out = []
    for key, value in data.items():
        if isinstance(value, Mapping):
            out.append(_data_text(value, f"{prefix}{key}."))
        elif isinstance(value, float):
            out.append(f"{prefix}{key}={value:.4g}")
        else:
            out.append(f"{prefix}{key}={value}")
    return ", ".join(out)


def _where(report: Mapping[str, Any]) -> str:
    jobs = report.get("jobs")
    return "a Dask cluster" if jobs is None else f"{jobs} worker process(es)"


def figures_main(argv: Sequence[str] | None = None, root: str | None = None) -> int:
    """``scripts/figures [--quick] [--workers N] [--scheduler ADDRESS] [--cache DIR]
    [--out DIR]`` (the runner's options as ``python -m dyncontact study`` takes them):
    0 when every figure was drawn (unstable runs are results, not failures), 1 otherwise,
    2 on a bad command line, 130 on Ctrl-C or SIGTERM (the pool's workers stopped, the
    finished runs cached)."""
    root = root or os.getcwd()
    p = OneLineParser(prog="scripts/figures", label="figures", description="Regenerate the "
                                "seed's Figures 1-7, the 3D Figures 8-9 (runs in parallel) "
                                "and index.md.")
    p.add_argument("--quick", action="store_true", help="h = 0.1 and 0.05, T = 3 (tests)")
    add_runner_options(p, "--jobs", "-j")
    p.add_argument("--out", default=None, help="output folder (default: ROOT/out/figures)")
    args = p.parse_args(argv)
    if args.workers is not None and args.workers < 1:
        p.error("--workers must be >= 1")
    out = args.out or os.path.join(root, "out", "figures")
    try:
        with sigterm_as_interrupt(), scheduler_timeout(args):
            report = make_figures(out, quick=args.quick, workers=args.workers,
                                  scheduler=args.scheduler, cache=args.cache,
                                  log=lambda s: print(s, flush=True))
    except SchedulerUnreachable as exc:
        print(scheduler_unreachable_line("figures", args, exc), file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("figures: interrupted (finished runs are cached; run the same command "
              "again to resume)", file=sys.stderr)
        return 130
    bad = [f["key"] for f in report["figures"] if not f["plot"]["ok"]]
    errors = [r["name"] for r in report["runs"] if r["status"] in (ERROR, REFUSED)]
    if bad or errors:
        print(f"figures: not drawn: {', '.join(bad) or '-'}; runs that failed to run: "
              f"{', '.join(errors) or '-'}", file=sys.stderr)
        return 1
    return 0
