"""Overlay run traces in the seed's four panels: u_n, v_n, p_n (with the total contact
force f_n on a second scale, when the traces have it) and the energy.

matplotlib is imported on first use and only through its object-oriented API
(``Figure`` + the Agg canvas): no pyplot, no global backend switch, nothing shown.

>>> from dyncontact.plotting import plot_traces
>>> fig = plot_traces(["out/bar2d_hht"], "out/bar2d_hht/trace.png")   # doctest: +SKIP
"""

from __future__ import annotations

import math
import os
from typing import Any, Iterable, Sequence

import numpy as np

__all__ = ["plot_traces", "run_label", "scene_title", "plot_field_snapshots", "read_pvd",
           "run_colours"]

# (column, y label) of the first three panels; the fourth is the energy. The p_n label
# is the formula of the runs' contact method (_P_N_LABELS, _method_label).
_PANELS = (
    ("u_n", r"$u_n$ at the probe"),
    ("v_n", r"$\dot u_n$ at the probe"),
    ("p_n", r"$p_n = [P_1(u) + \gamma_N g]_-$"),
)

#: p_n at the probe by contact method (docs/scenes.md, &contact method and "trace.csv").
_P_N_LABELS = {
    "nitsche": r"$p_n = [P_1(u) + \gamma_N g]_-$",
    "penalty": r"$p_n = -\varepsilon_N\,[u_n - g]_+$",
    "alm integral": r"$p_n = \lambda$ (ALM, integral)",
    "alm nodal": r"$p_n = \lambda_i\,/\,|\Gamma_i|$ (ALM, nodal)",
}
#: f_n, the second scale of the p_n panel (dashed), by contact method: Nitsche's and
#: penalty's integral of the pressure, the ALM's multipliers' resultant (the f_n column
#: of trace.csv in docs/scenes.md, "Outputs").
_F_N_LABELS = {
    "nitsche": r"$f_n = \int_{\Gamma_C} [P_1(u) + \gamma_N g]_-\,ds$ (dashed)",
    "penalty": r"$f_n = -\int_{\Gamma_C} \varepsilon_N\,[u_n - g]_+\,ds$ (dashed)",
    "alm integral": r"$f_n = \int_{\Gamma_C} \lambda\,ds$ (dashed)",
    "alm nodal": r"$f_n = \sum_i \lambda_i$ (dashed)",
}

_SCHEME_PARAMS = {
    "hht": ("alpha",),
    "hht_seed": ("alpha",),
    "pc_hht": ("alpha",),
    "pc_hht_seed": ("alpha",),
    "newmark": ("beta", "gamma"),
    "pc": ("beta", "gamma"),
    "theta": ("theta",),
    "galpha": ("rho_inf",),
}
_SYMBOL = {"alpha": "α", "beta": "β", "gamma": "γ", "theta": "θ", "rho_inf": "ρ∞"}

#: plot_traces' figure (inches) with a legend of up to _LEGEND_ROWS_IN_PLACE rows (two
#: runs a row), which takes its room from the panels; each row beyond makes the figure
#: taller by _LEGEND_ROW_IN, so that the panels keep their height however many runs are
#: drawn (with a fixed height the legend would push the panels' bottom above their top
#: from 74 runs on, which matplotlib refuses to draw).
_FIG_W_IN, _FIG_H_IN = 11.0, 7.5
_LEGEND_ROWS_IN_PLACE = 6
_LEGEND_ROW_IN = 0.024 * _FIG_H_IN
#: the panels' bottom margin (x-axis labels) under the legend, and the top margin without
#: and with a title, in inches
_BOTTOM_IN = 0.085 * _FIG_H_IN
_TOP_IN, _TOP_TITLE_IN = 0.03 * _FIG_H_IN, 0.06 * _FIG_H_IN


def _num(v: Any) -> str:
    """A parameter value, short: 0.0025, -0.1, 0.25, 1e-05."""
    try:
        x = float(v)
    except (TypeError, ValueError):
        return str(v)
    return f"{x:.6g}"


def _get(d: Any, *keys, default=None):
    for k in keys:
        if not isinstance(d, dict) or k not in d:
            return default
        d = d[k]
    return d


def run_label(summary: dict, fallback: str = "") -> str:
    """'hht α=-0.1, Δt=0.0025, h=0.05' from a summary.json (fallback if it says nothing):
    the scheme and its parameters, Δt, the mesh (its file's name, or h and '1D' / '3D'
    for the built-in bar out of the plane), a mass other than the consistent one, and a
    contact method other than Nitsche's."""
    scene = summary.get("scene") if isinstance(summary.get("scene"), dict) else {}
    scheme = _get(scene, "scheme", default={}) or {}
    name = scheme.get("name") or (summary.get("scheme") if isinstance(summary.get("scheme"),
                                                                     str) else None)
    if not name:
        return fallback
    parts = []
    params = [f"{_SYMBOL[p]}={_num(scheme[p])}" for p in _SCHEME_PARAMS.get(name, ())
              if p in scheme]
    if "dt" in scheme:
        params.append(f"Δt={_num(scheme['dt'])}")
    mesh = _get(scene, "mesh", default={}) or {}
    if mesh.get("file"):
        params.append(os.path.basename(str(mesh["file"])))
    elif "h" in mesh:
        params.append(f"h={_num(mesh['h'])}")
        if mesh.get("dim") in (1, 3):
            params.append(f"{mesh['dim']}D")
    if scheme.get("mass") in ("lumped", "redistributed"):
        params.append(scheme["mass"])
    contact = _get(scene, "contact", default={}) or {}
    if contact.get("method") == "penalty":
        params.append("penalty")
    elif contact.get("method") == "alm":
        params.append(f"ALM {contact.get('multiplier', '')}".strip())
    parts.append(name + (" " + ", ".join(params) if params else ""))
    return parts[0]


