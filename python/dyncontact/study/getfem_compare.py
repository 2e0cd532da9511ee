"""Against the GetFEM script (``scripts/bench --getfem``): time per step and peak memory of
GetFEM and of dyncontact on the same scene, at several mesh sizes, in one run.

Optional: dyncontact never needs GetFEM. The GetFEM side is ``scripts/getfem_bar.py``,
run by a Python that has GetFEM's interface (Debian ``python3-getfem``; ``--getfem-python``,
else ``$DYNCONTACT_GETFEM_PYTHON``, else ``/usr/bin/python3``, else ``python3`` on PATH).
Without one, the driver says so and exits 0.

The scene, for each h: the seed's strip (SPEC §2), hht α = 0 (= Newmark ¼, ½), Δt = 0.0005,
Nitsche θ = 1, γ0 = 10, contact integrated with 3 Gauss points a facet as GetFEM does
(``&contact quadrature = 'gauss', quad_points = 3``), the same number of steps on both
sides. With Δt = 0.0005 and at most a few hundred steps, every step is before the first
impact (t ≈ 1.15): the comparison is the flight phase, where both codes do one Newton
iteration a step with an unchanged Jacobian.

Measured, for each size, ``--repeats`` rounds, each running in turn (interleaved, so that
both sides see the same machine state):

- the GetFEM script (``getfem_bar.py --loop scipy``, the reference's loop: GetFEM's
  assembly, numpy/scipy Newton, sparse LU reused while the Jacobian does not change);
- dyncontact: the executable under ``/usr/bin/time`` for the peak, and the same scene's
  time loop in an open run (:class:`dyncontact.core.Stepper`, set-up excluded);
- with ``--model``, also GetFEM's own ``Model.solve`` (``--loop model``: assembly and a
  MUMPS factorization at every Newton iteration), with fewer steps (``MODEL_STEPS``).

Times are CPU seconds (user + system) of the time loop only, divided by the steps: on a
shared machine the wall time would count the other processes. The smallest of the rounds is
kept, and the largest peak (max RSS of the whole process, /usr/bin/time). ratio = GetFEM
ms/step ÷ dyncontact ms/step. The wall time of the same loops is kept too (the smallest of
the rounds; ``wall_ratio``): with two threads in dyncontact's solves (``&solver threads``,
automatic by default) its CPU time counts both threads, and only the wall time shows
what they save. GetFEM runs with one BLAS/OpenMP thread (its loop's sparse LU is
single-threaded); dyncontact with the threads of its default (``--threads auto``: the
process's environment decides, docs/scenes.md) or ``--threads 1``/``2``
(``DYNCONTACT_THREADS``), or several settings against the same GetFEM runs
(``--threads auto,1``: a row for each); ``ours_threads`` is the threads its solves used. Writes
``getfem.csv`` and ``getfem.md`` into ``--out``.

    scripts/bench --getfem [--sizes 0.01,0.005] [--steps N] [--repeats 2] [--model]
        [--threads auto,1] [--out out/getfem] [--getfem-python PY]
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from typing import Any, Mapping, Sequence

from .common import (OneLineParser, environment, loadavg, md_table, mesh_sizes, positive,
                     write_csv)
from .sweep import child_group, sigterm_as_interrupt

__all__ = ["SIZES", "DT", "STEPS", "MAX_STEPS", "MODEL_STEPS", "find_getfem_python", "scene_text",
           "steps_for", "ratio", "rows_table", "parse_time_v", "measure_getfem",
           "measure_ours", "compare", "main"]

#: Mesh sizes (2 200 to 129 600 dofs).
SIZES = (0.01, 0.005, 0.0025, 0.00125)
DT = 0.0005
#: Steps of each size (both codes): enough that our loop takes tens of ms of CPU time or
#: more, at most 2000 (t = 1, before the first impact at t ≈ 1.15), few at the largest
#: size where GetFEM's step is tens to hundreds of ms.
STEPS = {0.01: 2000, 0.005: 1000, 0.0025: 400, 0.00125: 200}
#: The last step before the first impact (t = 1.15 at the probe): the comparison is the
#: flight phase (see the module docstring).
MAX_STEPS = 2000
#: Steps of GetFEM's Model.solve (a factorization a step: hundreds of ms at 32 800 dofs).
MODEL_STEPS = {0.01: 100, 0.005: 20, 0.0025: 6, 0.00125: 3}
#: The GetFEM script, in the repository.
SCRIPT = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__))))), "scripts", "getfem_bar.py")

COLUMNS = ["h", "dofs", "steps", "getfem_ms", "ours_ms", "ratio", "getfem_peak_mb",
           "ours_peak_mb", "getfem_setup_s", "getfem_factorizations", "model_steps",
           "model_ms", "model_ratio", "model_peak_mb", "getfem_dofs", "getfem_wall_ms",
           "ours_wall_ms", "wall_ratio", "ours_threads", "threads_setting"]


def steps_for(h: float, table: Mapping[float, int] = STEPS) -> int:
    """The steps of size h: the table's entry, else scaled as 1/h² from the nearest."""
    if h in table:
        return int(table[h])
    near = min(table, key=lambda k: abs(k - h))
    return max(1, min(MAX_STEPS, int(round(table[near] * (h / near) ** 2))))


