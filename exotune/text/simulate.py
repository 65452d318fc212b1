"""Text of ``exotune simulate``: the summary of a nonlinear time-domain run."""

from __future__ import annotations

from ..errors import printable
from .numbers import count_text, unit_text

__all__ = ["format_simulation"]


def _num(v, fmt: str = ".6g") -> str:
    return "null" if v is None else format(v, fmt)


def _extra(name: str, y, unit: str) -> str:
    """One attribute of a quantity: a ``tolerance`` is in the quantity's own unit, a ``…_per_s``
    rate in 1/s, a ``…_hz`` frequency in Hz and a ``…_s`` time in s ("none" when null); the others
    are words or plain numbers."""
    text = _num(y) if isinstance(y, float) or y is None else str(y)
    if name == "tolerance" and isinstance(y, (int, float)):
        return f"tolerance {text} {unit_text(unit)}"
    if name.endswith("_per_s") and (y is None or isinstance(y, (int, float))):
        return f"{name[: -len('_per_s')].replace('_', ' ')} {text} 1/s"
    for suffix, u in (("_hz", "Hz"), ("_s", "s")):  # a frequency, a time: "none" when there is none
        if name.endswith(suffix) and (y is None or isinstance(y, (int, float))):
            label = name[: -len(suffix)].replace("_", " ")
            return f"{label}: none" if y is None else f"{label} {text} {u}"
    if name == "signal":
        return f"measured on {y}"
    return f"{name.replace('_', ' ')} {text}"


#: unit suffixes of metric keys (``cuff_oscillation_start_rad``): the unit is printed after the value
_KEY_UNITS = ("_rad", "_s", "_nm", "_hz")


def _label(k: str) -> str:
    for suffix in _KEY_UNITS:
        if k.endswith(suffix):
            k = k[: -len(suffix)]
            break
    return k.replace("_", " ")


def _line(k: str, v, indent: str = "  ", missing: str = "not measured") -> str:
    """One quantity: ``label: value unit; attributes``; a quantity without a value says so in words
    (``missing``, e.g. why a growing run has no metrics) instead of printing "null"."""
    if isinstance(v, dict) and "value" in v:
        if v["value"] is None:
            return f"{indent}{_label(k)}: {missing}"
        tail = "".join(f"; {_extra(x, y, v['unit'])}" for x, y in v.items() if x not in ("value", "unit"))
        return f"{indent}{_label(k)}: {_num(v['value'])} {unit_text(v['unit'])}{tail}"
    return f"{indent}{k.replace('_', ' ')}: {v}"


def format_simulation(rep: dict) -> str:
    """Readable text for ``exotune simulate``.

    Parameters
    ----------
    rep : dict
        The result of :func:`exotune.simulation.run_scenario`.

    Returns
    -------
    str
        The scenario, the sample rate and delay, the verdict and why (what decided it: the
        envelope, the linearized loop's eigenvalues, or nothing for a run too short to judge) with
        the envelope's growth rate and the linearized loop's spectral radius and dominant
        oscillation, one line per metric (with its unit; "not measured" with the reason for a
        growing or an inconclusive run), and the scenario's own measurements (windup recovery, limit
        cycle, the DOB's friction estimate, friction sensitivity).

    References
    ----------
    docs/cli.md#simulate.
    """
    sm = rep["summary"]
    out = [f"exotune simulate — {rep['scenario']}: {rep['description']}",
           f"  sample rate {rep['sample_rate_hz']:g} Hz, delay {count_text(rep['delay_samples'], 'sample')}, start {sm['start']}",
           f"  verdict: {sm['verdict']}"]
    e = rep.get("gain_schedule_entry")
    if e:  # before the verdict: which controller ran
        out.insert(2, f"  gain-schedule entry: {e['joint_angle']['value']:g} rad (ratio {e['ratio']['value']:g}), the "
                      f"nearest to the requested {e['joint_angle_requested']['value']:g} rad: its plant and controller, "
                      "frozen at that angle, as the runtime picks it")
    if sm.get("verdict_reason"):
        out.append(f"  why: {sm['verdict_reason']}")
    why = sm.get("metrics_null_reason")
    out += [_line(k, v, missing="not measured" + (" (see below)" if why else ""))
            for k, v in sm.items() if k not in ("start", "verdict", "verdict_basis", "verdict_reason",
                                                "metrics_null_reason")]
    if why:
        out.append(f"  why these metrics were not measured: {why}")
    w = rep.get("windup_recovery")
    if w:
        out.append(f"  windup recovery after the release at {w['release_at']['value']:g} s:")
        for label in ("with_clamp", "without_clamp"):
            out.append(f"    {label.replace('_', ' ')}:")
            out += [_line(k, v, "      ") for k, v in w[label].items()]
    lc = rep.get("limit_cycle")
    if lc:
        run = "inconclusive" if sm.get("verdict") == "inconclusive" else "growing"
        state = {True: "present", False: "absent", None: f"undefined ({run} run)"}[lc["present"]]
        out.append(f"  limit cycle: {state}")
        out += [_line(k, v, "    ") for k, v in lc.items() if k not in ("present", "without_backlash")]
        wb = lc.get("without_backlash")
        if wb:
            out.append(f"    the same run without backlash: {wb['verdict']} (envelope growth "
                       f"{_num(wb['envelope_growth_rate']['value'], '.4g')} 1/s)")
    fe = rep.get("friction_estimate")
    if fe:
        out.append("  the DOB's friction estimate:")
        out += [_line(k, v, "    ") for k, v in fe.items()]
    for k, v in rep.get("friction_sensitivity", {}).items():
        out.append(f"  friction sensitivity {k.replace('_', ' ')}: {_num(v['value'], '.4g')} {unit_text(v['unit'])}")
    if "summary_without_dob" in rep:
        out.append("  without the DOB:")
        out += [_line(k, v, "    ") for k, v in rep["summary_without_dob"].items() if k != "verdict_basis"]
    return printable("\n".join(out), keep="\n")  # the input's own texts quoted cannot drive the terminal
