"""Quasi-polynomials Δ(s) = P0(s) + P1(s)·e^{−sT} and exact root counting (docs/method.md#analyses-and-metrics).

Every closed loop exotune analyses (any controller structure, any rational human or environment,
the DOB, the exact delay) has a characteristic function of this form with a *single* delay:
the DOB substitutes e^{−sT} → e^{−sT} d_q/(d_q − n_q + n_q e^{−sT}), which keeps Δ affine in e^{−sT}.
With deg P1 < deg P0 (retarded type, guaranteed by proper controller blocks) Δ has finitely many
right-half-plane (RHP) zeros and the argument principle on the imaginary axis counts them:

    N_RHP = ( n·π/2 + ψ − Δθ ) / π,      Δθ = arg Δ(j∞) − arg Δ(j0) (continuous),

n = deg P0, ψ = atan(Im c_n / Re c_n) for the leading coefficient c_n (0 for real Δ). This is
the Nyquist criterion for 1 + L with L = P1 e^{−sT}/P0 multiplied through by the open-loop
characteristic polynomial P0: the open-loop poles (roots of P0, however close to the axis)
become ordinary, smooth points of Δ, and the number of open-loop RHP poles is accounted for
exactly instead of being assumed.

The phase is followed on an *adaptive* frequency set: an interval [a, b] is accepted only when
the wrapped phase step is < 0.8 rad **and** h·|L(b) − L(a)| ≤ 1 with L = Δ'/Δ and h = b − a.
A zero of Δ at distance σ from the axis inside the interval makes h·|L(b) − L(a)| ≈ h²/(σ² + h²/4),
so an accepted interval has h ≲ 1.2σ and that zero moves the phase by < 1.1 rad across it: an
interval that steps over a near-axis zero is always split, down to the zero's own damping
(10⁻⁵ rad/s or less costs ~25 bisections, only there), while the smooth background of distant
zeros (L ≈ n/ω) does not force dense sampling.
The tail ω > ω_max is bounded analytically (no sampling): ω_max is chosen so that for every
ω ≥ ω_max, |Σ_{k<n} c_k (jω)^k| ≤ ¼|c_n ω^n| and |P1(jω)| ≤ ¼|P0(jω)|.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .engine import resolve_engine as _engine
from .poly import degree, leading, pder
from .budgets import MAX_GROUP_EVALS, MAX_TASK_EVALS, MAX_TASK_LEAVES
from .timebudget import check_time

__all__ = ["QP", "count_rhp", "omega_max", "adaptive_leaves", "bisect_roots", "golden_max", "dip_candidates", "dip_rise", "DIP_RISE", "DIP_RISE_UNEVEN"]

ARG_STEP = 0.8  # max accepted phase step per interval [rad] (any value < π keeps unwrapping exact)
DER_STEP = 1.0  # max accepted (b − a)·|Δ'/Δ(b) − Δ'/Δ(a)| per interval
MAX_LEVELS = 64
# a sampled local minimum of a function of one sign is searched for the other sign when it is
# nearer to 0 than DIP_RISE times its rise to the higher neighbour (see dip_candidates): evenly
# spaced samples, and unevenly spaced ones (the passivity samples: at least DIP_RISE_UNEVEN, more
# where the neighbouring cells differ in length, see dip_rise)
DIP_RISE = 0.5
DIP_RISE_UNEVEN = 2.0
_TAN_ARG = float(np.tan(ARG_STEP))


@dataclass(frozen=True)
class QP:
    """A batch of quasi-polynomials: rows of ``p0``/``p1`` (ascending coefficients), delays ``T``."""

    p0: np.ndarray
    p1: np.ndarray
    T: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "T", np.broadcast_to(np.asarray(self.T, dtype=float), self.p0.shape[:1]).copy())
        # contiguous coefficient columns for fast row gathers in Horner's rule
        object.__setattr__(self, "_c0", np.ascontiguousarray(np.asarray(self.p0).T))
        object.__setattr__(self, "_c1", np.ascontiguousarray(np.asarray(self.p1).T))

    @property
    def n(self) -> int:
        return self.p0.shape[0]

    def parts(self, idx: np.ndarray, w: np.ndarray):
        """P0(jω) and P1(jω) (the polynomial parts, without the delay) for rows ``idx``."""
        return _horner_vd(self._c0, idx, 1j * w, False)[0], self.delayed_part(idx, w)

    def delayed_part(self, idx: np.ndarray, w: np.ndarray):
        """P1(jω), the polynomial that multiplies the delay, for rows ``idx``."""
        return _horner_vd(self._c1, idx, 1j * w, False)[0]

    def take(self, idx) -> "QP":
        return QP(self.p0[idx], self.p1[idx], self.T[idx])

    def eval(self, idx: np.ndarray, w: np.ndarray, deriv: bool = True):
        """Δ(jω) and dΔ/ds at s = jω for rows ``idx`` (flat arrays of equal length)."""
        s = 1j * w
        e = np.exp(-s * self.T[idx])
        v0, d0 = _horner_vd(self._c0, idx, s, deriv)
        v1, d1 = _horner_vd(self._c1, idx, s, deriv)
        val = v0 + v1 * e
        if not deriv:
            return val, None
        return val, d0 + (d1 - self.T[idx] * v1) * e


def _horner_vd(cT: np.ndarray, idx: np.ndarray, s: np.ndarray, deriv: bool):
    """Value and derivative of rows ``idx`` at ``s`` in one Horner pass; ``cT`` holds the
    coefficients transposed (power-major, contiguous) so each gather is a 1-D take."""
    m = cT.shape[0]
    rows = cT[:, idx]  # one gather of every power's coefficients (the same values as a take per power)
    v = rows[m - 1].astype(complex)
    d = np.zeros_like(v) if deriv else None
    for k in range(m - 2, -1, -1):
        if deriv:
            d = d * s + v
        v = v * s + rows[k]
    return v, d


def _der(c: np.ndarray) -> np.ndarray:
    d = pder(c)
    return d if d.shape[-1] else np.zeros(c.shape[:-1] + (1,), c.dtype)


def omega_max(p0: np.ndarray, p1: np.ndarray, frac: float = 0.25, engine: str | None = None) -> np.ndarray:
    """A frequency beyond which the tail bounds of the module docstring hold, in closed form.

    With n = deg P0 and m_k the number of terms, requiring every term of
    δ(ω) = Σ_{k<n} |c_k| ω^{k−n}/|c_n| to be ≤ frac/n0 and every term of
    ρ(ω) = Σ_k |p1_k| ω^{k−n}/(|c_n|(1 − frac)) to be ≤ frac/n1 gives
    ω ≥ (n0 |c_k| / (frac |c_n|))^{1/(n−k)} and ω ≥ (n1 |p1_k| / (frac (1−frac) |c_n|))^{1/(n−k)};
    both sums are non-increasing in ω, so the bounds hold on the whole tail.
    Returns +inf for rows that are not of retarded type (deg P1 ≥ deg P0) or where P0 ≡ 0.
    Compiled (:func:`exotune._fastphase.omega_max`) unless the numpy engine is selected.

    Parameters
    ----------
    p0, p1 : numpy.ndarray
        Rows (T, ·) of the quasi-polynomials' P0 and P1, ascending coefficients.
    frac : float, optional
        The tail bounds' fraction (0 < frac < 1).
    engine : str or None, optional
        ``"numba"`` or ``"numpy"``; None chooses (:func:`exotune.numerics.engine.resolve_engine`).

    Returns
    -------
    numpy.ndarray
        ω_max [rad/s] per row, +inf where no tail bound holds.
    """
    if _engine(engine) == "numba":
        from . import kernels as _fastphase

        return _fastphase.omega_max(p0, p1, frac)
    n = degree(p0)
    cn = np.abs(leading(p0))
    deg1 = degree(p1)
    a0 = np.abs(p0)
    a1 = np.abs(p1)
    k0 = np.arange(p0.shape[-1])[None, :]
    k1 = np.arange(p1.shape[-1])[None, :]
    nn = n[:, None]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        m0 = (k0 < nn) & (a0 > 0)
        cnt0 = np.maximum(m0.sum(-1), 1)[:, None]
        e0 = np.where(m0, np.exp(np.log(cnt0 * a0 / (frac * cn[:, None])) / (nn - k0)), 0.0)
        m1 = a1 > 0
        cnt1 = np.maximum(m1.sum(-1), 1)[:, None]
        e1 = np.where(m1 & (k1 < nn), np.exp(np.log(cnt1 * a1 / (frac * (1 - frac) * cn[:, None])) / (nn - k1)), 0.0)
        w = np.maximum(e0.max(-1, initial=0.0), e1.max(-1, initial=0.0))
    ok = (cn > 0) & (deg1 < n) & np.isfinite(w)
    w = np.where(w > 0, w, 1.0)
    return np.where(ok, w * 1.0000001, np.inf)


def adaptive_leaves(evalfn, ntask: int, grid: np.ndarray, valid: np.ndarray | None = None, extra_ok=None,
                    geometric: bool = False, max_evals: int | None = None, cut=None, max_leaves=None,
                    depth0=None):
    """Adaptive refinement of per-task frequency grids.

    ``evalfn(idx, w) -> list[(val, der)]`` evaluates the tracked functions at s = jω.
    ``extra_ok(task, a, b, va, vb, da, db) -> bool array`` optionally adds an acceptance test
    (e.g. a magnitude criterion); intervals failing it are split but never marked unresolved.
    ``grid`` has shape (T, K), increasing along axis 1. Returns a dict of flat arrays describing
    the accepted leaf intervals: ``task, a, b`` and per tracked function ``va[i], vb[i]``; plus a
    per-task boolean ``resolved`` (False where refinement hit the resolution floor or a value was
    not finite / exactly zero — a zero on the imaginary axis).
    ``geometric``: split intervals wider than a ratio ``_fastphase.GEO_SPLIT_RATIO`` at their
    geometric mean instead of their midpoint (the argument-principle counts do; same rule as the
    compiled kernel).

    One function on purpose (over 80 lines): it is the numpy reference of the compiled kernel
    :func:`exotune.numerics.kernels.leaves` and follows its loop step by step, so that the two can
    be read side by side; its work list, budget and leaf arrays are shared by every step.

    Parameters
    ----------
    evalfn : callable
        ``evalfn(idx, w)``: the tracked functions' (value, derivative) at s = jω, ω = ``w``
        [rad/s].
    ntask : int
        Number of tasks (rows).
    grid : numpy.ndarray
        Initial grid per task (T, K) [rad/s], increasing.
    valid : numpy.ndarray or None, optional
        Tasks to refine (T,), bool; None for all.
    extra_ok : callable or None, optional
        An extra acceptance test of an interval, as described above.
    geometric : bool, optional
        Split wide intervals at their geometric mean.
    max_evals : int or None, optional
        Budget per task in evaluations (the argument-principle counts: ``MAX_TASK_EVALS``, as
        :func:`exotune.numerics.kernels.phase_sums`) instead of ``MAX_TASK_LEAVES`` leaves.
    cut : callable or None, optional
        ``cut(task, a, b, va, vb) -> bool array``: an accepted leaf that holds what the search is
        for (the first −3 dB crossing of the amplification bandwidth); nothing right of the
        leftmost such leaf of a task is refined further, as the compiled kernel stops its
        left-to-right search there (so a task is not exhausted by a range it does not need).
    max_leaves : numpy.ndarray or None, optional
        Leaf budget per task (T,) instead of ``MAX_TASK_LEAVES`` (what is left of it when a search
        is continued cell by cell, :func:`leaves_pair`).
    depth0 : numpy.ndarray or None, optional
        Halvings already spent per task (T,): a grid cell that is itself a half of a half… of an
        initial cell reaches the resolution floor ``MAX_LEVELS`` as that initial cell would.

    Returns
    -------
    dict
        The accepted leaves as flat arrays (``task``, ``a``, ``b`` [rad/s], the tracked functions'
        values at both ends) and ``resolved`` per task.
    """
    T, K = grid.shape
    if valid is None:
        valid = np.ones(T, bool)
    tasks = np.nonzero(valid)[0]
    idx = np.repeat(tasks, K)
    w = grid[tasks].ravel()
    vals = evalfn(idx, w)
    nf = len(vals)
    V = [v.reshape(len(tasks), K) for v, _ in vals]
    D = [d.reshape(len(tasks), K) for _, d in vals]
    # intervals between consecutive points
    ti = np.repeat(tasks, K - 1)
    a = grid[tasks, :-1].ravel()
    b = grid[tasks, 1:].ravel()
    va = [x[:, :-1].ravel() for x in V]
    vb = [x[:, 1:].ravel() for x in V]
    da = [x[:, :-1].ravel() for x in D]
    db = [x[:, 1:].ravel() for x in D]
    resolved = np.ones(ntask, bool)
    exhausted = np.zeros(ntask, bool)
    nleaf = np.zeros(ntask, np.int64)
    nev = np.zeros(ntask, np.int64)
    nev[tasks] = K
    limit = np.full(ntask, np.inf)  # per task: refine nothing right of this (``cut``)
    out_t, out_a, out_b = [], [], []
    out_va = [[] for _ in range(nf)]
    out_vb = [[] for _ in range(nf)]
    for level in range(MAX_LEVELS + 1):
        if ti.size == 0:
            break
        check_time()  # an enclosing time budget (analyze --time-budget-s) stops a pathological design
        h = b - a
        ok = np.ones(ti.size, bool)
        bad = np.zeros(ti.size, bool)
        for i in range(nf):
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                ratio = vb[i] / va[i]
                # |arg ratio| ≤ ARG_STEP without computing the angle
                small_arg = (ratio.real > 0) & (np.abs(ratio.imag) <= _TAN_ARG * ratio.real)
                # change of the logarithmic derivative across the interval: a zero at distance
                # σ from the axis inside (or next to) [a, b] makes h·|L(b) − L(a)| ≳ h²/(σ² + h²/4),
                # while the smooth background of distant zeros (≈ n/ω) barely changes
                La = da[i] / va[i]
                Lb = db[i] / vb[i]
                crit = h * np.abs(Lb - La)
                # the trapezoid estimate of the phase change, ∫ Re L dω ≈ h (Re L_a + Re L_b)/2,
                # must agree with the measured principal step (guards against L_a ≈ L_b by
                # coincidence while the phase winds in between)
                trap = np.abs(0.5 * h * (La.real + Lb.real) - np.angle(ratio))
                crit = np.maximum(crit, 2.0 * trap)
            # an exact zero at ω = 0 (a structural root at s = 0) is known, not sampled: the
            # function is skipped on the first interval [0, ω1] only
            skip = (a == 0) & (va[i] == 0) & (vb[i] != 0) & np.isfinite(vb[i])
            fin = np.isfinite(ratio) & np.isfinite(crit) & (va[i] != 0) & (vb[i] != 0)
            bad |= ~fin & ~skip
            ok &= skip | (fin & small_arg & (crit <= DER_STEP))
        floor = h <= 1e-13 * np.maximum(np.abs(b), 1e-300)
        ok_phase = ok.copy()
        if extra_ok is not None:
            ok &= extra_ok(ti, a, b, va, vb, da, db) | bad
            floor = floor | (ok_phase & (h <= 1e-9 * np.maximum(np.abs(b), 1e-300)))
        if depth0 is None and level == MAX_LEVELS:
            floor[:] = True
        elif depth0 is not None:
            floor |= level + depth0[ti] >= MAX_LEVELS
        stop = ok | floor | bad
        unres = (floor & ~ok_phase) | bad
        if unres.any():
            resolved[np.unique(ti[unres])] = False
        if stop.any():
            out_t.append(ti[stop])
            out_a.append(a[stop])
            out_b.append(b[stop])
            for i in range(nf):
                out_va[i].append(va[i][stop])
                out_vb[i].append(vb[i][stop])
        go = ~stop
        if cut is not None:
            j = np.nonzero(stop & ~bad)[0]
            if j.size:
                hit = cut(ti[j], a[j], b[j], [x[j] for x in va], [x[j] for x in vb])
                np.minimum.at(limit, ti[j[hit]], b[j[hit]])
            go &= a < limit[ti]
        nleaf += np.bincount(ti[stop], minlength=ntask)
        # the compiled kernel's per-task budget (MAX_TASK_LEAVES): a task whose leaves would pass
        # it is dropped, unresolved (the same verdicts; its partial leaves may differ)
        ngo = np.bincount(ti[go], minlength=ntask)
        budget = MAX_TASK_LEAVES if max_leaves is None else max_leaves
        over = nleaf + 2 * ngo > budget if max_evals is None else nev + ngo > max_evals
        if over.any():
            resolved[over] = False
            exhausted[over] = True
            go &= ~over[ti]
        if not go.any():
            break
        nev += np.bincount(ti[go], minlength=ntask)
        ti, a, b = ti[go], a[go], b[go]
        va = [x[go] for x in va]
        vb = [x[go] for x in vb]
        da = [x[go] for x in da]
        db = [x[go] for x in db]
        m = 0.5 * (a + b)
        if geometric:
            from .budgets import GEO_SPLIT_RATIO

            with np.errstate(divide="ignore", invalid="ignore"):
                wide = (a > 0) & (b > GEO_SPLIT_RATIO * a)
                m = np.where(wide, a * np.sqrt(b / np.where(wide, a, 1.0)), m)
        mv = evalfn(ti, m)
        ti = np.concatenate([ti, ti])
        a, b = np.concatenate([a, m]), np.concatenate([m, b])
        va = [np.concatenate([va[i], mv[i][0]]) for i in range(nf)]
        vb = [np.concatenate([mv[i][0], vb[i]]) for i in range(nf)]
        da = [np.concatenate([da[i], mv[i][1]]) for i in range(nf)]
        db = [np.concatenate([mv[i][1], db[i]]) for i in range(nf)]
    cat = lambda xs, dt=float: np.concatenate(xs) if xs else np.zeros(0, dt)
    res = {
        "task": cat(out_t, int),
        "a": cat(out_a),
        "b": cat(out_b),
        "va": [cat(x, complex) for x in out_va],
        "vb": [cat(x, complex) for x in out_vb],
        "resolved": resolved,
        "exhausted": exhausted,
        "evaluations": nev,
    }
    order = np.lexsort((res["a"], res["task"]))
    for key in ("task", "a", "b"):
        res[key] = res[key][order]
    res["va"] = [x[order] for x in res["va"]]
    res["vb"] = [x[order] for x in res["vb"]]
    return res


def log_grid(wmax: np.ndarray, decades: float = 9.0, per_decade: int = 8) -> np.ndarray:
    """Per-task grid: 0, then log-spaced from wmax·10^-decades to wmax."""
    K = int(decades * per_decade) + 1
    u = np.linspace(-decades, 0.0, K)
    g = wmax[:, None] * 10.0 ** u[None, :]
    return np.concatenate([np.zeros((len(wmax), 1)), g], axis=1)


def leaves_pair(qa: QP, qb: QP, grid: np.ndarray, valid: np.ndarray, magnitude_ok=None, lthr=None, engine: str | None = None):
    """Adaptive leaves tracking two quasi-polynomials with equal delays (compiled when possible).

    ``magnitude_ok``/``lthr``: the amplification-bandwidth magnitude criterion (numpy callback /
    per-task log −3 dB level for the compiled kernel)."""
    if _engine(engine) == "numba":
        from . import kernels as _fastphase

        return _fastphase.leaves2(qa, qb, grid, valid, ARG_STEP, DER_STEP, MAX_LEVELS, lthr=lthr)

    def evalfn(i, w):
        return [qa.eval(i, w), qb.eval(i, w)]

    if lthr is None:
        return adaptive_leaves(evalfn, qa.n, grid, valid)

    def first_crossing(t, a, b, va, vb):
        # the compiled kernel's stop: a leaf clearly bracketing the first −3 dB down-crossing
        lev = np.exp(lthr[t])
        with np.errstate(divide="ignore", invalid="ignore"):
            return (np.abs(va[0] / va[1]) > lev * (1.0 + 1e-9)) & (np.abs(vb[0] / vb[1]) < lev * (1.0 - 1e-9))

    lv = adaptive_leaves(evalfn, qa.n, grid, valid, extra_ok=magnitude_ok, cut=first_crossing)
    if lv["exhausted"].any():
        lv = _rescan_left_to_right(lv, evalfn, qa.n, grid, magnitude_ok, first_crossing)
    return lv


def _rescan_left_to_right(lv: dict, evalfn, ntask: int, grid: np.ndarray, extra_ok, cut) -> dict:
    """The tasks of a level-by-level bandwidth search that spent their leaf budget, searched again
    from the left as the compiled kernel does (depth first): the budget is spent only left of the
    first −3 dB crossing, and a task stops at the cell whose leaves bracket it.

    Each round refines every such task's leftmost pending cell level by level; a cell that would
    pass the task's remaining budget is replaced by its two halves (the same halves the refinement
    makes, with their depth), so memory stays bounded by one cell per task and the leaves are the
    compiled kernel's."""
    redo = lv["exhausted"]
    left = np.where(redo, MAX_TASK_LEAVES, 0).astype(np.int64)
    resolved = np.ones(ntask, bool)
    exhausted = np.zeros(ntask, bool)
    pending = {int(t): [(grid[t, j], grid[t, j + 1], 0) for j in range(grid.shape[1] - 2, -1, -1)]
               for t in np.nonzero(redo)[0]}
    parts = []
    while pending:
        ts = np.array(sorted(pending))
        cells = np.array([pending[t].pop() for t in ts])
        g = np.zeros((ntask, 2))
        g[ts] = cells[:, :2]
        depth = np.zeros(ntask, np.int64)
        depth[ts] = cells[:, 2]
        act = np.zeros(ntask, bool)
        act[ts] = True
        cell = adaptive_leaves(evalfn, ntask, g, act, extra_ok=extra_ok, cut=cut, max_leaves=left, depth0=depth)
        spent = cell["exhausted"] & act
        for t, (a, b, d) in zip(ts, cells):
            if spent[t] and left[t] > 0 and d < MAX_LEVELS:
                m = 0.5 * (a + b)
                pending[t] += [(m, b, d + 1), (a, m, d + 1)]
            elif spent[t]:
                exhausted[t] = True
                pending[t] = []
        t = cell["task"]
        kept = ~spent[t]
        leaf = {key: cell[key][kept] for key in ("task", "a", "b")}
        leaf["va"] = [x[kept] for x in cell["va"]]
        leaf["vb"] = [x[kept] for x in cell["vb"]]
        parts.append(leaf)
        left -= np.bincount(leaf["task"], minlength=ntask)
        resolved &= cell["resolved"] | spent | ~act
        with np.errstate(invalid="ignore", divide="ignore"):
            clean = np.logical_and.reduce([np.isfinite(x) & (x != 0) for x in leaf["va"] + leaf["vb"]])
            hit = leaf["task"][clean & cut(leaf["task"], leaf["a"], leaf["b"], leaf["va"], leaf["vb"])]
        for t in set(hit.tolist()) | {t for t in pending if not pending[t]}:
            pending.pop(t, None)
    keep = ~redo[lv["task"]]
    out = {key: np.concatenate([lv[key][keep]] + [c[key] for c in parts]) for key in ("task", "a", "b")}
    for end in ("va", "vb"):
        out[end] = [np.concatenate([lv[end][i][keep]] + [c[end][i] for c in parts]) for i in range(len(lv[end]))]
    order = np.lexsort((out["a"], out["task"]))
    for key in ("task", "a", "b"):
        out[key] = out[key][order]
    for end in ("va", "vb"):
        out[end] = [x[order] for x in out[end]]
    out["resolved"] = np.where(redo, resolved & ~exhausted, lv["resolved"])
    out["exhausted"] = exhausted
    return out