def _common(summaries: Sequence[dict], group: str, key: str) -> Any:
    """The value of scene key group.key when every run has the same one (vectors as
    tuples), else None."""
    values = []
    for s in summaries:
        v = _get(s, "scene", group, key)
        values.append(tuple(v) if isinstance(v, list) else v)
    if not values or values[0] is None or any(v != values[0] for v in values[1:]):
        return None
    return values[0]


def _vector(v: Any) -> str:
    return "(" + ", ".join(_num(x) for x in v) + ")" if isinstance(v, tuple) else _num(v)


def scene_title(summaries: Sequence[dict], width: int = 100) -> str:
    """A title saying what scene the runs (their summary.json) are of, from the scene
    keys they share (the legend tells the runs apart by the others): the body (the mesh
    file's name, or the built-in bar's dimension and size) and h, the material (E, ν,
    ρ, gravity when not 0), the initial state, the contact method (Nitsche, the default,
    when the scenes do not say; θ and γ0 for Nitsche, γ0 for penalty), and the scheme
    and Δt when every run has the same; on lines of at most ``width`` characters, broken
    between these groups. '' when the summaries hold no scene (runs written before
    summary.json had one).

    >>> scene_title([{"scene": {"mesh": {"file": "", "dim": 1, "length": 1.0, "h": 0.01},
    ...                          "material": {"young": 1.0},
    ...                          "contact": {"method": "penalty", "gamma0": 10.0}}}])
    '1D bar, length 1, h = 0.01; E = 1; penalty, γ0 = 10'
    """
    summaries = [s for s in summaries if isinstance(s.get("scene"), dict)]
    if not summaries:
        return ""
    groups = []
    body = []
    file = _common(summaries, "mesh", "file")
    dim = _common(summaries, "mesh", "dim")
    length = _common(summaries, "mesh", "length")
    bar_width = _common(summaries, "mesh", "width")
    if file:
        body.append(os.path.basename(str(file)))
    elif file == "" and dim in (1, 2, 3):
        if dim == 1:
            body.append("1D bar" + (f", length {_num(length)}" if length is not None else ""))
        elif length is not None and bar_width is not None:
            size = " × ".join([_num(bar_width)] * (dim - 1) + [_num(length)])
            body.append(f"{dim}D bar {size}")
        else:
            body.append(f"{dim}D bar")
    h = _common(summaries, "mesh", "h")
    if h is not None and not str(file or "").lower().endswith(".msh"):
        body.append(f"h = {_num(h)}")
    groups.append(", ".join(body))
    material = [f"{sym} = {_num(v)}" for sym, key in (("E", "young"), ("ν", "poisson"),
                                                        ("ρ", "density"))
                if (v := _common(summaries, "material", key)) is not None]
    gravity = _common(summaries, "material", "gravity")
    if isinstance(gravity, tuple) and any(float(g) != 0 for g in gravity):
        material.append(f"gravity {_vector(gravity)}")
    groups.append(", ".join(material))
    kind = _common(summaries, "initial", "kind")
    if kind == "compressed_bar":
        amplitude = _common(summaries, "initial", "amplitude")
        groups.append("compressed bar" + (f" (lift {_num(amplitude)})"
                                          if amplitude is not None else ""))
    elif kind == "velocity":
        velocity = _common(summaries, "initial", "velocity")
        groups.append("initial velocity" + (f" {_vector(velocity)}"
                                            if velocity is not None else ""))
    elif kind:
        groups.append(f"initial state: {kind}")
    methods = {_contact_method(s) for s in summaries}
    if len(methods) == 1:
        method = next(iter(methods))
        gamma0 = _common(summaries, "contact", "gamma0")
        name = {"nitsche": "Nitsche", "penalty": "penalty"}.get(method, method.replace(
            "alm", "ALM"))
        if method == "nitsche":
            theta = _common(summaries, "contact", "theta")
            if theta is not None:
                name += f" θ = {_num(theta)}"
        if method in ("nitsche", "penalty") and gamma0 is not None:
            name += f", γ0 = {_num(gamma0)}"
        groups.append(name)
    scheme = _common(summaries, "scheme", "name")
    dt = _common(summaries, "scheme", "dt")
    groups.append(", ".join(([scheme] if scheme else [])
                            + ([f"Δt = {_num(dt)}"] if dt is not None else [])))
    lines = [""]
    for g in (g for g in groups if g):
        if lines[-1] and len(lines[-1]) + 2 + len(g) > width:
            lines[-1] += ";"
            lines.append(g)
        else:
            lines[-1] += ("; " if lines[-1] else "") + g
    return "\n".join(lines)


