"""The one style module of every exotune figure (the sweep report's included). It holds no numbers of the analysis: figure sizes, fonts, dpi, grid, colour
maps, the physical names, symbols and display units of the configuration paths and sweep metrics
(:func:`label`, :func:`quantity`), axis helpers that scale tick values into those units
(:func:`unit_axis`), log/symlog helpers for values that span decades, colour bars without offset
text and the PNG renderer.
"""

from __future__ import annotations

import io
import re
from dataclasses import dataclass

import numpy as np

__all__ = ["DPI", "FIGSIZE", "FONTSIZE", "SMALL", "GRID", "CMAPS", "BAD_COLOR", "BAD_MEANING", "Quantity",
           "quantity", "label", "short_name", "scale_of", "unit_axis", "tick_labels", "log_if_decades",
           "symlog_if_decades", "plain_formatter", "colorbar", "grid", "new_figure", "png", "rc"]

DPI = 110
FIGSIZE = {"single": (7.2, 5.0), "wide": (8.5, 5.6), "bode": (7.0, 6.0), "tall": (8.5, 9.5),
           "panel": (5.6, 4.4)}
FONTSIZE = 10
SMALL = 8
GRID = {"alpha": 0.3, "which": "both"}
CMAPS = {"sequential": "viridis", "fraction": "RdYlGn", "excess": "magma_r", "inertia": "magma"}
BAD_COLOR = "#d0d0d0"
BAD_MEANING = "grey: not defined (metric NaN, e.g. no DOB) or not computed"


@dataclass(frozen=True)
class Quantity:
    """Physical name, symbol, display unit and SI → display factor of one quantity."""

    name: str
    symbol: str = ""
    unit: str = ""
    scale: float = 1.0


# configuration paths (sweep axes, design fields) and sweep metric columns
_Q = {
    "plant.motor_inertia": Quantity("motor inertia", "J_m", "kg·m²"),
    "plant.motor_damping": Quantity("motor damping", "B_m", "N·m·s/rad"),
    "plant.sea_stiffness": Quantity("SEA stiffness", "K_s", "N·m/rad"),
    "plant.joint_inertia": Quantity("joint inertia", "J_j", "kg·m²"),
    "plant.cuff_stiffness": Quantity("cuff stiffness", "K_c", "N·m/rad"),
    "design.amplification": Quantity("amplification", "α", "–"),
    "design.felt_inertia": Quantity("felt inertia", "Ĵ", "kg·m²"),
    "design.felt_damping": Quantity("felt damping", "B̂", "N·m·s/rad"),
    "design.zeta": Quantity("damping ratio", "ζ", "–"),
    "design.zeta_hat": Quantity("virtual-motor damping ratio", "ζ̂", "–"),
    "implementation.delay_s": Quantity("total delay", "T", "ms", 1e3),
    "implementation.sample_rate_hz": Quantity("sample rate", "f_s", "Hz"),
    "implementation.gv_filter.cutoff_hz": Quantity("G_v filter cutoff", "f_v", "Hz"),
    "implementation.gv_filter.damping": Quantity("G_v filter damping", "ζ_v", "–"),
    "implementation.derivative_filter.cutoff_hz": Quantity("derivative filter cutoff", "f_d", "Hz"),
    "implementation.dob.cutoff_hz": Quantity("DOB cutoff", "f_q", "Hz"),
    "implementation.dob.damping": Quantity("DOB damping", "ζ_q", "–"),
    "implementation.velocity_filter.cutoff_hz": Quantity("velocity filter cutoff", "f_ω", "Hz"),
    "latency_margin_s": Quantity("latency margin", "ΔT", "ms", 1e3),
    "plant_margin_lower": Quantity("plant-uncertainty margin, lower bound", "k*", "–"),
    "plant_margin_upper": Quantity("plant-uncertainty margin, upper bound", "k*", "–"),
    "dob_delay_margin_s": Quantity("DOB delay margin", "ΔT", "ms", 1e3),
    "dob_phase_margin_deg": Quantity("DOB phase margin", "PM", "deg"),
    "dob_gain_margin_db": Quantity("DOB gain margin", "GM", "dB"),
    "passivity_max_phase_excess_deg": Quantity("max phase excess of C7", "", "deg"),
    "amplification_bandwidth_hz": Quantity("amplification bandwidth", "f_−3dB", "Hz"),
    "fraction robust": Quantity("fraction of robust designs", "", "–"),
}
_FAMILY = re.compile(r"^(human|env)(\d+)_lightest_stable_inertia$|^(human|env)(\d+)_stiffest_stable_stiffness$")


