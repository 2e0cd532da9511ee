"""The work-precision study's finest filtered 2D reference level is shipped with the
package (python/dyncontact/study/data/), not run by the study: these tests check that the
file is the level the study would run (the scene the core parses, but for the keys that
change neither numbers nor rows), that its rows fall on the next coarser level's, and that
a file computed for another scene is refused with a message naming it."""

from __future__ import annotations

import gzip
import json
import os
import shutil

import numpy as np

from dyncontact.study import workprecision as wp
from dyncontact.study.common import write_base_scenes


def _shipped_tasks(tmp_path):
    bases = write_base_scenes(str(tmp_path / "scenes"))
    refs = wp._reference_tasks(bases["seed2d"], "full", wp.T_END["full"])
    return [(t, k) for t, k in refs if (k[0], k[2]) in wp.SHIPPED and k[1] != "dt"]


def test_every_shipped_level_is_a_level_of_the_full_study(tmp_path):
    found = {(k[0], k[2]) for _t, k in _shipped_tasks(tmp_path)}
    assert found == set(wp.SHIPPED)


def test_the_shipped_file_is_the_studys_scene_and_nests_with_the_coarser_level(tmp_path):
    for task, (name, i, h, dt) in _shipped_tasks(tmp_path):
        rec = wp._shipped_record(task, name, h)
        assert rec["status"] == "ok", rec.get("message")
        t = rec["arrays"]["t"]
        every = dict(task.settings)["output.every"]
        # rows every `every` steps from 0 to T: on the rows of the level at 2 h (dt = 2 h / c,
        # a row a step or every/2 steps)
        assert every == wp._nested_every(dt) == 2
        assert t[0] == 0.0 and abs(t[-1] - wp.T_END["full"]) < 1e-12
        assert np.allclose(np.diff(t), every * dt, rtol=0, atol=1e-12)
        for col in wp.COLUMNS.split(","):
            assert np.all(np.isfinite(rec["arrays"][col]))
        header, _ = wp.read_shipped(rec["shipped"])
        assert header["h"] == h and header["reference"] == name
        assert header["cpu_s"] > 0 and header["code"]["fortran"]


def test_nested_every_puts_rows_on_the_coarser_levels():
    assert wp._nested_every(wp.OUTPUT_DT / 4) == 1
    assert wp._nested_every(0.000390625) == 2
    assert wp._nested_every(0.0001953125) == 4
    for dt in (0.0004, 0.0003, 0.0001):
        e = wp._nested_every(dt)
        assert e * dt >= wp.OUTPUT_DT / 4 and (e == 1 or e / 2 * dt < wp.OUTPUT_DT / 4)


def test_a_file_for_another_scene_is_refused_naming_it(tmp_path, monkeypatch):
    (task, (name, _i, h, _dt)), = _shipped_tasks(tmp_path)
    src = os.path.join(wp.SHIPPED_DIR, wp.SHIPPED[(name, h)])
    dst_dir = tmp_path / "data"
    dst_dir.mkdir()
    dst = dst_dir / wp.SHIPPED[(name, h)]
    with gzip.open(src, "rt", encoding="utf-8") as f:
        header = json.loads(f.readline()[1:])
        rest = f.read()
    header["scene"]["scheme"]["rho_inf"] = 0.25
    with gzip.open(dst, "wt", encoding="utf-8") as f:
        f.write("#" + json.dumps(header) + "\n" + rest)
    monkeypatch.setattr(wp, "SHIPPED_DIR", str(dst_dir))
    rec = wp._shipped_record(task, name, h)
    assert rec["status"] == "error"
    assert str(dst) in rec["message"] and "write_shipped_reference" in rec["message"]
    os.remove(dst)
    rec = wp._shipped_record(task, name, h)
    assert rec["status"] == "error" and str(dst) in rec["message"]
    shutil.rmtree(dst_dir)


def test_write_shipped_reference_writes_what_the_study_reads(tmp_path, monkeypatch):
    """The writer on a cheap level (the coarsest filtered one, 480 steps): the file it
    writes is accepted for that level and holds the run's trace."""
    cheap = ("filtered", wp.REFERENCES["filtered"][3]["full"][0])
    monkeypatch.setattr(wp, "SHIPPED", {cheap: "cheap.csv.gz"})
    monkeypatch.setattr(wp, "SHIPPED_DIR", str(tmp_path / "data"))
    paths = wp.write_shipped_reference(cache=str(tmp_path / "cache"), log=lambda *a: None)
    assert paths == [str(tmp_path / "data" / "cheap.csv.gz")]
    (task, (name, _i, h, _dt)), = _shipped_tasks(tmp_path)
    assert (name, h) == cheap
    rec = wp._shipped_record(task, name, h)
    assert rec["status"] == "ok", rec.get("message")
    from dyncontact.study.sweep import sweep
    run = sweep([task], str(tmp_path / "cache2"), workers=1, progress=False,
                log=lambda *a: None)[0]
    for col in wp.COLUMNS.split(","):
        assert np.array_equal(rec["arrays"][col], run["arrays"][col])
