"""Inputs a user of many runs gets wrong: a sweep grid that names one case twice (the
sweep runs it once and gives its record to each task); a study's --schemes that names a
scheme twice (refused: its rows would be counted twice in the fits, the tables and the
CSVs); a folder given to `plot` whose trace.csv is empty or another CSV (bad input, exit
2 naming the file, not exit 4 or an empty chart)."""

from __future__ import annotations

import os

import pytest

from conftest import stderr_line
from dyncontact.study import sweep as sweep_mod
from dyncontact.study.common import scheme_list, write_base_scenes
from dyncontact.study.sweep import by_tags, make_task, sweep


def _settings(t_end: float) -> dict:
    return {"mesh.h": 0.1, "scheme.dt": 0.005, "scheme.t_end": t_end}


def test_tasks_of_one_key_are_run_once(tmp_path, monkeypatch):
    """Two tasks of one scene (one of them with other tags) and a third task: two runs,
    and each task's record carries its own tags with the shared run's numbers."""
    base = write_base_scenes(str(tmp_path / "scenes"))["exact1d"]
    tasks = [make_task(base, _settings(0.5), tags={"label": "a"}),
             make_task(base, _settings(0.5), tags={"label": "a"}),
             make_task(base, _settings(0.5), tags={"label": "b"}),
             make_task(base, _settings(0.25), tags={"label": "c"})]
    runs: list[str] = []
    real = sweep_mod.execute

    def counting(task, cache, key=None, threads=None):
        runs.append(key)
        return real(task, cache, key, threads)

    monkeypatch.setattr(sweep_mod, "execute", counting)
    cache = str(tmp_path / "cache")
    lines: list[str] = []
    recs = sweep(tasks, cache, workers=1, progress=False, log=lines.append)
    assert len(runs) == 2 and len(set(runs)) == 2, runs
    assert "runs: 4 runs, 0 from the cache, 2 to do (2 more the same run as another)" \
        in lines, lines
    assert [r["status"] for r in recs] == ["ok"] * 4
    assert [row["label"] for row in by_tags(recs)] == ["a", "a", "b", "c"]
    assert recs[0]["key"] == recs[1]["key"] == recs[2]["key"] != recs[3]["key"]
    assert recs[0]["run_dir"] == recs[2]["run_dir"]
    assert recs[0]["metrics"] == recs[2]["metrics"]
    assert recs[0] is not recs[1]          # each task has a record of its own
    assert recs[3]["steps"] == 50 and recs[0]["steps"] == 100

    runs.clear()
    lines.clear()
    again = sweep(tasks, cache, workers=1, progress=False, log=lines.append)
    assert runs == []
    assert "runs: 4 runs, 4 from the cache, 0 to do" in lines, lines
    assert all(r["cached"] for r in again)
    assert [r["metrics"] for r in again] == [r["metrics"] for r in recs]


def test_scheme_list_refuses_a_key_given_twice():
    with pytest.raises(ValueError, match="more than once: newmark$"):
        scheme_list("newmark,pc,newmark")
    assert [s.key for s in scheme_list("newmark,pc")] == ["newmark", "pc"]


def test_study_schemes_given_twice_is_refused_naming_it(run_cli, tmp_path):
    line = stderr_line(run_cli("study", "convergence", "--quick", "--no-progress",
                               "--schemes", "newmark,pc,newmark", "--out",
                               str(tmp_path / "s")), 2, "dyncontact study: ")
    assert "--schemes" in line and "newmark" in line, line
    assert sorted(os.listdir(tmp_path)) == []


@pytest.mark.parametrize("text, words", [
    ("", "empty file"),
    ("a,b\n1,2\n3,4\n", "no column 't'"),
])
def test_plot_of_a_folder_whose_trace_is_not_a_run_is_bad_input(run_cli, tmp_path, text,
                                                                 words):
    run = tmp_path / "run"
    run.mkdir()
    (run / "trace.csv").write_text(text)
    line = stderr_line(run_cli("plot", run, "--out", tmp_path / "x.png"), 2, "dyncontact: ")
    assert str(run / "trace.csv") in line and words in line, line
    assert not (tmp_path / "x.png").exists()


def test_plot_traces_refuses_another_csv(tmp_path):
    from dyncontact import BadInputError
    from dyncontact.plotting import plot_traces

    (tmp_path / "trace.csv").write_text("a,b\n1,2\n")
    with pytest.raises(BadInputError, match="no column 't'"):
        plot_traces([tmp_path], None)
