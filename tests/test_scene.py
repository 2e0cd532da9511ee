"""Scene files, read by the one reader (fortran/io/scene.f90) through both entry points:
dyncontact._core directly and dyncontact.Scene (which only edits and writes). Every good
file must read to the values written in it, every bad file must be refused with one line
naming the file, group and key."""

from __future__ import annotations

import json
import os
import random
import re
import subprocess
import sys
import warnings
from collections import namedtuple
from pathlib import Path

import numpy as np
import pytest

from conftest import ROOT, SCHEME_PARAMS, SUBPROCESS_TIMEOUT, drop_unused

import dyncontact
from dyncontact import BadInputError, Scene, SceneError

SCENES_DIR = ROOT / "scripts" / "scenes"
SCENE_FILES = sorted(SCENES_DIR.glob("*.nml"))
#: Status code of bad input (errors.f90 STAT_BAD_INPUT).
STAT_BAD_INPUT = 2
#: The keys of the first scene dump (summary.json "scene"); readers of older summaries
#: rely on them, so they must all stay.
KEYS_BEFORE = {
    "mesh": ["file", "dim", "length", "width", "h"],
    "boundary": ["clamped", "slip_x", "slip_y", "contact"],
    "material": ["young", "poisson", "density", "gravity"],
    "contact": ["method", "theta", "gamma0", "obstacle_point", "obstacle_normal", "probe",
                "quadrature", "quad_points"],
    "initial": ["kind", "amplitude", "velocity"],
    "scheme": ["name", "alpha", "beta", "gamma", "theta", "dt", "t_end", "mass",
               "newton_tol", "newton_maxit", "blowup"],
    "output": ["dir", "every", "fields_every"],
}

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
    BadCase("empty_file", b"", "", "empty scene file"),
    BadCase("binary_file", bytes(range(256)) * 8, "", "not a text file"),
    BadCase("utf16_file", "&scheme dt = 1e-3 /\n".encode("utf-16"), "", "UTF-16 text"),
    BadCase("utf16_be_file", b"\xfe\xff" + "&scheme dt = 1e-3 /\n".encode("utf-16-be"), "",
            "UTF-16 text (byte-order mark FE FF)"),
    # a string value goes into summary.json (UTF-8): Latin-1, a surrogate, an overlong form
    BadCase("latin1_string", b"&output dir = 'r\xe9sultats' /\n", "&output dir",
            "not UTF-8 text (byte 233 at character 2"),
    BadCase("surrogate_string", b"&boundary contact = 'a\xed\xa0\x80' /\n",
            "&boundary contact", "not UTF-8 text (byte 237 at character 2"),
    BadCase("overlong_string", b"&boundary clamped = '\xc0\xaf' /\n", "&boundary clamped",
            "not UTF-8 text (byte 192 at character 1"),
    BadCase("truncated_utf8_string", b"&mesh file = 'm\xe2\x82' /\n", "&mesh file",
            "not UTF-8 text (byte 226 at character 2"),
    BadCase("nul_in_text", b"&scheme dt = 1e-3 /\n\x00\n", "", "not a text file"),
    BadCase("garbage", "this is not a scene file\n", "", "text outside a group"),
    BadCase("garbage_symbols", "#%^ $$ {{ }} ::\n", "", "text outside a group"),
    BadCase("too_large", "! " + "x" * 1_100_000 + "\n&scheme /\n", "", "too large"),
    BadCase("giant_key", "&scheme " + "k" * 100_000 + " = 1 /\n", "&scheme " + "k" * 40 + "...",
            "unknown key"),
    BadCase("giant_number", "&output every = " + "0" * 500_000 + "1 /\n", "&output every",
            "out of range"),
    BadCase("missing_scene_file", MISSING, "", "no such scene file"),
    BadCase("scene_is_directory", DIRECTORY, "", "a folder, not a scene file"),
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
    # forms the list-directed read would take, each hiding a slip: an exponent without
    # its letter (2.5+1 reads as 25), text after ';' (dropped), a repeat too many for a
    # vector, a quad-precision letter, Fortran kind suffixes
    BadCase("nan_real", "&material young = NaN /\n", "&material young",
            "expected a real number"),
    BadCase("real_sum", "&scheme dt = 2.5+1 /\n", "&scheme dt", "expected a real number"),
    BadCase("real_no_exponent_letter", "&scheme dt = 1-3 /\n", "&scheme dt",
            "expected a real number"),
    BadCase("semicolon_in_value", "&scheme dt = 1e-3;5 /\n", "&scheme dt",
            "expected a real number"),
    BadCase("semicolon_between_keys", "&scheme dt = 1e-3; t_end = 1.0 /\n", "&scheme dt",
            "expected a real number"),
    BadCase("semicolon_in_vector", "&material gravity = 0.0;-9.81 /\n", "&material gravity",
            "expected a real number"),
    BadCase("repeat_too_many", "&material gravity = 3*0.0 /\n", "&material gravity",
            "expected 1 or 2 values"),
    BadCase("repeat_null", "&material gravity = 2* /\n", "&material gravity", "empty value"),
    BadCase("quad_letter", "&scheme dt = 1.0q-3 /\n", "&scheme dt", "expected a real number"),
    BadCase("kind_suffix", "&scheme dt = 1.0e-3_dp /\n", "&scheme dt",
            "expected a real number"),
    BadCase("array_element", "&material gravity(2) = -9.81 /\n", "&material gravity",
            "expected '='"),
    BadCase("old_end_marker", "&scheme dt = 1e-3 &end\n", "&scheme", "unterminated group"),
    BadCase("dollar_groups", "$scheme dt = 1e-3 $end\n", "", "text outside a group"),
    BadCase("unquoted_string", "&scheme mass = lumped /\n", "&scheme mass",
            "expected a quoted string"),
    BadCase("too_many_values", "&contact probe = 0.05, 0.0, 0.0 /\n", "&contact probe",
            "expected 1 or 2 values in 2D"),
    BadCase("many_values", "&scheme dt = " + "1, " * 300_000 + "1 /\n", "&scheme dt",
            "expected 1 value (got '1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1,"),
    BadCase("two_values_for_scalar", "&scheme dt = 1e-3, 2e-3 /\n", "&scheme dt",
            "expected 1 value"),
    # files named in the scene
    BadCase("missing_mesh_file", "&mesh file = 'no_such_mesh.msh' /\n", "&mesh file",
            "cannot read mesh file"),
    BadCase("mesh_file_is_directory", "&mesh file = '.' /\n", "&mesh file",
            "cannot read mesh file"),
    # ranges and choices
    BadCase("dim_4", "&mesh dim = 4 /\n", "&mesh dim", "must be 0, 1, 2 or 3"),
    # vectors against the dimension
    BadCase("vector_2_in_3d", "&mesh dim = 3 /\n&contact probe = 0.05, 0.0 /\n",
            "&contact probe", "expected 3 values in 3D (got '0.05, 0.0')"),
    BadCase("gravity_1_in_3d", "&mesh dim = 3 /\n&material gravity = -9.81 /\n",
            "&material gravity", "expected 3 values in 3D"),
    BadCase("vector_3_in_2d", "&initial velocity = 0.0, 0.0, 1.0 /\n", "&initial velocity",
            "expected 1 or 2 values in 2D"),
    BadCase("vector_4_values", "&mesh dim = 3 /\n&initial velocity = 0, 0, 1, 2 /\n",
            "&initial velocity", "expected 3 values in 3D (got '0, 0, 1, 2')"),
    BadCase("vector_4_values_2d", "&material gravity = 0, -9.81, 0, 0 /\n",
            "&material gravity", "expected 1 or 2 values in 2D (got '0, -9.81, 0, 0')"),
    # a 1D mesh uses component 1 only: a nonzero second component is not dropped unseen
    BadCase("gravity_2d_in_1d", "&mesh dim = 1 /\n&material gravity = 0.0, -9.81 /\n",
            "&material gravity", "expected 1 value in 1D, or 2 whose second is 0"),
    BadCase("velocity_2d_in_1d",
            "&mesh dim = 1 /\n&initial kind = 'velocity', velocity = 0.0, -1.0 /\n",
            "&initial velocity", "expected 1 value in 1D, or 2 whose second is 0"),
    BadCase("normal_2d_in_1d", "&mesh dim = 1 /\n&contact obstacle_normal = 0.0, -1.0 /\n",
            "&contact obstacle_normal", "expected 1 value in 1D, or 2 whose second is 0"),
    BadCase("vector_4_values_dim_unknown",
            f"&mesh file = '{ROOT / 'meshes' / 'bar3d_getfem_h0.05.msh'}' /\n"
            "&material gravity = 0, 0, 0, 0 /\n",
            "&material gravity", "expected 1, 2 or 3 values (got '0, 0, 0, 0')"),
    BadCase("quad_points_7_in_2d", "&contact quadrature = 'gauss', quad_points = 7 /\n",
            "&contact quad_points", "must be in 1..6 in 2D"),
    BadCase("quad_points_4_in_3d",
            "&mesh dim = 3 /\n&contact quadrature = 'gauss', quad_points = 4 /\n",
            "&contact quad_points", "must be 1, 3, 6 or 7 in 3D"),
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
    BadCase("method_unknown", "&contact method = 'mortar' /\n", "&contact method",
            "must be one of 'nitsche', 'penalty', 'alm'"),
    BadCase("theta_2", "&contact theta = 2 /\n", "&contact theta", "must be -1, 0 or 1"),
    BadCase("theta_real", "&contact theta = 1.0 /\n", "&contact theta",
            "expected an integer"),
    BadCase("gamma0_zero", "&contact gamma0 = 0.0 /\n", "&contact gamma0", "must be > 0"),
    BadCase("normal_zero", "&contact obstacle_normal = 0.0, 0.0 /\n",
            "&contact obstacle_normal", "nonzero"),
    BadCase("normal_1d_zero", "&mesh dim = 1 /\n&contact obstacle_normal = 0.0 /\n",
            "&contact obstacle_normal", "nonzero in 1D"),
    BadCase("quadrature_unknown", "&contact quadrature = 'simpson' /\n",
            "&contact quadrature", "must be 'exact' or 'gauss'"),
    BadCase("quad_points_8", "&contact quad_points = 8 /\n", "&contact quad_points",
            "must be in 1..7"),
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
            "is scheme 'central'"),
    BadCase("newmark_gamma_negative", "&scheme name = 'newmark', gamma = -0.5 /\n",
            "&scheme gamma", "must be >= 0"),
    BadCase("theta_scheme_out", "&scheme name = 'theta', theta = 0.4 /\n", "&scheme theta",
            "must be in [1/2, 1]"),
    BadCase("dt_zero", "&scheme dt = 0.0 /\n", "&scheme dt", "must be > 0"),
    BadCase("dt_negative", "&scheme dt = -1e-3 /\n", "&scheme dt", "must be > 0"),
    BadCase("t_end_negative", "&scheme t_end = -1.0 /\n", "&scheme t_end", "must be >= 0"),
    BadCase("t_end_below_dt", "&scheme dt = 1e-3, t_end = 5e-4 /\n", "&scheme t_end",
            "must be 0 or at least dt = 1.000E-003"),
    BadCase("steps_overflow", "&scheme dt = 1e-300 /\n", "&scheme dt",
            "more than &scheme max_steps = 100000000"),
    BadCase("steps_over_limit", "&scheme t_end = 2e3, dt = 1e-6 /\n", "&scheme dt",
            "t_end / dt = 2.000E+009 steps"),
    BadCase("steps_over_own_limit", "&scheme t_end = 1.0, dt = 1e-3, max_steps = 999 /\n",
            "&scheme dt", "more than &scheme max_steps = 999"),
    BadCase("max_steps_zero", "&scheme max_steps = 0 /\n", "&scheme max_steps", "must be > 0"),
    BadCase("bar_too_fine", "&mesh h = 1e-4 /\n", "&mesh h",
            "2.000E+007 elements, more than &mesh max_elements = 2000000"),
    BadCase("bar_over_own_limit", "&mesh h = 0.05, max_elements = 79 /\n", "&mesh h",
            "8.000E+001 elements, more than &mesh max_elements = 79"),
    BadCase("bar1d_too_fine", "&mesh dim = 1, h = 1e-300 /\n&contact obstacle_normal = -1 /\n",
            "&mesh h", "more than &mesh max_elements"),
    BadCase("mass_unknown", "&scheme mass = 'diagonal' /\n", "&scheme mass",
            "must be one of 'consistent', 'lumped', 'redistributed'"),
    BadCase("mass_redistributed_explicit",
            "&scheme name = 'pc', dt = 0.0005, mass = 'redistributed' /\n", "&scheme mass",
            "the redistributed mass (no inertia on the contact nodes) needs an implicit scheme, "
            "and &scheme name = 'pc' is explicit in its contact (got 'redistributed')"),
    BadCase("alm_explicit", "&contact method = 'alm' /\n&scheme name = 'central', dt = 0.001 /\n",
            "&contact method", "the augmented Lagrangian (multipliers solved with the "
            "displacement by Newton) needs an implicit scheme, and &scheme name = 'central' "
            "is explicit (got 'alm')"),
    BadCase("alm_pc", "&contact method = 'alm' /\n&scheme name = 'pc', dt = 0.0005 /\n",
            "&contact method", "needs an implicit scheme, and &scheme name = 'pc' is explicit "
            "in its contact (got 'alm')"),
    BadCase("multiplier_unknown", "&contact method = 'alm', multiplier = 'mortar' /\n",
            "&contact multiplier", "must be 'integral' or 'nodal'"),
    BadCase("dt_zero_implicit", "&scheme dt = 0.0 /\n", "&scheme dt",
            "must be > 0 (0, a step chosen by the run, is for scheme 'central')"),
    BadCase("dt_negative_central", "&scheme name = 'central', dt = -1e-3 /\n", "&scheme dt",
            "must be >= 0 for scheme 'central'"),
    BadCase("rho_inf_above_one", "&scheme name = 'galpha', rho_inf = 1.5 /\n",
            "&scheme rho_inf", "must be in [0, 1] for scheme 'galpha'"),
    BadCase("newton_tol_zero", "&scheme newton_tol = 0.0 /\n", "&scheme newton_tol",
            "must be in (0, 1)"),
    # a relative tolerance of 1 or more stops every Newton at its first iterate
    BadCase("newton_tol_one", "&scheme newton_tol = 1.0 /\n", "&scheme newton_tol",
            "must be in (0, 1) (got '1.0')"),
    BadCase("newton_tol_huge", "&scheme newton_tol = 1e308 /\n", "&scheme newton_tol",
            "must be in (0, 1) (got '1e308')"),
    BadCase("newton_maxit_zero", "&scheme newton_maxit = 0 /\n", "&scheme newton_maxit",
            "must be > 0"),
    BadCase("blowup_one", "&scheme blowup = 1.0 /\n", "&scheme blowup", "must be > 1"),
    BadCase("output_dir_empty", "&output dir = '' /\n", "&output dir", "must not be empty"),
    BadCase("every_zero", "&output every = 0 /\n", "&output every", "must be > 0"),
    BadCase("fields_every_negative", "&output fields_every = -1 /\n", "&output fields_every",
            "must be >= 0"),
    BadCase("checkpoint_every_negative", "&output checkpoint_every = -1 /\n",
            "&output checkpoint_every", "must be >= 0"),
    BadCase("solver_threads_three", "&solver threads = 3 /\n", "&solver threads",
            "must be 0, 1 or 2"),
    BadCase("solver_threads_negative", "&solver threads = -1 /\n", "&solver threads",
            "must be 0, 1 or 2"),
    BadCase("solver_threads_name", "&solver threads = 'auto' /\n", "&solver threads",
            "expected an integer, not a string"),
    # a quoted value is quoted as written, not with its quotes doubled (''abc'')
    BadCase("real_given_a_string", "&scheme dt = 'abc' /\n", "&scheme dt",
            "expected a real number, not a string (got \"'abc'\")"),
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
    """(stat, errmsg, dict or None) from the core's dc_scene_dump."""
    json_path = tmp_path / f"{path.name}.json"
    _given, stat, errmsg = core.dc_scene_dump(str(path), str(json_path))
    if int(stat) != 0:
        return int(stat), _text(errmsg), None
    with open(json_path, encoding="utf-8") as fh:
        return 0, "", json.load(fh)


