"""Exact evaluation of a population of candidate designs: constraints, violation, objective.

Every candidate is analysed by :func:`exotune.analysis.analyze_batch` (whole populations in one
call). The latency-margin constraint ``latency_margin_s ≥ m`` is imposed during the search by
requiring the delay-sensitive verdicts (cuff-free exoskeleton, environments, every human family
robust over its range — the loops of :func:`exotune.analysis.latency_margin.latency_margin`) also at the
delays T + Δ for the extra delays Δ of :meth:`OptimizeSpec.checked_delays` (m·k/K, k = 1..K):
the candidates are repeated once per extra delay and analysed in one batch. The objective
``latency_margin_s`` is estimated per candidate from the same verdicts: a ladder of extra delays
(:data:`LADDER_S`) gives the first failing level, then three rounds of 7-point multisection of
that bracket (geometric) give a value within ≈ 0.2 % below the first destabilizing extra delay
found on the ladder; the optimizer evaluates the final short list with the exact margin.

References
----------
docs/optimize-spec.md; paper §IV (coupled stability, delay in the actuator path: Fig. 5).
"""

from __future__ import annotations

import math

import numpy as np

from .peak import amplification_peak
from .spec import CONSTRAINTS, OBJECTIVES, OptimizeSpec

__all__ = ["evaluate", "column", "delay_verdicts", "latency_ladder", "LADDER_S", "robust_fraction", "delay_sensitive_ok",
           "schedule_verdicts", "schedule_worst"]

#: extra delays [s] of the latency-objective ladder (the estimate is capped at the last one)
LADDER_S = np.geomspace(1e-5, 0.2, 12)
_LADDER_ROUNDS = 3
_LADDER_POINTS = 7


def _log_fraction(ivs, lo, hi) -> float:
    if hi <= lo:
        return 1.0 if ivs else 0.0
    f = (lambda x: math.log(x)) if lo > 0 else (lambda x: x)
    return sum(f(b) - f(a) for a, b in ivs) / (f(hi) - f(lo))


def robust_fraction(cfg, res) -> np.ndarray:
    """Smallest, over the human families, stable log-fraction of the family's range (1: robust),
    from a :class:`~exotune.analysis.BatchAnalysis` ``res`` of the batch.

    Parameters
    ----------
    cfg : DesignConfig
        The batch config (its human families and ranges).
    res : BatchAnalysis
        Its analysis.

    Returns
    -------
    numpy.ndarray
        Per design, in [0, 1] (1 only when robust).
    """
    frac = np.ones(res.n)
    for fam, h in zip(cfg.humans, res.humans):
        fr = np.array([_log_fraction(iv, fam.lo, fam.hi) for iv in h.stable_intervals])
        fr = np.where(np.asarray(h.robust, bool), 1.0, np.minimum(fr, 1.0 - 1e-9))
        frac = np.minimum(frac, fr)
    return frac


def delay_sensitive_ok(res) -> np.ndarray:
    """The loops of the latency margin all stable: free, every environment, every human family
    (:meth:`~exotune.analysis.BatchAnalysis.loops_ok` of the batch analysis ``res``).

    Parameters
    ----------
    res : BatchAnalysis
        The batch analysis.

    Returns
    -------
    numpy.ndarray
        Per design, bool.
    """
    return res.loops_ok()


def column(ev: dict, name: str) -> np.ndarray:
    """The values of the objective or constraint column ``name`` (docs/optimize-spec.md: the
    column names of docs/sweep-spec.md#columns) for the rows of an evaluation ``ev``: the batch
    analysis's column, or the optimizer's own ``amplification_peak_db``/``_hz`` and
    ``latency_margin_s`` estimate when the evaluation computed them.

    Parameters
    ----------
    ev : dict
        The evaluation.
    name : str
        The column's name.

    Returns
    -------
    numpy.ndarray
        One value per row, in the column's unit.
    """
    own = ev.get("own_columns", {})
    return own[name] if name in own else ev["analysis"].column(name)


def _overrides(spec, X, rep: int = 1) -> dict:
    return {p: np.repeat(X[:, j], rep) for j, p in enumerate(spec.free)}


def _delays(spec, X) -> np.ndarray:
    paths = list(spec.free)
    if "implementation.delay_s" in paths:
        return X[:, paths.index("implementation.delay_s")].astype(float)
    return np.full(X.shape[0], float(spec.cfg.implementation.delay_s))


