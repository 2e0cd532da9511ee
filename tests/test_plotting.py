"""dyncontact.plotting on synthetic run folders (no simulation): four panels, stopped runs
drawn up to their stop and marked, blow-ups kept off the scale, field snapshots."""

from __future__ import annotations

import json

import numpy as np
import pytest

HEADER = "t,u_n,v_n,p_n,e_kin,e_el,e_contact,e_total,newton_its,active"
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _write_run(folder, t_end=3.0, n=301, status="ok", scheme="hht", blow_up=False, **params):
    """A run folder shaped like the 1D exact solution (period 3); blow_up: the last rows
    grow geometrically, as an unstable explicit run does before it trips `blowup`."""
    folder.mkdir(parents=True, exist_ok=True)
    t = np.linspace(0.0, t_end, n)
    u = np.where(t < 1, -0.5 + t / 2, np.where(t < 2, 0.0, (t - 2) / 2))
    v = np.where(t < 1, 0.5, np.where(t < 2, 0.0, 0.5))
    p = np.where((t > 1) & (t < 2), -0.5, 0.0)
    e_kin = 0.25 * v**2
    e_el = 0.125 - e_kin
    if blow_up:
        g = 3.0 ** np.arange(8)
        u[-8:] *= g
        v[-8:] *= -g
        p[-8:] -= g
        e_kin[-8:] *= g**2
    e_total = e_kin + e_el
    rows = np.column_stack([t, u, v, p, e_kin, e_el, np.zeros_like(t), e_total,
                            np.ones_like(t), (p < 0) * 3.0])
    np.savetxt(folder / "trace.csv", rows, delimiter=",", header=HEADER, comments="",
               fmt="%.12e")
    scheme_keys = {"name": scheme, "dt": 0.0025, "mass": "consistent", **params}
    summary = {"status": status, "steps": n - 1, "t_end_reached": float(t[-1]),
               "wall_s": 0.01, "newton_its_total": 0, "factorizations": 1, "dofs": 10,
               "elements": 4, "contact_facets": 2, "scheme": scheme, "version": "test",
               "scene": {"mesh": {"file": "", "dim": 2, "h": 0.05},
                         "contact": {"obstacle_point": [0.0, 0.0],
                                     "obstacle_normal": [0.0, -1.0]},
                         "scheme": scheme_keys}}
    (folder / "summary.json").write_text(json.dumps(summary))
    return folder


def _stop_artists(ax):
    markers = [ln for ln in ax.get_lines() if ln.get_gid() == "stop-marker"]
    vlines = [ln for ln in ax.get_lines() if ln.get_gid() == "stop-line"]
    return markers, vlines


def test_two_runs_and_an_unstable_one(tmp_path):
    from dyncontact.plotting import plot_traces

    a = _write_run(tmp_path / "a", alpha=0.0)
    b = _write_run(tmp_path / "b", alpha=-0.1)
    t_stop = 1.7
    c = _write_run(tmp_path / "c", t_end=t_stop, n=171, status="unstable", scheme="pc",
                   beta=0.25, gamma=0.5)
    png = tmp_path / "figs" / "three.png"
    fig = plot_traces([a, b, c], png, title="two ok, one unstable")
    assert png.is_file() and png.stat().st_size > 10_000
    assert png.read_bytes()[:8] == PNG_MAGIC
    assert len(fig.axes) == 4
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert labels[0] == "hht α=0, Δt=0.0025, h=0.05"
    assert labels[1] == "hht α=-0.1, Δt=0.0025, h=0.05"
    assert labels[2] == "pc β=0.25, γ=0.5, Δt=0.0025, h=0.05 (unstable at t=1.7)"
    for k, ax in enumerate(fig.axes):
        curves = [ln for ln in ax.get_lines() if ln.get_gid() is None
                  and ln.get_linestyle() == "-"]
        assert len(curves) == 3, k
        # The finished runs go to the end; the unstable one ends at its stop.
        assert curves[0].get_xdata()[-1] == pytest.approx(3.0)
        assert curves[2].get_xdata()[-1] == pytest.approx(t_stop)
        markers, vlines = _stop_artists(ax)
        assert len(markers) == 1 and len(vlines) == 1, k
        assert markers[0].get_xdata()[0] == pytest.approx(t_stop)
        assert markers[0].get_marker() == "x"
        assert markers[0].get_color() == curves[2].get_color()
        assert vlines[0].get_xdata()[0] == pytest.approx(t_stop)
        # Without a blow-up the marker sits on the curve's last value.
        assert markers[0].get_ydata()[0] == pytest.approx(curves[2].get_ydata()[-1])


