"""Exact stable intervals of a one-parameter impedance family (human or environment).

Human family with z = z0 + p φ over p ∈ [lo, hi]: Δ = (Δ00 + z0 Δ10) + p φ Δ10. A root can only
cross the imaginary axis at s = jω where p = −Δ_0(jω)/(φΔ10(jω)) is real, i.e. at the zeros of
g(ω) = Im[Δ_0 · conj(φ Δ10)], found by bracketing on the adaptive frequency set and bisection (to
float precision). These critical values split [lo, hi]; each sub-interval is classified by an
exact RHP count (argument principle, :mod:`exotune.numerics.quasipoly`). ``stable_intervals``
are therefore exact (no grid of trial values). The environment (spring/mass families) is the
same with Δ01 in place of Δ10.

References
----------
Paper §IV (coupled stability: stiff springs versus light inertias); docs/method.md#stable-intervals-of-a-human-family.
"""

from __future__ import annotations

import numpy as np

from ..model.humans import HumanFamily, family_split
from ..numerics.engine import compiled
from ..numerics.poly import degree, leading, padd, pmul
from ..numerics.quasipoly import DIP_RISE, QP, dip_candidates, golden_max, leaves_pair, log_grid, omega_max
from .batch_result import FamilyBatch
from .brackets import pair_roots
from .charfun import CharTerms, trim_poly
from .counting import RootCounter

__all__ = ["FamilySide", "family_intervals", "family_wmax", "classify", "classify_numpy", "subsample_brackets", "critical_uncertainty",
           "MAX_FAMILY_PIECES", "NEAR_REAL_RAD", "SIN_NEAR"]