def scene_text(tmp_path: Path, text: str, name: str = "s.nml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


# --------------------------------------------------------------------------- good files

def test_scene_files_exist():
    names = {p.name for p in SCENE_FILES}
    expected = {"bar2d_hht.nml", "bar1d.nml", "bar2d_newmark.nml", "bar2d_hht_seed.nml",
                "bar2d_theta.nml", "bar2d_pc.nml", "bar2d_pc_hht.nml",
                "bar2d_pc_hht_seed.nml", "bar2d_alm_consistent.nml", "bar2d_alm_redistributed.nml"}
    assert expected <= names, expected - names


@pytest.mark.parametrize("path", SCENE_FILES, ids=lambda p: p.name)
def test_scene_file_reads(core_ext, path, tmp_path):
    stat, errmsg, f_dict = fortran_read(core_ext, path, tmp_path)
    assert stat == 0, errmsg
    assert Scene.read(path).to_dict() == f_dict
    # each file starts with a one-line comment and writes to out/<name>
    assert path.read_text().startswith("! ")
    assert f_dict["output"]["dir"] == f"out/{path.stem}"


def test_dump_keeps_the_keys_it_had(tmp_path):
    d = Scene().to_dict()
    # new groups come after the old ones (&solver), as new keys come after a group's old keys
    assert list(d)[:len(KEYS_BEFORE)] == list(KEYS_BEFORE)
    for group, keys in KEYS_BEFORE.items():
        assert [k for k in d[group] if k in keys] == keys, group


def test_seed_default_scene_is_the_default():
    """bar2d_hht.nml spells out the defaults except the output folder, and dim = 2, the
    dimension the default dim = 0 gives the built-in bar."""
    scn = Scene.read(SCENES_DIR / "bar2d_hht.nml")
    assert scn.get("mesh.dim") == 2
    scn.set("output.dir", "out")
    scn.set("mesh.dim", 0)
    assert scn == Scene()


def test_defaults_are_the_documented_ones(tmp_path):
    """The example of docs/scenes.md lists every key with its default: read as a scene it
    gives the defaults, and every key has a row in its group's table."""
    doc = (ROOT / "docs" / "scenes.md").read_text()
    block = doc.split("```fortran\n", 1)[1].split("```", 1)[0]
    assert Scene.read(scene_text(tmp_path, block)) == Scene()
    # every key is written in the block, in its group (a key left out would read to its
    # default too, so the equality above cannot see a missing one)
    groups = dict(re.findall(r"&(\w+)\s+(.*?)/\n", block, flags=re.S))
    for group, keys in Scene().to_dict().items():
        assert group in groups, group
        written = set(re.findall(r"\b(\w+) =", re.sub(r"!.*", "", groups[group])))
        assert written == set(keys), (group, set(keys) ^ written)
    for group, keys in Scene().to_dict().items():
        section = doc.split(f"### `&{group}`", 1)[1].split("\n### ", 1)[0]
        for key in keys:
            assert f"| `{key}` |" in section, (group, key)


def test_defaults_values():
    d = Scene().to_dict()
    assert d["material"]["young"] == 2 / 3 and d["material"]["poisson"] == 1 / 3
    assert d["scheme"]["name"] == "hht" and d["scheme"]["dt"] == 0.0025
    assert d["scheme"]["max_steps"] == 100_000_000 and d["mesh"]["max_elements"] == 2_000_000
    # a vector key not given is None in the dump (the default of the mesh's dimension),
    # and get gives that default
    assert d["contact"]["obstacle_normal"] is None
    assert Scene().get("contact.obstacle_normal") == [0.0, -1.0]


@pytest.mark.parametrize("content", ["! nothing but a comment\n\n", "\n  \t\n", "\n",
                                     "! all defaults\n&output /\n", "&mesh /\n&scheme /\n"])
def test_empty_scene_is_the_default(core_ext, content, tmp_path):
    """A file with only blanks, comments or empty groups is the default scene
    (docs/scenes.md); a 0-byte file is refused (BAD_CASES 'empty_file')."""
    path = scene_text(tmp_path, content)
    stat, errmsg, f_dict = fortran_read(core_ext, path, tmp_path)
    assert stat == 0, errmsg
    assert f_dict == Scene().to_dict()
    assert Scene.read(path) == Scene()


def test_byte_order_mark_is_skipped(core_ext, tmp_path):
    """A UTF-8 byte-order mark before the text reads like the same file without it,
    with LF or CRLF line ends; a mark anywhere else is still text outside a group."""
    text = "! saved by an editor\n&scheme name = 'newmark', dt = 1e-3 /\n&mesh h = 0.1 /\n"
    plain = scene_text(tmp_path, text, "plain.nml")
    ref = fortran_read(core_ext, plain, tmp_path)
    assert ref[0] == 0 and ref[2]["scheme"]["dt"] == 1e-3, ref
    for name, data in [("bom.nml", text.encode()),
                       ("bom_crlf.nml", text.replace("\n", "\r\n").encode())]:
        path = tmp_path / name
        path.write_bytes(b"\xef\xbb\xbf" + data)
        assert fortran_read(core_ext, path, tmp_path)[2] == ref[2], name
        assert Scene.read(path) == Scene.read(plain)
    only_bom = tmp_path / "only_bom.nml"
    only_bom.write_bytes(b"\xef\xbb\xbf")
    assert fortran_read(core_ext, only_bom, tmp_path)[2] == Scene().to_dict()
    twice = tmp_path / "twice.nml"
    twice.write_bytes(b"\xef\xbb\xbf\xef\xbb\xbf" + text.encode())
    stat, msg, _ = fortran_read(core_ext, twice, tmp_path)
    assert stat == STAT_BAD_INPUT and msg.startswith(f"{twice}: line 1: text outside a group"), msg


def test_utf8_strings_are_kept(core_ext, tmp_path):
    """Well-formed UTF-8 of 2, 3 and 4 bytes in a string value reads as written."""
    path = tmp_path / "u.nml"
    path.write_bytes("&boundary contact = 'bas_é€😀' /\n".encode())
    stat, msg, d = fortran_read(core_ext, path, tmp_path)
    assert stat == 0, msg
    assert d["boundary"]["contact"] == "bas_é€😀"


def test_run_refuses_empty_file(tmp_path):
    """dyncontact.run on a 0-byte scene raises BadInputError naming the file."""
    path = tmp_path / "copy_failed.nml"
    path.write_bytes(b"")
    with pytest.raises(BadInputError, match=f"^{path}: empty scene file"):
        dyncontact.run(path, out=tmp_path / "out")
    assert not (tmp_path / "out" / "trace.csv").exists()


def test_bar1d_scene():
    d = Scene.read(SCENES_DIR / "bar1d.nml").to_dict()
    assert d["mesh"]["dim"] == 1 and d["mesh"]["h"] == 0.01
    assert d["contact"]["obstacle_normal"] == [-1.0, 0.0]
    assert d["contact"]["probe"] == [0.0, 0.0]
    assert d["scheme"]["name"] == "newmark" and d["scheme"]["dt"] == 0.0005
    assert (d["scheme"]["beta"], d["scheme"]["gamma"]) == (0.25, 0.5)


def test_syntax_variants(tmp_path):
    """Case, d exponents, repeat counts, blanks as separators, comments, quotes."""
    (tmp_path / "m.msh").write_text("$MeshFormat\n")
    path = scene_text(tmp_path, (
        "! variants\r\n"
        "&MESH File = \"m.msh\" DIM=1 H=1D-2, length = 2. /\r\n"
        "&boundary clamped = 'top, left' ! two groups\n"
        "  slip_x = 'it''s', slip_y = \"a\"\"b\", contact = 'a!b/c&d' /\n"
        "&material gravity = 2*-9.81 young = .5e+1 /\n"
        "&contact obstacle_normal = 3.0\n  probe = 0.0 theta = -1 quad_points = +2 /\n"
        "&scheme name = 'theta' theta = 1 dt = 5E-4, t_end = 6 /\n"
        "! " + "y" * 200_000 + "\n"), "variants.nml")
    d = Scene.read(path).to_dict()
    assert d["mesh"]["file"] == os.path.join(str(tmp_path), "m.msh")
    assert d["mesh"]["h"] == 0.01 and d["mesh"]["length"] == 2.0
    assert d["mesh"]["dim"] == 1          # kept (checked against the file's when it is read)
    assert d["boundary"] == {"clamped": "top, left", "slip_x": "it's",
                             "slip_y": 'a"b', "slip_z": "", "contact": "a!b/c&d"}
    assert d["material"]["gravity"] == [-9.81, -9.81]
    assert d["material"]["young"] == 5.0
    assert d["contact"]["obstacle_normal"] == [1.0, 0.0]   # 2D rule: normalized
    assert d["contact"]["theta"] == -1 and d["contact"]["quad_points"] == 2
    assert d["scheme"]["theta"] == 1.0 and d["scheme"]["dt"] == 5e-4


def test_tabs_repeats_and_other_namelist_forms(core_ext, tmp_path):
    """Tabs wherever blanks go, repeat counts, a comma before '/', no blanks at all,
    '1*x', signs and exponents in e/E/d/D: each file reads like the plain one."""
    plain = scene_text(tmp_path, "&material gravity = -1.0, -1.0, young = 2.0 /\n"
                       "&scheme name = 'theta', dt = 0.001, t_end = 0.5 /\n", "plain.nml")
    ref = fortran_read(core_ext, plain, tmp_path)
    assert ref[0] == 0, ref
    forms = {
        "tabs": "&material\tgravity\t=\t-1.0,\t-1.0\tyoung\t=\t2.0\t/\n"
                "\t&scheme\tname='theta'\tdt=0.001\tt_end=0.5/\n",
        "repeat": "&material gravity = 2*-1.0, young = 1*2.0 /\n"
                  "&scheme name = 'theta', dt = 1*1d-3, t_end = 5E-1 /\n",
        "trailing_comma": "&material gravity = -1.0, -1.0, young = 2.0, /\n"
                          "&scheme name = 'theta', dt = 0.001, t_end = 0.5, /\n",
        "no_blanks": "&material gravity=-1.,-1.,young=+2./\n"
                     "&scheme name='theta',dt=.1e-2,t_end=0.5D0/\n",
        "one_per_line": "&material\n gravity =\n -1.0\n -1.0\n young\n =\n 2.0\n/\n"
                        "&scheme\n name = 'theta' ! the scheme\n dt = 1.0e-03\n t_end = .5\n/\n",
    }
    for name, text in forms.items():
        got = fortran_read(core_ext, scene_text(tmp_path, text, f"{name}.nml"), tmp_path)
        assert got[0] == 0 and got[2] == ref[2], (name, got[1])


#: Every numeric key, and values that are not finite reals or that overflow.
NUMERIC_KEYS = [(g, k) for g, kv in Scene().to_dict().items() for k, v in kv.items()
                if not isinstance(v, str)]
NOT_FINITE = ["nan", "NaN", "-nan", "inf", "+Inf", "-Infinity", "INFINITY", "nan(0x1)",
              "1e400", "-1d999", "2*nan", "0.0, nan", "inf, 0.0", "0.0 -inf"]


@pytest.mark.parametrize("group, key", NUMERIC_KEYS, ids=lambda x: str(x))
def test_nan_and_inf_are_refused_in_every_key(core_ext, group, key, tmp_path):
    """NaN or Inf, in any spelling the list-directed read knows, or a value that
    overflows, in any real, vector or integer key: one line naming the key."""
    for k, value in enumerate(NOT_FINITE):
        path = scene_text(tmp_path, f"&{group} {key} = {value} /\n", f"v{k}.nml")
        stat, msg, _ = fortran_read(core_ext, path, tmp_path)
        assert stat == STAT_BAD_INPUT, (value, msg)
        assert msg.startswith(f"{path}: &{group} {key}: "), (value, msg)
        assert "\n" not in msg


def test_read_scene_keeps_its_mesh_file_after_a_change_of_folder(tmp_path, monkeypatch):
    """A scene read by a relative path, whose relative &mesh file counts from the scene's
    folder, still finds its mesh once the process has changed its current folder (a
    notebook's %cd before the run): the Scene held the path relative to the folder it was
    read from, and validate() then said "cannot read mesh file 'sub/disk.geo'"."""
    sub = tmp_path / "sub"
    sub.mkdir()
    (sub / "disk.geo").write_text((ROOT / "meshes" / "disk.geo").read_text())
    scene_text(sub, "&mesh file = 'disk.geo' /\n&contact probe = 0.0, 0.01 /\n")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(tmp_path)
    scn = Scene.read("sub/s.nml")
    monkeypatch.chdir(elsewhere)
    assert os.path.samefile(scn.get("mesh.file"), sub / "disk.geo")
    scn.validate()
    assert scn.dimension() == 2


def test_normal_is_normalized(tmp_path):
    path = scene_text(tmp_path, "&contact obstacle_normal = 3.0, -4.0 /\n")
    assert Scene.read(path).get("contact.obstacle_normal") == [0.6, -0.8]


def test_dim_given_with_a_mesh_file_must_be_the_files(tmp_path):
    """dim = 1 with a 2D mesh file: the 1D check of the normal does not apply (the mesh
    decides the dimension), and the model refuses the dim that is not the file's, naming
    the key and the file; left out (0, the default) or 2, the model is built from it."""
    mesh = ROOT / "meshes" / "bar2d_getfem_h0.05.msh"
    path = scene_text(tmp_path, f"&mesh file = '{mesh}', dim = 1 /\n")
    scn = Scene.read(path)
    assert scn.get("contact.obstacle_normal") == [-1.0, 0.0]    # the default of dim = 1
    with pytest.raises(BadInputError, match=f"&mesh dim: 1 given, but the mesh file "
                                            f"'{mesh}' is 2D"):
        dyncontact.core.Model(path)
    for keys in ("", ", dim = 2"):
        ok = scene_text(tmp_path, f"&mesh file = '{mesh}'{keys} /\n", "ok.nml")
        assert Scene.read(ok).get("mesh.dim") == (2 if keys else 0)
        with dyncontact.core.Model(ok) as m:
            assert m.elements == 80    # the file's triangles
    no_file = scene_text(tmp_path, "&mesh dim = 1 /\n&contact obstacle_normal = 0 /\n",
                         "nofile.nml")
    with pytest.raises(BadInputError, match="&contact obstacle_normal: component 1"):
        Scene.read(no_file)


@pytest.mark.parametrize("t_end, dt, steps", [(0.0, 1e-3, 0), (1e-3, 1e-3, 1),
                                              (0.0105, 1e-3, 11), (1.0, 1e-3, 1000)])
def test_steps_reach_t_end(tmp_path, t_end, dt, steps):
    """The run ends at the first step >= t_end (docs/scenes.md)."""
    path = scene_text(tmp_path, f"&scheme t_end = {t_end!r}, dt = {dt!r} /\n")
    with dyncontact.core.Model(path) as m:
        assert m.n_steps == steps


def test_large_numbers_in_messages_have_an_exponent(tmp_path):
    path = scene_text(tmp_path, "&scheme dt = 1e-300, t_end = 1e300 /\n")
    with pytest.raises(BadInputError) as err:
        Scene.read(path)
    assert "t_end / dt = Infinity steps" in str(err.value) or "E+" in str(err.value)
    path = scene_text(tmp_path, "&scheme dt = 1e-200, t_end = 1e-100 /\n", "b.nml")
    with pytest.raises(BadInputError, match=r"t_end / dt = 1\.000E\+100 steps"):
        Scene.read(path)


# --------------------------------------------------------------------------- keys given

def test_the_keys_given_are_those_written(tmp_path):
    """The core says which keys a scene gives ('group.key'), whatever their values: none for
    the empty scene, every key for the example of docs/scenes.md that writes them all (the
    list fits the API's buffer), the file's keys for a file; Scene keeps them through
    set (a value at its default included) and writes only them."""
    every = {f"{g}.{k}" for g, kv in Scene().to_dict().items() for k in kv}
    core = dyncontact.core
    assert core.scene_parse("", "s", with_given=True)[1] == frozenset()
    docs = (ROOT / "docs" / "scenes.md").read_text(encoding="utf-8")
    example = docs.split("```fortran\n", 1)[1].split("```", 1)[0]
    assert core.scene_parse(example, "s", with_given=True)[1] == every
    path = scene_text(tmp_path, "&scheme beta = 0.25 /\n&contact theta = 1 /\n")
    assert core.scene_dump(path, with_given=True)[1] == {"scheme.beta", "contact.theta"}
    scn = Scene.read(path)
    scn.set("scheme.dt", 0.0025)                     # the default: given all the same
    assert {n for n in every if scn.given(n)} == {"scheme.beta", "contact.theta", "scheme.dt"}
    assert Scene.read(scene_text(tmp_path, scn.to_text(), "again.nml")) == scn
    assert core.scene_dump(tmp_path / "again.nml", with_given=True)[1] == {
        "scheme.beta", "contact.theta", "scheme.dt"}
    assert not Scene().copy().given("scheme.dt") and scn.copy().given("scheme.dt")


def test_unset_leaves_a_key_out_and_its_warning_with_it(tmp_path):
    """Scene.unset: a base scene switched to another scheme (bar2d_hht.nml, which gives
    alpha, run with newmark) warns that alpha is not used; unset, alpha is no longer given
    nor written, takes its default, and the run gives no warning and the same trace. &mesh
    dim and file cannot be unset; an unknown key is refused as set refuses it."""
    from dyncontact.core import DyncontactWarning

    base = Scene.read(ROOT / "scripts" / "scenes" / "bar2d_hht.nml")
    base.set("scheme.name", "newmark")
    base.set("scheme.t_end", 0.05)
    with pytest.warns(DyncontactWarning, match="&scheme alpha: not used by scheme 'newmark'"):
        before = dyncontact.run(base, out=tmp_path / "a", progress=False)
    switched = base.copy()
    switched.unset("scheme.alpha", "scheme.rho_inf")     # rho_inf: not given, left as is
    assert base.given("scheme.alpha") and not switched.given("scheme.alpha")
    assert switched.get("scheme.alpha") == Scene().get("scheme.alpha")
    assert "alpha" not in switched.to_text() and switched == base
    with warnings.catch_warnings():
        warnings.simplefilter("error", DyncontactWarning)
        after = dyncontact.run(switched, out=tmp_path / "b", progress=False)
    assert (tmp_path / "a" / "trace.csv").read_bytes() == (tmp_path / "b" / "trace.csv").read_bytes()
    assert before.ok and after.ok
    for name in ("mesh.dim", "mesh.file"):
        with pytest.raises(SceneError, match="cannot be unset"):
            switched.unset(name)
    with pytest.raises(SceneError, match="unknown key"):
        switched.unset("scheme.nope")


@pytest.mark.parametrize("name", sorted(SCHEME_PARAMS))
def test_drop_unused_leaves_out_what_the_core_warns_about(name, tmp_path):
    """conftest's SCHEME_PARAMS (which the tests' drop_unused follows) is the core's rule:
    a scene giving every &scheme parameter, a contact theta and multiplier, quad_points and
    an amplitude, run with kind = 'velocity' and the penalty method, warns that exactly the
    keys drop_unused leaves out are not used; after drop_unused it gives no warning."""
    from dyncontact.core import DyncontactWarning, Stepper

    s = Scene()
    for key, value in {"scheme.name": name, "scheme.t_end": 0.01, "scheme.alpha": 0.0,
                       "scheme.beta": 0.25, "scheme.gamma": 0.5, "scheme.theta": 1.0,
                       "scheme.rho_inf": 0.5, "contact.method": "penalty",
                       "contact.theta": 1, "contact.multiplier": "integral",
                       "contact.quad_points": 3, "initial.kind": "velocity",
                       "initial.velocity": [0.0, -0.1], "initial.amplitude": 0.5}.items():
        s.set(key, value)
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        Stepper(s, tmp_path / "all").close()
    unused = [k for k in ("alpha", "beta", "gamma", "theta", "rho_inf")
              if k not in SCHEME_PARAMS[name]]
    notes = [str(w.message) for w in seen if w.category is DyncontactWarning]
    scheme_notes = [n for n in notes if n.startswith("warning: &scheme ")
                    and "not used by scheme" in n]
    assert scheme_notes == [f"warning: &scheme {', '.join(unused)}: not used by scheme "
                            f"'{name}'" + scheme_notes[0].split(f"'{name}'", 1)[1]], notes
    for what in ("&contact theta: not used", "&contact multiplier: not used",
                 "&contact quad_points: not used", "&initial amplitude is not used"):
        assert sum(what in n for n in notes) == 1, (what, notes)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DyncontactWarning)
        Stepper(drop_unused(s), tmp_path / "dropped").close()


