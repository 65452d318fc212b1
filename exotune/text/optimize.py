"""Text of an optimization result (``exotune optimize``).

References
----------
docs/optimize-spec.md#result.
"""

from __future__ import annotations

import math

from ..errors import printable
from ..units import PARAM_UNITS, path_unit
from .kyp import format_certificates

__all__ = ["format_optimize", "ms_text", "unit_word"]


def ms_text(v) -> str:
    """A time [s] in milliseconds, or "unbounded" (None or not finite).

    Parameters
    ----------
    v : float or None
        The time [s].

    Returns
    -------
    str
        The text.
    """
    return "unbounded" if v is None or not math.isfinite(v) else f"{v * 1e3:.6g} ms"


#: the unit of the ranged parameter of a one-parameter human kind (an msd family names it in its key)
_KIND_UNITS = {"mass": PARAM_UNITS["inertia"], "spring": PARAM_UNITS["stiffness"],
               "complex_stiffness": PARAM_UNITS["stiffness"]}


def unit_word(unit: str) -> str:
    """A unit as the text prints it: dimensionless "1" as "–" (as :func:`exotune.text.numbers.unit_text`).

    Parameters
    ----------
    unit : str
        The unit.

    Returns
    -------
    str
        The unit as printed.
    """
    return "–" + unit[1:] if unit == "1" or unit.startswith("1 (") else unit


def _intervals(key: str, iv) -> str:
    """Stable intervals of a family column ``human<i>_<kind>_stable_intervals`` with their unit."""
    if not iv:
        return "none"
    kind = key.split("_", 1)[1].removesuffix("_stable_intervals") if "_" in key else ""
    unit = _KIND_UNITS.get(kind, "")
    return ", ".join(f"[{a:.6g}, {b:.6g}]" for a, b in iv) + (f" {unit}" if unit else "")


def _value(path: str, v: float) -> str:
    """A design-file value with the unit of its path (``design.felt_inertia`` → kg·m²)."""
    try:
        unit = path_unit(path, dimensionless="–")
    except KeyError:
        return f"{v:.6g}"
    return f"{v:.6g} {unit}"


def _violation_lines(r: dict) -> list[str]:
    lines = []
    for v in r.get("violations", []):
        if v["constraint"] == "robust":
            unst = v.get("unstable")
            part = (", unstable for " + ", ".join(f"[{a:.6g}, {b:.6g}]" for a, b in unst) + f" {unit_word(v['unit'])}") if unst else ""
            lines.append(f"  robust: {v['family']} not stable over {v['parameter']} ∈ "
                         f"[{v['range'][0]:.6g}, {v['range'][1]:.6g}] {unit_word(v['unit'])}{part}")
        elif v["constraint"] == "gain_schedule":
            lines.append(f"  gain_schedule: the entry at joint angle {v['joint_angle_rad']:.6g} rad (transmission ratio "
                         f"{v['ratio']:.6g}) is not stable for {', '.join(v['loops'])}; needed: {v['needed']}")
        elif "bound" in v:
            val = "n/a" if v["value"] is None else f"{v['value']:.6g}"
            u = unit_word(v["unit"])
            lines.append(f"  {v['constraint']}: {val} {u}, needed {v['op']} {v['bound']:.6g} {u}")
        else:
            lines.append(f"  {v['constraint']}: false, needed true")
    return lines


def _bound_lines(r: dict) -> list[str]:
    if not r.get("at_bounds"):
        return []
    return ["  at their bounds: " + ", ".join(f"{b['parameter']} = {_value(b['parameter'], b['value'])} ({b['bound']})"
                                             for b in r["at_bounds"])]


def _latency_line(r: dict) -> str:
    lm = r["latency_margin"]
    ach = lm["achieved_s"]
    req = lm["required_s"]
    n = lm.get("achieved_samples")
    smp = f" = {n:.3g} sample{'' if f'{n:.3g}' == '1' else 's'}" if n is not None else ""
    need = f"required ≥ {ms_text(req)} ({lm['required_from']})" if req > 0 else f"none required ({lm['required_from']})"
    if lm.get("model"):  # a sample rate: decided on the sampled-data loop
        cont = lm.get("continuous_s")
        return (f"  latency margin ({lm['model']}, the model of record): {ms_text(ach)}{smp}; {need}; "
                f"continuous-time {ms_text(cont)} (not what the runtime tolerates)")
    return f"  latency margin (exact): {ms_text(ach)}{smp}; {need}"


