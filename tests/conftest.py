"""Shared paths and fixtures of the pytest suite (run it with scripts/test)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from contextlib import contextmanager
from pathlib import Path

import pytest

#: The repository root.
ROOT = Path(__file__).resolve().parents[1]
#: The standalone executable built by scripts/setup (meson build folder ./build).
EXE = ROOT / "build" / "dyncontact"
#: Seconds a subprocess of a test may take before it counts as hung.
SUBPROCESS_TIMEOUT = 120

# Parallel test workers (pytest-xdist sets PYTEST_XDIST_WORKER) share the cores: each
# runs its triangular solves on one thread, as the package's sweeps do (docs/scenes.md,
# &solver threads), unless the environment already says otherwise. Subprocesses inherit it.
if os.environ.get("PYTEST_XDIST_WORKER"):
    os.environ.setdefault("DYNCONTACT_THREADS", "1")

#: The test files that measure wall time, send signals, limit memory or count threads:
#: under pytest-xdist with --dist loadfile (scripts/test) they form one unit of work, run
#: on one worker one after another, never two of them at once (pytest_xdist_make_scheduler).
ALONE_FILES = frozenset({
    "test_auto_rule.py", "test_fields_outputs.py", "test_geo_estimate.py",
    "test_out_of_memory.py", "test_parallel_solve.py", "test_reliability.py",
    "test_restart.py", "test_scaling.py", "test_signals_entry_points.py",
    "test_signals_mesh_file.py", "test_signals_setup.py", "test_solver_threads.py",
    "test_studies.py", "test_study_signals.py",
})


def alone_or_file(nodeid: str) -> str:
    """The unit of work of a test under --dist loadfile: "alone" for a test of
    ALONE_FILES, else its file (its module-scoped fixtures are then built once)."""
    path = nodeid.split("::", 1)[0]
    return "alone" if path.rsplit("/", 1)[-1] in ALONE_FILES else path


@pytest.hookimpl(tryfirst=True, optionalhook=True)
def pytest_xdist_make_scheduler(config, log):
    """--dist loadfile with ALONE_FILES as one file (alone_or_file). xdist's own
    --dist loadgroup cannot do it here: it tags the tests' node ids, which pytest 9 no
    longer lets a plugin change. Other --dist modes are xdist's; without xdist the hook
    is never called (optionalhook)."""
    if config.getvalue("dist") != "loadfile":
        return None
    from xdist.scheduler import LoadFileScheduling

    if not callable(getattr(LoadFileScheduling, "_split_scope", None)):
        # an xdist without the scope hook that --dist loadfile is built on: its own
        # loadfile (the files of ALONE_FILES then may run beside each other)
        return None

    class AloneOrFileScheduling(LoadFileScheduling):
        def _split_scope(self, nodeid: str) -> str:
            return alone_or_file(nodeid)

    return AloneOrFileScheduling(config, log)


@pytest.fixture(scope="session")
def root() -> Path:
    return ROOT


@pytest.fixture(scope="session")
def core_ext():
    """The Fortran extension dyncontact._core; the test is skipped if it cannot be
    imported (scripts/test builds it first, so a skip there means a broken set-up)."""
    try:
        from dyncontact import _core
    except ImportError as exc:
        pytest.skip(f"dyncontact._core cannot be imported ({exc}); run scripts/setup")
    return _core


@pytest.fixture(scope="session")
def exe() -> Path:
    """Path of build/dyncontact (skip if it has not been built)."""
    if not EXE.is_file():
        pytest.skip(f"{EXE} is not built; run scripts/setup")
    return EXE


def _run(cmd, cwd, timeout=SUBPROCESS_TIMEOUT) -> subprocess.CompletedProcess:
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    return subprocess.run([str(c) for c in cmd], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=timeout)


@pytest.fixture
def run_cli(tmp_path):
    """run_cli(*args, cwd=tmp_path): `python -m dyncontact ARGS` as a subprocess."""

    def run(*args, cwd=None):
        return _run([sys.executable, "-m", "dyncontact", *args], cwd or tmp_path)

    return run


@pytest.fixture
def run_exe(exe, tmp_path):
    """run_exe(*args, cwd=tmp_path): build/dyncontact ARGS as a subprocess."""

    def run(*args, cwd=None):
        return _run([exe, *args], cwd or tmp_path)

    return run


@pytest.fixture(autouse=True)
def _close_figures():
    """Close the pyplot figures a test left open (those a chart test takes from
    saved_figures, or a plotting call it inspects), so that they do not pile up in the
    worker's process over the suite."""
    yield
    pyplot = sys.modules.get("matplotlib.pyplot")
    if pyplot is not None:
        pyplot.close("all")