# --------------------------------------------------------------------------- round trip

@pytest.mark.parametrize("path", SCENE_FILES, ids=lambda p: p.name)
def test_write_round_trip(core_ext, path, tmp_path):
    scn = Scene.read(path)
    out = tmp_path / "written.nml"
    scn.write(out)
    stat, errmsg, f_dict = fortran_read(core_ext, out, tmp_path)
    assert stat == 0, errmsg
    assert f_dict == scn.to_dict()
    assert Scene.read(out) == scn


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
    scn.set("boundary.slip_y", "'quoted'")           # quoted: the quotes are the syntax
    scn.set("output.every", "10")
    scn.set("output.dir", "ñ日本")
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
    assert expected["boundary"]["slip_x"] == "it's \"quoted\""
    assert expected["boundary"]["slip_y"] == "quoted"
    assert expected["material"]["young"] == 1 / 3 and expected["scheme"]["gamma"] == 0.6
    assert f_dict == expected
    assert Scene.read(out).to_dict() == expected


# --------------------------------------------------------------------------- get / set

@pytest.mark.parametrize("name, value, expected", [
    ("scheme.dt", "0.001", 0.001),
    ("scheme.dt", "1d-3", 0.001),
    ("scheme.dt", 2, 2.0),
    ("scheme.dt", np.float32(0.001), 0.001),
    ("scheme.dt", np.float64(0.001), 0.001),
    ("scheme.dt", np.int32(2), 2.0),
    ("output.every", np.int64(7), 7),
    ("Scheme.DT", "5e-4", 0.0005),
    ("scheme.mass", "'lumped'", "lumped"),
    ("scheme.mass", '"lumped"', "lumped"),
    ("scheme.mass", "lumped", "lumped"),
    ("contact.obstacle_normal", "0.0,-1.0", [0.0, -1.0]),
    ("contact.obstacle_normal", "0.0 -1.0", [0.0, -1.0]),
    ("contact.obstacle_normal", (1, 0), [1.0, 0.0]),
    ("contact.obstacle_normal", np.array([0.1, -1.0], dtype=np.float32), [0.1, -1.0]),
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
    # a group without its key: the message said '&scheme : unknown key'
    ("scheme", "1", "unknown key 'scheme' (expected group.key, 'scheme.KEY' with KEY one of "
                    "name, alpha"),
    ("scheme.", "1", "unknown key 'scheme.' (expected group.key"),
    ("scheme.dt", "abc", "&scheme dt"),
    ("scheme.dt", "nan", "&scheme dt"),
    ("scheme.dt", float("inf"), "&scheme dt"),
    ("scheme.dt", True, "&scheme dt"),
    ("scheme.newton_maxit", "1.5", "&scheme newton_maxit"),
    ("scheme.newton_maxit", 2.0, "&scheme newton_maxit"),
    ("contact.probe", "1,2,3,4", "&contact probe: expected 1 or 2 values in 2D"),
    ("scheme.mass", 3, "&scheme mass"),
    ("output.dir", "a\nb", "&output dir"),
    ("scheme.dt", "1 / &mesh h = 2", "&mesh"),
    ("scheme.dt", "1 / &output dir = 'x'", "&output"),
    ("scheme.dt", "1, t_end = 5", "&scheme dt: expected values only, not another key"),
])
def test_set_rejects(name, value, where):
    scn = Scene()
    with pytest.raises(BadInputError) as err:
        scn.set(name, value)
    assert where in str(err.value)
    assert "\n" not in str(err.value)
    assert scn == Scene()                    # unchanged


