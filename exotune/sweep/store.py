"""Parquet storage of a sweep: numpy columns → Arrow arrays, chunk files, reading the dataset back.

Chunk ``i`` is ``DIR/chunks/part-{i:06d}.parquet``; its schema carries the spec hash, the chunk
index and exotune's version as metadata (see the :mod:`exotune.sweep` package docstring).
"""

from __future__ import annotations

import os

import numpy as np

from ..errors import ConfigError
from .manifest import load_manifest

__all__ = ["CHUNK_DIR", "np_arrow", "arrow_column", "nested_float_lists", "table_bytes", "schema_list",
           "chunk_file", "chunk_ok", "read_tables", "load_results"]

CHUNK_DIR = "chunks"


def np_arrow(v: np.ndarray, kind: str):
    """A flat numpy column as an Arrow array, built on its buffer (zero-copy for float64/int64).

    ``pa.array`` would give the same array, but on its first call it imports pandas to test for
    pandas objects: ~1 s of every worker's start-up, for nothing (a sweep chunk holds numpy
    arrays only). NaN stays a NaN value, as with ``pa.array(..., from_pandas=False)``."""
    import pyarrow as pa

    if kind == "b":
        v = np.ascontiguousarray(v, dtype=bool)
        return pa.Array.from_buffers(pa.bool_(), v.size, [None, pa.py_buffer(np.packbits(v, bitorder="little"))])
    dt, at = {"i": (np.int64, pa.int64()), "i32": (np.int32, pa.int32()), "f": (np.float64, pa.float64())}[kind]
    v = np.ascontiguousarray(v, dtype=dt)
    return pa.Array.from_buffers(at, v.size, [None, pa.py_buffer(v)])


def arrow_column(name: str, v, n: int):
    """Column ``name`` of ``n`` rows as an Arrow array: a flat numpy array (bool, int, float) or a
    sequence of lists of [a, b] items (``list<list<double>>``)."""
    if isinstance(v, np.ndarray):
        if v.shape != (n,):
            raise ValueError(f"column {name!r} has shape {v.shape}, expected ({n},)")
        k = v.dtype.kind
        if k in "biuf":
            return np_arrow(v, {"u": "i"}.get(k, k))
        if k == "O":
            v = v.tolist()
        else:
            raise TypeError(f"column {name!r}: unsupported dtype {v.dtype}")
    if isinstance(v, (list, tuple)):
        if len(v) != n:
            raise ValueError(f"column {name!r} has {len(v)} entries, expected {n}")
        return nested_float_lists(v)
    raise TypeError(f"column {name!r}: unsupported type {type(v).__name__}")


def nested_float_lists(rows):
    """list<list<double>> Arrow array of rows of items (e.g. intervals [lo, hi]), built from flat
    offsets and values (the same array as ``pa.array(rows, type=list<list<double>>)``, without a
    Python-level conversion of every number)."""
    import itertools

    import pyarrow as pa

    items = list(itertools.chain.from_iterable(rows))
    outer = np.zeros(len(rows) + 1, np.int32)
    np.cumsum([len(r) for r in rows], out=outer[1:])
    inner = np.zeros(len(items) + 1, np.int32)
    np.cumsum([len(it) for it in items], out=inner[1:])
    values = np.fromiter(itertools.chain.from_iterable(items), dtype=np.float64, count=int(inner[-1]))
    lists = pa.ListArray.from_arrays(np_arrow(inner, "i32"), np_arrow(values, "f"))
    return pa.ListArray.from_arrays(np_arrow(outer, "i32"), lists)


