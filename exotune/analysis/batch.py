"""Every metric for a batch of designs at once: the columns of a sweep.

References
----------
docs/method.md#analyses-and-metrics; docs/sweep-spec.md#columns.
"""

from __future__ import annotations

import contextlib
import gc
from dataclasses import replace

import numpy as np

from ..model.controller import build_controller
from ..model.humans import HumanFamily
from ..model.shaping import Gains
from .amplification_ratio import dc_and_bandwidth
from .batch_result import (GAIN_NAMES, AmplificationBatch, BatchAnalysis, DobBatch, EnvironmentBatch, FamilyBatch,
                           LoopBatch)
from .charfun import amplification_qps, char_terms
from .counting import RootCounter
from .dob import dob_margins
from .intervals import FamilySide
from .latency import INFINITE_PROBES_S, batch_latency_margin, delay_limit
from .operator_passivity import passivity

__all__ = ["analyze_batch", "BatchAnalysis", "GAIN_NAMES", "cfg_size", "slice_cfg", "first_unstable_probe"]


def analyze_batch(cfg, max_chunk: int = 2048, verify: int = 0, latency: bool = False) -> BatchAnalysis:
    """Every docs/method.md#analyses-and-metrics metric for a batch configuration (fields may be arrays of length N).

    Parameters
    ----------
    cfg : DesignConfig
        One design or a batch (:func:`exotune.config.batch_config`: fields of length N).
    max_chunk : int
        Designs analysed together at most (larger batches are split and joined).
    verify : int
        > 0: additionally count RHP roots exactly at that many log-spaced values of every human
        family's range and check them against the intervals; a mismatch makes the family
        inconclusive (hence not robust) and is listed in its ``verification_mismatches``. The
        single-design report uses 64; sweeps use 0 (the interval method alone).
    latency : bool
        Also compute ``latency_margin_s`` [s]
        (:func:`~exotune.analysis.latency.batch_latency_margin`, docs/method.md#latency-margin):
        the largest extra delay every loop tolerates, 0 for a design that is not robust at its
        nominal delay. Sweeps always ask for it.

    Returns
    -------
    BatchAnalysis
        The typed metrics, one entry per design; ``.to_columns()`` gives the columns named as in
        docs/sweep-spec.md#columns (numpy arrays and, for interval-valued metrics, lists of lists
        of [lo, hi]).

    References
    ----------
    docs/method.md#analyses-and-metrics; docs/sweep-spec.md#columns.
    """

    # extreme designs overflow intermediate numbers; every result is checked for finiteness and
    # reported inconclusive, so numpy's warnings would only clutter a sweep's terminal
    with _gc_paused(), np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        N = cfg_size(cfg)
        if N > max_chunk:
            parts = [_analyze_chunk(slice_cfg(cfg, slice(i, min(i + max_chunk, N))), verify, latency)
                     for i in range(0, N, max_chunk)]
            return BatchAnalysis.concat(parts)
        return _analyze_chunk(cfg, verify, latency)


@contextlib.contextmanager
def _gc_paused():
    """The interval columns are lists of small lists (one per design): allocating them lets
    Python's cyclic garbage collector re-scan every live container again and again (it was a
    third of the run time). The analysis creates no reference cycles, so it is paused here."""
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()


