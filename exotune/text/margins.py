"""Text view of the stability margins (``exotune analyze``, first section; docs/method.md#latency-margin)."""

from __future__ import annotations

import math

from .numbers import count_text, fmt_num

__all__ = ["format_margins"]


def _delay(x: float) -> str:
    if x is None:
        return "—"
    if math.isinf(x):
        return "∞ (no extra delay destabilizes)"
    if math.isnan(x):
        return "unknown"
    return f"{x * 1e3:.4g} ms"


def _entry_lines(lm: dict) -> list[str]:
    """Where a gain-schedule entry's margin is the design's: its joint angle and the plant section's own."""
    g = lm.get("gain_schedule_entry")
    if not g:
        return []
    main = lm.get("main_controller_s")
    own = "no instability up to 200 samples of total delay" if main is None else _delay(main)
    return [f"    in the gain-schedule entry at joint angle {g['joint_angle_rad']:g} rad (transmission ratio "
            f"{g['ratio']:g}), the smallest of the schedule's; the plant section's controller: {own}"]


def format_margins(margins: dict | None) -> list[str]:
    """Lines of the ``margins`` section: the latency margin with its critical loop, member and
    crossing frequency (and in samples when a sample rate is set).

    Parameters
    ----------
    margins : dict or None
        The ``margins`` section (``latency``, ``latency_continuous``, ``plant_uncertainty``,
        ``model_of_record``); None or empty for none.

    Returns
    -------
    list of str
        The lines (none without margins).
    """
    if not margins:
        return []
    L = ["Margins:"]
    lm = margins.get("latency")
    if margins.get("model_of_record"):  # a sample rate: the sampled-data margin decides
        s = (f"  latency margin ({margins['model_of_record']}, the model of record): "
             + ("no instability up to 200 samples of total delay" if lm["extra_delay_s"] is None else
                f"{lm['extra_delay_s'] * 1e3:.4g} ms ({count_text(lm['extra_delay_samples'], 'sample')})")
             + f" of extra delay on top of T = {lm['delay_s'] * 1e3:.4g} ms")
        req = lm.get("required_s")
        if req:
            s += f"; required ≥ {req * 1e3:.4g} ms: " + ("met" if lm.get("met") else "NOT MET")
        L.append(s)
        c = lm.get("critical")
        if c:
            L.append(f"    critical: {c['loop']}" + (f" at {c['parameter']} = {fmt_num(c['value'], 6)} {c['unit']}"
                                                   if c.get("parameter") else ""))
        L += _entry_lines(lm)
        b = lm.get("bound")
        if b:
            L.append(f"    bounded by the hysteretic family's continuous-time margin ({b['model']}); the sampled-data "
                     f"loops alone tolerate {b['sampled_extra_delay_s'] * 1e3:.4g} ms")
        lm = margins.get("latency_continuous")
        L.append("  continuous-time figure (exact delay, no sampling; not what the runtime tolerates):")
    if lm:
        s = f"  latency margin: {_delay(lm['extra_delay_s'])} of extra delay on top of T = {lm['delay_s'] * 1e3:.4g} ms"
        n = lm.get("extra_delay_samples")
        if n is not None and math.isfinite(n):
            s += f" ({count_text(n, 'sample')})"
        L.append(s)
        c = lm.get("critical")
        if c:
            where = f"    critical: {c['loop']}"
            if c.get("value") is not None:
                where += f" at {c['parameter']} = {fmt_num(c['value'], 6)} {c['unit']}"
            if c.get("frequency_hz") is not None:
                where += f", crossing at {fmt_num(c['frequency_hz'], 4)} Hz"
            L.append(where)
        L += _entry_lines(lm)
        if lm.get("note"):
            L.append(f"    note: {lm['note']}")
        if lm.get("verified") is True:
            L.append("    confirmed by root-count verdicts just below and above the margin")
    pm = margins.get("plant_uncertainty")
    if pm:
        up = "∞" if pm["upper"] is None or (isinstance(pm["upper"], float) and math.isinf(pm["upper"])) else fmt_num(pm["upper"], 4)
        L.append(f"  plant-uncertainty margin: {fmt_num(pm['lower'], 4)} ≤ k* ≤ {up} × the declared relative "
                 "plant uncertainty (lower bound certified, upper bound witnessed)")
        w = pm.get("witness")
        if w:
            dev = ", ".join(f"{k} {v * 100:+.3g} %" for k, v in (w.get("deviations") or {}).items() if v)
            member = f" at {w['parameter']} = {fmt_num(w['value'], 6)} {w['unit']}" if w.get("value") is not None else ""
            root = w.get("rightmost_root")
            where = f", root {fmt_num(root['re'], 4)} {'+' if root['im'] >= 0 else '−'} {fmt_num(abs(root['im']), 6)}j rad/s" if root else ""
            L.append(f"    witness (unstable at k = {fmt_num(w['k'], 4)}): {w['loop']}{member}; plant {dev or 'nominal'}{where}")
        mc = pm.get("main_controller")
        if mc:
            mu = "∞" if mc["upper"] is None or math.isinf(mc["upper"]) else fmt_num(mc["upper"], 4)
            L.append(f"    the main controller alone (transmission ratio 1): {fmt_num(mc['lower'], 4)} ≤ k* ≤ {mu}")
        if pm.get("note"):
            L.append(f"    note: {pm['note']}")
    return L