class FamilySide:
    """One side of the loop (human at θ_h or environment at θ_j) with a list of families.

    Families with the same fixed impedance z0 share one adaptive frequency set tracking
    Δ_0 = Δ{key0} + z0 Δ{key1} and Δ{key1}; each family's crossing function is
    g(ω) = Im[Δ_0 · conj(f φ(jω) Δ{key1})] (f = 1 + jη for the hysteretic human).
    """

    def __init__(self, ct: CharTerms, key0: str, key1: str, families, per_decade: int = 2, verify: int = 0):
        self.ct, self.key0, self.key1 = ct, key0, key1
        self.verify = int(verify)
        self.fams = list(families)
        self.per_decade = per_decade
        self.groups: dict = {}
        for i, fam in enumerate(self.fams):
            z0, phi, factor = family_split(fam.kind, fam.param, fam.fixed(), fam.eta)
            self.groups.setdefault(tuple(z0), []).append((i, phi, factor))
        self.leaves = {}
        self.results = [None] * len(self.fams)

    def group_functions(self, z0):
        if not np.any(z0):  # Δ_0 = Δ{key0} (the product with z0 = 0 would add only zeros)
            A = self.ct.qp(self.key0)
            return QP(trim_poly(A.p0), trim_poly(A.p1), A.T), self.ct.qp(self.key1)
        D0, D1 = self.ct.combine(self.key0, self.key1, np.asarray(z0))
        return QP(trim_poly(D0.p0), trim_poly(D0.p1), D0.T), D1

    def compute_leaves(self, z0, extra_wmax=None):
        D0, D1 = self.group_functions(z0)
        # the functions' own tail bound (always: a group may have no family, e.g. the z0 = 0 group
        # that passivity uses), then every member family's range envelope
        wmax = np.maximum(omega_max(D0.p0, D0.p1), omega_max(D1.p0, D1.p1))
        if extra_wmax is not None:
            wmax = np.maximum(wmax, extra_wmax)
        for i, phi, factor in self.groups.get(tuple(z0), []):
            fam = self.fams[i]
            wmax = np.maximum(wmax, family_wmax(D0, D1, phi, factor, fam.lo, fam.hi))
        valid = np.isfinite(wmax) & (wmax > 0)
        grid = log_grid(np.where(valid, wmax, 1.0), decades=6, per_decade=self.per_decade)
        lv = leaves_pair(D0, D1, grid, valid)
        lv["valid"] = valid
        self.leaves[tuple(z0)] = (D0, D1, lv)
        return self.leaves[tuple(z0)]

    def submit(self, counter: RootCounter):
        """Find every family's critical values and queue its sub-interval RHP counts."""
        for z0, members in self.groups.items():
            D0, D1, lv = self.leaves.get(z0) or self.compute_leaves(z0)
            Nd = D0.n
            rows = np.arange(Nd)
            for i, phi, factor in members:
                fam = self.fams[i]
                k = int(np.nonzero(phi)[0][0])

                def g(task, w, k=k, factor=factor):
                    a, _ = D0.eval(task, w, deriv=False)
                    b, _ = D1.eval(task, w, deriv=False)
                    return np.imag(a * np.conj(factor * (1j * w) ** k * b))

                ga, gb, br, sus = classify(lv, k, factor, fam.lo, fam.hi)
                tk, ba, bb, bga, bgb = lv["task"][br], lv["a"][br], lv["b"][br], ga[br], gb[br]
                if sus.any():
                    st, sa_, sb_ = lv["task"][sus], lv["a"][sus], lv["b"][sus]
                    sub = subsample_brackets(D0, D1, k, factor, st, sa_, sb_)
                    if sub[0].size:
                        tk, ba, bb, bga, bgb = (np.concatenate([x, y]) for x, y in zip((tk, ba, bb, bga, bgb), sub))
                ws = _refine_crossings(g, D0, D1, k, factor, tk, ba, bb, bga, bgb)
                a_, _ = D0.eval(tk, ws, deriv=False)
                b_ = (factor * 1j**k) * (ws**k * D1.eval(tk, ws, deriv=False)[0])  # f (jω)^k Δ1
                with np.errstate(divide="ignore", invalid="ignore"):
                    pc = -np.real(a_ * np.conj(b_)) / np.abs(b_) ** 2
                # a real root through s = 0 at p = −Δ_0(0)/(φ Δ1)(0) (only φ = 1 can vanish there)
                z0v = np.real(D0.eval(rows, np.zeros(Nd), deriv=False)[0])
                z1v = np.real(D1.eval(rows, np.zeros(Nd), deriv=False)[0]) if k == 0 else np.zeros(Nd)
                with np.errstate(divide="ignore", invalid="ignore"):
                    p_at0 = np.where(z1v != 0, -z0v / z1v, np.nan)
                ct_ = np.concatenate([tk, rows])
                cp = np.concatenate([pc, p_at0])
                cw = np.concatenate([ws, np.zeros(Nd)])
                inside = np.isfinite(cp) & (cp > fam.lo) & (cp < fam.hi)
                cu = np.zeros(cp.size)
                near = np.nonzero(inside[:tk.size])[0]
                cu[near] = critical_uncertainty(D0, D1, k, factor, tk[near], ws[near], pc[near])
                ct_, cp, cw, cu = ct_[inside], cp[inside], cw[inside], cu[inside]
                order = np.lexsort((cp, ct_))
                ct_, cp, cw, cu = ct_[order], cp[order], cw[order], cu[order]
                bounds, crit = _bounds(Nd, ct_, cp, cw, fam.lo, fam.hi, cu)
                # a design with more critical values in the range than MAX_FAMILY_PIECES is not
                # counted piece by piece (each count is bounded, their number is not): inconclusive
                too_many = np.diff(bounds[1]) - 1 > MAX_FAMILY_PIECES
                bounds, bu = bounds[:2], bounds[2]
                rep_t, rep_p, rep_ab = _representatives(*bounds, bu)
                if too_many.any():
                    kept = ~too_many[rep_t]
                    rep_t, rep_p, rep_ab = rep_t[kept], rep_p[kept], tuple(x[kept] for x in rep_ab)
                h = _queue_points(counter, D0, D1, phi, factor, rep_t, rep_p)
                res = dict(bounds=bounds, bounds_uncertainty=bu, crit=crit, rep_t=rep_t, rep_ab=rep_ab, handle=h,
                           leaves_ok=lv["valid"] & lv["resolved"] & ~too_many, too_many=too_many)
                if self.verify:
                    # independent check of the interval structure: exact counts at a grid of values
                    vp = np.geomspace(fam.lo, fam.hi, self.verify) if fam.lo > 0 else np.linspace(fam.lo, fam.hi, self.verify)
                    vp = np.clip(vp, fam.lo, fam.hi)  # geomspace(v, v) is not exactly v
                    ver_t = np.repeat(np.arange(Nd), vp.size)
                    ver_p = np.tile(vp, Nd)
                    res.update(ver_t=ver_t, ver_p=ver_p, ver_handle=_queue_points(counter, D0, D1, phi, factor, ver_t, ver_p))
                self.results[i] = res

    def collect(self, counter: RootCounter, allowed_rigid: int = 1) -> list[FamilyBatch]:
        """Every family's result from the counts of ``counter`` (run after :meth:`submit`): one
        :class:`~exotune.analysis.batch_result.FamilyBatch` per family, in order
        (``verification_mismatches`` only with ``verify`` > 0)."""
        out = []
        for i, fam in enumerate(self.fams):
            R = self.results[i]
            N, r, ok = counter.result(R["handle"])
            # a design whose crossing search is incomplete (budget spent, unresolved or invalid
            # leaves) may miss critical values: its sub-intervals are not known to be one sign
            # each, so none is reported stable (the counts alone do not make an interval)
            st = ok & (N == 0) & (r <= allowed_rigid) & R["leaves_ok"][R["rep_t"]]
            bv, bo = R["bounds"]
            Nd = len(bo) - 1
            conclusive = R["leaves_ok"].copy()
            conclusive[R["rep_t"][~ok]] = False
            # sub-interval j of design rep_t[j] is [sa[j], sb[j]] (same order as the counts);
            # runs of consecutive stable sub-intervals of one design are the stable intervals
            t_ = R["rep_t"]
            sa, sb, ua, ub = R["rep_ab"]
            first = np.r_[True, t_[1:] != t_[:-1]] if t_.size else np.zeros(0, bool)
            starts = st & (first | ~np.r_[False, st[:-1]])
            ends = st & np.r_[(t_[1:] != t_[:-1]) | ~st[1:], True] if t_.size else np.zeros(0, bool)
            # an end at a critical value known only to ±u (critical_uncertainty) moves inward by u
            run_t, run_a, run_b = t_[starts], sa[starts] + ua[starts], sb[ends] - ub[ends]
            # (a single-value family, lo = hi, has one sub-interval [lo, lo]: a point, kept)
            kept = (run_a < run_b) | ((run_a == run_b) & (fam.lo == fam.hi))
            run_t, run_a, run_b = run_t[kept], run_a[kept], run_b[kept]
            intervals = [[] for _ in range(Nd)]
            for t, a, b in zip(run_t.tolist(), run_a.tolist(), run_b.tolist()):
                intervals[t].append([a, b])
            nrun = np.bincount(run_t, minlength=Nd)
            whole = np.zeros(Nd, bool)
            whole[run_t[(run_a == fam.lo) & (run_b == fam.hi)]] = True
            robust = (nrun == 1) & whole
            mismatches = [[] for _ in range(Nd)]
            if "ver_handle" in R:
                Nv, rv, okv = counter.result(R["ver_handle"])
                stv = okv & (Nv == 0) & (rv <= allowed_rigid)
                bu = R["bounds_uncertainty"]
                for t_v, p_, s_, ok_ in zip(R["ver_t"].tolist(), R["ver_p"].tolist(), stv.tolist(), okv.tolist()):
                    edges = zip(bv[bo[t_v] + 1: bo[t_v + 1] - 1].tolist(), bu[bo[t_v] + 1: bo[t_v + 1] - 1].tolist())
                    if not ok_ or not R["leaves_ok"][t_v] or any(abs(p_ - e) <= max(1e-6 * max(abs(e), 1e-300), u)
                                                                 for e, u in edges):
                        continue
                    if s_ != any(a <= p_ <= b for a, b in intervals[t_v]):
                        mismatches[t_v].append(p_)
                bad = np.array([bool(m) for m in mismatches], dtype=bool)
                conclusive &= ~bad
            # an inconclusive design claims no interval stable (a sub-interval count or the
            # verification undecided: what it lists would not be a decided structure)
            intervals = [iv if conclusive[t] else [] for t, iv in enumerate(intervals)]
            out.append(FamilyBatch(kind=fam.kind, robust=robust & conclusive, stable_intervals=intervals,
                                   conclusive=conclusive, critical=R["crit"],
                                   verification_mismatches=mismatches if self.verify else None))
        return out


