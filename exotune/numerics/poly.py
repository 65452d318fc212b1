"""Batched polynomial and rational-function arithmetic.

Conventions used throughout exotune's numerics:

* A polynomial batch is an array ``c`` of shape ``(..., d + 1)`` holding the coefficients in
  **ascending** powers of ``s``: ``p(s) = c[..., 0] + c[..., 1] s + ... + c[..., d] s^d``.
  Leading dimensions index designs (or tasks); every operation is vectorized over them.
* Products and sums are formed coefficient-wise without any rounding tricks, so a structural zero
  coefficient (e.g. the constant term of ``J_m s^2 + B_m s``) stays *exactly* ``0.0``. The analysis
  relies on this to remove the rigid-body root at ``s = 0`` exactly (docs/method.md#double-compliance-shaping), never by a tolerance.

These are tiny kernels (degrees <= ~16) applied to large batches, in numpy; the product of large
real batches runs compiled (:func:`exotune._fastphase.pmul_rows`, same accumulation order, same
bits) when numba is available.
"""

from __future__ import annotations

import math

from dataclasses import dataclass

import numpy as np

__all__ = [
    "ascending",
    "descending",
    "as_poly",
    "padd",
    "psub",
    "pmul",
    "pscale",
    "pder",
    "pval",
    "pval_flat",
    "degree",
    "leading",
    "strip_common_low_zeros",
    "trim_high",
    "poly_roots",
    "is_hurwitz",
    "root_grid",
    "Rational",
]


def as_poly(*coeffs, shape=None) -> np.ndarray:
    """Stack ascending coefficients (scalars or arrays broadcast together) into a poly batch.

    Parameters
    ----------
    *coeffs : array_like
        The coefficients c_0, c_1, …, c_d (ascending powers), each a scalar or an array over the
        batch.
    shape : tuple of int or None, optional
        Leading (batch) shape to broadcast the result to; None keeps the broadcast shape.

    Returns
    -------
    numpy.ndarray
        The batch (..., d+1), float or complex.
    """
    arrs = np.broadcast_arrays(*[np.asarray(c) for c in coeffs])
    out = np.stack(arrs, axis=-1)
    if out.dtype.kind not in "fc":
        out = out.astype(float)
    if shape is not None:
        out = np.broadcast_to(out, tuple(shape) + out.shape[-1:]).copy()
    return out


def pad_cols(a: np.ndarray, n: int) -> np.ndarray:
    """Append zero coefficients up to n (np.pad's result, without its per-call overhead)."""
    if a.shape[-1] == n:
        return a
    out = np.zeros(a.shape[:-1] + (n,), dtype=a.dtype)
    out[..., : a.shape[-1]] = a
    return out