def find_getfem_python(explicit: str | None = None) -> tuple[str | None, list[str]]:
    """(a Python that imports getfem, the candidates tried). ``explicit`` alone when
    given; else $DYNCONTACT_GETFEM_PYTHON, /usr/bin/python3, python3 on PATH."""
    if explicit:
        cands = [explicit]
    else:
        cands = [c for c in (os.environ.get("DYNCONTACT_GETFEM_PYTHON"), "/usr/bin/python3",
                             shutil.which("python3")) if c]
    tried = []
    for c in dict.fromkeys(cands):
        tried.append(c)
        try:
            r = subprocess.run([c, "-c", "import getfem, scipy"], capture_output=True,
                               timeout=120)
        except (OSError, subprocess.TimeoutExpired):
            continue
        if r.returncode == 0:
            return c, tried
    return None, tried


def scene_text(h: float, steps: int, out_dir: str) -> str:
    """The strip at mesh size h as the GetFEM script computes it (module docstring)."""
    return (
        "! Against the GetFEM script: the seed's strip, written by "
        "dyncontact.study.getfem_compare.\n"
        f"&mesh file = '', dim = 2, length = 1.0, width = 0.1, h = {h!r} /\n"
        "&boundary clamped = 'top', contact = 'bottom' /\n"
        "&material young = 0.6666666666666666, poisson = 0.3333333333333333, density = 1.0 /\n"
        "&contact method = 'nitsche', theta = 1, gamma0 = 10.0, obstacle_point = 0.0, 0.0,\n"
        "         obstacle_normal = 0.0, -1.0, probe = 0.05, 0.0, quadrature = 'gauss',\n"
        "         quad_points = 3 /\n"
        "&initial kind = 'compressed_bar', amplitude = 0.5 /\n"
        f"&scheme name = 'hht', alpha = 0.0, dt = {DT!r}, t_end = {steps * DT!r},"
        " mass = 'consistent', newton_tol = 1e-10 /\n"
        f"&output dir = '{out_dir}', every = 1, fields_every = 0 /\n")


def parse_time_v(text: str) -> float | None:
    """Peak resident memory in MB from ``/usr/bin/time -v``'s report (None if absent)."""
    for line in text.splitlines():
        if "Maximum resident set size" in line:
            try:
                return float(line.rsplit(":", 1)[1]) / 1024.0
            except ValueError:
                return None
    return None


def ratio(getfem_ms: float | None, ours_ms: float | None) -> float | None:
    """GetFEM's time per step over ours (None when either is missing or ours is 0)."""
    if getfem_ms is None or ours_ms is None or ours_ms <= 0:
        return None
    return getfem_ms / ours_ms


