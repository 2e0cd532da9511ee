"""Bad scenes through both entry points (SPEC sections 3 and 5): `build/dyncontact SCENE`
and `python -m dyncontact run SCENE` must exit with status 2 and print exactly one line
on stderr that names the scene file and the offending group and key, with no traceback,
and must not write a trace."""

from __future__ import annotations

import pytest

from test_scene import BAD_CASES, MESH_CASES, write_case

#: Exit status of bad input (SPEC section 3).
EXIT_BAD_INPUT = 2

#: Cases run by the quick suite (`pytest -m "not slow"`): one of each kind; the others
#: start two subprocesses each and are marked slow (scripts/test runs them all).
QUICK = {"unknown_key", "unterminated_group", "empty_file", "nan_real", "real_sum",
         "latin1_string", "utf16_file", "binary_file", "missing_scene_file",
         "unquoted_string", "missing_mesh_file", "dt_zero", "t_end_below_dt",
         "steps_over_limit", "bar_too_fine", "output_dir_empty", "boundary_group_missing",
         "probe_off_contact", "alm_explicit"}
ALL_CASES = [pytest.param(c, id=c.id, marks=() if c.id in QUICK else pytest.mark.slow)
             for c in BAD_CASES + MESH_CASES]


def check_one_line(res, path, case):
    assert res.returncode == EXIT_BAD_INPUT, (res.returncode, res.stdout, res.stderr)
    assert "Traceback" not in res.stderr, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, res.stderr
    line = lines[0]
    assert str(path) in line, (line, path)
    if case.where:
        assert f"{case.where}:" in line or f"{case.where} " in line, (line, case.where)
    assert not (path.parent / "out" / "trace.csv").exists()


def test_quick_cases_exist():
    assert QUICK <= {c.id for c in BAD_CASES + MESH_CASES}


@pytest.mark.parametrize("case", ALL_CASES)
def test_exe_bad_scene(run_exe, case, tmp_path):
    path = write_case(case, tmp_path)
    res = run_exe(path, cwd=tmp_path)
    check_one_line(res, path, case)


@pytest.mark.parametrize("case", ALL_CASES)
def test_python_cli_bad_scene(run_cli, case, tmp_path):
    path = write_case(case, tmp_path)
    res = run_cli("run", path, cwd=tmp_path)
    check_one_line(res, path, case)
