"""The vector keys (gravity, obstacle_point, obstacle_normal, probe, velocity) against the
mesh's dimension (docs/scenes.md, "Vector keys"): a key left out takes the default of the
dimension, 1D, 2D or 3D, which for a mesh file with `&mesh dim = 0` is the file's; a Scene
keeps such a key left out, so that both entry points run the same scene (SPEC §3); a
vector with a wrong count of components is refused quoting it as written."""

from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import ROOT

import dyncontact
from dyncontact import BadInputError, Scene
from dyncontact.scene import VECTOR_DEFAULTS

MESH3D = ROOT / "meshes" / "bar3d_getfem_h0.05.msh"
VECTOR_KEYS = [("material", "gravity"), ("contact", "obstacle_point"),
               ("contact", "obstacle_normal"), ("contact", "probe"), ("initial", "velocity")]
#: The scene of the defect report: a 3D mesh file, &mesh dim left at 0, some vectors given.
BOX_FILE = (f"&mesh file = '{MESH3D}' /\n&initial kind = 'compressed_bar' /\n"
            "&contact obstacle_point = 0.0, 0.0, 0.0, obstacle_normal = 0.0, 0.0, -1.0, "
            "probe = 0.05, 0.05, 0.0 /\n"
            "&scheme t_end = 0.01 /\n")


def write(folder, text, name="s.nml"):
    path = folder / name
    path.write_text(text)
    return path


def summary_scene(out):
    return json.loads((out / "summary.json").read_text())["scene"]


def test_scene_with_a_3d_mesh_file_keeps_vectors_it_does_not_give(tmp_path):
    """Read, edited and written back, the scene gives no vector key the file does not
    give; get returns the 3D defaults the run uses."""
    scn = Scene.read(write(tmp_path, BOX_FILE))
    assert scn.get("material.gravity") == [0.0, 0.0, 0.0]
    assert scn.get("initial.velocity") == [0.0, 0.0, 0.0]
    assert scn.dimension() == 3
    assert not scn.given("material.gravity") and scn.given("contact.probe")
    scn.set("scheme.dt", 0.001)
    text = scn.to_text()
    assert "gravity" not in text and "velocity" not in text
    assert "probe = 0.05, 0.05, 0.0" in text
    scn.validate()
    again = tmp_path / "again.nml"
    scn.write(again)
    assert Scene.read(again) == scn
    assert "gravity" not in again.read_text()


def test_both_entry_points_run_a_3d_mesh_file_scene_alike(run_exe, run_cli, tmp_path):
    """The scene of the defect report: the executable, `python -m dyncontact run` (with and
    without --set) and dyncontact.run(Scene) all run it, to the same trace. The same core
    code runs the same scene text, so the traces are equal bit for bit."""
    path = write(tmp_path, BOX_FILE)
    res = run_exe(path, "--out", tmp_path / "exe")
    assert res.returncode == 0, res.stderr
    res = run_cli("run", path, "--out", tmp_path / "cli", "--quiet")
    assert res.returncode == 0, res.stderr
    res = run_cli("run", path, "--set", "scheme.dt=0.001", "--out", tmp_path / "cli_set",
                  "--quiet")
    assert res.returncode == 0, res.stderr
    ref = dyncontact.core.read_trace(tmp_path / "exe")
    for out in ("cli",):
        got = dyncontact.core.read_trace(tmp_path / out)
        for col in ref:
            assert np.array_equal(ref[col], got[col]), (out, col)
    res = dyncontact.run(Scene.read(path), out=tmp_path / "api", progress=False)
    assert res.status == "ok"
    for col in ref:
        assert np.array_equal(ref[col], res.trace[col]), col
    api, exe = summary_scene(tmp_path / "api"), summary_scene(tmp_path / "exe")
    api["output"].pop("dir")
    exe["output"].pop("dir")
    assert api == exe
    assert summary_scene(tmp_path / "cli_set")["scheme"]["dt"] == 0.001
    assert summary_scene(tmp_path / "cli_set")["material"]["gravity"] == [0.0, 0.0, 0.0]


@pytest.mark.parametrize("dim_text, dim", [("&mesh dim = 1 /\n", 1), ("", 2),
                                           ("&mesh dim = 2 /\n", 2), ("&mesh dim = 3 /\n", 3),
                                           (f"&mesh file = '{MESH3D}' /\n"
                                            "&initial kind = 'compressed_bar' /\n", 3)])
