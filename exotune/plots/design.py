"""Bode plots of ``exotune design --plots DIR``: the nominal C4, C5, Ĉ5, C7 and G_v, and C5 against
the virtual motor Ĉ5. The numbers come from :func:`exotune.analysis.design_summary.design_bode_figures`;
this module only draws them (magnitude in dB, phase in deg vs Hz) and renders PNG bytes in memory.
"""

from __future__ import annotations

from . import style

__all__ = ["design_plots", "bode_png"]


def bode_png(curves, title: str, ylabel: str) -> bytes:
    """One Bode figure rendered to PNG bytes (Agg).

    Parameters
    ----------
    curves : list of (label, f_hz, magnitude_db, phase_deg)
        As returned by :func:`exotune.analysis.design_summary.bode_curves`.
    title : str
        Figure title.
    ylabel : str
        Unit of the magnitude (the dB reference).

    Returns
    -------
    bytes
        The PNG image.

    References
    ----------
    docs/cli.md#design.
    """
    fig = style.new_figure(style.FIGSIZE["bode"])
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    for label, f, mag_db, phase_deg in curves:
        ax1.semilogx(f, mag_db, label=label)
        ax2.semilogx(f, phase_deg, label=label)
    ax1.set_ylabel(f"magnitude |·| [dB re 1 {ylabel}]")
    ax2.set_ylabel("phase ∠ [deg]")
    ax2.set_xlabel("frequency f [Hz]")
    ax1.set_title(title)
    for ax in (ax1, ax2):
        style.grid(ax)
    if len(curves) > 1:
        ax1.legend()
    return style.png(fig)


def design_plots(figures) -> dict[str, bytes]:
    """The Bode figures of a design, rendered in memory (nothing is written).

    Parameters
    ----------
    figures : dict
        ``{file name: (title, unit, curves)}`` as computed by
        :func:`exotune.analysis.design_summary.design_bode_figures` (this module only draws them).

    Returns
    -------
    dict
        ``{file name: PNG bytes}``: ``bode_C4.png``, ``bode_C5.png``, ``bode_C5_hat.png``,
        ``bode_C7_nominal.png``, ``bode_G_v.png`` and ``bode_C5_vs_C5_hat.png``.

    References
    ----------
    Paper §II-C–§IV; docs/cli.md#design.
    """
    return {name: bode_png(curves, title, unit) for name, (title, unit, curves) in figures.items()}
