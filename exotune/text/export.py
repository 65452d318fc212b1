"""Text of ``exotune export``: the one-line summary of a written controller file."""

from __future__ import annotations

from ..controllerfile.model import as_controller_file
from ..errors import printable
from .numbers import sampled_verdict_word

__all__ = ["format_export"]


def format_export(doc, out) -> str:
    """One line: where the controller file went, its rate, filters and sampled-data verdicts.

    Parameters
    ----------
    doc : ControllerFile or dict
        The exported controller document (:func:`exotune.controllerfile.export_design`).
    out : str or os.PathLike
        The path it was written to.

    Returns
    -------
    str
        ``wrote OUT: F Hz, N sos filters, sampled-data loop free …, locked …; sampled-data latency margin … (required …); continuous …; run `exotune certify OUT```.

    References
    ----------
    Paper §V (its stability predictions account for the discrete-time implementation); docs/cli.md#export.
    """
    cf = as_controller_file(doc)
    sa = cf.predicted.sampled
    n = len(cf.controller.filters)
    lm = cf.predicted.latency_margin
    slm = cf.predicted.sampled_latency_margin
    req = None if cf.requirements is None else cf.requirements.latency_margin_s
    ms = lambda m: "none" if m is None else f"{m * 1e3:.4g} ms"  # noqa: E731 (None: no extra delay destabilizes)
    margin = ""
    if slm is not None:
        margin = f"; sampled-data latency margin {ms(slm['extra_delay_s'])}"
        if slm.get("extra_delay_samples") is not None:
            margin += f" ({slm['extra_delay_samples']:.4g} samples)"
    if req:
        margin += f" (required {req * 1e3:.4g} ms)"
    if lm is not None:
        margin += f"; continuous {ms(lm['extra_delay_s'])}"
    bad = cf.provenance.uncertified
    tail = (f"; WRITTEN UNCERTIFIED (--allow-uncertified): {'; '.join(bad)}" if bad
            else f"; run `exotune certify {out}`")
    # the output's path (and the file's own texts) quoted: their control characters escaped
    return printable(f"wrote {out}: {cf.sample_rate_hz:g} Hz, {n} sos filters, "
                     f"sampled-data loop free {sampled_verdict_word(sa['free_stable'])}, "
                     f"locked {sampled_verdict_word(sa['locked_stable'])}{margin}{tail}")
