"""Scaling sweep: time and memory of the 2D strip as the mesh is refined.

For each mesh size h of the seed's strip (hht, Δt = 0.0005) the executable is run as a
user runs it, once with 0 steps (the set-up) and once with ``steps`` steps; each child's
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

    python -m dyncontact.study.scaling --out out/scaling [--large] [--steps N]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from typing import Any, Sequence

from .common import md_table, new_figure, save_figure, slope, write_csv

__all__ = ["SIZES", "LARGE", "strip_scene", "measure_one", "run_scaling", "main"]

#: The strip's mesh sizes swept by default (2 200 to 129 600 dofs).
SIZES = (0.01, 0.005, 0.0025, 0.00125)
#: The size added by ``--large`` (about 520 000 dofs; minutes and about 2 GB today).
LARGE = 0.000625
DT = 0.0005

COLUMNS = ["h", "contact", "dofs", "matrix_nnz", "factor_nnz", "solver", "solve_kernel",
           "ordering", "setup_s", "loop_ms_per_step", "solve_ms", "spmv_ms", "step_over_floor",
           "peak_mb", "setup_peak_mb", "model_mb", "peak_over_model", "steps"]


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
                             env=env)
        _pid, status, ru = os.wait4(p.pid, 0)
        p.returncode = os.waitstatus_to_exitcode(status)
        cpu = ru.ru_utime + ru.ru_stime
        peak = ru.ru_maxrss / 1024.0
        if cmd[0] == timer:
            text = rss.read().split()
            if len(text) >= 3:
                peak = float(text[-3]) / 1024.0
    return cpu, peak, p.returncode


def measure_one(exe: str, h: float, contact: bool, steps: int, work: str,
                floors: bool = True, env: dict[str, str] | None = None, repeats: int = 2) -> dict[str, Any]:
    """One row of the table (see the module docstring). Each run is repeated ``repeats``
    times: the smallest CPU time is kept (the machine is shared), and the largest peak.
    Below h = 0.00125 the step count grows as 1/h^2 (at most 2000)."""
    from ..core import read_summary

    tag = f"h{h:g}_{'c' if contact else 'nc'}"
    rows: dict[int, tuple[float, float, int]] = {}
    summary: dict[str, Any] = {}
    # small meshes: more steps, so that the loop is not lost in the start-up's noise
    steps = min(2000, max(steps, int(round(steps * 0.0026 / (h * h * 200.0)))))
    for n in (0, steps):
        out = os.path.join(work, f"{tag}_{n}")
        path = os.path.join(work, f"{tag}_{n}.nml")
        with open(path, "w", encoding="utf-8") as f:
            f.write(strip_scene(h, n, contact, out))
        best = None
        for _ in range(max(1, repeats)):
            got = _run_child(exe, path, env)
            if got[2] != 0:
                raise RuntimeError(f"{exe} {path} exited with status {got[2]}")
            best = got if best is None else (min(best[0], got[0]), max(best[1], got[1]), 0)
        rows[n] = best
        summary = read_summary(out)
    (w0, m0, _), (_w1, m1, _) = rows[0], rows[steps]
    loop_ms, fl = _loop_and_floors(os.path.join(work, f"{tag}_{steps}.nml"),
                                   os.path.join(work, f"{tag}_stepper"), steps, repeats,
                                   int(summary.get("dofs", 1)), floors, env)
    mnnz = summary.get("matrix_nnz")
    fnnz = summary.get("factor_nnz")
    model = None
    if mnnz is not None and fnnz is not None:
        model = (4 * 12.0 * mnnz + 12.0 * fnnz) / 1.0e6
    solve_ms = fl["solve_us"] / 1e3 if fl and fl.get("solve_us") else None
    spmv_ms = fl["spmv_us"] / 1e3 if fl and fl.get("spmv_us") else None
    return {
        "h": h, "contact": int(contact), "dofs": summary.get("dofs"), "matrix_nnz": mnnz,
        "factor_nnz": fnnz, "solver": summary.get("solver"),
        "solve_kernel": summary.get("solve_kernel"), "ordering": summary.get("ordering", ""),
        "setup_s": w0, "loop_ms_per_step": loop_ms, "solve_ms": solve_ms, "spmv_ms": spmv_ms,
        "step_over_floor": (loop_ms / (solve_ms + spmv_ms)) if solve_ms and spmv_ms else None,
        "peak_mb": max(m0, m1), "setup_peak_mb": m0, "model_mb": model,
        "peak_over_model": (max(m0, m1) / model) if model else None, "steps": steps,
    }


def _loop_and_floors(scene: str, out: str, steps: int, repeats: int, dofs: int,
                     floors: bool, env: dict[str, str] | None):
    """(ms per step, floors) on one open run: the CPU time of ``repeats`` stretches of
    steps // repeats steps (the smallest kept: the set-up is not in it, and a stretch
    slowed down by the other processes on the machine is dropped), then the floors
    measured on the same run's factors (:meth:`dyncontact.core.Stepper.floors`)."""
    from ..core import Stepper

    old = {k: os.environ.get(k) for k in (env or {})}
    os.environ.update(env or {})
    try:
        with Stepper(scene, out) as st:
            per = max(1, steps // max(1, repeats))
            best = float("inf")
            for _ in range(max(1, repeats)):
                t0 = time.process_time()
                done = st.advance(per)
                if done < 1:
                    break
                best = min(best, (time.process_time() - t0) / done * 1e3)
            n_rep = max(20, int(2.0e6 / max(1, dofs)))
            fl = st.floors(n_rep=n_rep, batches=5) if floors else None
    finally:
        for k, v in old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
    return best, fl


def _fmt(x: Any, nd: int = 3) -> str:
    if x is None or x == "":
        return "–"
    if isinstance(x, float):
        return f"{x:.{nd}g}"
    return str(x)


def run_scaling(out: str, sizes: Sequence[float] = SIZES, steps: int = 20,
                exe: str | None = None, no_contact: bool = True, floors: bool = True,
                env: dict[str, str] | None = None, repeats: int = 2, log=print) -> list[dict[str, Any]]:
    """The sweep; writes scaling.csv, scaling.md and scaling.png into ``out``."""
    os.makedirs(out, exist_ok=True)
    if exe is None:
        root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(
            os.path.abspath(__file__)))))
        exe = os.path.join(root, "build", "dyncontact")
    rows = []
    with tempfile.TemporaryDirectory(prefix="dyncontact-scaling-") as work:
        for h in sizes:
            for contact in ((True, False) if no_contact else (True,)):
                r = measure_one(exe, h, contact, steps, work, floors=floors, env=env,
                                repeats=repeats)
                rows.append(r)
                log(f"h = {h:g} contact = {int(contact)}: dofs {r['dofs']}, set-up "
                    f"{_fmt(r['setup_s'])} s, loop {_fmt(r['loop_ms_per_step'])} ms/step, "
                    f"solve {_fmt(r['solve_ms'])} ms, SpMV {_fmt(r['spmv_ms'])} ms, peak "
                    f"{_fmt(r['peak_mb'])} MB, model {_fmt(r['model_mb'])} MB")
    write_csv(os.path.join(out, "scaling.csv"), rows, COLUMNS)
    _write_md(out, rows)
    _plot(out, rows)
    return rows


