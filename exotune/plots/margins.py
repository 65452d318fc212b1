"""The latency-boundary figure of ``exotune analyze --plots`` (docs/method.md#latency-margin):
draws :func:`exotune.analysis.latency_margin.latency_boundaries`, computes nothing."""

from __future__ import annotations

import numpy as np

__all__ = ["latency_boundary_figure"]


def latency_boundary_figure(boundaries, margin_s: float | None = None, ax=None):
    """For each human family, the extra delay at which each member first loses stability (the
    region below a curve is stable); members already unstable at the nominal delay are marked on
    the axis; the design's latency margin is drawn as a horizontal line. Returns the Figure.

    Parameters
    ----------
    boundaries : sequence of LatencyBoundary
        Per family: the members' ``values`` (in ``unit``), their ``extra_delay_s`` [s] (NaN:
        unstable at the nominal delay), ``loop``, ``parameter`` and the nominal ``delay_s`` [s].
    margin_s : float or None, optional
        The design's latency margin [s]; None or not finite for no line.
    ax : matplotlib.axes.Axes or None, optional
        Where to draw; None for a new figure.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    from matplotlib.figure import Figure

    if ax is None:
        fig = Figure(figsize=(7.0, 4.5), layout="constrained")
        ax = fig.add_subplot(1, 1, 1)
    fig = ax.figure
    units = set()
    for b in boundaries:
        ok = np.isfinite(b.extra_delay_s)
        y = np.where(ok, b.extra_delay_s, np.nan) * 1e3
        (line,) = ax.plot(b.values, y, label=f"{b.loop.replace('_', ' ')}: {b.parameter} [{b.unit}]")
        bad = np.isnan(b.extra_delay_s)
        if bad.any():
            ax.plot(b.values[bad], np.zeros(bad.sum()), "x", color=line.get_color(), ms=4,
                    label=f"{b.loop.replace('_', ' ')}: unstable at the nominal delay")
        units.add((b.parameter, b.unit))
    if margin_s is not None and np.isfinite(margin_s):
        ax.axhline(margin_s * 1e3, color="k", ls="--", lw=1, label=f"design latency margin {margin_s * 1e3:.3g} ms")
    ax.set_xscale("log")
    ax.set_xlabel("human parameter: " + ", ".join(f"{p} [{u}]" for p, u in sorted(units)))
    ax.set_ylabel("extra delay on top of T [ms] (stable below each curve)")
    if boundaries:
        ax.set_title(f"latency boundary of the human families (T = {boundaries[0].delay_s * 1e3:.3g} ms)")
    ax.grid(True, which="both", alpha=0.3)
    if ax.get_legend_handles_labels()[0]:  # nothing drawn (no human family, no margin): no empty legend
        ax.legend(fontsize=7)
    return fig