def peak_run(cmd, cwd, env=None,
             field: str = "VmPeak") -> tuple[int, subprocess.CompletedProcess]:
    """Run cmd (which must succeed) and return its peak in bytes and the result: the
    /proc status `field`, read while it runs, VmPeak (address space) or VmHWM (resident
    memory), a high-water mark, so any read after the peak gives it. env: default the
    test's environment without PYTHONPATH."""
    if env is None:
        env = dict(os.environ)
        env.pop("PYTHONPATH", None)
    p = subprocess.Popen([str(c) for c in cmd], cwd=cwd, env=env, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    peak = 0
    status = Path(f"/proc/{p.pid}/status")
    while p.poll() is None:
        try:
            for line in status.read_text().splitlines():
                if line.startswith(field + ":"):
                    peak = max(peak, int(line.split()[1]) * 1024)
        except (OSError, ValueError, IndexError):
            pass
        time.sleep(0.001)
    out, err = p.communicate()
    assert p.returncode == 0, err
    assert peak > 0
    return peak, subprocess.CompletedProcess(p.args, p.returncode, out, err)


def stable_grid(schemes, h: float, ratios, t_end: float = 1.0) -> tuple[list, dict]:
    """Made-up input of the stability study's maps (study/stability.py, _heatmaps): the
    grid rows of every scheme (objects with .key) at mesh size h, gamma0 = 10, theta = 1
    and each dt/h in ratios, all stable, and the grid (rows, grid)."""
    rows = [{"phase": "grid", "scheme": s.key, "h": h, "gamma0": 10.0, "theta": 1,
             "dt_over_h": r, "classification": "stable", "stop_time": None}
            for s in schemes for r in ratios]
    grid = {"h": [h], "gamma0": [10.0], "theta": [1], "t_end": t_end,
            "dt_over_h": {"implicit": list(ratios), "explicit": list(ratios)}}
    return rows, grid


def saved_figures(monkeypatch, module) -> list:
    """Replace module.save_figure by one that lays each figure out as save_figure does
    (tight_layout in its rect, or below its top) and keeps it instead of writing it: the
    list of the figures the module saves, in order, for a test to inspect."""
    figs = []

    def keep(fig, path, top: float = 1.0, rect=None):
        fig.tight_layout(rect=rect or (0, 0, 1, top))
        figs.append(fig)
        return path

    monkeypatch.setattr(module, "save_figure", keep)
    return figs


def stderr_line(res, code: int, prefix: str = "") -> str:
    """The one line a program printed on stderr, which exits with `code`: exactly one
    line, starting with `prefix`, no traceback (bad input and numerical failures are one
    line each)."""
    assert res.returncode == code, (res.returncode, res.stdout[-2000:], res.stderr[-2000:])
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, res.stderr
    assert lines[0].startswith(prefix), res.stderr
    assert "Traceback" not in res.stderr
    return lines[0]


class Ended:
    """What :func:`signal_after` collected of the process it signalled."""

    def __init__(self) -> None:
        self.stdout: str | None = None
        self.stderr: str | None = None
        self.returncode: int | None = None
        #: seconds from the signal to the process's end (its output collected)
        self.waited: float | None = None


@contextmanager
def signal_after(proc: subprocess.Popen, sig: int, timeout: float = SUBPROCESS_TIMEOUT):
    """``with signal_after(proc, sig) as ended:`` the block waits for the moment to
    signal the running process (a line it writes, rows in its trace); on leaving the block
    `sig` is sent and the process's output collected (communicate within `timeout`) into
    ``ended`` (stdout, stderr, returncode, and waited: the seconds from the signal to the
    process's end). Whatever fails on the way (the block, the
    wait), the process does not outlive the test: still running, it is killed and reaped."""
    ended = Ended()
    try:
        yield ended
        sent = time.monotonic()
        proc.send_signal(sig)
        ended.stdout, ended.stderr = proc.communicate(timeout=timeout)
        ended.waited = time.monotonic() - sent
        ended.returncode = proc.returncode
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def lame(young, poisson):
    """Lamé's (lambda, mu) of Young's modulus and Poisson's ratio."""
    return (young * poisson / ((1 + poisson) * (1 - 2 * poisson)),
            young / (2 * (1 + poisson)))


def fd_jacobian_errors(m, u, active: int, rng, tries: int,
                       switch: str = "skip") -> list[float]:
    """Relative errors |FD - J du| / |J du| of a Model `m`'s Jacobian at u against
    central differences of B, for `tries` random directions. A direction along which a
    quadrature point switches (the active count differs from `active`; B is not
    differentiable there) is skipped with switch="skip", and fails the test with
    switch="fail" (a state whose active set is meant to stay put)."""
    import numpy as np

    errs = []
    for _ in range(tries):
        du = rng.standard_normal(u.shape)
        eps = 1e-7 * np.linalg.norm(u) / np.linalg.norm(du)
        bp, act_p = m.eval_b(u + eps * du)
        bm, act_m = m.eval_b(u - eps * du)
        if act_p != active or act_m != active:
            assert switch == "skip", f"a direction switched a point: {act_m}, {act_p} " \
                                     f"active points against {active}"
            continue
        fd = (bp - bm) / (2 * eps)
        jdu = m.jacobian_apply(u, du)
        errs.append(float(np.linalg.norm(fd - jdu) / np.linalg.norm(jdu)))
    return errs


def sampled_steps(run, n_steps: int, samples, extra=None) -> dict:
    """Advance a Stepper `run` to n_steps, keeping at each step of `samples` the states
    before and after it: {step: (s0, s1)}, or (s0, s1, *extra(s0, s1)) with `extra`."""
    states = {}
    step = 0
    while step < n_steps:
        if step in samples:
            s0 = run.state()
            run.advance(1)
            s1 = run.state()
            states[step] = (s0, s1) + (tuple(extra(s0, s1)) if extra else ())
            step += 1
        else:
            step += run.advance(min(n_steps - step, min(s for s in set(samples) | {n_steps}
                                                        if s > step) - step))
    return states


#: The &scheme parameters each scheme uses (docs/scenes.md, &scheme); the others, given,
#: change nothing and the run warns.
SCHEME_PARAMS = {"newmark": ("beta", "gamma"), "pc": ("beta", "gamma"),
                 "hht": ("alpha",), "hht_seed": ("alpha",), "pc_hht": ("alpha",),
                 "pc_hht_seed": ("alpha",), "theta": ("theta",), "galpha": ("rho_inf",),
                 "central": ()}


def drop_unused(scene):
    """`scene` (a dyncontact.Scene) without the keys it gives that its scheme, contact
    method and quadrature, initial kind and mesh do not use (Scene.unset): a test that
    switches a base scene's scheme (hht's alpha under newmark), method, quadrature or
    initial kind on purpose runs without the warnings that those keys change nothing,
    so that the suite's warnings summary keeps the warnings someone should look at. The
    run is the same: only keys that change nothing are left out. Returns the scene."""
    used = SCHEME_PARAMS[scene.get("scheme.name")]
    names = [f"scheme.{k}" for k in ("alpha", "beta", "gamma", "theta", "rho_inf")
             if k not in used]
    method = scene.get("contact.method")
    if method != "nitsche":
        names.append("contact.theta")
    if method != "alm":
        names.append("contact.multiplier")
    if scene.get("contact.quadrature") != "gauss":
        names.append("contact.quad_points")
    if scene.get("initial.kind") != "compressed_bar":
        names.append("initial.amplitude")
    if scene.get("mesh.file").lower().endswith(".msh"):
        names += ["mesh.h", "mesh.width"]
        if scene.get("initial.kind") != "compressed_bar":
            names.append("mesh.length")
    scene.unset(*[n for n in names if scene.given(n)])
    return scene


def design_warnings(scene) -> list[str]:
    """The patterns (regexes) of the warnings the core gives, by design, about a choice
    `scene` makes (docs/scenes.md, "Warnings and notes"): the augmented Lagrangian on a
    mass other than the redistributed one, the redistributed mass with a scheme that
    weighs its massless dofs half at each end of the step, central's dt = 0 where the
    estimate is not a safe bound, no contact boundary (&boundary contact = ''). Every one
    is a choice a test can make on purpose."""
    found = []
    contact = bool(scene.get("boundary.contact"))
    if not contact:
        found.append(r"no contact boundary \(&boundary contact = ''\)")
    mass, name = scene.get("scheme.mass"), scene.get("scheme.name")
    method = scene.get("contact.method")
    if contact and method == "alm" and mass != "redistributed":
        found.append(f"&contact method = 'alm' with &scheme mass = '{mass}'")
    if contact and mass == "redistributed" and (
            (name == "galpha" and scene.get("scheme.rho_inf") >= 1.0)
            or (name == "theta" and scene.get("scheme.theta") <= 0.5)):
        found.append("&scheme mass = 'redistributed' with")
    if contact and name == "central" and scene.get("scheme.dt") == 0.0:
        if method == "nitsche" and scene.get("contact.theta") != 1:
            found.append("&scheme dt = 0 picks at most .* with &contact theta")
        elif scene.dimension() == 1:
            found.append("&scheme dt = 0 picks at most .* in 1D")
    return found


@contextmanager
def warns_as_designed(scene):
    """A block that opens a run of `scene`: when it ends without an exception (a refused
    scene gives no warnings) it must have given each of design_warnings(scene), as
    pytest.warns would check (the test runs that case on purpose); any other warning goes
    on to the caller's filters (the suite's summary)."""
    import re
    import warnings

    from dyncontact.core import DyncontactWarning

    patterns = design_warnings(scene)
    raised = True
    seen: list = []
    try:
        with warnings.catch_warnings(record=True) as seen:
            warnings.simplefilter("always")
            yield
        raised = False
    finally:
        expected = [w for w in seen if issubclass(w.category, DyncontactWarning)
                    and any(re.search(p, str(w.message)) for p in patterns)]
        for w in seen:
            if w not in expected:
                warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    if not raised:
        for p in patterns:
            assert any(re.search(p, str(w.message)) for w in expected), \
                f"the run did not warn as designed: {p!r} (warnings: " \
                f"{[str(w.message) for w in seen]})"


def run_as_designed(scene, out=None, **kwargs):
    """dyncontact.run(scene, out, ...) (progress off unless given) of drop_unused(scene)
    (a Scene; a scene file is run as it is), expecting its design_warnings
    (warns_as_designed): a test's run of a switched base scene."""
    import dyncontact

    kwargs.setdefault("progress", False)
    if isinstance(scene, dyncontact.Scene):
        designed = drop_unused(scene)
    else:
        designed = dyncontact.Scene.read(scene)
    with warns_as_designed(designed):
        return dyncontact.run(scene, out=out, **kwargs)


def stepper_as_designed(scene, out):
    """A dyncontact Stepper of drop_unused(scene), its design_warnings expected; use it as
    the Stepper: ``with stepper_as_designed(s, out) as run:``."""
    from dyncontact.core import Stepper

    with warns_as_designed(drop_unused(scene)):
        return Stepper(scene, out)


def scene_beside_its_mesh(folder: Path, t_end: float, out_dir: str) -> Path:
    """A scene file folder/s.nml whose mesh, a copy of the seed's GetFEM mesh at h = 0.05,
    is named relative to the scene (folder/meshes/...), as a user's own folder of scenes
    holds them: the compressed bar, Δt = 0.01 to t_end, &output dir = out_dir."""
    (folder / "meshes").mkdir(parents=True)
    shutil.copy(ROOT / "meshes" / "bar2d_getfem_h0.05.msh", folder / "meshes")
    scene = folder / "s.nml"
    scene.write_text("&mesh file = 'meshes/bar2d_getfem_h0.05.msh' /\n"
                     "&initial kind = 'compressed_bar' /\n"
                     f"&scheme dt = 0.01, t_end = {t_end} /\n&output dir = '{out_dir}' /\n")
    return scene


@contextmanager
def gmsh_session(model: str):
    """A gmsh session of the test's own, opened as a caller of the package would: gmsh
    initialized without config files, terminal output off, `model` added (the current
    one); finalized on leaving. Tests set up with it, not with mesh_io._gmsh_session,
    which is what some of them check."""
    import gmsh

    gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add(model)
        yield gmsh
    finally:
        gmsh.finalize()


@contextmanager
def callers_gmsh_session():
    """gmsh_session("mine") holding one point (entities [(0, 1)]): the caller's session
    that a read or a generation by the package must leave as it found it."""
    with gmsh_session("mine") as gmsh:
        gmsh.model.occ.addPoint(0, 0, 0)
        gmsh.model.occ.synchronize()
        yield gmsh


def write_msh41(gmsh, path) -> None:
    """Write gmsh's current model to path as MSH 4.1, ASCII."""
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.option.setNumber("Mesh.Binary", 0)
    gmsh.write(str(path))


def occ_disk(gmsh, radius: float, h: float):
    """A disk of the given radius centred at (0, radius) in gmsh's current model (OCC: four
    quarter arcs, counter-clockwise from (radius, radius)), synchronized, with mesh size at
    most h; returns (surface tag, [arc tags])."""
    import numpy as np

    occ = gmsh.model.occ
    c = occ.addPoint(0, radius, 0)
    p = [occ.addPoint(radius * np.cos(a), radius + radius * np.sin(a), 0)
         for a in (0.0, np.pi / 2, np.pi, 1.5 * np.pi)]
    arcs = [occ.addCircleArc(p[i], c, p[(i + 1) % 4]) for i in range(4)]
    s = occ.addPlaneSurface([occ.addCurveLoop(arcs)])
    occ.synchronize()
    gmsh.option.setNumber("Mesh.MeshSizeMax", h)
    return s, arcs


@pytest.fixture
def tmpfs(tmp_path):
    """mount(options) -> a folder on a fresh tmpfs with those options (root only; else
    skip); unmounted at the end. For the tests of a full disk."""
    mounted = []

    def mount(options: str) -> Path:
        mnt = tmp_path / f"disk{len(mounted)}"
        mnt.mkdir()
        res = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(mnt)],
                             capture_output=True, text=True)
        if res.returncode != 0:
            pytest.skip(f"cannot mount a tmpfs here ({res.stderr.strip()})")
        mounted.append(mnt)
        return mnt

    yield mount
    for mnt in mounted:
        subprocess.run(["umount", "-l", str(mnt)], capture_output=True)
