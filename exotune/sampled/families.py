"""Sampled-data verdicts, stable intervals and latency margins of many designs at once (the sweep's
``sampled: true`` columns, docs/sweep-spec.md#sampled-data-columns), on :class:`~exotune.sampled.batch.BatchLoops`.

Family intervals — the acceptance rule of ``exotune certify`` (:mod:`exotune.controllerfile.continuation`),
batched over designs and with fewer eigenvalue problems: verdicts (|λ| < 1 for every eigenvalue, the
rigid-body z = 1 of an ungrounded loop set aside; within 1e-6 of 1 certify's rounding estimate
decides, inconclusive is not stable) at ``POINTS`` log-spaced members of the range (certify: 96);
every cell between two stable members is halved until its eigenvalue paths are resolved — each
eigenvalue (matched between the ends) moves, by its chord and by its first-order motion at either
end (a forward difference over ``FD_CELL`` of certify's grid spacing), less than its distance to
the unit circle — down to certify's finest cell (12 halvings of its cell, more of the coarser one);
every change of verdict is narrowed to 1e-10 relative by the Illinois method on ρ − 1 (certify
bisects). Each stage is one batch of eigenvalue problems over every design and cell.

Critical member of a family: the member with the largest spectral radius among those the verdict
evaluated (grid, refinements, edges) — nearest to instability in a robust family, the most
unstable one otherwise; located to the grid's resolution.

Latency margin — the one sampled-data latency-margin engine, that of the sweep's columns and of
``exotune certify`` (which runs it on a batch of one design, the controller file's own realization,
:meth:`~exotune.sampled.batch.BatchLoops.of_controller`, and then confirms the result with its full
family check, :mod:`exotune.controllerfile.latency`): the largest extra delay ΔT ≥ 0 for which free,
locked, every environment range and every rational human family over its whole range stay stable.
Probe loops (free, locked, each family's ends and critical member, any extra probes) are evaluated at
ΔT_c − T_s/2 and ΔT_c (ΔT_c the continuous margin: the zero-order hold costs about half a sample;
else growing from half a sample, doubling); the probe that crosses first is followed alone by the
Illinois method on ρ − 1 to ``MARGIN_REL`` relative, then all probes are checked at the result
(another probe unstable there is followed in turn) — :func:`first_crossing`. The family check above
then runs at ΔT (1 − ``CONFIRM``): a gap found there gives its critical member as a new probe;
otherwise its member of largest spectral radius (located by the check's step control, which refines
where ρ is near 1) is evaluated at ΔT, and becomes a probe when it is unstable there by more than a
``NEGLIGIBLE`` relative change of the margin (judged with the followed probe's dρ/dΔT). With a new
probe the search goes on from the last margin (at most ``ROUNDS`` times).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..numerics.engine import compiled
from .batch import BatchLoops, Loop

__all__ = ["POINTS", "MARGIN_REL", "MAX_SAMPLES", "Margin", "Probes", "family_check", "family_loops", "first_crossing",
           "latency_margin"]

POINTS = 8  # base grid per family (certify: 96)
CERTIFY_POINTS = 96
FD_CELL = 1e-3  # of certify's grid spacing
_FD = 1e-7
CHORD = 1.0
BISECT_REL = 1e-10
MARGIN_REL = 1e-9
ILLINOIS_STEPS = 200
CONFIRM = 1e-3
NEGLIGIBLE = 1e-6  # relative change of the margin below which a member of largest ρ is not followed
ROUNDS = 4
MAX_SAMPLES = 200.0
EDGE_SLIVER = 1e-6  # certify's: an interval end's stable side is checked up to this distance (relative)
MARCH_STEPS = 96  # rounds (one batch each) of cells tried on the stable sides of the interval ends; the rest is left unresolved


def _greedy_match(la: np.ndarray, lb: np.ndarray) -> np.ndarray:
    """perm (c, N): a one-to-one matching of the eigenvalues ``la`` (c, N) to ``lb`` (c, N),
    nearest pairs first by squared distance (where every eigenvalue's nearest partner is a
    different one, that is the matching; the other rows are matched pair by pair). The compiled engine runs the same
    rule in :func:`exotune.numerics.kernels.eig.match_spectra`."""
    if compiled():
        from ..numerics.kernels.eig import match_spectra

        return match_spectra(la, lb)
    c, N = la.shape
    with np.errstate(invalid="ignore", over="ignore"):
        diff = la[:, :, None] - lb[:, None, :]
        D = np.nan_to_num(diff.real * diff.real + diff.imag * diff.imag, nan=1e300, posinf=1e300)  # squared
    perm = np.argmin(D, axis=2)
    srt = np.sort(perm, axis=1)
    clash = np.nonzero(np.any(srt[:, 1:] == srt[:, :-1], axis=1))[0]
    if clash.size:
        D = D[clash]
        k = clash.size
        rows = np.arange(k)
        p = np.zeros((k, N), np.int64)
        for _ in range(N):
            flat = D.reshape(k, -1).argmin(axis=1)
            r, col = flat // N, flat % N
            p[rows, r] = col
            D[rows, r, :] = np.inf
            D[rows, :, col] = np.inf
        perm[clash] = p
    return perm


class _Family:
    """The members evaluated for one loop (family) of several designs: flat arrays of points."""

    def __init__(self, bl: BatchLoops, des: np.ndarray, loop: Loop, lo: float, hi: float, delay: np.ndarray):
        self.bl, self.des, self.loop, self.lo, self.hi = bl, des, loop, lo, hi
        self.delay = delay  # per local design
        self.log = lo > 0
        self.width = 8 + int(bl.nz[des].max(initial=0)) + int(np.max(delay, initial=0.0) / bl.Ts + 1e-9)
        # the points' columns: views of buffers that grow by doubling (:meth:`_append`)
        self._buf = {"v": np.zeros(64), "owner": np.zeros(64, np.int64), "rho": np.zeros(64),
                     "st": np.zeros(64, bool), "eig": np.zeros((64, self.width), complex),
                     "der": np.zeros((64, self.width), complex), "has_der": np.zeros(64, bool)}
        self._view(0)
        # certify's grid spacing in u: the derivative step and the finest cell are certify's
        self.fd_spacing = (self.u(hi) - self.u(lo)) / (CERTIFY_POINTS - 1)

    def u(self, v):
        return np.log(v) if self.log else v

    def from_u(self, u):
        return np.exp(u) if self.log else u

    def mid(self, a, b):
        return np.sqrt(a * b) if self.log else 0.5 * (a + b)

    def spectra(self, owner: np.ndarray, v: np.ndarray, delay=None):
        return self.bl.spectra(self.des[owner], self.loop, v, self.delay[owner] if delay is None else delay, self.width)

    def eval(self, owner: np.ndarray, v: np.ndarray, derivative: bool = False) -> np.ndarray:
        """Evaluate members ``v`` of local designs ``owner``; returns their point indices. With
        ``derivative`` their dλ/du too, in the same batch (:meth:`derivatives`' forward difference)."""
        if derivative:
            h = self.step(v)
            rho, eig, st = self.spectra(np.concatenate([owner, owner]), np.concatenate([v, v + h]))
            eh, (rho, eig, st) = eig[v.size:], (rho[:v.size], eig[:v.size], st[:v.size])
        else:
            rho, eig, st = self.spectra(owner, v)
        start = self.v.size
        self._append(v=v, owner=owner, rho=rho, st=st, eig=eig, der=0.0, has_der=derivative)
        pts = np.arange(start, start + v.size)
        if derivative:
            self._set_derivatives(pts, h, eh)
        return pts

    def _view(self, size: int) -> None:
        for name, buf in self._buf.items():
            setattr(self, name, buf[:size])

    def _append(self, **cols) -> None:
        """Append points (a value per column, arrays or scalars) to the columns."""
        start = self.v.size
        stop = start + np.size(cols["v"])
        if stop > self._buf["v"].shape[0]:
            cap = max(2 * self._buf["v"].shape[0], stop)
            for name, buf in self._buf.items():
                grown = np.zeros((cap,) + buf.shape[1:], buf.dtype)
                grown[:start] = buf[:start]
                self._buf[name] = grown
        for name, val in cols.items():
            self._buf[name][start:stop] = val
        self._view(stop)

    def step(self, v: np.ndarray) -> np.ndarray:
        """The forward-difference step at the members ``v`` (certify's)."""
        if self.log:
            return v * max(_FD, FD_CELL * self.fd_spacing)
        return np.maximum(_FD * np.where(v != 0, np.abs(v), max(abs(self.hi), 1.0)), FD_CELL * self.fd_spacing)

    def _set_derivatives(self, pts: np.ndarray, h: np.ndarray, eh: np.ndarray) -> None:
        v = self.v[pts]
        perm = _greedy_match(self.eig[pts], eh)
        du = self.u(v + h) - self.u(v)
        with np.errstate(invalid="ignore"):
            self.der[pts] = (np.take_along_axis(eh, perm, 1) - self.eig[pts]) / du[:, None]
        self.has_der[pts] = True

    def derivatives(self, pts: np.ndarray) -> None:
        """dλ/du at the points ``pts`` (certify's forward difference, eigenvalues matched)."""
        pts = np.unique(pts)
        pts = pts[~self.has_der[pts]]
        if not pts.size:
            return
        h = self.step(self.v[pts])
        _rho, eh, _st = self.spectra(self.owner[pts], self.v[pts] + h)
        self._set_derivatives(pts, h, eh)

    def resolved(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Step control of the cells (point indices ``a``, ``b``, both stable)."""
        la, lb = self.eig[a], self.eig[b]
        perm = _greedy_match(la, lb)
        lbm = np.take_along_axis(lb, perm, 1)
        dist = np.minimum(np.abs(1.0 - np.abs(la)), np.abs(1.0 - np.abs(lbm)))
        ok = np.all(np.abs(lbm - la) <= CHORD * dist, axis=1)
        if ok.any():
            self.derivatives(np.concatenate([a[ok], b[ok]]))
            length = np.abs(self.u(self.v[b[ok]]) - self.u(self.v[a[ok]]))
            speed = np.maximum(np.abs(self.der[a[ok]]), np.abs(np.take_along_axis(self.der[b[ok]], perm[ok], 1)))
            ok[ok] = np.all(length[:, None] * speed <= CHORD * dist[ok], axis=1)
        return ok


def _refine(fam: _Family, a: np.ndarray, b: np.ndarray, depth: int) -> list:
    """Halve unresolved stable cells (``a``, ``b``: point indices), batched by level; returns the
    unresolved cells [(owner, va, vb)]."""
    unresolved = []
    while a.size:
        keep = fam.st[a] & fam.st[b]
        a, b = a[keep], b[keep]
        if not a.size:
            break
        bad = ~fam.resolved(a, b)
        a, b = a[bad], b[bad]
        if not depth:
            unresolved += list(zip(fam.owner[a].tolist(), fam.v[a].tolist(), fam.v[b].tolist()))
            break
        m = fam.eval(fam.owner[a], fam.mid(fam.v[a], fam.v[b]))
        a, b = np.concatenate([a, m]), np.concatenate([m, b])
        depth -= 1
    return unresolved


def _edges(fam: _Family) -> tuple[np.ndarray, list, tuple]:
    """(points sorted by design then member, [(design, position, stable after)], sides): every change
    of verdict narrowed to ``BISECT_REL`` by the Illinois method on ρ − 1 (bracket kept by the verdicts).
    ``sides`` = (design, stable neighbour's point index, stable end of the bracket, unstable end) per edge."""
    order = np.lexsort((fam.v, fam.owner))
    o, st = fam.owner[order], fam.st[order]
    j = np.nonzero((o[:-1] == o[1:]) & (st[:-1] != st[1:]))[0]
    own, left = o[j], st[j]
    ua, ub = fam.u(fam.v[order[j]]), fam.u(fam.v[order[j + 1]])
    ga, gb = fam.rho[order[j]] - 1.0, fam.rho[order[j + 1]] - 1.0
    side = np.zeros(j.size, np.int64)
    for it in range(48):
        act = np.nonzero(fam.from_u(ub) - fam.from_u(ua) > BISECT_REL * np.abs(fam.from_u(ub)))[0]
        if not act.size:
            break
        x = _illinois_point(ua[act], ga[act], ub[act], gb[act], it % 4 == 3)
        p = fam.eval(own[act], fam.from_u(x))
        _illinois_move(ua, ga, ub, gb, side, act, x, fam.rho[p] - 1.0, fam.st[p] == left[act])
    a, b = fam.from_u(ua), fam.from_u(ub)
    sides = (own, np.where(left, order[j], order[j + 1]), np.where(left, a, b), np.where(left, b, a))
    return order, [(int(i), float(0.5 * (x + y)), not bool(s)) for i, x, y, s in zip(own, a, b, left)], sides


def _predicted_cell(fam: _Family, pts: np.ndarray) -> np.ndarray:
    """The widest cell (in u) from the points ``pts`` that step control is expected to resolve:
    0.9 × min over eigenvalues of distance to the unit circle / (|dλ/du| + |d|λ|/du|) (the chord
    and the first-order motion each stay below the distance, which shrinks at the normal speed)."""
    fam.derivatives(pts)
    lam, d = fam.eig[pts], fam.der[pts]
    dist = np.abs(1.0 - np.abs(lam))
    with np.errstate(invalid="ignore", divide="ignore"):
        normal = np.abs(np.real(np.conj(lam) * d)) / np.maximum(np.abs(lam), 1e-300)
        w = np.min(dist / (np.abs(d) + normal), axis=1)
    return 0.9 * np.where(np.isfinite(w), w, np.inf)


def _march(fam: _Family, own, spt, t, bad, unresolved: list) -> bool:
    """The stable sides of interval ends (:func:`exotune.controllerfile.continuation.stable_intervals`'s
    march, step control only): from the stable point ``spt`` toward the bracket's stable end ``t``
    by cells (half the way first, then the width step control is predicted to resolve after each
    resolved cell, :func:`_predicted_cell`), halved after an unresolved one, up to ``EDGE_SLIVER`` (relative) from ``t``, at most ``MARCH_STEPS``
    rounds. An unstable member on the way is a window: the points from it to the edge's unstable
    end ``bad`` are set unstable (the stable part beyond a window is not claimed) and True is
    returned (the edges are narrowed again); cells left are appended to ``unresolved``."""
    ut = fam.u(t)
    sliver = EDGE_SLIVER * (np.ones_like(t) if fam.log else np.maximum(np.abs(t), 1e-300))
    pos, sign = spt.copy(), np.sign(ut - fam.u(fam.v[spt]))
    w = 0.5 * np.abs(ut - fam.u(fam.v[spt]))  # the first cell: half the way (a window far from the end is met at once)
    act = np.nonzero(np.abs(ut - fam.u(fam.v[pos])) > sliver)[0]
    fresh = act[:0]  # edges whose next cell is predicted from their new position
    window = False
    for _ in range(MARCH_STEPS):
        if fresh.size:
            w[fresh] = _predicted_cell(fam, pos[fresh])
        pu = fam.u(fam.v[pos[act]])
        w[act] = np.minimum(np.abs(w[act]), np.abs(ut[act] - pu))
        tiny = w[act] < sliver[act] * 1e-3
        unresolved += [(int(own[k]), *sorted((float(fam.v[pos[k]]), float(t[k])))) for k in act[tiny]]
        act = act[~tiny]
        if not act.size:
            break
        pu = fam.u(fam.v[pos[act]])
        y = np.where(np.abs(ut[act] - pu) <= w[act], t[act], fam.from_u(pu + sign[act] * w[act]))
        p = fam.eval(fam.owner[pos[act]], y, derivative=True)
        unst = ~fam.st[p]
        for k, q in zip(act[unst], p[unst]):  # a window: the members beyond it are not claimed
            lo, hi = sorted((fam.v[q], bad[k]))
            fam.st[(fam.owner == fam.owner[q]) & (fam.v > lo) & (fam.v < hi)] = False
            window = True
        act, p = act[~unst], p[~unst]
        ok = fam.resolved(pos[act], p) if act.size else np.zeros(0, bool)
        pos[act[ok]] = p[ok]
        w[act[~ok]] *= 0.5
        fresh = act[ok]
        act = act[np.abs(ut[act] - fam.u(fam.v[pos[act]])) > sliver[act]]
        fresh = np.intersect1d(fresh, act)
        if not act.size:
            break
    else:
        unresolved += [(int(own[k]), *sorted((float(fam.v[pos[k]]), float(t[k])))) for k in act]
    return window


def _illinois_point(lo, glo, hi, ghi, bisect: bool) -> np.ndarray:
    """The regula falsi point of brackets [lo, hi] (g values glo, ghi), the midpoint where it is
    not strictly inside or when ``bisect``."""
    with np.errstate(invalid="ignore", divide="ignore"):
        x = (lo * ghi - hi * glo) / (ghi - glo)
    bad = ~np.isfinite(x) | (x <= lo) | (x >= hi) | bisect
    x[bad] = 0.5 * (lo[bad] + hi[bad])
    return x


def _illinois_move(lo, glo, hi, ghi, side, act, x, g, left) -> None:
    """Brackets ``act`` take the new points ``x`` (values ``g``) as their lower end where
    ``left``, else as their upper end; an end kept twice has its g halved (the Illinois method)."""
    a, b = act[left], act[~left]
    lo[a], glo[a] = x[left], g[left]
    ghi[a] *= np.where(side[a] == -1, 0.5, 1.0)
    side[a] = -1
    hi[b], ghi[b] = x[~left], g[~left]
    glo[b] *= np.where(side[b] == 1, 0.5, 1.0)
    side[b] = 1


def family_check(bl: BatchLoops, des, loop: Loop, lo: float, hi: float, delay=None, points: int | None = None) -> dict:
    """Stable intervals of one family for the designs ``des`` (at total delays ``delay`` [s],
    default their own), by the module docstring's method.

    Parameters
    ----------
    bl : BatchLoops
        The sampled-data loops of the batch.
    des : array_like of int
        Indices of the designs to check.
    loop : Loop
        The family (which loop and which parameter varies).
    lo, hi : float
        Range of the varied parameter, in its unit (inertia [kg·m²], damping [N·m·s/rad],
        stiffness [N·m/rad]).
    delay : array_like or None, optional
        Total delay [s] per design; None for each design's own.
    points : int or None, optional
        Grid members per design; None for ``POINTS``.

    Returns
    -------
    dict of per-design lists/arrays: ``stable_intervals``, ``robust`` (the whole range stable and
    every cell resolved), ``critical`` (member of largest spectral radius), ``critical_radius``,
    ``unresolved`` (cells), ``evaluations``, ``points`` (the members evaluated: design, value,
    spectral radius).
    """
    des = np.asarray(des, dtype=np.int64)
    nd = des.size
    points = POINTS if points is None else points
    delay = bl.delay[des] if delay is None else np.asarray(delay, dtype=float)
    fam = _Family(bl, des, loop, lo, hi, delay)
    vals = np.geomspace(lo, hi, points) if lo > 0 else np.linspace(lo, hi, points)
    grid = fam.eval(np.repeat(np.arange(nd), points), np.tile(vals, nd)).reshape(nd, points)
    depth = 12 + max(0, math.ceil(math.log2((CERTIFY_POINTS - 1) / max(points - 1, 1))))  # certify's finest cell
    unresolved = _refine(fam, grid[:, :-1].ravel(), grid[:, 1:].ravel(), depth)
    marched: set = set()
    while True:  # the stable side of every interval end is checked; a window found moves that end
        order, edges, (own, spt, t, bad) = _edges(fam)
        new = np.array([(int(i), x) not in marched for i, x, _ in edges], bool)
        marched |= {(int(i), x) for i, x, _ in edges}
        if not (new.any() and _march(fam, fam.owner[spt[new]], spt[new], t[new], bad[new], unresolved)):
            break
    out = {"stable_intervals": [], "robust": np.zeros(nd, bool), "critical": np.zeros(nd),
           "critical_radius": np.zeros(nd), "unresolved": [[] for _ in range(nd)], "evaluations": fam.v.size,
           "points": (fam.owner, fam.v, fam.rho)}
    for i, a, b in unresolved:
        out["unresolved"][i].append([a, b])
    per = [[] for _ in range(nd)]
    for i, x, after in edges:
        per[i].append((x, after))
    first = fam.st[grid[:, 0]]
    for i in range(nd):
        cuts = [lo] + [x for x, _ in per[i]] + [hi]
        after = [bool(first[i])] + [s for _, s in per[i]]
        ivs = [[cuts[k], cuts[k + 1]] for k in range(len(after)) if after[k]]
        out["stable_intervals"].append(ivs)
        out["robust"][i] = ivs == [[lo, hi]] and not out["unresolved"][i]
    top = np.lexsort((fam.rho, fam.owner))
    last = top[np.r_[fam.owner[top][1:] != fam.owner[top][:-1], True]]
    out["critical"][fam.owner[last]], out["critical_radius"][fam.owner[last]] = fam.v[last], fam.rho[last]
    return out


def family_loops(humans, environment) -> list:
    """The checked families of a design or a controller file's ``certify`` section, as loops: the
    one list behind the sweep's sampled-data columns and ``exotune certify``'s latency margin.

    Parameters
    ----------
    humans : sequence of HumanFamily
        The human families (:func:`exotune.config.parse_human`).
    environment : sequence
        The environments (:func:`exotune.config.parse_env`).

    Returns
    -------
    list of tuple
        ``(loop, lo, hi)``: the :class:`~exotune.sampled.batch.Loop` named ``human{i}_{kind}`` of
        every rational one-parameter human family (hysteretic humans and boxes of several uncertain
        parameters have none), then ``env{i}_{kind}`` of every environment spring or mass range,
        with the range of the varied parameter.
    """
    out = []
    for i, fam in enumerate(humans):
        if fam.kind == "complex_stiffness" or fam.box:
            continue
        fixed = {k: v for k, v in fam.fixed().items() if k in ("inertia", "damping", "stiffness")}
        out.append((Loop(f"human{i}_{fam.kind}", human=fixed, param=fam.param), fam.lo, fam.hi))
    for i, env in enumerate(environment):
        if env.kind in ("spring", "mass"):
            out.append((Loop(f"env{i}_{env.kind}", env_param=env.param, env_damping=env.damping), env.lo, env.hi))
    return out


class Probes:
    """The probe loops of the latency margin of the designs ``des`` of ``bl``: ``loops``, a list of
    (:class:`~exotune.sampled.batch.Loop`, member per design (n,) or None); a NaN member is no
    probe for that design. A probe's verdict is its spectral radius ρ < 1 (the rigid-body z = 1 of
    an ungrounded loop set aside; no rounding estimate: certify decides the probes on ρ alone)."""

    def __init__(self, bl: BatchLoops, des, loops: list):
        self.bl, self.des, self.loops = bl, np.asarray(des, dtype=np.int64), list(loops)

    def __len__(self) -> int:
        return len(self.loops)

    def all(self, idx: np.ndarray, x: np.ndarray):
        """(ρ, stable) (len(idx), probes) of designs ``idx`` (positions in ``des``) at extra delays ``x`` [s]."""
        P = len(self.loops)
        r, s = self.one(np.repeat(idx, P), np.tile(np.arange(P), idx.size), np.repeat(x, P))
        return r.reshape(idx.size, P), s.reshape(idx.size, P)

    def one(self, idx: np.ndarray, which: np.ndarray, x: np.ndarray):
        """(ρ, stable) (len(idx),) of probe ``which[j]`` of design ``idx[j]`` at extra delay ``x[j]``;
        the probes of one loop (a family's members) in one batch."""
        r, s = np.zeros(idx.size), np.ones(idx.size, bool)
        groups: dict = {}
        for q in np.unique(which).tolist():
            groups.setdefault(id(self.loops[q][0]), []).append(q)
        for qs in groups.values():
            loop = self.loops[qs[0]][0]
            j = np.nonzero(np.isin(which, qs))[0]
            v = None
            if self.loops[qs[0]][1] is not None:
                v = np.full(j.size, np.nan)
                for q in qs:
                    k = which[j] == q
                    v[k] = self.loops[q][1][idx[j[k]]]
                j, v = j[np.isfinite(v)], v[np.isfinite(v)]
            if j.size:
                d = self.des[idx[j]]
                r[j], _e, s[j] = self.bl.spectra(d, loop, v, self.bl.delay[d] + x[j], rounding=False)
        return r, s


def _illinois(pr, idx, which, lo, glo, hi, ghi, rel: float):
    """Narrow [lo, hi] (probe ``which`` stable at lo, not at hi; g = ρ − 1) to hi − lo ≤ ``rel``·lo."""
    side = np.zeros(idx.size, np.int64)
    for it in range(ILLINOIS_STEPS):
        act = np.nonzero(hi - lo > rel * lo)[0]
        if not act.size:
            break
        x = _illinois_point(lo[act], glo[act], hi[act], ghi[act], it % 5 == 4)
        r, s = pr.one(idx[act], which[act], x)
        _illinois_move(lo, glo, hi, ghi, side, act, x, r - 1.0, s)
    return lo, hi


def _bracket(pr, idx, hint, Ts: float, cap: np.ndarray):
    """(lo, hi, ρ at hi (len(idx), probes)): every probe stable at lo, some unstable at hi (hi = inf
    when none is up to ``cap``), from ΔT_c − T_s/2 and ΔT_c, else growing from half a sample."""
    n = idx.size
    lo, hi = np.zeros(n), np.full(n, np.inf)
    Rhi = np.zeros((n, len(pr)))
    h = np.asarray(hint, float) if hint is not None else np.full(n, np.nan)
    for trial in (h - 0.5 * Ts, h):  # the zero-order hold costs about half a sample
        act = np.nonzero(np.isinf(hi) & np.isfinite(trial) & (trial > lo) & (trial < cap))[0]
        if act.size:
            R, S = pr.all(idx[act], trial[act])
            un = ~S.all(axis=1)
            hi[act[un]], Rhi[act[un]] = trial[act[un]], R[un]
            lo[act[~un]] = trial[act[~un]]
    while True:
        act = np.nonzero(np.isinf(hi) & (lo < cap))[0]
        if not act.size:
            break
        x = np.minimum(lo[act] + np.maximum(0.5 * Ts, lo[act]), cap[act])
        R, S = pr.all(idx[act], x)
        un = ~S.all(axis=1)
        hi[act[un]], Rhi[act[un]] = x[un], R[un]
        lo[act[~un]] = x[~un]
    return lo, hi, Rhi


def _follow(pr, idx, lo, hi, Rhi, rel: float):
    """Narrow the brackets to the first crossing: follow the probe of largest ρ at hi alone
    (Illinois), check all probes at its stable end, follow another one unstable there; returns
    (lo, hi, dρ/dΔT of the probe followed last, over its bracket) per design."""
    lo, hi, Rhi = lo.copy(), hi.copy(), Rhi.copy()
    slope = np.zeros(idx.size)
    act = np.arange(idx.size)
    for _ in range(len(pr)):  # a probe followed once is stable below the brackets that follow
        if not act.size:
            break
        which = np.argmax(Rhi[act], axis=1)
        glo = pr.one(idx[act], which, lo[act])[0] - 1.0
        ghi = Rhi[act, which] - 1.0
        slope[act] = (ghi - glo) / (hi[act] - lo[act])
        a, b = _illinois(pr, idx[act], which, lo[act].copy(), glo, hi[act].copy(), ghi, rel)
        R, S = pr.all(idx[act], a)
        un = ~S.all(axis=1)
        lo[act[~un]], hi[act[~un]] = a[~un], b[~un]
        hi[act[un]], Rhi[act[un]] = a[un], R[un]
        act = act[un]
    return lo, hi, slope


def first_crossing(probes, idx, hint, Ts: float, cap, rel: float = MARGIN_REL):
    """The bracketing of the sampled-data latency margin (module docstring), on any probe set: per
    design, the first extra delay at which some probe turns unstable, bracketed from ΔT_c − T_s/2
    and ΔT_c (else growing from half a sample, doubling, up to ``cap``) and narrowed by the
    Illinois method on one probe's ρ − 1 at a time (the verdicts keep the bracket).

    Parameters
    ----------
    probes : Probes
        Or any object with ``len(probes)`` probes, ``probes.all(idx, x)`` → (ρ, stable), each
        (len(idx), len(probes)), of designs ``idx`` at extra delays ``x`` [s], and
        ``probes.one(idx, which, x)`` → (ρ, stable) (len(idx),) of probe ``which[j]`` of design
        ``idx[j]``.
    idx : numpy.ndarray
        The designs to search (int, as ``probes`` numbers them).
    hint : array_like or None
        Continuous latency margin [s] per design of ``idx`` (NaN: none); None for none.
    Ts : float
        Sample period [s].
    cap : array_like
        Largest extra delay [s] searched, per design of ``idx``.
    rel : float, optional
        Relative resolution: hi − lo ≤ ``rel``·lo.

    Returns
    -------
    lo : numpy.ndarray
        Per design, an extra delay [s] at which every probe is stable (``cap`` when none turns
        unstable up to it).
    hi : numpy.ndarray
        An extra delay [s] at which some probe is unstable (inf: none up to ``cap``).
    slope : numpy.ndarray
        dρ/dΔT [1/s] of the probe followed last, over its bracket (0 without a crossing).
    """
    idx = np.asarray(idx, dtype=np.int64)
    cap = np.asarray(cap, dtype=float)
    lo, hi, Rhi = _bracket(probes, idx, hint, Ts, cap)
    slope = np.zeros(idx.size)
    act = np.nonzero(np.isfinite(hi))[0]
    if act.size:
        lo[act], hi[act], slope[act] = _follow(probes, idx[act], lo[act], hi[act], Rhi[act], rel)
    return lo, hi, slope


def _unstable_members(bl: BatchLoops, des, families: list, a: np.ndarray, slope: np.ndarray) -> list:
    """Per family, a member (per design; NaN: none) unstable at the extra delays ``a`` that no
    probe covers: the family check at ΔT (1 − ``CONFIRM``) finds a gap (its critical member), or
    its member of largest spectral radius there — located by the check's step control, which
    refines where ρ is near 1 — is unstable at ΔT by more than a ``NEGLIGIBLE`` relative change
    of the margin (judged with the followed probe's dρ/dΔT ``slope``)."""
    n = des.size
    T = bl.delay[des]
    new = [np.full(n, np.nan) for _f in families]
    rest = np.arange(n)
    for k, (loop, flo, fhi, _c) in enumerate(families):
        if not rest.size:
            break
        chk = family_check(bl, des[rest], loop, flo, fhi, T[rest] + a[rest] * (1.0 - CONFIRM))
        gap = np.array([ivs != [[flo, fhi]] for ivs in chk["stable_intervals"]], bool)
        new[k][rest[gap]] = chk["critical"][gap]
        top, crit = rest[~gap], chk["critical"][~gap]
        rest = top
        if top.size:
            rho, _e, _s = bl.spectra(des[top], loop, crit, T[top] + a[top], rounding=False)
            far = rho - 1.0 > NEGLIGIBLE * a[top] * np.maximum(slope[top], 0.0)
            new[k][top[far]] = crit[far]
            rest = top[~far]
    return new


@dataclass(frozen=True)
class Margin:
    """The sampled-data latency margin of a batch (:func:`latency_margin`): ``extra_delay_s`` [s]
    per design (every probe stable there; ``inf`` where none turns unstable up to ``MAX_SAMPLES``
    samples of total delay) and the :class:`Probes` at the end — free, locked, each family's ends
    and critical member, the extra probes given, and the members the family checks added."""

    extra_delay_s: np.ndarray
    probes: Probes


def latency_margin(bl: BatchLoops, des, families: list, hint=None, probes=()) -> Margin:
    """The sampled-data latency margin of the designs ``des`` (module docstring): the one engine
    of the sweep's ``sampled_latency_margin_samples`` and of ``exotune certify`` (on a batch of
    one, :meth:`~exotune.sampled.batch.BatchLoops.of_controller`). Call it on designs stable at
    their own delay (0 is not returned here).

    Parameters
    ----------
    bl : BatchLoops
        The sampled-data loops of the batch.
    des : array_like of int
        Indices of the designs, each stable at its own delay.
    families : list of tuple
        ``(loop, lo, hi, critical)`` per family: the :class:`~exotune.sampled.batch.Loop`, its
        range and its critical member per design (NaN: none).
    hint : array_like or None, optional
        Continuous latency margins [s] per design, where the search starts (NaN: none); None to
        grow from half a sample.
    probes : sequence of tuple, optional
        Extra probes ``(loop, member per design)`` (NaN: none for that design).

    Returns
    -------
    Margin
        ``extra_delay_s`` [s] per design (to ``MARGIN_REL`` relative of the first crossing of a
        probe; ``inf`` where no extra delay up to ``MAX_SAMPLES`` samples destabilizes one) and the
        probes at the end.
    """
    des = np.asarray(des, dtype=np.int64)
    n = des.size
    cap = MAX_SAMPLES * bl.Ts - bl.delay[des]
    loops = [(Loop("free"), None), (Loop("locked", env="locked"), None)]
    for loop, lo, hi, crit in families:
        loops += [(loop, np.full(n, float(lo))), (loop, np.full(n, float(hi))), (loop, np.asarray(crit, float))]
    pr = Probes(bl, des, loops + list(probes))
    h = np.full(n, np.nan) if hint is None else np.array(hint, dtype=float)
    out = np.full(n, math.inf)
    act = np.arange(n)
    for _ in range(ROUNDS):
        lo, hi, slope = first_crossing(pr, act, h[act], bl.Ts, cap[act])
        found = np.isfinite(hi)
        out[act] = np.where(found, lo, math.inf)
        act, a, slope = act[found], lo[found], slope[found]
        if not act.size:
            break
        new = _unstable_members(bl, des[act], families, a, slope)
        redo = ~np.all([np.isnan(c) for c in new], axis=0)
        if not redo.any():
            break
        for k, (loop, *_r) in enumerate(families):
            if np.any(~np.isnan(new[k])):
                col = np.full(n, np.nan)
                col[act] = new[k]
                pr.loops.append((loop, col))
        act = act[redo]
        h[act] = out[act]  # the search goes on from the last margin, where a new probe is unstable
    return Margin(out, pr)