def padd(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a + b for polynomial batches (broadcast over leading dims).

    Parameters
    ----------
    a, b : numpy.ndarray
        Polynomial batches (..., ·), ascending coefficients.

    Returns
    -------
    numpy.ndarray
        The sum, as long as the longer operand.
    """
    n = max(a.shape[-1], b.shape[-1])
    return pad_cols(np.asarray(a), n) + pad_cols(np.asarray(b), n)


def psub(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a - b for polynomial batches.

    Parameters
    ----------
    a, b : numpy.ndarray
        Polynomial batches (..., ·), ascending coefficients.

    Returns
    -------
    numpy.ndarray
        The difference, as long as the longer operand.
    """
    n = max(a.shape[-1], b.shape[-1])
    return pad_cols(np.asarray(a), n) - pad_cols(np.asarray(b), n)


_COMPILED_MIN_ROWS = 64  # below this many rows numpy's loop is as fast as the compiled one


def pmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a * b (batched convolution); exact zeros stay exact.

    Parameters
    ----------
    a, b : numpy.ndarray
        Polynomial batches (..., na) and (..., nb), ascending coefficients.

    Returns
    -------
    numpy.ndarray
        The product (..., na + nb − 1) over the broadcast leading dims.
    """
    a = np.asarray(a)
    b = np.asarray(b)
    lead = np.broadcast_shapes(a.shape[:-1], b.shape[:-1])
    na, nb = a.shape[-1], b.shape[-1]
    dtype = np.result_type(a, b, float)
    from .engine import compiled

    if len(lead) == 1 and lead[0] >= _COMPILED_MIN_ROWS and dtype == np.float64 and compiled():
        from .kernels import pmul_rows

        return pmul_rows(np.broadcast_to(a, lead + (na,)), np.broadcast_to(b, lead + (nb,)))
    out = np.zeros(lead + (na + nb - 1,), dtype=dtype)
    for j in range(nb):
        out[..., j : j + na] += a * b[..., j : j + 1]
    return out


def pscale(a: np.ndarray, k) -> np.ndarray:
    """k * a with k a scalar or an array over the leading dims.

    Parameters
    ----------
    a : numpy.ndarray
        Polynomial batch (..., d+1).
    k : float or array_like
        Factor, a scalar or one per row (the leading dims of ``a``).

    Returns
    -------
    numpy.ndarray
        The scaled batch.
    """
    return np.asarray(a) * np.asarray(k)[..., None]


def pder(a: np.ndarray) -> np.ndarray:
    """d/ds of a polynomial batch.

    Parameters
    ----------
    a : numpy.ndarray
        Polynomial batch (..., d+1), ascending coefficients.

    Returns
    -------
    numpy.ndarray
        The derivative (..., d) (a zero column for constants).
    """
    a = np.asarray(a)
    if a.shape[-1] == 1:
        return np.zeros_like(a)
    return a[..., 1:] * np.arange(1, a.shape[-1])


def pval(c: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Evaluate ``c`` (shape (..., d+1)) at ``s`` (shape (..., K)) by Horner's rule -> (..., K).

    Parameters
    ----------
    c : numpy.ndarray
        Polynomial batch (..., d+1), ascending coefficients.
    s : numpy.ndarray
        Evaluation points (..., K), real or complex (e.g. s = jω [rad/s]).

    Returns
    -------
    numpy.ndarray
        The values (..., K).
    """
    c = np.asarray(c)
    s = np.asarray(s)
    acc = np.broadcast_to(c[..., -1:], np.broadcast_shapes(c.shape[:-1] + (1,), s.shape)).astype(
        np.result_type(c, s, complex if np.iscomplexobj(s) else float)
    )
    for k in range(c.shape[-1] - 2, -1, -1):
        acc = acc * s + c[..., k : k + 1]
    return acc


def pval_flat(c: np.ndarray, idx: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Evaluate row ``idx[i]`` of the batch ``c`` (shape (T, d+1)) at ``s[i]`` -> shape (M,).

    Parameters
    ----------
    c : numpy.ndarray
        Polynomial batch (T, d+1), ascending coefficients.
    idx : numpy.ndarray
        Row of ``c`` per point (M,), int.
    s : numpy.ndarray
        Evaluation points (M,).

    Returns
    -------
    numpy.ndarray
        The complex values (M,).
    """
    cc = c[idx]
    acc = cc[:, -1].astype(np.result_type(cc, s, complex))
    for k in range(c.shape[-1] - 2, -1, -1):
        acc = acc * s + cc[:, k]
    return acc


def degree(c: np.ndarray) -> np.ndarray:
    """Index of the highest non-zero coefficient per row (-1 for the zero polynomial).

    Parameters
    ----------
    c : numpy.ndarray
        Polynomial batch (..., d+1), ascending coefficients.

    Returns
    -------
    numpy.ndarray
        Degree per row (int), −1 for the zero polynomial.
    """
    nz = np.asarray(c) != 0
    rev = nz[..., ::-1]
    has = rev.any(axis=-1)
    d = c.shape[-1] - 1 - np.argmax(rev, axis=-1)
    return np.where(has, d, -1)


def leading(c: np.ndarray) -> np.ndarray:
    """Leading (highest non-zero) coefficient per row.

    Parameters
    ----------
    c : numpy.ndarray
        Polynomial batch (..., d+1), ascending coefficients.

    Returns
    -------
    numpy.ndarray
        The leading coefficient per row (0 for the zero polynomial).
    """
    d = np.maximum(degree(c), 0)
    return np.take_along_axis(np.asarray(c), d[..., None], axis=-1)[..., 0]


def strip_common_low_zeros(*polys: np.ndarray, max_strip: int | None = None):
    """Divide every polynomial of a group by ``s**r``, r = the common number of *exactly* zero
    low-order coefficients (per row). Returns ``(r, stripped_polys)``.

    Used to take out the structural root at s = 0 (rigid-body mode, docs/method.md#double-compliance-shaping) exactly.

    Parameters
    ----------
    *polys : numpy.ndarray
        The polynomial batches of the group, ascending coefficients.
    max_strip : int or None, optional
        Largest power of s to divide out; None for no limit.

    Returns
    -------
    r : numpy.ndarray
        The power of s divided out, per row (int).
    stripped : list of numpy.ndarray
        The polynomials divided by s**r, same shapes (zero-padded at the top).
    """
    n = max(p.shape[-1] for p in polys)
    lead = np.broadcast_shapes(*[p.shape[:-1] for p in polys])
    big = np.full(lead, n, dtype=int)
    r = big
    for p in polys:
        nz = np.broadcast_to(np.asarray(p) != 0, lead + p.shape[-1:])
        has = nz.any(axis=-1)
        first = np.where(has, np.argmax(nz, axis=-1), n)
        r = np.minimum(r, first)
    r = np.where(r >= n, 0, r)
    if max_strip is not None:
        r = np.minimum(r, max_strip)
    out = []
    for p in polys:
        p = np.broadcast_to(np.asarray(p), lead + p.shape[-1:])
        m = p.shape[-1]
        j = np.arange(m)
        src = j + r[..., None]
        valid = src < m
        q = np.take_along_axis(p, np.minimum(src, m - 1), axis=-1)
        out.append(np.where(valid, q, 0).astype(p.dtype))
    return r, out


@dataclass(frozen=True)
class Rational:
    """A batch of rational transfer functions num(s)/den(s), ascending coefficients.

    ``num`` has shape (N, m+1) and ``den`` shape (N, n+1) (or broadcastable). Used for every
    controller block of the implementation structure (docs/method.md#controller).
    """

    num: np.ndarray
    den: np.ndarray

    @staticmethod
    def poly(c: np.ndarray) -> "Rational":
        c = np.asarray(c, dtype=float)
        return Rational(c, np.ones(c.shape[:-1] + (1,)))

    @staticmethod
    def const(k) -> "Rational":
        k = np.asarray(k, dtype=float)
        return Rational(k[..., None], np.ones(k.shape + (1,)))

    def __call__(self, s: np.ndarray) -> np.ndarray:
        return pval(self.num, s) / pval(self.den, s)

    def __mul__(self, other: "Rational") -> "Rational":
        if not isinstance(other, Rational):
            other = Rational.const(other)
        return Rational(pmul(self.num, other.num), pmul(self.den, other.den))

    __rmul__ = __mul__

    def __add__(self, other: "Rational") -> "Rational":
        if not isinstance(other, Rational):
            other = Rational.const(other)
        num = padd(pmul(self.num, other.den), pmul(other.num, self.den))
        return Rational(num, pmul(self.den, other.den))

    __radd__ = __add__

    def __neg__(self) -> "Rational":
        return Rational(-self.num, self.den)

    def descending(self, index: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """(num, den) of member ``index`` with descending coefficients (numpy/python-control order)."""
        return descending(_member(self.num, index)), descending(_member(self.den, index))

    def to_control(self, index: int = 0):
        """Member ``index`` as a ``control.TransferFunction`` (docs/api.md#python-control)."""
        import control

        return control.TransferFunction(*self.descending(index))

    def __sub__(self, other: "Rational") -> "Rational":
        return self + (-other if isinstance(other, Rational) else Rational.const(-np.asarray(other)))

    def is_proper(self) -> np.ndarray:
        return degree(self.num) <= degree(self.den)

    def take(self, idx) -> "Rational":
        n = np.broadcast_to(self.num, np.broadcast_shapes(self.num.shape[:-1], self.den.shape[:-1]) + self.num.shape[-1:])
        d = np.broadcast_to(self.den, n.shape[:-1] + self.den.shape[-1:])
        return Rational(n[idx], d[idx])

    # one transfer function (a batch of one): the design report's toolbox ----------------------
    def minimal(self) -> "Rational":
        """This transfer function (one row) with the common exact roots at s = 0 of num and den
        cancelled (structural, e.g. G_v with K̃1 = 0) and exactly-zero highest-order coefficients
        dropped; ``num`` and ``den`` become 1-D.

        Returns
        -------
        Rational
            num/den with 1-D ascending coefficients.
        """
        _, (n, d) = strip_common_low_zeros(_flat(self.num)[None, :], _flat(self.den)[None, :])
        return Rational(trim_high(n[0]), trim_high(d[0]))

    def poles(self) -> np.ndarray:
        """Roots of the denominator (one row) [rad/s], sorted by magnitude then imaginary part.

        Returns
        -------
        numpy.ndarray
            Complex poles.
        """
        return poly_roots(self.den)

    def zeros(self) -> np.ndarray:
        """Roots of the numerator (one row) [rad/s], sorted by magnitude then imaginary part.

        Returns
        -------
        numpy.ndarray
            Complex zeros.
        """
        return poly_roots(self.num)

    def at_jw(self, w) -> np.ndarray:
        """num(jω)/den(jω) of this transfer function (one row) at the angular frequencies ``w``.

        Parameters
        ----------
        w : array_like
            Angular frequencies [rad/s].

        Returns
        -------
        numpy.ndarray
            Complex response, the shape of ``w``.
        """
        s = 1j * np.asarray(w)
        return pval(_flat(self.num), s) / pval(_flat(self.den), s)


def _flat(c) -> np.ndarray:
    return np.asarray(c, dtype=float).reshape(-1)


def trim_high(c) -> np.ndarray:
    """Drop exactly-zero highest-order coefficients of one polynomial (ascending order).

    Parameters
    ----------
    c : array_like
        Ascending coefficients (flattened).

    Returns
    -------
    numpy.ndarray
        1-D coefficients, at least one (``[0.0]`` for the zero polynomial).
    """
    c = _flat(c)
    nz = np.flatnonzero(c)
    return c[: nz[-1] + 1] if nz.size else c[:1] * 0.0


def poly_roots(c) -> np.ndarray:
    """Roots of one ascending-coefficient polynomial, sorted by magnitude then imaginary part.

    Parameters
    ----------
    c : array_like
        Ascending coefficients (``np.roots`` wants descending order; this does the reversal).

    Returns
    -------
    numpy.ndarray
        Complex roots (empty for a constant).
    """
    c = trim_high(c)
    if c.size <= 1:
        return np.zeros(0, dtype=complex)
    r = np.roots(c[::-1]).astype(complex)
    return r[np.lexsort((r.imag, np.abs(r)))]


def root_grid(*polys, per_decade: int = 400, span: float = 3.0) -> np.ndarray:
    """Log grid of ω [rad/s] covering every non-zero root magnitude of ``polys`` ± ``span`` decades
    (the frequency sets of the quasi-polynomial counts are :func:`exotune.numerics.quasipoly.log_grid`).

    Parameters
    ----------
    *polys : array_like
        Ascending-coefficient polynomials.
    per_decade : int
        Points per decade.
    span : float
        Decades below the smallest and above the largest root magnitude.

    Returns
    -------
    numpy.ndarray
        Angular frequencies [rad/s] (10⁻² … 10⁴ when no polynomial has a non-zero root).
    """
    mags = []
    for p in polys:
        r = np.abs(poly_roots(p))
        mags.extend(r[r > 0].tolist())
    if mags:
        lo, hi = math.log10(min(mags)) - span, math.log10(max(mags)) + span
    else:
        lo, hi = -2.0, 4.0
    return np.logspace(lo, hi, int((hi - lo) * per_decade) + 1)


def descending(c) -> np.ndarray:
    """Ascending coefficients (the kernels' order) → descending (numpy, scipy.signal,
    python-control, MATLAB), highest-power exact zeros dropped.

    Parameters
    ----------
    c : array_like
        Coefficients in ascending powers of s.

    Returns
    -------
    numpy.ndarray
        Coefficients in descending powers, 1-D float (at least one entry).

    Examples
    --------
    >>> descending([1.0, 2.0, 3.0]).tolist()   # 1 + 2 s + 3 s²
    [3.0, 2.0, 1.0]
    """
    c = np.asarray(c, dtype=float).ravel()
    nz = np.flatnonzero(c)
    c = c[: nz[-1] + 1] if nz.size else c[:1]
    return c[::-1].copy()


def ascending(d) -> np.ndarray:
    """Descending coefficients (numpy/python-control order) → ascending (the kernels' order).

    Parameters
    ----------
    d : array_like
        Coefficients in descending powers of s.

    Returns
    -------
    numpy.ndarray
        Coefficients in ascending powers, 1-D float.

    Examples
    --------
    >>> ascending([3.0, 2.0, 1.0]).tolist()
    [1.0, 2.0, 3.0]
    """
    return np.asarray(d, dtype=float).ravel()[::-1].copy()


def _member(a, index: int) -> np.ndarray:
    """Row ``index`` of a batch of coefficient vectors (a 1-D array or a batch of one: itself)."""
    a = np.asarray(a, dtype=float)
    if a.ndim == 1:
        return a
    rows = a.reshape(-1, a.shape[-1])
    return rows[index if rows.shape[0] > 1 else 0]


def is_hurwitz(coeffs) -> bool:
    """Whether every root of a real polynomial lies in Re s < 0, decided exactly: the Routh array
    in rational arithmetic on the floating-point coefficients as given (no tolerance). A root on
    the imaginary axis (a row of zeros in the array) or at infinity is not Hurwitz.

    Parameters
    ----------
    coeffs : array_like
        Ascending coefficients c_0 … c_d (float; trailing zeros are dropped).

    Returns
    -------
    bool
        True when all d roots have negative real part (a nonzero constant is Hurwitz).

    References
    ----------
    Routh (1877); Gantmacher, *The Theory of Matrices* II, ch. XV.

    Examples
    --------
    >>> is_hurwitz([1.0, 2.0, 1.0]), is_hurwitz([1.0, 1.0, 1.0, 1.0]), is_hurwitz([6.0, 11.0, 6.0, 1.0])
    (True, False, True)
    """
    from fractions import Fraction

    a = [Fraction(float(x)) for x in np.ravel(coeffs)]
    while len(a) > 1 and a[-1] == 0:
        a.pop()
    a = a[::-1]  # descending
    if a[0] < 0:
        a = [-x for x in a]
    if any(x <= 0 for x in a):  # a Hurwitz polynomial has every coefficient of one sign
        return False
    rows, r0, r1 = 1, a[0::2], a[1::2]
    while r1:
        if r1[0] <= 0:
            return False
        rows += 1
        r1p = r1 + [Fraction(0)] * (len(r0) - len(r1))
        nxt = [r0[i + 1] - r0[0] * r1p[i + 1] / r1[0] for i in range(len(r0) - 1)]
        while nxt and nxt[-1] == 0:
            nxt.pop()
        r0, r1 = r1, nxt
    return rows == len(a)  # a row of zeros before the last: roots on the imaginary axis