def test_validate_after_set():
    scn = Scene()
    scn.set("scheme.dt", "-1")
    with pytest.raises(SceneError, match=r"^<scene>: &scheme dt: must be > 0"):
        scn.validate()
    scn.set("scheme.dt", "1e-3")
    scn.set("scheme.name", "hht")
    scn.set("scheme.alpha", "0.5")
    with pytest.raises(BadInputError, match=r"&scheme alpha: must be in \[-1/3, 0\]"):
        scn.validate()
    scn.set("scheme.name", "hht_seed")   # the seed's variant takes any alpha
    scn.validate()
    # the count of a vector's components against the dimension: checked by validate, so
    # that a scene can change &mesh dim and its vectors one after the other
    scn.set("contact.probe", "0.05, 0.05, 0.0")
    with pytest.raises(BadInputError, match=r"^<scene>: &contact probe: expected 1 or 2 "
                                            r"values in 2D \(got '0.05, 0.05, 0.0'\)"):
        scn.validate()
    scn.set("mesh.dim", 3)
    scn.validate()


def test_one_exception_class():
    assert SceneError is BadInputError and issubclass(BadInputError, ValueError)
    assert dyncontact.SceneError is BadInputError


@pytest.mark.parametrize("scene", [{"scheme": {"dt": 1e-3}}, None, 3.0])
def test_run_rejects_other_types(scene):
    with pytest.raises(TypeError, match="str, bytes or os.PathLike.*dyncontact.Scene"):
        dyncontact.run(scene)


