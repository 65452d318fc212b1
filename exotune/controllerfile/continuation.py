"""Stable intervals of a one-parameter family of sampled-data loops by eigenvalue continuation
with step control (docs/controller-file.md#certification).

Intervals of stable human parameters: verdicts at ``POINTS`` log-spaced values of each family's
range; every cell between two stable values is halved (at most ``MAX_DEPTH`` = 12 times) until
its eigenvalue paths are resolved — each eigenvalue's motion over the cell (the chord between its
end values and the first-order motion from its derivative at either end, a secant over
``FD_CELL`` of the grid spacing) is below its distance to
the unit circle (step control of eigenvalue continuation); every change of verdict is bisected
(geometric) to 1e-10 relative. Step control only proposes: with a ``cell_bound`` (certify's
:func:`exotune.controllerfile.cellbound.loop_cell`) every resolved cell is then **proven** stable as
a whole (:func:`_prove`), halved where the proof fails; without one, a window of instability could
hide inside a cell on an eigenvalue path much longer than its resolved chord and end speeds imply. A cell that stays
unresolved at the finest step (≈ 2e-5 relative: an eigenvalue within a hair of the circle and
moving fast), or when the refinement budget (``MAX_REFINED`` values per family, fewer for loops of
more than ``REF_STATES`` states) is spent, fails
the certification. The stable side of every interval end is checked as well: from the last stable
value before the end, cells that double after an acceptance and halve after a refusal march toward
the bisected end and stop ``EDGE_SLIVER`` (relative) short of it; an unstable member met on the way
is a window, which becomes the interval's end (the stable part beyond it is not claimed); a side
whose check stops on a budget is an unresolved cell, and the interval ends where the check ended.
So every member of a reported interval is accepted (proven, with a ``cell_bound``) except those
within ``EDGE_SLIVER`` of its ends and those in unresolved cells inside it.

References
----------
docs/controller-file.md#certification; paper §V (the sampled-data loop).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["POINTS", "MAX_DEPTH", "EDGE_SLIVER", "stable_intervals", "covers_range"]

POINTS = 96
NEAR_UNIT = 1e-6  # |ρ − 1| below which a member's verdict is decided with its rounding estimate
MAX_LISTED = 20  # inconclusive values listed per family
CHORD = 1.0  # over a resolved cell every eigenvalue moves ≤ CHORD × its distance to |z| = 1
MAX_DEPTH = 12  # halvings of one base-grid cell (≈ 2e-5 relative for the default grid)
MAX_REFINED = 20000  # refinement values per family; past it, unresolved cells are reported as such
# ... for loops of up to REF_STATES states; a bigger loop (a long delay at a high rate: one state per
# sample) gets the same eigen-solver work, MAX_REFINED·(REF_STATES/n)³ values (at least 50): a
# 200 kHz export of a 1 ms delay (230 states) otherwise ran for hours
REF_STATES = 40
_FD = 1e-7  # smallest relative step of the finite-difference eigenvalue derivative
# ... whose step is otherwise FD_CELL × the base grid's spacing: the rounding error of an
# eigenvalue near z = 1 (two close slow real modes at a high sample rate, ~1e-9) divided by a 1e-7 step read
# as a speed hundreds of times the true one, and 100 kHz families spent their refinement budget
# halving cells whose eigenvalues hardly moved (chord ≈ 0.003 × their distance to the circle)
FD_CELL = 1e-3
_BISECT = 48
SPAN = 8  # grid cells the rigorous pass tries to prove at once first (its span adapts: ×2 on success, ½ on failure)
MAX_SPAN = 64
EDGE_SLIVER = 1e-6  # an interval end's stable side is checked up to this distance (relative) from the bisected end
MARCH_STEPS = 600  # proven cells tried per family on the stable sides of its interval ends (out of the proof budget);
# step control alone (no cell bound) is bounded by the refinement budget
PROOFS = 1000  # cell proofs tried per family (scaled like MAX_REFINED for big loops, at least 200); past it, unresolved


_LSAP = []  # scipy's linear_sum_assignment, imported on the first match (not on every one: ~1e5 per family)


def _match(la: np.ndarray, lb: np.ndarray):
    """Minimum-cost assignment of two eigenvalue sets (indices into la, lb)."""
    if not _LSAP:
        from scipy.optimize import linear_sum_assignment

        _LSAP.append(linear_sum_assignment)
    return _LSAP[0](np.abs(la[:, None] - lb[None, :]))


def _cell_resolved(la: np.ndarray, lb: np.ndarray, length: float, derivatives) -> bool:
    """True when, over a cell of ``length`` (in the grid's coordinate u: ln v on a log grid),
    every eigenvalue (matched between the ends) moves by less than ``CHORD`` × its smaller
    distance to the unit circle — both the chord |λ(b) − λ(a)| and the first-order motions
    length·|dλ/du| at either end. ``la``, ``lb``: the eigenvalues at the ends;
    ``derivatives()`` → (dλ/du at a, dλ/du at b), asked only when the chords pass (each costs an
    eigen-solve). An eigenvalue that leaves the circle inside the cell and comes back has to
    travel at least twice that distance, so it would need a strongly curved path, or one whose
    speed rises far above its speed at both ends (step control of eigenvalue continuation)."""
    if la.size == 0 or lb.size == 0:
        return True
    r, c = _match(la, lb)
    dist = np.minimum(np.abs(1.0 - np.abs(la[r])), np.abs(1.0 - np.abs(lb[c])))
    if not (np.abs(lb[c] - la[r]) <= CHORD * dist).all():
        return False
    da, db = derivatives()
    return bool((length * np.maximum(np.abs(da[r]), np.abs(db[c])) <= CHORD * dist).all())


def _prove(grid: list, stable: list, unresolved: list, cell_bound, refine, budget: int) -> tuple[list, int, int]:
    """The rigorous pass (:mod:`exotune.controllerfile.cellbound`): every run of stable grid values
    that step control resolved is proven cell by cell — ``cell_bound(x, y)`` → (proven, margin)
    on spans of ``SPAN`` grid cells first, the span halved where the proof fails (the span
    doubles again after a success), a single grid cell halved by ``refine(x, y, depth)`` at most
    ``MAX_DEPTH`` times. ``refine`` returns the midpoint's verdict (a new value of the grid: an
    unstable midpoint is a window step control missed, its edges bisected afterwards) or None when
    the refinement budget is spent; at most ``budget`` proofs are tried. Returns (new grid values,
    cells proven, proofs tried — more than ``budget``: the budget is spent); cells still unproven are appended to ``unresolved``
    (certify then fails).
    """
    bad = {(x, y) for x, y in unresolved}
    new, proven, calls = [], 0, [0]

    def bound(x, y):
        calls[0] += 1
        return calls[0] <= budget and cell_bound(x, y)[0]

    def cell(x, y, depth):
        nonlocal proven
        if bound(x, y):
            proven += 1
            return
        if calls[0] > budget:
            unresolved.append([x, y])
            return
        st = refine(x, y, depth) if depth else None
        if st is None:
            unresolved.append([x, y])
            return
        m, ok = st
        new.append(m)
        if ok:
            cell(x, m, depth - 1)
            cell(m, y, depth - 1)

    i, size = 0, SPAN
    while i < len(grid) - 1:
        if not (stable[i] and stable[i + 1]) or (grid[i], grid[i + 1]) in bad:
            i, size = i + 1, SPAN
            continue
        j = i + 1  # the run of proposable cells from i, at most ``size`` of them
        while j < len(grid) - 1 and j - i < size and stable[j + 1] and (grid[j], grid[j + 1]) not in bad:
            j += 1
        if j - i == 1:
            cell(grid[i], grid[j], MAX_DEPTH)
            i, size = j, 2
        elif bound(grid[i], grid[j]):
            proven += 1
            i, size = j, min(2 * size, MAX_SPAN)
        else:
            size = max((j - i) // 2, 1)
    return new, proven, calls[0]


def stable_intervals(spectrum, lo: float, hi: float, points: int = POINTS, verdict=None,
                     cell_bound=None, spectra=None) -> tuple[list, dict]:
    """Stable intervals of one family. Verdicts on a grid of ``points`` values (log-spaced when
    lo > 0); every cell with a stable verdict at both ends is halved until its eigenvalue paths are
    resolved (:func:`_cell_resolved`), at most ``MAX_DEPTH`` times and ``MAX_REFINED`` values in
    all (a bounded run time) — cells still unresolved then are reported; every change of verdict is bisected to 1e-10 relative. ``spectrum(v)`` → loop
    eigenvalues at parameter value v (their derivatives by a forward difference).

    Parameters
    ----------
    spectrum : callable
        ``spectrum(v)``: the eigenvalues of the sampled-data loop at the parameter value ``v``.
    cell_bound : callable, optional
        ``cell_bound(a, b)`` → (proven, margin): a proof that every member on [a, b] is stable
        (:func:`exotune.controllerfile.cellbound.loop_cell`); with it a cell is accepted only when
        proven (:func:`_prove`), step control only proposes the cells. Without it the cells are
        accepted on step control alone (``info["proof"]`` says which).
    verdict : callable, optional
        ``verdict(v)`` → True/False/None (:func:`exotune.sampled.loop_verdict`), asked where the
        spectral radius is within ``NEAR_UNIT`` of 1: None (rounding cannot decide) counts as not
        stable and the value is listed in ``inconclusive``.
    lo, hi : float
        The family's range (log-spaced grid when ``lo > 0``).
    points : int
        Values of the base grid.
    spectra : callable, optional
        ``spectra(values)`` → the eigenvalues at each value, as ``spectrum`` gives them one at a
        time (:func:`exotune.sampled.loop_spectra`: stacked matrices): the base grid and its
        derivative steps are then computed in one call. The result is the same.

    Returns
    -------
    intervals : list of [a, b]
        The stable intervals (|λ| < 1 for every eigenvalue).
    info : dict
        ``points``, ``refined_points``, ``unresolved`` cells (the first ``MAX_LISTED``; their number
        in ``unresolved_cells``), ``refinement_budget``,
        ``budget_spent``, ``loop_states``, ``stable_points``, ``inconclusive`` values, ``proof``
        ("cell bound" or "step control only"), ``proven_cells`` (the proofs that succeeded).

    References
    ----------
    The certification method: the module docstring (eigenvalue continuation with step control).
    One function on purpose: the refinement and the bisections share the verdict cache of the
    closures ``at``/``with_derivative``.
    """
    cache = {}
    log = lo > 0
    coord = (lambda v: math.log(v)) if log else (lambda v: v)
    inv = math.exp if log else (lambda u: u)

    inconclusive = []
    ahead: dict = {}  # spectra computed in advance (the base grid and its derivative steps)

    def spec(v):
        return ahead.pop(v) if v in ahead else spectrum(v)

    def step(v):
        """The forward-difference step of the eigenvalue derivative at ``v``."""
        return (v * max(_FD, FD_CELL * spacing) if log
                else max(_FD * (abs(v) if v else max(abs(hi), 1.0)), FD_CELL * spacing))

    def at(v):
        if v not in cache:
            lam = np.asarray(spec(v))
            rho = float(np.max(np.abs(lam))) if lam.size else 0.0
            st = rho < 1.0
            if verdict is not None and abs(rho - 1.0) < NEAR_UNIT:
                decided = verdict(v)
                if decided is None:
                    inconclusive.append(v)
                st = bool(decided)
            cache[v] = (st, lam, None)
        return cache[v]

    def with_derivative(v):
        st, lam, d = at(v)
        if d is None:
            h = step(v)
            lh = np.asarray(spec(v + h))
            d = np.zeros_like(lam)
            if lam.size and lh.size:  # (an eigenvalue without a partner, e.g. at v = 0: speed 0)
                r, c = _match(lam, lh)
                d[r] = (lh[c] - lam[r]) / (coord(v + h) - coord(v))
            cache[v] = (st, lam, d)
        return cache[v][1], cache[v][2]

    mid = (lambda a, b: math.sqrt(a * b)) if lo > 0 else (lambda a, b: 0.5 * (a + b))
    spacing = (coord(hi) - coord(lo)) / max(points - 1, 1)  # of the base grid, in the coordinate u
    vals = [float(v) for v in (np.geomspace(lo, hi, points) if lo > 0 else np.linspace(lo, hi, points))]
    if spectra is not None:
        args = vals + [v + step(v) for v in vals]
        ahead.update(zip(args, spectra(args)))
    n = max(at(vals[0])[1].size, 1)
    max_refined = MAX_REFINED if n <= REF_STATES else max(50, int(MAX_REFINED * (REF_STATES / n) ** 3))
    grid = [vals[0]]
    refined = 0
    unresolved = []
    budget_spent = False
    proofs_spent = False  # the cell proofs failed until their budget was spent (stable by step control, not proven)
    for a, b in zip(vals[:-1], vals[1:]):
        stack = [(a, b, MAX_DEPTH)]
        pts = []
        while stack:
            x, y, depth = stack.pop()
            if not (at(x)[0] and at(y)[0]):
                continue
            if _cell_resolved(at(x)[1], at(y)[1], coord(y) - coord(x),
                              lambda x=x, y=y: (with_derivative(x)[1], with_derivative(y)[1])):
                continue
            if not depth or refined >= max_refined:
                unresolved.append([x, y])
                budget_spent = budget_spent or refined >= max_refined
                continue
            m = mid(x, y)
            at(m)
            refined += 1
            pts.append(m)
            stack += [(x, m, depth - 1), (m, y, depth - 1)]
        grid += sorted(pts) + [b]
    proven = 0
    if cell_bound is not None:
        def refine(x, y, depth):
            nonlocal refined, budget_spent
            if refined >= max_refined:
                budget_spent = True
                return None
            m = mid(x, y)
            refined += 1
            return m, at(m)[0]

        proofs = PROOFS if n <= REF_STATES else max(200, int(PROOFS * (REF_STATES / n) ** 3))
        extra, proven, tried = _prove(grid, [at(v)[0] for v in grid], unresolved, cell_bound, refine, proofs)
        budget_spent = budget_spent or tried > proofs
        proofs_spent = tried > proofs
        march_proofs = max(proofs - tried, 0)  # the march's proofs come out of the same budget
        grid = sorted(set(grid) | set(extra))
    marched: dict = {}
    march_calls = [0]
    if cell_bound is None:
        march_proofs = 0

    def accept(x, y):
        """Whether the cell between stable values x, y is accepted (proven with a cell bound,
        else resolved by step control); None when the proof budget is spent."""
        nonlocal march_proofs
        x, y = min(x, y), max(x, y)
        if cell_bound is not None:
            if march_proofs <= 0:
                return None
            march_proofs -= 1
            return bool(cell_bound(x, y)[0])
        return _cell_resolved(at(x)[1], at(y)[1], coord(y) - coord(x),
                              lambda: (with_derivative(x)[1], with_derivative(y)[1]))

    def march(s, t):
        """Check the stable side of an interval end: the cell from the stable value ``s`` (a grid
        value) to the stable bisection end ``t`` next to the edge, by cells that grow ×2 after an
        acceptance and halve after a refusal, up to ``EDGE_SLIVER`` (relative) from ``t``. Returns
        an unstable value found on the way (a window: a new change of verdict), else None; a cell
        that stays unaccepted is appended to ``unresolved`` and the value up to which the side was
        accepted is returned as ``cut``: (window, cut), each None when there is none."""
        nonlocal refined, budget_spent
        if (s, t) in marched:
            return marched[(s, t)]
        us, ut = coord(s), coord(t)
        sliver = EDGE_SLIVER * (1.0 if log else (abs(t) or spacing))
        pv, w, out, cut = s, 0.5 * (ut - us), None, None  # pv: the value up to which the side is accepted
        while abs(ut - coord(pv)) > sliver:
            pos = coord(pv)
            w = math.copysign(min(abs(w), abs(ut - pos)), ut - us)
            y = t if abs(ut - pos - w) <= 0.0 else inv(pos + w)
            if (refined >= max_refined or abs(w) < sliver * 1e-3
                    or (cell_bound is not None and march_calls[0] >= MARCH_STEPS)):
                budget_spent = budget_spent or refined >= max_refined
                unresolved.append(sorted([pv, t]))
                cut = pv
                break
            refined += 1
            march_calls[0] += 1
            if not at(y)[0]:
                out = y
                break
            ok = accept(pv, y)
            if ok is None:
                budget_spent = True
                unresolved.append(sorted([pv, t]))
                cut = pv
                break
            if ok:
                pv, w = y, 2.0 * w
            else:
                w = 0.5 * w
        marched[(s, t)] = (out, cut)
        return out, cut

    while True:  # windows found by a march become grid values, and the edges are bisected again
        grid = sorted(set(grid))
        st = [at(v)[0] for v in grid]
        edges = []  # (position, stable after)
        window = None
        for i in range(len(grid) - 1):
            if st[i] != st[i + 1]:
                a, b = grid[i], grid[i + 1]
                for _ in range(_BISECT):
                    if b - a <= 1e-10 * b:
                        break
                    m = mid(a, b)
                    if at(m)[0] == st[i]:
                        a = m
                    else:
                        b = m
                window, cut = march(grid[i], a) if st[i] else march(grid[i + 1], b)
                if window is not None:
                    break
                # a side not checked to the end: the interval ends where the check ended
                edges.append((0.5 * (a + b) if cut is None else cut, st[i + 1]))
        if window is None:
            break
        grid.append(window)
    ivs = []
    start = lo if st[0] else None
    for x, after in edges:
        if after:
            start = x
        elif start is not None:
            ivs.append([start, x])
            start = None
    if start is not None:
        ivs.append([start, hi])
    base = set(vals)
    # at most MAX_LISTED cells listed (an exhausted budget leaves ~20 000: a controller file that
    # lists them all outgrows the size certify reads), their number in ``unresolved_cells``
    return ivs, {"points": points, "refined_points": refined, "unresolved": sorted(unresolved)[:MAX_LISTED],
                 "unresolved_cells": len(unresolved), "edge_cells": march_calls[0],
                 "inconclusive": sorted(inconclusive)[:MAX_LISTED],
                 "refinement_budget": max_refined, "budget_spent": budget_spent, "proofs_spent": proofs_spent,
                 "loop_states": n,
                 "proof": "step control only" if cell_bound is None else "cell bound", "proven_cells": proven,
                 "stable_points": int(sum(st[i] for i, v in enumerate(grid) if v in base))}


def covers_range(family: dict) -> bool:
    """Whether a family's analysis (certify's per-family mapping) has one stable interval from end
    to end of its range: every member stable by its eigenvalues (it may still hold unproven cells).

    Parameters
    ----------
    family : dict
        ``range`` and ``stable_intervals`` of one family, as :func:`exotune.controllerfile.certify.sampled_analysis` gives them.

    Returns
    -------
    bool
        True when the stable intervals are exactly ``[range]``.
    """
    ivs = family.get("stable_intervals") or []
    return len(ivs) == 1 and list(ivs[0]) == list(family["range"])
