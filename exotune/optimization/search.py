"""The search of ``exotune optimize`` (method: the package docstring).

References
----------
docs/optimize-spec.md#method.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .diagnose import at_bounds, binding, exact_latency_margin, latency_record, violations
from .evaluate import column
from .peak import amplification_peak
from .space import Archive, from_unit, polish_boundary, polish_pattern, ray_max
from .spec import CONSTRAINTS, LATENCY_CHECKS, OBJECTIVES, OptimizeSpec, optimized_design_mapping

__all__ = ["optimize", "GLOBAL_SHARE", "TIGHTEN_ROUNDS"]

#: share of the budget spent by the global stage (the rest: local polish)
GLOBAL_SHARE = 0.5
#: rounds of tightening the checked extra delays when the exact margin falls short
TIGHTEN_ROUNDS = 3
_SHORTLIST = 3


def _global(ar: Archive, spec: OptimizeSpec):
    import scipy.optimize

    D = len(ar.paths)
    budget = max(50, int(spec.budget * GLOBAL_SHARE))
    popsize = max(5, int(round(min(60, budget / 20) / max(D, 1))))
    S = popsize * D
    maxiter = max(1, budget // S - 1)
    return scipy.optimize.differential_evolution(
        lambda U: ar.score(ar.evaluate(np.asarray(U).T)), [(0.0, 1.0)] * D, vectorized=True,
        updating="deferred", seed=spec.seed, popsize=popsize, maxiter=maxiter, polish=False, tol=1e-6,
        init="latinhypercube")


def _local(ar: Archive, u: np.ndarray, value: float, budget: int, rng, h: float) -> np.ndarray:
    """Polish from u, then take back the best feasible design evaluated (and, when the objective
    is a parameter, push it to its boundary once more)."""
    if ar.j is not None:
        polish_boundary(ar, u, budget, rng, h)
    else:
        polish_pattern(ar, u, value, budget, rng, h)
    best = ar.best_feasible()
    u = best[1]
    if ar.j is not None:
        u = ray_max(ar, u[None, :])[0]
    return u


def _shortlist_latency(ar: Archive, spec: OptimizeSpec, u: np.ndarray):
    """Objective latency_margin_s: the exact margin of the best few designs; the best exact wins."""
    cands = np.vstack([u[None, :], ar.top_feasible(_SHORTLIST)])
    _, first = np.unique(np.round(cands, 12), axis=0, return_index=True)
    cands = cands[np.sort(first)][:_SHORTLIST]
    best = None
    for c in cands:
        lm = exact_latency_margin(spec, from_unit(spec, c[None, :])[0])
        if best is None or lm.extra_delay_s > best[1].extra_delay_s:
            best = (c, lm)
    return best


def _tightened(spec: OptimizeSpec, achieved: float) -> OptimizeSpec:
    """More checked extra delays: twice as many on [0, m], plus one just past the shortfall."""
    m = float(spec.constraints["latency_margin_s"])
    K = max(LATENCY_CHECKS, len(spec.checked_delays())) * 2
    d = set(np.round(m * np.arange(1, K + 1) / K, 15).tolist()) | set(spec.checked_delays().tolist())
    if 0 < achieved < m:
        d |= {achieved * (1 + 1e-6), 0.5 * (achieved + m)}
    return dataclasses.replace(spec, latency_deltas=tuple(sorted(d)))


def _search(spec: OptimizeSpec, rng):
    """Global stage + polish + exact latency check (tightening on a shortfall).
    Returns (archive, u, latency margin, de result, spec used, tightening rounds) or an
    infeasible marker (archive, None, ...)."""
    ar = Archive(spec)
    res = _global(ar, spec)
    best = ar.best_feasible()
    if best is None:
        return ar, None, None, res, spec, 0
    total = max(spec.budget, ar.count + 40 * len(ar.paths) + 200)
    u = _local(ar, best[1], best[0], total, rng, 0.1)
    m = float(spec.constraints.get("latency_margin_s", 0.0))
    rounds = 0
    while True:
        if spec.objective == "latency_margin_s":
            u, lm = _shortlist_latency(ar, spec, u)
        else:
            lm = exact_latency_margin(spec, from_unit(spec, u[None, :])[0])
        if m <= 0 or lm.extra_delay_s >= m or rounds >= TIGHTEN_ROUNDS:
            return ar, u, lm, res, spec, rounds
        rounds += 1
        spec = _tightened(spec, float(lm.extra_delay_s))
        old = ar
        ar = Archive(spec)
        ar.count, ar.history = old.count, old.history + old.evs
        ev = ar.evaluate(old.top_feasible(64))
        b = ar.best_feasible([ev])
        if b is None:
            return ar, None, None, res, spec, rounds
        u = _local(ar, b[1], b[0], ar.count + 40 * len(ar.paths) + 200, rng, 0.02)


def optimize(spec: OptimizeSpec, pareto: bool = False) -> dict:
    """Run the search of the package docstring.

    Parameters
    ----------
    spec : OptimizeSpec
        The problem (:func:`load_optimize_spec`).
    pareto : bool
        Also return the non-dominated (objective, robust fraction) designs evaluated.

    Returns
    -------
    dict
        JSON-ready result: ``feasible``; for a feasible problem ``objective``, ``x``,
        ``active_constraints`` (binding), ``binding`` (how each was found), ``at_bounds``,
        ``latency_margin`` (required and achieved, exact, with units), ``metrics``, …; for an
        infeasible one the best design's ``x``, ``broken``, ``violations`` and ``at_bounds``.

    References
    ----------
    docs/optimize-spec.md; paper §IV (coupled stability) and §IV-A (passivity).
    """
    rng = np.random.default_rng(spec.seed)
    verdicts = None
    c = spec.constraints
    if spec.cfg.implementation.sample_rate_hz and c["robust"] and c["free_stable"] and c["locked_stable"]:
        # decided on the sampled-data loop — certify's decision requires every stability verdict,
        # so a spec that disables one keeps the continuous search (docs/optimize-spec.md#sample-rate)
        from .sampled import sampled_search

        ar, u, lm, res, used, rounds, verdicts, srec = sampled_search(spec, rng, _search)
    else:
        ar, u, lm, res, used, rounds = _search(spec, rng)
    if u is None:
        return _infeasible(ar, spec)
    if verdicts is not None:
        # decided on the sampled-data loop: the continuous constraints but the latency margin are
        # checked here, the margin is the sampled-data one (the continuous one reported beside it)
        ar = _rearchived(ar, dataclasses.replace(spec, constraints={**spec.constraints, "latency_margin_s": 0.0}))
        lm = exact_latency_margin(spec, from_unit(spec, u[None, :])[0])
    final = ar.evaluate(u[None, :])
    assert bool(final["feasible"][0]), "the optimum must be feasible"
    x = final["X"][0]
    what, sense, unit = OBJECTIVES[spec.objective]
    achieved = float(lm.extra_delay_s) if verdicts is None else verdicts.latency_margin_s
    names, details = binding(ar, u, final, achieved)
    if verdicts is not None:
        names, details = _sampled_binding(spec, verdicts, names, details)
    bounds = at_bounds(spec, u, x)
    if ar.j is not None and any(b["parameter"] == what for b in bounds):
        lo, hi, _sc = spec.free[what]
        names = names + [f"bound {what} ≤ {hi:g}" if sense == "max" else f"bound {what} ≥ {lo:g}"]
    near = [n for n, (col, op, _u) in CONSTRAINTS.items()
            if n in spec.constraints and n != "latency_margin_s" and _rel_slack(spec, final, n) < 0.01]
    value = achieved if spec.objective == "latency_margin_s" else float(final["objective"][0])
    out = {
        "feasible": True,
        "objective": {"name": spec.objective, "sense": sense, "value": value, "unit": unit},
        "x": dict(zip(ar.paths, x.tolist())),
        "x_relative": dict(zip(ar.paths, np.clip(u, 0.0, 1.0).tolist())),
        "active_constraints": names,
        "binding": details,
        "at_bounds": bounds,
        "near_binding": near,
        "evaluated": int(ar.count),
        "de_message": str(res.message),
        "latency_margin": ({**latency_record(used, lm), "tightening_rounds": rounds} if verdicts is None
                           else _sampled_latency_record(spec, lm, verdicts, srec)),
        "metrics": _metrics(spec, final),
        "robust_fraction": float(final["robust_fraction"][0]),
        "spec": spec.raw,
    }
    if not names:
        out["note"] = ("no constraint is binding (metric objective): a local optimum of the search"
                       + (", limited by the parameter bounds listed in at_bounds" if bounds else ""))
    if not out["latency_margin"]["met"]:
        out["latency_warning"] = (f"the exact latency margin {achieved * 1e3:.6g} ms is below the required "
                                  f"{out['latency_margin']['required_s'] * 1e3:.6g} ms after {rounds} tightening rounds")
    if verdicts is not None:
        out["sampled_data"] = {"certifiable": verdicts.certifiable, "problems": list(verdicts.problems),
                               "rounds": srec["rounds"], "polished": srec["polished"],
                               "continuous_constraint_s": srec["continuous_constraint_s"], "log": srec["log"],
                               "verdicts": verdicts.to_dict()}
        if not verdicts.certifiable:
            out["latency_warning"] = (f"the returned design does not certify on the sampled-data loop after "
                                      f"{srec['rounds']} rounds: " + "; ".join(verdicts.problems))
    _certificates(spec, out)
    if pareto:
        out["pareto"] = _pareto(spec, ar)
    return out


def _rearchived(old: Archive, spec: OptimizeSpec) -> Archive:
    """A new archive under ``spec`` that keeps the evaluation count and the old evaluations as history."""
    ar = Archive(spec)
    ar.count, ar.history = old.count, old.history + old.evs
    return ar


def _sampled_binding(spec, verdicts, names: list, details: list):
    """The sampled-data latency margin counts as binding within 2 % of its requirement (the
    objective is bisected on the sampled-data verdicts to 10⁻³, where the margin is the limit)."""
    m = float(spec.constraints.get("latency_margin_s", 0.0))
    ach = verdicts.latency_margin_s
    if m > 0 and math.isfinite(ach) and (ach - m) / m < 0.02:
        names = sorted(names + ["latency_margin_s"])
        details = details + [{"constraint": "latency_margin_s", "how": "slack (sampled-data)", "value": ach, "bound": m,
                              "op": ">=", "unit": "s"}]
    return names, details


def _sampled_latency_record(spec, lm, verdicts, srec) -> dict:
    """The ``latency_margin`` section with a sample rate: the sampled-data margin of record, the
    continuous one beside it."""
    rec = latency_record(spec, lm)
    fs = verdicts.sample_rate_hz
    ach = verdicts.latency_margin_s
    fin = math.isfinite(ach)
    cont = rec["achieved_s"]
    crit = verdicts.latency_margin.get("critical")
    return {**rec, "model": f"sampled-data at {fs:g} Hz", "achieved_s": ach if fin else None,
            "achieved_unbounded": not fin, "achieved_samples": ach * fs if fin else None,
            "met": bool(ach >= rec["required_s"]), "verified": verdicts.latency_margin.get("confirmed"),
            "critical": crit, "continuous_s": cont, "continuous_samples": None if cont is None else cont * fs,
            "tightening_rounds": srec["rounds"],
            "units": {**rec["units"], "continuous_s": "s", "continuous_samples": "samples"}}


def _rel_slack(spec, final, name) -> float:
    col, op, _u = CONSTRAINTS[name]
    b = spec.constraints[name]
    v = float(np.asarray(column(final, col))[0])
    return ((v - b) if op == ">=" else (b - v)) / max(abs(b), 1e-12)


def _infeasible(ar: Archive, spec: OptimizeSpec) -> dict:
    U, _v = ar.least_violation()
    ev = ar.evaluate(U[None, :])
    x = ev["X"][0]
    lm = exact_latency_margin(spec, x, ev, 0) if ev["broken"].get("latency_margin_s", [False])[0] else None
    achieved = None if lm is None else float(lm.extra_delay_s)
    broken = sorted(k for k, v in ev["broken"].items() if v[0])
    if not broken:  # every constraint met, yet no design to return: the objective is undefined wherever they are
        broken = [f"objective: {spec.objective} is undefined (NaN) at every design evaluated that meets the constraints"]
    return {"feasible": False, "evaluated": int(ar.count), "x": dict(zip(ar.paths, x.tolist())),
            "x_relative": dict(zip(ar.paths, np.clip(U, 0.0, 1.0).tolist())),
            "broken": broken,
            "violations": violations(spec, ev, 0, achieved),
            "at_bounds": at_bounds(spec, U, x), "spec": spec.raw}


def _certificates(spec, out) -> None:
    from ..analysis import kyp_certificates
    from ..analysis.kyp import certificates_dict
    from ..config import design_from_mapping

    opt_cfg = design_from_mapping(optimized_design_mapping(spec, out))
    # with a sample rate the optimum was decided on the sampled-data loop (out["sampled_data"])
    certs = certificates_dict(kyp_certificates(opt_cfg))
    # the convex sub-problem: KYP certificates of the optimum's rational C7 models (an SDP, Clarabel)
    out["passivity_certificates"] = certs
    nom = certs.get("nominal") or {}
    if spec.constraints["nominal_passive"] and nom.get("passive") is not True:
        out["certificate_warning"] = ("the KYP certificate does not confirm the closed-form nominal passivity of the "
                                      f"optimum: {nom.get('reason', certs.get('error'))}")


def _metrics(spec, final) -> dict:
    from ..config import batch_config
    from .evaluate import schedule_worst

    res = final["analysis"]
    g = lambda v: float(np.asarray(v)[0])  # noqa: E731
    cfg1 = batch_config(spec.cfg, {p: final["X"][:, j] for j, p in enumerate(spec.free)})
    pk_db, pk_hz = amplification_peak(cfg1)
    vals = {"passivity_max_phase_excess_deg": res.passivity.max_phase_excess_deg,
            "dob_phase_margin_deg": res.dob.phase_margin_deg, "dob_gain_margin_db": res.dob.gain_margin_db,
            "dob_delay_margin_s": res.dob.delay_margin_s, "amplification_bandwidth_hz": res.amplification.bandwidth_hz,
            "amplification_peak_db": pk_db, "amplification_peak_hz": pk_hz}
    sched = final.get("schedule")
    over = None
    if sched is not None:  # every entry runs on the joint: the worst of them (the constraints' values)
        worst = {"passivity_max_phase_excess_deg": "<=", "dob_phase_margin_deg": ">=", "dob_gain_margin_db": ">=",
                 "dob_delay_margin_s": ">=", "amplification_bandwidth_hz": ">=", "amplification_peak_db": "<="}
        vals.update(schedule_worst({**final, "own_columns": {"amplification_peak_db": pk_db, "amplification_peak_hz": pk_hz}},
                                   sched, worst))
        over = f"the worst of the main controller and its {len(sched.ratio)} gain-schedule entries"
    units = {"passivity_max_phase_excess_deg": "deg", "dob_phase_margin_deg": "deg", "dob_gain_margin_db": "dB",
             "dob_delay_margin_s": "s", "amplification_bandwidth_hz": "Hz", "amplification_peak_db": "dB"}
    # the keys of the optimize result (docs/optimize-spec.md#result): the sweep's column names
    out = {k: {"value": g(vals[k]), "unit": u, **({"over": over} if over else {})} for k, u in units.items()}
    out["amplification_peak_db"]["frequency_hz"] = g(vals["amplification_peak_hz"])
    out["human_stable_intervals"] = {f"{key}_stable_intervals": h.stable_intervals[0]
                                     for key, h in zip(res.human_names(), res.humans)}
    return out


def _pareto(spec, ar: Archive) -> list[dict]:
    """Non-dominated (objective, robust fraction) among designs meeting every other constraint
    (the latency margin, which needs robustness, excepted)."""
    what, sense, _ = OBJECTIVES[spec.objective]
    rows = []
    for ev in ar.history + ar.evs:
        other = np.ones(ev["X"].shape[0], bool)
        for n, v in ev["broken"].items():
            if n not in ("robust", "latency_margin_s"):
                other &= ~v
        for i in np.nonzero(other)[0]:
            o = float(ev["objective"][i])
            if math.isfinite(o):
                rows.append((o if sense == "max" else -o, float(ev["robust_fraction"][i]), ev["X"][i]))
    rows.sort(key=lambda r: (-r[0], -r[1]))
    front, best_r = [], -1.0
    for o, r, x in rows:
        if r > best_r:
            front.append({"objective": o if sense == "max" else -o, "robust_fraction": r,
                          **dict(zip(spec.free, x.tolist()))})
            best_r = r
    return front
