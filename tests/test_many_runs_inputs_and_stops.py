"""What a user of many runs meets, and what the code does:

- a sweep grid that names one case twice: the sweep runs it once and gives its record to
  each task; a pool of no process (workers < 1) is refused;
- a study's --schemes that names a scheme twice: refused (its rows would be counted twice
  in the fits, the tables and the CSVs);
- `plot` of a folder whose trace.csv is empty or another CSV: bad input, exit 2 naming the
  file (not exit 4, not an empty chart); the chart of many runs (from 74 runs matplotlib
  refused the layout; the 11th run took the 1st one's colour);
- scripts/convergence_1d: a scheme twice, a --finest off its grid of meshes, a --t-end
  <= 0 are exit 2 naming the option (not a silent single mesh or a traceback); its hht
  runs draw no warning about the base scene's keys that hht does not use;
- a script of one's own that calls sweep() and is ended by SIGTERM (`kill PID`, a batch
  system's time limit): its runs in progress leave no temporary cache entry, and it
  still ends by SIGTERM;
- central at &scheme dt = 0 gone unstable: the advice is a smaller dt, not dt = 0 again;
- a sweep task tagged with the name of a field of the run (`steps`, `status`, ...) or
  of a metric: refused (by_tags would put the run's value under the tag's name);
- a study whose --out or --cache folder cannot be made: one line naming the study, the
  option and the folder, exit 2 (not the system's bare message);
- a sweep task whose setting the core refuses (a key unknown or out of range, a probe off
  the contact boundary): the record's message names the setting, not only the base scene
  file, which does not hold that value.
"""

from __future__ import annotations

import dataclasses
import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

from conftest import ROOT, SUBPROCESS_TIMEOUT, stderr_line
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
    for rs in (recs, again):
        rs[1]["metrics"]["mine"] = 1.0
        assert "mine" not in rs[0]["metrics"]


@pytest.mark.parametrize("workers", [0, -2, 1.5, True])
def test_sweep_refuses_a_pool_of_no_process(tmp_path, workers):
    """workers = 0 ran on every core and a negative number on one, without a word."""
    base = write_base_scenes(str(tmp_path / "scenes"))["exact1d"]
    with pytest.raises(ValueError, match="workers must be a whole number >= 1"):
        sweep([make_task(base, _settings(0.25))], str(tmp_path / "cache"), workers=workers,
              progress=False)
    assert not (tmp_path / "cache").exists()


def test_scheme_list_refuses_a_key_given_twice():
    with pytest.raises(ValueError, match="more than once: newmark$"):
        scheme_list("newmark,pc,newmark")
    assert [s.key for s in scheme_list("newmark,pc")] == ["newmark", "pc"]


def test_a_tag_named_as_a_field_of_the_run_is_refused(tmp_path):
    """by_tags puts the run's fields and metrics beside the tags: a tag of the same name
    would be replaced by the run's value in the row without a word."""
    base = write_base_scenes(str(tmp_path / "scenes"))["exact1d"]
    for name in ("steps", "status", "message", "t_end_reached", "wall_s"):
        with pytest.raises(ValueError, match=f"'{name}'"):
            make_task(base, _settings(0.25), tags={"scheme": "newmark", name: 1})
    recs = sweep([make_task(base, _settings(0.25), tags={"label": "a"})],
                 str(tmp_path / "cache"), workers=1, progress=False)
    metric = sorted(recs[0]["metrics"])[0]
    recs[0]["task"] = dataclasses.replace(recs[0]["task"],
                                          tags=(("label", "a"), (metric, "mine")))
    with pytest.raises(ValueError, match=f"'{metric}'"):
        by_tags(recs)
    assert by_tags(recs[:0]) == []


