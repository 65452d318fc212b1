"""Text of ``exotune certify``: the verdicts of the sampled-data analysis of a controller file."""

from __future__ import annotations

from ..controllerfile.continuation import covers_range
from ..errors import printable
from ..model.humans import PARAM_UNITS
from .numbers import interval_text, sampled_verdict_word

__all__ = ["format_certify", "family_line", "margin_line", "schedule_entry_line"]


def family_line(h: dict) -> str:
    """One human or environment family: its range(s) with units and its verdict.

    Parameters
    ----------
    h : dict
        One family of a sampled-data analysis (kind, parameter, unit, range, box, verdict and
        ``stable_intervals``, or ``skipped`` (with a hysteretic family's ``continuous_check``) /
        ``not_certifiable``).

    Returns
    -------
    str
        The line (indented).
    """
    head = f"  {h['kind']} {h['parameter']} [{h['range'][0]:g}, {h['range'][1]:g}] {h['unit']}"
    for q, (a, b) in (h.get("box") or {}).items():
        head += f" × {q} [{a:g}, {b:g}] {PARAM_UNITS.get(q, '')}".rstrip()
    head += ": "
    if "skipped" in h:
        line = head + "skipped (" + h["skipped"] + ")"
        c = h.get("continuous_check")
        if c is None:
            return line
        if not c["checked"]:
            return line + "; not checked in continuous time either (" + c["reason"] + ")"
        verdict = "robust" if c["robust"] else ("inconclusive" if not c["conclusive"] else "NOT robust")
        return (line + f"; continuous time, exact delay: {verdict}, " + _stable_in(c["stable_intervals"], h["unit"])
                + " (not the sampled-data loop)")
    if "not_certifiable" in h:
        return head + "not certifiable (" + h["not_certifiable"] + ")"
    verdict = "robust" if h["robust"] else "NOT robust"
    if not h["robust"] and h.get("unresolved") and covers_range(h):  # stable by eigenvalues, cells unproven
        verdict = "NOT PROVEN robust (unresolved cells)"
    return head + verdict + "; " + _stable_in(h["stable_intervals"], h["unit"])


def _stable_in(intervals, unit: str) -> str:
    """"stable in [a, b] unit", or "no member is stable" for none."""
    return f"stable in {interval_text(intervals, unit)}" if len(intervals) else "no member is stable"


def _ms(x) -> str:
    return "none" if x is None else f"{x * 1e3:.4g} ms"


def schedule_entry_line(e: dict) -> str:
    """One gain-schedule entry of a certification (or of the verdicts of record): its verdict and
    its own sampled-data latency margin.

    Parameters
    ----------
    e : dict
        The entry (``joint_angle_rad``, ``ratio``, ``robust``, ``not_robust``, optional ``latency_margin``).

    Returns
    -------
    str
        The line (indented).
    """
    line = (f"  gain schedule, joint angle {e['joint_angle_rad']:g} rad (ratio {e['ratio']:g}): "
            + ("robust" if e["robust"] else "NOT robust for " + ", ".join(e["not_robust"])))
    lm = e.get("latency_margin")
    if not lm or not e["robust"]:
        return line
    if lm.get("extra_delay_s") is None:
        return line + "; latency margin: no instability up to 200 samples of total delay"
    return line + f"; latency margin {_ms(lm['extra_delay_s'])} ({lm['extra_delay_samples']:.4g} samples)"


