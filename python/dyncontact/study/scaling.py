"""Scaling sweep: time and memory as the mesh is refined, direct and CG solvers.

Geometries (``--geometry``): the seed's 2D strip (built-in, h = 0.01 to 0.00125, ``--large``
down to 0.000625), a 2D disk (meshes/disk.geo through gmsh, radius 0.1, its whole outline
the contact boundary, dropped at speed 1) and the 3D box [0, 0.1]^2 x [0, 1] of tetrahedra
(built-in, h = 0.05 to 0.00625); each with ``&solver kind`` 'direct' and/or 'cg'
(``--solvers``). Sizes whose estimated dofs exceed ``--max-dofs`` are left out (and
listed in scaling.md as such). For each mesh size h (hht, Δt = 0.0005) the executable is
run as a user runs it, once with 0 steps (the set-up) and once with ``steps`` steps; each child's
CPU time (user + system: the machine is shared, the wall time would count the other
processes) and peak resident memory (/usr/bin/time's max RSS) are recorded. The loop's
time per step is the CPU time of the steps of one open run (:class:`dyncontact.core.Stepper`,
the set-up left out), and the floors (one triangular solve of the factor the run uses,
one SpMV with K_θ) are measured on that run (:meth:`dyncontact.core.Stepper.floors`).
summary.json gives the sizes: the dofs, the stored entries of one matrix (``matrix_nnz``)
and of the factor (``factor_nnz``), and the ordering and kernel of the factorization.
Each size is also run without a contact boundary, which separates the contact
machinery's memory from the rest.

Writes ``scaling.csv``, ``scaling.png`` (log-log, with fitted slopes) and ``scaling.md``
into the output folder. The memory model the table reports, ``model_mb``, is
4 matrices (M, K, K_θ, J0 = M + c K_θ; 8-byte values and 4-byte rows) plus one factor
(8-byte values, 4-byte rows): the target is peak ≤ 1.5 × that (docs/performance.md, "Scaling").
The sweep also runs the same executable on a trivial scene of each geometry and solver (0 steps
on the geometry's coarsest mesh, ``BASE_H``): its peak, ``base_mb``, is the program's fixed
footprint (code, shared libraries, runtime; gmsh's library for the disk), which does not grow
with the problem, and ``peak_over_model_above_base`` = (peak_mb − base_mb) / model_mb is the
memory that grows with the problem against the model. ``peak_over_model`` is kept as it is.

The rows also give the CG iterations per solve (the timed run's mean), so the chart shows
where CG's step time crosses the direct solver's.

Threads (``--threads``, comma-separated settings: ``auto``, ``1``, ``2``): each setting of
the direct solver's triangular solves is run as DYNCONTACT_THREADS (``auto`` leaves the
environment as it is; scripts/bench sets OMP_NUM_THREADS=1, under which ``auto`` is one
thread); CG runs once, with the last setting (it solves on one thread). The CPU time counts
every thread, so each row also has the wall time a step of the same stretches
(``wall_ms_per_step``), the threads the solves used (summary.json ``solve_threads``) and the
setting (``threads``); the floors are wall times of one solve and one SpMV.

    python -m dyncontact.study.scaling --out out/scaling [--geometry strip,disk,box]
        [--solvers direct,cg] [--max-dofs N] [--large] [--steps N] [--threads 1,2]
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from typing import Any, Sequence

from ..mesh_io import find_geo
from .common import (OneLineParser, environment, md_table, mesh_sizes, new_figure,
                     positive, save_figure, slope, write_csv)
from .sweep import child_group, sigterm_as_interrupt

__all__ = ["SIZES", "LARGE", "GEOMETRY_SIZES", "BASE_H", "strip_scene", "scene_text",
           "estimate_dofs", "measure_base", "measure_one", "run_scaling", "main"]

#: The strip's mesh sizes swept by default (2 200 to 129 600 dofs).
SIZES = (0.01, 0.005, 0.0025, 0.00125)
#: The size added by ``--large`` (about 520 000 dofs; minutes and about 2 GB today).
LARGE = 0.000625
DT = 0.0005
#: Sizes of each geometry (the strip's ``--large`` size added on request).
GEOMETRY_SIZES = {
    "strip": SIZES,
    "disk": (0.005, 0.0025, 0.00125, 0.000625, 0.0003125),
    "box": (0.05, 0.025, 0.0125, 0.00625),
}
#: The coarsest mesh of each geometry: its 0-step run measures the fixed footprint (base_mb).
BASE_H = {"strip": 0.1, "disk": 0.05, "box": 0.1}
#: The disk's mesh file.
DISK_GEO = str(find_geo("disk.geo"))

COLUMNS = ["geometry", "solver_kind", "h", "contact", "dofs", "matrix_nnz", "factor_nnz", "solver", "solve_kernel",
           "ordering", "setup_s", "loop_ms_per_step", "solve_ms", "spmv_ms", "step_over_floor",
           "peak_mb", "setup_peak_mb", "model_mb", "peak_over_model", "base_mb",
           "peak_over_model_above_base", "steps", "cg_its_per_solve", "threads",
           "solve_threads", "wall_ms_per_step", "factorization", "blas"]


def estimate_dofs(geometry: str, h: float) -> int:
    """The free dofs of a geometry at mesh size h, before any run (for ``--max-dofs``):
    the strip and the box count their grid nodes less the clamped top; gmsh meshes the
    disk with about 1.19 area / h^2 + 0.78 perimeter / h nodes (area π 0.1^2, perimeter
    2π 0.1; fitted to the meshes at h = 0.01 and 0.005, within 5 % at 0.02)."""
    if geometry == "strip":
        nw, nl = round(0.1 / h), round(1.0 / h)
        return 2 * (nw + 1) * nl
    if geometry == "box":
        nx, nz = round(0.1 / h), round(1.0 / h)
        return 3 * (nx + 1) ** 2 * nz
    if geometry == "disk":
        pi = 3.141592653589793
        return int(2 * (1.19 * pi * 0.01 / h ** 2 + 0.78 * 2 * pi * 0.1 / h))
    raise ValueError(f"unknown geometry {geometry!r}")


def scene_text(geometry: str, h: float, steps: int, contact: bool, out_dir: str,
               solver: str = "direct") -> str:
    """The scene of one row: the strip (see :func:`strip_scene`), the disk (a free disk of
    radius 0.1 whose whole outline may touch the obstacle, its lowest point on the plane
    y = 0.01 at t = 0 and moving into it at speed 1: in contact from the first step) or the 3D box (the
    strip's set-up in 3D); hht with Δt = 0.0005, ``steps`` steps, ``&solver kind`` solver."""
    solver_line = f"&solver kind = '{solver}' /\n"
    if geometry == "strip":
        return strip_scene(h, steps, contact, out_dir) + solver_line
    if geometry == "box":
        return (
            "! Scaling sweep: the 3D box, written by dyncontact.study.scaling.\n"
            f"&mesh file = '', dim = 3, length = 1.0, width = 0.1, h = {h!r} /\n"
            f"&boundary clamped = 'top', contact = '{'bottom' if contact else ''}' /\n"
            "&material young = 0.6666666666666666, poisson = 0.3333333333333333, density = 1.0 /\n"
            "&contact method = 'nitsche', theta = 1, gamma0 = 10.0, obstacle_point = 0.0, 0.0, 0.0,\n"
            "         obstacle_normal = 0.0, 0.0, -1.0, probe = 0.05, 0.05, 0.0 /\n"
            "&initial kind = 'compressed_bar', amplitude = 0.5 /\n"
            f"&scheme name = 'hht', alpha = 0.0, dt = {DT!r}, t_end = {steps * DT!r},"
            " mass = 'consistent' /\n"
            f"&output dir = '{out_dir}', every = 1, fields_every = 0 /\n" + solver_line)
    if geometry == "disk":
        return (
            "! Scaling sweep: the 2D disk (meshes/disk.geo), written by dyncontact.study.scaling.\n"
            f"&mesh file = '{DISK_GEO}', h = {h!r}, width = 0.1 /\n"
            f"&boundary clamped = '', contact = '{'bottom,top' if contact else ''}' /\n"
            "&material young = 0.6666666666666666, poisson = 0.3333333333333333, density = 1.0 /\n"
            "&contact method = 'nitsche', theta = 1, gamma0 = 10.0, obstacle_point = 0.0, 0.01,\n"
            "         obstacle_normal = 0.0, -1.0, probe = 0.0, 0.01 /\n"
            "&initial kind = 'velocity', velocity = 0.0, -1.0 /\n"
            f"&scheme name = 'hht', alpha = 0.0, dt = {DT!r}, t_end = {steps * DT!r},"
            " mass = 'consistent' /\n"
            f"&output dir = '{out_dir}', every = 1, fields_every = 0 /\n" + solver_line)
    raise ValueError(f"unknown geometry {geometry!r}")


def strip_scene(h: float, steps: int, contact: bool, out_dir: str) -> str:
    """The seed's 2D strip at mesh size h, hht with Δt = 0.0005, ``steps`` steps."""
    return (
        "! Scaling sweep: the seed's 2D strip, written by dyncontact.study.scaling.\n"
        f"&mesh file = '', dim = 2, length = 1.0, width = 0.1, h = {h!r} /\n"
        f"&boundary clamped = 'top', contact = '{'bottom' if contact else ''}' /\n"
        "&material young = 0.6666666666666666, poisson = 0.3333333333333333, density = 1.0 /\n"
        "&contact method = 'nitsche', theta = 1, gamma0 = 10.0,\n"
        "         obstacle_point = 0.0, 0.0, obstacle_normal = 0.0, -1.0, probe = 0.05, 0.0 /\n"
        "&initial kind = 'compressed_bar', amplitude = 0.5 /\n"
        f"&scheme name = 'hht', alpha = 0.0, dt = {DT!r}, t_end = {steps * DT!r},"
        " mass = 'consistent' /\n"
        f"&output dir = '{out_dir}', every = 1, fields_every = 0 /\n")


def _run_child(exe: str, scene: str, env: dict[str, str] | None) -> tuple[float, float, int]:
    """(CPU s, peak RSS MB, exit status) of one run of the executable: user + system
    time (on a shared machine the wall time measures the other processes too) and the
    peak, /usr/bin/time's %M when it exists (a child forked from Python keeps Python's
    high-water mark in its ru_maxrss across exec), else os.wait4's ru_maxrss."""
    timer = "/usr/bin/time"
    with tempfile.NamedTemporaryFile("r", suffix=".rss") as rss:
        cmd = [exe, scene]
        if os.access(timer, os.X_OK):
            cmd = [timer, "-f", "%M %U %S", "-o", rss.name] + cmd
        p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                             env=env, start_new_session=True)
        with child_group(p):
            _pid, status, ru = os.wait4(p.pid, 0)
        p.returncode = os.waitstatus_to_exitcode(status)
        cpu = ru.ru_utime + ru.ru_stime
        peak = ru.ru_maxrss / 1024.0
        if cmd[0] == timer:
            text = rss.read().split()
            if len(text) >= 3:
                peak = float(text[-3]) / 1024.0
    return cpu, peak, p.returncode


