"""A body force does not raise a run's peak memory by a second factor. The blow-up
limit's load energy, 1/2 L.(K + M/t_end^2)^-1 L, factorizes a matrix of J0's size and
frees it at once; made while J0's factor is alive, the two factors would be held
together (on a 3D box of 14 700 dofs: 140 MB against 90 MB without the load). The
set-up makes it before the scheme's factors, and a run with gravity peaks at about the
memory of the same run without it. The load energy is the same number in either order,
so the traces are too (tests/test_traces_unchanged.py runs a scene with gravity)."""

from __future__ import annotations

from pathlib import Path

import pytest

from conftest import ROOT, peak_run

SCENE = (ROOT / "scripts" / "scenes" / "bar3d_hht.nml").read_text()


def _scene(tmp_path: Path, name: str, gravity: str) -> Path:
    """The 3D bar widened to a block [0, 0.5]^2 x [0, 1] at h = 0.04 (14 700 dofs), one
    step, gravity as given."""
    text = SCENE
    for old, new in (("width = 0.1, h = 0.05", "width = 0.5, h = 0.04"),
                     ("gravity = 0.0, 0.0, 0.0", f"gravity = {gravity}"),
                     ("probe = 0.05, 0.05, 0.0", "probe = 0.25, 0.25, 0.0"),
                     ("t_end = 15.0", "t_end = 0.0025"),
                     ("out/bar3d_hht", str(tmp_path / f"out_{name}"))):
        assert text.count(old) == 1, old
        text = text.replace(old, new)
    path = tmp_path / f"{name}.nml"
    path.write_text(text)
    return path


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="needs /proc")
def test_gravity_adds_no_second_factor_to_the_peak(exe, tmp_path):
    without, _ = peak_run([exe, _scene(tmp_path, "free", "0.0, 0.0, 0.0")], tmp_path,
                          field="VmHWM")
    loaded, _ = peak_run([exe, _scene(tmp_path, "gravity", "0.0, 0.0, -0.5")], tmp_path,
                         field="VmHWM")
    # J0's factor alone is some 50 MB here: a second one held with it gives 1.5x
    assert loaded < 1.15 * without, (loaded / 2**20, without / 2**20)
