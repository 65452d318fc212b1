"""The closed-loop characteristic function of the coupled exoskeleton (the model of paper §II closed by the controller of Fig. 3).

For a plant with a human impedance z(s) at θ_h and an environment impedance z_e(s) at θ_j, closed
by any :class:`~exotune.model.controller.ControllerStructure`, the closed-loop characteristic
function is *multilinear* in (z, z_e):

    Δ(s; z, z_e) = Δ00(s) + z Δ10(s) + z_e Δ01(s) + z z_e Δ11(s),   each Δij = P0 + P1 e^{−sT}

(the plant determinant and cofactors are multilinear in the diagonal impedances; the controller
and the DOB enter through the single delayed actuator path). :func:`char_terms` builds the eight
coefficient arrays for a batch of designs, in "grounded" form so that the rigid-body root at
s = 0 of the free exoskeleton (K1 = 0) is an *exact* zero coefficient that is divided out
structurally — never a rounding decision. C7(jω) = Δ10/Δ00 is the operator-side compliance
(:func:`exotune.analysis.operator_passivity.passivity`); :func:`amplification_qps` gives the
output-locked ratio C6/C5 (paper §II-D), with the DOB-modified delay.

References
----------
Paper §II, Table II (the model; the paper writes no characteristic function), §II-D (amplification); docs/method.md#one-characteristic-function.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model.controller import ControllerStructure
from ..model.plant import Plant
from ..numerics.poly import as_poly, pad_cols, padd, pmul, pscale, psub, strip_common_low_zeros
from ..numerics.quasipoly import QP

__all__ = ["CharTerms", "KEYS", "char_terms", "controller_polys", "amplification_qps", "trim_poly", "strip_qps",
           "design_column"]

#: the four characteristic terms Δ00, Δ10, Δ01, Δ11 (human and environment impedance exponents)
KEYS = ("00", "10", "01", "11")


@dataclass(frozen=True)
class CharTerms:
    """Multilinear characteristic terms Δij = P0ij + P1ij e^{−sT} (batched, ascending coeffs)."""

    terms: dict  # key "00","10","01","11" -> QP
    T: np.ndarray

    def qp(self, key: str) -> QP:
        return self.terms[key]

    def rows(self, sl) -> "CharTerms":
        """The terms of the designs ``sl`` (a slice or an index array) of the batch."""
        return CharTerms({k: QP(t.p0[sl], t.p1[sl], t.T[sl]) for k, t in self.terms.items()}, self.T[sl])

    @classmethod
    def stack(cls, parts) -> "CharTerms":
        """The terms of several batches as one batch (rows in order; coefficient rows padded with
        zeros to the widest, which leaves every polynomial unchanged).

        Parameters
        ----------
        parts : sequence of CharTerms
            Batches with the same keys.

        Returns
        -------
        CharTerms
            Their rows, one after the other.
        """
        def cat(arrays):
            n = max(a.shape[1] for a in arrays)
            return np.concatenate([pad_cols(np.asarray(a, dtype=float), n) for a in arrays])

        T = np.concatenate([np.asarray(c.T, dtype=float) for c in parts])
        keys = parts[0].terms.keys()
        return cls({k: QP(cat([c.terms[k].p0 for c in parts]), cat([c.terms[k].p1 for c in parts]),
                          np.concatenate([c.terms[k].T for c in parts])) for k in keys}, T)

    def combine(self, key0: str, key1: str, z0: np.ndarray) -> tuple[QP, QP]:
        """(Δ_0, Δ_1') with Δ_0 = Δ{key0} + z0(s)·Δ{key1}, Δ_1' = Δ{key1}."""
        A, B = self.terms[key0], self.terms[key1]
        z0 = np.asarray(z0, dtype=float)
        p0 = padd(A.p0, pmul(B.p0, np.broadcast_to(z0, B.p0.shape[:1] + z0.shape[-1:])))
        p1 = padd(A.p1, pmul(B.p1, np.broadcast_to(z0, B.p1.shape[:1] + z0.shape[-1:])))
        return QP(p0, p1, A.T), B


def design_column(x, N):
    """``x`` (a scalar or one value per design) as a float array of shape (N,) (a copy).

    Parameters
    ----------
    x : float or array_like
        A plant or controller parameter, scalar or of shape (N,).
    N : int
        Number of designs.

    Returns
    -------
    ndarray, shape (N,)
    """
    return np.broadcast_to(np.asarray(x, dtype=float), (N,)).copy()


def _blocks(cs: ControllerStructure, N: int):
    out = []
    for r in (cs.motor_position, cs.spring_torque, cs.cuff_torque):
        num = np.broadcast_to(r.num, (N,) + r.num.shape[-1:]).astype(float)
        den = np.broadcast_to(r.den, (N,) + r.den.shape[-1:]).astype(float)
        out.append((num, den))
    return out


def controller_polys(cs: ControllerStructure, N: int):
    """Common-denominator form of the controller: d = Π d_x, w_x = n_x · d/d_x for the blocks on
    θ_m, τ_s, τ_c, and the DOB filter Q = n_q/d_q (n_q = 0, d_q = 1 without a DOB).

    Parameters
    ----------
    cs : ControllerStructure
        The controller blocks and the DOB filter Q.
    N : int
        Number of designs (rows).

    Returns
    -------
    tuple of ndarray
        (d, w_θm, w_τs, w_τc, n_q, d_q), ascending coefficients, N rows each.
    """
    (nth, dth), (nts, dts), (ntc, dtc) = _blocks(cs, N)
    d_all = pmul(pmul(dth, dts), dtc)
    w_th = pmul(nth, pmul(dts, dtc))
    w_ts = pmul(nts, pmul(dth, dtc))
    w_tc = pmul(ntc, pmul(dth, dts))
    if cs.dob_q is not None:
        nq = np.broadcast_to(cs.dob_q.num, (N,) + cs.dob_q.num.shape[-1:]).astype(float)
        dq = np.broadcast_to(cs.dob_q.den, (N,) + cs.dob_q.den.shape[-1:]).astype(float)
    else:
        nq, dq = np.zeros((N, 1)), np.ones((N, 1))
    return d_all, w_th, w_ts, w_tc, nq, dq


def char_terms(plant: Plant, cs: ControllerStructure, N: int, *, dob_model=None, keys=KEYS,
               controller=None) -> CharTerms:
    """Build Δ00, Δ10, Δ01, Δ11 for N designs (see module docstring).

    Plant (grounded form, exact structural zeros): with A = J_m s² + B_m s + K_s, M = J_m s² + B_m s,
    X0 = M (J_j s² + K_s) + K_s J_j s², C = K_c + z:
      det   = K_c X0 + z (X0 + K_c A) + z_e K_c A + z z_e A
      N_θm  = K_c (J_j s² + K_s) + z (J_j s² + K_s + K_c) + z_e K_c + z z_e
      N_τs  = −K_s [K_c J_j s² + z (J_j s² + K_c) + z_e K_c + z z_e]
      N_τc  = −K_s K_c z
    (θ_m, τ_s, τ_c responses to τ_m are N_x/det). With blocks G_x = n_x/d_x, d = Π d_x and
    Q = n_q/d_q:  P0 = det·d·(d_q − n_q),  P1 = det·d·n_q − d_q Σ_x n_x (d/d_x) N_x.

    ``dob_model=(J_m0, B_m0)`` (scalars or (N,) arrays): the DOB's nominal motor model M0 = J_m0 s² + B_m0 s
    (paper eq. (15) with the nominal plant's J_m, B_m) differs
    from the plant's M (plant-uncertainty analysis, :mod:`exotune.analysis.plant_margin`). Its
    law δ̂ = Q (M0 θ_m − τ_s − τ_cmd) gives τ_cmd = (Σ_x G_x x − Q M0 θ_m + Q τ_s)/(1 − Q), so P0
    is unchanged and P1 = d·n_q·(M0 N_θm − N_τs) − d_q Σ_x n_x (d/d_x) N_x; with M0 = M this is the
    form above (det = M N_θm − N_τs for every key). ``None`` (default) is the original code path.

    Parameters
    ----------
    plant : Plant
        The plant (scalars or one value per design).
    cs : ControllerStructure
        The controller blocks, the DOB filter Q and the delay T [s].
    N : int
        Number of designs.
    dob_model : tuple of (float or ndarray), optional
        (J_m0 [kg·m²], B_m0 [N·m·s/rad]), the DOB's nominal motor model; None: the plant's own.
    keys : tuple of str, optional
        The terms to build (default all four); a loop that needs only some of them (the
        plant-uncertainty margin's models) saves the others' products.
    controller : tuple of ndarray, optional
        :func:`controller_polys` ``(cs, N)`` if already computed (the same arrays the call would
        build: the result is unchanged).

    Returns
    -------
    CharTerms
        Δ00, Δ10, Δ01, Δ11 (those of ``keys``; ascending coefficients, one row per design) and the delays T [s].

    References
    ----------
    Paper §II (the model), §III (the DOB, eq. (15)); docs/method.md#one-characteristic-function.
    """
    Ks, Kc, Jm, Bm, Jj = (design_column(v, N) for v in (plant.K_s, plant.K_c, plant.J_m, plant.B_m, plant.J_j))
    zero = np.zeros(N)
    one = np.ones(N)
    A = as_poly(Ks, Bm, Jm)
    M = as_poly(zero, Bm, Jm)
    Jg = as_poly(zero, zero, Jj)
    JgKs = as_poly(Ks, zero, Jj)
    X0 = padd(pmul(M, JgKs), pscale(Jg, Ks))
    det = {
        "00": pscale(X0, Kc),
        "10": padd(X0, pscale(A, Kc)),
        "01": pscale(A, Kc),
        "11": A,
    }
    Nth = {
        "00": pscale(JgKs, Kc),
        "10": as_poly(Ks + Kc, zero, Jj),
        "01": Kc[:, None],
        "11": one[:, None],
    }
    Nts = {
        "00": pscale(Jg, -Ks * Kc),
        "10": pscale(as_poly(Kc, zero, Jj), -Ks),
        "01": (-Ks * Kc)[:, None],
        "11": (-Ks)[:, None],
    }
    Ntc = {"00": zero[:, None], "10": (-Ks * Kc)[:, None], "01": zero[:, None], "11": zero[:, None]}
    d_all, w_th, w_ts, w_tc, nq, dq = controller_polys(cs, N) if controller is None else controller
    dmn = psub(dq, nq)
    T = design_column(cs.delay_s, N)
    terms = {}
    if dob_model is not None:
        M0 = as_poly(zero, design_column(dob_model[1], N), design_column(dob_model[0], N))
    for key in keys:
        dd = pmul(det[key], d_all)
        S = padd(padd(pmul(w_th, Nth[key]), pmul(w_ts, Nts[key])), pmul(w_tc, Ntc[key]))
        P0 = pmul(dd, dmn)
        if dob_model is None:
            P1 = psub(pmul(dd, nq), pmul(dq, S))
        else:
            dm = pmul(psub(pmul(M0, Nth[key]), Nts[key]), d_all)
            P1 = psub(pmul(dm, nq), pmul(dq, S))
        terms[key] = QP(trim_poly(P0), trim_poly(P1), T)
    return CharTerms(terms, T)


def trim_poly(c: np.ndarray) -> np.ndarray:
    """Drop trailing all-zero highest-order columns.

    Parameters
    ----------
    c : ndarray, shape (N, n)
        Ascending polynomial coefficients, one row per design.

    Returns
    -------
    ndarray, shape (N, m)
        ``c`` without its all-zero highest-order columns (at least one column kept).
    """
    nz = np.nonzero(np.any(c != 0, axis=0))[0]
    return c[:, : (nz[-1] + 1 if nz.size else 1)]


def amplification_qps(plant: Plant, cs: ControllerStructure, N: int) -> tuple[QP, QP]:
    """(numerator, denominator) quasi-polynomials of the amplification C6/C5 (output locked).

    Denominator = the output-locked characteristic function; its RHP count is the locked-output
    stability verdict. C6/C5 = num/den (same normalization).

    Parameters
    ----------
    plant : Plant
        The plant (scalars or one value per design).
    cs : ControllerStructure
        The controller blocks, the DOB filter Q and the delay T [s].
    N : int
        Number of designs.

    Returns
    -------
    num, den : QP
        Numerator and denominator of C6/C5, one row per design.

    References
    ----------
    Paper §II-D (amplification, eqs. (13)–(14)); docs/method.md#amplification.
    """
    Ks, Jm, Bm = (design_column(v, N) for v in (plant.K_s, plant.J_m, plant.B_m))
    A = as_poly(Ks, Bm, Jm)
    d_all, w_th, w_ts, w_tc, nq, dq = controller_polys(cs, N)
    T = design_column(cs.delay_s, N)
    Ad = pmul(A, d_all)
    P0 = pmul(Ad, psub(dq, nq))
    Sd = psub(w_th, pscale(w_ts, Ks))
    Sn = psub(Sd, pscale(w_tc, Ks))
    den = QP(trim_poly(P0), trim_poly(psub(pmul(Ad, nq), pmul(dq, Sd))), T)
    num = QP(trim_poly(P0), trim_poly(psub(pmul(Ad, nq), pmul(dq, Sn))), T)
    return num, den


def strip_qps(*qps: QP, max_strip=None):
    """Divide the exact common s = 0 roots out of quasi-polynomials.

    Parameters
    ----------
    *qps : QP
        Quasi-polynomials of the same designs.
    max_strip : int or array_like, optional
        At most this many roots at s = 0 are divided out (default: all common ones).

    Returns
    -------
    r : ndarray of int, shape (N,)
        Number of exact zero low-order coefficients removed per design (common to every input).
    qps : list of QP
        The inputs divided by s^r, trimmed.
    """
    r, arrs = strip_common_low_zeros(*[a for q in qps for a in (q.p0, q.p1)], max_strip=max_strip)
    out = [QP(trim_poly(arrs[2 * i]), trim_poly(arrs[2 * i + 1]), qps[i].T) for i in range(len(qps))]
    return r, out
