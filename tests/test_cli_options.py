"""Option values the command lines refuse up front: one line naming the option, exit 2,
nothing written (`dyncontact study`, scripts/studies, `dyncontact mesh`, scripts/bench),
and the study sweep's progress line (what it counts as taken from the cache)."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

from conftest import ROOT, SUBPROCESS_TIMEOUT, stderr_line


def _script(name: str, *args, cwd) -> subprocess.CompletedProcess:
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    return subprocess.run([str(ROOT / "scripts" / name), *map(str, args)], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=SUBPROCESS_TIMEOUT)


# --------------------------------------------------------------------------- study

@pytest.mark.parametrize("study, option, value", [
    ("convergence", "--c-explicit", "0"),       # not a ZeroDivisionError
    ("convergence", "--c-implicit", "0"),
    ("convergence", "--c-implicit", "-20"),     # one message, not a "run failed" line per run
    ("work-precision", "--c-explicit", "-1"),
    ("convergence", "--t-end", "-1"),
    ("convergence", "--t-end", "0"),
    ("convergence", "--t-end", "nan"),
    ("convergence", "--t-end", "abc"),
    ("convergence", "--schemes", ""),           # not taken as every scheme
    ("convergence", "--schemes", ","),
    ("convergence", "--out", ""),               # not taken as the current folder
    ("convergence", "--workers", "0"),
])
def test_study_refuses_bad_values_naming_the_option(run_cli, tmp_path, study, option,
                                                   value):
    args = ["study", study, "--quick", "--no-progress"]
    if option != "--out":
        args += ["--out", str(tmp_path / "s")]
    line = stderr_line(run_cli(*args, option, value), 2, "dyncontact study: ")
    assert option in line
    assert sorted(os.listdir(tmp_path)) == []   # nothing written, here or in --out


def test_study_help_names_every_study(capsys):
    """`dyncontact study --help` says what it runs: its description named three of the
    five studies (no contact methods, no Hertz), though each is a STUDY it lists."""
    from dyncontact.study.cli import main

    assert main(["--help"]) == 0
    description = capsys.readouterr().out.split("positional arguments")[0]
    for study in ("convergence", "work-precision", "stability", "contact methods", "Hertz",
                  "'all'"):
        assert study in description, (study, description)


@pytest.mark.parametrize("args, command", [
    (("convergence", "--out", "o", "--bogus"), "python -m dyncontact study convergence"),
    (("work-precision", "--bogus", "--out", "o"), "python -m dyncontact study work-precision"),
    (("all", "--out", "o", "extra"), "python -m dyncontact study all"),
])
def test_study_unknown_option_points_to_the_studys_help(capsys, tmp_path, args, command):
    """`dyncontact study convergence --bogus` pointed to `dyncontact study --help`, which
    does not list the study's options: the study's own help is named, in one line, and
    nothing is written."""
    from dyncontact.study.cli import main

    args = [str(tmp_path / a) if a == "o" else a for a in args]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1, err
    assert err.startswith("dyncontact study: unrecognized arguments: "), err
    assert err.strip().endswith(f"(see `{command} --help`)"), err
    assert sorted(os.listdir(tmp_path)) == []


def test_top_level_help_says_what_plot_and_study_do():
    """`dyncontact --help` said that plot writes a PNG (it writes .pdf and .svg too) and
    that study runs three studies (contact methods and Hertz's impact missing)."""
    from dyncontact.cli import PLOT_FORMATS, build_parser

    text = " ".join(build_parser().format_help().split())
    plot = text[text.index(" plot "):text.index(" mesh ")]
    study = text[text.index(" study "):]
    for ext in PLOT_FORMATS:
        assert ext in plot, (ext, plot)
    for name in ("convergence", "work-precision", "stability", "contact methods", "Hertz"):
        assert name in study, (name, study)
    assert "a .geo" in text[text.index(" mesh "):text.index(" study ")]


@pytest.mark.parametrize("option", ["--out", "--cache"])
def test_study_refuses_a_file_for_a_folder(run_cli, tmp_path, option):
    """--out or --cache naming an existing file: one line naming the option, not the
    'File exists' of the folder's creation."""
    afile = tmp_path / "afile"
    afile.write_text("")
    args = {"--out": str(tmp_path / "s"), "--cache": str(tmp_path / "c")}
    args[option] = str(afile)
    line = stderr_line(run_cli("study", "convergence", "--quick", "--no-progress",
                              "--out", args["--out"], "--cache", args["--cache"]),
                      2, "dyncontact study: ")
    assert option in line and "not a folder" in line, line
    assert sorted(os.listdir(tmp_path)) == ["afile"]


@pytest.mark.parametrize("args", [["--out"], ["--out="], ["--out", ""]])
def test_studies_script_out_needs_a_folder(tmp_path, args):
    line = stderr_line(_script("studies", *args, cwd=tmp_path), 2, "studies: ")
    assert "--out" in line and "unbound" not in line
    assert sorted(os.listdir(tmp_path)) == []


def test_sweep_counts_only_real_cache_hits(tmp_path):
    """A task whose scene cannot be built (a bad key value) is an error record, not a run
    taken from the cache."""
    from dyncontact.study.common import write_base_scenes
    from dyncontact.study.sweep import make_task, sweep

    base = write_base_scenes(str(tmp_path / "scenes"))["exact1d"]
    good = make_task(base, {"mesh.h": 0.1, "scheme.dt": 0.005, "scheme.t_end": 0.5},
                     "trace", {"columns": "t,u_n"})
    bad = make_task(base, {"mesh.h": 0.1, "scheme.dt": -1.0}, "trace")
    cache = str(tmp_path / "cache")
    lines: list[str] = []
    recs = sweep([bad, good], cache, workers=1, progress=False, log=lines.append)
    assert [r["status"] for r in recs] == ["error", "ok"]
    assert ("runs: 2 runs, 0 from the cache, 1 to do, 1 whose scene could not be built"
            in lines), lines
    lines.clear()
    recs = sweep([bad, good], cache, workers=1, progress=False, log=lines.append)
    assert [r["cached"] for r in recs] == [False, True]
    assert ("runs: 2 runs, 1 from the cache, 0 to do, 1 whose scene could not be built"
            in lines), lines


# --------------------------------------------------------------------------- mesh

@pytest.mark.parametrize("out, words", [
    ("m.txt", ("--out", ".msh")),                           # not a gmsh traceback (exit 1)
    ("missing/m.msh", ("--out", "no folder missing")),      # not created silently
    ("./", ("--out", ".msh")),
])
def test_mesh_out_is_refused_in_one_line(run_cli, tmp_path, out, words):
    line = stderr_line(run_cli("mesh", "--h", "0.1", "--out", out, cwd=tmp_path), 2,
                      "dyncontact mesh: ")
    for w in words:
        assert w in line, line
    assert sorted(os.listdir(tmp_path)) == []


@pytest.mark.parametrize("link", ["missing/m.msh", "sub/missing/m.msh"])
def test_mesh_out_linking_into_a_missing_folder_is_refused_in_one_line(capsys, tmp_path,
                                                                        monkeypatch, link):
    """`--out LINK.msh` whose target's folder is not there failed at gmsh's write (exit 4)
    while `--out missing/m.msh` says to create the folder (exit 2): the link says the
    same, naming the target and its folder, and is left as it was."""
    from dyncontact.cli import main

    monkeypatch.chdir(tmp_path)
    (tmp_path / "sub").mkdir()
    (tmp_path / "LINK.msh").symlink_to(link)
    assert main(["mesh", "--h", "0.1", "--out", "LINK.msh"]) == 2
    target = tmp_path / link
    assert capsys.readouterr().err == (f"dyncontact mesh: --out LINK.msh: a link to "
                                       f"{target}: no folder {target.parent} (create it "
                                       "first)\n")
    assert (tmp_path / "LINK.msh").readlink() == Path(link)
    assert sorted(os.listdir(tmp_path)) == ["LINK.msh", "sub"]
    assert os.listdir(tmp_path / "sub") == []


#: File-size limit (bytes) of the test below: the mesh at h = 0.02 (250 nodes, ~1000
#: lines of ASCII .msh) is some 20 kB; the limit cuts it short.
MESH_FSIZE_LIMIT = 4096


@pytest.mark.parametrize("where", ["unopenable", "size_limit"])
def test_mesh_that_cannot_be_written_exits_4_naming_the_file(run_cli, tmp_path, where):
    """A mesh file gmsh cannot write is an output that cannot be written: exit 4, as a
    run's trace (docs/scenes.md, *Exit codes*), one line naming the file; not exit 2 (bad
    input). Either gmsh cannot open it (a file under /proc: a folder that exists, where
    no file can be made) or the write is cut short (a file-size limit, as a full disk:
    gmsh reports nothing and leaves a truncated file, which is removed). The Python CLI
    sets the limit after its import (the editable install's rebuild check writes the
    build log); Python ignores SIGXFSZ, so the write fails with EFBIG."""
    import sys

    if where == "unopenable":
        out = "/proc/m.msh"
        res = run_cli("mesh", "--h", "0.1", "--out", out, cwd=tmp_path)
        words = (out, "cannot write")
    else:
        out = str(tmp_path / "m.msh")
        code = ("import resource, sys\nfrom dyncontact.cli import main\n"
                f"resource.setrlimit(resource.RLIMIT_FSIZE, ({MESH_FSIZE_LIMIT}, "
                f"{MESH_FSIZE_LIMIT}))\n"
                f"sys.exit(main(['mesh', '--h', '0.02', '--out', {out!r}]))")
        res = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                             text=True, timeout=SUBPROCESS_TIMEOUT)
        words = (out, "could not write it whole", "File too large")
    line = stderr_line(res, 4, "dyncontact mesh: ")
    for w in words:
        assert w in line, line
    assert sorted(os.listdir(tmp_path)) == []      # no partial mesh left


