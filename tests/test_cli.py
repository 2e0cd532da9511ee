"""Command-line plumbing: plot, bad input, --set parsing (no simulation needed)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import ROOT

HEADER = "t,u_n,v_n,p_n,e_kin,e_el,e_contact,e_total,newton_its,active,e_load,f_n"
#: The header before e_load was appended (traces written by version 0.1.0).
OLD_HEADER = "t,u_n,v_n,p_n,e_kin,e_el,e_contact,e_total,newton_its,active"
#: The header before f_n was appended (the study caches hold such traces).
E_LOAD_HEADER = "t,u_n,v_n,p_n,e_kin,e_el,e_contact,e_total,newton_its,active,e_load"
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _write_run(folder, n=200, t_end=3.0, status="ok", alpha=-0.1, dt=0.0025, h=0.05):
    """A synthetic run folder shaped like the 1D exact solution (period 3)."""
    folder.mkdir(parents=True, exist_ok=True)
    t = np.linspace(0.0, t_end, n)
    u = np.where(t < 1, -0.5 + t / 2, np.where(t < 2, 0.0, -(t - 2) / 2))
    v = np.where(t < 1, 0.5, np.where(t < 2, 0.0, -0.5))
    p = np.where((t > 1) & (t < 2), -0.5, 0.0)
    e_kin = 0.5 * v**2 / 2
    e_el = 0.125 - e_kin
    e_contact = np.where(p < 0, 1e-3, 0.0)
    rows = np.column_stack([t, u, v, p, e_kin, e_el, e_contact, e_kin + e_el,
                            np.ones_like(t), (p < 0) * 3.0, np.zeros_like(t), 0.1 * p])
    np.savetxt(folder / "trace.csv", rows, delimiter=",", header=HEADER, comments="",
               fmt="%.10e")
    summary = {
        "status": status, "steps": n - 1, "t_end_reached": float(t[-1]), "wall_s": 0.1,
        "newton_its_total": n, "factorizations": 1, "dofs": 10, "elements": 4,
        "contact_facets": 2, "scheme": "hht", "version": "0.1.0",
        "scene": {"mesh": {"file": "", "dim": 2, "h": h},
                  "scheme": {"name": "hht", "alpha": alpha, "dt": dt, "mass": "consistent"}},
    }
    (folder / "summary.json").write_text(json.dumps(summary))
    return folder


def _one_error_line(res, code):
    assert res.returncode == code, (res.returncode, res.stdout, res.stderr)
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, res.stderr
    assert lines[0].startswith("dyncontact: "), res.stderr
    assert "Traceback" not in res.stderr
    return lines[0]


# --------------------------------------------------------------------------- plot

def test_plot_two_runs_writes_png(run_cli, tmp_path):
    a = _write_run(tmp_path / "a")
    b = _write_run(tmp_path / "b", n=80, t_end=1.3, status="unstable", alpha=0.0)
    png = tmp_path / "fig" / "both.png"
    res = run_cli("plot", a, b, "--out", png, "--title", "two runs")
    assert res.returncode == 0, res.stderr
    assert png.is_file() and png.stat().st_size > 10_000
    assert png.read_bytes()[:8] == PNG_MAGIC


def test_plot_labels_of_runs_alike_name_the_keys_that_differ(tmp_path):
    """Runs whose labels read alike are told apart by the scene keys that differ between
    them (not by folders that say nothing, such as a sweep cache's 64-digit hashes); where
    the scenes do not differ, by the folder, a hash cut to 12 digits."""
    from dyncontact.plotting import plot_traces

    cache = tmp_path / "cache"
    runs = []
    for gamma0, digit in ((10.0, "a"), (20.0, "b")):
        run = _write_run(cache / (digit * 64))
        summary = json.loads((run / "summary.json").read_text())
        summary["scene"]["contact"] = {"gamma0": gamma0}
        (run / "summary.json").write_text(json.dumps(summary))
        runs.append(run)
    same = _write_run(tmp_path / "c")
    labels = [t.get_text() for t in plot_traces(runs, None).legends[0].get_texts()]
    assert labels == ["hht α=-0.1, Δt=0.0025, h=0.05 [contact.gamma0=10]",
                      "hht α=-0.1, Δt=0.0025, h=0.05 [contact.gamma0=20]"], labels
    twins = [_write_run(cache / ("c" * 64)), same]
    labels = [t.get_text() for t in plot_traces(twins, None).legends[0].get_texts()]
    assert labels == ["hht α=-0.1, Δt=0.0025, h=0.05 [cccccccccccc]",
                      "hht α=-0.1, Δt=0.0025, h=0.05 [c]"], labels


def test_plot_traces_api_labels(tmp_path):
    from dyncontact.plotting import plot_traces, run_label

    a = _write_run(tmp_path / "a")
    b = _write_run(tmp_path / "b", n=50, t_end=1.2, status="unstable")
    fig = plot_traces([a, b], tmp_path / "x.png")
    assert (tmp_path / "x.png").stat().st_size > 0
    assert len(fig.axes) == 5      # the four panels and f_n's scale beside p_n's
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    # the same settings: told apart by their folders
    assert labels[0] == "hht α=-0.1, Δt=0.0025, h=0.05 [a]"
    assert labels[1].startswith("hht α=-0.1, Δt=0.0025, h=0.05 [b] (unstable at t=1.2")
    summary = json.loads((a / "summary.json").read_text())
    assert run_label(summary) == "hht α=-0.1, Δt=0.0025, h=0.05"
    summary["scene"]["scheme"] = {"name": "newmark", "beta": 0.3025, "gamma": 0.6,
                                  "dt": 0.001, "mass": "lumped"}
    assert run_label(summary) == "newmark β=0.3025, γ=0.6, Δt=0.001, h=0.05, lumped"
    # what else tells runs apart: the built-in bar's dimension out of the plane, the
    # redistributed mass, a contact method other than Nitsche's
    summary["scene"]["scheme"]["mass"] = "redistributed"
    summary["scene"]["mesh"]["dim"] = 3
    summary["scene"]["contact"] = {"method": "alm", "multiplier": "nodal"}
    assert run_label(summary) == ("newmark β=0.3025, γ=0.6, Δt=0.001, h=0.05, 3D, "
                                  "redistributed, ALM nodal")
    summary["scene"]["contact"] = {"method": "penalty"}
    summary["scene"]["mesh"]["dim"] = 2
    assert run_label(summary).endswith("h=0.05, redistributed, penalty")
    # e_total + e_contact is drawn dashed when e_contact is not all zero.
    energy_lines = fig.axes[3].get_lines()
    assert any(line.get_linestyle() == "--" for line in energy_lines)


#: The parameters each scheme uses (docs/scenes.md, &scheme: "newmark and pc: beta,
#: gamma; the HHT family: alpha; theta: theta; galpha: rho_inf; central: none") and how
#: a legend writes them.
SCHEME_PARAMETERS = {
    "newmark": {"beta": "β", "gamma": "γ"}, "pc": {"beta": "β", "gamma": "γ"},
    "hht": {"alpha": "α"}, "hht_seed": {"alpha": "α"}, "pc_hht": {"alpha": "α"},
    "pc_hht_seed": {"alpha": "α"}, "theta": {"theta": "θ"}, "galpha": {"rho_inf": "ρ∞"},
    "central": {},
}


@pytest.mark.parametrize("name", sorted(SCHEME_PARAMETERS))
def test_run_label_gives_the_parameters_the_scheme_uses(name):
    """A legend says the scheme's own parameters and no other: galpha's labels left
    its rho_inf out ('galpha Δt=0.0025, h=0.05' for every rho_inf)."""
    from dyncontact.plotting import run_label

    scheme = {"name": name, "alpha": -0.05, "beta": 0.3, "gamma": 0.6, "theta": 0.7,
              "rho_inf": 0.8, "dt": 0.0025, "mass": "consistent"}
    values = {k: v for k, v in scheme.items() if k not in ("name", "dt", "mass")}
    label = run_label({"scene": {"scheme": scheme, "mesh": {"file": "", "h": 0.05}}})
    used = SCHEME_PARAMETERS[name]
    params = ", ".join(f"{symbol}={values[key]:g}" for key, symbol in used.items())
    assert label == f"{name} {params + ', ' if params else ''}Δt=0.0025, h=0.05", label


def test_run_label_knows_every_scheme():
    """SCHEME_PARAMETERS above lists the core's schemes (the names the scene reader
    takes, as its message lists them)."""
    import dyncontact

    scene = dyncontact.Scene()
    scene.set("scheme.name", "no_such_scheme")
    with pytest.raises(dyncontact.BadInputError) as err:
        scene.validate()
    listed = str(err.value).split("must be one of ")[1].split(" (got")[0]
    assert sorted(listed.replace("'", "").split(", ")) == sorted(SCHEME_PARAMETERS)


def test_plot_explicit_labels_and_result_objects(tmp_path):
    from dyncontact.core import RunResult, read_summary, read_trace
    from dyncontact.plotting import plot_traces

    a = _write_run(tmp_path / "a")
    res = RunResult(trace=read_trace(a), summary=read_summary(a), out_dir=str(a))
    fig = plot_traces([res, a], None, labels=["first", "second"])
    assert [t.get_text() for t in fig.legends[0].get_texts()] == ["first", "second"]


def test_plot_missing_trace_is_bad_input(run_cli, tmp_path):
    (tmp_path / "empty").mkdir()
    line = _one_error_line(run_cli("plot", tmp_path / "empty", "--out",
                                   tmp_path / "x.png"), 2)
    assert "trace.csv" in line
    assert not (tmp_path / "x.png").exists()


def test_plot_needs_out(run_cli, tmp_path):
    a = _write_run(tmp_path / "a")
    _one_error_line(run_cli("plot", a), 2)


@pytest.mark.parametrize("given, said", [
    ("x", "1 label for 2 folders"),
    ("x,y,z", "3 labels for 2 folders"),
])
def test_plot_labels_not_one_per_folder_is_one_line_naming_the_option(run_cli, tmp_path,
                                                                      given, said):
    a, b = _write_run(tmp_path / "a"), _write_run(tmp_path / "b")
    line = _one_error_line(run_cli("plot", a, b, "--labels", given, "--out",
                                   tmp_path / "x.png"), 2)
    assert line == f"dyncontact: --labels: {said}; give one per folder, comma-separated"
    assert not (tmp_path / "x.png").exists()


@pytest.mark.parametrize("given, said", [
    ("", "label 1 of 1 is empty"),
    ("x,", "label 2 of 2 is empty"),
    ("x,,y", "label 2 of 3 is empty"),
    (" ,y", "label 1 of 2 is empty"),
])
def test_plot_empty_labels_are_refused_naming_the_option(capsys, tmp_path, given, said):
    """`--labels ""` drew the default labels and `a,,b` a blank legend entry, silently (an
    empty label has no meaning of its own): one line naming --labels, nothing drawn."""
    from dyncontact.cli import main

    a, b = _write_run(tmp_path / "a"), _write_run(tmp_path / "b")
    dirs = [a] if given == "" else [a, b, _write_run(tmp_path / "c")][:len(given.split(","))]
    assert main(["plot", *map(str, dirs), "--labels", given, "--out",
                 str(tmp_path / "x.png")]) == 2
    assert capsys.readouterr().err == (f"dyncontact: --labels: {said}; give one per folder, "
                                       "comma-separated\n")
    assert not (tmp_path / "x.png").exists()


@pytest.mark.parametrize("labels, said", [
    ([""], "label 1 of 1 is empty"),
    (["x", "  "], "label 2 of 2 is empty"),
])
def test_plot_traces_empty_label_is_bad_input(tmp_path, labels, said):
    from dyncontact import BadInputError
    from dyncontact.plotting import plot_traces

    runs = [_write_run(tmp_path / name) for name in "ab"[:len(labels)]]
    with pytest.raises(BadInputError) as info:
        plot_traces(runs, tmp_path / "x.png", labels=labels)
    assert str(info.value) == f"labels: {said}; give one per run"
    assert not (tmp_path / "x.png").exists()


def test_plot_traces_labels_not_one_per_run_is_bad_input(tmp_path):
    """The package's bad-input error, still the ValueError it was."""
    from dyncontact import BadInputError
    from dyncontact.plotting import plot_traces

    a, b = _write_run(tmp_path / "a"), _write_run(tmp_path / "b")
    with pytest.raises(BadInputError) as info:
        plot_traces([a, b], None, labels=["x"])
    assert isinstance(info.value, ValueError)
    assert str(info.value) == "labels: 1 label for 2 runs; give one per run"
    with pytest.raises(BadInputError, match="nothing to plot") as info:
        plot_traces([], None)
    assert isinstance(info.value, ValueError)


