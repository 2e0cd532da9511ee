"""The Newmark family's initial acceleration, M a0 = L - B(u0) (implicit_schemes'
implicit_init, mass_solver_start), on the 3D bar (scripts/scenes/bar3d_hht.nml):

- where L - B(u0) is zero at every dof (no load, u0 = 0: the bar thrown with a velocity
  alone), a0 = 0 with no factorization of M: summary.json's factorizations one fewer
  than with the solve forced (the test-only environment variable
  DYNCONTACT_INITIAL_SOLVE = 'solve'), and the same trace, bit for bit; a redistributed
  mass is still checked (its definiteness: one factorization either way) and a lumped
  one is never factorized;
- with gravity, M is factorized (counted) and a0 stands for what it is: M a0 = L - B(u0)
  to round-off.
- S (M = S (x) I_3) factorized supernodally or simplicially gives the same a0 to
  round-off (the supernodal factorization serves this one solve where it is faster).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import dyncontact
from dyncontact import Scene
from dyncontact.core import Stepper

from conftest import ROOT, drop_unused, run_as_designed, warns_as_designed

#: Relative round-off bound of a residual of a sparse solve, scaled by |M| |a0| and the
#: right-hand side's terms.
THR = 1e-12


def bar(tmp_path, scheme="hht", mass="consistent", gravity=(0.0, 0.0, 0.0)) -> Scene:
    s = Scene.read(ROOT / "scripts" / "scenes" / "bar3d_hht.nml")
    s.set("initial.kind", "velocity")
    s.set("initial.velocity", "0.0, 0.0, -1.0")
    s.set("material.gravity", ", ".join(str(g) for g in gravity))
    s.set("scheme.name", scheme)
    s.set("scheme.mass", mass)
    s.set("scheme.t_end", 0.05)
    s.set("output.dir", str(tmp_path / "out"))
    return s


@pytest.mark.parametrize("scheme, mass, saved", [
    ("hht", "consistent", 1), ("newmark", "consistent", 1), ("galpha", "consistent", 1),
    ("hht", "redistributed", 0), ("hht", "lumped", 0)])
def test_zero_right_hand_side_needs_no_factorization(scheme, mass, saved, tmp_path,
                                                     monkeypatch):
    s = bar(tmp_path, scheme, mass)
    if scheme == "galpha":
        s.set("scheme.rho_inf", 0.8)
    skipped = run_as_designed(s, tmp_path / "skipped")
    monkeypatch.setenv("DYNCONTACT_INITIAL_SOLVE", "solve")
    solved = run_as_designed(s, tmp_path / "solved")
    assert skipped.summary["factorizations"] == solved.summary["factorizations"] - saved, \
        (skipped.summary["factorizations"], solved.summary["factorizations"])
    assert skipped.trace["t"][-1] == pytest.approx(0.05)
    for col in skipped.trace:
        assert np.array_equal(skipped.trace[col], solved.trace[col]), col


def test_gravity_factorizes_and_a0_balances(tmp_path):
    s = drop_unused(bar(tmp_path, gravity=(0.0, 0.0, -2.0)))
    out = tmp_path / "run"
    with warns_as_designed(s):
        run = Stepper(s, out)
    with run:
        M = run.matrix("M")
        st = run.state()
        a, load, bu = st["a"], st["load"], st["bu"]
        assert np.any(load - bu != 0.0)
        assert run.advance(1) == 1
    res = M @ a - (load - bu)
    scale = np.max(np.abs(M) @ np.abs(a)) + np.max(np.abs(load)) + np.max(np.abs(bu))
    assert np.max(np.abs(res)) <= THR * scale, np.max(np.abs(res)) / scale
    summary = json.loads((out / "summary.json").read_text())
    assert summary["factorizations"] == 2    # M (a0) and J0


def initial_acceleration(tmp_path, name, scene):
    with warns_as_designed(scene):
        run = Stepper(scene, tmp_path / name)
    with run:
        return run.state()["a"]


def test_supernodal_and_simplicial_mass_give_the_same_a0(tmp_path, monkeypatch):
    """S factorized both ways (DYNCONTACT_FACTORIZATION forces it): the same a0 to
    round-off. The run's own choice (supernodal where S's factor columns are long, on 3D
    meshes from some 3 000 to 10 000 nodes on) changes a0 at that level only."""
    s = drop_unused(bar(tmp_path, gravity=(0.0, 0.0, -2.0)))
    s.set("mesh.h", 0.025)
    a = {}
    for f in ("simplicial", "supernodal"):
        monkeypatch.setenv("DYNCONTACT_FACTORIZATION", f)
        a[f] = initial_acceleration(tmp_path, f, s)
    assert np.max(np.abs(a["supernodal"])) > 0.0
    err = np.max(np.abs(a["supernodal"] - a["simplicial"])) / np.max(np.abs(a["simplicial"]))
    assert err <= THR, err