def delay_verdicts(spec: OptimizeSpec, X: np.ndarray, extra: np.ndarray) -> tuple:
    """Delay-sensitive verdicts of the rows of X at T + extra[i, l] (one batch).

    Returns (ok of shape ``extra.shape``, the :class:`~exotune.analysis.BatchAnalysis`).

    Parameters
    ----------
    spec : OptimizeSpec
        The optimization problem.
    X : numpy.ndarray
        Designs (n, D), natural units.
    extra : numpy.ndarray
        Extra delays [s] per design (n, L).

    Returns
    -------
    ok : numpy.ndarray
        Whether every delay-sensitive verdict holds, (n, L) bool.
    res : BatchAnalysis
        The batch analysis of the n·L designs.
    """
    from ..analysis import analyze_batch
    from ..analysis.gain_schedule import analyze_schedule
    from ..config.batch import batch_config, continuous

    X = np.atleast_2d(X)
    extra = np.asarray(extra, float).reshape(X.shape[0], -1)
    L = extra.shape[1]
    ov = _overrides(spec, X, L)
    ov["implementation.delay_s"] = (_delays(spec, X)[:, None] + extra).ravel()
    cfg = batch_config(continuous(spec.cfg), ov)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        # continuous analysis: the probed delays may exceed the sampled model's delay-state limit
        res = analyze_batch(cfg)
        ok = delay_sensitive_ok(res)
        sched = analyze_schedule(cfg)  # a gain schedule: every entry must tolerate the delay too
    if sched is not None:
        ok = ok & sched.robust()
    return ok.reshape(X.shape[0], L), res


def latency_ladder(spec: OptimizeSpec, X: np.ndarray) -> np.ndarray:
    """Estimated latency margin [s] of the rows of X (module docstring): a value at which every
    delay-sensitive verdict still holds, within ≈ 0.2 % of the first failing extra delay of the
    ladder; capped at the last ladder level (no failure up to it).

    Parameters
    ----------
    spec : OptimizeSpec
        The optimization problem.
    X : numpy.ndarray
        Designs (n, D), natural units.

    Returns
    -------
    numpy.ndarray
        The estimated latency margin [s] per design (n,).
    """
    X = np.atleast_2d(X)
    n = X.shape[0]
    if n == 0:
        return np.zeros(0)
    ok, _ = delay_verdicts(spec, X, np.broadcast_to(LADDER_S, (n, LADDER_S.size)))
    fail = ~ok
    first = np.where(fail.any(1), fail.argmax(1), LADDER_S.size)
    lo = np.where(first == 0, 0.0, LADDER_S[np.maximum(first - 1, 0)])
    hi = np.where(first < LADDER_S.size, LADDER_S[np.minimum(first, LADDER_S.size - 1)], np.nan)
    todo = np.nonzero(np.isfinite(hi))[0]
    t = np.arange(1, _LADDER_POINTS + 1) / (_LADDER_POINTS + 1)
    for _ in range(_LADDER_ROUNDS):
        if todo.size == 0:
            break
        a, b = lo[todo], hi[todo]
        geo = a > 0
        P = np.where(geo[:, None], np.where(geo, a, 1.0)[:, None] * (b / np.where(geo, a, 1.0))[:, None] ** t[None, :],
                     a[:, None] + (b - a)[:, None] * t[None, :])
        okp, _ = delay_verdicts(spec, X[todo], P)
        # first failing interior point: the bracket ends there, starts at the point before it
        f = ~okp
        k = np.where(f.any(1), f.argmax(1), t.size)
        new_lo = np.where(k == 0, a, P[np.arange(todo.size), np.maximum(k - 1, 0)])
        new_hi = np.where(k < t.size, P[np.arange(todo.size), np.minimum(k, t.size - 1)], b)
        lo[todo], hi[todo] = new_lo, new_hi
    return lo


def _verdict_violation(spec, res, frac):
    """Violation and broken flags of the boolean stability constraints at the nominal delay."""
    n = frac.size
    viol = np.zeros(n)
    broken = {}
    if spec.constraints["robust"]:
        v = 1.0 - frac
        viol += v
        broken["robust"] = v > 0
    for name, loop in (("free_stable", res.free), ("locked_stable", res.locked)):
        if spec.constraints[name]:
            bad = ~np.asarray(loop.stable, bool)
            viol += bad
            broken[name] = bad
    if spec.constraints["locked_stable"]:
        for key, e in zip(res.environment_names(), res.environment):
            bad = ~np.asarray(e.verdict, bool)
            viol += bad
            broken[key + ("_stable" if e.stable is not None else "_robust")] = bad  # the column's name
    return viol, broken