@pytest.mark.parametrize("kind", ["missing", "a file", "no trace"])
def test_plot_of_a_folder_that_is_not_a_run_says_what_the_api_says(run_cli, tmp_path, kind):
    """`plot DIR` refuses a folder in the words of plot_traces(DIR) (RunNotFoundError):
    'no such run folder' for one that is not there, not 'no trace.csv'."""
    from dyncontact import RunNotFoundError
    from dyncontact.plotting import plot_traces

    folder = tmp_path / "run"
    if kind == "a file":
        folder.write_text("x\n")
    elif kind == "no trace":
        folder.mkdir()
    with pytest.raises(RunNotFoundError) as info:
        plot_traces([folder], None)
    line = _one_error_line(run_cli("plot", folder, "--out", tmp_path / "x.png"), 2)
    assert line == f"dyncontact: {info.value}"
    if kind == "missing":
        assert line == f"dyncontact: {folder}: no such run folder"
    assert not (tmp_path / "x.png").exists()


@pytest.mark.parametrize("out, written", [
    ("cmp_dt0.001", "cmp_dt0.001.png"),          # dots in a name are not an extension
    ("run.v2", "run.v2.png"),
    ("newdir2/", "newdir2/traces.png"),          # a trailing slash names a folder
    ("fig.PDF", "fig.PDF"),
    ("fig.svg", "fig.svg"),
    ("fig.png", "fig.png"),
])
def test_plot_out_names_the_file_docs_promise(run_cli, tmp_path, out, written):
    """docs/scenes.md: OUT.png when OUT has no extension, OUT/traces.png for a folder."""
    a = _write_run(tmp_path / "a")
    res = run_cli("plot", a, "--out", out)
    assert res.returncode == 0, res.stderr
    path = tmp_path / written
    assert path.is_file() and path.stat().st_size > 1000
    assert res.stdout.strip() == f"dyncontact: wrote {written}"
    assert sorted(p.name for p in tmp_path.iterdir() if p.is_file()) == \
        ([] if "/" in written else [written])


