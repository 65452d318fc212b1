"""State-space realization of a transfer function: ``scipy.signal.tf2ss``'s controllable canonical
form, without importing ``scipy.signal``.

exotune prefers a well-kept library to its own code; this one function is the exception because of
its import cost: ``import scipy.signal`` takes 1–1.5 s (it imports ``scipy.stats``), more than the
whole analysis of a design, and tf2ss is all that the continuous analysis (the KYP certificates,
:mod:`exotune.analysis.kyp`) and the Tustin discretization (:mod:`exotune.sampled.loop`) used of it.
The realization is scipy's, step for step (same normalization, same arrays);
``tests/numerics/test_statespace.py`` checks it against ``scipy.signal.tf2ss``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["tf2ss"]

NUM_ZERO = 1e-14  # scipy.signal.normalize: leading numerator coefficients this small are dropped


def tf2ss(num, den) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Controllable canonical realization (A, B, C, D) of the proper transfer function num/den, as
    ``scipy.signal.tf2ss`` gives it (single input, single output).

    Leading zeros of ``den`` are dropped and both polynomials divided by its leading coefficient;
    leading numerator coefficients of magnitude at most 1e-14 (after that division) are dropped
    (scipy also warns ``BadCoefficients`` then); the numerator is padded with zeros to the
    denominator's length n + 1. Then A has the first row −den[1:] and ones on its subdiagonal,
    B = e₁, C = num[1:] − num[0]·den[1:] and D = num[0] (for n = 0: zero 1×1 A, B, C).

    Parameters
    ----------
    num, den : array_like
        Coefficients of the numerator and denominator, in descending powers of s (1-D).

    Returns
    -------
    A, B, C, D : numpy.ndarray
        Shapes (n, n), (n, 1), (1, n), (1, 1); four empty arrays for an empty numerator.

    Raises
    ------
    ValueError
        When ``den`` is zero or not 1-D, ``num`` is not 1-D, or num/den is improper.

    Examples
    --------
    >>> A, B, C, D = tf2ss([1.0, 3.0, 3.0], [1.0, 2.0, 1.0])
    >>> A.tolist(), B.tolist(), C.tolist(), D.tolist()
    ([[-2.0, -1.0], [1.0, 0.0]], [[1.0], [0.0]], [[1.0, 2.0]], [[1.0]])
    """
    num = np.atleast_1d(np.asarray(num))
    den = np.atleast_1d(np.asarray(den))
    if den.ndim != 1 or num.ndim != 1:
        raise ValueError("tf2ss takes 1-D numerator and denominator coefficients")
    if np.all(den == 0):
        raise ValueError("the denominator is zero")
    den = np.trim_zeros(den, "f")
    num, den = num / den[0], den / den[0]
    lead = 0
    while lead < num.size and abs(num[lead]) <= NUM_ZERO:
        lead += 1
    num = num[min(lead, num.size - 1):]
    M, K = num.size, den.size
    if M > K:
        raise ValueError("improper transfer function: the numerator is longer than the denominator")
    if M == 0:
        return (np.array([], float),) * 4
    num = np.concatenate((np.zeros(K - M, dtype=num.dtype), num))
    D = num[:1].reshape(1, 1)
    if K == 1:
        return np.zeros((1, 1)), np.zeros((1, 1)), np.zeros((1, 1)), D
    A = np.vstack((-den[1:][None, :], np.eye(K - 2, K - 1)))
    B = np.eye(K - 1, 1)
    C = (num[1:] - num[0] * den[1:])[None, :]
    return A, B, C, D
