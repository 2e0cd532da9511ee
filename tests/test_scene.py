"""Scene files: the Fortran reader (fortran/scene.f90, through dyncontact._core) and
the Python one (dyncontact.scene.Scene) must read every file to the same values and
reject every bad file with the same one-line message naming the group and key."""

from __future__ import annotations

import json
import math
import os
import random
import subprocess
import sys
from collections import namedtuple
from pathlib import Path

import pytest

from conftest import ROOT, SUBPROCESS_TIMEOUT

from dyncontact.scene import SCHEMA, Scene, SceneError

SCENES_DIR = ROOT / "scripts" / "scenes"
SCENE_FILES = sorted(SCENES_DIR.glob("*.nml"))
#: Reals printed by the Fortran JSON must read back to Python's values.
REL_TOL = 1e-15
#: Status code of bad input (errors.f90 STAT_BAD_INPUT).
STAT_BAD_INPUT = 2

MISSING = object()     # no file at all
DIRECTORY = object()   # a folder where the scene file should be

#: A bad scene: content (str, bytes, MISSING or DIRECTORY); `where` is the
#: '&group key' (or '&group', or '' for file-level problems) that the message
#: must name right after 'PATH: '; `what` is a fragment of the explanation.
BadCase = namedtuple("BadCase", "id content where what")