def phase_sums(q: QP, grid: np.ndarray, valid: np.ndarray, engine: str | None = None):
    """Σ of the accepted principal phase steps of Δ(jω) over each task's grid, and whether every
    interval was resolved. ``engine``: "numba" (compiled kernel, default when numba is
    installed and EXOTUNE_NUMPY_ONLY is unset) or "numpy" (the reference implementation)."""
    total, resolved, _, _ = _phase_sums_counted(q, grid, valid, engine)
    return total, resolved


def _phase_sums_counted(q: QP, grid: np.ndarray, valid: np.ndarray, engine: str | None = None, max_evals=None):
    """:func:`phase_sums` with, per task, the evaluations spent and whether its budget ran out
    (both engines spend the same evaluations: one per grid point, one per split). ``max_evals``
    (numpy engine): the budget per task, a number or one per task (default MAX_TASK_EVALS)."""
    if _engine(engine) == "numba":
        from . import kernels as _fastphase

        total, resolved, cnt = _fastphase.phase_sums(q.p0, q.p1, q.T, grid, valid, ARG_STEP, DER_STEP, MAX_LEVELS)
        return total, resolved, cnt, valid & ~resolved & (cnt >= MAX_TASK_EVALS)
    budget = MAX_TASK_EVALS if max_evals is None else max_evals
    lv = adaptive_leaves(lambda idx, w: [q.eval(idx, w)], q.n, grid, valid, geometric=True, max_evals=budget)
    with np.errstate(divide="ignore", invalid="ignore"):
        steps = np.angle(lv["vb"][0] / lv["va"][0])
    return np.bincount(lv["task"], weights=steps, minlength=q.n), lv["resolved"], lv["evaluations"], lv["exhausted"]


