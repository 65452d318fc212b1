"""Text view of the stability margins (``exotune analyze``, first section; docs/method.md#latency-margin)."""

from __future__ import annotations

import math

from .numbers import fmt_num

__all__ = ["format_margins"]


def _delay(x: float) -> str:
    if x is None:
        return "—"
    if math.isinf(x):
        return "∞ (no extra delay destabilizes)"
    return f"{x * 1e3:.4g} ms"


def format_margins(margins: dict | None) -> list[str]:
    """Lines of the ``margins`` section: the latency margin with its critical loop, member and
    crossing frequency (and in samples when a sample rate is set)."""
    if not margins:
        return []
    L = ["Margins:"]
    lm = margins.get("latency")
    if lm:
        s = f"  latency margin: {_delay(lm['extra_delay_s'])} of extra delay on top of T = {lm['delay_s'] * 1e3:.4g} ms"
        n = lm.get("extra_delay_samples")
        if n is not None and math.isfinite(n):
            s += f" ({fmt_num(n, 4)} samples)"
        L.append(s)
        c = lm.get("critical")
        if c:
            where = f"    critical: {c['loop']}"
            if c.get("value") is not None:
                where += f" at {c['parameter']} = {fmt_num(c['value'], 6)} {c['unit']}"
            if c.get("frequency_hz") is not None:
                where += f", crossing at {fmt_num(c['frequency_hz'], 4)} Hz"
            L.append(where)
        if lm.get("note"):
            L.append(f"    note: {lm['note']}")
        if lm.get("verified") is True:
            L.append("    confirmed by the exact verdicts just below and above the margin")
    pm = margins.get("plant_uncertainty")
    if pm:
        L.append(f"  plant-uncertainty margin: k* in [{fmt_num(pm['lower'], 4)}, {fmt_num(pm['upper'], 4)}] "
                 "× the declared relative uncertainty (lower bound certified)")
        w = pm.get("witness")
        if w:
            L.append(f"    witness just above: {w.get('summary', '')}")
    return L
