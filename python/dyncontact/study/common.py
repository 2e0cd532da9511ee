"""Shared pieces of the studies, the figures and the benchmark: base scenes, named runs
of the seed's bar, the scheme catalogue, CSV/markdown/plots."""

from __future__ import annotations

import argparse
import contextlib
import csv
import dataclasses
import functools
import math
import os
import sys
from typing import Any, Iterable, Iterator, Mapping, Sequence

from ..core import BadInputError, Model
from .sweep import SCHEDULER_TIMEOUT_S, default_scheduler_timeout

__all__ = ["SchemeSpec", "SCHEMES", "scheme_list", "step_ratio", "PENALTY_GAMMA0",
           "CENTRAL_C", "write_base_scenes", "study_folder", "write_csv",
           "md_table", "fmt", "slope", "new_figure", "save_figure", "STATUS_COLORS",
           "RunSpec", "seed_spec", "every_for", "scheme_text", "num", "loadavg",
           "package_version", "add_runner_options", "MAX_ROWS", "OneLineParser",
           "positive", "mesh_sizes", "UserScene", "UserSceneError", "read_user_scene", "on_scene",
           "refusal_on_scene", "scene_step_ratio", "critical_step_estimate",
           "contact_free_by_design", "ticks_at", "wrapped_suptitle"]

#: The 1D exact case of SPEC section 2 (Dabaghi-Petrov-Pousin-Renard 2016). The base
#: scenes give no key that a study's scheme or method may not use (the scheme's
#: parameters, the Nitsche theta: their defaults, newmark 1/4 1/2 and theta = 1, are
#: the runs'), so that the run's warnings about unused keys are about the study's own
#: settings.
EXACT_1D = """\
! 1D impact with a closed form (docs/numerics.md, the seed's test case), by dyncontact.study.
&mesh     file = '', dim = 1, length = 1.0, h = 0.04 /
&boundary clamped = 'top', contact = 'bottom' /
&material young = 1.0, poisson = 0.0, density = 1.0 /
&contact  method = 'nitsche', gamma0 = 10.0,
          obstacle_point = 0.0, obstacle_normal = -1.0, probe = 0.0 /
&initial  kind = 'compressed_bar', amplitude = 0.5 /
&scheme   name = 'newmark', dt = 0.002, t_end = 3.0, mass = 'consistent' /
&output   dir = 'out', every = 1, fields_every = 0 /
"""

#: The seed's 2D bar (SPEC section 2): built-in mesh, theta = 1 (the default), gamma0 =
#: 10, hht with alpha = 0 (the default).
SEED_2D = """\
! The seed's 2D bar (docs/numerics.md, "The seed's test case"), written by dyncontact.study.
&mesh     file = '', dim = 2, length = 1.0, width = 0.1, h = 0.05 /
&boundary clamped = 'top', contact = 'bottom' /
&material young = 0.6666666666666666, poisson = 0.3333333333333333, density = 1.0 /
&contact  method = 'nitsche', gamma0 = 10.0,
          obstacle_point = 0.0, 0.0, obstacle_normal = 0.0, -1.0, probe = 0.05, 0.0 /
&initial  kind = 'compressed_bar', amplitude = 0.5 /
&scheme   name = 'hht', dt = 0.0025, t_end = 15.0, mass = 'consistent' /
&output   dir = 'out', every = 1, fields_every = 0 /
"""


def write_base_scenes(folder: str) -> dict[str, str]:
    """Write the base scenes into folder; returns {'exact1d': path, 'seed2d': path}."""
    os.makedirs(folder, exist_ok=True)
    paths = {}
    for name, text in (("exact1d", EXACT_1D), ("seed2d", SEED_2D)):
        p = os.path.abspath(os.path.join(folder, f"base_{name}.nml"))
        if not os.path.isfile(p) or open(p, encoding="utf-8").read() != text:
            with open(p, "w", encoding="utf-8") as f:
                f.write(text)
        paths[name] = p
    return paths


def study_folder(out: str, cache: str | None) -> tuple[str, str, dict[str, str]]:
    """A study's output folder ``out`` made absolute and created, its run cache
    (``cache``, else out/cache) and its base scenes (written into out/scenes by
    :func:`write_base_scenes`)."""
    out = os.path.abspath(out)
    os.makedirs(out, exist_ok=True)
    return out, cache or os.path.join(out, "cache"), write_base_scenes(os.path.join(out, "scenes"))


# --------------------------------------------------------------------------- named runs

#: Trace rows a figure run keeps at most (output.every is chosen for it).
MAX_ROWS = 3000


