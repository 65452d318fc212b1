"""Every metric for a batch of designs at once: the columns of a sweep.

References
----------
docs/method.md#analyses-and-metrics; docs/sweep-spec.md#columns.
"""

from __future__ import annotations

import contextlib
import gc

import numpy as np

from ..model.controller import build_controller
from ..model.humans import HumanFamily
from .amplification_ratio import dc_and_bandwidth
from .charfun import amplification_qps, char_terms
from .counting import RootCounter
from .dob import dob_margins
from .intervals import FamilySide
from .latency_batch import batch_latency_margin
from .phase_excess import passivity

__all__ = ["analyze_batch", "GAIN_NAMES"]


GAIN_NAMES = ("K1", "B1", "K2", "B2", "K2_hat", "B2_hat")


def analyze_batch(cfg, max_chunk: int = 2048, verify: int = 0, latency: bool = False) -> dict:
    """Every docs/method.md#analyses-and-metrics metric for a batch configuration (fields may be arrays of length N).

    Returns a dict of columns named as in docs/sweep-spec.md: numpy arrays (one entry per design) and, for
    interval-valued metrics, lists of lists of [lo, hi].

    ``verify`` > 0 additionally counts RHP roots exactly at that many log-spaced values of every
    family's range and checks them against the intervals; a mismatch makes the family
    inconclusive (hence not robust) and is listed in ``human{i}_{kind}_verification_mismatches``.
    The single-design report uses 64; sweeps use 0 (the interval method alone).

    ``latency`` adds the column ``latency_margin_s`` [s] (:func:`~exotune.analysis.latency_batch.batch_latency_margin`,
    docs/method.md#latency-margin): the largest extra delay every loop tolerates, 0 for a design
    that is not robust at its nominal delay. Sweeps always ask for it.
    """

    # extreme designs overflow intermediate numbers; every result is checked for finiteness and
    # reported inconclusive, so numpy's warnings would only clutter a sweep's terminal
    with _gc_paused(), np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        N = _cfg_size(cfg)
        if N > max_chunk:
            parts = [_analyze_chunk(_slice_cfg(cfg, slice(i, min(i + max_chunk, N))), verify, latency)
                     for i in range(0, N, max_chunk)]
            return _concat_columns(parts)
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


def _analyze_chunk(cfg, verify: int, latency: bool = False) -> dict:
    N = _cfg_size(cfg)
    cs, ds = build_controller(cfg.plant, cfg.design, cfg.implementation)
    ct = char_terms(cfg.plant, cs, N)
    out: dict = {}
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
    free_stable = okf & (Nf == 0) & (rf <= 1)
    out["free_stable"] = free_stable
    out["free_rigid_body_roots"] = rf
    out["free_conclusive"] = okf
    _human_columns(out, cfg.humans, human.collect(counter), edge_fams, edge_of, verify, N)
    Nn, rn, okn = counter.result(h_num)
    Nd_, rd, okd = counter.result(h_den)
    locked_stable = okd & (Nd_ == 0) & (rd == 0)
    env_res = iter(env_side.collect(counter))
    for i, env in enumerate(cfg.environment):
        key = f"env{i}_{env.kind}"
        if env.kind == "locked":
            out[f"{key}_stable"] = locked_stable
        elif env.kind == "free":
            out[f"{key}_stable"] = free_stable
        else:
            res = next(env_res)
            out[f"{key}_robust"] = res["robust"]
            out[f"{key}_stable_intervals"] = res["stable_intervals"]
    ps = passivity(human)
    out["passivity_conclusive"] = ps["conclusive"]
    out["passivity_max_phase_excess_deg"] = ps["max_phase_excess_deg"]
    out["passivity_nonpassive_band_hz"] = ps["nonpassive_band_hz"]
    dob = dob_margins(cs, N)
    nanv = np.full(N, np.nan)
    out["dob_phase_margin_deg"] = dob["phase_margin_deg"] if dob else nanv
    out["dob_gain_margin_db"] = dob["gain_margin_db"] if dob else nanv
    out["dob_delay_margin_s"] = dob["delay_margin_s"] if dob else nanv
    out["dob_crossover_hz"] = dob["crossover_hz"] if dob else nanv
    out["dob_stable"] = dob["stable"] if dob else np.ones(N, bool)
    dc, bw = dc_and_bandwidth(num, den)
    out["amplification_dc"] = dc
    out["amplification_bandwidth_hz"] = bw
    out["amplification_minimum_phase"] = okn & (Nn == 0) & (rn == 0)
    out["amplification_conclusive"] = okn  # False: the minimum-phase verdict is unknown (reported False)
    out["locked_stable"] = locked_stable
    out["locked_conclusive"] = okd
    if latency:
        out["latency_margin_s"] = batch_latency_margin(ct, cfg.humans, cfg.environment, out)
    for g in GAIN_NAMES:
        out[g] = np.broadcast_to(np.asarray(getattr(ds.gains, g), dtype=float), (N,)).copy()
    return out


def _human_columns(out: dict, humans, edge_res: list, edge_fams: list, edge_of: list, verify: int, N: int) -> None:
    """Write the columns of every human family into ``out`` from the results of its edges (one
    edge for a one-parameter family; a box's edges, Edge Theorem)."""
    for i, fam in enumerate(humans):
        key = f"human{i}_{fam.kind}"
        if not fam.box:
            res = edge_res[edge_of[i][0]]
            out[f"{key}_robust"] = res["robust"]
            out[f"{key}_stable_intervals"] = res["stable_intervals"]
            out[f"{key}_conclusive"] = res["conclusive"]
            out[f"{key}_critical"] = res["critical"]
            if verify:
                out[f"{key}_verification_mismatches"] = res["verification_mismatches"]
            continue
        # Edge Theorem: the box is robustly stable iff every edge is; the stable set of a box is
        # not one interval, so the interval column holds [[lo, hi]] of the first ranged parameter
        # when the whole box is stable and [] otherwise (per-edge details: analyze_design)
        ers = [edge_res[j] for j in edge_of[i]]
        robust = np.logical_and.reduce([r["robust"] for r in ers])
        out[f"{key}_robust"] = robust
        out[f"{key}_stable_intervals"] = [[[fam.lo, fam.hi]] if rb else [] for rb in robust]
        out[f"{key}_conclusive"] = np.logical_and.reduce([r["conclusive"] for r in ers])
        out[f"{key}_critical"] = [[] for _ in range(N)]  # per edge (different parameters): see _edges
        out[f"{key}_edges"] = [[(edge_fams[j], ers[k]["stable_intervals"][t_]) for k, j in enumerate(edge_of[i])] for t_ in range(N)]
        if verify:
            out[f"{key}_verification_mismatches"] = [[m for r in ers for m in r["verification_mismatches"][t_]] for t_ in range(N)]


def _cfg_size(cfg) -> int:
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


def _slice_cfg(cfg, sl):
    import dataclasses

    return dataclasses.replace(
        cfg,
        plant=_slice_dc(cfg.plant, sl),
        design=_slice_dc(cfg.design, sl),
        implementation=_slice_dc(cfg.implementation, sl),
    )


def _concat_columns(parts: list[dict]) -> dict:
    out = {}
    for k in parts[0]:
        v = parts[0][k]
        if isinstance(v, np.ndarray):
            out[k] = np.concatenate([p[k] for p in parts])
        else:
            out[k] = [x for p in parts for x in p[k]]
    return out
