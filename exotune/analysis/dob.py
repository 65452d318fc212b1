"""Margins of the disturbance-observer loop L_dob = Q e^{−sT}/(1 − Q) (paper Fig. 4).

Gain crossovers are exact roots of |n_q|² = |d_q − n_q|², every crossover is considered.

References
----------
Paper §III (disturbance observer, Fig. 4); docs/method.md#dob-margins.
"""

from __future__ import annotations

import numpy as np

from ..model.controller import ControllerStructure
from ..numerics.poly import degree, leading, padd, pmul, psub, pval_flat
from ..numerics.quasipoly import QP
from .batch_result import DobBatch, take_designs
from .charfun import design_column, trim_poly
from .counting import rhp_count

__all__ = ["dob_margins", "dob_margins_rows"]


def dob_margins(cs: ControllerStructure, N: int) -> DobBatch | None:
    """Gain [dB], phase [deg] and delay [s] margins of L_dob = Q e^{−sT}/(1 − Q) (docs/method.md#analyses-and-metrics), and
    whether the closed DOB loop is stable (no positive margin when it is not), as a
    :class:`~exotune.analysis.batch_result.DobBatch` of N designs; None without a DOB.

    Gain crossovers are the positive real roots of |n_q(jω)|² − |(d_q − n_q)(jω)|² (a polynomial
    in ω; closed forms for the standard Q); delay margin = min_k PM_k/ω_k with PM_k ∈ [0, 2π).
    Phase crossovers (arg L = −180° mod 360°) are bracketed on a dense log grid of the continuous
    phase (from the roots of n_q and d_q − n_q, so no unwrapping) and bisected; gain margin = min
    over them of 1/|L|. Phase margin: 180° + arg L(jω_k) in (−180°, 180°] for a stable loop; an
    unstable one reports PM ≤ 0 (its continuous value, saturated at −180°), GM ≤ 0 dB and delay
    margin 0 (:func:`dob_margins_rows`).

    Parameters
    ----------
    cs : ControllerStructure
        The controller blocks: the DOB filter Q and the delay T [s].
    N : int
        Number of designs.

    Returns
    -------
    DobBatch or None
        Gain [dB], phase [deg] and delay [s] margins and the closed-loop verdict, one entry per
        design; None when the controller has no DOB.

    References
    ----------
    Paper §III (the DOB), Fig. 4 (tuning the DOB's Q filter against the delay); docs/method.md#dob-margins.
    """
    if cs.dob_q is None:
        return None
    nq = np.broadcast_to(cs.dob_q.num, (N,) + cs.dob_q.num.shape[-1:]).astype(float)
    dq = np.broadcast_to(cs.dob_q.den, (N,) + cs.dob_q.den.shape[-1:]).astype(float)
    T = design_column(cs.delay_s, N)
    # the margins depend on (Q, T) only: compute once per distinct row (sweeps repeat them)
    key = np.concatenate([nq, dq, T[:, None]], axis=1)
    uniq, inv = np.unique(key, axis=0, return_inverse=True)
    inv = inv.ravel()
    if len(uniq) < N:
        nu = nq.shape[1]
        return take_designs(dob_margins_rows(uniq[:, :nu], uniq[:, nu:-1], uniq[:, -1]), inv)
    return dob_margins_rows(nq, dq, T)


def _dob_margins_standard(nq, dq, T):
    """Closed forms for the standard Q = ω_q²/(s² + 2ζω_q s + ω_q²) (docs/method.md#controller):
    L_dob = ω_q² e^{−sT}/(s (s + a)), a = 2ζω_q, has monotone gain and phase, one gain crossover
    ω_c = ω_q/√(√(4ζ⁴ + 1) + 2ζ²) (the cancellation-free form of ω_q √(√(4ζ⁴ + 1) − 2ζ²)), the
    continuous PM = atan(a/ω_c) − ω_c T (= π/2 − atan(ω_c/a) − ω_c T, positive iff the closed loop
    is stable), and the smallest gain margin at the first −180° crossing ω_p, atan(a/ω_p) = ω_p T,
    bisected on a bracket of ratio ≤ 2 (min(π/(4T), √(πa/(4T))), min(π/(2T), √(a/T))).
    Returns (continuous PM [rad], gain margin [dB], crossover [rad/s])."""
    wq2 = nq[:, 0]
    a = dq[:, 1]
    wq = np.sqrt(wq2)
    z2 = (a / (2 * wq)) ** 2
    wc = wq / np.sqrt(np.hypot(2 * z2, 1.0) + 2 * z2)
    pm = np.arctan2(a, wc) - wc * T
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):  # T = 0: no phase crossover
        Tp = np.where(T > 0, T, 1.0)
        lo = np.minimum(np.pi / (4 * Tp), np.sqrt(np.pi * a / (4 * Tp)))
        hi = np.minimum(np.pi / (2 * Tp), np.sqrt(a / Tp))
        for _ in range(64):
            mid = 0.5 * (lo + hi)
            f = np.arctan2(a, mid) - mid * Tp
            lo = np.where(f > 0, mid, lo)
            hi = np.where(f > 0, hi, mid)
        wp = 0.5 * (lo + hi)
        gm = np.where(T > 0, 20 * (np.log10(wp) + np.log10(np.hypot(wp, a)) - np.log10(wq2)), np.inf)
    return pm, gm, wc