# More critical values than this in one family's range (one design) make the family inconclusive
# for that design: each sub-interval costs an exact count (a real design has a handful: ≤ 84 seen
# with a 50 ms delay; a degenerate one, e.g. a 1e-9 kg·m² felt inertia with a 0.2 s delay, has
# ~10⁴ and would take minutes).
MAX_FAMILY_PIECES = 1000

NEAR_REAL_RAD = 1.0  # leaves with κ this close (in angle) to the real axis at an end are sub-sampled
SIN_NEAR = float(np.sin(NEAR_REAL_RAD))
DIP_ITERATIONS = 40  # golden-section steps of the search for a dip between sub-sampled points


def classify_numpy(lv: dict, k: int, factor: complex, lo: float, hi: float):
    """Crossing function at both ends of every leaf, and which leaves hold a sign-change bracket
    or must be sub-sampled, for one family (f φ = factor·(jω)^k) of a pair's leaves ``lv``
    (numpy reference of :func:`exotune._fastphase.classify_leaves`). Returns (ga, gb, br, sus).

    Brackets are kept only when their crossing value can lie in [lo, hi]: within a leaf the phase
    of κ = −Δ_0/(fφΔ1) moves < 1 rad, so a crossing at p > 0 has Re κ > 0 at an end; |κ| is bounded
    loosely (factor 1e3) from the end values. A leaf can hold several crossings (an even number
    without a sign change at its ends, or three with one) when κ comes near the positive real
    axis — e.g. a nearly decoupled light mass on the cuff spring at high frequency, where the delay
    makes Im κ ripple with period 2π/T. The leaf criteria bound each function's phase step
    (< 0.8 rad) and its departure from the trapezoid estimate (≤ 0.5 rad), so arg κ cannot swing by
    ≳ 1 rad inside a leaf and back: every plausible leaf with κ within NEAR_REAL_RAD of the real
    axis at an end is sub-sampled (≥ 8 points, ≥ 8 per ripple period) by the caller.

    Parameters
    ----------
    lv : dict
        The pair's leaves: ends ``a``, ``b`` [rad/s] and the values ``va``, ``vb`` of (Δ_0, Δ1) there.
    k : int
        The power of (jω) in f φ.
    factor : complex
        The constant f of f φ (1 + jη for the hysteretic human).
    lo, hi : float
        The family's range (in its parameter's unit: [kg·m²], [N·m·s/rad] or [N·m/rad]).

    Returns
    -------
    ga, gb : ndarray
        The crossing function at the leaves' ends.
    br : ndarray of bool
        The leaves holding a plausible sign-change bracket.
    sus : ndarray of bool
        The leaves to sub-sample.

    References
    ----------
    docs/method.md#stable-intervals-of-a-human-family.
    """
    # f (jω)^k v as a complex constant times a real power (no complex power)
    fl = lambda v, w: (factor * 1j**k) * (w**k * v)  # noqa: E731
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        fva, fvb = fl(lv["va"][1], lv["a"]), fl(lv["vb"][1], lv["b"])
        ga = np.imag(lv["va"][0] * np.conj(fva))
        gb = np.imag(lv["vb"][0] * np.conj(fvb))
        br = (np.sign(ga) * np.sign(gb) < 0) & (lv["a"] > 0)
        ka = -lv["va"][0] / fva
        kb = -lv["vb"][0] / fvb
    kmin = np.minimum(np.abs(ka), np.abs(kb))
    kmax = np.maximum(np.abs(ka), np.abs(kb))
    plausible = ((ka.real > 0) | (kb.real > 0)) & ~(kmax * 1e3 < lo) & ~(kmin > hi * 1e3)
    br &= plausible | ~np.isfinite(kmax)
    with np.errstate(divide="ignore", invalid="ignore"):
        near_real = (np.abs(ka.imag) <= SIN_NEAR * np.abs(ka)) | (np.abs(kb.imag) <= SIN_NEAR * np.abs(kb))
    sus = (lv["a"] > 0) & plausible & near_real & ~(kmax * 4.0 < lo) & ~(kmin > hi * 4.0)
    br &= ~sus
    return ga, gb, br, sus


