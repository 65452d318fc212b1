"""Search space of the optimizer: unit coordinates, the archive of evaluated designs, the
penalty, and the local stages (boundary multisection along a ray, batched pattern searches).

References
----------
docs/optimize-spec.md#method.
"""

from __future__ import annotations

import math

import numpy as np

from .evaluate import evaluate
from .spec import OBJECTIVES, OptimizeSpec

__all__ = ["to_unit", "from_unit", "Archive", "ray_max", "ray_bisect", "polish_boundary", "polish_pattern", "H_MIN"]

#: smallest pattern step (unit coordinates)
H_MIN = 1e-5
_H0 = 0.1
_RAY_POINTS = 8
_RAY_ROUNDS = 5
_LADDER = 8
_LADDER_ROWS = 6
#: multiples of the last successful step tried first (Hooke–Jeeves pattern moves, accelerating)
_MOVES = 2.0 ** np.arange(7)


def to_unit(spec: OptimizeSpec, X: np.ndarray) -> np.ndarray:
    """Natural units → unit coordinates (log coordinates for ``scale: log``).

    Parameters
    ----------
    spec : OptimizeSpec
        The optimization problem (the free parameters' bounds and scales).
    X : numpy.ndarray
        Designs (n, D), natural units.

    Returns
    -------
    numpy.ndarray
        Unit coordinates (n, D).
    """
    X = np.atleast_2d(np.asarray(X, float))
    U = np.empty_like(X)
    for j, (lo, hi, sc) in enumerate(spec.free.values()):
        U[:, j] = (np.log(X[:, j] / lo) / math.log(hi / lo)) if sc == "log" else (X[:, j] - lo) / (hi - lo)
    return U


def from_unit(spec: OptimizeSpec, U: np.ndarray) -> np.ndarray:
    """Unit coordinates (clipped to [0, 1]) → natural units; the bounds are reproduced exactly.

    Parameters
    ----------
    spec : OptimizeSpec
        The optimization problem (the free parameters' bounds and scales).
    U : numpy.ndarray
        Unit coordinates (n, D).

    Returns
    -------
    numpy.ndarray
        Designs (n, D), natural units.
    """
    U = np.atleast_2d(np.asarray(U, float))
    X = np.empty_like(U, dtype=float)
    for j, (lo, hi, sc) in enumerate(spec.free.values()):
        u = np.clip(U[:, j], 0.0, 1.0)
        x = lo * (hi / lo) ** u if sc == "log" else lo + u * (hi - lo)
        X[:, j] = np.where(u <= 0.0, lo, np.where(u >= 1.0, hi, x))
    return X


class Archive:
    """Every design evaluated (in order), with the fixed objective normalization of the penalty."""

    def __init__(self, spec: OptimizeSpec):
        self.spec = spec
        self.evs: list[dict] = []
        self.history: list[dict] = []  # evaluations under an earlier (looser) set of checks
        self.count = 0
        what, self.sense, _ = OBJECTIVES[spec.objective]
        self.paths = list(spec.free)
        self.j = self.paths.index(what) if what in spec.free else None
        self._scale = None

    def evaluate(self, U: np.ndarray) -> dict:
        U = np.clip(np.atleast_2d(np.asarray(U, float)), 0.0, 1.0)
        ev = evaluate(self.spec, from_unit(self.spec, U))
        ev["U"] = U
        self.evs.append(ev)
        self.count += U.shape[0]
        return ev

    def value(self, ev: dict) -> np.ndarray:
        """Objective, larger is better (−objective when minimized), −inf where undefined."""
        o = np.asarray(ev["objective"], float)
        v = o if self.sense == "max" else -o
        return np.where(np.isnan(v), -np.inf, v)

    def score(self, ev: dict) -> np.ndarray:
        """The penalty minimized by the global stage: −normalized objective when feasible,
        1 + 10³ + violation otherwise."""
        v = self.value(ev)
        if self.j is not None:
            lo, hi, _sc = self.spec.free[self.paths[self.j]]
            on = v / (hi - lo)
        else:
            if self._scale is None:
                fin = np.isfinite(v)
                self._scale = max(float(np.max(np.abs(v[fin]))) if fin.any() else 1.0, 1e-12)
            on = v / self._scale
        on = np.nan_to_num(on, nan=-1e3, neginf=-1e3, posinf=1e3)
        return np.where(ev["feasible"], -on, 1.0 + 1e3 + ev["violation"])

    def best_feasible(self, evs=None):
        """(value, U row, ev, row) of the best feasible design evaluated (first on ties), or None."""
        best = None
        for ev in self.evs if evs is None else evs:
            v = np.where(ev["feasible"], self.value(ev), -np.inf)
            if not np.isfinite(v).any():
                continue
            i = int(np.argmax(v))
            if best is None or v[i] > best[0]:
                best = (float(v[i]), ev["U"][i].copy(), ev, i)
        return best

    def least_violation(self):
        """(U row, violation) of the design with the smallest violation (first on ties)."""
        best = None
        for ev in self.evs:
            i = int(np.argmin(ev["violation"]))
            if best is None or ev["violation"][i] < best[1]:
                best = (ev["U"][i].copy(), float(ev["violation"][i]))
        return best

    def top_feasible(self, n: int) -> np.ndarray:
        """Up to n distinct feasible designs (unit coordinates), best first."""
        rows, vals = [], []
        for ev in self.evs:
            v = np.where(ev["feasible"], self.value(ev), -np.inf)
            for i in np.nonzero(np.isfinite(v))[0]:
                rows.append(ev["U"][i])
                vals.append(v[i])
        if not rows:
            return np.zeros((0, len(self.paths)))
        order = np.argsort(-np.asarray(vals), kind="stable")
        U = np.asarray(rows)[order]
        _, first = np.unique(np.round(U, 12), axis=0, return_index=True)
        return U[np.sort(first)][:n]


