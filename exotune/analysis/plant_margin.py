"""Plant-uncertainty margin: how large a multiple of the declared plant uncertainty the design takes.

The controller is designed once on the nominal plant q0 = (J_m, B_m, K_s, J_j, K_c) and kept
fixed, its disturbance observer included (whose motor model M0 = J_m0 s² + B_m0 s, paper eq. (15) with the nominal plant's J_m and B_m,
stays the nominal one).
The actual plant is q_i = q0_i (1 + δ_i) with |δ_i| ≤ k·w_i (weights w_i, 1 by default). The margin
k* is the largest k for which the cuff-free exoskeleton and every environment stay stable and every
human family stays robust over its whole range, for every plant of the box.

**Lower bound (certified).** Every loop's characteristic quasi-polynomial
Δ(s; q, p) = P0 + P1 e^{−sT} has coefficients multilinear in (q, p) (each mass, damper and spring is a
rank-one element; the family member p enters affinely; :func:`exotune.analysis.charfun.char_terms`
with ``dob_model``). Hence, at each ω, Δ(jω, box) lies in the convex hull of the 2^n vertex values
(mapping theorem). The family over the (connected) box contains the nominal loop, which is stable,
has the same structural roots at s = 0 everywhere (exact zero coefficients, divided out) and is
retarded uniformly (deg P0 > deg P1, the leading coefficient of P0 bounded away from 0 over the box,
checked at the vertices); roots therefore stay in a bounded set of the right half-plane and can only
enter it through the imaginary axis (zero exclusion principle). :func:`exotune.analysis.
plant_margin_box.certify_loop` proves 0 ∉ Δ̃(jω, box) on [0, ω_tail] (beyond ω_tail,
|P0| > |P1| for every member by a Cauchy bound on the vertex coefficient magnitudes) by interval
covering with a derivative bound and box subdivision. The bound is rigorous in exact arithmetic up
to the rounding of one evaluation of Δ at one frequency, which is covered by a relative allowance
of 10⁻⁹·Σ|c_k|ω^k. For the hysteretic human the real twin's Δ(0) must also keep its sign.

**Upper bound (witness).** For a given k, the 32 plant vertices (and the members of a grid of each
family range) are checked by the exact argument-principle count; the smallest such k (bisection
along the segments nominal → vertex) is the upper bound and its unstable (plant, member) pair the
witness, whose right-half-plane root is confirmed by the independent Newton/Padé root finder of
:mod:`exotune.analysis.crosscheck`. Failed certifications return the small boxes where the hull
kept containing 0; their centres are checked too (local refinement).

References
----------
Paper §II (the plant), §III (the DOB); docs/method.md#plant-uncertainty-margin. Zadeh & Desoer
(1963) mapping theorem; Fu, Olbrot & Polis (1989) for polytopes of quasi-polynomials.
"""

from __future__ import annotations

import contextlib
import math
import time
from dataclasses import dataclass, field

import numpy as np

from ..model.plant import Plant
from ..record import Result
from ..numerics.beside import beside
from ..numerics.engine import cached_engine
from .counting import RootCounter
from .plant_margin_box import PLANT_FIELDS, PLANT_SYMBOLS, LoopModel, certify_loop, strip_rows

__all__ = ["PlantWitness", "LoopPlantMargin", "PlantMargin", "plant_loops", "plant_uncertainty_margin", "schedule_plant_margin",
           "loop_counts_at", "vertex_upper_bounds"]

UNIT_K = "1 (multiple of the relative weights)"
#: the note of a margin computed on the plant section of a design with a gain schedule
SCHEDULE_NOT_APPLIED = "the transmission schedule is not applied: nominal plant = the plant section"
K_CAP = 0.999  # k·max(w) < 1 keeps every parameter positive
MEMBER_GRID = 33


@dataclass(frozen=True)
class PlantWitness(Result):
    """An unstable (plant, member) pair at the relative uncertainty level ``k``: the plant
    parameters [SI units of :attr:`Plant.UNITS`], their relative deviations, the loop and member,
    and the rightmost root found by the independent root finder (``confirmed``)."""

    loop: str
    k: float
    plant: dict
    deviations: dict
    parameter: str | None = None
    value: float | None = None
    unit: str | None = None
    n_rhp: int = 0
    rightmost_root: complex | None = None
    confirmed: bool = False

    def to_dict(self) -> dict:
        r = self.rightmost_root
        return {"loop": self.loop, "k": self.k,
                "plant": {f: {"value": v, "unit": Plant.UNITS[f]} for f, v in self.plant.items()},
                "deviations": dict(self.deviations), "parameter": self.parameter, "value": self.value,
                "unit": self.unit, "n_rhp": self.n_rhp,
                "rightmost_root": None if r is None else {"re": r.real, "im": r.imag, "unit": "rad/s"},
                "confirmed": self.confirmed}


