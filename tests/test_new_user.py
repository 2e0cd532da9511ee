"""What a new user tries, through the executable, the Python CLI and the API: each case
ends either as a correct run or as exit 2 (BadInputError) with one line naming the file
and the key. Cases already covered by test_reliability.py and test_bad_input_cli.py are
not repeated here."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from conftest import gmsh_session, occ_disk, signal_after, write_msh41
from test_reliability import (ENTRIES, EXIT_BAD_INPUT, EXIT_OK, EXIT_WRITE, one_line, run,
                              write_scene)

#: Radius and centre height of the disk; the obstacle is the plane y = 0.
RADIUS = 0.1


def disk_mesh(path: Path, h: float = 0.02, invert_every: int = 0) -> Path:
    """A disk of radius RADIUS centred at (0, RADIUS), meshed by gmsh's Python API, with
    its whole outline as the physical group 'outline' and the surface as 'body'. With
    invert_every = k, every k-th triangle is written with its nodes in clockwise order
    (negative Jacobian), as some mesh tools write them."""
    pytest.importorskip("gmsh")
    with gmsh_session("disk") as gmsh:
        s, arcs = occ_disk(gmsh, RADIUS, h)
        gmsh.model.addPhysicalGroup(1, arcs, 1, "outline")
        gmsh.model.addPhysicalGroup(2, [s], 2, "body")
        gmsh.model.mesh.generate(2)
        if invert_every:
            types, tags, nodes = gmsh.model.mesh.getElements(2, s)
            tri = np.asarray(nodes[0]).reshape(-1, 3)
            tri[::invert_every] = tri[::invert_every, ::-1]
            gmsh.model.mesh.removeElements(2, s)
            gmsh.model.mesh.addElements(2, s, [types[0]], [tags[0]], [tri.ravel()])
        write_msh41(gmsh, path)
    return path


def disk_scene(path: Path, mesh: Path, **over) -> Path:
    """The disk falling onto y = 0 at speed 0.1, nothing clamped, whole outline in contact
    (newmark 1/4 1/2; BASE's keys that this scene does not use are left out: alpha, which
    BASE sets for hht, h, width and length, which a .msh does not use, and amplitude,
    which only kind = 'compressed_bar' uses)."""
    settings = dict(mesh__file=f"'{mesh.name}'", mesh__h=None, mesh__width=None,
                    mesh__length=None, initial__amplitude=None, boundary__clamped="''",
                    boundary__contact="'outline'", initial__kind="'velocity'",
                    initial__velocity="0.0, -0.1", scheme__name="'newmark'",
                    scheme__alpha=None,
                    scheme__dt="0.001", scheme__t_end="0.1", contact__probe="0.0, 0.0")
    settings.update(over)
    return write_scene(path, **settings)


# ------------------------------------------------------------------ 2D disk, closed contact

@pytest.mark.parametrize("kind", ENTRIES)
def test_disk_with_closed_contact_boundary_says_nothing_false(kind, tmp_path):
    """A probe at a negative x is snapped and the note prints its coordinates (a format
    too narrow for a sign printed asterisks); the closed outline gives no warning about
    obstacle_normal, with either sign of it (every closed boundary has facets that face
    the obstacle)."""
    mesh = disk_mesh(tmp_path / "disk.msh")
    a = -2.0   # a point of the true circle with x < 0, below the centre
    probe = np.array([RADIUS * np.cos(a), RADIUS + RADIUS * np.sin(a)])
    # down: the plane y = 0 below; up: the plane y = 1 above (never reached)
    for name, normal, point in (("down", "0.0, -1.0", "0.0, 0.0"), ("up", "0.0, 1.0", "0.0, 1.0")):
        scene = disk_scene(tmp_path / f"{name}.nml", mesh,
                           contact__probe=f"{float(probe[0])!r}, {float(probe[1])!r}",
                           contact__obstacle_normal=normal, contact__obstacle_point=point)
        res = run(kind, scene, "--out", tmp_path / name, cwd=tmp_path)
        assert res.returncode == EXIT_OK, res.stderr
        assert "*" not in res.stderr and "obstacle_normal" not in res.stderr, res.stderr
        note = [ln for ln in res.stderr.splitlines() if "probe snapped to" in ln]
        assert len(note) == 1, res.stderr
        words = note[0].split("snapped to ")[1].replace("(distance ", "").rstrip(")").split()
        x, y, dist = (float(w) for w in words)
        # the nearest point of a chord: inside the circle, within a facet of the probe
        assert x < 0 and math.hypot(x, y - RADIUS) < RADIUS
        assert dist == pytest.approx(math.hypot(x - probe[0], y - probe[1]), rel=1e-3)
        assert 0 < dist < 0.02


@pytest.mark.parametrize("kind", ENTRIES)
def test_open_contact_boundary_facing_away_still_warns(kind, tmp_path):
    """The bar's bottom with obstacle_normal along +y: no facet faces the obstacle; the
    warning says so (the default normal gives none, test_reliability)."""
    scene = write_scene(tmp_path / "s.nml", contact__obstacle_normal="0.0, 1.0",
                        contact__obstacle_point="0.0, -1.0", scheme__t_end="0.05")
    res = run(kind, scene, "--out", tmp_path / "o", cwd=tmp_path)
    assert res.returncode == EXIT_OK, res.stderr
    warn = [ln for ln in res.stderr.splitlines() if "obstacle_normal" in ln]
    assert len(warn) == 1 and "no contact facet faces the obstacle" in warn[0], res.stderr
    assert "-1.000" in warn[0]    # every bottom facet's outward normal is -y


# ------------------------------------------------------------------ inverted cells

def test_gmsh_mesh_with_inverted_cells_runs_like_the_oriented_one(tmp_path):
    """A third of the disk's triangles written clockwise (negative Jacobian): the mesh
    is the same set of cells, so the run gives the same trace (to round-off: the
    element matrices are summed in another order) and the same energy."""
    import dyncontact
    from dyncontact.core import load_mesh

    plain = disk_mesh(tmp_path / "plain.msh")
    inv = disk_mesh(tmp_path / "inv.msh", invert_every=3)
    m = load_mesh(inv)
    tri = m["cells"]
    x = m["x"]
    e1, e2 = x[tri[:, 1]] - x[tri[:, 0]], x[tri[:, 2]] - x[tri[:, 0]]
    d = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]    # twice the signed area
    assert (d < 0).sum() == len(tri[::3]) and (d > 0).sum() == len(tri) - len(tri[::3])
    res = {}
    for name, mesh in (("plain", plain), ("inv", inv)):
        scene = disk_scene(tmp_path / f"{name}.nml", mesh, scheme__t_end="0.2")
        res[name] = dyncontact.run(scene, out=tmp_path / f"o_{name}", progress=False)
        assert res[name].ok
    a, b = res["plain"].trace, res["inv"].trace
    assert min(a["p_n"]) < 0          # the disk has hit the plane (p_n < 0 in contact)
    for col in ("u_n", "v_n", "p_n", "e_total"):
        np.testing.assert_allclose(b[col], a[col], rtol=1e-9, atol=1e-12 * max(abs(a[col])))



# ------------------------------------------------------------------ fields_every = 1

@pytest.mark.parametrize("kind", ENTRIES)
def test_fields_every_1_that_cannot_fit_is_refused_before_writing(kind, tmpfs, tmp_path):
    """The seed run with a snapshot every step: 6001 snapshots of 16.6 kB (102.0 MB with
    the trace) on a 1 MB disk. Refused before anything is written, naming the key and
    saying how much; a previous run's results stay as they were."""
    disk = tmpfs("size=1m")
    out = disk / "o"
    small = write_scene(tmp_path / "small.nml", scheme__t_end="0.05", output__fields_every="5")
    assert run(kind, small, "--out", out, cwd=tmp_path).returncode == EXIT_OK
    before = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    assert len([p for p in before if p.suffix == ".vtu"]) == 5
    scene = write_scene(tmp_path / "s.nml", scheme__t_end="15.0", output__fields_every="1")
    line = one_line(run(kind, scene, "--out", out, cwd=tmp_path), EXIT_BAD_INPUT)
    assert f"{scene}: &output fields_every: the run would write about 102.0 MB" in line
    assert "6001 snapshots of 16.6 kB each" in line and f"but {out} has" in line
    after = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    assert after == before