def ray_bisect(ar: Archive, U: np.ndarray, a: np.ndarray, b: np.ndarray, rounds: int = _RAY_ROUNDS) -> np.ndarray:
    """Multisection of the objective coordinate of each row of U between a (feasible) and b:
    each round keeps, in each bracket, the *largest* feasible point evaluated (so a better
    feasible piece past an infeasible gap is never lost). Returns the rows with the objective
    coordinate at the last feasible point (each row stays feasible).

    Parameters
    ----------
    ar : Archive
        The search's archive (the objective is the free parameter ``ar.j``).
    U : numpy.ndarray
        Designs (n, D), unit coordinates.
    a : numpy.ndarray
        Feasible objective coordinate per row (n,).
    b : numpy.ndarray
        The other end per row (n,).
    rounds : int, optional
        Multisection rounds.

    Returns
    -------
    numpy.ndarray
        The rows (n, D) with the objective coordinate moved.
    """
    j = ar.j
    U = np.array(np.atleast_2d(U), float)
    a, b = np.array(a, float), np.array(b, float)
    t = np.arange(1, _RAY_POINTS + 1) / (_RAY_POINTS + 1)
    todo = np.nonzero(a != b)[0]
    for _ in range(rounds):
        if todo.size == 0:
            break
        P = a[todo, None] + (b[todo] - a[todo])[:, None] * t[None, :]
        Ut = np.repeat(U[todo], t.size, axis=0)
        Ut[:, j] = P.ravel()
        ok = ar.evaluate(Ut)["feasible"].reshape(todo.size, t.size)
        has = ok.any(1)
        k = np.where(has, t.size - 1 - np.argmax(ok[:, ::-1], axis=1), -1)  # last feasible point
        r = np.arange(todo.size)
        new_a = np.where(has, P[r, np.maximum(k, 0)], a[todo])
        new_b = np.where(k + 1 < t.size, P[r, np.minimum(k + 1, t.size - 1)], b[todo])
        a[todo], b[todo] = new_a, new_b
    U[:, j] = a
    return U


def ray_max(ar: Archive, U: np.ndarray, rounds: int = _RAY_ROUNDS) -> np.ndarray:
    """Push the objective coordinate of each (feasible) row of U toward its better bound: the
    bound itself when feasible, else :func:`ray_bisect` between the row and the bound.

    Parameters
    ----------
    ar : Archive
        The search's archive (the objective is the free parameter ``ar.j``).
    U : numpy.ndarray
        Feasible designs (n, D), unit coordinates.
    rounds : int, optional
        Multisection rounds of :func:`ray_bisect`.

    Returns
    -------
    numpy.ndarray
        The rows (n, D), each still feasible.
    """
    j = ar.j
    U = np.array(np.atleast_2d(U), float)
    c = 1.0 if ar.sense == "max" else 0.0
    Ub = U.copy()
    Ub[:, j] = c
    done = ar.evaluate(Ub)["feasible"]
    U[done, j] = c
    b = np.full(U.shape[0], c)
    a = U[:, j].copy()
    return ray_bisect(ar, U, a, np.where(done, a, b), rounds)


def _directions(rng, D: int, skip: int | None, n_random: int) -> np.ndarray:
    idx = [i for i in range(D) if i != skip]
    E = np.zeros((2 * len(idx), D))
    for k, i in enumerate(idx):
        E[2 * k, i], E[2 * k + 1, i] = 1.0, -1.0
    R = rng.standard_normal((n_random, D))
    if skip is not None:
        R[:, skip] = 0.0
    R /= np.maximum(np.linalg.norm(R, axis=1, keepdims=True), 1e-12)
    return np.vstack([E, R])