@pytest.mark.parametrize("out", ["x.xyz", "x.jpg"])
def test_plot_unsupported_format_is_one_line(run_cli, tmp_path, out):
    a = _write_run(tmp_path / "a")
    line = _one_error_line(run_cli("plot", a, "--out", out), 2)
    assert "--out" in line and "unsupported format" in line and ".png" in line
    assert not (tmp_path / out).exists()


# --------------------------------------------------------------------------- run: bad input

def test_run_missing_scene_file(run_cli, tmp_path):
    line = _one_error_line(run_cli("run", tmp_path / "nope.nml"), 2)
    assert "nope.nml" in line


@pytest.mark.parametrize("out", [False, True])
def test_run_bad_scene_exits_2(run_cli, tmp_path, core_ext, out):
    scene = tmp_path / "bad.nml"
    scene.write_text("&scheme name = 'hht', dt = -1.0 /\n")
    args = ["run", scene] + (["--out", tmp_path / "o"] if out else [])
    line = _one_error_line(run_cli(*args), 2)
    assert "bad.nml" in line
    assert not (tmp_path / "o" / "trace.csv").exists()


def test_exe_bad_scene_exits_2(run_exe, tmp_path):
    scene = tmp_path / "bad.nml"
    scene.write_text("&scheme name = 'no_such_scheme' /\n")
    res = run_exe(scene, "--out", tmp_path / "o")
    _one_error_line(res, 2)