#: What a run's energies and f_n are, by its model's dimension (docs/scenes.md, trace.csv).
_PER_DIM = {1: "1D per unit cross-section", 2: "2D per unit thickness", 3: "3D whole body"}

#: At most this many scene keys tell runs of one label apart ("[contact.gamma0=20]").
APART_KEYS = 3


def _scene_items(summary: dict) -> dict[str, Any]:
    """The scene of a summary.json as {'group.key': value} (vectors as tuples); the
    output keys, which do not change what was run, left out."""
    scene = summary.get("scene") if isinstance(summary.get("scene"), dict) else {}
    return {f"{g}.{k}": tuple(v) if isinstance(v, list) else v
            for g, keys in scene.items() if isinstance(keys, dict) and g != "output"
            for k, v in keys.items()}


def _short_folder(name: str) -> str:
    """A folder's name for a legend: a hash (a sweep cache's run folder, 64 hex digits)
    cut to its first 12 digits, as git shortens commits."""
    if len(name) > 16 and all(ch in "0123456789abcdef" for ch in name):
        return name[:12]
    return name


def _told_apart(names: list[str], summaries: list[dict], folders: list[str]) -> list[str]:
    """Labels of runs that read alike (:func:`run_label` does not list every key) made
    different: each run of a group of equal labels gets the scene keys whose values
    differ within the group ('[contact.gamma0=20]', at most APART_KEYS of them), or its
    folder's name where the scenes do not differ or differ in more keys than that."""
    out = list(names)
    for name in set(names):
        group = [i for i, n in enumerate(names) if n == name]
        if len(group) < 2:
            continue
        items = [_scene_items(summaries[i]) for i in group]
        keys = sorted({k for it in items for k in it})
        differ = [k for k in keys if len({repr(it.get(k)) for it in items}) > 1]
        for i, it in zip(group, items):
            if 0 < len(differ) <= APART_KEYS:
                what = ", ".join(f"{k}={_apart_value(it.get(k))}" for k in differ)
            else:
                what = _short_folder(folders[i])
            out[i] = f"{name} [{what}]"
    return out


def _apart_value(v: Any) -> str:
    """A scene value in a legend: numbers as :func:`_num`, vectors comma-separated, a
    key the scene does not have as '-'."""
    if v is None:
        return "-"
    if isinstance(v, tuple):
        return ",".join(_apart_value(x) for x in v)
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        return _num(v)
    return str(v)


def _contact_method(summary: dict) -> str:
    """'nitsche', 'penalty', 'alm integral' or 'alm nodal' from a summary.json (Nitsche
    when it does not say: the default method)."""
    contact = _get(summary, "scene", "contact", default={}) or {}
    method = str(contact.get("method") or "nitsche")
    if method == "alm":
        method = f"alm {contact.get('multiplier') or 'integral'}"
    return method


def _method_label(summaries: Sequence[dict], labels: dict[str, str], plain: str) -> str:
    """A label that depends on the contact method (``labels``: _P_N_LABELS for the p_n
    panel, _F_N_LABELS for f_n's scale): the formula of the runs' method, or ``plain``
    when the runs use several methods (or one this module does not know)."""
    methods = {_contact_method(s) for s in summaries}
    if len(methods) == 1 and next(iter(methods)) in labels:
        return labels[next(iter(methods))]
    return plain


def _load(item) -> tuple[dict[str, np.ndarray], dict, str]:
    """(trace, summary, default label) of a run folder or a RunResult."""
    from .core import read_summary, read_trace

    if hasattr(item, "trace") and hasattr(item, "summary"):
        name = os.path.basename(os.path.normpath(str(getattr(item, "out_dir", "") or "")))
        return item.trace, dict(item.summary or {}), name or "run"
    from .core import BadInputError, run_file

    d = os.fspath(item)
    trace_path = run_file(d, "trace.csv", "")
    if os.path.getsize(trace_path) == 0:
        raise BadInputError(f"{trace_path}: empty file (not a trace of a run)")
    trace = read_trace(d)
    if "t" not in trace:   # another CSV: nothing of it would be drawn
        raise BadInputError(f"{trace_path}: no column 't' (not a trace of a run: "
                            f"its columns are {', '.join(trace)})")
    return trace, read_summary(d), os.path.basename(os.path.normpath(d))


def _last_finite(y: np.ndarray) -> float:
    """The last finite value of y (nan if none)."""
    finite = np.flatnonzero(np.isfinite(y))
    return float(y[finite[-1]]) if finite.size else math.nan