def test_vector_defaults_are_the_runs(run_exe, tmp_path, dim_text, dim):
    """Scene's defaults of the vector keys (VECTOR_DEFAULTS) are the ones the executable
    runs with: summary.json's scene, every key filled in, of a run to t = 0."""
    path = write(tmp_path, dim_text + "&scheme t_end = 0.0 /\n")
    res = run_exe(path, "--out", tmp_path / "out")
    assert res.returncode == 0, res.stderr
    ran = summary_scene(tmp_path / "out")
    scn = Scene.read(path)
    assert scn.dimension() == dim
    for group, key in VECTOR_KEYS:
        assert ran[group][key] == VECTOR_DEFAULTS[dim][(group, key)], (group, key)
        assert scn.get(f"{group}.{key}") == ran[group][key], (group, key)
        assert scn.to_dict()[group][key] is None and not scn.given(f"{group}.{key}")


def test_1d_bar_runs_with_the_defaults(run_exe, tmp_path):
    """`&mesh dim = 1` alone is a scene: the 1D defaults put the obstacle at x = 0 with
    normal -1 and the probe on Γ_C (x = 0), the 1D bar of scripts/scenes/bar1d.nml."""
    path = write(tmp_path, "&mesh dim = 1 /\n&scheme t_end = 0.05 /\n")
    res = run_exe(path, "--out", tmp_path / "exe")
    assert res.returncode == 0, res.stderr
    assert "warning" not in res.stderr and "note" not in res.stderr, res.stderr
    scene = summary_scene(tmp_path / "exe")
    assert scene["contact"]["obstacle_normal"] == [-1.0, 0.0]
    assert scene["contact"]["probe"] == [0.0, 0.0]
    # the same as bar1d.nml's explicit values, which run the same bar
    bar1d = Scene.read(ROOT / "scripts" / "scenes" / "bar1d.nml")
    for name in ("contact.obstacle_point", "contact.obstacle_normal", "contact.probe",
                 "initial.velocity"):
        assert Scene.read(path).get(name) == bar1d.get(name), name
    scn = Scene()
    scn.set("mesh.dim", 1)
    scn.set("scheme.t_end", 0.05)
    res = dyncontact.run(scn, out=tmp_path / "api", progress=False)
    assert res.status == "ok"
    assert np.array_equal(res.trace["u_n"], dyncontact.core.read_trace(tmp_path / "exe")["u_n"])


def test_changing_dim_keeps_the_vectors_given():
    """bar3d_hht.nml gives every vector with 3 components: set('mesh.dim', 0) keeps them
    (validate then names the first that does not fit 2D), the vectors not given and those
    given with the old 2D default follow the new dimension."""
    scn = Scene.read(ROOT / "scripts" / "scenes" / "bar3d_hht.nml")
    scn.set("mesh.dim", 0)
    assert scn.get("contact.probe") == [0.05, 0.05, 0.0]
    assert scn.get("contact.obstacle_normal") == [0.0, 0.0, -1.0]
    scn.set("contact.quad_points", 3)     # its 7 is a 3D rule
    with pytest.raises(BadInputError, match=r"&material gravity: expected 1 or 2 values in "
                                            r"2D \(got '0.0, 0.0, 0.0'\)"):
        scn.validate()
    scn.set("mesh.dim", 3)
    scn.validate()
    # a scene that spells out the 2D defaults (bar2d_hht.nml) follows a new dimension; a
    # vector of its own is kept, and validate names it
    seed = Scene.read(ROOT / "scripts" / "scenes" / "bar2d_hht.nml")
    assert seed.given("contact.probe")
    seed.set("mesh.dim", 3)
    assert seed.get("contact.probe") == [0.05, 0.05, 0.0]
    assert seed.get("contact.obstacle_normal") == [0.0, 0.0, -1.0]
    seed.validate()
    seed.set("mesh.dim", 2)
    assert seed.get("contact.probe") == [0.05, 0.0]
    seed.set("contact.probe", "0.02, 0.0")
    seed.set("mesh.dim", 3)
    assert seed.get("contact.probe") == [0.02, 0.0]
    with pytest.raises(BadInputError, match=r"&contact probe: expected 3 values in 3D "
                                            r"\(got '0.02, 0.0'\)"):
        seed.validate()
    fresh = Scene()
    fresh.set("mesh.dim", 3)
    assert fresh.get("contact.probe") == [0.05, 0.05, 0.0]
    fresh.validate()
    fresh.set("mesh.dim", 1)
    assert fresh.get("contact.probe") == [0.0, 0.0]
    fresh.validate()


