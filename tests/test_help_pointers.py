"""The usage lines and the "see `... --help`" pointers of the Python command line name the
command a user can type, `python -m dyncontact ...`: the program `dyncontact` on a PATH
(`pip install`, build/) is the executable, which runs a scene file and has no `run`,
`mesh` or `study` (`dyncontact mesh --help` prints the executable's usage instead)."""

import re
import shlex

import pytest

COMMAND = "python -m dyncontact"


def _pointer(text: str) -> str:
    found = re.findall(r"see `([^`]*) --help`", text)
    assert found, text
    return found[-1]


@pytest.mark.parametrize("argv", [
    ["run", "s.nml", "--bogus"],
    ["plot", "a", "--out", "x.png", "--bogus"],
    ["mesh", "--bogus"],
    ["study", "convergence", "--out", "o", "--bogus"],
    ["study", "bogus"],
    ["--bogus"],
])
def test_an_error_points_to_a_help_that_runs_as_written(capsys, tmp_path, monkeypatch, argv):
    """The pointer of a bad command line is `python -m dyncontact ... --help`, and that
    command, run as written, prints the usage of the same command."""
    from dyncontact.cli import main

    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1, err
    assert err.startswith("dyncontact"), err        # the messages' prefix is the project's
    pointer = _pointer(err)
    assert pointer.startswith(f"{COMMAND}"), err
    words = shlex.split(pointer)[len(shlex.split(COMMAND)):]
    try:                      # argparse's --help exits; `study` returns the status
        status = main([*words, "--help"])
    except SystemExit as stop:
        status = stop.code
    assert status == 0
    usage = capsys.readouterr().out
    assert usage.startswith(f"usage: {pointer}"), usage[:200]


def test_the_top_level_help_points_to_commands_that_run():
    """`python -m dyncontact --help` says where mesh's and study's options are: in the
    help of `python -m dyncontact mesh` and `... study`."""
    from dyncontact.cli import build_parser

    text = " ".join(build_parser().format_help().split())
    assert text.startswith(f"usage: {COMMAND} "), text[:80]
    pointers = re.findall(r"see `([^`]*) --help`", text)
    assert sorted(pointers) == [f"{COMMAND} mesh", f"{COMMAND} study"], pointers


def test_version_names_the_project(capsys):
    import dyncontact
    from dyncontact.cli import main

    with pytest.raises(SystemExit):
        main(["--version"])
    assert capsys.readouterr().out == f"dyncontact {dyncontact.__version__}\n"


@pytest.mark.parametrize("argv", [["--help"], ["stability", "--help"], ["all", "--help"]])
def test_study_help_gives_the_exit_statuses(capsys, argv):
    """A study whose run fails to run completes and exits 1, which a batch script must
    know: every study's help ends with the exit statuses."""
    from dyncontact.study.cli import main

    assert main(argv) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "Exit status: 0 every run done" in text and "1 some runs failed to run" in text
    assert "130 interrupted" in text, text
