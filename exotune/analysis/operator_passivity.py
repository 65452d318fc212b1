"""Passivity of the operator-side compliance C7 = Δ10/Δ00 with the exact delay (paper §IV-A).

References
----------
Paper §IV-A "Passivity of the Operator Compliance"; docs/method.md#passivity-of-the-operator-compliance.
"""

from __future__ import annotations

import numpy as np

from ..numerics.engine import compiled
from ..numerics.quasipoly import bisect_roots
from .batch_result import PassivityBatch
from .brackets import pair_roots
from .charfun import CharTerms
from .intervals import FamilySide

__all__ = ["c7_response", "passivity", "BAND_MIN_EXCESS_DEG"]


def c7_response(ct: CharTerms, w: np.ndarray) -> np.ndarray:
    """C7(jω) = Δ10/Δ00 for every design (rows) at frequencies w (N, K) [rad/(N·m)].

    Parameters
    ----------
    ct : CharTerms
        The characteristic terms of the N designs.
    w : ndarray, shape (N, K)
        Frequencies [rad/s], one row per design.

    Returns
    -------
    ndarray of complex, shape (N, K)
        C7(jω) [rad/(N·m)].
    """
    N = ct.T.shape[0]
    idx = np.repeat(np.arange(N), w.shape[1])
    a, _ = ct.qp("00").eval(idx, w.ravel(), deriv=False)
    b, _ = ct.qp("10").eval(idx, w.ravel(), deriv=False)
    return (b / a).reshape(w.shape)


BAND_MIN_EXCESS_DEG = 0.1


