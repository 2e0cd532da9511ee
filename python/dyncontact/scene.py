"""Scene files (SPEC section 3): read, modify, validate and write them.

A scene is a Fortran-namelist text file with the groups ``&mesh``, ``&boundary``,
``&material``, ``&contact``, ``&initial``, ``&scheme`` and ``&output``. The
Fortran core (``fortran/scene.f90``) and this module read it the same way: same
grammar, same defaults, same checks, and errors of one line::

    PATH: &group key: what is wrong (got 'VALUE')

Values are parsed with f90nml; a small tokenizer (the same as the Fortran one)
first checks what f90nml lets through: text outside groups, unknown or repeated
groups and keys, unterminated groups, unquoted strings, non-text files.

Everything is driven by one table, :data:`SCHEMA`.

>>> scn = Scene()
>>> scn.set('scheme.dt', '0.001')
>>> scn.get('scheme.dt')
0.001
"""

from __future__ import annotations

import io
import math
import os
import re
import sys
from typing import Any

import f90nml

__all__ = ["Scene", "SceneError", "SCHEMA"]

#: Longest path string (mesh file, output folder), in bytes (Fortran PATH_LEN).
PATH_LEN = 1024
#: Longest name string (boundary groups, scheme names...), in bytes (Fortran NAME_LEN).
NAME_LEN = 256
#: Larger scene files are rejected.
MAX_FILE_BYTES = 1048576
#: Raw tokens kept per key (for messages).
MAX_TOKENS = 8
#: Repeat counts r*value are capped at this for counting.
MAX_REPEAT = 1000
#: Characters of file text quoted in messages.
EXCERPT_LEN = 40
#: Characters of a value quoted in messages.
VALUE_LEN = 200

INT, REAL, NAME, PATH = "int", "real", "name", "path"

#: (group, key, type, default, count): the scene format. count 2 = a 2-vector
#: that accepts 1 value (component 2 = 0) or 2 values. Same order as the
#: Fortran key table, which is the order of checks and of to_dict().
SCHEMA: tuple[tuple[str, str, str, Any, int], ...] = (
    ("mesh", "file", PATH, "", 1),
    ("mesh", "dim", INT, 2, 1),
    ("mesh", "length", REAL, 1.0, 1),
    ("mesh", "width", REAL, 0.1, 1),
    ("mesh", "h", REAL, 0.05, 1),
    ("boundary", "clamped", NAME, "top", 1),
    ("boundary", "slip_x", NAME, "", 1),
    ("boundary", "slip_y", NAME, "", 1),
    ("boundary", "contact", NAME, "bottom", 1),
    ("material", "young", REAL, 2.0 / 3.0, 1),
    ("material", "poisson", REAL, 1.0 / 3.0, 1),
    ("material", "density", REAL, 1.0, 1),
    ("material", "gravity", REAL, (0.0, 0.0), 2),
    ("contact", "method", NAME, "nitsche", 1),
    ("contact", "theta", INT, 1, 1),
    ("contact", "gamma0", REAL, 10.0, 1),
    ("contact", "obstacle_point", REAL, (0.0, 0.0), 2),
    ("contact", "obstacle_normal", REAL, (0.0, -1.0), 2),
    ("contact", "probe", REAL, (0.05, 0.0), 2),
    ("contact", "quadrature", NAME, "exact", 1),
    ("contact", "quad_points", INT, 3, 1),
    ("initial", "kind", NAME, "compressed_bar", 1),
    ("initial", "amplitude", REAL, 0.5, 1),
    ("initial", "velocity", REAL, (0.0, 0.0), 2),
    ("scheme", "name", NAME, "hht", 1),
    ("scheme", "alpha", REAL, 0.0, 1),
    ("scheme", "beta", REAL, 0.25, 1),
    ("scheme", "gamma", REAL, 0.5, 1),
    ("scheme", "theta", REAL, 0.5, 1),
    ("scheme", "dt", REAL, 0.0025, 1),
    ("scheme", "t_end", REAL, 15.0, 1),
    ("scheme", "mass", NAME, "consistent", 1),
    ("scheme", "newton_tol", REAL, 1e-10, 1),
    ("scheme", "newton_maxit", INT, 50, 1),
    ("scheme", "blowup", REAL, 10.0, 1),
    ("output", "dir", PATH, "out", 1),
    ("output", "every", INT, 1, 1),
    ("output", "fields_every", INT, 0, 1),
)

