"""Compiled frozen-ripple frame of the operator compliance C7 = Δ10/Δ00 (numpy reference:
:func:`exotune.analysis.operator_passivity._frame`; docs/method.md#passivity-of-the-operator-compliance).

With the polynomial parts frozen at ω (Δ00 = P00 + P01 e^{−jωT}, Δ10 = P10 + P11 e^{−jωT}),
|Δ00|² Im C7 = A0 + Im(G e^{−jωT}), A0 = Im(P10 conj P00 + P11 conj P01), G = P11 conj P00 − conj P10 · P01.
"""

from __future__ import annotations

import math

import numpy as np

from .common import AVAILABLE, coefficients, njit
from .pair import pair_args

if AVAILABLE:
    from .common import cdiv, eval_quasi, horner
    from .pair import dip_search, is_dip

__all__ = ["ripple_frame", "c7_samples"]

if AVAILABLE:

    @njit(cache=True)
    def _frame_at(cA1, cB1, t, T, x, d0, d1, lift_min):
        """(flag, G) of the frozen ripple at one sample ω = x of a delayed design (T > 0)."""
        ar, ai, _, _ = horner(cA1, t, x)
        br, bi, _, _ = horner(cB1, t, x)
        p01 = complex(ar, ai)
        p11 = complex(br, bi)
        e = complex(math.cos(x * T), -math.sin(x * T))
        p00 = d0 - p01 * e
        p10 = d1 - p11 * e
        a0 = (p10 * p00.conjugate() + p11 * p01.conjugate()).imag
        gi = p11 * p00.conjugate() - p10.conjugate() * p01
        crest = a0 + abs(gi)
        den = max(abs(p00) - abs(p01), 0.0) * max(abs(p10) - abs(p11), 0.0)
        if not (crest > 0.0):  # also NaN
            return False, gi
        if den > 0.0:
            lift = math.degrees(crest / den)
            return not (lift < lift_min), gi  # NaN or inf lifts count
        return True, gi

    @njit(cache=True)
    def _frame(cA1, cB1, Ts, task, w, d0, d1, lift_min, flag, g):
        for i in range(task.shape[0]):
            t = task[i]
            T = Ts[t]
            if not (T > 0.0):
                flag[i] = False
                g[i] = 0.0
                continue
            flag[i], g[i] = _frame_at(cA1, cB1, t, T, w[i], d0[i], d1[i], lift_min)


def ripple_frame(qa, qb, task, w, d0, d1, lift_min: float):
    """Whether the frozen delay ripple of C7 = Δb/Δa can make Im C7 positive and lift its phase by
    ``lift_min`` degrees or more at each sample, and its G.

    Parameters
    ----------
    qa, qb : QP
        Δ00 and Δ10 (same delays T [s]).
    task : ndarray of int
        Design row of each sample.
    w : ndarray
        The samples [rad/s].
    d0, d1 : ndarray of complex
        Δ00(jω) and Δ10(jω) at the samples.
    lift_min : float
        The smallest lift of the phase that counts [deg].

    Returns
    -------
    flag : ndarray of bool
        The crest A0 + |G| is positive and (A0 + |G|)/((|P00| − |P01|)(|P10| − |P11|)) ≥ ``lift_min``
        (a non-positive bound counts); False without a delay.
    g : ndarray of complex
        G at the samples (0 without a delay).
    """
    n = len(task)
    flag = np.zeros(n, bool)
    g = np.zeros(n, complex)
    if n:
        _, cA1 = coefficients(qa)
        _, cB1 = coefficients(qb)
        if cA1.dtype != cB1.dtype:  # one compiled specialization per dtype: real rows stay real
            cA1, cB1 = (np.ascontiguousarray(x, dtype=complex) for x in (cA1, cB1))
        c = lambda x: np.ascontiguousarray(x, dtype=complex)  # noqa: E731
        _frame(cA1, cB1, np.ascontiguousarray(qa.T, dtype=float), np.ascontiguousarray(task, dtype=np.int64),
               np.ascontiguousarray(w, dtype=float), c(d0), c(d1), float(lift_min), flag, g)
    return flag, g


