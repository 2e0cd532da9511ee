"""The suite's own units of work for pytest-xdist (tests/conftest.py, scripts/test)."""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import tomllib
from importlib.metadata import version
from pathlib import Path

import pytest
from packaging.specifiers import SpecifierSet
from packaging.version import Version

from conftest import ALONE_FILES, ROOT, alone_or_file, signal_after

#: The packages the suite's scheduler (conftest.pytest_xdist_make_scheduler) builds on.
RUNNERS = ("pytest", "pytest-xdist")


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
    assert "'pytest-xdist>=" in (ROOT / "scripts" / "setup").read_text()
    assert "--dist loadfile" in (ROOT / "scripts" / "test").read_text()


def _pins_of(requirements) -> dict[str, SpecifierSet]:
    """{name: specifier} of the requirements (PEP 508 strings) that name a runner."""
    pins = {}
    for req in requirements:
        m = re.fullmatch(r"([A-Za-z0-9_.-]+)\s*(.*)", req.strip())
        if m and m.group(1).lower() in RUNNERS:
            pins[m.group(1).lower()] = SpecifierSet(m.group(2))
    return pins


def test_runners_are_pinned_to_the_major_versions_the_scheduler_works_with():
    """pyproject.toml's test extra holds pytest and pytest-xdist to a range below their
    next major version, scripts/setup installs the same ranges, the environment's
    versions are in them, and its pytest-xdist has the hook the scheduler overrides."""
    extra = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"][
        "optional-dependencies"]["test"]
    pins = _pins_of(extra)
    assert sorted(pins) == sorted(RUNNERS), extra
    for name, spec in pins.items():
        lower = [Version(s.version) for s in spec if s.operator == ">="]
        upper = [Version(s.version) for s in spec if s.operator == "<"]
        assert len(lower) == 1 and upper == [Version(f"{lower[0].major + 1}")], (name, spec)
        assert Version(version(name)) in spec, (name, version(name), spec)
    setup = (ROOT / "scripts" / "setup").read_text()
    arrays = re.search(r"^py_pkgs=\((.*?)\)", setup, re.S | re.M).group(1)
    words = [quoted or bare for quoted, bare in re.findall(r"'([^']*)'|(\S+)", arrays)]
    assert _pins_of(words) == pins, words
    from xdist.scheduler import LoadFileScheduling

    assert callable(getattr(LoadFileScheduling, "_split_scope", None))


def test_signal_after_collects_the_output_or_ends_the_process(tmp_path):
    """conftest.signal_after: the signal sent after the block, the output collected; a
    block that fails leaves no process behind (killed and reaped)."""
    child = ("import signal, sys, time\n"
             "signal.signal(signal.SIGTERM, lambda *a: (print('term'), sys.exit(7)))\n"
             "print('ready', flush=True)\n"
             "time.sleep(60)\n")
    proc = subprocess.Popen([sys.executable, "-c", child], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    with signal_after(proc, signal.SIGTERM) as ended:
        assert proc.stdout.readline() == "ready\n"
    assert (ended.stdout, ended.stderr, ended.returncode) == ("term\n", "", 7)
    proc = subprocess.Popen([sys.executable, "-c", child], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    with pytest.raises(ZeroDivisionError):
        with signal_after(proc, signal.SIGTERM) as ended:
            proc.stdout.readline()
            1 / 0
    assert proc.returncode == -signal.SIGKILL and ended.returncode is None
    proc.stdout.close()
    proc.stderr.close()
