"""Discretization of controller blocks to cascades of second-order sections (scipy ``sos``):
the prewarped bilinear transform (:func:`tustin_sos`) and the state space of a cascade as the
runtime runs it (:func:`sos_ss`, direct form II transposed).

One implementation for the exported file (:mod:`exotune.controllerfile`, which re-exports these)
and the batched sampled-data columns of a sweep (:mod:`exotune.sampled.batch`): the controller a
sweep judges is the one ``exotune export`` writes, by construction.
"""

from __future__ import annotations

import numpy as np
import scipy.signal

from .loop import prewarped

__all__ = ["tustin_sos", "sos_ss"]


def tustin_sos(num_asc, den_asc, sample_rate_hz: float, prewarp_hz: float | None = None) -> np.ndarray:
    """Second-order sections (scipy ``sos``) of the proper num/den (ascending powers of s) by the
    bilinear transform, prewarped at ``prewarp_hz`` (exact response there): s ← ω/tan(ωT_s/2)·(z−1)/(z+1)."""
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
    s2⁺ = b2 x − a2 y; rows normalized by a0), chained in order."""
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
