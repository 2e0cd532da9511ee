"""What a batch job script relies on, from both entry points (build/dyncontact and
`python -m dyncontact run`): an output folder that cannot be made says why in one line,
the reason of the folder that failed, not of the ones below it (exit 2 for a bad path,
4 for a read-only file system or one without room)."""
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
    code = 4 if refused.errno in (errno.EROFS, errno.ENOSPC, errno.EDQUOT) else 2
    line = stderr_line(r, code, "dyncontact: ")
    assert line == f"dyncontact: --out {out}: cannot create the folder ({refused.strerror})", \
        line


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
    line = stderr_line(r, 2, "dyncontact: ")
    assert line == (f"dyncontact: {scene}: &output dir: out/run: cannot create the folder "
                    "(Permission denied)"), line


# ------------------------------------------------------- one output folder, several machines

OTHER_BOOT = "11111111-2222-3333-4444-555555555555"


def _boot_id() -> str:
    path = "/proc/sys/kernel/random/boot_id"
    if not os.path.exists(path):
        pytest.skip("no boot id")
    with open(path) as f:
        return f.read().strip()


def _dead_pid() -> int:
    """A pid that no process of this machine has now."""
    pid = 4_000_000
    while True:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return pid
        except PermissionError:
            pass
        pid -= 1


@pytest.mark.parametrize("kind", ["exe", "python"])
def test_lock_of_a_run_on_another_machine_is_held(kind, exe, tmp_path):
    """An output folder on a file system that the nodes of a cluster share: the lock of a
    run on another node (another host name and boot id) names a pid this machine cannot
    check. It is held (exit 2, naming the host and the lock to remove), not taken over as
    a dead pid's: two runs would write into one folder."""
    _boot_id()
    out = tmp_path / "o"
    out.mkdir()
    lock = out / ".dyncontact.lock"
    held = f"{_dead_pid()} 123456 {OTHER_BOOT} node17-of-the-cluster\n"
    lock.write_text(held)
    scene = tmp_path / "s.nml"
    scene.write_text(SCENE)
    r = _run([*_entry(kind, exe), scene, "--out", "o"], tmp_path)
    line = stderr_line(r, 2, "dyncontact: ")
    assert "o: another run (pid" in line and "on host node17-of-the-cluster" in line, line
    assert "remove o/.dyncontact.lock" in line, line
    assert lock.read_text() == held and sorted(os.listdir(out)) == [".dyncontact.lock"]


@pytest.mark.parametrize("where", ["rebooted", "container"])
def test_lock_of_a_dead_run_of_this_machine_is_taken_over(where, exe, tmp_path):
    """A lock of this host written before a reboot (another boot id), or by a container of
    this machine (another host name, the same kernel): its pid is checked here, and a dead
    one is stale as before."""
    import socket

    boot = _boot_id()
    lock_line = (f"{_dead_pid()} 123456 {OTHER_BOOT} {socket.gethostname()}\n"
                 if where == "rebooted" else f"{_dead_pid()} 123456 {boot} a-container\n")
    out = tmp_path / "o"
    out.mkdir()
    (out / ".dyncontact.lock").write_text(lock_line)
    scene = tmp_path / "s.nml"
    scene.write_text(SCENE)
    r = _run([exe, scene, "--out", "o"], tmp_path)
    assert r.returncode == 0, r.stderr
    assert not (out / ".dyncontact.lock").exists()
