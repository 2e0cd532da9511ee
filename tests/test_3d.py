"""The 3D model (P1 tetrahedra, triangle contact facets) through whole runs of the built-in
box (&mesh dim = 3): GetFEM's 3D reference trace, the 1D closed form (nu = 0), every
scheme and mass, the outputs, and the bad inputs that only a 3D scene can have. The
element kernels are checked in test_tet.py, the box mesh in test_mesh3d.py, rotation
invariance and the facet quadrature by the Fortran programs test_rotation3d and
test_facet3d (test_fortran_units.py)."""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

import dyncontact
from dyncontact import BadInputError, Scene
from dyncontact import exact1d as ex
from dyncontact.core import DyncontactWarning
from conftest import fd_jacobian_errors

REF = Path(__file__).resolve().parent / "data" / "reference"

#: GetFEM's 3D run and ours solve the same discrete equations (the same mesh; element
#: integrals exact on both sides; the same 7-point face rule) with Newton to 1e-10; the reference
#: file has 11 significant digits (e_total to 4e-11 of e0). Observed: 5.1e-12 in u_n,
#: 4.0e-11 in e_total relative to e0 (5e-14 absolute: the file's rounding).
GETFEM_TOL = 1e-10
#: The nu = 0 box against the 1D closed form at h = 0.025 (observed: max |u_n - exact|
#: 0.032, mean p_n in the contact phases -0.495 and -0.487, e_total within 1.6 % of
#: 1/8 per unit cross-section; at h = 0.05: 0.053, 3.3 %).
U_N_TOL_3D = 0.05
P_N_TOL_3D = 0.05
ENERGY_TOL_3D = 0.025


def box(**keys) -> Scene:
    """The 3D box [0, 0.1]^2 x [0, 1] at h = 0.05 (the GetFEM settings), keys as group__key."""
    s = Scene()
    s.set("mesh.dim", 3)
    for name, value in keys.items():
        s.set(name.replace("__", "."), value)
    return s


def run(s: Scene, tmp_path: Path, name: str) -> dyncontact.RunResult:
    return dyncontact.run(s, out=tmp_path / name, progress=False)


def test_box_scene_defaults_are_3d():
    s = box()
    assert s.get("contact.obstacle_normal") == [0.0, 0.0, -1.0]
    assert s.get("contact.probe") == [0.05, 0.05, 0.0]
    assert s.get("material.gravity") == [0.0, 0.0, 0.0]


def test_matches_getfem_3d_reference(tmp_path):
    """GetFEM 5.4.2's 3D run (shared/reference/bar3d_h0.05_hht_a0.csv): HHT alpha = 0,
    dt = 0.0025, T = 15, its face rule (7 points) on the contact triangles."""
    res = run(box(contact__quadrature="gauss", contact__quad_points=7, scheme__alpha=0.0,
                  output__every=5), tmp_path, "getfem3d")
    assert res.status == "ok"
    ref = np.genfromtxt(REF / "bar3d_h0.05_hht_a0.csv", delimiter=",", names=True)
    tr = res.trace
    assert np.allclose(tr["t"], ref["t"], atol=1e-12)
    du = np.max(np.abs(tr["u_n"] - ref["u_n"]))
    de = np.max(np.abs(tr["e_total"] - ref["e_total"])) / ref["e_total"][0]
    print(f"max |u_n - GetFEM| = {du:.2e}, max |e_total - GetFEM| / e0 = {de:.2e}")
    assert du <= GETFEM_TOL and de <= GETFEM_TOL
    # the first contact at the probe, as GetFEM's run (t ~ 1.21)
    t_first = tr["t"][np.argmax(tr["u_n"] > 0)]
    assert 1.15 < t_first < 1.25


