"""Computing one chunk of a sweep (runs in the workers): design points → :func:`analyze_batch` →
Arrow table → Parquet file or bytes.

A design whose analysis raises does not lose the chunk: the chunk is split (bisection) until the
failing designs are isolated; their rows keep ``point_index`` and the axis values, every analysis
column is null, and the reasons are listed in the chunk's schema metadata
(``exotune.failed_rows``, JSON) and in the status record (``failed_rows``). A chunk without a
failing design is built exactly as before (same bytes). A chunk whose every design fails fails
whole, with the error of the whole batch.
"""

from __future__ import annotations

import hashlib
import json
import time
import traceback

import numpy as np

from ..version import __version__
from ..analysis import analyze_batch
from ..analysis.gain_schedule import analyze_schedule
from ..config import batch_config
from ..jsonio import write_atomic
from .plan import SweepPlan, chunk_points
from .store import FAILED_ROWS_KEY, arrow_column, chunk_file, failed_rows_of, np_arrow, schema_list, table_bytes

__all__ = ["compute_table", "chunk_task"]

_PLAN_CACHE: dict[str, SweepPlan] = {}


def _plan_from_spec(spec: dict, spec_hash: str) -> SweepPlan:
    plan = _PLAN_CACHE.get(spec_hash)
    if plan is None:
        plan = SweepPlan(spec)
        if plan.hash != spec_hash:
            raise RuntimeError("spec hash mismatch in worker (different exotune version?)")
        _PLAN_CACHE.clear()
        _PLAN_CACHE[spec_hash] = plan
    return plan


def _table(plan: SweepPlan, index: int, g: np.ndarray, vals: dict):
    """The Arrow table of the design points ``g`` (values ``vals``) of chunk ``index``."""
    import pyarrow as pa

    n = g.size
    cfg = batch_config(plan.cfg, vals)
    verify = int(plan.spec.get("verify_points", 0))
    res = analyze_batch(cfg, verify=verify, latency=True)
    cols = res.to_columns()  # the Parquet schema: the column names of docs/sweep-spec.md#columns
    sched = analyze_schedule(cfg, latency=True, verify=verify)  # None without a gain schedule
    if sched is not None:
        cols.update(sched.to_columns(res))
    for k in [k for k in cols if k.endswith("_edges")]:
        del cols[k]  # per-edge details of box families (objects): single-design reports only
    for k in [k for k in cols if k.endswith("_verification_mismatches")]:
        cols[k] = np.array([len(m) for m in cols[k]], dtype=np.int64)  # count per design
    if "plant_margin" in plan.spec:
        cols.update(_plant_margin_columns(cfg, res, plan.spec["plant_margin"]["budget"]))
    if plan.spec.get("sampled"):
        from .sampledcols import sampled_columns, sampled_schedule_columns

        cols.update(sampled_columns(cfg, res))
        if sched is not None:
            cols.update(sampled_schedule_columns(sched, cols))
    names, arrays = ["point_index"], [np_arrow(g, "i")]
    for p in plan.paths:
        names.append(p)
        arrays.append(np_arrow(vals[p], "f"))
    for k, v in cols.items():
        if k in names:
            raise ValueError(f"analysis column {k!r} clashes with an axis column")
        names.append(k)
        arrays.append(arrow_column(k, v, n))
    meta = {b"exotune.spec_hash": plan.hash.encode(), b"exotune.chunk": str(index).encode(),
            b"exotune.version": __version__.encode()}
    schema = pa.schema([pa.field(nm, a.type) for nm, a in zip(names, arrays)], metadata=meta)
    return pa.Table.from_arrays(arrays, schema=schema)


def _plant_margin_columns(cfg, res, budget: int) -> dict:
    """The opt-in columns ``plant_margin_lower`` / ``plant_margin_upper`` (multiples of the base
    design's declared ``uncertainty``, docs/method.md#plant-uncertainty-margin), one design at a
    time; 0 for a design that is not robust at the nominal plant (no search is spent on it)."""
    from ..analysis.design import design_plant_margin
    from ..config import design_row
    from ..numerics.beside import serial

    n = res.n
    lower, upper = np.zeros(n), np.zeros(n)
    weights = getattr(cfg, "uncertainty", None)
    with serial():  # the sweep's workers already use every core: no child process per design
        for i in range(n):
            pm = design_plant_margin(design_row(cfg, i), weights, nominal=res.row(i), budget=budget,
                                     loop_detail=False)  # with a gain schedule: the smallest over its entries
            lower[i], upper[i] = pm.lower, pm.upper
    return {"plant_margin_lower": lower, "plant_margin_upper": upper}


def _reason(e: BaseException, limit: int = 300) -> str:
    """One line: the exception's type and message, at most ``limit`` characters."""
    text = " ".join(f"{type(e).__name__}: {e}".split())
    return text if len(text) <= limit else text[: limit - 1] + "…"


