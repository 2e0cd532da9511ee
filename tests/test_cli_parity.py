"""The executable and `python -m dyncontact run` print the same stdout lines at the same
moments on one scene (docs/scenes.md, *Output on stdout*): the run's line before the
steps (so a run stopped by SIGTERM has it in its log), the restart line, the output
folder as given; only the Python CLI's wall time on the last line differs."""

from __future__ import annotations

import re
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import EXE, signal_after


def scene(t_end: str, every: int = 1) -> str:
    return ("&mesh file = '', dim = 2, length = 1.0, width = 0.1, h = 0.05 /\n"
            "&boundary clamped = 'top', contact = 'bottom' /\n"
            "&contact theta = 1, gamma0 = 10.0, probe = 0.05, 0.0 /\n"
            "&initial kind = 'compressed_bar', amplitude = 0.5 /\n"
            f"&scheme name = 'newmark', dt = 0.0025, t_end = {t_end} /\n"
            f"&output dir = 'out', checkpoint_every = 100, every = {every} /\n")


def commands(scn: str, *args: str) -> dict[str, list[str]]:
    if not EXE.is_file():
        pytest.skip(f"{EXE} is not built; run scripts/setup")
    return {"exe": [str(EXE), scn, *args],
            "cli": [sys.executable, "-m", "dyncontact", "run", scn, *args]}


def lines(text: str) -> list[str]:
    """stdout lines with the Python CLI's wall time (', 0.01 s') taken out."""
    return [re.sub(r", \d+\.\d\d s -> ", " -> ", line) for line in text.splitlines()]


def test_run_and_restart_print_the_same_lines(tmp_path: Path):
    (tmp_path / "s.nml").write_text(scene("0.5"))
    (tmp_path / "s2.nml").write_text(scene("1.0"))
    out = {}
    for who in ("exe", "cli"):
        run = subprocess.run(commands("s.nml", "--out", who)[who], cwd=tmp_path,
                             capture_output=True, text=True, timeout=120)
        assert run.returncode == 0, run.stderr
        again = subprocess.run(commands("s2.nml", "--restart", who)[who], cwd=tmp_path,
                               capture_output=True, text=True, timeout=120)
        assert again.returncode == 0, again.stderr
        out[who] = (lines(run.stdout), lines(again.stdout.replace(f"-> {who}", "-> DIR")))
        out[who] = ([x.replace(f"-> {who}", "-> DIR") for x in out[who][0]], out[who][1])
    assert out["exe"] == out["cli"]
    first, restarted = out["cli"]
    assert first == ["dyncontact: s.nml: 120 dofs, 80 elements, 2 contact facets; newmark, "
                     "200 steps -> DIR",
                     "dyncontact: ok, 200 steps to t=5.00000E-001 -> DIR"]
    assert restarted[0] == "dyncontact: restart at step 200, t=5.00000E-001"
    assert restarted[1].startswith("dyncontact: s2.nml: ") and "400 steps -> DIR" in restarted[1]


@pytest.mark.parametrize("who", ["exe", "cli"])
def test_sigterm_run_has_its_first_line(tmp_path: Path, who: str):
    """The run's line is on stdout (flushed) before the steps: a run stopped by SIGTERM
    while stepping has it, and nothing else, on stdout."""
    (tmp_path / "s.nml").write_text(scene("1.0e3", every=100))
    proc = subprocess.Popen(commands("s.nml", "--out", "o")[who], cwd=tmp_path,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    with signal_after(proc, signal.SIGTERM, timeout=60) as ended:
        first = proc.stdout.readline()   # blocks until the line is written and flushed
    rest, err = ended.stdout, ended.stderr
    assert first == ("dyncontact: s.nml: 120 dofs, 80 elements, 2 contact facets; newmark, "
                     "400000 steps -> o\n")
    assert rest == ""
    assert proc.returncode == 130, err
    assert err.splitlines()[-1].startswith("dyncontact: interrupted")


@pytest.mark.parametrize("who", ["exe", "cli"])
def test_closed_stdout_keeps_the_run(tmp_path: Path, who: str):
    """A reader that closed stdout's pipe (`| head -1`, here closed before the run starts,
    so every line fails with EPIPE) neither kills the run (SIGPIPE, exit 141) nor stops
    it: its trace and summary are complete, stderr has no traceback, and the exit status
    is the run's (docs/scenes.md, *Output on stdout*)."""
    import json
    import os

    (tmp_path / "s.nml").write_text(scene("0.5"))
    read_end, write_end = os.pipe()
    os.close(read_end)
    try:
        run = subprocess.run(commands("s.nml", "--out", "o")[who], cwd=tmp_path,
                             stdout=write_end, stderr=subprocess.PIPE, text=True, timeout=120)
    finally:
        os.close(write_end)
    assert run.returncode == 0, run.stderr
    assert run.stderr == ""
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summary["status"] == "ok" and summary["steps"] == 200
    rows = (tmp_path / "o" / "trace.csv").read_text().splitlines()
    assert len(rows) == 1 + 201       # the header, t = 0 and every step


def test_executable_help_stands_without_the_source_tree():
    """An installed executable has no docs/ beside it: --help names the scene groups, the
    documentation by its title, and the Python command line's own help, not a path only."""
    text = subprocess.run([str(commands("x.nml")["exe"][0]), "--help"], capture_output=True,
                          text=True, timeout=30).stdout
    flat = " ".join(text.split())
    for group in ("&mesh", "&boundary", "&material", "&contact", "&initial", "&scheme",
                  "&output", "&solver"):
        assert group in flat
    assert '"Scene files, outputs and exit codes"' in flat
    assert "python -m dyncontact run --help" in flat


@pytest.mark.parametrize("who", ["exe", "cli"])
def test_out_and_restart_take_the_equals_form(tmp_path: Path, who: str):
    """The executable refused --out=DIR and --restart=DIR as unknown options, which
    `python -m dyncontact run` takes: both take them, as --out DIR and --restart DIR, and
    both refuse an empty folder name in one line naming the option (exit 2)."""
    (tmp_path / "s.nml").write_text(scene("0.05", every=1), encoding="utf-8")
    (tmp_path / "s2.nml").write_text(scene("0.1", every=1), encoding="utf-8")
    run = subprocess.run(commands("s.nml", "--out=o")[who], cwd=tmp_path,
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    assert lines(run.stdout)[-1] == "dyncontact: ok, 20 steps to t=5.00000E-002 -> o"
    again = subprocess.run(commands("s2.nml", "--restart=o")[who], cwd=tmp_path,
                           capture_output=True, text=True, timeout=120)
    assert again.returncode == 0, again.stderr
    assert lines(again.stdout)[-1] == "dyncontact: ok, 40 steps to t=1.00000E-001 -> o"
    for args, option in ((("--out=",), "--out"), (("--restart=",), "--restart"),
                         (("--out", ""), "--out"), (("--restart", ""), "--restart")):
        res = subprocess.run(commands("s.nml", *args)[who], cwd=tmp_path,
                             capture_output=True, text=True, timeout=120)
        assert (res.returncode, res.stderr) == (2, f"dyncontact: {option}: empty folder "
                                                   "name\n"), (args, res.stderr)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o", "s.nml", "s2.nml"]
