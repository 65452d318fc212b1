"""Compiled (numba) scalar functions of a pair of quasi-polynomials Δa, Δb on the imaginary axis:
their values, Illinois roots on sign-change brackets and golden-section maxima, the crossing
classification of adaptive leaves and the sub-sampling of leaves into sign-change brackets
(the numpy references are in :mod:`exotune.analysis`).
"""

from __future__ import annotations

import math

import numpy as np

from .common import AVAILABLE, coefficients, njit

if AVAILABLE:
    from .common import cdiv, eval_quasi

__all__ = ["pair_values", "pair_roots", "refine_crossings", "golden_max", "classify_leaves", "subsample_brackets"]

if AVAILABLE:

    # scalar functions of the two tracked quasi-polynomials a = Δa(jω), b = Δb(jω):
    #   MODE_CROSS  g = Im[a · conj(f (jω)^k b)]      (crossings of κ = −a/(f φ b) with the real axis)
    #   MODE_MAG    g = |a/b|² − c_t                    (the −3 dB level of |C6/C5|)
    #   MODE_EXCESS g = passivity phase excess [deg] of b/a (C7 = Δ10/Δ00)
    MODE_CROSS, MODE_MAG, MODE_EXCESS = 0, 1, 2

    @njit(cache=True, inline="always")
    def _fun(cA0, cA1, cB0, cB1, t, T, w, mode, k, fre, fim, cval):
        a, _ = eval_quasi(cA0, cA1, t, T, w)
        b, _ = eval_quasi(cB0, cB1, t, T, w)
        if mode == 1:
            return abs(cdiv(a, b)) ** 2 - cval
        if mode == 2:
            c = cdiv(b, a)
            ph = math.degrees(math.atan2(c.imag, c.real))
            if not (ph > 0):  # also NaN
                return 0.0
            return min(ph, 180.0 - ph)
        s = 1j * w
        phi = 1.0 + 0j
        for _ in range(k):
            phi = phi * s
        fb = complex(fre, fim) * phi * b
        return (a * fb.conjugate()).imag

    @njit(cache=True)
    def _values(cA0, cA1, cB0, cB1, Ts, task, w, mode, k, fre, fim, cvals, out):
        for i in range(task.shape[0]):
            t = task[i]
            out[i] = _fun(cA0, cA1, cB0, cB1, t, Ts[t], w[i], mode, k, fre, fim, cvals[t])

    @njit(cache=True)
    def _illinois(cA0, cA1, cB0, cB1, Ts, task, a, b, fa, fb, mode, k, fre, fim, cvals, out):
        for i in range(task.shape[0]):
            t = task[i]
            T = Ts[t]
            cv = cvals[t]
            x0 = a[i]
            x1 = b[i]
            f0 = fa[i]
            f1 = fb[i]
            side = 0
            for _ in range(200):
                if abs(x1 - x0) <= 1e-14 * max(abs(x1), 1e-300):
                    break
                x = (x0 * f1 - x1 * f0) / (f1 - f0) if f1 != f0 else 0.5 * (x0 + x1)
                if not (x > min(x0, x1) and x < max(x0, x1)):
                    x = 0.5 * (x0 + x1)
                fx = _fun(cA0, cA1, cB0, cB1, t, T, x, mode, k, fre, fim, cv)
                if fx == 0:
                    x0 = x
                    x1 = x
                    break
                if (fx > 0) == (f0 > 0):
                    if side == 1:
                        f1 = 0.5 * f1
                    x0 = x
                    f0 = fx
                    side = 1
                else:
                    if side == -1:
                        f0 = 0.5 * f0
                    x1 = x
                    f1 = fx
                    side = -1
            out[i] = 0.5 * (x0 + x1)

    @njit(cache=True)
    def _golden_max(cA0, cA1, cB0, cB1, Ts, task, a, b, mode, iters, out, out_w):
        gr = 0.5 * (math.sqrt(5.0) - 1.0)
        for i in range(task.shape[0]):
            t = task[i]
            T = Ts[t]
            lo = a[i]
            hi = b[i]
            c1 = hi - gr * (hi - lo)
            c2 = lo + gr * (hi - lo)
            f1 = _fun(cA0, cA1, cB0, cB1, t, T, c1, mode, 0, 1.0, 0.0, 0.0)
            f2 = _fun(cA0, cA1, cB0, cB1, t, T, c2, mode, 0, 1.0, 0.0, 0.0)
            for _ in range(iters):
                if f1 >= f2:
                    hi = c2
                    c2 = c1
                    f2 = f1
                    c1 = hi - gr * (hi - lo)
                    f1 = _fun(cA0, cA1, cB0, cB1, t, T, c1, mode, 0, 1.0, 0.0, 0.0)
                else:
                    lo = c1
                    c1 = c2
                    f1 = f2
                    c2 = lo + gr * (hi - lo)
                    f2 = _fun(cA0, cA1, cB0, cB1, t, T, c2, mode, 0, 1.0, 0.0, 0.0)
            out_w[i] = 0.5 * (lo + hi)
            out[i] = _fun(cA0, cA1, cB0, cB1, t, T, out_w[i], mode, 0, 1.0, 0.0, 0.0)