# --------------------------------------------------------------------------- bad files

@pytest.mark.parametrize("case", BAD_CASES, ids=lambda c: c.id)
def test_bad_scene(core_ext, case, tmp_path):
    path = write_case(case, tmp_path)
    prefix = f"{path}: {case.where}:" if case.where else f"{path}: "
    stat, f_msg, _ = fortran_read(core_ext, path, tmp_path)
    assert stat == STAT_BAD_INPUT, (stat, f_msg)
    assert f_msg.startswith(prefix), (f_msg, prefix)
    assert case.what in f_msg, (f_msg, case.what)
    assert "\n" not in f_msg and len(f_msg) < 512
    with pytest.raises(BadInputError) as err:
        Scene.read(path)
    assert str(err.value) == f_msg


#: Scenes the reader accepts, whose errors only the mesh can reveal (checked by
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


# --------------------------------------------------------------------------- fuzzing

_FUZZ_SCRIPT = r"""
import json, sys
from dyncontact import _core
for path in sys.argv[1:]:
    _given, stat, errmsg = _core.dc_scene_dump(path, path + '.json')
    f = errmsg.decode('utf-8', 'replace').strip() if int(stat) else json.load(open(path + '.json'))
    print(json.dumps([path, int(stat), f]))
"""

_FUZZ_PIECES = list("&/!=,'\" \n\t*.-+0123456789eEdDxyz_") + [
    "\r", "\x00", "\xe9", "dt", "name", "&scheme", "'hht'", "1.5", "2*", "mesh", "theta"]