@dataclass(frozen=True)
class LoopPlantMargin(Result):
    """One loop: ``lower`` is a certified level for it — the design's certified level when the
    design is robust at the nominal plant (every loop is certified there; a loop's own margin may
    be larger), its own certified bound otherwise, 0 when the loop is not stable/robust at the
    nominal plant; ``upper`` is its smallest witnessed level (inf: no unstable plant found with
    every parameter positive) and ``witness`` the unstable (plant, member) pair there."""

    loop: str
    lower: float
    upper: float
    witness: PlantWitness | None = None
    nominal_robust: bool = True

    def to_dict(self) -> dict:
        return {"loop": self.loop, "lower": self.lower, "upper": self.upper, "nominal_robust": self.nominal_robust,
                "witness": None if self.witness is None else self.witness.to_dict()}


@dataclass(frozen=True)
class PlantMargin(Result):
    """The plant-uncertainty margin of a design: certified ``lower`` ≤ k* ≤ ``upper`` (multiples of
    the relative uncertainty ``weights``), the witness of the upper bound, the per-loop detail,
    the interval ``evaluations`` spent by the certification and the wall time ``seconds`` (not in
    :meth:`to_dict`, which is deterministic)."""

    lower: float
    upper: float
    witness: PlantWitness | None
    loops: tuple[LoopPlantMargin, ...] = field(default_factory=tuple)
    weights: dict = field(default_factory=dict)
    note: str = ""
    evaluations: int = 0
    seconds: float = 0.0
    #: with a gain schedule whose entry has the smallest lower bound: (joint angle [rad], ratio)
    gain_schedule_entry: tuple[float, float] | None = None
    #: with a gain schedule: the main controller's own (lower, upper)
    main_controller: tuple[float, float] | None = None

    @property
    def ratio(self) -> float:
        """upper/lower (inf when lower is 0 or upper is unbounded)."""
        return self.upper / self.lower if self.lower > 0 else math.inf

    def to_dict(self) -> dict:
        return {"lower": self.lower, "upper": self.upper,
                "ratio": self.ratio if math.isfinite(self.ratio) else None,
                "witness": None if self.witness is None else self.witness.to_dict(),
                "loops": [m.to_dict() for m in self.loops], "weights": dict(self.weights), "note": self.note,
                "evaluations": self.evaluations,
                **({} if self.main_controller is None else {
                    "gain_schedule_entry": None if self.gain_schedule_entry is None else
                    {"joint_angle_rad": self.gain_schedule_entry[0], "ratio": self.gain_schedule_entry[1]},
                    "main_controller": {"lower": self.main_controller[0], "upper": self.main_controller[1]}}),
                "units": {"lower": UNIT_K, "upper": UNIT_K, "weights": "1 (relative)"}}

    def to_text(self) -> str:
        """The plant-uncertainty lines of ``exotune analyze``'s margins section.

        Returns
        -------
        str
            The text.
        """
        from ..text.margins import format_margins

        return "\n".join(format_margins({"plant_uncertainty": self.to_dict()}))

    def __repr__(self) -> str:
        w = self.witness
        where = ""
        if w is not None:
            where = f", witness {w.loop}" + (f" at {w.parameter} = {w.value:.6g} {w.unit}" if w.value is not None else "")
        return f"PlantMargin({self.lower:.6g} ≤ k* ≤ {self.upper:.6g}{where})"


def _weights(weights) -> np.ndarray:
    """The five relative weights from None, a sequence or a mapping keyed by symbol or field name."""
    if weights is None:
        return np.ones(5)
    if isinstance(weights, dict):
        out = np.ones(5)
        for key, v in weights.items():
            i = PLANT_SYMBOLS.index(key) if key in PLANT_SYMBOLS else PLANT_FIELDS.index(key)
            out[i] = float(v)
    else:
        out = np.asarray(weights, dtype=float).reshape(5)
    if np.any(out < 0) or not np.any(out > 0):
        raise ValueError("plant-uncertainty weights must be ≥ 0 and not all zero")
    return out


