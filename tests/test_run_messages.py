"""The run lines of the executable and of `python -m dyncontact run` (docs/scenes.md:
numbers in messages use a full exponent, as `2.225E-307`): the opening line counts in the
singular for one ('1 contact facet'), and the restart and final lines give t with its
full exponent, not Fortran's G form (`0.100000E-1`)."""

from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path

import pytest

from conftest import EXE, signal_after

#: t in a message: d.ddddd, the letter E, the exponent's sign and three digits.
FULL_EXPONENT = r"-?\d\.\d{5}E[+-]\d{3}"


def run(*args, cwd: Path) -> subprocess.CompletedProcess:
    if not EXE.is_file():
        pytest.skip(f"{EXE} is not built; run scripts/setup")
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    return subprocess.run([str(EXE), *map(str, args)], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=120)


def test_run_lines_count_in_the_singular_and_give_t_with_a_full_exponent(tmp_path):
    scene = tmp_path / "one.nml"     # a 1D bar: its contact boundary is one point
    scene.write_text("&mesh file = '', dim = 1, length = 1.0, h = 0.05 /\n"
                     "&contact obstacle_point = 0.0, obstacle_normal = -1.0, probe = 0.0 /\n"
                     "&initial kind = 'compressed_bar', amplitude = 0.5 /\n"
                     "&scheme name = 'hht', dt = 0.0025, t_end = 0.01 /\n"
                     "&output dir = 'out', checkpoint_every = 3 /\n")
    res = run("one.nml", "--out", "o", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    first, last = res.stdout.splitlines()
    assert first == "dyncontact: one.nml: 20 dofs, 20 elements, 1 contact facet; hht, 4 steps -> o"
    assert last == "dyncontact: ok, 4 steps to t=1.00000E-002 -> o"
    res = run("one.nml", "--restart", "o", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    restart = res.stdout.splitlines()[0]
    assert restart == "dyncontact: restart at step 4, t=1.00000E-002"   # its last step
    for line in (last, restart):
        assert re.search(r"t=" + FULL_EXPONENT + r"( |$)", line), line


def test_python_cli_run_lines_read_as_the_executables(tmp_path):
    import sys

    scene = tmp_path / "one.nml"
    scene.write_text("&mesh file = '', dim = 1, length = 1.0, h = 0.05 /\n"
                     "&contact obstacle_point = 0.0, obstacle_normal = -1.0, probe = 0.0 /\n"
                     "&scheme name = 'hht', dt = 0.0025, t_end = 0.01 /\n")
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    res = subprocess.run([sys.executable, "-m", "dyncontact", "run", "one.nml", "--out", "o"],
                         cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    first, last = res.stdout.splitlines()
    assert first == ("dyncontact: one.nml: 20 dofs, 20 elements, 1 contact facet; hht, 4 steps"
                     " -> o")
    assert re.fullmatch(r"dyncontact: ok, 4 steps to t=1\.00000E-002, [0-9.]+ s -> o", last)


def test_trace_size_note_gives_the_size_with_its_unit(tmp_path):
    """docs/scenes.md, "Limits": a trace over 100 MB is announced before the run as
    'the trace will take about 128.5 MB (500001 rows; ...)', a number with a digit before
    its point (the note wrote '.1 GB', Fortran's f0.1 dropping the zero). The run is
    stopped by SIGINT as soon as the note is read."""
    import signal

    if not EXE.is_file():
        pytest.skip(f"{EXE} is not built; run scripts/setup")
    (tmp_path / "big.nml").write_text("&scheme t_end = 1250.0, dt = 0.0025 /\n")
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    proc = subprocess.Popen([str(EXE), "big.nml", "--out", "o"], cwd=tmp_path, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    with signal_after(proc, signal.SIGINT, timeout=60):
        note = proc.stderr.readline()
    assert re.fullmatch(r"dyncontact: note: the trace will take about \d+\.\d (MB|GB) "
                        r"\(500001 rows; &output every thins it\)\n", note), note


def test_unstable_message_tells_the_energy_from_the_limit(tmp_path):
    """The blow-up message writes the energy and the limit with the digits that tell them
    apart: the seed's literal pc_hht variant passes 10 e_total(0) = 0.125 by 3e-5, which 4
    digits wrote as '1.250E-001 exceeds ... 1.250E-001'. The numbers read back as the trace's
    last e_total and 10 e_total(0) to the digits written."""
    import dyncontact
    from conftest import ROOT

    res = dyncontact.run(ROOT / "scripts" / "scenes" / "bar2d_pc_hht_seed.nml",
                         out=tmp_path / "o", progress=False)
    assert res.status == "unstable"
    m = re.search(r"e_total = (\S+) exceeds blowup x e_total\(0\) = (\S+) ", res.message)
    assert m, res.message
    energy, limit = m.group(1), m.group(2)
    assert energy != limit and float(energy) > float(limit)
    digits = len(energy.split("E")[0].replace(".", "").lstrip("-"))
    assert float(energy) == pytest.approx(res.trace["e_total"][-1], rel=10.0 ** (1 - digits))
    assert float(limit) == pytest.approx(10 * res.trace["e_total"][0], rel=10.0 ** (1 - digits))