def _phase_sums_grouped(q: QP, grid: np.ndarray, valid: np.ndarray, group: np.ndarray):
    """:func:`_phase_sums_counted` on the numpy engine where consecutive tasks of one ``group``
    share MAX_GROUP_EVALS in queue order, as in :func:`exotune.numerics.kernels.count_tasks`: a
    task gets min(MAX_TASK_EVALS, what is left) and is unresolved when it needs more.

    All tasks first run together, each within an equal share of its group's budget (so the work in
    flight, and the memory, stay bounded by the group budget even for a family of 1 000 sub-interval
    counts); a task that needed more is run again alone with the budget the queue order leaves it
    (:func:`_group_budget`'s ``rerun``). A task that fits its share gets the same result as with the
    compiled kernel's allowance, which is never smaller than the share. Returns (total, resolved)."""
    starts = np.flatnonzero(np.r_[True, group[1:] != group[:-1]]) if group.size else np.zeros(0, int)
    ends = np.r_[starts[1:], group.size]
    share = np.repeat(np.minimum(MAX_TASK_EVALS, MAX_GROUP_EVALS // np.maximum(ends - starts, 1)), ends - starts)
    total, resolved, evals, exhausted = _phase_sums_counted(q, grid, valid, engine="numpy", max_evals=share)

    def rerun(t, b):
        if not (exhausted[t] and share[t] < b):
            return None  # its share was enough: the result stands
        one = _phase_sums_counted(q.take(np.array([t])), grid[t:t + 1], np.ones(1, bool), engine="numpy", max_evals=b)
        total[t] = one[0][0]
        return one[1][0], one[2][0], one[3][0]

    return total, _group_budget(resolved, valid, evals, exhausted, group, rerun)


def _group_budget(ok: np.ndarray, valid: np.ndarray, evals: np.ndarray, exhausted: np.ndarray, group: np.ndarray,
                  rerun=None):
    """Consecutive tasks of one ``group`` share MAX_GROUP_EVALS, in queue order, as in
    :func:`exotune.numerics.kernels.count_tasks`: a task gets min(MAX_TASK_EVALS, what is left) and
    is unresolved when it needs more; once the group's budget is spent the rest are unresolved.
    ``rerun(t, allowance)``: optionally counts task t again with its allowance, returning its new
    (resolved, evaluations, exhausted), or None to keep the result it has."""
    ok, evals, exhausted = ok.copy(), evals.copy(), exhausted.copy()
    spent = np.where(valid, np.where(exhausted, MAX_TASK_EVALS, evals), 0)
    starts = np.flatnonzero(np.r_[True, group[1:] != group[:-1]])
    for lo, hi in zip(starts, np.r_[starts[1:], group.size]):
        if rerun is None and spent[lo:hi].sum() <= MAX_GROUP_EVALS:
            continue  # the whole group fits: nothing changes
        left = MAX_GROUP_EVALS
        for t in range(lo, hi):
            if not valid[t]:
                continue
            if left <= 0:
                ok[t] = False
                continue
            b = min(MAX_TASK_EVALS, left)
            again = rerun(t, b) if rerun is not None else None
            if again is not None:
                ok[t], evals[t], exhausted[t] = again
            if exhausted[t] or evals[t] > b:
                ok[t] = False
                left -= b
            else:
                left -= evals[t]
    return ok


def count_rhp(qp: QP, v0: np.ndarray | None = None, per_decade: int = 2, group: np.ndarray | None = None):
    """Number of zeros of Δ in the open RHP, by the argument principle (module docstring).

    ``v0`` optionally overrides Δ(j0) (a real number per row): used for the hysteretic
    (complex-stiffness) human, whose Z(jω) = k(1 + jη sign ω) is regularized through the real
    value k at ω = 0 (the jump to 0+ is the straight segment, which never passes through 0).

    Returns ``(N, conclusive)``: integer counts and a flag that is False when a zero lies on (or
    within the float resolution of) the imaginary axis, the type is not retarded, or the count is
    not an integer — callers must treat inconclusive as **not stable**.

    Parameters
    ----------
    qp : QP
        The batch of quasi-polynomials Δ(s) = P0(s) + P1(s) e^{−sT}.
    v0 : numpy.ndarray or None, optional
        Δ(j0) per row, overriding the evaluated value (NaN keeps it); None for none.
    per_decade : int, optional
        Initial grid points per decade of frequency.
    group : numpy.ndarray or None, optional
        Work-budget group per row: consecutive rows with the same id share MAX_GROUP_EVALS (as
        :func:`exotune.numerics.kernels.count_tasks`); None: every row its own group.

    Returns
    -------
    N : numpy.ndarray
        Number of open-RHP zeros per row (int; −1 where not finite).
    conclusive : numpy.ndarray
        Whether each count holds (bool).
    """
    p0 = np.asarray(qp.p0)
    p1 = np.asarray(qp.p1)
    T = qp.T
    # zero delay: fold P1 into P0 (Δ is then an ordinary polynomial)
    z = T == 0
    if z.any():
        n = max(p0.shape[-1], p1.shape[-1])
        p0 = np.pad(p0, ((0, 0), (0, n - p0.shape[-1]))).astype(np.result_type(p0, p1))
        p1 = np.pad(p1, ((0, 0), (0, n - p1.shape[-1]))).astype(np.result_type(p0, p1))
        p0[z] = p0[z] + p1[z]
        p1[z] = 0
    q = QP(p0, p1, T)
    ntask = q.n
    wmax = omega_max(p0, p1)
    valid = np.isfinite(wmax)
    grid = log_grid(np.where(valid, wmax, 1.0), decades=6, per_decade=per_decade)
    if group is not None and _engine(None) != "numba":
        total, resolved = _phase_sums_grouped(q, grid, valid, np.asarray(group))
    else:
        total, resolved, evals, exhausted = _phase_sums_counted(q, grid, valid)
        if group is not None:
            resolved = _group_budget(resolved, valid, evals, exhausted, np.asarray(group))
    idx = np.arange(ntask)
    vmax, _ = q.eval(idx, np.where(valid, wmax, 1.0), deriv=False)
    n = degree(p0)
    cn = leading(p0)
    tail = np.angle(cn * (1j ** n) / vmax)
    total = total + tail
    base, _ = q.eval(idx, np.zeros(ntask), deriv=False)
    if v0 is not None:
        v0 = np.asarray(v0, dtype=complex)
        use = np.isfinite(v0)
        with np.errstate(divide="ignore", invalid="ignore"):
            jump = np.angle(base / np.where(use, v0, 1.0))
        total = total + np.where(use, jump, 0.0)
        base = np.where(use, v0, base)
    psi = np.arctan(np.imag(cn) / np.real(cn)) if np.iscomplexobj(cn) else np.zeros(ntask)
    N = (n * np.pi / 2 + psi - total) / np.pi
    Nr = np.rint(N)
    conclusive = valid & resolved & (np.abs(N - Nr) < 0.05) & (base != 0) & np.isfinite(N)
    return np.where(np.isfinite(Nr), Nr, -1).astype(int), conclusive


def bisect_roots(fun, task: np.ndarray, a: np.ndarray, b: np.ndarray, fa: np.ndarray, iters: int = 100, fb=None):
    """Vectorized Illinois (modified regula falsi) on sign changes of real ``fun(task, w)``.

    Brackets are kept (the Illinois modification makes both ends move), so convergence is
    guaranteed; every bracket is shrunk to a relative width of 1e-14 (or ``iters`` steps).

    Parameters
    ----------
    fun : callable
        ``fun(task, w)``: real values of the tracked function at ``w`` for the rows ``task``.
    task : numpy.ndarray
        Row per bracket (int).
    a, b : numpy.ndarray
        Bracket ends, with a sign change of ``fun`` between them.
    fa : numpy.ndarray
        ``fun`` at ``a``.
    iters : int, optional
        Most steps.
    fb : numpy.ndarray or None, optional
        ``fun`` at ``b``, evaluated when None.

    Returns
    -------
    numpy.ndarray
        The midpoint of each final bracket (a root).
    """
    a = a.astype(float).copy()
    b = b.astype(float).copy()
    fa = fa.astype(float).copy()
    fb = fun(task, b) if fb is None else fb.astype(float).copy()
    side = np.zeros(a.shape, int)
    x = 0.5 * (a + b)
    act = np.ones(a.shape, bool)
    for _ in range(iters):
        act &= np.abs(b - a) > 1e-14 * np.maximum(np.abs(b), 1e-300)
        if not act.any():
            break
        with np.errstate(divide="ignore", invalid="ignore"):
            x = (a * fb - b * fa) / (fb - fa)
        bad = ~np.isfinite(x) | (x <= np.minimum(a, b)) | (x >= np.maximum(a, b))
        x = np.where(bad, 0.5 * (a + b), x)
        fx = np.zeros_like(x)
        fx[act] = fun(task[act], x[act])
        left = (np.sign(fx) == np.sign(fa)) & act
        right = ~left & act
        # Illinois: halve the retained end's value when the same side is kept twice
        fb = np.where(left & (side == 1), 0.5 * fb, fb)
        fa = np.where(right & (side == -1), 0.5 * fa, fa)
        a = np.where(left, x, a)
        fa = np.where(left, fx, fa)
        b = np.where(right, x, b)
        fb = np.where(right, fx, fb)
        side = np.where(left, 1, np.where(right, -1, side))
        hit = (fx == 0) & act
        a = np.where(hit, x, a)
        b = np.where(hit, x, b)
    return 0.5 * (a + b)


def golden_max(f, a_, b_, iters: int = 40, where: bool = False, best: bool = False):
    """Maximum of the vectorized ``f`` on each bracket [a_, b_] by ``iters`` golden-section steps
    (numpy reference of :func:`exotune.numerics.kernels.golden_max`, the same iteration).

    Parameters
    ----------
    f : callable
        ``f(w)``: real values at the points ``w`` (one per bracket).
    a_, b_ : numpy.ndarray
        The brackets' ends.
    iters : int, optional
        Golden-section steps (one new evaluation each).
    where : bool, optional
        Also return where each maximum was found.
    best : bool, optional
        Return the larger of the two final interior points (NaN ignored) instead of evaluating ``f``
        once more at the final bracket's midpoint.

    Returns
    -------
    numpy.ndarray, or (numpy.ndarray, numpy.ndarray) when ``where``
        ``f`` at the final bracket's midpoint (``best``: at the better interior point), and that point.
    """
    gr = 0.5 * (np.sqrt(5) - 1)
    c1 = b_ - gr * (b_ - a_)
    c2 = a_ + gr * (b_ - a_)
    f1, f2 = f(c1), f(c2)
    for _ in range(iters):  # golden section, one new evaluation per iteration
        left = f1 >= f2
        b_ = np.where(left, c2, b_)
        a_ = np.where(left, a_, c1)
        c2n = np.where(left, c1, a_ + gr * (b_ - a_))
        c1n = np.where(left, b_ - gr * (b_ - a_), c2)
        new = np.where(left, c1n, c2n)
        fn = f(new)
        f1, f2 = np.where(left, fn, f2), np.where(left, f1, fn)
        c1, c2 = c1n, c2n
    if best:
        fm, wm = np.fmax(f1, f2), np.where(f1 >= f2, c1, c2)
    else:
        wm = 0.5 * (a_ + b_)
        fm = f(wm)
    return (fm, wm) if where else fm


def dip_rise(h1, h2, least: float = DIP_RISE_UNEVEN):
    """The dip test's factor for a sample between cells of lengths ``h1`` and ``h2``:
    max(``least``, 1/(ρ(1 + ρ))) with ρ = min(h1, h2)/max(h1, h2) (infinite when a cell is empty).

    A parabola through three samples whose middle one is the nearest to 0 dips below it by at most
    1/(4ρ(1 + ρ)) times the rise to the higher neighbour (the bound is attained when the other
    neighbour is level with the middle sample); this factor keeps four times that margin, so a
    minimum of the other sign between samples of any spacing is searched
    (docs/method.md#passivity-of-the-operator-compliance).

    Parameters
    ----------
    h1, h2 : numpy.ndarray
        The lengths of the cells before and after the middle sample (≥ 0).
    least : float, optional
        The smallest factor.

    Returns
    -------
    numpy.ndarray
        The factor for :func:`dip_candidates`.
    """
    h1, h2 = np.asarray(h1, float), np.asarray(h2, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = np.minimum(h1, h2) / np.maximum(h1, h2)
        return np.maximum(least, np.where(rho > 0, 1.0 / (rho * (1.0 + rho)), np.inf))


def dip_candidates(uq, up, un, rise: float = DIP_RISE):
    """Which middle points of three consecutive samples ``(uq, up, un)`` of one sign s may hide a
    pair of sign changes between the outer two: s·u has a local minimum at the middle point that is
    nearer to 0 than ``rise`` times its rise to the higher neighbour.

    A smooth minimum sampled evenly (a parabola, or a sinusoid at 8 points per period) lies below
    its sampled value by at most a quarter of that rise, so with ``DIP_RISE`` (½) a minimum of the
    other sign always passes the test, with a factor 2 to spare. Unevenly spaced samples have no
    bound that ignores their spacing (the minimum can sit deep in the longer cell): they use
    :func:`dip_rise`, at least ``DIP_RISE_UNEVEN`` (2).

    Parameters
    ----------
    uq, up, un : numpy.ndarray
        The normalized function at the three points (NaN: never a candidate).
    rise : float or numpy.ndarray, optional
        The factor of the test (one per point: :func:`dip_rise`).

    Returns
    -------
    cand : numpy.ndarray of bool
        The candidates.
    sign : numpy.ndarray
        s, the sign of the middle value.
    """
    sg = np.sign(up)
    with np.errstate(invalid="ignore"):
        lo_, mid, hi_ = sg * uq, sg * up, sg * un
        cand = (mid > 0) & (lo_ > 0) & (hi_ > 0) & (mid <= lo_) & (mid < hi_) & (mid < rise * (np.maximum(lo_, hi_) - mid))
    return cand, sg
