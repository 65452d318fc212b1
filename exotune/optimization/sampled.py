"""``exotune optimize`` with a sample rate: the returned design is decided on the sampled-data loop
the exported controller runs (docs/method.md#one-model-of-record).

The search screens with the continuous model (exact delay), which overstates the latency margin of
a sampled runtime by about half a sample (the zero-order hold). Its optimum is then judged by
``certify``'s own decision on the controller ``export`` would write
(:func:`exotune.controllerfile.verdicts.design_verdicts`). While that refuses it, the search runs
again with the continuous latency constraint raised by the measured gap (continuous − sampled
margin at the refused design, at least half a sample, growing 25 % per round). Once one design
holds, the constraint is adjusted by a safeguarded secant between the largest refused and the
smallest accepted constraint, aiming at a sampled-data margin just above the requirement (so that
the tightening costs no more objective than it must); ``ROUNDS`` re-runs at most, and the best
accepted design wins. When the objective is a free parameter, its value is finally pushed back
towards the first (continuous-only) optimum by bisection on the sampled-data verdicts (the other
parameters fixed, every continuous constraint but the latency margin still checked) to
``POLISH_REL`` relative.

References
----------
docs/optimize-spec.md#sample-rate; docs/method.md#one-model-of-record.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .space import Archive, from_unit, to_unit
from .spec import OptimizeSpec, optimized_design_mapping

__all__ = ["ROUNDS", "POLISH_REL", "TARGET_SLACK", "sampled_search", "verdicts_at"]

#: searches re-run with an adjusted continuous latency constraint, at most
ROUNDS = 5
#: relative resolution of the final bisection of the objective parameter on the sampled-data verdicts
POLISH_REL = 1e-3
#: the secant on the continuous constraint aims at a sampled-data margin this much above the requirement
TARGET_SLACK = 0.002


def verdicts_at(spec: OptimizeSpec, x: np.ndarray, continuous_margin=None):
    """The sampled-data verdicts of record (:class:`~exotune.controllerfile.verdicts.SampledVerdicts`)
    of the design ``x`` (free-parameter values) held to the spec's latency margin.

    Parameters
    ----------
    spec : OptimizeSpec
        The optimization problem (a base design with a sample rate).
    x : numpy.ndarray
        The design's free-parameter values, natural units (D,).
    continuous_margin : LatencyMargin or None, optional
        The design's continuous latency margin, where the sampled margin's search starts.

    Returns
    -------
    SampledVerdicts
        The verdicts of record.
    """
    from ..config import design_from_mapping
    from ..controllerfile.verdicts import design_verdicts

    cfg = design_from_mapping(optimized_design_mapping(spec, {"x": dict(zip(spec.free, map(float, x)))}))
    m = float(spec.constraints.get("latency_margin_s", 0.0))
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        return design_verdicts(cfg, require_latency_margin_s=m, continuous_margin=continuous_margin)


def _raised(spec: OptimizeSpec, m_c: float) -> OptimizeSpec:
    return dataclasses.replace(spec, constraints={**spec.constraints, "latency_margin_s": m_c}, latency_deltas=())


def _other_constraints_ok(spec: OptimizeSpec, x: np.ndarray) -> bool:
    """Every continuous constraint of the spec but the latency margin holds at ``x``."""
    ar = Archive(_raised(spec, 0.0))
    return bool(ar.evaluate(to_unit(spec, x[None, :]))["feasible"][0])


def _polish(spec: OptimizeSpec, x_ok: np.ndarray, v_ok, hi_value: float, log: list):
    """Bisect the objective parameter between the certifiable ``x_ok`` and ``hi_value`` (its value
    at the continuous-only optimum) on the sampled-data verdicts; returns (x, verdicts)."""
    from .spec import OBJECTIVES

    what, sense, _u = OBJECTIVES[spec.objective]
    j = list(spec.free).index(what)
    lo_b, hi_b, _sc = spec.free[what]
    a, b = float(x_ok[j]), float(np.clip(hi_value, lo_b, hi_b))
    if (b - a) * (1 if sense == "max" else -1) <= POLISH_REL * abs(a):
        return x_ok, v_ok
    best = (x_ok, v_ok)
    while abs(b - a) > POLISH_REL * abs(a):
        x = x_ok.copy()
        x[j] = 0.5 * (a + b)
        ok = _other_constraints_ok(spec, x)
        v = verdicts_at(spec, x) if ok else None
        good = v is not None and v.certifiable
        log.append({"stage": "polish", what: float(x[j]), "certifiable": good,
                    "sampled_latency_margin_s": None if v is None else _fin(v.latency_margin_s)})
        if good:
            a, best = x[j], (x, v)
        else:
            b = x[j]
    return best


def _fin(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def _next_constraint(m: float, fs: float, k: int, bad: list, good: list, gap: float) -> float:
    """The next continuous latency constraint [s]: raised by the measured gap while no design
    certifies, then a secant (safeguarded bisection) between the largest refused and the smallest
    accepted constraint aiming at a sampled-data margin of m·(1 + ``TARGET_SLACK``)."""
    if not good:
        return max(bad[-1][0], m) + max(gap, 0.5 / fs) * (1.0 + 0.25 * k)
    lo = max(bad, key=lambda b: b[0])
    hi = min(good, key=lambda g: g[0])
    span = hi[0] - lo[0]
    want = m * (1.0 + TARGET_SLACK)
    t = 0.5
    if math.isfinite(lo[1]) and math.isfinite(hi[1]) and hi[1] > lo[1] and lo[1] < want < hi[1]:
        t = (want - lo[1]) / (hi[1] - lo[1])
    return lo[0] + span * min(max(t, 0.1), 0.9)


def sampled_search(spec: OptimizeSpec, rng, search):
    """The search of ``optimize`` (``search(spec, rng)`` → archive, u, continuous latency margin,
    DE result, spec used, tightening rounds) closed on the sampled-data verdicts (module docstring).

    Parameters
    ----------
    spec : OptimizeSpec
        The optimization problem (a base design with a sample rate).
    rng : numpy.random.Generator
        The random generator of the search.
    search : callable
        The continuous search, ``search(spec, rng)``.

    Returns
    -------
    tuple
        (archive, u, continuous latency margin, DE result, spec used, tightening rounds, verdicts of
        record of the returned design or None, the record of the sampled-data rounds: a dict with
        ``rounds``, ``polished``, ``continuous_constraint_s`` and ``log``).
    """
    fs = float(spec.cfg.implementation.sample_rate_hz)
    m = float(spec.constraints.get("latency_margin_s", 0.0))
    state = search(spec, rng)
    record = {"rounds": 0, "polished": False, "log": [], "continuous_constraint_s": m}
    if state[1] is None:
        return (*state, None, record)
    x0 = from_unit(state[4], state[1][None, :])[0]
    m_c, bad, good, best = m, [], [], None
    for k in range(ROUNDS + 1):
        ar, u, lm, _res, used, _r = state
        x = from_unit(used, u[None, :])[0]
        v = verdicts_at(spec, x, lm)
        value = float(ar.value(ar.evaluate(u[None, :]))[0])
        record["log"].append({"stage": f"round {k}", "continuous_constraint_s": m_c, "x": dict(zip(spec.free, x.tolist())),
                              "objective": value, "certifiable": v.certifiable,
                              "sampled_latency_margin_s": _fin(v.latency_margin_s),
                              "continuous_latency_margin_s": _fin(float(lm.extra_delay_s)), "problems": list(v.problems)})
        if v.certifiable:
            good.append((m_c, v.latency_margin_s))
            if best is None or value > best[0]:
                best = (value, state, v, m_c)
            if not bad or m <= 0 or v.latency_margin_s <= m * (1.0 + 2 * TARGET_SLACK):
                break  # the continuous constraint never bound, or the sampled margin is tight
        else:
            bad.append((m_c, v.latency_margin_s if v.latency_margin_s < m or m <= 0 else -math.inf))
        if k == ROUNDS:
            break
        cont, samp = float(lm.extra_delay_s), v.latency_margin_s
        gap = cont - samp if math.isfinite(cont) and math.isfinite(samp) else 0.0
        m_c = _next_constraint(m, fs, k, bad, good, gap)
        record["rounds"] = k + 1
        state = search(_raised(spec, m_c), rng)
        if state[1] is None:
            if best is None:
                return (*state, None, record)
            bad.append((m_c, -math.inf))
            break
    if best is None:
        return (*state, v, record)
    _value, state, v, record["continuous_constraint_s"] = best
    ar, u, lm, res, used, rounds = state
    if record["rounds"] and ar.j is not None:
        x_ok = from_unit(used, u[None, :])[0]
        x_best, v = _polish(spec, x_ok, v, float(x0[ar.j]), record["log"])
        if x_best is not x_ok:
            record["polished"] = True
            u = to_unit(used, x_best[None, :])[0]
    return ar, u, lm, res, used, rounds, v, record
