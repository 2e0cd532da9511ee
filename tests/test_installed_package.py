"""The package as `meson install` (and so `pip install .`, which installs the same files)
puts it, used from a folder outside the source tree: what it needs at run time must be
among the installed files, not looked up in the repository."""
from __future__ import annotations

import csv
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import dyncontact
from conftest import EXE, ROOT, scene_beside_its_mesh

#: The installed package only: the editable install of the test environment (a finder on
#: sys.meta_path that maps `dyncontact` to the source tree) is taken out, and the
#: destdir's site-packages is the first path.
ONLY_INSTALLED = """
import runpy, sys
site = sys.argv.pop(1)
sys.meta_path[:] = [f for f in sys.meta_path if 'editable' not in type(f).__module__]
sys.path.insert(0, site)
import dyncontact
assert dyncontact.__file__.startswith(site), dyncontact.__file__
"""
#: Runs `python -m dyncontact ARGS` on the installed package only.
RUN_INSTALLED = ONLY_INSTALLED + """
sys.argv[0] = 'dyncontact'
runpy.run_module('dyncontact', run_name='__main__', alter_sys=True)
"""


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> Path:
    """The site-packages folder of build/ installed with `meson install --destdir`."""
    meson = shutil.which("meson", path=os.path.dirname(sys.executable)) or shutil.which("meson")
    if meson is None or not EXE.is_file():
        pytest.skip("no meson or no build/; run scripts/setup")
    dest = tmp_path_factory.mktemp("destdir")
    subprocess.run([meson, "install", "-C", str(ROOT / "build"), "--destdir", str(dest),
                    "--no-rebuild", "-q"], check=True, capture_output=True, timeout=300)
    found = list(dest.rglob("site-packages/dyncontact/__init__.py"))
    assert len(found) == 1, found
    return found[0].parent.parent


def _run_installed(site: Path, args, cwd: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    return subprocess.run([sys.executable, "-c", RUN_INSTALLED, str(site), *args], cwd=cwd,
                          env=env, capture_output=True, text=True, timeout=120)


def test_installed_mesh_command_has_its_default_geometry(installed, tmp_path):
    """`python -m dyncontact mesh --out bar.msh`, from a folder outside the source tree,
    meshes the default bar (bar2d.geo); the example geometries are installed unchanged."""
    r = _run_installed(installed, ["mesh", "--h", "0.05", "--out", "bar.msh"], tmp_path)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "bar.msh").stat().st_size > 0
    for name in ("bar2d.geo", "disk.geo", "ball.geo", "ball_pole.geo"):
        shipped = installed / "dyncontact" / name
        assert shipped.read_bytes() == (ROOT / "meshes" / name).read_bytes(), name


def test_installed_run_help_names_the_scene_documentation(installed, tmp_path):
    """`python -m dyncontact run --help` of the installed package (no docs/ beside it)
    lists the scene groups and names the documentation by its title, in the lines that
    end the installed executable's --help too (run_help.txt, installed beside the
    modules)."""
    r = _run_installed(installed, ["run", "--help"], tmp_path)
    assert r.returncode == 0, r.stderr
    said = " ".join(r.stdout.split())
    assert '"Scene files, outputs and exit codes"' in said and "&solver" in said, said
    assert "Exit status: 0 ok, 2 bad input" in said, said
    text = (installed / "dyncontact" / "run_help.txt").read_text(encoding="utf-8")
    assert text == (ROOT / "python" / "dyncontact" / "run_help.txt").read_text(encoding="utf-8")
    exe = next(installed.parents[2].rglob("bin/dyncontact"))
    e = subprocess.run([str(exe), "--help"], capture_output=True, text=True, timeout=30)
    assert e.returncode == 0 and e.stdout.endswith(text) and r.stdout.endswith(text)


def test_installed_entry_points_give_one_trace(installed, tmp_path):
    """The installed executable and the installed `python -m dyncontact run`, started in a
    folder of their own on a scene of another folder whose mesh path is relative to it,
    write the same trace."""
    exe = next(installed.parents[2].rglob("bin/dyncontact"))
    scene = scene_beside_its_mesh(tmp_path / "scenes", 0.3, "res/run")
    work = tmp_path / "work"
    work.mkdir()
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    r = subprocess.run([str(exe), str(scene), "--out", "exe"], cwd=work, env=env,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    r = _run_installed(installed, ["run", str(scene), "--quiet"], work)
    assert r.returncode == 0, r.stderr
    assert (work / "res" / "run" / "trace.csv").read_bytes() == \
        (work / "exe" / "trace.csv").read_bytes()


def test_installed_studies_find_the_ball_scene_and_meshes(installed, tmp_path):
    """The studies' ball scene (study hertz, the figures' Fig. 9) and meshes (the Hertz
    ball, the scaling sweep's disk) are the installed package's own files, from a folder
    outside the source tree; the installed scene is the source tree's, its mesh named
    beside it."""
    code = ONLY_INSTALLED + """
import json
from dyncontact import Scene
from dyncontact.study import figures, hertz, scaling
paths = [figures.BALL_SCENE, hertz.BALL_SCENE, hertz.BALL_POLE_GEO, scaling.DISK_GEO]
print(json.dumps({"paths": paths, "scene": Scene.read(hertz.BALL_SCENE).to_dict()}))
"""
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    r = subprocess.run([sys.executable, "-c", code, str(installed)], cwd=tmp_path, env=env,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    got = json.loads(r.stdout)
    package = installed / "dyncontact"
    assert got["paths"] == [str(package / "ball3d_newmark.nml")] * 2 + \
        [str(package / "ball_pole.geo"), str(package / "disk.geo")]
    source = dyncontact.Scene.read(ROOT / "scripts" / "scenes" / "ball3d_newmark.nml")
    expected = source.to_dict()
    assert os.path.normpath(expected["mesh"]["file"]) == str(ROOT / "meshes" / "ball.geo")
    assert os.path.normpath(got["scene"]["mesh"]["file"]) == str(package / "ball.geo")
    expected["mesh"]["file"] = got["scene"]["mesh"]["file"]
    assert got["scene"] == expected


def test_installed_study_hertz_runs_outside_the_source_tree(installed, tmp_path):
    """`python -m dyncontact study hertz --quick` of the installed package, from a folder
    outside the source tree: both runs of its table done."""
    r = _run_installed(installed, ["study", "hertz", "--quick", "--workers", "1",
                                   "--no-progress", "--out", "h"], tmp_path)
    assert r.returncode == 0, r.stderr[-2000:]
    with open(tmp_path / "h" / "hertz.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [r["status"] for r in rows] == ["ok", "ok"]
