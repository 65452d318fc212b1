"""Second opinion on the exact-delay verdicts by an independent root finder (docs/method.md#analyses-and-metrics).

docs/method.md#analyses-and-metrics: "count encirclements with the Nyquist criterion on an indented contour ... and
cross-check with closed-loop eigenvalues of a rational (Padé or sampled-data) model". For one
design, :func:`pade_crosscheck` looks for right-half-plane roots of every characteristic
quasi-polynomial Δ = P0 + P1 e^{−sT} of :mod:`exotune.analysis` that exotune reports a verdict for
(free cuff, output locked, every rational human family at its range ends and inside each
sub-interval between critical values): the roots of two Padé models (``control.pade``, orders 10
and 16: closed-loop eigenvalues of the rational model) and a line of seeds up to the radius beyond
which |P0| > |P1| are polished by Newton's method on the *exact* Δ. Padé roots alone are not
trusted: with ωT ≫ 1 a Padé model misses delay-induced roots that the exact function has.

* exotune stable and an exact RHP root found → ``disagreements`` (the critical direction);
* exotune unstable and no RHP root found → ``unconfirmed`` (the seeded search is not a proof);
* otherwise the verdicts agree.

This is a diagnostic: exotune's verdicts come from the exact argument principle.
"""

from __future__ import annotations

import numpy as np

from .batch import analyze_batch
from .charfun import char_terms, strip_qps, trim_poly
from ..model.controller import build_controller
from ..model.humans import family_split
from ..numerics.poly import pad_cols, padd, pmul
from ..numerics.quasipoly import QP, omega_max

__all__ = ["pade_crosscheck", "pade_stable", "pade_coefficients"]