def quantity(path: str) -> Quantity:
    """The :class:`Quantity` of a configuration path or metric column.

    Parameters
    ----------
    path : str
        A dotted configuration path (``implementation.delay_s``), a sweep metric column
        (``dob_delay_margin_s``, ``human0_lightest_stable_inertia``) or any other name.

    Returns
    -------
    Quantity
        Its physical name, symbol, display unit and SI → display factor; an unknown name is
        returned as its own name (underscores as spaces), unit-less, factor 1.

    References
    ----------
    docs/sweep-spec.md (the sweepable paths and report metrics).
    """
    key = str(path).strip()
    if key in _Q:
        return _Q[key]
    m = _FAMILY.match(key)
    if m:
        who, i = (m.group(1), m.group(2)) if m.group(1) else (m.group(3), m.group(4))
        if m.group(1):
            return Quantity(f"lightest stable inertia, {who} {i}", "", "kg·m²")
        return Quantity(f"stiffest stable spring, {who} {i}", "", "N·m/rad")
    return Quantity(key.rsplit(".", 1)[-1].replace("_", " "))


def label(path_or_name: str) -> str:
    """Axis label of a quantity: physical name, symbol and display unit.

    Parameters
    ----------
    path_or_name : str
        See :func:`quantity`; a label of the form ``"<path> [<unit>]"`` (the sweep report's
        axis labels) is accepted too and its path translated.

    Returns
    -------
    str
        E.g. ``label("implementation.delay_s") == "total delay T [ms]"`` (values must be scaled
        by :func:`scale_of`, 1e3 here).

    References
    ----------
    docs/sweep-spec.md.
    """
    q = quantity(_strip_unit(path_or_name))
    head = f"{q.name} {q.symbol}".strip()
    return f"{head} [{q.unit}]" if q.unit else head


def short_name(path_or_name: str) -> str:
    """Physical name and symbol without unit (for titles), e.g. ``"total delay T"``.

    Parameters
    ----------
    path_or_name : str
        A dotted parameter path or column name, with or without a unit suffix.

    Returns
    -------
    str
        The quantity's name and symbol.
    """
    q = quantity(_strip_unit(path_or_name))
    return f"{q.name} {q.symbol}".strip()


def scale_of(path_or_name: str) -> float:
    """SI → display factor of a quantity (1e3 for a delay shown in ms).

    Parameters
    ----------
    path_or_name : str
        A dotted parameter path or column name.

    Returns
    -------
    float
        The factor from SI to the display unit.
    """
    return quantity(_strip_unit(path_or_name)).scale


def _strip_unit(text: str) -> str:
    text = str(text)
    m = re.match(r"^([A-Za-z0-9_.]+) \[[^\]]*\]$", text)
    return m.group(1) if m else text


def tick_labels(values, scale: float = 1.0) -> list[str]:
    """Tick texts of axis values in display units (up to four significant digits).

    Parameters
    ----------
    values : array_like
        Axis values in SI units.
    scale : float, optional
        SI → display factor (:func:`scale_of`).

    Returns
    -------
    list of str
        One text per value.
    """
    return [f"{float(v) * scale:.4g}" if abs(float(v) * scale) < 1e4 else f"{float(v) * scale:.3g}"
            for v in np.asarray(values, dtype=float)]


def unit_axis(ax, which: str, path_or_name: str):
    """Label an axis with a quantity's physical name and show its ticks in display units.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes.
    which : {"x", "y"}
        Which axis.
    path_or_name : str
        See :func:`quantity`; the data stay in SI units, only the tick texts are scaled.

    Returns
    -------
    matplotlib.axis.Axis
        The labelled axis.

    References
    ----------
    docs/sweep-spec.md.
    """
    from matplotlib.ticker import FuncFormatter

    axis = ax.xaxis if which == "x" else ax.yaxis
    s = scale_of(path_or_name)
    if s != 1.0:
        axis.set_major_formatter(FuncFormatter(lambda v, _pos: f"{v * s:.4g}"))
    axis.set_label_text(label(path_or_name))
    return axis


def log_if_decades(ax, values, which: str = "y", decades: float = 2.0) -> bool:
    """Log scale on ``which`` axis when the positive finite ``values`` span more than ``decades``.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes.
    values : array_like
        The values shown along the axis.
    which : str, optional
        ``"x"`` or ``"y"``.
    decades : float, optional
        Span (max/min, in decades) above which the axis becomes logarithmic.

    Returns
    -------
    bool
        Whether the scale was set to log.
    """
    v = np.asarray(values, dtype=float).ravel()
    v = v[np.isfinite(v) & (v > 0)]
    if v.size and v.max() / v.min() > 10.0 ** decades:
        (ax.set_xscale if which == "x" else ax.set_yscale)("log")
        return True
    return False


