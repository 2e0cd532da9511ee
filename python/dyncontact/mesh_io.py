"""Meshes in Python: mesh files read by the core (through gmsh's API, the same reader
as the executable) and the built-in bar as :class:`MeshData`, and any ``.geo`` meshed
and written through the gmsh API (``python -m dyncontact mesh``).

The core reads every .msh gmsh reads (versions 2.2 and 4.x, ASCII or binary) and
``.geo`` files, meshed in-process with the parameters h, length, width
(``fortran/io/gmsh_shim.c``, ``fortran/io/gmsh_mesh.f90``). Conventions (0-based
indices here):

- nodes are numbered in increasing order of their gmsh tags (a .geo: the nodes of
  the kept cells);
- groups are the named physical groups by (dimension, tag) -- the order of
  ``$PhysicalNames`` in every file gmsh writes -- then the unnamed ones (named by
  their tag) in order of first use by an entity;
- the mesh dimension is the highest element dimension present (1: segments,
  2: triangles, 3: tetrahedra); cells are the elements of that dimension, entity
  by entity (increasing tag), with the first physical group of their entity (-1 if
  none); from a .geo with physical groups, only the cells of entities with a
  group, as gmsh would save them;
- facets are the elements of dimension ``dim - 1`` (points in 1D, segments in
  2D, triangles in 3D) of entities with physical groups, stored once per group;
  others are dropped;
- the groups of a lower dimension (Physical Points; Physical Curves of a 3D mesh)
  keep their nodes (``lower_nodes``, ``lower_group``), which ``&boundary clamped`` and
  ``slip_*`` hold;
- ``x`` holds the first ``dim`` coordinates (the others must be constant).

>>> from dyncontact import mesh_io              # from the repository's root folder
>>> m = mesh_io.read_msh_fortran("meshes/bar2d_getfem_h0.02.msh")
>>> m.dim, m.x.shape, m.group_names
(2, (306, 2), ['bottom', 'top', 'left', 'right', 'body'])
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import errno
import os
import sys
from pathlib import Path
from typing import Callable, Iterator, Sequence

import numpy as np

from .core import (BadInputError, DyncontactError, geo_check, geo_refusal, gmsh_guard,
                   gmsh_guard_after_init, removed_if_stopped, unmeshed_text)
from .scene import packaged_file

__all__ = ["MeshData", "read_mesh", "read_msh_fortran", "builtin_bar", "generate_bar",
           "generate", "find_geo", "main"]

#: ``python -m dyncontact mesh --max-elements`` by default: the default of ``&mesh max_elements``.
DEFAULT_MAX_ELEMENTS = 2000000

#: Parameters of a .geo set by :func:`generate` and by the core (like gmsh -setnumber).
GEO_PARAMETERS = ("h", "length", "width")

#: Their values where a .geo uses them without defining them and they are not given
#: (the defaults of ``&mesh h``, ``length`` and ``width``).
GEO_DEFAULTS = {"h": 0.05, "length": 1.0, "width": 0.1}


@dataclasses.dataclass
class MeshData:
    """A simplicial mesh with named physical groups (0-based indices).

    Attributes
    ----------
    dim : int
        1 (segments), 2 (triangles) or 3 (tetrahedra).
    x : ndarray, shape (n_nodes, dim), float64
        Node coordinates.
    cells : ndarray, shape (n_cells, dim + 1), int
        Node indices of each cell.
    cell_group : ndarray, shape (n_cells,), int
        Group index of each cell, -1 if none.
    facets : ndarray, shape (n_facets, dim), int
        Node indices of each tagged boundary facet (a point in 1D, a segment in 2D,
        a triangle in 3D).
    facet_group : ndarray, shape (n_facets,), int
        Group index of each facet.
    group_names : list of str
        Name of each group.
    group_dim : ndarray, shape (n_groups,), int
        Dimension of each group's entities.
    lower_nodes : ndarray, shape (n_lower,), int
        Nodes of the groups of dimension below ``dim - 1`` (Physical Points; Curves of
        a 3D mesh), once per group, sorted by group then node.
    lower_group : ndarray, shape (n_lower,), int
        Group index of each of them.
    """

    dim: int
    x: np.ndarray
    cells: np.ndarray
    cell_group: np.ndarray
    facets: np.ndarray
    facet_group: np.ndarray
    group_names: list
    group_dim: np.ndarray
    lower_nodes: np.ndarray = dataclasses.field(
        default_factory=lambda: np.zeros(0, dtype=np.int64))
    lower_group: np.ndarray = dataclasses.field(
        default_factory=lambda: np.zeros(0, dtype=np.int64))

    def group(self, name: str) -> int:
        """Index of the group called `name`; KeyError if absent."""
        try:
            return self.group_names.index(name)
        except ValueError:
            raise KeyError(f"group {name!r} not in mesh") from None


# --------------------------------------------------------------------------- gmsh session

@contextlib.contextmanager
def _gmsh_session(path: str | os.PathLike, model: str = "dyncontact") -> Iterator:
    """gmsh with a fresh, empty current model, for the file `path`; everything is undone
    on exit.

    If gmsh is not initialized, it is initialized (no config files, no terminal
    output) and finalized afterwards. If the caller already runs gmsh, a new model
    is added and removed afterwards, and the caller's current model, options
    and parser variables set here are restored; its ONELAB database is set aside
    (emptied, :func:`_onelab_empty`) and put back as it was.

    Its calls into gmsh are inside :func:`dyncontact.core.gmsh_guard` (unless the
    caller's block is already): the signal dispositions that loading gmsh and its
    initialization change (SIGTERM's reset to its default) are put back, and in a program
    that asked for it (``python -m dyncontact mesh``) SIGINT or SIGTERM ends the process
    at once, exit status 130, with a line naming `path`.
    """
    with gmsh_guard(path):
        with _gmsh_model(model) as gmsh:
            yield gmsh


@contextlib.contextmanager
def _gmsh_model(model: str) -> Iterator:
    """The gmsh session of :func:`_gmsh_session`, inside its guard."""
    import gmsh

    own = not gmsh.isInitialized()
    if own:
        gmsh.initialize(readConfigFiles=False, interruptible=False)
        gmsh_guard_after_init()
        saved = {}
        previous_model = None
        names_before: set = set()
        onelab_before = None
    else:
        saved = {k: gmsh.option.getNumber(k)
                 for k in ("General.Terminal", "Mesh.MshFileVersion", "Mesh.Binary",
                           "Mesh.MeshSizeMax")}
        previous_model = gmsh.model.getCurrent()
        names_before = set(gmsh.parser.getNames())
        onelab_before = gmsh.onelab.get()
    _onelab_empty(gmsh)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add(model)
        _parse_bbox_reset(gmsh, model)
        yield gmsh
    finally:
        if own:
            gmsh.finalize()
        else:
            with contextlib.suppress(Exception):
                gmsh.model.setCurrent(model)
                gmsh.model.remove()
            with contextlib.suppress(Exception):
                for name in set(gmsh.parser.getNames()) - names_before:
                    gmsh.parser.clear(name)
            with contextlib.suppress(Exception):
                _onelab_empty(gmsh)
                gmsh.onelab.set(onelab_before)
            for key, value in saved.items():
                gmsh.option.setNumber(key, value)
            if previous_model is not None and previous_model in gmsh.model.list():
                gmsh.model.setCurrent(previous_model)


def _parse_bbox_reset(gmsh, model: str) -> None:
    """Make gmsh's parser forget the points of earlier parses, so that a .geo meshes to the
    same bits whatever the process parsed before, as in a fresh process (as the core's
    reader does, fortran/io/gmsh_shim.c, parse_bbox_reset).

    While it parses, gmsh takes its characteristic length (the scale of the tolerances of
    some of its geometric operations) from the bounding box of every point parsed since
    its last ``gmsh.open``: a state that neither ``gmsh.finalize``/``initialize``, a new
    model nor ``gmsh.clear`` resets (gmsh 4.15: meshes/disk.geo meshed after the same
    file 1000 times larger had 177 of its 246 coordinates off in their last digits).
    ``gmsh.open`` of an empty file resets it and parses nothing, but also clears the
    parser's variables: the caller's numbers and strings are set again after it (its
    macros and ``SetFactory`` choice are not). The open empties the current model, `model`, and takes its name: it is added again."""
    saved = {}
    for name in gmsh.parser.getNames():
        with contextlib.suppress(Exception):
            strings = gmsh.parser.getString(name)
            if strings:
                saved[name] = ("s", strings)
                continue
        with contextlib.suppress(Exception):
            saved[name] = ("n", gmsh.parser.getNumber(name))
    gmsh.open(os.devnull)
    gmsh.model.remove()
    gmsh.model.add(model)
    for name, (kind, value) in saved.items():
        if kind == "s":
            gmsh.parser.setString(name, list(value))
        else:
            gmsh.parser.setNumber(name, list(value))


# --------------------------------------------------------------------------- reading

def _from_core(d: dict) -> MeshData:
    """MeshData from the dict of :func:`dyncontact.core.load_mesh`."""
    return MeshData(
        dim=int(d["dim"]),
        x=np.asarray(d["x"], dtype=np.float64),
        cells=np.asarray(d["cells"], dtype=np.int64),
        cell_group=np.asarray(d["cell_group"], dtype=np.int64),
        facets=np.asarray(d["facets"], dtype=np.int64).reshape(-1, int(d["dim"])),
        facet_group=np.asarray(d["facet_group"], dtype=np.int64),
        group_names=list(d["group_names"]),
        group_dim=np.asarray(d["group_dim"], dtype=np.int64),
        lower_nodes=np.asarray(d["lower_nodes"], dtype=np.int64),
        lower_group=np.asarray(d["lower_group"], dtype=np.int64),
    )


def read_mesh(path: str | os.PathLike, *, h: float | None = None,
              length: float | None = None, width: float | None = None,
              check: bool = True) -> MeshData:
    """Read a mesh file as the core does: .msh (2.2, 4.x, ASCII or binary) or .geo
    (meshed in-process; h, length, width are its parameters of those names, and h the
    largest mesh size where the file uses no h). None (the default) meshes a .geo as a
    run of a scene without that key does: a file that defines the parameter
    (``DefineConstant``) keeps its own value, one that uses it without defining it gets
    the key's default (:data:`GEO_DEFAULTS`: 0.05, 1.0, 0.1); ``h=None`` leaves a file
    that uses no h its own mesh sizes.

    ``check=False`` skips the core's mesh checks (for meshes the model does not take).

    Raises
    ------
    BadInputError
        With the core's message, which starts with the path.
    """
    from .core import load_mesh

    path = os.fspath(path)
    if not path.strip():
        raise BadInputError("read_mesh: empty file name")
    values = {"h": h, "length": length, "width": width}
    return _from_core(load_mesh(
        path, check=check, given=[k for k, v in values.items() if v is not None],
        **{k: GEO_DEFAULTS[k] if v is None else v for k, v in values.items()}))


def read_msh_fortran(path: str | os.PathLike) -> MeshData:
    """:func:`read_mesh` with its defaults (the name the package used first)."""
    return read_mesh(path)


def builtin_bar(dim: int = 2, length: float = 1.0, width: float = 0.1,
                h: float = 0.05) -> MeshData:
    """The Fortran built-in bar (``bar_mesh_build``): GetFEM's structured triangles in
    2D, segments in 1D.

    >>> builtin_bar(2, 1.0, 0.1, 0.05).cells.shape
    (80, 3)
    """
    from .core import load_mesh

    return _from_core(load_mesh("", dim=dim, length=length, width=width, h=h))


# --------------------------------------------------------------------------- generation

def find_geo(name: str = "bar2d.geo") -> Path:
    """The .geo file `name`: next to this module, or in the source tree's meshes/."""
    return packaged_file(name, "meshes")


def _check_sizes(who: str, **sizes: float) -> None:
    """BadInputError naming `who` unless every size is finite and > 0."""
    for name, value in sizes.items():
        if not (np.isfinite(value) and value > 0):
            raise BadInputError(f"{who}: {name} = {value} (must be > 0)")


#: gmsh's last error before the parse of _geo_probe: still the last one after it when
#: the parse met no error.
_PROBE_MARK = "dyncontact: parsing the .geo without h"


def _onelab_empty(gmsh) -> None:
    """Empty gmsh's ONELAB database, so that a parse sees no parameter an earlier parse
    created, as the core's reader does (fortran/io/gmsh_shim.c, onelab_empty): a
    DefineConstant with a Name takes the value of an existing ONELAB parameter of that
    Name over its own (``DefineConstant[h = {0.02, Name "Mesh/h"}]`` parsed after a file
    that made "Mesh/h" 0.1 would mesh at 0.1); `gmsh file.geo` starts with none.
    :func:`_gmsh_session` sets a caller's database aside first and puts it back."""
    gmsh.onelab.clear()


def _set_parameters(gmsh, values: dict[str, float], names) -> None:
    """Set the .geo parameters ``names`` to their ``values`` and clear the others."""
    for name in GEO_PARAMETERS:
        if name in names:
            gmsh.parser.setNumber(name, [float(values[name])])
        else:
            gmsh.parser.clear(name)


def _geo_probe(gmsh, geo: Path, values: dict[str, float], names,
               model: str) -> tuple[bool, set[str]]:
    """Parse the .geo once with the parameters ``names`` set to their ``values`` and the
    others cleared (as the core's reader does, fortran/io/gmsh_shim.c, geo_probe):
    whether the parse has an error (the file uses a parameter it does not define, or is
    bad), and the parameters that are parser variables after it (those set and those
    the file defines, DefineConstant). The parse runs to the end of the file whatever
    its errors (General.AbortOnError 0): a parse stopped at its first error leaves the
    rest of the file in gmsh's lexer, which the next parse would read first ("line 0:
    syntax error"); after a variable used undefined it goes on, so the file's later
    definitions are seen. An error is seen as gmsh's last error replacing _PROBE_MARK.
    The parse's model, variables and ONELAB parameters are removed after it (a fresh
    ``model`` added)."""
    before = set(gmsh.parser.getNames())
    _set_parameters(gmsh, values, names)
    abort = gmsh.option.getNumber("General.AbortOnError")
    gmsh.option.setNumber("General.AbortOnError", 0)
    try:
        gmsh.logger.write(_PROBE_MARK, "error")
        try:
            gmsh.merge(str(geo))
            error = gmsh.logger.getLastError() != _PROBE_MARK
        except Exception:   # noqa: BLE001 - any failure: a parameter needed (or bad)
            error = True
        after = set(gmsh.parser.getNames())
    finally:
        gmsh.option.setNumber("General.AbortOnError", abort)
    gmsh.model.remove()
    gmsh.model.add(model)
    for name in after - before:     # the variables of that parse
        gmsh.parser.clear(name)
    _onelab_empty(gmsh)             # and its ONELAB parameters
    return error, after & set(GEO_PARAMETERS)


def _geo_settings(gmsh, geo: Path, values: dict[str, float],
                  given: set[str], model: str) -> tuple[set[str], bool]:
    """Which parameters to set for meshing the .geo, and whether it uses h (the core's
    geo_parse): those ``given``, and those not given that the file uses without defining
    (a file that defines one keeps its own value). length and width not given are set
    unless the file defines them (a first parse without them and without h); h is set
    where given, or where a parse with length and width so set and without h fails."""
    lw = {"length", "width"}
    error, defined = _geo_probe(gmsh, geo, values, given & lw, model)
    names = (given | (lw - defined)) & lw
    if error and names != given & lw:
        error, defined = _geo_probe(gmsh, geo, values, names, model)
    if "h" in given or error:
        names.add("h")
    return names, error or "h" in defined


def generate(geo_path: str | os.PathLike, out_path: str | os.PathLike,
             h: float | None = 0.05, length: float | None = 1.0,
             width: float | None = 0.1,
             binary: bool = False, version: float = 4.1, max_elements: int = 0,
             keys: tuple[str, str] = ("max_elements", "h"),
             verify: Callable[[Path], None] | None = None) -> Path:
    """Mesh a .geo with gmsh and write it as .msh (default 4.1 ASCII).

    h, length and width are set as the file's parameters of those names (as
    ``gmsh -setnumber h 0.02`` would); where the file uses no h, h is the largest
    mesh size. None (``python -m dyncontact mesh`` without ``--h``, ``--length`` or ``--width``):
    as a run's .geo for a scene without that key, the parameter is not set: a file
    that defines it (``DefineConstant[h = {...}]``) keeps its own value, one that uses
    it without defining it gets the key's default (:data:`GEO_DEFAULTS`: 0.05, 1.0,
    0.1), and ``h=None`` leaves a file that uses no h its own mesh sizes. The mesh has
    the geometry's dimension.

    The file is written under a temporary name in `out_path`'s folder and renamed to
    `out_path` once whole (`out_path` a symbolic link: in the folder of the file it
    points to, and renamed to that file, so that the mesh goes through the link and the
    link stays): an error, a KeyboardInterrupt or a stop signal
    (:func:`dyncontact.core.exit_on_signal_during_mesh_read`) leaves no part of a mesh
    under that name, and an existing file of that name as it was. ``verify(path)``, when
    given, is called with the temporary file before the rename (``python -m dyncontact mesh`` reads
    it back); an exception it raises discards the file and goes on to the caller.

    ``max_elements > 0``: a .geo whose element count, estimated before meshing
    (:func:`dyncontact.core.estimate_geo`), exceeds the refusal's margin times it is not
    meshed: :class:`BadInputError` naming the file and `keys` (the names of the limit and
    of h; h only when given), as a run refuses it (docs/scenes.md).

    Returns
    -------
    Path
        `out_path`.

    Raises
    ------
    BadInputError
        A size not > 0, no such .geo, a gmsh command that ends, stalls or escapes the
        process (`Exit`, `Sleep`, `SystemCall`) or writes to disk (`Save`, `Print`,
        `CreateDir`, `Printf(...) > "file"`: docs/scenes.md), or gmsh cannot mesh it.
    DyncontactError
        gmsh cannot write `out_path` (nothing is left under that name). A write cut
        short midway gmsh does not report: ``python -m dyncontact mesh`` finds it when it reads
        the file back.
    """
    given = {k for k, v in (("h", h), ("length", length), ("width", width))
             if v is not None}
    values = {k: GEO_DEFAULTS[k] if v is None else v
              for k, v in (("h", h), ("length", length), ("width", width))}
    _check_sizes("generate", **values)
    geo = Path(geo_path)
    if not geo.is_file():
        raise BadInputError(f"{geo}: no such file")
    out = Path(out_path)
    # the mesh is written under a temporary name beside `out` and given its name once
    # whole (and read back by `verify`), so that `out` is never a part of a mesh: not
    # after an error, a KeyboardInterrupt, nor a stop signal that ends the program
    # (python -m dyncontact mesh), which removes the part first (removed_if_stopped);
    # `out` a symbolic link: beside the file it points to, which the rename replaces
    target = _written_file(out)
    part = _part_name(target)
    with removed_if_stopped(part):
        try:
            # one guard for gmsh's parse of the estimate, its meshing, the write and the
            # read back: a stop signal during any of them says the .geo's name
            with gmsh_guard(geo):
                if max_elements > 0:
                    refusal = geo_refusal(geo, int(max_elements), keys[0],
                                          keys[1] if "h" in given else "", given=given,
                                          **values)
                    if refusal:
                        raise BadInputError(refusal)
                else:   # the estimate's scan for gmsh's commands that end, stall or escape
                    geo_check(geo)
                # the folders of the file written: a link's target's, not the link's
                target.parent.mkdir(parents=True, exist_ok=True)
                _mesh_into(geo, part, out, values, given, binary, version)
                if verify is not None:
                    verify(part)
            os.replace(part, target)
        except BaseException:
            _discard(part)
            raise
    return out


def _mesh_into(geo: Path, part: Path, out: Path, values: dict[str, float], given: set[str],
               binary: bool, version: float) -> None:
    """Mesh `geo` as :func:`generate` does and write the mesh to `part` (the errors name
    `out`, the file meant)."""
    with _gmsh_session(geo, "dyncontact-generate") as gmsh:
        names, uses_h = _geo_settings(gmsh, geo, values, given, "dyncontact-generate")
        _set_parameters(gmsh, values, names)
        try:
            gmsh.merge(str(geo))
            if not uses_h and "h" in given:
                gmsh.option.setNumber("Mesh.MeshSizeMax", float(values["h"]))
            gmsh.model.mesh.generate(gmsh.model.getDimension())
        except Exception as exc:
            raise BadInputError(f"{geo}: gmsh cannot mesh it: {exc}") from None
        unmeshed = _unmeshed(gmsh)
        if unmeshed:
            raise BadInputError(f"{geo}: {unmeshed}")
        gmsh.option.setNumber("Mesh.MshFileVersion", float(version))
        gmsh.option.setNumber("Mesh.Binary", int(bool(binary)))
        try:
            gmsh.write(str(part))
        except Exception as exc:   # gmsh raises a bare Exception with its last error
            raise DyncontactError(f"{out}: gmsh cannot write it: {exc}") from None


def _written_file(out: Path) -> Path:
    """The file that writing `out` writes: `out`, or where a symbolic link `out` points to
    (through a chain of links, each relative one from its own folder; the file need not
    exist yet), so that :func:`generate`'s rename writes through the link, as a write
    into `out` would, and leaves the link a link. A loop of links, which no write goes
    through: :class:`DyncontactError` naming `out`."""
    if not out.is_symlink():
        return out
    target = Path(os.path.realpath(out))
    if target.is_symlink():
        raise DyncontactError(f"{out}: cannot write it: {os.strerror(errno.ELOOP)}")
    return target


def _part_name(out: Path) -> Path:
    """The temporary name :func:`generate` writes `out` under: hidden, beside it (a
    rename within the folder), of this process, and ending in .msh, from which gmsh
    takes the format."""
    return out.with_name(f".{out.name}.{os.getpid()}.part.msh")


def _unmeshed(gmsh) -> str | None:
    """Why the model just meshed is not the body its physical groups describe, or None: an
    entity of a physical group, of the cells' dimension or above, that gmsh left without
    elements (a surface whose boundary crosses itself). Written as it is, the file would be
    the rest: the curves of a surface that failed, a 1D bar where a 2D body was meant. The
    words are the core's (:func:`dyncontact.core.unmeshed_text`), which refuses such a
    .geo in a run alike (gmsh_shim.c)."""
    def meshed(d: int, tag: int) -> bool:
        return any(len(t) for t in gmsh.model.mesh.getElements(d, tag)[1])

    dims = [d for d in range(1, 4) for _, tag in gmsh.model.getEntities(d)
            if meshed(d, tag) and gmsh.model.getPhysicalGroupsForEntity(d, tag).size]
    if not dims:
        return None
    for d in range(max(dims), 4):
        for _, tag in gmsh.model.getEntities(d):
            groups = gmsh.model.getPhysicalGroupsForEntity(d, tag)
            if groups.size and not meshed(d, tag):
                name = gmsh.model.getPhysicalName(d, int(groups[0])) or str(int(groups[0]))
                return unmeshed_text(d, tag, name)
    return None


def _discard(out: Path) -> None:
    """Remove a partly written output file, if any."""
    with contextlib.suppress(OSError):
        out.unlink()


def _cut_short(out: Path) -> str | None:
    """Why the write of `out` was cut short, or None if nothing says it was. gmsh does
    not report a write that fails midway (a full disk, a file-size limit such as
    ``ulimit -f``): it leaves a truncated file, which then does not read back. The
    system's answer to one more byte appended to that file gives the reason; a byte
    that is written is removed again (the file is the mesh gmsh wrote, whole)."""
    try:
        size = out.stat().st_size
        with open(out, "ab") as f:
            f.write(b"\n")
            f.flush()
            os.fsync(f.fileno())
    except OSError as exc:
        return exc.strerror or str(exc)
    with contextlib.suppress(OSError):
        os.truncate(out, size)
    return None


def generate_bar(h: float, out_path: str | os.PathLike, length: float = 1.0,
                 width: float = 0.1, geo_path: str | os.PathLike | None = None,
                 binary: bool = False, version: float = 4.1,
                 verify: Callable[[Path], None] | None = None) -> Path:
    """Mesh ``meshes/bar2d.geo`` with gmsh and write it as .msh (default 4.1 ASCII).

    Structured (transfinite) triangles of [0, width] x [0, length] with
    ``round(width/h)`` by ``round(length/h)`` squares and alternating diagonals;
    groups bottom, top, left, right (curves) and body (surface).

    Parameters
    ----------
    h : float
        Mesh size (> 0).
    out_path : str or path-like
        The .msh file to write (folders are created).
    length, width : float
        Bar size (> 0).
    geo_path : str or path-like, optional
        The .geo file (default: :func:`find_geo`).
    binary, version : bool, float
        Format of the file (see :func:`generate`).
    verify : callable, optional
        Called with the file written before it takes its name (see :func:`generate`).

    Returns
    -------
    Path
        `out_path`.
    """
    _check_sizes("generate_bar", h=h, length=length, width=width)
    if round(length / h) * round(width / h) > 5e7:
        raise BadInputError(f"generate_bar: h = {h} gives too many elements")
    geo = Path(geo_path) if geo_path is not None else find_geo()
    return generate(geo, out_path, h=h, length=length, width=width, binary=binary,
                    version=version, verify=verify)


# --------------------------------------------------------------------------- command line

def _summary(m: MeshData) -> str:
    """One line describing a mesh."""
    kind = {1: "segments", 2: "triangles", 3: "tetrahedra"}[m.dim]
    # each group's elements: facets and cells, or a point or curve group's nodes
    sizes = [int((m.facet_group == i).sum() + (m.cell_group == i).sum()
                 + (m.lower_group == i).sum()) for i in range(len(m.group_names))]
    groups = ", ".join(f"{n} ({k})" for n, k in zip(m.group_names, sizes))
    return f"{len(m.x)} nodes, {len(m.cells)} {kind}; groups {groups}"


def _check_out(out: str) -> None:
    """BadInputError naming ``--out`` unless it is a .msh file in an existing folder (a
    symbolic link: and the file it points to is in one)."""
    if not out.lower().endswith(".msh") or out.endswith(("/", os.sep)):
        raise BadInputError(f"--out {out}: the mesh file's name must end in .msh")
    folder = os.path.dirname(out) or "."
    if not os.path.isdir(folder):
        raise BadInputError(f"--out {out}: no folder {folder} (create it first)")
    if os.path.islink(out):
        # the mesh is written where the link points (generate): that file's folder must
        # be there too (a loop of links is generate's to refuse)
        target = os.path.realpath(out)
        target_folder = os.path.dirname(target)
        if not os.path.islink(target) and not os.path.isdir(target_folder):
            raise BadInputError(f"--out {out}: a link to {target}: no folder "
                                f"{target_folder} (create it first)")
    if os.path.isdir(out):
        raise BadInputError(f"--out {out}: is a folder")


class _Parser(argparse.ArgumentParser):
    """argparse whose errors are one line, as the other commands' (``dyncontact mesh:
    MESSAGE (see `python -m dyncontact mesh --help`)``, exit 2), not the usage and the message."""

    def error(self, message):  # noqa: D102 - argparse API
        raise BadInputError(f"{message} (see `{self.prog} --help`)")


def build_parser() -> argparse.ArgumentParser:
    """Parser of ``python -m dyncontact mesh``."""
    p = _Parser(
        prog="python -m dyncontact mesh",
        description="Mesh a .geo with gmsh (default: the bar of meshes/bar2d.geo, "
                    "structured triangles) and write it as .msh 4.1 ASCII. h, length and "
                    "width are set as the file's parameters of those names; where the file "
                    "uses no h, h is the largest mesh size.")
    p.add_argument("--h", type=float, default=None,
                   help="mesh size: the parameter h (default: the .geo's own, its "
                        "DefineConstant; 0.05 for a .geo that uses h without defining it), "
                        "or the largest mesh size of a .geo that uses no h (default: the "
                        "file's own sizes)")
    p.add_argument("--out", required=True, metavar="FILE.msh",
                   help="mesh file to write (.msh, in an existing folder)")
    p.add_argument("--length", type=float, default=None,
                   help="parameter length (the bar's length, y; default: a .geo's own, "
                        "its DefineConstant; 1 for the bar and a .geo that uses length "
                        "without defining it)")
    p.add_argument("--width", type=float, default=None,
                   help="parameter width (the bar's width, x; default: a .geo's own, its "
                        "DefineConstant; 0.1 for the bar and a .geo that uses width "
                        "without defining it)")
    p.add_argument("--geo", metavar="FILE.geo", help="geometry (default meshes/bar2d.geo)")
    p.add_argument("--binary", action="store_true", help="write binary .msh")
    p.add_argument("--msh-version", type=float, default=4.1, choices=(2.2, 4.1),
                   help="msh format version (default 4.1)")
    p.add_argument("--max-elements", type=int, default=DEFAULT_MAX_ELEMENTS, metavar="N",
                   help="a .geo estimated before meshing at more than 2 x N elements is not "
                        f"meshed (default {DEFAULT_MAX_ELEMENTS}, as &mesh max_elements; "
                        "0: no limit)")
    p.add_argument("--quiet", "-q", action="store_true", help="print nothing")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m dyncontact mesh --h 0.02 --out meshes/bar2d_h0.02.msh``.

    Returns the exit status: 0, 2 on bad input, or 4 when the mesh file cannot be
    written (as a run's output: docs/scenes.md, *Exit codes*); one line on stderr naming
    the file. ``--out`` must end in ``.msh`` and its folder must exist: a command that
    writes one file does not create folders a typo named (the API's :func:`generate`
    does create them).
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] == "mesh":
        argv = argv[1:]
    try:
        args = build_parser().parse_args(argv)
        _check_out(args.out)
        read, refused = [], []

        def read_back(part: Path) -> None:
            # the mesh as written, before it takes its name: gmsh does not report a write
            # cut short midway, which then does not read back, and is discarded; a file
            # written whole that the reader refuses (quadrangles) takes its name, as gmsh
            # wrote it, and the command fails as bad input (the messages name --out)
            try:
                read.append(read_mesh(part, check=False))
            except BadInputError as exc:
                reason = _cut_short(part)
                if reason is None:
                    refused.append(BadInputError(str(exc).replace(str(part),
                                                                  str(Path(args.out)))))
                    return
                raise DyncontactError(f"{Path(args.out)}: gmsh could not write it whole: "
                                      f"{reason}") from None

        fmt = dict(binary=args.binary, version=args.msh_version, verify=read_back)
        if args.geo is None:
            h = 0.05 if args.h is None else args.h
            out = generate_bar(h, args.out, **fmt,
                               length=1.0 if args.length is None else args.length,
                               width=0.1 if args.width is None else args.width)
        else:
            out = generate(args.geo, args.out, h=args.h, length=args.length,
                           width=args.width, max_elements=args.max_elements,
                           keys=("--max-elements", "--h"), **fmt)
        if refused:
            raise refused[0]
        mesh = read[0]
    except (BadInputError, OSError) as exc:
        print(f"dyncontact mesh: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    except DyncontactError as exc:      # the mesh file could not be written
        print(f"dyncontact mesh: {' '.join(str(exc).split())}", file=sys.stderr)
        return 4
    if not args.quiet:
        print(f"dyncontact mesh: wrote {out}: {_summary(mesh)}")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