def classify(lv: dict, k: int, factor: complex, lo: float, hi: float):
    """:func:`classify_numpy`, compiled when available; leaves with a zero or non-finite value
    (where numpy's complex inf/nan rules decide) go through the numpy reference.

    Parameters
    ----------
    lv : dict
        The pair's leaves: ends ``a``, ``b`` [rad/s] and the values ``va``, ``vb`` of (Δ_0, Δ1) there.
    k : int
        The power of (jω) in f φ.
    factor : complex
        The constant f of f φ (1 + jη for the hysteretic human).
    lo, hi : float
        The family's range (in its parameter's unit: [kg·m²], [N·m·s/rad] or [N·m/rad]).

    Returns
    -------
    ga, gb, br, sus : ndarray
        As :func:`classify_numpy`.
    """
    if not compiled():
        return classify_numpy(lv, k, factor, lo, hi)
    from ..numerics import kernels as _fastphase

    ga, gb, br, sus, deg = _fastphase.classify_leaves(lv, k, factor, lo, hi, SIN_NEAR)
    if deg.any():
        sub = {"a": lv["a"][deg], "b": lv["b"][deg], "va": [lv["va"][0][deg], lv["va"][1][deg]],
               "vb": [lv["vb"][0][deg], lv["vb"][1][deg]]}
        _, _, br[deg], sus[deg] = classify_numpy(sub, k, factor, lo, hi)
    return ga, gb, br, sus


