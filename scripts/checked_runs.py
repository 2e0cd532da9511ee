"""The runs of scripts/checked, against a build of the core with runtime checks and
sanitizers (gfortran's -fcheck=all and floating-point traps, AddressSanitizer with its leak
check, UndefinedBehaviorSanitizer): the Fortran unit-test programs; the program on every
example scene and on variants of the 1D, 2D and 3D bars (each scheme, mass, Nitsche theta,
penalty, the augmented Lagrangian, the quadratures, the solvers, a restart, outputs, bad
input, blow-ups); with --python, a selection of the pytest files against the checked
extension. One line per run, then a summary; exit status 1 when any run has a finding.

Standard library only: it does not import dyncontact (whose editable install would load,
and rebuild, the extension of ./build). Run it through scripts/checked, which builds first.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "scripts" / "scenes"

#: What in a run's stderr is a finding of the checks (gfortran's -fcheck, its
#: -ffpe-trap, AddressSanitizer, LeakSanitizer, UndefinedBehaviorSanitizer).
FINDING = re.compile(
    r"Fortran runtime error|Program received signal|ERROR: AddressSanitizer"
    r"|ERROR: LeakSanitizer|runtime error:|Fortran runtime warning: (?!An array temporary)")

#: The environment of a checked run: the sanitizers stop at the first error (UBSan
#: included) and report leaks; gfortran's backtrace names the line.
SANITIZER_ENV = {
    "ASAN_OPTIONS": "detect_leaks=1:abort_on_error=0:halt_on_error=1:malloc_context_size=30",
    "UBSAN_OPTIONS": "halt_on_error=1:print_stacktrace=1",
    "GFORTRAN_ERROR_BACKTRACE": "1",
}

# ---- scene text ----------------------------------------------------------------------


def _groups(text: str) -> list[tuple[str, int, int]]:
    """(name, start of its body, index of its closing '/') of each &group, quotes and
    '!' comments outside strings respected."""
    out = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if c == "!":
            i = text.find("\n", i)
            i = n if i < 0 else i
            continue
        if c == "&":
            m = re.match(r"&(\w+)", text[i:])
            name, j, quote = m.group(1).lower(), i + m.end(), None
            body = j
            while j < n:
                ch = text[j]
                if quote:
                    if ch == quote:
                        quote = None
                elif ch in "'\"":
                    quote = ch
                elif ch == "!":
                    j = text.find("\n", j)
                    j = n if j < 0 else j
                    continue
                elif ch == "/":
                    break
                j += 1
            out.append((name, body, j))
            i = j + 1
            continue
        i += 1
    return out


def _pairs(body: str) -> list[tuple[str, str]]:
    """The key = value pairs of a group's body, in order (comment lines dropped)."""
    body = "\n".join(line for line in body.splitlines() if not line.strip().startswith("!"))
    keys = [m for m in re.finditer(r"(?:^|[,\s])([A-Za-z_]\w*)\s*=", body)
            if body[:m.start(1)].count("'") % 2 == 0 and body[:m.start(1)].count('"') % 2 == 0]
    pairs = []
    for k, m in enumerate(keys):
        end = keys[k + 1].start(1) if k + 1 < len(keys) else len(body)
        value = body[m.end():end].strip().rstrip(",").strip()
        pairs.append((m.group(1).lower(), value))
    return pairs


def edit_scene(text: str, settings: dict[str, str | None]) -> str:
    """The scene text with each 'group.key' of settings given the namelist value text
    (None: the key left out); a group it lacks is added."""
    by_group: dict[str, dict[str, str | None]] = {}
    for name, value in settings.items():
        group, key = name.split(".")
        by_group.setdefault(group, {})[key] = value
    for name, start, end in reversed(_groups(text)):
        if name not in by_group:
            continue
        want = by_group.pop(name)
        pairs = [(k, want.get(k, v)) for k, v in _pairs(text[start:end])]
        have = {k for k, _ in pairs}
        pairs += [(k, v) for k, v in want.items() if k not in have]
        body = " " + ", ".join(f"{k} = {v}" for k, v in pairs if v is not None) + " "
        text = text[:start] + body + text[end:]
    for group, want in by_group.items():
        body = ", ".join(f"{k} = {v}" for k, v in want.items() if v is not None)
        text += f"\n&{group} {body} /\n"
    return text


