"""Text view of the single-design analysis (``exotune analyze``)."""

from __future__ import annotations

from ..errors import printable
from ..model.humans import PARAM_UNITS
from .kyp import format_certificates
from .margins import format_margins
from .numbers import unit_text
from .verdicts import format_verdicts

__all__ = ["format_report", "TEXT_LIST_MAX"]


TEXT_LIST_MAX = 12  # the text report lists at most this many intervals / boundaries (--json: all)


def _fmt_iv(iv, unit):
    if not iv:
        return "none"
    s = ", ".join(f"[{a:.6g}, {b:.6g}]" for a, b in iv[:TEXT_LIST_MAX]) + (f" {unit}" if unit else "")
    if len(iv) > TEXT_LIST_MAX:
        s += f" … ({len(iv)} intervals in all; --json lists every one)"
    return s


def _box_lines(h: dict, yn) -> list[str]:
    """The lines of an msd box family: its ranges with units, the verdict and every edge."""
    box = ", ".join(f"{q} in [{a:.6g}, {b:.6g}] {PARAM_UNITS[q]}" for q, (a, b) in h["box"].items())
    L = [f"  {h['kind']:17s} box {box}: robust {yn(h['robust'])} (Edge Theorem, {len(h['edges'])} edges)"]
    for e in h["edges"]:
        at = ", ".join(f"{q} = {v:.6g} {PARAM_UNITS[q]}" for q, v in e["at"].items())
        whole = " (the whole edge)" if e["stable_intervals"] == [e["range"]] else ""
        L.append(f"    edge {e['parameter']} at {at}: stable on "
                 f"{_fmt_iv(e['stable_intervals'], PARAM_UNITS[e['parameter']])}{whole}")
    return L


def _human_lines(h: dict, yn) -> list[str]:
    """The lines of one human family (or box) of the report."""
    L = []
    if h.get("box"):
        L += _box_lines(h, yn)
        return L
    L.append(f"  {h['kind']:17s} {h['parameter']} in [{h['range'][0]:.6g}, {h['range'][1]:.6g}] {h['unit']}: robust {yn(h['robust'])}")
    if h.get("conclusive") is False and not h["stable_intervals"]:
        L.append("    inconclusive: its critical values or root counts were not decided (a work budget spent or "
                 "float resolution; docs/method.md#stable-intervals-of-a-human-family), so no interval is claimed stable")
    else:
        L.append(f"    stable on {_fmt_iv(h['stable_intervals'], h['unit'])}")
    for c in h["critical"][:TEXT_LIST_MAX]:
        L.append(f"    boundary at {h['parameter']} = {c['value']:.6g} {h['unit']} (crossing at {c['frequency_hz']:.4g} Hz)")
    if len(h["critical"]) > TEXT_LIST_MAX:
        L.append(f"    … {len(h['critical'])} boundaries in all (--json lists every one)")
    if h.get("verification_mismatches"):
        L.append(f"    VERIFICATION FAILED at {h['parameter']} = {h['verification_mismatches']}: treated as not robust")
    if h.get("lowest_stable_value_below_range_top") is not None and h["kind"] in ("mass", "msd") and h["parameter"] == "inertia":
        L.append(f"    lightest stable inertia: {h['lowest_stable_value_below_range_top']:.6g} kg·m²")
    return L


def _sampled_and_crosscheck_lines(r: dict, yn) -> list[str]:
    """The lines of the sampled-data check and of the Padé cross-check (when present)."""
    L = []
    sd = r.get("sampled_data")
    if sd and "certifiable" not in sd:  # the grid check (the verdicts of record come first in the report)
        L.append(f"Sampled-data check at {sd['sample_rate_hz']:g} Hz ({sd['method']}):")
        sv = lambda b: "inconclusive (spectral radius within rounding of 1)" if b is None else yn(b)  # noqa: E731
        L.append(f"  cuff free stable: {sv(sd['free_stable'])}; output locked stable: {sv(sd['locked_stable'])}")
        for side, fams in (("human", sd["humans"]), ("environment", sd.get("environment", []))):
            for h in fams:
                if "skipped" in h:
                    L.append(f"  {side} {h['kind']}: skipped ({h['skipped']})")
                    continue
                L.append(f"  {side} {h['kind']}: {h['stable_points']} of {h['points']} grid values stable, "
                         f"{len(h['disagreements'])} disagreement(s) with the continuous intervals")
                for b in h["boundaries"]:
                    moved = "not found within a factor 2" if b["sampled"] is None else f"{b['sampled']:.5g}"
                    u = PARAM_UNITS.get(h["parameter"], "")
                    L.append(f"    boundary {h['parameter']} = {b['continuous']:.5g} {u} (continuous) -> {moved}"
                             + (f" {u}" if b["sampled"] is not None else "") + " (sampled)")
    cc = r.get("cross_check")
    if cc:
        L.append(
            f"Cross-check (Padé {cc['pade_orders']} roots + Newton on the exact Δ): {cc['agree']} of {cc['checked']} verdicts agree"
            + (f"; {len(cc['unconfirmed'])} unstable verdicts not confirmed by the root search" if cc["unconfirmed"] else "")
        )
        for d in cc["disagreements"]:
            L.append(f"  DISAGREEMENT at {d['case']}: exotune says stable, but Δ has a root at "
                     f"{d['rhp_root']['re']:.6g} + {d['rhp_root']['im']:.6g}j rad/s")
    return L


