"""Report figures: matplotlib (object-oriented Figure with its own Agg canvas: no display, no
pyplot state and no change of the user's backend, no network) rendered to base64 PNG.

Every function takes plain data (lists/arrays in the units named in the argument names, as stored
in a run's ``run.json``) and returns a ``data:image/png;base64,...`` URI that the HTML embeds, so
the report is one self-contained file. The figures mirror Mu et al. 2018: trajectories measured vs
simulated (figures 7a, 8a, 10), time series of u, v, r, psi and delta (figures 7b-c, 8b-c, 9),
course keeping under disturbance (figures 11-12), plus the Ma et al. turning-diameter fit.
"""

from __future__ import annotations

import base64
import io
from collections.abc import Mapping, Sequence
from typing import Any

import matplotlib
import matplotlib.image as mimage
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

#: PNG resolution [dots per inch]: sharp enough to print, small enough to embed (~40-80 kB each).
DPI = 96
#: White margin around a figure's ink [inches] (matplotlib's ``savefig.pad_inches`` default).
PAD_INCHES = 0.1
_MEASURED = {"color": "#1f77b4", "lw": 1.2}
_SIMULATED = {"color": "#d62728", "lw": 1.2, "ls": "--"}
_STYLE = {
    "font.size": 8.5,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "svg.hashsalt": "usvid",
}


def fig_to_data_uri(fig: Any) -> str:
    """Render a matplotlib figure to a ``data:image/png;base64,...`` URI, cropped to its ink.

    One Agg draw at :data:`DPI`, then the image is cropped to the bounding box of its non-white
    pixels plus :data:`PAD_INCHES` of white on each side: the picture ``savefig(...,
    bbox_inches="tight")`` gives, without its second (layout) draw, which doubled the report's
    drawing time. A figure whose ink reaches the canvas edge (an artist outside the figure,
    which only the layout draw can bring back in) takes the ``bbox_inches="tight"`` path. The
    PNG carries no timestamp (``metadata={"Software": None}``), so the same data give the same
    bytes.
    """
    buf = io.BytesIO()
    fig.set_dpi(DPI)
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    rgba = np.asarray(canvas.buffer_rgba())
    ink = np.any(rgba[..., :3] != 255, axis=2) | (rgba[..., 3] != 255)
    rows, cols = np.flatnonzero(ink.any(axis=1)), np.flatnonzero(ink.any(axis=0))
    h, w = ink.shape
    if rows.size == 0 or rows[0] == 0 or cols[0] == 0 or rows[-1] == h - 1 or cols[-1] == w - 1:
        fig.savefig(buf, format="png", dpi=DPI, bbox_inches="tight", pad_inches=PAD_INCHES,
                    metadata={"Software": None})
    else:
        pad = round(PAD_INCHES * DPI)
        crop = rgba[rows[0]:rows[-1] + 1, cols[0]:cols[-1] + 1]
        img = np.full((crop.shape[0] + 2 * pad, crop.shape[1] + 2 * pad, 4), 255, np.uint8)
        img[pad:pad + crop.shape[0], pad:pad + crop.shape[1]] = crop
        mimage.imsave(buf, img, format="png", dpi=DPI, metadata={"Software": None})
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def _arr(values: Any) -> np.ndarray:
    """A float array; ``None`` entries (JSON null for NaN) become NaN."""
    if values is None:
        return np.array([], dtype=float)
    return np.array([np.nan if v is None else v for v in np.ravel(values)], dtype=float)


def trajectory_figure(
    tracks: Mapping[str, Mapping[str, Sequence[float]]], title: str = ""
) -> str:
    """Plan view of one or more tracks: x north [m] up, y east [m] to the right, equal axes.

    ``tracks`` maps a label (``"measured"``, ``"simulated"``, ...) to ``{"x": [...], "y": [...]}``
    in metres (NED). Returns a PNG data URI.
    """
    with matplotlib.rc_context(_STYLE):
        fig = Figure(figsize=(4.2, 4.0))
        ax = fig.subplots()
        for label, tr in tracks.items():
            style = _SIMULATED if label.startswith("sim") else _MEASURED
            if label not in ("measured", "simulated"):
                style = {"lw": 1.2}
            x, y = _arr(tr.get("x")), _arr(tr.get("y"))
            if x.size:
                ax.plot(y, x, label=label, **style)
                ax.plot(y[:1], x[:1], "o", ms=3, color=style.get("color", "k"))
        ax.set_xlabel("y east [m]")
        ax.set_ylabel("x north [m]")
        ax.set_aspect("equal", adjustable="datalim")
        ax.legend(loc="best", fontsize=7)
        if title:
            ax.set_title(title)
        return fig_to_data_uri(fig)