@pytest.mark.slow
def test_fuzzed_scenes(tmp_path):
    """Mutated scene files: the reader never dies (it runs in a subprocess), refuses with
    one line naming the file, or reads values that Scene writes and reads back unchanged."""
    rng = random.Random(20240607)
    bases = [p.read_text() for p in SCENE_FILES]
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
    for path, stat, f in rows:
        if stat == 0:
            scn = Scene.read(path)
            assert scn.to_dict() == f
            out = Path(path + ".written.nml")
            scn.write(out)
            assert Scene.read(out).to_dict() == f, path
            n_ok += 1
        else:
            assert stat == STAT_BAD_INPUT, (path, stat, f)
            assert f.startswith(path + ": ") and "\n" not in f, (path, f)
    assert 0 < n_ok < len(rows)


def test_every_example_scene_is_documented():
    """docs/scenes.md, "Example scenes", names every scene of scripts/scenes/ (and no other)."""
    doc = (ROOT / "docs" / "scenes.md").read_text()
    section = doc.split("## Example scenes", 1)[1].split("\n## ", 1)[0]
    named = set(re.findall(r"`(\w+)`", section))
    shipped = {p.stem for p in SCENES_DIR.glob("*.nml")}
    assert shipped <= named, shipped - named
    assert {n for n in named if n.startswith(("bar", "ball"))} <= shipped
