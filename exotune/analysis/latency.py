"""The latency margin of a batch of designs at once: the sweep column ``latency_margin_s``.

The definition and the construction are those of :mod:`exotune.analysis.latency_margin`
(docs/method.md#latency-margin): a loop Δ = P0 + P1 e^{−sτ} gains a root on the imaginary axis at
s = jω for the delay τ exactly when |P0(jω)| = |P1(jω)| and e^{−jωτ} = −P0/P1, so a crossing at ω
costs the extra delay ΔT(ω) = ((−arg(−P0/P1) − ωT) mod 2π)/ω; for a family P_i = A_i + p B_i,
p ∈ [lo, hi], the crossings form curves p(ω) (roots of a real quadratic in p at each ω) whose ends
inside the range are the end members' crossings. A design's margin is the minimum of ΔT over the
crossings of its free loop, its environments and every human family (a box through its edges),
0 when one of them is not stable/robust at the nominal delay, ``inf`` when no crossing exists.

Here every step runs on all designs of a batch together:

* polynomials are evaluated at jω through their even and odd parts in x = ω² (real Horner steps);
* the frequency grid of a design spans nine decades below a tail bound beyond which no member can
  cross (:func:`tail_bound`), ``GRID_PER_DECADE`` points per decade;
* the end members' (and the single loops') crossings are the sign changes of |P0|² − |P1|² on the
  grid, refined by bisection to machine precision, plus grazing points (relative |F| below 10⁻⁶ at
  a local minimum);
* along each branch of the crossing curves every grid local minimum of ΔT is refined by
  golden-section search in log ω, after the bracket's ends are moved (bisection) to the edges of
  the curve segment it samples;
* a curve segment that starts at an end member's crossing but holds no grid point (narrower than
  a grid step) is sampled at ``SEED_POINTS`` points around that crossing and refined the same way.
  A closed crossing curve inside the range narrower than a grid step, touching no end member, is
  the one feature this grid can miss.

Designs that are not robust at the nominal delay are not computed (their margin is 0). Unlike the
single-design :func:`exotune.analysis.latency_margin.latency_margin`, no exact re-check at T + ΔT(1 ∓ 10⁻⁶)
follows (it would cost two more full analyses per design); the tests compare the two on random
designs (tests/analysis/test_latency.py).
"""

from __future__ import annotations

import math

import numpy as np

from ..model.humans import HumanFamily, family_split
from ..numerics.poly import pad_cols, padd, pmul
from ..numerics.quasipoly import golden_max

__all__ = ["batch_latency_margin", "loop_latency_margins", "member_latency_margins", "design_loops",
           "qp_latency_margin", "family_latency_margin", "tail_bound", "GRID_PER_DECADE", "GRID_DECADES",
           "INFINITE_PROBES_S", "delay_limit"]

#: extra delays [s] at which an infinite margin (no destabilizing crossing found) is checked by exact
#: verdicts (docs/method.md#latency-margin): a pole beyond the frequency range the crossing search
#: resolves can hide every crossing
INFINITE_PROBES_S = (1e-4, 3e-4, 1e-3, 3e-3, 1e-2, 3e-2, 0.1, 0.3)


def delay_limit() -> float:
    """The largest delay [s] a design (hence an exact verdict) accepts.

    Returns
    -------
    float
        The upper end of ``implementation.delay_s``'s accepted range [s].
    """
    from ..config.batch import OVERRIDE_LIMITS
    from ..config.validate import LIMITS

    return LIMITS[OVERRIDE_LIMITS["implementation.delay_s"]][2]

TWO_PI = 2.0 * math.pi
GRID_DECADES = 9.0
GRID_PER_DECADE = 40
GOLDEN_ITERATIONS = 26
BISECTION_ITERATIONS = 44
GRAZE_REL = 1e-6
# bisections that move a refinement bracket's end to its segment's edge; where the smallest ΔT of the
# branch sits at that edge (a turning point of the crossing curve, where ΔT varies as the square
# root of the distance: 16 bisections alone left it 1e-3 too large), EDGE_ITERATIONS more follow
SHRINK_ITERATIONS = 16
EDGE_ITERATIONS = 36  # further bisections of an edge that holds the smallest ΔT (52 in all: float resolution)
# golden-section steps that look, between two grid points, for the deepest point of a grid local
# minimum of (|P0|² − |P1|²)/(|P0|² + |P1|²): a lightly damped resonance whose band |P1| > |P0| is
# narrower than a grid step (an undamped light mass on the cuff spring: 0.4 % wide) has no grid
# point inside; 40 steps narrow two grid steps (12 % in ω) to 5e-10 relative
PEAK_ITERATIONS = 40
# golden-section steps that locate a near-axis root of P0 or P1 inside a grid cell (6 % in ω) to
# 1e-15 relative: the band around it where |P1| > |P0| may be 1e-10 wide
DIP_ITERATIONS = 72
# a branch point (ω, p) counts only where |P0|² − |P1|² vanishes to this relative accuracy at the p
# the quadratic gives (it does not near an undamped resonance, where p is ill-conditioned)
BRANCH_REL = 1e-6
POLISH_STEPS = 2  # Newton steps polishing a branch's member p (_polish_member)
SEED_POINTS = 9  # samples of each branch over ± one grid step around an end member's crossing
MAX_CROSSINGS = 64  # per loop and design, the end-member crossings that seed curve segments
NEUTRAL_TAIL = 1e7  # rad/s: the grid top when a loop has no tail bound (neutral: deg P1 ≥ deg P0)


