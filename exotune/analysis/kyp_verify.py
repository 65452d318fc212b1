"""Independent, a-posteriori checks of a KYP passivity certificate: the SDP solver is not trusted.

Two checks, either of which makes a "passive" verdict *verified*
(docs/method.md#guarantees):

``lmi_holds``       the solver's P, as returned (rounded to floating point), is put back into the
                    KYP LMI at d = 0 in numpy; the largest eigenvalue of the LMI matrix must lie
                    below −δ, δ a bound on the rounding of forming the matrix and of the symmetric
                    eigenvalue solver (ten times the standard bounds). A strictly negative definite
                    LMI at d = 0 is a proof that Re Y(jω) > 0 for the realization (A, B, C, q0).
``positive_on_axis`` exact rational arithmetic (``fractions``) on the transfer function's own
                    floating-point coefficients: the denominator is Hurwitz (Routh array), and
                    p(x) = Re[num(jω) · conj(den(jω))], x = ω², has p(0) > 0, a positive leading
                    coefficient and no root in (0, ∞) (Sturm sequence). Then Re Y(jω) > 0 for every
                    finite ω and Y is positive real. Needed when the LMI cannot be strict (a strictly
                    proper Y whose real part tends to 0, where the LMI's corner is 0).

Both are proofs about the model as computed in floating point (its coefficients' own rounding
from the design numbers, about 1e−15 relative, is not propagated). A model that is passive only
with equality somewhere (Re Y touching 0) is verified by neither; its verdict stays unverified.

References
----------
Paper §IV-A, Fig. 5 (the passive phase region); docs/method.md#guarantees.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np

from ..numerics.poly import is_hurwitz

__all__ = ["lmi_holds", "positive_on_axis", "SAFETY"]

SAFETY = 10.0  # factor on the rounding bounds of lmi_holds


def lmi_holds(A, B, C, q0: float, P, d: float = 0.0) -> tuple[bool, float, float]:
    """Whether the KYP LMI [[AᵀP + PA, PB − Cᵀ], [BᵀP − C, −2(q0 + d)]] is negative definite with a
    margin above rounding, for the given (floating-point) P.

    Parameters
    ----------
    A, B, C : ndarray
        The realization of the strictly proper part Y_p (n×n, n×1, 1×n).
    q0 : float
        The constant part of Y.
    P : ndarray
        The certificate (n×n; symmetrized here).
    d : float
        The shift tested (0 proves Re Y ≥ 0, i.e. passivity).

    Returns
    -------
    tuple
        ``(ok, lambda_max, bound)``: ``ok`` when λ_max(LMI) ≤ −bound, the bound being SAFETY times
        (n + 1)·ε·(2‖A‖_F‖P‖_F (n + 1) + ‖P‖_F‖B‖_F + ‖C‖_F + 2|q0 + d| + ‖LMI‖_F).
    """
    A, B, C = np.asarray(A, float), np.asarray(B, float).reshape(-1, 1), np.asarray(C, float).reshape(1, -1)
    P = 0.5 * (np.asarray(P, float) + np.asarray(P, float).T)
    n = A.shape[0]
    off = P @ B - C.T
    M = np.block([[A.T @ P + P @ A, off], [off.T, np.array([[-2.0 * (q0 + d)]])]])
    M = 0.5 * (M + M.T)
    if not np.all(np.isfinite(M)):
        return False, float("nan"), float("nan")
    lam = float(np.linalg.eigvalsh(M)[-1])
    fro = np.linalg.norm
    eps = np.finfo(float).eps
    bound = SAFETY * (n + 1) * eps * (2.0 * fro(A) * fro(P) * (n + 1) + fro(P) * fro(B) + fro(C)
                                      + 2.0 * abs(q0 + d) + fro(M))
    return bool(lam <= -bound), lam, float(bound)


def _frac(c) -> list[Fraction]:
    """Ascending float coefficients → exact Fractions, trailing (highest-power) zeros removed."""
    out = [Fraction(float(x)) for x in np.ravel(c)]
    while len(out) > 1 and out[-1] == 0:
        out.pop()
    return out


def _pmul(a, b):
    out = [Fraction(0)] * (len(a) + len(b) - 1)
    for i, x in enumerate(a):
        if x:
            for j, y in enumerate(b):
                out[i + j] += x * y
    return out


def _prem(a, b):
    """Remainder of a / b (ascending coefficients)."""
    a = list(a)
    while len(a) >= len(b) and any(a):
        f = a[-1] / b[-1]
        k = len(a) - len(b)
        for i, y in enumerate(b):
            a[k + i] -= f * y
        a.pop()
    while len(a) > 1 and a[-1] == 0:
        a.pop()
    return a


def _sign_changes(vals) -> int:
    s = [v for v in vals if v != 0]
    return sum(1 for x, y in zip(s, s[1:]) if (x > 0) != (y > 0))


def _roots_in_open_positive(p: list[Fraction]) -> int:
    """Distinct real roots of p in (0, ∞) by Sturm's theorem (p(0) ≠ 0)."""
    dp = [i * c for i, c in enumerate(p)][1:]
    seq = [p, dp]
    while len(seq[-1]) > 1:
        r = _prem(seq[-2], seq[-1])
        if not any(r):
            break
        seq.append([-x for x in r])
    at0 = [q[0] for q in seq]
    at_inf = [q[-1] for q in seq]
    return _sign_changes(at0) - _sign_changes(at_inf)


def positive_on_axis(num, den) -> tuple[bool, str]:
    """Exact proof that Y = num/den (ascending float coefficients) is positive real with
    Re Y(jω) > 0 at every finite ω ≥ 0.

    Parameters
    ----------
    num, den : sequence of float
        Ascending coefficients of Y's numerator and denominator (converted to exact fractions).

    Returns
    -------
    tuple
        ``(ok, why)``: ``ok`` only when the proof goes through; ``why`` says which step failed.
    """
    n, d = _frac(num), _frac(den)
    if not any(d):
        return False, "zero denominator"
    if not is_hurwitz([float(x) for x in d]):
        return False, "the denominator is not Hurwitz (exact Routh test)"
    # num(jω) = Σ n_k j^k ω^k; Re[num conj(den)] = E_n E_d + O_n O_d in x = ω², where
    # num(jω) = E_n(x) + jω O_n(x) with E_n = Σ n_2k (−x)^k, O_n = Σ n_2k+1 (−x)^k
    def parts(c):
        ev = [c[k] * (-1) ** (k // 2) for k in range(0, len(c), 2)]
        od = [c[k] * (-1) ** (k // 2) for k in range(1, len(c), 2)] or [Fraction(0)]
        return ev, od
    en, on = parts(n)
    ed, od = parts(d)
    a, b = _pmul(en, ed), _pmul(_pmul(on, od), [Fraction(0), Fraction(1)])  # O_n O_d ω² = O_n O_d x
    p = [Fraction(0)] * max(len(a), len(b))
    for i, v in enumerate(a):
        p[i] += v
    for i, v in enumerate(b):
        p[i] += v
    while len(p) > 1 and p[-1] == 0:
        p.pop()
    if p[0] <= 0:
        return False, "Re Y(0) ≤ 0"
    if p[-1] <= 0:
        return False, "Re Y(jω) is not positive at high frequency"
    if len(p) > 1 and _roots_in_open_positive(p) > 0:
        return False, "Re Y(jω) has a real zero crossing or touching point (Sturm count)"
    return True, "Re Y(jω) > 0 for every ω ≥ 0 and the denominator is Hurwitz (exact rational arithmetic)"
