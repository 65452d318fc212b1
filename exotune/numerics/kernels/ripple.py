"""Compiled frozen-ripple frame of the operator compliance C7 = Δ10/Δ00 (numpy reference:
:func:`exotune.analysis.operator_passivity._frame`; docs/method.md#passivity-of-the-operator-compliance).

With the polynomial parts frozen at ω (Δ00 = P00 + P01 e^{−jωT}, Δ10 = P10 + P11 e^{−jωT}),
|Δ00|² Im C7 = A0 + Im(G e^{−jωT}), A0 = Im(P10 conj P00 + P11 conj P01), G = P11 conj P00 − conj P10 · P01.
"""

from __future__ import annotations

import math

import numpy as np

from .common import AVAILABLE, coefficients, njit

if AVAILABLE:
    from .common import horner

__all__ = ["ripple_frame"]

if AVAILABLE:

    @njit(cache=True)
    def _frame(cA1, cB1, Ts, task, w, d0, d1, lift_min, flag, g):
        for i in range(task.shape[0]):
            t = task[i]
            T = Ts[t]
            if not (T > 0.0):
                flag[i] = False
                g[i] = 0.0
                continue
            x = w[i]
            ar, ai, _, _ = horner(cA1, t, x)
            br, bi, _, _ = horner(cB1, t, x)
            p01 = complex(ar, ai)
            p11 = complex(br, bi)
            e = complex(math.cos(x * T), -math.sin(x * T))
            p00 = d0[i] - p01 * e
            p10 = d1[i] - p11 * e
            a0 = (p10 * p00.conjugate() + p11 * p01.conjugate()).imag
            gi = p11 * p00.conjugate() - p10.conjugate() * p01
            g[i] = gi
            crest = a0 + abs(gi)
            den = max(abs(p00) - abs(p01), 0.0) * max(abs(p10) - abs(p11), 0.0)
            if not (crest > 0.0):  # also NaN
                flag[i] = False
            elif den > 0.0:
                lift = math.degrees(crest / den)
                flag[i] = not (lift < lift_min)  # NaN or inf lifts count
            else:
                flag[i] = True


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
