"""dyncontact.run and the CLI around it, driven by a fake `_core` (no Fortran numerics):
chunked advancing, progress, status codes, handles always closed."""

from __future__ import annotations

import json
import os
import types

import numpy as np
import pytest

import dyncontact
from dyncontact import cli, core

HEADER = ",".join(core.TRACE_COLUMNS)


class FakeCore:
    """Mimics the flat API of fortran/app/api.f90 as f2py exposes it."""

    def __init__(self, n_steps=1000, fail_at=None, fail_stat=3, open_stat=0, stall=False):
        self.n_steps, self.fail_at, self.fail_stat = n_steps, fail_at, fail_stat
        self.open_stat, self.stall = open_stat, stall
        self.calls = []
        self.open_handles = set()
        self.out_dir = None

    def dc_version(self):
        return b"0.1.0" + b" " * 27

    def __getattr__(self, name):
        # anything not faked (dc_scene_text: dyncontact.Scene edits through the reader)
        # is the real core's, but for the calls on a run's handle: the real core given
        # the fake handle would read memory that is not a run (a crash, not a failure)
        if name.startswith("dc_sim_"):
            raise AttributeError(f"FakeCore fakes no {name}")
        from dyncontact import _core

        return getattr(_core, name)

    def dc_sim_lines(self, handle, scene_said, out_said):
        assert handle in self.open_handles
        return b"", (os.fsdecode(scene_said) + ": 10 dofs -> " + os.fsdecode(out_said)).encode()

    def dc_sim_stopped_by(self, handle, head):
        assert handle in self.open_handles
        self.calls.append(("stopped_by", os.fsdecode(head)))

    def dc_scene_dump(self, path, json_path):
        from dyncontact import _core   # the real reader, with another output folder

        given, stat, errmsg = _core.dc_scene_dump(path, json_path)
        with open(os.fsdecode(json_path)) as f:
            scene = json.load(f)
        scene["output"]["dir"] = "fake_out"
        with open(os.fsdecode(json_path), "w") as f:
            json.dump(scene, f)
        return given, stat, errmsg

    def dc_sim_open(self, path, out_dir, build_only, out_said=b""):
        self.calls.append(("open", os.fsdecode(path), os.fsdecode(out_dir), build_only))
        if self.open_stat:
            return 0, 0, 0, 0, 0, self.open_stat, b"scene.nml: &scheme dt: must be > 0   "
        self.out_dir, self.step = os.fsdecode(out_dir), 0
        out_dir = self.out_dir
        os.makedirs(out_dir, exist_ok=True)
        with open(os.path.join(out_dir, "trace.csv"), "w") as f:
            f.write(HEADER + "\n" + ",".join(["0"] * len(core.TRACE_COLUMNS)) + "\n")
        self.open_handles.add(42)
        return 42, self.n_steps, 10, 4, 2, 0, b""

    def dc_sim_info(self, handle):
        assert handle in self.open_handles
        return self.n_steps, 257 * self.n_steps, b" " * 4096

    def dc_sim_advance(self, handle, max_steps):
        assert handle in self.open_handles
        self.calls.append(("advance", max_steps))
        if self.stall:
            return 0, self.step, 0, 0, b""
        todo = min(max_steps, self.n_steps - self.step)
        stat, msg = 0, b""
        if self.fail_at is not None and self.step + todo >= self.fail_at:
            todo, stat = self.fail_at - self.step, self.fail_stat
            msg = b"unstable: e_total = 1.2e+03 > blowup * e_total(0) at t = 1.5"
        with open(os.path.join(self.out_dir, "trace.csv"), "a") as f:
            for k in range(self.step + 1, self.step + todo + 1):
                f.write(",".join([f"{k * 0.01:.6e}"] + ["0"] * (len(core.TRACE_COLUMNS) - 1)) + "\n")
        self.step += todo
        finished = int(self.step >= self.n_steps or stat != 0)
        return todo, self.step, finished, stat, msg

    def dc_sim_close(self, handle):
        self.calls.append(("close", handle))
        self.open_handles.discard(handle)
        status = "ok" if self.step >= self.n_steps else (
            "unstable" if self.fail_stat == 3 else "failed")
        with open(os.path.join(self.out_dir, "summary.json"), "w") as f:
            json.dump({"status": status, "steps": self.step,
                       "t_end_reached": self.step * 0.01}, f)
        return 0, b""