def _sampled_lines(r: dict) -> list[str]:
    """How the optimum was decided on the sampled-data loop (rounds, polish, verdict)."""
    sd = r.get("sampled_data")
    if not sd:
        return []
    v = sd["verdicts"]
    lines = [f"  sampled-data verdicts of record at {v['sample_rate_hz']:g} Hz: "
             + ("CERTIFIABLE (export writes it, certify accepts it)" if sd["certifiable"] else "NOT CERTIFIABLE")
             + f"; {sd['rounds']} tightening round{'' if sd['rounds'] == 1 else 's'} of the continuous search"
             + (f" (continuous latency constraint raised to {ms_text(sd['continuous_constraint_s'])})" if sd["rounds"] else "")
             + ("; objective polished on the sampled-data verdicts" if sd["polished"] else "")]
    for h in v["humans"] + v["environment"]:
        if "stable_intervals" in h:
            ivs = ", ".join(f"[{a:.6g}, {b:.6g}]" for a, b in h["stable_intervals"])
            lines.append(f"    sampled-data {h['kind']} {h['parameter']}: "
                         + (f"stable on {ivs} {unit_word(h['unit'])}" if ivs else "no member is stable"))
    lines += [f"    - {p}" for p in sd["problems"]]
    return lines


def format_optimize(r: dict) -> str:
    """The text of ``exotune optimize`` for a result of :func:`optimize`.

    Parameters
    ----------
    r : dict
        The optimization's result as a mapping (``OptimizeResult.to_dict()``).

    Returns
    -------
    str
        The report.
    """
    if not r["feasible"]:
        lines = ["NO FEASIBLE DESIGN found in the bounds after "
                 f"{r['evaluated']} exact analyses; the best one breaks: {', '.join(r['broken'])}"]
        lines += [f"  {p} = {_value(p, v)}" for p, v in r["x"].items()]
        lines += _violation_lines(r) + _bound_lines(r)
        return printable("\n".join(lines), keep="\n")
    o = r["objective"]
    lines = [f"optimum ({r['evaluated']} designs analysed exactly): {o['name']} = {o['value']:.6g} {unit_word(o['unit'])} ({o['sense']}imized)"]
    lines += [f"  {p} = {_value(p, v)}" for p, v in r["x"].items()]
    lines.append("  active constraints (binding at the optimum): " + (", ".join(r["active_constraints"]) or "none"))
    lines += _bound_lines(r)
    if r.get("near_binding"):
        lines.append("  within 1 % of their bound: " + ", ".join(r["near_binding"]))
    if "latency_margin" in r:
        lines.append(_latency_line(r))
    lines += _sampled_lines(r)
    over = next((m["over"] for m in r["metrics"].values() if isinstance(m, dict) and m.get("over")), None)
    if over:
        lines.append(f"  metrics below: {over}")
    for k, m in r["metrics"].items():
        if k == "human_stable_intervals":
            for fk, iv in m.items():
                lines.append(f"  {fk}: {_intervals(fk, iv)}")
        else:
            at = f" at {m['frequency_hz']:.6g} Hz" if m.get("frequency_hz") else ""
            lines.append(f"  {k}: {m['value']:.6g} {unit_word(m['unit'])}{at}")
    lines += format_certificates(r.get("passivity_certificates"))
    if r.get("certificate_warning"):
        lines.append("  WARNING: " + r["certificate_warning"])
    if r.get("latency_warning"):
        lines.append("  WARNING: " + r["latency_warning"])
    if "pareto" in r:
        lines.append(f"  Pareto front (objective vs robust fraction): {len(r['pareto'])} designs")
    return printable("\n".join(lines), keep="\n")  # the spec's paths and texts cannot drive the terminal
