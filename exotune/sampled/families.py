"""Sampled-data verdicts, stable intervals and latency margins of many designs at once (the sweep's
``sampled: true`` columns, docs/sweep-spec.md#sampled-data-columns), on :class:`~exotune.sampled.batch.BatchLoops`.

Family intervals — the method of ``exotune certify`` (:mod:`exotune.controllerfile.continuation`),
batched over designs: verdicts (|λ| < 1 for every eigenvalue, the rigid-body z = 1 of an
ungrounded loop set aside) at ``POINTS`` log-spaced members of the range; every cell between two
stable members is halved (at most ``MAX_DEPTH`` times) until its eigenvalue paths are resolved —
each eigenvalue (matched between the ends) moves, by its chord and by its first-order motion at
either end (a forward difference over ``FD_CELL`` of the grid spacing), less than its distance to
the unit circle; every change of verdict is bisected to 1e-10 relative. Each stage is one batch of
eigenvalue problems over every design and cell.

Critical member of a family: the member with the largest spectral radius among those the verdict
evaluated (grid, refinements and bisections) — the member nearest to instability of a robust
family, the most unstable one otherwise; located to the grid's resolution.

Latency margin: the largest extra delay ΔT ≥ 0 for which free, locked, every environment range and
every rational human family over its whole range stay stable (as ``exotune certify`` defines it).
Probe loops (free, locked, the ends, ``SCAN`` interior members and the critical member of every
family) are bracketed from the continuous margin (ΔT_c − T_s/2, then ΔT_c; else growing from half
a sample) and the bracket is narrowed by the Illinois method on max ρ − 1 to ``MARGIN_REL``
relative; the stable end is then confirmed by the full family check above; a member found unstable
there becomes a probe and the search restarts (at most ``ROUNDS`` times).
"""

from __future__ import annotations

import math

import numpy as np

from .batch import BatchLoops, Loop

__all__ = ["POINTS", "MAX_DEPTH", "SCAN", "MARGIN_REL", "family_check", "latency_margin"]

POINTS = 96  # base grid per family (certify's)
MAX_DEPTH = 12
FD_CELL = 1e-3
_FD = 1e-7
CHORD = 1.0
BISECT_REL = 1e-10
SCAN = 6
MARGIN_REL = 1e-7
ROUNDS = 4
MAX_SAMPLES = 200.0


def _greedy_match(la: np.ndarray, lb: np.ndarray) -> np.ndarray:
    """perm (c, N): a one-to-one matching of the eigenvalues ``la`` (c, N) to ``lb`` (c, N),
    nearest pairs first."""
    c, N = la.shape
    D = np.abs(la[:, :, None] - lb[:, None, :])
    perm = np.zeros((c, N), np.int64)
    rows = np.arange(c)
    for _ in range(N):
        flat = D.reshape(c, -1).argmin(axis=1)
        r, col = flat // N, flat % N
        perm[rows, r] = col
        D[rows, r, :] = np.inf
        D[rows, :, col] = np.inf
    return perm