def num(x: float) -> str:
    """A number as it appears in run names and labels: 0.05, 0.0025, -0.1, 1e-05."""
    return f"{float(x):.6g}"


@dataclasses.dataclass
class RunSpec:
    """One run with a name (its output folder) and the scene keys it sets.

    ``settings`` maps 'group.key' to a value (``Scene.set``), applied to the scene file
    ``base`` or, when ``base`` is None, to the built-in default scene (the seed's test
    case). ``label`` (optional) is the legend text; by default the figures use
    :func:`dyncontact.plotting.run_label` of the run's summary.
    """

    name: str
    settings: dict[str, Any]
    base: str | None = None
    label: str | None = None

    def scene(self):
        """The :class:`dyncontact.Scene` of this run."""
        from ..scene import Scene

        scn = Scene.read(self.base) if self.base else Scene()
        for key, value in self.settings.items():
            scn.set(key, value)
        return scn

    def task(self, analysis: str = "outputs"):
        """This run as a :class:`.sweep.Task` (tagged with its name)."""
        from .sweep import make_task

        return make_task(self.base, self.settings, analysis, tags={"name": self.name})

    def get(self, key: str) -> Any:
        """A scene key of this run: its setting, or the base scene's value."""
        return self.settings[key] if key in self.settings else self.scene().get(key)

    def estimated_steps(self) -> int:
        """Steps to t_end (the run stops earlier if it blows up)."""
        dt, t_end = float(self.get("scheme.dt")), float(self.get("scheme.t_end"))
        return max(0, math.ceil(t_end / dt - 1e-9))


def every_for(t_end: float, dt: float, max_rows: int = MAX_ROWS) -> int:
    """The smallest output.every that keeps a trace to at most ~max_rows rows."""
    steps = max(1, math.ceil(float(t_end) / float(dt) - 1e-9))
    return max(1, math.ceil(steps / max_rows))


_SCHEME_KEYS = {"alpha": "a", "beta": "b", "gamma": "g", "theta": "th"}


def seed_spec(scheme: str, h: float, dt: float, t_end: float, *, mass: str = "consistent",
              every: int | None = None, max_rows: int | None = MAX_ROWS,
              fields_every: int = 0, prefix: str = "", **params: float) -> RunSpec:
    """A run of the seed's 2D bar (the built-in default scene) with one scheme.

    ``params`` are scheme keys (alpha, beta, gamma, theta). ``every`` = output.every;
    None: :func:`every_for` (max_rows), or 1 when max_rows is None. The name says all:
    ``hht_a-0.05_h0.02_dt0.001_T15`` (+ ``_lumped``).
    """
    dt = round(float(dt), 15)
    if every is None:
        every = 1 if max_rows is None else every_for(t_end, dt, max_rows)
    settings: dict[str, Any] = {"mesh.h": float(h), "scheme.name": scheme,
                                "scheme.dt": dt, "scheme.t_end": float(t_end),
                                "scheme.mass": mass, "output.every": int(every),
                                "output.fields_every": int(fields_every)}
    tag = [scheme]
    for key, value in params.items():
        if key not in _SCHEME_KEYS:
            raise ValueError(f"unknown scheme parameter {key!r}")
        settings[f"scheme.{key}"] = float(value)
        tag.append(f"{_SCHEME_KEYS[key]}{num(value)}")
    name = "_".join(tag) + f"_h{num(h)}_dt{num(dt)}_T{num(t_end)}"
    if mass != "consistent":
        name += f"_{mass}"
    return RunSpec(name=prefix + name, settings=settings)


def scheme_text(settings: Mapping[str, Any], base: str | None = None) -> str:
    """A run's scheme as a report shows it: 'pc β=0.25, γ=0.5, lumped mass'.

    ``settings`` and ``base`` as a :class:`RunSpec`'s: the scheme and mass a key of
    ``settings`` does not set are those of the scene file ``base`` (the built-in
    default scene's, hht and consistent, when there is none), the scene the run ran.
    The parameters shown are those ``settings`` sets."""
    name, mass = settings.get("scheme.name"), settings.get("scheme.mass")
    if (name is None or mass is None) and base:
        from ..scene import Scene

        scn = Scene.read(base)
        name = scn.get("scheme.name") if name is None else name
        mass = scn.get("scheme.mass") if mass is None else mass
    name = "hht" if name is None else name
    params = [f"{sym}={num(settings[f'scheme.{k}'])}"
              for k, sym in (("alpha", "α"), ("beta", "β"), ("gamma", "γ"), ("theta", "θ"))
              if f"scheme.{k}" in settings]
    text = name + (" " + ", ".join(params) if params else "")
    if (mass or "consistent") != "consistent":
        text += f", {mass} mass"
    return text


