"""What limits an optimum (binding constraints, parameters at their bounds), what an infeasible
problem's best design breaks, and the exact latency margin of a returned design.

References
----------
docs/optimize-spec.md#result; paper §IV (coupled stability).
"""

from __future__ import annotations

import math

import numpy as np

from .evaluate import column, delay_sensitive_ok, latency_ladder, schedule_verdicts
from .space import Archive, from_unit
from .spec import CONSTRAINTS, OptimizeSpec, optimized_design_mapping

__all__ = ["at_bounds", "binding", "violations", "exact_latency_margin", "PERTURB", "SLACK_TOL"]

#: perturbation of the optimum toward a better objective (unit coordinates)
PERTURB = 1e-3
#: relative slack under which a bound constraint counts as binding
SLACK_TOL = 1e-3
_BOUND_TOL = 1e-9


def at_bounds(spec: OptimizeSpec, u: np.ndarray, x: np.ndarray) -> list[dict]:
    """Parameters at (within 10⁻⁹ in unit coordinates of) one of their bounds.

    Parameters
    ----------
    spec : OptimizeSpec
        The optimization problem.
    u : numpy.ndarray
        The design in unit coordinates (D,).
    x : numpy.ndarray
        The same design in natural units (D,).

    Returns
    -------
    list of dict
        ``{parameter, bound ("lower" or "upper"), value}`` per parameter at a bound.
    """
    out = []
    for j, p in enumerate(spec.free):
        if u[j] <= _BOUND_TOL:
            out.append({"parameter": p, "bound": "lower", "value": float(x[j])})
        elif u[j] >= 1.0 - _BOUND_TOL:
            out.append({"parameter": p, "bound": "upper", "value": float(x[j])})
    return out


def _slack(spec, ev, achieved_latency):
    """(name, value, bound, op, unit, relative slack) of every bound constraint set."""
    out = []
    for name, (col, op, unit) in CONSTRAINTS.items():
        if name not in spec.constraints:
            continue
        b = float(spec.constraints[name])
        if name == "latency_margin_s":
            if b <= 0:
                continue
            v = achieved_latency
        else:
            v = float(np.asarray(column(ev, col))[0])
        slack = (v - b) if op == ">=" else (b - v)
        out.append((name, v, b, op, unit, slack / max(abs(b), 1e-12)))
    return out


def binding(ar: Archive, u: np.ndarray, final: dict, achieved_latency: float) -> tuple[list, list]:
    """Binding constraints of the optimum ``u`` (unit coordinates).

    A constraint is binding when its relative slack is below :data:`SLACK_TOL`, or when it is
    broken by a perturbation of the optimum (:data:`PERTURB` along each free coordinate, either
    way) that improves the objective — so a constraint that limits the optimum through one
    parameter is found while the optimum is interior in another. Returns (names, details).

    Parameters
    ----------
    ar : Archive
        The search's archive (spec, evaluation, objective).
    u : numpy.ndarray
        The optimum in unit coordinates (D,).
    final : dict
        The evaluation of the optimum.
    achieved_latency : float
        The optimum's latency margin [s].

    Returns
    -------
    names : list of str
        The binding constraints, sorted.
    details : list of dict
        Per name: how it binds (``slack`` with value, bound, op and unit, or ``perturbation`` with
        the parameter moved).
    """
    spec = ar.spec
    details = {}
    for name, v, b, op, unit, rel in _slack(spec, final, achieved_latency):
        if rel < SLACK_TOL:
            details[name] = {"constraint": name, "how": "slack", "value": v, "bound": b, "op": op, "unit": unit}
    base = float(ar.value(final)[0])
    rows = []
    for i in range(u.size):
        if ar.j is not None and i != ar.j:
            continue  # the objective is the parameter itself: only moving it changes the objective
        for s in (1.0, -1.0):
            w = u.copy()
            w[i] = u[i] + s * PERTURB
            if 0.0 <= w[i] <= 1.0:
                rows.append(w)
    if rows:
        U = np.asarray(rows)
        ev = ar.evaluate(U)
        val = ar.value(ev)
        if spec.objective == "latency_margin_s":
            val = latency_ladder(spec, from_unit(spec, U))
        for r in np.nonzero(val > base + 1e-12 * max(abs(base), 1e-300))[0]:
            for name, bad in ev["broken"].items():
                if bad[r] and name not in details:
                    details[name] = {"constraint": name, "how": "perturbation",
                                     "parameter": ar.paths[int(np.argmax(np.abs(U[r] - u)))]}
    names = sorted(details)
    return names, [details[n] for n in names]


def _unstable_parts(ivs, lo, hi):
    gaps, prev = [], lo
    for a, b in sorted(ivs):
        if a > prev:
            gaps.append([prev, a])
        prev = max(prev, b)
    if prev < hi:
        gaps.append([prev, hi])
    return gaps