@pytest.mark.parametrize("kind", ENTRIES)
def test_the_estimate_counts_the_last_steps_snapshot(kind, tmpfs, tmp_path):
    """6000 steps with a snapshot every 7: steps 0, 7, ..., 5999 and the last one, 6000,
    off the grid (858 + 1 snapshots), each counted before the run is refused."""
    disk = tmpfs("size=1m")
    scene = write_scene(tmp_path / "s.nml", scheme__t_end="15.0", output__fields_every="7")
    line = one_line(run(kind, scene, "--out", disk / "o", cwd=tmp_path), EXIT_BAD_INPUT)
    assert "&output fields_every: the run would write about" in line
    assert "859 snapshots of 16.6 kB each" in line, line


def test_fields_every_1_refused_in_python(tmpfs, tmp_path):
    import dyncontact

    disk = tmpfs("size=1m")
    scene = write_scene(tmp_path / "s.nml", scheme__t_end="15.0", output__fields_every="1")
    with pytest.raises(dyncontact.BadInputError, match="&output fields_every: the run would"):
        dyncontact.run(scene, out=disk / "o", progress=False)


@pytest.mark.parametrize("kind", ENTRIES)
def test_more_snapshot_files_than_the_disk_holds_is_refused(kind, tmpfs, tmp_path):
    """Room for the bytes, not for the files: a file system with 64 inodes and a run of
    201 snapshots."""
    disk = tmpfs("size=64m,nr_inodes=64")
    scene = write_scene(tmp_path / "s.nml", scheme__t_end="0.5", output__fields_every="1")
    line = one_line(run(kind, scene, "--out", disk / "o", cwd=tmp_path), EXIT_BAD_INPUT)
    assert "&output fields_every: the run would write 201 snapshot files" in line
    assert "more files" in line


