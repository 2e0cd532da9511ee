"""The build: one version everywhere, the executable's usage, kinds across f2py."""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
import pytest

from conftest import ROOT

#: Round-off tolerance of the element-matrix check (float32 would miss it by 1e8).
RTOL_DOUBLE = 1e-14


def _meson_version() -> str:
    text = (ROOT / "meson.build").read_text()
    m = re.search(r"project\(\s*'dyncontact'.*?version:\s*'([^']+)'", text, re.S)
    assert m, "meson.build: no project(version:)"
    return m.group(1)


def test_version_is_the_same_everywhere(core_ext):
    import tomllib

    import dyncontact
    from dyncontact.core import fortran_version

    meson = _meson_version()
    assert re.fullmatch(r"\d+\.\d+\.\d+", meson)
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    # pyproject.toml takes the version from meson.build (no second copy to drift).
    assert "version" in project.get("dynamic", []) and "version" not in project
    assert dyncontact.__version__ == meson, "python/dyncontact/_version.py (generated)"
    # fortran/base/version_info.f90 is generated from meson.build (configure_file)
    assert fortran_version() == meson, "dc_version() of the compiled core"


def test_installed_metadata_version(core_ext):
    from importlib.metadata import version

    assert version("dyncontact") == _meson_version()


def test_executable_without_argument_prints_usage(run_exe):
    res = run_exe()
    assert res.returncode == 2, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("usage: dyncontact"), res.stderr
    assert "SCENE" in lines[0]


def _p1_matrices_numpy(x, young, poisson, density):
    """Plane-strain P1 triangle: stiffness and consistent mass, dofs (x1, y1, x2, ...)."""
    lam = young * poisson / ((1 + poisson) * (1 - 2 * poisson))
    mu = young / (2 * (1 + poisson))
    jac = np.array([x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]]).T
    area = abs(np.linalg.det(jac)) / 2
    grad = np.linalg.solve(jac.T, np.array([[-1.0, 1.0, 0.0], [-1.0, 0.0, 1.0]]))
    b = np.zeros((3, 6))
    b[0, 0::2] = grad[0]
    b[1, 1::2] = grad[1]
    b[2, 0::2] = grad[1]
    b[2, 1::2] = grad[0]
    d = np.array([[lam + 2 * mu, lam, 0], [lam, lam + 2 * mu, 0], [0, 0, mu]])
    ke = area * b.T @ d @ b
    scalar = density * area / 12 * (np.ones((3, 3)) + np.eye(3))
    me = np.kron(scalar, np.eye(2))
    return ke, me


def test_double_precision_round_trip(core_ext):
    """c_double is float64 through f2py: element matrices agree with numpy to round-off
    on coordinates that float32 cannot represent."""
    from dyncontact.core import p1_element

    x = np.array([[0.1, 0.1 + 1 / 3, 0.1], [0.2, 0.2, 0.2 + np.pi / 10]])
    young, poisson, density = 2 / 3, 1 / 3, 1.0 + 1e-12
    ke, me, ml = p1_element(2, x, young, poisson, density)
    for a in (ke, me, ml):
        assert a.dtype == np.float64 and a.shape == (6, 6)
    ke_ref, me_ref = _p1_matrices_numpy(x, young, poisson, density)
    np.testing.assert_allclose(me, me_ref, rtol=RTOL_DOUBLE, atol=0,
                               err_msg="consistent mass")
    np.testing.assert_allclose(ke, ke_ref, rtol=0, atol=RTOL_DOUBLE * np.abs(ke_ref).max(),
                               err_msg="stiffness")
    np.testing.assert_allclose(ml.sum(), me_ref.sum(), rtol=RTOL_DOUBLE)
    # The raw f2py call: float64, Fortran order in, float64 out.
    xf = np.zeros((3, 4), order="F")     # room for a tetrahedron; 2D uses x[:2, :3]
    xf[:2, :3] = x
    raw = core_ext.dc_p1_element(2, xf, young, poisson, density)
    assert all(a.dtype == np.float64 for a in raw)
    np.testing.assert_array_equal(raw[1][:6, :6], me)


def test_fortran_strings_are_decoded(core_ext):
    from dyncontact.core import fortran_version

    raw = core_ext.dc_version()
    assert isinstance(raw, bytes)
    v = fortran_version()
    assert isinstance(v, str) and v == v.strip() and v


@pytest.mark.parametrize("name", ["main.f90", "api.f90"])
def test_core_library_excludes_program_and_api(name):
    """fortran/meson.build keeps main.f90 and api.f90 out of the core library."""
    import json

    plan = ROOT / "build" / "meson-info" / "intro-targets.json"
    if not plan.is_file():
        pytest.skip("build/ not configured")
    targets = json.loads(plan.read_text())
    core = [t for t in targets if t["name"] == "dyncontact_core"]
    assert core, "no dyncontact_core target"
    sources = [s for src in core[0]["target_sources"] for s in src.get("sources", [])]
    assert not any(s.endswith("/" + name) for s in sources)
    assert any(s.endswith("/kinds.f90") for s in sources)


