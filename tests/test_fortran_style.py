"""House rules of the Fortran core that a reader of the text can check: explicit intent,
a doc comment on every public procedure and a `!!` on every dummy argument, errors
returned and never stopped on in library code, one real kind, no mutable module state.
Every .f90 under fortran/ is parsed: free-form continuations joined, comments and strings
set apart, procedures, interface bodies and derived types tracked. A planted file shows
that each check can fail."""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

from conftest import ROOT

#: Programs may stop; everything else is library code and returns a status.
PROGRAMS = {"fortran/app/main.f90"}

_PROC = re.compile(
    r"^((?:(?:pure|elemental|impure|recursive|module|non_recursive)\s+|"
    r"(?:integer|real|logical|character|complex|type)\s*(?:\([^)]*\))?\s+)*)"
    r"(subroutine|function)\s+(\w+)\s*(?:\(([^)]*)\))?(.*)$", re.I)
_END_PROC = re.compile(r"^end\s*(?:subroutine|function)\b", re.I)
_MODULE = re.compile(r"^module\s+(\w+)\s*$", re.I)
_PROGRAM = re.compile(r"^program\s+\w+", re.I)
_INTERFACE = re.compile(r"^(?:abstract\s+)?interface\b", re.I)
_END_INTERFACE = re.compile(r"^end\s*interface\b", re.I)
_TYPE_DEF = re.compile(r"^type\s*(?:,[^:]*)?(?:::)?\s*\w+\s*$", re.I)
_END_TYPE = re.compile(r"^end\s*type\b", re.I)
_CONTAINS = re.compile(r"^contains\s*$", re.I)
_DECL = re.compile(r"^(?:integer|real|logical|character|complex|type\s*\(|class\s*\(|"
                   r"procedure\s*\()", re.I)
_PUBLIC = re.compile(r"^public\s*(?:::)?\s*(.*)$", re.I)
_STOP = re.compile(r"^(?:\w+\s*:\s*)?(?:if\s*\(.*\)\s*)?(?:error\s+)?stop\b", re.I)
_BAD_KINDS = (
    (re.compile(r"\breal\s*\*\s*8\b", re.I), "real*8"),
    (re.compile(r"\bdouble\s+precision\b", re.I), "double precision"),
    (re.compile(r"\bkind\s*=\s*8\b", re.I), "kind=8"),
    (re.compile(r"\breal\s*\(\s*8\s*\)", re.I), "real(8)"),
    (re.compile(r"(?<![\w.])\d+\.?\d*d[+-]?\d+\b", re.I), "a d-exponent literal"),
)


@dataclass
class Proc:
    name: str
    line: int
    args: list[str]
    interface: bool
    bind_c: bool
    nested: bool
    public: bool = False
    decls: dict[str, tuple[str, int]] = field(default_factory=dict)


def _code(line: str) -> str:
    """The part of a line before its comment (a '!' outside quotes)."""
    quote = None
    for i, ch in enumerate(line):
        if quote:
            if ch == quote:
                quote = None
        elif ch in "'\"":
            quote = ch
        elif ch == "!":
            return line[:i]
    return line


def statements(lines: list[str]) -> list[tuple[int, str]]:
    """(first line number, statement) with continuation lines joined."""
    out, buf, start = [], "", 0
    for k, line in enumerate(lines, 1):
        s = _code(line).strip()
        if not s:
            continue
        if buf:
            buf += " " + (s[1:] if s.startswith("&") else s)
        else:
            buf, start = s, k
        if buf.endswith("&"):
            buf = buf[:-1].rstrip()
            continue
        out.append((start, buf))
        buf = ""
    return out


def _declared_names(stmt: str) -> tuple[str, list[str]]:
    """The attributes of a declaration and the names it declares."""
    if "::" in stmt:
        attrs, names = stmt.split("::", 1)
    else:
        m = re.match(r"^(\w+(?:\s*\([^)]*\))?)\s+(.*)$", stmt)
        if not m:
            return "", []
        attrs, names = m.groups()
    parts, depth, cur = [], 0, ""
    for ch in names:
        depth += ch in "([" and 1 or (ch in ")]" and -1 or 0)
        if ch == "," and depth == 0:
            parts.append(cur)
            cur = ""
        else:
            cur += ch
    parts.append(cur)
    return attrs.lower(), [m.group(1).lower() for p in parts if (m := re.match(r"\s*(\w+)", p))]


