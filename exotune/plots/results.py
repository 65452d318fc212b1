"""Figures of the sweep and optimization results (docs/api.md): each draws given numbers into an
``ax`` (a new figure when None) and returns its matplotlib ``Figure``; none computes."""

from __future__ import annotations

import numpy as np

from . import style

__all__ = ["sweep_map", "optimum_in_bounds", "pareto_front"]


def _axes(ax, size=(7.0, 4.6)):
    if ax is not None:
        return ax.figure, ax
    fig = style.new_figure(size)
    return fig, fig.add_subplot(1, 1, 1)


def sweep_map(grid, xvals, yvals, xlabel: str, ylabel: str, title: str, cbar_label: str, ax=None, **kw):
    """A sweep metric over two axes: ``grid[iy, ix]`` (one value per cell, already reduced over
    the other axes) as a heatmap with its colour bar (+inf: the "over" colour, NaN: grey).

    Parameters
    ----------
    grid : array_like
        Cell values (ny, nx), in display units.
    xvals, yvals : array_like
        The axis values (SI units).
    xlabel, ylabel : str
        The axes' parameter paths.
    title : str
        The title.
    cbar_label : str
        The colour bar's label (quantity and unit).
    ax : matplotlib.axes.Axes or None, optional
        Where to draw; None for a new figure.
    **kw
        Options of the heatmap (``vmin``, ``vmax``, ``cmap``, ``log``, ``annotate``, ``fmt``,
        ``fontsize``).

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    from .sweep import draw_heatmap

    fig, ax = _axes(ax)
    draw_heatmap(ax, np.asarray(grid, float), np.asarray(xvals, float), np.asarray(yvals, float), xlabel, ylabel,
                 title, cbar_label, **kw)
    return fig


def optimum_in_bounds(names, rel, at_bounds=(), binding_text: str = "", title: str = "", ax=None):
    """Where the optimum sits in each free parameter's bounds: ``rel`` ∈ [0, 1] per name (0: lower
    bound, 1: upper bound); parameters in ``at_bounds`` drawn in red.

    Parameters
    ----------
    names : sequence of str
        The free parameters' paths.
    rel : array_like
        Position of the optimum in each one's bounds, in [0, 1].
    at_bounds : iterable of str, optional
        Parameters at a bound.
    binding_text : str, optional
        The binding constraints, shown under the title.
    title : str, optional
        The title.
    ax : matplotlib.axes.Axes or None, optional
        Where to draw; None for a new figure.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    fig, ax = _axes(ax, (7.0, 0.6 + 0.45 * max(len(names), 1)))
    y = np.arange(len(names))
    colors = ["tab:red" if n in set(at_bounds) else "tab:blue" for n in names]
    ax.barh(y, np.ones(len(names)), color="0.92", edgecolor="0.6")
    ax.scatter(np.asarray(rel, float), y, color=colors, zorder=3, s=40)
    ax.set_yticks(y, [n.replace("implementation.", "").replace("design.", "") for n in names], fontsize=8)
    ax.set_xlim(-0.05, 1.05)
    ax.set_xticks([0, 0.5, 1], ["lower bound", "", "upper bound"])
    ax.set_title(title + (f"\nbinding: {binding_text}" if binding_text else ""), fontsize=9)
    style.grid(ax)
    return fig


def pareto_front(objective, robust_fraction, optimum=None, objective_label: str = "objective", ax=None):
    """The non-dominated designs (objective, fraction of the human range robust) of an
    optimization, with the returned optimum marked.

    Parameters
    ----------
    objective : array_like
        The front's objective values.
    robust_fraction : array_like
        Their robust fractions [–].
    optimum : tuple of float or None, optional
        (objective, robust fraction) of the returned design; None for no marker.
    objective_label : str, optional
        The x axis' label.
    ax : matplotlib.axes.Axes or None, optional
        Where to draw; None for a new figure.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    fig, ax = _axes(ax)
    ax.plot(np.asarray(objective, float), np.asarray(robust_fraction, float), "o-", ms=4, label="Pareto front")
    if optimum is not None:
        ax.plot([optimum[0]], [optimum[1]], "*", ms=14, color="tab:red", label="returned design")
    ax.set_xlabel(objective_label)
    ax.set_ylabel("robust fraction [–]")
    style.grid(ax)
    ax.legend(fontsize=8)
    return fig