def _limit_blowups(ax, ok: list[np.ndarray], stopped: list[np.ndarray],
                   factor: float = 1.0) -> None:
    """Keep the runs that finished readable when a stopped run blew up.

    If the stopped runs leave the range of the finished ones by more than ``factor``
    times that range, the y axis shows the finished runs' range widened by ``factor``
    on each side: the blow-up leaves the panel, its stop stays marked.
    """
    ok = [y for y in ok if y.size]
    st = [y for y in stopped if y.size]
    if not ok or not st:
        return
    lo = min(float(y.min()) for y in ok)
    hi = max(float(y.max()) for y in ok)
    span = hi - lo
    if span <= 0:
        span = max(abs(hi), 1e-12)
    s_lo = min(float(y.min()) for y in st)
    s_hi = max(float(y.max()) for y in st)
    if s_lo >= lo - factor * span and s_hi <= hi + factor * span:
        return   # the stopped runs stay on the scale of the others: autoscale
    y_lo = max(min(lo, s_lo), lo - factor * span)
    y_hi = min(max(hi, s_hi), hi + factor * span)
    margin = 0.05 * (y_hi - y_lo)
    ax.set_ylim(y_lo - margin, y_hi + margin)


def plot_traces(dirs_or_results: Iterable, out_png: str | os.PathLike | None = None,
                labels: Sequence[str] | None = None, title: str | None = None):
    """Draw the traces of one or more runs in four panels and save them as an image.

    Parameters
    ----------
    dirs_or_results : run folders (holding trace.csv and summary.json) and/or
        :class:`dyncontact.RunResult` objects; one colour per run.
    out_png : file to write (None: do not save); its extension gives the format (.png,
        .pdf, .svg; without one, matplotlib writes OUT.png), its folders are created.
    labels : legend labels (default: scheme and parameters from summary.json, e.g.
        'hht α=-0.1, Δt=0.0025, h=0.05' (:func:`run_label`); where two runs would read
        alike, followed by the scene keys that differ between them, or by the run's
        folder). A run whose status is not 'ok' is drawn up to
        where it stopped, marked with an 'x', and labelled '(unstable at t=...)'.
    title : figure title (wrapped to the figure's width; its own line breaks kept).

    The panels: u_n, v_n and p_n at the probe (p_n labelled with the formula of the runs'
    contact method, from summary.json), and the energy e_kin + e_el (solid) and
    + e_contact (dashed); when a run has a body force (a nonzero e_load column), e_load is
    added to both for every run, so that the curves show the mechanical energy (runs of
    models of different dimensions get a note there: their energies are per unit
    cross-section in 1D, per unit thickness in 2D, whole in 3D). When a
    trace has the f_n column (the total normal contact force), the p_n panel draws it
    dashed on a second scale at its right (a fifth Axes, ``fig.axes[4]``, twin of the p_n
    panel); traces written before f_n existed are drawn without it. The legend goes
    under the panels, two runs a row; beyond 12 runs the figure grows taller with it,
    the panels keeping their height. Each run has a colour of its own (beyond ten runs,
    from 'tab20', then 'turbo').

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    BadInputError
        (a ``ValueError`` too) no run given, or ``labels`` not one per run or with
        an empty (or blank) one.
    RunNotFoundError
        a run folder that is not there or has no trace.csv (a ``BadInputError``).
    """
    from matplotlib.figure import Figure

    from .core import BadInputError   # a ValueError too, which these were before

    items = list(dirs_or_results) if not isinstance(dirs_or_results, (str, os.PathLike)) \
        else [dirs_or_results]
    if not items:
        raise BadInputError("plot_traces: nothing to plot (no run folder or RunResult)")
    if labels is not None and len(labels) != len(items):
        n = len(labels)
        raise BadInputError(f"labels: {n} label{'' if n == 1 else 's'} for "
                            f"{len(items)} run{'' if len(items) == 1 else 's'}; "
                            "give one per run")
    for i, label in enumerate(labels or [], 1):
        if not str(label).strip():   # a blank legend entry, which no run can be told by
            raise BadInputError(f"labels: label {i} of {len(labels)} is empty; give one "
                                "per run")

    # A fixed layout (constrained layout costs about half of the drawing time): the
    # legend, one row per two runs, goes under the panels.
    loaded = [_load(item) for item in items]
    # f_n (total contact force: other units than p_n) on a second scale of the p_n panel,
    # its labels between the columns (wider apart for them)
    with_f_n = any("f_n" in trace for trace, _summary, _name in loaded)
    legend_rows = math.ceil(len(items) / 2)
    height = _FIG_H_IN + _LEGEND_ROW_IN * max(0, legend_rows - _LEGEND_ROWS_IN_PLACE)
    fig = Figure(figsize=(_FIG_W_IN, height))
    fig.subplots_adjust(left=0.08, right=0.985,
                        top=1.0 - (_TOP_TITLE_IN if title else _TOP_IN) / height,
                        bottom=(_BOTTOM_IN + _LEGEND_ROW_IN * legend_rows) / height,
                        hspace=0.07, wspace=0.42 if with_f_n else 0.24)
    axes = fig.subplots(2, 2, sharex=True).ravel()
    colours = run_colours(len(items))
    handles = []
    # Per panel: finite values of the runs that finished ('ok') and of the stopped ones,
    # to keep a blow-up from flattening everything else (see _limit_blowups).
    ok_values: list[list[np.ndarray]] = [[] for _ in axes]
    stopped_values: list[list[np.ndarray]] = [[] for _ in axes]
    stops = []   # (t_stop, colour, [(ax index, y_last)])
    ax_f = axes[2].twinx() if with_f_n else None
    f_ok: list[np.ndarray] = []
    f_stopped: list[np.ndarray] = []
    # Under a body force e_kin + e_el is not what the schemes conserve: the energy panel
    # then adds e_load = -u.L (the mechanical energy, docs/scenes.md) for every run (0
    # for the runs without a load), and its label says so.
    with_load = any(np.any(np.asarray(trace.get("e_load", [])) != 0)
                    for trace, _summary, _name in loaded)
    names = labels if labels is not None else [run_label(summary, default_name)
                                               for _, summary, default_name in loaded]
    if labels is None:
        names = _told_apart(names, [summary for _, summary, _ in loaded],
                            [default_name for _, _, default_name in loaded])
    for i, (trace, summary, _name) in enumerate(loaded):
        label = names[i]
        t = np.asarray(trace.get("t", np.empty(0)), dtype=float)
        status = str(summary.get("status", "ok"))
        stopped = status != "ok"
        t_stop = t[-1] if t.size else math.nan
        if stopped:
            what = "unstable" if status == "unstable" else status.replace("_", " ")
            label = f"{label} ({what} at t={t_stop:.4g})"
        colour = colours[i]
        e_total = np.asarray(trace.get("e_total", np.full(t.shape, np.nan)), dtype=float)
        if with_load and "e_load" in trace:
            e_total = e_total + np.asarray(trace["e_load"], dtype=float)
        columns = [np.asarray(trace.get(col, np.full(t.shape, np.nan)), dtype=float)
                   for col, _ in _PANELS] + [e_total]
        line = None
        for k, (ax, y) in enumerate(zip(axes, columns)):
            (line,) = ax.plot(t, y, color=colour, lw=1.2, label=label)
            (stopped_values if stopped else ok_values)[k].append(y[np.isfinite(y)])
        if ax_f is not None and "f_n" in trace:
            y = np.asarray(trace["f_n"], dtype=float)
            ax_f.plot(t, y, color=colour, lw=1.0, ls="--", gid="f_n")
            (f_stopped if stopped else f_ok).append(y[np.isfinite(y)])
        e_contact = trace.get("e_contact")
        if e_contact is not None and np.any(np.asarray(e_contact) != 0):
            y = e_total + np.asarray(e_contact, dtype=float)
            axes[3].plot(t, y, color=colour, lw=1.0, ls="--")
            (stopped_values if stopped else ok_values)[3].append(y[np.isfinite(y)])
        if stopped and t.size:
            stops.append((t_stop, colour, [_last_finite(y) for y in columns]))
        handles.append(line)

    for k, ax in enumerate(axes):
        _limit_blowups(ax, ok_values[k], stopped_values[k])
    if ax_f is not None:
        _limit_blowups(ax_f, f_ok, f_stopped)
        ax_f.set_ylabel(_method_label([summary for trace, summary, _name in loaded
                                       if "f_n" in trace], _F_N_LABELS,
                                      r"$f_n$, total normal contact force (dashed)"))
    # The stop of a run that did not finish: an 'x' at its last value (kept inside the
    # panel when the value is off the scale or not finite) and a dotted vertical line.
    for t_stop, colour, lasts in stops:
        for ax, y_last in zip(axes, lasts):
            lo, hi = ax.get_ylim()
            y_mark = min(max(y_last, lo), hi) if math.isfinite(y_last) else hi
            ax.plot([t_stop], [y_mark], "x", color=colour, ms=9, mew=2, gid="stop-marker",
                    clip_on=False)
            ax.axvline(t_stop, color=colour, lw=0.8, ls=":", gid="stop-line")
            ax.set_ylim(lo, hi)

    for ax, (_, ylabel) in zip(axes[:2], _PANELS):
        ax.set_ylabel(ylabel)
    axes[2].set_ylabel(_method_label([summary for _trace, summary, _name in loaded],
                                     _P_N_LABELS, r"$p_n$ at the probe (contact pressure)"))
    axes[3].set_ylabel("energy: $e_{kin}+e_{el}" + ("+e_{load}" if with_load else "")
                       + "$ (solid), $+\\,e_{contact}$ (dashed)")
    # the energies and f_n are those of each run's model: per unit cross-section in 1D,
    # per unit thickness in 2D, of the whole body in 3D; runs of several dimensions on one
    # chart get a note saying so, since their curves are not in the same units
    dims = sorted({int(summary["dim"]) for _trace, summary, _name in loaded
                   if isinstance(summary.get("dim"), int) and summary["dim"] in _PER_DIM})
    if len(dims) > 1:
        # in a band above the curves (the scale's top raised by a fifth of its range)
        lo, hi = axes[3].get_ylim()
        axes[3].set_ylim(lo, hi + 0.2 * (hi - lo))
        axes[3].text(0.5, 0.98, "energies" + (" and $f_n$" if with_f_n else "")
                     + " not comparable across dimensions:\n"
                     + ", ".join(_PER_DIM[d] for d in dims),
                     transform=axes[3].transAxes, fontsize=7, va="top", ha="center",
                     gid="dims-note", bbox={"fc": "white", "alpha": 0.8, "lw": 0})
    for ax in [*axes, *([ax_f] if ax_f is not None else [])]:
        _unit_free_ticks(ax)
    for ax in axes:
        ax.grid(True, lw=0.4, alpha=0.5)
    for ax in axes[2:]:
        ax.set_xlabel("t")
    # the title as far below the figure's top in inches whatever the legend's rows make
    # the figure's height (matplotlib's y = 0.98 is a fraction of it)
    title_text = _wrapped_title(fig, title, 1.0 - 0.02 * _FIG_H_IN / height) \
        if title else None
    _fit_margins(fig, axes, ax_f, title_text)
    if ax_f is not None:
        _clear_columns(fig, ax_f, axes[3])
    fig.legend(handles=handles, loc="lower center", bbox_to_anchor=(0.5, 0.0),
               ncols=min(len(handles), 2), fontsize="small", frameon=False)
    _save(fig, out_png)
    return fig