def test_finished_runs_have_no_stop_marks(tmp_path):
    from dyncontact.plotting import plot_traces

    fig = plot_traces([_write_run(tmp_path / "a"), _write_run(tmp_path / "b")], None)
    for ax in fig.axes:
        assert _stop_artists(ax) == ([], [])


def test_blow_up_stays_off_the_scale_and_its_stop_is_marked(tmp_path):
    from dyncontact.plotting import plot_traces

    a = _write_run(tmp_path / "a")
    t_stop = 2.5
    c = _write_run(tmp_path / "c", t_end=t_stop, n=251, status="unstable", scheme="pc",
                   blow_up=True)
    fig = plot_traces([a, c], tmp_path / "x.png")
    ax_u, ax_e = fig.axes[0], fig.axes[3]
    # u_n of the finished run spans [-0.5, 0.5]; the blow-up reaches ~0.5 * 3^7 ~ 1e3.
    lo, hi = ax_u.get_ylim()
    assert hi < 5.0 and lo > -5.0
    for ax in (ax_u, ax_e):
        lo, hi = ax.get_ylim()
        markers, vlines = _stop_artists(ax)
        assert len(markers) == 1 and len(vlines) == 1
        x, y = markers[0].get_xdata()[0], markers[0].get_ydata()[0]
        assert x == pytest.approx(t_stop)
        assert lo <= y <= hi            # kept inside the panel, at its edge
    # The curve itself still holds every value up to the stop (only the view is limited).
    curve = [ln for ln in ax_u.get_lines() if ln.get_gid() is None][1]
    assert curve.get_xdata()[-1] == pytest.approx(t_stop)
    assert abs(curve.get_ydata()[-1]) > 100


def test_non_finite_last_value(tmp_path):
    from dyncontact.plotting import plot_traces

    a = _write_run(tmp_path / "a")
    c = _write_run(tmp_path / "c", t_end=1.5, n=151, status="unstable")
    text = (c / "trace.csv").read_text().splitlines()
    last = text[-1].split(",")
    last[1:8] = ["nan"] * 7
    text[-1] = ",".join(last)
    (c / "trace.csv").write_text("\n".join(text) + "\n")
    fig = plot_traces([a, c], None)
    for ax in fig.axes:
        markers, _ = _stop_artists(ax)
        assert len(markers) == 1
        assert markers[0].get_xdata()[0] == pytest.approx(1.5)
        assert np.isfinite(markers[0].get_ydata()[0])


def _write_snapshots(folder, n=5):
    """fields.pvd + fields/step_*.vtu of a 2 x 4 triangle bar sinking and compressing."""
    import meshio

    (folder / "fields").mkdir(parents=True)
    xs, ys = np.meshgrid(np.linspace(0, 0.1, 3), np.linspace(0, 1, 5))
    pts = np.column_stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)])
    tris = []
    for j in range(4):
        for i in range(2):
            a, b, c, d = j * 3 + i, j * 3 + i + 1, (j + 1) * 3 + i, (j + 1) * 3 + i + 1
            tris += [[a, b, d], [a, d, c]]
    entries = []
    for k in range(n):
        t = 0.5 * k
        u = np.zeros_like(pts)
        u[:, 1] = (0.5 - 0.1 * k) * (1 - pts[:, 1])
        name = f"fields/step_{k:07d}.vtu"
        meshio.write(folder / name, meshio.Mesh(pts, [("triangle", np.array(tris))],
                                                point_data={"displacement": u,
                                                            "velocity": 0 * u}))
        entries.append(f'    <DataSet timestep="{t}" group="" part="0" file="{name}"/>')
    (folder / "fields.pvd").write_text(
        '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n  <Collection>\n'
        + "\n".join(entries) + "\n  </Collection>\n</VTKFile>\n")
    return folder