def subsample_brackets(D0: QP, D1: QP, k: int, factor: complex, st, sa, sb):
    """Sign-change brackets (task, a, b, g(a), g(b)) of the crossing function g on M equally
    spaced points of each leaf [sa, sb] (ends included; M ≥ 8 and ≥ 8 per delay ripple period
    2π/T, at most 512), and the two brackets of each dip between points; compiled when available.

    A dip is a pair of crossings closer than the point spacing (the delay ripple's crest or trough
    just reaching the real axis): at three consecutive points of one sign s, the normalized
    s·g/(|Δ_0||f φ Δ1|) has a local minimum at the middle one that may hide the other sign
    (:func:`~exotune.numerics.quasipoly.dip_candidates`); s·g is then minimized between the outer
    points by golden section (``DIP_ITERATIONS`` steps), and a minimum of the other sign splits
    them into two brackets.

    Parameters
    ----------
    D0, D1 : QP
        Δ_0 and Δ1 of the family's group.
    k : int
        The power of (jω) in f φ.
    factor : complex
        The constant f of f φ.
    st : ndarray of int
        Design row of each leaf.
    sa, sb : ndarray
        The leaves' ends [rad/s].

    Returns
    -------
    task, a, b, ga, gb : ndarray
        Design row, bracket ends [rad/s] and the crossing function's values there (opposite signs).
    """
    if compiled():
        from ..numerics import kernels as _fastphase

        return _fastphase.subsample_brackets(D0, D1, k, factor, st, sa, sb, iters=DIP_ITERATIONS, rise=DIP_RISE)
    Tt = D0.T[st]
    per = np.where(Tt > 0, 2 * np.pi / np.maximum(Tt, 1e-300), np.inf)
    M = np.clip(np.ceil(8.0 * (sb - sa) / per), 8, 512).astype(int)
    rep = np.repeat(np.arange(len(st)), M)
    # M points per leaf, both ends included (a sign change at the ends is kept)
    frac = (np.arange(rep.size) - np.repeat(np.cumsum(M) - M, M)) / np.repeat(M - 1, M)
    wsub = sa[rep] + frac * (sb - sa)[rep]
    tsub = st[rep]
    gsub, usub = _cross_normalized(D0, D1, k, factor, tsub, wsub)
    nxt = np.r_[rep[1:] == rep[:-1], False]
    j = np.nonzero(nxt & (np.sign(gsub) * np.sign(np.r_[gsub[1:], 0.0]) < 0))[0]
    out = [(rep[j], tsub[j], wsub[j], wsub[j + 1], gsub[j], gsub[j + 1])]
    # dips between points (dip_candidates): s·g is minimized between the outer two of three points,
    # and a minimum of the other sign gives two brackets
    m = np.flatnonzero(nxt & np.r_[False, nxt[:-1]])  # middle points (neighbours in the same leaf)
    dip, sg = dip_candidates(usub[m - 1], usub[m], usub[m + 1])
    m, sg = m[dip], sg[dip]
    if m.size:
        tm = tsub[m]
        v, wd = golden_max(lambda x: -sg * _cross_normalized(D0, D1, k, factor, tm, x)[0], wsub[m - 1], wsub[m + 1],
                           iters=DIP_ITERATIONS, where=True)
        hit = v > 0  # the minimum of s·g (= −v) has the other sign
        m, wd, gd, tm = m[hit], wd[hit], -v[hit] * sg[hit], tm[hit]
        out += [(rep[m], tm, wsub[m - 1], wd, gsub[m - 1], gd), (rep[m], tm, wd, wsub[m + 1], gd, gsub[m + 1])]
    leaf, *res = (np.concatenate(x) for x in zip(*out))
    order = np.lexsort((res[1], leaf))  # leaf by leaf, increasing ω (the compiled pass's order)
    return tuple(x[order] for x in res)