def _analyze_chunk(cfg, verify: int, latency: bool = False) -> BatchAnalysis:
    N = cfg_size(cfg)
    cs, ds = build_controller(cfg.plant, cfg.design, cfg.implementation)
    ct = char_terms(cfg.plant, cs, N)
    counter = RootCounter()
    h_free = counter.add(ct.qp("00").p0, ct.qp("00").p1, ct.T)
    num, den = amplification_qps(cfg.plant, cs, N)
    h_num = counter.add(num.p0, num.p1, num.T)
    h_den = counter.add(den.p0, den.p1, den.T)
    # box families (several ranged msd parameters) are analysed through their edges
    edge_fams, edge_of = [], []
    for fam in cfg.humans:
        es = fam.edges()
        edge_of.append(list(range(len(edge_fams), len(edge_fams) + len(es))))
        edge_fams.extend(es)
    human = FamilySide(ct, "00", "10", edge_fams, verify=verify)
    human.compute_leaves((0.0, 0.0, 0.0))  # shared with passivity
    human.submit(counter)
    env_fams = [e for e in cfg.environment if e.kind in ("spring", "mass")]
    env_side = FamilySide(ct, "00", "01", [HumanFamily(e.kind, e.param, e.lo, e.hi, damping=e.damping) for e in env_fams])
    env_side.submit(counter)
    counter.run()
    Nf, rf, okf = counter.result(h_free)
    free = LoopBatch(stable=okf & (Nf == 0) & (rf <= 1), conclusive=okf, rigid_body_roots=rf)
    humans = _human_results(cfg.humans, human.collect(counter), edge_fams, edge_of, verify, N)
    Nn, rn, okn = counter.result(h_num)
    Nd_, rd, okd = counter.result(h_den)
    locked = LoopBatch(stable=okd & (Nd_ == 0) & (rd == 0), conclusive=okd)
    env_res = iter(env_side.collect(counter))
    environment = []
    for env in cfg.environment:
        if env.kind in ("locked", "free"):
            environment.append(EnvironmentBatch(env.kind, stable=(locked if env.kind == "locked" else free).stable))
        else:
            res = next(env_res)
            environment.append(EnvironmentBatch(env.kind, robust=res.robust, stable_intervals=res.stable_intervals))
    ps = passivity(human)
    dob = dob_margins(cs, N)
    dc, bw = dc_and_bandwidth(num, den)
    # amplification conclusive False: the minimum-phase verdict is unknown (reported False)
    amp = AmplificationBatch(dc=dc, bandwidth_hz=bw, minimum_phase=okn & (Nn == 0) & (rn == 0), conclusive=okn)
    gains = Gains(**{g: np.broadcast_to(np.asarray(getattr(ds.gains, g), dtype=float), (N,)).copy()
                     for g in GAIN_NAMES})
    out = BatchAnalysis(free=free, humans=tuple(humans), environment=tuple(environment), passivity=ps,
                        dob=dob if dob is not None else DobBatch.absent(N), amplification=amp, locked=locked,
                        gains=gains)
    if latency:
        m = batch_latency_margin(ct, cfg.humans, cfg.environment, out.loops_ok())
        out = replace(out, latency_margin_s=_infinite_checked(cfg, m))
    return out


def _infinite_checked(cfg, m: np.ndarray) -> np.ndarray:
    """The sweep's margins ``m`` [s] with every infinite one checked by
    :func:`first_unstable_probe`, as the single-design margin is: a row unstable at one of the
    probes is unknown (NaN), never infinite (docs/method.md#latency-margin). Infinite margins are
    rare (none in 2 000 random designs around either example), so this costs a sweep nothing in
    the usual case."""
    rows = np.flatnonzero(np.isinf(m))
    if rows.size == 0:
        return m
    out = m.copy()
    out[rows[np.isfinite(first_unstable_probe(cfg, rows))]] = np.nan
    return out


