"""A run stopped by a numerical failure (exit 3) with &output fields_every > 0 ends with a
VTU snapshot of the state it stopped at, listed last in fields.pvd: after a blow-up the
step that failed the test (the trace's last row), after a Newton failure the last step
accepted. The snapshot is the one a run that ends there writes, byte for byte; a restart
from the failed run's checkpoint removes it and gives the fields of the run made straight
with the restarting scene; the size check before the run counts it (the count stays
exact); a Stepper writes it as the executable does and removes it when it loads an
earlier state."""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import meshio
import pytest

from conftest import ROOT
from dyncontact.core import NumericalError, Stepper
from dyncontact.plotting import read_pvd
from test_restart import (CKPT, EXIT_NUMERIC, EXIT_OK, assert_same_results, checkpoint_step,
                          exe_cmd, restart_with, run, scene_text)

DT = 0.0025
FIELDS_EVERY = 7
#: newmark on the built-in bar with blowup = 1.001: e_total exceeds the limit in a contact
#: at t = 1.34 (step 536, off the grid of 7), after the checkpoint of step 300.
BLOWUP = scene_text("newmark", t_end="3.0", extra=", blowup = 1.001", fields=FIELDS_EVERY)
#: the same run with newton_maxit = 1: Newton fails at the first step in contact.
NEWTON = scene_text("newmark", t_end="3.0", extra=", newton_maxit = 1", fields=FIELDS_EVERY)


def write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def snapshot_steps(folder: Path) -> list[int]:
    return sorted(int(p.name[5:-4]) for p in (folder / "fields").glob("step_*.vtu"))


def listed(folder: Path) -> list[tuple[float, int]]:
    return [(t, int(Path(f).name[5:-4])) for t, f in read_pvd(folder / "fields.pvd")]


def vtu(folder: Path, step: int) -> Path:
    return folder / "fields" / f"step_{step:07d}.vtu"


def steps_done(folder: Path) -> int:
    return json.loads((folder / "summary.json").read_text())["steps"]


def grid(below: int) -> list[int]:
    """The steps of the snapshots' grid before step `below`."""
    return list(range(0, below, FIELDS_EVERY))


def test_a_blow_up_ends_with_a_snapshot_of_the_step_that_failed(tmp_path):
    scene = write(tmp_path, "low.nml", BLOWUP)
    res = run(exe_cmd(scene, "--out", "part"), tmp_path)
    assert res.returncode == EXIT_NUMERIC and "unstable at t = 1.3" in res.stderr, res.stderr
    part = tmp_path / "part"
    failed = steps_done(part)
    assert failed % FIELDS_EVERY != 0
    assert snapshot_steps(part) == grid(failed) + [failed], "no snapshot of the failed step"
    trace_t = float((part / "trace.csv").read_text().splitlines()[-1].split(",")[0])
    assert listed(part)[-1] == (trace_t, failed)
    assert [s for _, s in listed(part)] == snapshot_steps(part)
    # the state the run that ends at that step (blowup high enough) writes last
    ends = write(tmp_path, "ends.nml", BLOWUP.replace("t_end = 3.0", f"t_end = {failed * DT!r}")
                 .replace("blowup = 1.001", "blowup = 10.0"))
    assert run(exe_cmd(ends, "--out", "ends"), tmp_path).returncode == EXIT_OK
    assert vtu(part, failed).read_bytes() == vtu(tmp_path / "ends", failed).read_bytes()


def test_a_newton_failure_ends_with_a_snapshot_of_the_last_step_accepted(tmp_path):
    scene = write(tmp_path, "s.nml", NEWTON)
    res = run(exe_cmd(scene, "--out", "part"), tmp_path)
    assert res.returncode == EXIT_NUMERIC and "Newton did not converge" in res.stderr, res.stderr
    part = tmp_path / "part"
    accepted = steps_done(part)
    assert accepted % FIELDS_EVERY != 0
    assert snapshot_steps(part) == grid(accepted + 1) + [accepted]
    assert listed(part)[-1] == (pytest.approx(accepted * DT, rel=1e-12), accepted)
    ends = write(tmp_path, "ends.nml", NEWTON.replace("t_end = 3.0", f"t_end = {accepted * DT!r}"))
    assert run(exe_cmd(ends, "--out", "ends"), tmp_path).returncode == EXIT_OK
    assert vtu(part, accepted).read_bytes() == vtu(tmp_path / "ends", accepted).read_bytes()


def test_a_newton_failure_on_the_grid_writes_no_second_snapshot(tmp_path):
    """The last step accepted has its snapshot already (fields_every divides it): the list
    is the grid's, each step once."""
    scene = write(tmp_path, "s.nml", NEWTON)
    assert run(exe_cmd(scene, "--out", "probe"), tmp_path).returncode == EXIT_NUMERIC
    accepted = steps_done(tmp_path / "probe")
    every = next(k for k in range(2, accepted) if accepted % k == 0)
    scene = write(tmp_path, "g.nml", NEWTON.replace(f"fields_every = {FIELDS_EVERY}",
                                                    f"fields_every = {every}"))
    assert run(exe_cmd(scene, "--out", "g"), tmp_path).returncode == EXIT_NUMERIC
    expected = list(range(0, accepted + 1, every))
    assert snapshot_steps(tmp_path / "g") == [s for _, s in listed(tmp_path / "g")] == expected