def _dob_margins_general(nq, m, T):
    """Margins of L_dob = n_q e^{−sT}/m, m = d_q − n_q, for any rational Q (:func:`dob_margins`).
    Returns (min wrapped PM_k [rad] in (−π, π], min continuous PM_k [rad], gain margin [dB],
    delay margin [s] (before the stability verdict), lowest crossover [Hz]); the continuous phase
    is the sum of the root angles, its branch fixed by the phase in [−π, π) at low frequency."""
    N = len(T)
    # |p(jω)|² as a polynomial in ω
    def sq(c):
        k = np.arange(c.shape[-1])
        jk = 1j ** k
        pc = c * jk  # coefficients of p(jω) in ω
        re, im = np.real(pc), np.imag(pc)
        return padd(pmul(re, re), pmul(im, im))

    u = psub(sq(nq), sq(m))
    roots = _batched_roots(u)
    wc = np.where((np.abs(roots.imag) <= 1e-9 * np.abs(roots)) & (roots.real > 0), roots.real, np.nan)
    zn = _batched_roots(nq)
    zm = _batched_roots(m)
    ln, lm = leading(nq), leading(m)

    def phase(rows, w):  # continuous phase of L(jω) at scattered (row, ω)
        s = (1j * w)[:, None]
        ph = np.angle(ln[rows]) - np.angle(lm[rows]) - w * T[rows]
        ph = ph + np.nansum(np.angle(s - zn[rows]), axis=1)
        return ph - np.nansum(np.angle(s - zm[rows]), axis=1)

    def mag(rows, w):
        s = 1j * w
        return np.abs(pval_flat(nq, rows, s)) / np.abs(pval_flat(m, rows, s))

    allr = np.abs(np.concatenate([zn, zm], axis=1))
    scale = np.nanmax(np.where(np.isfinite(allr), allr, 0.0), axis=1)
    scale = np.where(scale > 0, scale, 1.0)
    # the branch of the continuous phase: the rational part's phase in [−π, π) below every
    # crossover and nonzero root (the delay's −ωT is continuous from 0)
    low = np.where(np.isfinite(allr) & (allr > 1e-9 * scale[:, None]), allr, np.inf)
    low = np.minimum(np.min(low, axis=1), np.min(np.where(np.isfinite(wc), wc, np.inf), axis=1))
    w0 = 1e-3 * np.minimum(low, scale)
    ph0 = phase(np.arange(N), w0) + w0 * T
    shift = -2 * np.pi * np.floor((ph0 + np.pi) / (2 * np.pi))
    rows_c, col_c = np.nonzero(np.isfinite(wc))
    w_c = wc[rows_c, col_c]
    pm_c = np.pi + phase(rows_c, w_c) + shift[rows_c]
    pm_k = np.mod(pm_c, 2 * np.pi)
    dm = np.full(N, np.inf)
    pm = np.full(N, np.inf)
    pmc = np.full(N, np.inf)
    np.minimum.at(dm, rows_c, pm_k / w_c)
    np.minimum.at(pm, rows_c, np.where(pm_k > np.pi, pm_k - 2 * np.pi, pm_k))
    np.minimum.at(pmc, rows_c, pm_c)
    fc_tmp = np.full(N, np.inf)
    np.minimum.at(fc_tmp, rows_c, w_c / (2 * np.pi))
    fc = np.where(np.isfinite(fc_tmp), fc_tmp, np.nan)
    # phase crossovers on a log grid spanning the DOB dynamics and the delay
    hi = np.maximum(scale * 1e3, np.where(T > 0, 400.0 / np.maximum(T, 1e-12), 0.0))
    hi = np.minimum(hi, scale * 1e6)
    K = 400
    lo = np.minimum(scale * 1e-4, np.where(T > 0, 0.1 / np.maximum(T, 1e-300), np.inf))  # below the delay's lag
    wg = np.exp(np.linspace(np.log(lo), np.log(hi), K, axis=1))
    rows_g = np.repeat(np.arange(N), K)
    ph = phase(rows_g, wg.ravel()).reshape(N, K)
    kk = np.floor((ph + np.pi) / (2 * np.pi))
    rr, cc = np.nonzero(kk[:, 1:] != kk[:, :-1])
    target = np.maximum(kk[rr, cc], kk[rr, cc + 1]) * 2 * np.pi - np.pi
    a, b = wg[rr, cc], wg[rr, cc + 1]
    fa = phase(rr, a) - target
    for _ in range(60):
        mid = 0.5 * (a + b)
        f = phase(rr, mid) - target
        same = np.sign(f) == np.sign(fa)
        a = np.where(same, mid, a)
        fa = np.where(same, f, fa)
        b = np.where(same, b, mid)
    gm = np.full(N, np.inf)
    if rr.size:
        np.minimum.at(gm, rr, -20 * np.log10(mag(rr, 0.5 * (a + b))))
    return pm, pmc, gm, dm, fc