def table_bytes(table) -> bytes:
    """A table as Parquet file bytes (zstd)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    sink = pa.BufferOutputStream()
    pq.write_table(table, sink, compression="zstd")
    return sink.getvalue().to_pybytes()


def _type_str(t) -> str:
    """Arrow type as text, independent of list child-field names ("item" vs Parquet's "element")."""
    import pyarrow as pa

    if pa.types.is_list(t) or pa.types.is_large_list(t):
        return f"list<{_type_str(t.value_type)}>"
    return str(t)


def schema_list(schema) -> list[list[str]]:
    """An Arrow schema as [[name, type], …] (the manifest's ``columns``)."""
    return [[f.name, _type_str(f.type)] for f in schema]


def chunk_file(out_dir: str, index: int) -> str:
    """The path of chunk ``index``'s Parquet file in the sweep directory ``out_dir``."""
    return os.path.join(out_dir, CHUNK_DIR, f"part-{index:06d}.parquet")


def chunk_ok(path: str, rows: int, spec_hash: str, schema: list | None) -> bool:
    """True when ``path`` is a complete chunk of this sweep: readable Parquet metadata, ``rows`` rows,
    the spec hash and (when known) the sweep's schema."""
    import pyarrow.parquet as pq

    try:
        md = pq.read_metadata(path)
    except Exception:
        return False
    if md.num_rows != rows:
        return False
    kv = md.metadata or {}
    if kv.get(b"exotune.spec_hash") != spec_hash.encode():
        return False
    if schema is not None:
        try:
            arrow = md.schema.to_arrow_schema()
        except Exception:
            return False
        if schema_list(arrow) != schema:
            return False
    return True


def read_tables(out_dir: str, columns=None, allow_partial: bool = False):
    """(manifest, the finished chunks concatenated as one Arrow table or None, missing chunk indices);
    ConfigError for an unreadable chunk, or for missing chunks unless ``allow_partial``."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    m = load_manifest(out_dir)
    tables, missing = [], []
    for c in m["chunks"]:
        path = os.path.join(out_dir, c["file"])
        if c.get("status") != "done" or not os.path.exists(path):
            missing.append(c["index"])
            continue
        try:
            tables.append(pq.read_table(path, columns=columns))
        except (OSError, pa.ArrowException) as e:
            raise ConfigError(path, f"unreadable chunk ({' '.join(str(e).split())}); rerun "
                                    "`exotune sweep` with the same spec to recompute it") from None
    if missing and not allow_partial:
        raise ConfigError(
            out_dir, f"the sweep is incomplete ({len(missing)} of {len(m['chunks'])} chunks missing); rerun `exotune sweep`"
        )
    if not tables:
        return m, None, missing
    return m, pa.concat_tables(tables), missing


def load_results(out_dir, columns: list[str] | None = None, allow_partial: bool = False, nested: str = "list"):
    """All chunk files of a sweep, in row order, as a :class:`pandas.DataFrame`.

    Parameters
    ----------
    out_dir : str or os.PathLike
        The sweep directory.
    columns : list of str, optional
        The columns to read (default all).
    allow_partial : bool
        Read the finished chunks of an incomplete sweep instead of raising.
    nested : {"list", "raw"}
        ``list<list<double>>`` columns become Python lists of ``[a, b]`` lists (``"list"``, the
        format of :func:`~exotune.analysis.analyze_batch`) or are left as pandas/pyarrow objects
        (``"raw"``).

    Returns
    -------
    pandas.DataFrame
        One row per design, ``point_index`` first.

    Raises
    ------
    ConfigError
        Not a sweep directory, an unreadable chunk, or an incomplete sweep (unless
        ``allow_partial``).

    References
    ----------
    docs/sweep.md (output directory, columns).
    """
    import pandas as pd
    import pyarrow as pa

    out_dir = os.fspath(out_dir)
    m, table, _ = read_tables(out_dir, columns, allow_partial)
    if table is None:
        names = columns if columns is not None else [c[0] for c in (m.get("columns") or [])]
        return pd.DataFrame({c: [] for c in names})
    data = {}
    for name, col in zip(table.column_names, table.columns):
        if nested == "list" and pa.types.is_list(col.type):
            data[name] = pd.Series(col.to_pylist(), dtype=object)
        else:
            data[name] = col.to_numpy()
    return pd.DataFrame(data)
