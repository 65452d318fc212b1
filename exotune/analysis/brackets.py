"""Refinement of sign-change brackets of functions of two quasi-polynomials, compiled or numpy.

The crossing function of a family, Im C7 at a band edge and |C6/C5|² at the −3 dB level are
functions of a pair of quasi-polynomials (qa, qb); the compiled kernels
(:mod:`exotune.numerics.kernels`) evaluate and refine them by name (``mode``), the numpy
reference calls the Python function ``fun``.
"""

from __future__ import annotations

from ..numerics.engine import compiled
from ..numerics.quasipoly import QP, bisect_roots

__all__ = ["pair_roots", "pair_values"]


def pair_roots(fun, qa: QP, qb: QP, mode: str, task, a, b, fa, fb, k: int = 0, factor: complex = 1.0, c=None):
    """Illinois refinement of sign-change brackets of ``fun`` (numpy reference), or of the same
    function compiled (:func:`exotune.numerics.kernels.pair_roots`, ``mode``/``k``/``factor``/``c``).

    Parameters
    ----------
    fun : callable or None
        ``fun(task, w)``, the numpy reference function (unused when compiled).
    qa, qb : QP
        The pair of quasi-polynomials the function is built from.
    mode : str
        The compiled function's name: "cross" (a family's crossing function) or "mag" (|qa/qb|² − c).
    task, a, b, fa, fb : ndarray
        Design row, bracket ends [rad/s] and the function's values there (opposite signs).
    k, factor, c :
        Parameters of the compiled function: the family's (jω)^k and factor, the magnitude level c.

    Returns
    -------
    ndarray
        The zero in each bracket [rad/s].
    """
    if compiled():
        from ..numerics import kernels as _fastphase

        return _fastphase.pair_roots(qa, qb, mode, task, a, b, fa, fb, k=k, factor=factor, c=c)
    return bisect_roots(fun, task, a, b, fa, fb=fb)


def pair_values(fun, qa: QP, qb: QP, mode: str, task, w, k: int = 0, factor: complex = 1.0, c=None):
    """``fun(task, w)`` (numpy reference) or the same function compiled.

    Parameters
    ----------
    fun : callable or None
        ``fun(task, w)``, the numpy reference function (unused when compiled).
    qa, qb : QP
        The pair of quasi-polynomials the function is built from.
    mode : str
        The compiled function's name: "cross" (a family's crossing function) or "mag" (|qa/qb|² − c).
    task : ndarray of int
        Design row of each point.
    w : ndarray
        Frequencies [rad/s].
    k, factor, c :
        Parameters of the compiled function: the family's (jω)^k and factor, the magnitude level c.

    Returns
    -------
    ndarray
        The function's value at each point.
    """
    if compiled():
        from ..numerics import kernels as _fastphase

        return _fastphase.pair_values(qa, qb, mode, task, w, k=k, factor=factor, c=c)
    return fun(task, w)
