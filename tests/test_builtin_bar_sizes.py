"""The built-in bar's cell counts for an h that does not divide its width and length,
against the rule docs/scenes.md states (&mesh h): nint(width/h) x nint(length/h) cells,
nint(length/h) segments in 1D, nint(width/h)^2 x nint(length/h) cuboids of 6 tetrahedra
in 3D, at least 1 each way. The page said "square side" alone, and h = 0.03 gives cells
of 0.0333 x 0.0303."""

from __future__ import annotations

import pytest

from conftest import ROOT

import dyncontact

#: The rule as docs/scenes.md writes it in the &mesh h row.
DOC_RULE = ("The bar is cut into nint(`width`/h) × nint(`length`/h) cells, in 1D "
            "nint(`length`/h) segments, in 3D nint(`width`/h)² × nint(`length`/h) cuboids "
            "(at least 1 each way)")


def _cells(dim: int, length: float, width: float, h: float) -> int:
    along = max(1, round(length / h))
    across = max(1, round(width / h))
    return {1: along, 2: 2 * across * along, 3: 6 * across**2 * along}[dim]


def test_the_rule_is_in_the_docs():
    text = (ROOT / "docs" / "scenes.md").read_text(encoding="utf-8")
    assert DOC_RULE in text
    assert "h = 0.03: 3 × 33 cells of 0.0333 × 0.0303, 198 triangles" in text


@pytest.mark.parametrize("dim, length, width, h", [
    (1, 1.0, 0.1, 0.03), (2, 1.0, 0.1, 0.03), (3, 1.0, 0.1, 0.03), (2, 1.0, 0.1, 0.3),
    (2, 0.7, 0.25, 0.04), (3, 0.5, 0.1, 0.07)])
def test_cell_counts_follow_the_documented_rule(tmp_path, dim, length, width, h):
    scene = dyncontact.Scene()
    for key, value in (("mesh.dim", dim), ("mesh.length", length), ("mesh.width", width),
                       ("mesh.h", h), ("scheme.t_end", 0.0)):
        scene.set(key, value)
    result = dyncontact.run(scene, out=tmp_path / "run", progress=False)
    assert result.summary["elements"] == _cells(dim, length, width, h)
    if dim == 2 and h == 0.03:
        assert result.summary["elements"] == 198
