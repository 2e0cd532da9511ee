"""The contact correction on the active contact dofs (fortran/schemes/contact_columns.f90):
the columns of Z = J0⁻¹Pᵀ and W = P Z are solved when a contact dof first needs them and
kept in a bounded cache. The traces must equal those of the full precomputation of every
column (DYNCONTACT_CONTACT_COLUMNS=all, the reference) on a scene whose active set
changes at nearly every step, and must not depend on the cache's history (a budget of
0 MB drops every column not needed at the current step, so columns are solved again,
by the same calls, many times). And a scene over &mesh max_elements is refused before
the model allocates, in 3D as in 2D, naming the key."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import dyncontact
from dyncontact import BadInputError, Scene

ROOT = Path(__file__).resolve().parents[1]
ENV = "DYNCONTACT_CONTACT_COLUMNS"


def ball(t_end: float) -> Scene:
    """The coarse ball dropped at speed 1, ten times the scene's speed: its patch grows
    by some points at nearly every step of the window (the algebra under test does not
    need the small strains of the scene's speed)."""
    s = Scene.read(ROOT / "scripts" / "scenes" / "ball3d_newmark.nml")
    s.set("mesh.h", 0.1)
    s.set("initial.velocity", "0.0, 0.0, -1.0")
    s.set("scheme.dt", 0.005)
    s.set("scheme.t_end", t_end)
    s.set("output.fields_every", 0)
    return s


def run_with(monkeypatch, mode: str | None, s: Scene, out: Path):
    if mode is None:
        monkeypatch.delenv(ENV, raising=False)
    else:
        monkeypatch.setenv(ENV, mode)
    return dyncontact.run(s, out=out, progress=False)


def test_active_columns_equal_the_full_correction_while_the_patch_moves(monkeypatch, tmp_path):
    s = ball(0.075)
    lazy = run_with(monkeypatch, None, s, tmp_path / "lazy")
    full = run_with(monkeypatch, "all", s, tmp_path / "all")
    evicting = run_with(monkeypatch, "0", s, tmp_path / "zero")
    active = lazy.trace["active"]
    inside = active[np.argmax(active > 0):]
    # the contact patch grows: its active points change at most steps of the window
    assert inside.size >= 10 and np.count_nonzero(np.diff(inside)) >= 0.6 * (inside.size - 1)
    for col in lazy.trace:
        # the same columns by the same solves, summed in the same order: equal to the bit
        # (stronger than the 1e-12 round-off bound)
        np.testing.assert_array_equal(lazy.trace[col], full.trace[col], err_msg=col)
        np.testing.assert_array_equal(lazy.trace[col], evicting.trace[col], err_msg=col)


@pytest.mark.parametrize("name", ["hht", "theta"])
def test_2d_strip_lazy_equals_full_through_contact(monkeypatch, tmp_path, name):
    s = Scene.read(ROOT / "scripts" / "scenes" / f"bar2d_{name}.nml")
    s.set("scheme.t_end", 1.6)      # the bar lands at t = 1.13
    s.set("output.fields_every", 0)
    lazy = run_with(monkeypatch, None, s, tmp_path / "lazy")
    full = run_with(monkeypatch, "all", s, tmp_path / "all")
    evicting = run_with(monkeypatch, "0", s, tmp_path / "zero")
    assert lazy.trace["active"].max() > 0
    for col in lazy.trace:
        np.testing.assert_array_equal(lazy.trace[col], full.trace[col], err_msg=col)
        np.testing.assert_array_equal(lazy.trace[col], evicting.trace[col], err_msg=col)


def test_3d_built_in_bar_over_max_elements_is_refused_naming_the_key(tmp_path):
    s = Scene.read(ROOT / "scripts" / "scenes" / "bar3d_hht.nml")
    s.set("mesh.h", 0.001)        # 6 x 1000 x 100^2 elements: refused when read
    with pytest.raises(BadInputError, match=r"&mesh h.*more than &mesh max_elements"):
        dyncontact.run(s, out=tmp_path / "o", progress=False)


def test_3d_mesh_file_over_max_elements_is_refused_before_the_model(tmp_path):
    s = ball(0.01)
    s.set("mesh.max_elements", 10)
    with pytest.raises(BadInputError, match=r"&mesh max_elements"):
        dyncontact.run(s, out=tmp_path / "o", progress=False)