def measure_base(exe: str, work: str, env: dict[str, str] | None = None, repeats: int = 2,
                 geometry: str = "strip", solver: str = "direct") -> float:
    """The executable's fixed footprint in MB: the peak RSS of the geometry's scene with
    contact on its coarsest mesh (``BASE_H``), 0 steps, the same solver kind and
    environment as the rows. The smallest of ``repeats`` runs is kept: the rows keep their
    largest peak, so peak − base is not made smaller by the noise. The trivial scene's own
    matrices and factor are in it (under 0.1 MB)."""
    h = BASE_H[geometry]
    out = os.path.join(work, f"base_{geometry}_{solver}")
    path = out + ".nml"
    with open(path, "w", encoding="utf-8") as f:
        f.write(scene_text(geometry, h, 0, True, out, solver))
    best = None
    for _ in range(max(1, repeats)):
        _cpu, peak, status = _run_child(exe, path, env)
        if status != 0:
            raise RuntimeError(f"{exe} {path} exited with status {status}")
        best = peak if best is None else min(best, peak)
    return best


def measure_one(exe: str, h: float, contact: bool, steps: int, work: str,
                floors: bool = True, env: dict[str, str] | None = None, repeats: int = 2,
                geometry: str = "strip", solver: str = "direct",
                base_mb: float | None = None, threads: str = "") -> dict[str, Any]:
    """One row of the table (see the module docstring). Each run is repeated ``repeats``
    times: the smallest CPU time is kept (the machine is shared), and the largest peak.
    Small meshes take more steps (up to 2000), so that the loop is not lost in the
    start-up's noise. ``base_mb`` (:func:`measure_base`, None: not measured) gives the
    row's ``base_mb`` and ``peak_over_model_above_base``. ``threads`` ('1', '2': the
    direct solves' DYNCONTACT_THREADS; '' or 'auto': ``env`` as it is) is the row's
    ``threads``."""
    from ..core import read_summary

    if threads in ("1", "2"):
        env = dict(os.environ if env is None else env, DYNCONTACT_THREADS=threads)
    tag = f"{geometry}_h{h:g}_{'c' if contact else 'nc'}_{solver}_t{threads or 'auto'}"
    rows: dict[int, tuple[float, float, int]] = {}
    sums: dict[int, dict[str, Any]] = {}
    if geometry == "strip":
        steps = min(2000, max(steps, int(round(steps * 0.0026 / (h * h * 200.0)))))
    else:
        steps = min(2000, max(steps, int(steps * 20000 / max(1, estimate_dofs(geometry, h)))))
    for n in (0, steps):
        out = os.path.join(work, f"{tag}_{n}")
        path = os.path.join(work, f"{tag}_{n}.nml")
        with open(path, "w", encoding="utf-8") as f:
            f.write(scene_text(geometry, h, n, contact, out, solver))
        best = None
        for _ in range(max(1, repeats)):
            got = _run_child(exe, path, env)
            if got[2] != 0:
                raise RuntimeError(f"{exe} {path} exited with status {got[2]}")
            best = got if best is None else (min(best[0], got[0]), max(best[1], got[1]), 0)
        rows[n] = best
        sums[n] = read_summary(out)
    summary = sums[steps]
    (w0, m0, _), (_w1, m1, _) = rows[0], rows[steps]
    loop_ms, wall_ms, fl = _loop_and_floors(os.path.join(work, f"{tag}_{steps}.nml"),
                                   os.path.join(work, f"{tag}_stepper"), steps, repeats,
                                   int(summary.get("dofs", 1)), floors, env)
    mnnz = summary.get("matrix_nnz")
    fnnz = summary.get("factor_nnz")
    model = None
    if mnnz is not None and fnnz is not None:
        model = (4 * 12.0 * mnnz + 12.0 * fnnz) / 1.0e6
    solve_ms = fl["solve_us"] / 1e3 if fl and fl.get("solve_us") else None
    spmv_ms = fl["spmv_us"] / 1e3 if fl and fl.get("spmv_us") else None
    # CG iterations of the steps' solves (the set-up's solves, Z = J0^-1 P^T, left out)
    d_solves = summary.get("cg_solves", 0) - sums[0].get("cg_solves", 0)
    d_its = summary.get("cg_iterations", 0) - sums[0].get("cg_iterations", 0)
    peak = max(m0, m1)
    return {
        "geometry": geometry, "solver_kind": solver,
        "h": h, "contact": int(contact), "dofs": summary.get("dofs"), "matrix_nnz": mnnz,
        "factor_nnz": fnnz, "solver": summary.get("solver"),
        "solve_kernel": summary.get("solve_kernel"), "ordering": summary.get("ordering", ""),
        "factorization": summary.get("factorization", ""), "blas": summary.get("blas", ""),
        "setup_s": w0, "loop_ms_per_step": loop_ms, "solve_ms": solve_ms, "spmv_ms": spmv_ms,
        "step_over_floor": (loop_ms / (solve_ms + spmv_ms)) if solve_ms and spmv_ms else None,
        "peak_mb": peak, "setup_peak_mb": m0, "model_mb": model,
        "peak_over_model": (peak / model) if model else None, "base_mb": base_mb,
        "peak_over_model_above_base": ((peak - base_mb) / model)
        if model and base_mb is not None else None,
        "steps": steps,
        "cg_its_per_solve": (d_its / d_solves) if d_solves > 0 else None,
        "threads": threads or "auto", "solve_threads": summary.get("solve_threads"),
        "wall_ms_per_step": wall_ms,
    }