def test_mesh_the_reader_refuses_is_bad_input_and_left_whole(run_cli, tmp_path):
    """A mesh that gmsh wrote whole but the reader refuses (quadrangles) is bad input,
    not a write cut short: exit 2, and the file is left byte for byte as gmsh writes it
    (the check's probe byte removed again)."""
    from dyncontact import mesh_io

    geo = tmp_path / "quads.geo"
    geo.write_text((ROOT / "meshes" / "bar2d.geo").read_text() + "\nRecombine Surface{1};\n")
    line = stderr_line(run_cli("mesh", "--geo", geo, "--h", "0.05", "--out", "q.msh",
                              cwd=tmp_path), 2, "dyncontact mesh: ")
    assert "not a linear simplex" in line, line
    ref = mesh_io.generate(geo, tmp_path / "ref" / "q.msh", h=0.05)
    assert (tmp_path / "q.msh").read_bytes() == ref.read_bytes()


# --------------------------------------------------------------------------- bench

@pytest.mark.parametrize("args, words", [
    (["--repeat", "0"], ("--repeat", ">= 1")),          # not one run and "ran 0 more times"
    (["--repeat", "-3"], ("--repeat", ">= 1")),
    (["--quick", "--only", "seed_h0.02"],               # not listed as available
     ("seed_h0.02", "--quick", "without --quick")),
    (["--only", "seed_h0.05,nope"], ("--only nope",)),  # nope is not ignored
    (["--only", "seed_h0.05", "--only", "pc_h9*"], ("--only pc_h9*",)),
    (["--out", "missing/dir/x.json"], ("--out", "no folder missing/dir")),   # not created
    (["--out", "./"], ("--out", "folder")),
])
def test_bench_refuses_bad_options_before_running(tmp_path, monkeypatch, capsys, args,
                                                  words):
    from dyncontact.study.bench import bench_main

    monkeypatch.chdir(tmp_path)
    assert bench_main(args, root=str(tmp_path)) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("bench: "), err
    for w in words:
        assert w in err[0], err
    assert sorted(os.listdir(tmp_path)) == []       # no run, no folder


