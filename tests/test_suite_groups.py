"""The suite's own units of work for pytest-xdist (tests/conftest.py, scripts/test)."""

from __future__ import annotations

from pathlib import Path

from conftest import ALONE_FILES, ROOT, alone_or_file


def test_the_files_that_run_alone_exist():
    """Each name of ALONE_FILES is a test file here (a renamed file would silently leave
    the unit and run beside the others)."""
    here = Path(__file__).parent
    assert sorted(n for n in ALONE_FILES if not (here / n).is_file()) == []


def test_units_of_work():
    """A test of ALONE_FILES is in the one unit "alone", whatever its parameters; any
    other test is in its file's unit (its module fixtures built once, on one worker)."""
    assert alone_or_file("tests/test_restart.py::test_x[2]") == "alone"
    assert alone_or_file("tests/test_study_signals.py::test_y") == "alone"
    assert alone_or_file("tests/test_cli.py::test_z[a::b]") == "tests/test_cli.py"
    assert alone_or_file("tests/test_restart_more.py::t") == "tests/test_restart_more.py"


def test_setup_installs_xdist_and_the_suite_uses_loadfile():
    """scripts/test's workers come from the project's own set-up, and the suite's units
    are built only under --dist loadfile."""
    assert " pytest-xdist " in (ROOT / "scripts" / "setup").read_text()
    assert "--dist loadfile" in (ROOT / "scripts" / "test").read_text()