# ---- the runs ------------------------------------------------------------------------

BASE = {1: "bar1d.nml", 2: "bar2d_hht.nml", 3: "bar3d_hht.nml"}
#: t_end of the variant runs: past the first impact (t ~ 1.0 in 1D, 1.13 in 2D, 1.21 in 3D).
T_VARIANT = {1: "1.5", 2: "1.5", 3: "1.4"}
SCHEMES = ("newmark", "hht", "hht_seed", "theta", "galpha", "pc", "pc_hht", "pc_hht_seed",
           "central")
EXPLICIT = ("pc", "pc_hht", "pc_hht_seed", "central")
#: Each scheme's own keys; the others are left out of a variant that switches scheme.
SCHEME_KEYS = {"newmark": ("beta", "gamma"), "pc": ("beta", "gamma"), "hht": ("alpha",),
               "hht_seed": ("alpha",), "pc_hht": ("alpha",), "pc_hht_seed": ("alpha",),
               "theta": ("theta",), "galpha": ("rho_inf",), "central": ()}


class Run:
    """One run of the program: a scene (a file, or a file with settings), its expected
    exit status, and optionally a restart of it."""

    def __init__(self, name, scene, settings=None, status=0, restart_settings=None,
                 args=(), pad=""):
        self.name, self.scene, self.settings = name, scene, dict(settings or {})
        self.status, self.restart_settings, self.args = status, restart_settings, list(args)
        self.pad = pad     # text appended to the scene


def scheme_settings(dim: int, scheme: str) -> dict[str, str | None]:
    """A base scene switched to `scheme` (its own keys only), past the first impact."""
    s: dict[str, str | None] = {f"scheme.{k}": None
                                for k in ("alpha", "beta", "gamma", "theta", "rho_inf")}
    s["scheme.name"] = f"'{scheme}'"
    s["scheme.t_end"] = T_VARIANT[dim]
    if scheme == "central":
        s["scheme.dt"] = "0"                  # the automatic step under 0.9 x the estimate
        s["scheme.mass"] = "'lumped'"
    elif scheme in EXPLICIT:
        s["scheme.dt"] = {1: "0.0001", 2: "0.0005", 3: "0.0005"}[dim]
    if scheme in ("hht_seed", "pc_hht_seed"):
        s["scheme.alpha"] = "-0.1"
    return s