GROUPS: tuple[str, ...] = tuple(dict.fromkeys(g for g, *_ in SCHEMA))
_SPEC = {(g, k): (t, d, c) for g, k, t, d, c in SCHEMA}

SCHEMES = ("newmark", "hht", "hht_seed", "theta", "pc", "pc_hht", "pc_hht_seed")
INITIAL_KINDS = ("rest", "velocity", "compressed_bar")

_IDENT = re.compile(r"[A-Za-z][A-Za-z0-9_]*")
_INT = re.compile(r"[+-]?[0-9]+")
_REAL = re.compile(r"[+-]?([0-9]+(\.[0-9]*)?|\.[0-9]+)([eEdD][+-]?[0-9]+)?")
_BLANK = " \t\r\n"


class SceneError(ValueError):
    """A bad scene: the message is one line ``PATH: &group key: what is wrong``."""


# ---------------------------------------------------------------- messages

def _sanitize(text: str, maxlen: int) -> str:
    """Printable ASCII only ('?' for the rest), at most maxlen characters + '...'."""
    out = "".join(c if 32 <= ord(c) <= 126 else "?" for c in text[:maxlen])
    return out + "..." if len(text) > maxlen else out


def _excerpt(text: str, i: int) -> str:
    """File text from i to the end of its line, shortened."""
    j = i
    while j < len(text) and text[j] not in "\r\n":
        j += 1
    return _sanitize(text[i:j].rstrip(" "), EXCERPT_LEN)


def _as_bytes(text: str) -> str:
    """Text as the Fortran sees it: one character per UTF-8 byte (for messages)."""
    return text.encode("utf-8", "surrogateescape").decode("latin-1")


def _num(x: float) -> str:
    return repr(float(x))


def _vec(v) -> str:
    return f"{_num(v[0])}, {_num(v[1])}"


# ---------------------------------------------------------------- tokenizer

class _Token:
    __slots__ = ("raw", "value", "quoted", "rep")

    def __init__(self, raw: str, value: str, quoted: bool, rep: int = 1):
        self.raw, self.value, self.quoted, self.rep = raw, value, quoted, rep


class _Entry:
    __slots__ = ("tokens", "nval")

    def __init__(self):
        self.tokens: list[_Token] = []
        self.nval = 0


def _skip_space(text: str, i: int, line: int) -> tuple[int, int]:
    n = len(text)
    while i < n:
        c = text[i]
        if c == "\n":
            line += 1
            i += 1
        elif c in " \t\r":
            i += 1
        elif c == "!":
            while i < n and text[i] != "\n":
                i += 1
        else:
            break
    return i, line


def _ident_end(text: str, i: int) -> int:
    m = _IDENT.match(text, i)
    return m.end() if m else i


