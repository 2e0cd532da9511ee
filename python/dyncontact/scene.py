"""Scene files (SPEC section 3, docs/scenes.md): edit and write them.

The Fortran core (``fortran/io/scene.f90``) is the only reader: :meth:`Scene.read`,
:meth:`Scene.set` and :meth:`Scene.validate` send the scene through it (``core.scene_dump``,
``core.scene_parse``), so the defaults, the checks and the one-line messages
``PATH: &group key: what is wrong (got 'VALUE')`` are the executable's. A bad scene raises
:class:`dyncontact.BadInputError` (``SceneError`` is the same class).

>>> scn = Scene()
>>> scn.set('scheme.dt', '0.001')
>>> scn.get('scheme.dt')
0.001
"""

from __future__ import annotations

import copy
import numbers
import os
from typing import Any

from . import core
from .core import BadInputError

__all__ = ["Scene", "SceneError"]

#: The exception of a bad scene (the same class as BadInputError).
SceneError = BadInputError


def _quote(s: str) -> str:
    return "'" + s.replace("'", "''") + "'"


def _value_text(value: Any, current: Any) -> str:
    """A Python value (or a command-line string) as namelist text for a key whose current
    value is `current` (its type is the key's type); the core converts and checks it."""
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
    decimal, so np.float32(0.001) is 0.001); anything else as text for the core to refuse."""
    if type(x) in (int, float):
        return repr(x)
    return str(x)


class Scene:
    """A scene: every key with its value (defaults filled in), addressed as
    ``'group.key'`` (``'scheme.dt'``, ``'contact.theta'``, ``'scheme.theta'``...).

    >>> Scene().get('contact.obstacle_normal')
    [0.0, -1.0]
    """

    def __init__(self) -> None:
        #: The scene file read ('' if built in code); used in messages.
        self.path = ""
        self._values: dict[str, dict[str, Any]] = core.scene_parse("", "<scene>")

    @classmethod
    def read(cls, path: str | os.PathLike) -> "Scene":
        """Read and validate a scene file (raises :class:`BadInputError`).

        A relative ``&mesh file`` is resolved against the scene file's folder.
        """
        scn = cls()
        scn.path = os.fspath(path)
        scn._values = core.scene_dump(scn.path)
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
        raise SceneError(f"{self._name()}: &{group} {key}: unknown key (expected one of "
                         f"{', '.join(self._values[group])})")

    def get(self, name: str) -> Any:
        """Value of ``'group.key'`` (a list of 2 floats for vectors, 3 in 3D)."""
        group, key = self._check_name(name)
        return copy.copy(self._values[group][key])

    def set(self, name: str, value: Any) -> None:
        """Set ``'group.key'``; the core converts ``value`` to the key's type.

        ``value`` may be a Python or numpy value or a command-line string: ``'0.001'``,
        ``"'lumped'"`` or ``'lumped'``, ``'0.0,-1.0'``. A single number for a vector sets
        component 1 and zeroes component 2. Ranges are checked by :meth:`validate`.

        Setting ``'mesh.dim'`` gives the vector keys still at the old dimension's defaults
        those of the new one (3 components in 3D).
        """
        group, key = self._check_name(name)
        text = _value_text(value, self._values[group][key])
        omit = set()
        if (group, key) == ("mesh", "dim") and self._values["mesh"]["dim"] in (0, 1, 2, 3):
            old = core.scene_parse(f"&mesh dim = {self._values['mesh']['dim']} /", "<defaults>")
            omit = {(g, k) for g, keys in old.items() for k, v in keys.items()
                    if isinstance(v, list) and self._values[g][k] == v}
        self._values = core.scene_parse(self.to_text({(group, key): text}, omit=omit),
                                        self._name())

    def __getitem__(self, name: str) -> Any:
        return self.get(name)

    def __setitem__(self, name: str, value: Any) -> None:
        self.set(name, value)

    def copy(self) -> "Scene":
        """An independent copy."""
        other = Scene.__new__(Scene)
        other.path = self.path
        other._values = copy.deepcopy(self._values)
        return other

    def to_dict(self) -> dict[str, dict[str, Any]]:
        """``{group: {key: value}}`` for every key, as the Fortran scene JSON."""
        return copy.deepcopy(self._values)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Scene) and self._values == other._values

    def __repr__(self) -> str:
        return f"Scene(path={self.path!r})"

    def validate(self) -> None:
        """Check ranges and consistency in the core (raises :class:`BadInputError`).

        Normalizes ``contact.obstacle_normal``. A relative mesh file counts from the
        current folder here (``read`` has resolved it against the scene file's folder).
        """
        self._values = core.scene_parse(self.to_text(), self._name(), full=True)

    # -- writing
    def to_text(self, replace: dict[tuple[str, str], str] | None = None,
                absolute_mesh: bool = False, omit: set[tuple[str, str]] | None = None) -> str:
        """The scene as namelist text, one key a line (`replace`: value texts to use
        instead of the stored values; `absolute_mesh`: write the mesh file absolute;
        `omit`: keys left out, so that they take their defaults)."""
        lines = ["! dyncontact scene (written by dyncontact.Scene)"]
        for group, keys in self._values.items():
            lines.append(f"&{group}")
            for key, value in keys.items():
                if omit and (group, key) in omit:
                    continue
                if absolute_mesh and (group, key) == ("mesh", "file") and value \
                        and not os.path.isabs(value):      # as the core reads it, '..' kept
                    value = os.path.abspath(value)
                if replace and (group, key) in replace:
                    text = replace[(group, key)]
                elif isinstance(value, str):
                    text = _quote(value)
                else:
                    text = _value_text(value, value)
                lines.append(f"    {key} = {text}")
            lines.append("/")
        return "\n".join(lines) + "\n"

    def write(self, path: str | os.PathLike) -> None:
        """Validate, then write the scene as a namelist file (mesh file made absolute)."""
        self.validate()
        with open(os.fspath(path), "w", encoding="utf-8", errors="surrogateescape") as fh:
            fh.write(self.to_text(absolute_mesh=True))