def runs() -> list[Run]:
    out: list[Run] = []
    # 1. every example scene, shortened to t_end = 2.5 (the seed's unstable variants blow
    # up before it: exit 3 is their expected end)
    for path in sorted(SCENES.glob("*.nml")):
        text = path.read_text()
        body = next(text[b:e] for g, b, e in _groups(text) if g == "scheme")
        t_end = float(dict(_pairs(body)).get("t_end", "15.0"))
        status = 3 if path.stem == "bar2d_hht_seed" else 0
        s = {"scheme.t_end": "2.5"} if t_end > 2.5 else {}
        out.append(Run(f"scene {path.stem}", path, s, status))
    # 2. each scheme in 1D, 2D and 3D
    for dim in (1, 2, 3):
        for scheme in SCHEMES:
            status = 3 if scheme == "hht_seed" and dim == 1 else 0
            out.append(Run(f"{dim}D {scheme}", SCENES / BASE[dim],
                           scheme_settings(dim, scheme), status))
    # 3. masses (an implicit and an explicit scheme), Nitsche theta, penalty
    for dim in (1, 2, 3):
        for mass in ("consistent", "lumped", "redistributed"):
            out.append(Run(f"{dim}D hht mass {mass}", SCENES / BASE[dim],
                           {"scheme.t_end": T_VARIANT[dim], "scheme.mass": f"'{mass}'"}))
        for mass in ("consistent", "lumped"):
            s = scheme_settings(dim, "pc")
            s["scheme.mass"] = f"'{mass}'"
            out.append(Run(f"{dim}D pc mass {mass}", SCENES / BASE[dim], s))
        for theta in ("-1", "0", "1"):
            out.append(Run(f"{dim}D hht theta {theta}", SCENES / BASE[dim],
                           {"scheme.t_end": T_VARIANT[dim], "contact.theta": theta}))
        out.append(Run(f"{dim}D hht penalty", SCENES / BASE[dim],
                       {"scheme.t_end": T_VARIANT[dim], "contact.method": "'penalty'",
                        "contact.theta": None, "contact.gamma0": "100.0"}))
        # 4. the augmented Lagrangian, both multipliers
        for mult in ("integral", "nodal"):
            out.append(Run(f"{dim}D alm {mult}", SCENES / BASE[dim],
                           {"scheme.t_end": T_VARIANT[dim], "contact.method": "'alm'",
                            "contact.theta": None, "contact.multiplier": f"'{mult}'",
                            "scheme.mass": "'redistributed'",
                            "contact.quad_points": None if dim < 3 else "3"}))
    # 5. quadratures
    for q in ("1", "2", "3", "6"):
        out.append(Run(f"2D gauss {q}", SCENES / BASE[2],
                       {"scheme.t_end": "1.5", "contact.quadrature": "'gauss'",
                        "contact.quad_points": q}))
    for q in ("1", "3", "6", "7"):
        out.append(Run(f"3D gauss {q}", SCENES / BASE[3],
                       {"scheme.t_end": "1.4", "contact.quadrature": "'gauss'",
                        "contact.quad_points": q}))
    out.append(Run("3D exact", SCENES / BASE[3],
                   {"scheme.t_end": "1.4", "contact.quadrature": "'exact'",
                    "contact.quad_points": None}))
    # 6. the solvers: conjugate gradients, the automatic choice, two threads
    for dim in (2, 3):
        for kind in ("cg", "auto"):
            out.append(Run(f"{dim}D solver {kind}", SCENES / BASE[dim],
                           {"scheme.t_end": T_VARIANT[dim], "solver.kind": f"'{kind}'"}))
        out.append(Run(f"{dim}D solver threads 2", SCENES / BASE[dim],
                       {"scheme.t_end": T_VARIANT[dim], "solver.threads": "2"}))
    # 7. outputs: field snapshots, trace rows every 7 steps; a mesh file
    out.append(Run("2D fields", SCENES / BASE[2],
                   {"scheme.t_end": "1.5", "output.fields_every": "50", "output.every": "7"}))
    out.append(Run("3D fields", SCENES / BASE[3],
                   {"scheme.t_end": "1.3", "output.fields_every": "100"}))
    out.append(Run("2D mesh file", SCENES / BASE[2],
                   {"scheme.t_end": "1.5", "mesh.file":
                    f"'{ROOT / 'meshes/bar2d_getfem_h0.05.msh'}'",
                    "mesh.dim": None, "mesh.length": None, "mesh.width": None,
                    "mesh.h": None}))
    # more of the scene: a load and other initial states, slip boundaries, the scheme
    # parameters off their defaults, the mass solves of pc by CG
    more = {
        "2D gravity from rest": {"initial.kind": "'rest'", "initial.amplitude": None,
                                 "material.gravity": "0.0, -1.0",
                                 "contact.obstacle_point": "0.0, -0.01"},
        "2D initial velocity": {"initial.kind": "'velocity'", "initial.amplitude": None,
                                "initial.velocity": "0.0, -1.0",
                                "contact.obstacle_point": "0.0, -0.1"},
        "2D slip top": {"boundary.clamped": "''", "boundary.slip_x": "'top'",
                        "boundary.slip_y": "'top'"},
        "2D newmark gamma 0.6": {**scheme_settings(2, "newmark"), "scheme.beta": "0.3025",
                                 "scheme.gamma": "0.6"},
        "2D galpha rho 0.5 redistributed": {**scheme_settings(2, "galpha"),
                                            "scheme.rho_inf": "0.5",
                                            "scheme.mass": "'redistributed'"},
        "2D theta 0.6 redistributed": {**scheme_settings(2, "theta"), "scheme.theta": "0.6",
                                       "scheme.mass": "'redistributed'"},
        "2D pc solver cg": {**scheme_settings(2, "pc"), "solver.kind": "'cg'"},
    }
    for name, s in more.items():
        out.append(Run(name, SCENES / BASE[2], {"scheme.t_end": "1.5", **s}))
    # 8. a restart: a run to t = 1.2 with checkpoints, continued to 1.5
    for dim in (1, 2, 3):
        out.append(Run(f"{dim}D restart", SCENES / BASE[dim],
                       {"scheme.t_end": "1.2", "output.checkpoint_every": "100"},
                       restart_settings={"scheme.t_end": T_VARIANT[dim],
                                         "output.checkpoint_every": "100"}))
    # 9. bad input (exit 2) and a blow-up (exit 3)
    out.append(Run("bad dt", SCENES / BASE[2], {"scheme.dt": "-1.0"}, 2))
    out.append(Run("bad key", SCENES / BASE[2], {"scheme.nosuchkey": "1"}, 2))
    out.append(Run("bad group name", SCENES / BASE[2], {"boundary.contact": "'nowhere'"}, 2))
    out.append(Run("bad gamma0", SCENES / BASE[2], {"contact.gamma0": "0.01"}, 2))
    out.append(Run("bad: scene file too large", SCENES / BASE[2], {}, 2,
                   pad="! " + "x" * 1_100_000 + "\n"))
    out.append(Run("bad mesh file", SCENES / BASE[2],
                   {"mesh.file": f"'{ROOT / 'README.md'}'", "mesh.dim": None,
                    "mesh.length": None, "mesh.width": None, "mesh.h": None}, 2))
    out.append(Run("blow-up central", SCENES / BASE[2],
                   {"scheme.name": "'central'", "scheme.alpha": None, "scheme.dt": "0.04",
                    "scheme.mass": "'lumped'", "scheme.t_end": "3.0"}, 3))
    # energies near the largest real (the largest blowup the scene accepts)
    out.append(Run("blow-up to 1e300", SCENES / BASE[2],
                   {"scheme.name": "'central'", "scheme.alpha": None, "scheme.dt": "0.1",
                    "scheme.mass": "'lumped'", "scheme.t_end": "100.0",
                    "scheme.blowup": "1.0e300"}, 3))
    out.append(Run("blow-up implicit", SCENES / BASE[2],
                   {"scheme.name": "'hht_seed'", "scheme.alpha": "-0.1", "scheme.t_end": "3.0"},
                   3))
    return out