def test_api_bad_scene_raises(tmp_path, core_ext):
    import dyncontact

    scene = tmp_path / "bad.nml"
    scene.write_text("&contact theta = 7 /\n")
    with pytest.raises(dyncontact.BadInputError) as info:
        dyncontact.run(scene, out=tmp_path / "o", progress=False)
    assert isinstance(info.value, dyncontact.DyncontactError)
    assert "bad.nml" in str(info.value)
    with pytest.raises(dyncontact.BadInputError):
        dyncontact.run(tmp_path / "missing.nml")


# --------------------------------------------------------------------------- --set

@pytest.mark.parametrize("item", ["scheme", "scheme.dt", "dt=0.1", "a.b.c=1", "scheme.dt=",
                                  ".dt=1", "scheme.=1", "sch eme.dt=1"])
def test_set_syntax_errors_exit_2(run_cli, tmp_path, item):
    scene = tmp_path / "s.nml"
    scene.write_text("&scheme dt = 0.01 /\n")
    line = _one_error_line(run_cli("run", scene, "--set", item), 2)
    assert "--set" in line


@pytest.mark.parametrize("item, expected", [
    ("scheme.dt=0.001", ("scheme", "dt", "0.001")),
    ("Scheme.Name=hht", ("scheme", "name", "hht")),
    (" scheme.name = 'pc_hht' ", ("scheme", "name", "'pc_hht'")),
    ("contact.probe=0.05,0.0", ("contact", "probe", "0.05,0.0")),
    ("boundary.slip_x=''", ("boundary", "slip_x", "''")),
    ("mesh.file=meshes/a=b.msh", ("mesh", "file", "meshes/a=b.msh")),
])
def test_parse_set_syntax(item, expected):
    from dyncontact.cli import parse_set

    assert parse_set(item) == expected