def violations(spec: OptimizeSpec, ev: dict, i: int, achieved_latency: float | None) -> list[dict]:
    """Every broken constraint of row i of an evaluation, with its value and the bound it needed
    (for ``robust``: each non-robust family, its range and the unstable part of it).

    Parameters
    ----------
    spec : OptimizeSpec
        The optimization problem.
    ev : dict
        An evaluation (``analysis``, ``broken``, …).
    i : int
        The row.
    achieved_latency : float or None
        The row's latency margin [s], when computed.

    Returns
    -------
    list of dict
        One entry per broken constraint (its value, op, bound and unit, or the family's range and
        stable and unstable parts).
    """
    res = ev["analysis"]
    out = []
    for name, bad in ev["broken"].items():
        if not bad[i]:
            continue
        if name == "robust":
            for fam, key, h in zip(spec.cfg.humans, res.human_names(), res.humans):
                if bool(np.asarray(h.robust)[i]):
                    continue
                ivs = [list(map(float, iv)) for iv in h.stable_intervals[i]]
                out.append({"constraint": "robust", "family": key, "parameter": fam.param, "unit": fam.unit,
                            "range": [float(fam.lo), float(fam.hi)], "stable": ivs,
                            "unstable": _unstable_parts(ivs, fam.lo, fam.hi) if not fam.box else None,
                            "needed": "stable over the whole range"})
        elif name in CONSTRAINTS and name != "latency_margin_s":
            col, op, unit = CONSTRAINTS[name]
            out.append({"constraint": name, "value": float(np.asarray(column(ev, col))[i]), "op": op,
                        "bound": float(spec.constraints[name]), "unit": unit})
        elif name == "latency_margin_s":
            out.append({"constraint": name, "value": achieved_latency, "op": ">=",
                        "bound": float(spec.constraints[name]), "unit": "s"})
        elif name == "gain_schedule":
            out.extend(_schedule_violations(spec, ev["schedule"], i))
        else:
            out.append({"constraint": name, "value": False, "needed": True})
    return out


def _schedule_violations(spec, sched, i: int) -> list[dict]:
    """One violation per gain-schedule entry of design ``i`` that breaks a stability constraint,
    naming the entry (joint angle [rad], transmission ratio) and its loops that fail."""
    ok = schedule_verdicts(spec, sched)[:, i]
    out = []
    for e in np.flatnonzero(~ok):
        row = sched.entry(int(e)).row(i)
        loops = [k for k, h in zip(row.human_names(), row.humans) if not bool(h.robust[0])]
        loops += [k for k, lp in (("free", row.free), ("locked", row.locked)) if not bool(lp.stable[0])]
        loops += [k for k, env in zip(row.environment_names(), row.environment) if not bool(env.verdict[0])]
        out.append({"constraint": "gain_schedule", "joint_angle_rad": sched.joint_angle_rad[e],
                    "ratio": sched.ratio[e], "loops": loops,
                    "needed": "every gain-schedule entry stable (robust over the whole ranges)"})
    return out


def exact_latency_margin(spec: OptimizeSpec, x: np.ndarray, ev: dict | None = None, i: int = 0):
    """Exact latency margin (:func:`exotune.analysis.latency_margin.latency_margin`) of the design x
    (with a gain schedule: the smallest over its entries, :func:`~exotune.analysis.latency_margin.schedule_latency_margin`);
    0 without computing when its delay-sensitive verdicts already fail at the nominal delay.

    Parameters
    ----------
    spec : OptimizeSpec
        The optimization problem.
    x : numpy.ndarray
        The design's free-parameter values, natural units (D,).
    ev : dict or None, optional
        An evaluation holding the design; None to compute the margin without the shortcut.
    i : int, optional
        The design's row in ``ev``.

    Returns
    -------
    LatencyMargin
        The latency margin (``extra_delay_s`` [s]; 0 when not robust at the nominal delay).
    """
    from ..analysis.latency_margin import LatencyMargin, latency_margin, schedule_latency_margin
    from ..config import design_from_mapping

    if ev is not None and not bool(delay_sensitive_ok(ev["analysis"])[i]):
        return LatencyMargin(0.0, None, (), float(spec.cfg.implementation.delay_s),
                             spec.cfg.implementation.sample_rate_hz or None, None, "not robust at the nominal delay")
    cfg = design_from_mapping(optimized_design_mapping(spec, {"x": dict(zip(spec.free, map(float, x)))}))
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        # a gain-scheduled design: the smallest over its entries, as analyze reports it
        return schedule_latency_margin(cfg, latency_margin(cfg))[0]


def latency_record(spec: OptimizeSpec, lm) -> dict:
    """The ``latency_margin`` section of the result: required and achieved (exact), with units."""
    req = float(spec.constraints.get("latency_margin_s", 0.0))
    fs = spec.cfg.implementation.sample_rate_hz
    ach = float(lm.extra_delay_s)
    crit = lm.critical
    return {
        "required_s": req,
        "required_from": spec.latency_default or "spec",
        "achieved_s": ach if math.isfinite(ach) else None,
        "achieved_unbounded": not math.isfinite(ach),
        "achieved_samples": (ach * float(fs) if math.isfinite(ach) else None) if fs else None,
        "required_samples": req * float(fs) if fs else None,
        "met": bool(ach >= req),
        "verified": lm.verified,
        "critical": None if crit is None else crit.to_dict(),
        "checked_extra_delays_s": [float(d) for d in spec.checked_delays()],
        "units": {"required_s": "s", "achieved_s": "s", "achieved_samples": "samples", "required_samples": "samples"},
    }