#: Powers of ten (matplotlib's axes.formatter.limits) outside which an axis writes its
#: ticks as a mantissa and a common factor (1e-4): matplotlib's own (-5, 6) writes the
#: time axis of an SI impact, ticks 2.5e-5 s apart, as nine overlapping 8-digit labels
#: (0.000025, 0.000050, ...), and a stress in Pa up to 999999 in full. The nondimensional
#: scenes' values (10^-3 to 10^4) keep their plain ticks.
TICK_POWER_LIMITS = (-4, 5)


def _unit_free_ticks(ax) -> None:
    """Plain ticks for values of 10^-3 to 10^4, a mantissa and a factor beyond: readable
    in whatever units a scene is given (docs/scenes.md)."""
    for axis in (ax.xaxis, ax.yaxis):
        fmt = axis.get_major_formatter()
        if hasattr(fmt, "set_powerlimits"):
            fmt.set_powerlimits(TICK_POWER_LIMITS)


def _wrap(text: str, width: int) -> str:
    """`text` broken into lines of at most `width` characters, its own line breaks kept
    (a line too long alone, a path, is cut)."""
    import textwrap

    return "\n".join(line for part in str(text).splitlines()
                     for line in textwrap.wrap(part, max(1, width)) or [""])


def _wrapped_title(fig, title: str, y: float, pad_px: float = 4.0):
    """The figure's title (suptitle at `y`) wrapped to the figure's width: lines of about
    10 characters an inch at 12 points, then narrower while the text drawn is still wider
    than the figure less pad_px each side (capitals and wide glyphs take more room than
    the average): unwrapped, a long ``--title`` would run off both edges."""
    width = int(10 * fig.get_figwidth())
    text = fig.suptitle(_wrap(title, width), y=y)
    room = fig.bbox.width - 2 * pad_px
    for _ in range(8):
        drawn = text.get_window_extent().width
        if drawn <= room or width <= 1:
            break
        width = min(width - 1, int(width * room / drawn))
        text.set_text(_wrap(title, width))
    return text