def schedule_verdicts(spec: OptimizeSpec, sched) -> np.ndarray:
    """Per gain-schedule entry and design, shape (E, N): the entry meets the boolean stability
    constraints the spec asks for (``robust``: every human family robust; ``free_stable``;
    ``locked_stable``: the locked loop and every environment), paper §IV gain scheduling.

    Parameters
    ----------
    spec : OptimizeSpec
        The optimization problem.
    sched : ScheduleBatch
        The entries' analysis (:func:`exotune.analysis.gain_schedule.analyze_schedule`).

    Returns
    -------
    numpy.ndarray
        bool, (E, N).
    """
    res = sched.analysis
    ok = np.ones(res.n, bool)
    if spec.constraints["robust"]:
        for h in res.humans:
            ok &= np.asarray(h.robust, bool)
    if spec.constraints["free_stable"]:
        ok &= np.asarray(res.free.stable, bool)
    if spec.constraints["locked_stable"]:
        ok &= np.asarray(res.locked.stable, bool)
        for e in res.environment:
            ok &= np.asarray(e.verdict, bool)
    return ok.reshape(len(sched.ratio), -1)


def schedule_worst(ev: dict, sched, want: dict) -> dict:
    """Metric columns worst over the main controller and every gain-schedule entry (the runtime
    runs each: paper §IV gain scheduling): the smallest value of a ``>=`` column (a lower bound
    or a maximized metric), the largest of a ``<=`` one; NaN when any of them is NaN.

    Parameters
    ----------
    ev : dict
        The evaluation of the main controllers (its ``analysis`` and ``own_columns``).
    sched : ScheduleBatch
        Their entries (:func:`exotune.analysis.gain_schedule.analyze_schedule`).
    want : dict
        Column name (docs/sweep-spec.md#columns, or ``amplification_peak_db``) → ``">="`` or ``"<="``.

    Returns
    -------
    dict
        Column name → values (N,), in the column's unit; ``amplification_peak_hz`` goes with the
        worst ``amplification_peak_db``.
    """
    from ..analysis.gain_schedule import worst_over

    e = len(sched.ratio)
    out = {}
    for col, op in want.items():
        if col == "amplification_peak_db":
            db, hz = amplification_peak(sched.cfg)
            main_db, main_hz = (column(ev, col), column(ev, "amplification_peak_hz")) if col in ev["own_columns"] \
                else amplification_peak(ev["cfg"])
            vals = np.vstack([np.asarray(main_db, float), np.asarray(db, float).reshape(e, -1)])
            hzs = np.vstack([np.asarray(main_hz, float), np.asarray(hz, float).reshape(e, -1)])
        else:
            vals = np.vstack([np.asarray(column(ev, col), float),
                              np.asarray(sched.analysis.column(col), float).reshape(e, -1)])
        out[col], k = worst_over(vals, op)
        if col == "amplification_peak_db":
            out["amplification_peak_hz"] = hzs[k, np.arange(vals.shape[1])]
    return out


def _spec_columns(spec) -> dict:
    """The metric columns the constraints and the objective read, with their direction."""
    want = {CONSTRAINTS[n][0]: CONSTRAINTS[n][1] for n in spec.constraints if n in CONSTRAINTS and n != "latency_margin_s"}
    what, sense, _u = OBJECTIVES[spec.objective]
    if what not in spec.free and what != "latency_margin_s":
        want.setdefault(what, ">=" if sense == "max" else "<=")
    return want


def _schedule_violation(spec, sched):
    """Violation and broken flag of the gain schedule: every entry must meet the stability
    constraints (:func:`schedule_verdicts`); the violation is the mean over the entries of the
    failed flag plus the unstable log-fraction of the families."""
    ok = schedule_verdicts(spec, sched)
    fr = robust_fraction(spec.cfg, sched.analysis).reshape(ok.shape) if spec.constraints["robust"] else 1.0
    return np.mean(~ok + (1.0 - fr), axis=0), ~ok.all(axis=0)


def _latency_violation(spec, X, res, frac):
    """Violation and broken flag of ``latency_margin_s ≥ m`` (the checked extra delays)."""
    deltas = spec.checked_delays()
    n = X.shape[0]
    if deltas.size == 0:
        return np.zeros(n), np.zeros(n, bool)
    nominal = delay_sensitive_ok(res)
    viol = np.where(nominal, 0.0, 2.0)  # not stable at T: its margin is 0
    broken = ~nominal
    sel = np.nonzero(nominal)[0]
    if sel.size:
        ok, dres = delay_verdicts(spec, X[sel], np.broadcast_to(deltas, (sel.size, deltas.size)))
        fr = robust_fraction(spec.cfg, dres).reshape(sel.size, deltas.size)
        viol[sel] = np.mean(~ok + (1.0 - fr), axis=1)
        broken[sel] = ~ok.all(1)
    return viol, broken