def symlog_if_decades(ax, *arrays, which: str = "y", decades: float = 3.0) -> bool:
    """Symmetric-log scale when |values| exceed the initial scale (first 5 % of each array) by
    more than ``decades``; the linear band is that initial scale.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes.
    *arrays : array_like
        The series shown along the axis.
    which : str, optional
        ``"x"`` or ``"y"``.
    decades : float, optional
        Ratio (in decades) of the largest |value| to the initial scale above which the axis becomes
        symmetric-log.

    Returns
    -------
    bool
        Whether the scale was set to symlog.
    """
    arrs = [np.asarray(a, float).ravel() for a in arrays if np.size(a)]
    if not arrs:
        return False
    v = np.abs(np.concatenate(arrs))
    v = v[np.isfinite(v)]
    early = np.abs(np.concatenate([a[: max(1, a.size // 20)] for a in arrs]))
    early = early[np.isfinite(early) & (early > 0)]
    lin = float(early.max()) if early.size else float(np.median(v[v > 0])) if np.any(v > 0) else 1.0
    if v.size and v.max() > 10.0 ** decades * lin:
        (ax.set_xscale if which == "x" else ax.set_yscale)("symlog", linthresh=lin)
        return True
    return False


def plain_formatter():
    """A tick formatter without offset text and without a shared ×10ⁿ factor: every tick shows its
    full value with as many digits as the tick spacing needs.

    Returns
    -------
    matplotlib.ticker.ScalarFormatter
        The formatter.
    """
    from matplotlib.ticker import ScalarFormatter

    f = ScalarFormatter(useOffset=False)
    f.set_scientific(False)
    return f


def colorbar(fig, mappable, ax, label_text: str, *, extend: str = "neither", fontsize: float = SMALL + 1,
             log: bool = False):
    """A colour bar with its label and plain tick texts (never an offset text over the title).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.
    mappable : matplotlib.cm.ScalarMappable
        What the bar shows (an image, a mesh).
    ax : matplotlib.axes.Axes
        The axes the bar is placed beside.
    label_text : str
        The bar's label (quantity and unit).
    extend : str, optional
        Matplotlib's ``extend`` (``"neither"``, ``"min"``, ``"max"``, ``"both"``).
    fontsize : float, optional
        Label size [pt]; tick texts one point smaller.
    log : bool, optional
        A log-scaled bar keeps matplotlib's tick formatter.

    Returns
    -------
    matplotlib.colorbar.Colorbar
        The colour bar.
    """
    cb = fig.colorbar(mappable, ax=ax, extend=extend)
    cb.set_label(label_text, fontsize=fontsize)
    if not log:
        cb.ax.yaxis.set_major_formatter(plain_formatter())
        cb.ax.yaxis.get_offset_text().set_visible(False)
    cb.ax.tick_params(labelsize=fontsize - 1)
    return cb


def grid(ax, **kw) -> None:
    """The common grid.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes.
    **kw
        Overrides of the grid's ``which`` and ``alpha`` and further ``Axes.grid`` arguments.
    """
    ax.grid(True, which=kw.pop("which", GRID["which"]), alpha=kw.pop("alpha", GRID["alpha"]), **kw)


def rc() -> dict:
    """matplotlib rc parameters of the look (for ``matplotlib.rc_context``).

    Returns
    -------
    dict
        rc parameter names and values.
    """
    return {"font.size": FONTSIZE, "axes.titlesize": FONTSIZE, "axes.labelsize": FONTSIZE - 1,
            "legend.fontsize": SMALL, "xtick.labelsize": SMALL + 0.5, "ytick.labelsize": SMALL + 0.5,
            "figure.dpi": DPI, "savefig.dpi": DPI, "axes.formatter.useoffset": False}


def new_figure(figsize=None, *, layout: str | None = "constrained"):
    """A :class:`matplotlib.figure.Figure` at :data:`DPI` on its own Agg canvas (pyplot and the global
    backend are never touched); ``layout="constrained"`` by default so that no label is cut off.

    Parameters
    ----------
    figsize : tuple of float or None, optional
        (width, height) [in]; None for ``FIGSIZE["single"]``.
    layout : str or None, optional
        Matplotlib layout engine; None for none.

    Returns
    -------
    matplotlib.figure.Figure
        The empty figure.
    """
    import matplotlib
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    with matplotlib.rc_context(rc()):
        fig = Figure(figsize=figsize or FIGSIZE["single"], dpi=DPI, layout=layout)
    FigureCanvasAgg(fig)
    return fig


def png(fig, *, tight: bool = True) -> bytes:
    """Render ``fig`` to PNG bytes at :data:`DPI` (``bbox_inches="tight"``: nothing cut off).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.
    tight : bool, optional
        Crop to the drawn content (``bbox_inches="tight"``).

    Returns
    -------
    bytes
        The PNG file's content.
    """
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI, bbox_inches="tight" if tight else None, pad_inches=0.08)
    return buf.getvalue()