def test_too_many_values_are_quoted_whole(run_exe, tmp_path):
    """A vector of 4 values is refused quoting the 4 values, with the count the
    dimension takes; a 2-value vector on a 3D mesh file is quoted as written."""
    path = write(tmp_path, "&mesh dim = 3 /\n&material gravity = 0, 0, 0, 0 /\n")
    res = run_exe(path)
    assert res.returncode == 2
    assert res.stderr.strip() == (f"dyncontact: {path}: &material gravity: expected 3 values "
                                  "in 3D (got '0, 0, 0, 0')")
    scn = Scene()
    scn.set("mesh.dim", 3)
    with pytest.raises(BadInputError, match=r"^<scene>: &contact probe: expected 3 values "
                                            r"in 3D \(got '0.05, 0.05, 0.0, 1.0'\)$"):
        scn.set("contact.probe", (0.05, 0.05, 0.0, 1.0))
    path = write(tmp_path, f"&mesh file = '{MESH3D}' /\n&contact probe = 0.0, 1e-2 /\n",
                 "p2.nml")
    res = run_exe(path)
    assert res.returncode == 2
    assert res.stderr.strip() == (f"dyncontact: {path}: &contact probe: expected 3 values "
                                  "in 3D (got '0.0, 1e-2')")


def test_dumps_fill_the_vectors_of_a_known_dimension(tmp_path):
    """core.scene_dump and scene_parse (the study's cache keys and shipped references)
    fill a vector key not given with the default of the dimension known before the mesh is
    read; None only for a mesh file with dim = 0 (the core's JSON has null for every key
    not given, keep_omitted=True)."""
    bar = write(tmp_path, "&mesh dim = 3 /\n")
    assert dyncontact.core.scene_dump(bar)["contact"]["probe"] == [0.05, 0.05, 0.0]
    assert dyncontact.core.scene_dump(bar, keep_omitted=True)["contact"]["probe"] is None
    assert dyncontact.core.scene_parse("", "s")["contact"]["obstacle_normal"] == [0.0, -1.0]
    assert dyncontact.core.scene_parse("&mesh dim = 1 /", "s")["contact"]["probe"] == [0.0, 0.0]
    box = write(tmp_path, BOX_FILE, "box.nml")
    dump = dyncontact.core.scene_dump(box)
    assert dump["material"]["gravity"] is None
    assert dump["contact"]["probe"] == [0.05, 0.05, 0.0]


def test_get_with_a_dimension_out_of_range_says_so():
    """A vector left out has no default for a dim that set took but validate refuses."""
    scn = Scene()
    scn.set("mesh.dim", 4)
    with pytest.raises(BadInputError, match=r"^<scene>: &mesh dim: must be 0, 1, 2 or 3"):
        scn.get("contact.probe")


def test_a_scene_run_from_python_is_named_by_its_file_in_errors(run_cli, tmp_path):
    """A Scene is run through a temporary file; an error the core finds only once the mesh
    is read (a 2-component probe on a 3D mesh file) names the scene's own file from
    dyncontact.run, and the --set item that gave the value from `python -m dyncontact run
    --set`, never the temporary file."""
    path = write(tmp_path, BOX_FILE)
    scn = Scene.read(path)
    scn.set("contact.probe", [0.05, 0.0])
    with pytest.raises(dyncontact.BadInputError) as err:
        dyncontact.run(scn, out=tmp_path / "o", progress=False)
    assert str(err.value).startswith(f"{path}: &contact probe: expected 3 values in 3D")
    assert "dyncontact-" not in str(err.value)
    res = run_cli("run", path, "--set", "contact.probe=0.05,0.0", "--out", tmp_path / "o2")
    assert res.returncode == 2
    assert res.stderr.strip() == ("dyncontact: --set contact.probe=0.05,0.0: &contact probe: "
                                  "expected 3 values in 3D (got '0.05, 0.0')")


