"""The module layers of docs/architecture.md against the code: every Fortran `use` line
and every Python import goes to the module's own layer or a lower one, every module has a
place in the diagrams, only `core` imports the extension and nobody imports core's private
helpers. A planted violation shows that the checks can fail."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

from conftest import ROOT

DOC = ROOT / "docs" / "architecture.md"
FORTRAN = ROOT / "fortran"
PYTHON = ROOT / "python" / "dyncontact"

#: Modules of the compiler, not of the project.
INTRINSIC = {"iso_c_binding", "iso_fortran_env", "ieee_arithmetic", "ieee_exceptions",
             "ieee_features", "omp_lib"}
#: The Python unit that is the Fortran extension (built from fortran/app/api.f90).
EXTENSION = "_core"
#: The only Python unit that may import the extension.
BOUNDARY = "core"


def read_layers(which: str) -> dict[str, int]:
    """Module -> layer number, from the diagram after `<!-- layers: WHICH -->`."""
    return read_layer_table(which)[0]


def read_layer_table(which: str) -> tuple[dict[str, int], dict[str, str]]:
    """Module -> layer number and module -> layer name, from the diagram after
    `<!-- layers: WHICH -->`."""
    text = DOC.read_text()
    m = re.search(r"<!-- layers: " + which + r" -->\s*```\w*\n(.*?)```", text, re.S)
    assert m, f"{DOC}: no diagram marked <!-- layers: {which} -->"
    layers: dict[str, int] = {}
    names: dict[str, str] = {}
    numbers = []
    for line in m.group(1).splitlines():
        if not line.strip():
            continue
        lm = re.fullmatch(r"\s*(\d+)\s+(\w+)\s+(.+)", line)
        assert lm, f"{DOC}: bad diagram line {line!r} (NUMBER NAME MODULE ...)"
        number = int(lm.group(1))
        numbers.append(number)
        for name in lm.group(3).split():
            assert name not in layers, f"{DOC}: {name} is in two layers"
            layers[name] = number
            names[name] = lm.group(2)
    assert numbers == sorted(numbers, reverse=True), f"{DOC}: layers not listed top down"
    return layers, names


def fortran_files() -> list[Path]:
    """The Fortran sources of the core, in their layer folders."""
    return sorted(FORTRAN.rglob("*.f90")) + sorted(FORTRAN.rglob("*.f90.in"))


def fortran_folders() -> dict[str, str]:
    """Fortran unit -> the folder (below fortran/) of its file."""
    out: dict[str, str] = {}
    for path in fortran_files():
        for unit in _units_of_file(path):
            out[unit] = path.parent.relative_to(FORTRAN).as_posix()
    return out


def _units_of_file(path: Path) -> list[str]:
    """The modules and programs a file defines (its stem if none)."""
    found = []
    for line in path.read_text().splitlines():
        code = line.split("!", 1)[0].lower()
        m = re.match(r"\s*(module|program)\s+(\w+)\s*$", code)
        if m and m.group(2) != "procedure":
            found.append(m.group(2))
    return found or [path.name.split(".")[0]]


def fortran_units() -> dict[str, set[str]]:
    """Fortran unit (module, program, or the file stem of a file of external procedures)
    -> the project modules it uses."""
    units: dict[str, set[str]] = {}
    for path in fortran_files():
        name = path.name.split(".")[0]
        used: set[str] = set()
        for line in path.read_text().splitlines():
            code = line.split("!", 1)[0].lower()
            m = re.match(r"\s*(module|program)\s+(\w+)\s*$", code)
            if m and m.group(2) != "procedure":
                name = m.group(2)
            m = re.match(r"\s*use\b\s*(?:,\s*(intrinsic|non_intrinsic)\s*)?(?:::)?\s*(\w+)",
                         code)
            if m and m.group(1) != "intrinsic" and m.group(2) not in INTRINSIC:
                used.add(m.group(2))
        units[name] = used
    return units


def _unit_of(path: Path) -> str:
    """Python unit of a file: the module name, 'study' for the whole study package."""
    rel = path.relative_to(PYTHON)
    return rel.parts[0] if len(rel.parts) > 1 else rel.name.split(".")[0]


def python_units() -> tuple[dict[str, set[str]], list[str]]:
    """Python unit -> the units it imports; and the imports of private names of another
    unit ('file: name')."""
    files = sorted(PYTHON.rglob("*.py"))
    known = {_unit_of(p) for p in files} | {_unit_of(p) for p in PYTHON.glob("*.py.in")}
    known.add(EXTENSION)
    units: dict[str, set[str]] = {_unit_of(p): set() for p in PYTHON.glob("*.py.in")}
    private: list[str] = []
    for path in files:
        unit = _unit_of(path)
        pkg = list(path.relative_to(PYTHON).parts[:-1])     # package path inside dyncontact
        imported = units.setdefault(unit, set())
        aliases: dict[str, str] = {}                       # local name -> unit it is
        tree = ast.parse(path.read_text(), filename=str(path))
        for node in ast.walk(tree):
            targets: list[tuple[str, str | None, str]] = []   # (unit, imported name, alias)
            if isinstance(node, ast.Import):
                for a in node.names:
                    parts = a.name.split(".")
                    if parts[0] == "dyncontact":
                        u = parts[1] if len(parts) > 1 else "__init__"
                        targets.append((u, None, a.asname or parts[0]))
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = pkg[:len(pkg) - (node.level - 1)] if node.level > 1 else pkg
                    mod = base + (node.module.split(".") if node.module else [])
                elif node.module and node.module.split(".")[0] == "dyncontact":
                    mod = node.module.split(".")[1:]
                else:
                    continue
                for a in node.names:
                    if mod:
                        u = mod[0]
                        targets.append((u, a.name, a.asname or a.name))
                    elif a.name in known:                   # from . import core
                        targets.append((a.name, None, a.asname or a.name))
                    else:                                   # from . import __version__
                        targets.append(("__init__", a.name, a.asname or a.name))
            for u, name, alias in targets:
                imported.add(u)
                if name is None:
                    aliases[alias] = u
                elif u != unit and name.startswith("_") and not name.startswith("__") \
                        and name not in known:
                    private.append(f"{path.relative_to(ROOT)}: {u}.{name}")
        for node in ast.walk(tree):
            if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
                    and node.value.id in aliases and aliases[node.value.id] != unit
                    and node.attr.startswith("_") and not node.attr.startswith("__")):
                private.append(f"{path.relative_to(ROOT)}:{node.lineno}: "
                               f"{aliases[node.value.id]}.{node.attr}")
        imported.discard(unit)
    return units, private


def violations(layers: dict[str, int], units: dict[str, set[str]]) -> list[str]:
    """Uses that go up a layer, and units or diagram entries without a counterpart."""
    out = [f"{u}: not in the diagram" for u in units if u not in layers]
    out += [f"{m}: in the diagram but not in the code" for m in layers
            if m not in units and m != EXTENSION]
    for u, used in sorted(units.items()):
        for m in sorted(used):
            if m not in layers:
                out.append(f"{u} uses {m}, which is not in the diagram")
            elif u in layers and layers[m] > layers[u]:
                out.append(f"{u} (layer {layers[u]}) uses {m} (layer {layers[m]})")
    return out


def test_fortran_uses_follow_the_layers():
    assert violations(read_layers("fortran"), fortran_units()) == []


def test_each_fortran_module_is_in_its_layers_folder():
    """The folders of fortran/ are the layers of the diagram: fortran/<layer name>/."""
    _, names = read_layer_table("fortran")
    folders = fortran_folders()
    wrong = {u: (folders[u], names[u]) for u in folders
             if u in names and folders[u] != names[u]}
    assert wrong == {}, "module: (its folder, its layer's folder)"
    assert not list(FORTRAN.glob("*.f90")), "a Fortran file outside the layer folders"


def test_a_misplaced_module_is_found():
    """The folder check can fail: a module of layer 'fem' filed under 'io'."""
    _, names = read_layer_table("fortran")
    folders = dict(fortran_folders(), model="io")
    assert [u for u in folders if u in names and folders[u] != names[u]] == ["model"]


def test_python_imports_follow_the_layers():
    units, _private = python_units()
    assert violations(read_layers("python"), units) == []


def test_only_core_imports_the_extension_and_nobody_its_private_helpers():
    units, private = python_units()
    assert sorted(u for u, used in units.items() if EXTENSION in used) == [BOUNDARY]
    assert private == []


def test_the_numerical_core_sees_no_scene_and_no_file_reader():
    """The point of the layering: model and schemes are below the readers."""
    layers = read_layers("fortran")
    for low in ("model", "time_scheme", "implicit_schemes", "explicit_schemes",
                "central_difference", "mass_solver"):
        for reader in ("scene", "gmsh_mesh", "mesh_source", "os_files"):
            assert layers[low] < layers[reader], (low, reader)


@pytest.mark.parametrize("planted, expected", [
    ({"model": {"scene"}}, "model (layer 3) uses scene (layer 5)"),
    ({"new_module": {"kinds"}}, "new_module: not in the diagram"),
    ({"sparse": {"no_such_module"}}, "sparse uses no_such_module, which is not in the diagram"),
])
def test_a_planted_violation_is_found(planted, expected):
    units = {k: set(v) for k, v in fortran_units().items()}
    for k, v in planted.items():
        units.setdefault(k, set()).update(v)
    assert expected in violations(read_layers("fortran"), units)


def test_a_planted_private_import_is_found(tmp_path, monkeypatch):
    """The private-helper check on a copy of the package with one bad module added."""
    import shutil

    copy = tmp_path / "dyncontact"
    shutil.copytree(PYTHON, copy, ignore=shutil.ignore_patterns("__pycache__"))
    (copy / "bad.py").write_text("from . import core\nfrom .core import _fpath\n"
                                 "x = core._core\n")
    monkeypatch.setattr(__import__(__name__), "PYTHON", copy)
    monkeypatch.setattr(__import__(__name__), "ROOT", tmp_path)
    units, private = python_units()
    assert units["bad"] == {"core"}
    assert private == ["dyncontact/bad.py: core._fpath", "dyncontact/bad.py:3: core._core"]