def run_colours(n: int) -> list:
    """One colour per run, no two alike: matplotlib's ten default colours (C0..C9) up
    to ten runs; 'tab20' up to twenty; beyond, n colours spread over 'turbo' (the
    default cycle repeats after ten, which drew the 11th run in the 1st one's colour)."""
    if n <= 10:
        return [f"C{i}" for i in range(n)]
    from matplotlib import colormaps

    if n <= 20:
        return [colormaps["tab20"](i) for i in range(n)]
    return [colormaps["turbo"](x) for x in np.linspace(0.05, 0.95, n)]


def _fit_margins(fig, axes, twin, title_text=None, pad_px: float = 4.0,
                 row_pad_px: float = 12.0) -> None:
    """Widen the fixed layout's margins where the panels' labels need it: the left
    margin until the left column's y labels and tick labels (u_n from -0.0075 to 0.0125:
    seven characters) begin pad_px inside the figure, the space between the rows until
    the lower panels' scale factors ('1e8' above p_n in SI units, which matplotlib puts
    above the panel's top) end row_pad_px under the upper panels (closer, they read as
    the upper panel's tick labels), and the top margin until
    the upper panels' scale factors end pad_px under the title (or the figure's top)."""
    upper = list(axes[:2])
    lower = list(axes[2:]) + ([twin] if twin is not None else [])
    height = fig.bbox.height
    for _ in range(4):
        sp = fig.subplotpars
        changed = False
        x0 = min(ax.get_tightbbox().x0 for ax in (axes[0], axes[2]))
        if x0 < pad_px:
            fig.subplots_adjust(left=sp.left + (pad_px - x0) / fig.bbox.width)
            changed = True
        ceiling = height - pad_px
        if title_text is not None:
            ceiling = title_text.get_window_extent().y0 - pad_px
        over = max(ax.get_tightbbox().y1 for ax in upper) - ceiling
        if over > 0:
            fig.subplots_adjust(top=sp.top - over / height)
            changed = True
        overlap = (max(ax.get_tightbbox().y1 for ax in lower) + row_pad_px
                   - min(ax.get_tightbbox().y0 for ax in upper))
        if overlap > 0.5:
            # the gap between the rows is hspace x a panel's height, span / (2 + hspace)
            span = sp.top - sp.bottom
            gap = sp.hspace * span / (2.0 + sp.hspace) + overlap / height
            fig.subplots_adjust(hspace=2.0 * gap / (span - gap))
            changed = True
        if not changed:
            return


