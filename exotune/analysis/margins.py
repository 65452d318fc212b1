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
leaving the range ends at an end member). The curves are followed on a log-spaced frequency grid up
to the family's tail bound and every local minimum is refined by bounded scalar minimization; the
result is then checked by the exact argument-principle verdicts at T + ΔT(1 ∓ 10⁻⁶) (above: also
10⁻⁵ and 10⁻⁴, for a set of members unstable just above the margin too narrow to resolve) (see
:func:`latency_margin` ``verify``) and, if the first check fails (a dip between grid points), the
member found unstable there lowers the margin until both checks pass.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

__all__ = ["LoopMargin", "LatencyMargin", "qp_latency_margin", "family_latency_margin", "latency_margin"]

TWO_PI = 2.0 * math.pi
GRID_PER_DECADE = 120
GRID_DECADES = 9.0
VERIFY_REL = 1e-6
ABOVE_REL = (VERIFY_REL, 1e-5, 1e-4)  # relative steps above the margin where a verdict must change


@dataclass(frozen=True)
class LoopMargin:
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
class LatencyMargin:
    """Design latency margin: the minimum over its loops, with the critical loop and the per-loop list."""

    extra_delay_s: float
    critical: LoopMargin | None
    loops: tuple[LoopMargin, ...] = field(default_factory=tuple)
    delay_s: float = 0.0
    sample_rate_hz: float | None = None
    verified: bool | None = None
    note: str = ""

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
            "units": {"extra_delay_s": "s", "extra_delay_samples": "samples", "frequency_hz": "Hz"},
        }

    def __repr__(self) -> str:
        c = self.critical
        where = f", critical {c.loop}" + (f" at {c.parameter} = {c.value:.6g} {c.unit}" if c and c.value is not None else "") if c else ""
        return f"LatencyMargin({self.extra_delay_s * 1e3:.6g} ms{where})"


# ---------------------------------------------------------------------------------------------
# polynomial helpers (ascending coefficients, one design)
# ---------------------------------------------------------------------------------------------
def _at_jw(c: np.ndarray, w: np.ndarray) -> np.ndarray:
    """P(jω) for ascending coefficients ``c`` (1-D, real or complex) at the frequencies ``w``."""
    s = 1j * np.asarray(w, dtype=float)
    out = np.zeros(s.shape, dtype=complex)
    for a in np.asarray(c)[::-1]:
        out = out * s + a
    return out


def _first_delay(P0: np.ndarray, P1: np.ndarray, w: np.ndarray, T: float) -> np.ndarray:
    """ΔT ≥ 0 of the first crossing at ω for loops with P0(jω), P1(jω) of equal magnitude."""
    theta = np.angle(-P0 / P1)
    return np.mod(-theta - w * T, TWO_PI) / w


def _tail(c0: np.ndarray, c1: np.ndarray) -> float:
    """A frequency above which |P0(jω)| > |P1(jω)| (Cauchy-type bound; inf for neutral loops)."""
    c0 = np.trim_zeros(np.asarray(c0), "b")
    c1 = np.trim_zeros(np.asarray(c1), "b")
    if c0.size == 0:
        return math.inf
    n0 = c0.size - 1
    lead = abs(c0[-1])
    if c1.size - 1 >= n0:
        return math.inf
    # |P0| ≥ lead ω^n0 − Σ_{k<n0} |c0_k| ω^k and |P1| ≤ Σ |c1_k| ω^k: beyond the root bound of
    # lead ω^n0 = Σ_k (|c0_k| + |c1_k|) ω^k every crossing is excluded
    tot = np.zeros(n0)
    tot[: c0.size - 1] += np.abs(c0[:-1])
    tot[: c1.size] += np.abs(c1)
    ratios = [(tot[k] / lead) ** (1.0 / (n0 - k)) for k in range(n0) if tot[k] > 0]
    return 2.0 * max(ratios) if ratios else 1.0