def _loop_and_floors(scene: str, out: str, steps: int, repeats: int, dofs: int,
                     floors: bool, env: dict[str, str] | None):
    """(CPU ms per step, wall ms per step, floors) on one open run: the CPU and wall
    times of ``repeats`` stretches of steps // repeats steps (the smallest of each kept:
    the set-up is not in it, and a stretch slowed down by the other processes on the
    machine is dropped), then the floors measured on the same run's factors
    (:meth:`dyncontact.core.Stepper.floors`)."""
    from ..core import Stepper
    from .common import contact_free_by_design

    # the rows without a contact boundary are contact-free by design
    with environment(env), contact_free_by_design():
        with Stepper(scene, out) as st:
            per = max(1, steps // max(1, repeats))
            best = wall = float("inf")
            for _ in range(max(1, repeats)):
                t0, w0 = time.process_time(), time.perf_counter()
                done = st.advance(per)
                if done < 1:
                    break
                best = min(best, (time.process_time() - t0) / done * 1e3)
                wall = min(wall, (time.perf_counter() - w0) / done * 1e3)
            n_rep = max(20, int(2.0e6 / max(1, dofs)))
            fl = st.floors(n_rep=n_rep, batches=5) if floors else None
    return best, wall, fl


def _fmt(x: Any, nd: int = 3) -> str:
    if x is None or x == "":
        return "–"
    if isinstance(x, float):
        return f"{x:.{nd}g}"
    return str(x)


def run_scaling(out: str, sizes: Sequence[float] | None = None, steps: int = 20,
                exe: str | None = None, no_contact: bool = True, floors: bool = True,
                env: dict[str, str] | None = None, repeats: int = 2, log=print,
                geometries: Sequence[str] = ("strip",), solvers: Sequence[str] = ("direct",),
                max_dofs: int | None = None, large: bool = False,
                threads: Sequence[str] = ("auto",)) -> list[dict[str, Any]]:
    """The sweep; writes scaling.csv, scaling.md and scaling.png into ``out``. ``sizes``
    replaces every geometry's own (GEOMETRY_SIZES); runs without contact are made for the
    strip only (``no_contact``); sizes above ``max_dofs`` (estimated) are skipped and
    listed in scaling.md. ``threads``: the settings of the direct solves measured at each
    size, one after another ('auto', '1', '2'); CG runs with the last one only."""
    os.makedirs(out, exist_ok=True)
    if exe is None:
        root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(
            os.path.abspath(__file__)))))
        exe = os.path.join(root, "build", "dyncontact")
    rows = []
    skipped = []
    bases: dict[tuple[str, str], float] = {}
    with tempfile.TemporaryDirectory(prefix="dyncontact-scaling-") as work:
        for geometry in geometries:
            hs = list(sizes) if sizes else list(GEOMETRY_SIZES[geometry])
            if large and not sizes and geometry == "strip":
                hs.append(LARGE)
            for h in hs:
                est = estimate_dofs(geometry, h)
                if max_dofs and est > max_dofs:
                    skipped.append((geometry, h, est))
                    log(f"{geometry} h = {h:g}: about {est} dofs, above --max-dofs {max_dofs}: "
                        "skipped")
                    continue
                for solver in solvers:
                    if (geometry, solver) not in bases:
                        bases[(geometry, solver)] = measure_base(exe, work, env, repeats,
                                                                 geometry, solver)
                        log(f"{geometry} {solver}: fixed footprint (0 steps, h = "
                            f"{BASE_H[geometry]:g}) {_fmt(bases[(geometry, solver)])} MB")
                    contacts = (True, False) if (no_contact and geometry == "strip"
                                                 and solver == solvers[0]) else (True,)
                    settings = list(threads) if solver != "cg" else list(threads)[-1:]
                    for contact, t in ((c, t) for c in contacts for t in settings):
                        r = measure_one(exe, h, contact, steps, work, floors=floors, env=env,
                                        repeats=repeats, geometry=geometry, solver=solver,
                                        base_mb=bases[(geometry, solver)], threads=t)
                        rows.append(r)
                        log(f"{geometry} h = {h:g} {solver} threads {t} ({r['solve_threads']} "
                            f"used) contact = {int(contact)}: dofs "
                            f"{r['dofs']}, set-up {_fmt(r['setup_s'])} s, loop "
                            f"{_fmt(r['loop_ms_per_step'])} ms/step, solve {_fmt(r['solve_ms'])} "
                            f"ms, SpMV {_fmt(r['spmv_ms'])} ms, peak {_fmt(r['peak_mb'])} MB, "
                            f"model {_fmt(r['model_mb'])} MB, above base / model "
                            f"{_fmt(r['peak_over_model_above_base'])}, CG its "
                            f"{_fmt(r['cg_its_per_solve'])}, wall {_fmt(r['wall_ms_per_step'])} "
                            f"ms/step, load average {_load()}")
                        # each row as it comes: a long sweep stopped halfway keeps its rows
                        write_csv(os.path.join(out, "scaling.csv"), rows, COLUMNS)
    write_csv(os.path.join(out, "scaling.csv"), rows, COLUMNS)
    _write_md(out, rows, skipped, max_dofs)
    _plot(out, rows)
    return rows