# ---------------------------------------------------------------------------------------------
# evaluation at s = jω
# ---------------------------------------------------------------------------------------------
class _Jw:
    """A batch of real polynomials (rows, ascending) prepared for evaluation at s = jω:
    P(jω) = E(ω²) + j ω O(ω²) with real E, O."""

    def __init__(self, c: np.ndarray):
        c = np.asarray(c, dtype=float)
        k = np.arange(c.shape[1])
        signed = c * np.where((k // 2) % 2 == 0, 1.0, -1.0)  # the real/imaginary sign of j^k
        self.even = signed[:, 0::2]
        self.odd = signed[:, 1::2]

    def grid(self, w: np.ndarray) -> np.ndarray:
        """Values at ``w`` of shape (N, G) (row i at w[i])."""
        x = w * w
        return _horner(self.even, x) + 1j * w * _horner(self.odd, x)

    def points(self, rows: np.ndarray, w: np.ndarray) -> np.ndarray:
        """Values of rows ``rows`` at ``w`` (flat arrays of equal length)."""
        x = w * w
        return _horner(self.even[rows], x, flat=True) + 1j * w * _horner(self.odd[rows], x, flat=True)


def _horner(c: np.ndarray, x: np.ndarray, flat: bool = False) -> np.ndarray:
    if c.shape[1] == 0:
        return np.zeros(x.shape)
    cT = c.T if flat else c.T[:, :, None]  # column k: the k-th coefficient of every row
    acc = np.empty(x.shape)
    acc[...] = cT[-1]
    for k in range(c.shape[1] - 2, -1, -1):
        acc *= x
        acc += cT[k]
    return acc


def tail_bound(c0: np.ndarray, c1: np.ndarray) -> np.ndarray:
    """Per row, a frequency [rad/s] above which |P0(jω)| > |P1(jω)| (a Cauchy-type bound on
    coefficient magnitudes; ``inf`` for a neutral row, deg P1 ≥ deg P0, or P0 ≡ 0).

    |P0| ≥ |c0_n| ωⁿ − Σ_{k<n} |c0_k| ω^k and |P1| ≤ Σ |c1_k| ω^k, so beyond twice the largest
    (Σ_k-term / |c0_n|)^{1/(n−k)} no crossing exists.

    Parameters
    ----------
    c0, c1 : ndarray, shape (N, n)
        Ascending coefficients of P0 and P1, one row per design.

    Returns
    -------
    ndarray, shape (N,)
        The frequency bound [rad/s] (``inf`` when none exists).
    """
    m0 = np.abs(np.asarray(c0))
    m1 = np.abs(np.asarray(c1))
    n = max(m0.shape[1], m1.shape[1])
    m0, m1 = pad_cols(m0, n), pad_cols(m1, n)
    k = np.arange(n)
    deg0 = np.where((m0 > 0).any(1), n - 1 - np.argmax((m0 > 0)[:, ::-1], axis=1), -1)
    deg1 = np.where((m1 > 0).any(1), n - 1 - np.argmax((m1 > 0)[:, ::-1], axis=1), -1)
    lead = m0[np.arange(m0.shape[0]), np.maximum(deg0, 0)]
    below = k[None, :] < deg0[:, None]
    tot = np.where(below, m0 + m1, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        expo = 1.0 / np.where(below, deg0[:, None] - k[None, :], 1)
        r = np.where(below & (tot > 0), (tot / np.where(lead > 0, lead, 1.0)[:, None]) ** expo, 0.0)
    out = 2.0 * r.max(axis=1)
    out = np.where(out > 0, out, 1.0)
    return np.where((deg0 <= 0) | (deg1 >= deg0), np.inf, out)


# ---------------------------------------------------------------------------------------------
# one loop (or family) for a batch
# ---------------------------------------------------------------------------------------------
PAIRS = ("00", "10", "01")  # the characteristic terms a loop combines (charfun.CharTerms keys)


class _Terms:
    """The batch rows' characteristic pairs Δ_j = P0 + P1 e^{−sT} (j over :data:`PAIRS`), ready
    for evaluation at s = jω."""

    def __init__(self, ct, rows: np.ndarray):
        self.coef = [(np.asarray(ct.qp(k).p0, dtype=float)[rows], np.asarray(ct.qp(k).p1, dtype=float)[rows])
                     for k in PAIRS]
        self.jw = [(_Jw(c0), _Jw(c1)) for c0, c1 in self.coef]

    @classmethod
    def from_pairs(cls, pairs) -> "_Terms":
        """Terms from coefficient rows (P0, P1) given directly, one pair per position of :data:`PAIRS`."""
        self = cls.__new__(cls)
        self.coef = [(np.atleast_2d(np.asarray(a, dtype=float)), np.atleast_2d(np.asarray(b, dtype=float))) for a, b in pairs]
        self.jw = [(_Jw(c0), _Jw(c1)) for c0, c1 in self.coef]
        return self

    def grid(self, w: np.ndarray) -> list:
        return [(j0.grid(w), j1.grid(w)) for j0, j1 in self.jw]


class _Loop:
    """One loop of every design of a batch: Δ = (A0 + p B0) + (A1 + p B1) e^{−sT} with
    A = Δ_a + z0(s) Δ_b and B = f φ(s) Δ_b (a family Z = z0 + p f φ closed over pair b), or
    A = Δ_a, B = 0 (a single loop, ``kb`` = −1)."""

    def __init__(self, terms: _Terms, ka: int, kb: int = -1, z0=(0.0, 0.0, 0.0), phi=(0.0, 0.0, 0.0),
                 factor: complex = 1.0, lo: float = 0.0, hi: float = 0.0):
        self.terms, self.ka, self.kb = terms, ka, kb
        self.single = kb < 0
        self.z0 = np.asarray(z0, dtype=float)
        self.phi = np.asarray(phi, dtype=float)
        self.f = complex(factor)
        self.lo, self.hi = float(lo), float(hi)

    def members(self) -> tuple[float, ...]:
        return (0.0,) if self.single else ((self.lo,) if self.lo == self.hi else (self.lo, self.hi))

    def coefficients(self):
        """(A0, A1, B0, B1) as coefficient rows (ascending; B's complex with the factor)."""
        a0, a1 = self.terms.coef[self.ka]
        if self.single:
            return a0, a1, None, None
        d0, d1 = self.terms.coef[self.kb]
        n = d0.shape[0]
        z = np.broadcast_to(self.z0, (n, 3))
        ph = np.broadcast_to(self.phi, (n, 3))
        return (padd(a0, pmul(d0, z)), padd(a1, pmul(d1, z)), pmul(d0, ph) * self.f, pmul(d1, ph) * self.f)

    def wmax(self) -> np.ndarray:
        """Per row, a frequency above which no member crosses (tail bounds of the end members and
        of seven members between them, ×4; ``NEUTRAL_TAIL`` for a neutral loop)."""
        a0, a1, b0, b1 = self.coefficients()
        if self.single:
            t = tail_bound(a0, a1)
            return np.where(np.isfinite(t), t, NEUTRAL_TAIL)
        n0 = max(a0.shape[1], b0.shape[1])
        n1 = max(a1.shape[1], b1.shape[1])
        a0, b0, a1, b1 = pad_cols(a0, n0), pad_cols(b0, n0), pad_cols(a1, n1), pad_cols(b1, n1)
        ps = np.unique(np.r_[self.lo, self.hi, np.geomspace(self.lo, self.hi, 9) if self.lo > 0
                             else np.linspace(self.lo, self.hi, 9)])
        t = np.max([tail_bound(a0 + p * b0, a1 + p * b1) for p in ps], axis=0)
        return np.where(np.isfinite(t), 4.0 * t, NEUTRAL_TAIL)

    def _combine(self, Va, Vb, w):
        if self.single:
            return Va[0], Va[1], 0.0, 0.0
        z = (self.z0[0] - self.z0[2] * w * w) + 1j * self.z0[1] * w
        ph = self.f * ((self.phi[0] - self.phi[2] * w * w) + 1j * self.phi[1] * w)
        return Va[0] + z * Vb[0], Va[1] + z * Vb[1], ph * Vb[0], ph * Vb[1]

    def values(self, w: np.ndarray, rows: np.ndarray | None = None, V: list | None = None):
        """(A0, A1, B0, B1) at jω: on the grid ``w`` (N, G) (from the pairs' grid values ``V`` when
        given) or, with ``rows``, at the points (rows[i], w[i])."""
        if rows is None:
            V = V if V is not None else self.terms.grid(w)
            Va, Vb = V[self.ka], (None if self.single else V[self.kb])
        else:
            ja = self.terms.jw[self.ka]
            Va = (ja[0].points(rows, w), ja[1].points(rows, w))
            Vb = None
            if not self.single:
                jb = self.terms.jw[self.kb]
                Vb = (jb[0].points(rows, w), jb[1].points(rows, w))
        return self._combine(Va, Vb, w)


def _take_min(best: np.ndarray, args: tuple, r: np.ndarray, v: np.ndarray, payload: tuple) -> None:
    """Per row, ``best`` ← min(best, the candidates ``v`` of the row) (rows ``r``, non-finite values
    ignored), and ``args`` ← the ``payload`` values of each new minimum (in place)."""
    v = np.where(np.isfinite(v), v, np.inf)
    if r.size == 0:
        return
    order = np.lexsort((v, r))
    rs, vs = r[order], v[order]
    first = np.r_[True, rs[1:] != rs[:-1]]
    rr, vv = rs[first], vs[first]
    better = vv < best[rr]
    best[rr[better]] = vv[better]
    for out, val in zip(args, payload):
        out[rr[better]] = np.broadcast_to(val, v.shape)[order][first][better]


def _first_delay(P0, P1, w, T):
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.mod(-np.angle(-P0 / P1) - w * T, TWO_PI) / w


def _member_margin(loop: _Loop, p: float, w, vals, T):
    """Per row, the smallest ΔT over the crossings of member p found on the grid ``w`` (N, G) and
    its crossing frequency ω [rad/s] (NaN: none), and those crossings as (rows, log ω, grid index)
    (sign changes refined by bisection, grazing points). ``p`` may hold one member per row."""
    A0, A1, B0, B1 = vals
    per_row = np.ndim(p) > 0  # one member per row (member_latency_margins)
    pg = np.asarray(p, dtype=float)[:, None] if per_row else p
    P0, P1 = A0 + pg * B0, A1 + pg * B1
    m0, m1 = np.abs(P0) ** 2, np.abs(P1) ** 2
    F = m0 - m1
    N = w.shape[0]
    best = np.full(N, np.inf)
    best_w = np.full(N, np.nan)
    rows, logs, gidx = [], [], []

    def record(rr, pk, lc, cell):  # a crossing of member(s) pk of rows rr at log ω = lc, in grid cell ``cell``
        x = np.exp(lc)
        a0, a1, b0, b1 = loop.values(x, rr)
        _take_min(best, (best_w,), rr, _first_delay(a0 + pk * b0, a1 + pk * b1, x, T[rr]), (x,))
        rows.append(rr)
        logs.append(lc)
        gidx.append(cell)

    r, i = np.nonzero(np.signbit(F[:, :-1]) != np.signbit(F[:, 1:]))
    if r.size:
        lo_l, hi_l = np.log(w[r, i]), np.log(w[r, i + 1])
        f_lo = np.signbit(F[r, i])
        pr = np.asarray(p, dtype=float)[r] if per_row else p

        def Fp(lw):
            a0, a1, b0, b1 = loop.values(np.exp(lw), r)
            return np.abs(a0 + pr * b0) ** 2 - np.abs(a1 + pr * b1) ** 2

        for _ in range(BISECTION_ITERATIONS):
            mid = 0.5 * (lo_l + hi_l)
            same = np.signbit(Fp(mid)) == f_lo
            lo_l = np.where(same, mid, lo_l)
            hi_l = np.where(same, hi_l, mid)
        record(r, pr, 0.5 * (lo_l + hi_l), i)
    # bands |P1| > |P0| narrower than a grid step (a lightly damped or undamped resonance)
    for rr, pk, lc, cell in _narrow_crossings(loop, p, per_row, w, P0, P1, F / np.where(m0 + m1 > 0, m0 + m1, 1.0)):
        record(rr, pk, lc, cell)
    # grazing points: |F| relative to its scale at a local minimum within 1e-6 of 0
    rel = np.abs(F) / np.where(m0 + m1 > 0, m0 + m1, 1.0)
    g = (rel[:, 1:-1] < rel[:, :-2]) & (rel[:, 1:-1] < rel[:, 2:]) & (rel[:, 1:-1] < GRAZE_REL)
    r, i = np.nonzero(g)
    if r.size:
        i = i + 1
        dT = _first_delay(P0[r, i], P1[r, i], w[r, i], T[r])
        _take_min(best, (best_w,), r, dT, (w[r, i],))
        rows.append(r)
        logs.append(np.log(w[r, i]))
        gidx.append(i)
    cross = ((np.concatenate(rows), np.concatenate(logs), np.concatenate(gidx)) if rows
             else (np.zeros(0, np.int64), np.zeros(0), np.zeros(0, np.int64)))
    return best, best_w, cross


def _golden(f, a, b, n: int):
    """Golden-section search of the vectorized ``f`` over [a, b] (arrays), ``n`` steps: the smallest
    value reached and where (:func:`~exotune.numerics.quasipoly.golden_max` of −f)."""
    m, x = golden_max(lambda x: -f(x), a, b, n, where=True, best=True)
    return -m, x


def _narrow_crossings(loop: _Loop, p, per_row: bool, w, P0, P1, sg):
    """The crossings (rows, member(s), log ω, grid cell) of bands |P1| > |P0| that hold no grid
    point, for member(s) ``p`` with grid values P0, P1 and signed relative F ``sg`` (N, G):

    * a grid local minimum of ``sg``, positive with both neighbours, searched between them
      (a lightly damped resonance narrower than a grid step); where ``sg`` < 0 there, both band
      edges are bisected;
    * where the phase of P0 or P1 turns by more than π/2 between two grid points (a root near the
      axis inside the cell: an undamped light mass on the cuff spring makes both vanish within
      1e-6 of each other, and |P1| > |P0| holds on a band 1e-10 wide), the deepest point of |P| in
      the cell is searched and the sign changes of F between it and the cell's ends are bisected.
    """
    out = []
    r, i = np.nonzero((sg[:, 1:-1] <= sg[:, :-2]) & (sg[:, 1:-1] <= sg[:, 2:]) & (sg[:, 1:-1] > 0)
                      & (sg[:, :-2] > 0) & (sg[:, 2:] > 0))
    if r.size:
        i = i + 1
        pr = np.asarray(p, dtype=float)[r] if per_row else p
        lx, found = _narrow_band(loop, r, pr, np.log(w[r, i - 1]), np.log(w[r, i + 1]))
        rr, pk, xin, ii = r[found], (pr[found] if per_row else pr), lx[found], i[found]
        for end in (ii - 1, ii + 1):
            lc = _bisect_sign(loop, rr, pk, np.log(w[rr, end]), xin)
            out.append((rr, pk, lc, np.where(lc < np.log(w[rr, ii]), ii - 1, ii)))
    for which, P in enumerate((P0, P1)):
        r, i = np.nonzero(np.real(P[:, 1:] * np.conj(P[:, :-1])) < 0)
        if not r.size:
            continue
        pr = np.asarray(p, dtype=float)[r] if per_row else p
        lx = _root_dip(loop, r, pr, which, np.log(w[r, i]), np.log(w[r, i + 1]))
        pos_x = _signed_rel(loop, r, pr, lx) > 0
        for end in (i, i + 1):
            k = (sg[r, end] > 0) != pos_x
            if k.any():
                pk, le, lk = (pr[k] if per_row else pr), np.log(w[r[k], end[k]]), lx[k]
                lc = _bisect_sign(loop, r[k], pk, np.where(pos_x[k], lk, le), np.where(pos_x[k], le, lk))
                out.append((r[k], pk, lc, i[k]))
    return out


def _signed_rel(loop: _Loop, r, p, lx):
    """(|P0|² − |P1|²)/(|P0|² + |P1|²) of member(s) ``p`` of rows ``r`` at log ω = ``lx``."""
    a0, a1, b0, b1 = loop.values(np.exp(lx), r)
    m0, m1 = np.abs(a0 + p * b0) ** 2, np.abs(a1 + p * b1) ** 2
    return (m0 - m1) / np.where(m0 + m1 > 0, m0 + m1, 1.0)


def _narrow_band(loop: _Loop, r, p, a, b):
    """Golden-section search of the signed relative F over [a, b] (log ω) for a point where it is
    negative (a band |P1| > |P0| between two grid points): the point reached and whether F < 0 there."""
    m, x = _golden(lambda x: _signed_rel(loop, r, p, x), a, b, PEAK_ITERATIONS)
    return x, m < 0


def _root_dip(loop: _Loop, r, p, which: int, a, b):
    """Golden-section search of |P0| (``which`` 0) or |P1| (1) of member(s) ``p`` over [a, b]
    (log ω) for its smallest value (a near-axis root in the cell): where it is (log ω)."""
    def f(x):
        a0, a1, b0, b1 = loop.values(np.exp(x), r)
        return np.abs(a0 + p * b0) if which == 0 else np.abs(a1 + p * b1)

    return _golden(f, a, b, DIP_ITERATIONS)[1]


def _bisect_sign(loop: _Loop, r, p, lo_l, hi_l):
    """The sign change of F between log ω = ``lo_l`` (F > 0) and ``hi_l`` (F < 0), by bisection."""
    for _ in range(BISECTION_ITERATIONS):
        mid = 0.5 * (lo_l + hi_l)
        pos = _signed_rel(loop, r, p, mid) > 0
        lo_l = np.where(pos, mid, lo_l)
        hi_l = np.where(pos, hi_l, mid)
    return 0.5 * (lo_l + hi_l)


def _branches(loop: _Loop, w, vals, T, members: bool = False):
    """ΔT along the two branches p±(ω) of the crossing curves (inf where the branch leaves the
    range or does not exist): a list of two arrays of the shape of ``w`` (``members``: a list of
    two (ΔT, p) pairs)."""
    A0, A1, B0, B1 = vals
    qa = np.abs(B0) ** 2 - np.abs(B1) ** 2
    qb = 2.0 * np.real(A0 * np.conj(B0) - A1 * np.conj(B1))
    qc = np.abs(A0) ** 2 - np.abs(A1) ** 2
    big = max(abs(loop.lo), abs(loop.hi))
    sc = np.abs(qa) * big * big + np.abs(qb) * big + np.abs(qc)
    sc = np.where(sc > 0, sc, 1.0)
    qa, qb, qc = qa / sc, qb / sc, qc / sc
    with np.errstate(invalid="ignore", divide="ignore"):
        disc = qb * qb - 4.0 * qa * qc
        sq = np.sqrt(np.where(disc >= 0, disc, np.nan))
        q = -0.5 * (qb + np.copysign(sq, qb))
        r1 = np.where(qa != 0, q / qa, -qc / qb)
        r2 = np.where((qa != 0) & (q != 0), qc / q, np.nan)
    out = []
    for pm in (np.fmin(r1, r2), np.fmax(r1, r2)):
        pm = _polish_member(A0, A1, B0, B1, pm)
        ok = np.isfinite(pm) & (pm >= loop.lo) & (pm <= loop.hi)
        P1 = A1 + pm * B1
        ok &= np.abs(P1) > 0
        # the member must cross there: near an undamped resonance A0 ≈ −p B0 to 1e-10 and the
        # quadratic's root p is off by more than its band is wide (|P0| ≫ |P1| at the p it gives)
        m0, m1 = np.abs(A0 + pm * B0) ** 2, np.abs(P1) ** 2
        ok &= np.abs(m0 - m1) <= BRANCH_REL * (m0 + m1)
        dT = _first_delay(A0 + pm * B0, np.where(ok, P1, 1.0), w, T)
        dT = np.where(ok & np.isfinite(dT), dT, np.inf)
        out.append((dT, pm) if members else dT)
    return out


def _polish_member(A0, A1, B0, B1, pm):
    """The quadratic's root p polished by POLISH_STEPS Newton steps on G(p) = |A0 + pB0|² − |A1 + pB1|²
    evaluated directly (its expanded coefficients lose the digits where A0 ≈ −p B0; ΔT at the
    unpolished p was off by up to 5e-3 relative); a step is kept only where it lowers |G|."""
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        for _ in range(POLISH_STEPS):
            P0, P1 = A0 + pm * B0, A1 + pm * B1
            G = np.abs(P0) ** 2 - np.abs(P1) ** 2
            dG = 2.0 * np.real(B0 * np.conj(P0) - B1 * np.conj(P1))
            q = pm - G / dG
            Gq = np.abs(A0 + q * B0) ** 2 - np.abs(A1 + q * B1) ** 2
            pm = np.where(np.isfinite(q) & (np.abs(Gq) < np.abs(G)), q, pm)
    return pm


def _refine(loop: _Loop, which: int, r, T, a, x0, b):
    """Per candidate, the smallest ΔT on branch ``which`` near the finite point log ω = x0 of the
    bracket [a, b] (log ω) and where it is (log ω): an end where the branch does not exist is
    first moved, by bisection, to the edge of the segment holding x0; then golden-section search.
    An edge itself may hold the smallest ΔT (a turning point of the crossing curve, where ΔT varies
    as the square root of the distance): where it is below the golden-section minimum, the edge is
    bisected on to float resolution and evaluated there."""
    Tr = T[r]

    def f(x):
        xw = np.exp(x)
        return _branches(loop, xw, loop.values(xw, r), Tr)[which]

    def edge(inside, outside, n):  # the last point of x0's segment towards ``outside``
        for _ in range(n):
            mid = 0.5 * (inside + outside)
            fin = np.isfinite(f(mid))
            inside, outside = np.where(fin, mid, inside), np.where(fin, outside, mid)
        return inside, outside

    ends = []
    for e in (a, b):
        shrink = ~np.isfinite(f(e))
        inside, outside = edge(x0, e, SHRINK_ITERATIONS)
        ends.append((shrink, np.where(shrink, inside, e), outside))
    a, b = ends[0][1], ends[1][1]
    m, x = _golden(f, a, b, GOLDEN_ITERATIONS)
    for shrink, e, outside in ends:
        fe = f(e)
        on = shrink & (fe < m)
        if on.any():
            e = np.where(on, edge(e, outside, EDGE_ITERATIONS)[0], e)
            fe = f(e)
        x = np.where(fe < m, e, x)
        m = np.fmin(m, fe)
    return m, x


def _curve_margin(loop: _Loop, w, vals, T, cross):
    """Per row, the smallest ΔT along the crossing curves, its crossing frequency ω [rad/s] and
    member p (NaN: none): every grid local minimum of a branch, and the segments that start at an
    end member's crossing ``cross`` = (rows, log ω, grid index) where the grid does not sample them
    (narrower than a grid step), each refined by :func:`_refine`."""
    N, G = w.shape
    best = np.full(N, np.inf)
    best_w, best_p = np.full(N, np.nan), np.full(N, np.nan)
    lw = np.log(w)
    h = GRID_DECADES * math.log(10.0) / (G - 1)
    cr_all, cx_all, ci_all = cross
    for which, (dT, pm) in enumerate(_branches(loop, w, vals, T[:, None], members=True)):
        fin = np.isfinite(dT)
        left = np.concatenate([np.full((N, 1), np.inf), dT[:, :-1]], axis=1)
        right = np.concatenate([dT[:, 1:], np.full((N, 1), np.inf)], axis=1)
        r, i = np.nonzero(fin & (dT <= left) & (dT <= right))
        _take_min(best, (best_w, best_p), r, dT[r, i], (w[r, i], pm[r, i]))
        rs, a, x0, b = [r], [lw[r, np.maximum(i - 1, 0)]], [lw[r, i]], [lw[r, np.minimum(i + 1, G - 1)]]
        # a crossing whose grid neighbours are both off the branch may start a segment the grid misses
        unseen = ~fin[cr_all, ci_all] & ~fin[cr_all, np.minimum(ci_all + 1, G - 1)]
        cr, cx = cr_all[unseen], cx_all[unseen]
        if cr.size:
            ys = cx[:, None] + h * np.linspace(-1.0, 1.0, SEED_POINTS)[None, :]
            rr = np.repeat(cr, SEED_POINTS)
            v, vp = _branches(loop, np.exp(ys.ravel()), loop.values(np.exp(ys.ravel()), rr), T[rr], members=True)[which]
            v, vp = v.reshape(ys.shape), vp.reshape(ys.shape)
            k = np.argmin(v, axis=1)
            v0 = v[np.arange(cr.size), k]
            ok = np.isfinite(v0)
            y0 = ys[np.arange(cr.size), k][ok]
            _take_min(best, (best_w, best_p), cr[ok], v0[ok], (np.exp(y0), vp[np.arange(cr.size), k][ok]))
            step = 2.0 * h / (SEED_POINTS - 1)
            rs.append(cr[ok]); a.append(y0 - step); x0.append(y0); b.append(y0 + step)
        r = np.concatenate(rs)
        if r.size:
            m, x = _refine(loop, which, r, T, np.concatenate(a), np.concatenate(x0), np.concatenate(b))
            xw = np.exp(x)
            pm_x = _branches(loop, xw, loop.values(xw, r), T[r], members=True)[which][1]
            _take_min(best, (best_w, best_p), r, m, (xw, pm_x))
    return best, best_w, best_p


def _grid(wmax: np.ndarray) -> np.ndarray:
    G = int(GRID_DECADES * GRID_PER_DECADE) + 1
    return wmax[:, None] * np.logspace(-GRID_DECADES, 0.0, G)[None, :]


def _margins_numpy(terms: _Terms, loops: list, T: np.ndarray, wmax: np.ndarray) -> np.ndarray:
    """Per row, the smallest extra delay over every loop's crossings (the numpy reference)."""
    return np.min(_loop_margins(terms, loops, T, wmax)[0], axis=0, initial=np.inf)


def _loop_margins(terms: _Terms, loops: list, T: np.ndarray, wmax: np.ndarray):
    """Per loop and row (arrays (L, N)): the smallest extra delay ΔT [s] over the loop's crossings,
    the crossing frequency ω [rad/s] and the member p there (NaN: no crossing; p is NaN for a
    single loop)."""
    w = _grid(wmax)
    V = terms.grid(w)
    L, N = len(loops), w.shape[0]
    dT, om, pp = np.full((L, N), np.inf), np.full((L, N), np.nan), np.full((L, N), np.nan)
    for j, loop in enumerate(loops):
        vals = loop.values(w, V=V)
        crossings = []
        for p in loop.members():
            m, mw, cross = _member_margin(loop, p, w, vals, T)
            _take_min(dT[j], (om[j], pp[j]), np.arange(N), m, (mw, np.nan if loop.single else p))
            crossings.append(cross)
        if not loop.single and loop.hi > loop.lo:
            cross = tuple(np.concatenate([c[k] for c in crossings]) for k in range(3))
            m, mw, mp = _curve_margin(loop, w, vals, T, cross)
            _take_min(dT[j], (om[j], pp[j]), np.arange(N), m, (mw, mp))
    return dT, om, pp


def _margins_compiled(terms: _Terms, loops: list, T: np.ndarray, wmax: np.ndarray) -> np.ndarray:
    """The same construction in the compiled kernel (:mod:`exotune.numerics.kernels.latency`)."""
    from ..numerics.kernels.latency import design_margins

    js = [j for pair in terms.jw for j in pair]
    m_e = max(j.even.shape[1] for j in js)
    m_o = max(max(j.odd.shape[1] for j in js), 1)
    ev = np.stack([pad_cols(j.even, m_e) for j in js])
    od = np.stack([pad_cols(j.odd, m_o) for j in js])
    L = len(loops)
    members = np.zeros((L, 2))
    nmem = np.zeros(L, dtype=np.int64)
    for i, lp in enumerate(loops):
        ms = lp.members()
        members[i, : len(ms)] = ms
        nmem[i] = len(ms)

    def arr(xs, dt=float):
        return np.ascontiguousarray(np.asarray(xs, dtype=dt))

    return design_margins(
        arr(ev), arr(od), arr([lp.ka for lp in loops], np.int64), arr([lp.kb for lp in loops], np.int64),
        arr([lp.z0 for lp in loops]).reshape(L, 3), arr([lp.phi for lp in loops]).reshape(L, 3),
        arr([lp.f.real for lp in loops]), arr([lp.f.imag for lp in loops]), members, nmem,
        arr([lp.lo for lp in loops]), arr([lp.hi for lp in loops]),
        arr([(not lp.single) and lp.hi > lp.lo for lp in loops], np.bool_),
        arr(T), arr(wmax), GRID_DECADES, int(GRID_DECADES * GRID_PER_DECADE) + 1,
        BISECTION_ITERATIONS, SHRINK_ITERATIONS, GOLDEN_ITERATIONS, GRAZE_REL, SEED_POINTS, MAX_CROSSINGS,
        PEAK_ITERATIONS, DIP_ITERATIONS, BRANCH_REL, EDGE_ITERATIONS)


# ---------------------------------------------------------------------------------------------
# the design's loops
# ---------------------------------------------------------------------------------------------
def _family_loop(terms: _Terms, fam: HumanFamily, key1: str) -> _Loop:
    z0, phi, factor = family_split(fam.kind, fam.param, fam.fixed(), fam.eta)
    return _Loop(terms, 0, PAIRS.index(key1), z0, phi, factor, fam.lo, fam.hi)


def design_loops(humans, environment) -> list:
    """(name, family or None, closing pair) of every loop whose crossings bound a design's latency
    margin: the free exoskeleton, the locked joint and the spring/mass environments, and every
    human family (a box through its edges, ``human{i}_{kind}_edge{j}``).

    Parameters
    ----------
    humans, environment : sequences
        The design's human families and environments.

    Returns
    -------
    list of tuple
        (loop name, :class:`~exotune.model.humans.HumanFamily` or None, "01"/"10" or None).
    """
    out = [("free", None, None)]
    for i, e in enumerate(environment):
        if e.kind == "locked":
            out.append((f"env{i}_locked", None, "01"))
        elif e.kind in ("spring", "mass"):
            out.append((f"env{i}_{e.kind}", HumanFamily(e.kind, e.param, e.lo, e.hi, damping=e.damping), "01"))
    for i, fam in enumerate(humans):
        for j, edge in enumerate(fam.edges()):
            out.append((f"human{i}_{fam.kind}" + (f"_edge{j}" if fam.box else ""), edge, "10"))
    return out


def _design_loops(terms: _Terms, humans, environment) -> list:
    """The :class:`_Loop` of every loop of :func:`design_loops`."""
    return [_Loop(terms, 0) if fam is None and key is None else
            _Loop(terms, PAIRS.index(key)) if fam is None else _family_loop(terms, fam, key)
            for _name, fam, key in design_loops(humans, environment)]


def loop_latency_margins(ct, humans, environment):
    """Every loop's latency margin for every design of a batch, with where it is reached: the
    construction of :func:`batch_latency_margin` (the same grid, the same refinement, numpy), loop
    by loop. The single-design margin (:func:`exotune.analysis.latency_margin.latency_margin`) is this
    for a batch of one.

    Parameters
    ----------
    ct : CharTerms
        The batch's characteristic terms.
    humans, environment : sequences
        The human families and environments of the batch's designs.

    Returns
    -------
    loops : list of tuple
        :func:`design_loops`.
    extra_delay_s, omega, member : ndarray, shape (L, N)
        Per loop and design: the smallest extra delay ΔT [s] over its crossings (``inf``: none),
        the crossing frequency ω [rad/s] and the family member p there (NaN: none, or a single loop).
    """
    N = ct.T.shape[0]
    terms = _Terms(ct, np.arange(N))
    loops = _design_loops(terms, humans, environment)
    wmax = np.max([lp.wmax() for lp in loops], axis=0)
    return (design_loops(humans, environment), *_loop_margins(terms, loops, np.asarray(ct.T, dtype=float), wmax))


def member_latency_margins(ct, row: int, fam: HumanFamily, key: str, members) -> tuple[np.ndarray, np.ndarray]:
    """The latency margins of single members of a family of design ``row`` (each member a loop of
    its own, on its own tail bound's grid).

    Parameters
    ----------
    ct : CharTerms
        The characteristic terms.
    row : int
        The design.
    fam : HumanFamily
        The family (its range is ignored: the members are given).
    key : str
        The pair the family closes ("10": human, "01": environment).
    members : array_like
        Member values p [fam.unit].

    Returns
    -------
    extra_delay_s, omega : ndarray
        Per member: ΔT [s] (``inf``: no crossing) and the crossing frequency ω [rad/s] (NaN: none).
    """
    ps = np.atleast_1d(np.asarray(members, dtype=float)).ravel()
    if ps.size == 0:
        return np.zeros(0), np.zeros(0)
    # one row per member (the design's terms repeated): each member on the grid of its own tail
    # bound, exactly as the single-member loop _Loop(..., p, p) would compute it, in one pass
    terms = _Terms(ct, np.full(ps.size, int(row)))
    z0, phi, factor = family_split(fam.kind, fam.param, fam.fixed(), fam.eta)
    loop = _Loop(terms, 0, PAIRS.index(key), z0, phi, factor)
    a0, a1, b0, b1 = loop.coefficients()
    n0, n1 = max(a0.shape[1], b0.shape[1]), max(a1.shape[1], b1.shape[1])
    a0, b0, a1, b1 = pad_cols(a0, n0), pad_cols(b0, n0), pad_cols(a1, n1), pad_cols(b1, n1)
    # the single-member loop's tail members: p, p and the 9 points of geomspace/linspace(p, p)
    sample = np.geomspace(ps, ps, 9) if np.all(ps > 0) else np.array([np.geomspace(p, p, 9) if p > 0
                                                                        else np.linspace(p, p, 9) for p in ps]).T
    t = np.max([tail_bound(a0 + q[:, None] * b0, a1 + q[:, None] * b1) for q in (ps, *sample)], axis=0)
    wmax = np.where(np.isfinite(t), 4.0 * t, NEUTRAL_TAIL)
    T = np.full(ps.size, float(np.asarray(ct.T, dtype=float)[int(row)]))
    w = _grid(wmax)
    dT, om, _ = _member_margin(loop, ps, w, loop.values(w), T)
    return dT, om


def qp_latency_margin(c0, c1, T: float) -> tuple[float, float | None]:
    """Latency margin of one loop Δ = P0 + P1 e^{−sT} given by its coefficients (1-D, ascending,
    real; the exact roots at s = 0 divided out beforehand).

    Parameters
    ----------
    c0, c1 : array_like
        Ascending coefficients of P0 and P1.
    T : float
        Nominal delay [s].

    Returns
    -------
    tuple
        (ΔT [s], ``inf`` when no crossing; crossing frequency ω [rad/s] or None).
    """
    z = np.zeros((1, 1))
    terms = _Terms.from_pairs([(c0, c1), (z, z), (z, z)])
    lp = _Loop(terms, 0)
    dT, om, _ = _loop_margins(terms, [lp], np.array([float(T)]), lp.wmax())
    return float(dT[0, 0]), (None if not np.isfinite(om[0, 0]) else float(om[0, 0]))


def family_latency_margin(a0, a1, b0, b1, lo: float, hi: float, T: float, wmax: float | None = None,
                          factor: complex = 1.0):
    """Latency margin of the family P0 = A0 + p f B0, P1 = A1 + p f B1, p ∈ [lo, hi].

    Parameters
    ----------
    a0, a1, b0, b1 : array_like
        Ascending real coefficients of A0, A1, B0, B1.
    lo, hi : float
        The member range.
    T : float
        Nominal delay [s].
    wmax : float, optional
        Top of the frequency grid [rad/s] (default: the members' tail bound, ×4).
    factor : complex, optional
        f (1 + jη for the hysteretic human).

    Returns
    -------
    tuple
        (ΔT [s], ω [rad/s] or None, critical member p or None).
    """
    z = np.zeros((1, 1))
    terms = _Terms.from_pairs([(a0, a1), (b0, b1), (z, z)])
    lp = _Loop(terms, 0, 1, (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), factor, lo, hi)
    top = lp.wmax() if wmax is None else np.array([float(wmax)])
    dT, om, pp = _loop_margins(terms, [lp], np.array([float(T)]), top)
    fin = np.isfinite(dT[0, 0])
    return float(dT[0, 0]), (float(om[0, 0]) if fin else None), (float(pp[0, 0]) if fin else None)


def batch_latency_margin(ct, humans, environment, robust: np.ndarray) -> np.ndarray:
    """The latency margin [s] of every design of a batch (module docstring).

    Parameters
    ----------
    ct : CharTerms
        The batch's characteristic terms (:func:`exotune.analysis.charfun.char_terms`).
    humans, environment : sequences
        The human families and environments of the batch's designs.
    robust : ndarray of bool, shape (N,)
        The designs robust at their nominal delay (free exoskeleton, every environment and every
        human family: :meth:`BatchAnalysis.loops_ok <exotune.analysis.BatchAnalysis.loops_ok>`);
        the others have margin 0 and are not computed.

    Returns
    -------
    ndarray, shape (N,)
        ΔT [s]: 0 where not robust at the nominal delay, ``inf`` where no extra delay destabilizes.

    References
    ----------
    docs/method.md#latency-margin; paper Fig. 5.
    """
    from ..numerics.engine import compiled

    N = ct.T.shape[0]
    out = np.zeros(N)
    rows = np.nonzero(np.asarray(robust, dtype=bool))[0]
    if rows.size == 0:
        return out
    T = np.asarray(ct.T, dtype=float)[rows]
    terms = _Terms(ct, rows)
    loops = _design_loops(terms, humans, environment)
    wmax = np.max([lp.wmax() for lp in loops], axis=0)
    run = _margins_compiled if compiled() else _margins_numpy
    out[rows] = run(terms, loops, T, wmax)
    return out
