"""Scene files (SPEC section 3, docs/scenes.md): edit and write them.

The Fortran core (``fortran/io/scene.f90``) is the only reader: :meth:`Scene.read`,
:meth:`Scene.set` and :meth:`Scene.validate` send the scene through it (``core.scene_dump``,
``core.scene_parse``), so the defaults, the checks and the one-line messages
``PATH: &group key: what is wrong (got 'VALUE')`` are the executable's. A bad scene raises
:class:`dyncontact.BadInputError` (``SceneError`` is the same class).

A vector key the scene does not give (``material.gravity``, ``contact.obstacle_point``,
``contact.obstacle_normal``, ``contact.probe``, ``initial.velocity``) takes the default of
the mesh's dimension (1D, 2D or 3D; docs/scenes.md), which for a mesh file with
``&mesh dim = 0`` is known only from the file. The scene keeps such a key omitted: it is
never written back (so the run derives it from the mesh, as the executable does), and
:meth:`Scene.get` returns the default of the dimension, reading the mesh file if it must.

A scene also keeps which keys it gives: those of the file read and those set since
(:meth:`Scene.given`). Only those are written (:meth:`Scene.to_text`, :meth:`Scene.write`,
and so the scene a Scene runs), so that the run's warnings about keys that change nothing
(a scheme parameter the scheme does not use, the default initial state on a mesh file; see
docs/scenes.md) are about what the user wrote, as for a scene file.

>>> scn = Scene()
>>> scn.set('scheme.dt', '0.001')
>>> scn.get('scheme.dt')
0.001
"""

from __future__ import annotations

import copy
import numbers
import os
from pathlib import Path
from typing import Any

from . import core
from .core import BadInputError

__all__ = ["Scene", "SceneError", "find_scene", "packaged_file"]

#: The exception of a bad scene (the same class as BadInputError).
SceneError = BadInputError

#: The defaults of the vector keys by mesh dimension (1D, 2D, 3D), as the core's.
VECTOR_DEFAULTS = core.VECTOR_DEFAULTS


def _quote(s: str) -> str:
    return "'" + s.replace("'", "''") + "'"


def _value_text(value: Any, current: Any) -> str:
    """A Python value (or a command-line string) as namelist text for a key whose current
    value is `current` (its type is the key's type); the core converts and checks it.
    A path (``pathlib.Path``) is its text, as a string value; a list of names for a
    string key (``&boundary``'s groups) is the comma-separated list."""
    if isinstance(value, os.PathLike):
        value = os.fsdecode(value)
    if isinstance(current, str) and isinstance(value, (list, tuple)) \
            and all(isinstance(v, str) for v in value):
        value = ",".join(v.strip() for v in value)
    if isinstance(current, str):
        if isinstance(value, str):
            v = value.strip()
            if len(v) >= 2 and v[0] == v[-1] and v[0] in "'\"":
                return v                                  # already quoted
            return _quote(value)
        return str(value)                                 # the core says: not a string
    if isinstance(value, str):
        return value                                      # '0.001', '1d-3', '0.0,-1.0'
    if getattr(value, "ndim", 0) == 1:                # a numpy array: its numpy scalars
        value = list(value)
    if isinstance(value, (list, tuple)):
        return ", ".join(_number_text(x) for x in value)
    return _number_text(value)


def _number_text(x: Any) -> str:
    """One number: Python numbers by repr (exact), numpy scalars by str (their shortest
    decimal, so np.float32(0.001) is 0.001), a fraction (``fractions.Fraction``) as its
    nearest float (its text '1/400' would end the namelist group); anything else as text
    for the core to refuse."""
    if type(x) in (int, float):
        return repr(x)
    if isinstance(x, numbers.Rational) and not isinstance(x, numbers.Integral) \
            and type(x).__module__ != "numpy":
        return repr(float(x))
    return str(x)


def packaged_file(name: str, *source_folder: str) -> Path:
    """The data file `name` that the package installs beside its modules (an install), or
    else the source tree's ``source_folder/name``; FileNotFoundError naming both places."""
    here = Path(__file__).resolve().parent
    candidates = [here / name, here.parent.parent.joinpath(*source_folder, name)]
    for c in candidates:
        if c.is_file():
            return c
    raise FileNotFoundError(f"{name} not found (looked in {', '.join(map(str, candidates))})")