# ---- running -------------------------------------------------------------------------


def findings(text: str) -> list[str]:
    """The lines of a run's output that report a finding, with the first lines of the
    backtrace or report that follow each."""
    lines = text.splitlines()
    out = []
    for i, line in enumerate(lines):
        if FINDING.search(line):
            out.append(line.strip())
            for follow in lines[i + 1:i + 40]:
                if re.search(r"\bat \.\./|\.\./fortran/|\.\./tests/", follow):
                    out.append("    " + follow.strip())
                    if len(out) > 6:
                        break
    return out


def run_program(exe: Path, scene: Path, out_dir: Path, env, args=(), timeout=900):
    cmd = [str(exe), str(scene), "--out", str(out_dir), *args]
    t0 = time.monotonic()
    try:
        p = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=timeout)
        status, text = p.returncode, p.stdout + p.stderr
    except subprocess.TimeoutExpired as exc:
        status, text = -1, f"timeout after {timeout} s\n{exc.stdout or ''}{exc.stderr or ''}"
    return status, text, time.monotonic() - t0


#: gmsh (a mesh file, read or meshed through libgmsh) computes with non-finite values on
#: purpose and keeps some memory to the end: a run that loads it goes without the
#: floating-point traps (a preloaded no-op in place of libgfortran's _gfortran_set_fpe,
#: which the program calls at its start to enable them), and LeakSanitizer leaves out
#: what gmsh's own parser, mesher and start-up keep (full stacks, to see them).
NO_FPE_C = "void _gfortran_set_fpe(int val) { (void) val; }\n"
GMSH_LEAKS = "leak:gmshMerge\nleak:gmshModelMeshGenerate\nleak:gmshOpen\nleak:_dl_init\n"


