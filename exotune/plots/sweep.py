"""The figures of a sweep report, rendered in memory as PNG bytes (matplotlib, Agg, the look of
:mod:`exotune.plots.style`): heatmaps over a pair of axes (+inf in the colour bar's "over" colour,
NaN grey and explained under the figure), panels of heatmaps, profiles against one axis.

Axis labels given as configuration paths (``implementation.delay_s [s]``, the report's labels) are
shown by their physical name with the display unit and the tick values scaled into it ("total
delay T [ms]"); paths in titles are replaced by the physical names. Colour bars carry plain tick
texts (no offset text); values are written into the cells only when the cells are large enough.
"""

from __future__ import annotations

import math
import re
import textwrap

import numpy as np

from .style import (BAD_COLOR, BAD_MEANING, FIGSIZE, colorbar, grid, label, new_figure, png, scale_of, short_name,
                    tick_labels)

__all__ = ["draw_heatmap", "heatmap", "heatmap_panels", "profile_figure"]

_PATH = re.compile(r"\b(?:plant|design|implementation)\.[A-Za-z0-9_.]*[A-Za-z0-9_]")
_MIN_CELL_PT = (26.0, 11.0)  # width, height of a cell (points) below which it is not annotated


def _physical(text: str) -> str:
    """``text`` with every configuration path replaced by its physical name."""
    return _PATH.sub(lambda m: short_name(m.group(0)), str(text))


def _ticks(values: np.ndarray, scale: float = 1.0, maxn: int = 8):
    n = values.size
    step = max(1, int(math.ceil(n / maxn)))
    idx = list(range(0, n, step))
    if idx[-1] != n - 1 and n - 1 - idx[-1] >= step / 2:
        idx.append(n - 1)
    return idx, tick_labels(values[idx], scale)


def _cells_fit(fig, axes_shapes) -> list[bool]:
    """Whether a cell of each ``(ax, shape)`` (rows × columns ``shape``) has room for a short
    annotation: one layout pass of the whole figure (no rendering), then every axes' size."""
    fig.draw_without_rendering()  # final layout, so that the axes' sizes are known
    fits = []
    for ax, shape in axes_shapes:
        bb = ax.get_window_extent()
        w = bb.width * 72.0 / fig.dpi / max(shape[1], 1)
        h = bb.height * 72.0 / fig.dpi / max(shape[0], 1)
        fits.append(w >= _MIN_CELL_PT[0] and h >= _MIN_CELL_PT[1])
    return fits


def _norm_and_cmap(data, cmap, vmin, vmax, log):
    from matplotlib import colormaps, colors

    finite = data[np.isfinite(data)]
    if log:
        pos = finite[finite > 0]
        if pos.size == 0 or (pos.max() / pos.min() < 10):
            log = False
    if vmin is None:
        vmin = (finite[finite > 0].min() if log else finite.min()) if finite.size else 0.0
    if vmax is None:
        vmax = finite.max() if finite.size else 1.0
    if vmax - vmin <= 1e-6 * max(abs(vmin), abs(vmax)) and vmax > vmin and not log:
        vmin = vmax  # constant to 6 digits: one colour, not a bar of rounding noise
    if vmax <= vmin:
        vmax = vmin + (abs(vmin) * 0.01 or 1.0)
    cm = colormaps[cmap].with_extremes(bad=BAD_COLOR, over="#ffffff" if cmap.endswith("_r") else "#ff00ff",
                                       under="#000000")
    norm = colors.LogNorm(vmin=vmin, vmax=vmax) if log else colors.Normalize(vmin=vmin, vmax=vmax)
    return cm, norm, log, vmax


def _draw_heatmap(fig, ax, grid_: np.ndarray, xvals, yvals, xlabel, ylabel, title, cbar_label, *, annotate=False,
                  **kw) -> dict:
    """Draw grid[iy, ix] into ``ax`` with a colour bar; +inf cells get the colormap's "over" colour,
    NaN cells are grey; the values written into the cells when ``annotate`` and they fit. Returns
    what the figure's note must explain (``{"nan": bool, "inf": bool}``)."""
    flags, cells = _draw_cells(fig, ax, grid_, xvals, yvals, xlabel, ylabel, title, cbar_label, **kw)
    if annotate and _cells_fit(fig, [(ax, np.shape(grid_))])[0]:
        _annotate(ax, *cells)
    return flags