def _tokenize(path: str, text: str) -> dict[tuple[str, str], _Entry]:
    """Groups and key = value entries of the file (raises SceneError)."""
    entries: dict[tuple[str, str], _Entry] = {}
    seen: dict[str, int] = {}
    n = len(text)
    i, line = 0, 1
    while True:
        i, line = _skip_space(text, i, line)
        if i >= n:
            break
        if text[i] != "&":
            raise SceneError(f"{path}: line {line}: text outside a group "
                             f"(got '{_excerpt(text, i)}')")
        j = _ident_end(text, i + 1)
        if j == i + 1:
            raise SceneError(f"{path}: line {line}: '&' without a group name "
                             f"(got '{_excerpt(text, i)}')")
        group = _sanitize(text[i + 1:j].lower(), EXCERPT_LEN)
        where = f"{path}: &{group}"
        if group not in GROUPS:
            known = ", ".join("&" + g for g in GROUPS)
            raise SceneError(f"{where}: unknown group (expected one of {known})")
        if group in seen:
            raise SceneError(f"{where}: group given twice (lines {seen[group]} and {line})")
        seen[group] = line
        i = j
        if i < n and text[i] not in _BLANK + "/!":
            raise SceneError(f"{where}: expected a blank after the group name "
                             f"(got '{_excerpt(text, i)}')")
        closed = False
        while True:
            i, line = _skip_space(text, i, line)
            if i >= n:
                break
            if text[i] == "/":
                i += 1
                closed = True
                break
            if text[i] == "&":
                break
            j = _ident_end(text, i)
            if j == i:
                raise SceneError(f"{where}: expected a key name (got '{_excerpt(text, i)}')")
            key = _sanitize(text[i:j].lower(), EXCERPT_LEN)
            if (group, key) not in _SPEC:
                known = ", ".join(k for g, k, *_ in SCHEMA if g == group)
                raise SceneError(f"{where} {key}: unknown key (expected one of {known})")
            if (group, key) in entries:
                raise SceneError(f"{where} {key}: key given twice")
            i, line = _skip_space(text, j, line)
            if i >= n:
                break
            if text[i] != "=":
                raise SceneError(f"{where} {key}: expected '=' after the key "
                                 f"(got '{_excerpt(text, i)}')")
            entry = _Entry()
            entries[(group, key)] = entry
            i, line = _read_values(text, i + 1, line, entry, f"{where} {key}")
        if not closed:
            if i >= n:
                raise SceneError(f"{where}: unterminated group "
                                 "(no '/' before the end of the file)")
            raise SceneError(f"{where}: unterminated group "
                             f"(no '/' before '{_excerpt(text, i)}')")
    if not seen:
        raise SceneError(f"{path}: empty scene file (no &group)")
    return entries


def _read_values(text: str, i: int, line: int, entry: _Entry, where: str) -> tuple[int, int]:
    """Values of one key from after its '=' up to the next key, '/' or '&'."""
    n = len(text)
    expect = True
    while True:
        i, line = _skip_space(text, i, line)
        if i >= n:
            break
        c = text[i]
        if c in "/&":
            break
        if c == ",":
            if expect:
                raise SceneError(f"{where}: empty value (got '{_excerpt(text, i)}')")
            expect = True
            i += 1
            continue
        if c == "=":
            raise SceneError(f"{where}: unexpected '=' (got '{_excerpt(text, i)}')")
        if c in "'\"":
            tok, j = _read_quoted(text, i)
            if tok is None:
                raise SceneError(f"{where}: unterminated string (got '{_excerpt(text, i)}')")
            if j < n and text[j] not in _BLANK + ",/!":
                raise SceneError(f"{where}: unexpected text after a string "
                                 f"(got '{_excerpt(text, i)}')")
            i = j
        else:
            j = i
            while j < n and text[j] not in _BLANK + ",/!=":
                j += 1
            if _ident_end(text, i) == j:
                p, _ = _skip_space(text, j, line)
                if p < n and text[p] == "=":
                    break  # the next key
            tok = _split_repeat(_Token(text[i:j], text[i:j], False), where)
            i = j
        entry.nval = min(entry.nval + tok.rep, MAX_TOKENS * MAX_REPEAT)
        if len(entry.tokens) < MAX_TOKENS:
            entry.tokens.append(tok)
        expect = False
    if entry.nval == 0:
        got = _excerpt(text, i) if i < n else ""
        raise SceneError(f"{where}: missing value (got '{got}')")
    return i, line


def _read_quoted(text: str, i: int) -> tuple[_Token | None, int]:
    q = text[i]
    n = len(text)
    p = i + 1
    while p < n:
        c = text[p]
        if c in "\r\n":
            return None, 0
        if c == q:
            if p + 1 < n and text[p + 1] == q:
                p += 2
                continue
            raw = text[i:p + 1]
            return _Token(raw, raw[1:-1].replace(q + q, q), True), p + 1
        p += 1
    return None, 0