@pytest.mark.parametrize("h", [0.05, 0.025])
def test_nu0_box_follows_the_1d_closed_form(h, tmp_path):
    """With nu = 0 and E = 1 the box's exact solution is the 1D bar's (u = w(z, t) e_z, the
    lateral faces free of traction): u_n, the contact stress -1/2 and the energy 1/8 per
    unit cross-section, Newmark (1/4, 1/2) at dt = h/20, T = 6."""
    res = run(box(mesh__h=h, material__young=1.0, material__poisson=0.0,
                  scheme__name="newmark", scheme__dt=h / 20, scheme__t_end=6.0),
              tmp_path, f"nu0_{h}")
    tr = res.trace
    t, tau = tr["t"], np.mod(tr["t"], 3.0)
    err = float(np.max(np.abs(tr["u_n"] - ex.u_n(t))))
    dev = float(np.max(np.abs(tr["e_total"] / 0.01 - ex.ENERGY)) / ex.ENERGY)
    means = [float(np.mean(tr["p_n"][(tau >= 1.2) & (tau <= 1.8) & (t >= 3 * k) & (t < 3 * k + 3)]))
             for k in (0, 1)]
    print(f"h = {h}: max |u_n - exact| = {err:.4f}, energy {dev:.2e}, mean p_n {means}")
    flight = (tau > 0.2) & (tau < 0.8) | (tau > 2.2) & (tau < 2.8)
    assert np.all(tr["p_n"][flight] == 0.0)
    if h == 0.025:
        assert err <= U_N_TOL_3D
        assert dev <= ENERGY_TOL_3D
        assert all(abs(m + 0.5) <= P_N_TOL_3D for m in means)
    else:     # coarser: larger errors (the finer run must beat these)
        assert err <= 2 * U_N_TOL_3D and dev <= 2 * ENERGY_TOL_3D


#: The seed's HHT coefficients (gamma = 1/2 + alpha < 1/2 for alpha < 0) amplify: with
#: alpha = -0.1 the 2D bar stops as unstable at t = 2.5, the 3D box at t = 1.48 (its energy
#: grows in flight too); they run here with alpha = -0.01, where the energy still grows
#: (6 % by t = 1.5 in 3D), so only the others are held to their initial energy.
SCHEMES = {
    "newmark": {}, "hht": {"scheme.alpha": -0.1}, "hht_seed": {"scheme.alpha": -0.01},
    "theta": {}, "galpha": {"scheme.rho_inf": 0.8}, "pc": {"scheme.dt": 0.0005},
    "pc_hht": {"scheme.dt": 0.0005, "scheme.alpha": -0.1},
    "pc_hht_seed": {"scheme.dt": 0.0005, "scheme.alpha": -0.01},
    "central": {"scheme.dt": 0.0, "scheme.mass": "lumped"},
}


@pytest.mark.parametrize("name", sorted(SCHEMES))
def test_every_scheme_runs_in_3d(name, tmp_path):
    """Through the first impact (t = 1.5): ok, in contact, the energy bounded by its start
    (5 %: the dissipative schemes lose, the others keep it to their contact error)."""
    s = box(scheme__name=name, scheme__t_end=1.5)
    for key, value in SCHEMES[name].items():
        s.set(key, value)
    res = run(s, tmp_path, name)
    assert res.status == "ok", res.message
    tr = res.trace
    assert tr["u_n"].max() > 0 and tr["p_n"].min() < -0.1
    e0 = tr["e_total"][0]
    if not name.endswith("_seed"):
        assert np.all(tr["e_total"] <= 1.05 * e0)


@pytest.mark.parametrize("mass", ["consistent", "lumped", "redistributed"])
def test_masses_and_penalty_in_3d(mass, tmp_path):
    """The three masses, and penalty contact, with Newmark: ok through the first impact;
    newmark conserves e_kin + e_el + e_contact in flight (before the impact)."""
    for method in ("nitsche", "penalty"):
        res = run(box(scheme__name="newmark", scheme__mass=mass, scheme__t_end=1.5,
                      contact__method=method, contact__gamma0=20.0), tmp_path, f"{mass}_{method}")
        assert res.status == "ok", res.message
        tr = res.trace
        assert tr["p_n"].min() < -0.1
        flight = (tr["t"] > 0) & (tr["t"] < 1.0)    # t = 0: redistributed's massless nodes
        conserved = tr["e_total"][flight] + tr["e_contact"][flight]
        assert np.ptp(conserved) <= 1e-9 * conserved[0]