@pytest.mark.parametrize("entry", ["exe", "api"])
def test_a_restart_with_a_raised_blowup_removes_the_failure_snapshot(entry, tmp_path):
    """Restarted from the checkpoint of step 300 with blowup = 10: the fields and
    fields.pvd of the run made with blowup = 10 throughout; the failure snapshot (and a
    .vtu.tmp of it a kill would leave) is gone."""
    low = write(tmp_path, "low.nml", BLOWUP)
    high = write(tmp_path, "high.nml", BLOWUP.replace("blowup = 1.001", "blowup = 10.0"))
    assert run(exe_cmd(high, "--out", "full"), tmp_path).returncode == EXIT_OK
    assert run(exe_cmd(low, "--out", "part"), tmp_path).returncode == EXIT_NUMERIC
    part = tmp_path / "part"
    failed = steps_done(part)
    assert vtu(part, failed).is_file() and checkpoint_step(part / CKPT) == 300
    tmp = part / "fields" / f"step_{failed:07d}.vtu.tmp"
    tmp.write_text("x")
    restart_with(entry, high, part, tmp_path)
    assert not tmp.exists()
    assert_same_results(part, tmp_path / "full", f"raised blowup, {entry}")


def test_a_restart_from_a_checkpoint_at_the_failure_snapshot_gives_the_straight_run(tmp_path):
    """Newton fails right after the checkpoint of the last step accepted, off the
    snapshots' grid: the failure snapshot is at the checkpoint's step, not in its list.
    The restart (the same scene, failing again) removes it and writes it again: the
    folder of the run made straight."""
    probe = write(tmp_path, "p.nml", NEWTON)
    assert run(exe_cmd(probe, "--out", "probe"), tmp_path).returncode == EXIT_NUMERIC
    accepted = steps_done(tmp_path / "probe")
    scene = write(tmp_path, "s.nml", NEWTON.replace("checkpoint_every = 300",
                                                    f"checkpoint_every = {accepted}"))
    assert run(exe_cmd(scene, "--out", "full"), tmp_path).returncode == EXIT_NUMERIC
    assert run(exe_cmd(scene, "--out", "part"), tmp_path).returncode == EXIT_NUMERIC
    part = tmp_path / "part"
    assert checkpoint_step(part / CKPT) == accepted and vtu(part, accepted).is_file()
    vtu(part, accepted).write_text("stale")         # the restart writes its own
    res = run(exe_cmd(scene, "--restart", "part"), tmp_path)
    assert res.returncode == EXIT_NUMERIC, res.stderr
    assert_same_results(part, tmp_path / "full", "restart at the failure snapshot's step")


def test_a_stepper_writes_the_failure_snapshot_and_removes_it_on_load(tmp_path):
    scene = write(tmp_path, "low.nml", BLOWUP)
    assert run(exe_cmd(scene, "--out", "exe"), tmp_path).returncode == EXIT_NUMERIC
    failed = steps_done(tmp_path / "exe")
    out = tmp_path / "st"
    with Stepper(scene, out) as st:
        st.advance(300)
        st.save(tmp_path / "at300.bin")
        with pytest.raises(NumericalError, match="unstable"):
            st.advance(10_000)
        assert vtu(out, failed).read_bytes() == vtu(tmp_path / "exe", failed).read_bytes()
        assert st.load(tmp_path / "at300.bin") == 300
        assert snapshot_steps(out) == grid(301)
        assert [s for _, s in listed(out)] == grid(301)
        with pytest.raises(NumericalError, match="unstable"):
            st.advance(10_000)
    assert snapshot_steps(out) == snapshot_steps(tmp_path / "exe")
    assert (out / "fields.pvd").read_bytes() == (tmp_path / "exe" / "fields.pvd").read_bytes()


def test_the_size_check_counts_the_failure_snapshot(tmpfs, tmp_path):
    """A run that blows up at its last step, off the grid, writes as many snapshots as the
    check before the run counts for it (the grid's and the end's): exact, not one short."""
    probe = write(tmp_path, "p.nml", BLOWUP)
    assert run(exe_cmd(probe, "--out", "probe"), tmp_path).returncode == EXIT_NUMERIC
    failed = steps_done(tmp_path / "probe")
    scene = write(tmp_path, "s.nml", BLOWUP.replace("t_end = 3.0", f"t_end = {failed * DT!r}"))
    res = run(exe_cmd(scene, "--out", tmpfs("size=256k") / "o"), tmp_path)
    assert res.returncode == 2, res.stderr
    counted = len(grid(failed)) + 1
    assert f"{counted} snapshots of" in res.stderr, res.stderr
    res = run(exe_cmd(scene, "--out", "o"), tmp_path)
    assert res.returncode == EXIT_NUMERIC and steps_done(tmp_path / "o") == failed, res.stderr
    assert len(snapshot_steps(tmp_path / "o")) == counted


