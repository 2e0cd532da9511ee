"""Overlay run traces in the seed's four panels: u_n, v_n, p_n and the energy.

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

__all__ = ["plot_traces", "run_label"]

# (column, y label) of the first three panels; the fourth is the energy.
_PANELS = (
    ("u_n", r"$u_n$ at the probe"),
    ("v_n", r"$\dot u_n$ at the probe"),
    ("p_n", r"$p_n = [P_1(u) + \gamma_N g]_-$"),
)

_SCHEME_PARAMS = {
    "hht": ("alpha",),
    "hht_seed": ("alpha",),
    "pc_hht": ("alpha",),
    "pc_hht_seed": ("alpha",),
    "newmark": ("beta", "gamma"),
    "pc": ("beta", "gamma"),
    "theta": ("theta",),
}
_SYMBOL = {"alpha": "α", "beta": "β", "gamma": "γ", "theta": "θ"}


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
    """'hht α=-0.1, Δt=0.0025, h=0.05' from a summary.json (fallback if it says nothing)."""
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
    if scheme.get("mass") == "lumped":
        params.append("lumped")
    parts.append(name + (" " + ", ".join(params) if params else ""))
    return parts[0]


def _load(item) -> tuple[dict[str, np.ndarray], dict, str]:
    """(trace, summary, default label) of a run folder or a RunResult."""
    from .core import read_summary, read_trace

    if hasattr(item, "trace") and hasattr(item, "summary"):
        name = os.path.basename(os.path.normpath(str(getattr(item, "out_dir", "") or "")))
        return item.trace, dict(item.summary or {}), name or "run"
    d = os.fspath(item)
    trace_path = os.path.join(d, "trace.csv")
    if not os.path.isfile(trace_path):
        raise FileNotFoundError(f"{d}: no trace.csv")
    return read_trace(d), read_summary(d), os.path.basename(os.path.normpath(d))


def plot_traces(dirs_or_results: Iterable, out_png: str | os.PathLike | None = None,
                labels: Sequence[str] | None = None, title: str | None = None):
    """Draw the traces of one or more runs in four panels and save them as a PNG.

    Parameters
    ----------
    dirs_or_results : run folders (holding trace.csv and summary.json) and/or
        :class:`dyncontact.RunResult` objects; one colour per run.
    out_png : file to write (None: do not save).
    labels : legend labels (default: scheme and parameters from summary.json, e.g.
        'hht α=-0.1, Δt=0.0025, h=0.05'). A run whose status is not 'ok' is drawn up to
        where it stopped, marked with an 'x', and labelled '(unstable at t=...)'.
    title : figure title.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    items = list(dirs_or_results) if not isinstance(dirs_or_results, (str, os.PathLike)) \
        else [dirs_or_results]
    if not items:
        raise ValueError("nothing to plot")
    if labels is not None and len(labels) != len(items):
        raise ValueError(f"{len(labels)} labels for {len(items)} runs")

    fig = Figure(figsize=(11.0, 7.5), layout="constrained")
    axes = fig.subplots(2, 2, sharex=True).ravel()
    colours = [f"C{i % 10}" for i in range(len(items))]
    handles = []
    for i, item in enumerate(items):
        trace, summary, default_name = _load(item)
        label = labels[i] if labels is not None else run_label(summary, default_name)
        t = np.asarray(trace.get("t", np.empty(0)), dtype=float)
        status = str(summary.get("status", "ok"))
        stopped = status != "ok"
        if stopped:
            t_stop = t[-1] if t.size else math.nan
            what = "unstable" if status == "unstable" else status.replace("_", " ")
            label = f"{label} ({what} at t={t_stop:.4g})"
        colour = colours[i]
        line = None
        for ax, (col, _) in zip(axes[:3], _PANELS):
            y = np.asarray(trace.get(col, np.full(t.shape, np.nan)), dtype=float)
            (line,) = ax.plot(t, y, color=colour, lw=1.2, label=label)
            if stopped and t.size:
                ax.plot(t[-1:], y[-1:], "x", color=colour, ms=9, mew=2)
        e_total = np.asarray(trace.get("e_total", np.full(t.shape, np.nan)), dtype=float)
        ax = axes[3]
        (line,) = ax.plot(t, e_total, color=colour, lw=1.2, label=label)
        e_contact = trace.get("e_contact")
        if e_contact is not None and np.any(np.asarray(e_contact) != 0):
            ax.plot(t, e_total + np.asarray(e_contact, dtype=float), color=colour, lw=1.0,
                    ls="--")
        if stopped and t.size:
            ax.plot(t[-1:], e_total[-1:], "x", color=colour, ms=9, mew=2)
        handles.append(line)

    for ax, (_, ylabel) in zip(axes[:3], _PANELS):
        ax.set_ylabel(ylabel)
    axes[3].set_ylabel("energy: $e_{kin}+e_{el}$ (solid), $+\\,e_{contact}$ (dashed)")
    for ax in axes:
        ax.grid(True, lw=0.4, alpha=0.5)
    for ax in axes[2:]:
        ax.set_xlabel("t")
    fig.legend(handles=handles, loc="outside lower center", ncols=min(len(handles), 2),
               fontsize="small", frameon=False)
    if title:
        fig.suptitle(title)
    if out_png is not None:
        out_png = os.fspath(out_png)
        folder = os.path.dirname(out_png)
        if folder:
            os.makedirs(folder, exist_ok=True)
        fig.savefig(out_png, dpi=120)
    return fig