_MODES = {"cross": 0, "mag": 1, "excess": 2}


def pair_args(qa, qb):
    cA0, cA1 = coefficients(qa)
    cB0, cB1 = coefficients(qb)
    if cA0.dtype != cB0.dtype:
        cA0, cA1, cB0, cB1 = (x.astype(complex) for x in (cA0, cA1, cB0, cB1))
    return cA0, cA1, cB0, cB1, np.ascontiguousarray(qa.T, dtype=float)


def _cvals(c, n):
    return np.ascontiguousarray(np.broadcast_to(np.asarray(0.0 if c is None else c, dtype=float), (n,)))


def pair_values(qa, qb, mode: str, task, w, k: int = 0, factor: complex = 1.0, c=None):
    """One of the scalar functions of ``mode`` ("cross", "mag", "excess"; see ``_fun``) at the
    (task, ω) pairs, compiled.

    Parameters
    ----------
    qa, qb : QP
        The pair of quasi-polynomials Δa, Δb (same delays T [s]).
    mode : str
        "cross" (Im[Δa·conj(f (jω)^k Δb)]), "mag" (|Δa/Δb|² − c) or "excess" (the passivity phase
        excess of Δb/Δa [deg]).
    task : ndarray of int
        Design row of each point.
    w : ndarray
        Frequencies [rad/s].
    k : int
        The power of (jω) in f φ.
    factor : complex
        The constant f (1 + jη for the hysteretic human).
    c : float or ndarray, optional
        The magnitude level c per design ("mag").

    Returns
    -------
    ndarray
        The function's value at each point.
    """
    factor = complex(factor)
    out = np.empty(len(task))
    if len(task):
        _values(*pair_args(qa, qb), np.ascontiguousarray(task, dtype=np.int64), np.ascontiguousarray(w, dtype=float),
                _MODES[mode], int(k), factor.real, factor.imag, _cvals(c, qa.n), out)
    return out


def pair_roots(qa, qb, mode: str, task, a, b, fa, fb, k: int = 0, factor: complex = 1.0, c=None):
    """Compiled Illinois (same algorithm as :func:`exotune.quasipoly.bisect_roots`) on sign-change
    brackets of the ``mode`` function.

    Parameters
    ----------
    qa, qb : QP
        The pair of quasi-polynomials Δa, Δb (same delays T [s]).
    mode : str
        "cross" (Im[Δa·conj(f (jω)^k Δb)]), "mag" (|Δa/Δb|² − c) or "excess" (the passivity phase
        excess of Δb/Δa [deg]).
    task : ndarray of int
        Design row of each bracket.
    a, b : ndarray
        The brackets' ends [rad/s].
    fa, fb : ndarray
        The function's values there (opposite signs).
    k : int
        The power of (jω) in f φ.
    factor : complex
        The constant f (1 + jη for the hysteretic human).
    c : float or ndarray, optional
        The magnitude level c per design ("mag").

    Returns
    -------
    ndarray
        The zero in each bracket [rad/s].
    """
    factor = complex(factor)
    out = np.empty(len(task))
    if len(task):
        f = lambda x: np.ascontiguousarray(x, dtype=float)  # noqa: E731
        _illinois(*pair_args(qa, qb), np.ascontiguousarray(task, dtype=np.int64), f(a), f(b), f(fa), f(fb),
                  _MODES[mode], int(k), factor.real, factor.imag, _cvals(c, qa.n), out)
    return out