def _isolate(plan: SweepPlan, index: int, g: np.ndarray, vals: dict, pos: np.ndarray, good: list, bad: list) -> None:
    """Bisect the rows ``pos`` of a chunk until every failing design is alone: tables of the
    analysable groups go to ``good`` as (positions, table), failures to ``bad`` as (position, reason)."""
    try:
        good.append((pos, _table(plan, index, g[pos], {p: v[pos] for p, v in vals.items()})))
        return
    except Exception as e:
        if pos.size == 1:
            bad.append((int(pos[0]), _reason(e)))
            return
    h = pos.size // 2
    _isolate(plan, index, g, vals, pos[:h], good, bad)
    _isolate(plan, index, g, vals, pos[h:], good, bad)


def _with_failed_rows(plan: SweepPlan, index: int, g: np.ndarray, vals: dict, err: Exception):
    """The table of a chunk in which some designs fail: the analysable designs (computed in groups;
    the analysis is batch-invariant) and, for the failing ones, rows with null results. Re-raises
    ``err`` (the whole batch's error) when every design fails."""
    import pyarrow as pa

    good: list = []
    bad: list = []
    _isolate(plan, index, g, vals, np.arange(g.size), good, bad)
    if not good:
        raise err
    tables = [t for _, t in good]
    merged = pa.concat_tables(tables)
    where = np.full(g.size, -1, dtype=np.int64)
    where[np.concatenate([p for p, _ in good])] = np.arange(merged.num_rows)
    take = pa.array(where, mask=where < 0)
    merged = merged.take(take)
    full = {"point_index": np_arrow(g, "i"), **{p: np_arrow(vals[p], "f") for p in plan.paths}}
    arrays = [full[nm] if nm in full else merged.column(nm).combine_chunks() for nm in merged.column_names]
    rows = [{"row": r, "point_index": int(g[r]), "reason": why} for r, why in sorted(bad)]
    meta = dict(tables[0].schema.metadata or {})
    meta[FAILED_ROWS_KEY] = json.dumps(rows).encode()
    schema = pa.schema([pa.field(nm, a.type) for nm, a in zip(merged.column_names, arrays)], metadata=meta)
    return pa.Table.from_arrays(arrays, schema=schema)


def compute_table(plan: SweepPlan, index: int):
    """The Arrow table of chunk ``index`` of ``plan``: ``point_index``, one float64 column per axis,
    then every column of :func:`~exotune.analysis.analyze_batch` (schema metadata: spec hash, chunk,
    version; with failing designs also ``exotune.failed_rows``, see the module docstring).

    Parameters
    ----------
    plan : SweepPlan
        The sweep.
    index : int
        The chunk.

    Returns
    -------
    pyarrow.Table
        One row per design of the chunk.

    References
    ----------
    docs/sweep-spec.md (columns, failed designs).
    """
    g, vals = chunk_points(plan, index)
    try:
        return _table(plan, index, g, vals)
    except Exception as e:
        if g.size == 1:
            raise
        return _with_failed_rows(plan, index, g, vals, e)


def chunk_task(spec: dict, spec_hash: str, index: int, out_dir: str | None) -> dict:
    """Compute chunk ``index``; write it to ``out_dir`` (or return the Parquet bytes when
    ``out_dir`` is None, for remote Dask workers). Never raises: errors come back as text.

    Parameters
    ----------
    spec : dict
        The validated sweep spec.
    spec_hash : str
        Its hash (the plan is rebuilt from the spec and checked against it).
    index : int
        Chunk index (from 0).
    out_dir : str or None
        The sweep directory, or None to return the file's bytes.

    Returns
    -------
    dict
        The status record: ``index``, ``rows``, ``schema``, ``error`` (None or the error text),
        ``sha256``, ``failed_rows``, ``seconds`` [s], and ``data`` (the Parquet bytes) when
        ``out_dir`` is None; a failed chunk has ``traceback`` instead of the file's fields.
    """
    t0 = time.perf_counter()
    try:
        plan = _plan_from_spec(spec, spec_hash)
        table = compute_table(plan, index)
        data = table_bytes(table)
        res = {"index": index, "rows": table.num_rows, "schema": schema_list(table.schema), "error": None,
               "sha256": hashlib.sha256(data).hexdigest(), "failed_rows": failed_rows_of(table.schema)}
        if out_dir is None:
            res["data"] = data
        else:
            write_atomic(chunk_file(out_dir, index), data)
    except Exception as e:  # reported by the parent, never dropped
        msg = " ".join(f"{type(e).__name__}: {e}".split())
        return {"index": index, "rows": 0, "schema": None, "error": msg,
                "traceback": traceback.format_exc(), "seconds": time.perf_counter() - t0}
    res["seconds"] = time.perf_counter() - t0
    return res
