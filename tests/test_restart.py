"""Checkpoint and restart (&output checkpoint_every, --restart DIR, run(restart=),
Stepper.save/load): a run killed with SIGKILL at a random step, or stopped by SIGTERM
or Ctrl-C, and continued from its checkpoint gives the files of the run never stopped,
byte for byte (trace.csv, the numbers of summary.json, the VTU fields), for every scheme
family and mass kind whose carried data differ; a restart with a later t_end or a raised
blowup gives the files of the run made straight with that scene; a checkpoint that is
missing, of another scene, step or build, at or past the restart's t_end, truncated or
corrupt is refused with exit 2 naming the file and leaves the folder as it was."""

from __future__ import annotations

import json
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import dyncontact
from conftest import EXE
from dyncontact.core import DyncontactWarning, Stepper

EXIT_OK, EXIT_BAD_INPUT, EXIT_NUMERIC, EXIT_SIGNAL = 0, 2, 3, 130
#: The checkpoint's file name in the output folder (docs/scenes.md).
CKPT = "checkpoint.bin"
#: Bytes of the checkpoint header (docs/scenes.md): 7 fields of 8 bytes, a 96-byte build id.
HEADER = 7 * 8 + 96
#: The checkpoint format version this build writes (docs/scenes.md).
FORMAT_VERSION = 6
#: Steps between checkpoints: more than the ~280 rows of the trace's write buffer, so that
#: a killed run sometimes leaves rows after its checkpoint in trace.csv (cut at restart).
EVERY = 300


def scene_text(name: str, mass: str = "consistent", dt: str = "0.0025", t_end: str = "15.0",
               extra: str = "", gamma0: str = "10.0", fields: int = 0,
               every: int = EVERY, contact: str = "theta = 1") -> str:
    return ("&mesh file = '', dim = 2, length = 1.0, width = 0.1, h = 0.05 /\n"
            "&boundary clamped = 'top', contact = 'bottom' /\n"
            f"&contact {contact}, gamma0 = {gamma0}, probe = 0.05, 0.0 /\n"
            "&initial kind = 'compressed_bar', amplitude = 0.5 /\n"
            f"&scheme name = '{name}', dt = {dt}, t_end = {t_end}, mass = '{mass}'{extra} /\n"
            f"&output dir = 'out', checkpoint_every = {every}, fields_every = {fields} /\n")


def exe_cmd(scene: Path, *args) -> list[str]:
    if not EXE.is_file():
        pytest.skip(f"{EXE} is not built; run scripts/setup")
    return [str(EXE), str(scene), *map(str, args)]


def cli_cmd(scene: Path, *args) -> list[str]:
    return [sys.executable, "-m", "dyncontact", "run", str(scene), "--quiet", *map(str, args)]


def run(cmd, cwd) -> subprocess.CompletedProcess:
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    return subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=300)


def summary_numbers(folder: Path) -> dict:
    """summary.json without its timing and without the output folder's name."""
    s = json.loads((folder / "summary.json").read_text())
    s.pop("wall_s")
    s["scene"]["output"].pop("dir")
    return s


def assert_same_results(a: Path, b: Path, what: str) -> None:
    assert (a / "trace.csv").read_bytes() == (b / "trace.csv").read_bytes(), what
    assert summary_numbers(a) == summary_numbers(b), what
    fields_a = sorted(p.name for p in (a / "fields").glob("*.vtu")) if (a / "fields").exists() else []
    fields_b = sorted(p.name for p in (b / "fields").glob("*.vtu")) if (b / "fields").exists() else []
    assert fields_a == fields_b, what
    for name in fields_a:
        assert (a / "fields" / name).read_bytes() == (b / "fields" / name).read_bytes(), what
    if fields_a:
        assert (a / "fields.pvd").read_bytes() == (b / "fields.pvd").read_bytes(), what


def checkpoint_step(path: Path) -> int:
    return int(np.frombuffer(path.read_bytes()[48:56], dtype="<i8")[0])


# (scheme, mass, dt, t_end, extra keys): every family, and the mass kinds that change
# what a step carries (lumped: no solve, the one-pass end of central; redistributed:
# massless dofs updated apart in the implicit schemes).
FAMILIES = [
    ("newmark", "consistent", "0.0025", "15.0", ""),
    ("hht", "consistent", "0.0025", "15.0", ", alpha = -0.1"),
    ("hht", "lumped", "0.0025", "15.0", ", alpha = -0.1"),
    ("hht", "redistributed", "0.0025", "15.0", ", alpha = -0.1"),
    ("theta", "consistent", "0.0025", "15.0", ", theta = 0.6"),
    ("galpha", "redistributed", "0.0025", "15.0", ", rho_inf = 0.8"),
    ("pc", "consistent", "0.0005", "3.0", ""),
    ("pc_hht", "lumped", "0.0005", "3.0", ", alpha = -0.1"),
    ("central", "lumped", "0.01", "15.0", ""),
    ("central", "consistent", "0.0", "60.0", ""),
]


# the augmented Lagrangian carries its multipliers lambda from step to step (in the
# checkpoint with the state): both multipliers, on the mass each is meant for and on the
# chattering consistent mass
ALM_FAMILIES = [
    ("newmark", "consistent", "integral"),
    ("hht", "redistributed", "nodal"),
]


@pytest.mark.parametrize("name,mass,dt,t_end,extra", FAMILIES,
                         ids=[f"{f[0]}-{f[1]}" for f in FAMILIES])
def test_kill_9_at_a_random_step_then_restart_is_bit_identical(name, mass, dt, t_end, extra,
                                                                tmp_path):
    kill_9_then_restart(tmp_path, scene_text(name, mass, dt, t_end, extra, fields=1000),
                        f"{name}/{mass}")


@pytest.mark.parametrize("name,mass,multiplier", ALM_FAMILIES,
                         ids=[f"{f[0]}-{f[1]}-alm_{f[2]}" for f in ALM_FAMILIES])
def test_kill_9_then_restart_with_the_augmented_lagrangian_is_bit_identical(name, mass,
                                                                            multiplier, tmp_path):
    extra = ", alpha = -0.1" if name == "hht" else ""
    contact = f"method = 'alm', multiplier = '{multiplier}'"
    # every 500 steps: the first checkpoint (t = 1.25) is in the first contact phase
    kill_9_then_restart(tmp_path, scene_text(name, mass, extra=extra, fields=1000,
                                             contact=contact, every=500),
                        f"{name}/{mass}/alm {multiplier}", every=500)


#: Columns of J0^-1 solved together as one group by the contact correction's cache
#: (ZCHUNK, fortran/schemes/contact_columns.f90).
COLUMN_GROUP = 16


def test_kill_9_then_restart_with_cg_counts_the_whole_runs_cg_solves(monkeypatch, tmp_path):
    """&solver kind = 'cg': summary.json's cg_solves, cg_iterations and cg_max_iterations
    after a restart are the whole run's (carried in the checkpoint). With every column of
    the contact correction solved at set-up (DYNCONTACT_CONTACT_COLUMNS=all) the restarted
    run does the same solves as the whole one: every number is equal."""
    monkeypatch.setenv("DYNCONTACT_CONTACT_COLUMNS", "all")
    text = scene_text("hht", extra=", alpha = -0.1") + "&solver kind = 'cg' /\n"
    kill_9_then_restart(tmp_path, text, "hht/cg")
    summary = json.loads((tmp_path / "part" / "summary.json").read_text())
    assert summary["solver_kind"] == "cg" and summary["cg_solves"] > summary["steps"] > 0