def _clear_columns(fig, left_ax, right_ax, pad_px: float = 14.0) -> None:
    """Widen the space between the two columns until left_ax's right side (f_n's tick
    labels and label) ends pad_px before right_ax's left side (the energy's label and
    ticks): with wide tick labels on both (3D: f_n -0.007, energies 0.00125) the fixed
    wspace let the two labels overlap."""
    for _ in range(4):
        overlap = left_ax.get_tightbbox().x1 + pad_px - right_ax.get_tightbbox().x0
        if overlap <= 0:
            return
        sp = fig.subplotpars
        span = sp.right - sp.left
        # the gap between the columns is wspace × an axis' width, span / (2 + wspace)
        gap = sp.wspace * span / (2.0 + sp.wspace) + overlap / fig.bbox.width
        fig.subplots_adjust(wspace=2.0 * gap / (span - gap))


def _save(fig, out_png) -> None:
    """Write fig to out_png (folders created) unless out_png is None."""
    if out_png is None:
        return
    out_png = os.fspath(out_png)
    folder = os.path.dirname(out_png)
    if folder:
        os.makedirs(folder, exist_ok=True)
    try:
        fig.savefig(out_png, dpi=120)
    except OSError as exc:   # the image writer's errors do not name the file
        raise OSError(exc.errno, exc.strerror or str(exc), out_png) from exc


# --------------------------------------------------------------------------- fields

def read_pvd(path: str | os.PathLike) -> list[tuple[float, str]]:
    """(time, absolute .vtu path) of each data set of a ParaView .pvd collection."""
    import xml.etree.ElementTree as ET

    path = os.fspath(path)
    folder = os.path.dirname(os.path.abspath(path))
    root = ET.parse(path).getroot()
    out = []
    for ds in root.iter("DataSet"):
        out.append((float(ds.get("timestep", "nan")),
                    os.path.join(folder, ds.get("file", ""))))
    return out


def _clip_line(p: np.ndarray, d: np.ndarray, box) -> np.ndarray | None:
    """The segment of the line p + s d inside box = (x_lo, x_hi, y_lo, y_hi) as a (2, 2)
    array of its ends (Liang-Barsky), or None when the line misses the box."""
    s_lo, s_hi = -np.inf, np.inf
    for k, (lo, hi) in enumerate(((box[0], box[1]), (box[2], box[3]))):
        if abs(d[k]) < 1e-15:
            if not lo <= p[k] <= hi:
                return None
            continue
        s1, s2 = sorted(((lo - p[k]) / d[k], (hi - p[k]) / d[k]))
        s_lo, s_hi = max(s_lo, s1), min(s_hi, s2)
    if not s_lo < s_hi:
        return None
    return np.array([p + s_lo * d, p + s_hi * d])


def _pick(n: int, k: int) -> list[int]:
    """k >= 1 indices spread evenly over range(n), first and last included (k = 1: the
    last alone)."""
    if n <= k:
        return list(range(n))
    if k == 1:
        return [n - 1]
    return sorted({int(round(i * (n - 1) / (k - 1))) for i in range(k)})