def _cross_normalized(D0: QP, D1: QP, k: int, factor: complex, task, w):
    """The crossing function g = Im[Δ_0·conj(f (jω)^k Δ1)] and g/(|Δ_0|·|f (jω)^k Δ1|)."""
    a, _ = D0.eval(task, w, deriv=False)
    fb = (factor * 1j**k) * (w**k * D1.eval(task, w, deriv=False)[0])
    g = np.imag(a * np.conj(fb))
    with np.errstate(divide="ignore", invalid="ignore"):
        return g, g / (np.abs(a) * np.abs(fb))


def _refine_crossings(g, D0: QP, D1: QP, k: int, factor: complex, task, a, b, fa, fb):
    """Zeros of the crossing function g on its brackets (compiled Illinois when available)."""
    return pair_roots(g, D0, D1, "cross", task, a, b, fa, fb, k=k, factor=factor)

def _queue_points(counter: RootCounter, D0: QP, D1: QP, phi, factor: complex, rows: np.ndarray, p: np.ndarray):
    """Queue exact RHP counts of Δ(s; p) = D0 + p f φ D1 for the given (design row, p) pairs
    (complex coefficients with the real regularized twin for the hysteretic human)."""
    phi_arr = np.asarray(phi, float)
    D1p0 = pmul(D1.p0, phi_arr[None, :])
    D1p1 = pmul(D1.p1, phi_arr[None, :])
    reg = None
    if factor.imag != 0:
        reg = (padd(D0.p0[rows], p[:, None] * D1p0[rows]), padd(D0.p1[rows], p[:, None] * D1p1[rows]))
    P0 = padd(D0.p0[rows].astype(complex if reg else float), (factor if reg else 1.0) * p[:, None] * D1p0[rows])
    P1 = padd(D0.p1[rows].astype(complex if reg else float), (factor if reg else 1.0) * p[:, None] * D1p1[rows])
    return counter.add(P0, P1, D0.T[rows], reg, group=rows)


def _bounds(Nd, ct_, cp, cw, lo, hi, cu):
    """Sub-interval bounds of every design, flat: design t owns ``bv[bo[t]:bo[t + 1]]`` = lo, its
    distinct critical values (ascending), hi; their uncertainties ``bu`` (``cu`` of the critical
    values, the largest of those merged; 0 at lo and hi); and the list of critical (value,
    frequency [Hz]) per design. The crossings arrive sorted by (design, value); a value within
    1e-12 (relative) of the last kept one of its design is the same critical value."""
    crit = [[] for _ in range(Nd)]
    keep = np.zeros(len(cp), bool)
    unc = np.array(cu, dtype=float)
    last_t, last_p, last_j = -1, lo, -1
    for j, (t, p, w) in enumerate(zip(ct_.tolist(), cp.tolist(), cw.tolist())):
        crit[t].append((p, w / (2 * np.pi)))
        if t != last_t:
            last_t, last_p, last_j = t, lo, -1
        if p > last_p * (1 + 1e-12):
            keep[j] = True
            last_p, last_j = p, j
        elif last_j >= 0:  # the same critical value as the last kept one (at lo: none to merge into)
            unc[last_j] = max(unc[last_j], unc[j])
    tk, pk = ct_[keep], cp[keep]
    nk = np.bincount(tk, minlength=Nd)
    bo = np.r_[0, np.cumsum(nk + 2)]
    bv = np.empty(bo[-1])
    bu = np.zeros(bo[-1])
    bv[bo[:-1]] = lo
    bv[bo[1:] - 1] = hi
    kstart = np.r_[0, np.cumsum(nk)][:-1]
    at = bo[tk] + 1 + np.arange(tk.size) - kstart[tk]
    bv[at] = pk
    bu[at] = unc[keep]
    return (bv, bo, bu), crit


