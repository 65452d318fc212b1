"""Compiled latency margin of a batch of loops: the kernel behind
:func:`exotune.analysis.latency.batch_latency_margin`.

Row by row, the same construction as the numpy reference in :mod:`exotune.analysis.latency`
(docs/method.md#latency-margin), in the same order and with the same iteration counts: on the
log-spaced grid of ``npts`` points from ``wmax·10^−decades`` to ``wmax``, (1) every member in
``members``: sign changes of |P0|² − |P1|² refined by bisection in log ω, and grazing points;
(2) for a family, both branches p±(ω) of the crossing curves: every grid local minimum of the extra
delay, refined by golden-section search in log ω. The polynomials arrive as their even and odd
parts in x = ω² (real, signed as in ``_Jw``), so P(jω) = E(x) + j ω O(x).
"""

from __future__ import annotations

import math

import numpy as np

from .common import AVAILABLE, njit

__all__ = ["design_margins"]

TWO_PI = 2.0 * math.pi

if AVAILABLE:
    # Only the three leaf helpers (_val, _abs2, _first_delay) are inlined by numba itself; the loop,
    # branch and record helpers are ordinary calls that LLVM may still inline. Inlining them too
    # at numba's level copied their IR into every call site of _refine and the searches: the
    # kernel took 74 s to compile instead of 16 s, for no measurable speed (columns bit-identical).

    @njit(cache=True, inline="always")
    def _val(ev, od, t, w):
        x = w * w
        m = ev.shape[1]
        e = 0.0
        for k in range(m - 1, -1, -1):
            e = e * x + ev[t, k]
        m = od.shape[1]
        o = 0.0
        for k in range(m - 1, -1, -1):
            o = o * x + od[t, k]
        return complex(e, w * o)

    @njit(cache=True, inline="always")
    def _abs2(z):
        return z.real * z.real + z.imag * z.imag

    @njit(cache=True, inline="always")
    def _first_delay(P0, P1, w, T):
        q = -P0 / P1
        v = (-math.atan2(q.imag, q.real) - w * T) % TWO_PI
        return v / w

    @njit(cache=True)
    def _branch(A0, A1, B0, B1, w, T, lo, hi, which, branch_rel):
        """ΔT on branch ``which`` (0: p−, 1: p+) at ω, inf where it does not exist in [lo, hi]."""
        qa = _abs2(B0) - _abs2(B1)
        qb = 2.0 * (A0 * B0.conjugate() - A1 * B1.conjugate()).real
        qc = _abs2(A0) - _abs2(A1)
        big = max(abs(lo), abs(hi))
        sc = abs(qa) * big * big + abs(qb) * big + abs(qc)
        if not sc > 0:
            sc = 1.0
        qa /= sc
        qb /= sc
        qc /= sc
        disc = qb * qb - 4.0 * qa * qc
        sq = math.sqrt(disc) if disc >= 0 else np.nan
        q = -0.5 * (qb + math.copysign(sq, qb))
        r1 = q / qa if qa != 0 else -qc / qb
        r2 = qc / q if (qa != 0 and q != 0) else np.nan
        if which == 0:
            pm = r2 if math.isnan(r1) else (r1 if math.isnan(r2) else min(r1, r2))
        else:
            pm = r2 if math.isnan(r1) else (r1 if math.isnan(r2) else max(r1, r2))
        for _ in range(2):  # Newton polish of p on G evaluated directly (analysis.latency._polish_member)
            P0 = A0 + pm * B0
            P1 = A1 + pm * B1
            G = _abs2(P0) - _abs2(P1)
            dG = 2.0 * (B0 * P0.conjugate() - B1 * P1.conjugate()).real
            if not dG != 0.0:
                break
            q = pm - G / dG
            Gq = _abs2(A0 + q * B0) - _abs2(A1 + q * B1)
            if math.isfinite(q) and abs(Gq) < abs(G):
                pm = q
        if not (math.isfinite(pm) and pm >= lo and pm <= hi):
            return np.inf
        P1 = A1 + pm * B1
        if not _abs2(P1) > 0:
            return np.inf
        P0 = A0 + pm * B0
        m0 = _abs2(P0)
        m1 = _abs2(P1)
        if not abs(m0 - m1) <= branch_rel * (m0 + m1):  # the member does not cross there (ill-conditioned p)
            return np.inf
        d = _first_delay(P0, P1, w, T)
        return d if math.isfinite(d) else np.inf

    @njit(cache=True)
    def _maybe_root(A0, A1, B0, B1, Glo, Ghi, lo, hi):
        """Whether G(p) = |A0 + pB0|² − |A1 + pB1|² may vanish for p ∈ [lo, hi], from its values
        at the ends (``Glo``, ``Ghi``) and its vertex (a cheap test before the branch roots)."""
        if not (Glo > 0 and Ghi > 0) and not (Glo < 0 and Ghi < 0):
            return True  # a sign change, a zero or a NaN: let the root computation decide
        qa = _abs2(B0) - _abs2(B1)
        if qa == 0:
            return False
        qb = 2.0 * (A0 * B0.conjugate() - A1 * B1.conjugate()).real
        pv = -qb / (2.0 * qa)
        if not (pv > lo and pv < hi):
            return False
        gv = Glo + (pv - lo) * (qa * (pv + lo) + qb)  # G(pv) = G(lo) + (pv − lo)(qa (pv + lo) + qb)
        return not (gv > 0) if Glo > 0 else not (gv < 0)

    @njit(cache=True)
    def _loop_at(ev, od, t, w, ka, kb, z0, phi, f):
        """(A0, A1, B0, B1) of one loop at ω: A = Δ_a + z0(jω) Δ_b, B = f φ(jω) Δ_b (B = 0 for a
        single loop, kb < 0); Δ_j = P0 + P1 e^{−sT} is the coefficient pair 2j, 2j + 1."""
        a0 = _val(ev[2 * ka], od[2 * ka], t, w)
        a1 = _val(ev[2 * ka + 1], od[2 * ka + 1], t, w)
        if kb < 0:
            return a0, a1, 0j, 0j
        d0 = _val(ev[2 * kb], od[2 * kb], t, w)
        d1 = _val(ev[2 * kb + 1], od[2 * kb + 1], t, w)
        z = complex(z0[0] - z0[2] * w * w, z0[1] * w)
        ph = f * complex(phi[0] - phi[2] * w * w, phi[1] * w)
        return a0 + z * d0, a1 + z * d1, ph * d0, ph * d1

    @njit(cache=True)
    def _branch_at(ev, od, t, x, ka, kb, z0, phi, f, Tt, lo, hi, which, branch_rel):
        v0, v1, v2, v3 = _loop_at(ev, od, t, x, ka, kb, z0, phi, f)
        return _branch(v0, v1, v2, v3, x, Tt, lo, hi, which, branch_rel)

    @njit(cache=True)
    def _segment_edge(ev, od, t, ka, kb, z0, phi, f, Tt, lo, hi, which, inside, outside, n, branch_rel):
        """The edge of the branch segment holding log ω = ``inside``, towards ``outside`` (where
        the branch does not exist), by ``n`` bisections; returns (the last point inside, the
        first outside)."""
        for _ in range(n):
            mid = 0.5 * (inside + outside)
            if math.isfinite(_branch_at(ev, od, t, math.exp(mid), ka, kb, z0, phi, f, Tt, lo, hi, which, branch_rel)):
                inside = mid
            else:
                outside = mid
        return inside, outside

    @njit(cache=True)
    def _signed_rel(ev, od, t, lx, ka, kb, z0, phi, f, p):
        """(|P0|² − |P1|²)/(|P0|² + |P1|²) of member p at log ω = ``lx``."""
        a0, a1, b0, b1 = _loop_at(ev, od, t, math.exp(lx), ka, kb, z0, phi, f)
        m0 = _abs2(a0 + p * b0)
        m1 = _abs2(a1 + p * b1)
        sm = m0 + m1
        return (m0 - m1) / (sm if sm > 0 else 1.0)

    @njit(cache=True)
    def _narrow_band(ev, od, t, ka, kb, z0, phi, f, p, a, b, n_peak):
        """Golden-section search of the signed relative F over [a, b] (log ω) for a point where it
        is negative (a band |P1| > |P0| between two grid points): (the point, its value)."""
        g = (math.sqrt(5.0) - 1.0) / 2.0
        c = b - g * (b - a)
        d = a + g * (b - a)
        fc = _signed_rel(ev, od, t, c, ka, kb, z0, phi, f, p)
        fd = _signed_rel(ev, od, t, d, ka, kb, z0, phi, f, p)
        for _ in range(n_peak):
            if fc <= fd:
                b = d
                d = c
                fd = fc
                c = b - g * (b - a)
                fc = _signed_rel(ev, od, t, c, ka, kb, z0, phi, f, p)
            else:
                a = c
                c = d
                fc = fd
                d = a + g * (b - a)
                fd = _signed_rel(ev, od, t, d, ka, kb, z0, phi, f, p)
        if fc <= fd:
            return c, fc
        return d, fd

    @njit(cache=True)
    def _record(ev, od, t, ka, kb, z0, phi, f, p, Tt, lx, cell, best, cross, cidx, ncross):
        """A crossing of member p at log ω = ``lx`` in grid cell ``cell``: (the smaller of ``best``
        and its ΔT, the crossings kept; the crossing added to ``cross``/``cidx`` while there is room)."""
        x = math.exp(lx)
        a0, a1, b0, b1 = _loop_at(ev, od, t, x, ka, kb, z0, phi, f)
        d = _first_delay(a0 + p * b0, a1 + p * b1, x, Tt)
        if math.isfinite(d) and d < best:
            best = d
        if ncross < cross.shape[0]:
            cross[ncross] = lx
            cidx[ncross] = cell
            ncross += 1
        return best, ncross

    @njit(cache=True)
    def _root_dip(ev, od, t, ka, kb, z0, phi, f, p, which, a, b, n_dip):
        """Golden-section search of |P0| (``which`` 0) or |P1| (1) over [a, b] (log ω) for its
        smallest value (a near-axis root in the cell): where it is (log ω)."""
        g = (math.sqrt(5.0) - 1.0) / 2.0
        c = b - g * (b - a)
        d = a + g * (b - a)
        a0, a1, b0, b1 = _loop_at(ev, od, t, math.exp(c), ka, kb, z0, phi, f)
        fc = abs(a0 + p * b0) if which == 0 else abs(a1 + p * b1)
        a0, a1, b0, b1 = _loop_at(ev, od, t, math.exp(d), ka, kb, z0, phi, f)
        fd = abs(a0 + p * b0) if which == 0 else abs(a1 + p * b1)
        for _ in range(n_dip):
            if fc <= fd:
                b = d
                d = c
                fd = fc
                c = b - g * (b - a)
                a0, a1, b0, b1 = _loop_at(ev, od, t, math.exp(c), ka, kb, z0, phi, f)
                fc = abs(a0 + p * b0) if which == 0 else abs(a1 + p * b1)
            else:
                a = c
                c = d
                fc = fd
                d = a + g * (b - a)
                a0, a1, b0, b1 = _loop_at(ev, od, t, math.exp(d), ka, kb, z0, phi, f)
                fd = abs(a0 + p * b0) if which == 0 else abs(a1 + p * b1)
        return c if fc <= fd else d

    @njit(cache=True)
    def _bisect_sign(ev, od, t, ka, kb, z0, phi, f, p, lo_l, hi_l, n_bisect):
        """The sign change of F between log ω = ``lo_l`` (F > 0) and ``hi_l`` (F < 0)."""
        for _ in range(n_bisect):
            mid = 0.5 * (lo_l + hi_l)
            if _signed_rel(ev, od, t, mid, ka, kb, z0, phi, f, p) > 0:
                lo_l = mid
            else:
                hi_l = mid
        return 0.5 * (lo_l + hi_l)

    @njit(cache=True)
    def _refine(ev, od, t, ka, kb, z0, phi, f, Tt, lo, hi, which, a, x0, b, n_shrink, n_golden, branch_rel, n_edge):
        """The smallest ΔT on branch ``which`` near the finite point log ω = x0 of the bracket
        [a, b] (log ω): ends where the branch does not exist are first moved, by bisection, to
        the edge of the segment that holds x0; then golden-section search; an edge below the
        golden-section minimum is bisected ``n_edge`` more times and evaluated there."""
        sa = not math.isfinite(_branch_at(ev, od, t, math.exp(a), ka, kb, z0, phi, f, Tt, lo, hi, which, branch_rel))
        oa = a
        if sa:
            a, oa = _segment_edge(ev, od, t, ka, kb, z0, phi, f, Tt, lo, hi, which, x0, a, n_shrink, branch_rel)
        sb = not math.isfinite(_branch_at(ev, od, t, math.exp(b), ka, kb, z0, phi, f, Tt, lo, hi, which, branch_rel))
        ob = b
        if sb:
            b, ob = _segment_edge(ev, od, t, ka, kb, z0, phi, f, Tt, lo, hi, which, x0, b, n_shrink, branch_rel)
        ea = a
        eb = b
        g = (math.sqrt(5.0) - 1.0) / 2.0
        c = b - g * (b - a)
        d = a + g * (b - a)
        fc = _branch_at(ev, od, t, math.exp(c), ka, kb, z0, phi, f, Tt, lo, hi, which, branch_rel)
        fd = _branch_at(ev, od, t, math.exp(d), ka, kb, z0, phi, f, Tt, lo, hi, which, branch_rel)
        for _ in range(n_golden):
            if fc <= fd:
                b = d
                d = c
                fd = fc
                c = b - g * (b - a)
                fc = _branch_at(ev, od, t, math.exp(c), ka, kb, z0, phi, f, Tt, lo, hi, which, branch_rel)
            else:
                a = c
                c = d
                fc = fd
                d = a + g * (b - a)
                fd = _branch_at(ev, od, t, math.exp(d), ka, kb, z0, phi, f, Tt, lo, hi, which, branch_rel)
        m = min(fc, fd)
        for k in range(2):  # an edge itself may hold the smallest ΔT (golden-section never reaches it)
            e = ea if k == 0 else eb
            fe = _branch_at(ev, od, t, math.exp(e), ka, kb, z0, phi, f, Tt, lo, hi, which, branch_rel)
            if (sa if k == 0 else sb) and fe < m:
                e, _ = _segment_edge(ev, od, t, ka, kb, z0, phi, f, Tt, lo, hi, which, e, oa if k == 0 else ob,
                                     n_edge, branch_rel)
                fe = _branch_at(ev, od, t, math.exp(e), ka, kb, z0, phi, f, Tt, lo, hi, which, branch_rel)
            if fe < m:
                m = fe
        return m

    @njit(cache=True, error_model="numpy")
    def design_margins(ev, od, ka, kb, z0, phi, fr, fi, members, nmem, lo, hi, curve,
                       T, wmax, decades, npts, n_bisect, n_shrink, n_golden, graze, n_seed, max_cross, n_peak, n_dip, branch_rel,
                       n_edge):
        """Per row, the smallest extra delay over the crossings of every loop (module docstring):
        ``ev``/``od`` (2·pairs, K, m) hold the even/odd parts of the characteristic terms, loop l
        combines pairs ``ka[l]`` and ``kb[l]`` (−1: a single loop) with z0[l], φ[l], factor
        fr[l] + j fi[l], its members ``members[l, :nmem[l]]`` and its range [lo[l], hi[l]].

        One function on purpose (over 80 lines): a compiled kernel whose scan, bisection, shrink
        and golden-section stages share per-row scratch arrays, which split stages would pass
        through a dozen arguments of separately compiled functions."""
        K = T.shape[0]
        L = ka.shape[0]
        npair = ev.shape[0] // 2
        out = np.full(K, np.inf)
        V = np.empty((2 * npair, npts), np.complex128)
        A0 = np.empty(npts, np.complex128)
        A1 = np.empty(npts, np.complex128)
        B0 = np.empty(npts, np.complex128)
        B1 = np.empty(npts, np.complex128)
        w = np.empty(npts)
        Fm = np.empty((2, npts))
        rel = np.empty(npts)
        sgv = np.empty(npts)
        dT2 = np.empty((2, npts))
        cross = np.empty(max_cross)
        cidx = np.empty(max_cross, np.int64)
        grid = np.empty(npts)
        for i in range(npts):
            grid[i] = 10.0 ** (-decades + decades * i / (npts - 1))
        h = decades * math.log(10.0) / (npts - 1)  # the grid step in log ω
        for t in range(K):
            best = np.inf
            Tt = T[t]
            for i in range(npts):
                w[i] = wmax[t] * grid[i]
                for j in range(2 * npair):
                    V[j, i] = _val(ev[j], od[j], t, w[i])
            for l in range(L):
                f = complex(fr[l], fi[l])
                a_, b_ = ka[l], kb[l]
                z0l = z0[l]
                phil = phi[l]
                for i in range(npts):
                    if b_ < 0:
                        A0[i] = V[2 * a_, i]
                        A1[i] = V[2 * a_ + 1, i]
                        B0[i] = 0j
                        B1[i] = 0j
                    else:
                        x = w[i]
                        z = complex(z0l[0] - z0l[2] * x * x, z0l[1] * x)
                        ph = f * complex(phil[0] - phil[2] * x * x, phil[1] * x)
                        A0[i] = V[2 * a_, i] + z * V[2 * b_, i]
                        A1[i] = V[2 * a_ + 1, i] + z * V[2 * b_ + 1, i]
                        B0[i] = ph * V[2 * b_, i]
                        B1[i] = ph * V[2 * b_ + 1, i]
                ncross = 0
                for mi in range(nmem[l]):
                    p = members[l, mi]
                    F = Fm[mi]
                    for i in range(npts):
                        m0 = _abs2(A0[i] + p * B0[i])
                        m1 = _abs2(A1[i] + p * B1[i])
                        F[i] = m0 - m1
                        s = m0 + m1
                        rel[i] = abs(F[i]) / (s if s > 0 else 1.0)
                        sgv[i] = F[i] / (s if s > 0 else 1.0)
                    for i in range(npts - 1):
                        neg_lo = F[i] < 0 or (F[i] == 0 and math.copysign(1.0, F[i]) < 0)
                        neg_hi = F[i + 1] < 0 or (F[i + 1] == 0 and math.copysign(1.0, F[i + 1]) < 0)
                        if neg_lo == neg_hi:
                            continue
                        la = math.log(w[i])
                        lb = math.log(w[i + 1])
                        for _ in range(n_bisect):
                            mid = 0.5 * (la + lb)
                            a0, a1, b0, b1 = _loop_at(ev, od, t, math.exp(mid), a_, b_, z0l, phil, f)
                            fm = _abs2(a0 + p * b0) - _abs2(a1 + p * b1)
                            neg = fm < 0 or (fm == 0 and math.copysign(1.0, fm) < 0)
                            if neg == neg_lo:
                                la = mid
                            else:
                                lb = mid
                        best, ncross = _record(ev, od, t, a_, b_, z0l, phil, f, p, Tt, 0.5 * (la + lb), i, best,
                                               cross, cidx, ncross)
                    # narrow bands: a grid local minimum of the signed relative F, positive with both
                    # neighbours, searched between them; where F < 0 there, both band edges are bisected
                    for i in range(1, npts - 1):
                        if not (sgv[i] <= sgv[i - 1] and sgv[i] <= sgv[i + 1] and sgv[i] > 0 and sgv[i - 1] > 0
                                and sgv[i + 1] > 0):
                            continue
                        xin, vin = _narrow_band(ev, od, t, a_, b_, z0l, phil, f, p, math.log(w[i - 1]),
                                                math.log(w[i + 1]), n_peak)
                        if not vin < 0:
                            continue
                        for side in range(2):
                            out_l = math.log(w[i - 1]) if side == 0 else math.log(w[i + 1])
                            lx = _bisect_sign(ev, od, t, a_, b_, z0l, phil, f, p, out_l, xin, n_bisect)
                            best, ncross = _record(ev, od, t, a_, b_, z0l, phil, f, p, Tt, lx,
                                                   i - 1 if lx < math.log(w[i]) else i, best, cross, cidx, ncross)
                    # near-axis roots: the phase of P0 or P1 turns by more than π/2 within a cell
                    for which in range(2):
                        for i in range(npts - 1):
                            if which == 0:
                                u = A0[i] + p * B0[i]
                                v = A0[i + 1] + p * B0[i + 1]
                            else:
                                u = A1[i] + p * B1[i]
                                v = A1[i + 1] + p * B1[i + 1]
                            if not (v * u.conjugate()).real < 0:
                                continue
                            xin = _root_dip(ev, od, t, a_, b_, z0l, phil, f, p, which, math.log(w[i]),
                                            math.log(w[i + 1]), n_dip)
                            pos_x = _signed_rel(ev, od, t, xin, a_, b_, z0l, phil, f, p) > 0
                            for e in range(i, i + 2):
                                if (sgv[e] > 0) == pos_x:
                                    continue
                                le = math.log(w[e])
                                if pos_x:
                                    lx = _bisect_sign(ev, od, t, a_, b_, z0l, phil, f, p, xin, le, n_bisect)
                                else:
                                    lx = _bisect_sign(ev, od, t, a_, b_, z0l, phil, f, p, le, xin, n_bisect)
                                best, ncross = _record(ev, od, t, a_, b_, z0l, phil, f, p, Tt, lx, i, best, cross, cidx,
                                                       ncross)
                    for i in range(1, npts - 1):
                        if rel[i] < rel[i - 1] and rel[i] < rel[i + 1] and rel[i] < graze:
                            d = _first_delay(A0[i] + p * B0[i], A1[i] + p * B1[i], w[i], Tt)
                            if math.isfinite(d) and d < best:
                                best = d
                            if ncross < max_cross:
                                cross[ncross] = math.log(w[i])
                                cidx[ncross] = i
                                ncross += 1
                if not curve[l]:
                    continue
                lo_, hi_ = lo[l], hi[l]
                for i in range(npts):  # both branches, where a root p ∈ [lo, hi] can exist
                    dT2[0, i] = np.inf
                    dT2[1, i] = np.inf
                    if not _maybe_root(A0[i], A1[i], B0[i], B1[i], Fm[0, i], Fm[1, i], lo_, hi_):
                        continue
                    dT2[0, i] = _branch(A0[i], A1[i], B0[i], B1[i], w[i], Tt, lo_, hi_, 0, branch_rel)
                    dT2[1, i] = _branch(A0[i], A1[i], B0[i], B1[i], w[i], Tt, lo_, hi_, 1, branch_rel)
                for which in range(2):
                    dT = dT2[which]
                    # (1) every grid local minimum of the branch
                    for i in range(npts):
                        if not math.isfinite(dT[i]):
                            continue
                        left = dT[i - 1] if i > 0 else np.inf
                        right = dT[i + 1] if i < npts - 1 else np.inf
                        if not (dT[i] <= left and dT[i] <= right):
                            continue
                        if dT[i] < best:
                            best = dT[i]
                        m = _refine(ev, od, t, a_, b_, z0l, phil, f, Tt, lo_, hi_, which,
                                    math.log(w[max(i - 1, 0)]), math.log(w[i]), math.log(w[min(i + 1, npts - 1)]),
                                    n_shrink, n_golden, branch_rel, n_edge)
                        if m < best:
                            best = m
                    # (2) the segments that start at an end member's crossing (narrower than the grid)
                    for ci in range(ncross):
                        lx = cross[ci]
                        i = cidx[ci]
                        if math.isfinite(dT[i]) or (i + 1 < npts and math.isfinite(dT[i + 1])):
                            continue  # the grid samples this segment: (1) refines it
                        x0 = np.inf
                        v0 = np.inf
                        for k in range(n_seed):
                            y = lx - h + 2.0 * h * k / (n_seed - 1)
                            v = _branch_at(ev, od, t, math.exp(y), a_, b_, z0l, phil, f, Tt, lo_, hi_, which, branch_rel)
                            if v < v0:
                                v0 = v
                                x0 = y
                        if not math.isfinite(v0):
                            continue
                        if v0 < best:
                            best = v0
                        step = 2.0 * h / (n_seed - 1)
                        m = _refine(ev, od, t, a_, b_, z0l, phil, f, Tt, lo_, hi_, which, x0 - step, x0, x0 + step,
                                    n_shrink, n_golden, branch_rel, n_edge)
                        if m < best:
                            best = m
            out[t] = best
        return out

else:  # pragma: no cover - numba missing: the numpy reference runs instead
    design_margins = None