def plant_loops(cfg) -> list:
    """(name, family or None, key0, key1) of every loop of the design, in the order and with the
    names of the latency margin (free, environments, every human family or box edge).

    Parameters
    ----------
    cfg : DesignConfig
        One design.

    Returns
    -------
    list of tuple
        ``(name, family, key0, key1)``: the loop's name, its HumanFamily (None for a single loop)
        and its characteristic terms (``key1`` None for a single loop).

    References
    ----------
    docs/method.md#plant-uncertainty-margin.
    """
    from ..model.humans import HumanFamily

    out = [("free", None, "00", None)]
    for i, e in enumerate(cfg.environment):
        if e.kind == "locked":
            out.append((f"env{i}_locked", None, "01", None))
        elif e.kind in ("spring", "mass"):
            out.append((f"env{i}_{e.kind}", HumanFamily(e.kind, e.param, e.lo, e.hi, damping=e.damping), "00", "01"))
    for i, fam in enumerate(cfg.humans):
        for j, edge in enumerate(fam.edges()):
            out.append((f"human{i}_{fam.kind}" + (f"_edge{j}" if fam.box else ""), edge, "00", "10"))
    return out


def _nominal_ok(res, name: str) -> bool:
    return bool(res.loop(name).verdict[0])


class _Loop:
    """A loop with its model, nominal structural zero count and member grid."""

    def __init__(self, name, fam, model: LoopModel, ok: bool):
        self.name, self.fam, self.model, self.ok = name, fam, model, ok
        if fam is None:
            self.members = None
        elif fam.lo > 0:
            self.members = np.unique(np.r_[fam.lo, fam.hi, np.geomspace(fam.lo, fam.hi, MEMBER_GRID)])
        else:
            self.members = np.unique(np.r_[fam.lo, fam.hi, np.linspace(fam.lo, fam.hi, MEMBER_GRID)])
        q0 = model.q0[None, :]
        _, r, _ = model.counts(q0, None if fam is None else np.array([fam.lo, fam.hi]))
        self.r0 = int(np.min(r))
        self.found: list = []  # (k, δ, p) unstable points found so far
        self.certified_at = 0.0  # highest level certified so far
        self.failed_at = math.inf  # lowest level whose certification failed

    def box(self, k: float, w: np.ndarray):
        lo, hi = -k * w, k * w
        if self.fam is not None:
            lo, hi = np.r_[lo, self.fam.lo], np.r_[hi, self.fam.hi]
        return lo, hi


def loop_counts_at(model: LoopModel, deltas: np.ndarray, members, r0: int) -> np.ndarray:
    """Unstable mask (plant-major, member-minor) of the plants q0(1 + δ) (rows of ``deltas``) and the
    family ``members`` by the exact argument-principle count (more roots at s = 0 than ``r0``, a
    right-half-plane root or an inconclusive count).

    Parameters
    ----------
    model : LoopModel
        The loop, its controller fixed.
    deltas : ndarray, shape (n, 5)
        Relative deviations δ of (J_m, B_m, K_s, J_j, K_c) from the nominal plant (dimensionless).
    members : ndarray or None
        The family members p (in the family parameter's unit), None for a single loop.
    r0 : int
        The roots at s = 0 allowed (the nominal loop's).

    Returns
    -------
    ndarray of bool
        True where the plant (and member) is unstable or the count inconclusive.
    """
    q = model.q0[None, :] * (1.0 + np.atleast_2d(deltas))
    N, r, ok = model.counts(q, members)
    return ~(ok & (N == 0) & (r <= r0))


def _vertex_deltas(k: float, w: np.ndarray) -> np.ndarray:
    import itertools

    s = np.array(list(itertools.product((-1.0, 1.0), repeat=5)))
    return np.unique(s * (k * w)[None, :], axis=0)


def _search_points(lp: _Loop, k: float, w: np.ndarray, extra=()):
    """The points (δ rows, members) checked for an unstable point of the box at level k: its
    vertices × member grid, the ``extra`` relative points and the loop's unstable points found so far."""
    pts = [_vertex_deltas(k, w)]
    pts += [np.asarray(e, float)[None, :5] for e in extra]
    pts += [d[None, :] for (kk, d, _p) in lp.found if kk <= k]
    members = lp.members
    extra_p = [e[5] for e in extra if len(e) > 5]
    if members is not None and extra_p:
        members = np.unique(np.r_[members, extra_p])
    return np.concatenate(pts), members


def _job_size(lp: _Loop, k: float, w: np.ndarray, extra=()) -> int:
    """Number of counts of :func:`_search_points` (points × members) for one job."""
    D, members = _search_points(lp, k, w, extra)
    return D.shape[0] * (1 if members is None else members.size)


