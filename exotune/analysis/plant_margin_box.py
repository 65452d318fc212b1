"""Boxes of plants for the plant-uncertainty margin: coefficients, exact counts and zero exclusion.

One loop of a design (the free exoskeleton, an environment, one human family or one edge of a
human box) with the controller fixed has the characteristic quasi-polynomial
Δ(s; q, p) = P0(s) + P1(s) e^{−sT} whose coefficients are multilinear in the five plant
parameters q = (J_m, B_m, K_s, J_j, K_c) and affine in the family member p
(:func:`exotune.analysis.charfun.char_terms` with the DOB model of the nominal plant). Over a box
of (q, p) the value set Δ(jω, box) therefore lies in the convex hull of the 2^n vertex values
(mapping theorem, Zadeh & Desoer 1963), and :func:`certify_loop` proves zero exclusion
0 ∉ Δ(jω, box) for every ω ≥ 0 by interval covering of the frequency axis and subdivision of the
box (module :mod:`exotune.analysis.plant_margin` states the theorem and its assumptions).

References
----------
Paper §II (the plant); docs/method.md#plant-uncertainty-margin.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from ..model.humans import family_split
from ..model.plant import Plant
from ..numerics.poly import pad_cols, padd, pmul
from .charfun import char_terms, controller_polys, trim_poly
from .counting import RootCounter

__all__ = ["PLANT_FIELDS", "PLANT_SYMBOLS", "LoopModel", "certify_loop", "hull_distance", "CertifyResult", "strip_rows"]

PLANT_FIELDS = ("motor_inertia", "motor_damping", "sea_stiffness", "joint_inertia", "cuff_stiffness")
PLANT_SYMBOLS = ("J_m", "B_m", "K_s", "J_j", "K_c")
ROUND_REL = 1e-9  # relative safety on the float evaluation of Δ at one frequency (vs. Σ|c_k| ω^k)
GILBERT_ITERS = 12
MAX_DEPTH = 150  # box halvings along one path (about 25 per coordinate)


class LoopModel:
    """The coefficient factory of one loop with the controller ``cs`` fixed.

    Parameters
    ----------
    cs : ControllerStructure
        The controller designed on the nominal plant.
    plant0 : Plant
        The nominal plant (scalar fields).
    fam : HumanFamily or None
        The loop's family (its member p ranges over [lo, hi]) or None for a single loop.
    key0, key1 : str
        The characteristic terms of the loop (``"00"`` and ``"10"`` for a human, ``"01"`` for an
        environment family; ``key1`` None for a single loop whose term is ``key0``).
    """

    def __init__(self, cs, plant0: Plant, fam, key0: str, key1: str | None):
        self.cs, self.fam, self.key0, self.key1 = cs, fam, key0, key1
        self.q0 = np.array([float(getattr(plant0, f)) for f in PLANT_FIELDS])
        self.T = float(np.asarray(cs.delay_s))
        if fam is not None:
            self.z0, self.phi, self.factor = family_split(fam.kind, fam.param, fam.fixed(), fam.eta)
        else:
            self.z0 = self.phi = None
            self.factor = 1.0 + 0j
        self.complex = bool(self.factor.imag != 0)
        self._keys = (key0,) if key1 is None else (key0, key1)
        self._controller = {}

    @property
    def ndim(self) -> int:
        """Number of box coordinates: the five relative plant deviations (+ the member p)."""
        return 5 if self.fam is None else 6

    def plants(self, q: np.ndarray) -> Plant:
        """A batch Plant from absolute parameter rows ``q`` (n, 5)."""
        return Plant(*(q[:, i].copy() for i in range(5)))

    @property
    def keys(self) -> tuple:
        """The characteristic terms the loop uses (``"00"``, ``"10"``, ``"01"``)."""
        return self._keys

    def terms(self, q: np.ndarray, keys: tuple | None = None):
        """The characteristic terms (:func:`~exotune.analysis.charfun.char_terms`, the DOB's model
        the nominal plant's) of the plant rows ``q`` (n, 5): the loop's own, or ``keys`` (the
        union of several loops' whose rows are computed at once)."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        n = q.shape[0]
        if n not in self._controller:  # the controller is fixed: its polynomials once per row count
            self._controller[n] = controller_polys(self.cs, n)
        return char_terms(self.plants(q), self.cs, n, dob_model=(self.q0[0], self.q0[1]),
                          keys=self._keys if keys is None else keys, controller=self._controller[n])

    def coeffs(self, q: np.ndarray, p: np.ndarray | None, real_twin: bool = False, ct=None):
        """(P0, P1) rows for every (plant row of ``q``, member of ``p``), plant-major, member-minor.

        ``real_twin``: the hysteretic family's real twin (factor 1 instead of 1 + jη); ``ct``: the
        characteristic terms of the rows of ``q`` when already computed (:meth:`terms`)."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        n = q.shape[0]
        if ct is None:
            ct = self.terms(q)
        if self.fam is None:
            t = ct.qp(self.key0)
            return t.p0, t.p1
        if np.any(self.z0):
            D0, D1 = ct.combine(self.key0, self.key1, self.z0)
        else:
            D0, D1 = ct.qp(self.key0), ct.qp(self.key1)
        f = 1.0 if (real_twin or not self.complex) else self.factor
        B0 = pmul(D1.p0, self.phi[None, :]) * f
        B1 = pmul(D1.p1, self.phi[None, :]) * f
        p = np.asarray(p, dtype=float)
        rep = lambda a: np.repeat(a, p.size, axis=0)  # noqa: E731
        pp = np.tile(p, n)[:, None]
        P0 = padd(rep(D0.p0).astype(B0.dtype), pp * rep(B0))
        P1 = padd(rep(D0.p1).astype(B1.dtype), pp * rep(B1))
        return P0, P1

    def box_points(self, lo: np.ndarray, hi: np.ndarray):
        """Absolute plant rows and members of the 2^ndim vertices of the relative box [lo, hi]
        (δ_i for the plant, p itself for the member)."""
        corners = np.array(list(itertools.product((0, 1), repeat=5)), dtype=float)
        d = lo[:5] + corners * (hi[:5] - lo[:5])
        q = self.q0 * (1.0 + d)
        p = None if self.fam is None else np.array([lo[5], hi[5]])
        return q, p

    def submit(self, counter: RootCounter, q: np.ndarray, p: np.ndarray | None, ct=None):
        """Queue the exact RHP counts of every (plant, member) row on ``counter`` (several loops'
        rows then run in one call); returns the handle of :meth:`RootCounter.result`. ``ct``: the
        characteristic terms of the rows of ``q`` when already computed (:meth:`terms`)."""
        ct = self.terms(q) if ct is None else ct
        P0, P1 = self.coeffs(q, p, ct=ct)
        reg = self.coeffs(q, p, real_twin=True, ct=ct) if self.complex else None
        reg = None if reg is None else (trim_poly(reg[0]), trim_poly(reg[1]))
        return counter.add(trim_poly(P0), trim_poly(P1), self.T, reg=reg)

    def counts(self, q: np.ndarray, p: np.ndarray | None):
        """Exact RHP counts (argument principle) of every (plant, member) row: (N, r, ok)."""
        c = RootCounter()
        h = self.submit(c, q, p)
        c.run()
        return c.result(h)


def strip_rows(P0: np.ndarray, P1: np.ndarray):
    """Divide the exact zero low-order coefficients common to every row (structural roots at s = 0).

    Parameters
    ----------
    P0, P1 : ndarray
        Ascending coefficients of P0 and P1, one row per loop.

    Returns
    -------
    r : int
        Number of low-order columns divided out (roots at s = 0).
    P0, P1 : ndarray
        The divided coefficients, trailing all-zero columns dropped.
    """
    w = max(P0.shape[1], P1.shape[1])
    nz = np.any(pad_cols(P0, w) != 0, axis=0) | np.any(pad_cols(P1, w) != 0, axis=0)
    r = int(np.argmax(nz)) if nz.any() else 0
    return r, trim_poly(P0[:, r:]), trim_poly(P1[:, r:])


def _horner(c: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Rows of ascending coefficients ``c`` (R, n) evaluated at ``s`` (W,) → (W, R)."""
    out = np.zeros((s.size, c.shape[0]), dtype=complex)
    sc = s[:, None]
    for k in range(c.shape[1] - 1, -1, -1):  # in place: the same products and sums, no temporaries
        out *= sc
        out += c[None, :, k]
    return out


def _abs_poly(cmax: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Σ_k cmax_k w^k for nonnegative ``cmax`` (monotone in w ≥ 0)."""
    out = np.zeros(w.shape)
    for a in cmax[::-1]:
        out = out * w + a
    return out


def hull_distance(V: np.ndarray, slack: np.ndarray | None = None):
    """A rigorous lower bound on the distance from 0 to the convex hull of each row of ``V`` (W, R)
    (≤ 0 when no separating direction is found): max over Gilbert's iterates x of
    min_v Re(V_v x̄)/|x|, the distance of 0 to the hull along the direction x. With ``slack``
    (W, R), every point v may move by up to slack[:, v]: the bound min_v (Re(V_v x̄)/|x| − slack_v)
    is still rigorous for the moved hull. Rows stop iterating once that bound is positive.

    Parameters
    ----------
    V : ndarray of complex, shape (W, R)
        The points, one hull per row (the vertex values Δ(jω) at one frequency).
    slack : ndarray, shape (W, R), optional
        How far each point may move (default: 0).

    Returns
    -------
    (bound with slack, bound without slack) : ndarrays of shape (W,)
    """
    W = V.shape[0]
    if slack is None:
        slack = np.zeros(V.shape)
    # 0 is outside the hull iff the points' angles leave a gap wider than π; the direction opposite
    # to the gap's bisector then separates them (a first bound; Gilbert's iterations refine it)
    ang = np.sort(np.angle(V), axis=1)
    gaps = np.concatenate([np.diff(ang, axis=1), (ang[:, :1] + 2.0 * np.pi) - ang[:, -1:]], axis=1)
    g = np.argmax(gaps, axis=1)
    gmax = gaps[np.arange(W), g]
    u = -np.exp(1j * (ang[np.arange(W), g] + 0.5 * gmax))
    dots0 = np.real(V * np.conj(u)[:, None])
    best = np.min(dots0, axis=1)
    best_s = np.min(dots0 - slack, axis=1)
    inside = (gmax <= np.pi) | (np.min(np.abs(V), axis=1) == 0)
    best[inside] = -np.mean(np.abs(V[inside]), axis=1) * (np.pi - gmax[inside] + 1e-3)
    best_s[inside] = best[inside]
    x = V[np.arange(W), np.argmin(np.abs(V), axis=1)]
    act = np.nonzero(~inside & (best_s <= 0))[0]
    for _ in range(GILBERT_ITERS):
        Va, xa = V[act], x[act]
        ax = np.abs(xa)
        safe = np.where(ax > 0, ax, 1.0)
        dots = np.real(Va * np.conj(xa)[:, None]) / safe[:, None]
        j = np.argmin(dots, axis=1)
        r = np.arange(act.size)
        lb = np.where(ax > 0, dots[r, j], -np.inf)
        lbs = np.where(ax > 0, np.min(dots - slack[act], axis=1), -np.inf)
        best[act] = np.maximum(best[act], lb)
        best_s[act] = np.maximum(best_s[act], lbs)
        sp = Va[r, j]
        e = xa - sp
        den = np.abs(e) ** 2
        t = np.clip(np.real(xa * np.conj(e)) / np.where(den > 0, den, 1.0), 0.0, 1.0)
        x[act] = xa - t * e
        # done: certified, or converged (the bound equals the distance of the current iterate)
        keep = (best_s[act] <= 0) & (np.abs(x[act]) - best[act] > 1e-3 * np.abs(x[act])) & (den > 0)
        act = act[keep]
        if act.size == 0:
            break
    return best_s, best


@dataclass
class _Box:
    lo: np.ndarray
    hi: np.ndarray
    depth: int
    P0: np.ndarray  # (R, n0) stripped vertex coefficients
    P1: np.ndarray
    c0max: np.ndarray
    c1max: np.ndarray
    # the rows _eval_box evaluates together, zero-padded at the top (the same values as one row
    # set at a time: the padding adds exact zeros until a row's own leading coefficient)
    P01: np.ndarray = None  # P0 over P1 (the vertex values; |·|: the rounding allowance)
    slope: np.ndarray = None  # P0', P1', P1 (the motion bound at the interval's end)

    def __post_init__(self):
        d0 = self.P0[:, 1:] * np.arange(1, self.P0.shape[1])
        d1 = self.P1[:, 1:] * np.arange(1, self.P1.shape[1])
        n = max(self.P0.shape[1], self.P1.shape[1])
        self.P01 = np.concatenate([pad_cols(self.P0, n), pad_cols(self.P1, n)])
        self.slope = np.concatenate([pad_cols(d0, n), pad_cols(d1, n), pad_cols(self.P1, n)])


@dataclass(frozen=True)
class CertifyResult:
    """The outcome of one zero-exclusion proof: ``certified``, the evaluations spent, a reason when
    not certified, and ``hints`` (relative box centres where the hull kept containing 0)."""

    certified: bool
    evaluations: int
    reason: str = ""
    hints: tuple = ()
    frequency: float | None = None  # rad/s, where the subdivision stalled


def _make_box(model: LoopModel, lo, hi, depth, r0: int):
    """The box [lo, hi] with its vertex coefficients divided by s^r0, or None when its common
    structural zero count at s = 0 is not the nominal loop's r0 (an extra root at s = 0)."""
    q, p = model.box_points(lo, hi)
    r, P0s, P1s = strip_rows(*model.coeffs(q, p))
    if r != r0:
        return None
    return _Box(np.asarray(lo, float), np.asarray(hi, float), depth, P0s, P1s,
                np.max(np.abs(P0s), axis=0), np.max(np.abs(P1s), axis=0))


def _tail(box: _Box) -> float:
    """ω above which |P0(s)| > |P1(s)| for every member of the box and every |s| ≥ ω, Re s ≥ 0
    (inf when the box holds a neutral member or a vanishing leading coefficient)."""
    n = box.P0.shape[1] - 1
    if box.P1.shape[1] - 1 >= n or n < 1:
        return math.inf
    lead = box.P0[:, n]
    u = np.mean(lead)
    if u == 0:
        return math.inf
    lead_lb = float(np.min(np.real(lead * np.conj(u / abs(u)))))  # multilinear: min at a vertex
    if lead_lb <= 0:
        return math.inf
    tot = box.c0max[:n].copy()
    tot[: box.c1max.size] += box.c1max
    ratios = [(tot[k] / lead_lb) ** (1.0 / (n - k)) for k in range(n) if tot[k] > 0]
    return 2.0 * max(ratios) if ratios else 1.0


def _split_points(box: "_Box", ndim: int) -> np.ndarray:
    """The halving point of every coordinate (geometric for a positive member range)."""
    mid = 0.5 * (box.lo + box.hi)
    if ndim == 6 and box.lo[5] > 0:
        mid[5] = math.sqrt(box.lo[5] * box.hi[5])
    return mid


def _split_axes(box: "_Box", V: np.ndarray, ndim: int) -> np.ndarray:
    """For each row of vertex values ``V`` (n, R), the coordinate whose halving gives the children
    with the largest smaller hull distance. The children's vertex values follow exactly from the
    parent's (Δ is affine in each coordinate), so no coefficient is re-evaluated."""
    n, R = V.shape
    mid = _split_points(box, ndim)
    span = box.hi - box.lo
    t = np.where(span > 0, (mid - box.lo) / np.where(span > 0, span, 1.0), 0.5)
    g = V.reshape((n,) + (2,) * ndim)
    kids = np.empty((n, ndim, 2) + (2,) * ndim, dtype=complex)
    for i in range(ndim):
        a = np.take(g, [0], axis=1 + i)
        b = np.take(g, [1], axis=1 + i)
        m = a + t[i] * (b - a)
        kids[:, i, 0] = np.concatenate([a, m], axis=1 + i)
        kids[:, i, 1] = np.concatenate([m, b], axis=1 + i)
    _, d = hull_distance(kids.reshape(n * ndim * 2, R))
    score = np.min(d.reshape(n, ndim, 2), axis=2)
    score[:, span <= 0] = -np.inf
    spread = np.stack([np.mean(np.abs(np.diff(g, axis=1 + i)).reshape(n, -1), axis=1) for i in range(ndim)], axis=1)
    best = np.argmax(score, axis=1)
    # no split clears the hull yet: halve the coordinate that spreads the values most
    return np.where(np.max(score, axis=1) > 0, best, np.argmax(spread, axis=1))


def _abs_rows(c: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Σ_k |c_k| w^k per row of ``c`` (R, n) at the points ``w`` (W,) → (W, R)."""
    a = np.abs(c)
    out = np.zeros((w.size, c.shape[0]))
    wc = w[:, None]
    for k in range(c.shape[1] - 1, -1, -1):  # in place: the same products and sums, no temporaries
        out *= wc
        out += a[None, :, k]
    return out


def _eval_box(box: _Box, T: float, a: np.ndarray, b: np.ndarray):
    """(certified distance bound over [a, b], hull distance at the midpoints, vertex values at the
    midpoints) of the intervals [a, b] of one box: each vertex value moves by at most
    (b − a)/2 · max|dΔ_v/dω| over the interval, plus a rounding allowance."""
    c = 0.5 * (a + b)
    h = 0.5 * (b - a)
    s = 1j * c
    R = box.P0.shape[0]
    H = _horner(box.P01, s)
    V = H[:, :R] + H[:, R:] * np.exp(-s * T)[:, None]
    B = _abs_rows(box.slope, b)  # Σ|P0'_k| b^k, Σ|P1'_k| b^k, Σ|P1_k| b^k
    L = B[:, :R] + B[:, R:2 * R] + T * B[:, 2 * R:]
    C = _abs_rows(box.P01, c)  # Σ|P0_k| c^k, Σ|P1_k| c^k
    scale = C[:, :R] + C[:, R:]
    slack = h[:, None] * L + ROUND_REL * scale
    d_cert, d_mid = hull_distance(V, slack)
    return d_cert, d_mid, V


def _zero_freq_ok(model: LoopModel, lo, hi, r0: int) -> bool:
    """The hysteretic family's real twin at ω = 0: Δ̃(0) keeps its sign over the box (exact for a
    multilinear real function: its range over a box is spanned by the vertex values)."""
    q, p = model.box_points(lo, hi)
    R0, R1 = model.coeffs(q, p, real_twin=True)
    w = max(R0.shape[1], R1.shape[1])
    v = pad_cols(R0, w)[:, r0] + pad_cols(R1, w)[:, r0]
    return bool(np.all(v > 0) or np.all(v < 0))


def certify_loop(model: LoopModel, lo: np.ndarray, hi: np.ndarray, r0: int, budget: int) -> CertifyResult:
    """Prove 0 ∉ Δ̃(jω, box) for every ω ≥ 0 over the relative box [lo, hi] (Δ̃ = Δ/s^r0, the
    nominal structural roots at s = 0 divided out).

    The frequency axis [0, ω_tail] is covered by intervals; on [a, b] the hull distance at the
    midpoint must exceed the motion bound (b − a)/2 · max|dΔ/dω| plus a rounding allowance, or the
    interval is halved (when the hull is clear of 0) or the box is halved along the coordinate that
    most reduces the hull's spread (when it is not). ``budget`` caps the interval evaluations.

    Parameters
    ----------
    model : LoopModel
        The loop, its controller fixed.
    lo, hi : ndarray, shape (ndim,)
        The box: relative plant deviations δ (dimensionless) and, for a family, the member p.
    r0 : int
        The nominal loop's structural roots at s = 0.
    budget : int
        The most interval evaluations spent.

    Returns
    -------
    CertifyResult
        ``certified``, the evaluations spent, and otherwise the reason, the box hints and the
        frequency [rad/s] where the subdivision stalled.

    References
    ----------
    docs/method.md#plant-uncertainty-margin.
    """
    root = _make_box(model, lo, hi, 0, r0)
    if root is None:
        return CertifyResult(False, 0, "an extra root at s = 0 inside the box")
    if model.complex and not _zero_freq_ok(model, lo, hi, r0):
        return CertifyResult(False, 0, "Δ(0) of the real twin changes sign over the box")
    wt = _tail(root)
    if not math.isfinite(wt):
        return CertifyResult(False, 0, "no uniform tail bound (leading coefficient may vanish or neutral member)")
    boxes = {(tuple(lo), tuple(hi)): root}
    edges = np.r_[0.0, np.geomspace(wt * 1e-7, wt, 600)]
    pending = {(tuple(lo), tuple(hi)): (edges[:-1], edges[1:])}
    used, hints = 0, []
    while pending:
        key, (a, b) = pending.popitem()
        box = boxes[key]
        used += a.size
        if used > budget:
            return CertifyResult(False, used, "work budget exhausted", tuple(hints[-8:]))
        dc, d, V = _eval_box(box, model.T, a, b)
        bad = dc <= 0.0
        if not bad.any():
            continue
        a, b, d, V = a[bad], b[bad], d[bad], V[bad]
        clear = d > 0.0
        too_fine = (b - a) <= 1e-12 * np.maximum(b, 1e-300)
        split_w = clear & ~too_fine
        if split_w.any():  # the hull is clear of 0: halve the interval (the motion bound ∝ width)
            m = 0.5 * (a[split_w] + b[split_w])
            pa, pb = pending.get(key, (np.zeros(0), np.zeros(0)))
            pending[key] = (np.r_[pa, a[split_w], m], np.r_[pb, m, b[split_w]])
        sb = ~split_w
        if not sb.any():
            continue
        if box.depth >= MAX_DEPTH:
            return CertifyResult(False, used, "box subdivision limit", tuple(hints[-8:]), float(a[sb][0]))
        if box.depth >= 3:
            hints.append(0.5 * (box.lo + box.hi))
        axes = {}
        sidx = np.nonzero(sb)[0]
        for i, ax in zip(sidx, _split_axes(box, V[sidx], model.ndim)):
            axes.setdefault(int(ax), []).append(i)
        mids = _split_points(box, model.ndim)
        for ax, idx in axes.items():
            mid = mids[ax]
            lo1, hi1 = box.lo.copy(), box.hi.copy()
            hi1[ax] = mid
            lo2, hi2 = box.lo.copy(), box.hi.copy()
            lo2[ax] = mid
            for clo, chi in ((lo1, hi1), (lo2, hi2)):
                ck = (tuple(clo), tuple(chi))
                if ck not in boxes:
                    child = _make_box(model, clo, chi, box.depth + 1, r0)
                    if child is None:
                        return CertifyResult(False, used, "an extra root at s = 0 inside the box", (0.5 * (clo + chi),))
                    boxes[ck] = child
                pa, pb = pending.get(ck, (np.zeros(0), np.zeros(0)))
                pending[ck] = (np.r_[pa, a[idx]], np.r_[pb, b[idx]])
    return CertifyResult(True, used)