def test_bench_only_rows_of_the_quick_mode_pass_the_check():
    from dyncontact.study.bench import bench_specs, unmatched_only

    assert unmatched_only(True, ["seed_h0.05,pc_*"]) is None
    assert unmatched_only(False, ["seed_h0.02"]) is None
    assert [s.name for s in bench_specs(quick=True, only=["pc_*"])] == [
        "pc_h0.05_consistent", "pc_h0.05_lumped"]


@pytest.mark.parametrize("args, words", [
    (["--sizes", "abc"], ("--sizes", "abc")),          # not a traceback
    (["--sizes", "0"], ("--sizes", "h = 0")),
    (["--sizes", "-0.01"], ("--sizes", "h = -0.01")),
    (["--sizes", "0.01,nan"], ("--sizes", "nan")),
    (["--steps", "0"], ("--steps", ">= 1")),           # wrote inf
    (["--repeats", "0"], ("--repeats", ">= 1")),
    (["--replot", "missing.csv"], ("--replot", "missing.csv")),
])
def test_scaling_refuses_bad_options_in_one_line(tmp_path, monkeypatch, capsys, args, words):
    from dyncontact.study import scaling

    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exc:
        scaling.main([*args, "--out", str(tmp_path / "sc")])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("scripts/bench --scaling: "), err
    for w in words:
        assert w in err[0], err
    assert sorted(os.listdir(tmp_path)) == []


@pytest.mark.parametrize("args, words", [
    (["--steps", "0"], ("--steps", ">= 1")),            # timed nothing
    (["--repeats", "0"], ("--repeats", ">= 1")),        # kept no round
    (["--sizes", "abc"], ("--sizes", "abc")),           # argparse's usage, two lines
    (["--sizes", "0.01,-1"], ("--sizes", "h = -1")),
])
def test_getfem_compare_refuses_bad_options_in_one_line(tmp_path, capsys, args, words):
    from dyncontact.study import getfem_compare

    with pytest.raises(SystemExit) as exc:
        getfem_compare.main([*args, "--out", str(tmp_path / "gf")], root=str(tmp_path))
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("bench --getfem: "), err
    for w in words:
        assert w in err[0], err
    assert sorted(os.listdir(tmp_path)) == []


def test_figures_refuses_an_unknown_option_in_one_line(tmp_path, capsys):
    from dyncontact.study.figures import figures_main

    with pytest.raises(SystemExit) as exc:
        figures_main(["--bogus"], root=str(tmp_path))
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("figures: ") and "--bogus" in err[0], err
