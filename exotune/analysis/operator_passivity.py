"""Passivity of the operator-side compliance C7 = Δ10/Δ00 with the exact delay (paper §IV-A).

References
----------
Paper §IV-A "Passivity of the Operator Compliance"; docs/method.md#passivity-of-the-operator-compliance.
"""

from __future__ import annotations

import numpy as np

from ..numerics.engine import compiled
from ..numerics.quasipoly import DIP_RISE_UNEVEN, bisect_roots, dip_candidates, dip_rise, golden_max
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
# the delay ripple (docs/method.md#passivity-of-the-operator-compliance): beyond the last leaf, the
# sampled range is extended by octaves while the frozen ripple can still lift the phase by
# more than RIPPLE_MIN_DEG (a fifth of the listing threshold), up to TAIL_STEPS octaves
RIPPLE_MIN_DEG = 0.02
TAIL_STEPS = 12
# at most this many ripple samples per design (4 per period); a design that would need more (or a
# longer tail) is reported with partial coverage (NaN maximum, no bands) rather than with merged bands
MAX_RIPPLE_SAMPLES = 20_000


def passivity(side: FamilySide) -> PassivityBatch:
    """max_phase_excess_deg [deg] and nonpassive_band_hz [Hz] of C7 = Δ10/Δ00 (docs/method.md#analyses-and-metrics),
    as a :class:`~exotune.analysis.batch_result.PassivityBatch`.

    Passive phase band: arg C7 ∈ [−180°, 0°] ⇔ Im C7(jω) ≤ 0. The excess is the angular distance
    of the (wrapped) phase from that band, min(φ, 180° − φ) for φ ∈ (0°, 180°).

    C7 is sampled at the ends of the root-counting leaves and, with a delay, at four points per
    period 2π/T of the delay ripple, placed on the crests and troughs of the frozen ripple
    (:func:`_ripple_points`) wherever the ripple can make Im C7 positive, up to the frequency where
    it can no longer lift the phase by ``RIPPLE_MIN_DEG``; a lobe or gap narrower than the samples
    is searched where the sampled phase comes near the band's edge and turns back (:func:`_dips`),
    and a gap where the samples of a band that may be listed fall steeply (:func:`_gaps`).
    Bands are the runs of samples with Im C7 > 0 (the maximal intervals of Im C7 > 0); their edges
    are the exact zeros of Im C7. Where the phase passes 90° between samples, the maximum is 90° at
    the bisected zero of Re C7; otherwise every sampled local maximum that could hold the maximum,
    or lift its band to the listing threshold, is refined by golden section (:func:`_peak_cells`).
    Bands whose peak excess is below ``BAND_MIN_EXCESS_DEG`` (0.1°) are not listed (with a delay,
    C7 → 1/K_c with a decaying ripple of period 1/T in frequency).

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
    task, w, c, over = _samples(D0, D1, lv)
    # passive gaps that end a listable band early (or split it) but hold no sample
    *gaps, pre = _gaps(D0, D1, task, w, c)
    if gaps[0].size:  # the samples changed: their runs and maxima are those of the new samples
        task, w, c = _insert(task, w, c, *gaps)
        pre = None
    im, ex, same, first, resolved, last, inside, newrun = _runs(task, c) if pre is None else pre[0]
    best = np.zeros(Nd)
    starts_t = np.flatnonzero(np.r_[True, ~same]) if task.size else np.zeros(0, np.int64)
    if task.size:  # samples are grouped by design: segment maxima
        best[task[starts_t]] = np.maximum.reduceat(ex, starts_t)
    rid = np.cumsum(newrun) - 1
    starts = np.flatnonzero(newrun)
    peak = np.maximum.reduceat(ex, starts) if starts.size else np.zeros(0)
    ct, ca, cb, at = _peak_cells(D0, D1, task, w, c, ex, same, best, None if pre is None else pre[1])
    j90, f90 = _through_90(D0, D1, task, w, c, im, resolved, same)
    ct, at = np.r_[ct, task[j90]], np.r_[at, j90]
    if ct.size:
        f = np.r_[_refine_max(D0, D1, ct[:ca.size], ca, cb), f90]
        f = np.where(np.isfinite(f), f, 0.0)
        np.maximum.at(best, ct, f)
        np.maximum.at(peak, rid[at], f)
    ends = np.r_[starts[1:], task.size] - 1
    qual = inside[starts] & (peak >= BAND_MIN_EXCESS_DEG)
    qs, qe = starts[qual], ends[qual]
    # a run's edges are zeros of Im C7 bracketed by resolved samples: a run starts on one, and
    # the last resolved sample before it (`last`) brackets its start; its last resolved sample and
    # the next run's first bracket its end (the samples between are below the float resolution)
    opens = (qs > 0) & ~first[qs]
    before = last[np.maximum(qs - 1, 0)]
    ws = _edges(D0, D1, task, w, c, before, qs, np.where(opens, w[np.maximum(qs - 1, 0)], w[qs]),
                ok=opens & resolved[before])
    nxt = np.minimum(qe + 1, task.size - 1)
    closes = (qe + 1 < task.size) & (task[nxt] == task[qe])
    we = np.where(closes, _edges(D0, D1, task, w, c, last[qe], nxt, w[nxt], ok=closes & resolved[nxt]), np.inf)
    bands = [[] for _ in range(Nd)]
    for t_, w0, w1 in zip(task[qs].tolist(), ws.tolist(), we.tolist()):
        bands[t_].append([w0 / (2 * np.pi), w1 / (2 * np.pi)])
    partial = over.copy()
    exh = lv.get("exhausted")
    if exh is not None:
        partial |= exh
    if partial.any():  # partial frequency coverage: the metrics are undefined
        best[partial] = np.nan
        for t in np.flatnonzero(partial):
            bands[t] = []
    return PassivityBatch(conclusive=lv["valid"] & lv["resolved"], max_phase_excess_deg=best, nonpassive_band_hz=bands)


def _excess(c):
    """The passivity phase excess of C7 values ``c`` [deg]."""
    ph = np.degrees(np.angle(c))
    return np.where(ph > 0, np.minimum(ph, 180.0 - ph), 0.0)


def _excess_where(c, im):
    """:func:`_excess` where it can be positive (Im c > 0 ⇔ phase in (0°, 180°)), 0 elsewhere and
    where ``c`` is not finite (the same values, without the angles of the rest)."""
    out = np.zeros(c.shape)
    sel = (im > 0) & np.isfinite(c)
    out[sel] = _excess(c[sel])
    return out


def _signed_excess(c):
    """The passivity excess of C7 values ``c`` [deg], negative inside the passive band: minus the
    angular distance of the phase from the band's nearer edge (0° or −180°). Continuous in the
    phase (a kink at ±90° only), it is the excess where Im C7 > 0; NaN where ``c`` is not finite."""
    ph = np.degrees(np.angle(c))
    return np.where(np.isfinite(c), np.where(ph > 0, np.minimum(ph, 180.0 - ph), np.maximum(ph, -180.0 - ph)), np.nan)


def _samples(D0, D1, lv):
    """C7 samples of every design, ordered by (design, ω): the leaves' ends, the tail extension
    of delayed designs, the ripple points (:func:`_ripple_points`) and the dips (:func:`_dips`).

    Returns ``(task, w, c7, over)``: design row, ω [rad/s] and C7(jω) per sample, and per design
    whether the ripple needed more than ``MAX_RIPPLE_SAMPLES`` samples or more than ``TAIL_STEPS``
    octaves of tail (partial coverage). Compiled: :func:`exotune.numerics.kernels.c7_samples`, the
    same steps in one pass per design."""
    if compiled():
        from ..numerics import kernels as _fastphase

        return _fastphase.c7_samples(D0, D1, lv, RIPPLE_MIN_DEG, TAIL_STEPS, MAX_RIPPLE_SAMPLES, DIP_RISE_UNEVEN,
                                     iters=40)
    Nd = D0.n
    pos = lv["a"] > 0  # all leaves unless a grid starts at ω = 0
    keep = (lambda x: x) if pos.all() else (lambda x: x[pos])  # noqa: E731  (no copies when all)
    lt = keep(lv["task"])
    if lt.size == 0:
        z = np.zeros(0)
        return np.zeros(0, np.int64), z, z.astype(complex), np.zeros(Nd, bool)
    first = np.flatnonzero(np.r_[True, lt[1:] != lt[:-1]])
    # the leaves' ends: the a-end of each design's first leaf, then every b-end (no evaluation)
    ins = np.zeros(lt.size, np.int64)
    ins[first[1:] - 1] = 1  # a design's a-end follows the previous design's last b-end
    put = _inserter(ins)

    def ends(x, y):
        return np.r_[keep(x)[:1], put(keep(y), keep(x)[first[1:]])]

    task = np.r_[lt[:1], put(lt, lt[first[1:]])]
    w = ends(lv["a"], lv["b"])
    d0 = ends(lv["va"][0], lv["vb"][0])  # Δ00(jω)
    d1 = ends(lv["va"][1], lv["vb"][1])  # Δ10(jω)
    T = D0.T
    over = np.zeros(Nd, bool)
    if (T > 0).any():
        task, w, d0, d1, flag, gval, over = _tail(D0, D1, task, w, d0, d1)
        # the ripple: four points per period in every cell (two samples of one design) where the
        # frozen ripple's crest of Im C7 is positive and lifts the phase by RIPPLE_MIN_DEG at an end
        cell = np.flatnonzero((task[1:] == task[:-1]) & (flag[1:] | flag[:-1]))
        phase = _ripple_phase(w[cell], w[cell + 1], T[task[cell]], gval[cell], gval[cell + 1])
        over |= np.bincount(task[cell], weights=phase[0], minlength=Nd) > MAX_RIPPLE_SAMPLES
        keep = ~over[task[cell]]
        n, rw = _ripple_points(w[cell][keep], w[cell + 1][keep], *(x[keep] for x in phase))
        cell = cell[keep]
        if rw.size:
            rt = np.repeat(task[cell], n)
            ins = np.zeros(task.size, np.int64)
            ins[cell] = n
            put = _inserter(ins)
            task, w = put(task, rt), put(w, rw)
            d0, d1 = put(d0, D0.eval(rt, rw, deriv=False)[0]), put(d1, D1.eval(rt, rw, deriv=False)[0])
    with np.errstate(divide="ignore", invalid="ignore"):
        c = d1 / d0
    # a lobe (or a gap in a band) narrower than the sampling: where sin arg C7 comes near 0 and
    # turns back, Im C7 is searched for the other sign between the neighbours; such a point is
    # added as a sample, and the lobe's (gap's) edges follow
    task, w, c = _insert(task, w, c, *_dips(D0, D1, task, w, c))
    return task, w, c, over


def _tail(D0, D1, task, w, d0, d1):
    """The frozen-ripple frame (:func:`_frame`) of every sample of a delayed design, and the tail.

    Every cell between consecutive samples gets the frame at both ends (also a cell shorter than a
    quarter ripple period can hold a lobe: a crest point is placed in it when the frozen crest
    falls inside). A delayed design
    whose last sample is flagged gets a tail: up to ``TAIL_STEPS`` octaves beyond it, kept while
    the frame is flagged (and one step beyond); beyond the last leaf the frequency set's tail
    bounds hold and the ripple's lift only decays.

    Returns the samples with the tails inserted, the frame (``flag``, ``g``; False and 0 without a
    delay), and per design whether the ripple could still lift the phase at the last tail step
    (the coverage is then partial)."""
    T = D0.T
    last = np.flatnonzero(np.r_[task[1:] != task[:-1], True])
    last = last[T[task[last]] > 0]
    flag, g = _frame(D0, D1, task, w, d0, d1)
    last = last[flag[last]]
    unfinished = np.zeros(D0.n, bool)
    if last.size == 0:
        return task, w, d0, d1, flag, g, unfinished
    t_task = np.repeat(task[last], TAIL_STEPS)
    t_w = (w[last][:, None] * 2.0 ** np.arange(1, TAIL_STEPS + 1)[None, :]).ravel()
    t_d0, t_d1 = D0.eval(t_task, t_w, deriv=False)[0], D1.eval(t_task, t_w, deriv=False)[0]
    t_flag, t_g = _frame(D0, D1, t_task, t_w, t_d0, t_d1)
    lifts = t_flag.reshape(-1, TAIL_STEPS)
    # steps up to the last one that can still lift the phase, plus one (at least one step)
    n_t = np.where(lifts.any(axis=1), np.minimum(TAIL_STEPS - np.argmax(lifts[:, ::-1], axis=1) + 1, TAIL_STEPS), 1)
    keep = (np.arange(TAIL_STEPS)[None, :] < n_t[:, None]).ravel()
    ins = np.zeros(task.size, np.int64)
    ins[last] = n_t
    put = _inserter(ins)
    unfinished[task[last]] = lifts[:, -1]
    out = (put(task, t_task[keep]), put(w, t_w[keep]), put(d0, t_d0[keep]), put(d1, t_d1[keep]),
           put(flag, t_flag[keep]), put(g, t_g[keep]))
    return out + (unfinished,)


def _frame(D0, D1, task, w, d0, d1):
    """The frozen delay ripple at each sample (the numpy reference; the compiled pass
    :func:`exotune.numerics.kernels.c7_samples` computes it per sample, as does
    :func:`exotune.numerics.kernels.ripple_frame`): whether its crest A0 + |G| of |Δ00|² Im C7 is positive and can lift the phase by
    ``RIPPLE_MIN_DEG`` or more (bounded with |Δ00| ≥ |P00| − |P01| and |Δ10| ≥ |P10| − |P11|; a
    non-positive bound counts), and G (docs/method.md#passivity-of-the-operator-compliance).
    Δ00 = P00 + P01 e^{−sT} and Δ10 = P10 + P11 e^{−sT}; the delayed parts P01, P11 are evaluated,
    P00 and P10 follow from Δ00 and Δ10. No delay: no flag, G = 0."""
    flag = np.zeros(task.size, bool)
    g = np.zeros(task.size, complex)
    dl = np.flatnonzero(D0.T[task] > 0)
    if dl.size == 0:
        return flag, g
    t_, x = task[dl], w[dl]
    e = np.exp(-1j * x * D0.T[t_])
    p01, p11 = D0.delayed_part(t_, x), D1.delayed_part(t_, x)
    p00, p10 = d0[dl] - p01 * e, d1[dl] - p11 * e
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        a0 = np.imag(p10 * np.conj(p00) + p11 * np.conj(p01))
        gd = p11 * np.conj(p00) - np.conj(p10) * p01
        crest = a0 + np.abs(gd)
        den = np.maximum(np.abs(p00) - np.abs(p01), 0.0) * np.maximum(np.abs(p10) - np.abs(p11), 0.0)
        lift = np.degrees(crest / den)
    flag[dl] = (crest > 0) & ~((den > 0) & (lift < RIPPLE_MIN_DEG))
    g[dl] = gd
    return flag, g


def _inserter(counts):
    """A function that returns its ``base`` with ``counts[i]`` items of ``extra`` (in order)
    inserted after each ``base[i]`` (the positions computed once for every array)."""
    pos = np.arange(counts.size) + np.cumsum(counts) - counts
    size = counts.size + int(counts.sum())
    mask = np.ones(size, bool)
    mask[pos] = False

    def put(base, extra):
        out = np.empty(size, dtype=np.result_type(base, extra))
        out[pos] = base
        out[mask] = extra
        return out

    return put


def _dips(D0, D1, task, w, c):
    """Lobes of Im C7 > 0, and gaps of Im C7 < 0 inside a band, narrower than the samples.
    Candidates: samples j where sin arg C7 (= Im C7/|C7|) may hide the other sign between its
    neighbours (:func:`~exotune.numerics.quasipoly.dip_candidates`, with the factor of
    :func:`~exotune.numerics.quasipoly.dip_rise` for the spacing of the three samples). −s·Im(Δ10·conj Δ00) = −s|Δ00|² Im C7 is maximized on [w_{j−1}, w_{j+1}] by
    golden section; where its maximum is positive (Im C7 changes sign), that point is returned.

    Returns ``(after, w, c7)``: the index of the sample each new point follows, the point [rad/s]
    and C7 there."""
    n = task.size
    z = np.zeros(0, np.int64)
    if n < 3:
        return z, np.zeros(0), np.zeros(0, complex)
    with np.errstate(invalid="ignore", divide="ignore"):
        sn = np.imag(c) / np.abs(c)
    j = np.arange(1, n - 1)
    cand, sg = dip_candidates(sn[j - 1], sn[j], sn[j + 1], rise=dip_rise(w[j] - w[j - 1], w[j + 1] - w[j]))
    cand &= (task[j - 1] == task[j]) & (task[j + 1] == task[j])
    j, sg = j[cand], sg[cand]
    if j.size == 0:
        return z, np.zeros(0), np.zeros(0, complex)
    v, ws = np.zeros(j.size), np.zeros(j.size)
    for s_, qa, qb in ((-1.0, D1, D0), (1.0, D0, D1)):  # −s·Im(Δ10 conj Δ00) = Im(qa conj qb)
        k = sg == s_
        if not k.any():
            continue
        tk = task[j[k]]
        if compiled():
            from ..numerics import kernels as _fastphase

            v[k], ws[k] = _fastphase.golden_max(qa, qb, "cross", tk, w[j[k] - 1], w[j[k] + 1], iters=40, where=True)
        else:
            def f(x, qa=qa, qb=qb, tk=tk):
                return np.imag(qa.eval(tk, x, deriv=False)[0] * np.conj(qb.eval(tk, x, deriv=False)[0]))

            v[k], ws[k] = golden_max(f, w[j[k] - 1], w[j[k] + 1], where=True)
    hit = v > 0
    j, ws = j[hit], ws[hit]
    tj = task[j]
    a, _ = D0.eval(tj, ws, deriv=False)
    b, _ = D1.eval(tj, ws, deriv=False)
    return np.where(ws < w[j], j - 1, j), ws, b / a


def _ripple_phase(wa, wb, T, ga, gb):
    """The ripple phase ψ(ω) = ωT − arg G(ω) + π/2 at the cells' a-ends and its increase across
    them, and the number n and first index k0 of the quarter periods ψ = kπ/2 inside each cell."""
    with np.errstate(invalid="ignore", divide="ignore"):
        dpsi = (wb - wa) * T - np.angle(gb / ga)
        psi_a = wa * T - np.angle(ga) + 0.5 * np.pi
    ok = np.isfinite(dpsi) & np.isfinite(psi_a) & (dpsi > 0)
    q = 0.5 * np.pi
    k0 = np.where(ok, np.floor(psi_a / q) + 1, 0)
    k1 = np.where(ok, np.ceil((psi_a + dpsi) / q) - 1, -1)
    cnt = k1 - k0 + 1
    n = np.where(cnt > 0, np.minimum(cnt, 4.0 * MAX_RIPPLE_SAMPLES), 0).astype(np.int64)  # NaN: none
    return n, k0, psi_a, dpsi


def _ripple_points(wa, wb, n, k0, psi_a, dpsi):
    """Four points per period of the delay ripple in each cell [wa, wb] [rad/s], on the crests,
    troughs and midway points of the frozen ripple A0 + |G| sin(arg G − ωT) (:func:`_frame`):
    ψ(ω) = ωT − arg G(ω) + π/2 ≡ 0 (mod π/2), with arg G interpolated linearly across the cell.
    A lobe where Im C7 > 0 is then sampled at its crest, and the gap between two lobes at its
    trough, unless the lobe (gap) is so shallow that its peak excess is negligible.

    ``n, k0, psi_a, dpsi``: the cells' ripple phase (:func:`_ripple_phase`).

    Returns ``(n, w)``: the number of points in each cell and the points, cell by cell, increasing."""
    q = 0.5 * np.pi
    cell = np.repeat(np.arange(wa.size), n)
    k = k0[cell] + (np.arange(cell.size) - np.repeat(np.cumsum(n) - n, n))
    w = wa[cell] + (k * q - psi_a[cell]) / dpsi[cell] * (wb[cell] - wa[cell])
    # rounding can put a point on a cell end: keep it strictly inside
    w = np.minimum(np.maximum(w, np.nextafter(wa[cell], np.inf)), np.nextafter(wb[cell], -np.inf))
    return n, w


def _local_maxima(w, c, ex, same):
    """The sampled local maxima of the excess ``ex`` [deg] and how high each could rise between its
    neighbours.

    A parabola through three samples whose middle one is the highest rises above it by at most
    1/(4ρ(1 + ρ)) times its fall to the lower neighbour (ρ: the ratio of the shorter to the longer
    of the two cells); the reach is the middle value plus that fall times
    :func:`~exotune.numerics.quasipoly.dip_rise`, at least four times the parabola's bound
    (docs/method.md#passivity-of-the-operator-compliance). The fall is measured on the signed
    excess (:func:`_signed_excess` of the C7 samples ``c``): a sample just inside a band whose
    neighbours lie deep in the passive band can sit far below the band's peak between them. A
    sample without a (finite) neighbour has an infinite reach. Returns ``(top, reach)``: whether
    each sample is a positive local maximum, and its reach [deg] (the sample's excess elsewhere)."""
    n = ex.size
    if n < 2:
        return ex > 0, np.where(ex > 0, np.inf, ex)
    left, right = np.r_[False, same], np.r_[same, False]
    top = (ex > 0) & ~(left & (np.r_[0.0, ex[:-1]] > ex)) & ~(right & (np.r_[ex[1:], 0.0] > ex))
    i = np.flatnonzero(top)
    li, ri = np.maximum(i - 1, 0), np.minimum(i + 1, n - 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        sl = np.where(left[i], _signed_excess(c[li]), np.nan)
        sr = np.where(right[i], _signed_excess(c[ri]), np.nan)
        fall = ex[i] - np.fmin(sl, sr)  # NaN: no (finite) neighbour
        rise = dip_rise(np.where(left[i], w[i] - w[li], 0.0), np.where(right[i], w[ri] - w[i], 0.0))
        lift = np.where(fall > 0, rise * fall, np.where(np.isnan(fall), np.inf, 0.0))
    reach = ex.copy()
    reach[i] += lift
    return top, reach


def _peak_cells(D0, D1, task, w, c, ex, same, best, maxima=None):
    """The brackets where the maximum of the excess is refined by golden section: around every
    sampled local maximum whose reach (:func:`_local_maxima`) attains its design's largest sampled
    excess ``best`` (it may hold the maximum), or, below ``BAND_MIN_EXCESS_DEG``, attains that
    threshold or lies within a factor 2 below it (it may decide whether its band is listed).
    The bracket runs between the sample's neighbours, or from the zero of Im C7 towards a passive
    neighbour (:func:`_edges`): the excess is positive inside, so golden section cannot turn away
    from the lobe where the excess is flat (zero). ``maxima``: :func:`_local_maxima` of these
    samples when already known. Returns ``(task, a, b, sample)``: the sample names the run that
    the refined value belongs to."""
    n = task.size
    if n < 2:
        z = np.zeros(0, np.int64)
        return z, np.zeros(0), np.zeros(0), z
    top, reach = _local_maxima(w, c, ex, same) if maxima is None else maxima
    low = ex < BAND_MIN_EXCESS_DEG
    i = np.flatnonzero(top & ((reach >= best[task]) | (low & ((reach >= BAND_MIN_EXCESS_DEG)
                                                               | (ex >= 0.5 * BAND_MIN_EXCESS_DEG)))))
    left, right = np.r_[False, same][i], np.r_[same, False][i]
    li, ri = np.where(left, i - 1, i), np.where(right, i + 1, i)
    a = _edges(D0, D1, task, w, c, li, i, w[li], ok=left)
    b = _edges(D0, D1, task, w, c, i, ri, w[ri], ok=right)
    return task[i], a, b, i


def _runs(task, c):
    """The runs of samples of one design and one sign of Im C7 (a run with Im C7 > 0 is a band).

    The sign of Im C7 is only trusted above the float resolution (|Im C7| > 1e-8 |C7|); samples
    below it inherit the state of the previous sample of the same design, so rounding noise in the
    high-frequency tail neither splits nor ends a band. Returns ``(im, ex, same, first, resolved,
    last, inside, newrun)``: Im C7 and the excess [deg] per sample, whether each sample and the
    next are of one design, whether it is its design's first, whether its sign is resolved, the
    last resolved sample up to it, whether it lies in a band, and whether it starts a run."""
    im = np.imag(c)
    ex = _excess_where(c, im)
    same = task[1:] == task[:-1]
    first = np.r_[True, ~same][: task.size]
    resolved = np.abs(im) > 1e-8 * np.abs(c)
    last = np.maximum.accumulate(np.where(resolved | first, np.arange(task.size), 0))
    inside = (im > 0)[last]
    newrun = np.r_[True, ~same | (inside[1:] != inside[:-1])][: task.size]
    return im, ex, same, first, resolved, last, inside, newrun


def _gaps(D0, D1, task, w, c):
    """Passive gaps without a sample inside the bands that may be listed (a band whose reach,
    :func:`_local_maxima`, attains ``BAND_MIN_EXCESS_DEG``): they would merge the band with a
    lobe beyond the gap, or end it past its true edge.

    Candidates: every cell between two resolved samples of such a band whose sin arg C7 differ,
    where the lower one is nearer to 0 than ``DIP_RISE_UNEVEN`` times the difference and is not
    a sampled local minimum (the dips search those, :func:`_dips`): the samples fall towards the
    band's end, or towards a lower sample. −|Δ00|² Im C7 = Im(Δ00·conj Δ10) is maximized on the
    cell by golden section; where its maximum is positive (Im C7 < 0: a gap), that point is
    returned (docs/method.md#passivity-of-the-operator-compliance).

    Returns ``(after, w, c7, pre)``: the index of the sample each new point follows, the point
    [rad/s] and C7 there, and the :func:`_runs` and :func:`_local_maxima` of the given samples
    (None when fewer than two), for the caller to reuse when no point is found."""
    n = task.size
    z = np.zeros(0, np.int64)
    if n < 2:
        return z, np.zeros(0), np.zeros(0, complex), None
    runs = _runs(task, c)
    im, ex, same, first, resolved, last, inside, newrun = runs
    rid = np.cumsum(newrun) - 1
    starts = np.flatnonzero(newrun)
    maxima = _local_maxima(w, c, ex, same)
    reach = maxima[1]
    listable = (inside[starts] & (np.maximum.reduceat(reach, starts) >= BAND_MIN_EXCESS_DEG))[rid]
    # the cells of one run of a listable band (the tests below only there: a fraction of the samples)
    i = np.flatnonzero(same & listable[:-1] & listable[1:] & (rid[:-1] == rid[1:]))

    def u(k):  # sin arg C7 at samples k; NaN: not a resolved band sample
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(resolved[k] & (im[k] > 0), im[k] / np.abs(c[k]), np.nan)

    ua, ub = u(i), u(i + 1)
    dec = ua > ub
    hi_, lo_ = np.fmax(ua, ub), np.fmin(ua, ub)
    # the lower sample's other neighbour (beyond the cell): a higher band sample makes it a dip
    o = np.where(dec, i + 2, i - 1)
    ok_o = (o >= 0) & (o < n)
    o = np.clip(o, 0, n - 1)
    uo = np.where(ok_o & (task[o] == task[i]), u(o), np.nan)
    with np.errstate(invalid="ignore"):
        j = i[(ua != ub) & ~(uo > lo_) & (lo_ < DIP_RISE_UNEVEN * (hi_ - lo_))]
    if j.size == 0:
        return z, np.zeros(0), np.zeros(0, complex), (runs, maxima)
    tj = task[j]
    if compiled():
        from ..numerics import kernels as _fastphase

        v, ws = _fastphase.golden_max(D0, D1, "cross", tj, w[j], w[j + 1], iters=40, where=True)
    else:
        def f(x):
            return np.imag(D0.eval(tj, x, deriv=False)[0] * np.conj(D1.eval(tj, x, deriv=False)[0]))

        v, ws = golden_max(f, w[j], w[j + 1], where=True)
    hit = v > 0
    j, ws = j[hit], ws[hit]
    a, _ = D0.eval(task[j], ws, deriv=False)
    b, _ = D1.eval(task[j], ws, deriv=False)
    return j, ws, b / a, (runs, maxima)


def _insert(task, w, c, after, wd, cd):
    """The samples ``(task, w, c)`` with the points ``(wd, cd)`` inserted after the samples
    ``after`` (points after one sample given in increasing order)."""
    if after.size == 0:
        return task, w, c
    ins = np.zeros(task.size, np.int64)
    np.add.at(ins, after, 1)
    order = np.argsort(after, kind="stable")
    put = _inserter(ins)
    return put(task, task[after][order]), put(w, wd[order]), put(c, cd[order])


def _through_90(D0, D1, task, w, c, im, resolved, same):
    """The excess [deg] where the phase passes 90° between two samples of Im C7 > 0 (Re C7 changes
    sign): Re C7 = 0 is bisected (the zero of Re(Δ10·conj Δ00) = |Δ00|² Re C7, the compiled
    refinement's crossing function of the pair (Δ10, Δ00) with f = −j) and the excess evaluated
    there (90° to rounding; golden section is not used: the excess has a kink at 90°). Returns
    ``(sample, excess)``: the cell's first sample and the value."""
    pos = (im > 0) & resolved
    j = np.flatnonzero(same & pos[:-1] & pos[1:] & (np.sign(np.real(c[:-1])) != np.sign(np.real(c[1:]))))
    if j.size == 0:
        return j, np.zeros(0)
    tj = task[j]

    def fre(t_, x):
        return np.real(D1.eval(t_, x, deriv=False)[0] * np.conj(D0.eval(t_, x, deriv=False)[0]))

    with np.errstate(over="ignore", invalid="ignore"):
        ga, gb = fre(tj, w[j]), fre(tj, w[j + 1])
    if compiled():
        w90 = pair_roots(None, D1, D0, "cross", tj, w[j], w[j + 1], ga, gb, k=0, factor=-1j)
    else:
        w90 = bisect_roots(fre, tj, w[j], w[j + 1], ga, fb=gb)
    a, _ = D0.eval(tj, w90, deriv=False)
    b, _ = D1.eval(tj, w90, deriv=False)
    return j, _excess_where(b / a, np.imag(b / a))


def _refine_max(D0, D1, task, a, b):
    """The maximum of the excess [deg] on each bracket [a, b] by golden section (compiled or the
    numpy reference :func:`~exotune.numerics.quasipoly.golden_max`)."""
    if compiled():
        from ..numerics import kernels as _fastphase

        return _fastphase.golden_max(D0, D1, "excess", task, a, b, iters=40)

    def f(w):
        a_, _ = D0.eval(task, w, deriv=False)
        b_, _ = D1.eval(task, w, deriv=False)
        return _excess(b_ / a_)

    return golden_max(f, a, b)


def _edges(D0, D1, task, w, c, lo, hi, fallback, ok):
    """Band edges [rad/s]: the zero of Im C7 between samples ``lo`` and ``hi`` (of one design)
    where ``ok`` and their signs differ, else ``fallback``. The callers pass resolved samples
    (|Im C7| above the float resolution); the samples between them are not (they inherited the
    run's state), so the zero found lies where Im C7 is within the float resolution of 0."""
    out = np.array(fallback, dtype=float, copy=True)
    if lo.size == 0 or task.size < 2:
        return out
    a_, b_ = np.clip(lo, 0, task.size - 1), np.clip(hi, 0, task.size - 1)
    im = np.imag(c)
    br = ok & (np.sign(im[a_]) * np.sign(im[b_]) < 0) & (task[a_] == task[b_])
    if br.any():
        ka, kb = a_[br], b_[br]

        # the zeros of Im C7 = Im(Δ10/Δ00) are those of Im(Δ00·conj Δ10) = −|Δ00|² Im C7 (no
        # division; the compiled refinement's "cross" function)
        def fim(t_, x):
            return np.imag(D0.eval(t_, x, deriv=False)[0] * np.conj(D1.eval(t_, x, deriv=False)[0]))

        with np.errstate(over="ignore", invalid="ignore"):
            ga, gb = fim(task[ka], w[ka]), fim(task[ka], w[kb])
        if compiled():
            out[br] = pair_roots(None, D0, D1, "cross", task[ka], w[ka], w[kb], ga, gb)
        else:
            out[br] = bisect_roots(fim, task[ka], w[ka], w[kb], ga, fb=gb)
    return out