def passivity(side: FamilySide) -> PassivityBatch:
    """max_phase_excess_deg [deg] and nonpassive_band_hz [Hz] of C7 = Δ10/Δ00 (docs/method.md#analyses-and-metrics),
    as a :class:`~exotune.analysis.batch_result.PassivityBatch`.

    Passive phase band: arg C7 ∈ [−180°, 0°] ⇔ Im C7(jω) ≤ 0. The excess is the angular distance
    of the (wrapped) phase from that band, min(φ, 180° − φ) for φ ∈ (0°, 180°); its maximum is
    refined by golden-section search. Band edges are the exact zeros of Im C7. With a delay,
    C7 → 1/K_c with a decaying ripple of period 1/T in frequency, giving infinitely many tiny
    bands: bands whose peak excess is below ``BAND_MIN_EXCESS_DEG`` (0.1°) are not listed
    (``max_phase_excess_deg`` itself is exact, and the band holding it is listed whenever it
    reaches 0.1°; other bands are judged by their sampled peak).

    One function (over 80 lines): the peak refinement, the band runs and their edges all index the
    same vectorized leaf arrays of every design; split, they would pass a dozen arrays around.

    Parameters
    ----------
    side : FamilySide
        The human side of the loop (Δ00, Δ10), whose leaves at z0 = 0 are reused or computed.

    Returns
    -------
    PassivityBatch
        ``conclusive``, ``max_phase_excess_deg`` [deg] (NaN: partial frequency coverage) and
        ``nonpassive_band_hz`` [Hz], one entry per design.

    References
    ----------
    Paper §IV-A (passivity of the operator compliance), Fig. 5 (the passive phase region);
    docs/method.md#passivity-of-the-operator-compliance.
    """
    z0 = (0.0, 0.0, 0.0)
    D0, D1, lv = side.leaves.get(z0) or side.compute_leaves(z0)
    Nd = D0.n

    def c7(task, w):
        a, _ = D0.eval(task, w, deriv=False)
        b, _ = D1.eval(task, w, deriv=False)
        return b / a

    def excess(c):
        ph = np.degrees(np.angle(c))
        return np.where(ph > 0, np.minimum(ph, 180.0 - ph), 0.0)

    def excess_where(c, im):
        # excess(c) where it can be positive (Im c > 0 ⇔ phase in (0°, 180°)), 0 elsewhere and
        # where c is not finite; the same values as excess(c) without the angles of the rest
        out = np.zeros(c.shape)
        sel = (im > 0) & np.isfinite(c)
        out[sel] = excess(c[sel])
        return out

    pos = lv["a"] > 0
    # the leaves with a > 0 (all of them unless a grid starts at ω = 0): no copies when all
    on = (lambda x: x) if pos.all() else (lambda x: x[pos])  # noqa: E731
    task = on(lv["task"])
    a_l, b_l = on(lv["a"]), on(lv["b"])
    with np.errstate(divide="ignore", invalid="ignore"):
        cb = on(lv["vb"][1]) / on(lv["vb"][0])
    imb = np.imag(cb)
    leaf = np.flatnonzero(pos)

    def ima(k):  # Im C7 at the a-end of leaves k (only the bracketing leaves need it)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.imag(lv["va"][1][leaf[k]] / lv["va"][0][leaf[k]])

    exb = excess_where(cb, imb)
    best = np.zeros(Nd)
    np.maximum.at(best, task, exb)
    arg = _argmax_by_task(task, exb, Nd)
    have = arg >= 0
    if have.any():
        ti = np.nonzero(have)[0]
        j = arg[ti]
        nxt = np.minimum(j + 1, len(b_l) - 1)
        a_ = a_l[j]
        b_ = np.where(task[nxt] == ti, b_l[nxt], b_l[j])
        if compiled():
            from ..numerics import kernels as _fastphase

            peak = _fastphase.golden_max(D0, D1, "excess", ti, a_, b_, iters=40)
        else:
            peak = _golden_max(lambda w: excess(c7(ti, w)), a_, b_)
        best[ti] = np.maximum(best[ti], peak)
    # bands = runs of consecutive samples with Im C7 > 0; only runs whose sampled peak excess
    # reaches the threshold get their two edges refined (exact zeros of Im C7)
    # the sign of Im C7 is only trusted above the float resolution (|Im C7| > 1e-8 |C7|); samples
    # below it inherit the state of the previous sample of the same design, so rounding noise in
    # the high-frequency tail (C7 → 1/K_c) neither splits nor ends a band
    resolved_sign = np.abs(imb) > 1e-8 * np.abs(cb)
    inside = imb > 0
    if task.size:
        first_of_task = np.r_[True, task[1:] != task[:-1]]
        keep = resolved_sign | first_of_task
        last = np.maximum.accumulate(np.where(keep, np.arange(task.size), 0))
        inside = inside[last]
        # the a-end of a leaf is the b-end of the previous leaf of the same design
        resolved_a = np.r_[False, resolved_sign[:-1]] & ~first_of_task
    else:
        resolved_a = np.zeros(0, bool)
    if task.size:
        newrun = np.r_[True, (task[1:] != task[:-1]) | (inside[1:] != inside[:-1])]
    else:
        newrun = np.zeros(0, bool)
    rid = np.cumsum(newrun) - 1
    nrun = int(rid[-1]) + 1 if rid.size else 0
    peak = np.zeros(nrun)
    np.maximum.at(peak, rid, exb)
    if have.any():  # the refined maximum counts for the band that holds its leaf
        np.maximum.at(peak, rid[j], np.where(np.isfinite(best[ti]), best[ti], 0.0))
    starts = np.nonzero(newrun)[0]
    qual = inside[starts] & (peak >= BAND_MIN_EXCESS_DEG)
    qs = starts[qual]
    # the run after each qualifying run (same task) holds the closing edge in its first leaf
    nxt_run = np.searchsorted(starts, qs, side="right")
    has_end = nxt_run < len(starts)
    je = np.where(has_end, starts[np.minimum(nxt_run, len(starts) - 1)], -1)
    has_end &= task[np.maximum(je, 0)] == task[qs]
    fim = lambda t_, w: np.imag(c7(t_, w))
    # the band edges are the zeros of Im C7 = Im(Δ10/Δ00); the compiled refinement uses the same
    # zeros of Im(Δ00·conj Δ10) = −|Δ00|² Im C7 (no division): its bracket values change sign
    # (computed for the bracketing leaves only; index k among the leaves with a > 0)
    def gva(k):
        with np.errstate(over="ignore", invalid="ignore"):  # only their signs are used
            return np.imag(lv["va"][0][leaf[k]] * np.conj(lv["va"][1][leaf[k]]))

    def gvb(k):
        with np.errstate(over="ignore", invalid="ignore"):
            return np.imag(lv["vb"][0][leaf[k]] * np.conj(lv["vb"][1][leaf[k]]))

    bracket_start = (np.sign(ima(qs)) != np.sign(imb[qs])) & resolved_sign[qs] & resolved_a[qs]
    ws = a_l[qs].copy()
    if bracket_start.any():
        k = qs[bracket_start]
        ws[bracket_start] = _edge_roots(fim, D0, D1, task[k], a_l[k], b_l[k], ima(k), imb[k], gva(k), gvb(k))
    we = np.full(len(qs), np.inf)
    jj = np.maximum(je, 0)
    closes = has_end & (np.sign(ima(jj)) != np.sign(imb[jj])) & resolved_sign[jj] & resolved_a[jj]
    we[has_end & ~closes] = b_l[np.maximum(je, 0)][has_end & ~closes] if (has_end & ~closes).any() else we[has_end & ~closes]
    has_end = closes
    if has_end.any():
        k = je[has_end]
        we[has_end] = _edge_roots(fim, D0, D1, task[k], a_l[k], b_l[k], ima(k), imb[k], gva(k), gvb(k))
    bands = [[] for _ in range(Nd)]
    for t_, w0, w1 in zip(task[qs].tolist(), ws.tolist(), we.tolist()):
        bands[t_].append([w0 / (2 * np.pi), w1 / (2 * np.pi)])
    exh = lv.get("exhausted")
    if exh is not None and exh.any():  # partial frequency coverage: the metrics are undefined
        best[exh] = np.nan
        for t in np.flatnonzero(exh):
            bands[t] = []
    return PassivityBatch(conclusive=lv["valid"] & lv["resolved"], max_phase_excess_deg=best, nonpassive_band_hz=bands)


