"""Exact right-half-plane root counts of characteristic quasi-polynomials, batched.

:class:`RootCounter` collects the counting tasks of several analyses and runs them in one
vectorized (compiled or numpy) call of the argument principle
(:func:`exotune.numerics.quasipoly.count_rhp`); :func:`rhp_count`, :func:`free_stability` and
:func:`coupled_stable` are the verdicts built on it.

References
----------
Paper §IV (coupled stability with the person); docs/method.md#free-and-locked-stability.
"""

from __future__ import annotations

import numpy as np

from ..model.controller import ControllerStructure
from ..model.plant import Plant
from ..numerics.engine import compiled
from ..numerics.poly import as_poly, pad_cols, padd, pmul, strip_common_low_zeros
from ..numerics.quasipoly import QP, count_rhp
from .charfun import CharTerms, char_terms, trim_poly

__all__ = ["RootCounter", "rhp_count", "free_stability", "coupled_stable"]


def rhp_count(qp: QP):
    """(N_rhp, rigid_body_roots, conclusive) with the exact s = 0 roots divided out first.

    Parameters
    ----------
    qp : QP
        Characteristic quasi-polynomials, one row per design.

    Returns
    -------
    n_rhp : ndarray of int, shape (N,)
        Roots in the open right half-plane.
    rigid_body_roots : ndarray of int, shape (N,)
        Exact roots at s = 0 divided out.
    conclusive : ndarray of bool, shape (N,)
        Whether the count is exact.
    """
    c = RootCounter()
    h = c.add(qp.p0, qp.p1, qp.T)
    c.run()
    return c.result(h)


class RootCounter:
    """Collects RHP-count tasks of several analyses and runs them in one vectorized call.

    Every task is stripped of its *exact* common low-order zero coefficients first (the rigid-body
    root at s = 0, docs/method.md#double-compliance-shaping); the number stripped is returned as ``rigid_body_roots``. Tasks of the
    hysteretic human carry a real "regularized" twin (k instead of k(1 + jη)) whose value at
    ω = 0 is used as Δ(j0) (see :func:`exotune.quasipoly.count_rhp`).
    """

    def __init__(self):
        self.items = []
        self.n = 0

    def add(self, p0, p1, T, reg=None, group=None):
        """Queue the rows of (p0, p1, T) [with their regularized twin ``reg``]; rows with the same
        ``group`` id (consecutive) share one work budget (``_fastphase.MAX_GROUP_EVALS``)."""
        T = np.broadcast_to(np.asarray(T, float), p0.shape[:1])
        self.items.append((p0, p1, T, reg, group))
        h = slice(self.n, self.n + p0.shape[0])
        self.n += p0.shape[0]
        return h

    def run(self, engine: str | None = None):
        """Count every queued task (compiled pipeline :func:`exotune._fastphase.count_tasks` by
        default; ``engine="numpy"``: the reference path strip → count_rhp)."""
        if self.n == 0:
            self.N = np.zeros(0, int)
            self.r = np.zeros(0, int)
            self.ok = np.zeros(0, bool)
            return
        w0 = max(i[0].shape[-1] for i in self.items)
        w1 = max(i[1].shape[-1] for i in self.items)
        cplx = any(np.iscomplexobj(i[0]) or np.iscomplexobj(i[1]) for i in self.items)
        dt = complex if cplx else float
        pad = lambda c, w: pad_cols(np.asarray(c), w).astype(dt)
        P0 = np.concatenate([pad(i[0], w0) for i in self.items])
        P1 = np.concatenate([pad(i[1], w1) for i in self.items])
        T = np.concatenate([i[2] for i in self.items])
        R0 = np.concatenate([pad(i[3][0] if i[3] is not None else i[0], w0) for i in self.items]).real
        R1 = np.concatenate([pad(i[3][1] if i[3] is not None else i[1], w1) for i in self.items]).real
        has_reg = np.concatenate([np.full(i[0].shape[0], i[3] is not None) for i in self.items])
        groups, base = [], 0
        for i in self.items:
            g = np.arange(i[0].shape[0]) if i[4] is None else np.asarray(i[4], np.int64)
            groups.append(base + g)
            base += int(g.max()) + 1 if g.size else 0
        group = np.concatenate(groups)
        if (engine is None and compiled()) or engine == "numba":
            from ..numerics import kernels as _fastphase
            from ..numerics.quasipoly import ARG_STEP, DER_STEP, MAX_LEVELS

            self.N, self.r, self.ok = _fastphase.count_tasks(P0, P1, T, R0, R1, has_reg, ARG_STEP, DER_STEP, MAX_LEVELS,
                                                             group=group)
            return
        r, (P0s, P1s, R0s, R1s) = strip_common_low_zeros(P0, P1, R0, R1)
        v0 = np.where(has_reg, R0s[:, 0] + R1s[:, 0], np.nan)
        if not cplx:
            v0 = None
        N, ok = count_rhp(QP(trim_poly(P0s), trim_poly(P1s), T), v0=v0, group=group)
        self.N, self.r, self.ok = N, r, ok

    def result(self, h):
        return self.N[h], self.r[h], self.ok[h]