def _crossings_1d(c0: np.ndarray, c1: np.ndarray, wmax: float) -> np.ndarray:
    """Positive roots of F(ω) = |P0(jω)|² − |P1(jω)|² below ``wmax``: sign changes on a log grid,
    refined by bisection, plus the real roots of the polynomial F (which also finds tangencies)."""
    from scipy.optimize import brentq

    w = np.geomspace(wmax * 10.0 ** (-GRID_DECADES), wmax, int(GRID_DECADES * GRID_PER_DECADE) + 1)

    def F(x):
        return np.abs(_at_jw(c0, x)) ** 2 - np.abs(_at_jw(c1, x)) ** 2

    f = F(w)
    roots = []
    idx = np.nonzero(np.sign(f[:-1]) * np.sign(f[1:]) < 0)[0]
    for i in idx:
        roots.append(brentq(lambda x: float(F(np.array([x]))[0]), w[i], w[i + 1], xtol=1e-15 * w[i + 1], rtol=1e-15))
    # tangencies: local minima of |F| relative to its scale that come within float resolution of 0
    scale = np.abs(_at_jw(c0, w)) ** 2 + np.abs(_at_jw(c1, w)) ** 2
    r = np.abs(f) / np.where(scale > 0, scale, 1.0)
    loc = np.nonzero((r[1:-1] < r[:-2]) & (r[1:-1] < r[2:]) & (r[1:-1] < 1e-6))[0] + 1
    roots.extend(w[loc])
    return np.unique(np.asarray(roots, dtype=float))


def qp_latency_margin(c0: np.ndarray, c1: np.ndarray, T: float) -> tuple[float, float | None]:
    """Latency margin of one stable loop Δ = P0 + P1 e^{−sT} (1-D ascending coefficients; the
    exact roots at s = 0 divided out beforehand): (ΔT [s], crossing frequency [rad/s] or None)."""
    c0 = np.asarray(c0)
    c1 = np.asarray(c1)
    if not np.any(c1):
        return math.inf, None
    wmax = _tail(c0, c1)
    if not math.isfinite(wmax):
        wmax = 1e7
    ws = _crossings_1d(c0, c1, wmax)
    if ws.size == 0:
        return math.inf, None
    dT = _first_delay(_at_jw(c0, ws), _at_jw(c1, ws), ws, T)
    k = int(np.argmin(dT))
    return float(dT[k]), float(ws[k])


def _quad_roots(a, b, c):
    """Real roots p of a p² + b p + c = 0 elementwise: (p_minus, p_plus), NaN where none."""
    with np.errstate(invalid="ignore", divide="ignore"):
        disc = b * b - 4.0 * a * c
        sq = np.sqrt(np.where(disc >= 0, disc, np.nan))
        # numerically stable pair
        q = -0.5 * (b + np.copysign(sq, b))
        r1 = np.where(a != 0, q / a, -c / b)
        r2 = np.where(q != 0, c / q, np.nan)
        r2 = np.where(a != 0, r2, np.nan)
    return np.minimum(r1, r2), np.maximum(r1, r2)