def gmsh_env(env: dict, work: Path) -> dict:
    """The environment of a run that loads gmsh (see NO_FPE_C, GMSH_LEAKS)."""
    so, supp = work / "no_fpe_trap.so", work / "lsan_gmsh.supp"
    if not so.is_file():
        (work / "no_fpe_trap.c").write_text(NO_FPE_C)
        subprocess.run(["cc", "-shared", "-fPIC", "-o", str(so), str(work / "no_fpe_trap.c")],
                       check=True)
    supp.write_text(GMSH_LEAKS)
    env = dict(env)
    env["LD_PRELOAD"] = str(so)
    env["ASAN_OPTIONS"] += ":verify_asan_link_order=0:fast_unwind_on_malloc=0"
    env["LSAN_OPTIONS"] = f"suppressions={supp}"
    return env


def uses_gmsh(scene_text: str) -> bool:
    """Whether the scene names a mesh file (read through gmsh)."""
    return re.search(r"\bfile\s*=\s*'[^']+'", scene_text) is not None


#: The pytest files run against the checked extension (--python): the ones that drive the
#: core through the Python API; not those that time runs, send signals, limit memory or
#: compare the extension's traces bit for bit with the unchecked program's (the checked
#: build, at -O0, differs from it in round-off: gfortran's library matmul, say).
PYTEST_FILES = (
    "test_scene", "test_mesh", "test_mesh_forms", "test_schemes", "test_core_run",
    "test_python_api_in_one_process", "test_linalg", "test_solver_cg", "test_pc", "test_reprs",
    "test_beyond_seed", "test_contact_force", "test_contact_columns", "test_verify_residual",
    "test_verify_assembly", "test_verify_tangent", "test_alm", "test_3d",
    "test_initial_acceleration", "test_invariants", "test_restart_fields",
    "test_setup_factorizations", "test_woodbury_reuse", "test_woodbury_basis", "test_zt_basis",
    "test_fe", "test_tet", "test_lower_groups", "test_json_string", "test_factorization_count",
    "test_unmeshed_geometry_and_edited_scene")


class Tally:
    """The lines printed so far and the runs with findings."""

    def __init__(self, total: int):
        self.total, self.done, self.bad = total, 0, []

    def report(self, name: str, status: int, secs: float, found: list[str], note: str = ""):
        self.done += 1
        verdict = "clean" if not found else "FINDING"
        line = (f"[{self.done:3d}/{self.total}] {name:38s} exit {status:3d} {secs:7.1f} s  "
                f"{verdict}")
        print(line + (f"  ({note})" if note else ""), flush=True)
        for f in found[:8]:
            print("      " + f, flush=True)
        if found:
            self.bad.append(name)


def unit_programs(build: Path) -> list[Path]:
    """The Fortran (and C) unit-test programs of the build."""
    return sorted(p for p in (build / "tests").glob("test_*")
                  if p.is_file() and os.access(p, os.X_OK))