def refine_crossings(qa, qb, k: int, factor: complex, task, a, b, fa, fb):
    """Compiled Illinois refinement of the zeros of g(ω) = Im[Δa(jω)·conj(f (jω)^k Δb(jω))] on
    sign-change brackets (same algorithm as :func:`exotune.quasipoly.bisect_roots`).

    Parameters
    ----------
    qa, qb : QP
        The pair of quasi-polynomials Δa, Δb (same delays T [s]).
    k : int
        The power of (jω) in f φ.
    factor : complex
        The constant f (1 + jη for the hysteretic human).
    task : ndarray of int
        Design row of each bracket.
    a, b : ndarray
        The brackets' ends [rad/s].
    fa, fb : ndarray
        g at the ends (opposite signs).

    Returns
    -------
    ndarray
        The crossing frequency in each bracket [rad/s].
    """
    return pair_roots(qa, qb, "cross", task, a, b, fa, fb, k=k, factor=factor)


def golden_max(qa, qb, mode: str, task, a, b, iters: int = 40, where: bool = False):
    """Golden-section maximization of the ``mode`` function on [a, b] per entry (one new
    evaluation per iteration); returns the value at the final midpoint (same iteration as the numpy
    reference in exotune.analysis), and that midpoint too when ``where``.

    Parameters
    ----------
    qa, qb : QP
        The pair of quasi-polynomials Δa, Δb (same delays T [s]).
    mode : str
        "cross" (Im[Δa·conj(f (jω)^k Δb)]), "mag" (|Δa/Δb|² − c) or "excess" (the passivity phase
        excess of Δb/Δa [deg]).
    task : ndarray of int
        Design row of each interval.
    a, b : ndarray
        The intervals' ends [rad/s].
    iters : int
        Golden-section iterations.
    where : bool
        Also return where each maximum was found.

    Returns
    -------
    ndarray, or (ndarray, ndarray) when ``where``
        The maximum found on each interval (for "excess": [deg]), and its frequency [rad/s].
    """
    out = np.empty(len(task))
    out_w = np.empty(len(task))
    if len(task):
        f = lambda x: np.ascontiguousarray(x, dtype=float)  # noqa: E731
        _golden_max(*pair_args(qa, qb), np.ascontiguousarray(task, dtype=np.int64), f(a), f(b), _MODES[mode], int(iters),
                    out, out_w)
    return (out, out_w) if where else out


if AVAILABLE:

    @njit(cache=True)
    def _classify(a, b, va0, va1, vb0, vb1, k, cr, ci, lo, hi, sin_near, ga, gb, flags):
        """Per leaf of a pair (Δ0, Δ1) and one family (f φ = c (jω)^k): the crossing function at
        both ends and the bracket/sub-sampling flags of :func:`exotune.analysis._classify_numpy`
        (bit 0: sign-change bracket, bit 1: sub-sample, bit 2: degenerate — a zero or non-finite
        value, left to the numpy reference)."""
        c = complex(cr, ci)
        for i in range(a.size):
            ai = a[i]
            bi = b[i]
            pa = 1.0
            pb = 1.0
            for _ in range(k):  # ω^k by products (numpy's power for k ≤ 2)
                pa *= ai
                pb *= bi
            fa = c * (pa * va1[i])
            fb = c * (pb * vb1[i])
            xa = va0[i]
            xb = vb0[i]
            g1 = xa.imag * fa.real - xa.real * fa.imag  # Im(xa·conj fa)
            g2 = xb.imag * fb.real - xb.real * fb.imag
            ga[i] = g1
            gb[i] = g2
            na = fa.real * fa.real + fa.imag * fa.imag
            nb = fb.real * fb.real + fb.imag * fb.imag
            if not (na > 0.0 and nb > 0.0 and np.isfinite(na) and np.isfinite(nb)
                    and np.isfinite(xa.real) and np.isfinite(xa.imag) and np.isfinite(xb.real) and np.isfinite(xb.imag)):
                flags[i] = 4
                continue
            # κ = −x/f at both ends
            kar = -(xa.real * fa.real + xa.imag * fa.imag) / na
            kai = -(xa.imag * fa.real - xa.real * fa.imag) / na
            kbr = -(xb.real * fb.real + xb.imag * fb.imag) / nb
            kbi = -(xb.imag * fb.real - xb.real * fb.imag) / nb
            ma = math.sqrt(kar * kar + kai * kai)
            mb = math.sqrt(kbr * kbr + kbi * kbi)
            if not (np.isfinite(ma) and np.isfinite(mb)):
                flags[i] = 4
                continue
            kmin = min(ma, mb)
            kmax = max(ma, mb)
            pos = ai > 0.0
            plausible = (kar > 0.0 or kbr > 0.0) and not (kmax * 1e3 < lo) and not (kmin > hi * 1e3)
            br = pos and ((g1 < 0.0 and g2 > 0.0) or (g1 > 0.0 and g2 < 0.0)) and plausible
            near = abs(kai) <= sin_near * ma or abs(kbi) <= sin_near * mb
            sus = pos and plausible and near and not (kmax * 4.0 < lo) and not (kmin > hi * 4.0)
            flags[i] = 2 if sus else (1 if br else 0)