if AVAILABLE:

    @njit(cache=True)
    def _grow(x, n):
        """``x`` if it holds ``n`` items, else a copy of it with room for max(2 len(x), n)."""
        if n <= x.shape[0]:
            return x
        y = np.empty(max(2 * x.shape[0], n), x.dtype)
        y[: x.shape[0]] = x
        return y

    @njit(cache=True)
    def _pair(cA0, cA1, cB0, cB1, t, T, x):
        """Δa(jx) and Δb(jx) of row t (a call, not inlined: it keeps the compilation short)."""
        v0, _ = eval_quasi(cA0, cA1, t, T, x)
        v1, _ = eval_quasi(cB0, cB1, t, T, x)
        return v0, v1

    @njit(cache=True, inline="always")
    def _dip_rise(h1, h2, least):
        """The dip test's factor for cells of lengths h1 and h2 around a sample
        (:func:`exotune.numerics.quasipoly.dip_rise`)."""
        if not (h1 > 0.0 and h2 > 0.0):  # an empty cell (or NaN)
            return math.inf
        rho = min(h1, h2) / max(h1, h2)
        d = rho * (1.0 + rho)
        if not (d > 0.0):  # an infinite cell: numba's float division by 0 would raise
            return math.inf
        return max(least, 1.0 / d)

    @njit(cache=True, inline="always")
    def _sin_arg(c):
        """Im c / |c| (NaN where c is 0 or not finite; numba's float division by 0 would raise)."""
        a = abs(c)
        return c.imag / a if a != 0.0 else math.nan

    @njit(cache=True)
    def _leaf_ends(la, lb, va0, va1, vb0, vb1, i, e, sw, s0, s1):
        """The leaves i..e−1 of one design: the a-end of the first leaf with a > 0, then every
        b-end, into (sw, s0, s1); returns their number."""
        m = 0
        for lf in range(i, e):
            if not (la[lf] > 0):
                continue
            if m == 0:
                sw[0] = la[lf]
                s0[0] = va0[lf]
                s1[0] = va1[lf]
                m = 1
            sw[m] = lb[lf]
            s0[m] = vb0[lf]
            s1[m] = vb1[lf]
            m += 1
        return m

    @njit(cache=True)
    def _frame_tail(cA0, cA1, cB0, cB1, t, T, m, sw, s0, s1, sf, sg, lift_min, tail_steps, over):
        """The frame of the m samples of a delayed design and, when the last is flagged, its tail:
        octaves while the ripple can lift the phase, and one more (``over[t]`` when the last one
        still can); returns the number of samples."""
        for j in range(m):
            sf[j], sg[j] = _frame_at(cA1, cB1, t, T, sw[j], s0[j], s1[j], lift_min)
        if not sf[m - 1]:
            return m
        wl = sw[m - 1]
        lastf = -1
        for k in range(tail_steps):
            x = wl * 2.0 ** (k + 1)
            v0, v1 = _pair(cA0, cA1, cB0, cB1, t, T, x)
            sw[m + k] = x
            s0[m + k] = v0
            s1[m + k] = v1
            sf[m + k], sg[m + k] = _frame_at(cA1, cB1, t, T, x, v0, v1, lift_min)
            if sf[m + k]:
                lastf = k
        if lastf == tail_steps - 1:
            over[t] = True
        return m + (min(lastf + 2, tail_steps) if lastf >= 0 else 1)

    @njit(cache=True)
    def _ripple_cells(T, m, sw, sf, sg, max_ripple, rn, rk, rp, rd):
        """The ripple phase of every flagged cell of one design: the number of quarter periods
        ψ = kπ/2 inside (rn), the first k (rk), ψ at the cell's a-end (rp) and its increase (rd);
        returns the total (numpy reference: ``_ripple_phase``)."""
        q = 0.5 * math.pi
        total = 0
        for j in range(m - 1):
            rn[j] = 0
            if not (sf[j] or sf[j + 1]):
                continue
            gq = cdiv(sg[j + 1], sg[j])
            dpsi = (sw[j + 1] - sw[j]) * T - math.atan2(gq.imag, gq.real)
            psi_a = sw[j] * T - math.atan2(sg[j].imag, sg[j].real) + 0.5 * math.pi
            if not (np.isfinite(dpsi) and np.isfinite(psi_a) and dpsi > 0):
                continue
            k0 = np.floor(psi_a / q) + 1.0
            k1 = np.ceil((psi_a + dpsi) / q) - 1.0
            cnt = k1 - k0 + 1.0
            if not (cnt > 0.0):  # also NaN (an overflowed phase): no point
                continue
            rn[j] = int(min(cnt, 4.0 * max_ripple))
            rk[j] = k0
            rp[j] = psi_a
            rd[j] = dpsi
            total += rn[j]
        return total

    @njit(cache=True)
    def _fill(cA0, cA1, cB0, cB1, t, T, m, ripple, sw, s0, s1, rn, rk, rp, rd, fw, fc):
        """C7 at the samples of one design in order: each base sample, then (``ripple``) its cell's
        ripple points (numpy reference: ``_ripple_points``); returns their number."""
        q = 0.5 * math.pi
        p = 0
        for j in range(m):
            fw[p] = sw[j]
            fc[p] = cdiv(s1[j], s0[j])
            p += 1
            if j == m - 1 or not ripple:
                continue
            wa = sw[j]
            wb = sw[j + 1]
            lo = np.nextafter(wa, np.inf)
            hi = np.nextafter(wb, -np.inf)
            for r in range(rn[j]):
                x = wa + ((rk[j] + r) * q - rp[j]) / rd[j] * (wb - wa)
                x = min(max(x, lo), hi)
                v0, v1 = _pair(cA0, cA1, cB0, cB1, t, T, x)
                fw[p] = x
                fc[p] = cdiv(v1, v0)
                p += 1
        return p

    @njit(cache=True)
    def _find_dips(cA0, cA1, cB0, cB1, t, T, M, fw, fc, rise, iters, da, dw):
        """Lobes and gaps narrower than the samples of one design: golden section of
        Im(Δ00 conj Δ10) between the neighbours of each candidate (numpy reference: ``_dips``);
        the sample each point follows (da, increasing: two neighbours are never both candidates)
        and the point (dw); returns their number."""
        nd = 0
        up = _sin_arg(fc[0])
        un = _sin_arg(fc[1]) if M > 1 else math.nan
        for j in range(1, M - 1):
            uq = up
            up = un
            un = _sin_arg(fc[j + 1])
            if not is_dip(uq, up, un, _dip_rise(fw[j] - fw[j - 1], fw[j + 1] - fw[j], rise)):
                continue
            s = 1.0 if up > 0 else -1.0
            wd, gd = dip_search(cA0, cA1, cB0, cB1, t, T, fw[j - 1], fw[j + 1], -s, 0, 1.0, 0.0, iters)
            if s * gd > 0:
                da[nd] = j - 1 if wd < fw[j] else j
                dw[nd] = wd
                nd += 1
        return nd

    @njit(cache=True)
    def _emit(cA0, cA1, cB0, cB1, t, T, M, fw, fc, nd, da, dw, n, o_t, o_w, o_c):
        """The samples of one design with the dips' points merged in, from position n of the
        output; returns the new end."""
        r = 0
        for j in range(M):
            o_t[n] = t
            o_w[n] = fw[j]
            o_c[n] = fc[j]
            n += 1
            if r < nd and da[r] == j:
                v0, v1 = _pair(cA0, cA1, cB0, cB1, t, T, dw[r])
                o_t[n] = t
                o_w[n] = dw[r]
                o_c[n] = cdiv(v1, v0)
                n += 1
                r += 1
        return n

    @njit(cache=True)
    def _samples(cA0, cA1, cB0, cB1, Ts, lt, la, lb, va0, va1, vb0, vb1, lift_min, tail_steps, max_ripple, rise,
                 iters, over):
        """One pass per design over its leaves: the samples of C7 in order (numpy reference and
        description: :func:`exotune.analysis.operator_passivity._samples`). Returns (task, w, c, n).
        The stages are functions of their own; this loop owns the scratch arrays and grows them."""
        n_l = lt.shape[0]
        cap = n_l + 64
        o_t = np.empty(cap, np.int64)
        o_w = np.empty(cap)
        o_c = np.empty(cap, np.complex128)
        n = 0
        # per-design scratch: base samples (leaf ends and tail) with their frame, the cells' ripple
        # phase, the samples with the ripple points, the dips
        sw, s0, s1, sg = np.empty(64), np.empty(64, np.complex128), np.empty(64, np.complex128), np.empty(64, np.complex128)
        sf = np.empty(64, np.bool_)
        rn, rk, rp, rd = np.empty(64, np.int64), np.empty(64), np.empty(64), np.empty(64)
        fw, fc = np.empty(64), np.empty(64, np.complex128)
        da, dw = np.empty(64, np.int64), np.empty(64)
        i = 0
        while i < n_l:
            t = lt[i]
            e = i
            while e < n_l and lt[e] == t:
                e += 1
            need = e - i + 1 + tail_steps
            sw, s0, s1, sf, sg = _grow(sw, need), _grow(s0, need), _grow(s1, need), _grow(sf, need), _grow(sg, need)
            m = _leaf_ends(la, lb, va0, va1, vb0, vb1, i, e, sw, s0, s1)
            i = e
            if m == 0:
                continue
            T = Ts[t]
            total = 0
            if T > 0.0:
                m = _frame_tail(cA0, cA1, cB0, cB1, t, T, m, sw, s0, s1, sf, sg, lift_min, tail_steps, over)
                rn, rk, rp, rd = _grow(rn, m), _grow(rk, m), _grow(rp, m), _grow(rd, m)
                total = _ripple_cells(T, m, sw, sf, sg, max_ripple, rn, rk, rp, rd)
                if total > max_ripple:  # partial coverage: no ripple points
                    over[t] = True
                if over[t]:
                    total = 0
            M = m + total
            fw, fc = _grow(fw, M), _grow(fc, M)
            _fill(cA0, cA1, cB0, cB1, t, T, m, total > 0, sw, s0, s1, rn, rk, rp, rd, fw, fc)
            da, dw = _grow(da, M), _grow(dw, M)
            nd = _find_dips(cA0, cA1, cB0, cB1, t, T, M, fw, fc, rise, iters, da, dw)
            need = n + M + nd
            o_t, o_w, o_c = _grow(o_t, need), _grow(o_w, need), _grow(o_c, need)
            n = _emit(cA0, cA1, cB0, cB1, t, T, M, fw, fc, nd, da, dw, n, o_t, o_w, o_c)
        return o_t, o_w, o_c, n


