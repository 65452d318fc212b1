"""The state-variable filter of the identification and how a sampled signal goes through it.

Every signal x is passed through H(s) = ω³/(s + ω)³ and through s·H and s²·H (strictly proper, so
that no measured signal is differentiated numerically). A measured signal is the sample train of a
smooth signal: it is filtered with a first-order hold (the signal taken linear between samples),
which scales every frequency component ν of the signal by sinc²(νT/2) = 1 − (νT)²/12 + O((νT)⁴)
in all three filters alike (the hold's images pass the strictly proper filters attenuated, at
O((ωT)³) relative). The equations of the plant hold between the continuous signals, so they hold
between these filtered samples with the same coefficients, up to O((ωT)³).

A command held between samples (``tau_cmd``, zero-order hold) is known exactly between samples: its
exact filtering (zero-order-hold discretization) would not carry that sinc² factor, and the
equation it enters would then mix two operators (the held-command bias, +0.0325·(ωT)² relative in
J_m). It is therefore filtered exactly and then through the same factor, 1 + T²s²/12 (that is
sinc²(νT/2) at s = jν up to O((νT)⁴)): H_held[u] = H[u] + (T²/12)·s²H[u], both exact for a held u.
Every signal then goes through one operator, (1 + T²s²/12)·H, to O((ωT)³); the noise-free
estimates come back to 10⁻⁸–10⁻⁹ relative at 1 and 10 kHz (tests/identification).

References
----------
docs/identification.md#method.
"""

from __future__ import annotations

import functools
import math

import numpy as np

__all__ = ["svf", "svf_order", "held_svf", "discretization_bound", "velocity_sign"]


@functools.lru_cache(maxsize=16)
def _discrete(sample_rate_hz: float, filter_hz: float, hold: str) -> tuple:
    import scipy.signal  # here: importing it costs about a second, and only identify needs it

    w = 2 * math.pi * filter_hz
    den = np.polymul(np.polymul([1.0, w], [1.0, w]), [1.0, w])
    out = []
    for num in ([w ** 3], [w ** 3, 0.0], [w ** 3, 0.0, 0.0]):
        b, a, _ = scipy.signal.cont2discrete((num, den), 1.0 / sample_rate_hz, method=hold)
        out.append((np.ravel(b), np.ravel(a)))
    return tuple(out)


def svf(x: np.ndarray, sample_rate_hz: float, filter_hz: float,
        hold: str = "foh") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """H[x], sH[x], s²H[x] for H(s) = ω³/(s + ω)³, ω = 2π·filter_hz, from the zero state;
    ``hold``: "foh" for a measured signal (linear between samples), "zoh" for the exact filtering
    of a signal held between samples (see :func:`held_svf` for the one to use with measured
    signals).

    Parameters
    ----------
    x : numpy.ndarray
        The signal's samples.
    sample_rate_hz : float
        Sample rate [Hz].
    filter_hz : float
        Filter corner [Hz].
    hold : str, optional
        ``"foh"`` or ``"zoh"``.

    Returns
    -------
    tuple of numpy.ndarray
        H[x], sH[x] (per second) and s²H[x] (per second squared).
    """
    import scipy.signal

    return tuple(scipy.signal.lfilter(b, a, x) for b, a in _discrete(sample_rate_hz, filter_hz, hold))


def svf_order(x: np.ndarray, sample_rate_hz: float, filter_hz: float, k: int, hold: str = "foh") -> np.ndarray:
    """One of :func:`svf`'s outputs: s^k·H[x] (k = 0, 1, 2).

    Parameters
    ----------
    x : numpy.ndarray
        The signal's samples.
    sample_rate_hz : float
        Sample rate [Hz].
    filter_hz : float
        Filter corner [Hz].
    k : int
        The derivative's order (0, 1, 2).
    hold : str, optional
        ``"foh"`` or ``"zoh"``.

    Returns
    -------
    numpy.ndarray
        s^k·H[x].
    """
    import scipy.signal

    b, a = _discrete(sample_rate_hz, filter_hz, hold)[k]
    return scipy.signal.lfilter(b, a, x)


def held_svf(u: np.ndarray, sample_rate_hz: float, filter_hz: float) -> np.ndarray:
    """H_held[u] = H[u] + (T²/12)·s²H[u] of a command ``u`` held between samples (both filters
    exact for a held signal): the same operator as the first-order hold gives a measured smooth
    signal, to O((ωT)³) (module docstring).

    Parameters
    ----------
    u : numpy.ndarray
        The command's samples (e.g. τ_cmd [N·m]).
    sample_rate_hz : float
        Sample rate [Hz].
    filter_hz : float
        Filter corner [Hz].

    Returns
    -------
    numpy.ndarray
        H_held[u].
    """
    h = svf_order(u, sample_rate_hz, filter_hz, 0, "zoh")
    h += svf_order(u, sample_rate_hz, filter_hz, 2, "zoh") / (12.0 * sample_rate_hz ** 2)
    return h


def discretization_bound(sample_rate_hz: float, filter_hz: float) -> float:
    """Relative bound of what the hold leaves in the dynamic equations' estimates: 4·10⁻³·(ωT)³
    (the O((ωT)³) images: noise-free, measured below 1.03·10⁻³·(ωT)³ at ωT up to 0.25, the
    largest corner accepted, at 1-10 kHz from held and smooth logs; 5·10⁻³·(ωT)³ at ωT = 1.57,
    a quarter of the rate, which is why corners above ωT = 0.25 are refused) plus 10⁻⁷ (the
    filters' rounding, measured below 2·10⁻⁸ down to ωT = 2.5·10⁻³, the smallest corner accepted).

    Parameters
    ----------
    sample_rate_hz : float
        Sample rate [Hz].
    filter_hz : float
        Filter corner [Hz].

    Returns
    -------
    float
        The relative bound [–].
    """
    wt = 2 * math.pi * filter_hz / sample_rate_hz
    return 4e-3 * wt ** 3 + 1e-7


def velocity_sign(theta: np.ndarray, fs: float, fh: float) -> np.ndarray:
    """sign(θ̇) from the motor angle: central differences smoothed forward and backward (zero
    phase) at 5× the filter corner.

    Parameters
    ----------
    theta : numpy.ndarray
        Motor angle θ_m [rad].
    fs : float
        Sample rate [Hz].
    fh : float
        Filter corner [Hz].

    Returns
    -------
    numpy.ndarray
        −1, 0 or 1 per sample.
    """
    import scipy.signal

    b, a = scipy.signal.butter(2, min(5 * fh, 0.4 * fs) / (fs / 2))
    return np.sign(scipy.signal.filtfilt(b, a, np.gradient(theta)))