def run_units(programs: list[Path], work: Path, env: dict, tally: Tally) -> None:
    for exe in programs:
        folder = work / "units" / exe.name
        shutil.rmtree(folder, ignore_errors=True)
        folder.mkdir(parents=True)
        t0 = time.monotonic()
        p = subprocess.run([str(exe)] + ([str(folder)] if exe.name == "test_vtk_output" else []),
                           cwd=folder, env=env, capture_output=True, text=True, timeout=1800)
        output = p.stdout + p.stderr
        (work / f"unit_{exe.name}.log").write_text(output)
        found = [f"exit status {p.returncode}"] * (p.returncode != 0) + findings(output)
        tally.report(f"unit {exe.name}", p.returncode, time.monotonic() - t0, found)


def run_program_runs(exe: Path, work: Path, env: dict, reference: Path | None,
                     todo: list[Run], tally: Tally) -> None:
    plain_env = {k: v for k, v in env.items() if k not in SANITIZER_ENV}
    for r in todo:
        slug = re.sub(r"[^A-Za-z0-9]+", "_", r.name).strip("_")
        scene = work / f"{slug}.nml"
        # a relative &mesh file of an example scene, from the folder the scene is written to
        base = Path(r.scene).read_text().replace("'../../meshes/", f"'{ROOT / 'meshes'}/")
        text = edit_scene(base, r.settings) + r.pad
        scene.write_text(text)
        run_env = gmsh_env(env, work) if uses_gmsh(text) else env
        out_dir = work / slug
        shutil.rmtree(out_dir, ignore_errors=True)
        status, output, secs = run_program(exe, scene, out_dir, run_env, r.args)
        found, note = [], ""
        if r.restart_settings is not None and status == 0:
            # continued from its checkpoint, then the same run in one go: the same trace
            scene.write_text(edit_scene(base, r.restart_settings))
            status, more, s2 = run_program(exe, scene, out_dir, run_env,
                                           ["--restart", str(out_dir)])
            whole = work / f"{slug}_whole"
            shutil.rmtree(whole, ignore_errors=True)
            _, more2, s3 = run_program(exe, scene, whole, run_env)
            output, secs = output + more + more2, secs + s2 + s3
            same = (whole / "trace.csv").is_file() and (out_dir / "trace.csv").is_file() and \
                (whole / "trace.csv").read_bytes() == (out_dir / "trace.csv").read_bytes()
            note = "restarted trace = whole run's" if same else ""
            if not same:
                found.append("the restarted trace differs from the whole run's")
        if reference is not None and r.restart_settings is None:
            ref = work / f"{slug}_unchecked"
            shutil.rmtree(ref, ignore_errors=True)
            q = subprocess.run([str(reference), str(scene), "--out", str(ref)],
                               capture_output=True, text=True, env=plain_env)
            if q.returncode != status:
                found.append(f"exit status {status} here, {q.returncode} in the unchecked build")
        found = [f"exit status {status}, expected {r.status}"] * (status != r.status) \
            + found + findings(output)
        (work / f"{slug}.log").write_text(output)
        tally.report(r.name, status, secs, found, note)


def python_root(build: Path, work: Path) -> Path:
    """A package folder of the Python sources with the checked build's extension."""
    pyroot = work / "pyroot"
    shutil.rmtree(pyroot, ignore_errors=True)
    shutil.copytree(ROOT / "python" / "dyncontact", pyroot / "dyncontact",
                    ignore=shutil.ignore_patterns("__pycache__", "*.in"))
    for f in (build / "python").glob("_core*.so"):
        shutil.copy2(f, pyroot / "dyncontact")
    shutil.copy2(build / "python" / "_version.py", pyroot / "dyncontact")
    for f in (ROOT / "meshes").glob("*.geo"):
        shutil.copy2(f, pyroot / "dyncontact")
    return pyroot


