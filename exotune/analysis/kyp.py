"""Passivity certificates of the rational operator-side compliance by the KYP lemma (an SDP, Clarabel).

Paper §IV-A "Passivity of the Operator Compliance": "while the nominal operator compliance can be
made passive, the phase lag in the cuff feedback signal make it impractical to actually achieve
this". docs/method.md#analyses-and-metrics defines passivity of C7 as Re{jω C7(jω)} ≥ 0 for all ω, i.e. the operator-side
*admittance* Y(s) = s·C7(s) is positive real; docs/controller-file.md names "passivity/KYP certificates of the
rational model" as the convex sub-problem. This module computes that certificate for the
two rational models of a design:

``nominal``     the paper's nominal C7 (eq. (16), zero delay, no filters, no DOB);
``delay_free``  the implemented controller structure (G_v and derivative filters, DOB) with T = 0,
                C7 = Δ10/Δ00 of :mod:`exotune.analysis` at e^{−sT} = 1.

With the real delay C7 is not rational; the exact frequency-domain metric
(``passivity.max_phase_excess_deg``) covers that case, and the certificate is *not* a claim about it.

Method, for Y = s·C = q1 s + q0 + Y_p(s) (Y_p strictly proper, q1 s the lossless cuff-spring term,
q1 = 1/K_c for C7):

1. Y is positive real iff q1 ≥ 0, Y_p has no pole in Re s ≥ 0 (here: none on the axis either —
   the rigid-body pole of C7 at s = 0 is cancelled by the s of Y exactly), and
   Re Y(jω) = q0 + Re Y_p(jω) ≥ 0 for every ω.
2. KYP lemma (A Hurwitz, (A, B) controllable): Re[Y_p(jω)] + q0 + d ≥ 0 ∀ω ⇔ ∃ P = Pᵀ with

       [ AᵀP + PA    PB − Cᵀ      ]
       [ BᵀP − C    −2 (q0 + d)   ]  ⪯ 0.

   The smallest such d is the *passivity shortage* d* = max(0, −inf_ω Re Y(jω)) [rad/(N·m·s)]:
   a semidefinite program (minimize d), posed directly to the interior-point solver Clarabel (what
   cvxpy would hand it, without cvxpy's import cost; cvxpy with SCS as fallback). d* = 0 ⇔
   passive; d* > 0 is the admittance the compliance lacks: a damper of damping 1/d* in series with
   the cuff would make it passive (admittances add in series, paper Proposition 2).
3. Conditioning: the frequency is scaled (s = ω0 ŝ, ω0 the geometric mean of the pole magnitudes),
   Y_p is realized (:func:`exotune.numerics.statespace.tf2ss`, scipy's controllable canonical
   form) and balanced (square-root method from the two Gramians); Hankel singular values below
   1e−12 of the largest are truncated and the truncation bound 2 Σ σ_dropped is reported and added
   to the verdict's tolerance.
4. The returned P is checked independently in numpy: the largest eigenvalue of the LMI matrix at
   (P, d*) relative to its norm is the ``certificate_residual``.

The verdict is ``passive`` when d* ≤ ``tol`` · σ1 + truncation bound, σ1 the largest Hankel singular
value of Y_p (a lower bound of its H∞ norm): the solver's accuracy is about 1e−8 relative.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from ..numerics.statespace import tf2ss
from .kyp_verify import lmi_holds, positive_on_axis

__all__ = ["KypCertificate", "admittance_certificate", "compliance_certificate", "operator_certificates",
           "certificates_dict", "nominal_shortage", "realization_error", "SHORTAGE_UNIT"]

SHORTAGE_UNIT = "rad/(N·m·s)"  # admittance: angular velocity per torque
LOSSLESS_UNIT = "rad/(N·m)"  # compliance of the lossless spring-like term q1·s of Y
TOL = 1e-6


@dataclass(frozen=True)
class KypCertificate:
    """Result of :func:`admittance_certificate` (one rational model)."""

    model: str
    passive: bool | None  # None: undecided (poles on the axis, solver failure)
    shortage: float  # d* [rad/(N·m·s)]; inf when improper with a non-passive polynomial part
    relative_shortage: float  # d* / σ1 (dimensionless)
    lossless_compliance: float  # q1 [rad/(N·m)]
    states: int  # order of the balanced realization of Y_p
    truncation_bound: float  # 2 Σ dropped Hankel singular values [rad/(N·m·s)]
    certificate_residual: float  # λ_max(LMI(P, d*)) / ‖LMI‖ (≈ 0 for a valid certificate)
    solver: str
    reason: str
    shortage_upper: float = float("nan")  # the SDP's d* (an upper bound: the LMI holds at it)
    witness_frequency_hz: float = float("nan")  # where Re Y(jω) = −shortage (the non-passive proof)
    verified: bool = False  # a passive verdict checked without the solver (kyp_verify); False otherwise
    verification: str = ""  # how it was checked, or why the check did not go through

    def as_dict(self) -> dict:
        return {
            "model": self.model,
            "passive": self.passive,
            "shortage": self.shortage,
            "shortage_unit": SHORTAGE_UNIT,
            "relative_shortage": self.relative_shortage,
            "lossless_compliance": self.lossless_compliance,
            "lossless_compliance_unit": LOSSLESS_UNIT,
            "states": self.states,
            "truncation_bound": self.truncation_bound,
            "certificate_residual": self.certificate_residual,
            "shortage_upper": self.shortage_upper,
            "witness_frequency_hz": self.witness_frequency_hz,
            "verified": self.verified,
            "verification": self.verification,
            "solver": self.solver,
            "method": "KYP lemma: min d s.t. [[AᵀP+PA, PB−Cᵀ], [BᵀP−C, −2(q0+d)]] ⪯ 0 (SDP, Clarabel): "
                      "passive when d* ≈ 0 and verified without the solver (the LMI at d = 0 strictly "
                      "negative for the returned P, or Re Y > 0 proven in exact arithmetic); otherwise shortage = −Re{jω C7(jω)} at a witness frequency "
                      "(refined minimum, a proof of non-passivity), bracketed above by d*",
            "reason": self.reason,
        }


def _trim(c: np.ndarray) -> np.ndarray:
    c = np.asarray(c, dtype=float)
    nz = np.nonzero(c)[0]
    return c[: nz[-1] + 1] if nz.size else np.zeros(1)


def _balanced(A, B, C):
    """Square-root balanced realization; returns (A, B, C, hsv_kept, truncation_bound,
    gramians_ill_conditioned)."""
    import scipy.linalg as sla

    # scipy warns when two poles nearly cancel in λ_i + λ_j (poles decades apart, e.g. a filter
    # cutoff far above the plant): the Gramians are then ill-conditioned, but the balanced
    # realization stays an exact similarity transform (Ti·Tm = I by construction) and the
    # certificate is re-checked on it, so the warning is recorded, not printed
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", RuntimeWarning)
        Wc = sla.solve_continuous_lyapunov(A, -B @ B.T)
        Wo = sla.solve_continuous_lyapunov(A.T, -C.T @ C)
    ill = any(issubclass(w.category, RuntimeWarning) for w in caught)

    def factor(W):
        e, V = np.linalg.eigh(0.5 * (W + W.T))
        return V * np.sqrt(np.clip(e, 0.0, None))

    Lc, Lo = factor(Wc), factor(Wo)
    U, S, Vt = np.linalg.svd(Lo.T @ Lc)
    keep = S > 1e-12 * S[0] if S.size and S[0] > 0 else np.zeros(S.size, bool)
    bound = 2.0 * float(S[~keep].sum())
    U, Sk, V = U[:, keep], S[keep], Vt[keep].T
    Tm = Lc @ V / np.sqrt(Sk)
    Ti = (U / np.sqrt(Sk)).T @ Lo.T
    return Ti @ A @ Tm, Ti @ B, C @ Tm, Sk, bound, ill


def _test_frequencies(poles, n: int) -> np.ndarray:
    """A log grid of n frequencies two decades beyond the range of the pole magnitudes, plus
    those magnitudes (where resonances peak)."""
    mags = np.abs(poles[np.abs(poles) > 0])
    lo, hi = (mags.min(), mags.max()) if mags.size else (1.0, 1.0)
    return np.unique(np.r_[np.geomspace(lo / 100.0, hi * 100.0, n), mags])


def realization_error(A, B, C, num_desc, den_desc, poles) -> float:
    """Relative error of a state-space realization against its transfer function.

    sup over test frequencies of |C(jωI − A)⁻¹B − num/den(jω)| / sup |num/den(jω)|: an
    independent check (transfer-function values, not Gramians) that the realization handed to the
    SDP is the model. Test frequencies: a log grid two decades beyond the poles' range, and the
    pole magnitudes (where resonances peak).

    Parameters
    ----------
    A, B, C : ndarray
        The realization (n×n, n×1, 1×n).
    num_desc, den_desc : ndarray
        The strictly proper transfer function, descending coefficients.
    poles : ndarray
        Its poles (they place the test frequencies).

    Returns
    -------
    float
        The relative error (inf when the transfer function vanishes or is not finite).

    References
    ----------
    Paper §IV-A; docs/method.md#passivity-of-the-operator-compliance.
    """
    s = 1j * _test_frequencies(poles, 400)
    ref = np.polyval(num_desc, s) / np.polyval(den_desc, s)
    n = A.shape[0]
    got = np.array([(C @ np.linalg.solve(si * np.eye(n) - A, B)).item() for si in s])
    scale = float(np.max(np.abs(ref)))
    if not np.isfinite(scale) or scale == 0.0:
        return float("inf")
    return float(np.max(np.abs(got - ref)) / scale)


def _witness(num_desc, den_desc, q0, poles):
    """(ω̂*, min Re Y(jω̂*)) of Y = q0 + num/den (its real part; the lossless q1·s adds none; ω̂* = ∞
    when the infimum is the limit q0 at high frequency): a log
    grid two decades beyond the poles' range plus the pole magnitudes, then a bounded refinement
    (log ω) around the smallest value. A frequency-domain *witness*: Re Y(jω̂*) < 0 proves Y not
    positive real, and −Re Y(jω̂*) is a lower bound on the shortage (tight at the refined minimum)."""
    import scipy.optimize

    w = _test_frequencies(poles, 4000)
    re = lambda x: q0 + np.real(np.polyval(num_desc, 1j * x) / np.polyval(den_desc, 1j * x))  # noqa: E731
    v = re(w)
    k = int(np.nanargmin(v))
    a, b = math.log(w[max(k - 1, 0)]), math.log(w[min(k + 1, w.size - 1)])
    r = scipy.optimize.minimize_scalar(lambda x: float(re(math.exp(x))), bounds=(a, b), method="bounded",
                                       options={"xatol": 1e-12})
    best = (math.exp(r.x), float(r.fun)) if r.success and r.fun < v[k] else (float(w[k]), float(v[k]))
    if q0 <= best[1]:  # Re Y → q0 as ω → ∞ (Y_p strictly proper): the infimum is at infinity
        return math.inf, float(q0)
    return best


def _svec(S: np.ndarray) -> np.ndarray:
    """The scaled upper triangle of a symmetric matrix, column by column (Clarabel's
    ``PSDTriangleConeT`` vectorization: off-diagonal entries times √2, so that the inner product
    of two vectorized matrices is the trace inner product)."""
    i, j = np.triu_indices(S.shape[0])
    order = np.lexsort((i, j))  # column-major: j, then i ≤ j
    i, j = i[order], j[order]
    return S[i, j] * np.where(i == j, 1.0, math.sqrt(2.0))


def _solve_kyp_clarabel(A, B, C, q0):
    """:func:`_solve_kyp` posed directly to Clarabel (the interior-point solver cvxpy would call):
    the LMI −M(P, d) ⪰ 0 is affine in x = (the upper triangle of P, d), so its constraint is
    s = b − Gx ∈ PSD with b the vectorized −M(0, 0) and G's columns the vectorized M of each unit
    variable. Importing cvxpy (and through it ``scipy.stats``) takes about 1.8 s of every
    ``exotune analyze``; Clarabel takes milliseconds. None when Clarabel is not installed or does
    not solve the problem (the caller then asks cvxpy)."""
    try:
        import clarabel
        import scipy.sparse as sp
    except ImportError:  # pragma: no cover - clarabel comes with cvxpy
        return None
    n = A.shape[0]
    m = n + 1

    def lmi(Pm, d):  # M(P, d) of the module docstring, without its constant part
        off = (Pm @ B).reshape(n, 1)
        return np.block([[A.T @ Pm + Pm @ A, off], [off.T, np.array([[-2.0 * d]])]])

    iu, ju = np.triu_indices(n)
    cols = []
    for i, j in zip(iu, ju):
        E = np.zeros((n, n))
        E[i, j] = E[j, i] = 1.0
        cols.append(_svec(lmi(E, 0.0)))
    cols.append(_svec(lmi(np.zeros((n, n)), 1.0)))
    G = sp.csc_matrix(np.column_stack(cols))  # s = b − G x = svec(−M(P, d))
    c = np.reshape(C, (1, n))
    M0 = np.block([[np.zeros((n, n)), -c.T], [-c, np.array([[-2.0 * q0]])]])
    b = -_svec(M0)
    nx = iu.size + 1
    q = np.zeros(nx)
    q[-1] = 1.0
    if not (np.all(np.isfinite(G.data)) and np.all(np.isfinite(b))):
        return None
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    try:
        sol = clarabel.DefaultSolver(sp.csc_matrix((nx, nx)), q, G, b, [clarabel.PSDTriangleConeT(m)], settings).solve()
    except Exception:  # noqa: BLE001 - whatever the solver raises, the cvxpy path decides
        return None
    status = {"Solved": "optimal", "AlmostSolved": "optimal_inaccurate"}.get(str(sol.status).split(".")[-1])
    x = np.asarray(sol.x, dtype=float)
    if status is None or x.size != nx or not np.all(np.isfinite(x)):
        return None
    Pm = np.zeros((n, n))
    Pm[iu, ju] = x[:-1]
    Pm[ju, iu] = x[:-1]
    return float(x[-1]), Pm, "CLARABEL", status


def _solve_kyp(A, B, C, q0):
    """min d s.t. the KYP LMI; returns (d*, P, solver name, status): Clarabel called directly
    (:func:`_solve_kyp_clarabel`), else cvxpy with Clarabel, then SCS (the fallback for a problem
    Clarabel does not solve)."""
    direct = _solve_kyp_clarabel(A, B, C, q0)
    if direct is not None:
        return direct
    import cvxpy as cp

    n = A.shape[0]
    P = cp.Variable((n, n), symmetric=True)
    d = cp.Variable()
    off = P @ B - C.T
    corner = cp.reshape(-2.0 * (q0 + d), (1, 1), order="C")
    M = cp.bmat([[A.T @ P + P @ A, off], [off.T, corner]])
    prob = cp.Problem(cp.Minimize(d), [0.5 * (M + M.T) << 0])
    last = "no solver"
    for solver in ("CLARABEL", "SCS"):
        if solver not in cp.installed_solvers():
            continue
        try:
            prob.solve(solver=solver)
        except Exception as e:  # noqa: BLE001 - cvxpy's SolverError or the solver's own error: try the next
            last = f"{solver}: {e}"
            continue
        if prob.status in ("optimal", "optimal_inaccurate") and d.value is not None:
            return float(d.value), np.asarray(P.value), solver, prob.status
        last = f"{solver}: {prob.status}"
    return float("nan"), None, last, "failed"


def _polynomial_only(q0: float, tol: float, reason: str, base: dict) -> KypCertificate:
    """Y = q1 s + q0 (q1 ≥ 0 checked by the caller): passive iff q0 ≥ 0."""
    d_ = max(0.0, -q0)
    return KypCertificate(passive=d_ <= tol * max(abs(q0), 1e-300), shortage=d_,
                          relative_shortage=d_ / max(abs(q0), 1e-300), reason=reason, **base)


def admittance_certificate(num, den, model: str = "", tol: float = TOL) -> KypCertificate:
    """Positive-realness certificate of one rational admittance Y = num/den (ascending coefficients).

    See the module docstring for the method. Poles of Y in the closed right half plane make Y not
    positive real (``passive`` False, shortage NaN) or, on the axis, undecided (None).

    One function (over 80 lines): the steps 1–4 of the module docstring in order, each ending in an
    early return with its verdict.

    Parameters
    ----------
    num, den : array_like
        Ascending coefficients of Y's numerator and denominator.
    model : str
        The model's name, carried into the certificate.
    tol : float
        Relative tolerance on the shortage (against the largest Hankel singular value).

    Returns
    -------
    KypCertificate
        ``passive`` (True, False or None: undecided), the shortage [rad/(N·m·s)] and why.

    Raises
    ------
    ValueError
        When the denominator is zero.
    ImportError
        When the SDP is needed and Clarabel does not solve it and cvxpy is missing.

    References
    ----------
    Paper §IV-A (passivity of the operator compliance); docs/method.md#passivity-of-the-operator-compliance.
    """
    num, den = _trim(num), _trim(den)
    if not np.any(den):
        raise ValueError("zero denominator")
    # exact common zeros at s = 0 (e.g. the s of Y against the rigid-body pole of C)
    while num.size > 1 and den.size > 1 and num[0] == 0.0 and den[0] == 0.0:
        num, den = num[1:], den[1:]
    nd = den.size - 1
    nz = np.nonzero(den)[0]
    # frequency scaling s = w0·ŝ: w0 the geometric mean of the pole magnitudes
    w0 = (abs(den[nz[0]]) / abs(den[-1])) ** (1.0 / max(nd - nz[0], 1)) if nd > 0 else 1.0
    if not np.isfinite(w0) or w0 <= 0:
        w0 = 1.0
    kn, kd = w0 ** np.arange(num.size), w0 ** np.arange(den.size)
    lead = den[-1]
    nS, dS = num * kn / lead, den * kd / lead  # Ŷ(ŝ) = Y(w0 ŝ)
    q, r = np.polydiv(nS[::-1], dS[::-1])  # descending
    q = np.trim_zeros(q, "f")
    q1 = float(q[-2]) / w0 if q.size >= 2 else 0.0  # Y ~ q1 s in original units
    q0 = float(q[-1]) if q.size >= 1 else 0.0
    base = dict(model=model, lossless_compliance=q1, states=0, truncation_bound=0.0,
                certificate_residual=float("nan"), solver="")
    if q.size > 2:
        return KypCertificate(passive=False, shortage=float("inf"), relative_shortage=float("inf"),
                              reason=f"Y = s·C grows like s^{q.size - 1}: not positive real", **base)
    if q1 < 0:
        return KypCertificate(passive=False, shortage=float("inf"), relative_shortage=float("inf"),
                              reason="the lossless term q1·s of Y has q1 < 0: not positive real", **base)
    poles = np.roots(dS[::-1]) * w0
    r = np.atleast_1d(r)
    lead_r = np.nonzero(np.abs(r) > 1e-13 * np.max(np.abs(r), initial=0.0))[0]
    r = r[lead_r[0]:] if lead_r.size else np.zeros(0)  # drop the rounding residue of polydiv
    if r.size == 0 or not np.any(r):  # Y = q1 s + q0
        return _polynomial_only(q0, tol, "no strictly proper part", base)
    if np.any(poles.real > 0):
        return KypCertificate(passive=False, shortage=float("nan"), relative_shortage=float("nan"),
                              reason="Y has poles in the right half plane (the loop is unstable): not positive real", **base)
    if np.any(poles.real >= -1e-12 * np.maximum(np.abs(poles), 1.0)):
        return KypCertificate(passive=None, shortage=float("nan"), relative_shortage=float("nan"),
                              reason="Y has poles on the imaginary axis (besides the cancelled rigid-body pole): "
                                     "not decided by this certificate", **base)
    A, B, C, _ = tf2ss(r, dS[::-1])  # not scipy.signal's: importing it takes a second
    Ab, Bb, Cb, hsv, bound, ill = _balanced(A, B, C)
    if hsv.size == 0:  # Y_p vanishes numerically: Y = q1 s + q0
        return _polynomial_only(q0, tol, "the strictly proper part vanishes numerically", base)
    fit = realization_error(Ab, Bb, Cb, r, dS[::-1], poles / w0)
    if not fit <= 1e-6:
        # the (balanced, truncated) state space does not reproduce Y_p: coefficients decades
        # apart (e.g. a filter cutoff far above the plant) make the polynomial-to-state-space
        # step inexact, and a certificate of the wrong system would be a wrong verdict
        return KypCertificate(passive=None, shortage=float("nan"), relative_shortage=float("nan"),
                              reason=f"ill-conditioned model: its state-space realization misses Y_p by {fit:.1e} "
                                     "(relative) — not decided by this certificate; the frequency metric stands"
                                     + ("; ill-conditioned Gramians (poles decades apart)" if ill else ""),
                              **base)
    s1 = float(hsv[0])
    g = 1.0 / s1  # normalize ‖Ŷ_p‖ to about 1: the SDP works on g·Y
    d, P, solver, status = _solve_kyp(Ab, Bb * np.sqrt(g), Cb * np.sqrt(g), g * q0)
    base.update(states=int(Ab.shape[0]), truncation_bound=bound, solver=solver)
    if P is None:
        return KypCertificate(passive=None, shortage=float("nan"), relative_shortage=float("nan"),
                              reason=f"SDP not solved ({solver})", **base)
    # independent check of the certificate (numpy): the LMI at (P, d*)
    Bg, Cg = Bb * np.sqrt(g), Cb * np.sqrt(g)
    off = P @ Bg - Cg.T
    M = np.block([[Ab.T @ P + P @ Ab, off], [off.T, np.array([[-2.0 * (g * q0 + d)]])]])
    M = 0.5 * (M + M.T)
    resid = float(np.linalg.eigvalsh(M)[-1] / max(np.linalg.norm(M, 2), 1e-300))
    upper = max(0.0, d / g)
    w_hat, re_min = _witness(r, dS[::-1], q0, poles / w0)
    lower = max(0.0, -re_min)
    thr = tol * s1 + bound
    base.update(certificate_residual=resid, shortage_upper=upper)
    note = "; ill-conditioned Gramians (poles decades apart): truncation bound approximate" if ill else ""
    if upper <= thr and lower <= thr:  # the solver says passive: believe it only once verified
        ok, how = _verify_passive(Ab, Bg, Cg, g * q0, P, num, den)
        if ok:
            return KypCertificate(passive=True, shortage=0.0, relative_shortage=0.0, verified=True,
                                  verification=how,
                                  reason=f"positive real: KYP certificate ({status}) verified without the solver: "
                                         f"{how}{note}", **base)
        return KypCertificate(passive=None, shortage=float("nan"), relative_shortage=float("nan"),
                              verification=how,
                              reason=f"the SDP reports passive (d* = {upper:.2g}, {status}) but its answer was not "
                                     f"verified ({how}): not decided by this certificate; the frequency metric "
                                     f"stands{note}", **base)
    if lower > thr:  # proof by a frequency witness; the SDP brackets it from above
        base.update(witness_frequency_hz=w_hat * w0 / (2.0 * math.pi))
        why = ("not positive real: Re{Y(jω)} < 0 at the witness frequency; shortage = −min Re Y"
               if upper > thr else
               "not positive real: Re{Y(jω)} < 0 at the witness frequency, although the SDP's d* "
               "is within its tolerance (solver inaccuracy)")
        return KypCertificate(passive=False, shortage=lower, relative_shortage=lower / s1,
                              reason=f"{why} ({status}){note}", **base)
    return KypCertificate(passive=False, shortage=upper, relative_shortage=upper / s1,
                          reason="not positive real by the SDP optimum d* (no frequency witness found: "
                                 f"shortage is d*, an upper bound) ({status}){note}", **base)


def _verify_passive(A, B, C, q0, P, num, den) -> tuple[bool, str]:
    """A passive verdict of the SDP checked without the solver (:mod:`exotune.analysis.kyp_verify`):
    the returned P in the LMI at d = 0, else Re Y > 0 in exact arithmetic on Y's coefficients."""
    ok, lam, bound = lmi_holds(A, B, C, q0, P, 0.0)
    if ok:
        return True, f"the LMI at d = 0 with the solver's P is negative definite (λ_max = {lam:.2e} ≤ −{bound:.1e}, numpy)"
    ok, why = positive_on_axis(num, den)
    if ok:
        return True, why
    return False, f"LMI at d = 0: λ_max = {lam:.2e} > −{bound:.1e}; exact test: {why}"