def margin_line(lm: dict) -> str:
    """The sampled-data latency margin, its critical member, the file's prediction and requirement.

    Parameters
    ----------
    lm : dict
        The sampled-data latency margin: ``extra_delay_s`` [s] (None: none up to 200 samples),
        ``extra_delay_samples``, ``critical``, ``method``, ``predicted_continuous_s`` [s] and
        ``required_s`` [s].

    Returns
    -------
    str
        The line (indented).
    """
    if lm["extra_delay_s"] is None:
        head = "  latency margin (sampled-data): no instability up to 200 samples of total delay"
    else:
        head = f"  latency margin (sampled-data): {_ms(lm['extra_delay_s'])} ({lm['extra_delay_samples']:.4g} samples)"
    c = lm.get("critical")
    if c:
        head += f", critical {c['loop']}" + (f" at {c['parameter']} = {c['value']:.6g} {c['unit']}" if c["parameter"] else "")
    g = lm.get("gain_schedule_entry")
    if g:
        main = lm.get("main_controller_s")
        head += (f", in the gain-schedule entry at joint angle {g['joint_angle_rad']:g} rad (ratio {g['ratio']:g}; "
                 f"the main controller: {'no instability up to 200 samples' if main is None else _ms(main)})")
    b = lm.get("bound")
    if b:
        head += (f" (the hysteretic family's continuous-time margin bounds it: it has no sampled-data model; "
                 f"the sampled-data loops alone {_ms(b['sampled_extra_delay_s'])})")
    if lm["extra_delay_s"] == 0.0:
        head += " (" + lm["method"] + ")"
    head += f"; predicted continuous {_ms(lm.get('predicted_continuous_s'))}"
    req = lm.get("required_s")
    return head + ("; required " + (_ms(req) if req else "none (0)") if req is not None else "; no requirement in the file")


def precision_line(p: dict) -> str:
    """The float32 line of a certify report: the realization and its rounding bound."""
    amp = ", ".join(f"{s} {q['value']:g} {q['unit']}" for s, q in p["input_amplitudes"].items())
    top = p["by_location"][0] if p["by_location"] else None
    return ("  certify --precision float32 (the file is float64 and unchanged): " if p.get("asked") else "  ") + (
            f"float32 ({p['form']} realization, analysed exactly): |float32 - float64 controller| <= "
            f"{p['total']['value']:.3g} N·m (arithmetic {p['arithmetic']['value']:.3g}, coefficients "
            f"{p['coefficients']['value']:.3g}; typical {p['arithmetic_rms_estimate']['value']:.2g} N·m rms) over "
            f"{p['horizon']['seconds']:g} s from rest for |inputs| <= {amp}"
            + (f"; largest share {top['where']} {top['bound']['value']:.3g} N·m" if top else ""))


def format_certify(rep: dict) -> str:
    """Readable text for ``exotune certify``.

    Parameters
    ----------
    rep : dict
        The result of :func:`exotune.controllerfile.certify.certify`.

    Returns
    -------
    str
        The report, ending with ``CERTIFIED`` or ``NOT CERTIFIED:`` and the reasons.

    References
    ----------
    Paper §V (its stability predictions account for the discrete-time implementation); docs/cli.md#certify.
    """
    sa = rep["sampled"]
    lines = [f"exotune certify — {rep['schema']}, {rep['sample_rate_hz']['value']:g} Hz, "
             f"delay {rep['delay_s'] * 1e3:.6g} ms",
             f"  golden vectors: {rep['golden']['samples']} samples, max error "
             f"{rep['golden']['max_abs_error']['value']:.3g} N·m",
             f"  free (cuff free): {sampled_verdict_word(sa['free_stable'])} (spectral radius "
             f"{sa['free_spectral_radius']:.9f})",
             f"  locked joint:     {sampled_verdict_word(sa['locked_stable'])} (spectral radius "
             f"{sa['locked_spectral_radius']:.9f})"]
    for e in rep.get("gain_schedule", []):
        lines.append(schedule_entry_line(e))
    lines += [family_line(h) for h in sa["humans"] + sa["environment"]]
    if rep.get("latency_margin"):
        lines.append(margin_line(rep["latency_margin"]))
    if rep.get("precision"):
        lines.append(precision_line(rep["precision"]))
    lines.append("  method: " + rep["method"])
    if rep["certified"]:
        lines.append("CERTIFIED")
    else:
        lines.append("NOT CERTIFIED:")
        lines += [f"  - {p}" for p in rep["problems"]]
    return printable("\n".join(lines), keep="\n")  # a hand-tuned file's own texts (names, reasons) cannot drive the terminal