def measure_getfem(py: str, h: float, steps: int, loop: str = "scipy",
                   env: Mapping[str, str] | None = None,
                   script: str = SCRIPT) -> dict[str, Any]:
    """One run of the GetFEM script: its JSON record (ms_per_step = CPU ms of the loop a
    step, setup_s, dofs, factorizations) and peak_mb (/usr/bin/time -v, when present).
    Raises RuntimeError when it fails."""
    cmd = [py, script, "--h", repr(h), "--dt", repr(DT), "--steps", str(steps),
           "--loop", loop]
    timer = "/usr/bin/time"
    if os.access(timer, os.X_OK):
        cmd = [timer, "-v"] + cmd
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=dict(env) if env else None, start_new_session=True)
    with child_group(proc):
        out, err = proc.communicate()
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} exited with status {proc.returncode}: "
                           f"{err.strip()[-500:]}")
    lines = [ln for ln in out.splitlines() if ln.startswith("{")]
    if not lines:
        raise RuntimeError(f"{' '.join(cmd)} printed no record")
    rec = json.loads(lines[-1])
    rec["peak_mb"] = parse_time_v(err)
    return rec


def measure_ours(exe: str, h: float, steps: int, work: str,
                 env: Mapping[str, str] | None = None) -> dict[str, Any]:
    """dyncontact on the same scene: the executable's peak (max RSS, /usr/bin/time), its
    dofs and the threads of its solves (summary.json ``solve_threads``), and the CPU and
    wall ms a step of the time loop of an open run of the same scene
    (:class:`dyncontact.core.Stepper`: the set-up left out, as on GetFEM's side)."""
    from ..core import Stepper, read_summary
    from .scaling import _run_child

    tag = f"strip_h{h:g}_{steps}"
    out = os.path.join(work, tag)
    path = os.path.join(work, f"{tag}.nml")
    with open(path, "w", encoding="utf-8") as f:
        f.write(scene_text(h, steps, out))
    _cpu, peak, rc = _run_child(exe, path, dict(env) if env else None)
    if rc != 0:
        raise RuntimeError(f"{exe} {path} exited with status {rc}")
    summary = read_summary(out)
    with environment(env), Stepper(path, out + "_loop") as st:
        t0, w0 = time.process_time(), time.perf_counter()
        done = st.advance(steps)
        cpu, wall = time.process_time() - t0, time.perf_counter() - w0
    return {"dofs": summary.get("dofs"), "steps": done, "status": summary.get("status"),
            "ms_per_step": 1e3 * cpu / max(1, done), "peak_mb": peak,
            "wall_ms_per_step": 1e3 * wall / max(1, done),
            "threads": summary.get("solve_threads")}


def _best(old: dict[str, Any] | None, new: dict[str, Any]) -> dict[str, Any]:
    """The round kept: the smallest CPU time a step, the largest peak, the smallest wall
    time a step (``wall_ms_per_step``, dyncontact; ``ms_per_step_wall``, the script)."""
    if old is None:
        return dict(new)
    out = dict(old if old["ms_per_step"] <= new["ms_per_step"] else new)
    peaks = [p for p in (old.get("peak_mb"), new.get("peak_mb")) if p is not None]
    out["peak_mb"] = max(peaks) if peaks else None
    for key in ("wall_ms_per_step", "ms_per_step_wall"):
        walls = [w for w in (old.get(key), new.get(key)) if w is not None]
        out[key] = min(walls) if walls else None
    return out