def pade_coefficients(T: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The (n, n) Padé approximant of e^{−sT} as (num, den), ascending coefficients with den(0) = 1:
    den = Σ c_k (sT)^k, num = Σ (−1)^k c_k (sT)^k, c_k = (2n−k)! n! / ((2n)! k! (n−k)!) — the
    classic closed form (python-control's ``control.pade`` gives the same rational function; the
    tests compare them). Importing python-control only for this costs a second per process.

    Parameters
    ----------
    T : float
        The delay [s].
    n : int
        The approximant's order.

    Returns
    -------
    num, den : ndarray, shape (n + 1,)
        Ascending coefficients in s of the numerator and denominator.

    Examples
    --------
    >>> num, den = pade_coefficients(0.001, 1)   # (1 − sT/2)/(1 + sT/2)
    >>> num.tolist(), den.tolist()
    ([1.0, -0.0005], [1.0, 0.0005])
    """
    from math import factorial

    k = np.arange(n + 1)
    c = np.array([factorial(2 * n - j) * factorial(n) / (factorial(2 * n) * factorial(j) * factorial(n - j))
                  for j in k]) * float(T) ** k
    return c * (-1.0) ** k, c



def _roots_scaled(c: np.ndarray) -> np.ndarray:
    """Roots of an ascending-coefficient polynomial, computed in a scaled variable s = σ x."""
    c = np.trim_zeros(np.asarray(c, dtype=complex), "b")
    n = len(c) - 1
    if n < 1:
        return np.zeros(0, complex)
    mags = np.abs(c)
    nz = mags > 0
    k = np.nonzero(nz)[0]
    sigma = (mags[k[0]] / mags[-1]) ** (1.0 / max(n - k[0], 1)) if k.size else 1.0
    sigma = sigma if np.isfinite(sigma) and sigma > 0 else 1.0
    cs = c * sigma ** np.arange(n + 1)
    return np.roots(cs[::-1]) * sigma


def pade_stable(p0: np.ndarray, p1: np.ndarray, T: float, order: int, allowed_rigid: int = 1):
    """(stable, rightmost root) of P0 + P1·Padé_n(e^{−sT}) for one real quasi-polynomial.

    Parameters
    ----------
    p0, p1 : ndarray
        Ascending coefficients of P0 and P1.
    T : float
        The delay [s].
    order : int
        The Padé approximant's order.
    allowed_rigid : int
        Roots at s = 0 allowed (1: the free exoskeleton's rigid-body root).

    Returns
    -------
    stable : bool
        Every root of the rational model in the open left half-plane, besides the allowed s = 0 roots.
    rightmost : complex
        Its root of largest real part [rad/s] (−inf without roots).
    """
    q = QP(np.atleast_2d(p0), np.atleast_2d(p1), np.array([T]))
    r, (qs,) = strip_qps(q)
    roots = _pade_roots(qs.p0[0], qs.p1[0], T, order)
    right = roots[np.argmax(roots.real)] if roots.size else complex(-np.inf)
    return bool((right.real < 0) and (r[0] <= allowed_rigid)), right


#: Below this delay [s] the Padé model is the undelayed polynomial: its poles (≈ order/T) would lie
#: beyond 10¹³ rad/s, and for T → 0 its coefficients underflow (1e-300 s gave NaN roots).
PADE_MIN_DELAY_S = 1e-12


def _pade_roots(p0, p1, T, order):
    if T >= PADE_MIN_DELAY_S:
        num, den = pade_coefficients(T, order)
        poly = padd(pmul(p0, den), pmul(p1, num))
    else:
        poly = padd(p0, p1)
    return _roots_scaled(poly)


def _polyvals(C: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Every row of ``C`` (ascending coefficients) at the points ``x``: numpy's ``polyval``
    recurrence, in one pass for all rows. The zero padding at the top of a shorter row adds exact
    zeros until its own leading coefficient, so each row's value is ``polyval``'s, bit for bit."""
    n = C.shape[1]
    c0 = C[:, -1:] + x * 0
    for i in range(2, n + 1):
        c0 = C[:, n - i:n - i + 1] + c0 * x
    return c0


def exact_rhp_roots(p0: np.ndarray, p1: np.ndarray, T: float, orders=(10, 16), n_seeds: int = 600) -> np.ndarray:
    """Right-half-plane roots of the exact Δ = P0 + P1 e^{−sT} found by Newton's method (an
    independent root finder, not the argument principle), seeded with the Padé models' roots and a
    log-spaced line of points Re s = 0.05·Im s up to the radius R beyond which |P0| > |P1|.

    Returns the distinct converged roots with Re s > 0 (an empty array proves nothing by itself).
    """
    P = np.polynomial.polynomial
    R = float(omega_max(np.atleast_2d(p0), np.atleast_2d(p1))[0]) if T > 0 else 0.0
    seeds = [_pade_roots(p0, p1, T, n) for n in orders]
    if T > 0 and np.isfinite(R):
        im = np.geomspace(1e-2, max(R, 1.0), n_seeds)
        seeds.append(0.05 * im + 1j * im)
    s = np.concatenate(seeds)
    s = s[np.isfinite(s)]
    d0, d1 = P.polyder(p0), P.polyder(p1)
    n = max(len(p0), len(p1))  # the four polynomials as the rows of one array, zero-padded at the top
    C = np.stack([pad_cols(np.asarray(c, dtype=np.result_type(c, float)), n) for c in (p0, p1, d0, d1)])
    with np.errstate(all="ignore"):
        for _ in range(80):
            e = np.exp(-s * T)
            v0, v1, v2, v3 = _polyvals(C, s)
            F = v0 + v1 * e
            dF = v2 + (v3 - T * v1) * e
            s = s - F / dF
        e = np.exp(-s * T)
        F = P.polyval(s, p0) + P.polyval(s, p1) * e
        scale = P.polyval(np.abs(s), np.abs(p0)) + P.polyval(np.abs(s), np.abs(p1)) * np.abs(e)
        ok = np.isfinite(s) & (np.abs(F) <= 1e-9 * scale) & (s.real > 1e-9 * np.abs(s))
    roots = s[ok]
    out = []
    for z in roots[np.argsort(-roots.real)]:
        if all(abs(z - w) > 1e-6 * max(abs(z), 1.0) for w in out):
            out.append(z)
    return np.asarray(out, complex)


def pade_crosscheck(cfg, orders=(10, 16)) -> dict:
    """Compare exotune's verdicts (exact delay) for one design with two Padé models (module docstring).

    Parameters
    ----------
    cfg : DesignConfig
        One design.
    orders : tuple of int
        The Padé orders of the rational models.

    Returns
    -------
    dict
        ``pade_orders``, ``checked`` and ``agree`` (numbers of cases), ``unconfirmed`` (labels of
        the cases exotune calls unstable without an RHP root found) and ``disagreements`` (cases
        exotune calls stable, with the exact RHP root found, ``re``/``im`` [rad/s]).

    References
    ----------
    docs/method.md#second-opinions.
    """
    res = analyze_batch(cfg)
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    ct = char_terms(cfg.plant, cs, 1)
    T = float(np.asarray(cfg.implementation.delay_s))
    cases = []  # (label, p0, p1, allowed_rigid, exotune verdict)
    q00, q01 = ct.qp("00"), ct.qp("01")
    cases.append(("free cuff", q00.p0[0], q00.p1[0], 1, bool(res.free.stable[0])))
    cases.append(("output locked", q01.p0[0], q01.p1[0], 0, bool(res.locked.stable[0])))
    for i, (fam, h) in enumerate(zip(cfg.humans, res.humans)):
        if fam.kind == "complex_stiffness" or fam.box:
            continue  # not rational / a box (its edges' verdicts are not listed per point)
        ivs = h.stable_intervals[0]
        crit = sorted(p for p, _ in h.critical[0])
        edges = [fam.lo] + [p for p in crit if fam.lo < p < fam.hi] + [fam.hi]
        pts = set([fam.lo, fam.hi])
        for a, b in zip(edges[:-1], edges[1:]):
            pts.add(float(np.sqrt(a * b)) if a > 0 else 0.5 * (a + b))
        z0, phi, _ = family_split(fam.kind, fam.param, fam.fixed(), fam.eta)
        D0, D1 = ct.combine("00", "10", z0)
        for p in sorted(pts):
            if any(abs(p - e) <= 1e-9 * max(abs(e), 1e-300) for e in crit):
                continue
            p0 = padd(D0.p0[0], p * pmul(D1.p0[0], phi))
            p1 = padd(D0.p1[0], p * pmul(D1.p1[0], phi))
            verdict = any(a <= p <= b for a, b in ivs)
            cases.append((f"human{i} {fam.kind} {fam.param} = {p:.6g} {fam.unit}", trim_poly(p0[None])[0], trim_poly(p1[None])[0], 1, verdict))
    out = {"pade_orders": list(orders), "checked": 0, "agree": 0, "unconfirmed": [], "disagreements": []}
    for label, p0, p1, allowed, verdict in cases:
        q = QP(np.atleast_2d(p0), np.atleast_2d(p1), np.array([T]))
        r, (qs,) = strip_qps(q)
        rhp = exact_rhp_roots(qs.p0[0], qs.p1[0], T, orders)
        second = bool(rhp.size == 0 and r[0] <= allowed)
        out["checked"] += 1
        if second == verdict:
            out["agree"] += 1
        elif verdict and not second:
            # an RHP root of the exact Δ exists where exotune says stable: the critical direction
            z = rhp[0] if rhp.size else 0j
            out["disagreements"].append({"case": label, "exotune_stable": True, "rhp_root": {"re": float(z.real), "im": float(z.imag)}})
        else:
            # exotune counts RHP roots that the seeded Newton search did not reach: not a proof of
            # either, listed for information
            out["unconfirmed"].append(label)
    return out