def family_latency_margin(a0, a1, b0, b1, lo: float, hi: float, T: float, wmax: float):
    """Latency margin of the family P0 = A0 + p B0, P1 = A1 + p B1, p ∈ [lo, hi] (1-D ascending
    coefficient arrays; B already multiplied by φ and the complex factor for ω > 0).

    Returns (ΔT [s], ω [rad/s] or None, p critical)."""
    from scipy.optimize import minimize_scalar

    a0, a1, b0, b1 = (np.asarray(x, dtype=complex) for x in (a0, a1, b0, b1))

    def pad(x, n):
        return np.concatenate([x, np.zeros(n - x.size, dtype=complex)])

    n0 = max(a0.size, b0.size)
    n1 = max(a1.size, b1.size)
    a0, b0, a1, b1 = pad(a0, n0), pad(b0, n0), pad(a1, n1), pad(b1, n1)
    best = (math.inf, None, None)
    for p in (lo, hi):  # the end members, exactly
        dT, w = qp_latency_margin(a0 + p * b0, a1 + p * b1, T)
        if dT < best[0]:
            best = (dT, w, p)
    if lo == hi:
        return best

    def branch_delay(w, which):
        w = np.atleast_1d(np.asarray(w, dtype=float))
        A0, B0, A1, B1 = (_at_jw(x, w) for x in (a0, b0, a1, b1))
        qa = np.abs(B0) ** 2 - np.abs(B1) ** 2
        qb = 2.0 * np.real(A0 * np.conj(B0) - A1 * np.conj(B1))
        qc = np.abs(A0) ** 2 - np.abs(A1) ** 2
        # scale-free: divide by a common magnitude (the quadratic's roots are unchanged)
        sc = np.abs(qa) * max(abs(lo), abs(hi)) ** 2 + np.abs(qb) * max(abs(lo), abs(hi)) + np.abs(qc)
        sc = np.where(sc > 0, sc, 1.0)
        pm = _quad_roots(qa / sc, qb / sc, qc / sc)[which]
        ok = np.isfinite(pm) & (pm >= lo) & (pm <= hi)
        P0 = A0 + pm * B0
        P1 = A1 + pm * B1
        with np.errstate(invalid="ignore", divide="ignore"):
            dT = np.where(ok & (np.abs(P1) > 0), _first_delay(P0, np.where(P1 != 0, P1, 1.0), w, T), np.inf)
        return dT, pm

    w = np.geomspace(wmax * 10.0 ** (-GRID_DECADES), wmax, int(GRID_DECADES * GRID_PER_DECADE) + 1)
    for which in (0, 1):
        dT, pm = branch_delay(w, which)
        fin = np.isfinite(dT)
        if not fin.any():
            continue
        # local minima of ΔT along the branch (grid), each refined in its bracket
        cand = [i for i in np.nonzero(fin)[0]
                if (i == 0 or dT[i] <= dT[i - 1]) and (i == w.size - 1 or dT[i] <= dT[i + 1])]
        cand = sorted(cand, key=lambda i: dT[i])[:12]
        for i in cand:
            lo_w, hi_w = w[max(i - 1, 0)], w[min(i + 1, w.size - 1)]
            val, wi, pi = float(dT[i]), float(w[i]), float(pm[i])
            if hi_w > lo_w:
                res = minimize_scalar(lambda x: min(float(branch_delay(x, which)[0][0]), 1e300), bounds=(lo_w, hi_w),
                                      method="bounded", options={"xatol": 1e-12 * hi_w})
                if res.fun < val:
                    val, wi = float(res.fun), float(res.x)
                    pi = float(branch_delay(wi, which)[1][0])
            if val < best[0]:
                best = (val, wi, pi)
    return best


# ---------------------------------------------------------------------------------------------
# the design's loops
# ---------------------------------------------------------------------------------------------
def _family_tail(a0, a1, b0, b1, lo: float, hi: float) -> float:
    """A frequency above which no member p ∈ [lo, hi] has |P0(jω)| ≤ |P1(jω)| (tail bounds of
    members on a log grid of the range, with a safety factor: the exact checks confirm)."""
    ps = np.unique(np.r_[lo, hi, np.geomspace(lo, hi, 33) if lo > 0 else np.linspace(lo, hi, 33)])
    n0 = max(a0.size, b0.size)
    n1 = max(a1.size, b1.size)
    pad = lambda x, n: np.concatenate([np.asarray(x, dtype=complex), np.zeros(n - np.asarray(x).size, dtype=complex)])
    A0, B0, A1, B1 = pad(a0, n0), pad(b0, n0), pad(a1, n1), pad(b1, n1)
    t = max(_tail(A0 + p * B0, A1 + p * B1) for p in ps)
    return 4.0 * t if math.isfinite(t) else 1e7


def _family_coeffs(ct, fam, key0: str, key1: str):
    """(A0, A1, B0, B1) of Δ = Δ_0 + p φ f Δ_1 for one family (1-D ascending coefficients)."""
    from ..model.humans import family_split

    z0, phi, factor = family_split(fam.kind, fam.param, fam.fixed(), fam.eta)
    D0, D1 = ct.combine(key0, key1, z0) if np.any(z0) else (ct.qp(key0), ct.qp(key1))
    a0, a1 = np.asarray(D0.p0[0]), np.asarray(D0.p1[0])
    b0 = np.convolve(np.asarray(D1.p0[0]), phi) * factor
    b1 = np.convolve(np.asarray(D1.p1[0]), phi) * factor
    return a0, a1, b0, b1


def _add(a, b):
    n = max(a.size, b.size)
    return np.pad(np.asarray(a, dtype=complex), (0, n - a.size)) + np.pad(np.asarray(b, dtype=complex), (0, n - b.size))


