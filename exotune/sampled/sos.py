"""Discretization of controller blocks to cascades of second-order sections (scipy ``sos``):
the prewarped bilinear transform (:func:`tustin_sos`) and the state space of a cascade as the
runtime runs it (:func:`sos_ss`, direct form II transposed).

One implementation for the exported file (:mod:`exotune.controllerfile.sos` re-exports these)
and the batched sampled-data columns of a sweep (:mod:`exotune.sampled.batch`): the controller a
sweep judges is the one ``exotune export`` writes, by construction.
"""

from __future__ import annotations

import numpy as np

from .loop import prewarped

__all__ = ["tustin_sos", "sos_ss", "bilinear_batch", "df2t_batch", "tustin_sections_batch", "sos_ss_batch"]


def tustin_sos(num_asc, den_asc, sample_rate_hz: float, prewarp_hz: float | None = None) -> np.ndarray:
    """Second-order sections (scipy ``sos``) of the proper num/den (ascending powers of s) by the
    bilinear transform, prewarped at ``prewarp_hz`` (exact response there): s ← ω/tan(ωT_s/2)·(z−1)/(z+1).

    Parameters
    ----------
    num_asc, den_asc : array_like
        Numerator and denominator of the continuous block, ascending powers of s (proper).
    sample_rate_hz : float
        Sample rate [Hz].
    prewarp_hz : float or None, optional
        Prewarp frequency [Hz]; None for the plain bilinear transform.

    Returns
    -------
    numpy.ndarray
        Second-order sections (q, 6): ``[b0, b1, b2, a0, a1, a2]`` per row, descending powers of z.

    Raises
    ------
    ValueError
        When the block is improper (numerator of higher degree than the denominator).
    """
    import scipy.signal  # here: importing it costs a second, and only a design with a sample rate needs it

    num = np.trim_zeros(np.atleast_1d(np.asarray(num_asc, dtype=float)), "b")
    den = np.trim_zeros(np.atleast_1d(np.asarray(den_asc, dtype=float)), "b")
    if num.size > den.size:
        raise ValueError("an improper block cannot be discretized")
    num, den = prewarped(num, den, 1.0 / float(sample_rate_hz), prewarp_hz)
    z, p, k = scipy.signal.tf2zpk(num[::-1], den[::-1])
    zd, pd, kd = scipy.signal.bilinear_zpk(z, p, k, float(sample_rate_hz))
    return scipy.signal.zpk2sos(zd, pd, kd)