def format_report(r: dict) -> str:
    """Readable text report of :func:`analyze_design` with units.

    Parameters
    ----------
    r : dict
        The analysis as a mapping (``DesignAnalysis.to_dict()``, the ``exotune analyze --json``
        object).

    Returns
    -------
    str
        The report.
    """
    L = []
    yn = lambda b: "yes" if b else "NO"
    L.append("exotune analyze — " + r["model"])
    L.append(f"delay T = {r['delay_s'] * 1e3:.4g} ms, controller structure '{r['structure']}'")
    L.append("")
    sd = r.get("sampled_data")
    if sd and "certifiable" in sd:
        L += format_verdicts(sd)
        L.append("")
    if r.get("margins"):
        L += format_margins(r["margins"])
        L.append("")
    if sd and "certifiable" in sd:
        L.append("Continuous-time analysis (exact delay, no sampling; the verdicts of record are the sampled-data ones above):")
    L.append("Gains (torque units, docs/method.md#double-compliance-shaping):")
    for k, v in r["gains"].items():
        L.append(f"  {k:7s} = {v:12.6g}  [{unit_text(r['units'][k])}]")
    L.append("")
    L.append(f"Free exoskeleton (cuff free) stable: {yn(r['free_stable'])} (rigid-body roots at s=0 removed: {r['free']['rigid_body_roots']})")
    L.append(f"Output locked stable:               {yn(r['locked_stable'])}")
    for e in r["environment"]:
        if "stable" in e:
            L.append(f"Environment {e['kind']}: stable {yn(e['stable'])}")
        else:
            u = PARAM_UNITS[e["parameter"]]
            L.append(f"Environment {e['kind']} {e['parameter']} in [{e['range'][0]:.6g}, {e['range'][1]:.6g}] {u}: "
                     f"robust {yn(e['robust'])}, stable on {_fmt_iv(e['stable_intervals'], u)}")
    L.append("")
    L.append("Coupled stability with the human models:")
    for h in r["humans"]:
        L += _human_lines(h, yn)
    L.append("")
    p = r["passivity"]
    L.append(f"Passivity of C7: max phase excess {p['max_phase_excess_deg']:.4g} deg outside [-180°, 0°]; non-passive bands: {_fmt_iv(p['nonpassive_band_hz'], 'Hz')}")
    L += format_certificates(p.get("kyp"))
    if r["dob"]:
        d = r["dob"]
        L.append(
            f"DOB loop L_dob = Q e^(-sT)/(1-Q): gain margin {d['gain_margin_db']:.4g} dB, phase margin {d['phase_margin_deg']:.4g} deg, "
            f"delay margin {d['delay_margin_s'] * 1e3:.4g} ms (extra delay), crossover {d['crossover_hz']:.4g} Hz"
        )
        if not d["stable"]:
            L.append("  the closed DOB loop is UNSTABLE with the modelled delay (delay margin reported as 0)")
    else:
        L.append("DOB: none")
    a = r["amplification"]
    mp = ("minimum phase: unknown (root count inconclusive)" if a.get("conclusive") is False
          else f"minimum phase {yn(a['minimum_phase'])}")
    L.append(f"Amplification C6/C5: DC {a['dc']:.6g}, -3 dB bandwidth {a['bandwidth_hz']:.4g} Hz, {mp}")
    L.append(f"J_m_hat / J_j = {r['J_m_hat_over_J_j']:.4g}")
    for e in r.get("gain_schedule") or []:
        L.append(f"Gain schedule, joint angle {e['joint_angle_rad']:g} rad (ratio {e['ratio']:g}): "
                 + ("robust" if e["robust"] else "NOT robust: " + ", ".join(e["not_robust"]))
                 + f"; K2 = {e['gains']['K2']:.6g}, B2 = {e['gains']['B2']:.6g} s")
    L += _sampled_and_crosscheck_lines(r, yn)
    for w in r["warnings"]:
        L.append(f"warning: {w}")
    return printable("\n".join(L), keep="\n")  # a string of the user's quoted here cannot drive the terminal
