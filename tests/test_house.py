"""House rules a grep can check: code, tests, docs, scripts and build files say what and
why, never which ticket or which period of work ("issue 12's options", "this session").
Someone who has only the repository cannot follow such a pointer; history lives in git
log. Every tracked text file is read (binary and data files are skipped); a planted line
shows that the check can fail."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

from conftest import ROOT

#: Ordinals and pointers that turn "session", "sprint" or "period" into a label of a
#: period of work.
_WHEN = (r"(?:this|that|the|previous|next|last|earlier|later|same|first|second|third|"
         r"fourth|fifth|sixth|seventh|eighth|ninth|tenth|\d+(?:st|nd|rd|th))")

#: (pattern, what it finds); matched case-insensitively, line by line.
PATTERNS = (
    (re.compile(r"\b(?:issue|ticket|bug|pr|pull request)s?\s*(?:no\.?\s*)?#?\s*\d+", re.I),
     "a ticket number"),
    (re.compile(r"(?<![\w&/])#\d+\b(?![\w-])"), "a ticket number"),
    (re.compile(r"\btickets?\b", re.I), "a ticket"),
    (re.compile(r"\b(?:this|that|the|an?) issue's\b|\bthis issue\b|\bissue's\b", re.I),
     "a pointer to a ticket"),
    (re.compile(_WHEN + r"\s+(?:work\s+)?(?:session|sprint)s?\b", re.I), "a diary label"),
    (re.compile(r"\b(?:session|sprint)\s+\d+\b", re.I), "a diary label"),
    (re.compile(r"\bsprints?\b", re.I), "a diary label"),
)

#: Data files (meshes, traces, pictures, binaries): their text is numbers, not prose.
DATA_SUFFIXES = {".msh", ".csv", ".png", ".jpg", ".svg", ".vtu", ".pvd", ".npz", ".npy",
                 ".pdf", ".gz", ".zip", ".whl"}

#: Tracked files the checks leave out: this one, whose patterns and planted lines spell
#: out what the checks look for.
NOT_CHECKED = {"tests/test_house.py"}


def tracked_files(root: Path = ROOT) -> list[str]:
    """The repository's files, relative to root: `git ls-files` in a checkout, otherwise
    every file outside hidden, build and output folders. Only files that exist."""
    try:
        out = subprocess.run(["git", "ls-files", "-z"], cwd=root, capture_output=True,
                             check=True).stdout.decode()
        names = [n for n in out.split("\0") if n]
    except (OSError, subprocess.CalledProcessError):
        skip = {"build", "out", "__pycache__"}
        names = [str(p.relative_to(root)) for p in root.rglob("*") if p.is_file()
                 and not any(part.startswith(".") or part in skip
                             for part in p.relative_to(root).parts)]
    return sorted(n for n in names if (root / n).is_file())


def text_lines(path: Path) -> list[str] | None:
    """The lines of a text file, None for data and binary files."""
    if path.suffix.lower() in DATA_SUFFIXES:
        return None
    data = path.read_bytes()
    if b"\0" in data:
        return None
    try:
        return data.decode("utf-8").splitlines()
    except UnicodeDecodeError:
        return None


def diary_lines(names: list[str], root: Path = ROOT) -> list[str]:
    """'file:line: what: text' for every line of the given files (relative to root) that
    names a ticket or a period of work."""
    found = []
    for name in names:
        if name in NOT_CHECKED:
            continue
        lines = text_lines(root / name)
        for k, line in enumerate(lines or (), start=1):
            for pattern, what in PATTERNS:
                if pattern.search(line):
                    found.append(f"{name}:{k}: {what}: {line.strip()}")
                    break
    return found


def test_no_ticket_numbers_or_diary_labels_in_the_tree():
    names = tracked_files()
    assert len(names) > 50, names          # the listing found the repository
    assert any(n.endswith(".f90") for n in names) and "docs/numerics.md" in names
    found = diary_lines(names)
    assert not found, ("say what and why instead (history lives in git log):\n"
                       + "\n".join(found))


def test_a_planted_ticket_number_or_diary_label_is_found(tmp_path):
    """The same function on a planted file: every kind of pointer is reported with its
    file and line, and the wordings the project uses legitimately are not."""
    planted = [
        "! the standard HHT coefficients",             # 1: fine
        "# " + "issue" + " 12's options",              # 2
        "    (see " + "Issue" + " #7)",                # 3
        "fixed in " + "#" + "42",                      # 4
        "measured in the " + "eighth" + " session",    # 5
        "as in this " + "session",                     # 6
        "    # the " + "ticket" + " asked for it",     # 7
        "below the " + "issue's" + " bound",           # 8
        "a gmsh session of the caller",                # 9: fine
        '@pytest.fixture(scope="session")',            # 10: fine
        "color = '#1f77b4'  # 16 cores, 2x2 blocks",   # 11: fine
    ]
    (tmp_path / "planted.f90").write_text("\n".join(planted) + "\n")
    (tmp_path / "mesh.msh").write_text("issue" + " 3\n")           # data: not read
    found = diary_lines(["planted.f90", "mesh.msh"], root=tmp_path)
    assert [f.split(":")[1] for f in found] == ["2", "3", "4", "5", "6", "7", "8"], found
    assert all(f.startswith("planted.f90:") for f in found)


# ------------------------------------------------- references to sections of the docs

#: `docs/NAME.md, "Section"` or `(NAME.md, Section)`; comment markers at line starts are
#: removed first, so a reference may span two comment lines.
_REF = re.compile(r'(?:docs/)?([\w-]+\.md),\s*(?:"([^"]+)"|([A-Z][^)"]*?)\))')
_COMMENT_BREAK = re.compile(r"\s*\n\s*(?:!>|!!|!|#:|#|//|\*)?\s*")
#: Names in ASCII comments for the symbols of the docs.
_ASCII = {"gamma": "γ", "theta": "θ", "rho": "ρ", "alpha": "α"}


def _norm(text: str) -> str:
    text = text.lower()
    for word, symbol in _ASCII.items():
        text = text.replace(word, symbol)
    return " ".join(text.split())


def doc_sections(doc: Path) -> list[str]:
    """The headings and the bold paragraph leads (`**Title.**`, `- **Title**`) of a doc."""
    text = doc.read_text()
    return ([_norm(m.group(1)) for m in re.finditer(r"^#+\s+(.+)$", text, re.M)]
            + [_norm(m.group(1)) for m in re.finditer(r"\*\*([^*]+)\*\*", text)])


def broken_section_references(names: list[str], root: Path = ROOT) -> list[str]:
    """'file: doc, "section"' for every reference to a section of a doc in docs/ that no
    heading or bold paragraph lead of that doc contains."""
    broken = []
    for name in names:
        if name in NOT_CHECKED:
            continue
        lines = text_lines(root / name)
        if lines is None:
            continue
        text = _COMMENT_BREAK.sub(" ", "\n".join(lines))
        for m in _REF.finditer(text):
            doc, title = root / "docs" / m.group(1), (m.group(2) or m.group(3)).strip()
            if not doc.is_file():
                broken.append(f"{name}: {m.group(1)} does not exist (section {title!r})")
            elif not any(_norm(title) in s for s in doc_sections(doc)):
                broken.append(f"{name}: {m.group(1)} has no section {title!r}")
    return broken


def test_references_to_sections_of_the_docs_resolve():
    names = tracked_files()
    found = broken_section_references(names)
    assert not found, "\n".join(found)


def test_a_broken_section_reference_is_found(tmp_path):
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "numerics.md").write_text(
        "# Title\n\n## Linear solvers\n\n**Central differences** (`central`): ...\n")
    (tmp_path / "a.f90").write_text(
        '! see (docs/numerics.md, "Linear solvers") and (numerics.md, Central differences)\n'
        '!> the measurements (docs/numerics.md, "The\n!> solves")\n'
        '! and (docs/nowhere.md, "Anything")\n')
    found = broken_section_references(["a.f90"], root=tmp_path)
    assert found == ["a.f90: numerics.md has no section 'The solves'",
                     "a.f90: nowhere.md does not exist (section 'Anything')"], found