@pytest.mark.parametrize("scene_file, every", [(None, EVERY), ("ball3d_newmark.nml", 70)],
                         ids=["bar2d", "ball3d"])
def test_restart_with_cg_counts_the_solves_of_the_run_never_stopped(scene_file, every,
                                                                   tmp_path):
    """Columns of J0^-1 computed when first needed (the default): the checkpoint keeps
    which ones the cache holds, the restarted run solves them again before its first step
    without counting them, and then solves what the run never stopped solves: every
    number of summary.json is the whole run's, cg_solves and cg_iterations included. The
    bar (2 contact facets, one group of COLUMN_GROUP columns) restarts at step 5700 of
    6000, the ball (1146 contact-cell dofs, 330 columns and 99 node-basis columns held)
    at step 140 of 160; before the checkpoint kept the cache, the ball's restarted run
    counted 772 CG solves against 490."""
    scene = tmp_path / "s.nml"
    if scene_file is None:
        scene.write_text(scene_text("hht", extra=", alpha = -0.1") + "&solver kind = 'cg' /\n")
    else:
        scn = dyncontact.Scene.read(Path(__file__).resolve().parents[1] / "scripts" / "scenes"
                                    / scene_file)
        scn.set("solver.kind", "cg")
        scn.set("output.checkpoint_every", every)
        scn.write(scene)
    assert run(exe_cmd(scene, "--out", "full"), tmp_path).returncode == EXIT_OK
    shutil.copytree(tmp_path / "full", tmp_path / "again")
    res = run(exe_cmd(scene, "--restart", "again"), tmp_path)
    assert res.returncode == EXIT_OK, res.stderr
    full, again = summary_numbers(tmp_path / "full"), summary_numbers(tmp_path / "again")
    trace = [(tmp_path / d / "trace.csv").read_bytes() for d in ("again", "full")]
    assert trace[0] == trace[1]
    assert again == full
    assert full["cg_max_iterations"] > 0 and full["cg_solves"] > full["steps"]


def checkpoint_multipliers(path: Path) -> np.ndarray:
    """lambda from a checkpoint: after the 7 leading numbers and the 6 state vectors."""
    payload = path.read_bytes()[HEADER:]
    pos = 56
    for _ in range(6):
        pos += 8 + 8 * int(np.frombuffer(payload[pos:pos + 8], dtype="<i8")[0])
    count = int(np.frombuffer(payload[pos:pos + 8], dtype="<i8")[0])
    return np.frombuffer(payload[pos + 8:pos + 8 + 8 * count], dtype="<f8")


@pytest.mark.parametrize("multiplier", ["integral", "nodal"])
def test_alm_checkpoint_in_contact_holds_the_multipliers(multiplier, tmp_path):
    """Saved in contact (t = 1.25, lambda /= 0) and loaded into another run, the
    augmented Lagrangian continues as the run that never stopped, bit for bit."""
    scene = tmp_path / "s.nml"
    scene.write_text(scene_text("newmark", "redistributed",
                                contact=f"method = 'alm', multiplier = '{multiplier}'"))
    with Stepper(scene, tmp_path / "a") as a:
        a.advance(500)
        a.save(tmp_path / "state.bin")
        a.advance(700)
        ref = a.state()
    lam = checkpoint_multipliers(tmp_path / "state.bin")
    assert lam.size == 3 and lam.min() < 0.0     # the 3 nodes of the bottom
    with Stepper(scene, tmp_path / "b") as b:
        assert b.load(tmp_path / "state.bin") == 500
        b.advance(700)
        got = b.state()
    for key in ("t", "u", "v", "a", "mv", "bu"):
        assert np.array_equal(ref[key], got[key]), key


