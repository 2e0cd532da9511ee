"""Mesh files in an installed dyncontact: libgmsh is found in the environment it is
installed in, and the build does not need gmsh.

`pip install .` builds in pip's isolated environment, which holds the build requirements
(meson, numpy) but not gmsh, and installs the gmsh wheel (a run-time dependency) beside the
package: <venv>/lib/libgmsh.so.<version>, next to <venv>/bin/dyncontact and
<venv>/lib/pythonX.Y/site-packages/dyncontact/_core*.so. Such an install must read mesh
files (fortran/io/gmsh_shim.c, gmsh_api.h). A real `pip install` takes minutes; these
tests build the same layout in a temporary folder instead."""
from __future__ import annotations

import glob
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import ROOT, scene_beside_its_mesh

SHIM = ROOT / "fortran" / "io" / "gmsh_shim.c"


def _libgmsh() -> Path:
    """The gmsh wheel's library of the test's Python environment (skip without one)."""
    found = sorted(glob.glob(os.path.join(sys.prefix, "lib", "libgmsh.so*")))
    if not found:
        pytest.skip("no gmsh wheel (libgmsh) in this Python environment")
    return Path(found[-1])


def _env_with_gmsh(tmp_path: Path) -> Path:
    """A prefix <tmp>/env with bin/ and lib/libgmsh.so.<version> (a link to the wheel's)."""
    lib = _libgmsh()
    env = tmp_path / "env"
    (env / "bin").mkdir(parents=True)
    (env / "lib").mkdir()
    (env / "lib" / lib.name).symlink_to(lib)
    return env


def _clean_env(**extra) -> dict:
    env = dict(os.environ, **extra)
    for key in ("PYTHONPATH", "DYNCONTACT_GMSH_LIB", "LD_LIBRARY_PATH"):
        env.pop(key, None)
    return env


def test_shim_built_without_gmsh_finds_the_installed_wheel(tmp_path):
    """gmsh_shim.c compiled with neither gmshc.h nor a library path (pip's isolated build)
    and placed in <prefix>/bin loads <prefix>/lib/libgmsh.so.<version>; with no library
    there it says how to get gmsh."""
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.skip("no C compiler")
    env = _env_with_gmsh(tmp_path)
    driver = tmp_path / "driver.c"
    driver.write_text(
        "#include <stdio.h>\n"
        "int dc_gmsh_available(char *msg, int msglen);\n"
        "int dc_read_signal_exits(void) { return 0; }\n"
        "int main(void) {\n"
        "    char msg[1024];\n"
        "    int ok = dc_gmsh_available(msg, sizeof msg);\n"
        "    printf(\"%d %s\\n\", ok, msg);\n"
        "    return 0;\n"
        "}\n")
    probe = env / "bin" / "probe"
    subprocess.run([cc, "-O0", "-DDC_WITH_GMSH", str(SHIM), str(driver), "-o", str(probe),
                    "-ldl", "-lpthread", "-lm"], check=True, capture_output=True, timeout=120)
    r = subprocess.run([str(probe)], env=_clean_env(LD_DEBUG="files"), capture_output=True,
                       text=True, timeout=60, cwd=tmp_path)
    assert r.stdout.startswith("1 "), r.stdout + r.stderr[-2000:]
    assert f"file={env / 'lib'}/libgmsh.so" in r.stderr
    # the same program without the library beside it
    for lib in (env / "lib").iterdir():
        lib.unlink()
    r = subprocess.run([str(probe)], env=_clean_env(), capture_output=True, text=True,
                       timeout=60, cwd=tmp_path)
    assert r.stdout.startswith("0 mesh files need gmsh"), r.stdout
    assert "pip install gmsh" in r.stdout


def test_installed_executable_prefers_its_environments_gmsh(exe, tmp_path):
    """The executable installed as <prefix>/bin/dyncontact reads a .msh scene (from another
    folder, the mesh relative to the scene) through <prefix>/lib/libgmsh*, not through the
    library the build found (the build folder's environment may be gone on the machine
    that runs it)."""
    env = _env_with_gmsh(tmp_path)
    installed = env / "bin" / "dyncontact"
    shutil.copy2(exe, installed)
    scene = scene_beside_its_mesh(tmp_path / "scenes", 0.02, "out")
    work = tmp_path / "work"
    work.mkdir()
    r = subprocess.run([str(installed), str(scene)], env=_clean_env(LD_DEBUG="files"),
                       capture_output=True, text=True, timeout=120, cwd=work)
    assert r.returncode == 0, r.stderr[-2000:]
    assert f"file={env / 'lib'}/libgmsh.so" in r.stderr
    assert (work / "out" / "trace.csv").is_file()
