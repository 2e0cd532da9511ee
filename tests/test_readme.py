"""README.md's examples run as written: every ```python block, then every command
`python -m dyncontact run|plot|mesh ...` and `build/dyncontact ...` quoted in the text without
placeholders, in the order of the README, from a folder that has the repository's scripts/
and meshes/ (the examples name scripts/scenes/... and meshes/...) and writes out/ there. The shell commands that install or build
(scripts/setup, meson, pip) are run by scripts/setup itself, not here."""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys

import numpy as np
import pytest

from conftest import ROOT, SUBPROCESS_TIMEOUT

import dyncontact

README = (ROOT / "README.md").read_text()


def python_blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", README, flags=re.S)


def cli_examples() -> list[str]:
    """`python -m dyncontact run|plot|mesh ...` and `build/dyncontact ...` spans of the text
    (line breaks inside a span are blanks) without placeholders (upper-case names such as
    SCENE.nml, DIR, or [options])."""
    spans = re.findall(r"`((?:python -m dyncontact (?:run|plot|mesh)|build/dyncontact) [^`]+)`",
                       README)
    spans = [" ".join(s.split()) for s in spans]
    return [s for s in spans if not re.search(r"\[|\b[A-Z][A-Z0-9_.]{2,}\b", s)]


def test_readme_has_the_examples():
    assert len(python_blocks()) >= 1
    examples = cli_examples()
    assert any(" run " in e for e in examples) and any(" plot " in e and "--labels" in e
                                                       for e in examples), examples
    assert any(" mesh " in e for e in examples), examples
    assert any(e.startswith("build/dyncontact ") for e in examples), examples


def test_readme_examples_run_as_written(tmp_path, monkeypatch):
    (tmp_path / "scripts").symlink_to(ROOT / "scripts")
    (tmp_path / "meshes").symlink_to(ROOT / "meshes")
    monkeypatch.chdir(tmp_path)
    for block in python_blocks():
        exec(compile(block, "README.md", "exec"), {"__name__": "readme_example"})
    # the restart example continued the variant from its checkpoint to the end
    variant = dyncontact.core.read_trace("out/variant")
    assert variant["t"][-1] == pytest.approx(15.0)
    assert (tmp_path / "out" / "compare.png").is_file()
    assert (tmp_path / "out" / "stepped" / "state.bin").is_file()
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    for example in cli_examples():
        args = shlex.split(example)
        if args[0] == "build/dyncontact":
            args = [str(ROOT / "build" / "dyncontact"), *args[1:]]
        else:
            assert args[0] == "python"
            args = [sys.executable, *args[1:]]
        res = subprocess.run(args, cwd=tmp_path, env=env,
                             capture_output=True, text=True, timeout=SUBPROCESS_TIMEOUT)
        assert res.returncode == 0, (example, res.stderr)
    a01 = dyncontact.core.read_trace("out/hht_a01")
    assert np.all(np.isfinite(a01["e_total"]))
    assert (tmp_path / "out" / "hht_alpha.png").is_file()
    assert dyncontact.core.read_trace("out/bar1d")["t"][-1] == pytest.approx(6.0)
    assert (tmp_path / "out" / "disk.msh").read_text().startswith("$MeshFormat\n4.1 0 8")


def test_stepper_is_exported(tmp_path):
    """dyncontact.Stepper (docs/scenes.md, "Checkpoint and restart": Stepper.save and
    Stepper.load): a state saved and loaded continues as the run that saved it."""
    assert "Stepper" in dyncontact.__all__
    assert dyncontact.Stepper is dyncontact.core.Stepper
    scn = dyncontact.Scene()
    scn.set("scheme.t_end", 0.05)
    with dyncontact.Stepper(scn, tmp_path / "a") as st:
        st.advance(5)
        st.save(tmp_path / "five.bin")
        st.advance(3)
        u8 = st.state()["u"].copy()
        assert st.load(tmp_path / "five.bin") == 5
        st.advance(3)
        assert np.array_equal(st.state()["u"], u8)    # bit for bit (docs/scenes.md)


def test_a_closed_stepper_raises_instead_of_crashing(tmp_path):
    """After its `with` block a Stepper is closed: advance, state and matrix raise
    DyncontactError (they passed a null handle to the core, which crashed the
    interpreter); bad arguments are Python errors naming the argument."""
    import dyncontact

    scene = dyncontact.Scene.read(ROOT / "scripts" / "scenes" / "bar2d_hht.nml")
    with dyncontact.Stepper(scene, tmp_path / "run") as st:
        assert st.advance(3) == 3
        with pytest.raises(ValueError, match="steps must be >= 0"):
            st.advance(-5)
        with pytest.raises(TypeError, match="steps must be an int"):
            st.advance(2.5)
        with pytest.raises(ValueError, match="which must be one of M, K, K_theta"):
            st.matrix("X")
    for call in (lambda: st.advance(1), st.state, lambda: st.matrix("M")):
        with pytest.raises(dyncontact.DyncontactError, match="closed"):
            call()
    with pytest.raises(TypeError, match="out must be the output folder"):
        dyncontact.Stepper(scene, None)


@pytest.mark.parametrize("budget", [2**31, 10**12, "np.int64"])
def test_stepper_advance_takes_any_budget_to_the_end(tmp_path, budget):
    """advance(steps) advances by *at most* steps: a budget beyond the core's C int
    (2**31 - 1, more than any run's steps: &scheme max_steps is one) runs to the end, as
    advance(10**9) does; it raised OverflowError from the f2py boundary."""
    import dyncontact

    if budget == "np.int64":
        budget = np.int64(2**40)
    scene = dyncontact.Scene.read(ROOT / "scripts" / "scenes" / "bar2d_hht.nml")
    scene.set("scheme.t_end", 0.05)
    with dyncontact.Stepper(scene, tmp_path / "run") as st:
        assert st.advance(3) == 3
        assert st.advance(budget) == 17
        assert st.finished and st.step == 20