def kill_9_then_restart(tmp_path: Path, text: str, label: str, every: int = EVERY) -> None:
    """Run the scene whole; run it again, SIGKILL it at a random moment after its first
    checkpoint, restart from that checkpoint: the results are the whole run's, byte for byte."""
    scene = tmp_path / "s.nml"
    scene.write_text(text)
    full = run(exe_cmd(scene, "--out", "full"), tmp_path)
    assert full.returncode == EXIT_OK, full.stderr
    n_steps = json.loads((tmp_path / "full" / "summary.json").read_text())["steps"]
    assert n_steps > 3 * every
    seed = int.from_bytes(os.urandom(4), "little")
    rng = random.Random(seed)
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    proc = subprocess.Popen(exe_cmd(scene, "--out", "part"), cwd=tmp_path, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    t0 = time.time()
    while not (tmp_path / "part" / CKPT).exists() and proc.poll() is None:
        assert time.time() - t0 < 120
        time.sleep(0.0005)
    time.sleep(rng.uniform(0.0, 0.05))
    proc.kill()                      # SIGKILL: no handler runs, nothing is tidied up
    proc.wait(timeout=60)
    what = f"{label}, random seed {seed}"
    step = checkpoint_step(tmp_path / "part" / CKPT)
    # (a run that ended before the kill keeps the checkpoint of its last step)
    assert 0 < step <= n_steps and (step % every == 0 or step == n_steps), what
    res = run(exe_cmd(scene, "--restart", "part"), tmp_path)
    assert res.returncode == EXIT_OK, (what, res.stderr)
    assert f"restart at step {step}," in res.stdout, what
    assert_same_results(tmp_path / "part", tmp_path / "full", what)
    assert_f_n_restarted(tmp_path / "part", step, every, what)


def assert_f_n_restarted(folder: Path, step: int, every: int, what: str) -> None:
    """The restarted trace (byte-identical to the whole run's, assert_same_results) has
    the f_n column, nonzero through the contacts: every row after the checkpoint with
    active contact points has f_n /= 0 (so the restart reproduced the force bit for bit,
    not a column of zeros), and the run has contact rows."""
    lines = (folder / "trace.csv").read_text().splitlines()
    header = lines[0].split(",")
    assert header[-1] == "f_n", what
    rows = np.loadtxt(lines[1:], delimiter=",", ndmin=2)
    f_n, active = rows[:, -1], rows[:, header.index("active")]
    every_row = json.loads((folder / "summary.json").read_text())["scene"]["output"]["every"]
    after = np.arange(len(rows)) > step // every_row     # rows written after the restart
    assert f_n.min() < 0.0, what
    # (nonzero, not < 0: the augmented Lagrangian's integral multipliers on the
    # chattering consistent mass can sum to a small positive force)
    assert np.all(f_n[after & (active > 0)] != 0.0), what


#: A free bar under gravity on slip walls, landing on the obstacle 0.05 below it: e_load
#: (= -u.L) is not 0 in any row after the first.
GRAVITY_SCENE = ("&mesh dim = 2, length = 1.0, width = 0.1, h = 0.05 /\n"
                 "&boundary clamped = '', slip_x = 'left,right', contact = 'bottom' /\n"
                 "&material gravity = 0.0, -1.0 /\n"
                 "&contact obstacle_point = 0.0, -0.05 /\n"
                 "&initial kind = 'rest' /\n"
                 "&scheme name = 'newmark', dt = 0.0025, t_end = 3.0 /\n"
                 "&output dir = 'out', checkpoint_every = 400 /\n")


@pytest.mark.parametrize("entry", ["exe", "cli"])
def test_restart_under_gravity_keeps_e_load(entry, tmp_path):
    """The load L = rho g is the model's, not the checkpoint's: a restarted run reports
    e_load = -u.L (and tests e_total + e_load for a blow-up, whose scale holds the load's
    energy over t_end: the restart's t_end) as the run never stopped. The run to 2.5,
    continued from its last step to 3.0, is the run to 3.0."""
    scene, short = tmp_path / "s.nml", tmp_path / "short.nml"
    scene.write_text(GRAVITY_SCENE)
    short.write_text(GRAVITY_SCENE.replace("t_end = 3.0", "t_end = 2.5"))
    cmd = exe_cmd if entry == "exe" else cli_cmd
    assert run(cmd(scene, "--out", "full"), tmp_path).returncode == EXIT_OK
    rows = np.genfromtxt(tmp_path / "full" / "trace.csv", delimiter=",", names=True)
    assert np.all(rows["e_load"][1:] != 0.0)
    assert run(cmd(short, "--out", "again"), tmp_path).returncode == EXIT_OK
    assert checkpoint_step(tmp_path / "again" / CKPT) == 1000
    res = run(cmd(scene, "--restart", "again"), tmp_path)
    assert res.returncode == EXIT_OK, res.stderr
    assert_same_results(tmp_path / "again", tmp_path / "full", "restart under gravity")


def test_restart_twice_and_from_the_last_checkpoint_of_a_finished_run(tmp_path):
    """A run that ends keeps the checkpoint of its last step: a restart from it (the same
    t_end) ends at once and leaves the same files, the last row included (2000 steps,
    every = 7: a row off the rows' grid, which the checkpoint does not count and the
    restart writes again); so does a restart of that restarted run."""
    scene = tmp_path / "s.nml"
    scene.write_text(scene_text("hht", extra=", alpha = -0.1", t_end="5.0")
                     .replace("&output dir = 'out'", "&output dir = 'out', every = 7"))
    assert run(exe_cmd(scene, "--out", "full"), tmp_path).returncode == EXIT_OK
    assert checkpoint_step(tmp_path / "full" / CKPT) == 2000
    shutil.copytree(tmp_path / "full", tmp_path / "again")
    for _ in range(2):
        res = run(exe_cmd(scene, "--restart", "again"), tmp_path)
        assert res.returncode == EXIT_OK, res.stderr
        assert "restart at step 2000," in res.stdout
        assert_same_results(tmp_path / "again", tmp_path / "full", "restart of a finished run")


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_signal_writes_a_checkpoint_at_the_step_it_stops_on(sig, tmp_path):
    scene = tmp_path / "s.nml"
    # h = 0.02 to t = 150: 150 000 steps, a few seconds on any machine here, so the run is
    # still stepping when the signal comes 0.2 s after its trace appears (at t_end = 15 it
    # can finish first); a checkpoint interval no signal falls on by chance; the trace every
    # 10 steps keeps the files small
    scene.write_text(scene_text("hht", extra=", alpha = -0.1", every=7919, t_end="150.0")
                     .replace("h = 0.05", "h = 0.02").replace("dt = 0.0025", "dt = 0.001")
                     .replace("dir = 'out',", "dir = 'out', every = 10,"))
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    proc = subprocess.Popen(exe_cmd(scene, "--out", "part"), cwd=tmp_path, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    t0 = time.time()
    while not (tmp_path / "part" / "trace.csv").exists():
        assert time.time() - t0 < 120 and proc.poll() is None
        time.sleep(0.001)
    time.sleep(0.2)
    proc.send_signal(sig)
    _out, err = proc.communicate(timeout=120)
    assert proc.returncode == EXIT_SIGNAL, err
    assert "checkpoint kept" in err
    summary = json.loads((tmp_path / "part" / "summary.json").read_text())
    assert summary["status"] == "interrupted"
    step = checkpoint_step(tmp_path / "part" / CKPT)
    assert step == summary["steps"] > 0                  # the step it stopped on
    assert run(exe_cmd(scene, "--out", "full"), tmp_path).returncode == EXIT_OK
    res = run(exe_cmd(scene, "--restart", "part"), tmp_path)
    assert res.returncode == EXIT_OK, res.stderr
    assert_same_results(tmp_path / "part", tmp_path / "full", f"signal {sig}")


def test_python_restart_after_ctrl_c_between_chunks(tmp_path):
    """run() stopped by KeyboardInterrupt (here from the progress callback) writes the
    checkpoint when it closes the run; run(restart=) and `python -m dyncontact run
    --restart` continue it."""
    scene = tmp_path / "s.nml"
    scene.write_text(scene_text("pc_hht", "lumped", "0.0005", "3.0", ", alpha = -0.1",
                                fields=1000))
    full = dyncontact.run(scene, out=tmp_path / "full", progress=False)
    assert full.ok

    def stop(step, n_steps):
        if step >= 2000:
            raise KeyboardInterrupt

    for entry in ("api", "cli"):
        part = tmp_path / f"part_{entry}"
        # the interruption says, as the executable does, where the run stopped and how to
        # continue it
        with pytest.raises(KeyboardInterrupt, match=r"^interrupted at t = \S+ \(trace and "
                           r"checkpoint kept: --restart .+ continues\)$"):
            dyncontact.run(scene, out=part, progress=False, callback=stop)
        assert json.loads((part / "summary.json").read_text())["status"] == "interrupted"
        step = checkpoint_step(part / CKPT)
        assert step == json.loads((part / "summary.json").read_text())["steps"] >= 2000
        if entry == "api":
            res = dyncontact.run(scene, restart=part, progress=False)
            assert res.ok and res.summary["steps"] == full.summary["steps"]
        else:
            res = run(cli_cmd(scene, "--restart", part), tmp_path)
            assert res.returncode == EXIT_OK, res.stderr
        assert_same_results(part, tmp_path / "full", entry)


def test_stepper_save_and_load(tmp_path):
    scene = tmp_path / "s.nml"
    scene.write_text(scene_text("galpha", "redistributed", extra=", rho_inf = 0.8"))
    with Stepper(scene, tmp_path / "a") as a:
        a.advance(777)
        a.save(tmp_path / "state.bin")
        a.advance(500)
        ref = a.state()
    with Stepper(scene, tmp_path / "b") as b:
        b.advance(3)              # any state: load replaces it
        assert b.load(tmp_path / "state.bin") == 777
        assert b.state()["t"] == 777 * 0.0025
        b.advance(500)
        got = b.state()
    for key in ("t", "u", "v", "a", "mv", "bu"):
        assert np.array_equal(ref[key], got[key]), key
    other = tmp_path / "other.nml"
    other.write_text(scene_text("galpha", "redistributed", extra=", rho_inf = 0.7"))
    with Stepper(other, tmp_path / "c") as c:
        with pytest.raises(dyncontact.BadInputError, match="state.bin.*another scene"):
            c.load(tmp_path / "state.bin")
        assert c.advance(10) == 0     # a failed load leaves the Stepper finished


def test_stepper_load_cuts_the_trace_back_as_restart_does(tmp_path):
    """advance, save, advance further, load, advance to the end: trace.csv, fields.pvd and
    the snapshots are those of the run never taken back (t never goes backwards)."""
    scene = tmp_path / "s.nml"
    scene.write_text(scene_text("hht", extra=", alpha = -0.1", t_end="2.0", fields=100))
    full = dyncontact.run(scene, out=tmp_path / "full", progress=False)
    assert full.ok
    with Stepper(scene, tmp_path / "b") as b:
        b.advance(100)
        b.save(tmp_path / "state.bin")
        b.advance(450)            # rows (and snapshots 200..500) the load drops
        assert b.load(tmp_path / "state.bin") == 100
        b.advance(10**6)
    t = np.loadtxt(tmp_path / "b" / "trace.csv", delimiter=",", skiprows=1)[:, 0]
    assert np.all(np.diff(t) > 0)
    for name in ("trace.csv", "fields.pvd"):
        assert (tmp_path / "b" / name).read_bytes() == (tmp_path / "full" / name).read_bytes()


def test_stepper_save_at_the_last_step_leaves_out_the_last_row_off_the_grid(tmp_path):
    """800 steps with every = 7: the last row is for the end only. A state saved at the
    last step counts the rows before it (a longer run continues from it with its own
    rows): loaded into the same run it cuts that row and writes it again, so the trace
    is the run's; loaded into the run to a later t_end (through --restart), the files
    are those of that run."""
    text = scene_text("hht", extra=", alpha = -0.1", t_end="2.0", every=0) \
        .replace("&output dir = 'out'", "&output dir = 'out', every = 7")
    scene, longer = tmp_path / "s.nml", tmp_path / "l.nml"
    scene.write_text(text)
    longer.write_text(text.replace("t_end = 2.0", "t_end = 2.5"))
    assert run(exe_cmd(scene, "--out", "whole"), tmp_path).returncode == EXIT_OK
    assert run(exe_cmd(longer, "--out", "full"), tmp_path).returncode == EXIT_OK
    with Stepper(scene, tmp_path / "o") as s:
        s.advance(10_000)
        s.save(tmp_path / "o" / CKPT)
        trace = (tmp_path / "o" / "trace.csv").read_bytes()
        assert trace == (tmp_path / "whole" / "trace.csv").read_bytes()
        assert s.load(tmp_path / "o" / CKPT) == 800
    assert (tmp_path / "o" / "trace.csv").read_bytes() == trace     # the same last row, once
    assert checkpoint_step(tmp_path / "o" / CKPT) == 800
    assert run(exe_cmd(longer, "--restart", "o"), tmp_path).returncode == EXIT_OK
    assert (tmp_path / "o" / "trace.csv").read_bytes() == \
        (tmp_path / "full" / "trace.csv").read_bytes()


# ------------------------------------------------------ a restart that extends the run

def in_3d(text: str) -> str:
    """The scene on the built-in 3D box (&mesh dim = 3), the probe at the bottom's centre."""
    return text.replace("dim = 2", "dim = 3").replace("probe = 0.05, 0.0", "probe = 0.05, 0.05, 0.0")


def folder_files(folder: Path) -> dict[str, bytes]:
    """A run folder's files by name, with their bytes (a refused restart changes none)."""
    return {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}


def refused_line(res, part: Path) -> str:
    """The one line of a restart refused as bad input (exit 2, no traceback), which names
    the checkpoint file of ``part``."""
    assert res.returncode == EXIT_BAD_INPUT, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in res.stderr, res.stderr
    assert f"{part / CKPT}" in lines[0], lines[0]
    return lines[0]


def restart_with(entry: str, scene: Path, folder: Path, cwd: Path) -> None:
    """Continue the run in `folder` with `scene` through one entry point; it ends ok."""
    if entry == "api":
        res = dyncontact.run(scene, restart=folder, progress=False)
        assert res.status == "ok", res.message
    else:
        cmd = exe_cmd if entry == "exe" else cli_cmd
        res = run(cmd(scene, "--restart", folder), cwd)
        assert res.returncode == EXIT_OK, res.stderr


# (label, scene of the first part, the later t_end): an implicit scheme, pc, central with
# dt = 0 where the step it takes for the later t_end is the same (15/926 and 30/1851 are
# not: test_central_automatic_step_of_another_t_end below), and the 3D box; hht with field
# snapshots (fields.pvd continued, listing the first part's). every = 7
# divides neither part's step count, so the first part's last row is off the rows'
# grid: the restart cuts it with the rows after the checkpoint.
EXTEND = [
    ("hht", scene_text("hht", extra=", alpha = -0.1", t_end="2.0", fields=100), "4.0"),
    ("pc", scene_text("pc", dt="0.0005", t_end="1.0"), "2.0"),
    ("central-dt0", scene_text("central", dt="0.0", t_end="10.0", every=200), "20.0"),
    ("hht-3d", in_3d(scene_text("hht", t_end="1.0", every=100)), "2.0"),
]


@pytest.mark.parametrize("entry", ["exe", "cli", "api"])
@pytest.mark.parametrize("label,text,t_end2", EXTEND, ids=[e[0] for e in EXTEND])
def test_restart_with_a_later_t_end_continues_the_run(entry, label, text, t_end2, tmp_path):
    """A run to T1 that ended (with the checkpoint of its last step), restarted with t_end =
    T2 > T1 and another max_steps: the files of the run straight to T2, byte for byte (the
    first part's last row, off the rows' grid, is not counted by its checkpoint: cut)."""
    text = text.replace("&output dir = 'out'", "&output dir = 'out', every = 7")
    first, second = tmp_path / "t1.nml", tmp_path / "t2.nml"
    first.write_text(text)
    t_end1 = text.split("t_end = ")[1].split(",")[0]
    second.write_text(text.replace(f"t_end = {t_end1}", f"t_end = {t_end2}, max_steps = 50000"))
    assert run(exe_cmd(second, "--out", "full"), tmp_path).returncode == EXIT_OK
    assert run(exe_cmd(first, "--out", "part"), tmp_path).returncode == EXIT_OK
    s1 = json.loads((tmp_path / "part" / "summary.json").read_text())
    s2 = json.loads((tmp_path / "full" / "summary.json").read_text())
    assert s1["scene"]["scheme"]["dt"] == s2["scene"]["scheme"]["dt"]   # the same step
    assert 2 * s1["steps"] in (s2["steps"], s2["steps"] + 1) and s1["steps"] % 7 != 0
    assert checkpoint_step(tmp_path / "part" / CKPT) == s1["steps"]
    restart_with(entry, second, tmp_path / "part", tmp_path)
    assert_same_results(tmp_path / "part", tmp_path / "full", f"{label} to {t_end2}, {entry}")


@pytest.mark.parametrize("entry", ["exe", "api"])
def test_restart_with_a_raised_blowup_continues_a_run_it_stopped(entry, tmp_path):
    """A run stopped by the blow-up test (blowup = 1.001: newmark's e_total exceeds it in a
    contact at t = 1.34), restarted with blowup = 10: the files of the run made with
    blowup = 10 throughout (the limit is the restarting scene's, not the checkpoint's)."""
    low, high = tmp_path / "low.nml", tmp_path / "high.nml"
    text = scene_text("newmark", t_end="3.0", extra=", blowup = 1.001")
    low.write_text(text)
    high.write_text(text.replace("blowup = 1.001", "blowup = 10.0"))
    assert run(exe_cmd(high, "--out", "full"), tmp_path).returncode == EXIT_OK
    res = run(exe_cmd(low, "--out", "part"), tmp_path)
    assert res.returncode == EXIT_NUMERIC and "unstable at t = 1.3" in res.stderr, res.stderr
    assert checkpoint_step(tmp_path / "part" / CKPT) == EVERY
    restart_with(entry, high, tmp_path / "part", tmp_path)
    assert_same_results(tmp_path / "part", tmp_path / "full", f"raised blowup, {entry}")


@pytest.mark.parametrize("entry", ["exe", "cli"])
@pytest.mark.parametrize("t_end", ["1.5", "2.9975"])
def test_restart_before_the_checkpoint_is_refused(entry, t_end, stopped, tmp_path):
    """The finished run's checkpoint is at its last step, 1200, t = 3; a restart that
    ends before it (at 1.5, or one step before) is refused in one line naming the file,
    the checkpoint's t and &scheme t_end, and changes nothing (a run does not go back)."""
    _scene, part = stopped
    assert checkpoint_step(part / CKPT) == 1200
    short = tmp_path / "short.nml"
    short.write_text(scene_text("hht", extra=", alpha = -0.1", t_end=t_end))
    before = folder_files(part)
    cmd = exe_cmd if entry == "exe" else cli_cmd
    line = refused_line(run(cmd(short, "--restart", part), tmp_path), part)
    assert "t = 3.0" in line and "&scheme t_end" in line and "later t_end" in line, line
    assert folder_files(part) == before


def test_central_automatic_step_of_another_t_end_is_refused_naming_the_step(tmp_path):
    """central with dt = 0 takes the largest step <= 0.9 dt_crit that divides t_end: for
    t_end = 15 and 30 the steps differ (15/926 and 30/1851), so the restart to 30 is
    refused naming the checkpoint's step; that step given as &scheme dt continues the
    run, as the run to 30 with that dt throughout."""
    first, second = tmp_path / "t15.nml", tmp_path / "t30.nml"
    first.write_text(scene_text("central", dt="0.0", t_end="15.0", every=200))
    second.write_text(scene_text("central", dt="0.0", t_end="30.0", every=200))
    assert run(exe_cmd(first, "--out", "part"), tmp_path).returncode == EXIT_OK
    dt = json.loads((tmp_path / "part" / "summary.json").read_text())["scene"]["scheme"]["dt"]
    res = run(exe_cmd(second, "--restart", "part"), tmp_path)
    assert res.returncode == EXIT_BAD_INPUT, res.stderr
    line = res.stderr.strip()
    assert "part/checkpoint.bin" in line and "&scheme dt = 0" in line, line
    given = line.split("; &scheme dt = ")[1].split(" ")[0]
    assert float(given) == dt, line
    fixed = tmp_path / "t30dt.nml"
    fixed.write_text(scene_text("central", dt=given, t_end="30.0", every=200))
    assert run(exe_cmd(fixed, "--out", "full"), tmp_path).returncode == EXIT_OK
    restart_with("exe", fixed, tmp_path / "part", tmp_path)
    assert_same_results(tmp_path / "part", tmp_path / "full", "central, the checkpoint's dt")


def test_restart_to_a_later_t_end_checks_the_space_its_snapshots_need(tmpfs, tmp_path):
    """The free-space check of a run with field snapshots counts, on a restart, what the
    rest of the run to the restart's t_end will write: on a 2 MB tmpfs, a run to t = 0.5
    (21 snapshots) restarted to t = 50 (1 980 more) is refused naming &output fields_every
    and changes nothing; restarted to t = 1 it runs."""
    disk = tmpfs("size=2m")
    text = scene_text("hht", extra=", alpha = -0.1", t_end="0.5", fields=10, every=100)
    scene, far, near = tmp_path / "s.nml", tmp_path / "far.nml", tmp_path / "near.nml"
    scene.write_text(text)
    far.write_text(text.replace("t_end = 0.5", "t_end = 50.0"))
    near.write_text(text.replace("t_end = 0.5", "t_end = 1.0"))
    part = disk / "part"
    assert run(exe_cmd(scene, "--out", part), tmp_path).returncode == EXIT_OK
    before = folder_files(part)
    res = run(exe_cmd(far, "--restart", part), tmp_path)
    assert res.returncode == EXIT_BAD_INPUT, res.stderr
    assert "&output fields_every" in res.stderr and "1980 snapshots" in res.stderr, \
        res.stderr
    assert folder_files(part) == before
    res = run(exe_cmd(near, "--restart", part), tmp_path)
    assert res.returncode == EXIT_OK, res.stderr


# ------------------------------------------------------------------ refusals

def pvd_files(folder: Path) -> list[str]:
    """The files fields.pvd lists, in its order."""
    import xml.etree.ElementTree as ET

    return [d.get("file") for d in ET.parse(folder / "fields.pvd").getroot().iter("DataSet")]


def without_line(pvd: bytes, name: str) -> bytes:
    """A fields.pvd's bytes without the line that lists `name`."""
    return b"".join(line for line in pvd.splitlines(keepends=True)
                    if f'file="{name}"'.encode() not in line)


@pytest.mark.parametrize("entry", ["exe", "cli", "api"])
def test_restart_lists_only_the_snapshots_still_there(entry, tmp_path):
    """A snapshot deleted between the runs (fields/step_0000100.vtu) is not in the
    restarted run's fields.pvd (a collection listing a missing file does not open in
    ParaView): the collection is the straight run's without that line, every file it lists
    is there, and one warning line names the missing file."""
    text = scene_text("hht", extra=", alpha = -0.1", t_end="1.0", fields=100)
    first, second = tmp_path / "t1.nml", tmp_path / "t2.nml"
    first.write_text(text)
    second.write_text(text.replace("t_end = 1.0", "t_end = 2.0"))
    assert run(exe_cmd(second, "--out", "full"), tmp_path).returncode == EXIT_OK
    assert run(exe_cmd(first, "--out", "part"), tmp_path).returncode == EXIT_OK
    part = tmp_path / "part"
    gone = "fields/step_0000100.vtu"
    assert gone in pvd_files(part)
    (part / gone).unlink()
    if entry == "api":
        with pytest.warns(DyncontactWarning) as seen:
            assert dyncontact.run(second, restart=part, progress=False).ok
        lines = [str(w.message) for w in seen]
    else:
        cmd = exe_cmd if entry == "exe" else cli_cmd
        res = run(cmd(second, "--restart", part), tmp_path)
        assert res.returncode == EXIT_OK, res.stderr
        lines = res.stderr.splitlines()
    named = [line for line in lines if gone in line]
    assert len(named) == 1 and "warning" in named[0] and "missing" in named[0], lines
    listed = pvd_files(part)
    assert gone not in listed and all((part / f).is_file() for f in listed), listed
    assert len(listed) == len(pvd_files(tmp_path / "full")) - 1
    assert (part / "fields.pvd").read_bytes() == \
        without_line((tmp_path / "full" / "fields.pvd").read_bytes(), gone)
    # the next restart's checkpoint no longer counts it: no warning a second time
    third = tmp_path / "t3.nml"
    third.write_text(text.replace("t_end = 1.0", "t_end = 2.5"))
    res = run(exe_cmd(third, "--restart", part), tmp_path)
    assert res.returncode == EXIT_OK and gone not in res.stderr, res.stderr
    assert gone not in pvd_files(part)


def test_stepper_load_lists_only_the_snapshots_still_there(tmp_path):
    """Stepper.load of a state whose snapshots include one deleted since: fields.pvd lists
    the others, and a DyncontactWarning names the missing file."""
    scene = tmp_path / "s.nml"
    scene.write_text(scene_text("hht", extra=", alpha = -0.1", t_end="1.0", fields=100))
    with Stepper(scene, tmp_path / "b") as b:
        b.advance(200)
        b.save(tmp_path / "state.bin")
        (tmp_path / "b" / "fields" / "step_0000100.vtu").unlink()
        with pytest.warns(DyncontactWarning, match="step_0000100.vtu is missing"):
            assert b.load(tmp_path / "state.bin") == 200
        assert pvd_files(tmp_path / "b") == ["fields/step_0000000.vtu", "fields/step_0000200.vtu"]
        b.advance(10**6)
    listed = pvd_files(tmp_path / "b")
    assert "fields/step_0000100.vtu" not in listed and len(listed) == 4
    assert all((tmp_path / "b" / f).is_file() for f in listed)


@pytest.fixture
def stopped(tmp_path):
    """A run that ended (the folder `part`, its checkpoint at its last step) and its scene."""
    scene = tmp_path / "s.nml"
    scene.write_text(scene_text("hht", extra=", alpha = -0.1", t_end="3.0"))
    assert run(exe_cmd(scene, "--out", "part"), tmp_path).returncode == EXIT_OK
    return scene, tmp_path / "part"


def _flip(path: Path, offset: int) -> None:
    data = bytearray(path.read_bytes())
    data[offset] ^= 0x01
    path.write_bytes(bytes(data))


def _truncate(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[:len(data) - 8])


def _other_build(path: Path) -> None:
    data = bytearray(path.read_bytes())
    data[56:HEADER] = b"0.0.0 x86-64 GCC version 1.0".ljust(96)
    path.write_bytes(bytes(data))


def _bad_magic(path: Path) -> None:
    _flip(path, 0)


def _old_format(path: Path) -> None:
    data = bytearray(path.read_bytes())
    data[8:16] = np.array([FORMAT_VERSION - 1], dtype="<i8").tobytes()
    path.write_bytes(bytes(data))


DAMAGE = {
    "corrupt_payload_byte": (lambda p: _flip(p, HEADER + 1000), "corrupt checkpoint"),
    "corrupt_last_byte": (lambda p: _flip(p, p.stat().st_size - 1), "corrupt checkpoint"),
    "truncated": (_truncate, "truncated"),
    "truncated_to_the_header": (lambda p: p.write_bytes(p.read_bytes()[:HEADER - 1]),
                                "truncated"),
    "empty": (lambda p: p.write_bytes(b""), "truncated"),
    "other_build": (_other_build, "another build"),
    "old_format": (_old_format, f"checkpoint format {FORMAT_VERSION - 1}, this build reads"),
    "not_a_checkpoint": (_bad_magic, "not a dyncontact checkpoint"),
}


@pytest.mark.parametrize("entry", ["exe", "cli"])
@pytest.mark.parametrize("damage", sorted(DAMAGE))
def test_damaged_checkpoint_is_refused_naming_the_file(entry, damage, stopped, tmp_path):
    scene, part = stopped
    harm, words = DAMAGE[damage]
    harm(part / CKPT)
    before = folder_files(part)
    cmd = exe_cmd if entry == "exe" else cli_cmd
    line = refused_line(run(cmd(scene, "--restart", part), tmp_path), part)
    assert words in line, line
    assert folder_files(part) == before       # nothing was used, nothing was written


@pytest.mark.parametrize("entry", ["exe", "cli"])
def test_checkpoint_of_another_scene_is_refused(entry, stopped, tmp_path):
    _scene, part = stopped
    other = tmp_path / "other.nml"
    other.write_text(scene_text("hht", extra=", alpha = -0.1", t_end="3.0", gamma0="20.0"))
    cmd = exe_cmd if entry == "exe" else cli_cmd
    res = run(cmd(other, "--restart", part), tmp_path)
    assert res.returncode == EXIT_BAD_INPUT, res.stderr
    assert f"{part / CKPT}" in res.stderr and "another scene" in res.stderr, res.stderr
    with pytest.raises(dyncontact.BadInputError, match="another scene"):
        dyncontact.run(other, restart=part, progress=False)


@pytest.mark.parametrize("entry", ["exe", "api"])
def test_checkpoint_of_another_dt_or_every_is_refused(entry, stopped, tmp_path):
    """dt (the step taken, carried in the payload) and &output every (the trace's rows,
    in the scene hash) change the run: refused, naming the step or another scene."""
    _scene, part = stopped
    for name, text, words in [
            ("dt.nml", scene_text("hht", extra=", alpha = -0.1", t_end="3.0", dt="0.005"),
             "the step dt = 2.5E-003, this run's is 5.0E-003 (&scheme dt)"),
            ("every.nml", scene_text("hht", extra=", alpha = -0.1", t_end="3.0")
             .replace("&output dir = 'out'", "&output dir = 'out', every = 2"),
             "another scene")]:
        other = tmp_path / name
        other.write_text(text)
        if entry == "exe":
            res = run(exe_cmd(other, "--restart", part), tmp_path)
            assert res.returncode == EXIT_BAD_INPUT and words in res.stderr, res.stderr
        else:
            with pytest.raises(dyncontact.BadInputError, match=re.escape(words)):
                dyncontact.run(other, restart=part, progress=False)


def test_checkpoint_of_the_same_values_with_other_keys_given_is_taken(stopped, tmp_path):
    """Which keys a scene gives is not part of the checkpoint's scene hash: the stopped
    run's scene with beta = 0.25 and the Nitsche theta = 1 written (their defaults, so the
    same numbers) restarts from its checkpoint, the executable's and --set's alike, and
    warns about beta, which hht does not use. Another value is another scene (above)."""
    scene, part = stopped
    trace = (part / "trace.csv").read_bytes()
    other = tmp_path / "given.nml"
    other.write_text(scene_text("hht", extra=", alpha = -0.1, beta = 0.25", t_end="3.0"))
    res = run(exe_cmd(other, "--restart", part), tmp_path)
    assert res.returncode == EXIT_OK, res.stderr
    assert "&scheme beta: not used by scheme 'hht'" in res.stderr, res.stderr
    res = run(cli_cmd(scene, "--set", "scheme.gamma=0.5", "--restart", part), tmp_path)
    assert res.returncode == EXIT_OK, res.stderr
    assert "&scheme gamma: not used by scheme 'hht'" in res.stderr, res.stderr
    assert (part / "trace.csv").read_bytes() == trace


def _move_one_interior_node(msh: Path) -> None:
    """Move the first node of a msh 2.2 ASCII file that lies inside the bar by 1e-3 in x:
    the same nodes, cells and groups, so the same dofs, but another mesh."""
    lines = msh.read_text().splitlines()
    first = lines.index("$Nodes") + 2
    for i in range(first, lines.index("$EndNodes")):
        tag, x, y, z = lines[i].split()
        if 0.0 < float(x) < 0.1 and 0.0 < float(y) < 1.0:
            lines[i] = f"{tag} {float(x) + 1e-3!r} {y} {z}"
            break
    else:
        raise AssertionError("no interior node")
    msh.write_text("\n".join(lines) + "\n")


def _mesh_file_scene(folder: Path) -> Path:
    """folder/s.nml on the mesh file folder/m.msh (the built-in bar's, msh 2.2 ASCII),
    named relatively ('m.msh', from the scene's folder)."""
    made = run([sys.executable, "-m", "dyncontact", "mesh", "--h", "0.05", "--msh-version",
                "2.2", "--out", folder / "m.msh"], folder)
    assert made.returncode == EXIT_OK, made.stderr
    scene = folder / "s.nml"
    scene.write_text(scene_text("hht", extra=", alpha = -0.1", t_end="3.0")
                     .replace("&mesh file = ''", "&mesh file = 'm.msh'")
                     .replace(", width = 0.1, h = 0.05 /", " /"))   # a .msh uses neither
    return scene


@pytest.mark.parametrize("entry", ["exe", "cli"])
def test_checkpoint_of_another_mesh_in_the_same_file_is_refused(entry, tmp_path):
    """The scene names its mesh file, it does not hold it: a mesh file edited between the
    stop and the restart (here one node moved, the same number of dofs) makes another run,
    whose restart from the old state would be neither run. It is refused as another
    scene's checkpoint is; with the mesh put back the restart goes on."""
    scene = _mesh_file_scene(tmp_path)
    msh = tmp_path / "m.msh"
    assert run(exe_cmd(scene, "--out", "part"), tmp_path).returncode == EXIT_OK
    original = msh.read_bytes()
    _move_one_interior_node(msh)
    cmd = exe_cmd if entry == "exe" else cli_cmd
    res = run(cmd(scene, "--restart", "part"), tmp_path)
    assert res.returncode == EXIT_BAD_INPUT, res.stderr
    assert f"part/{CKPT}" in res.stderr and "another scene or mesh" in res.stderr, res.stderr
    msh.write_bytes(original)
    res = run(cmd(scene, "--restart", "part"), tmp_path)
    assert res.returncode == EXIT_OK, res.stderr


def test_scene_object_restarts_the_checkpoint_of_its_scene_file(tmp_path):
    """dyncontact.run(Scene.read(f), restart=DIR) continues a run the executable made of
    the scene file f, and the other way round: the Scene's copy names the mesh file by its
    absolute path where the executable, given f relatively, has 'm.msh', which made the
    scene's hash differ ("written by another scene") though the mesh, hashed itself, is
    the same. The results are the run never stopped's (summary.json but for the spelling
    of the mesh file's name)."""
    scene = _mesh_file_scene(tmp_path)
    rel = Path(scene.name)                   # as a user types it, in its folder

    def numbers(folder: Path) -> dict:
        s = summary_numbers(folder)
        s["scene"]["mesh"].pop("file")
        return s

    assert run(exe_cmd(rel, "--out", "whole"), tmp_path).returncode == EXIT_OK
    for first, then in (("exe", "api"), ("api", "exe")):
        part = tmp_path / f"{first}_then_{then}"
        # the first part ends at t = 2.25 (its checkpoint at its last step, 900), so that
        # the restart with the whole scene does steps of its own
        if first == "exe":
            (tmp_path / "short.nml").write_text(scene.read_text().replace("t_end = 3.0",
                                                                          "t_end = 2.25"))
            res = run(exe_cmd(Path("short.nml"), "--out", part.name), tmp_path)
            assert res.returncode == EXIT_OK, res.stderr
        else:
            short_scene = dyncontact.Scene.read(scene)
            short_scene.set("scheme.t_end", 2.25)
            dyncontact.run(short_scene, out=part, progress=False)
        assert checkpoint_step(part / CKPT) == 900       # 1200 steps, EVERY = 300
        if then == "api":
            res = dyncontact.run(dyncontact.Scene.read(scene), restart=part, progress=False)
            assert res.status == "ok"
        else:
            res = run(exe_cmd(rel, "--restart", part.name), tmp_path)
            assert res.returncode == EXIT_OK, res.stderr
        what = f"{first} then {then}"
        whole = tmp_path / "whole"
        assert (part / "trace.csv").read_bytes() == (whole / "trace.csv").read_bytes(), what
        assert numbers(part) == numbers(whole), what


@pytest.mark.parametrize("entry", ["exe", "cli"])
def test_missing_restart_folder_is_refused_naming_the_folder(entry, stopped, tmp_path):
    scene, _part = stopped
    cmd = exe_cmd if entry == "exe" else cli_cmd
    res = run(cmd(scene, "--restart", "nowhere"), tmp_path)
    assert res.returncode == EXIT_BAD_INPUT, res.stderr
    assert res.stderr == ("dyncontact: nowhere: no such folder (a restart continues a "
                          "stopped run in its output folder)\n"), res.stderr
    assert "Traceback" not in res.stderr
    assert not (tmp_path / "nowhere").exists()


def test_restart_with_another_out_folder_is_refused(stopped, tmp_path):
    scene, part = stopped
    res = run(exe_cmd(scene, "--restart", part, "--out", tmp_path / "elsewhere"), tmp_path)
    assert res.returncode == EXIT_BAD_INPUT and "--out" in res.stderr, res.stderr
    with pytest.raises(dyncontact.BadInputError, match="out must be"):
        dyncontact.run(scene, out=tmp_path / "elsewhere", restart=part, progress=False)


def test_restart_with_another_out_folder_is_said_in_options_on_the_command_line(tmp_path):
    """The Python CLI refuses --out B --restart A in the executable's words, of its
    options (--restart, --out, left out), not in run()'s (restart=, out=, None)."""
    scene = tmp_path / "s.nml"
    scene.write_text(scene_text("hht", t_end="1.0"))
    said = []
    for cmd in (exe_cmd, cli_cmd):
        res = run(cmd(Path("s.nml"), "--restart", "part", "--out", "elsewhere"), tmp_path)
        assert res.returncode == EXIT_BAD_INPUT, res.stderr
        said.append(res.stderr.strip().split(": ", 1)[1])
    assert said[1] == said[0] == ("--restart part continues the run in that folder: --out "
                                  "must be the same folder or left out"), said
    assert not (tmp_path / "elsewhere").exists() and not (tmp_path / "part").exists()


@pytest.mark.parametrize("entry,spelling", [
    (e, s) for e in ("exe", "cli") for s in ("part/", "./part", "absolute", "link")])
def test_restart_with_out_naming_the_same_folder_otherwise(entry, spelling, stopped, tmp_path):
    """--out may name the --restart folder in another spelling: a trailing slash, ./,
    its absolute path, a symbolic link to it (the same folder, not the same text)."""
    scene, part = stopped
    (tmp_path / "link").symlink_to(part)
    out = {"absolute": str(part), "link": "link"}.get(spelling, spelling)
    cmd = exe_cmd if entry == "exe" else cli_cmd
    res = run(cmd(scene, "--restart", "part", "--out", out), tmp_path)
    assert res.returncode == EXIT_OK, res.stderr
    assert json.loads((part / "summary.json").read_text())["status"] == "ok"


def test_restart_refuses_a_trace_shorter_than_the_checkpoint(stopped, tmp_path):
    scene, part = stopped
    (part / "trace.csv").write_text("t,u_n\n")
    res = run(exe_cmd(scene, "--restart", part), tmp_path)
    assert res.returncode == EXIT_BAD_INPUT, res.stderr
    assert "trace.csv" in res.stderr and "shorter" in res.stderr, res.stderr


def test_checkpoint_every_zero_writes_none(tmp_path):
    scene = tmp_path / "s.nml"
    scene.write_text(scene_text("hht", t_end="1.0", every=0))
    assert run(exe_cmd(scene, "--out", "o"), tmp_path).returncode == EXIT_OK
    assert not (tmp_path / "o" / CKPT).exists()
    assert not list((tmp_path / "o").glob("*.tmp"))


def test_checkpoint_file_holds_the_state_it_stands_for(tmp_path):
    """The format of docs/scenes.md, read independently: the header's dofs and step, the
    payload's checksum (64-bit FNV-1a), and the state vectors equal to the run's own."""
    scene = tmp_path / "s.nml"
    scene.write_text(scene_text("hht", extra=", alpha = -0.1"))
    with Stepper(scene, tmp_path / "o") as s:
        s.advance(123)
        s.save(tmp_path / "c.bin")
        st = s.state()
        dofs = s.dofs
    data = (tmp_path / "c.bin").read_bytes()
    assert data[:8] == b"DYNCKPT\0"
    version, _hash, plen, checksum, n, step = np.frombuffer(data[8:56], dtype="<i8")
    assert (version, n, step) == (FORMAT_VERSION, dofs, 123)
    payload = data[HEADER:]
    assert plen == len(payload)
    h = 0xcbf29ce484222325
    for byte in payload:
        h = ((h ^ byte) * 0x100000001b3) & 0xFFFFFFFFFFFFFFFF
    assert np.int64(np.uint64(h)) == checksum
    ints = np.frombuffer(payload[:56], dtype="<i8")
    reals = np.frombuffer(payload[:56], dtype="<f8")
    assert ints[0] == 123 and reals[1] == st["t"] and reals[2] == 0.0025   # step, t, dt
    pos = 56
    for key in ("u", "v", "a", "mv", "bu"):
        count = int(np.frombuffer(payload[pos:pos + 8], dtype="<i8")[0])
        assert count == dofs
        vec = np.frombuffer(payload[pos + 8:pos + 8 + 8 * count], dtype="<f8")
        assert np.array_equal(vec, st[key]), key
        pos += 8 + 8 * count


@pytest.mark.parametrize("entry", ["exe", "cli"])
def test_a_restart_without_a_checkpoint_says_why(entry, tmp_path):
    """A run killed before its first checkpoint, restarted with its scene, which gives
    checkpoint_every: the refusal says that a run stopped before the first checkpoint
    starts again without --restart (`&output checkpoint_every writes one` alone would not
    help a scene that gives it). A folder that is not there is said missing:
    test_missing_restart_folder_is_refused_naming_the_folder."""
    cmd = exe_cmd if entry == "exe" else cli_cmd
    scene = tmp_path / "s.nml"
    scene.write_text(scene_text("newmark", t_end="1.5", every=200))
    (tmp_path / "o").mkdir()        # what a run killed before its first checkpoint leaves
    (tmp_path / "o" / "trace.csv").write_text("t\n")
    line = refused_line(run(cmd(scene, "--restart", tmp_path / "o"), tmp_path), tmp_path / "o")
    assert line.endswith("no checkpoint to restart from (no such file; &output "
                         "checkpoint_every = 200 writes the first at that step: a run "
                         "stopped before it starts again without --restart)"), line
    plain = tmp_path / "plain.nml"
    plain.write_text(scene_text("newmark", t_end="1.5", every=0))
    line = refused_line(run(cmd(plain, "--restart", tmp_path / "o"), tmp_path), tmp_path / "o")
    assert line.endswith("(no such file; &output checkpoint_every writes one)"), line


@pytest.mark.parametrize("entry", ["exe", "cli"])
def test_a_new_run_removes_an_earlier_runs_checkpoint(entry, tmp_path):
    """A run (not a restart) into a folder where another run left its checkpoint removes
    it once its own trace is there: `--restart` then finds no checkpoint, and never one
    whose trace is gone (the earlier run's checkpoint at step 600 against a new trace of
    200 steps was refused as a truncated trace, naming trace.csv, not the stale file).
    A new run that does not start (bad input) leaves the earlier run's results whole."""
    cmd = exe_cmd if entry == "exe" else cli_cmd
    first = tmp_path / "first.nml"
    first.write_text(scene_text("newmark", t_end="1.5"))
    assert run(cmd(first, "--out", tmp_path / "o"), tmp_path).returncode == EXIT_OK
    assert checkpoint_step(tmp_path / "o" / CKPT) == 600
    kept = (tmp_path / "o" / CKPT).read_bytes()
    bad = tmp_path / "bad.nml"
    bad.write_text(scene_text("newmark", t_end="0.5", gamma0="-1.0", every=0))
    assert run(cmd(bad, "--out", tmp_path / "o"), tmp_path).returncode == EXIT_BAD_INPUT
    assert (tmp_path / "o" / CKPT).read_bytes() == kept
    second = tmp_path / "second.nml"
    second.write_text(scene_text("newmark", t_end="0.5", every=0))
    assert run(cmd(second, "--out", tmp_path / "o"), tmp_path).returncode == EXIT_OK
    assert not (tmp_path / "o" / CKPT).exists()
    assert not (tmp_path / "o" / f"{CKPT}.tmp").exists()
    line = refused_line(run(cmd(second, "--restart", tmp_path / "o"), tmp_path),
                        tmp_path / "o")
    assert "no checkpoint to restart from" in line, line