def _summary(out: Path) -> dict:
    import json

    return json.loads((out / "summary.json").read_text())


def test_simd_build_is_bit_identical_to_portable(exe, tmp_path):
    """meson option simd (meson.options): the default build uses x86-64-v3 (AVX2, no FMA)
    when the build machine has it; a -Dsimd=portable build must give the same traces,
    byte for byte (implicit with contact, predictor-corrector, theta)."""
    import shutil
    import subprocess
    import sys

    from test_reliability import write_scene

    scenes = {
        "hht": {"scheme__t_end": "3.0"},
        "pc": {"scheme__name": "'pc'", "scheme__dt": "0.0005", "scheme__t_end": "1.0"},
        "theta": {"scheme__name": "'theta'", "scheme__theta": "1.0", "scheme__t_end": "3.0"},
    }

    def run_all(binary: Path, tag: str) -> dict[str, Path]:
        outs = {}
        for name, over in scenes.items():
            out = tmp_path / f"{tag}_{name}"
            scene = write_scene(tmp_path / f"{tag}_{name}.nml", output__dir=f"'{out}'", **over)
            res = subprocess.run([str(binary), str(scene)], capture_output=True, text=True,
                                 timeout=120)
            assert res.returncode == 0, res.stderr
            outs[name] = out
        return outs

    main = run_all(exe, "main")
    isa = _summary(main["hht"])["isa"]
    assert isa in ("x86-64", "x86-64-v3")
    if isa != "x86-64-v3":
        pytest.skip("this machine's build is already the portable one")
    bindir = Path(sys.executable).parent
    meson = shutil.which("meson", path=str(bindir)) or shutil.which("meson")
    ninja = shutil.which("ninja", path=str(bindir)) or shutil.which("ninja")
    if not meson or not ninja:
        pytest.skip("meson/ninja not found")
    env = dict(os.environ, PATH=f"{bindir}{os.pathsep}{os.environ.get('PATH', '')}")
    env.pop("PYTHONPATH", None)
    build = tmp_path / "portable"
    for cmd in ([meson, "setup", str(build), str(ROOT), "-Dsimd=portable"],
                [ninja, "-C", str(build), "dyncontact"]):
        res = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=600)
        assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    portable = run_all(build / "dyncontact", "portable")
    assert _summary(portable["hht"])["isa"] == "x86-64"
    for name in scenes:
        a = (main[name] / "trace.csv").read_bytes()
        b = (portable[name] / "trace.csv").read_bytes()
        assert len(a.splitlines()) > 100, name
        assert a == b, f"{name}: the x86-64-v3 and portable builds' traces differ"


def _blas_file(text: str) -> str:
    """The library file of summary.json's "blas" (after OpenBLAS's configuration, if any)."""
    return text.rsplit(": ", 1)[-1]


def test_summary_names_the_blas_the_factorization_calls(exe, run_exe, tmp_path):
    """summary.json's "blas": the library that defines dgemm_ for CHOLMOD's supernodal
    factorization, the same from both entry points; it is mapped into the process that
    ran (this one, for the extension), defines dgemm_, and is named OpenBLAS exactly when
    it has OpenBLAS's openblas_get_config."""
    import ctypes
    import json

    import dyncontact
    from dyncontact import Scene

    scene = ROOT / "scripts" / "scenes" / "bar3d_hht.nml"
    scn = Scene.read(scene)
    scn.set("scheme.t_end", 0.0)
    text = dyncontact.run(scn, out=tmp_path / "py", progress=False).summary["blas"]
    assert text, "the loader found no dgemm_ for CHOLMOD"
    lib = _blas_file(text)
    assert os.path.isabs(lib) and os.path.isfile(lib)
    assert lib == os.path.realpath(lib), "links resolved (Debian's alternatives)"
    with open("/proc/self/maps", encoding="utf-8") as f:
        mapped = {os.path.realpath(line.split()[-1]) for line in f
                  if len(line.split()) >= 6 and line.split()[-1].startswith("/")}
    assert lib in mapped
    handle = ctypes.CDLL(lib)
    assert hasattr(handle, "dgemm_")
    if hasattr(handle, "openblas_get_config"):
        handle.openblas_get_config.restype = ctypes.c_char_p
        assert text == f"{handle.openblas_get_config().decode()}: {lib}"
    else:
        assert text == lib
    # the executable loads the same system library
    scene_exe = tmp_path / "exe.nml"
    scene_exe.write_text(scene.read_text().replace("t_end = 15.0", "t_end = 0.0")
                        .replace("'out/bar3d_hht'", f"'{tmp_path / 'exe'}'"))
    res = run_exe(str(scene_exe))
    assert res.returncode == 0, res.stderr
    assert json.loads((tmp_path / "exe" / "summary.json").read_text())["blas"] == text