def _draw_cells(fig, ax, grid_: np.ndarray, xvals, yvals, xlabel, ylabel, title, cbar_label, *, vmin=None,
                vmax=None, cmap="viridis", log=False, fmt="{:.2f}", fontsize=10):
    """:func:`_draw_heatmap` without the cell values: (its flags, the arguments of
    :func:`_annotate` after ``ax``) — a figure of several panels lays itself out once before it
    writes the values of those whose cells fit."""
    data = np.array(grid_, dtype=float)
    has_over = bool(np.any(np.isposinf(data)))
    cm, norm, log, vmax = _norm_and_cmap(data, cmap, vmin, vmax, log)
    zero = log & np.isfinite(data) & (data <= 0)  # not on a log scale: the "under" colour
    has_under = bool(np.any(np.isneginf(data)) or np.any(zero))
    plot = np.where(np.isposinf(data), vmax * 10 if vmax > 0 else vmax + 1e300, data)
    plot = np.where(np.isneginf(plot) | zero, norm.vmin * 1e-3 if log else -1e300, plot)
    im = ax.imshow(np.ma.masked_invalid(plot), origin="lower", aspect="auto", cmap=cm, norm=norm,
                   interpolation="nearest")
    extend = "both" if has_over and has_under else "max" if has_over else "min" if has_under else "neither"
    colorbar(fig, im, ax, label(cbar_label) + ("  (arrow: ∞)" if has_over else ""), extend=extend,
             fontsize=fontsize - 1, log=log)
    sx, sy = scale_of(xlabel), scale_of(ylabel)
    xi, xl = _ticks(np.asarray(xvals, dtype=float), sx)
    yi, yl = _ticks(np.asarray(yvals, dtype=float), sy)
    ax.set_xticks(xi, xl, rotation=45, ha="right")
    ax.set_yticks(yi, yl)
    ax.set_xlabel(label(xlabel), fontsize=fontsize - 1)
    ax.set_ylabel(label(ylabel), fontsize=fontsize - 1)
    ax.set_title(_physical(title), fontsize=fontsize)
    flags = {"nan": bool(np.any(np.isnan(data))), "inf": has_over, "zero": bool(np.any(zero))}
    return flags, (grid_, plot, cm, norm, log, fmt)


def _annotate(ax, grid_, plot, cm, norm, log, fmt) -> None:
    for iy in range(grid_.shape[0]):
        for ix in range(grid_.shape[1]):
            v = grid_[iy, ix]
            if not np.isnan(v):
                pv = plot[iy, ix]
                rgba = cm(norm(pv)) if np.isfinite(pv) else (1, 1, 1, 1)
                lum = 0.299 * rgba[0] + 0.587 * rgba[1] + 0.114 * rgba[2]
                ax.text(ix, iy, "∞" if np.isinf(v) else fmt.format(v), ha="center", va="center", fontsize=6.5,
                        color="white" if lum < 0.5 else "black")


def _note(fig, flags: list[dict]) -> None:
    """The legend of the cell colours that are not on the colour bar."""
    parts = []
    if any(f["nan"] for f in flags):
        parts.append(BAD_MEANING)
    if any(f["inf"] for f in flags):
        parts.append("colour of the colour bar's upper arrow: ∞ (no crossover, never reached, or nothing stable)")
    if any(f.get("zero") for f in flags):
        parts.append("black (lower arrow): 0 on a log scale (stiffest stable spring 0: unstable at the range's "
                     "lower end)")
    if parts:
        fig.text(0.5, 0.0, "Cells — " + ";\n".join(parts) + ".", ha="center", va="top", fontsize=7.5)


def draw_heatmap(ax, grid: np.ndarray, xvals, yvals, xlabel, ylabel, title, cbar_label, **kw) -> dict:
    """Draw grid[iy, ix] into the existing ``ax`` (with its colour bar): +inf cells in the
    colormap's "over" colour, NaN cells grey. Returns what a note must explain
    (``{"nan": bool, "inf": bool, "zero": bool}``).

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes to draw into.
    grid : numpy.ndarray
        Cell values (ny, nx), in display units.
    xvals, yvals : array_like
        The axis values (SI units).
    xlabel, ylabel : str
        The axes' parameter paths or labels.
    title : str
        The panel's title.
    cbar_label : str
        The colour bar's label (quantity and unit).
    **kw
        ``vmin``, ``vmax``, ``cmap``, ``log``, ``annotate``, ``fmt``, ``fontsize``.

    Returns
    -------
    dict
        Whether the grid has NaN, +inf and (on a log scale) non-positive cells.
    """
    return _draw_heatmap(ax.figure, ax, grid, xvals, yvals, xlabel, ylabel, title, cbar_label, **kw)


def heatmap(grid: np.ndarray, xvals, yvals, xlabel, ylabel, title, cbar_label, **kw) -> bytes:
    """One heatmap figure as PNG bytes (see :func:`_draw_heatmap`).

    Parameters
    ----------
    grid : numpy.ndarray
        Cell values (ny, nx), in display units.
    xvals, yvals : array_like
        The axis values (SI units).
    xlabel, ylabel : str
        The axes' parameter paths or labels.
    title : str
        The figure's title.
    cbar_label : str
        The colour bar's label (quantity and unit).
    **kw
        As :func:`draw_heatmap`; ``annotate`` defaults to True for at most 144 cells.

    Returns
    -------
    bytes
        The PNG file's content.
    """
    fig = new_figure(FIGSIZE["single"])
    ax = fig.add_subplot(1, 1, 1)
    kw.setdefault("annotate", grid.size <= 144)
    _note(fig, [_draw_heatmap(fig, ax, grid, xvals, yvals, xlabel, ylabel, title, cbar_label, **kw)])
    return png(fig)


