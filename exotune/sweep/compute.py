"""Computing one chunk of a sweep (runs in the workers): design points → :func:`analyze_batch` →
Arrow table → Parquet file or bytes."""

from __future__ import annotations

import time
import traceback

import numpy as np

from ..version import __version__
from ..analysis import analyze_batch
from ..config import batch_config
from ..jsonio import write_atomic
from .plan import SweepPlan, chunk_points
from .store import arrow_column, chunk_file, np_arrow, schema_list, table_bytes

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


def compute_table(plan: SweepPlan, index: int):
    """The Arrow table of chunk ``index`` of ``plan``: ``point_index``, one float64 column per axis,
    then every column of :func:`~exotune.analysis.analyze_batch` (schema metadata: spec hash, chunk, version)."""
    import pyarrow as pa

    g, vals = chunk_points(plan, index)
    n = g.size
    cfg = batch_config(plan.cfg, vals)
    cols = analyze_batch(cfg, verify=int(plan.spec.get("verify_points", 0)))
    for k in [k for k in cols if k.endswith("_edges")]:
        del cols[k]  # per-edge details of box families (objects): single-design reports only
    for k in [k for k in cols if k.endswith("_verification_mismatches")]:
        cols[k] = np.array([len(m) for m in cols[k]], dtype=np.int64)  # count per design
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


def chunk_task(spec: dict, spec_hash: str, index: int, out_dir: str | None) -> dict:
    """Compute chunk ``index``; write it to ``out_dir`` (or return the Parquet bytes when
    ``out_dir`` is None, for remote Dask workers). Never raises: errors come back as text."""
    t0 = time.perf_counter()
    try:
        plan = _plan_from_spec(spec, spec_hash)
        table = compute_table(plan, index)
        data = table_bytes(table)
        res = {"index": index, "rows": table.num_rows, "schema": schema_list(table.schema), "error": None}
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