def polish_boundary(ar: Archive, u: np.ndarray, budget: int, rng, h: float = _H0) -> np.ndarray:
    """Objective = a free parameter: maximize the feasibility boundary along it over the other
    parameters (batched pattern search with Hooke–Jeeves pattern moves). A trial moves the other
    coordinates by h (coordinate and random directions, directions scattered around the last
    successful step, and 1, 2, 4, …, 64 times that step) with the objective coordinate just past
    the incumbent's: a feasible trial is an improvement. The first six successes climb a ladder of objective levels (one batch); the best
    one is pushed toward its own boundary by :func:`ray_bisect` (three rounds). No success: h
    halves; a success doubles it (at most 0.2). Below :data:`H_MIN` the search restarts with the
    initial step as long as the previous start improved and the budget lasts.

    Parameters
    ----------
    ar : Archive
        The search's archive (the objective is the free parameter ``ar.j``).
    u : numpy.ndarray
        A feasible design (D,), unit coordinates.
    budget : int
        Evaluations of the archive after which the search stops.
    rng : numpy.random.Generator
        The random generator of the directions.
    h : float, optional
        The initial step, unit coordinates.

    Returns
    -------
    numpy.ndarray
        The polished design (D,), feasible.
    """
    j, D = ar.j, u.size
    u = ray_max(ar, u[None, :])[0]
    if D == 1:
        return u
    sgn = 1.0 if ar.sense == "max" else -1.0
    c = 1.0 if ar.sense == "max" else 0.0
    levels = 1e-6 * 4.0 ** np.arange(_LADDER)
    prev = mom = None
    h0, start = h, u[j]
    while ar.count < budget and u[j] != c:
        if h < H_MIN:  # stalled: restart with a large step while the last restart improved
            if u[j] == start:
                break
            h, start, prev, mom = h0, u[j], None, None
        T = u[None, :] + h * _directions(rng, D, j, max(8, 6 * (D - 1)))
        if prev is not None:
            # pattern moves, and directions scattered around the last successful ones (a ridge)
            n = np.linalg.norm(prev)
            ms = max(8, 6 * (D - 1))
            R = np.vstack([prev / n, mom / max(np.linalg.norm(mom), 1e-300)])[rng.integers(0, 2, ms)]
            R = R + np.repeat([0.05, 0.15, 0.4], -(-ms // 3))[:ms, None] * rng.standard_normal((ms, D))
            R[:, j] = 0.0
            R *= (n * 2.0 ** rng.integers(-1, 3, ms))[:, None] / np.maximum(np.linalg.norm(R, axis=1, keepdims=True), 1e-300)
            T = np.vstack([u[None, :] + _MOVES[:, None] * prev[None, :], u[None, :] + _MOVES[:4, None] * mom[None, :],
                           u[None, :] + R, T])
        T = np.clip(T, 0.0, 1.0)
        T[:, j] = np.clip(u[j] + sgn * 1e-7, 0.0, 1.0)
        ok = np.nonzero(ar.evaluate(T)["feasible"])[0]
        if ok.size == 0:
            h *= 0.5
            prev = None
            continue
        ok = ok[:_LADDER_ROWS]  # pattern moves first, then coordinate, then random directions
        L = np.clip(u[j] + sgn * levels, 0.0, 1.0)
        Tl = np.repeat(T[ok], L.size, axis=0)
        Tl[:, j] = np.tile(L, ok.size)
        okl = ar.evaluate(Tl)["feasible"].reshape(ok.size, L.size)
        k = np.where(okl.any(1), L.size - 1 - np.argmax(okl[:, ::-1], axis=1), -1)
        pick = np.argsort(-k, kind="stable")[:1]
        a = np.where(k[pick] >= 0, L[np.maximum(k[pick], 0)], T[ok[pick], j])
        b = np.where(k[pick] + 1 < L.size, L[np.minimum(k[pick] + 1, L.size - 1)], c)
        best = ray_bisect(ar, T[ok[pick]], a, b, rounds=3)[0]
        step = best - u
        step[j] = 0.0
        if np.linalg.norm(step) > 0:
            prev = step
            mom = step if mom is None else 0.5 * mom + step
        u = best
        h = min(2.0 * h, 0.2)
    return u


def polish_pattern(ar: Archive, u: np.ndarray, value: float, budget: int, rng, h: float = _H0) -> np.ndarray:
    """Metric objective: batched pattern search on the feasible designs (coordinate and random
    directions, and 1, 2, 4 times the last successful step; h halved on failure down to
    :data:`H_MIN`, doubled on success up to 0.2); moves only to a feasible design with a
    strictly better objective.

    Parameters
    ----------
    ar : Archive
        The search's archive.
    u : numpy.ndarray
        A feasible design (D,), unit coordinates.
    value : float
        Its objective value (larger is better, as the archive ranks it).
    budget : int
        Evaluations of the archive after which the search stops.
    rng : numpy.random.Generator
        The random generator of the directions.
    h : float, optional
        The initial step, unit coordinates.

    Returns
    -------
    numpy.ndarray
        The polished design (D,), feasible.
    """
    D = u.size
    prev = None
    while h >= H_MIN and ar.count < budget:
        T = u[None, :] + h * _directions(rng, D, None, max(8, 6 * D))
        if prev is not None:
            T = np.vstack([u[None, :] + np.array([1.0, 2.0, 4.0])[:, None] * prev[None, :], T])
        T = np.clip(T, 0.0, 1.0)
        ev = ar.evaluate(T)
        v = np.where(ev["feasible"], ar.value(ev), -np.inf)
        k = int(np.argmax(v))
        if v[k] > value + 1e-12 * max(abs(value), 1e-300):
            prev = T[k] - u
            u, value = T[k].copy(), float(v[k])
            h = min(2.0 * h, 0.2)
        else:
            h *= 0.5
            prev = None
    return u
