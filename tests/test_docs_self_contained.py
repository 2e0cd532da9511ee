"""What a user reads cites only what the repository holds: the docs, the example scenes
and the texts the package writes into its outputs (the studies' summaries, the figures'
index, the scenes written for the runs) cite no "SPEC §2" or the like, the project's
contract, which is not part of the repository; the seed's test case is a section of
docs/numerics.md."""

from __future__ import annotations

import ast

import pytest

from conftest import ROOT

USER_TEXTS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")),
              *sorted((ROOT / "scripts" / "scenes").glob("*.nml"))]


@pytest.mark.parametrize("path", USER_TEXTS, ids=lambda p: p.name)
def test_user_texts_cite_no_spec(path):
    lines = [f"{k}: {line}" for k, line in
             enumerate(path.read_text(encoding="utf-8").splitlines(), 1) if "SPEC" in line]
    assert not lines, lines


def _strings_written(tree: ast.AST):
    """The string constants of a module that are not docstrings (what it prints or
    writes; its comments are not in the tree)."""
    docstrings = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef,
                             ast.AsyncFunctionDef)):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and \
                    isinstance(body[0].value, ast.Constant):
                docstrings.add(id(body[0].value))
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) \
                and id(node) not in docstrings:
            yield node


@pytest.mark.parametrize("path", sorted((ROOT / "python" / "dyncontact").rglob("*.py")),
                         ids=lambda p: str(p.relative_to(ROOT / "python")))
def test_written_texts_cite_no_spec(path):
    tree = ast.parse(path.read_text(encoding="utf-8"))
    found = [f"line {node.lineno}: {node.value[:60]!r}" for node in _strings_written(tree)
             if "SPEC" in node.value]
    assert not found, found


def test_the_seed_case_has_its_section():
    text = (ROOT / "docs" / "numerics.md").read_text(encoding="utf-8")
    assert "\n## The seed's test case\n" in text
    # the sections the other pages point to instead
    for heading in ("## Space: P1 + Nitsche", "## Time schemes"):
        assert f"\n{heading}\n" in text, heading
    assert "\n## The blow-up test\n" in (ROOT / "docs" / "scenes.md").read_text(
        encoding="utf-8")
