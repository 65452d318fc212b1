"""The figures of a sweep report, rendered in memory as PNG bytes (matplotlib, Agg): heatmaps over
a pair of axes (+inf in the colour bar's "over" colour, NaN grey), panels of heatmaps, profiles
against one axis."""

from __future__ import annotations

import io
import math

import numpy as np

__all__ = ["heatmap", "heatmap_panels", "profile_figure"]


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _ticks(values: np.ndarray, maxn: int = 8):
    n = values.size
    step = max(1, int(math.ceil(n / maxn)))
    idx = list(range(0, n, step))
    if idx[-1] != n - 1 and n - 1 - idx[-1] >= step / 2:
        idx.append(n - 1)
    return idx, [f"{values[i]:.3g}" for i in idx]


def _png(fig) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    _plt().close(fig)
    return buf.getvalue()


def _draw_heatmap(fig, ax, grid: np.ndarray, xvals, yvals, xlabel, ylabel, title, cbar_label, *, vmin=None,
                  vmax=None, cmap="viridis", log=False, annotate=False, fmt="{:.2f}", fontsize=10) -> None:
    """Draw grid[iy, ix] into ``ax`` with a colour bar; +inf cells get the colormap's "over" colour,
    NaN cells are grey."""
    from matplotlib import colors

    plt = _plt()
    data = np.array(grid, dtype=float)
    finite = data[np.isfinite(data)]
    has_over = bool(np.any(np.isposinf(data)))
    has_under = bool(np.any(np.isneginf(data)))
    if log:
        pos = finite[finite > 0]
        if pos.size == 0 or (pos.max() / pos.min() < 10):
            log = False
    if vmin is None:
        vmin = (finite[finite > 0].min() if log else finite.min()) if finite.size else 0.0
    if vmax is None:
        vmax = finite.max() if finite.size else 1.0
    if vmax <= vmin:
        vmax = vmin + (abs(vmin) * 0.01 or 1.0)
    cm = plt.get_cmap(cmap).with_extremes(bad="#d0d0d0", over="#ffffff" if cmap.endswith("_r") else "#ff00ff",
                                          under="#000000")
    if log:
        data = np.where((data <= 0) & np.isfinite(data), np.nan, data)
        norm = colors.LogNorm(vmin=vmin, vmax=vmax)
    else:
        norm = colors.Normalize(vmin=vmin, vmax=vmax)
    plot = np.where(np.isposinf(data), vmax * 10 if vmax > 0 else vmax + 1e300, data)
    plot = np.where(np.isneginf(plot), -1e300, plot)
    im = ax.imshow(np.ma.masked_invalid(plot), origin="lower", aspect="auto", cmap=cm, norm=norm,
                   interpolation="nearest")
    extend = "both" if has_over and has_under else "max" if has_over else "min" if has_under else "neither"
    cb = fig.colorbar(im, ax=ax, extend=extend)
    cb.set_label(cbar_label + ("  (arrow: ∞)" if has_over else ""), fontsize=fontsize - 1)
    xi, xl = _ticks(np.asarray(xvals))
    yi, yl = _ticks(np.asarray(yvals))
    ax.set_xticks(xi, xl, rotation=45, ha="right")
    ax.set_yticks(yi, yl)
    ax.set_xlabel(xlabel, fontsize=fontsize - 1)
    ax.set_ylabel(ylabel, fontsize=fontsize - 1)
    ax.set_title(title, fontsize=fontsize)
    if annotate:
        for iy in range(grid.shape[0]):
            for ix in range(grid.shape[1]):
                v = grid[iy, ix]
                if not np.isnan(v):
                    pv = plot[iy, ix]
                    rgba = cm(norm(pv)) if np.isfinite(pv) and not (log and pv <= 0) else (1, 1, 1, 1)
                    lum = 0.299 * rgba[0] + 0.587 * rgba[1] + 0.114 * rgba[2]
                    ax.text(ix, iy, "∞" if np.isinf(v) else fmt.format(v), ha="center", va="center", fontsize=7,
                            color="white" if lum < 0.5 else "black")


def heatmap(grid: np.ndarray, xvals, yvals, xlabel, ylabel, title, cbar_label, **kw) -> bytes:
    """One heatmap figure as PNG bytes (see :func:`_draw_heatmap`)."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7.2, 5.4))
    kw.setdefault("annotate", grid.size <= 144)
    _draw_heatmap(fig, ax, grid, xvals, yvals, xlabel, ylabel, title, cbar_label, **kw)
    fig.subplots_adjust(left=0.15, right=0.98, bottom=0.17, top=0.92)
    return _png(fig)


def heatmap_panels(panels: list[dict], xvals, yvals, xlabel, ylabel, suptitle) -> bytes:
    """Several heatmaps over the same pair of axes in one figure (one panel per metric)."""
    plt = _plt()
    n = len(panels)
    ncols = 1 if n == 1 else 2 if n <= 4 else 3
    nrows = -(-n // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(5.6 * ncols, 4.3 * nrows + 0.5), squeeze=False)
    for ax, p in zip(axes.ravel(), panels):
        grid = p.pop("grid")
        _draw_heatmap(fig, ax, grid, xvals, yvals, xlabel, ylabel, fontsize=9,
                      annotate=grid.size <= 36, **p)
    for ax in axes.ravel()[n:]:
        ax.set_visible(False)
    fig.suptitle(suptitle, fontsize=11)
    H = 4.3 * nrows + 0.5
    fig.subplots_adjust(left=0.25 / ncols, right=0.97, bottom=0.75 / H, top=1 - 0.95 / H, wspace=0.45,
                        hspace=0.6)
    return _png(fig)


def profile_figure(x, series, xlabel, logx, title) -> bytes:
    """Stacked panels of ``series`` [(label, y)] against ``x`` as PNG bytes (+inf drawn as markers
    at the top of the finite values)."""
    plt = _plt()
    n = len(series)
    fig, axes = plt.subplots(n, 1, figsize=(7, 1.9 * n + 0.8), sharex=True, squeeze=False)
    for ax, (label, y) in zip(axes[:, 0], series):
        y = np.asarray(y, float)
        fin = np.isfinite(y)
        ax.plot(x[fin], y[fin], "o-", ms=3)
        if np.any(np.isposinf(y)):
            top = np.nanmax(y[fin]) if fin.any() else 1.0
            ax.plot(x[np.isposinf(y)], np.full(int(np.isposinf(y).sum()), top), "^", color="m", ms=5, label="∞")
            ax.legend(fontsize=7, loc="best")
        ax.set_ylabel(label, fontsize=8)
        ax.grid(True, alpha=0.3)
        if logx:
            ax.set_xscale("log")
    axes[-1, 0].set_xlabel(xlabel)
    axes[0, 0].set_title(title, fontsize=10)
    fig.tight_layout()
    return _png(fig)