def heatmap_panels(panels: list[dict], xvals, yvals, xlabel, ylabel, suptitle) -> bytes:
    """Several heatmaps over the same pair of axes in one figure (one panel per metric); a metric
    that is the same in every cell (to six digits) is named with its value under the title instead
    of drawing a panel of one colour.

    Parameters
    ----------
    panels : list of dict
        One per metric: ``grid`` and the keyword arguments of :func:`draw_heatmap` (``title``,
        ``cbar_label``, …).
    xvals, yvals : array_like
        The axis values (SI units).
    xlabel, ylabel : str
        The axes' parameter paths.
    suptitle : str
        The figure's title.

    Returns
    -------
    bytes
        The PNG file's content.
    """
    varying, constant = [], []
    for p in panels:
        g = np.asarray(p["grid"], dtype=float)
        fin = g[np.isfinite(g)]
        same = fin.size == g.size and g.size > 1 and np.ptp(fin) <= 1e-6 * max(float(np.abs(fin).max()), 1e-300)
        (constant if same else varying).append((p, fin[0] if same else None))
    if not varying:
        varying, constant = constant, []
    panels = [p for p, _ in varying]
    if constant:
        text = "; ".join(f"{label(p['cbar_label']).rsplit(' [', 1)[0]}: {v:.4g} {p['cbar_label'].rsplit('[', 1)[-1][:-1]}"
                         for p, v in constant)
        suptitle = f"{suptitle}\n" + textwrap.fill("the same in every cell: " + text, 110)
    n = len(panels)
    ncols = 1 if n == 1 else 2 if n <= 4 else 3
    nrows = -(-n // ncols)
    w, h = FIGSIZE["panel"]
    fig = new_figure((w * ncols, h * nrows + 0.5))
    axes = np.atleast_1d(fig.subplots(nrows, ncols, squeeze=False)).ravel()
    flags, pending = [], []
    for ax, p in zip(axes, panels):
        p = dict(p)
        grid_ = np.asarray(p.pop("grid"))
        p.pop("annotate", None)
        p["fmt"] = "{:.2g}"  # two digits: the cells of a panel are small
        f, cells = _draw_cells(fig, ax, grid_, xvals, yvals, xlabel, ylabel, fontsize=9, **p)
        flags.append(f)
        if grid_.size <= 36:
            pending.append((ax, cells))
    for ax in axes[n:]:
        ax.set_visible(False)
    fig.suptitle(_physical(suptitle), fontsize=11)
    _note(fig, flags)
    if pending:  # one layout of the finished figure decides every panel (a layout per panel cost seconds each)
        for (ax, cells), fit in zip(pending, _cells_fit(fig, [(ax, np.shape(c[0])) for ax, c in pending])):
            if fit:
                _annotate(ax, *cells)
    return png(fig)


def profile_figure(x, series, xlabel, logx, title) -> bytes:
    """Stacked panels of ``series`` [(label, y)] against ``x`` as PNG bytes (+inf drawn as markers
    at the top of the finite values).

    Parameters
    ----------
    x : array_like
        The axis values (SI units).
    series : list of tuple
        ``(label, y)`` per panel.
    xlabel : str
        The axis' parameter path.
    logx : bool
        Logarithmic x axis.
    title : str
        The figure's title.

    Returns
    -------
    bytes
        The PNG file's content.
    """
    n = len(series)
    fig = new_figure((7, 1.9 * n + 0.8))
    axes = np.atleast_1d(fig.subplots(n, 1, sharex=True, squeeze=False))
    sx = scale_of(xlabel)
    xs = np.asarray(x, float) * sx
    for ax, (lab, y) in zip(axes[:, 0], series):
        y = np.asarray(y, float)
        fin = np.isfinite(y)
        ax.plot(xs[fin], y[fin], "o-", ms=3)
        if np.any(np.isposinf(y)):
            top = np.nanmax(y[fin]) if fin.any() else 1.0
            ax.plot(xs[np.isposinf(y)], np.full(int(np.isposinf(y).sum()), top), "^", color="m", ms=5, label="∞")
            ax.legend(fontsize=7, loc="best")
        name = lab.split("\n")[0]
        ax.set_ylabel(label(name) if name in ("fraction robust",) or "_" in name else lab, fontsize=8)
        grid(ax)
        if logx:
            ax.set_xscale("log")
    axes[-1, 0].set_xlabel(label(xlabel))
    axes[0, 0].set_title(_physical(title), fontsize=10)
    return png(fig)
