"""summary.json's `setup_factorizations`: the numeric factorizations the set-up makes
outside the scheme, which `factorizations` (the scheme's own) leaves out: the blow-up
limit's factorization of K + M/t_end² when there is a load (docs/numerics.md). 0 without
a load, 1 with gravity, the scheme's count the same either way; a restarted run counts
what the run that never stopped counts. tests/test_factorization_count.py checks the two
counts together against the calls to CHOLMOD and UMFPACK."""

from __future__ import annotations

import shutil

import pytest

import dyncontact
from dyncontact import Scene

#: Steps of the short 2D runs: t_end / dt.
STEPS = 40
#: A checkpoint every this many steps.
EVERY = 15


def _bar(out, gravity=None) -> Scene:
    s = Scene()
    s.set("mesh.h", 0.05)
    s.set("scheme.name", "hht")
    s.set("scheme.dt", 0.0025)
    s.set("scheme.t_end", STEPS * 0.0025)
    s.set("output.dir", str(out))
    if gravity is not None:
        s.set("material.gravity", gravity)
    return s


@pytest.mark.parametrize("gravity, made", [(None, 0), ("0.0, -9.81", 1)])
def test_setup_factorizations_count_the_load_energy(tmp_path, gravity, made):
    res = dyncontact.run(_bar(tmp_path / "o", gravity), progress=False)
    assert res.ok, res.message
    assert res.summary["setup_factorizations"] == made
    assert res.summary["factorizations"] == 2     # M for a0 and J0, load or not


def test_a_restart_counts_as_the_run_that_never_stopped(tmp_path):
    """A run of 30 steps (its checkpoint at its end) continued to 40 by a restart, whose
    set-up factorizes K + M/t_end^2 again, counts as the run of 40 steps."""
    scene = _bar("unused", "0.0, -9.81")
    scene.set("output.checkpoint_every", EVERY)
    full = dyncontact.run(scene, out=tmp_path / "full", progress=False)
    first = scene.copy()
    first.set("scheme.t_end", 2 * EVERY * 0.0025)
    assert dyncontact.run(first, out=tmp_path / "again", progress=False).ok
    again = dyncontact.run(scene, restart=tmp_path / "again", progress=False)
    assert again.ok and full.ok
    assert again.trace["t"].size == full.trace["t"].size == STEPS + 1
    for key in ("steps", "factorizations", "setup_factorizations"):
        assert again.summary[key] == full.summary[key], key
    assert again.summary["setup_factorizations"] == 1
