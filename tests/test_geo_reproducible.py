""".geo meshing is reproducible within a process: a .geo read or generated after another,
much larger model gives the same bits as in a fresh process.

gmsh's parser takes the scale of its geometric tolerances from the bounding box of every
point parsed since its last ``open``, which neither finalize/initialize nor a new model
resets; the readers reset it before each .geo (mesh_io._parse_bbox_reset,
fortran/io/gmsh_shim.c parse_bbox_reset). Without that, meshes/disk.geo meshed after the
same file 1000 times larger had nodes one bit off.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import callers_gmsh_session
from dyncontact import mesh_io

ROOT = Path(__file__).resolve().parents[1]
DISK = ROOT / "meshes" / "disk.geo"
SMALL = dict(h=0.02, length=1.0, width=0.1)
LARGE = {k: 1000.0 * v for k, v in SMALL.items()}

#: Meshes disk.geo at SMALL through the core's reader and through generate (binary .msh,
#: which keeps every bit), and saves both coordinate arrays to argv[1].
FRESH = f"""
import sys
from pathlib import Path
import numpy as np
from dyncontact import mesh_io
geo, out = Path({str(DISK)!r}), Path(sys.argv[1])
core = mesh_io.read_mesh(geo, check=False, **{SMALL!r})
msh = mesh_io.generate(geo, out.with_suffix(".msh"), binary=True, **{SMALL!r})
np.savez(out, core=core.x, generated=mesh_io.read_mesh(msh, check=False).x)
"""


@pytest.fixture(scope="module")
def fresh(tmp_path_factory):
    """disk.geo's coordinates meshed in a fresh process: {"core": x, "generated": x}."""
    out = tmp_path_factory.mktemp("fresh") / "disk.npz"
    subprocess.run([sys.executable, "-c", FRESH, str(out)], check=True, timeout=120)
    with np.load(out) as f:
        return {k: f[k] for k in f.files}


def _core(**par) -> np.ndarray:
    return mesh_io.read_mesh(DISK, check=False, **par).x


def _generated(folder: Path, name: str, **par) -> np.ndarray:
    msh = mesh_io.generate(DISK, folder / f"{name}.msh", binary=True, **par)
    return mesh_io.read_mesh(msh, check=False).x


def _same_bits(x: np.ndarray, ref: np.ndarray) -> None:
    assert x.shape == ref.shape
    differ = np.flatnonzero(x.view(np.uint64).ravel() != ref.view(np.uint64).ravel())
    assert differ.size == 0, f"{differ.size} coordinates differ, e.g. " \
        f"{x.ravel()[differ[0]]!r} != {ref.ravel()[differ[0]]!r}"


def test_core_reader_after_a_large_model_gives_the_fresh_bits(fresh):
    _core(**LARGE)
    _same_bits(_core(**SMALL), fresh["core"])


def test_generate_after_a_large_model_gives_the_fresh_bits(fresh, tmp_path):
    _generated(tmp_path, "large", **LARGE)
    _same_bits(_generated(tmp_path, "small", **SMALL), fresh["generated"])


def test_in_a_callers_session_same_bits_and_its_variables_kept(fresh, tmp_path):
    """In a session the caller runs, the small model read after the large one gives the
    fresh bits, and the caller's model and parser variables (numbers and strings) are
    there afterwards."""
    with callers_gmsh_session() as gmsh:
        gmsh.parser.setNumber("scale", [1000.0, 2.5])
        gmsh.parser.setString("label", ["mine", "too"])
        _core(**LARGE)
        core = _core(**SMALL)
        _generated(tmp_path, "large", **LARGE)
        generated = _generated(tmp_path, "small", **SMALL)
        assert gmsh.model.getCurrent() == "mine"
        assert gmsh.model.getEntities() == [(0, 1)]
        assert sorted(gmsh.parser.getNames()) == ["label", "scale"]
        assert list(gmsh.parser.getNumber("scale")) == [1000.0, 2.5]
        assert list(gmsh.parser.getString("label")) == ["mine", "too"]
    _same_bits(core, fresh["core"])
    _same_bits(generated, fresh["generated"])