def _search_unstable_many(jobs, rows=None, engine=None, index: bool = False):
    """:func:`_search_unstable` for several (loop, k, w, extra) jobs, every count in one
    :class:`~exotune.analysis.counting.RootCounter` run (one vectorized call instead of one per
    loop): a list of hits (δ, p) or None, in the order of ``jobs``.

    ``rows[j]`` (optional, an int or None) restricts job j to that one search point (row-major
    index point × member); ``engine`` overrides the engine chosen for the batch size (so that a
    restricted search counts exactly as the full one would); ``index`` appends the hit's index to
    each hit: (δ, p, i)."""
    counter = RootCounter()
    queued, points = [], []
    for j, (lp, k, w, extra) in enumerate(jobs):
        D, members = _search_points(lp, k, w, extra)
        m = 1 if members is None else members.size
        base = 0
        if rows is not None and rows[j] is not None:
            base = int(rows[j])
            D = D[base // m:base // m + 1]
            members = None if members is None else members[base % m:base % m + 1]
        points.append((lp, D, members, base, lp.model.q0[None, :] * (1.0 + D)))
    # the loops share the design: the characteristic terms of every job's plant rows in one call
    models = [lp.model for lp, *_ in points]
    shared = bool(models) and all(md.cs is models[0].cs and np.array_equal(md.q0, models[0].q0) for md in models)
    if shared:
        ct_all = models[0].terms(np.concatenate([pt[4] for pt in points]),
                                 tuple(sorted({key for md in models for key in md.keys})))
    start = 0
    for lp, D, members, base, q in points:
        ct = ct_all.rows(slice(start, start + D.shape[0])) if shared else None
        start += D.shape[0]
        h = lp.model.submit(counter, q, members, ct=ct)
        queued.append((lp, D, members, h, base))
    counter.run(engine=engine if engine is not None else cached_engine(counter.n))
    out = []
    for lp, D, members, h, base in queued:
        N, r, ok = counter.result(h)
        bad = ~(ok & (N == 0) & (r <= lp.r0))
        if not bad.any():
            out.append(None)
            continue
        i = int(np.nonzero(bad)[0][0])
        m = 1 if members is None else members.size
        hit = (D[i // m], (None if members is None else float(members[i % m])))
        out.append((*hit, base + i) if index else hit)
    return out


def _search_unstable(lp: _Loop, k: float, w: np.ndarray, extra=()):
    """An unstable point (δ, p) of the box at level k among its vertices × member grid and the
    ``extra`` relative points, or None."""
    return _search_unstable_many([(lp, k, w, extra)])[0]


def _loops_upper(lps, w: np.ndarray, rel_tol: float, k_hi: float, shortcut: bool = True) -> dict:
    """Each loop's smallest level k ≤ k_hi with an unstable vertex point (bisection on k), the
    loops' bisections run in lockstep so that every step is one counting call: {name: (k, δ, p) or
    None}. Each loop's bisection is exactly the one it would run alone.

    A step first counts, for each loop, only the vertex point × member that was unstable at the
    loop's last unstable level (the vertices keep their order from level to level): when it is
    unstable again, the level is unstable without the full search (half the steps, usually). The
    hit recorded is the first unstable point of the full search, so the full search runs once at
    the final level of such a loop; the engine is the one the full step would have used. Results
    are those of a full search at every step (``shortcut=False``)."""
    nvert = _vertex_deltas(1.0, w).shape[0]
    state = {}
    jobs = [(lp, k_hi, w, ()) for lp in lps]
    eng = cached_engine(sum(_job_size(*j) for j in jobs))
    for lp, hit in zip(lps, _search_unstable_many(jobs, engine=eng, index=True)):
        if hit is not None:
            # [loop, lo, hi, hit (k, δ, p) at hi or None while pending, index of the hit, engine]
            state[lp.name] = [lp, 0.0, k_hi, (k_hi, *hit[:2]), hit[2], eng]
    while True:
        active = [st for st in state.values() if st[2] - st[1] > 0.125 * rel_tol * st[2]]
        if not active:
            break
        jobs = [(st[0], 0.5 * (st[1] + st[2]), w, ()) for st in active]
        eng = cached_engine(sum(_job_size(*j) for j in jobs))
        m = [1 if st[0].members is None else st[0].members.size for st in active]
        rows = [st[4] if shortcut and st[4] < nvert * mm else None for st, mm in zip(active, m)]
        quick = [None] * len(active)
        ask = [a for a, r in enumerate(rows) if r is not None]
        for a, hit in zip(ask, _search_unstable_many([jobs[a] for a in ask], [rows[a] for a in ask], eng, True)):
            quick[a] = hit
        full = [a for a in range(len(active)) if quick[a] is None]
        hits = dict(zip(full, _search_unstable_many([jobs[a] for a in full], engine=eng, index=True)))
        for a, (st, job) in enumerate(zip(active, jobs)):
            mid = job[1]
            if quick[a] is not None:
                st[2], st[3], st[5] = mid, None, eng  # unstable; its first unstable point later
            elif hits[a] is None:
                st[1] = mid
            else:
                st[2], st[3], st[4], st[5] = mid, (mid, *hits[a][:2]), hits[a][2], eng
    pending = [st for st in state.values() if st[3] is None]
    for st in pending:  # the full search at the final level, on the engine of that step
        hit = _search_unstable_many([(st[0], st[2], w, ())], engine=st[5])[0]
        st[3] = (st[2], *hit)
    for st in state.values():
        st[0].found.append(st[3])
    return {lp.name: (state[lp.name][3] if lp.name in state else None) for lp in lps}


def _witness(lp: _Loop, k: float, delta: np.ndarray, p) -> PlantWitness:
    """The witness record of an unstable point, with the independent root finder's confirmation."""
    from .crosscheck import exact_rhp_roots

    model = lp.model
    q = model.q0 * (1.0 + delta)
    members = None if p is None else np.array([p])
    P0, P1 = model.coeffs(q[None, :], members)
    N, r, _ok = model.counts(q[None, :], members)
    _, P0s, P1s = strip_rows(P0, P1)
    roots = exact_rhp_roots(P0s[0], P1s[0], model.T)
    if model.complex:  # the hysteretic factor 1 + jη holds for Im s > 0 only (its conjugate below)
        roots = roots[roots.imag > 0]
    extra_zero = int(r[0]) > lp.r0
    root = complex(roots[0]) if roots.size else (0j if extra_zero else None)
    fam = lp.fam
    return PlantWitness(lp.name, float(k), {f: float(v) for f, v in zip(PLANT_FIELDS, q)},
                        {s: float(d) + 0.0 for s, d in zip(PLANT_SYMBOLS, delta)},
                        None if fam is None else fam.param, p, None if fam is None else fam.unit,
                        int(N[0]), root, bool(roots.size) or extra_zero)


def _witnesses(loops, ups: dict) -> dict:
    """The witness record of every loop with an unstable point in ``ups`` (loop name → (k, δ, p))."""
    return {lp.name: _witness(lp, *ups[lp.name]) for lp in loops if ups.get(lp.name) is not None}


@contextlib.contextmanager
def _confirm_beside(loops, ups: dict):
    """:func:`_witnesses` of ``ups`` started beside the caller's work
    (:func:`exotune.numerics.beside.beside`: a child process when that is safe and pays off), or
    None when there is nothing to confirm."""
    if not any(v is not None for v in ups.values()):
        yield None
        return
    with beside("plant_margin_witnesses", _witnesses, loops, ups) as job:
        yield job


def _certify_all(loops, k, w, budget):
    """Certify every loop at level k: (all certified, evaluations, hints per loop). A loop
    certified at a level ≥ k is not redone (the boxes are nested); loops that failed before go
    first."""
    used, hints = 0, {}
    for lp in sorted(loops, key=lambda x: x.failed_at):
        if lp.certified_at >= k:
            continue
        lo, hi = lp.box(k, w)
        res = certify_loop(lp.model, lo, hi, lp.r0, budget)
        used += res.evaluations
        if not res.certified:
            lp.failed_at = min(lp.failed_at, k)
            hints[lp.name] = res.hints
            return False, used, hints
        lp.certified_at = k
    return True, used, hints


def _level(delta: np.ndarray, w: np.ndarray) -> float:
    """The smallest k whose box holds the relative deviation ``delta``."""
    pos = w > 0
    return float(np.max(np.abs(delta[pos]) / w[pos])) if pos.any() else 0.0


def _ray_search(lp: _Loop, hint: np.ndarray, w: np.ndarray, k_up: float, steps: int = 8):
    """Local refinement: along the ray from the nominal plant through a stall point (member fixed),
    the first unstable plant below the level ``k_up`` (bisection on the scale): (k, δ, p) or None."""
    d0 = np.asarray(hint, float)[:5]
    p = None if lp.fam is None else float(np.clip(hint[5], lp.fam.lo, lp.fam.hi))
    lev = _level(d0, w)
    if lev <= 0 or k_up <= lev:
        return None
    ts = np.linspace(1.0, k_up / lev, 9)
    members = None if p is None else np.array([p])
    bad = loop_counts_at(lp.model, ts[:, None] * d0[None, :], members, lp.r0)
    if not bad.any():
        return None
    i = int(np.argmax(bad))
    lo, hi = (ts[i - 1] if i > 0 else 0.0), ts[i]
    for _ in range(steps if i > 0 else 0):
        mid = 0.5 * (lo + hi)
        if loop_counts_at(lp.model, (mid * d0)[None, :], members, lp.r0)[0]:
            hi = mid
        else:
            lo = mid
    return hi * lev, hi * d0, p


def _check_hints(loops, k, w, hints, k_up=math.inf):
    """Exact counts at the centres of the boxes where a failed certification stalled, then along
    the rays through them up to the level ``k_up``: the first unstable point as
    (level, loop, (δ, p)), or None."""
    for lp in loops:
        hs = hints.get(lp.name, ())
        if not hs:
            continue
        hit = _search_unstable(lp, k, w, extra=[np.asarray(h, float) for h in hs])
        if hit is not None:
            lp.found.append((k, *hit))
            return k, lp, hit
        for h in hs[::-1][:3]:
            ray = _ray_search(lp, h, w, k_up) if math.isfinite(k_up) else None
            if ray is not None:
                lp.found.append(ray)
                return ray[0], lp, ray[1:]
    return None


def _lower_search(loops, w, k_start, rel_tol, budget, max_steps=4, k_up=math.inf):
    """Certified level below ``k_start``: tries k_start, then levels lower by growing factors, then
    bisects (geometrically) between the last failure and the first success. A failed certification
    whose stall points are unstable lowers the upper bound on the way.
    Returns (lower, evaluations, new witness (k, loop, (δ, p)) or None)."""
    used, new_wit = 0, None

    def attempt(k):
        nonlocal used, new_wit
        ok, u, hints = _certify_all(loops, k, w, budget)
        used += u
        if not ok:
            hit = _check_hints(loops, k, w, hints, k_up if new_wit is None else new_wit[0])
            if hit is not None and (new_wit is None or hit[0] < new_wit[0]):
                new_wit = hit
        return ok

    if attempt(k_start):
        return k_start, used, None
    hi, lo = k_start, 0.0
    for f in (1.0 + 4.0 * rel_tol, 1.1, 1.25, 1.6, 2.5, 5.0, 20.0, 1e3):
        k = k_start / f
        if attempt(k):
            lo = k
            break
        hi = k
    if lo == 0.0:
        return 0.0, used, new_wit
    for _ in range(max_steps):
        if hi / lo <= 1.0 + rel_tol:
            break
        mid = math.sqrt(lo * hi)
        if attempt(mid):
            lo = mid
        else:
            hi = mid
    return lo, used, new_wit


def schedule_plant_margin(cfg, pm: PlantMargin, weights=None, **kw) -> PlantMargin:
    """The plant-uncertainty margin of a design with a gain schedule (a ``transmission`` table):
    the runtime runs the design rescheduled at each joint angle (paper §IV gain scheduling), each
    entry designed on its nominal reflected plant, so the margin is the smallest over the main
    controller's ``pm`` and the entries' (the smallest certified lower bound, the smallest
    witnessed upper bound with its witness), naming the entry of the lower bound
    (``gain_schedule_entry``) and keeping the main controller's bounds (``main_controller``).

    Parameters
    ----------
    cfg : DesignConfig
        One design, with or without ``transmission``.
    pm : PlantMargin
        Its own margin (:func:`plant_uncertainty_margin`).
    weights : None, sequence of 5 floats or mapping
        The relative uncertainty, as given for ``pm``.
    **kw
        The other keywords given for ``pm`` (``families``, ``budget``, ``rel_tol``, ``loop_detail``).

    Returns
    -------
    PlantMargin
        ``pm`` without a schedule; else the schedule's margin.

    References
    ----------
    docs/method.md#plant-uncertainty-margin; paper §IV (gain scheduling).
    """
    tr = (cfg.raw or {}).get("transmission")
    if not tr:
        return pm
    import dataclasses

    from .gain_schedule import rescheduled

    each = [(None, pm)] + [((float(a), float(r)), plant_uncertainty_margin(rescheduled(cfg, float(r)), weights, **kw))
                           for a, r in zip(tr["joint_angle_rad"], tr["ratio"])]
    low_at, low = min(each, key=lambda e: e[1].lower)
    up_at, up = min(each, key=lambda e: e[1].upper)
    where = (lambda at: "the main controller" if at is None else  # noqa: E731
             f"the gain-schedule entry at joint angle {at[0]:.6g} rad (ratio {at[1]:.6g})")
    notes = [f"the smallest over the main controller and the {len(each) - 1} gain-schedule entries: lower bound "
             f"of {where(low_at)}, upper bound (and witness) of {where(up_at)}"]
    notes += [n for n in low.note.split("; ") if n and n != SCHEDULE_NOT_APPLIED]
    return dataclasses.replace(low, upper=up.upper, witness=up.witness, note="; ".join(notes),
                               evaluations=sum(m.evaluations for _, m in each),
                               seconds=sum(m.seconds for _, m in each), gain_schedule_entry=low_at,
                               main_controller=(pm.lower, pm.upper))


def plant_uncertainty_margin(cfg, weights=None, *, families=None, budget: int = 150_000, rel_tol: float = 0.01,
                             nominal=None, loop_detail: bool = True) -> PlantMargin:
    """Plant-uncertainty margin of a design (module docstring): certified lower and witnessed upper
    bounds on the largest multiple k of the relative plant uncertainty for which every loop stays
    stable/robust with the controller designed on the nominal plant.

    Parameters
    ----------
    cfg : DesignConfig
        One design. Its ``plant`` section is the nominal plant; a ``transmission`` schedule is not
        applied (the margin is that of the plant section, transmission ratio 1; the schedule's is
        :func:`schedule_plant_margin`, which ``exotune analyze`` and the sweep report).
    weights : None, sequence of 5 floats or mapping
        Relative uncertainty per parameter (J_m, B_m, K_s, J_j, K_c), by symbol or field name;
        default 1 each. q_i = q0_i (1 + δ_i), |δ_i| ≤ k w_i.
    families : iterable of str, optional
        Restrict to these loop names (``plant_loops``): e.g. ``["free", "human0_mass"]``.
    budget : int
        Interval evaluations allowed per loop and certification attempt; a certification that
        runs out of it fails (the lower bound is then smaller, never wrong).
    rel_tol : float
        Target relative gap: the upper bound is bisected to rel_tol/8 and the certification first
        tried at upper/(1 + rel_tol).
    nominal : BatchAnalysis, optional
        The design's batch analysis (``analyze_batch(cfg)``) if already computed.
    loop_detail : bool
        When the design is not robust at the nominal plant (k* = 0), also bound each robust
        loop's own margin (the costly part); False lists those loops with NaN bounds.

    Returns
    -------
    PlantMargin
        ``lower`` (certified), ``upper`` (inf when no unstable plant was found with every
        parameter positive, k < 1/max w) and its ``witness``; 0 and 0 when the design is not robust
        at the nominal plant (the per-loop entries of the robust loops are still computed).

    References
    ----------
    docs/method.md#plant-uncertainty-margin; paper §II (the plant), §III (the DOB).
    """
    t0 = time.perf_counter()
    w = _weights(weights)
    k_cap = K_CAP / float(np.max(w))
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        loops = _make_loops(cfg, families, nominal)
        notes = []
        if cfg.raw.get("transmission") is not None:
            notes.append(SCHEDULE_NOT_APPLIED)
        robust = [lp for lp in loops if lp.ok]
        detail = loop_detail or len(robust) == len(loops)
        ups = _loops_upper(robust, w, rel_tol, k_cap) if detail else {}
        first = dict(ups)  # the vertex witnesses, confirmed beside the certification (their own process)
        with _confirm_beside(loops, first) as early:
            if len(robust) < len(loops):
                notes.insert(0, "not robust at the nominal plant (" + ", ".join(lp.name for lp in loops if not lp.ok)
                             + "): k* = 0" + ("; the robust loops' margins are listed" if detail else ""))
                lower, upper, crit, per, used = _not_robust(loops, ups, w, k_cap, rel_tol, budget)
            else:
                lower, upper, crit, per, used = _robust(robust, ups, w, k_cap, rel_tol, budget)
                if not math.isfinite(upper):
                    notes.append(f"no unstable plant found up to k = {k_cap:.6g} (every parameter kept positive)")
            confirmed = early.result() if early is not None else {}
        out, witness = [], None
        for lp in loops:
            v = ups.get(lp.name)
            # a witness the certification replaced (a lower unstable point) is confirmed here
            wit = None if v is None else (confirmed[lp.name] if v is first.get(lp.name) else _witness(lp, *v))
            witness = wit if lp.name == crit else witness
            if lp.ok and lp.name not in ups:  # not bounded (loop_detail False)
                out.append(LoopPlantMargin(lp.name, math.nan, math.nan, None, True))
                continue
            up = 0.0 if not lp.ok else (math.inf if v is None else v[0])
            out.append(LoopPlantMargin(lp.name, per.get(lp.name, 0.0), up, wit, lp.ok))
        if witness is not None and not witness.confirmed:
            notes.append("the witness's instability is not confirmed by the independent root finder")
    wd = {s: float(x) for s, x in zip(PLANT_SYMBOLS, w)}
    return PlantMargin(float(lower), float(upper), witness, tuple(out), wd, "; ".join(notes), int(used),
                       time.perf_counter() - t0)


def _make_loops(cfg, families, nominal) -> list:
    """The loops of :func:`plant_loops` (those named in ``families``), their controller designed on
    the nominal plant, each with its nominal robust verdict."""
    from ..model.controller import build_controller
    from .batch import analyze_batch

    cols = nominal if nominal is not None else analyze_batch(cfg)
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    return [_Loop(name, fam, LoopModel(cs, cfg.plant, fam, key0, key1), _nominal_ok(cols, name))
            for name, fam, key0, key1 in plant_loops(cfg) if families is None or name in families]


def vertex_upper_bounds(cfg, weights=None, *, families=None, rel_tol: float = 0.01, shortcut: bool = True) -> dict:
    """Each loop's witnessed upper bound before any certification: the smallest level k (bisected
    to ``rel_tol``/8 relative) at which a vertex of the box × a member of the family's grid is
    unstable — the first stage of :func:`plant_uncertainty_margin`.

    Parameters
    ----------
    cfg : DesignConfig
        One design (its ``plant`` section is the nominal plant).
    weights : None, sequence of 5 floats or mapping
        Relative uncertainty per parameter, as in :func:`plant_uncertainty_margin`.
    families : iterable of str, optional
        Restrict to these loop names.
    rel_tol : float
        Relative gap target (the bisection stops at rel_tol/8).
    shortcut : bool
        True (default): each bisection step first re-counts only the vertex point that was unstable
        at the loop's last unstable level; False: the full vertex × member search at every step (the
        reference; the results are the same).

    Returns
    -------
    dict
        Loop name → (k [1], δ (relative deviations of J_m, B_m, K_s, J_j, K_c), member or None), or
        None when no vertex point is unstable up to k·max(w) = 0.999; loops that are not robust at
        the nominal plant are left out.

    References
    ----------
    docs/method.md#plant-uncertainty-margin.
    """
    w = _weights(weights)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        robust = [lp for lp in _make_loops(cfg, families, None) if lp.ok]
        return _loops_upper(robust, w, rel_tol, K_CAP / float(np.max(w)), shortcut)


def _not_robust(loops, ups, w, k_cap, rel_tol, budget):
    """k* = 0: each robust loop's own bounds, the unstable members of the nominal plant as
    witnesses (``ups`` completed in place). Returns (0, 0, critical loop, per-loop lower, evaluations)."""
    per, used = {}, 0
    for lp in loops:
        if lp.ok and lp.name not in ups:  # robust loop, not bounded (loop_detail False)
            continue
        if lp.ok:
            k_up = math.inf if ups[lp.name] is None else ups[lp.name][0]
            per[lp.name], u, _ = _lower_search([lp], w, _start(k_up, k_cap, rel_tol), rel_tol, budget, k_up=k_up)
            used += u
        else:
            hit = _search_unstable(lp, 0.0, w)
            ups[lp.name] = None if hit is None else (0.0, *hit)
    crit = next((lp.name for lp in loops if not lp.ok and ups[lp.name] is not None), None)
    return 0.0, 0.0, crit, per, used


def _robust(robust, ups, w, k_cap, rel_tol, budget):
    """All loops robust at the nominal plant: the design's certified level just below the smallest
    loop upper bound (``ups`` updated in place by witnesses found on the way).
    Returns (lower, upper, critical loop, per-loop lower, evaluations)."""
    finite = [(v[0], n) for n, v in ups.items() if v is not None]
    k_up = min(finite)[0] if finite else math.inf
    lower, used, new = _lower_search(robust, w, _start(k_up, k_cap, rel_tol), rel_tol, budget, k_up=k_up)
    for _ in range(2):  # a witness below the vertex bound: certify again just below it
        if new is None or new[0] >= k_up:
            break
        k_up, lp, hit = new[0], new[1], new[2]
        ups[lp.name] = (k_up, *hit)
        start = _start(k_up, k_cap, rel_tol)
        if start <= lower * (1.0 + 1e-9):
            break
        lo2, u, new = _lower_search(robust, w, start, rel_tol, budget, k_up=k_up)
        used += u
        if lo2 > lower:
            lower = lo2
    finite = [(v[0], n) for n, v in ups.items() if v is not None]
    upper, crit = min(finite) if finite else (math.inf, None)
    return lower, upper, crit, {lp.name: lower for lp in robust}, used


def _start(k_up: float, k_cap: float, rel_tol: float) -> float:
    """The first level tried by the certification: just below the upper bound (or the cap)."""
    return k_cap if not math.isfinite(k_up) else k_up / (1.0 + rel_tol)