def _load() -> str:
    try:
        return " ".join(f"{x:.2f}" for x in os.getloadavg())
    except OSError:
        return "?"


def _label(r) -> str:
    """The row's solver kind, with its threads setting when one was given."""
    kind = r.get("solver_kind", "direct")
    t = r.get("threads")
    if t not in (None, "", "auto") and kind != "cg":
        return f"{kind} {int(float(t))}t"
    return kind


def _slopes(rows, key):
    c = [r for r in rows if r["contact"] and r.get(key)]
    return slope([r["dofs"] for r in c], [r[key] for r in c])


def _series(rows):
    """(geometry, solver kind) -> the rows with contact, in order of dofs."""
    out: dict[tuple[str, str], list] = {}
    for r in rows:
        if r["contact"]:
            out.setdefault((r.get("geometry", "strip"), _label(r)), []).append(r)
    return {k: sorted(v, key=lambda r: r["dofs"]) for k, v in out.items()}


def _write_md(out: str, rows, skipped=(), max_dofs=None) -> None:
    head = ["geometry", "solver", "h", "contact", "dofs", "set-up s", "loop ms/step",
            "solve ms", "SpMV ms", "CG its/solve", "peak MB", "model MB", "peak/model",
            "base MB", "(peak − base)/model", "factor nnz", "ordering", "kernel",
            "solve threads", "wall ms/step"]
    body = [[r.get("geometry", "strip"), _label(r), _fmt(r["h"]),
             r["contact"], r["dofs"], _fmt(r["setup_s"]),
             _fmt(r["loop_ms_per_step"]), _fmt(r["solve_ms"]), _fmt(r["spmv_ms"]),
             _fmt(r.get("cg_its_per_solve")),
             _fmt(r["peak_mb"]), _fmt(r["model_mb"]), _fmt(r["peak_over_model"]),
             _fmt(r.get("base_mb")), _fmt(r.get("peak_over_model_above_base")),
             _fmt(r["factor_nnz"]), _fmt(r["ordering"]), _fmt(r["solve_kernel"]),
             _fmt(r.get("solve_threads")), _fmt(r.get("wall_ms_per_step"))]
            for r in rows]
    lines = md_table(head, body)
    lines.append("")
    for (geometry, solver), c in _series(rows).items():
        if len(c) < 2:
            continue
        lines.append(f"Fitted slopes against dofs ({geometry}, {solver}, with contact): " + ", ".join(
            f"{k} {_slopes(c, k):.2f}" for k in ("setup_s", "loop_ms_per_step", "solve_ms",
                                               "spmv_ms", "peak_mb") if _has(c, k)))
        lines.append("")
    blas = sorted({r["blas"] for r in rows if r.get("blas")})
    if blas:
        lines.append("BLAS (the supernodal factorization's): " + "; ".join(blas) + ".")
        lines.append("")
    for geometry, h, est in skipped:
        lines.append(f"Skipped: {geometry} h = {h:g} (about {est} dofs, above --max-dofs "
                     f"{max_dofs}).")
    with open(os.path.join(out, "scaling.md"), "w", encoding="utf-8") as f:
        f.write("\n".join(lines) + "\n")