@contextlib.contextmanager
def environment(env: Mapping[str, str] | None) -> Iterator[None]:
    """Set the variables of ``env`` in os.environ for the body of a with block (the core
    reads its DYNCONTACT_* switches when a run opens), then restore what was there."""
    old = {k: os.environ.get(k) for k in (env or {})}
    os.environ.update(env or {})
    try:
        yield
    finally:
        for k, v in old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def loadavg() -> list[float] | None:
    """The machine's load averages (1, 5, 15 min), or None where there are none."""
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except (AttributeError, OSError):
        return None


def package_version() -> str:
    from .. import __version__

    return __version__


class OneLineParser(argparse.ArgumentParser):
    """argparse whose errors are one line on stderr, ``LABEL: MESSAGE (see `PROG --help`)``,
    and exit status 2, as every command of the project reports a bad command line
    (docs/scenes.md, *Exit codes*). ``label`` is the command's name as its other messages
    give it (default: ``prog``); the sub-parsers of :meth:`add_subparsers` keep it."""

    def __init__(self, *args, label: str | None = None, **kwargs):
        super().__init__(*args, **kwargs)
        self.label = label or self.prog

    def add_subparsers(self, **kwargs):  # noqa: D102 - argparse API
        kwargs.setdefault("parser_class", functools.partial(OneLineParser, label=self.label))
        return super().add_subparsers(**kwargs)

    def error(self, message):  # noqa: D102 - argparse API
        one = " ".join(str(message).split())
        print(f"{self.label}: {one} (see `{self.prog} --help`)", file=sys.stderr)
        raise SystemExit(2)


