"""Text of ``exotune design``: gains, compliance shape, poles and zeros, approximation, warnings."""

from __future__ import annotations

import math

from ..errors import printable
from .numbers import fmt_num, unit_text

__all__ = ["format_design", "format_roots"]


def format_roots(entries) -> list[str]:
    """Poles or zeros as text lines, one per real root or complex-conjugate pair.

    Parameters
    ----------
    entries : list of dict
        Roots as given by :func:`exotune.analysis.design_summary.root_entries`.

    Returns
    -------
    list of str
        ``"re ± im j rad/s (f_n = … Hz, ζ = …)"`` lines, ``["none"]`` without roots.

    References
    ----------
    docs/cli.md#design.
    """
    lines = []
    for r in entries:
        if r["im"] < 0:
            continue
        if r["im"] > 0:
            z = f"{fmt_num(r['re'], 5)} ± {fmt_num(r['im'], 5)}j"
        else:
            z = f"{fmt_num(r['re'], 5)}"
        zeta = "" if r["damping_ratio"] is None or (isinstance(r["damping_ratio"], float) and math.isnan(r["damping_ratio"])) else f", ζ = {fmt_num(r['damping_ratio'], 3)}"
        lines.append(f"{z} rad/s (f_n = {fmt_num(r['natural_frequency_hz'], 4)} Hz{zeta})")
    return lines or ["none"]


def format_design(rep: dict) -> str:
    """Readable text for ``exotune design`` (units on every number).

    Parameters
    ----------
    rep : dict
        The result of :func:`exotune.analysis.design_summary.design_report`.

    Returns
    -------
    str
        The report, lines joined by newlines (no trailing newline).

    References
    ----------
    Paper §IV; docs/cli.md#design.
    """
    out = []
    src = f" — {printable(rep['source'])}" if rep.get("source") else ""  # a path: its control characters escaped
    out.append(f"exotune {rep['exotune_version']} design{src}")
    out.append("Double compliance shaping (paper §IV, docs/method.md#double-compliance-shaping).")
    out.append("Gain convention: " + rep["gain_convention_note"] + ".")
    out.append("")
    out.append("Controller gains")
    for k, v in rep["gains"].items():
        out.append(f"  {k:<8} {fmt_num(v):>14}  {unit_text(rep['units'][k])}")
    out.append("")
    out.append("Compliance shape  C4(s) = (s² + B̃2 s + K̃2) / (K_s (s² + B̃1 s + K̃1)), virtual motor Ĵ_m, B̂_m")
    for k, v in rep["shape"].items():
        out.append(f"  {k:<9} {fmt_num(v):>13}  {unit_text(rep['shape_units'][k])}")
    out.append("")
    out.append("Nominal transfer functions (zero delay, no filters); poles and zeros in rad/s")
    for name, tf in rep["transfer_functions"].items():
        out.append(f"  {name} = {tf['transfer']} [{unit_text(tf['units'])}]: {tf['description']}")
        for label in ("poles", "zeros"):
            rows = format_roots(tf[label])
            out.append(f"    {label}: {rows[0]}")
            out.extend(f"           {r}" for r in rows[1:])
    out.append("")
    ap = rep["approximation"]
    out.append(
        f"Approximation Ĉ5 ≈ C5: {ap['criterion']} for f < {fmt_num(ap['valid_below_hz'], 4)} Hz "
        f"(Ĵ_m/J_j = {fmt_num(ap['J_m_hat_over_J_j'], 4)})"
    )
    out.append("")
    if rep["warnings"]:
        out.append("Warnings")
        out.extend(f"  - {w}" for w in rep["warnings"])
    else:
        out.append("Warnings: none")
    return "\n".join(out)