def evaluate(spec: OptimizeSpec, X: np.ndarray) -> dict:
    """Analyse the candidate designs of the rows of X exactly (module docstring).

    Parameters
    ----------
    spec : OptimizeSpec
        The problem.
    X : numpy.ndarray
        One candidate per row, columns in ``spec.free`` order, natural units.

    Returns
    -------
    dict
        ``X``, ``analysis`` (the :class:`~exotune.analysis.BatchAnalysis`), ``own_columns`` (the
        optimizer's own ``amplification_peak_db``/``_hz`` when that constraint is set and the
        ``latency_margin_s`` estimate when it is the objective; read both through :func:`column`),
        ``violation`` (0 for feasible rows, else the total normalized
        violation), ``feasible``, ``broken`` (constraint name → bool per row), ``objective`` and
        ``robust_fraction``.

    References
    ----------
    docs/optimize-spec.md; paper §IV (coupled stability).
    """
    from ..analysis import analyze_batch
    from ..analysis.gain_schedule import analyze_schedule
    from ..config import batch_config

    X = np.atleast_2d(np.asarray(X, float))
    paths = list(spec.free)
    cfg_b = batch_config(spec.cfg, _overrides(spec, X))
    ev = {"X": X, "analysis": analyze_batch(cfg_b), "own_columns": {}, "cfg": cfg_b}
    res, own = ev["analysis"], ev["own_columns"]
    if "amplification_peak_db" in spec.constraints:
        own["amplification_peak_db"], own["amplification_peak_hz"] = amplification_peak(cfg_b)
    frac = robust_fraction(spec.cfg, res)
    viol, broken = _verdict_violation(spec, res, frac)
    dob_stable = np.asarray(res.dob.stable, bool)
    sched = ev["schedule"] = analyze_schedule(cfg_b)
    if sched is not None:
        v, bad = _schedule_violation(spec, sched)
        viol += v
        broken["gain_schedule"] = bad
        frac = np.minimum(frac, robust_fraction(spec.cfg, sched.analysis).reshape(len(sched.ratio), -1).min(axis=0))
        own.update(schedule_worst(ev, sched, _spec_columns(spec)))  # every entry's metrics meet the bounds
        dob_stable = dob_stable & np.asarray(sched.analysis.dob.stable, bool).reshape(len(sched.ratio), -1).all(axis=0)
    for name, (col, op, _unit) in CONSTRAINTS.items():
        if name not in spec.constraints or name == "latency_margin_s":
            continue
        b = spec.constraints[name]
        val = np.asarray(column(ev, col), float)
        val = np.where(np.isnan(val), -np.inf if op == ">=" else np.inf, val)
        gap = (b - val) if op == ">=" else (val - b)
        if name.startswith("dob_"):  # a DOB margin of an unstable DOB loop never meets a bound
            gap = np.where(dob_stable, gap, np.inf)
        v = np.clip(gap / max(abs(b), 1e-12), 0.0, 10.0)
        v = np.where(np.isfinite(v), v, 10.0)
        viol += v
        broken[name] = gap > 0
    if spec.constraints["nominal_passive"]:
        short, b_over_kc = _nominal_shortage(cfg_b, X.shape[0])
        v = np.clip(short / b_over_kc, 0.0, 10.0)
        viol += v
        broken["nominal_passive"] = short > 0
    if spec.constraints.get("latency_margin_s", 0.0) > 0:
        v, bad = _latency_violation(spec, X, res, frac)
        viol += v
        broken["latency_margin_s"] = bad
    what = OBJECTIVES[spec.objective][0]
    if what in paths:
        obj = X[:, paths.index(what)]
    elif what == "latency_margin_s":
        obj = np.full(X.shape[0], np.nan)
        sel = np.nonzero(viol == 0)[0]
        obj[sel] = latency_ladder(spec, X[sel])
        own["latency_margin_s"] = obj
    else:
        obj = np.asarray(column(ev, what), float)
    ev.update(violation=viol, feasible=viol == 0, broken=broken, objective=obj, robust_fraction=frac)
    return ev


def _nominal_shortage(c, n):
    """Closed-form nominal passivity shortage of a batch (:func:`exotune.analysis.kyp.nominal_shortage`)
    and its normalization B̂_m/(Ĵ_m K_c) (the shortage when ζ̂ = 0)."""
    from ..analysis.kyp import nominal_shortage

    d, pl = c.design, c.plant
    short = nominal_shortage(d.amplification, d.felt_inertia, d.felt_damping, pl.K_c, d.zeta_hat)
    b_over_kc = np.asarray(d.felt_damping, float) / np.asarray(d.felt_inertia, float) / np.asarray(pl.K_c, float)
    return np.broadcast_to(short, (n,)), np.broadcast_to(b_over_kc, (n,))
