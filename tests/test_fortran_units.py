"""The Fortran unit-test programs of tests/fortran/ (built by meson into build/tests/)."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

BUILD = Path(__file__).resolve().parents[1] / "build" / "tests"


@pytest.mark.parametrize("name", ["sparse", "umfpack", "cholmod", "vtk_output", "trace_output", "text",
                                  "vector_ops", "alm_contact", "mesh3d", "rotation3d", "facet3d",
                                  "blocks3d", "dense_lu", "zt_columns", "contact_clear",
                                  "zcache_restore", "stop_signal", "model_fp_flags"])
def test_fortran_unit_program(name, tmp_path):
    exe = BUILD / f"test_{name}"
    if not exe.exists():
        pytest.skip(f"{exe} not built (scripts/setup builds it)")
    args = [str(exe)] + ([str(tmp_path)] if name == "vtk_output" else [])
    proc = subprocess.run(args, capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert proc.returncode == 0, proc.stdout + proc.stderr
