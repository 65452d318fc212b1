"""Text of the verdicts of record of a design with a sample rate (``exotune analyze``, first
section; docs/method.md#one-model-of-record)."""

from __future__ import annotations

from ..errors import printable
from .certify import family_line, margin_line, schedule_entry_line
from .numbers import sampled_verdict_word

__all__ = ["format_verdicts"]


def format_verdicts(sd: dict) -> list[str]:
    """Lines of the sampled-data verdicts of record (the ``sampled_data`` section of ``exotune
    analyze --json`` with a rate, :class:`exotune.controllerfile.verdicts.SampledVerdicts`): the
    verdict, the free and locked loops, every family's intervals, the latency margin
    against its requirement and, when the exported file would not certify, why.

    Parameters
    ----------
    sd : dict
        The verdicts of record (``SampledVerdicts.to_dict()``).

    Returns
    -------
    list of str
        The lines.
    """
    req = sd["requirements"]
    lines = [f"Sampled-data verdicts of record at {sd['sample_rate_hz']:g} Hz, delay {sd['delay_s'] * 1e3:.6g} ms "
             f"({sd['delay_samples']:.4g} samples) — the loop the exported controller runs, as certify judges it:",
             "  " + ("CERTIFIABLE: export writes this controller and certify accepts it" if sd["certifiable"] else
                     "NOT CERTIFIABLE: export refuses this controller (--allow-uncertified writes it) and certify "
                     "rejects it"),
             f"  free (cuff free): {sampled_verdict_word(sd['free_stable'])} (spectral radius "
             f"{sd['free_spectral_radius']:.9f}); locked joint: {sampled_verdict_word(sd['locked_stable'])}"]
    lines += [family_line(h) for h in sd["humans"] + sd["environment"]]
    for e in sd.get("gain_schedule") or []:
        lines.append(schedule_entry_line(e))
    lines.append(margin_line({**sd["latency_margin"], "required_s": req.get("latency_margin_s")})
                 + f" ({printable(str(req.get('source')))})")  # the file's own text: no terminal controls
    lines += [f"  - {p}" for p in sd["problems"]]
    return lines
