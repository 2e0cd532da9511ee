"""What a batch job script relies on, from both entry points (build/dyncontact and
`python -m dyncontact run`): an output folder that cannot be made says why in one line
(exit 4), the reason of the folder that failed, not of the ones below it."""
from __future__ import annotations

import errno
import os
import sys
import uuid

import pytest

from conftest import _run, stderr_line

SCENE = "&mesh h = 0.1 /\n&scheme dt = 0.01, t_end = 0.02 /\n&output dir = 'out' /\n"


def _entry(kind, exe):
    return [exe] if kind == "exe" else [sys.executable, "-m", "dyncontact", "run"]


def _mkdir_error(path: str) -> OSError:
    """The error mkdir gives for path (the test is skipped where mkdir succeeds)."""
    try:
        os.mkdir(path)
    except OSError as exc:
        return exc
    os.rmdir(path)
    pytest.skip(f"{path} could be made here")


@pytest.mark.parametrize("kind", ["exe", "python"])
def test_output_folder_under_a_parent_that_refuses_says_why(kind, exe, tmp_path):
    """--out PARENT/run/x where PARENT refuses new folders (sysfs: EPERM, or EROFS where it
    is mounted read-only, as a read-only project folder would): the line gives that reason;
    it gave the "No such file or directory" of PARENT/run/x, which hides the cause."""
    top = f"/sys/dyncontact-{uuid.uuid4().hex[:8]}"
    refused = _mkdir_error(top)
    assert refused.errno != errno.ENOENT
    scene = tmp_path / "s.nml"
    scene.write_text(SCENE)
    out = f"{top}/run/x"
    r = _run([*_entry(kind, exe), scene, "--out", out], tmp_path)
    line = stderr_line(r, 4, "dyncontact: ")
    assert line == f"dyncontact: {out}: cannot create folder: {refused.strerror}", line


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write into a read-only folder")
@pytest.mark.parametrize("kind", ["exe", "python"])
def test_relative_output_in_a_read_only_folder_says_why(kind, exe, tmp_path):
    """A job started in a folder it may not write, with the scene's relative &output dir
    'out/run': 'Permission denied', naming the folder."""
    (tmp_path / "ro").mkdir()
    scene = tmp_path / "s.nml"
    scene.write_text(SCENE.replace("'out'", "'out/run'"))
    os.chmod(tmp_path / "ro", 0o555)
    try:
        r = _run([*_entry(kind, exe), scene], tmp_path / "ro")
    finally:
        os.chmod(tmp_path / "ro", 0o755)
    line = stderr_line(r, 4, "dyncontact: ")
    assert line == "dyncontact: out/run: cannot create folder: Permission denied", line