def classify_leaves(lv: dict, k: int, factor: complex, lo: float, hi: float, sin_near: float):
    """Compiled :func:`exotune.analysis._classify_numpy` over the leaves ``lv`` of a pair:
    (ga, gb, bracket mask, sub-sample mask, degenerate mask).

    Parameters
    ----------
    lv : dict
        The pair's leaves: ends ``a``, ``b`` [rad/s] and the values ``va``, ``vb`` of (Δa, Δb) there.
    k : int
        The power of (jω) in f φ.
    factor : complex
        The constant f (1 + jη for the hysteretic human).
    lo, hi : float
        The family's range (in its parameter's unit: [kg·m²], [N·m·s/rad] or [N·m/rad]).
    sin_near : float
        sin of the angle within which κ counts as near the real axis (``intervals.SIN_NEAR``).

    Returns
    -------
    ga, gb : ndarray
        The crossing function at the leaves' ends.
    bracket, subsample, degenerate : ndarray of bool
        The leaves holding a sign-change bracket, those to sub-sample, and those with a zero or
        non-finite value (left to the numpy reference).
    """
    n = lv["a"].size
    ga, gb = np.empty(n), np.empty(n)
    flags = np.empty(n, np.uint8)
    f = lambda x: np.ascontiguousarray(x, dtype=complex)  # noqa: E731
    factor = complex(factor) * (1j ** int(k))
    if n:
        _classify(np.ascontiguousarray(lv["a"], dtype=float), np.ascontiguousarray(lv["b"], dtype=float),
                  f(lv["va"][0]), f(lv["va"][1]), f(lv["vb"][0]), f(lv["vb"][1]), int(k), factor.real, factor.imag,
                  float(lo), float(hi), float(sin_near), ga, gb, flags)
    return ga, gb, flags == 1, flags == 2, flags == 4