def run_pytest(build: Path, work: Path, files: list[str], tally: Tally) -> None:
    """Each file in its own process: `python -S` (no .pth file: the editable install's
    loader stays out), the package from python_root, AddressSanitizer preloaded (Python is
    not built with it; libstdc++ too, for gmsh's C++ exceptions) without its leak check
    (the interpreter keeps memory to its end), no floating-point traps (no Fortran program
    sets them)."""
    pyroot = python_root(build, work)
    purelib = subprocess.run([sys.executable, "-c",
                              "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                             capture_output=True, text=True, check=True).stdout.strip()
    libs = [subprocess.run(["gcc", f"-print-file-name={n}"], capture_output=True, text=True,
                           check=True).stdout.strip() for n in ("libasan.so", "libstdc++.so.6")]
    env = dict(os.environ, **SANITIZER_ENV)
    env["ASAN_OPTIONS"] = env["ASAN_OPTIONS"].replace("detect_leaks=1", "detect_leaks=0")
    env["LD_PRELOAD"] = " ".join(libs)
    env["PYTHONPATH"] = f"{pyroot}{os.pathsep}{purelib}"
    for name in files:
        t0 = time.monotonic()
        p = subprocess.run([sys.executable, "-S", "-m", "pytest", "-q", "-p", "no:cacheprovider",
                            str(ROOT / "tests" / f"{name}.py")], cwd=ROOT, env=env,
                           capture_output=True, text=True, timeout=3600)
        output = p.stdout + p.stderr
        (work / f"pytest_{name}.log").write_text(output)
        summary = [ln for ln in output.splitlines() if re.search(r"\d+ (passed|failed)", ln)]
        found = [f"pytest exit status {p.returncode}"] * (p.returncode != 0) + findings(output)
        tally.report(f"pytest {name}", p.returncode, time.monotonic() - t0, found,
                     summary[-1].strip("= ") if summary else "")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="scripts/checked_runs.py")
    ap.add_argument("--build", required=True, type=Path, help="the checked build folder")
    ap.add_argument("--work", required=True, type=Path, help="folder for scenes and outputs")
    ap.add_argument("--only", default="", help="only the runs whose name contains this text")
    ap.add_argument("--reference", type=Path, default=None,
                    help="an unchecked program (./build/dyncontact): exit statuses compared")
    ap.add_argument("--python", action="store_true", help="also the pytest selection")
    ap.add_argument("--list", action="store_true", help="list the runs and stop")
    a = ap.parse_args(argv)
    a.build, a.work = a.build.resolve(), a.work.resolve()
    env = dict(os.environ, **SANITIZER_ENV)
    env.pop("PYTHONPATH", None)
    units = [p for p in unit_programs(a.build) if a.only in f"unit {p.name}"]
    todo = [r for r in runs() if a.only in r.name]
    files = [f for f in PYTEST_FILES if a.only in f"pytest {f}"] if a.python else []
    if a.list:
        for name in [f"unit {p.name}" for p in units] + [r.name for r in todo] \
                + [f"pytest {f}" for f in files]:
            print(name)
        return 0
    a.work.mkdir(parents=True, exist_ok=True)
    t0 = time.monotonic()
    tally = Tally(len(units) + len(todo) + len(files))
    run_units(units, a.work, env, tally)
    run_program_runs(a.build / "dyncontact", a.work, env, a.reference, todo, tally)
    if files:
        run_pytest(a.build, a.work, files, tally)
    secs = time.monotonic() - t0
    print(f"checked: {tally.done - len(tally.bad)} of {tally.done} runs clean, "
          f"{len(tally.bad)} with findings, {secs:.0f} s"
          + (": " + ", ".join(tally.bad) if tally.bad else "")
          + f" (logs in {a.work})", flush=True)
    return 1 if tally.bad else 0


if __name__ == "__main__":
    sys.exit(main())