def c7_samples(qa, qb, lv: dict, lift_min: float, tail_steps: int, max_ripple: int, rise: float, iters: int = 40):
    """The samples of C7 = Δb/Δa of every design, ordered by (design, ω), in one compiled pass per
    design: the leaves' ends, the tail of a delayed design, four ripple points per period in every
    cell the frozen ripple flags, and the points of the lobes and gaps narrower than the samples.

    Parameters
    ----------
    qa, qb : QP
        Δ00 and Δ10 (same delays T [s]).
    lv : dict
        Their adaptive frequency set (``task``, ``a``, ``b``, ``va``, ``vb``; leaves sorted by
        design and frequency).
    lift_min : float
        The smallest lift of the phase by the frozen ripple that flags a sample [deg].
    tail_steps : int
        The most octaves of tail beyond the last leaf.
    max_ripple : int
        The most ripple points of one design (more: partial coverage, no ripple points).
    rise : float
        The dip test's least factor (:func:`exotune.numerics.quasipoly.dip_rise`: larger where the
        cells around a sample differ in length).
    iters : int
        Golden-section steps of a dip search.

    Returns
    -------
    task : ndarray of int
        Design row of each sample.
    w : ndarray
        The samples [rad/s].
    c : ndarray of complex
        C7(jω) there [rad/(N·m)].
    over : ndarray of bool, shape (ntask,)
        Per design: partial coverage (too many ripple points, or the ripple could still lift the
        phase at the last tail step).

    References
    ----------
    docs/method.md#passivity-of-the-operator-compliance; numpy reference:
    :func:`exotune.analysis.operator_passivity._samples`.
    """
    cA0, cA1, cB0, cB1, T = pair_args(qa, qb)
    over = np.zeros(T.shape[0], np.bool_)
    c = lambda x: np.ascontiguousarray(x, dtype=complex)  # noqa: E731
    task, w, c7, n = _samples(cA0, cA1, cB0, cB1, T, np.ascontiguousarray(lv["task"], dtype=np.int64),
                              np.ascontiguousarray(lv["a"], dtype=float), np.ascontiguousarray(lv["b"], dtype=float),
                              c(lv["va"][0]), c(lv["va"][1]), c(lv["vb"][0]), c(lv["vb"][1]), float(lift_min),
                              int(tail_steps), int(max_ripple), float(rise), int(iters), over)
    return task[:n], w[:n], c7[:n], over