if AVAILABLE:

    @njit(cache=True, inline="always")
    def _cross_norm(cA0, cA1, cB0, cB1, t, T, w, k, fre, fim):
        """The crossing function g = Im[a·conj(f (jω)^k b)] and |a|·|f (jω)^k b| (its scale)."""
        a, _ = eval_quasi(cA0, cA1, t, T, w)
        b, _ = eval_quasi(cB0, cB1, t, T, w)
        s = 1j * w
        phi = 1.0 + 0j
        for _ in range(k):
            phi = phi * s
        fb = complex(fre, fim) * phi * b
        # the scale by two square roots (cheaper than abs, which guards against overflow only
        # beyond 1e154, where the normalized value is not needed)
        return (a * fb.conjugate()).imag, math.sqrt(a.real * a.real + a.imag * a.imag) * math.sqrt(
            fb.real * fb.real + fb.imag * fb.imag)

    @njit(cache=True)
    def dip_search(cA0, cA1, cB0, cB1, t, T, lo, hi, sg, k, fre, fim, iters):
        """Golden-section minimum of sg·g on [lo, hi]: (where, g there)."""
        gr = 0.5 * (math.sqrt(5.0) - 1.0)
        c1 = hi - gr * (hi - lo)
        c2 = lo + gr * (hi - lo)
        f1 = sg * _cross_norm(cA0, cA1, cB0, cB1, t, T, c1, k, fre, fim)[0]
        f2 = sg * _cross_norm(cA0, cA1, cB0, cB1, t, T, c2, k, fre, fim)[0]
        for _ in range(iters):
            if f1 <= f2:
                hi = c2
                c2 = c1
                f2 = f1
                c1 = hi - gr * (hi - lo)
                f1 = sg * _cross_norm(cA0, cA1, cB0, cB1, t, T, c1, k, fre, fim)[0]
            else:
                lo = c1
                c1 = c2
                f1 = f2
                c2 = lo + gr * (hi - lo)
                f2 = sg * _cross_norm(cA0, cA1, cB0, cB1, t, T, c2, k, fre, fim)[0]
        wm = 0.5 * (lo + hi)
        return wm, _cross_norm(cA0, cA1, cB0, cB1, t, T, wm, k, fre, fim)[0]

    @njit(cache=True)
    def _subsample(cA0, cA1, cB0, cB1, Ts, st, sa, sb, Ms, k, fre, fim, iters, rise, otask, oa, ob, oga, ogb):
        """Sign-change brackets of the crossing function on Ms[i] equally spaced points (ends
        included) of each leaf [sa, sb] of task st, and the two brackets of each dip between
        points (numpy reference: :func:`exotune.analysis.intervals.subsample_brackets`)."""
        n = 0
        for i in range(st.shape[0]):
            t = st[i]
            T = Ts[t]
            a = sa[i]
            b = sb[i]
            M = Ms[i]
            wp = a
            gp, npv = _cross_norm(cA0, cA1, cB0, cB1, t, T, wp, k, fre, fim)
            # the point before the previous one (normalized value; NaN: none)
            wq = a
            gq = 0.0
            uq = np.nan
            up = gp / npv if npv > 0 else np.nan
            for j in range(1, M):
                w = a + (j / (M - 1)) * (b - a)
                g, nv = _cross_norm(cA0, cA1, cB0, cB1, t, T, w, k, fre, fim)
                u = g / nv if nv > 0 else np.nan
                if (gp < 0.0 and g > 0.0) or (gp > 0.0 and g < 0.0):
                    otask[n] = t
                    oa[n] = wp
                    ob[n] = w
                    oga[n] = gp
                    ogb[n] = g
                    n += 1
                elif is_dip(uq, up, u, rise):
                    sg = 1.0 if up > 0 else -1.0
                    wd, gd = dip_search(cA0, cA1, cB0, cB1, t, T, wq, w, sg, k, fre, fim, iters)
                    if sg * gd < 0.0:
                        otask[n] = t
                        oa[n] = wq
                        ob[n] = wd
                        oga[n] = gq
                        ogb[n] = gd
                        otask[n + 1] = t
                        oa[n + 1] = wd
                        ob[n + 1] = w
                        oga[n + 1] = gd
                        ogb[n + 1] = g
                        n += 2
                wq = wp
                gq = gp
                uq = up
                wp = w
                gp = g
                up = u
        return n

    @njit(cache=True, inline="always")
    def is_dip(uq, up, u, rise):
        """Normalized values at three consecutive points of one sign s: s·u has a local minimum
        at the middle one, nearer to 0 than ``rise`` times its rise to the higher neighbour
        (:func:`exotune.numerics.quasipoly.dip_candidates`)."""
        if not (uq * up > 0.0 and up * u > 0.0):  # also NaN
            return False
        sg = 1.0 if up > 0 else -1.0
        m, l, r = sg * up, sg * uq, sg * u
        return m <= l and m < r and m < rise * (max(l, r) - m)


def subsample_brackets(qa, qb, k: int, factor: complex, st, sa, sb, iters: int = 40, rise: float = 0.5):
    """Compiled sub-sampling of leaves (see :meth:`exotune.analysis._Side.submit`): the sign-change
    brackets (task, a, b, g(a), g(b)) of g(ω) = Im[Δa·conj(f (jω)^k Δb)] on each leaf's points.

    Parameters
    ----------
    qa, qb : QP
        The pair of quasi-polynomials Δa, Δb (same delays T [s]).
    k : int
        The power of (jω) in f φ.
    factor : complex
        The constant f (1 + jη for the hysteretic human).
    st : ndarray of int
        Design row of each leaf.
    sa, sb : ndarray
        The leaves' ends [rad/s].
    iters : int
        Golden-section steps of the search for a dip between points.
    rise : float
        The dip test's factor (:func:`exotune.numerics.quasipoly.dip_candidates`).

    Returns
    -------
    task, a, b, ga, gb : ndarray
        Design row, bracket ends [rad/s] and g there (opposite signs).
    """
    factor = complex(factor)
    Tt = qa.T[st]
    per = np.where(Tt > 0, 2 * np.pi / np.maximum(Tt, 1e-300), np.inf)
    M = np.clip(np.ceil(8.0 * (sb - sa) / per), 8, 512).astype(np.int64)  # ≥ 8 points per ripple period
    m = int(M.sum()) - len(st)
    out = (np.empty(m, np.int64), np.empty(m), np.empty(m), np.empty(m), np.empty(m))
    n = 0
    if len(st):
        f = lambda x: np.ascontiguousarray(x, dtype=float)  # noqa: E731
        n = _subsample(*pair_args(qa, qb), np.ascontiguousarray(st, dtype=np.int64), f(sa), f(sb), M, int(k),
                       factor.real, factor.imag, int(iters), float(rise), *out)
    return tuple(x[:n] for x in out)