@pytest.mark.parametrize("item, key", [("scheme.dt=abc", "dt"), ("scheme.bogus=1", "bogus"),
                                       ("nogroup.dt=1", "nogroup"),
                                       ("contact.theta=1.5", "theta"),
                                       ("scheme.dt=-1", "dt"), ("contact.gamma0=0", "gamma0")])
def test_set_bad_key_or_value_exits_2(run_cli, tmp_path, item, key):
    """The Scene rejects unknown keys and values of the wrong type, and the run values out
    of range, naming the key; either way the line begins with the --set item, so that a
    value that is not in the scene file is not blamed on it."""
    scene = tmp_path / "s.nml"
    scene.write_text("&scheme dt = 0.01 /\n&contact gamma0 = 10 /\n")
    line = _one_error_line(run_cli("run", scene, "--set", item, "--out", tmp_path / "o"), 2)
    assert key in line
    assert line.startswith(f"dyncontact: --set {item}: "), line
    assert "s.nml" not in line, line          # the file holds another value, or none
    assert not (tmp_path / "o").exists()


def test_set_blames_only_the_keys_it_set(run_cli, tmp_path):
    """A value out of range in the file itself is still the file's, with --set given for
    another key; of two items for one key, the one used (the last) is named."""
    scene = tmp_path / "s.nml"
    scene.write_text("&scheme dt = -0.01 /\n&contact theta = 1 /\n")
    line = _one_error_line(run_cli("run", scene, "--set", "contact.theta=0",
                                   "--out", tmp_path / "o"), 2)
    assert line.startswith(f"dyncontact: {scene}: &scheme dt: "), line
    scene.write_text("&scheme dt = 0.01 /\n")
    line = _one_error_line(run_cli("run", scene, "--set", "contact.theta=4",
                                   "--set", "contact.theta=5", "--out", tmp_path / "o"), 2)
    assert line.startswith("dyncontact: --set contact.theta=5: &contact theta: "), line


def test_bad_command_line_is_one_line(run_cli):
    _one_error_line(run_cli("frobnicate"), 2)
    _one_error_line(run_cli("run"), 2)
    _one_error_line(run_cli("run", "x.nml", "--bogus"), 2)