def plot_field_snapshots(run_dir: str | os.PathLike, out_png: str | os.PathLike | None = None,
                         title: str | None = None, max_snapshots: int = 12,
                         field: str = "displacement"):
    """Deformed meshes of a run's VTU snapshots side by side, coloured by |u|.

    Parameters
    ----------
    run_dir : folder of a run with ``fields_every > 0`` (holding fields.pvd and fields/).
    out_png : file to write (None: do not save).
    title : figure title (wrapped to the figure's width).
    max_snapshots : at most this many snapshots (>= 1, else ValueError), spread evenly
        over the run, the first and the last included; 1: the last alone.
    field : the point field that deforms the mesh and colours it.

    Each snapshot is drawn at its true deformation (scale 1) on the nodes x + u, shifted
    sideways from the previous one, with its time underneath; the obstacle plane is drawn
    with its side hatched: one line under all of them when it is horizontal (the seed's
    bar), else its trace under each snapshot, shifted with it. Needs a 2D (triangle) mesh;
    reads the files with meshio.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import meshio
    from matplotlib.figure import Figure
    from matplotlib.tri import Triangulation

    from .core import read_summary, run_file

    if isinstance(max_snapshots, bool) or int(max_snapshots) != max_snapshots \
            or max_snapshots < 1:
        raise ValueError(f"max_snapshots = {max_snapshots!r} (must be an integer >= 1)")
    max_snapshots = int(max_snapshots)
    run_dir = os.fspath(run_dir)
    pvd = run_file(run_dir, "fields.pvd", " (run with &output fields_every > 0)")
    sets = read_pvd(pvd)
    if not sets:
        raise ValueError(f"{pvd}: no snapshots")
    sets = [sets[i] for i in _pick(len(sets), max_snapshots)]
    snaps = []
    for t, vtu in sets:
        m = meshio.read(vtu)
        tri = m.cells_dict.get("triangle")
        if tri is None:
            raise ValueError(f"{vtu}: snapshots need a 2D triangle mesh")
        u = np.asarray(m.point_data[field], dtype=float)[:, :2]
        snaps.append((t, np.asarray(m.points, dtype=float)[:, :2], np.asarray(tri), u))
    vmax = max(float(np.max(np.hypot(u[:, 0], u[:, 1]))) for _, _, _, u in snaps) or 1.0
    x_all = np.concatenate([x[:, 0] + u[:, 0] for _, x, _, u in snaps])
    y_all = np.concatenate([x[:, 1] + u[:, 1] for _, x, _, u in snaps])
    width = float(x_all.max() - x_all.min())
    height = float(y_all.max() - y_all.min()) or 1.0
    gap = max(1.2 * width, 0.15 * height)

    fig = Figure(figsize=(max(6.0, 1.0 + 0.75 * len(snaps)), 5.0), layout="constrained")
    ax = fig.subplots()
    mappable = None
    for k, (t, x, tri, u) in enumerate(snaps):
        mag = np.hypot(u[:, 0], u[:, 1])
        xs = x[:, 0] + u[:, 0] + k * gap
        tr = Triangulation(xs, x[:, 1] + u[:, 1], tri)
        mappable = ax.tripcolor(tr, mag, shading="gouraud", cmap="viridis", vmin=0.0,
                                vmax=vmax)
        ax.triplot(tr, color="k", lw=0.15, alpha=0.35)
        ax.text(float(np.mean(xs)), float(y_all.min()) - 0.06 * height, f"t={t:.3g}",
                ha="center", va="top", fontsize="small")
    # The obstacle plane: horizontal (normal ±e_y), one line under all the snapshots;
    # tilted, its trace under each snapshot, shifted with it (a sideways shift moves a
    # tilted line), clipped to the snapshot's box widened by a third of the gap.
    scene = read_summary(run_dir).get("scene") or {}
    contact = scene.get("contact", {}) if isinstance(scene, dict) else {}
    try:
        normal = np.array([float(c) for c in contact.get("obstacle_normal", [0.0, -1.0])[:2]])
        point = np.array([float(c) for c in contact.get("obstacle_point", [0.0, 0.0])[:2]])
        ok = normal.shape == (2,) and point.shape == (2,) and np.hypot(*normal) > 0
    except (TypeError, IndexError, ValueError, AttributeError):
        ok = False
    if ok:
        normal = normal / np.hypot(*normal)
        depth = 0.04 * height
        if abs(normal[0]) < 1e-12:
            y0 = float(point[1])
            x_lo = float(x_all.min()) - 0.5 * gap
            x_hi = float(x_all.max()) + (len(snaps) - 0.5) * gap
            ax.axhline(y0, color="0.3", lw=1.5, gid="obstacle")
            below = -1.0 if float(normal[1]) < 0 else 1.0
            ax.fill_between([x_lo, x_hi], y0, y0 + below * depth, color="0.85",
                            hatch="///", edgecolor="0.5", lw=0)
        else:
            margin = gap / 3.0
            for k, (_t, x, _tri, u) in enumerate(snaps):
                xd = x + u
                box = (float(xd[:, 0].min()) - margin, float(xd[:, 0].max()) + margin,
                       float(y_all.min()) - 0.1 * height, float(y_all.max()) + 0.03 * height)
                seg = _clip_line(point, np.array([-normal[1], normal[0]]), box)
                if seg is None:
                    continue
                a, b = seg[0] + [k * gap, 0.0], seg[1] + [k * gap, 0.0]
                ax.plot([a[0], b[0]], [a[1], b[1]], color="0.3", lw=1.5, gid=f"obstacle-{k}")
                quad = np.array([a, b, b + depth * normal, a + depth * normal])
                ax.fill(quad[:, 0], quad[:, 1], color="0.85", hatch="///", edgecolor="0.5",
                        lw=0)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_ylabel("y (deformed)")
    ax.set_ylim(float(y_all.min()) - 0.12 * height, float(y_all.max()) + 0.03 * height)
    fig.colorbar(mappable, ax=ax, shrink=0.8, label=f"|{'u' if field == 'displacement' else field}|")
    if title:
        # wrapped to the figure's width (about 10 characters an inch at 12 points): a
        # figure of few snapshots is narrow, and a long title would run past both its edges
        fig.suptitle(_wrap(title, int(10 * fig.get_figwidth())))
    _save(fig, out_png)
    return fig