def test_field_snapshots(tmp_path):
    from dyncontact.plotting import plot_field_snapshots, read_pvd

    run = _write_snapshots(tmp_path / "run", n=5)
    sets = read_pvd(run / "fields.pvd")
    assert [t for t, _ in sets] == [0.0, 0.5, 1.0, 1.5, 2.0]
    assert all(p.endswith(".vtu") for _, p in sets)
    png = tmp_path / "fig1.png"
    fig = plot_field_snapshots(run, png, title="snapshots")
    assert png.read_bytes()[:8] == PNG_MAGIC
    ax = fig.axes[0]
    times = [t.get_text() for t in ax.texts]
    assert times == ["t=0", "t=0.5", "t=1", "t=1.5", "t=2"]
    # One coloured mesh per snapshot, coloured by |u| on the same scale (0 .. 0.5).
    meshes = [c for c in ax.collections if hasattr(c, "get_clim") and c.get_array() is not None
              and c.get_clim()[1] > 0]
    assert len(meshes) >= 5
    assert meshes[0].get_clim() == pytest.approx((0.0, 0.5))
    # At most max_snapshots, first and last kept.
    fig = plot_field_snapshots(run, None, max_snapshots=3)
    assert [t.get_text() for t in fig.axes[0].texts] == ["t=0", "t=1", "t=2"]


def test_field_snapshots_need_fields(tmp_path):
    from dyncontact.plotting import plot_field_snapshots

    with pytest.raises(FileNotFoundError, match="fields_every"):
        plot_field_snapshots(_write_run(tmp_path / "a"))


#: File-size limit (bytes) of the test below: the four-panel PNG is tens of kB.
PNG_FSIZE_LIMIT = 4096


def test_plot_that_cannot_be_written_exits_4_naming_the_file(tmp_path):
    """An image that cannot be written for want of room (here a file-size limit, as a
    full disk) is an output that cannot be written: exit 4, as a run's trace
    (docs/scenes.md, *Exit codes*), one line naming the image; not exit 2 (bad input)."""
    import subprocess
    import sys

    _write_run(tmp_path / "a")
    png = tmp_path / "p.png"
    code = ("import resource, sys\nfrom dyncontact.cli import main\n"
            f"resource.setrlimit(resource.RLIMIT_FSIZE, ({PNG_FSIZE_LIMIT}, "
            f"{PNG_FSIZE_LIMIT}))\n"
            f"sys.exit(main(['plot', {str(tmp_path / 'a')!r}, '--out', {str(png)!r}]))")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 4, (res.returncode, res.stderr)
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("dyncontact: "), res.stderr
    assert str(png) in lines[0] and "File too large" in lines[0], lines[0]


def test_energy_panel_adds_e_load_under_a_body_force(tmp_path):
    """A body falling freely under gravity: e_kin grows as e_load falls and their sum
    stays 0. The energy panel draws e_kin + e_el + e_load (flat) and says so in its
    label; a run without a load drawn with it is unchanged (e_load = 0)."""
    from dyncontact.plotting import plot_traces

    header = HEADER + ",e_load"
    t = np.linspace(0.0, 1.0, 11)
    v = -t                                  # g = -1, unit mass
    e_kin = 0.5 * v**2
    zeros = np.zeros_like(t)
    rows = np.column_stack([t, 0.5 * t**2, -v, zeros, e_kin, zeros, zeros, e_kin, zeros,
                            zeros, -e_kin])
    fall = _write_run(tmp_path / "fall")
    np.savetxt(fall / "trace.csv", rows, delimiter=",", header=header, comments="",
               fmt="%.12e")
    bar = _write_run(tmp_path / "bar")
    fig = plot_traces([fall, bar], None)
    ax_e = fig.axes[3]
    assert "e_{load}" in ax_e.get_ylabel()
    curves = [ln for ln in ax_e.get_lines() if ln.get_gid() is None]
    np.testing.assert_array_equal(curves[0].get_ydata(), zeros)
    e_bar = np.loadtxt(bar / "trace.csv", delimiter=",", skiprows=1)[:, 7]
    np.testing.assert_array_equal(curves[1].get_ydata(), e_bar)
    # without a load anywhere, the label and curves are e_kin + e_el
    fig = plot_traces([bar], None)
    assert "e_{load}" not in fig.axes[3].get_ylabel()