BAD_CASES = [
    # structure
    BadCase("unknown_key", "&scheme foo = 1 /\n", "&scheme foo", "unknown key"),
    BadCase("unknown_key_upper", "&SCHEME Foo = 1 /\n", "&scheme foo", "unknown key"),
    BadCase("key_twice", "&scheme dt = 1e-3, dt = 2e-3 /\n", "&scheme dt", "given twice"),
    BadCase("unknown_group", "&schema dt = 1e-3 /\n", "&schema", "unknown group"),
    BadCase("group_twice", "&scheme dt = 1e-3 /\n&scheme t_end = 1.0 /\n", "&scheme",
            "given twice"),
    BadCase("unterminated_group", "&scheme dt = 1e-3\n", "&scheme", "unterminated group"),
    BadCase("unterminated_before_next", "&scheme dt = 1e-3\n&mesh h = 0.1 /\n", "&scheme",
            "unterminated group"),
    BadCase("unterminated_string", "&scheme name = 'hht /\n", "&scheme name",
            "unterminated string"),
    BadCase("indexed_key", "&material gravity(2) = -9.81 /\n", "&material gravity",
            "expected '='"),
    BadCase("missing_value", "&scheme dt = /\n", "&scheme dt", "missing value"),
    BadCase("empty_value", "&material gravity = 1.0,, 2.0 /\n", "&material gravity",
            "empty value"),
    BadCase("text_after_group", "&scheme dt = 1e-3 / trailing words\n", "",
            "text outside a group"),
    # file level
    BadCase("empty_file", "", "", "empty scene file"),
    BadCase("only_comments", "! nothing but a comment\n\n", "", "empty scene file"),
    BadCase("binary_file", bytes(range(256)) * 8, "", "not a text file"),
    BadCase("nul_in_text", b"&scheme dt = 1e-3 /\n\x00\n", "", "not a text file"),
    BadCase("garbage", "this is not a scene file\n", "", "text outside a group"),
    BadCase("garbage_symbols", "#%^ $$ {{ }} ::\n", "", "text outside a group"),
    BadCase("too_large", "! " + "x" * 1_100_000 + "\n&scheme /\n", "", "too large"),
    BadCase("giant_key", "&scheme " + "k" * 100_000 + " = 1 /\n", "&scheme " + "k" * 40 + "...",
            "unknown key"),
    BadCase("giant_number", "&output every = " + "0" * 500_000 + "1 /\n", "&output every",
            "out of range"),
    BadCase("missing_scene_file", MISSING, "", "cannot read scene file"),
    BadCase("scene_is_directory", DIRECTORY, "", "cannot read scene file"),
    # types
    BadCase("string_for_int", "&mesh dim = 'two' /\n", "&mesh dim", "expected an integer"),
    BadCase("real_for_int", "&scheme newton_maxit = 1.5 /\n", "&scheme newton_maxit",
            "expected an integer"),
    BadCase("int_out_of_range", "&output every = 99999999999 /\n", "&output every",
            "out of range"),
    BadCase("text_for_real", "&scheme dt = abc /\n", "&scheme dt", "expected a real number"),
    BadCase("string_for_real", "&scheme dt = '1e-3' /\n", "&scheme dt",
            "expected a real number"),
    BadCase("real_overflow", "&scheme t_end = 1d400 /\n", "&scheme t_end", "out of range"),
    BadCase("unquoted_string", "&scheme mass = lumped /\n", "&scheme mass",
            "expected a quoted string"),
    BadCase("too_many_values", "&contact probe = 0.05, 0.0, 0.0 /\n", "&contact probe",
            "expected 1 or 2 values"),
    BadCase("two_values_for_scalar", "&scheme dt = 1e-3, 2e-3 /\n", "&scheme dt",
            "expected 1 value"),
    # files named in the scene
    BadCase("missing_mesh_file", "&mesh file = 'no_such_mesh.msh' /\n", "&mesh file",
            "cannot read mesh file"),
    BadCase("mesh_file_is_directory", "&mesh file = '.' /\n", "&mesh file",
            "cannot read mesh file"),
    # ranges and choices
    BadCase("dim_3", "&mesh dim = 3 /\n", "&mesh dim", "must be 1 or 2"),
    BadCase("h_zero", "&mesh h = 0.0 /\n", "&mesh h", "must be > 0"),
    BadCase("h_negative", "&mesh h = -0.05 /\n", "&mesh h", "must be > 0"),
    BadCase("length_zero", "&mesh length = 0 /\n", "&mesh length", "must be > 0"),
    BadCase("young_zero", "&material young = 0.0 /\n", "&material young", "must be > 0"),
    BadCase("poisson_half", "&material poisson = 0.5 /\n", "&material poisson",
            "must be in (-1, 1/2)"),
    BadCase("poisson_minus_one", "&material poisson = -1.0 /\n", "&material poisson",
            "must be in (-1, 1/2)"),
    BadCase("density_negative", "&material density = -1.0 /\n", "&material density",
            "must be > 0"),
    BadCase("method_penalty", "&contact method = 'penalty' /\n", "&contact method",
            "must be 'nitsche'"),
    BadCase("theta_2", "&contact theta = 2 /\n", "&contact theta", "must be -1, 0 or 1"),
    BadCase("theta_real", "&contact theta = 1.0 /\n", "&contact theta",
            "expected an integer"),
    BadCase("gamma0_zero", "&contact gamma0 = 0.0 /\n", "&contact gamma0", "must be > 0"),
    BadCase("normal_zero", "&contact obstacle_normal = 0.0, 0.0 /\n",
            "&contact obstacle_normal", "nonzero"),
    BadCase("normal_1d_zero", "&mesh dim = 1 /\n&contact obstacle_normal = 0.0, -1.0 /\n",
            "&contact obstacle_normal", "nonzero in 1D"),
    BadCase("quadrature_unknown", "&contact quadrature = 'simpson' /\n",
            "&contact quadrature", "must be 'exact' or 'gauss'"),
    BadCase("quad_points_7", "&contact quad_points = 7 /\n", "&contact quad_points",
            "must be in 1..6"),
    BadCase("initial_kind_unknown", "&initial kind = 'moving' /\n", "&initial kind",
            "must be one of"),
    BadCase("scheme_unknown", "&scheme name = 'rk4' /\n", "&scheme name", "must be one of"),
    BadCase("hht_alpha_positive", "&scheme name = 'hht', alpha = 0.1 /\n", "&scheme alpha",
            "must be in [-1/3, 0]"),
    BadCase("hht_alpha_too_small", "&scheme name = 'hht', alpha = -0.34 /\n",
            "&scheme alpha", "must be in [-1/3, 0]"),
    BadCase("pc_hht_alpha_positive", "&scheme name = 'pc_hht', alpha = 0.2 /\n",
            "&scheme alpha", "must be in [-1/3, 0]"),
    BadCase("newmark_beta_zero", "&scheme name = 'newmark', beta = 0.0 /\n", "&scheme beta",
            "use 'pc'"),
    BadCase("newmark_gamma_negative", "&scheme name = 'newmark', gamma = -0.5 /\n",
            "&scheme gamma", "must be >= 0"),
    BadCase("theta_scheme_out", "&scheme name = 'theta', theta = 0.4 /\n", "&scheme theta",
            "must be in [1/2, 1]"),
    BadCase("dt_zero", "&scheme dt = 0.0 /\n", "&scheme dt", "must be > 0"),
    BadCase("dt_negative", "&scheme dt = -1e-3 /\n", "&scheme dt", "must be > 0"),
    BadCase("t_end_negative", "&scheme t_end = -1.0 /\n", "&scheme t_end", "must be >= 0"),
    BadCase("mass_unknown", "&scheme mass = 'diagonal' /\n", "&scheme mass",
            "must be 'consistent' or 'lumped'"),
    BadCase("newton_tol_zero", "&scheme newton_tol = 0.0 /\n", "&scheme newton_tol",
            "must be > 0"),
    BadCase("newton_maxit_zero", "&scheme newton_maxit = 0 /\n", "&scheme newton_maxit",
            "must be > 0"),
    BadCase("blowup_one", "&scheme blowup = 1.0 /\n", "&scheme blowup", "must be > 1"),
    BadCase("output_dir_empty", "&output dir = '' /\n", "&output dir", "must not be empty"),
    BadCase("every_zero", "&output every = 0 /\n", "&output every", "must be > 0"),
    BadCase("fields_every_negative", "&output fields_every = -1 /\n", "&output fields_every",
            "must be >= 0"),
]