#: A .geo whose dimension follows its parameters: the rectangle width x length (its own
#: width 0.2 and length 2.0), a box instead for width > 0.5, length < 1.5 or h < 0.3.
SWITCHING_GEO = """DefineConstant[
  h = {0.5, Name "Parameters/h"},
  length = {2.0, Name "Parameters/length"},
  width = {0.2, Name "Parameters/width"}
];
SetFactory("OpenCASCADE");
If (width > 0.5 || length < 1.5 || h < 0.3)
  Box(1) = {0, 0, 0, width, width, length};
Else
  Rectangle(1) = {0, 0, 0, width, length};
EndIf
Mesh.MeshSizeMax = h;
"""


@pytest.mark.parametrize("key, value", [("mesh.width", 1.0), ("mesh.h", 0.25),
                                        ("mesh.length", 1.0)])
def test_dimension_follows_the_mesh_keys_a_geo_is_meshed_with(tmp_path, key, value):
    """A scene's dimension read once from its .geo is not reused for a mesh of other
    &mesh h, length or width, nor once the scene gives a key it left to the file (here
    length = 1.0, the value the scene held without giving it): each makes the file a box."""
    (tmp_path / "switch.geo").write_text(SWITCHING_GEO)
    scn = Scene.read(write(tmp_path, "&mesh file = 'switch.geo', h = 0.5 /\n"
                                     "&initial kind = 'rest' /\n"))
    assert scn.dimension() == 2
    scn.set(key, value)
    assert scn.dimension() == 3
    assert Scene.read(scn.path).dimension() == 2


def test_a_vector_set_stays_when_the_dimension_changes(tmp_path):
    """A vector set through Scene.set is the user's, even with the 2D default's value: a
    later &mesh dim = 3 keeps it, and validate refuses its count as it refuses the same
    scene written as a file; the vectors left out follow the new dimension."""
    scn = Scene()
    scn.set("contact.probe", [0.05, 0.0])
    scn.set("mesh.dim", 3)
    assert scn.get("contact.probe") == [0.05, 0.0]
    assert scn.get("contact.obstacle_normal") == [0.0, 0.0, -1.0]
    said = r"&contact probe: expected 3 values in 3D \(got '0.05, 0.0'\)"
    with pytest.raises(BadInputError, match=r"^<scene>: " + said):
        scn.validate()
    path = write(tmp_path, "&mesh dim = 3 /\n&contact probe = 0.05, 0.0 /\n")
    with pytest.raises(BadInputError, match=said):
        Scene.read(path).validate()
    scn.set("contact.probe", [0.05, 0.05, 0.0])
    scn.validate()


#: The switching .geo's scene, spelling out the 2D defaults as bar2d_hht.nml does.
SPELLED_OUT = ("&mesh file = 'switch.geo', h = 0.5 /\n&initial kind = 'rest' /\n"
               "&contact obstacle_normal = 0.0, -1.0, probe = 0.05, 0.0 /\n")


@pytest.mark.parametrize("key, value", [("mesh.width", 1.0), ("mesh.h", 0.25),
                                        ("mesh.length", 1.0)])
def test_vector_defaults_follow_a_geo_made_3d_by_its_mesh_keys(tmp_path, key, value):
    """An &mesh h, length or width that makes the .geo a box makes the vectors 3D as
    &mesh dim = 3 does: those left out and those the file gives with the 2D default
    take the 3D defaults, and the scene validates; a vector set stays as set."""
    (tmp_path / "switch.geo").write_text(SWITCHING_GEO)
    path = write(tmp_path, SPELLED_OUT)
    scn = Scene.read(path)
    assert scn.dimension() == 2
    scn.set("initial.velocity", [0.0, 0.0])
    scn.set(key, value)
    assert scn.dimension() == 3
    for name in ("contact.probe", "contact.obstacle_normal", "material.gravity"):
        assert scn.get(name) == VECTOR_DEFAULTS[3][tuple(name.split("."))], name
    assert scn.get("initial.velocity") == [0.0, 0.0]
    with pytest.raises(BadInputError, match=r"&initial velocity: expected 3 values in 3D"):
        scn.validate()
    scn.set("initial.velocity", [0.0, 0.0, 0.0])
    scn.validate()
    scn.unset(key)                                    # back to the rectangle
    assert scn.dimension() == 2
    assert scn.get("contact.probe") == [0.05, 0.0]