def test_a_snapshot_of_a_run_whose_energy_overflowed_is_readable(run_cli, tmp_path):
    """The seed's bar thrown at 1e154: the largest initial velocity whose energy is
    finite (a larger one is refused as bad input), so the run stops as unstable when
    e_total overflows to Infinity. The failure snapshot holds that state (displacements
    of order 1e150); it is well-formed XML whose numbers parse as floats, and meshio (the
    reader of dyncontact.plotting) reads the same values."""
    scene = ROOT / "scripts" / "scenes" / "bar2d_hht.nml"
    res = run_cli("run", scene, "--out", "out", "-q", "--set", "initial.kind=velocity",
                  "--set", "initial.velocity=0,-1e154", "--set", "initial.amplitude=0",
                  "--set", "scheme.t_end=1", "--set", "output.fields_every=50")
    assert res.returncode == EXIT_NUMERIC and "e_total = Infinity" in res.stderr, res.stderr
    out = tmp_path / "out"
    failed = steps_done(out)
    assert failed % 50 != 0 and snapshot_steps(out) == [*range(0, failed, 50), failed]
    path = vtu(out, failed)
    values = []
    for array in ET.parse(path).getroot().iter("DataArray"):
        if array.get("type") == "Float64":
            values += [float(word) for word in array.text.split()]
    assert max(abs(v) for v in values if math.isfinite(v)) > 1e150
    mesh = meshio.read(path)
    n = len(mesh.points)
    assert mesh.point_data["displacement"].shape == (n, 3)
    read = [*mesh.points.ravel(), *mesh.point_data["displacement"].ravel(),
            *mesh.point_data["velocity"].ravel()]
    assert sorted(repr(float(v)) for v in read) == sorted(map(repr, values))


def test_an_interrupted_run_writes_no_snapshot_of_the_step_it_stopped_on(tmp_path):
    """Ctrl-C (here from the progress callback) is no numerical failure: the snapshots are
    the grid's up to the step it stopped on, and its restart gives the run made straight."""
    import dyncontact

    scene = write(tmp_path, "s.nml", BLOWUP.replace("blowup = 1.001", "blowup = 10.0"))
    assert run(exe_cmd(scene, "--out", "full"), tmp_path).returncode == EXIT_OK

    def stop(step, n_steps):
        if step >= 100 and step % FIELDS_EVERY != 0:
            raise KeyboardInterrupt

    part = tmp_path / "part"
    with pytest.raises(KeyboardInterrupt):
        dyncontact.run(scene, out=part, progress=False, callback=stop)
    stopped = steps_done(part)
    assert stopped % FIELDS_EVERY != 0 and checkpoint_step(part / CKPT) == stopped
    assert snapshot_steps(part) == [s for _, s in listed(part)] == grid(stopped)
    restart_with("exe", scene, part, tmp_path)
    assert_same_results(part, tmp_path / "full", "interrupted, then restarted")


@pytest.mark.parametrize("scheme, contact", [
    ("newmark", "theta = 1"), ("hht", "theta = 0"), ("theta", "theta = -1"),
    ("newmark", "method = 'penalty'"), ("newmark", "method = 'alm', multiplier = 'integral'"),
    ("hht", "method = 'alm', multiplier = 'nodal'")])
def test_a_newton_failure_ends_the_trace_at_the_last_step_accepted(scheme, contact, tmp_path):
    """With &output every = 7, the last step accepted before a Newton failure (off the
    rows' grid) gets its row, as the run's last: the same line, byte for byte, as the end
    row of the run whose t_end is that step (the failed step's iterations leave no trace
    in the state the row reads: u, v, their products, the contact state and the
    multipliers, the Newton count)."""
    rows = "&output dir = 'out', every = 7,"
    text = scene_text(scheme, t_end="3.0", extra=", newton_maxit = 1", contact=contact).replace(
        "&output dir = 'out',", rows)
    scene = write(tmp_path, "s.nml", text)
    res = run(exe_cmd(scene, "--out", "part"), tmp_path)
    assert res.returncode == EXIT_NUMERIC and "did not converge" in res.stderr, res.stderr
    part = tmp_path / "part"
    accepted = steps_done(part)
    assert accepted % 7 != 0
    last = (part / "trace.csv").read_text().splitlines()[-1]
    assert float(last.split(",")[0]) == pytest.approx(accepted * DT, rel=1e-12)
    ends = write(tmp_path, "ends.nml", text.replace("t_end = 3.0", f"t_end = {accepted * DT!r}"))
    assert run(exe_cmd(ends, "--out", "ends"), tmp_path).returncode == EXIT_OK
    assert last == (tmp_path / "ends" / "trace.csv").read_text().splitlines()[-1]
