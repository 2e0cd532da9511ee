"""A value given to Scene.set or `run --set` and refused by the core's range checks is
quoted as the user wrote it (docs/scenes.md: "(got 'VALUE')"), not as its reading printed
back ('0', not '0.0'; '1e-400', not the '0.0' it underflows to)."""

from __future__ import annotations

import pytest

from dyncontact import BadInputError, Scene
from dyncontact.cli import main


@pytest.mark.parametrize("key, value, shown", [
    ("contact.gamma0", "0", "0"),
    ("contact.gamma0", 0, "0"),
    ("contact.gamma0", "1e-400", "1e-400"),      # read as 0.0
    ("contact.gamma0", "-2", "-2"),
    ("scheme.dt", "-1d-3", "-1d-3"),
    ("scheme.newton_tol", 1, "1"),
    ("output.every", "+0", "+0"),                # an integer key
    ("contact.obstacle_normal", [0, 0], "0, 0"),  # a vector key
    ("contact.obstacle_normal", "0,0", "0, 0"),  # tokens joined by ', ', as for a file
])
def test_scene_set_refusal_quotes_the_value_given(key, value, shown):
    scn = Scene()
    scn.set(key, value)
    group, name = key.split(".")
    with pytest.raises(BadInputError) as info:
        scn.validate(mesh=False)
    msg = str(info.value)
    assert msg.startswith(f"<scene>: &{group} {name}: "), msg
    assert msg.endswith(f"(got '{shown}')"), msg


def test_run_set_refusal_quotes_the_value_given(capsys, tmp_path):
    scene = tmp_path / "s.nml"
    scene.write_text("&scheme dt = 0.01 /\n")
    assert main(["run", str(scene), "--set", "contact.gamma0=0",
                 "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err == ("dyncontact: --set contact.gamma0=0: &contact gamma0: must be > 0 "
                   "(got '0')"), err
    assert not (tmp_path / "o").exists()


def test_a_value_the_core_changes_is_written_as_changed():
    """validate() normalizes the obstacle normal: the scene then writes the normal it
    holds, not the text given, and reads back to the same scene."""
    scn = Scene()
    scn.set("contact.obstacle_normal", "0, -2")
    scn.set("contact.gamma0", "2d1")
    scn.validate(mesh=False)
    assert scn.get("contact.obstacle_normal") == [0.0, -1.0]
    assert scn.get("contact.gamma0") == 20.0
    text = scn.to_text()
    assert "obstacle_normal = 0.0, -1.0" in text, text
    other = Scene()
    other.set("contact.obstacle_normal", [0.0, -1.0])
    other.set("contact.gamma0", 20.0)
    assert scn == other