def _split_repeat(tok: _Token, where: str) -> _Token:
    p = tok.raw.find("*")
    if p < 1 or not tok.raw[:p].isdigit() or not tok.raw[:p].isascii():
        return tok
    if p == len(tok.raw) - 1:
        raise SceneError(f"{where}: empty value (got '{_sanitize(tok.raw, VALUE_LEN)}')")
    r = MAX_REPEAT if p > 6 else int(tok.raw[:p])
    if r == 0:
        raise SceneError(f"{where}: repeat count must be > 0 "
                         f"(got '{_sanitize(tok.raw, VALUE_LEN)}')")
    return _Token(tok.raw, tok.raw[p + 1:], False, min(r, MAX_REPEAT))


# ---------------------------------------------------------------- values

def _from_latin1(s: str) -> str:
    """File bytes (decoded as latin-1) back to text (UTF-8, undecodable bytes kept)."""
    return s.encode("latin-1").decode("utf-8", "surrogateescape")


def _nbytes(s: str) -> int:
    return len(s.encode("utf-8", "surrogateescape"))


def _check_tokens(where: str, typ: str, count: int, entry: _Entry) -> Any:
    """The checks of the Fortran reader on the raw tokens of one key; returns
    the value they spell (used to cross-check f90nml's)."""
    toks = entry.tokens
    joined = _sanitize(", ".join(t.raw for t in toks), EXCERPT_LEN)
    if count == 2:
        if entry.nval > 2:
            raise SceneError(f"{where}: expected 1 or 2 values (got '{joined}')")
    elif entry.nval != 1:
        raise SceneError(f"{where}: expected 1 value (got '{joined}')")

    def got(t: _Token) -> str:
        return _sanitize(t.raw, VALUE_LEN)

    if typ == INT:
        t = toks[0]
        if t.quoted:
            raise SceneError(f"{where}: expected an integer, not a string (got '{got(t)}')")
        if not _INT.fullmatch(t.value):
            raise SceneError(f"{where}: expected an integer (got '{got(t)}')")
        # more than 18 digits (leading zeros included) is out of range
        v = int(t.value) if len(t.value.lstrip("+-")) <= 18 else 2**63
        if not -2**31 <= v <= 2**31 - 1:
            raise SceneError(f"{where}: integer out of range (got '{got(t)}')")
        return v
    if typ == REAL:
        out = []
        for idx in range(entry.nval):
            t = toks[0] if toks[0].rep >= idx + 1 else toks[1]
            if t.quoted:
                raise SceneError(f"{where}: expected a real number, not a string "
                                 f"(got '{got(t)}')")
            if not _REAL.fullmatch(t.value):
                raise SceneError(f"{where}: expected a real number (got '{got(t)}')")
            v = float(t.value.replace("d", "e").replace("D", "e"))
            if not math.isfinite(v):
                raise SceneError(f"{where}: real number out of range (got '{got(t)}')")
            out.append(v)
        if count == 2:
            return out if len(out) == 2 else [out[0], 0.0]
        return out[0]
    t = toks[0]
    if not t.quoted:
        raise SceneError(f"{where}: expected a quoted string (got '{got(t)}')")
    v = t.value.rstrip(" ")
    maxlen = PATH_LEN if typ == PATH else NAME_LEN
    if len(v) > maxlen:  # latin-1 text: one character per byte
        raise SceneError(f"{where}: string too long (more than {maxlen} characters)")
    return v


def _from_f90nml(typ: str, count: int, parsed: Any) -> Any:
    """f90nml's value of a key whose tokens passed _check_tokens, in the key's type."""
    if typ == INT:
        if isinstance(parsed, bool) or not isinstance(parsed, int):
            raise TypeError(parsed)
        return parsed
    if typ == REAL:
        values = parsed if isinstance(parsed, list) else [parsed]
        if not 1 <= len(values) <= count or any(
                isinstance(x, bool) or not isinstance(x, (int, float)) for x in values):
            raise TypeError(parsed)
        out = [float(x) for x in values]
        if count == 2:
            return out if len(out) == 2 else [out[0], 0.0]
        return out[0]
    if parsed is None:
        parsed = ""
    if not isinstance(parsed, str):
        raise TypeError(parsed)
    return parsed.rstrip(" ")