def test_large_field_output_that_fits_is_announced(tmpfs, tmp_path):
    """Above 100 MB of snapshots the run says how much before it starts (as for a large
    trace); it is not refused when the disk has room. Stopped right after the note."""
    import subprocess
    import signal
    import sys

    disk = tmpfs("size=512m")
    scene = write_scene(tmp_path / "s.nml", scheme__t_end="16.0", output__fields_every="1")
    proc = subprocess.Popen([sys.executable, "-m", "dyncontact", "run", str(scene), "--out",
                             str(disk / "o")], cwd=tmp_path, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    with signal_after(proc, signal.SIGINT, timeout=120):
        line = proc.stderr.readline()
    # each snapshot is the size of the first one (same mesh), plus its line in fields.pvd
    first = (disk / "o" / "fields" / "step_0000000.vtu").stat().st_size
    total = 6401 * (first + 100)
    assert f"note: the field snapshots will take about {total / 1e6:.1f} MB (6401 files" \
        in line, line


# ------------------------------------------------------------------ locks after kill -9

def _proc_identity(pid: int) -> str:
    """'STARTTIME BOOT_ID' of a live process, as the core writes it in its lock."""
    stat = Path(f"/proc/{pid}/stat").read_text()
    start = stat[stat.rindex(")") + 2:].split()[19]
    boot = Path("/proc/sys/kernel/random/boot_id").read_text().strip()
    return f"{start} {boot}"


@pytest.mark.parametrize("kind", ENTRIES)
def test_lock_left_by_kill_9_is_taken_over_by_the_next_run(kind, tmp_path):
    """A run killed with SIGKILL leaves its lock (pid, start time, boot id); the next
    run into the folder takes it over, runs, and releases it."""
    import json
    import os
    import signal
    import subprocess
    import time

    if not Path("/proc/self/stat").exists():
        pytest.skip("no /proc")
    out = tmp_path / "o"
    long = write_scene(tmp_path / "long.nml", scheme__t_end="3000.0", output__every="100")
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    from test_reliability import entry
    proc = subprocess.Popen(entry(kind) + [str(long), "--out", str(out)], cwd=tmp_path,
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    lock = out / ".dyncontact.lock"
    t0 = time.time()
    while not (lock.exists() and lock.read_text().endswith("\n")):
        assert time.time() - t0 < 60 and proc.poll() is None, "the run did not start"
        time.sleep(0.01)
    import socket
    assert lock.read_text() == f"{proc.pid} {_proc_identity(proc.pid)} {socket.gethostname()}\n"
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=60)
    assert lock.exists()                       # left behind
    scene = write_scene(tmp_path / "s.nml", scheme__t_end="0.1")
    res = run(kind, scene, "--out", out, cwd=tmp_path)
    assert res.returncode == EXIT_OK, res.stderr
    assert not lock.exists()
    assert json.loads((out / "summary.json").read_text())["status"] == "ok"


@pytest.mark.parametrize("kind", ENTRIES)
def test_lock_whose_pid_was_reused_is_taken_over(kind, tmp_path):
    """After a kill -9 (or a reboot) the lock's pid may belong to another live process:
    the start time or boot id recorded in the lock tells them apart. A lock naming a live
    process with its own start time and boot id is held (exit 2, pid named)."""
    import subprocess
    import sys

    if not Path("/proc/self/stat").exists():
        pytest.skip("no /proc")
    other = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(120)"])
    try:
        start, boot = _proc_identity(other.pid).split()
        scene = write_scene(tmp_path / "s.nml", scheme__t_end="0.1")
        for name, content in (("start", f"{other.pid} {int(start) - 1} {boot}\n"),
                              ("boot", f"{other.pid} {start} 00000000-0000-0000-0000-0\n")):
            out = tmp_path / name
            out.mkdir()
            (out / ".dyncontact.lock").write_text(content)
            res = run(kind, scene, "--out", out, cwd=tmp_path)
            assert res.returncode == EXIT_OK, (name, res.stderr)
            assert not (out / ".dyncontact.lock").exists()
        out = tmp_path / "held"
        out.mkdir()
        (out / ".dyncontact.lock").write_text(f"{other.pid} {start} {boot}\n")
        line = one_line(run(kind, scene, "--out", out, cwd=tmp_path), EXIT_BAD_INPUT)
        assert "another run" in line and str(other.pid) in line
        assert not (out / "trace.csv").exists()
    finally:
        other.kill()
        other.wait()


# ------------------------------------------------------------------ threads, Dask

def _scenes(tmp_path, t_end="2.0"):
    return [write_scene(tmp_path / f"{name}.nml", scheme__name=f"'{name}'", scheme__t_end=t_end,
                        scheme__alpha=alpha)   # None: BASE's alpha (hht's) left out
            for name, alpha in (("newmark", None), ("hht", "-0.1"))]


def test_two_python_threads_run_scenes_like_one_after_the_other(tmp_path):
    """Two threads of one process, two scenes, two folders: each trace is the serial
    run's, bit for bit (the core keeps no module state). Into one folder: one run holds
    the lock, the other is refused with BadInputError naming the folder."""
    import threading

    import dyncontact

    scenes = _scenes(tmp_path)
    ref = [dyncontact.run(s, out=tmp_path / f"ref{k}", progress=False).trace
           for k, s in enumerate(scenes)]
    got, errors = [None, None], []

    def go(k, out):
        try:
            got[k] = dyncontact.run(scenes[k], out=out, progress=False)
        except Exception as e:            # noqa: BLE001 - reported below
            errors.append(e)

    threads = [threading.Thread(target=go, args=(k, tmp_path / f"t{k}")) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(120)
    assert not errors, errors
    for k in range(2):
        assert got[k].ok and set(got[k].trace) == set(ref[k])
        for col in ref[k]:
            np.testing.assert_array_equal(got[k].trace[col], ref[k][col])
    # one folder: long runs (60 000 steps), started together
    long = _scenes(tmp_path, t_end="150.0")
    got, errors = [None, None], []
    scenes[:] = long
    threads = [threading.Thread(target=go, args=(k, tmp_path / "same")) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(300)
    assert len(errors) == 1 and isinstance(errors[0], dyncontact.BadInputError), errors
    assert f"{tmp_path / 'same'}: another run" in str(errors[0])
    assert sum(r is not None and r.ok for r in got) == 1
    assert not (tmp_path / "same" / ".dyncontact.lock").exists()


def test_run_inside_a_dask_worker(tmp_path):
    """dyncontact.run as a task of a one-worker LocalCluster (threads of this process):
    the trace is the serial run's; bad input reaches the client as BadInputError with
    the core's one-line message."""
    distributed = pytest.importorskip("distributed")
    import dyncontact

    scene = _scenes(tmp_path)[0]
    bad = tmp_path / "bad.nml"
    bad.write_text("&scheme dt = nan /\n")
    ref = dyncontact.run(scene, out=tmp_path / "ref", progress=False).trace

    def task(path, out):
        return dyncontact.run(path, out=out, progress=False).trace

    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=":0") as cluster, \
            distributed.Client(cluster) as client:
        trace = client.submit(task, str(scene), str(tmp_path / "dask"), pure=False) \
            .result(timeout=120)
        with pytest.raises(dyncontact.BadInputError,
                           match="^" + re.escape(f"{bad}: &scheme dt: expected a real number "
                                                 "(got 'nan')") + "$"):
            client.submit(task, str(bad), str(tmp_path / "bad"), pure=False).result(timeout=120)
    for col in ref:
        np.testing.assert_array_equal(trace[col], ref[col])
    assert not (tmp_path / "bad" / "trace.csv").exists()


# ------------------------------------------------------------------ empty contact group

@pytest.mark.parametrize("kind", ENTRIES)
def test_empty_or_wrong_dimension_contact_group_is_refused(kind, tmp_path):
    """A contact group with no facets: declared in $PhysicalNames without elements (as
    a mesh tool leaves a group it emptied), or the body's surface group named as the
    contact boundary. One line naming &boundary contact, the group and the mesh."""
    mesh = disk_mesh(tmp_path / "disk.msh")
    text = mesh.read_text()
    head = '$PhysicalNames\n2\n1 1 "outline"\n2 2 "body"\n'
    assert head in text
    (tmp_path / "rim.msh").write_text(text.replace(
        head, '$PhysicalNames\n3\n1 1 "outline"\n2 2 "body"\n1 7 "rim"\n'))
    # gmsh reports no physical group without entities: the emptied group is not in the mesh
    for mesh_name, group, what in (("rim.msh", "rim", "not in mesh"),
                                   ("disk.msh", "body", "has no facets")):
        scene = disk_scene(tmp_path / f"{group}.nml", tmp_path / mesh_name,
                           boundary__contact=f"'{group}'")
        line = one_line(run(kind, scene, "--out", tmp_path / "o", cwd=tmp_path),
                        EXIT_BAD_INPUT)
        assert f"{scene}: &boundary contact: group '{group}' {what}" in line, line
        assert mesh_name in line
        assert not (tmp_path / "o" / "trace.csv").exists()
    # the same empty group, clamped: named as such
    scene = disk_scene(tmp_path / "clamped.nml", tmp_path / "rim.msh",
                       boundary__clamped="'rim'")
    line = one_line(run(kind, scene, "--out", tmp_path / "o", cwd=tmp_path), EXIT_BAD_INPUT)
    assert "&boundary clamped: group 'rim' not in mesh" in line


def test_repeated_contact_group_counts_each_facet_once(tmp_path):
    """contact = 'outline, outline' is the outline once: the same trace."""
    import dyncontact

    mesh = disk_mesh(tmp_path / "disk.msh")
    tr = [dyncontact.run(disk_scene(tmp_path / f"{k}.nml", mesh, boundary__contact=c),
                         out=tmp_path / f"o{k}", progress=False).trace
          for k, c in enumerate(("'outline'", "'outline, outline'"))]
    assert min(tr[0]["p_n"]) < 0
    for col in tr[0]:
        np.testing.assert_array_equal(tr[1][col], tr[0][col])


# ------------------------------------------------------------------ non-UTF-8 file names

@pytest.mark.parametrize("kind", ENTRIES)
def test_output_folder_named_in_latin1_bytes(kind, tmp_path):
    """A folder name that is not UTF-8 (b'r\\xe9s', as a Latin-1 system writes it) given
    with --out: the run is correct, summary.json stays UTF-8 JSON (the byte is written as
    \\udce9, Python's surrogate for it) and its dir names the folder exactly."""
    import json
    import os

    scene = write_scene(tmp_path / "s.nml", scheme__t_end="0.05")
    out = os.fsencode(str(tmp_path)) + b"/r\xe9s"
    import subprocess

    from test_reliability import entry

    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    # bytes out: the executable prints the folder's name as it is
    res = subprocess.run(entry(kind) + [str(scene), "--out", os.fsdecode(out)], cwd=tmp_path,
                         env=env, capture_output=True, timeout=120)
    assert res.returncode == EXIT_OK, res.stderr
    assert b"Traceback" not in res.stderr
    raw = (Path(os.fsdecode(out)) / "summary.json").read_bytes()
    summary = json.loads(raw.decode("utf-8"))         # strict UTF-8
    assert b"\\udcE9" in raw or b"\\udce9" in raw
    assert os.fsencode(summary["scene"]["output"]["dir"]) == out
    assert summary["status"] == "ok"


# ------------------------------------------------------------------ a scene of one's own

@pytest.mark.parametrize("kind", ENTRIES)
def test_group_not_in_mesh_lists_the_mesh_groups(kind, tmp_path):
    """A scene for one's own mesh that keeps the default clamped = 'top' (the bar's group)
    or names a group the mesh lacks: the one line also lists the mesh's groups, so that
    it says which names to use; the built-in bar lists its own, a mesh without physical
    groups says it has none."""
    mesh = disk_mesh(tmp_path / "disk.msh")
    scene = disk_scene(tmp_path / "top.nml", mesh, boundary__clamped="'top'")
    line = one_line(run(kind, scene, "--out", tmp_path / "o", cwd=tmp_path), EXIT_BAD_INPUT)
    assert ("&boundary clamped: group 'top' not in mesh, whose groups are 'outline', "
            "'body' (mesh '") in line and line.endswith("disk.msh')"), line
    scene = write_scene(tmp_path / "bar.nml", boundary__contact="'base'")
    line = one_line(run(kind, scene, "--out", tmp_path / "o", cwd=tmp_path), EXIT_BAD_INPUT)
    assert ("&boundary contact: group 'base' not in mesh, whose groups are 'bottom', 'top', "
            "'left', 'right', 'body' (the built-in bar)") in line, line
    (tmp_path / "bare.geo").write_text(
        "Point(1) = {0, 0, 0, 0.05}; Point(2) = {0.1, 0, 0, 0.05};\n"
        "Point(3) = {0, 0.1, 0, 0.05}; Line(1) = {1, 2}; Line(2) = {2, 3};\n"
        "Line(3) = {3, 1}; Curve Loop(1) = {1, 2, 3}; Plane Surface(1) = {1};\n")
    scene = write_scene(tmp_path / "bare.nml", mesh__file="'bare.geo'",
                        boundary__clamped="''", boundary__contact="'bottom'")
    line = one_line(run(kind, scene, "--out", tmp_path / "o", cwd=tmp_path), EXIT_BAD_INPUT)
    assert "group 'bottom' not in mesh, which has no groups (mesh '" in line, line
    assert line.endswith("bare.geo')"), line


@pytest.mark.parametrize("kind", ENTRIES)
def test_probe_left_out_on_a_mesh_of_ones_own_says_it_is_the_bars_default(kind, tmp_path):
    """A scene for one's own mesh that does not give &contact probe takes the default of
    its dimension, the middle of the built-in bar's bottom (0.05, 0), 0.012 from the disk
    here (h = 0.01: the probe snaps within 0.005): the one line says that the scene does not give the key and what to give, rather
    than only that "the point" is not on the contact boundary. A probe given far off gets
    the error alone."""
    mesh = disk_mesh(tmp_path / "disk.msh", h=0.01)
    scene = disk_scene(tmp_path / "noprobe.nml", mesh, contact__probe=None)
    line = one_line(run(kind, scene, "--out", tmp_path / "o", cwd=tmp_path), EXIT_BAD_INPUT)
    # the circle is 0.0118 from (0.05, 0); its chords lie inside it, by at most h²/(8 R)
    found = re.search(r"&contact probe: the point is not on the contact boundary: "
                      r"distance (\S+) to its nearest point", line)
    assert found and 0.01180 <= float(found[1]) <= 0.01180 + 0.01**2 / (8 * RADIUS), line
    assert line.endswith("the scene does not give &contact probe, whose default is the "
                         "middle of the built-in bar's bottom: give a point of the contact "
                         "boundary, such as that nearest point"), line
    scene = disk_scene(tmp_path / "far.nml", mesh, contact__probe="0.3, 0.3")
    line = one_line(run(kind, scene, "--out", tmp_path / "o", cwd=tmp_path), EXIT_BAD_INPUT)
    assert "&contact probe: the point is not on the contact boundary" in line, line
    assert "does not give" not in line, line


@pytest.mark.parametrize("kind", ENTRIES)
def test_velocity_without_kind_velocity_warns(kind, tmp_path):
    """&initial velocity given while kind keeps its default 'compressed_bar' (or is
    'rest'): the velocity is not used and the run says so before it starts, naming the
    state it starts from and the kind that would use it. kind = 'velocity', or a zero
    velocity, says nothing."""
    mesh = disk_mesh(tmp_path / "disk.msh")
    cases = {"default": ("compressed_bar", dict(initial__kind="'compressed_bar'")),
             "rest": ("rest", dict(initial__kind="'rest'"))}
    for name, (shown, over) in cases.items():
        scene = disk_scene(tmp_path / f"{name}.nml", mesh, **over)
        res = run(kind, scene, "--out", tmp_path / name, cwd=tmp_path)
        assert res.returncode == EXIT_OK, res.stderr
        assert (f"dyncontact: warning: &initial velocity is not used with kind = '{shown}': "
                "the run starts at rest") in res.stderr, res.stderr
        assert "kind = 'velocity' starts with that velocity" in res.stderr
    for name, over in (("velocity", {}),
                       ("zero", dict(initial__kind="'rest'", initial__velocity="0.0, 0.0"))):
        scene = disk_scene(tmp_path / f"{name}.nml", mesh, **over)
        res = run(kind, scene, "--out", tmp_path / name, cwd=tmp_path)
        assert res.returncode == EXIT_OK and "&initial velocity" not in res.stderr, res.stderr


def test_mesh_h_with_a_msh_file_is_noted_as_unused(tmp_path):
    """&mesh h given with a .msh file (a user refining the mesh by h): the file's mesh is
    used as it is, and the run says so before it starts, with the command that writes
    a .msh of that size; h written at its default value too (it is what the user wrote).
    h not given, or h with a .geo (which it sizes), says nothing."""
    import warnings

    import dyncontact
    from dyncontact.core import DyncontactWarning

    mesh = disk_mesh(tmp_path / "disk.msh")
    geo = tmp_path / "tri.geo"
    geo.write_text("Point(1) = {-0.1, 0, 0, h}; Point(2) = {0.1, 0, 0, h};\n"
                   "Point(3) = {0, 0.1, 0, h}; Line(1) = {1, 2}; Line(2) = {2, 3};\n"
                   "Line(3) = {3, 1}; Curve Loop(1) = {1, 2, 3}; Plane Surface(1) = {1};\n"
                   'Physical Curve("outline") = {1, 2, 3}; Physical Surface("body") = {1};\n')
    notes = {}
    for name, file, h in (("msh_h", mesh, "0.01"), ("msh_default", mesh, "0.05"),
                          ("msh", mesh, None), ("geo_h", geo, "0.02")):
        scene = disk_scene(tmp_path / f"{name}.nml", file, mesh__h=h, scheme__t_end="0.01")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            res = dyncontact.run(scene, out=tmp_path / name, progress=False)
        assert res.status == "ok"
        notes[name] = [str(w.message) for w in caught if w.category is DyncontactWarning
                       and "&mesh h" in str(w.message)]
    assert notes["msh_h"] == ["note: &mesh h = 1.0E-002 is not used: a .msh file is meshed "
                              "already (h sizes a .geo and the built-in bar; python -m "
                              "dyncontact mesh --geo FILE.geo --h H writes a .msh of size H)"]
    assert notes["msh_default"] == [notes["msh_h"][0].replace("1.0E-002", "5.0E-002")]
    assert notes["msh"] == [] and notes["geo_h"] == []


@pytest.mark.parametrize("kind", ENTRIES)
def test_mesh_sizes_and_amplitude_that_change_nothing_are_noted(kind, tmp_path):
    """&mesh width and length given with a .msh file size nothing (length still sets the
    compressed bar's lift), and &initial amplitude lifts only kind = 'compressed_bar':
    given, whatever their values, the run says so, one line each; not given, or used,
    nothing."""
    mesh = disk_mesh(tmp_path / "disk.msh")
    note = ("dyncontact: note: &mesh {}: not used with a .msh file, which is meshed already "
            "(they size a .geo and the built-in bar)")
    amp = ("dyncontact: warning: &initial amplitude is not used with kind = '{}' (it lifts "
           "the 'compressed_bar' state; docs/scenes.md, &initial)")
    cases = {
        "width": (dict(mesh__width="0.1"), [note.format("width")]),
        "both": (dict(mesh__width="0.2", mesh__length="1.0"), [note.format("width, length")]),
        "length_used": (dict(mesh__length="1.0", initial__kind="'compressed_bar'",
                             initial__velocity=None), []),
        "amplitude": (dict(initial__amplitude="0.5"), [amp.format("velocity")]),
        "amplitude_rest": (dict(initial__amplitude="0.0", initial__kind="'rest'",
                                initial__velocity=None), [amp.format("rest")]),
        "amplitude_used": (dict(initial__amplitude="0.1", initial__kind="'compressed_bar'",
                                initial__velocity=None), []),
        "none": ({}, []),
    }
    for name, (over, expected) in cases.items():
        scene = disk_scene(tmp_path / f"{name}.nml", mesh, scheme__t_end="0.01", **over)
        res = run(kind, scene, "--out", tmp_path / name, cwd=tmp_path)
        assert res.returncode == EXIT_OK, res.stderr
        assert res.stderr.splitlines() == expected, (name, res.stderr)


# ------------------------------------------------------------------ physics a user checks

def test_free_fall_reaches_the_obstacle_when_the_formula_says(tmp_path):
    """The disk at rest, gravity g = 1 toward the obstacle 0.0201 below its lowest node:
    the trapezoidal rule integrates the constant acceleration exactly (the consistent
    mass times the uniform g is the load), so in flight u_n = g t^2 / 2 and v_n = g t at
    the probe to round-off, the body stays unstrained (e_el = 0) and
    e_total + e_load = 0; the first step with a contact point is the first one past
    t = sqrt(2 d / g) = 0.2005 (t = 0.21 at dt = 0.01)."""
    import dyncontact

    gap, g, dt = 0.0201, 1.0, 0.01
    mesh = disk_mesh(tmp_path / "disk.msh")
    scene = disk_scene(tmp_path / "fall.nml", mesh, initial__kind="'rest'",
                       initial__velocity="0.0, 0.0", material__gravity=f"0.0, {-g}", contact__obstacle_point=f"0.0, {-gap}",
                       scheme__dt=f"{dt}", scheme__t_end="0.3")
    tr = dyncontact.run(scene, out=tmp_path / "o", progress=False).trace
    t = tr["t"]
    first = int(np.argmax(tr["active"] > 0))
    assert t[first] == pytest.approx(dt * math.ceil(math.sqrt(2 * gap / g) / dt), abs=1e-12)
    assert t[first - 1] < math.sqrt(2 * gap / g) < t[first]
    fly = slice(0, first)
    # round-off: a few eps of the values (u_n ~ 0.02, v_n ~ 0.2, energies ~ 6e-4)
    np.testing.assert_allclose(tr["u_n"][fly], 0.5 * g * t[fly] ** 2, rtol=0, atol=1e-15)
    np.testing.assert_allclose(tr["v_n"][fly], g * t[fly], rtol=0, atol=1e-14)
    scale = np.abs(tr["e_load"][fly]).max()
    assert scale > 1e-4
    assert np.abs(tr["e_el"][fly]).max() <= 1e-12 * scale
    assert np.abs(tr["e_total"][fly] + tr["e_load"][fly]).max() <= 1e-12 * scale
    assert np.all(tr["p_n"][fly] == 0) and np.any(tr["p_n"][first:] < 0)


def _rotated_disk(path: Path, angle: float) -> Path:
    """disk_mesh's mesh (h = 0.02) with every node turned by `angle` about the origin."""
    with gmsh_session("disk") as gmsh:
        s, arcs = occ_disk(gmsh, RADIUS, 0.02)
        gmsh.model.addPhysicalGroup(1, arcs, 1, "outline")
        gmsh.model.addPhysicalGroup(2, [s], 2, "body")
        gmsh.model.mesh.generate(2)
        tags, xyz, _ = gmsh.model.mesh.getNodes()
        c, si = math.cos(angle), math.sin(angle)
        for tag, (x, y, z) in zip(tags, np.asarray(xyz).reshape(-1, 3)):
            gmsh.model.mesh.setNode(int(tag), [c * x - si * y, si * x + c * y, z], [])
        write_msh41(gmsh, path)
    return path


def test_rotated_scene_gives_the_same_trace(tmp_path):
    """The disk thrown obliquely at the plane under gravity, and the same scene turned by
    30 degrees (mesh nodes, obstacle point and normal, gravity, velocity, probe): the
    traces (scalars: normal components and energies) are equal to round-off, through the
    impact. The built-in meshes are axis-aligned; tests/fortran/test_rotation3d does the
    same for the 3D kernels."""
    import dyncontact

    traces = []
    for angle in (0.0, math.radians(30.0)):
        rot = np.array([[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]])

        def vec(v, rot=rot):
            return ", ".join(repr(float(x)) for x in rot @ np.asarray(v))

        mesh = _rotated_disk(tmp_path / f"disk{angle:.2f}.msh", angle)
        scene = disk_scene(tmp_path / f"s{angle:.2f}.nml", mesh,
                           initial__velocity=vec([0.05, -0.2]), material__gravity=vec([0, -1.0]),
                           contact__obstacle_normal=vec([0, -1.0]),
                           contact__obstacle_point=vec([0, -0.005]),
                           contact__probe=vec([0, 0]), scheme__t_end="0.15")
        traces.append(dyncontact.run(scene, out=tmp_path / f"o{angle:.2f}",
                                     progress=False).trace)
    a, b = traces
    assert np.max(a["active"]) > 0 and np.min(a["p_n"]) < 0    # through an impact
    np.testing.assert_array_equal(a["active"], b["active"])
    for col in ("u_n", "v_n", "p_n", "e_kin", "e_el", "e_contact", "e_total", "e_load"):
        # the rounding of the turned coordinates (an eps each) carried through 150 steps
        # and their Newton solves: measured at most 5e-13 of the column's largest value
        # (e_contact, a difference of squares); 1e-11 leaves a factor 20
        np.testing.assert_allclose(b[col], a[col], rtol=0, atol=1e-11 * np.abs(a[col]).max(),
                                   err_msg=col)


def test_contact_impulse_is_the_momentum_change_normal_to_a_tilted_plane(tmp_path):
    """A cylinder of one's own .geo (OpenCASCADE, h = 0.06) thrown without gravity at a
    plane tilted 11 degrees, nothing clamped, the trapezoidal rule: the total momentum
    sum(M v) changes only through the contact force F (B(u) - K_theta u summed by
    component; the elastic part sums to zero on a free body), so after the impact
    Delta P = trapezoidal integral of F dt to round-off, and Delta P is along the
    obstacle normal (frictionless: the tangential momentum is kept). newton_tol = 1e-14
    makes the balance of each step exact to round-off."""
    import dyncontact
    from dyncontact.core import Stepper

    pytest.importorskip("gmsh")
    (tmp_path / "cyl.geo").write_text(
        'SetFactory("OpenCASCADE");\n'
        "Cylinder(1) = {0, 0, 0.05, 0, 0, 0.2, 0.1};\n"
        "MeshSize{ PointsOf{ Volume{1}; } } = h;\nMesh.MeshSizeMax = h;\n"
        'Physical Surface("lateral") = {1};\nPhysical Surface("lid") = {2};\n'
        'Physical Surface("sole") = {3};\nPhysical Volume("steel") = {1};\n')
    normal = np.array([0.2, 0.0, -1.0]) / math.hypot(0.2, 1.0)
    scene = tmp_path / "cyl.nml"
    scene.write_text(
        "&mesh file = 'cyl.geo', h = 0.06 /\n&boundary clamped = '', contact = 'sole' /\n"
        "&material young = 1.0, poisson = 0.3 /\n"
        "&contact obstacle_point = 0.0, 0.0, 0.0, obstacle_normal = 0.2, 0.0, -1.0,\n"
        "         probe = 0.1, 0.0, 0.05 /\n"
        "&initial kind = 'velocity', velocity = 0.05, 0.02, -0.3 /\n"
        "&scheme name = 'newmark', dt = 0.01, t_end = 0.8, newton_tol = 1e-14 /\n")
    times, momentum, force = [], [], []
    with Stepper(dyncontact.Scene.read(scene), tmp_path / "o") as st:
        _node, comp = st.dof_map()
        k_theta = st.matrix("K_theta")
        while True:
            x = st.state()
            f = x["bu"] - k_theta @ x["u"]
            times.append(x["t"])
            momentum.append([x["mv"][comp == c].sum() for c in range(3)])
            force.append([-f[comp == c].sum() for c in range(3)])
            if st.finished:
                break
            st.advance(1)
    tr = dyncontact.core.read_trace(tmp_path / "o")
    assert tr["active"][0] == 0 and tr["active"][-1] == 0 and tr["active"].max() > 0
    dp = np.subtract(momentum[-1], momentum[0])
    impulse = np.trapezoid(np.asarray(force), np.asarray(times), axis=0)
    # each step's balance holds to newton_tol = 1e-14 (below round-off) and the sums run
    # over ~250 dofs and 80 steps: measured 1.3e-14 of |Delta P|; 1e-12 leaves room
    np.testing.assert_allclose(impulse, dp, rtol=0, atol=1e-12 * np.linalg.norm(dp))
    assert np.linalg.norm(np.cross(dp, normal)) <= 1e-12 * np.linalg.norm(dp)
    assert dp @ normal < 0            # pushed back out of the obstacle


@pytest.mark.parametrize("kind", ENTRIES)
def test_a_missing_mesh_beside_a_scene_elsewhere_says_where_it_looked(kind, tmp_path):
    """A scene in a sub-folder naming a mesh file that is not there is told that a
    relative path counts from the scene file's folder (not `in the current folder`, which
    would read as if the path were the user's); a scene in the current folder is told `in
    the current folder`."""
    (tmp_path / "sub").mkdir()
    for scene in (tmp_path / "sub" / "s.nml", tmp_path / "s.nml"):
        scene.write_text("&mesh file = 'm.msh' /\n")
    line = one_line(run(kind, "sub/s.nml", "--out", "o", cwd=tmp_path), EXIT_BAD_INPUT)
    assert line == ("dyncontact: sub/s.nml: &mesh file: cannot read mesh file 'sub/m.msh' (a "
                    "relative path counts from the scene file's folder) (got 'm.msh')"), line
    line = one_line(run(kind, "s.nml", "--out", "o", cwd=tmp_path), EXIT_BAD_INPUT)
    assert line == ("dyncontact: s.nml: &mesh file: cannot read mesh file 'm.msh' in the "
                    "current folder (got 'm.msh')"), line
    assert not (tmp_path / "o").exists()


def test_set_mesh_file_counts_from_the_current_folder(run_cli, tmp_path):
    """--set mesh.file=disk.msh, the very text of the scene's own relative mesh file,
    run from another folder than the scene's: the value counts from the current folder,
    unlike the same path in the file, and the message says where it looked; from the
    scene's folder the same command runs."""
    folder = tmp_path / "work"
    folder.mkdir()
    mesh = disk_mesh(folder / "disk.msh")
    scene = disk_scene(folder / "s.nml", mesh)        # mesh file = 'disk.msh' in it
    args = ("run", scene, "--set", "mesh.file=disk.msh", "--out", "o", "--quiet")
    r = run_cli(*args, cwd=tmp_path)
    assert r.returncode == EXIT_BAD_INPUT
    assert ("&mesh file: cannot read mesh file 'disk.msh' in the current folder "
            "(got 'disk.msh')") in r.stderr, r.stderr
    r = run_cli(*args, cwd=folder)
    assert r.returncode == EXIT_OK, r.stderr


@pytest.mark.parametrize("kind", ENTRIES)
def test_scheme_keys_the_scheme_does_not_use_warn(kind, tmp_path):
    """&scheme keys given for another scheme than the one chosen change nothing: hht
    takes beta and gamma from alpha, newmark has no alpha, central none of them. The run
    says which keys it does not use and which it does, whatever their values (beta =
    0.25, its default, with hht included: the user wrote it); the keys of the scheme
    itself, and the others left out, say nothing."""
    cases = {
        "default": (dict(scheme__beta="0.25"),
                    "&scheme beta: not used by scheme 'hht' (it uses alpha;"),
        "hht": (dict(scheme__beta="0.3025", scheme__gamma="0.6"),
                "&scheme beta, gamma: not used by scheme 'hht' (it uses alpha;"),
        "newmark": (dict(scheme__name="'newmark'", scheme__theta="0.7"),
                    "&scheme alpha, theta: not used by scheme 'newmark' (it uses beta, gamma;"),
        "central": (dict(scheme__name="'central'", scheme__dt="0", scheme__rho_inf="0.5"),
                    "&scheme alpha, rho_inf: not used by scheme 'central' (it uses none of them;"),
        "quiet": (dict(scheme__name="'galpha'", scheme__alpha=None, scheme__rho_inf="0.8"),
                  None),
    }
    for name, (over, warning) in cases.items():
        scene = write_scene(tmp_path / f"{name}.nml", scheme__t_end="0.01", **over)
        res = run(kind, scene, "--out", tmp_path / name, cwd=tmp_path)
        assert res.returncode == EXIT_OK, res.stderr
        if warning is None:
            assert "not used by scheme" not in res.stderr, res.stderr
        else:
            assert f"dyncontact: warning: {warning} docs/scenes.md, &scheme)" in res.stderr, \
                res.stderr


def test_alm_without_the_redistributed_mass_warns(tmp_path):
    """&contact method = 'alm' keeps the default consistent mass (or takes the lumped
    one): docs/numerics.md says never to (the multipliers chatter and the energy grows
    several-fold). The run says so before it starts; with the redistributed mass, or
    with Nitsche, it says nothing."""
    import warnings

    import dyncontact
    from dyncontact.core import DyncontactWarning

    def notes(**over):
        scene = write_scene(tmp_path / "s.nml", scheme__name="'newmark'", scheme__alpha=None,
                            contact__theta=None,
                            scheme__t_end="0.01", **over)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            assert dyncontact.run(scene, out=tmp_path / "o", progress=False).ok
        return [str(w.message) for w in caught if w.category is DyncontactWarning]

    for mass in ("consistent", "lumped"):
        assert notes(contact__method="'alm'", scheme__mass=f"'{mass}'") == [
            f"warning: &contact method = 'alm' with &scheme mass = '{mass}': the multipliers "
            "chatter at the impacts and the energy grows several-fold (most runs blow up); "
            "use mass = 'redistributed' (docs/numerics.md, \"Which method, with which mass\")"]
    assert notes(contact__method="'alm'", scheme__mass="'redistributed'") == []
    assert notes(scheme__mass="'consistent'") == []


def test_contact_boundary_starting_inside_the_obstacle_warns(tmp_path):
    """The obstacle point put 0.01 above the disk's lowest node (a sign slip): the run
    says the contact boundary starts inside the obstacle, with the deepest gap and its
    node, before the contact throws the disk out. The disk touching the plane at one
    node (a gap of 0 to round-off), and the seed bar, say nothing; an obstacle normal
    into the body gets its own warning alone (the normal is what to fix)."""
    import warnings

    import dyncontact
    from dyncontact.core import DyncontactWarning

    mesh = disk_mesh(tmp_path / "disk.msh")

    def notes(scene):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            dyncontact.run(scene, out=tmp_path / "o", progress=False)
        return [str(w.message) for w in caught if w.category is DyncontactWarning]

    inside = notes(disk_scene(tmp_path / "in.nml", mesh, contact__obstacle_point="0.0, 0.01"))
    assert len(inside) == 1 and re.fullmatch(
        r"warning: the contact boundary starts inside the obstacle: initial gap -1\.000E-002 "
        r"at the node -?\d\.\d{5}E-0(17|00) 0\.00000E\+000 \(check &contact obstacle_point "
        r"and obstacle_normal: the contact pushes it out at the first step\)", inside[0]), inside
    assert notes(disk_scene(tmp_path / "on.nml", mesh)) == []
    assert notes(write_scene(tmp_path / "bar.nml", scheme__t_end="0.01")) == []
    away = notes(write_scene(tmp_path / "away.nml", contact__obstacle_normal="0.0, 1.0",
                             scheme__t_end="0.01"))
    assert len(away) == 1 and "obstacle_normal points into the body" in away[0], away


def test_docstring_examples_run_as_written(monkeypatch):
    """The examples of the modules' docstrings that run in a moment (the others write
    runs into out/ and are marked +SKIP), run from the repository's root as written:
    mesh_io's once named a mesh file that meshes/ does not have."""
    import doctest

    from dyncontact import mesh_io, scene
    from dyncontact.study import figures

    monkeypatch.chdir(Path(__file__).resolve().parents[1])
    for module in (mesh_io, scene, figures):
        failed, tried = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
        assert failed == 0 and tried > 0, module.__name__


#: (scheme keys, dt) of every scheme family, each at a step it is stable at on the disk
#: (h = 0.02: the predictor-correctors at about h/60, the others at h/2).
RIGID_SCHEMES = {
    "newmark": ({"name": "'newmark'"}, 0.01),
    "hht": ({"name": "'hht'", "alpha": "-0.1"}, 0.01),
    "hht_seed": ({"name": "'hht_seed'", "alpha": "-0.1"}, 0.01),
    "theta": ({"name": "'theta'", "theta": "1.0"}, 0.01),
    "galpha": ({"name": "'galpha'", "rho_inf": "0.5"}, 0.01),
    "pc": ({"name": "'pc'"}, 0.0003),
    "pc_hht": ({"name": "'pc_hht'", "alpha": "-0.1"}, 0.0003),
    "central": ({"name": "'central'", "mass": "'lumped'"}, 0.002),
}


@pytest.mark.parametrize("scheme", RIGID_SCHEMES)
def test_body_thrown_in_flight_moves_rigidly(scheme, tmp_path):
    """The disk thrown at (0.3, -0.1), no gravity, nothing clamped, the obstacle far
    below: every scheme moves it as a rigid body, so u_n = 0.1 t and v_n = 0.1 at the
    probe, e_kin stays ½ m |v|² and e_el = 0, to round-off (a translation is in the null
    space of K and the schemes integrate a constant velocity exactly)."""
    import dyncontact

    keys, dt = RIGID_SCHEMES[scheme]
    over = {f"scheme__{k}": v for k, v in keys.items()}   # alpha: left out unless given
    mesh = disk_mesh(tmp_path / "disk.msh")
    scene = disk_scene(tmp_path / "s.nml", mesh, initial__velocity="0.3, -0.1",
                       contact__obstacle_point="0.0, -1.0", scheme__dt=f"{dt}",
                       scheme__t_end="0.3", **over)
    res = dyncontact.run(scene, out=tmp_path / "o", progress=False)
    assert res.status == "ok"
    tr = res.trace
    mass = math.pi * RADIUS**2            # density 1; the disk's polygon is a bit less
    e_kin = 0.5 * (0.3**2 + 0.1**2)
    assert tr["e_kin"][0] == pytest.approx(e_kin * mass, rel=2e-2)
    # round-off, grown over up to 1000 steps: measured at most 2.5e-14 of each scale
    np.testing.assert_allclose(tr["u_n"], 0.1 * tr["t"], rtol=0, atol=1e-12 * 0.03)
    np.testing.assert_allclose(tr["v_n"], 0.1, rtol=0, atol=1e-12)
    np.testing.assert_allclose(tr["e_kin"], tr["e_kin"][0], rtol=1e-13)
    assert np.abs(tr["e_el"]).max() <= 1e-13 * tr["e_kin"][0]
    assert np.all(tr["active"] == 0)


def test_contact_keys_the_method_does_not_use_warn(tmp_path):
    """&contact theta (the Nitsche variant) with 'penalty', multiplier without 'alm',
    quad_points with the 'exact' quadrature: each changes nothing and the run says so,
    one line a key, whatever the value written (the defaults too); the same keys where
    they are used, or not given, say nothing."""
    import warnings

    import dyncontact
    from dyncontact.core import DyncontactWarning

    def notes(**over):
        scene = write_scene(tmp_path / "s.nml", scheme__t_end="0.01", **over)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            assert dyncontact.run(scene, out=tmp_path / "o", progress=False).ok
        return [str(w.message) for w in caught if w.category is DyncontactWarning]

    unused = [
        "warning: &contact theta: not used by method = 'penalty' (the Nitsche variant; "
        "docs/scenes.md, &contact)",
        "warning: &contact multiplier: not used by method = 'penalty' (only 'alm' has "
        "multipliers; docs/scenes.md, &contact)",
        "warning: &contact quad_points: not used with quadrature = 'exact' (it splits each "
        "facet at the kink; quad_points is for quadrature = 'gauss'; docs/scenes.md, "
        "&contact)"]
    assert notes(contact__method="'penalty'", contact__theta="0", contact__multiplier="'nodal'",
                 contact__quad_points="5") == unused
    assert notes(contact__theta="0", contact__gamma0="10.0", contact__quadrature="'gauss'",
                 contact__quad_points="5") == []
    # written at their defaults, they are what the user wrote all the same
    assert notes(contact__method="'penalty'", contact__theta="1",
                 contact__multiplier="'integral'", contact__quad_points="3") == unused
    assert notes(contact__method="'penalty'", contact__theta=None) == []


def test_keys_set_from_the_command_line_or_a_scene_count_as_given(run_cli, tmp_path):
    """A key given by --set (or Scene.set) is a key the user wrote, as one in the file:
    --set scheme.beta=0.25 (its default) with hht, --set contact.theta=1 with 'penalty',
    --set initial.kind=... on a mesh file; the same through dyncontact.Scene. Keys only
    read from the file and not set are not made given by the Scene that runs them."""
    import warnings

    import dyncontact
    from dyncontact.core import DyncontactWarning

    scene = write_scene(tmp_path / "s.nml", contact__method="'penalty'", contact__theta=None,
                        scheme__alpha=None, scheme__t_end="0.01")
    r = run_cli("run", scene, "--set", "scheme.beta=0.25", "--set", "contact.theta=1",
                "--out", tmp_path / "o", "--quiet")
    assert r.returncode == EXIT_OK, r.stderr
    assert r.stderr.splitlines() == [
        "dyncontact: warning: &scheme beta: not used by scheme 'hht' (it uses alpha; "
        "docs/scenes.md, &scheme)",
        "dyncontact: warning: &contact theta: not used by method = 'penalty' (the Nitsche "
        "variant; docs/scenes.md, &contact)"]
    r = run_cli("run", scene, "--set", "scheme.dt=0.005", "--out", tmp_path / "o", "--quiet")
    assert r.returncode == EXIT_OK and r.stderr == "", r.stderr
    scn = dyncontact.Scene.read(scene)
    scn.set("scheme.gamma", 0.5)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert dyncontact.run(scn, out=tmp_path / "o", progress=False).ok
    assert [str(w.message) for w in caught if w.category is DyncontactWarning] == [
        "warning: &scheme gamma: not used by scheme 'hht' (it uses alpha; docs/scenes.md, "
        "&scheme)"]
    mesh = disk_mesh(tmp_path / "disk.msh")
    scene = disk_scene(tmp_path / "d.nml", mesh, initial__kind=None, initial__velocity=None)
    r = run_cli("run", scene, "--out", tmp_path / "o", "--quiet")
    assert r.returncode == EXIT_OK and "&initial kind is not given" in r.stderr, r.stderr
    r = run_cli("run", scene, "--set", "initial.kind=compressed_bar", "--out", tmp_path / "o",
                "--quiet")
    assert r.returncode == EXIT_OK and r.stderr == "", r.stderr


@pytest.mark.parametrize("kind", ENTRIES)
def test_mesh_file_without_initial_kind_warns(kind, tmp_path):
    """A scene with a mesh file of its own that does not write &initial kind starts from
    the default 'compressed_bar', the seed bar's u0, which compresses the body by
    amplitude/length: the run says so, one line, naming the kinds to choose from. A kind
    written (even 'compressed_bar'), amplitude = 0 (u0 = 0), or the built-in bar (the
    seed's case, whose default it is) say nothing; a velocity given without kind gets
    the velocity's warning alone."""
    mesh = disk_mesh(tmp_path / "disk.msh")
    cases = {
        "no_kind": (dict(initial__kind=None, initial__velocity=None),
                    ["warning: &initial kind is not given: the mesh file's body starts from "
                     "the default kind = 'compressed_bar', the seed bar's u0 = -amplitude "
                     "(1 - d/length) n, at rest (compressed by amplitude/length = 2.5E-001 "
                     "along n); give kind = 'rest' or 'velocity' (with velocity), or "
                     "'compressed_bar' to keep it (docs/scenes.md, &initial)"]),
        "kind_given": (dict(initial__kind="'compressed_bar'", initial__velocity=None), []),
        "rest": (dict(initial__kind="'rest'", initial__velocity=None,
                      initial__amplitude=None, mesh__length=None), []),
        "no_lift": (dict(initial__kind=None, initial__velocity=None,
                         initial__amplitude="0.0"), []),
        "velocity": (dict(initial__kind=None),
                     ["warning: &initial velocity is not used with kind = 'compressed_bar'"]),
    }
    for name, (over, expected) in cases.items():
        scene = disk_scene(tmp_path / f"{name}.nml", mesh,
                           **{"initial__amplitude": "0.25", "mesh__length": "1.0", **over})
        res = run(kind, scene, "--out", tmp_path / name, cwd=tmp_path)
        assert res.returncode == EXIT_OK, res.stderr
        lines = res.stderr.splitlines()
        assert len(lines) == len(expected), (name, res.stderr)
        for line, start in zip(lines, expected):
            assert line.startswith(f"dyncontact: {start}"), (name, line)
    scene = write_scene(tmp_path / "bar.nml", initial__kind=None, scheme__t_end="0.01")
    res = run(kind, scene, "--out", tmp_path / "bar", cwd=tmp_path)
    assert res.returncode == EXIT_OK and res.stderr == "", res.stderr


@pytest.mark.parametrize("path", sorted((Path(__file__).resolve().parents[1] / "scripts" /
                                         "scenes").glob("*.nml")), ids=lambda p: p.stem)
def test_example_scenes_open_without_warnings(path, tmp_path):
    """Every scene of scripts/scenes/ opens its run with no warning nor note but the one it
    shows (bar2d_alm_consistent: the augmented Lagrangian with the consistent mass): the
    project's own scenes write only keys they use (a kind with a mesh file, no parameter
    of another scheme), so a warning a user sees there is news."""
    import warnings

    from dyncontact.core import DyncontactWarning, Stepper

    expected = {"bar2d_alm_consistent": ["warning: &contact method = 'alm' with &scheme "
                                         "mass = 'consistent': the multipliers chatter"]}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with Stepper(path, tmp_path / "o"):
            pass
    got = [str(w.message) for w in caught if w.category is DyncontactWarning]
    want = expected.get(path.stem, [])
    assert len(got) == len(want) and all(g.startswith(w) for g, w in zip(got, want)), got


def test_stepper_gives_the_runs_warnings(tmp_path):
    """A Stepper is a run driven step by step: the warnings and notes run() gives before
    the run starts are DyncontactWarning warnings there too (not silence);
    turned into errors, they leave no run open (the output folder's lock is released)."""
    import warnings

    import dyncontact
    from dyncontact.core import DyncontactWarning, Stepper

    scene = write_scene(tmp_path / "s.nml", contact__obstacle_normal="0.0, 1.0",
                        scheme__t_end="0.01")
    with pytest.warns(DyncontactWarning, match="obstacle_normal points into the body"):
        with Stepper(scene, tmp_path / "o") as st:
            st.advance(1)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DyncontactWarning)
        with pytest.raises(DyncontactWarning):
            Stepper(scene, tmp_path / "o")
    assert not (tmp_path / "o" / ".dyncontact.lock").exists()
    with pytest.warns(DyncontactWarning, match="obstacle_normal points into the body"):
        assert dyncontact.run(scene, out=tmp_path / "o", progress=False).ok


# ------------------------------------------------------------------ an --out that is no folder

@pytest.mark.parametrize("kind", ENTRIES)
@pytest.mark.parametrize("out, why", [("afile", "a file of that name is in the way"),
                                      ("afile/run", "Not a directory"),
                                      ("afile/run/deeper", "Not a directory")])
def test_out_that_cannot_be_a_folder_says_why(kind, out, why, tmp_path):
    """--out naming a file, or a folder under a file: a bad path, so exit 2 (bad input)
    as for `study` and `plot`, not 4 (kept for a full or read-only disk), and one line
    naming the option and the folder and saying why; the file is left as it was."""
    scene = write_scene(tmp_path / "s.nml", scheme__t_end="0.01")
    (tmp_path / "afile").write_text("results of last week\n")
    line = one_line(run(kind, scene, "--out", out, cwd=tmp_path), EXIT_BAD_INPUT)
    assert line == f"dyncontact: --out {out}: cannot create the folder ({why})", line
    assert (tmp_path / "afile").read_text() == "results of last week\n"


@pytest.mark.parametrize("kind", ENTRIES)
def test_output_folder_of_the_scene_that_cannot_be_a_folder_names_the_key(kind, tmp_path):
    """Without --out the folder is the scene's &output dir: the line names the scene
    file and the key, exit 2."""
    (tmp_path / "afile").write_text("")
    scene = write_scene(tmp_path / "s.nml", scheme__t_end="0.01", output__dir="'afile/run'")
    line = one_line(run(kind, scene, cwd=tmp_path), EXIT_BAD_INPUT)
    assert line == (f"dyncontact: {scene}: &output dir: afile/run: cannot create the folder "
                    "(Not a directory)"), line


@pytest.mark.parametrize("kind", ENTRIES)
def test_out_on_a_read_only_disk_is_exit_4(kind, tmpfs, tmp_path):
    """A folder that cannot be made for want of a writable disk is not a bad path: exit 4
    (as `study` says it, WRITE_ERRNOS), one line naming --out and the folder."""
    disk = tmpfs("size=64k,ro")
    scene = write_scene(tmp_path / "s.nml", scheme__t_end="0.01")
    line = one_line(run(kind, scene, "--out", disk / "o", cwd=tmp_path), EXIT_WRITE)
    assert line == (f"dyncontact: --out {disk / 'o'}: cannot create the folder "
                    "(Read-only file system)"), line


def test_out_that_cannot_be_a_folder_from_python_names_the_argument(tmp_path):
    """From Python the folder is named as run()'s and Stepper()'s argument (out='...'),
    not as the command line's option, and the error is bad input."""
    import dyncontact
    from dyncontact import BadInputError

    scene = write_scene(tmp_path / "s.nml", scheme__t_end="0.01")
    (tmp_path / "afile").write_text("")
    out = str(tmp_path / "afile" / "run")
    want = f"out={out!r}: cannot create the folder (Not a directory)"
    for call in (lambda: dyncontact.run(scene, out=out, progress=False),
                 lambda: dyncontact.Stepper(scene, out)):
        with pytest.raises(BadInputError) as info:
            call()
        assert str(info.value) == want