def violations(root: Path, names: list[str]) -> list[str]:
    """'file:line: rule: detail' for every break of the rules in the given files
    (paths relative to root)."""
    found: list[str] = []
    for name in names:
        raw = (root / name).read_text().splitlines()
        procs: list[Proc] = []
        stack: list[Proc] = []
        publics: set[str] = set()
        default_public = True
        in_module = in_contains = in_type = False
        in_interface = 0
        is_program = name in PROGRAMS
        for start, stmt in statements(raw):
            low = stmt.lower()
            where = f"{name}:{start}"
            for pattern, what in _BAD_KINDS:
                if pattern.search(stmt) and "'" not in stmt and '"' not in stmt:
                    found.append(f"{where}: real64 only: {what}")
            if _PROGRAM.match(stmt):
                is_program = True
                continue
            if _MODULE.match(stmt):
                in_module, in_contains, default_public, publics = True, False, True, set()
                continue
            if low == "private" and not stack and not in_type:
                default_public = False
                continue
            m = _PUBLIC.match(stmt)
            if m and not stack and not in_type:
                publics.update(n.strip().lower() for n in m.group(1).split(",") if n.strip())
                continue
            if _CONTAINS.match(stmt):
                in_contains = in_contains or not stack
                continue
            if _INTERFACE.match(stmt):
                in_interface += 1
                continue
            if _END_INTERFACE.match(stmt):
                in_interface -= 1
                continue
            if (not stack and not in_interface and _TYPE_DEF.match(stmt)
                    and not re.match(r"type\s*\(", low)):
                in_type = True
                continue
            if _END_TYPE.match(stmt):
                in_type = False
                continue
            if in_type:
                continue
            m = _PROC.match(stmt)
            if m and not low.startswith("end"):
                args = [a.strip().lower() for a in (m.group(4) or "").split(",") if a.strip()]
                p = Proc(m.group(3).lower(), start, args, bool(in_interface),
                         "bind(" in m.group(5).lower(), bool(stack))
                stack.append(p)
                procs.append(p)
                continue
            if _END_PROC.match(stmt) or (re.match(r"^end\s*$", low) and stack):
                stack.pop()
                continue
            if stack:
                if _DECL.match(stmt):
                    attrs, declared = _declared_names(stmt)
                    for n in declared:
                        stack[-1].decls.setdefault(n, (attrs, start))
                if _STOP.match(stmt) and not is_program:
                    found.append(f"{where}: library code returns a status: {stmt[:60]}")
                continue
            if in_module and not in_contains and not in_interface and _DECL.match(stmt):
                attrs, declared = _declared_names(stmt)
                if "parameter" not in attrs:
                    found.append(f"{where}: no mutable module state: {', '.join(declared)}")
        for p in procs:
            p.public = not p.nested and not p.interface and (p.name in publics or default_public)
            for a in p.args:
                attrs, k = p.decls.get(a, ("", p.line))
                if a == "*" or "intent" in attrs or (p.bind_c and "value" in attrs):
                    continue
                found.append(f"{name}:{k}: explicit intent: {p.name}: {a}")
            for a in p.args:
                if a not in p.decls:
                    continue
                k = p.decls[a][1]
                last = k
                while _code(raw[last - 1]).rstrip().endswith("&"):
                    last += 1
                nxt = raw[last].strip() if last < len(raw) else ""
                if "!!" not in raw[k - 1] and "!!" not in raw[last - 1] \
                        and not nxt.startswith("!!"):
                    found.append(f"{name}:{k}: !! on every dummy: {p.name}: {a}")
            if p.public and not is_program:
                above = raw[p.line - 2].strip() if p.line >= 2 else ""
                last = p.line
                while _code(raw[last - 1]).rstrip().endswith("&"):
                    last += 1
                after = raw[last].strip() if last < len(raw) else ""
                if not (above.startswith(("!>", "!!")) or after.startswith("!!")):
                    found.append(f"{name}:{p.line}: doc comment on public procedures: {p.name}")
    return found


def fortran_files(root: Path = ROOT) -> list[str]:
    return sorted(str(p.relative_to(root)) for p in (root / "fortran").rglob("*.f90"))


def test_the_fortran_core_keeps_the_house_rules():
    names = fortran_files()
    assert len(names) > 30 and "fortran/fem/fe_p1.f90" in names, names
    found = violations(ROOT, names)
    assert not found, "\n".join(found)


def test_a_planted_break_of_each_rule_is_found(tmp_path):
    """Each rule on a planted module, and the forms the core uses legitimately pass."""
    (tmp_path / "fortran").mkdir()
    (tmp_path / "fortran" / "planted.f90").write_text("""\
!> A planted module.
module planted
    use kinds, only: dp
    implicit none
    private
    public :: documented, undocumented
    integer, parameter :: FINE = 1                  ! 7: a constant: fine
    integer :: counter = 0                          ! 8: mutable
    type :: thing_t
        integer :: n = 0                            !! a component: fine
    end type thing_t
    interface
        function c_call(fd) bind(C, name='c_call') result(r)
            import :: c_int
            integer(c_int), value :: fd             !! a value dummy of bind(C): fine
            integer(c_int) :: r
        end function c_call
    end interface
contains
    !> Documented, but with a dummy without intent and one without !!.
    subroutine documented(a, b, &
                          c)
        real(dp), intent(in) :: a                   !! fine
        real(dp) :: b                               !! 24: no intent
        integer, intent(out) :: c
        real*8 :: z
        z = 1.0d0
        c = FINE
        if (a < 0) error stop 'no'
        b = a + z
    end subroutine documented
    subroutine undocumented(x)
        real(dp), intent(in) :: x                   !! fine
        write (*, '(a)') 'stop 1.0d0 is text'
    end subroutine undocumented
end module planted
""")
    found = violations(tmp_path, ["fortran/planted.f90"])
    got = sorted((int(f.split(":")[1]), f.split(": ")[1]) for f in found)
    assert got == [
        (8, "no mutable module state"),
        (24, "explicit intent"),
        (25, "!! on every dummy"),
        (26, "real64 only"),
        (27, "real64 only"),
        (29, "library code returns a status"),
        (32, "doc comment on public procedures"),
    ], found