def _has(c, key) -> bool:
    return sum(1 for r in c if r.get(key)) >= 2


def _plot(out: str, rows) -> None:
    series = _series(rows)
    geometries = []
    for g, _s in series:
        if g not in geometries:
            geometries.append(g)
    if not geometries:
        geometries = ["strip"]
    fig, axes = new_figure(len(geometries), 2, width=5.0)
    for gi, geometry in enumerate(geometries):
        ax_t, ax_m = axes[gi][0], axes[gi][1]
        for (g, solver), c in series.items():
            if g != geometry:
                continue
            style = "--" if solver == "cg" else "-"
            keys = (("loop_ms_per_step", "step (ms)", ax_t), ("solve_ms", "one solve (ms)", ax_t),
                    ("setup_s", "set-up (s)", ax_t), ("peak_mb", "peak RSS (MB)", ax_m))
            if solver.startswith("direct"):
                keys += (("spmv_ms", "one SpMV (ms)", ax_t),
                         ("model_mb", "matrices + factor (MB)", ax_m))
            for key, label, ax in keys:
                pts = [(r["dofs"], r[key]) for r in c if r.get(key)]
                if len(pts) < 2:
                    continue
                sl = slope([p[0] for p in pts], [p[1] for p in pts])
                ax.loglog([p[0] for p in pts], [p[1] for p in pts], style, marker="o",
                          label=f"{solver}: {label}, slope {sl:.2f}")
            # the memory that grows with the problem: the peak above the fixed footprint
            pts = [(r["dofs"], r["peak_mb"] - r["base_mb"]) for r in c
                   if r.get("peak_mb") and r.get("base_mb") is not None
                   and r["peak_mb"] > r["base_mb"]]
            if len(pts) >= 2:
                sl = slope([p[0] for p in pts], [p[1] for p in pts])
                ax_m.loglog([p[0] for p in pts], [p[1] for p in pts], style, marker="s",
                            label=f"{solver}: peak RSS − fixed footprint (MB), slope {sl:.2f}")
        if geometry == "strip":
            nc = [r for r in rows if not r["contact"] and r.get("geometry", "strip") == "strip"]
            pts = [(r["dofs"], r["peak_mb"]) for r in nc if r.get("peak_mb")]
            if len(pts) >= 2:
                sl = slope([p[0] for p in pts], [p[1] for p in pts])
                ax_m.loglog([p[0] for p in pts], [p[1] for p in pts], ":", marker="o",
                            label=f"direct: peak RSS, no contact, slope {sl:.2f}")
        ax_t.set_ylabel("time: ms (step, solve, SpMV), s (set-up)", fontsize=8)
        ax_m.set_ylabel("memory (MB)", fontsize=8)
        for ax, title in ((ax_t, "time"), (ax_m, "memory")):
            ax.set_xlabel("dofs")
            ax.set_title(f"{geometry}, hht, dt = {DT:g}: {title}", fontsize=8)
            if ax.get_legend_handles_labels()[0]:
                ax.legend(fontsize=5)
            ax.grid(True, which="both", alpha=0.3)
    save_figure(fig, os.path.join(out, "scaling.png"))


