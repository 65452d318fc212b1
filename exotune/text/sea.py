"""Text of ``exotune sea``: gains, compliance shape, stiffness, resonance, passivity, phase."""

from __future__ import annotations

from ..errors import printable
from .design import format_roots
from .numbers import fmt_num, unit_text

__all__ = ["format_sea"]


def format_sea(rep: dict) -> str:
    """Readable text for ``exotune sea``.

    Parameters
    ----------
    rep : dict
        The result of :func:`exotune.analysis.sea.sea_report`.

    Returns
    -------
    str
        The report, lines joined by newlines (no trailing newline).

    References
    ----------
    Paper §II-B; docs/cli.md#sea.
    """
    out = []
    src = f" — {printable(str(rep['source']))}" if rep.get("source") else ""
    out.append(f"exotune {rep['exotune_version']} sea{src}")
    out.append("SEA compliance shaping (paper §II-B): τ_m = −(K1 + B1 s) θ_m + (K2 + B2 s) τ_s (torque units)")
    out.append("")
    out.append(f"Gains (input given in {rep['input_gain_units']} units)")
    for k in ("K1", "B1", "K2", "B2"):
        out.append(
            f"  {k:<3} {fmt_num(rep['gains_torque'][k]):>13}  {unit_text(rep['gains_torque_units'][k]):<40}"
            f" = {fmt_num(rep['gains_deflection'][k])} {unit_text(rep['gains_deflection_units'][k])}"
        )
    out.append("")
    out.append("Compliance shape  C4(s) = (s² + B̃2 s + K̃2) / (K_s (s² + B̃1 s + K̃1))")
    for k, v in rep["shape"].items():
        out.append(f"  {k:<9} {fmt_num(v):>13}  {unit_text(rep['shape_units'][k])}")
    out.append("")
    st = rep["low_frequency_stiffness"]
    extra = " (K1 = 0: no position feedback, zero static stiffness)" if st == 0 else ""
    out.append(f"Low-frequency stiffness 1/C4(0) = K_s K̃1/K̃2: {fmt_num(st)} N·m/rad{extra}")
    if rep["resonance_hz"] is None:
        out.append("Resonance of C5 = θ_j/τ_j (paper eq. (10)): none (no peak of |C5(jω)|)")
    else:
        out.append(
            f"Resonance of C5 = θ_j/τ_j (paper eq. (10)): {fmt_num(rep['resonance_hz'], 5)} Hz, "
            f"peak |C5| = {fmt_num(rep['resonance_peak_compliance'], 4)} rad/(N·m)"
        )
    out.append(f"C5 poles ({'stable' if rep['c5_stable'] else 'UNSTABLE'}):")
    out.extend(f"  {r}" for r in format_roots(rep["c5_poles"]))
    p = rep["passivity"]
    out.append("")
    out.append(f"Nominal passivity conditions: {'all hold (passive)' if p['passive'] else 'NOT passive'}")
    for k, ok in p["conditions"].items():
        out.append(f"  [{'ok' if ok else 'FAIL'}] {k}")
    out.append(
        f"Phase of C4(jω): max {fmt_num(rep['max_phase_deg'], 4)} deg at {fmt_num(rep['max_phase_hz'], 4)} Hz, "
        f"min {fmt_num(rep['min_phase_deg'], 4)} deg at {fmt_num(rep['min_phase_hz'], 4)} Hz "
        "(passive compliance: phase within [−180°, 0°])"
    )
    if rep["notes"]:
        out.append("")
        out.append("Notes")
        out.extend(f"  - {n}" for n in rep["notes"])
    return "\n".join(out)
