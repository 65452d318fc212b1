"""Latency margin of the coupled loops: the largest extra delay the design tolerates.

Every loop of a design (the free exoskeleton, each environment, each member of each human family)
has the characteristic quasi-polynomial Δ(s) = P0(s) + P1(s) e^{−sτ} with τ the total
measured-to-applied latency (docs/method.md#analyses-and-metrics; the delay enters only through the
actuator path, paper Fig. 3). An extra latency ΔT ≥ 0 turns τ = T into T + ΔT. A root reaches the
imaginary axis at s = jω (ω > 0) for the delay τ exactly when

    |P0(jω)| = |P1(jω)|    and    e^{−jωτ} = −P0(jω)/P1(jω),

so for each crossing frequency ω_k the delays that put a root there are
τ = (−arg(−P0/P1) + 2πn)/ω_k; the first one above T gives ΔT_k = ((−θ_k − ω_k T) mod 2π)/ω_k, and
the loop's latency margin is min_k ΔT_k (a stable loop can only lose stability at a crossing, and
the first crossing is the first destabilizing delay — later stability windows are never reported).

For a family Z = Z0 + p φ with p ∈ [lo, hi] (Δ = Δ_0 + p φ Δ_1, coefficients affine in p), the
crossing condition at fixed ω is a real quadratic in p,

    (|B0|² − |B1|²) p² + 2 Re(A0 B̄0 − A1 B̄1) p + |A0|² − |A1|² = 0      (P_i = A_i + p B_i),

so the crossing set is a few smooth curves p(ω) in the (ω, p) plane. The family margin is the
minimum of ΔT along those curves inside [lo, hi] and of the two end members' own margins (a curve
leaving the range ends at an end member).

One engine computes it: :mod:`exotune.analysis.latency` (the sweep column's), here for a
batch of one design with every loop's margin, crossing frequency and critical member
(:func:`~exotune.analysis.latency.loop_latency_margins`). The single-design margin is then
checked by the exact argument-principle verdicts at T + ΔT(1 ∓ 10⁻⁶) (above: also
10⁻⁵ and 10⁻⁴, for a set of members unstable just above the margin too narrow to resolve) (see
:func:`latency_margin` ``verify``) and, if the first check fails (a dip between grid points), the
member found unstable there lowers the margin until both checks pass.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from ..record import Result
from .latency import INFINITE_PROBES_S, delay_limit, design_loops, loop_latency_margins, member_latency_margins

__all__ = ["LoopMargin", "LatencyMargin", "latency_margin", "schedule_latency_margin", "latency_boundaries",
           "LatencyBoundary"]

TWO_PI = 2.0 * math.pi
VERIFY_REL = 1e-6
ABOVE_REL = (VERIFY_REL, 1e-5, 1e-4)  # relative steps above the margin where a verdict must change


@dataclass(frozen=True)
class LoopMargin(Result):
    """The latency margin of one loop: ``extra_delay_s`` (inf when no extra delay destabilizes it,
    0 when it is not stable at the nominal delay), the crossing ``frequency_hz`` and, for a family,
    the critical member ``value`` of ``parameter``."""

    loop: str
    extra_delay_s: float
    frequency_hz: float | None = None
    parameter: str | None = None
    value: float | None = None
    unit: str | None = None

    def to_dict(self) -> dict:
        return {"loop": self.loop, "extra_delay_s": self.extra_delay_s, "frequency_hz": self.frequency_hz,
                "parameter": self.parameter, "value": self.value, "unit": self.unit}


@dataclass(frozen=True)
class LatencyMargin(Result):
    """Design latency margin: the minimum over its loops, with the critical loop and the per-loop list."""

    extra_delay_s: float
    critical: LoopMargin | None
    loops: tuple[LoopMargin, ...] = field(default_factory=tuple)
    delay_s: float = 0.0
    sample_rate_hz: float | None = None
    verified: bool | None = None
    note: str = ""
    #: (joint angle [rad], transmission ratio) of the gain-schedule entry whose margin this is (None: the plant section's)
    gain_schedule_entry: tuple[float, float] | None = None
    #: the plant section's own margin [s] when an entry's is smaller
    main_controller_s: float | None = None

    @property
    def extra_delay_samples(self) -> float | None:
        if not self.sample_rate_hz or not math.isfinite(self.extra_delay_s):
            return None if not self.sample_rate_hz else math.inf
        return self.extra_delay_s * self.sample_rate_hz

    def to_dict(self) -> dict:
        return {
            "extra_delay_s": self.extra_delay_s,
            "extra_delay_samples": self.extra_delay_samples,
            "delay_s": self.delay_s,
            "critical": None if self.critical is None else self.critical.to_dict(),
            "loops": [m.to_dict() for m in self.loops],
            "verified": self.verified,
            "note": self.note,
            "gain_schedule_entry": (None if self.gain_schedule_entry is None else
                                    dict(zip(("joint_angle_rad", "ratio"), self.gain_schedule_entry))),
            "main_controller_s": self.main_controller_s,
            "units": {"extra_delay_s": "s", "extra_delay_samples": "samples", "frequency_hz": "Hz",
                      "main_controller_s": "s"},
        }

    def to_text(self) -> str:
        """The latency lines of ``exotune analyze``'s margins section.

        Returns
        -------
        str
            The text.
        """
        from ..text.margins import format_margins

        return "\n".join(format_margins({"latency": self.to_dict()}))

    def __repr__(self) -> str:
        c = self.critical
        where = f", critical {c.loop}" + (f" at {c.parameter} = {c.value:.6g} {c.unit}" if c and c.value is not None else "") if c else ""
        return f"LatencyMargin({self.extra_delay_s * 1e3:.6g} ms{where})"


def _nominal_ok(res, name: str, t: int = 0) -> bool:
    """The verdict of one loop from a batch analysis (a box's edges share the box's flag)."""
    return bool(res.loop(name).verdict[t])


def _all_ok(res, t: int) -> bool:
    return bool(res.loops_ok()[t])


def _analyze_delays(cfg, delays):
    from ..config.batch import batch_config, continuous
    from .batch import analyze_batch

    # the continuous analysis: probing delays may exceed the sampled model's delay-state limit
    b = batch_config(continuous(cfg), {"implementation.delay_s": np.asarray(delays, dtype=float)})
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        return analyze_batch(b)


def latency_margin(cfg, nominal=None, verify: bool = True) -> LatencyMargin:
    """Latency margin of a design (module docstring): the largest extra measured-to-applied delay
    ΔT ≥ 0 for which the cuff-free exoskeleton and every environment stay stable and every human
    family stays robust over its whole range.

    Parameters
    ----------
    cfg : DesignConfig
        One design (``exotune.config.load_design``).
    nominal : BatchAnalysis, optional
        The design's batch analysis (``analyze_batch(cfg)``) if already computed.
    verify : bool
        Confirm the margin by the exact verdicts at T + ΔT(1 ∓ 10⁻⁶) (and lower it while the
        first check fails).

    Returns
    -------
    LatencyMargin
        ``extra_delay_s`` [s] (``inf``: no extra delay destabilizes; 0: not robust at the nominal
        delay), the critical loop, its member and crossing frequency, and every loop's margin.

    References
    ----------
    docs/method.md#latency-margin; paper Fig. 5 (a delay in the actuator path destabilizes the amplification loop) and Fig. 3.

    Examples
    --------
    >>> import exotune
    >>> m = latency_margin(exotune.load_design("examples/scheduled.yaml"))
    >>> round(m.extra_delay_s * 1e3, 2), m.critical.loop
    (2.13, 'human0_mass')
    >>> latency_margin(exotune.load_design("examples/paper.yaml")).note   # light masses unstable already
    'not robust at the nominal delay'
    """
    return _latency_margins([cfg], [nominal], verify)[0]


def _latency_margins(cfgs: list, nominals: list, verify: bool) -> list:
    """:func:`latency_margin` of designs that share their human families and environments (a design
    and its gain-schedule entries): the crossing search of every loop runs on them as one batch
    (:func:`~exotune.analysis.latency.loop_latency_margins` treats each row on its own), then each
    margin is checked on its own design."""
    from .batch import analyze_batch
    from .charfun import CharTerms

    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        cts = [_terms(c) for c in cfgs]
        ct = cts[0] if len(cts) == 1 else CharTerms.stack(cts)
        names, dTs, ws, ps = loop_latency_margins(ct, cfgs[0].humans, cfgs[0].environment)
        out = []
        for i, (cfg, nominal) in enumerate(zip(cfgs, nominals)):
            cols = nominal if nominal is not None else analyze_batch(cfg)
            out.append(_design_margin(cfg, cols, cts[i], names, dTs[:, i], ws[:, i], ps[:, i], verify))
        return out


def _design_margin(cfg, cols, ct, names, dTs, ws, ps, verify: bool) -> LatencyMargin:
    """One design's margin from its loops' crossing-search results (``cols``: its nominal analysis)."""
    T = float(ct.T[0])
    fs = cfg.implementation.sample_rate_hz or None
    loops = []
    for (name, fam, _key), dT, w, p in zip(names, dTs, ws, ps):
        kw = {} if fam is None else {"parameter": fam.param, "unit": fam.unit}
        if not _nominal_ok(cols, name):
            loops.append(LoopMargin(name, 0.0, **kw))
            continue
        found = bool(np.isfinite(dT))
        loops.append(LoopMargin(name, float(dT), float(w) / TWO_PI if found else None,
                                value=float(p) if found and fam is not None else None, **kw))
    crit = min(loops, key=lambda m: m.extra_delay_s) if loops else None
    margin = crit.extra_delay_s if crit else math.inf
    if verify and margin == math.inf:
        return _infinite_checked(cfg, LatencyMargin(margin, crit, tuple(loops), T, fs))
    if not verify or not math.isfinite(margin) or margin == 0.0:
        note = "not robust at the nominal delay" if margin == 0.0 else ""
        return LatencyMargin(margin, crit, tuple(loops), T, fs, None, note)
    return _verified(cfg, ct, LatencyMargin(margin, crit, tuple(loops), T, fs))


def schedule_latency_margin(cfg, lm: LatencyMargin) -> tuple[LatencyMargin, tuple[LatencyMargin, ...]]:
    """The latency margin of a design with a gain schedule (a ``transmission`` table): the smallest
    of the plant section's margin ``lm`` and every entry's (the design rescheduled at each joint
    angle, paper §IV gain scheduling: J_m, B_m, K_s × ratio², gains recomputed). The runtime runs
    every entry, so each must tolerate the extra delay; an unknown margin (NaN) of any of them makes
    the design's unknown.

    Parameters
    ----------
    cfg : DesignConfig
        One design, with or without ``transmission``.
    lm : LatencyMargin
        Its own margin (:func:`latency_margin`).

    Returns
    -------
    (LatencyMargin, tuple of LatencyMargin)
        The design's margin (``gain_schedule_entry`` and ``main_controller_s`` set when an entry's
        is the smallest) and one margin per entry (empty without a schedule).

    References
    ----------
    docs/method.md#latency-margin; paper §IV (gain scheduling).
    """
    tr = (cfg.raw or {}).get("transmission")
    if not tr:
        return lm, ()
    cfgs = [replace(cfg, plant=cfg.plant.reflected(float(r))) for r in tr["ratio"]]
    entries = _latency_margins(cfgs, [None] * len(cfgs), True)  # one crossing search for every entry
    pick = [(lm, None)] + list(zip(entries, zip(map(float, tr["joint_angle_rad"]), map(float, tr["ratio"]))))
    unknown = [p for p in pick if math.isnan(p[0].extra_delay_s)]
    worst, where = unknown[0] if unknown else min(pick, key=lambda p: p[0].extra_delay_s)
    if where is None or (not unknown and worst.extra_delay_s >= lm.extra_delay_s):
        return lm, tuple(entries)
    return replace(worst, gain_schedule_entry=where, main_controller_s=lm.extra_delay_s), tuple(entries)




def _infinite_checked(cfg, res: LatencyMargin) -> LatencyMargin:
    """An infinite margin is a claim about every extra delay: it is checked by the exact verdicts at
    :data:`INFINITE_PROBES_S` (within the accepted delays; :func:`~exotune.analysis.batch.first_unstable_probe`,
    the sweep column's check too). A loop unstable at one of them means the crossing search missed
    its crossing (a pole far beyond the frequency range it resolves): the margin is then unknown
    (NaN, not verified), never infinite."""
    from .batch import first_unstable_probe

    probed = res.delay_s + INFINITE_PROBES_S[0] <= delay_limit()
    bad = float(first_unstable_probe(cfg, [0])[0]) if probed else math.nan
    if math.isnan(bad):
        return replace(res, verified=True if probed else None)
    loops = tuple(replace(lp, extra_delay_s=math.nan) if lp.extra_delay_s == math.inf else lp for lp in res.loops)
    return replace(res, extra_delay_s=math.nan, verified=False, critical=None, loops=loops,
                   note=(f"no destabilizing crossing was found, yet the loops are not all stable at "
                         f"{bad * 1e3:.3g} ms of extra delay: the margin is unknown (a pole beyond the "
                         "frequency range the analysis resolves?)"))


def _verified(cfg, ct, res: LatencyMargin) -> LatencyMargin:
    """Check the margin by exact verdicts just below and above it; lower it while the check below
    fails (a destabilizing dip between grid points: its unstable member gives a smaller margin)."""
    T = res.delay_s
    hi = delay_limit()
    loops = list(res.loops)
    crit = res.critical
    for _ in range(8):
        m = crit.extra_delay_s
        if T + m * (1 - VERIFY_REL) > hi:  # beyond the delays the analysis accepts: not checked
            return LatencyMargin(m, crit, tuple(loops), T, res.sample_rate_hz, None,
                                 f"the total delay at the margin exceeds {hi:g} s, the largest the exact "
                                 "verdicts accept: not verified")
        above = [r for r in ABOVE_REL if T + m * (1 + r) <= hi]
        cols = _analyze_delays(cfg, [T + m * (1 - VERIFY_REL)] + [T + m * (1 + r) for r in above])
        if _all_ok(cols, 0):
            changed = [r for t, r in enumerate(above, start=1) if not _all_ok(cols, t)]
            note = ""
            if not above:
                note = f"not checked above the margin (beyond the {hi:g} s delay the exact verdicts accept)"
            elif not changed:
                note = (f"no verdict change up to {ABOVE_REL[-1]:g} above the margin "
                        "(a crossing that does not destabilize)")
            elif changed[0] > VERIFY_REL:
                note = (f"the verdict changes between {VERIFY_REL:g} and {changed[0]:g} above the margin "
                        "(the members unstable just above it form a very narrow set)")
            return LatencyMargin(m, crit, tuple(loops), T, res.sample_rate_hz, bool(changed), note)
        lowered = None
        for name, fam, key1 in design_loops(cfg.humans, cfg.environment):
            if fam is None or _nominal_ok(cols, name, 0):
                continue
            key = name.split("_edge")[0]
            ivs = [] if fam.box else list(cols.loop(key).stable_intervals[0])
            gaps, prev = [], fam.lo
            for a, b in sorted(ivs):
                if a > prev:
                    gaps.append((prev, a))
                prev = max(prev, b)
            if prev < fam.hi:
                gaps.append((prev, fam.hi))
            for a, b in gaps or [(fam.lo, fam.hi)]:
                dT, w, pm = _member_minimum(ct, fam, key1, a, b)
                if dT < m and (lowered is None or dT < lowered.extra_delay_s):
                    lowered = LoopMargin(name, float(dT), None if w is None else w / TWO_PI, fam.param, float(pm), fam.unit)
        if lowered is None:
            return LatencyMargin(m, crit, tuple(loops), T, res.sample_rate_hz, False,
                                 "the exact check below the margin failed and no lower member was found")
        crit = lowered
        loops = [lowered if lp.loop == lowered.loop else lp for lp in loops]
    return LatencyMargin(crit.extra_delay_s, crit, tuple(loops), T, res.sample_rate_hz, False,
                         "the exact checks did not settle after 8 refinements")


def _terms(cfg):
    """The characteristic terms of one design (a batch of one)."""
    from ..model.controller import build_controller
    from .charfun import char_terms

    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    return char_terms(cfg.plant, cs, 1)


def _member_minimum(ct, fam, key: str, a: float, b: float, n: int = 17):
    """The smallest single-member latency margin over members p ∈ [a, b] of a family: ``n``
    members (log-spaced for a positive range; one batch of the latency engine), then bounded
    scalar minimization around the best one. Returns (ΔT [s], ω [rad/s] or None, p)."""
    from scipy.optimize import minimize_scalar

    def member(p):
        return member_latency_margins(ct, 0, fam, key, [p])

    ps = np.geomspace(a, b, n) if a > 0 else np.linspace(a, b, n)
    vals, _ = member_latency_margins(ct, 0, fam, key, ps)
    k = int(np.argmin(vals))
    best_p = float(ps[k])
    if b > a:
        lo_p, hi_p = float(ps[max(k - 1, 0)]), float(ps[min(k + 1, n - 1)])
        res = minimize_scalar(lambda p: min(float(member(p)[0][0]), 1e300), bounds=(lo_p, hi_p), method="bounded",
                              options={"xatol": 1e-10 * max(abs(hi_p), 1e-300)})
        if res.fun < vals[k]:
            best_p = float(res.x)
    dT, w = member(best_p)
    return float(dT[0]), (float(w[0]) if np.isfinite(w[0]) else None), best_p


@dataclass(frozen=True)
class LatencyBoundary:
    """The stability boundary of one human family in the (member, extra delay) plane: for each
    member ``values`` [unit], the extra delay ``extra_delay_s`` [s] at which it first loses
    stability (inf: never; NaN: unstable already at the nominal delay)."""

    loop: str
    parameter: str
    unit: str
    values: np.ndarray
    extra_delay_s: np.ndarray
    delay_s: float


def latency_boundaries(cfg, n: int = 160, intervals: list | None = None) -> list[LatencyBoundary]:
    """Per human family (a box: per edge), the first destabilizing extra delay of ``n`` members
    spread over its range (log-spaced for a positive range) — the data of the latency-boundary
    figure of ``exotune analyze --plots``.

    Members unstable at the nominal delay (by the exact family intervals) get NaN.

    Parameters
    ----------
    cfg : DesignConfig
        One design.
    n : int
        Members per family.
    intervals : list, optional
        The exact stable intervals of each human family, in the order of ``cfg.humans`` (as
        ``exotune analyze`` reports them: ``result["humans"][i]["stable_intervals"]``); given, the
        design is not analysed again (``analyze --plots`` analyses once).

    Returns
    -------
    list of LatencyBoundary

    References
    ----------
    docs/method.md#latency-margin; paper Fig. 5.

    Examples
    --------
    >>> import exotune
    >>> b = latency_boundaries(exotune.load_design("examples/scheduled.yaml"), n=8)
    >>> b[0].loop, b[0].unit, b[0].values.size
    ('human0_mass', 'kg·m²', 8)
    """
    from .batch import analyze_batch

    out = []
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        if intervals is None:
            intervals = [h.stable_intervals[0] for h in analyze_batch(cfg).humans]
        ct = _terms(cfg)
        T = float(ct.T[0])
        for name, fam, key1 in design_loops(cfg.humans, cfg.environment):
            if fam is None or not name.startswith("human"):
                continue
            lo, hi = fam.lo, fam.hi
            ps = np.geomspace(lo, hi, n) if lo > 0 else np.linspace(lo, hi, n)
            i = int(name[len("human"):].split("_")[0])
            ivs = [] if fam.box else [tuple(iv) for iv in (intervals[i] or [])]
            stable = np.array([fam.box or any(a <= p <= b for a, b in ivs) for p in ps], dtype=bool)
            dts = np.full(n, np.nan)
            if stable.any():
                dts[stable] = member_latency_margins(ct, 0, fam, key1, ps[stable])[0]
            out.append(LatencyBoundary(name, fam.param, fam.unit, ps, dts, T))
    return out