def replot(out: str, csv_paths: Sequence[str]) -> list[dict[str, Any]]:
    """scaling.md and scaling.png in ``out`` from the rows of earlier sweeps' CSV files
    (e.g. one sweep per geometry, or a sweep stopped halfway: its CSV has every row done)."""
    import csv

    rows = []
    for path in csv_paths:
        with open(path, encoding="utf-8") as f:
            for r in csv.DictReader(f):
                row: dict[str, Any] = {}
                for k, v in r.items():
                    if v in ("", None):
                        row[k] = None
                        continue
                    try:
                        if k == "threads":
                            row[k] = v
                            continue
                        row[k] = int(v) if k in ("contact", "dofs", "steps", "matrix_nnz",
                                                 "factor_nnz", "solve_threads") else float(v)
                    except ValueError:
                        row[k] = v
                rows.append(row)
    os.makedirs(out, exist_ok=True)
    write_csv(os.path.join(out, "scaling.csv"), rows, COLUMNS)
    _write_md(out, rows)
    _plot(out, rows)
    return rows


def main(argv: Sequence[str] | None = None) -> int:
    ap = OneLineParser(prog="scripts/bench --scaling", description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="out/scaling", help="output folder")
    ap.add_argument("--steps", type=positive(int), default=20,
                    help="steps of the timed runs (>= 1)")
    ap.add_argument("--large", action="store_true", help=f"add h = {LARGE} (~520k dofs)")
    ap.add_argument("--sizes", type=mesh_sizes, default=None,
                    help="comma-separated h values (each > 0) instead of the default")
    ap.add_argument("--no-floors", action="store_true", help="skip the floors")
    ap.add_argument("--contact-only", action="store_true", help="skip the runs without contact")
    ap.add_argument("--repeats", type=positive(int), default=2,
                    help="runs of each (fastest kept; >= 1)")
    ap.add_argument("--exe", default=None, help="the dyncontact executable")
    ap.add_argument("--geometry", default="strip",
                    help="comma-separated: strip, disk, box (default strip)")
    ap.add_argument("--solvers", default="direct",
                    help="comma-separated &solver kinds: direct, cg, auto (default direct)")
    ap.add_argument("--max-dofs", type=positive(int), default=None,
                    help="skip the sizes estimated above this many dofs")
    ap.add_argument("--threads", default="auto",
                    help="comma-separated settings of the direct solves' threads, each run at "
                         "every size: auto (the environment's), 1, 2 (DYNCONTACT_THREADS); "
                         "CG runs with the last (default auto)")
    ap.add_argument("--replot", nargs="+", default=None, metavar="CSV",
                    help="no runs: table and chart in --out from these scaling.csv files")
    a = ap.parse_args(argv)
    if not a.out.strip():
        ap.error("--out: must not be empty")
    if a.replot:
        missing = [c for c in a.replot if not os.path.isfile(c)]
        if missing:
            ap.error(f"--replot: no such file {', '.join(missing)}")
        rows = replot(a.out, a.replot)
        print(json.dumps({"rows": len(rows), "out": a.out}))
        return 0
    sizes = a.sizes
    geometries = [g for g in a.geometry.split(",") if g]
    for g in geometries:
        if g not in GEOMETRY_SIZES:
            ap.error(f"--geometry: unknown geometry {g!r} (expected strip, disk or box)")
    solvers = [k for k in a.solvers.split(",") if k]
    for k in solvers:
        if k not in ("direct", "cg", "auto"):
            ap.error(f"--solvers: unknown solver kind {k!r} (expected direct, cg or auto)")
    threads = [t.strip() for t in a.threads.split(",") if t.strip()]
    if not threads or any(t not in ("auto", "1", "2") for t in threads):
        ap.error(f"--threads: a comma-separated list of auto, 1, 2: {a.threads!r}")
    print(f"scaling: load average {_load()} at the start, {os.cpu_count()} cores", flush=True)
    try:
        with sigterm_as_interrupt():
            rows = run_scaling(a.out, sizes, a.steps, a.exe, no_contact=not a.contact_only,
                               floors=not a.no_floors, repeats=a.repeats,
                               geometries=geometries, solvers=solvers, max_dofs=a.max_dofs,
                               large=a.large, threads=threads)
    except KeyboardInterrupt:
        print(f"{ap.prog}: interrupted (the run in progress was stopped)", file=sys.stderr)
        return 130
    print(json.dumps({"rows": len(rows), "out": a.out}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
