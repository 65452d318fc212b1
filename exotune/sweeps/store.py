"""Parquet storage of a sweep: numpy columns → Arrow arrays, chunk files, reading the dataset back.

Chunk ``i`` is ``DIR/chunks/part-{i:06d}.parquet``; its schema carries the spec hash, the chunk
index and exotune's version as metadata, and the failed designs when there are any (see the
:mod:`exotune.sweeps` package docstring). Reading a sweep back: :mod:`exotune.sweeps.dataset`.
"""

from __future__ import annotations

import os

import numpy as np

__all__ = ["CHUNK_DIR", "FAILED_ROWS_KEY", "np_arrow", "arrow_column", "nested_float_lists", "table_bytes",
           "schema_list", "chunk_file", "failed_rows_of"]

CHUNK_DIR = "chunks"
FAILED_ROWS_KEY = b"exotune.failed_rows"


def np_arrow(v: np.ndarray, kind: str):
    """A flat numpy column as an Arrow array, built on its buffer (zero-copy for float64/int64).

    ``pa.array`` would give the same array, but on its first call it imports pandas to test for
    pandas objects: ~1 s of every worker's start-up, for nothing (a sweep chunk holds numpy
    arrays only). NaN stays a NaN value, as with ``pa.array(..., from_pandas=False)``.

    Parameters
    ----------
    v : numpy.ndarray
        A flat column.
    kind : str
        ``"b"`` (bool), ``"i"`` (int64), ``"i32"`` (int32) or ``"f"`` (float64).

    Returns
    -------
    pyarrow.Array
        The column.
    """
    import pyarrow as pa

    if kind == "b":
        v = np.ascontiguousarray(v, dtype=bool)
        return pa.Array.from_buffers(pa.bool_(), v.size, [None, pa.py_buffer(np.packbits(v, bitorder="little"))])
    dt, at = {"i": (np.int64, pa.int64()), "i32": (np.int32, pa.int32()), "f": (np.float64, pa.float64())}[kind]
    v = np.ascontiguousarray(v, dtype=dt)
    return pa.Array.from_buffers(at, v.size, [None, pa.py_buffer(v)])


def arrow_column(name: str, v, n: int):
    """Column ``name`` of ``n`` rows as an Arrow array: a flat numpy array (bool, int, float) or a
    sequence of lists of [a, b] items (``list<list<double>>``).

    Parameters
    ----------
    name : str
        Column name, for the errors.
    v : numpy.ndarray or sequence
        The column's values.
    n : int
        Expected number of rows.

    Returns
    -------
    pyarrow.Array
        The column.

    Raises
    ------
    ValueError
        When the column does not have ``n`` rows.
    TypeError
        When its type or dtype is not supported.
    """
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
    Python-level conversion of every number).

    Parameters
    ----------
    rows : sequence of sequence of sequence of float
        Per row, its items (each a list of floats).

    Returns
    -------
    pyarrow.ListArray
        The ``list<list<double>>`` array.
    """
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
    """A table as Parquet file bytes (zstd).

    Parameters
    ----------
    table : pyarrow.Table
        The table.

    Returns
    -------
    bytes
        The Parquet file's content.
    """
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
    """An Arrow schema as [[name, type], …] (the manifest's ``columns``).

    Parameters
    ----------
    schema : pyarrow.Schema
        The chunk's schema.

    Returns
    -------
    list of list of str
        Column names and type texts.
    """
    return [[f.name, _type_str(f.type)] for f in schema]


def chunk_file(out_dir: str, index: int) -> str:
    """The path of chunk ``index``'s Parquet file in the sweep directory ``out_dir``.

    Parameters
    ----------
    out_dir : str
        The sweep directory.
    index : int
        Chunk index (from 0).

    Returns
    -------
    str
        The file's path.
    """
    return os.path.join(out_dir, CHUNK_DIR, f"part-{index:06d}.parquet")


def failed_rows_of(schema) -> list[dict]:
    """The failed designs recorded in a chunk's schema metadata (``exotune.failed_rows``):
    ``[{row, point_index, reason}]``, empty for a chunk without failures.

    Parameters
    ----------
    schema : pyarrow.Schema
        The chunk's schema.

    Returns
    -------
    list of dict
        The failures (an unreadable record gives one entry saying so).
    """
    import json

    raw = (schema.metadata or {}).get(FAILED_ROWS_KEY)
    if not raw:
        return []
    try:
        rows = json.loads(raw.decode())
    except ValueError:
        return [{"row": None, "point_index": None, "reason": "unreadable failed_rows metadata"}]
    return rows if isinstance(rows, list) else []