def positive(kind: type) -> Any:
    """argparse type: a finite number > 0 of ``kind``, float or int (an int >= 1)."""
    what = "an integer >= 1" if kind is int else "a number > 0"

    def convert(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
        if not (math.isfinite(value) and value > 0):
            raise argparse.ArgumentTypeError(
                f"must be {'>= 1' if kind is int else 'a finite number > 0'}, got {text!r}")
        return value

    convert.__name__ = kind.__name__   # argparse names the type in its messages
    return convert


def mesh_sizes(text: str) -> list[float]:
    """argparse type: comma-separated mesh sizes, each finite and > 0."""
    sizes = []
    for item in (t.strip() for t in text.split(",")):
        if not item:
            continue
        try:
            h = float(item)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{item!r} is not a number") from None
        if not (h > 0 and h != float("inf")):
            raise argparse.ArgumentTypeError(f"h = {item} (each size must be finite and > 0)")
        sizes.append(h)
    if not sizes:
        raise argparse.ArgumentTypeError(f"no size given in {text!r}")
    return sizes


@contextlib.contextmanager
def scheduler_timeout(args) -> Iterator[None]:
    """The sweeps of the block wait ``args.scheduler_timeout`` seconds for the scheduler
    when ``args.scheduler`` is given (:func:`~dyncontact.study.sweep.default_scheduler_timeout`;
    :class:`~dyncontact.study.sweep.SchedulerUnreachable` after it)."""
    if getattr(args, "scheduler", None) is None:
        yield
        return
    with default_scheduler_timeout(args.scheduler_timeout):
        yield


def scheduler_unreachable_line(label: str, args, exc) -> str:
    """The one line of a command whose --scheduler did not answer (exit status 2)."""
    return (f"{label}: --scheduler {exc.address}: no Dask scheduler answers there within "
            f"{args.scheduler_timeout:g} s (is it running? --scheduler-timeout SECONDS waits "
            "longer)")


def add_runner_options(parser, *worker_aliases: str) -> None:
    """The sweep runner's options, the same for every command that runs a sweep:
    --workers N (and ``worker_aliases``) or --scheduler ADDRESS (not both: a Dask
    cluster's workers are its own, started with it, so N would size nothing; the pair is a
    usage error naming both, exit status 2), --scheduler-timeout SECONDS and --cache DIR."""
    runner = parser.add_mutually_exclusive_group()
    runner.add_argument("--workers", *worker_aliases, dest="workers", type=int,
                        default=None, metavar="N",
                        help="processes of the local pool (default: all cores)")
    runner.add_argument("--scheduler", metavar="ADDRESS", default=None,
                        help="run on this dask.distributed scheduler instead of the pool "
                             "(on the cluster's own workers: not with --workers)")
    parser.add_argument("--scheduler-timeout", metavar="SECONDS", type=positive(float),
                        default=SCHEDULER_TIMEOUT_S,
                        help="seconds to wait for the scheduler to answer (default "
                             f"{SCHEDULER_TIMEOUT_S:g}; exit 2 naming it when none does)")
    parser.add_argument("--cache", metavar="DIR", default=None,
                        help="per-run cache (default: OUT/cache)")


# --------------------------------------------------------------------------- schemes

@dataclasses.dataclass(frozen=True)
class SchemeSpec:
    """A scheme with its parameters: ``key`` (command line), ``label`` (plots, tables),
    ``settings`` (scene keys), ``explicit`` (no Newton solve: the predictor-corrector
    family and central differences), ``c``: its own step Δt = h/c in the convergence and
    work-precision studies (None: the family's default, 20 implicit / 100 explicit)."""

    key: str
    label: str
    settings: tuple[tuple[str, Any], ...]
    explicit: bool = False
    c: float | None = None

    @property
    def mass(self) -> str:
        return dict(self.settings).get("scheme.mass", "consistent")

    @property
    def method(self) -> str:
        """The contact method: 'nitsche' (the scenes' default), 'penalty' or 'alm'."""
        return dict(self.settings).get("contact.method", "nitsche")


def _s(key, label, explicit=False, c=None, contact=None, **kw) -> SchemeSpec:
    settings = {"scheme.name": kw.pop("name")}
    settings.update({f"scheme.{k}": v for k, v in kw.items()})
    settings.setdefault("scheme.mass", "consistent")
    settings.update({f"contact.{k}": v for k, v in (contact or {}).items()})
    return SchemeSpec(key, label, tuple(settings.items()), explicit, c)


#: The penalty parameter of the penalty rows, ε_N = PENALTY_GAMMA0/h_T: the seed's Nitsche
#: γ0 = 10, so that both methods have the same contact stiffness scale (the stability
#: study sweeps it like Nitsche's γ0).
PENALTY_GAMMA0 = 10.0
#: central differences run at Δt = h/CENTRAL_C in the convergence and work-precision
#: studies: about half the critical step the run estimates on both cases at γ0 = 10
#: (0.47 h in 1D, 0.55 h on the seed's 2D bar with lumped mass).
CENTRAL_C = 4.0


#: Every scheme the studies know, by command-line key.
SCHEMES: dict[str, SchemeSpec] = {s.key: s for s in (
    _s("newmark", "newmark β=¼ γ=½", name="newmark", beta=0.25, gamma=0.5),
    _s("newmark_diss", "newmark β=0.3025 γ=0.6", name="newmark", beta=0.3025, gamma=0.6),
    # β < γ/2: conditionally stable; a product carried instead of formed from its vector
    # would grow by round-off here (docs/numerics.md, "The state and the products")
    _s("newmark_g0.6", "newmark β=¼ γ=0.6", name="newmark", beta=0.25, gamma=0.6),
    _s("hht-0.05", "hht α=-0.05", name="hht", alpha=-0.05),
    _s("hht-0.1", "hht α=-0.1", name="hht", alpha=-0.1),
    _s("hht_seed-0.1", "hht_seed α=-0.1", name="hht_seed", alpha=-0.1),
    _s("theta0.5", "theta θ=½", name="theta", theta=0.5),
    _s("theta1", "theta θ=1", name="theta", theta=1.0),
    _s("pc", "pc β=¼ γ=½", True, name="pc", beta=0.25, gamma=0.5),
    _s("pc_lumped", "pc β=¼ γ=½ lumped", True, name="pc", beta=0.25, gamma=0.5,
       mass="lumped"),
    _s("pc_hht-0.1", "pc_hht α=-0.1", True, name="pc_hht", alpha=-0.1),
    _s("pc_hht_seed-0.1", "pc_hht_seed α=-0.1", True, name="pc_hht_seed", alpha=-0.1),
    # beyond the seed: generalized-α, central differences, lumped/redistributed mass, penalty
    _s("galpha1", "galpha ρ∞=1", name="galpha", rho_inf=1.0),
    _s("galpha0.8", "galpha ρ∞=0.8", name="galpha", rho_inf=0.8),
    _s("galpha0.5", "galpha ρ∞=0.5", name="galpha", rho_inf=0.5),
    _s("central_lumped", "central lumped", True, CENTRAL_C, name="central", mass="lumped"),
    _s("central", "central consistent", True, CENTRAL_C, name="central"),
    _s("newmark_lumped", "newmark β=¼ γ=½ lumped", name="newmark", beta=0.25, gamma=0.5,
       mass="lumped"),
    _s("newmark_redist", "newmark β=¼ γ=½ redistributed", name="newmark", beta=0.25,
       gamma=0.5, mass="redistributed"),
    _s("hht-0.1_redist", "hht α=-0.1 redistributed", name="hht", alpha=-0.1,
       mass="redistributed"),
    _s("newmark_penalty", f"newmark β=¼ γ=½ penalty γ0={PENALTY_GAMMA0:g}", name="newmark",
       beta=0.25, gamma=0.5, contact={"method": "penalty", "gamma0": PENALTY_GAMMA0}),
    _s("hht-0.1_penalty", f"hht α=-0.1 penalty γ0={PENALTY_GAMMA0:g}", name="hht",
       alpha=-0.1, contact={"method": "penalty", "gamma0": PENALTY_GAMMA0}),
    # stiffer penalties (the oscillation sweep: chattering with the trapezoidal rule)
    _s("newmark_penalty100", "newmark β=¼ γ=½ penalty γ0=100", name="newmark", beta=0.25,
       gamma=0.5, contact={"method": "penalty", "gamma0": 100.0}),
    _s("newmark_penalty1000", "newmark β=¼ γ=½ penalty γ0=1000", name="newmark", beta=0.25,
       gamma=0.5, contact={"method": "penalty", "gamma0": 1000.0}),
    # the augmented Lagrangian (r = γ0/h_T, the scene's γ0): integral and nodal
    # multipliers, with the consistent mass (where a multiplier method chatters) and the
    # redistributed one (where it behaves)
    _s("newmark_alm", "newmark β=¼ γ=½ ALM integral", name="newmark", beta=0.25, gamma=0.5,
       contact={"method": "alm", "multiplier": "integral"}),
    _s("newmark_alm_nodal", "newmark β=¼ γ=½ ALM nodal", name="newmark", beta=0.25,
       gamma=0.5, contact={"method": "alm", "multiplier": "nodal"}),
    _s("newmark_alm_redist", "newmark β=¼ γ=½ ALM integral redistributed", name="newmark",
       beta=0.25, gamma=0.5, mass="redistributed",
       contact={"method": "alm", "multiplier": "integral"}),
    _s("newmark_alm_nodal_redist", "newmark β=¼ γ=½ ALM nodal redistributed", name="newmark",
       beta=0.25, gamma=0.5, mass="redistributed",
       contact={"method": "alm", "multiplier": "nodal"}),
    _s("hht-0.1_alm_redist", "hht α=-0.1 ALM integral redistributed", name="hht",
       alpha=-0.1, mass="redistributed", contact={"method": "alm", "multiplier": "integral"}),
    _s("hht-0.1_alm_nodal_redist", "hht α=-0.1 ALM nodal redistributed", name="hht",
       alpha=-0.1, mass="redistributed", contact={"method": "alm", "multiplier": "nodal"}),
)}


class UserSceneError(BadInputError):
    """A scene of one's own that a study refuses (a :class:`dyncontact.BadInputError`):
    ``scene`` names the scene file the study reads, ``why`` is what is wrong. The line is
    ``SCENE: WHY`` (``WHY`` alone when it names the file already, as the core's refusals
    do); the command line, where the scene came from ``--scene``, says
    ``--scene SCENE: WHY``."""

    def __init__(self, scene: str, why: str) -> None:
        self.scene, self.why = scene, why
        super().__init__(why if why.startswith(f"{scene}: ") else f"{scene}: {why}")


@dataclasses.dataclass(frozen=True)
class UserScene:
    """A scene file of one's own for ``study ... --scene``: its absolute ``path`` and the
    keys the studies derive their runs from (the scene's own values; ``dim``: the mesh's
    dimension, 1, 2 or 3, also when the scene leaves ``&mesh dim`` at 0; ``h_given``:
    whether the scene gives ``&mesh h``, without which a .geo is meshed with its own
    sizes; ``length`` and ``width``: the .geo's parameters of those names, None where the
    scene does not give them: a .geo that defines them then keeps its own values)."""

    path: str
    dim: int
    h: float
    dt: float
    t_end: float
    mass: str
    method: str
    gamma0: float
    theta: int
    mesh_file: str
    scheme: str = "hht"
    h_given: bool = True
    length: float | None = 1.0
    width: float | None = 0.1


def read_user_scene(path, out: str | None = None) -> UserScene:
    """The scene file ``path`` as a :class:`UserScene`; :class:`UserSceneError` (a
    :class:`dyncontact.BadInputError`, a ValueError) with one line naming the file when
    it is missing, refused by the core, or has no time step of its own (dt = 0, the
    automatic step of central differences: the ladders are multiples of it).
    ``path`` may also be a :class:`dyncontact.Scene` (a scene built or edited in Python):
    it is written as ``out/scene.nml`` (``Scene.write``: its mesh file made absolute),
    the file the study's runs then read and its messages name (a Scene that cannot be
    written: the Scene's own message, :class:`dyncontact.BadInputError`); TypeError for
    anything else."""
    from ..scene import Scene

    if isinstance(path, Scene):
        if out is None:
            raise TypeError("a Scene needs the study's output folder to be written into")
        os.makedirs(out, exist_ok=True)
        scene, path = path, os.path.join(os.path.abspath(out), "scene.nml")
        try:
            scene.copy().write(path)   # the caller's Scene left as it is (not normalized)
        except Exception as exc:  # noqa: BLE001 - refused by the core: its one line,
            raise BadInputError(" ".join(str(exc).split())) from None   # naming the scene
    elif isinstance(path, os.PathLike):
        path = os.fspath(path)
    elif not isinstance(path, str):
        raise TypeError(f"scene: a scene file's path or a dyncontact.Scene, not "
                        f"{type(path).__name__}")
    if not os.path.isfile(path):
        raise UserSceneError(path, "no such file")
    try:
        scn = Scene.read(path)
        scn.validate()
        values = {k: scn.get(k) for k in ("mesh.h", "scheme.dt", "scheme.t_end",
                                          "scheme.mass", "contact.method", "contact.gamma0",
                                          "contact.theta", "mesh.file", "scheme.name",
                                          "mesh.length", "mesh.width")}
        values["h_given"] = scn.given("mesh.h")
        for k in ("mesh.length", "mesh.width"):     # None: the .geo's own, if it has one
            if not scn.given(k):
                values[k] = None
        # the mesh's dimension, not &mesh dim: 0 (the default) means the file's, or 2D
        values["dim"] = scn.dimension()
        # the checks that need the mesh (a group it lacks, a probe off the contact
        # boundary, gamma0 below the element bound), which every run of the study would
        # fail on: said here, once, before anything runs
        with Model(path):
            pass
    except Exception as exc:  # noqa: BLE001 - any refusal of the scene: one line
        raise UserSceneError(path, " ".join(str(exc).split())) from None
    if not values["scheme.dt"] > 0:
        hint = ("; central's automatic step is chosen when the scene runs: `python -m "
                "dyncontact run` it once and give the Δt its summary.json records "
                "(scene.scheme.dt)"
                if values["scheme.name"] == "central" else "")
        raise UserSceneError(path, f"&scheme dt = {values['scheme.dt']:g}: the study "
                             "derives its time steps from the scene's, give one > 0"
                             f"{hint}")
    return UserScene(os.path.abspath(path), int(values["dim"]),
                     float(values["mesh.h"]), float(values["scheme.dt"]),
                     float(values["scheme.t_end"]), str(values["scheme.mass"]),
                     str(values["contact.method"]), float(values["contact.gamma0"]),
                     int(values["contact.theta"]), str(values["mesh.file"] or ""),
                     str(values["scheme.name"]), bool(values["h_given"]),
                     *(None if values[k] is None else float(values[k])
                       for k in ("mesh.length", "mesh.width")))


def on_scene(s: SchemeSpec, scene: UserScene) -> SchemeSpec:
    """Scheme ``s`` as a time scheme on ``scene``'s space discretization: its ``scheme.*``
    keys but the scene's mass and contact (method, γ0, multiplier), so that every scheme
    of a scene study solves the same semi-discrete problem as the scene and its
    reference. The label is the scheme's own when that changes nothing, else the scheme
    as :func:`scheme_text` writes it on the scene's mass."""
    settings = {k: v for k, v in s.settings
                if k.startswith("scheme.") and k != "scheme.mass"}
    settings["scheme.mass"] = scene.mass
    if scene.method != "nitsche":
        settings["contact.method"] = scene.method
    same = s.mass == scene.mass and s.method == scene.method and all(
        not k.startswith("contact.") or k == "contact.method" for k, _ in s.settings)
    label = s.label if same else scheme_text(settings)
    return SchemeSpec(s.key, label, tuple(settings.items()), s.explicit, s.c)


def _scene_with(s: SchemeSpec, scene: UserScene):
    """``scene``'s file read as a :class:`dyncontact.Scene`, with scheme ``s``'s keys set
    (as :func:`on_scene` gives it)."""
    from ..scene import Scene

    scn = Scene.read(scene.path)
    for key, value in s.settings:
        scn.set(key, value)
    return scn


def refusal_on_scene(s: SchemeSpec, scene: UserScene) -> str | None:
    """Why the core refuses scheme ``s`` (as :func:`on_scene` gives it) on ``scene``
    (one line: an explicit scheme with the augmented Lagrangian or the redistributed
    mass), or None when it takes it. Only the scene is parsed, nothing is run."""
    try:
        scn = _scene_with(s, scene)
        scn.validate(mesh=False)      # the scene's mesh was checked once, when it was read
    except Exception as exc:  # noqa: BLE001 - the core's reason, whatever its class
        return " ".join(str(exc).replace(scene.path + ": ", "").split())
    return None


def critical_step_estimate(s: SchemeSpec, scene: UserScene) -> float | None:
    """The core's estimate of the critical step of scheme ``s`` (as :func:`on_scene` gives
    it) on ``scene``: summary.json's ``dt_crit_estimate`` of the scene run with ``s``'s
    keys, opened and closed without a step (a :class:`dyncontact.core.Stepper`: the
    model's set-up and the power iterations, no time step; about 12 ms on the seed's bar
    at h = 0.01). Omega_c/omega_max at full contact, approached from above
    (docs/numerics.md, "Explicit schemes"): it depends on the mesh, material, mass and
    contact and on the scheme's parameters, not on Δt or T. None for a scheme that has
    none (an implicit one) or that the core refuses on the scene; 0.0 where no step is
    stable (pc_hht_seed with α < 0). The run's warnings are left out: they are those of
    the study's own runs of the scheme, which the sweep records."""
    import tempfile
    import warnings

    from ..core import DyncontactError, DyncontactWarning, Stepper, read_summary

    if not s.explicit:
        return None
    try:
        scn = _scene_with(s, scene)
        scn.set("output.fields_every", 0)
        scn.set("output.checkpoint_every", 0)
        with tempfile.TemporaryDirectory(prefix="dyncontact-dtcrit-") as tmp:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", DyncontactWarning)
                with Stepper(scn, tmp):
                    pass
            est = read_summary(tmp).get("dt_crit_estimate")
    except (DyncontactError, ValueError, OSError):
        return None
    return None if est is None else float(est)


@contextlib.contextmanager
def contact_free_by_design(free: bool = True) -> Iterator[None]:
    """Within the block, the core's warning that a run has no contact boundary (its probe
    then reports nothing) is left out when ``free``: the benchmarks' contact-free rows
    are so by design, and the warning is not news to them (it came once a run). Any other
    warning goes on to the caller."""
    import warnings

    from ..core import DyncontactWarning

    with warnings.catch_warnings():
        if free:
            warnings.filterwarnings("ignore", "warning: no contact boundary",
                                    DyncontactWarning)
        yield


def step_ratio(s: SchemeSpec, c_implicit: float, c_explicit: float) -> float:
    """c in Δt = h/c for scheme s: its own, else the family's."""
    if s.c is not None:
        return float(s.c)
    return c_explicit if s.explicit else c_implicit


def scene_step_ratio(scene: UserScene, c_implicit: float, c_explicit: float) -> float:
    """The c that ``scene``'s own Δt stands for: its scheme is run at Δt = h/c in the
    studies, so a scheme of ratio c' runs at the scene's Δt × c/c'. It is
    :func:`step_ratio` of the studies' schemes of the scene's &scheme name (central's own
    CENTRAL_C, the explicit family's c for the pc schemes, the implicit one's else). A
    scene written for central at its stable step thus runs central at that step (and
    the implicit schemes at a CENTRAL_C/c_implicit of it), not at c_implicit/CENTRAL_C
    times it, past its stability limit."""
    for s in SCHEMES.values():
        if dict(s.settings)["scheme.name"] == scene.scheme:
            return step_ratio(s, c_implicit, c_explicit)
    return c_implicit


def scheme_list(keys: str | Sequence[str]) -> list[SchemeSpec]:
    """Schemes from a comma-separated list of keys (ValueError names a bad key, and
    refuses an empty list: a study of no scheme is a mistake, not a request for all; and
    a key given twice, whose runs would be counted twice in the study's fits, its tables
    and its CSVs)."""
    if isinstance(keys, str):
        keys = [k.strip() for k in keys.split(",") if k.strip()]
    if not keys:
        raise ValueError(f"no scheme key given; known: {', '.join(SCHEMES)}")
    bad = [k for k in keys if k not in SCHEMES]
    if bad:
        raise ValueError(f"unknown scheme key(s) {', '.join(bad)}; known: "
                         f"{', '.join(SCHEMES)}")
    twice = sorted({k for k in keys if list(keys).count(k) > 1}, key=list(keys).index)
    if twice:
        raise ValueError(f"scheme key(s) given more than once: {', '.join(twice)}")
    return [SCHEMES[k] for k in keys]


# --------------------------------------------------------------------------- output

def fmt(x: Any, spec: str = ".3g") -> str:
    if x is None:
        return "-"
    if isinstance(x, str):
        return x
    try:
        xf = float(x)
    except (TypeError, ValueError):
        return str(x)
    if math.isnan(xf):
        return "-"
    return format(xf, spec)


def write_csv(path: str, rows: Sequence[Mapping[str, Any]], columns: Sequence[str]) -> str:
    """rows as CSV with exactly these columns (floats with repr precision)."""
    with open(path, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(columns)
        for r in rows:
            out = []
            for c in columns:
                v = r.get(c)
                if hasattr(v, "item") and not isinstance(v, (str, bytes)):
                    v = v.item()    # numpy scalar -> Python scalar
                if v is None or (isinstance(v, float) and math.isnan(v)):
                    out.append("")
                elif isinstance(v, float):
                    out.append(repr(v))
                else:
                    out.append(str(v))
            w.writerow(out)
    return path


def write_markdown(path: str, lines: Sequence[str]) -> str:
    """Write markdown lines (one per list item) to ``path``; returns the path."""
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(lines) + "\n")
    return path


def md_table(header: Sequence[str], rows: Iterable[Sequence[Any]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for r in rows:
        lines.append("| " + " | ".join(str(c).replace("|", "\\|") for c in r) + " |")
    return lines


def slope(xs: Sequence[float], ys: Sequence[float]) -> float:
    """Least-squares slope of log y against log x (NaN with fewer than two points)."""
    import numpy as np

    x = np.asarray(xs, dtype=float)
    y = np.asarray(ys, dtype=float)
    ok = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
    if ok.sum() < 2:
        return float("nan")
    return float(np.polyfit(np.log(x[ok]), np.log(y[ok]), 1)[0])


STATUS_COLORS = {"stable": "#2ca02c", "unstable": "#d62728", "newton_failed": "#ff7f0e",
                 "error": "#7f7f7f", "refused": "#d9d9d9"}


def new_figure(nrows: int, ncols: int, width: float = 4.0, height: float = 3.2):
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(nrows, ncols, figsize=(width * ncols, height * nrows),
                             squeeze=False)
    return fig, axes


def ticks_at(ax, values: Sequence[float], spec: str = "g") -> None:
    """The x axis of a log-log panel ticked at ``values`` alone (the sizes a study ran),
    each labelled in format ``spec``: over a decade or so the log axis's own ticks give
    one number, or numbers (4×10⁻¹) that are not the values run."""
    from matplotlib.ticker import FixedFormatter, FixedLocator, NullFormatter, NullLocator

    ax.xaxis.set_major_locator(FixedLocator(values))
    ax.xaxis.set_major_formatter(FixedFormatter([format(x, spec) for x in values]))
    ax.xaxis.set_minor_locator(NullLocator())
    ax.xaxis.set_minor_formatter(NullFormatter())


def wrapped_suptitle(fig, text: str) -> int:
    """``text`` as the figure's title at 9 points, wrapped to the figure's width (about 14
    characters an inch at that size); the number of lines, for the room the caller leaves
    above the panels."""
    import textwrap

    lines = textwrap.wrap(text, width=int(14 * fig.get_figwidth()))
    fig.suptitle("\n".join(lines), fontsize=9)
    return len(lines)


def save_figure(fig, path: str, top: float = 1.0,
                rect: tuple[float, float, float, float] | None = None) -> str:
    """Save and close; ``top`` < 1 leaves room for a suptitle, ``rect`` (the axes' box in
    figure fractions, in place of ``top``) for a legend beside them. An error names the
    file (the image writer's own do not)."""
    import matplotlib.pyplot as plt

    fig.tight_layout(rect=rect or (0, 0, 1, top))
    try:
        fig.savefig(path, dpi=110)
    except OSError as exc:   # the image writer's errors do not name the file
        raise OSError(exc.errno, exc.strerror or str(exc), path) from exc
    finally:
        plt.close(fig)
    return path