def _golden_max(f, a_, b_):
    """Maximum of ``f`` on each bracket [a_, b_] by 40 golden-section steps (numpy reference of
    :func:`exotune.numerics.kernels.golden_max`): ``f`` at the final bracket's midpoint."""
    gr = 0.5 * (np.sqrt(5) - 1)
    c1 = b_ - gr * (b_ - a_)
    c2 = a_ + gr * (b_ - a_)
    f1, f2 = f(c1), f(c2)
    for _ in range(40):  # golden section, one new evaluation per iteration
        left = f1 >= f2
        b_ = np.where(left, c2, b_)
        a_ = np.where(left, a_, c1)
        c2n = np.where(left, c1, a_ + gr * (b_ - a_))
        c1n = np.where(left, b_ - gr * (b_ - a_), c2)
        new = np.where(left, c1n, c2n)
        fn = f(new)
        f1, f2 = np.where(left, fn, f2), np.where(left, f1, fn)
        c1, c2 = c1n, c2n
    return f(0.5 * (a_ + b_))


def _edge_roots(fim, D0, D1, task, a, b, ima, imb, ga, gb):
    if compiled():
        return pair_roots(None, D0, D1, "cross", task, a, b, ga, gb)
    return bisect_roots(fim, task, a, b, ima, fb=imb)


def _argmax_by_task(task, vals, Nd):
    """Index of the largest positive value of each task (-1 when none); ties: the last index."""
    out = np.full(Nd, -1)
    if task.size == 0:
        return out
    best = np.full(Nd, -np.inf)
    np.maximum.at(best, task, vals)
    hit = np.nonzero((vals == best[task]) & (vals > 0))[0]
    # indices ascending: for repeated tasks the last assignment (largest index) wins
    out[task[hit]] = hit
    return out