def test_a_refused_setting_of_a_task_is_named_in_its_record(tmp_path):
    """The record of a task whose setting the core refuses said `BadInputError:
    /abs/base.nml: &scheme dt: must be > 0`, sending the user to a file that holds
    another value: the message begins with the setting and names the base scene, at the
    set (error) as at the run (refused); a refusal about a key the task does not set
    still names the file."""
    base = tmp_path / "base.nml"
    base.write_text("&scheme t_end = 0.05 /\n&contact gamma0 = -1.0 /\n")
    good = tmp_path / "good.nml"
    good.write_text("&scheme t_end = 0.05 /\n")
    tasks = [make_task(str(good), {"scheme.dt": -1.0}, tags={"n": 1}),
             make_task(str(good), {"scheme.bogus": 1}, tags={"n": 2}),
             make_task(str(good), {"contact.probe": [5.0, 5.0]}, tags={"n": 3}),
             make_task("", {"scheme.dt": -1.0}, tags={"n": 4}),
             make_task(str(base), {"scheme.dt": 0.01}, tags={"n": 5})]
    rows = {r["n"]: r for r in by_tags(sweep(tasks, str(tmp_path / "cache"), workers=1,
                                               progress=False))}
    said = {n: rows[n]["message"] for n in rows}
    assert said[1].startswith("BadInputError: setting scheme.dt=-1.0 of the task on "
                              "good.nml: &scheme dt: must be > 0"), said[1]
    assert said[2].startswith("BadInputError: setting scheme.bogus=1 of the task on "
                              "good.nml: &scheme bogus: unknown key"), said[2]
    assert rows[3]["status"] == "refused", rows[3]
    assert said[3].startswith("BadInputError: setting contact.probe=[5.0, 5.0] of the task "
                              "on good.nml: &contact probe: the point is not on the contact "
                              "boundary"), said[3]
    assert said[4].startswith("BadInputError: setting scheme.dt=-1.0 of the task on the "
                              "default scene: &scheme dt:"), said[4]
    assert said[5].startswith(f"BadInputError: {base}: &contact gamma0:"), said[5]


@pytest.mark.parametrize("option", ["--out", "--cache"])
def test_study_folder_that_cannot_be_made_is_refused_naming_the_option(run_cli, tmp_path,
                                                                       option):
    blocker = tmp_path / "file"
    blocker.write_text("")
    folder = blocker / "sub"            # below a file: ENOTDIR, whoever runs the test
    args = ["--out", str(tmp_path / "s")] if option == "--cache" else []
    line = stderr_line(run_cli("study", "convergence", "--quick", "--no-progress",
                               *args, option, str(folder)), 2,
                       "dyncontact study convergence: ")
    assert f"{option} {folder}: cannot create the folder" in line, line


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


def _convergence_1d(*args, cwd) -> subprocess.CompletedProcess:
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    return subprocess.run([str(ROOT / "scripts" / "convergence_1d"), *args], cwd=cwd,
                          env=env, capture_output=True, text=True,
                          timeout=SUBPROCESS_TIMEOUT)


@pytest.mark.parametrize("option, value, words", [
    ("--schemes", "newmark,newmark", "'newmark' given more than once"),
    ("--finest", "30", "25 times a power of 2"),    # ran 1/h = 25 alone, without orders
    ("--finest", "0", "25 times a power of 2"),
    ("--t-end", "-1", "finite number > 0"),         # a traceback, exit 1
    ("--t-end", "nan", "finite number > 0"),
])
def test_convergence_1d_refuses_bad_options_naming_them(tmp_path, option, value, words):
    res = _convergence_1d(option, value, cwd=tmp_path)
    assert res.returncode == 2, (res.returncode, res.stdout[-1000:], res.stderr[-1000:])
    assert "Traceback" not in res.stderr
    last = res.stderr.strip().splitlines()[-1]
    assert last.startswith("scripts/convergence_1d: error: ") and option in last, last
    assert words in last, last
    assert res.stdout == "" and os.listdir(tmp_path) == []