def sos_ss(sos) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Discrete state space (A, B, C, D) of a cascade of second-order sections, each section in
    the direct form II transposed states the runtime uses (y = b0 x + s1, s1⁺ = b1 x − a1 y + s2,
    s2⁺ = b2 x − a2 y; rows normalized by a0), chained in order.

    Parameters
    ----------
    sos : array_like
        Second-order sections (q, 6) as :func:`tustin_sos` returns them.

    Returns
    -------
    A : numpy.ndarray
        State matrix (2q, 2q).
    B : numpy.ndarray
        Input matrix (2q, 1).
    C : numpy.ndarray
        Output matrix (1, 2q).
    D : numpy.ndarray
        Feed-through (1, 1).
    """
    A = np.zeros((0, 0))
    B = np.zeros((0, 1))
    C = np.zeros((1, 0))
    D = np.ones((1, 1))
    for row in np.atleast_2d(np.asarray(sos, dtype=float)):
        b0, b1, b2, a0, a1, a2 = row
        b0, b1, b2, a1, a2 = b0 / a0, b1 / a0, b2 / a0, a1 / a0, a2 / a0
        As = np.array([[-a1, 1.0], [-a2, 0.0]])
        Bs = np.array([[b1 - a1 * b0], [b2 - a2 * b0]])
        Cs = np.array([[1.0, 0.0]])
        Ds = np.array([[b0]])
        # series: section input = previous output y = C x + D u
        n0 = A.shape[0]
        An = np.zeros((n0 + 2, n0 + 2))
        An[:n0, :n0] = A
        An[n0:, :n0] = Bs @ C
        An[n0:, n0:] = As
        Bn = np.vstack([B, Bs @ D])
        Cn = np.hstack([Ds @ C, Cs])
        A, B, C, D = An, Bn, Cn, Ds @ D
    return A, B, C, D


def bilinear_batch(num_asc: np.ndarray, den_asc: np.ndarray, sample_rate_hz: float, prewarp_hz=None):
    """The prewarped bilinear transform of a batch of blocks at once: numerators ``num_asc``
    (K, p, m+1) (p inputs sharing one denominator) over ``den_asc`` (K, m+1), ascending powers of
    s, every row of degree m in its denominator (the caller groups rows by degree); ``prewarp_hz``
    (K,) or None. Returns (b (K, p, m+1), a (K, m+1)), descending powers of z, a[:, 0] = 1.

    The same transfer function as :func:`tustin_sos` (s ← c (z−1)/(z+1), c = 2 f_s after the
    prewarp scaling of :func:`exotune.sampled.loop.prewarped`), by the polynomial substitution
    Σ_k x_k c^k (z−1)^k (z+1)^(m−k) instead of zeros and poles (no per-block root finding).

    Parameters
    ----------
    num_asc : numpy.ndarray
        Numerators (K, p, m+1), ascending powers of s.
    den_asc : numpy.ndarray
        Denominators (K, m+1), ascending powers of s, each of degree m.
    sample_rate_hz : float
        Sample rate [Hz].
    prewarp_hz : array_like or None, optional
        Prewarp frequency [Hz] per block (K,); a block with 0 is not prewarped; None for none.

    Returns
    -------
    b : numpy.ndarray
        Numerators (K, p, m+1), descending powers of z.
    a : numpy.ndarray
        Monic denominators (K, m+1), descending powers of z.
    """
    den = np.asarray(den_asc, dtype=float)
    num = np.asarray(num_asc, dtype=float)
    K, m1 = den.shape
    m = m1 - 1
    c = np.full(K, 2.0 * float(sample_rate_hz))
    if prewarp_hz is not None:
        w = 2.0 * np.pi * np.asarray(prewarp_hz, dtype=float)
        Ts = 1.0 / float(sample_rate_hz)
        t = np.tan(w * Ts / 2)
        c = np.where(w > 0, w / np.where(w > 0, t, 1.0), c)
    # T[j, k]: coefficient of z^(m−j) in (z−1)^k (z+1)^(m−k)
    T = np.zeros((m1, m1))
    for k in range(m1):
        T[:, k] = np.polymul(np.poly(np.ones(k)), np.poly(-np.ones(m - k)))
    ck = c[:, None] ** np.arange(m1)
    pad = np.zeros(num.shape[:-1] + (m1,))
    pad[..., :num.shape[-1]] = num
    a = (den * ck) @ T.T
    b = (pad * ck[:, None, :]) @ T.T
    return b / a[:, :1, None], a / a[:, :1]


def df2t_batch(b: np.ndarray, a: np.ndarray):
    """Stacks (A (K, m, m), B (K, m, p), C (m,), D (K, p)) of the direct form II transposed
    realization of p numerators ``b`` (K, p, m+1) over one monic denominator ``a`` (K, m+1)
    (descending powers of z): the states of :func:`sos_ss` for a single section, of any order.

    Parameters
    ----------
    b : numpy.ndarray
        Numerators (K, p, m+1), descending powers of z.
    a : numpy.ndarray
        Monic denominators (K, m+1), descending powers of z.

    Returns
    -------
    A : numpy.ndarray
        State matrices (K, m, m).
    B : numpy.ndarray
        Input matrices (K, m, p).
    C : numpy.ndarray
        Output row (m,), shared by the batch.
    D : numpy.ndarray
        Feed-throughs (K, p).
    """
    K, m1 = a.shape
    m = m1 - 1
    A = np.zeros((K, m, m))
    A[:, :, 0] = -a[:, 1:]
    A[:, np.arange(m - 1), np.arange(1, m)] = 1.0
    B = np.transpose(b[:, :, 1:] - a[:, None, 1:] * b[:, :, :1], (0, 2, 1))
    C = np.zeros(m)
    if m:
        C[0] = 1.0
    return A, B, C, b[:, :, 0]


def _roots_batch(c_asc: np.ndarray) -> np.ndarray:
    """Roots (K, m) of polynomials with ascending coefficients (K, m+1), leading coefficient
    non-zero: the eigenvalues of their companion matrices, one stacked eigenvalue problem (the
    method of ``numpy.roots``)."""
    K, m1 = c_asc.shape
    m = m1 - 1
    if m == 0:
        return np.zeros((K, 0), dtype=complex)
    comp = np.zeros((K, m, m))
    comp[:, 0, :] = -c_asc[:, m - 1::-1] / c_asc[:, m:m + 1]
    comp[:, np.arange(1, m), np.arange(m - 1)] = 1.0
    return np.linalg.eigvals(comp)


def _pairs(r: np.ndarray) -> np.ndarray:
    """Roots (K, 2q) ordered so that consecutive pairs are real: the real ones first (pairs of
    reals), then the complex ones by |Im|, real part (each next to its conjugate)."""
    order = np.lexsort((r.imag, r.real, np.abs(r.imag)), axis=-1)
    return np.take_along_axis(r, order, axis=-1)


def tustin_sections_batch(num_asc: np.ndarray, den_asc: np.ndarray, sample_rate_hz: float, prewarp_hz=None) -> np.ndarray:
    """Second-order sections (K, ⌈m/2⌉, 6) of a batch of single-input blocks ``num_asc`` (K, ·)
    over ``den_asc`` (K, m+1) (ascending powers of s, every denominator of degree m): the zeros,
    poles and gain of :func:`tustin_sos` (s-roots by companion matrices, z = (c + s)/(c − s),
    zeros at z = −1 for the excess poles, c = ω/tan(ωT_s/2) or 2 f_s), paired real with real and
    conjugate with conjugate, the gain in the first section — a cascade whose poles are each
    computed from their own pair (a single high-order companion form loses the poles clustered
    near z = 1 at high rates). An odd order gets a pole and a zero at z = 0.

    Parameters
    ----------
    num_asc : numpy.ndarray
        Numerators (K, ·), ascending powers of s (proper).
    den_asc : numpy.ndarray
        Denominators (K, m+1), ascending powers of s, each of degree m.
    sample_rate_hz : float
        Sample rate [Hz].
    prewarp_hz : array_like or None, optional
        Prewarp frequency [Hz] per block (K,); a block with 0 is not prewarped; None for none.

    Returns
    -------
    numpy.ndarray
        Sections (K, ⌈m/2⌉, 6), ``[b0, b1, b2, 1, a1, a2]`` per section, descending powers of z.
    """
    den = np.asarray(den_asc, dtype=float)
    num = np.asarray(num_asc, dtype=float)
    K, m1 = den.shape
    m = m1 - 1
    fs = float(sample_rate_hz)
    c = np.full(K, 2.0 * fs)
    if prewarp_hz is not None:
        w = 2.0 * np.pi * np.asarray(prewarp_hz, dtype=float)
        t = np.tan(w / (2.0 * fs))
        c = np.where(w > 0, w / np.where(w > 0, t, 1.0), c)
    q = (m + 1) // 2
    p = np.zeros((K, 2 * q), dtype=complex)
    z = np.full((K, 2 * q), -1.0 + 0j)
    if 2 * q > m:
        z[:, -1] = 0.0
    ps = _roots_batch(den)
    p[:, :m] = (c[:, None] + ps) / (c[:, None] - ps)
    k = np.zeros(K)
    numd = np.where(num != 0, np.arange(num.shape[1]), -1).max(axis=1)
    for dn in np.unique(numd):
        rows = np.nonzero(numd == dn)[0]
        if dn < 0:
            continue
        zs = _roots_batch(num[rows, :dn + 1])
        z[rows, :dn] = (c[rows, None] + zs) / (c[rows, None] - zs)
        gain = num[rows, dn] / den[rows, m] * np.prod(c[rows, None] - zs, axis=1) / np.prod(c[rows, None] - ps[rows], axis=1)
        k[rows] = gain.real
    p, z = _pairs(p), _pairs(z)
    sos = np.zeros((K, q, 6))
    sos[:, :, 0] = 1.0
    sos[:, :, 1] = -(z[:, 0::2] + z[:, 1::2]).real
    sos[:, :, 2] = (z[:, 0::2] * z[:, 1::2]).real
    sos[:, :, 3] = 1.0
    sos[:, :, 4] = -(p[:, 0::2] + p[:, 1::2]).real
    sos[:, :, 5] = (p[:, 0::2] * p[:, 1::2]).real
    sos[:, 0, :3] *= k[:, None]
    return sos


def sos_ss_batch(sos: np.ndarray):
    """:func:`sos_ss` of a stack of cascades ``sos`` (K, q, 6): stacks (A (K, 2q, 2q), B (K, 2q),
    C (K, 2q), D (K,)).

    Parameters
    ----------
    sos : numpy.ndarray
        Stack of cascades (K, q, 6).

    Returns
    -------
    A : numpy.ndarray
        State matrices (K, 2q, 2q).
    B : numpy.ndarray
        Input columns (K, 2q).
    C : numpy.ndarray
        Output rows (K, 2q).
    D : numpy.ndarray
        Feed-throughs (K,).
    """
    K, q, _ = sos.shape
    n = 2 * q
    A, B, C, D = np.zeros((K, n, n)), np.zeros((K, n)), np.zeros((K, n)), np.ones(K)
    for j in range(q):
        b0, b1, b2, a0, a1, a2 = (sos[:, j, i] for i in range(6))
        b0, b1, b2, a1, a2 = b0 / a0, b1 / a0, b2 / a0, a1 / a0, a2 / a0
        r = 2 * j
        Bs = np.stack([b1 - a1 * b0, b2 - a2 * b0], axis=1)
        A[:, r:r + 2, :r] = Bs[:, :, None] * C[:, None, :r]  # section input = the previous output C x + D u
        A[:, r, r], A[:, r, r + 1], A[:, r + 1, r] = -a1, 1.0, -a2
        B[:, r:r + 2] = Bs * D[:, None]
        C[:, :r] *= b0[:, None]
        C[:, r] = 1.0
        D = b0 * D
    return A, B, C, D