def dob_margins_rows(nq, dq, T):
    """DOB-loop margins for given rows of the filter Q = n_q/d_q and delays T.

    The standard second-order Q takes the closed forms; any other rational Q the general path
    (exact gain crossovers, bisected phase crossovers), see :func:`dob_margins`. The phase margin
    of a stable loop is 180° + arg L(jω_c) in (−180°, 180°] (the smallest over the crossovers); a
    closed DOB loop that is unstable never reports a healthy margin: its phase margin is the
    (negative) continuous one, 180° + arg L(jω_c) with the phase followed from low frequency,
    saturated at −180° (and 0° when the crossovers do not show the instability), its gain margin
    at most 0 dB and its delay margin 0.

    Parameters
    ----------
    nq, dq : ndarray, shape (N, m)
        Numerator and denominator of Q, ascending coefficients, one row per design.
    T : ndarray, shape (N,)
        Loop delay [s].

    Returns
    -------
    DobBatch
        ``phase_margin_deg`` [deg] (≤ 0 when the closed DOB loop is unstable), ``gain_margin_db``
        [dB] (≤ 0 when unstable), ``delay_margin_s`` [s] (the extra delay tolerated; 0 when
        unstable), ``crossover_hz`` [Hz] and ``stable``: arrays of shape (N,).

    References
    ----------
    Paper §III (Fig. 4); docs/method.md#dob-margins.
    """
    m = psub(dq, nq)
    # closed DOB loop 1 + L_dob ∝ (d_q − n_q) + n_q e^{−sT}, its right-half-plane roots counted
    Nd, rd, okd = rhp_count(QP(trim_poly(m), trim_poly(nq), T))
    stable = okd & (Nd == 0) & (rd == 0)
    standard = (nq.shape[1] == 1) and (dq.shape[1] == 3) and np.all(dq[:, 2] == 1) and np.all(dq[:, 0] == nq[:, 0])
    if standard:
        pmc, gm, wc = _dob_margins_standard(nq, dq, T)
        # one crossover, monotone phase: stable iff the continuous PM is positive (both must say so)
        stable = stable & (pmc > 0)
        pm, dm, fc = pmc, pmc / wc, wc / (2 * np.pi)
    else:
        pm, pmc, gm, dm, fc = _dob_margins_general(nq, m, T)
    # an unstable loop tolerates no extra delay, and its wrapped PM_k or PM_k/ω_k would read as a
    # (misleading) positive margin: PM ≤ 0 (continuous, ≥ −180°), GM ≤ 0 dB, delay margin 0
    pm = np.where(stable, pm, np.clip(pmc, -np.pi, 0.0))
    gm = np.where(stable, gm, np.minimum(gm, 0.0))
    dm = np.where(stable, dm, 0.0)
    return DobBatch(phase_margin_deg=np.degrees(pm), gain_margin_db=gm, delay_margin_s=dm, crossover_hz=fc,
                    stable=stable)


def _batched_roots(c: np.ndarray) -> np.ndarray:
    """Roots of each row (ascending coefficients) via batched companion eigenvalues; NaN-padded."""
    n = degree(c)
    N, m = c.shape
    dmax = int(n.max()) if N else 0
    out = np.full((N, max(dmax, 1)), np.nan + 0j)
    for d in np.unique(n):
        if d <= 0:
            continue
        rows = np.nonzero(n == d)[0]
        cc = c[rows, : d + 1]
        comp = np.zeros((len(rows), d, d), dtype=cc.dtype)
        comp[:, 1:, :-1] = np.eye(d - 1)
        comp[:, :, -1] = -cc[:, :d] / cc[:, d : d + 1]
        out[rows, :d] = np.linalg.eigvals(comp)
    return out

