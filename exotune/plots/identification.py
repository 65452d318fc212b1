"""Figures of ``exotune identify --plots``: each measured frequency response (H1 with its 99 %
coherence-weighted band) over the identified model's, the coherence, and the residual tests.
Draws what :class:`exotune.identification.validresult.Validation` holds, computes nothing."""

from __future__ import annotations

import numpy as np

from . import style

__all__ = ["bode_overlay", "residual_figure", "validation_figures"]


def bode_overlay(fr, axes=None):
    """Magnitude, phase and coherence of one :class:`FrequencyResponse`: the measured response
    with its band (coherent bins solid, the others faint) and the model. ``axes``: three axes,
    or None for a new figure. Returns the Figure.

    Parameters
    ----------
    fr : FrequencyResponse
        The measured response with its model.
    axes : sequence of matplotlib.axes.Axes or None, optional
        Magnitude, phase and coherence axes; None for a new figure.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    if axes is None:
        fig = style.new_figure((7.0, 7.0))
        axes = fig.subplots(3, 1, sharex=True, gridspec_kw={"height_ratios": [3, 2, 1]})
    am, ap, ac = axes
    f, H, M = fr.frequency_hz, fr.measured, fr.model
    low, high, z = fr.band()
    ok = fr.coherent
    mag = np.abs(H)
    am.fill_between(f, low, high, color="C0", alpha=0.2, lw=0, label="99 % band (coherence)")
    am.loglog(f, np.where(ok, mag, np.nan), "C0.-", ms=3, label="measured H1, γ² ≥ 0.9")
    am.loglog(f, np.where(ok, np.nan, mag), ".", color="C0", alpha=0.3, ms=2, label="measured, γ² < 0.9")
    am.loglog(f, np.abs(M), "C1-", label="identified model")
    am.set_ylabel(f"|{fr.output_name} / ({fr.input_name})| [{fr.unit}]")
    am.set_title(f"{fr.name}: {fr.output_name} / ({fr.input_name}), {fr.averages} averages")
    # phases unwrapped: the model's along frequency, the measured one as the model's plus the
    # (wrapped) difference, so that neither jumps by 360° between ±180°
    pm = np.unwrap(np.angle(M))
    ph = np.degrees(pm + np.angle(H * np.conj(M)))
    ap.fill_between(f, ph - np.degrees(z), ph + np.degrees(z), color="C0", alpha=0.2, lw=0)
    ap.semilogx(f, np.where(ok, ph, np.nan), "C0.-", ms=3)
    ap.semilogx(f, np.degrees(pm), "C1-")
    ap.set_ylabel("phase [deg]")
    ac.semilogx(f, fr.coherence, "C2-")
    ac.axhline(0.9, color="k", ls=":", lw=0.8)
    ac.set_ylim(0, 1.05)
    ac.set_ylabel("coherence γ²")
    ac.set_xlabel("frequency [Hz]")
    am.legend(fontsize=7)
    for a in axes:
        a.grid(True, which="both", alpha=0.3)
    return am.figure


def residual_figure(test, axes=None):
    """Autocorrelation of a simulation error with its whiteness bound, and its cross-correlation
    with the input with the bound. ``axes``: two axes, or None. Returns the Figure.

    Parameters
    ----------
    test : ResidualTest
        The residual test of one simulated output.
    axes : sequence of matplotlib.axes.Axes or None, optional
        Two axes; None for a new figure.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    if axes is None:
        fig = style.new_figure((7.0, 5.0))
        axes = fig.subplots(2, 1)
    a0, a1 = axes
    a0.stem(test.lags, test.autocorrelation, basefmt=" ")
    a0.axhspan(-test.auto_bound, test.auto_bound, color="C1", alpha=0.2, label="99 % bound ±2.58/√N")
    a0.set_ylabel(f"autocorrelation of the {test.output} error")
    a0.legend(fontsize=7)
    a1.stem(test.cross_lags, test.cross_correlation, basefmt=" ")
    a1.axhspan(-test.cross_bound, test.cross_bound, color="C1", alpha=0.2, label="99 % bound")
    a1.set_ylabel(f"cross-correlation with {test.input_name}")
    a1.set_xlabel("lag [samples] (positive: the input leads)")
    a1.legend(fontsize=7)
    return a0.figure


def validation_figures(v) -> dict[str, bytes]:
    """PNG files of a :class:`Validation`: ``bode_<name>.png`` per frequency response,
    ``residuals_<output>.png`` per simulated output.

    Parameters
    ----------
    v : Validation
        The validation of a plant estimate.

    Returns
    -------
    dict of str to bytes
        File name → PNG content.
    """
    files = {f"bode_{fr.name}.png": style.png(bode_overlay(fr)) for fr in v.frequency_responses}
    names = {"θ_m": "theta_m", "θ_j": "theta_j", "τ_s": "tau_s", "τ_c": "tau_c"}
    files.update({f"residuals_{names.get(t.output, t.output)}.png": style.png(residual_figure(t)) for t in v.residual_tests})
    return files
