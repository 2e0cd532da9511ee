"""A guard for refactors: the traces of a handful of scenes are those written by the last
commit that changed the numerics on purpose (tests/data/traces_before/, with a README
saying which commit wrote them). Every column is compared to round-off of the same binary.

A change that moves the numerics on purpose (a new solver, a new formula) regenerates the
files with `python tests/test_traces_unchanged.py` and says so in its commit and in the
README; a refactor must leave them unchanged. A column appended to trace.csv (e_load,
then f_n) regenerates them too, after checking that every old column is byte-identical
to what the build before it writes (README)."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import ROOT, drop_unused

import dyncontact
from dyncontact import Scene

BEFORE = ROOT / "tests" / "data" / "traces_before"
#: Same binary, same scene values: the traces agree to round-off at most.
RTOL = 1e-14
ATOL = 1e-14

#: name -> (scene file, keys set besides t_end = 0.5), as in BEFORE/README.md
CASES = {
    "bar1d": ("bar1d", {"output.every": 5}),
    "bar2d_pc": ("bar2d_pc", {"output.every": 5}),
    "bar2d_pc_hht": ("bar2d_pc_hht", {"output.every": 5}),
    "bar2d_pc_hht_seed": ("bar2d_pc_hht_seed", {"output.every": 5}),
    "bar2d_hht": ("bar2d_hht", {}),
    "bar2d_hht_seed": ("bar2d_hht_seed", {}),
    "bar2d_newmark": ("bar2d_newmark", {}),
    "bar2d_theta": ("bar2d_theta", {}),
    "bar2d_hht_mshfile": ("bar2d_hht", {
        "mesh.file": str(ROOT / "meshes" / "bar2d_getfem_h0.05.msh"),
        "material.gravity": "0,-0.5", "scheme.mass": "lumped"}),
}


def run_case(name, out):
    scene, keys = CASES[name]
    scn = Scene.read(ROOT / "scripts" / "scenes" / f"{scene}.nml")
    scn.set("scheme.t_end", 0.5)
    for key, value in keys.items():
        scn.set(key, value)
    # the base's keys the case does not use (h and width with a .msh file): the same run
    return dyncontact.run(drop_unused(scn), out=out, progress=False)


@pytest.mark.parametrize("name", sorted(CASES))
def test_trace_unchanged(name, tmp_path):
    res = run_case(name, tmp_path / name)
    before = np.genfromtxt(BEFORE / f"{name}.csv", delimiter=",", names=True)
    assert res.trace["t"].shape == before["t"].shape, name
    for col in before.dtype.names:
        np.testing.assert_allclose(res.trace[col], before[col], rtol=RTOL, atol=ATOL,
                                   err_msg=f"{name}: column {col}")


def test_trace_unchanged_through_the_executable(run_exe, tmp_path):
    scn = Scene.read(ROOT / "scripts" / "scenes" / "bar2d_newmark.nml")
    scn.set("scheme.t_end", 0.5)
    scn.set("output.dir", str(tmp_path / "out"))
    scn.write(tmp_path / "s.nml")
    res = run_exe(tmp_path / "s.nml")
    assert res.returncode == 0, res.stderr
    after = dyncontact.core.read_trace(tmp_path / "out")
    before = np.genfromtxt(BEFORE / "bar2d_newmark.csv", delimiter=",", names=True)
    for col in before.dtype.names:
        np.testing.assert_allclose(after[col], before[col], rtol=RTOL, atol=ATOL,
                                   err_msg=f"executable: column {col}")


if __name__ == "__main__":      # regenerate BEFORE (see the module docstring)
    import shutil
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        for case in sorted(CASES):
            run_case(case, f"{tmp}/{case}")
            shutil.copy(f"{tmp}/{case}/trace.csv", BEFORE / f"{case}.csv")
            print("wrote", BEFORE / f"{case}.csv")