def _resolve(scene_path: str, file: str) -> str:
    """A relative file resolved against the scene file's folder (as the Fortran)."""
    return os.path.join(os.path.dirname(scene_path), file)


def _coerce(where: str, typ: str, count: int, value: Any) -> Any:
    """A value given in code or on a command line, converted to the key's type."""
    shown = _sanitize(str(value), VALUE_LEN)
    if typ in (NAME, PATH):
        if not isinstance(value, str):
            raise SceneError(f"{where}: expected a string (got '{shown}')")
        s = value
        if len(s) >= 2 and s[0] in "'\"" and s[-1] == s[0]:
            s = s[1:-1].replace(s[0] * 2, s[0])
        if any(ord(c) < 32 or ord(c) == 127 for c in s):
            raise SceneError(f"{where}: control characters are not allowed (got '{shown}')")
        s = s.rstrip(" ")
        maxlen = PATH_LEN if typ == PATH else NAME_LEN
        if _nbytes(s) > maxlen:
            raise SceneError(f"{where}: string too long (more than {maxlen} characters)")
        return s
    if typ == INT:
        if isinstance(value, str) and _INT.fullmatch(value.strip()):
            value = int(value.strip())
        if isinstance(value, bool) or not isinstance(value, int):
            raise SceneError(f"{where}: expected an integer (got '{shown}')")
        if not -2**31 <= value <= 2**31 - 1:
            raise SceneError(f"{where}: integer out of range (got '{shown}')")
        return value
    # reals
    if isinstance(value, str):
        items = [s for s in re.split(r"[,\s]+", value.strip()) if s]
    elif isinstance(value, (list, tuple)):
        items = list(value)
    else:
        items = [value]
    if not 1 <= len(items) <= count:
        want = "1 value" if count == 1 else "1 or 2 values"
        raise SceneError(f"{where}: expected {want} (got '{shown}')")
    out = []
    for item in items:
        if isinstance(item, str):
            if not _REAL.fullmatch(item):
                raise SceneError(f"{where}: expected a real number (got '{shown}')")
            item = float(item.replace("d", "e").replace("D", "e"))
        if isinstance(item, bool) or not isinstance(item, (int, float)):
            raise SceneError(f"{where}: expected a real number (got '{shown}')")
        item = float(item)
        if not math.isfinite(item):
            raise SceneError(f"{where}: real number out of range (got '{shown}')")
        out.append(item)
    if count == 2:
        return out if len(out) == 2 else [out[0], 0.0]
    return out[0]


# ---------------------------------------------------------------- Scene