def _representatives(bv, bo, bu):
    """One value inside each sub-interval (geometric mean when positive): (design, value,
    (a, b, uncertainty of a, uncertainty of b))."""
    Nd = len(bo) - 1
    last = np.zeros(len(bv), bool)
    last[bo[1:] - 1] = True
    j = np.nonzero(~last)[0]
    a, b = bv[j], bv[j + 1]
    rep_t = np.repeat(np.arange(Nd), np.diff(bo) - 1)
    with np.errstate(invalid="ignore"):
        rep_p = np.where((a > 0) & (b > 0), np.sqrt(a * b), 0.5 * (a + b))
    return rep_t, rep_p, (a, b, bu[j], bu[j + 1])


def family_wmax(D0: QP, D1: QP, phi, factor, lo, hi):
    """A tail frequency valid for every p in [lo, hi] (coefficients are affine in p).

    Parameters
    ----------
    D0, D1 : QP
        Δ_0 = Δ{key0} + z0 Δ{key1} and Δ{key1} of the family's side.
    phi : array_like
        Ascending coefficients of the ranged part φ(s) of the impedance z = z0 + p φ.
    factor : complex
        1, or 1 + jη for the hysteretic human.
    lo, hi : float
        The family's range of p.

    Returns
    -------
    ndarray, shape (N,)
        Above this frequency no root of Δ(s; p) = D0 + p·factor·φ·D1 crosses the axis, for any p
        in [lo, hi]; inf when no such bound exists (the leading coefficient can vanish).

    References
    ----------
    Paper §IV (coupled stability); docs/method.md#stable-intervals-of-a-human-family.
    """
    phi = np.asarray(phi, float)
    real = not any(np.iscomplexobj(x) for x in (D0.p0, D0.p1, D1.p0, D1.p1))
    if real and compiled():
        from ..numerics import kernels as _fastphase

        return _fastphase.family_wmax(D0.p0, D0.p1, D1.p0, D1.p1, phi, factor, lo, hi)
    B0 = pmul(D1.p0, phi[None, :]).astype(complex) * factor
    B1 = pmul(D1.p1, phi[None, :]).astype(complex) * factor
    n0 = max(D0.p0.shape[-1], B0.shape[-1])
    n1 = max(D0.p1.shape[-1], B1.shape[-1])
    pad = lambda c, n: np.pad(c, ((0, 0), (0, n - c.shape[-1])))
    A0, B0 = pad(D0.p0, n0).astype(complex), pad(B0, n0)
    A1, B1 = pad(D0.p1, n1).astype(complex), pad(B1, n1)
    lo_c, hi_c = A0 + lo * B0, A0 + hi * B0
    env0 = np.maximum(np.abs(lo_c), np.abs(hi_c))
    env1 = np.maximum(np.abs(A1 + lo * B1), np.abs(A1 + hi * B1))
    nlo, nhi = degree(lo_c), degree(hi_c)
    cmin = _min_abs_affine(leading(lo_c), leading(hi_c), nlo, nhi)
    rows = np.arange(D0.n)
    env0[rows, np.maximum(nlo, 0)] = np.where(nlo == nhi, cmin, 0.0)
    w = omega_max(env0, env1)
    return np.where((nlo == nhi) & (cmin > 0), w, np.inf)