def write_case(case: BadCase, folder: Path) -> Path:
    """Materialize a bad case in folder; returns the scene path to read."""
    path = folder / f"{case.id}.nml"
    if case.content is MISSING:
        return path
    if case.content is DIRECTORY:
        path.mkdir()
        return path
    data = case.content if isinstance(case.content, bytes) else case.content.encode()
    path.write_bytes(data)
    return path


def _text(b) -> str:
    if isinstance(b, bytes):
        b = b.decode("utf-8", "replace")
    return str(b).strip().strip("\x00").strip()


def fortran_read(core, path: Path, tmp_path: Path):
    """(stat, errmsg, dict or None) from the Fortran reader."""
    json_path = tmp_path / f"{path.name}.json"
    stat, errmsg = core.dc_scene_dump(str(path), str(json_path))
    if int(stat) != 0:
        return int(stat), _text(errmsg), None
    with open(json_path, encoding="utf-8") as fh:
        return 0, "", json.load(fh)


def python_read(path: Path):
    """(error message or '', dict or None) from the Python reader."""
    try:
        return "", Scene.read(path).to_dict()
    except SceneError as exc:
        return str(exc), None


def assert_same_values(a, b, where="scene"):
    """Same nested structure; reals equal to REL_TOL, everything else exactly."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and list(a) == list(b), (where, list(a), list(b))
        for k in a:
            assert_same_values(a[k], b[k], f"{where}.{k}")
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), (where, a, b)
        for i, (x, y) in enumerate(zip(a, b)):
            assert_same_values(x, y, f"{where}[{i}]")
    elif isinstance(a, float) or isinstance(b, float):
        assert isinstance(a, float) and isinstance(b, float), (where, a, b)
        assert math.isclose(a, b, rel_tol=REL_TOL, abs_tol=0.0), (where, a, b)
    else:
        assert type(a) is type(b) and a == b, (where, a, b)


# --------------------------------------------------------------------------- good files

def test_scene_files_exist():
    names = {p.name for p in SCENE_FILES}
    expected = {"bar2d_hht.nml", "bar1d.nml", "bar2d_newmark.nml", "bar2d_hht_seed.nml",
                "bar2d_theta.nml", "bar2d_pc.nml", "bar2d_pc_hht.nml",
                "bar2d_pc_hht_seed.nml"}
    assert expected <= names, expected - names


@pytest.mark.parametrize("path", SCENE_FILES, ids=lambda p: p.name)
def test_scene_file_same_in_both_readers(core_ext, path, tmp_path):
    stat, errmsg, f_dict = fortran_read(core_ext, path, tmp_path)
    assert stat == 0, errmsg
    p_msg, p_dict = python_read(path)
    assert p_msg == "", p_msg
    assert_same_values(f_dict, p_dict)
    # each file starts with a one-line comment and writes to out/<name>
    assert path.read_text().startswith("! ")
    assert p_dict["output"]["dir"] == f"out/{path.stem}"


def test_seed_default_scene_is_the_default():
    """bar2d_hht.nml spells out the defaults except the output folder."""
    scn = Scene.read(SCENES_DIR / "bar2d_hht.nml")
    scn.set("output.dir", "out")
    assert scn.to_dict() == Scene().to_dict()


def test_bar1d_scene():
    d = Scene.read(SCENES_DIR / "bar1d.nml").to_dict()
    assert d["mesh"]["dim"] == 1 and d["mesh"]["h"] == 0.01
    assert d["contact"]["obstacle_normal"] == [-1.0, 0.0]
    assert d["contact"]["probe"] == [0.0, 0.0]
    assert d["scheme"]["name"] == "newmark" and d["scheme"]["dt"] == 0.0005
    assert (d["scheme"]["beta"], d["scheme"]["gamma"]) == (0.25, 0.5)


def test_defaults_equal(core_ext, tmp_path):
    path = tmp_path / "defaults.nml"
    path.write_text("! all defaults\n&output /\n")
    stat, errmsg, f_dict = fortran_read(core_ext, path, tmp_path)
    assert stat == 0, errmsg
    assert_same_values(f_dict, Scene().to_dict())
    assert_same_values(Scene.read(path).to_dict(), Scene().to_dict())
    # and they are the table's defaults
    d = Scene().to_dict()
    for group, key, _typ, default, count in SCHEMA:
        assert d[group][key] == (list(default) if count == 2 else default), (group, key)


def test_syntax_variants_same_in_both_readers(core_ext, tmp_path):
    """Case, d exponents, repeat counts, blanks as separators, comments, quotes."""
    (tmp_path / "m.msh").write_text("$MeshFormat\n")
    path = tmp_path / "variants.nml"
    path.write_text(
        "! variants\r\n"
        "&MESH File = \"m.msh\" DIM=1 H=1D-2, length = 2. /\r\n"
        "&boundary clamped = 'top, left' ! two groups\n"
        "  slip_x = 'it''s', slip_y = \"a\"\"b\", contact = 'a!b/c&d' /\n"
        "&material gravity = 2*-9.81 young = .5e+1 /\n"
        "&contact obstacle_normal = -3.0\n  probe = 0.0 theta = -1 quad_points = +2 /\n"
        "&scheme name = 'theta' theta = 1 dt = 5E-4, t_end = 6 /\n"
        "! " + "y" * 200_000 + "\n")
    stat, errmsg, f_dict = fortran_read(core_ext, path, tmp_path)
    assert stat == 0, errmsg
    p_msg, p_dict = python_read(path)
    assert p_msg == "", p_msg
    assert_same_values(f_dict, p_dict)
    assert p_dict["mesh"]["file"] == os.path.join(str(tmp_path), "m.msh")
    assert p_dict["mesh"]["h"] == 0.01 and p_dict["mesh"]["length"] == 2.0
    assert p_dict["boundary"] == {"clamped": "top, left", "slip_x": "it's",
                                  "slip_y": 'a"b', "contact": "a!b/c&d"}
    assert p_dict["material"]["gravity"] == [-9.81, -9.81]
    assert p_dict["material"]["young"] == 5.0
    assert p_dict["contact"]["obstacle_normal"] == [-1.0, 0.0]
    assert p_dict["contact"]["theta"] == -1 and p_dict["contact"]["quad_points"] == 2
    assert p_dict["scheme"]["theta"] == 1.0


def test_normal_is_normalized(core_ext, tmp_path):
    path = tmp_path / "n.nml"
    path.write_text("&contact obstacle_normal = 3.0, -4.0 /\n")
    _, _, f_dict = fortran_read(core_ext, path, tmp_path)
    p = Scene.read(path).get("contact.obstacle_normal")
    assert_same_values(f_dict["contact"]["obstacle_normal"], p)
    assert p == [0.6, -0.8]


# --------------------------------------------------------------------------- round trip

@pytest.mark.parametrize("path", SCENE_FILES, ids=lambda p: p.name)
def test_write_round_trip(core_ext, path, tmp_path):
    scn = Scene.read(path)
    out = tmp_path / "written.nml"
    scn.write(out)
    stat, errmsg, f_dict = fortran_read(core_ext, out, tmp_path)
    assert stat == 0, errmsg
    assert_same_values(f_dict, scn.to_dict())
    assert Scene.read(out).to_dict() == scn.to_dict()


def test_write_round_trip_after_set(core_ext, tmp_path, monkeypatch):
    mesh = tmp_path / "meshes" / "bar.msh"
    mesh.parent.mkdir()
    mesh.write_text("$MeshFormat\n")
    monkeypatch.chdir(tmp_path)
    scn = Scene()
    scn.set("mesh.file", "meshes/bar.msh")          # relative to the current folder
    scn.set("scheme.dt", "0.001")
    scn.set("scheme.mass", "'lumped'")
    scn.set("scheme.name", "newmark")
    scn.set("scheme.beta", 0.3025)
    scn.set("scheme.gamma", "6d-1")
    scn.set("contact.obstacle_normal", "0.0,-2.0")
    scn.set("contact.probe", "0.02")
    scn.set("material.gravity", [0, -9.81])
    scn.set("boundary.clamped", "top, left")
    scn.set("boundary.slip_x", "it's \"quoted\"")
    scn.set("output.every", "10")
    scn.set("material.young", 1 / 3)
    out = tmp_path / "sub" / "scene.nml"
    out.parent.mkdir()
    scn.write(out)                                   # validates: normal normalized
    assert str(mesh) in out.read_text()              # written as an absolute path
    stat, errmsg, f_dict = fortran_read(core_ext, out, tmp_path)
    assert stat == 0, errmsg
    expected = scn.to_dict()
    expected["mesh"]["file"] = str(mesh)
    assert expected["contact"]["obstacle_normal"] == [0.0, -1.0]
    assert_same_values(f_dict, expected)
    assert Scene.read(out).to_dict() == expected


# --------------------------------------------------------------------------- get / set

@pytest.mark.parametrize("name, value, expected", [
    ("scheme.dt", "0.001", 0.001),
    ("scheme.dt", "1d-3", 0.001),
    ("scheme.dt", 2, 2.0),
    ("Scheme.DT", "5e-4", 0.0005),
    ("scheme.mass", "'lumped'", "lumped"),
    ("scheme.mass", '"lumped"', "lumped"),
    ("scheme.mass", "lumped", "lumped"),
    ("contact.obstacle_normal", "0.0,-1.0", [0.0, -1.0]),
    ("contact.obstacle_normal", "0.0 -1.0", [0.0, -1.0]),
    ("contact.obstacle_normal", (1, 0), [1.0, 0.0]),
    ("contact.probe", "0.0", [0.0, 0.0]),
    ("contact.probe", 0.5, [0.5, 0.0]),
    ("contact.theta", "-1", -1),
    ("scheme.theta", "1", 1.0),
    ("mesh.dim", 1, 1),
    ("mesh.file", "''", ""),
])
def test_set_coerces(name, value, expected):
    scn = Scene()
    scn.set(name, value)
    got = scn.get(name)
    assert got == expected and type(got) is type(expected)


@pytest.mark.parametrize("name, value, where", [
    ("scheme.foo", "1", "&scheme foo"),
    ("schemes.dt", "1", "unknown key"),
    ("dt", "1", "unknown key"),
    ("scheme.dt", "abc", "&scheme dt"),
    ("scheme.dt", "nan", "&scheme dt"),
    ("scheme.dt", float("inf"), "&scheme dt"),
    ("scheme.dt", True, "&scheme dt"),
    ("scheme.newton_maxit", "1.5", "&scheme newton_maxit"),
    ("scheme.newton_maxit", 2.0, "&scheme newton_maxit"),
    ("contact.probe", "1,2,3", "&contact probe"),
    ("scheme.mass", 3, "&scheme mass"),
    ("output.dir", "a\nb", "&output dir"),
])
def test_set_rejects(name, value, where):
    with pytest.raises(SceneError) as err:
        Scene().set(name, value)
    assert where in str(err.value)
    assert "\n" not in str(err.value)


def test_validate_after_set():
    scn = Scene()
    scn.set("scheme.dt", "-1")
    with pytest.raises(SceneError, match=r"^<scene>: &scheme dt: must be > 0"):
        scn.validate()
    scn.set("scheme.dt", "1e-3")
    scn.set("scheme.name", "hht")
    scn.set("scheme.alpha", "0.5")
    with pytest.raises(SceneError, match=r"&scheme alpha: must be in \[-1/3, 0\]"):
        scn.validate()
    scn.set("scheme.name", "hht_seed")   # the seed's variant takes any alpha
    scn.validate()


# --------------------------------------------------------------------------- bad files

@pytest.mark.parametrize("case", BAD_CASES, ids=lambda c: c.id)
def test_bad_scene_both_readers(core_ext, case, tmp_path):
    path = write_case(case, tmp_path)
    prefix = f"{path}: {case.where}:" if case.where else f"{path}: "
    stat, f_msg, _ = fortran_read(core_ext, path, tmp_path)
    assert stat == STAT_BAD_INPUT, (stat, f_msg)
    p_msg, p_dict = python_read(path)
    assert p_dict is None, "the Python reader accepted it"
    for msg in (f_msg, p_msg):
        assert msg.startswith(prefix), (msg, prefix)
        assert case.what in msg, (msg, case.what)
        assert "\n" not in msg and len(msg) < 512
    assert f_msg == p_msg


#: Scenes both readers accept, whose errors only the mesh can reveal (checked by
#: tests/test_bad_input_cli.py through the executables).
MESH_CASES = [
    BadCase("boundary_group_missing", "&boundary clamped = 'no_such_group' /\n",
            "&boundary clamped", "no_such_group"),
    BadCase("probe_off_contact", "&contact probe = 0.05, 0.5 /\n", "&contact probe", ""),
]


@pytest.mark.parametrize("case", MESH_CASES, ids=lambda c: c.id)
def test_mesh_dependent_cases_are_valid_scenes(core_ext, case, tmp_path):
    path = write_case(case, tmp_path)
    stat, f_msg, _ = fortran_read(core_ext, path, tmp_path)
    assert stat == 0, f_msg
    assert python_read(path)[0] == ""


# --------------------------------------------------------------------------- fuzzing

_FUZZ_SCRIPT = r"""
import json, sys
from dyncontact import _core
from dyncontact.scene import Scene, SceneError
for path in sys.argv[1:]:
    stat, errmsg = _core.dc_scene_dump(path, path + '.json')
    f = errmsg.decode('utf-8', 'replace').strip() if int(stat) else json.load(open(path + '.json'))
    try:
        p = Scene.read(path).to_dict()
    except SceneError as exc:
        p = str(exc)
    print(json.dumps([path, int(stat), f, p]))
