"""The one JSON string writer of the core (text's json_string), through the two outputs
that use it: the scene as JSON (control characters escaped) and summary.json (through
trace_output, control characters as blanks). Each string must read back, with Python's
strict JSON parser, as exactly the text that was written."""

from __future__ import annotations

import json
import subprocess

from conftest import ROOT, SUBPROCESS_TIMEOUT

from dyncontact.core import scene_parse

EXE = ROOT / "build" / "dyncontact"

# quote, backslash, a two-byte UTF-8 letter, a blank inside
AWKWARD = 'a\\b"c \u00e9d'


def test_scene_json_round_trips_quotes_backslashes_utf8():
    text = "&output dir = '" + AWKWARD.replace("'", "''") + "' /\n"
    scene = scene_parse(text, "awkward", full=False)
    assert scene["output"]["dir"] == AWKWARD


def test_summary_json_strings_read_back(tmp_path):
    """summary.json (status, scheme and the scene's output folder) stays strict JSON with
    a folder name holding a quote, a backslash and a UTF-8 letter."""
    out = tmp_path / AWKWARD
    scene = tmp_path / "bar.nml"
    scene.write_text("&scheme name = 'newmark', dt = 0.01, t_end = 0.05 /\n", encoding="utf-8")
    res = subprocess.run([str(EXE), str(scene), "--out", str(out)], capture_output=True,
                         timeout=SUBPROCESS_TIMEOUT)
    assert res.returncode == 0, res.stderr
    summary = json.loads((out / "summary.json").read_bytes().decode("utf-8"))
    assert summary["status"] == "ok"
    assert summary["scheme"] == "newmark"
    assert summary["message"] == ""
    assert summary["scene"]["output"]["dir"] == str(out)