def compliance_certificate(num, den, model: str = "", tol: float = TOL) -> KypCertificate:
    """Certificate of a compliance C = num/den [rad/(N·m)]: Y = s·C (ascending coefficients).

    Parameters
    ----------
    num, den : array_like
        Ascending coefficients of C's numerator and denominator.
    model : str
        The model's name, carried into the certificate.
    tol : float
        Relative tolerance on the shortage.

    Returns
    -------
    KypCertificate
        The certificate of the admittance Y = s·C (:func:`admittance_certificate`).
    """
    return admittance_certificate(np.r_[0.0, _trim(num)], den, model=model, tol=tol)


def nominal_shortage(alpha, felt_inertia, felt_damping, K_c, zeta_hat):
    """Closed form of the nominal shortage (vectorized): with ω² = αK_c/Ĵ_m and b = B̂_m/Ĵ_m,
    nominal C7 = (s² + 2ζ̂ω s + ω²)/(K_c s (s + b)), so Y = s/K_c + ((2ζ̂ω − b)s + ω²)/(K_c (s + b)) and

        Re Y(jν) = [ω² b + (2ζ̂ω − b) ν²] / [K_c (b² + ν²)],

    monotone in ν² between ω²/(K_c b) (ν = 0) and (2ζ̂ω − b)/K_c (ν → ∞): the nominal C7 is passive
    iff 2ζ̂ω ≥ b, and the shortage is max(0, (b − 2ζ̂ω)/K_c) [rad/(N·m·s)]. Ĵ_m = α·felt_inertia,
    B̂_m = α·felt_damping (docs/method.md#double-compliance-shaping). Since B̂2 = (2ζ̂√(αK_cĴ_m) − B̂_m)/K_c (paper eq. for B̂2), this is
    max(0, −B̂2/Ĵ_m): the nominal C7 is passive iff the cuff-torque-rate gain B̂2 ≥ 0.

    Parameters
    ----------
    alpha : float or array_like
        The amplification α (dimensionless).
    felt_inertia : float or array_like
        The inertia the person feels, Ĵ_m/α [kg·m²].
    felt_damping : float or array_like
        The damping the person feels, B̂_m/α [N·m·s/rad].
    K_c : float or array_like
        The cuff stiffness [N·m/rad].
    zeta_hat : float or array_like
        The damping ratio ζ̂ of the nominal C7 (dimensionless).

    Returns
    -------
    ndarray
        The shortage max(0, (b − 2ζ̂ω)/K_c) [rad/(N·m·s)] (0: the nominal C7, eq. (16), is passive).

    References
    ----------
    Paper §IV-A (passivity of the operator compliance); docs/method.md#passivity-of-the-operator-compliance.
    """
    a = np.asarray(alpha, float)
    Jh = a * np.asarray(felt_inertia, float)
    b = a * np.asarray(felt_damping, float) / Jh
    w = np.sqrt(a * np.asarray(K_c, float) / Jh)
    return np.maximum(0.0, (b - 2.0 * np.asarray(zeta_hat, float) * w) / np.asarray(K_c, float))


