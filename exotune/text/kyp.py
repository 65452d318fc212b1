"""Text of the KYP passivity certificates (``exotune analyze`` and ``exotune optimize``;
docs/method.md#passivity-of-the-operator-compliance)."""

from __future__ import annotations

import math

__all__ = ["format_certificates"]


def format_certificates(certs: dict, indent: str = "  ") -> list[str]:
    """Text lines of an :func:`exotune.analysis.kyp.operator_certificates` result (or of its ``error`` entry).

    Parameters
    ----------
    certs : dict or None
        Model name → certificate (``passive``, ``shortage``, ``shortage_unit``,
        ``witness_frequency_hz`` [Hz], ``reason``), or ``error``; None for none.
    indent : str, optional
        Prefix of each line.

    Returns
    -------
    list of str
        One line per certificate.
    """
    lines = []
    for name, c in (certs or {}).items():
        if name == "error":
            lines.append(indent + str(c))
            continue
        verdict = {True: "passive (verified)", False: "NOT passive", None: "undecided"}[c["passive"]]
        sh = c["shortage"]
        line = f"{indent}KYP certificate, {c['model']}: {verdict}"
        if sh is not None and math.isfinite(sh):
            line += f"; shortage {sh:.4g} {c['shortage_unit']}"
        wf = c.get("witness_frequency_hz")
        if c["passive"] is False and wf is not None and wf == wf:
            line += (f" (Re{{jω C7}} minimum at {wf:.4g} Hz)" if math.isfinite(wf) else
                     " (Re{jω C7} approaches its infimum as ω → ∞)")
        if c["passive"] is None or sh is None or not math.isfinite(sh):
            line += f" — {c['reason']}"
        lines.append(line)
    return lines
