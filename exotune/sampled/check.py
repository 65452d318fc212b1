"""The sampled-data check of one design against its continuous analysis (``exotune analyze`` with a
sample rate): the free and locked verdicts of the exact sampled-data loop, and each rational
family's verdicts at log-spaced members and near its continuous interval ends.

References
----------
docs/method.md#sampled-data; paper §V (the experiments' 1 kHz runtime).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..numerics.threads import one_blas_thread
from .loop import default_prewarp, sampled_stable, sampled_verdict

__all__ = ["CHECK_POINTS", "Disagreement", "Boundary", "SampledFamilyCheck", "SampledCheck", "check_design"]

CHECK_POINTS = 24


@dataclass(frozen=True)
class Disagreement:
    """A member (``value``, in its parameter's unit) where the sampled-data and continuous verdicts differ."""

    value: float
    continuous_stable: bool
    sampled_stable: bool

    def to_dict(self) -> dict:
        return {"value": self.value, "continuous_stable": self.continuous_stable, "sampled_stable": self.sampled_stable}


@dataclass(frozen=True)
class Boundary:
    """An interior end ``continuous`` of a continuous stable interval and the sampled-data boundary
    found near it (``sampled``; None when none in [e/2, 2e]); ``unsafe``: the members between them
    that the continuous analysis calls stable and the sampled-data loop does not (None: none)."""

    continuous: float
    sampled: float | None
    unsafe: tuple[float, float] | None

    def to_dict(self) -> dict:
        return {"continuous": self.continuous, "sampled": self.sampled,
                "sampled_unstable_where_continuous_stable": None if self.unsafe is None else list(self.unsafe)}


@dataclass(frozen=True)
class SampledFamilyCheck:
    """One human family or environment: verdicts at ``points`` members (``stable_points`` stable),
    the ``disagreements`` and the ``boundaries``; or ``skipped`` with the reason (a complex
    stiffness, a box)."""

    kind: str
    parameter: str
    skipped: str | None = None
    note: str | None = None
    points: int = 0
    stable_points: int = 0
    disagreements: tuple[Disagreement, ...] = ()
    boundaries: tuple[Boundary, ...] = ()

    def to_dict(self) -> dict:
        d = {"kind": self.kind, "parameter": self.parameter}
        if self.skipped is not None:
            d["skipped"] = self.skipped
            return d
        if self.note is not None:
            d["note"] = self.note
        d.update({"points": self.points, "stable_points": self.stable_points,
                  "disagreements": [x.to_dict() for x in self.disagreements],
                  "boundaries": [b.to_dict() for b in self.boundaries]})
        return d


@dataclass(frozen=True)
class SampledCheck:
    """The sampled-data check of a design at ``sample_rate_hz`` [Hz]: the free and locked verdicts
    (None: inconclusive, a spectral radius within rounding of 1), the free loop's spectral radius
    [–] and the per-family checks."""

    sample_rate_hz: float
    method: str
    free_stable: bool | None
    free_spectral_radius: float
    locked_stable: bool | None
    humans: tuple[SampledFamilyCheck, ...] = ()
    environment: tuple[SampledFamilyCheck, ...] = ()

    def to_dict(self) -> dict:
        """The ``sampled_data`` section of ``exotune analyze --json``."""
        return {"sample_rate_hz": self.sample_rate_hz, "method": self.method, "free_stable": self.free_stable,
                "free_spectral_radius": self.free_spectral_radius, "locked_stable": self.locked_stable,
                "humans": [h.to_dict() for h in self.humans], "environment": [e.to_dict() for e in self.environment]}


def _compare(stable_at, kind: str, param: str, lo: float, hi: float, ivs, points: int,
             note: str | None = None) -> SampledFamilyCheck:
    """Sampled verdicts of one family against its continuous stable intervals ``ivs``: at
    ``points`` log-spaced values, and near every interior interval end (the sampled boundary,
    bisected in [e/2, 2e] ∩ [lo, hi], 40 steps)."""
    vals = np.geomspace(lo, hi, points) if lo > 0 else np.linspace(lo, hi, points)
    mism = []
    n_stable = 0
    for v in vals.tolist():
        s = stable_at(v)
        c = any(a <= v <= b for a, b in ivs)
        n_stable += bool(s)
        if s != c:
            mism.append(Disagreement(v, c, bool(s)))
    ends = []
    for e in sorted({x for iv in ivs for x in iv if lo < x < hi}):
        a, b = max(lo, e / 2), min(hi, 2 * e)
        sa, sb = stable_at(a), stable_at(b)
        found = None
        if sa != sb and a > 0:
            for _ in range(40):
                m = math.sqrt(a * b)
                if stable_at(m) == sa:
                    a = m
                else:
                    b = m
            found = math.sqrt(a * b)
        unsafe = None
        if found is not None and abs(found / e - 1.0) > 1e-6:
            mid = math.sqrt(e * found)
            if any(a_ <= mid <= b_ for a_, b_ in ivs):  # continuous stable there, sampled not
                unsafe = (min(e, found), max(e, found))
        ends.append(Boundary(e, found, unsafe))
    return SampledFamilyCheck(kind, param, note=note, points=int(vals.size), stable_points=n_stable,
                              disagreements=tuple(mism), boundaries=tuple(ends))


@one_blas_thread
def check_design(cfg, human_intervals, environment_intervals, points: int = CHECK_POINTS) -> SampledCheck:
    """Sampled-data check of one design at ``implementation.sample_rate_hz`` against its continuous
    analysis (:func:`exotune.analysis.analyze_design`): the free and locked verdicts, and for each
    rational human family the verdict at ``points`` log-spaced values of its range compared with
    the continuous stable intervals (``human_intervals``, ``environment_intervals``: one sequence
    of (lo, hi) per family or environment of ``cfg``, None for a box or a single loop).
    Disagreements are listed (value, continuous, sampled).

    Parameters
    ----------
    cfg : DesignConfig
        The validated design, with ``implementation.sample_rate_hz`` set.
    human_intervals : sequence
        Continuous stable intervals per human family of ``cfg``: a sequence of (lo, hi) in the
        family parameter's unit, or None.
    environment_intervals : sequence
        Continuous stable intervals per environment of ``cfg``, or None.
    points : int, optional
        Log-spaced members per family range.

    Returns
    -------
    SampledCheck
        The free and locked verdicts, the free loop's spectral radius and the per-family checks.

    References
    ----------
    docs/method.md#sampled-data.
    """
    from ..model.controller import build_controller

    fs = float(cfg.implementation.sample_rate_hz)
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    pw = default_prewarp(cfg.implementation)
    run = lambda human=None, env="free": sampled_stable(cfg.plant, cs, fs, human, env, prewarp=pw)  # noqa: E731
    free, rho_free, _ = sampled_verdict(cfg.plant, cs, fs, prewarp=pw)
    locked, _, _ = sampled_verdict(cfg.plant, cs, fs, env="locked", prewarp=pw)
    Ts = 1.0 / fs
    q = float(np.ravel(cfg.implementation.delay_s)[0]) / Ts
    method = ("plant (+ human) discretized exactly with a zero-order hold, delay as "
              f"{q:.4g} sample{'' if q == 1 else 's'} (shift states, fractional part exact); controller blocks by "
              "Tustin prewarped at " + ", ".join(f"{k}: {v:g} Hz" for k, v in pw.items())
              + ("; velocities by the discretized velocity filter" if cfg.implementation.velocity_filter is not None
                 else "; ideal sampled velocities") + "; DOB algebraic loop solved")
    humans = []
    for fam, ivs in zip(cfg.humans, human_intervals):
        if fam.kind == "complex_stiffness" or fam.box:
            humans.append(SampledFamilyCheck(fam.kind, fam.param, skipped=(
                "not rational (evaluated on the frequency axis only)" if fam.kind == "complex_stiffness"
                else "box family: see the per-edge continuous intervals")))
            continue
        h = {k: val for k, val in fam.fixed().items() if k in ("inertia", "damping", "stiffness")}
        humans.append(_compare(lambda v, h=h, q=fam.param: run(human={**h, q: v})[0], fam.kind, fam.param,
                               fam.lo, fam.hi, ivs or [], points))
    env = []
    for e, ivs in zip(cfg.environment, environment_intervals):
        if e.kind not in ("spring", "mass"):
            continue
        env.append(_compare(lambda v, e=e: run(env={e.param: v, "damping": e.damping})[0], e.kind, e.param,
                            e.lo, e.hi, ivs or [], points, note="cuff free, environment at the joint"))
    return SampledCheck(fs, method, free, rho_free, locked, tuple(humans), tuple(env))