def _loops(cfg, ct):
    """(name, family or None, key1, compute) for every loop of the design; compute() → (ΔT, ω, p)."""
    from ..model.humans import HumanFamily

    T = float(ct.T[0])
    out = []

    def single(key):
        q = ct.qp(key)
        return lambda: (*qp_latency_margin(q.p0[0], q.p1[0], T), None)

    def family(fam, key1):
        def run():
            a0, a1, b0, b1 = _family_coeffs(ct, fam, "00", key1)
            wmax = _family_tail(a0, a1, b0, b1, fam.lo, fam.hi)
            return family_latency_margin(a0, a1, b0, b1, fam.lo, fam.hi, T, wmax)
        return run

    out.append(("free", None, None, single("00")))
    for i, e in enumerate(cfg.environment):
        if e.kind == "locked":
            out.append((f"env{i}_locked", None, None, single("01")))
        elif e.kind in ("spring", "mass"):
            fam = HumanFamily(e.kind, e.param, e.lo, e.hi, damping=e.damping)
            out.append((f"env{i}_{e.kind}", fam, "01", family(fam, "01")))
    for i, fam in enumerate(cfg.humans):
        for j, edge in enumerate(fam.edges()):
            name = f"human{i}_{fam.kind}" + (f"_edge{j}" if fam.box else "")
            out.append((name, edge, "10", family(edge, "10")))
    return out


def _nominal_ok(res, name: str, t: int = 0) -> bool:
    """The verdict of one loop from a batch analysis (a box's edges share the box's flag)."""
    return bool(res.loop(name).verdict[t])


def _all_ok(res, t: int) -> bool:
    return bool(res.loops_ok()[t])


def _analyze_delays(cfg, delays):
    from ..config import batch_config, continuous
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
    from ..model.controller import build_controller
    from .batch import analyze_batch
    from .charfun import char_terms

    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        cols = nominal if nominal is not None else analyze_batch(cfg)
        cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
        ct = char_terms(cfg.plant, cs, 1)
        T = float(ct.T[0])
        fs = cfg.implementation.sample_rate_hz or None
        loops = []
        for name, fam, _key1, run in _loops(cfg, ct):
            kw = {} if fam is None else {"parameter": fam.param, "unit": fam.unit}
            if not _nominal_ok(cols, name):
                loops.append(LoopMargin(name, 0.0, **kw))
                continue
            dT, w, p = run()
            loops.append(LoopMargin(name, float(dT), None if w is None else w / TWO_PI,
                                    value=None if p is None else float(p), **kw))
        crit = min(loops, key=lambda m: m.extra_delay_s) if loops else None
        margin = crit.extra_delay_s if crit else math.inf
        if not verify or not math.isfinite(margin) or margin == 0.0:
            note = "not robust at the nominal delay" if margin == 0.0 else ""
            return LatencyMargin(margin, crit, tuple(loops), T, fs, None, note)
        return _verified(cfg, ct, LatencyMargin(margin, crit, tuple(loops), T, fs))


def _verified(cfg, ct, res: LatencyMargin) -> LatencyMargin:
    """Check the margin by exact verdicts just below and above it; lower it while the check below
    fails (a destabilizing dip between grid points: its unstable member gives a smaller margin)."""
    T = res.delay_s
    loops = list(res.loops)
    crit = res.critical
    for _ in range(8):
        m = crit.extra_delay_s
        cols = _analyze_delays(cfg, [T + m * (1 - VERIFY_REL)] + [T + m * (1 + r) for r in ABOVE_REL])
        if _all_ok(cols, 0):
            changed = [r for t, r in enumerate(ABOVE_REL, start=1) if not _all_ok(cols, t)]
            note = ""
            if not changed:
                note = (f"no verdict change up to {ABOVE_REL[-1]:g} above the margin "
                        "(a crossing that does not destabilize)")
            elif changed[0] > VERIFY_REL:
                note = (f"the verdict changes between {VERIFY_REL:g} and {changed[0]:g} above the margin "
                        "(the members unstable just above it form a very narrow set)")
            return LatencyMargin(m, crit, tuple(loops), T, res.sample_rate_hz, bool(changed), note)
        lowered = None
        for name, fam, key1, _run in _loops(cfg, ct):
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
            a0, a1, b0, b1 = _family_coeffs(ct, fam, "00", key1)
            for a, b in gaps or [(fam.lo, fam.hi)]:
                dT, w, pm = _member_minimum(a0, a1, b0, b1, a, b, T)
                if dT < m and (lowered is None or dT < lowered.extra_delay_s):
                    lowered = LoopMargin(name, float(dT), None if w is None else w / TWO_PI, fam.param, float(pm), fam.unit)
        if lowered is None:
            return LatencyMargin(m, crit, tuple(loops), T, res.sample_rate_hz, False,
                                 "the exact check below the margin failed and no lower member was found")
        crit = lowered
        loops = [lowered if lp.loop == lowered.loop else lp for lp in loops]
    return LatencyMargin(crit.extra_delay_s, crit, tuple(loops), T, res.sample_rate_hz, False,
                         "the exact checks did not settle after 8 refinements")