def timeseries_figure(
    t_s: Sequence[float],
    panels: Sequence[Mapping[str, Any]],
    title: str = "",
) -> str:
    """Stacked time series sharing the time axis [s].

    Each panel is ``{"ylabel": str, "lines": [{"label": str, "y": [...], "kind":
    "measured"|"simulated"|"other", "t": optional own time axis}]}``. Returns a PNG data URI.
    """
    t = _arr(t_s)
    n = max(len(panels), 1)
    with matplotlib.rc_context(_STYLE):
        fig = Figure(figsize=(7.0, 1.55 * n + 0.5))
        axes = fig.subplots(n, 1, sharex=True, squeeze=False)
        for ax, panel in zip(axes[:, 0], panels, strict=False):
            for line in panel.get("lines", []):
                kind = line.get("kind", "other")
                style = {"measured": _MEASURED, "simulated": _SIMULATED}.get(kind, {"lw": 1.0})
                tt = _arr(line["t"]) if line.get("t") is not None else t
                y = _arr(line.get("y"))
                if y.size and y.size == tt.size:
                    ax.plot(tt, y, label=line.get("label", kind), **style)
            ax.set_ylabel(panel.get("ylabel", ""))
            if panel.get("lines"):
                ax.legend(loc="upper right", fontsize=6.5, ncol=3)
        axes[-1, 0].set_xlabel("t [s]")
        if title:
            axes[0, 0].set_title(title)
        fig.align_ylabels()
        return fig_to_data_uri(fig)


def course_keeping_figure(cc: Mapping[str, Any]) -> str:
    """Course change 0 -> target under disturbance (Mu et al. 2018, figures 11-12): heading,
    heading error (magnified, +-8 deg), rudder angle and disturbance, one colour and dash
    pattern per run.

    ``cc``: ``{"t": [...s], "target_deg": float, "disturbance": [...] (optional), "runs":
    [{"label": "PD", "psi_deg": [...], "delta_deg": [...]}]}``. Returns a PNG data URI.
    """
    t = _arr(cc.get("t"))
    dist = _arr(cc.get("disturbance"))
    target = cc.get("target_deg")
    n = (3 if dist.size == t.size and t.size else 2) + (1 if target is not None else 0)
    # one colour and one dash pattern per run: gains that differ little (PD vs PID with a tiny
    # ki) stay distinguishable, and the heading-error panel magnifies their differences
    styles = ["-", "--", "-.", ":", (0, (5, 1, 1, 1))]
    with matplotlib.rc_context(_STYLE):
        fig = Figure(figsize=(7.0, 1.7 * n + 0.5))
        axes = fig.subplots(n, 1, sharex=True)
        for i, run in enumerate(cc.get("runs", [])):
            psi = _arr(run.get("psi_deg"))
            dlt = _arr(run.get("delta_deg"))
            kw = dict(color=f"C{i}", ls=styles[i % len(styles)], label=run.get("label", ""))
            if psi.size == t.size:
                axes[0].plot(t, psi, lw=1.1, **kw)
                if target is not None:
                    axes[1].plot(t, psi - float(target), lw=1.0, **kw)
            if dlt.size == t.size:
                axes[2 if target is not None else 1].plot(t, dlt, lw=0.9, **kw)
        if target is not None:
            axes[0].axhline(float(target), color="k", lw=0.8, ls=":", label="target")
            axes[1].axhline(0.0, color="k", lw=0.6, ls=":")
            axes[1].set_ylim(-8.0, 8.0)
            axes[1].set_ylabel("psi - psi_d [deg]")
        kd = 2 if target is not None else 1
        axes[0].set_ylabel("psi [deg]")
        axes[kd].set_ylabel("delta [deg]")
        axes[0].legend(loc="lower right", fontsize=7)
        axes[kd].legend(loc="upper right", fontsize=7)
        if dist.size == t.size and t.size:
            axes[-1].plot(t, dist, color="#555555", lw=0.8)
            axes[-1].set_ylabel("disturbance [deg]")
        axes[-1].set_xlabel("t [s]")
        fig.align_ylabels()
        return fig_to_data_uri(fig)


def scatter_fit_figure(
    x: Sequence[float],
    y: Sequence[float],
    curve_x: Sequence[float] | None,
    curve_y: Sequence[float] | None,
    xlabel: str,
    ylabel: str,
    title: str = "",
    point_label: str = "data",
    curve_label: str = "fit",
) -> str:
    """Data points and a fitted curve (turning-diameter fit, Norrbin steady turns).

    Units are whatever the labels say. Returns a PNG data URI.
    """
    with matplotlib.rc_context(_STYLE):
        fig = Figure(figsize=(4.6, 3.2))
        ax = fig.subplots()
        ax.plot(_arr(x), _arr(y), "o", ms=4, label=point_label)
        if curve_x is not None and curve_y is not None:
            ax.plot(_arr(curve_x), _arr(curve_y), "-", lw=1.2, color="#d62728", label=curve_label)
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.legend(loc="best", fontsize=7)
        if title:
            ax.set_title(title)
        return fig_to_data_uri(fig)