def test_blowup_stops_a_3d_run(tmp_path):
    """Central differences at twice its estimated stability limit (the step it picks
    itself is 0.9 x the estimate): the blow-up test stops the run."""
    auto = run(box(scheme__name="central", scheme__mass="lumped", scheme__dt=0.0,
                   scheme__t_end=0.1), tmp_path, "auto")
    dt_crit = auto.summary["dt_crit_estimate"]
    assert auto.status == "ok" and dt_crit > 0
    with pytest.warns(DyncontactWarning, match="2.00 x the critical step of central"):
        res = run(box(scheme__name="central", scheme__mass="lumped", scheme__dt=2 * dt_crit,
                      scheme__t_end=15.0), tmp_path, "blowup")
    assert res.status == "unstable"


def test_3d_fields_are_tetrahedra(tmp_path):
    meshio = pytest.importorskip("meshio")
    res = run(box(scheme__t_end=0.05, output__fields_every=10), tmp_path, "vtu")
    assert res.status == "ok"
    out = tmp_path / "vtu"
    files = [ds.get("file") for ds in ET.parse(out / "fields.pvd").getroot().iter("DataSet")]
    assert len(files) == 3
    m = meshio.read(os.path.join(out, files[-1]))
    assert list(m.cells_dict) == ["tetra"] and len(m.cells_dict["tetra"]) == 480
    assert m.point_data["displacement"].shape == (189, 3)
    text = (out / files[-1]).read_text()
    assert ">\n 10\n" in text or " 10" in text.split('Name="types"')[1][:200]


@pytest.mark.parametrize("keys,fragment", [
    ({"contact.probe": "0.05, 0.0"}, "&contact probe: expected 3 values in 3D"),
    ({"initial.velocity": "0.0, -1.0"}, "&initial velocity: expected 3 values in 3D"),
    ({"boundary.contact": "body"}, "has no facets"),
    ({"contact.probe": "0.05, 0.05, 0.3"}, "&contact probe: the point is not on the contact"),
])
def test_bad_3d_inputs(keys, fragment, tmp_path):
    s = box()
    with pytest.raises(BadInputError, match=fragment):
        for key, value in keys.items():
            s.set(key, value)
        run(s, tmp_path, "bad")


def test_slip_z_needs_3d(tmp_path):
    s = Scene()
    s.set("boundary.slip_z", "left")
    with pytest.raises(BadInputError, match="slip_z: a 2D model has no z component"):
        run(s, tmp_path, "bad")


def test_slip_z_holds_the_z_component(tmp_path):
    """slip_z removes the z dof of the group's nodes: the box (189 nodes, 9 on the top
    clamped) has 3 x 180 = 540 free dofs, 531 with slip_z on the 9 bottom nodes."""
    with pytest.warns(DyncontactWarning, match="no contact boundary"):
        res = run(box(boundary__slip_z="bottom", boundary__contact="", scheme__t_end=0.05,
                      initial__kind="rest"), tmp_path, "slipz")
    assert res.status == "ok" and res.summary["dofs"] == 531


@pytest.mark.parametrize("quadrature", ["exact", "gauss"])
@pytest.mark.parametrize("theta", [-1, 0, 1])
@pytest.mark.parametrize("depth", [-0.05, 0.002, 0.05], ids=["free", "partial", "deep"])
def test_3d_generalized_derivative_matches_finite_differences(theta, quadrature, depth):
    """B'(u) du of the 3D model (triangle facets, both quadratures) against central
    differences of B, as in 2D (test_schemes.py): relative error below 1e-6."""
    from dyncontact.core import Model

    rng = np.random.default_rng(11)
    s = box(contact__theta=theta, contact__quadrature=quadrature, contact__quad_points=7)
    with Model(s) as m:
        node, comp = m.dof_map()
        u = np.where(comp == 2, -depth, 0.0) + 1e-3 * rng.standard_normal(comp.shape)
        b, active = m.eval_b(u)
        assert (active == 0) if depth < 0 else (active > 0)
        errs = fd_jacobian_errors(m, u, active, rng, 4)
        assert errs, "every direction switched a quadrature point"
        for err in errs:
            assert err < 1e-6, f"theta={theta} {quadrature}: relative FD error {err:.2e}"