class _Family:
    """The members evaluated for one loop (family) of several designs: flat arrays of points."""

    def __init__(self, bl: BatchLoops, des: np.ndarray, loop: Loop, lo: float, hi: float, delay: np.ndarray):
        self.bl, self.des, self.loop, self.lo, self.hi = bl, des, loop, lo, hi
        self.delay = delay  # per local design
        self.log = lo > 0
        self.v: list = []
        self.owner: list = []
        self.rho: list = []
        self.eig: list = []
        self.der: dict = {}

    def u(self, v):
        return np.log(v) if self.log else v

    def mid(self, a, b):
        return np.sqrt(a * b) if self.log else 0.5 * (a + b)

    def eval(self, owner: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Evaluate members ``v`` of local designs ``owner``; returns their point indices."""
        rho, eig = self.bl.spectra(self.des[owner], self.loop, v, self.delay[owner])
        start = len(self.v)
        self.v += list(v)
        self.owner += list(owner)
        self.rho += list(rho)
        self.eig += eig
        return np.arange(start, start + v.size)

    def derivatives(self, pts: np.ndarray, spacing: float) -> None:
        """dλ/du at the points ``pts`` (forward difference, eigenvalues matched)."""
        pts = np.array([p for p in pts if p not in self.der], dtype=np.int64)
        if not pts.size:
            return
        v = np.array([self.v[p] for p in pts])
        own = np.array([self.owner[p] for p in pts])
        if self.log:
            h = v * max(_FD, FD_CELL * spacing)
        else:
            h = np.maximum(_FD * np.where(v != 0, np.abs(v), max(abs(self.hi), 1.0)), FD_CELL * spacing)
        _rho, eh = self.bl.spectra(self.des[own], self.loop, v + h, self.delay[own])
        du = self.u(v + h) - self.u(v)
        for sz in {e.size for e in eh}:
            idx = [j for j, e in enumerate(eh) if e.size == sz]
            la = np.stack([self.eig[pts[j]] for j in idx])
            lb = np.stack([eh[j] for j in idx])
            perm = _greedy_match(la, lb)
            d = (np.take_along_axis(lb, perm, 1) - la) / du[idx, None]
            for k, j in enumerate(idx):
                self.der[pts[j]] = d[k]

    def resolved(self, cells: np.ndarray, spacing: float) -> np.ndarray:
        """Step control of each cell (pairs of point indices, both stable)."""
        ok = np.zeros(len(cells), bool)
        sizes = np.array([self.eig[a].size for a, _ in cells])
        for sz in np.unique(sizes):
            idx = np.nonzero(sizes == sz)[0]
            la = np.stack([self.eig[cells[j][0]] for j in idx])
            lb = np.stack([self.eig[cells[j][1]] for j in idx])
            perm = _greedy_match(la, lb)
            lbm = np.take_along_axis(lb, perm, 1)
            dist = np.minimum(np.abs(1.0 - np.abs(la)), np.abs(1.0 - np.abs(lbm)))
            chord = np.all(np.abs(lbm - la) <= CHORD * dist, axis=1)
            idx2 = idx[chord]
            if not idx2.size:
                continue
            self.derivatives(np.unique(cells[idx2].ravel()), spacing)
            for j, pm, ds in zip(idx2, perm[chord], dist[chord]):
                a, b = cells[j]
                length = abs(self.u(self.v[b]) - self.u(self.v[a]))
                speed = np.maximum(np.abs(self.der[a]), np.abs(self.der[b][pm]))
                ok[j] = bool(np.all(length * speed <= CHORD * ds))
        return ok


def _refine(fam: _Family, grid_pts: np.ndarray, spacing: float) -> list:
    """Halve unresolved stable cells (batched by level); returns the unresolved cells [(owner, a, b)]."""
    cells = [(grid_pts[i, j], grid_pts[i, j + 1], MAX_DEPTH) for i in range(grid_pts.shape[0])
             for j in range(grid_pts.shape[1] - 1)]
    unresolved = []
    while cells:
        cells = [c for c in cells if fam.rho[c[0]] < 1.0 and fam.rho[c[1]] < 1.0]
        if not cells:
            break
        arr = np.array([(a, b) for a, b, _ in cells], dtype=np.int64)
        ok = fam.resolved(arr, spacing)
        todo = [c for c, k in zip(cells, ok) if not k]
        unresolved += [(fam.owner[a], fam.v[a], fam.v[b]) for a, b, dep in todo if dep == 0]
        todo = [c for c in todo if c[2] > 0]
        if not todo:
            break
        own = np.array([fam.owner[a] for a, _, _ in todo])
        mids = fam.mid(np.array([fam.v[a] for a, _, _ in todo]), np.array([fam.v[b] for _, b, _ in todo]))
        new = fam.eval(own, mids)
        cells = [c for (a, b, dep), m in zip(todo, new) for c in ((a, m, dep - 1), (m, b, dep - 1))]
    return unresolved


def _bisect_edges(fam: _Family, nd: int) -> list:
    """Per local design: the sorted (value, stable) points and the bisected verdict changes."""
    owner = np.array(fam.owner)
    v = np.array(fam.v)
    st = np.array(fam.rho) < 1.0
    per = []
    jobs = []  # (design, a, b, stable at a)
    for i in range(nd):
        idx = np.nonzero(owner == i)[0]
        idx = idx[np.argsort(v[idx], kind="stable")]
        per.append((v[idx], st[idx]))
        for j in np.nonzero(st[idx][:-1] != st[idx][1:])[0]:
            jobs.append([i, v[idx][j], v[idx][j + 1], st[idx][j]])
    for _ in range(48):
        act = [jb for jb in jobs if jb[2] - jb[1] > BISECT_REL * abs(jb[2])]
        if not act:
            break
        m = fam.mid(np.array([jb[1] for jb in act]), np.array([jb[2] for jb in act]))
        pts = fam.eval(np.array([jb[0] for jb in act], dtype=np.int64), m)
        for jb, mm, p in zip(act, m, pts):
            if (fam.rho[p] < 1.0) == jb[3]:
                jb[1] = mm
            else:
                jb[2] = mm
    edges = [[] for _ in range(nd)]
    for i, a, b, s in jobs:
        edges[i].append((float(fam.mid(a, b)), not s))
    return [(p, e) for p, e in zip(per, edges)]


def _intervals(st, edges, lo, hi) -> list:
    """The stable segments between the range ends and the bisected verdict changes ``edges``
    [(position, stable after)]: a segment is stable when the verdict after its left end is."""
    cuts = [lo] + [x for x, _ in edges] + [hi]
    after = [bool(st[0])] + [a for _, a in edges]
    return [[cuts[k], cuts[k + 1]] for k in range(len(after)) if after[k]]


def family_check(bl: BatchLoops, des, loop: Loop, lo: float, hi: float, delay=None, points: int = POINTS) -> dict:
    """Stable intervals of one family for the designs ``des`` (at total delays ``delay`` [s],
    default their own), by the module docstring's method.

    Returns
    -------
    dict of per-design lists/arrays: ``stable_intervals``, ``robust`` (the whole range stable and
    every cell resolved), ``critical`` (member of largest spectral radius), ``critical_radius``,
    ``unresolved`` (cells), ``evaluations``.
    """
    des = np.asarray(des, dtype=np.int64)
    nd = des.size
    delay = bl.delay[des] if delay is None else np.asarray(delay, dtype=float)
    fam = _Family(bl, des, loop, lo, hi, delay)
    vals = np.geomspace(lo, hi, points) if lo > 0 else np.linspace(lo, hi, points)
    spacing = (fam.u(hi) - fam.u(lo)) / max(points - 1, 1)
    grid = fam.eval(np.repeat(np.arange(nd), points), np.tile(vals, nd)).reshape(nd, points)
    unresolved = _refine(fam, grid, spacing)
    per = _bisect_edges(fam, nd)
    owner, rho, v = np.array(fam.owner), np.array(fam.rho), np.array(fam.v)
    out = {"stable_intervals": [], "robust": np.zeros(nd, bool), "critical": np.zeros(nd),
           "critical_radius": np.zeros(nd), "unresolved": [[] for _ in range(nd)], "evaluations": len(fam.v)}
    for i, a, b in unresolved:
        out["unresolved"][i].append([a, b])
    for i, ((pv, pst), edges) in enumerate(per):
        ivs = _intervals(pst, edges, lo, hi)
        out["stable_intervals"].append(ivs)
        out["robust"][i] = ivs == [[lo, hi]] and not out["unresolved"][i]
        idx = np.nonzero(owner == i)[0]
        k = idx[np.argmax(rho[idx])]
        out["critical"][i], out["critical_radius"][i] = v[k], rho[k]
    return out


def _probe_radius(bl: BatchLoops, des: np.ndarray, delay: np.ndarray, probes: list) -> np.ndarray:
    """max over each design's probes of the spectral radius at total delay ``delay`` [s].
    ``probes``: [(loop, member values per design (len(des),) or None)]."""
    worst = np.zeros(des.size)
    for loop, v in probes:
        rho, _ = bl.spectra(des, loop, v, delay)
        worst = np.maximum(worst, rho)
    return worst


def _illinois(g, lo: np.ndarray, glo: np.ndarray, hi: np.ndarray, ghi: np.ndarray, rel: float):
    """Narrow brackets [lo, hi] (g(lo) < 0 ≤ g(hi), vectorized) to ``rel`` relative."""
    side = np.zeros(lo.size, np.int64)
    for _ in range(200):
        act = np.nonzero(hi - lo > rel * hi)[0]
        if not act.size:
            break
        x = (lo[act] * ghi[act] - hi[act] * glo[act]) / (ghi[act] - glo[act])
        bad = ~np.isfinite(x) | (x <= lo[act]) | (x >= hi[act])
        x[bad] = 0.5 * (lo[act][bad] + hi[act][bad])
        gx = g(act, x)
        neg = gx < 0
        a, b = act[neg], act[~neg]
        lo[a], glo[a] = x[neg], gx[neg]
        ghi[a] *= np.where(side[a] == -1, 0.5, 1.0)
        side[a] = -1
        hi[b], ghi[b] = x[~neg], gx[~neg]
        glo[b] *= np.where(side[b] == 1, 0.5, 1.0)
        side[b] = 1
    return lo, hi


def latency_margin(bl: BatchLoops, des, families: list, hint=None) -> np.ndarray:
    """Sampled-data latency margin [s] of the designs ``des`` (module docstring); 0 is not
    returned here — call it on designs stable at their own delay. ``families``:
    [(loop, lo, hi, critical member per design)]; ``hint``: the continuous margins [s]."""
    des = np.asarray(des, dtype=np.int64)
    n = des.size
    T = bl.delay[des]
    Ts = bl.Ts
    cap = MAX_SAMPLES * Ts - T
    probes = [(Loop("free"), None), (Loop("locked", env="locked"), None)]
    for loop, lo, hi, crit in families:
        scan = np.geomspace(lo, hi, SCAN + 2) if lo > 0 else np.linspace(lo, hi, SCAN + 2)
        probes += [(loop, np.full(n, x)) for x in scan] + [(loop, np.asarray(crit, float))]
    extra: list = [[] for _ in range(n)]  # probes found by the confirming checks

    def g(idx, x):
        r = _probe_radius(bl, des[idx], T[idx] + x, [(lp, None if v is None else v[idx]) for lp, v in probes])
        for j, i in enumerate(idx):
            for lp, val in extra[i]:
                r[j] = max(r[j], bl.spectra(des[i:i + 1], lp, np.array([val]), np.array([T[i] + x[j]]))[0][0])
        return r - 1.0

    lo, glo = np.zeros(n), g(np.arange(n), np.zeros(n))
    hi, ghi = np.full(n, np.inf), np.full(n, np.nan)
    h = np.asarray(hint, float) if hint is not None else np.full(n, np.nan)
    for trial in (h - 0.5 * Ts, h):  # the zero-order hold costs about half a sample
        act = np.nonzero(np.isinf(hi) & np.isfinite(trial) & (trial > lo) & (trial < cap))[0]
        if act.size:
            gx = g(act, trial[act])
            un = gx >= 0
            hi[act[un]], ghi[act[un]] = trial[act[un]], gx[un]
            lo[act[~un]], glo[act[~un]] = trial[act[~un]], gx[~un]
    while True:
        act = np.nonzero(np.isinf(hi) & (lo < cap))[0]
        if not act.size:
            break
        x = np.minimum(lo[act] + np.maximum(0.5 * Ts, lo[act]), cap[act])
        gx = g(act, x)
        un = gx >= 0
        hi[act[un]], ghi[act[un]] = x[un], gx[un]
        st = act[~un]
        lo[st], glo[st] = x[~un], gx[~un]
        lo[st[x[~un] >= cap[st]]] = cap[st[x[~un] >= cap[st]]]
    out = np.full(n, math.inf)
    for _ in range(ROUNDS):
        act = np.nonzero(np.isfinite(hi))[0]
        if not act.size:
            break
        lo[act], hi[act] = _illinois(lambda i, x: g(act[i], x), lo[act], glo[act], hi[act], ghi[act], MARGIN_REL)
        out[act] = lo[act]
        redo = _confirm(bl, des, act, T + lo, families, extra)
        if not redo.size:
            break
        hi[redo], lo[redo] = lo[redo], 0.0
        glo[redo] = g(redo, np.zeros(redo.size))
        ghi[redo] = g(redo, hi[redo])
        keep = ghi[redo] >= 0
        hi[redo[~keep]] = np.inf  # (cannot happen: the new probe is unstable there)
    return out


def _confirm(bl: BatchLoops, des, act, delay, families, extra) -> np.ndarray:
    """Full family checks at the candidate delays; a design with an unstable member gets it as a
    probe and is returned for another round."""
    redo = set()
    for loop, lo, hi, _crit in families:
        chk = family_check(bl, des[act], loop, lo, hi, delay[act])
        for j, i in enumerate(act):
            if not chk["robust"][j]:
                extra[i].append((loop, float(chk["critical"][j])))
                redo.add(int(i))
    for loop in (Loop("free"), Loop("locked", env="locked")):
        rho, _ = bl.spectra(des[act], loop, None, delay[act])
        redo |= {int(i) for i in act[rho >= 1.0]}
    return np.array(sorted(redo), dtype=np.int64)