def find_scene(name: str) -> Path:
    """The example scene file `name` of the source tree's scripts/scenes/ that the package
    installs (the studies' ball, ``ball3d_newmark.nml``): next to this module (an install:
    its &mesh file names the .geo installed beside it), or in the source tree."""
    return packaged_file(name, "scripts", "scenes")


class Scene:
    """A scene: every key with its value (defaults filled in), addressed as
    ``'group.key'`` (``'scheme.dt'``, ``'contact.theta'``, ``'scheme.theta'``...).
    A vector key not given keeps the default of the mesh's dimension (see the module's
    documentation).

    >>> Scene().get('contact.obstacle_normal')
    [0.0, -1.0]
    """

    def __init__(self) -> None:
        #: The scene file read ('' if built in code); used in messages.
        self.path = ""
        #: The core's scene JSON; None: a vector key not given.
        self._values: dict[str, dict[str, Any]]
        #: The keys the scene gives, 'group.key' (the file's and those set since).
        self._given: frozenset[str]
        self._values, self._given = core.scene_parse("", "<scene>", keep_omitted=True,
                                                     with_given=True)
        #: The mesh file's dimension by everything that makes the mesh read (:meth:`_mesh_key`).
        self._mesh_dims: dict[tuple, int] = {}
        #: The keys set through :meth:`set`, each with the namelist text it was given as
        #: and the value the core read from it ('group.key' -> (text, value)). A vector
        #: among them stays as set when the dimension changes (:meth:`_follow_dimension`);
        #: :meth:`to_text` writes the text while the key keeps that value, so that a
        #: refusal quotes the user's own text ('0', not its reading '0.0'; '1e-400', not
        #: '0.0').
        self._set_texts: dict[str, tuple[str, Any]] = {}

    @classmethod
    def read(cls, path: str | os.PathLike) -> "Scene":
        """Read and validate a scene file (raises :class:`BadInputError`).

        A relative ``&mesh file`` is resolved against the scene file's folder, and made
        absolute: the Scene still names the same file after the process changes its
        current folder (``os.chdir``, a notebook's ``%cd``).
        """
        scn = cls()
        scn.path = os.fspath(path)
        scn._values, scn._given = core.scene_dump(scn.path, keep_omitted=True,
                                                  with_given=True)
        mesh = scn._values["mesh"]
        if mesh["file"] and not os.path.isabs(mesh["file"]):
            mesh["file"] = os.path.join(os.getcwd(), mesh["file"])   # '..' kept, as read
        return scn

    # -- access
    def _name(self) -> str:
        return self.path or "<scene>"

    def _check_name(self, name: str) -> tuple[str, str]:
        group, _, key = str(name).partition(".")
        group, key = group.strip().lower(), key.strip().lower()
        if key in self._values.get(group, {}):
            return group, key
        if group not in self._values:
            raise SceneError(f"{self._name()}: unknown key '{name}' (expected group.key with "
                             f"group one of {', '.join(self._values)})")
        if not key:     # a group alone ('scheme'): no key to name, '&scheme :' would say nothing
            raise SceneError(f"{self._name()}: unknown key '{name}' (expected group.key, "
                             f"'{group}.KEY' with KEY one of {', '.join(self._values[group])})")
        raise SceneError(f"{self._name()}: &{group} {key}: unknown key (expected one of "
                         f"{', '.join(self._values[group])})")

    def get(self, name: str) -> Any:
        """Value of ``'group.key'`` (a list of 2 floats for vectors, 3 in 3D): the value the
        run will use. A vector key the scene does not give is the default of the mesh's
        dimension; with a mesh file and ``&mesh dim = 0`` the file is read (through the
        core, as the run reads it) to know it, which raises :class:`BadInputError` when it
        cannot be read.
        """
        group, key = self._check_name(name)
        value = self._values[group][key]
        if value is None:
            return list(VECTOR_DEFAULTS[self.dimension()][(group, key)])
        return copy.copy(value)

    def given(self, name: str) -> bool:
        """Whether the scene gives ``'group.key'``: the file read writes it or it was set
        since, whatever its value (a key not given takes its default, and a vector key the
        default of the mesh's dimension). Only the keys given are written
        (:meth:`to_text`)."""
        group, key = self._check_name(name)
        return f"{group}.{key}" in self._given

    def dimension(self) -> int:
        """The mesh's dimension (1, 2 or 3): ``&mesh dim``, 2 for the built-in bar with
        dim = 0, and for a mesh file with dim = 0 the file's (read through the core, as
        the run reads it; :class:`BadInputError` if it cannot be read, naming the scene and
        ``&mesh file`` as the run's message does)."""
        mesh = self._values["mesh"]
        if mesh["dim"] not in (0, 1, 2, 3):     # set, not validated yet: the core's message
            core.scene_parse(f"&mesh dim = {mesh['dim']} /", self._name(), full=True)
        if mesh["dim"] != 0 or not mesh["file"]:
            return mesh["dim"] or 2
        key = self._mesh_key()
        if key not in self._mesh_dims:
            path, _, _, length, width, h, given, max_elements = key
            try:
                self._mesh_dims[key] = int(core.load_mesh(
                    path, length=length, width=width, h=h, check=False, given=list(given),
                    max_elements=max_elements)["dim"])
            except BadInputError as exc:    # named as the run names it: scene and key
                raise BadInputError(f"{self._name()}: &mesh file: {exc}") from None
        return self._mesh_dims[key]

    def _mesh_key(self) -> tuple:
        """Everything the mesh file's mesh follows: the file (path, mtime, size) and the
        &mesh keys it is read with (a .geo's h, length and width, which of them the scene
        gives, max_elements), so that a dimension read once is reused only for the same
        mesh."""
        mesh = self._values["mesh"]
        path = mesh["file"]
        try:
            st = os.stat(path)
            stamp = (st.st_mtime_ns, st.st_size)
        except OSError:
            stamp = (-1, -1)
        given = tuple(k for k in ("h", "length", "width") if self.given(f"mesh.{k}"))
        return (path, *stamp, float(mesh["length"]), float(mesh["width"]), float(mesh["h"]),
                given, int(mesh["max_elements"]))

    def set(self, name: str, value: Any) -> None:
        """Set ``'group.key'``; the core converts ``value`` to the key's type.

        ``value`` may be a Python or numpy value or a command-line string: ``'0.001'``,
        ``"'lumped'"`` or ``'lumped'``, ``'0.0,-1.0'``; a path (``pathlib.Path``) for
        ``mesh.file`` or ``output.dir``; a list of group names (``['left', 'right']``,
        the same as ``'left,right'``) for a ``&boundary`` key. A single number for a
        vector sets component 1 and zeroes component 2. Ranges, and the count of a
        vector's components against the mesh's dimension, are checked by
        :meth:`validate` (and by the run).

        Setting a ``&mesh`` key that changes the mesh's dimension (``'mesh.dim'``,
        ``'mesh.file'``, or a ``.geo``'s ``h``, ``length`` or ``width``) changes the
        defaults of the vector keys not given (3 components in 3D). A vector the scene
        file gives with exactly the old dimension's default of 1 or 2 components (a scene
        that spells out the 2D defaults) takes the new dimension's default; a vector set
        here, and any other, is kept as given, never shortened, so a vector with a count of
        components of the old dimension makes :meth:`validate` fail naming it, as in a
        scene file, until it is set too.
        """
        group, key = self._check_name(name)
        current = self._values[group][key]
        text = _value_text(value, [] if current is None else current)
        replace = {(group, key): text}
        try:
            parsed = core.scene_parse(self.to_text(replace), self._name(),
                                      keep_omitted=True, with_given=True)
        except BadInputError as exc:
            # the rest of the scene parsed before, so the value is at fault: a message
            # about another key or a line of the text written here ('1/400' or '0.1 /'
            # ends the group) is said about this key
            if f"&{group} {key}:" in str(exc):
                raise
            raise SceneError(f"{self._name()}: &{group} {key}: expected values only, not "
                             f"another key or a '/' (got '{text}')") from None
        # every group is written (so a value cannot open one again), but not every key:
        # a value that gives another key of its group ('1, t_end = 5') is refused
        if parsed[1] - self._given - {f"{group}.{key}"}:
            raise SceneError(f"{self._name()}: &{group} {key}: expected values only, not "
                             f"another key (got '{text}')")
        if group == "mesh":
            parsed = self._follow_dimension(parsed, replace)
        self._values, self._given = parsed
        self._set_texts = {**self._set_texts,
                           f"{group}.{key}": (text, copy.deepcopy(parsed[0][group][key]))}

    def unset(self, *names: str) -> None:
        """Leave each ``'group.key'`` out of the scene: it is no longer given, takes its
        default and draws no warning that it is not used. A scene that switches a base
        scene's scheme (or contact method, quadrature, initial kind) drops the base's keys
        the new choice does not use::

            scene.set("scheme.name", "newmark")
            scene.unset("scheme.alpha")     # bar2d_hht.nml's: newmark does not use it

        A key not given is left as it is. ``'mesh.dim'`` and ``'mesh.file'`` cannot be
        unset (the vector keys' defaults follow them: :meth:`set` them instead)."""
        omit = {self._check_name(name) for name in names}
        if omit & {("mesh", "dim"), ("mesh", "file")}:
            raise SceneError(f"{self._name()}: unset(): &mesh dim and file cannot be "
                             "unset (set them: the vector keys' defaults follow them)")
        parsed = core.scene_parse(self.to_text(omit=omit), self._name(), keep_omitted=True,
                                  with_given=True)
        if any(group == "mesh" for group, _ in omit):   # a .geo's h, length, width
            parsed = self._follow_dimension(parsed, omit=omit)
        self._values, self._given = parsed
        dropped = {f"{g}.{k}" for g, k in omit}
        self._set_texts = {name: entry for name, entry in self._set_texts.items()
                           if name not in dropped}

    def _follow_dimension(self, parsed: tuple[dict[str, dict[str, Any]], frozenset[str]],
                          replace: dict[tuple[str, str], str] | None = None,
                          omit: set[tuple[str, str]] | None = None
                          ) -> tuple[dict[str, dict[str, Any]], frozenset[str]]:
        """`parsed` (self with `replace` applied and `omit` left out: values and keys
        given) where the dimension changed: a vector the scene file gives with exactly the
        old dimension's default of 1 or 2 components becomes the key left out (the new
        dimension's default), as if the scene had not spelled out the default; a vector
        set through :meth:`set` or of 3 components is kept as given (never shortened). The
        dimensions are read (a mesh file's, a .geo meshed) only when a vector could
        follow."""
        values = parsed[0]

        def follows(gk: tuple[str, str], dim: int) -> bool:
            return values[gk[0]][gk[1]] == VECTOR_DEFAULTS[dim][gk] \
                and f"{gk[0]}.{gk[1]}" not in self._set_texts

        if not any(follows(gk, dim) for dim in (1, 2) for gk in VECTOR_DEFAULTS[dim]):
            return parsed
        other = self.copy()
        other._values, other._given = parsed
        try:
            old, new = self.dimension(), other.dimension()
        except BadInputError:          # a mesh file that cannot be read: the run says so
            return parsed
        self._mesh_dims.update(other._mesh_dims)
        if old == new or old == 3:
            return parsed
        follow = {gk for gk in VECTOR_DEFAULTS[old] if follows(gk, old)}
        if not follow:
            return parsed
        return core.scene_parse(self.to_text(replace, omit=follow | set(omit or ())),
                                self._name(), keep_omitted=True, with_given=True)

    def __getitem__(self, name: str) -> Any:
        return self.get(name)

    def __setitem__(self, name: str, value: Any) -> None:
        self.set(name, value)

    def copy(self) -> "Scene":
        """An independent copy."""
        other = Scene.__new__(Scene)
        other.path = self.path
        other._values = copy.deepcopy(self._values)
        other._given = self._given
        other._mesh_dims = dict(self._mesh_dims)
        other._set_texts = dict(self._set_texts)      # (text, value): never changed in place
        return other

    def to_dict(self) -> dict[str, dict[str, Any]]:
        """``{group: {key: value}}`` for every key, as the Fortran scene JSON: a vector
        key not given is None (the default of the mesh's dimension, which :meth:`get`
        gives)."""
        return copy.deepcopy(self._values)

    def _resolved(self) -> dict[str, dict[str, Any]]:
        values = copy.deepcopy(self._values)
        for group, keys in values.items():
            for key, value in keys.items():
                if value is None:
                    keys[key] = self.get(f"{group}.{key}")
        return values

    def __eq__(self, other: object) -> bool:
        """Scenes are equal when every key has the same value for the run (a key given
        with its default equals the key not given, though only the first one can draw a
        warning that it is not used)."""
        if not isinstance(other, Scene):
            return False
        if self._values == other._values:
            return True
        try:
            return self._resolved() == other._resolved()
        except BadInputError:        # a mesh file that cannot be read: not the same scene
            return False

    def __repr__(self) -> str:
        return f"Scene(path={self.path!r})"

    def validate(self, mesh: bool = True) -> None:
        """Check ranges and consistency in the core (raises :class:`BadInputError`).

        Normalizes ``contact.obstacle_normal``. A relative mesh file counts from the
        current folder here (``read`` has made the file's absolute; one given to
        :meth:`set` counts from the current folder).
        With a mesh file and ``mesh.dim`` 0, the keys that depend on the mesh's dimension
        (the vector keys' counts, ``contact.quad_points``) are checked against the file's
        dimension as the run checks them, so a vector of 2 components for a 3D mesh file
        is refused here, not only when the run starts: the file is read for that (as
        :meth:`dimension` does: a ``.geo`` is meshed, once per version of the file), and
        a file that cannot be read is refused as the run would. ``mesh=False`` leaves
        that check to the run, which reads the mesh anyway (:meth:`write` and
        :func:`dyncontact.run` do, so that a run does not read its mesh twice).
        """
        text = self.to_text()
        values, given = core.scene_parse(text, self._name(), full=True, keep_omitted=True,
                                         with_given=True)
        self._values, self._given = values, given
        if mesh and values["mesh"]["file"] and values["mesh"]["dim"] == 0:
            core.scene_check_dim(text, self._name(), self.dimension())

    # -- writing
    def to_text(self, replace: dict[tuple[str, str], str] | None = None,
                absolute_mesh: bool = False, omit: set[tuple[str, str]] | None = None) -> str:
        """The scene as namelist text, one key a line: the keys given (:meth:`given`) and
        those of `replace` (value texts to use instead of the stored values), but not those
        of `omit` (left out, so that they take their defaults); `absolute_mesh`: write the
        mesh file absolute. A key not given is left out: it takes its default (a vector
        key, the default of the mesh's dimension), and the scene read back gives the same
        keys. Every group is written, even with no key, so that a value cannot open a
        group again (:meth:`set`)."""
        lines = ["! dyncontact scene (written by dyncontact.Scene)"]
        for group, keys in self._values.items():
            lines.append(f"&{group}")
            for key, value in keys.items():
                if omit and (group, key) in omit:
                    continue
                if absolute_mesh and (group, key) == ("mesh", "file") and value \
                        and not os.path.isabs(value):      # as the core reads it, '..' kept
                    value = os.path.abspath(value)
                written = self._set_texts.get(f"{group}.{key}")
                if replace and (group, key) in replace:
                    text = replace[(group, key)]
                elif f"{group}.{key}" not in self._given:  # its default (a vector key:
                    continue                               # the dimension's)
                elif written is not None and written[1] == value:
                    text = written[0]            # as set (the core reads the same value)
                elif isinstance(value, str):
                    text = _quote(value)
                else:
                    text = _value_text(value, value)
                lines.append(f"    {key} = {text}")
            lines.append("/")
        return "\n".join(lines) + "\n"

    def write(self, path: str | os.PathLike) -> None:
        """Validate (without reading the mesh file: ``validate(mesh=False)``), then write
        the scene as a namelist file (mesh file made absolute)."""
        self.validate(mesh=False)
        with open(os.fspath(path), "w", encoding="utf-8", errors="surrogateescape") as fh:
            fh.write(self.to_text(absolute_mesh=True))