"""

_FUZZ_PIECES = list("&/!=,'\" \n\t*.-+0123456789eEdDxyz_") + [
    "\r", "\x00", "\xe9", "dt", "name", "&scheme", "'hht'", "1.5", "2*", "mesh", "theta"]


def test_fuzzed_scenes_same_in_both_readers(tmp_path):
    """Mutated scene files: the Fortran reader never dies (it runs in a subprocess),
    and both readers give the same values or the same message."""
    rng = random.Random(20240607)
    bases = [p.read_text() for p in SCENE_FILES] or ["&scheme dt = 1e-3 /\n"]
    paths = []
    for i in range(300):
        s = rng.choice(bases)
        for _ in range(rng.randint(1, 4)):
            pos = rng.randrange(len(s) + 1)
            op = rng.random()
            if op < 0.4:
                s = s[:pos] + rng.choice(_FUZZ_PIECES) + s[pos:]
            elif op < 0.7:
                s = s[:pos] + s[pos + rng.randint(1, 6):]
            else:
                a, b = sorted((pos, rng.randrange(len(s) + 1)))
                s = s[:a] + s[b:b + 8] + s[a:]
        path = tmp_path / f"fuzz{i}.nml"
        path.write_bytes(s.encode("latin-1"))
        paths.append(str(path))
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    res = subprocess.run([sys.executable, "-c", _FUZZ_SCRIPT, *paths], capture_output=True,
                         text=True, timeout=SUBPROCESS_TIMEOUT, env=env)
    assert res.returncode == 0, res.stderr[-2000:]
    rows = [json.loads(line) for line in res.stdout.splitlines()]
    assert len(rows) == len(paths)
    n_ok = 0
    for path, stat, f, p in rows:
        if stat == 0:
            assert isinstance(p, dict), (path, p)
            assert_same_values(f, p, path)
            n_ok += 1
        else:
            assert stat == STAT_BAD_INPUT, (path, stat, f)
            assert f == p, (path, f, p)
    assert n_ok > 0
