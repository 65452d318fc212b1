"""Figures of the typed results (docs/api.md): each draws given numbers into an ``ax`` and
returns its matplotlib ``Figure``; none computes."""

from __future__ import annotations

import numpy as np

from . import style

__all__ = ["bode_magnitude", "compliance_phase"]


def _axes(ax, nrows: int = 1):
    if ax is not None:
        return ax.figure, ax
    fig = style.new_figure((7.0, 4.2 * nrows / 1.5 if nrows > 1 else 4.2))
    return fig, fig.add_subplot(1, 1, 1)


def bode_magnitude(curves, ax=None, title: str = ""):
    """Magnitude (dB) of named frequency responses ``[(label, f_hz, H), …]`` on a log axis.

    Parameters
    ----------
    curves : iterable of tuple
        ``(label, f_hz, H)``: frequencies [Hz] and the complex response.
    ax : matplotlib.axes.Axes or None, optional
        Where to draw; None for a new figure.
    title : str, optional
        The axes' title.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    fig, ax = _axes(ax)
    for label, f, H in curves:
        ax.semilogx(f, 20.0 * np.log10(np.abs(H)), label=label.replace("_", " "))
    ax.set_xlabel("frequency f [Hz]")
    ax.set_ylabel("magnitude [dB]")
    style.grid(ax)
    ax.legend(fontsize=8)
    if title:
        ax.set_title(title)
    return fig


def compliance_phase(f_hz, H, bands=(), ax=None, title: str = ""):
    """Phase of a compliance C(j2πf) [deg] with the passivity limits of s·C (−180°…0°) drawn and
    the non-passive ``bands`` [Hz] shaded.

    Parameters
    ----------
    f_hz : array_like
        Frequencies [Hz].
    H : array_like
        The compliance's complex response [rad/(N·m)].
    bands : iterable of tuple, optional
        Non-passive bands (lo, hi) [Hz].
    ax : matplotlib.axes.Axes or None, optional
        Where to draw; None for a new figure.
    title : str, optional
        The axes' title.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    fig, ax = _axes(ax)
    ax.semilogx(f_hz, np.degrees(np.unwrap(np.angle(H))), label="phase of C7")
    for lim in (-180.0, 0.0):
        ax.axhline(lim, color="k", lw=0.8, ls="--")
    for i, (a, b) in enumerate(bands):
        ax.axvspan(a, b, color="tab:red", alpha=0.2, label="non-passive band" if i == 0 else None)
    ax.set_xlabel("frequency f [Hz]")
    ax.set_ylabel("phase ∠C7 [deg]")
    style.grid(ax)
    ax.legend(fontsize=8)
    if title:
        ax.set_title(title)
    return fig