class Scene:
    """A scene: every key of :data:`SCHEMA` with its value (defaults filled in).

    Parameters are addressed as ``'group.key'`` (``'scheme.dt'``,
    ``'contact.theta'``, ``'scheme.theta'``...).

    >>> scn = Scene()
    >>> scn.get('contact.obstacle_normal')
    [0.0, -1.0]
    """

    def __init__(self) -> None:
        #: The scene file read ('' if built in code); used in messages.
        self.path = ""
        self._values: dict[tuple[str, str], Any] = {
            (g, k): (list(d) if c == 2 else d) for g, k, _, d, c in SCHEMA}

    # -- reading
    @classmethod
    def read(cls, path: str | os.PathLike) -> "Scene":
        """Read and validate a scene file (raises :class:`SceneError`).

        A relative ``&mesh file`` is resolved against the scene file's folder.
        """
        path = os.fspath(path)
        try:
            with open(path, "rb") as fh:
                data = fh.read(MAX_FILE_BYTES + 1)
        except (OSError, ValueError):
            raise SceneError(f"{path}: cannot read scene file") from None
        if len(data) > MAX_FILE_BYTES:
            raise SceneError(f"{path}: scene file too large (more than {MAX_FILE_BYTES} bytes)")
        if not data:
            raise SceneError(f"{path}: empty scene file")
        for pos, b in enumerate(data):
            if (b < 32 and b not in (9, 10, 13)) or b == 127:
                line = data.count(b"\n", 0, pos) + 1
                raise SceneError(f"{path}: not a text file (control character on line {line})")
        text = data.decode("latin-1")
        entries = _tokenize(path, text)
        checked = {(g, k): _check_tokens(f"{path}: &{g} {k}", typ, count, entries[(g, k)])
                   for g, k, typ, _, count in SCHEMA if (g, k) in entries}
        # The values themselves come from f90nml; they must agree with the tokens.
        try:
            nml = f90nml.reads(text)
        except Exception as exc:
            msg = " ".join(str(exc).split())
            raise SceneError(f"{path}: f90nml cannot parse the file "
                             f"({_sanitize(msg, VALUE_LEN)})") from None
        scn = cls()
        scn.path = path
        for g, k, typ, _, count in SCHEMA:
            if (g, k) not in entries:
                continue
            try:
                value = _from_f90nml(typ, count, nml[g][k])
            except (KeyError, TypeError):
                value = None
            if value != checked[(g, k)]:
                raise SceneError(f"{path}: &{g} {k}: f90nml reads this value differently "
                                 f"(got '{_sanitize(entries[(g, k)].tokens[0].raw, VALUE_LEN)}')")
            scn._values[(g, k)] = _from_latin1(value) if typ in (NAME, PATH) else value
        given_file = scn._values[("mesh", "file")]
        if given_file:
            resolved = _resolve(path, given_file)
            if _nbytes(resolved) > PATH_LEN:
                raise SceneError(f"{path}: &mesh file: resolved path too long "
                                 f"(got '{_sanitize(given_file, VALUE_LEN)}')")
            scn._values[("mesh", "file")] = resolved
        scn._validate(given_file)
        return scn

    # -- access
    @staticmethod
    def _split(name: str) -> tuple[str, str]:
        group, _, key = str(name).partition(".")
        return group.strip().lower(), key.strip().lower()

    def _where(self, group: str, key: str) -> str:
        return f"{self.path or '<scene>'}: &{group} {key}"

    def _check_name(self, name: str) -> tuple[str, str]:
        group, key = self._split(name)
        if (group, key) in _SPEC:
            return group, key
        prefix = self.path or "<scene>"
        if group not in GROUPS:
            known = ", ".join(GROUPS)
            raise SceneError(f"{prefix}: unknown key '{_sanitize(str(name), VALUE_LEN)}' "
                             f"(expected group.key with group one of {known})")
        known = ", ".join(k for g, k, *_ in SCHEMA if g == group)
        raise SceneError(f"{prefix}: &{group} {key}: unknown key (expected one of {known})")

    def get(self, name: str) -> Any:
        """Value of ``'group.key'`` (a list of 2 floats for vectors)."""
        group, key = self._check_name(name)
        value = self._values[(group, key)]
        return list(value) if isinstance(value, list) else value

    def set(self, name: str, value: Any) -> None:
        """Set ``'group.key'``, converting ``value`` to the key's type.

        ``value`` may be a Python value or a command-line string: ``'0.001'``,
        ``"'lumped'"`` or ``'lumped'``, ``'0.0,-1.0'``. A single number for a
        vector sets component 1 and zeroes component 2. Ranges are checked by
        :meth:`validate`.
        """
        group, key = self._check_name(name)
        typ, _, count = _SPEC[(group, key)]
        self._values[(group, key)] = _coerce(self._where(group, key), typ, count, value)

    def __getitem__(self, name: str) -> Any:
        return self.get(name)

    def __setitem__(self, name: str, value: Any) -> None:
        self.set(name, value)

    def copy(self) -> "Scene":
        """An independent copy."""
        other = Scene()
        other.path = self.path
        other._values = {k: (list(v) if isinstance(v, list) else v)
                         for k, v in self._values.items()}
        return other

    def to_dict(self) -> dict[str, dict[str, Any]]:
        """``{group: {key: value}}`` for every key, as the Fortran scene JSON."""
        out: dict[str, dict[str, Any]] = {g: {} for g in GROUPS}
        for g, k, *_ in SCHEMA:
            v = self._values[(g, k)]
            out[g][k] = list(v) if isinstance(v, list) else v
        return out

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Scene) and self.to_dict() == other.to_dict()

    def __repr__(self) -> str:
        return f"Scene(path={self.path!r})"

    # -- checks
    def validate(self) -> None:
        """Check ranges and consistency (raises :class:`SceneError`).

        Normalizes ``contact.obstacle_normal`` (in 1D to (+-1, 0)). A relative
        mesh file counts from the current folder here (``read`` has already
        resolved it against the scene file's folder).
        """
        self._validate(self._values[("mesh", "file")])

    def _validate(self, given_file: str) -> None:
        v = self._values

        def bad(group: str, key: str, what: str, got: str) -> SceneError:
            got = _sanitize(_as_bytes(got), VALUE_LEN)
            return SceneError(f"{self._where(group, key)}: {what} (got '{got}')")

        # &mesh
        file = v[("mesh", "file")]
        if file:
            try:
                with open(file, "rb") as fh:
                    fh.read(1)
            except (OSError, ValueError):
                raise SceneError(
                    f"{self._where('mesh', 'file')}: cannot read mesh file "
                    f"'{_sanitize(_as_bytes(file), VALUE_LEN)}' "
                    f"(got '{_sanitize(_as_bytes(given_file), VALUE_LEN)}')"
                ) from None
        if v[("mesh", "dim")] not in (1, 2):
            raise bad("mesh", "dim", "must be 1 or 2", str(v[("mesh", "dim")]))
        for key in ("length", "width", "h"):
            if not v[("mesh", key)] > 0.0:
                raise bad("mesh", key, "must be > 0", _num(v[("mesh", key)]))
        # &material
        if not v[("material", "young")] > 0.0:
            raise bad("material", "young", "must be > 0", _num(v[("material", "young")]))
        if not -1.0 < v[("material", "poisson")] < 0.5:
            raise bad("material", "poisson", "must be in (-1, 1/2)",
                      _num(v[("material", "poisson")]))
        if not v[("material", "density")] > 0.0:
            raise bad("material", "density", "must be > 0", _num(v[("material", "density")]))
        # &contact
        if v[("contact", "method")] != "nitsche":
            raise bad("contact", "method", "must be 'nitsche'", v[("contact", "method")])
        if v[("contact", "theta")] not in (-1, 0, 1):
            raise bad("contact", "theta", "must be -1, 0 or 1", str(v[("contact", "theta")]))
        if not v[("contact", "gamma0")] > 0.0:
            raise bad("contact", "gamma0", "must be > 0", _num(v[("contact", "gamma0")]))
        n1, n2 = v[("contact", "obstacle_normal")]
        if v[("mesh", "dim")] == 1:
            if n1 == 0.0:
                raise bad("contact", "obstacle_normal", "component 1 must be nonzero in 1D",
                          _vec((n1, n2)))
            v[("contact", "obstacle_normal")] = [math.copysign(1.0, n1), 0.0]
        else:
            nrm = math.sqrt(n1 * n1 + n2 * n2)
            if not (nrm > 0.0 and math.isfinite(nrm)):
                raise bad("contact", "obstacle_normal", "must be a nonzero vector",
                          _vec((n1, n2)))
            # a unit normal (to round-off) is kept as is: normalizing is idempotent
            if abs(nrm - 1.0) > 4.0 * sys.float_info.epsilon:
                v[("contact", "obstacle_normal")] = [n1 / nrm, n2 / nrm]
        if v[("contact", "quadrature")] not in ("exact", "gauss"):
            raise bad("contact", "quadrature", "must be 'exact' or 'gauss'",
                      v[("contact", "quadrature")])
        if not 1 <= v[("contact", "quad_points")] <= 6:
            raise bad("contact", "quad_points", "must be in 1..6",
                      str(v[("contact", "quad_points")]))
        # &initial
        if v[("initial", "kind")] not in INITIAL_KINDS:
            raise bad("initial", "kind",
                      "must be one of " + ", ".join(f"'{s}'" for s in INITIAL_KINDS),
                      v[("initial", "kind")])
        # &scheme
        name = v[("scheme", "name")]
        if name not in SCHEMES:
            raise bad("scheme", "name", "must be one of " + ", ".join(f"'{s}'" for s in SCHEMES),
                      name)
        alpha = v[("scheme", "alpha")]
        if name in ("hht", "pc_hht") and not -1.0 / 3.0 <= alpha <= 0.0:
            raise bad("scheme", "alpha", f"must be in [-1/3, 0] for scheme '{name}'", _num(alpha))
        if name == "newmark" and not v[("scheme", "beta")] > 0.0:
            raise bad("scheme", "beta", "must be > 0 for scheme 'newmark' (explicit Newmark, "
                      "beta = 0, is not offered: use 'pc')", _num(v[("scheme", "beta")]))
        if name == "newmark" and not v[("scheme", "gamma")] >= 0.0:
            raise bad("scheme", "gamma", "must be >= 0 for scheme 'newmark'",
                      _num(v[("scheme", "gamma")]))
        if name == "theta" and not 0.5 <= v[("scheme", "theta")] <= 1.0:
            raise bad("scheme", "theta", "must be in [1/2, 1] for scheme 'theta'",
                      _num(v[("scheme", "theta")]))
        if not v[("scheme", "dt")] > 0.0:
            raise bad("scheme", "dt", "must be > 0", _num(v[("scheme", "dt")]))
        if not v[("scheme", "t_end")] >= 0.0:
            raise bad("scheme", "t_end", "must be >= 0", _num(v[("scheme", "t_end")]))
        if v[("scheme", "mass")] not in ("consistent", "lumped"):
            raise bad("scheme", "mass", "must be 'consistent' or 'lumped'", v[("scheme", "mass")])
        if not v[("scheme", "newton_tol")] > 0.0:
            raise bad("scheme", "newton_tol", "must be > 0", _num(v[("scheme", "newton_tol")]))
        if v[("scheme", "newton_maxit")] < 1:
            raise bad("scheme", "newton_maxit", "must be > 0", str(v[("scheme", "newton_maxit")]))
        if not v[("scheme", "blowup")] > 1.0:
            raise bad("scheme", "blowup", "must be > 1", _num(v[("scheme", "blowup")]))
        # &output
        if not v[("output", "dir")]:
            raise bad("output", "dir", "must not be empty", "")
        if v[("output", "every")] < 1:
            raise bad("output", "every", "must be > 0", str(v[("output", "every")]))
        if v[("output", "fields_every")] < 0:
            raise bad("output", "fields_every", "must be >= 0",
                      str(v[("output", "fields_every")]))

    # -- writing
    def to_namelist(self) -> f90nml.Namelist:
        """The scene as an f90nml Namelist (mesh file made absolute)."""
        nml = f90nml.Namelist()
        for group in GROUPS:
            items = []
            for g, k, typ, _, count in SCHEMA:
                if g != group:
                    continue
                value = self._values[(g, k)]
                if (g, k) == ("mesh", "file") and value:
                    value = os.path.abspath(value)
                elif typ == REAL:
                    value = [float(x) for x in value] if count == 2 else float(value)
                items.append((k, value))
            nml[group] = f90nml.Namelist(items)
        return nml

    def write(self, path: str | os.PathLike) -> None:
        """Validate, then write a namelist file that both readers accept."""
        self.validate()
        buf = io.StringIO()
        self.to_namelist().write(buf)
        text = "! dyncontact scene (written by dyncontact.Scene)\n" + buf.getvalue()
        with open(os.fspath(path), "w", encoding="utf-8", errors="surrogateescape") as fh:
            fh.write(text)