def _set_contact(folder, **contact):
    """Put &contact keys into a synthetic run's summary.json (scene.contact)."""
    path = folder / "summary.json"
    summary = json.loads(path.read_text())
    summary["scene"]["contact"].update(contact)
    path.write_text(json.dumps(summary))
    return folder


def test_p_n_label_is_the_formula_of_the_runs_contact_method(tmp_path):
    """Nitsche's [P_1(u) + gamma_N g]_- only for Nitsche runs: penalty and ALM runs get
    their own formula (summary.json's scene.contact), runs of several methods a name."""
    from dyncontact.plotting import plot_traces

    nitsche = _write_run(tmp_path / "n")
    penalty = _set_contact(_write_run(tmp_path / "p"), method="penalty")
    alm = _set_contact(_write_run(tmp_path / "a"), method="alm", multiplier="nodal")
    alm_int = _set_contact(_write_run(tmp_path / "i"), method="alm", multiplier="integral")
    label = {}
    for name, runs in (("n", [nitsche]), ("p", [penalty]), ("a", [alm]), ("i", [alm_int]),
                       ("mixed", [nitsche, penalty])):
        label[name] = plot_traces(runs, None).axes[2].get_ylabel()
    assert label["n"] == r"$p_n = [P_1(u) + \gamma_N g]_-$"
    assert "varepsilon_N" in label["p"] and "gamma_N" not in label["p"]
    assert "lambda_i" in label["a"] and "nodal" in label["a"]
    assert r"p_n = \lambda$" in label["i"] and "integral" in label["i"]
    assert "gamma_N" not in label["mixed"] and "varepsilon" not in label["mixed"]
    assert "p_n" in label["mixed"]


def _with_f_n(folder):
    """Append e_load = 0 and f_n = p_n / 10 to a synthetic run's trace."""
    rows = np.loadtxt(folder / "trace.csv", delimiter=",", skiprows=1)
    full = np.column_stack([rows, np.zeros(len(rows)), 0.1 * rows[:, 3]])
    np.savetxt(folder / "trace.csv", full, delimiter=",", header=HEADER + ",e_load,f_n",
               comments="", fmt="%.12e")
    return folder


def test_f_n_label_is_the_formula_of_the_runs_contact_method(tmp_path):
    """f_n's scale says what f_n is for the runs' method (Nitsche's integral of [P]_-,
    penalty's of eps_N [u_n - g]_+, the ALM's multipliers), a name for mixed runs: it
    gave Nitsche's integral for every run."""
    from dyncontact.plotting import plot_traces

    nitsche = _with_f_n(_write_run(tmp_path / "n"))
    penalty = _with_f_n(_set_contact(_write_run(tmp_path / "p"), method="penalty"))
    alm = _with_f_n(_set_contact(_write_run(tmp_path / "a"), method="alm",
                                 multiplier="nodal"))
    alm_int = _with_f_n(_set_contact(_write_run(tmp_path / "i"), method="alm",
                                     multiplier="integral"))
    label = {}
    for name, runs in (("n", [nitsche]), ("p", [penalty]), ("a", [alm]), ("i", [alm_int]),
                       ("mixed", [nitsche, alm])):
        label[name] = plot_traces(runs, None).axes[4].get_ylabel()
    assert "gamma_N g" in label["n"] and label["n"].startswith("$f_n")
    assert "varepsilon_N" in label["p"] and "gamma_N" not in label["p"]
    assert r"\sum_i \lambda_i" in label["a"]
    assert r"\lambda\,ds" in label["i"]
    for name in ("p", "a", "i", "mixed"):
        assert "[P" not in label[name], (name, label[name])
    assert "f_n" in label["mixed"] and "lambda" not in label["mixed"]