@pytest.fixture
def fake(monkeypatch):
    holder = {}

    def install(**kw):
        fc = FakeCore(**kw)
        monkeypatch.setattr(core, "_core", lambda: fc)
        holder["fc"] = fc
        return fc

    return install


@pytest.fixture
def scene_file(tmp_path):
    p = tmp_path / "s.nml"
    p.write_text("&scheme dt = 0.01 /\n")
    return p


def test_run_ok_in_chunks(fake, scene_file, tmp_path, monkeypatch):
    fc = fake(n_steps=45_000)
    monkeypatch.setattr(core, "CHUNK_S", 1e9)     # the largest chunks, whatever the load
    seen = []
    res = dyncontact.run(scene_file, out=tmp_path / "o", progress=False,
                         callback=lambda step, n: seen.append(step))
    assert res.ok and res.status == "ok" and res.message == ""
    advances = [c for c in fc.calls if c[0] == "advance"]
    # one step first, then chunks of about core.CHUNK_S, at most n_steps // 200 (the
    # fake's steps take no time)
    assert advances[0][1] == 1 and {c[1] for c in advances[1:]} == {45_000 // 200}
    assert seen[-1] == 45_000 and len(seen) == len(advances)
    assert fc.calls[0] == ("open", str(scene_file), str(tmp_path / "o"), 0)
    assert fc.calls[-1][0] == "close" and not fc.open_handles
    assert res.trace["t"].shape == (45_001,) and res.trace["t"].dtype == np.float64
    assert list(res.trace) == list(core.TRACE_COLUMNS)
    assert res.summary["steps"] == 45_000
    assert res.out_dir == str(tmp_path / "o")


def test_small_runs_use_chunks_of_100(fake, scene_file, tmp_path, monkeypatch):
    fc = fake(n_steps=250)
    monkeypatch.setattr(core, "CHUNK_S", 1e9)
    dyncontact.run(scene_file, out=tmp_path / "o", progress=False)
    assert [c[1] for c in fc.calls if c[0] == "advance"] == [1, 100, 100, 100]


def test_chunks_follow_the_time_of_a_step(fake, scene_file, tmp_path, monkeypatch):
    """Steps of 0.125 s (a mesh of 10^5 dofs; times exact in binary): chunks of
    CHUNK_S = 0.5 s, 4 steps, so Ctrl-C (between two chunks) waits about 0.5 s, not the
    100 steps (12.5 s) of a fixed chunk; when the steps get slower (0.25 s: contact), the
    chunks get shorter."""
    fc = fake(n_steps=40)
    clock = [0.0]
    advance = fc.dc_sim_advance

    def timed_advance(handle, max_steps):
        before = fc.step
        out = advance(handle, max_steps)
        clock[0] += (0.125 if fc.step <= 20 else 0.25) * (fc.step - before)
        return out

    monkeypatch.setattr(fc, "dc_sim_advance", timed_advance)
    monkeypatch.setattr(core, "time", types.SimpleNamespace(perf_counter=lambda: clock[0]))
    monkeypatch.setattr(core, "CHUNK_S", 0.5)
    res = dyncontact.run(scene_file, out=tmp_path / "o", progress=False)
    assert res.ok
    chunks = [c[1] for c in fc.calls if c[0] == "advance"]
    assert chunks[:6] == [1, 4, 4, 4, 4, 4] and chunks[6] == 2, chunks
    assert sum(chunks[:-1]) < 40 <= sum(chunks)


def test_default_out_dir_comes_from_the_scene(fake, scene_file, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    fc = fake(n_steps=10)
    res = dyncontact.run(str(scene_file), progress=False)
    assert res.out_dir == str(tmp_path / "fake_out")
    assert fc.calls[0][2] == "fake_out"    # as given: summary.json records it so


def test_unstable_returns_result_and_cli_exits_3(fake, scene_file, tmp_path, capsys):
    fc = fake(n_steps=1000, fail_at=150)
    res = dyncontact.run(scene_file, out=tmp_path / "o", progress=False)
    assert res.status == "unstable" and not res.ok
    assert "unstable" in res.message
    assert res.trace["t"].shape == (151,)
    assert not fc.open_handles
    rc = cli.main(["run", str(scene_file), "--out", str(tmp_path / "o2"), "--quiet"])
    assert rc == 3
    err = capsys.readouterr().err.strip().splitlines()
    # the core's message as it is, as the executable prints it (no second status and t)
    assert err == ["dyncontact: unstable: e_total = 1.2e+03 > blowup * e_total(0) at t = 1.5"]


def test_bad_input_at_open(fake, scene_file, tmp_path, capsys):
    fc = fake(open_stat=2)
    with pytest.raises(dyncontact.BadInputError, match="&scheme dt"):
        dyncontact.run(scene_file, out=tmp_path / "o", progress=False)
    assert not any(c[0] == "close" for c in fc.calls)
    assert cli.main(["run", str(scene_file), "--out", str(tmp_path / "o")]) == 2
    assert capsys.readouterr().err == "dyncontact: scene.nml: &scheme dt: must be > 0\n"


def test_internal_error_while_advancing_closes_the_handle(fake, scene_file, tmp_path,
                                                         capsys):
    fc = fake(n_steps=1000, fail_at=300, fail_stat=4)
    with pytest.raises(dyncontact.DyncontactError) as info:
        dyncontact.run(scene_file, out=tmp_path / "o", progress=False)
    assert not isinstance(info.value, dyncontact.BadInputError)
    assert not fc.open_handles
    assert cli.main(["run", str(scene_file), "--out", str(tmp_path / "o")]) == 4
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


def test_no_progress_is_an_error_not_a_hang(fake, scene_file, tmp_path):
    fc = fake(stall=True)
    with pytest.raises(dyncontact.DyncontactError, match="no progress"):
        dyncontact.run(scene_file, out=tmp_path / "o", progress=False)
    assert not fc.open_handles


def test_ctrl_c_closes_the_handle_and_exits_130(fake, scene_file, tmp_path, capsys):
    fc = fake(n_steps=1000)

    def interrupt(step, n):
        if step >= 200:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        dyncontact.run(scene_file, out=tmp_path / "o", progress=False, callback=interrupt)
    assert not fc.open_handles
    assert (tmp_path / "o" / "summary.json").is_file()

    real_run = core.run
    try:
        core.run = lambda *a, **k: real_run(*a, **k, callback=interrupt)
        rc = cli.main(["run", str(scene_file), "--out", str(tmp_path / "o2"), "--quiet"])
    finally:
        core.run = real_run
    assert rc == 130
    assert capsys.readouterr().err == "dyncontact: interrupted\n"
    assert not fc.open_handles


def test_progress_bar_when_forced(fake, scene_file, tmp_path, capsys):
    fake(n_steps=300)
    dyncontact.run(scene_file, out=tmp_path / "o", progress=True)
    err = capsys.readouterr().err
    assert "300" in err            # tqdm's total, on stderr


def test_scene_object_is_written_to_a_temporary_file(fake, tmp_path, monkeypatch):
    pytest.importorskip("dyncontact.scene")
    monkeypatch.chdir(tmp_path)
    fc = fake(n_steps=10)
    scn = dyncontact.Scene()
    scn.set("scheme.dt", "0.001")
    scn.set("output.dir", "rel_out")
    res = dyncontact.run(scn, progress=False)
    path = fc.calls[0][1]
    assert path != "" and not os.path.exists(path)      # temporary, removed afterwards
    assert res.out_dir == str(tmp_path / "rel_out")


def test_cli_set_goes_through_the_scene(fake, scene_file, tmp_path, capsys):
    pytest.importorskip("dyncontact.scene")
    fc = fake(n_steps=10)
    seen = {}
    orig_open = fc.dc_sim_open

    def spy_open(path, out_dir, build_only, out_said):
        seen["text"] = open(path).read()
        return orig_open(path, out_dir, build_only, out_said)

    fc.dc_sim_open = spy_open
    rc = cli.main(["run", str(scene_file), "--set", "scheme.dt=0.004",
                   "--set", "scheme.name=pc", "--out", str(tmp_path / "o")])
    assert rc == 0, capsys.readouterr().err
    text = seen["text"].lower()
    assert "0.004" in text and "'pc'" in text
    assert "dyncontact: ok, 10 steps" in capsys.readouterr().out