def compare(py: str, exe: str, sizes: Sequence[float], steps: int | None = None,
            repeats: int = 2, model: bool = False, log=print,
            env: Mapping[str, str] | None = None,
            ours_env: Mapping[str, str] | None = None,
            settings: Sequence[tuple[str, Mapping[str, str] | None]] | None = None
            ) -> list[dict[str, Any]]:
    """The rows (COLUMNS), one a size and a dyncontact setting, the runs interleaved
    (module docstring). ``env``: the environment of the runs (GetFEM's); ``settings``:
    (label, environment) of each dyncontact setting to measure against the same GetFEM
    runs (default: one, ``("auto", ours_env)``, ``ours_env`` defaulting to ``env``)."""
    if settings is None:
        settings = [("auto", env if ours_env is None else ours_env)]
    rows = []
    with tempfile.TemporaryDirectory(prefix="dyncontact-getfem-") as work:
        for h in sizes:
            n = steps or steps_for(h)
            nm = min(n, steps_for(h, MODEL_STEPS))
            g = m = None
            ours: dict[str, dict[str, Any] | None] = {label: None for label, _ in settings}
            for _ in range(max(1, repeats)):
                g = _best(g, measure_getfem(py, h, n, "scipy", env))
                for label, senv in settings:
                    ours[label] = _best(ours[label], measure_ours(exe, h, n, work, senv))
                if model:
                    m = _best(m, measure_getfem(py, h, nm, "model", env))
            for label, _ in settings:
                o = ours[label]
                row = {"h": h, "dofs": o["dofs"], "getfem_dofs": g["dofs"], "steps": n,
                       "getfem_ms": g["ms_per_step"], "ours_ms": o["ms_per_step"],
                       "ratio": ratio(g["ms_per_step"], o["ms_per_step"]),
                       "getfem_peak_mb": g["peak_mb"], "ours_peak_mb": o["peak_mb"],
                       "getfem_setup_s": g.get("setup_cpu_s"),
                       "getfem_factorizations": g.get("factorizations"),
                       "getfem_wall_ms": g.get("ms_per_step_wall"),
                       "ours_wall_ms": o.get("wall_ms_per_step"),
                       "wall_ratio": ratio(g.get("ms_per_step_wall"), o.get("wall_ms_per_step")),
                       "ours_threads": o.get("threads"), "threads_setting": label}
                if m is not None:
                    row.update(model_steps=nm, model_ms=m["ms_per_step"],
                               model_ratio=ratio(m["ms_per_step"], o["ms_per_step"]),
                               model_peak_mb=m["peak_mb"])
                rows.append(row)
                log(f"getfem: h = {h:g}: {row['dofs']} dofs, {n} steps: GetFEM script "
                    f"{_f(row['getfem_ms'])} ms/step, dyncontact ({label}) "
                    f"{_f(row['ours_ms'])} ms/step, ratio {_f(row['ratio'])} (wall: "
                    f"{_f(row['getfem_wall_ms'])} and {_f(row['ours_wall_ms'])} ms/step on "
                    f"{_f(row['ours_threads'])} thread(s), ratio {_f(row['wall_ratio'])}); "
                    f"peaks {_f(row['getfem_peak_mb'])} and {_f(row['ours_peak_mb'])} MB"
                    + (f"; GetFEM Model.solve {_f(row['model_ms'])} ms/step ({nm} steps)"
                       if m is not None else ""))
    return rows


def _f(x: Any, nd: int = 3) -> str:
    if x is None:
        return "–"
    if isinstance(x, float):
        return f"{x:.{nd}g}"
    return str(x)