def test_3d_probe_snapped_to_the_bottom_face(tmp_path):
    """A probe just below the bottom face is moved onto it, with a note giving the point.
    Probes inside a triangle's edge (the diagonal of a bottom square), at a node of six
    triangles and on the face's border edge are all located: u_n at t = 0 is the compressed
    bar's -1/2 (the same on the whole bottom face) and p_n shows the impact."""
    with pytest.warns(DyncontactWarning, match=r"probe snapped to 5\.00000E-002 5\.00000E-002 "
                                               r"0\.00000E\+000 \(distance 1\.000E-003\)"):
        res = run(box(contact__probe="0.05, 0.05, -0.001", scheme__t_end=0.01), tmp_path, "s")
    assert res.status == "ok"
    for probe in ("0.025, 0.025, 0.0", "0.05, 0.05, 0.0", "0.1, 0.03, 0.0"):
        tr = run(box(contact__probe=probe, scheme__t_end=1.5), tmp_path, "p").trace
        assert tr["u_n"][0] == pytest.approx(-0.5, abs=1e-15)
        assert tr["p_n"].min() < -0.1


MESHES = Path(__file__).resolve().parents[1] / "meshes"


def test_getfem_mesh_file_gives_the_box_trace(tmp_path):
    """GetFEM's 3D mesh file, read through gmsh, and the built-in box are the same mesh
    (same nodes, same tetrahedra, same order): the same trace to round-off, over the first
    contact (T = 3)."""
    keys = dict(contact__quadrature="gauss", contact__quad_points=7, scheme__t_end=3.0)
    a = run(box(**keys), tmp_path, "box")
    s = Scene()
    s.set("mesh.file", str(MESHES / "bar3d_getfem_h0.05.msh"))
    s.set("initial.kind", "compressed_bar")     # the built-in box's, by default
    for name, value in keys.items():
        s.set(name.replace("__", "."), value)
    for name, value in (("contact.obstacle_normal", "0.0, 0.0, -1.0"),
                        ("contact.probe", "0.05, 0.05, 0.0"),
                        ("material.gravity", "0.0, 0.0, 0.0"),
                        ("initial.velocity", "0.0, 0.0, 0.0"),
                        ("contact.obstacle_point", "0.0, 0.0, 0.0")):
        s.set(name, value)
    b = run(s, tmp_path, "file")
    assert a.status == b.status == "ok"
    assert b.summary["dofs"] == a.summary["dofs"]
    for col in ("u_n", "v_n", "p_n", "e_total"):
        scale = max(1.0, np.max(np.abs(a.trace[col])))
        assert np.max(np.abs(a.trace[col] - b.trace[col])) <= 1e-12 * scale, col


def test_3d_mesh_file_with_2d_vectors_is_refused(exe, tmp_path):
    """A 3D mesh file and a scene written for 2D (two components): exit 2 naming the key
    and the dimension, before anything is written."""
    import subprocess

    scene = tmp_path / "s.nml"
    scene.write_text(f"&mesh file = '{MESHES / 'bar3d_getfem_h0.05.msh'}' /\n"
                     "&contact probe = 0.05, 0.0 /\n")
    r = subprocess.run([str(exe), str(scene), "--out", str(tmp_path / "o")],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and str(scene) in lines[0]
    assert "&contact probe: expected 3 values in 3D" in lines[0], lines[0]
    assert not (tmp_path / "o" / "trace.csv").exists()


def test_ball_contact_patch_grows_and_shrinks(tmp_path):
    """The ball of meshes/ball.geo (coarse, h = 0.1) dropped at speed 0.1: the number of
    active contact points rises from 0, peaks and falls back to 0 as the ball bounces
    off; after the bounce the energy is e0 to a few % (measured: +0.2 % at this h; inside
    the contact e_total is not conserved by Nitsche's term: up to 12 % here)."""
    s = Scene.read(Path(__file__).resolve().parents[1] / "scripts" / "scenes"
                   / "ball3d_newmark.nml")
    s.set("mesh.h", 0.1)
    s.set("scheme.t_end", 1.6)
    s.set("output.fields_every", 0)
    res = run(s, tmp_path, "ball")
    assert res.status == "ok"
    active = res.trace["active"]
    k = int(np.argmax(active))
    assert active[0] == 0 and active[k] > 0 and active[-1] == 0
    e = res.trace["e_total"]
    print(f"peak {active[k]} active points at t = {res.trace['t'][k]:.3f}; "
          f"e_total: max |e - e0| / e0 = {np.max(np.abs(e - e[0])) / e[0]:.3e}, "
          f"at the end {(e[-1] - e[0]) / e[0]:.3e}")
    assert abs(e[-1] - e[0]) <= 0.03 * e[0]