def first_unstable_probe(cfg, rows) -> np.ndarray:
    """The first extra delay of :data:`~exotune.analysis.latency.INFINITE_PROBES_S` (within the
    accepted delays) at which a loop of each design ``rows`` of the batch ``cfg`` is not stable by
    the exact verdicts (continuous time); NaN where none is. The check behind every infinite
    latency margin (docs/method.md#latency-margin).

    Parameters
    ----------
    cfg : DesignConfig
        A design or a batch.
    rows : array of int
        The designs to check.

    Returns
    -------
    numpy.ndarray
        Extra delay [s] per row (NaN: stable at every probe).
    """
    rows = np.asarray(rows, dtype=np.int64)
    N = cfg_size(cfg)
    sub = slice_cfg(cfg, rows) if N > 1 else cfg
    T = np.broadcast_to(np.asarray(cfg.implementation.delay_s, dtype=float), (N,))[rows]
    hi = delay_limit()
    first = np.full(rows.size, np.nan)
    for d in INFINITE_PROBES_S:
        inside = T + d <= hi
        if not inside.any():
            break
        probe = replace(sub, implementation=replace(sub.implementation, sample_rate_hz=None,
                                                    delay_s=np.minimum(T + d, hi)))
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            ok = _analyze_chunk(probe, 0).loops_ok()
        first = np.where(np.isnan(first) & inside & ~ok, d, first)
    return first


def _human_results(humans, edge_res: list, edge_fams: list, edge_of: list, verify: int, N: int) -> list[FamilyBatch]:
    """The result of every human family from the results of its edges (one edge for a
    one-parameter family; a box's edges, Edge Theorem)."""
    out = []
    for i, fam in enumerate(humans):
        if not fam.box:
            out.append(edge_res[edge_of[i][0]])
            continue
        # Edge Theorem: the box is robustly stable iff every edge is; the stable set of a box is
        # not one interval, so the interval column holds [[lo, hi]] of the first ranged parameter
        # when the whole box is stable and [] otherwise (per-edge details: analyze_design)
        ers = [edge_res[j] for j in edge_of[i]]
        robust = np.logical_and.reduce([r.robust for r in ers])
        out.append(FamilyBatch(
            kind=fam.kind, robust=robust, stable_intervals=[[[fam.lo, fam.hi]] if rb else [] for rb in robust],
            conclusive=np.logical_and.reduce([r.conclusive for r in ers]),
            critical=[[] for _ in range(N)],  # per edge (different parameters): see edges
            edges=[[(edge_fams[j], ers[k].stable_intervals[t_]) for k, j in enumerate(edge_of[i])] for t_ in range(N)],
            verification_mismatches=([[m for r in ers for m in r.verification_mismatches[t_]] for t_ in range(N)]
                                     if verify else None)))
    return out


def cfg_size(cfg) -> int:
    """The number of designs N of a configuration (1 for one design, else the length of its
    array fields).

    Parameters
    ----------
    cfg : DesignConfig
        One design or a batch (:func:`exotune.config.batch_config`).

    Returns
    -------
    int
        N.
    """
    n = 1
    for obj in (cfg.plant, cfg.design, cfg.implementation):
        for v in vars(obj).values():
            for x in (v, *(vars(v).values() if hasattr(v, "__dataclass_fields__") else ())):
                if isinstance(x, np.ndarray) and x.ndim >= 1:
                    n = max(n, x.shape[0])
    return n


def _slice_dc(obj, sl):
    import dataclasses

    if obj is None or not dataclasses.is_dataclass(obj):
        return obj
    kw = {}
    for f in dataclasses.fields(obj):
        v = getattr(obj, f.name)
        if isinstance(v, np.ndarray) and v.ndim >= 1:
            kw[f.name] = v[sl]
        elif dataclasses.is_dataclass(v):
            kw[f.name] = _slice_dc(v, sl)
        else:
            kw[f.name] = v
    return dataclasses.replace(obj, **kw)


def slice_cfg(cfg, sl):
    """The designs ``sl`` of a batch configuration (every array field indexed by ``sl``; scalar
    fields, shared by every design, kept).

    Parameters
    ----------
    cfg : DesignConfig
        One design or a batch.
    sl : slice or array_like of int
        The designs kept, in this order (repeats allowed).

    Returns
    -------
    DesignConfig
        The batch of those designs.
    """
    import dataclasses

    return dataclasses.replace(
        cfg,
        plant=_slice_dc(cfg.plant, sl),
        design=_slice_dc(cfg.design, sl),
        implementation=_slice_dc(cfg.implementation, sl),
    )