def operator_certificates(cfg, tol: float = TOL) -> dict:
    """Both certificates of a single-design config: {"nominal": …, "delay_free": …} (each a
    :class:`KypCertificate`; :func:`certificates_dict` gives their JSON records).

    Parameters
    ----------
    cfg : DesignConfig
        One design.
    tol : float
        Relative tolerance on the shortage.

    Returns
    -------
    dict
        ``nominal`` (the nominal C7, eq. (16)) and ``delay_free`` (the implemented C7 with T = 0),
        each a :class:`KypCertificate`.

    Raises
    ------
    ImportError
        When an SDP is needed, Clarabel does not solve it and cvxpy is missing.
    ValueError
        When a model's denominator is zero.

    References
    ----------
    Paper §IV-A (passivity of the operator compliance); docs/method.md#passivity-of-the-operator-compliance.
    """
    from .charfun import char_terms
    from ..model.controller import build_controller
    from ..numerics.poly import padd
    from ..model.shaping import nominal_transfer_functions

    cs, ds = build_controller(cfg.plant, cfg.design, cfg.implementation)
    c7 = nominal_transfer_functions(cfg.plant, cfg.design, ds)["C7_nominal"]
    nom = compliance_certificate(np.ravel(np.atleast_2d(c7.num)[0]), np.ravel(np.atleast_2d(c7.den)[0]),
                                 model="nominal C7 (paper eq. (16): no delay, no filters, no DOB)", tol=tol)
    ct = char_terms(cfg.plant, cs, 1)
    d00 = padd(ct.qp("00").p0, ct.qp("00").p1)[0]
    d10 = padd(ct.qp("10").p0, ct.qp("10").p1)[0]
    dfree = compliance_certificate(d10, d00, model="implemented C7 = Δ10/Δ00 with T = 0 (filters and DOB included)", tol=tol)
    return {"nominal": nom, "delay_free": dfree}


def certificates_dict(certs) -> dict:
    """The JSON records of :func:`operator_certificates` (an ``error`` entry is kept as its text).

    Parameters
    ----------
    certs : dict
        Name → :class:`KypCertificate` (or the text of an error).

    Returns
    -------
    dict
        Name → the certificate's JSON record (``as_dict()``), or the text.
    """
    return {name: (c if isinstance(c, str) else c.as_dict()) for name, c in certs.items()}