def _member_minimum(a0, a1, b0, b1, a: float, b: float, T: float, n: int = 17):
    """The smallest single-member latency margin over members p ∈ [a, b] of a family: ``n``
    members (log-spaced for a positive range), then bounded scalar minimization around the best
    one. Returns (ΔT [s], ω [rad/s] or None, p)."""
    from scipy.optimize import minimize_scalar

    def member(p):
        return qp_latency_margin(_add(a0, p * b0), _add(a1, p * b1), T)

    ps = np.geomspace(a, b, n) if a > 0 else np.linspace(a, b, n)
    vals = [member(p)[0] for p in ps]
    k = int(np.argmin(vals))
    best_p = float(ps[k])
    if b > a:
        lo_p, hi_p = float(ps[max(k - 1, 0)]), float(ps[min(k + 1, n - 1)])
        res = minimize_scalar(lambda p: min(member(p)[0], 1e300), bounds=(lo_p, hi_p), method="bounded",
                              options={"xatol": 1e-10 * max(abs(hi_p), 1e-300)})
        if res.fun < vals[k]:
            best_p = float(res.x)
    dT, w = member(best_p)
    return dT, w, best_p


def analyze_with_margins(cfg, sampled_check: bool = True):
    """The single-design analysis (``exotune analyze``) with its margins: the latency margin of
    :func:`latency_margin` and the plant-uncertainty margin of
    :func:`exotune.analysis.plant_margin.plant_uncertainty_margin` (weights from the design's
    ``uncertainty`` section, 1 each when absent); ``to_dict()`` puts them first, as mappings with
    units.

    Parameters
    ----------
    cfg : DesignConfig
        One design.

    Returns
    -------
    DesignAnalysis
        :func:`exotune.analysis.analyze_design` with ``margins`` = (LatencyMargin, PlantMargin);
        its ``to_dict()`` is ``{"margins": {"latency": …, "plant_uncertainty": …}, …}`` followed
        by every key of the analysis.

    References
    ----------
    docs/method.md#latency-margin; paper Fig. 5.
    """
    from .design import analyze_design

    from .plant_margin import plant_uncertainty_margin

    from .batch import analyze_batch

    rec = analyze_design(cfg, sampled_check)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        cols = analyze_batch(cfg)  # the nominal verdicts, shared by both margins
        lm = latency_margin(cfg, nominal=cols)
        # a design that is not robust at the nominal plant has k* = 0: its robust loops' own bounds
        # (seconds of work) are left to plant_uncertainty_margin(cfg) — analyze stays quick
        pm = plant_uncertainty_margin(cfg, getattr(cfg, "uncertainty", None), nominal=cols, loop_detail=False)
    return replace(rec, margins=(lm, pm))


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
    from ..model.controller import build_controller
    from .batch import analyze_batch
    from .charfun import char_terms

    out = []
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        if intervals is None:
            intervals = [h.stable_intervals[0] for h in analyze_batch(cfg).humans]
        cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
        ct = char_terms(cfg.plant, cs, 1)
        T = float(ct.T[0])
        for name, fam, key1, _run in _loops(cfg, ct):
            if fam is None or not name.startswith("human"):
                continue
            lo, hi = fam.lo, fam.hi
            ps = np.geomspace(lo, hi, n) if lo > 0 else np.linspace(lo, hi, n)
            i = int(name[len("human"):].split("_")[0])
            ivs = [] if fam.box else [tuple(iv) for iv in (intervals[i] or [])]
            a0, a1, b0, b1 = _family_coeffs(ct, fam, "00", key1)
            dts = np.empty(n)
            for i, p in enumerate(ps):
                stable = fam.box or any(a <= p <= b for a, b in ivs)
                dts[i] = qp_latency_margin(_add(a0, p * b0), _add(a1, p * b1), T)[0] if stable else np.nan
            out.append(LatencyBoundary(name, fam.param, fam.unit, ps, dts, T))
    return out