def rows_table(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """The rows as a markdown table (the Model.solve columns only when measured)."""
    model = any(r.get("model_ms") is not None for r in rows)
    head = ["h", "dofs", "steps", "GetFEM script ms/step", "dyncontact ms/step", "ratio",
            "GetFEM peak MB", "dyncontact peak MB", "GetFEM wall ms/step",
            "dyncontact wall ms/step", "wall ratio", "dyncontact threads", "setting"]
    if model:
        head += ["Model.solve steps", "Model.solve ms/step", "ratio"]
    body = []
    for r in rows:
        line = [_f(r["h"]), _f(r["dofs"]), _f(r["steps"]), _f(r["getfem_ms"]),
                _f(r["ours_ms"]), _f(r["ratio"]), _f(r["getfem_peak_mb"]),
                _f(r["ours_peak_mb"]), _f(r.get("getfem_wall_ms")),
                _f(r.get("ours_wall_ms")), _f(r.get("wall_ratio")),
                _f(r.get("ours_threads")), _f(r.get("threads_setting", "auto"))]
        if model:
            line += [_f(r.get("model_steps")), _f(r.get("model_ms")),
                     _f(r.get("model_ratio"))]
        body.append(line)
    return md_table(head, body)


def main(argv: Sequence[str] | None = None, root: str | None = None) -> int:
    """``scripts/bench --getfem``: exit 0 when done or when GetFEM is absent (a benchmark
    never fails on time); 1 when a run could not run."""
    root = root or os.path.dirname(os.path.dirname(SCRIPT))
    ap = OneLineParser(prog="scripts/bench --getfem", label="bench --getfem",
                       description=" ".join(__doc__.split("\n\n")[0].split()))
    ap.add_argument("--sizes", type=mesh_sizes, default=",".join(repr(h) for h in SIZES),
                    help="comma-separated mesh sizes h (default %(default)s)")
    ap.add_argument("--steps", type=positive(int), default=None,
                    help="steps of every size (default: "
                         + ", ".join(f"{n} at h = {h}" for h, n in STEPS.items())
                         + f"; other sizes scaled as 1/h² from the nearest, at most {MAX_STEPS})")
    ap.add_argument("--repeats", type=positive(int), default=2,
                    help="interleaved rounds (best kept; >= 1)")
    ap.add_argument("--model", action="store_true",
                    help="also GetFEM's own Model.solve (MUMPS at every iteration)")
    ap.add_argument("--threads", default="auto",
                    help="dyncontact's solve threads, comma-separated settings measured "
                         "against the same GetFEM runs: auto (its default, from the "
                         "environment), 1 or 2 (DYNCONTACT_THREADS) (default %(default)s)")
    ap.add_argument("--out", default=os.path.join(root, "out", "getfem"), help="folder")
    ap.add_argument("--exe", default=os.path.join(root, "build", "dyncontact"))
    ap.add_argument("--getfem-python", default=None,
                    help="a Python with GetFEM's interface (default: see the module)")
    a = ap.parse_args(argv)
    sizes = a.sizes
    py, tried = find_getfem_python(a.getfem_python)
    if py is None:
        print("bench --getfem: GetFEM's Python interface is not available (tried "
              f"{', '.join(tried) or 'no Python'}): nothing to compare. Install it (Debian: "
              "apt-get install python3-getfem) or pass --getfem-python.", flush=True)
        return 0
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    # dyncontact: one BLAS thread (numpy), its solves' threads as a user gets them
    labels = [t.strip() for t in a.threads.split(",") if t.strip()]
    if not labels or any(t not in ("auto", "1", "2") for t in labels):
        ap.error(f"--threads: a comma-separated list of auto, 1, 2: {a.threads!r}")
    settings = []
    for label in labels:
        ours_env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
        ours_env.pop("DYNCONTACT_THREADS", None)
        if label != "auto":
            ours_env["DYNCONTACT_THREADS"] = label
        settings.append((label, ours_env))
    load0 = loadavg()
    print(f"bench --getfem: GetFEM through {py}; sizes {sizes}; dyncontact threads "
          f"{a.threads}; load average {load0}, {os.cpu_count()} cores", flush=True)
    try:
        with sigterm_as_interrupt():
            rows = compare(py, a.exe, sizes, a.steps, a.repeats, a.model, env=env,
                           settings=settings)
    except RuntimeError as exc:
        print(f"bench --getfem: a run failed: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("bench --getfem: interrupted (the run in progress was stopped)",
              file=sys.stderr)
        return 130
    load1 = loadavg()
    os.makedirs(a.out, exist_ok=True)
    write_csv(os.path.join(a.out, "getfem.csv"), rows, COLUMNS)
    lines = rows_table(rows)
    lines += ["", f"Load average (1, 5, 15 min): {load0} at the start, {load1} at the end; "
              f"{os.cpu_count()} cores. CPU time (and wall time) of the time loop only, best "
              f"of {a.repeats} interleaved rounds; peaks = max RSS of the whole process; "
              f"dyncontact threads: {a.threads}."]
    with open(os.path.join(a.out, "getfem.md"), "w", encoding="utf-8") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))
    print(f"bench --getfem: wrote {os.path.join(a.out, 'getfem.csv')} and getfem.md")
    return 0


if __name__ == "__main__":
    sys.exit(main())