def _main_line(capsys, *args) -> str:
    """The one line `python -m dyncontact ARGS` prints on stderr, exiting 2 (in process)."""
    from dyncontact.cli import main

    assert main([str(a) for a in args]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    return err.strip()


@pytest.mark.parametrize("first", ["scene.nml", "S.NML", "existing"])
def test_a_scene_given_for_the_command_says_the_run_command(capsys, tmp_path, monkeypatch,
                                                            first):
    """`python -m dyncontact scene.nml` (run forgotten) said "invalid choice: 'scene.nml'":
    an existing file or a name ending in .nml is said to need `run` before it, with the
    rest of the command line, and nothing is run."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "existing").write_text("&scheme dt = 0.01 /\n")
    line = _main_line(capsys, first, "--out", "o")
    assert line == (f"dyncontact: {first} is not a command; to run a scene file: "
                     f"`python -m dyncontact run {first} --out o`"), line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["existing"]
    assert "invalid choice: 'frob'" in _main_line(capsys, "frob")


@pytest.mark.parametrize("args, command", [
    (("run", "s.nml", "--bogus"), "python -m dyncontact run"),
    (("run", "s.nml", "t.nml"), "python -m dyncontact run"),
    (("plot", "a", "--out", "x.png", "--bogus"), "python -m dyncontact plot"),
    (("--bogus",), "python -m dyncontact"),
])
def test_an_unknown_option_points_to_its_commands_help(capsys, args, command):
    """`run s.nml --bogus` pointed to `dyncontact --help`, which does not list run's
    options: the subcommand's own help is named."""
    line = _main_line(capsys, *args)
    assert line.startswith("dyncontact: unrecognized arguments: "), line
    assert line.endswith(f"(see `{command} --help`)"), line


def test_version_and_help(run_cli):
    import dyncontact

    res = run_cli("--version")
    assert res.returncode == 0 and dyncontact.__version__ in res.stdout
    res = run_cli("run", "--help")
    assert res.returncode == 0 and "--set" in res.stdout


def test_run_help_and_the_executables_help_end_with_the_same_lines(run_cli, run_exe):
    """`run --help` (an installed package has no docs/) and the executable's --help end
    with the same lines, python/dyncontact/run_help.txt as written: the scene groups, the
    documentation by its title and the exit statuses."""
    text = (ROOT / "python" / "dyncontact" / "run_help.txt").read_text(encoding="utf-8")
    exe = run_exe("--help")
    cli = run_cli("run", "--help")
    assert exe.returncode == 0 and cli.returncode == 0, (exe.stderr, cli.stderr)
    start = "A scene file is"
    assert exe.stdout[exe.stdout.index(start):] == cli.stdout[cli.stdout.index(start):] == text
    said = " ".join(text.split())
    assert '"Scene files, outputs and exit codes"' in said and "&solver" in said
    assert "Exit status: 0 ok, 2 bad input" in said


@pytest.mark.parametrize("args, name", [
    (("--set", "scheme.dt=0.001"), "--set"),
    (("--set=scheme.dt=0.001",), "--set"),
    (("--quiet",), "--quiet"),
    (("-q",), "-q"),
    (("--wait",), "--wait"),
])
def test_the_executable_says_an_option_of_python_run_is_one(run_exe, run_cli, tmp_path,
                                                            args, name):
    """`build/dyncontact scene.nml --set k=v` said 'unknown option --set' with no hint:
    one line saying which command takes it (exit 2, nothing run); that command's help
    lists it, and the executable's help says it does."""
    line = _one_error_line(run_exe("scene.nml", *args), 2)
    assert line.startswith(f"dyncontact: {name} belongs to `python -m dyncontact run`, "
                           "not to the executable (usage: dyncontact SCENE.nml"), line
    assert sorted(tmp_path.iterdir()) == []
    assert f" {name}" in run_cli("run", "--help").stdout
    assert {"-q": "--quiet"}.get(name, name) in " ".join(run_exe("--help").stdout.split())
    assert "unknown option --setx" in _one_error_line(run_exe("scene.nml", "--setx"), 2)


@pytest.mark.parametrize("args", [
    ("run", "scene.nml"),
    ("run", "scene.nml", "--out", "o"),
    ("mesh", "--geo", "m.geo", "--out", "m.msh"),
    ("study", "all", "--out", "o"),
    ("plot", "o", "--out", "x.png"),
])
def test_the_executable_says_a_command_of_python_m_dyncontact_is_one(run_exe, tmp_path, args):
    """`build/dyncontact run scene.nml` (the word of `python -m dyncontact run`) said 'two
    scene files given (run, scene.nml)', and `dyncontact mesh --geo ...` 'unknown option
    --geo': one line saying the word is a command of `python -m dyncontact`, exit 2, nothing
    run or written. A file of that name is still a scene file."""
    (tmp_path / "scene.nml").write_text("&scheme t_end = 0.01 /\n")
    line = _one_error_line(run_exe(*args), 2)
    assert line.startswith(f"dyncontact: '{args[0]}' is a command of `python -m dyncontact`, "
                           "not of the executable, which takes the scene file alone "
                           "(usage: dyncontact SCENE.nml"), line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.nml"]
    (tmp_path / "run").write_text("&scheme t_end = 0.01 /\n")
    res = run_exe("run", "--out", "o")
    assert res.returncode == 0 and (tmp_path / "o" / "trace.csv").is_file(), res.stderr


def test_a_set_value_given_as_a_word_of_its_own_names_the_set_item(capsys):
    """`run s.nml --set scheme.dt 0.001` (a blank for the '=') said 'unrecognized
    arguments: 0.001', about the value rather than the item that lost it: one line naming
    the --set item and the form it takes."""
    line = _main_line(capsys, "run", "s.nml", "--set", "scheme.dt", "0.001")
    assert line == ("dyncontact: --set 'scheme.dt': expected group.key=value, one word "
                    "(e.g. --set scheme.dt=0.001)"), line
    line = _main_line(capsys, "run", "s.nml", "--set", "scheme.dt=0.01", "0.001")
    assert line.startswith("dyncontact: unrecognized arguments: 0.001 "), line


# --------------------------------------------------------------------------- outputs

def test_read_trace_drops_a_partial_last_line(tmp_path):
    from dyncontact.core import TRACE_COLUMNS, read_trace

    assert ",".join(TRACE_COLUMNS) == HEADER
    (tmp_path / "trace.csv").write_text(HEADER + "\n" + ",".join(["1.0"] * 12) + "\n"
                                        + "2.0,3.0,4")
    tr = read_trace(tmp_path)
    assert list(tr) == list(TRACE_COLUMNS)
    assert all(v.shape == (1,) and v.dtype == np.float64 for v in tr.values())
    (tmp_path / "trace.csv").write_text(HEADER + "\n")
    assert read_trace(tmp_path)["t"].shape == (0,)
    # A malformed line in the middle: the rows before it (read line by line).
    (tmp_path / "trace.csv").write_text(HEADER + "\n" + ",".join(["1.0"] * 12) + "\n"
                                        + ",".join(["x"] * 12) + "\n"
                                        + ",".join(["2.0"] * 12) + "\n")
    assert read_trace(tmp_path)["t"].tolist() == [1.0]
    # Fortran's non-finite values and signed exponents read as such.
    (tmp_path / "trace.csv").write_text(
        HEADER + "\n" + ",".join(["                     NaN"] * 10 + ["-Infinity"] * 2) + "\n"
        + ",".join(["-0.1234567890123457E-300"] * 12) + "\n")
    tr = read_trace(tmp_path)
    assert np.isnan(tr["t"][0]) and tr["e_load"][0] == -np.inf and tr["f_n"][0] == -np.inf
    assert tr["t"][1] == -0.1234567890123457e-300
    # A trace without the e_load column (older runs) still reads, column by header.
    (tmp_path / "trace.csv").write_text(OLD_HEADER + "\n" + ",".join(["1.0"] * 10) + "\n")
    tr = read_trace(tmp_path)
    assert "e_load" not in tr and tr["active"].shape == (1,)
    # Nor does one without f_n (appended after e_load): the old columns read as before.
    (tmp_path / "trace.csv").write_text(E_LOAD_HEADER + "\n" + ",".join(["1.0"] * 11) + "\n")
    tr = read_trace(tmp_path)
    assert "f_n" not in tr and tr["e_load"].tolist() == [1.0]


def test_readme_and_docs_exist():
    readme = (ROOT / "README.md").read_text()
    for text in ("scripts/demo", "scripts/test", "build/dyncontact", "docs/scenes.md"):
        assert text in readme
    assert (ROOT / "docs" / "scenes.md").is_file()


def test_both_entry_points_record_the_output_folder_as_given(run_cli, run_exe, tmp_path,
                                                             monkeypatch):
    """summary.json's scene.output.dir is the folder as the user gave it, relative or not,
    from the executable, the Python CLI, run() and Stepper alike (the Python side recorded
    the absolute path, the executable the path given)."""
    import dyncontact

    src = (ROOT / "scripts" / "scenes" / "bar1d.nml").read_text(encoding="utf-8")
    (tmp_path / "s.nml").write_text(src.replace("t_end = 6.0", "t_end = 0.01"),
                                    encoding="utf-8")
    assert run_exe("s.nml", "--out", "a").returncode == 0
    assert run_cli("run", "s.nml", "--out", "b", "--quiet").returncode == 0
    monkeypatch.chdir(tmp_path)
    dyncontact.run("s.nml", out="c", progress=False)
    with dyncontact.Stepper("s.nml", "d") as st:
        st.advance(2)
    with pytest.raises(dyncontact.BadInputError, match="out: empty folder name"):
        dyncontact.run("s.nml", out="", progress=False)
    for name in "abcd":
        summary = json.loads((tmp_path / name / "summary.json").read_text(encoding="utf-8"))
        assert summary["scene"]["output"]["dir"] == name, (name, summary["scene"]["output"])
    assert run_exe("s.nml", "--out", str(tmp_path / "e")).returncode == 0
    summary = json.loads((tmp_path / "e" / "summary.json").read_text(encoding="utf-8"))
    assert summary["scene"]["output"]["dir"] == str(tmp_path / "e")


@pytest.mark.parametrize("script, words", [
    ("demo", ["--quick"]), ("setup", ["DYNCONTACT_PYTHON"]),
    ("bench", ["--quick", "--scaling", "--getfem"]), ("figures", ["--workers"]),
    ("studies", ["out/studies", "--workers"]), ("convergence_1d", ["--schemes"]),
    ("test", ["-k", "not slow"]), ("geo_estimate", ["--quick", "--2d"]),
    ("checked", ["--build", "--only", "--python"])])
def test_every_script_answers_help(script, words):
    """`scripts/NAME --help` prints its usage and exits 0, without running anything (no install or
    build by setup, no usage error from demo, no '--out required' from studies);
    bench's help names the modes its wrapper dispatches (--scaling, --getfem)."""
    import subprocess

    from conftest import SUBPROCESS_TIMEOUT
    res = subprocess.run([str(ROOT / "scripts" / script), "--help"], capture_output=True,
                         text=True, timeout=SUBPROCESS_TIMEOUT)
    assert res.returncode == 0, res.stderr
    assert res.stdout.startswith("usage: scripts/"), res.stdout[:200]
    for word in words:
        assert word in res.stdout, (script, word)
    assert "wall time" not in res.stdout + res.stderr
    assert "setup:" not in res.stdout + res.stderr, (script, res.stderr[:200])


@pytest.mark.parametrize("failure", ["newton", "unstable"])
def test_both_entry_points_print_the_same_failure_line(run_cli, run_exe, tmp_path, failure):
    """A numerical failure (exit 3) is the same one line from the executable and the
    Python CLI: the core's message, which gives t and what to check (the Python line
    repeated the status and t before it, and the trace's folder after it)."""
    from dyncontact import Scene

    scn = Scene.read(ROOT / "scripts" / "scenes" / "bar1d.nml")
    if failure == "newton":
        scn.set("scheme.newton_maxit", 1)
        scn.set("scheme.t_end", 3.0)
    else:
        scn.set("scheme.blowup", 1.01)     # any contact error in the energy trips it
        scn.set("scheme.dt", 0.01)
    scn.set("output.dir", "o")
    scn.write(tmp_path / "s.nml")
    exe = run_exe("s.nml")
    cli = run_cli("run", "s.nml", "--out", "o2", "--quiet")
    assert exe.returncode == cli.returncode == 3, (exe.stderr, cli.stderr)
    lines = exe.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("dyncontact: "), exe.stderr
    assert cli.stderr.strip().splitlines() == lines
    assert lines[0].count("at t = ") == 1, lines[0]