def _slopes(rows, key):
    c = [r for r in rows if r["contact"] and r.get(key)]
    return slope([r["dofs"] for r in c], [r[key] for r in c])


def _write_md(out: str, rows) -> None:
    head = ["h", "contact", "dofs", "set-up s", "loop ms/step", "solve ms", "SpMV ms",
            "peak MB", "model MB", "peak/model", "factor nnz", "ordering", "kernel"]
    body = [[_fmt(r["h"]), r["contact"], r["dofs"], _fmt(r["setup_s"]),
             _fmt(r["loop_ms_per_step"]), _fmt(r["solve_ms"]), _fmt(r["spmv_ms"]),
             _fmt(r["peak_mb"]), _fmt(r["model_mb"]), _fmt(r["peak_over_model"]),
             _fmt(r["factor_nnz"]), _fmt(r["ordering"]), _fmt(r["solve_kernel"])]
            for r in rows]
    lines = md_table(head, body)
    lines.append("")
    lines.append("Fitted slopes against dofs (with contact): " + ", ".join(
        f"{k} {_slopes(rows, k):.2f}" for k in ("setup_s", "loop_ms_per_step", "solve_ms",
                                                   "spmv_ms", "peak_mb")))
    with open(os.path.join(out, "scaling.md"), "w", encoding="utf-8") as f:
        f.write("\n".join(lines) + "\n")


def _plot(out: str, rows) -> None:
    fig, axes = new_figure(1, 2, width=5.0)
    axes = axes[0]
    for contact, style in ((1, "-"), (0, ":")):
        c = [r for r in rows if r["contact"] == contact]
        if not c:
            continue
        x = [r["dofs"] for r in c]
        for key, label, ax in (("loop_ms_per_step", "step (ms)", axes[0]),
                               ("solve_ms", "one solve (ms)", axes[0]),
                               ("spmv_ms", "one SpMV (ms)", axes[0]),
                               ("setup_s", "set-up (s)", axes[0]),
                               ("peak_mb", "peak RSS (MB)", axes[1]),
                               ("model_mb", "matrices + factor (MB)", axes[1])):
            pts = [(xi, r[key]) for xi, r in zip(x, c) if r.get(key)]
            if len(pts) < 2 or (contact == 0 and key not in ("peak_mb", "loop_ms_per_step")):
                continue
            s = slope([p[0] for p in pts], [p[1] for p in pts])
            ax.loglog([p[0] for p in pts], [p[1] for p in pts], style, marker="o",
                      label=f"{label}{'' if contact else ', no contact'}: slope {s:.2f}")
    for ax, title in ((axes[0], "time"), (axes[1], "memory")):
        ax.set_xlabel("dofs")
        ax.set_title(f"2D strip, hht, dt = {DT:g}: {title}")
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=6)
        ax.grid(True, which="both", alpha=0.3)
    save_figure(fig, os.path.join(out, "scaling.png"))


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="scripts/bench --scaling", description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="out/scaling", help="output folder")
    ap.add_argument("--steps", type=int, default=20, help="steps of the timed runs")
    ap.add_argument("--large", action="store_true", help=f"add h = {LARGE} (~520k dofs)")
    ap.add_argument("--sizes", default="", help="comma-separated h values instead of the default")
    ap.add_argument("--no-floors", action="store_true", help="skip the floors")
    ap.add_argument("--contact-only", action="store_true", help="skip the runs without contact")
    ap.add_argument("--repeats", type=int, default=2, help="runs of each (fastest kept)")
    ap.add_argument("--exe", default=None, help="the dyncontact executable")
    a = ap.parse_args(argv)
    sizes = [float(s) for s in a.sizes.split(",") if s] if a.sizes else list(SIZES)
    if a.large:
        sizes.append(LARGE)
    rows = run_scaling(a.out, sizes, a.steps, a.exe, no_contact=not a.contact_only,
                       floors=not a.no_floors, repeats=a.repeats)
    print(json.dumps({"rows": len(rows), "out": a.out}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