def free_stability(ct: CharTerms):
    """Free exoskeleton (cuff free, no environment): stable except for ≤ 1 rigid-body root.

    Parameters
    ----------
    ct : CharTerms
        The characteristic terms of the designs (:func:`~exotune.analysis.charfun.char_terms`).

    Returns
    -------
    dict
        Arrays of shape (N,): ``stable``, ``n_rhp``, ``rigid_body_roots``, ``conclusive``.

    References
    ----------
    docs/method.md#free-and-locked-stability.
    """
    N, r, ok = rhp_count(ct.qp("00"))
    return {"stable": ok & (N == 0) & (r <= 1), "n_rhp": N, "rigid_body_roots": r, "conclusive": ok}


def coupled_stable(plant: Plant, cs: ControllerStructure, N: int, human: dict | None = None, env: dict | None = None):
    """Closed-loop verdict for specific human / environment impedances (no ranges).

    ``human``: {inertia, damping, stiffness} (any subset; None = cuff free);
    ``env``: None/"free", "locked", or {inertia, damping, stiffness}.
    Returns dict(stable, n_rhp, rigid_body_roots, conclusive) of arrays over the N designs.

    Parameters
    ----------
    plant : Plant
        The plant (scalars or one value per design).
    cs : ControllerStructure
        The controller blocks, the DOB filter and the delay.
    N : int
        Number of designs.
    human : dict, optional
        The person's impedance: ``inertia`` [kg·m²], ``damping`` [N·m·s/rad], ``stiffness``
        [N·m/rad] (any subset); None: cuff free.
    env : dict or str, optional
        The environment: None or "free", "locked", or an impedance as ``human``.

    Returns
    -------
    dict
        Arrays of shape (N,): ``stable`` (no RHP root; at most one rigid-body root unless locked),
        ``n_rhp``, ``rigid_body_roots``, ``conclusive``.

    References
    ----------
    docs/method.md#free-and-locked-stability.
    """
    ct = char_terms(plant, cs, N)
    if env == "locked":
        q = ct.qp("01") if human is None else _affine(ct, "01", "11", _zpoly(human))
        N_, r, ok = rhp_count(q)
        return {"stable": ok & (N_ == 0) & (r == 0), "n_rhp": N_, "rigid_body_roots": r, "conclusive": ok}
    zh = np.broadcast_to(_zpoly(human) if human else np.zeros(1), (N, 3 if human else 1))
    ze = np.broadcast_to(_zpoly(env) if isinstance(env, dict) else np.zeros(1), (N, 3 if isinstance(env, dict) else 1))
    # Δ = Δ00 + z Δ10 + ze Δ01 + z ze Δ11
    t = ct.terms
    p0 = padd(padd(t["00"].p0, pmul(t["10"].p0, zh)), padd(pmul(t["01"].p0, ze), pmul(t["11"].p0, pmul(zh, ze))))
    p1 = padd(padd(t["00"].p1, pmul(t["10"].p1, zh)), padd(pmul(t["01"].p1, ze), pmul(t["11"].p1, pmul(zh, ze))))
    N_, r, ok = rhp_count(QP(trim_poly(p0), trim_poly(p1), ct.T))
    return {"stable": ok & (N_ == 0) & (r <= 1), "n_rhp": N_, "rigid_body_roots": r, "conclusive": ok}


def _zpoly(d: dict) -> np.ndarray:
    """[k, b, m] ascending coefficients of Z(s) = k + b s + m s²; values may be arrays (per design)."""
    return as_poly(*(np.asarray(d.get(k, 0.0), dtype=float) for k in ("stiffness", "damping", "inertia")))


def _affine(ct: CharTerms, k0: str, k1: str, z: np.ndarray) -> QP:
    q, _ = ct.combine(k0, k1, z)
    return QP(trim_poly(q.p0), trim_poly(q.p1), q.T)