def family_intervals(ct: CharTerms, fam: HumanFamily, key0: str = "00", key1: str = "10") -> FamilyBatch:
    """Exact stable sub-intervals of one family (convenience wrapper around :class:`FamilySide`).

    Parameters
    ----------
    ct : CharTerms
        The characteristic terms of the designs.
    fam : HumanFamily
        The impedance family.
    key0, key1 : str
        The terms Δ{key0} + z Δ{key1}: "00", "10" for a human at θ_h; "00", "01" for an environment.

    Returns
    -------
    FamilyBatch
        The family's stable intervals, verdicts and critical values, one entry per design.

    References
    ----------
    Paper §IV (coupled stability); docs/method.md#stable-intervals-of-a-human-family.
    """
    side = FamilySide(ct, key0, key1, [fam])
    c = RootCounter()
    side.submit(c)
    c.run()
    return side.collect(c)[0]


def _min_abs_affine(c_lo, c_hi, n_lo, n_hi):
    """min over t ∈ [0,1] of |c_lo + t (c_hi − c_lo)| (the leading coefficient over the range)."""
    d = c_hi - c_lo
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.clip(-np.real(np.conj(d) * c_lo) / np.abs(d) ** 2, 0.0, 1.0)
    t = np.where(np.abs(d) > 0, t, 0.0)
    return np.abs(c_lo + t * d)



# relative rounding of one evaluation of g (Horner's rule on both factors, complex arithmetic, the
# delay factor), per term, times the sum of the terms' moduli
CROSSING_ROUNDING = 8.0 * np.finfo(float).eps
# critical values whose rounding bound is below this (relative) are reported as found: every
# ordinary crossing (none of 21 019 crossings of 3 000 benchmark-sweep designs reaches it)
CRITICAL_EXACT_RTOL = 1e-6


def critical_uncertainty(D0: QP, D1: QP, k: int, factor: complex, task, w, p):
    """A first-order rounding bound on each critical value, where it matters.

    Where the crossing curve −Δ_0/(f φ Δ1) runs almost along the real axis, g = Im[Δ_0 conj(f (jω)^k
    Δ1)] changes by less than its rounding over a band of frequencies, and the zero found may lie
    anywhere in it — rounding is biased there, so the computed g can look like a clean function
    with a displaced zero (docs/method.md#stable-intervals-of-a-human-family). The bound: Horner's
    rounding of g (the sum of the terms' moduli, times ``CROSSING_ROUNDING`` per term) over |g'(ω)|
    moves the zero by δω, and p by |dp/dω|·δω. It is pessimistic (by 10³–10⁴ on the crossings that
    need it) and is applied only where it exceeds ``CRITICAL_EXACT_RTOL``·|p|; elsewhere 0 (every
    ordinary crossing: the value is reported as found). Infinite where g' vanishes.

    Parameters
    ----------
    D0, D1 : QP
        Δ_0 and Δ1 of the family's side.
    k : int
        The power of s in φ (1, s or s²: k = 0, 1, 2).
    factor : complex
        1, or 1 + jη for the hysteretic human.
    task : numpy.ndarray
        The design row of each crossing.
    w : numpy.ndarray
        The crossing frequencies [rad/s].
    p : numpy.ndarray
        The critical values (the family parameter's unit).

    Returns
    -------
    numpy.ndarray
        The bound per critical value, in the family parameter's unit (0: as found).
    """
    if task.size == 0:
        return np.zeros(0)
    with np.errstate(all="ignore"):
        a, da = D0.eval(task, w)
        c, dc = D1.eval(task, w)
        s = 1j * w
        b = factor * s**k * c
        db = factor * 1j * ((k * s ** (k - 1) * c if k else 0.0) + s**k * dc)  # d/dω
        da = 1j * da
        mod = lambda q: np.sum(np.abs(q.p0[task]) * w[:, None] ** np.arange(q.p0.shape[1]), axis=1) + np.sum(  # noqa: E731
            np.abs(q.p1[task]) * w[:, None] ** np.arange(q.p1.shape[1]), axis=1)
        terms = D0.p0.shape[1] + D1.p0.shape[1] + 4
        dg = CROSSING_ROUNDING * terms * (mod(D0) * np.abs(b) + np.abs(a) * np.abs(factor) * w**k * mod(D1))
        dpdw = np.abs((da * b - a * db) / b**2)
        bound = dpdw * dg / np.abs(np.imag(da * np.conj(b) + a * np.conj(db)))
    bound = np.where(np.isnan(bound), np.inf, bound)
    return np.where(bound <= CRITICAL_EXACT_RTOL * np.abs(p), 0.0, bound)
