"""Text of ``exotune excite``: what was written, the band and its lines, the amplitude, the crest
factor and the frequency resolution, each with its unit (docs/identification.md#excite)."""

from __future__ import annotations

from ..errors import printable

__all__ = ["excitation_text"]


def excitation_text(e) -> str:
    """The report of an :class:`exotune.identification.excite.Excitation`.

    Parameters
    ----------
    e : Excitation
        The excitation.

    Returns
    -------
    str
        The report.
    """
    where = f"{e.path} (t [s], tau_cmd [N·m]; described in {e.sidecar})" if e.path else "not written"
    lines = [
        f"exotune excite — Schroeder-phased multisine: {where}",
        f"  {e.samples} samples at {e.sample_rate_hz:g} Hz: {e.periods} period{'' if e.periods == 1 else 's'} of "
        f"{e.period_s:.6g} s ({e.period_samples} samples), {e.duration_s:.6g} s",
        f"  band {e.f_lo_hz:g}–{e.f_hi_hz:g} Hz: {len(e.harmonics)} excited line{'' if len(e.harmonics) == 1 else 's'} "
        f"({e.selection}"
        + (f", seed {e.seed}" if e.seed is not None else "") + "), "
        + (f"{e.lines_hz[0]:.6g} Hz" if len(e.harmonics) == 1 else f"{e.lines_hz[0]:.6g}–{e.lines_hz[-1]:.6g} Hz"),
        f"  frequency resolution 1/period: {e.resolution_hz:.6g} Hz",
        f"  amplitude: peak {e.peak_nm:.6g} N·m, RMS {e.rms_nm:.6g} N·m ({e.amplitude_kind} {e.amplitude_nm:g} N·m "
        f"asked), {e.line_amplitude_nm:.4g} N·m per line",
        f"  crest factor (peak/RMS): {e.crest_factor:.3f} [–]",
        "  play it as the motor command and log tau_cmd with the measured signals; the first period is the "
        "plant's transient",
    ]
    return printable("\n".join(lines), keep="\n")  # the output's file name quoted: its control characters escaped
