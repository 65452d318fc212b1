"""Text of ``exotune export``: the one-line summary of a written controller file."""

from __future__ import annotations

from .numbers import sampled_verdict_word

__all__ = ["format_export"]


def format_export(doc: dict, out) -> str:
    """One line: where the controller file went, its rate, filters and sampled-data verdicts.

    Parameters
    ----------
    doc : dict
        The exported controller document (:func:`exotune.controllerfile.export_design`).
    out : str or os.PathLike
        The path it was written to.

    Returns
    -------
    str
        ``wrote OUT: F Hz, N sos filters, sampled-data loop free …, locked …; continuous latency margin … (required …); run `exotune certify OUT```.

    References
    ----------
    Paper §V (sampled-data implementation); docs/cli.md#export.
    """
    sa = doc["predicted"]["sampled"]
    n = len(doc["controller"]["filters"])
    lm = doc["predicted"].get("latency_margin")
    req = (doc.get("requirements") or {}).get("latency_margin_s")
    margin = ""
    if lm is not None:
        m = lm["extra_delay_s"]
        margin = ("; continuous latency margin " + ("none" if m is None else f"{m * 1e3:.4g} ms")
                  + (f" (required {req * 1e3:.4g} ms)" if req else ""))
    return (f"wrote {out}: {doc['sample_rate_hz']['value']:g} Hz, {n} sos filters, "
            f"sampled-data loop free {sampled_verdict_word(sa['free_stable'])}, "
            f"locked {sampled_verdict_word(sa['locked_stable'])}{margin}; run `exotune certify {out}`")