def test_f_n_label_does_not_overlap_the_energy_panel(tmp_path):
    """3D magnitudes (f_n near -0.007 N, energies near 0.00125 J) make wide tick labels
    on both sides of the gap between the columns: f_n's label and ticks must end before
    the energy panel's label begins (they overlapped)."""
    from dyncontact.plotting import plot_traces

    run = _with_f_n(_write_run(tmp_path / "r"))
    rows = np.loadtxt(run / "trace.csv", delimiter=",", skiprows=1)
    rows[:, 4:8] *= 0.01          # energies 0.00125
    rows[:, 11] *= 0.1234         # f_n down to -0.0062
    header = open(run / "trace.csv").readline().strip()
    np.savetxt(run / "trace.csv", rows, delimiter=",", header=header, comments="",
               fmt="%.12e")
    fig = plot_traces([run], None)
    fig.draw_without_rendering()
    assert fig.axes[4].get_tightbbox().x1 < fig.axes[3].get_tightbbox().x0


def test_f_n_is_drawn_on_a_second_scale_of_the_p_n_panel(tmp_path):
    """A trace with the f_n column: f_n dashed on a twin axis of the p_n panel (a fifth
    Axes), its values as written; an older trace without it draws the four panels alone,
    and drawn with a new one it adds no f_n curve."""
    from dyncontact.plotting import plot_traces

    new = _write_run(tmp_path / "new")
    rows = np.loadtxt(new / "trace.csv", delimiter=",", skiprows=1)
    f_n = 0.1 * rows[:, 3]
    full = np.column_stack([rows, np.zeros(len(rows)), f_n])
    np.savetxt(new / "trace.csv", full, delimiter=",", header=HEADER + ",e_load,f_n",
               comments="", fmt="%.12e")
    old = _write_run(tmp_path / "old")
    fig = plot_traces([new], None)
    assert len(fig.axes) == 5
    twin = fig.axes[4]
    assert twin.get_shared_x_axes().joined(twin, fig.axes[2])
    assert "f_n" in twin.get_ylabel()
    (curve,) = [ln for ln in twin.get_lines() if ln.get_gid() == "f_n"]
    np.testing.assert_array_equal(curve.get_ydata(), f_n)
    assert curve.get_linestyle() == "--"
    assert len(plot_traces([old], None).axes) == 4
    both = plot_traces([old, new], None)
    assert len([ln for ln in both.axes[4].get_lines() if ln.get_gid() == "f_n"]) == 1


def test_field_snapshots_draw_a_tilted_obstacle(tmp_path):
    """A plane tilted (normal (0.3, -1)): its trace is drawn under every snapshot,
    shifted with it, and lies on the plane (x - p) . n = 0 once the shift is taken off;
    the horizontal plane stays one line under all of them."""
    from dyncontact.plotting import plot_field_snapshots

    run = _write_snapshots(tmp_path / "run", n=3)
    normal, point = np.array([0.3, -1.0]), np.array([0.05, 0.25])   # under the bottom (y >= 0.3)
    (run / "summary.json").write_text(json.dumps(
        {"scene": {"contact": {"obstacle_normal": list(normal),
                               "obstacle_point": list(point)}}}))
    fig = plot_field_snapshots(run, None)
    ax = fig.axes[0]
    lines = {ln.get_gid(): ln for ln in ax.get_lines() if str(ln.get_gid()).startswith("obst")}
    assert sorted(lines) == ["obstacle-0", "obstacle-1", "obstacle-2"]
    for k, text in enumerate(ax.texts):
        shift = text.get_position()[0] - 0.05      # the bar's mean x is 0.05, u_x = 0
        xy = np.column_stack([lines[f"obstacle-{k}"].get_xdata() - shift,
                              lines[f"obstacle-{k}"].get_ydata()])
        np.testing.assert_allclose((xy - point) @ normal, 0.0, atol=1e-12)
        assert np.ptp(xy[:, 0]) > 0.1              # wider than the bar
    (run / "summary.json").write_text(json.dumps(
        {"scene": {"contact": {"obstacle_normal": [0.0, -1.0],
                               "obstacle_point": [0.0, -0.05]}}}))
    ax = plot_field_snapshots(run, None).axes[0]
    gids = [ln.get_gid() for ln in ax.get_lines() if str(ln.get_gid()).startswith("obst")]
    assert gids == ["obstacle"]