def test_convergence_1d_short_run_is_quiet_and_marks_p_n_unmeasured(tmp_path):
    """T = 0.5 ends before the first contact window: p_n is nan, with no numpy warning;
    hht runs without the base scene's beta and gamma (no warning that they change
    nothing)."""
    res = _convergence_1d("--schemes", "hht", "--finest", "50", "--t-end", "0.5",
                          "--keep", str(tmp_path / "runs"), cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert "Warning" not in res.stderr, res.stderr
    rows = [line.split() for line in res.stdout.splitlines()
            if line.split()[:1] in (["25"], ["50"], ["order"])]
    assert [r[0] for r in rows] == ["25", "50", "order"]
    assert all(r[3] == "nan" for r in rows), rows       # p_n
    assert all(r[1] != "nan" for r in rows), rows       # u_n is measured


#: A sweep of four runs of about a second each (1D bar, 80 000 steps), as a user's script.
SWEEP_SCRIPT = textwrap.dedent("""
    import sys
    from dyncontact.study.common import write_base_scenes
    from dyncontact.study.sweep import make_task, sweep

    base = write_base_scenes(sys.argv[1] + "/scenes")["exact1d"]
    tasks = [make_task(base, {"mesh.h": 0.02, "scheme.dt": dt, "scheme.t_end": 40.0,
                              "output.every": 1000}) for dt in (5e-4, 4e-4, 3e-4, 2e-4)]
    sweep(tasks, sys.argv[1] + "/cache", workers=int(sys.argv[2]), progress=False)
""")
START_S = 60.0


@pytest.mark.parametrize("workers", [2, 1])
def test_sigterm_to_a_script_of_ones_own_leaves_no_temporary_entry(tmp_path, workers):
    """A script without a SIGTERM handler of its own, ended by SIGTERM: the sweep unwinds
    first (as on Ctrl-C), so that no run in progress stays as a `<key>.tmp-<pid>-...`
    folder for the 6 h of sweep.STALE_S, then the process ends by SIGTERM."""
    script = tmp_path / "my_sweep.py"
    script.write_text(SWEEP_SCRIPT)
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    proc = subprocess.Popen([sys.executable, str(script), str(tmp_path), str(workers)],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    cache = tmp_path / "cache"
    deadline = time.monotonic() + START_S
    while not list(cache.glob("*/*.tmp-*")) and proc.poll() is None \
            and time.monotonic() < deadline:
        time.sleep(0.01)
    assert list(cache.glob("*/*.tmp-*")), f"no run started (exit {proc.poll()})"
    proc.send_signal(signal.SIGTERM)
    _out, err = proc.communicate(timeout=SUBPROCESS_TIMEOUT)
    assert proc.returncode == -signal.SIGTERM, (proc.returncode, err[-2000:])
    assert list(cache.glob("*/*.tmp-*")) == []
    assert "Traceback" not in err, err[-2000:]


def _result(i: int):
    import numpy as np

    from dyncontact import RunResult

    t = np.linspace(0.0, 1.0, 11)
    trace = {"t": t, "u_n": -0.5 + 0.01 * i * t, "v_n": 0 * t, "p_n": 0 * t,
             "e_kin": 0 * t, "e_el": 0 * t + 0.125, "e_contact": 0 * t, "e_total": 0 * t + 0.125}
    return RunResult(trace=trace, summary={"status": "ok"}, out_dir=f"run{i}")


def _panel_height_in(fig) -> float:
    return fig.axes[0].get_position().height * fig.get_figheight()


@pytest.mark.parametrize("title", [None, "a sweep"])
def test_plot_of_many_runs_keeps_its_panels(tmp_path, title):
    from dyncontact.plotting import plot_traces

    few = plot_traces([_result(i) for i in range(12)], None, title=title)
    many = plot_traces([_result(i) for i in range(80)], tmp_path / "many.png", title=title)
    assert (tmp_path / "many.png").is_file()
    assert len(many.legends[0].get_texts()) == 80
    assert few.get_figheight() == 7.5
    assert many.get_figheight() > few.get_figheight()
    assert abs(_panel_height_in(many) - _panel_height_in(few)) < 1e-9


@pytest.mark.parametrize("n", [3, 12, 20, 80])
def test_plot_of_many_runs_draws_each_in_a_colour_of_its_own(n):
    from matplotlib.colors import to_rgba

    from dyncontact.plotting import plot_traces

    fig = plot_traces([_result(i) for i in range(n)], None)
    colours = {to_rgba(line.get_color()) for line in fig.axes[0].get_lines()}
    assert len(colours) == n


CENTRAL_1D = """&mesh dim = 1, length = 1.0, h = 0.01 /
&boundary clamped = 'top', contact = 'bottom' /
&material young = 1.0, poisson = 0.0, density = 1.0 /
&contact method = 'nitsche', theta = 1, gamma0 = 10.0, obstacle_point = 0.0,
         obstacle_normal = -1.0, probe = 0.0 /
&initial kind = 'compressed_bar', amplitude = 0.5 /
&scheme name = 'central', dt = 0, t_end = 60, mass = 'lumped' /
&output dir = 'out', every = 10 /
"""


def test_central_at_dt_0_gone_unstable_asks_for_a_smaller_dt(run_exe, tmp_path):
    """The 1D bar at the step central chooses (0.9 x its estimate, a bound the run warns
    is not safe in 1D) goes unstable near t = 19; the message names the step the run took
    and asks for a smaller &scheme dt, not for dt = 0, the scene's own value."""
    (tmp_path / "s.nml").write_text(CENTRAL_1D)
    res = run_exe("s.nml")
    assert res.returncode == 3, res.stderr
    stop = [ln for ln in res.stderr.splitlines() if "unstable at t = " in ln]
    assert len(stop) == 1, res.stderr
    assert stop[0].endswith("(&scheme dt = 0 took 4.242E-003, at most 0.9 x the estimate, "
                            "which is not a safe bound on this scene): give a smaller "
                            "&scheme dt"), stop[0]
    assert "or dt = 0" not in stop[0]
