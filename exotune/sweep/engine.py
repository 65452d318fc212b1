"""Chunked, resumable, parallel parameter sweeps (SPEC §6).

Spec file
---------
::

    base: paper.yaml                      # a design file (path relative to this spec) or an inline mapping
    axes:
      design.amplification: {start: 2.0, stop: 20.0, num: 10, scale: log}
      design.zeta_hat: [0.5, 0.7, 0.9]
      implementation.delay_s: {start: 0.0, stop: 0.004, num: 5}     # scale defaults to lin
    chunk_size: 10000                     # optional (default 10000; ``--chunk-size`` overrides)
    verify_points: 16                     # optional: verify every family's intervals with exact
                                          # counts at N values (mismatch → not robust; default 0)

The spec is read with exotune's safe YAML loader (YAML 1.2 floats, duplicate keys rejected) and validated strictly:
unknown keys, an empty ``axes`` mapping, an axis that is neither a list of numbers nor a
``{start, stop, num[, scale]}`` mapping, ``num`` < 1 or not an integer, ``scale`` other than
``lin``/``log``, ``scale: log`` with a non-positive bound, duplicate values in a list, a parameter
path that cannot be swept, and values that the design-file rules reject (α < 1, a cutoff above
Nyquist, …) all raise :class:`~exotune.errors.ConfigError` naming the field as
``axes.<dotted path>[.<key>]`` (the CLI exits with code 2 and writes nothing). The sweepable
paths are :data:`exotune.config.OVERRIDABLE` (plant, design and implementation numbers); human and
environment families are the uncertainty sets every point is checked against. ``num: 1`` gives
the single value ``start``.

Grid and sampling
-----------------
The grid is the Cartesian product of the axes in the order they are listed, flattened in C order
(the last axis varies fastest): grid point ``g`` has axis indices ``numpy.unravel_index(g, shape)``.
Row ``i`` of the dataset is grid point ``g = i`` for a full sweep. With ``--sample N --seed S`` the
dataset is a *uniform random sample without replacement* of N grid points: row ``i`` is grid point
``g = π_S(i)`` where π_S is a seeded pseudo-random permutation of ``[0, grid size)`` (a 6-round
Feistel network on the next even power of two, restricted to the grid by cycle walking). Every row
is therefore defined by index arithmetic alone: any chunk is generated independently, in memory
proportional to the chunk, for grids of any size. ``--seed`` defaults to 0 with ``--sample``
(so that rerunning the same command resumes); ``--seed`` without ``--sample`` is an error. The
``point_index`` column holds ``g``.

Output directory
----------------
``DIR/manifest.json``
    the normalized spec (``base`` = the validated base design mapping, ``axes`` = explicit value
    lists), its SHA-256 ``spec_hash`` (canonical JSON of the normalized spec including the base
    design's content, the chunk size and ``sample``/``seed``), exotune's version, the numbers of
    points and chunks, the Parquet column schema, one entry per chunk (status ``done`` /
    ``pending`` / ``failed`` with the error text, rows, seconds), per-run timings (wall time,
    designs/s, backend) and created/updated timestamps (UTC, ISO 8601). Written atomically.
``DIR/chunks/part-XXXXXX.parquet``
    chunk ``XXXXXX`` (rows ``[XXXXXX·chunk_size, …)``), written atomically (temporary file in the
    same directory, fsync, :func:`os.replace`). Columns: ``point_index`` (int64), one float64
    column per axis named by its dotted path, then every column returned by
    :func:`exotune.analysis.analyze_batch` — bool, int64, float64 (±inf allowed: an infinite
    delay margin or bandwidth; NaN: undefined, e.g. DOB margins without a DOB) and
    ``list<list<double>>`` for interval-valued metrics (``[[lo, hi], …]``) and critical values
    (``[[value, freq_hz], …]``). The Arrow types are fixed by the Python types of the columns, so
    every chunk has the same schema (checked against the manifest).

Resuming: rerunning the same command in an existing DIR skips every chunk whose file exists, is
readable, carries the spec hash and has the expected number of rows, and computes the rest; chunking
is deterministic, so the final dataset is identical to an uninterrupted run. A DIR holding a sweep
of a different spec (or made by another exotune version) is refused with a ConfigError. A lock file
(``DIR/.lock``) prevents two runs in the same DIR at once.

Execution
---------
* ``workers=1`` (or a single chunk to compute): in-process.
* default: ``workers`` (default :func:`os.cpu_count`) local processes
  (:class:`concurrent.futures.ProcessPoolExecutor`, ``spawn`` context). Each task is one chunk
  index plus the normalized spec; the worker rebuilds the batch itself, analyses it and writes the
  chunk file, returning only a small status record. At most ``2·workers`` chunks are in flight.
* ``dask_address``: the chunks run on a Dask cluster through :class:`distributed.Client`
  (``client.submit`` + ``as_completed``, at most ``2·(number of worker threads)`` in flight).
  ``"tcp://host:8786"`` connects to an existing scheduler (its workers must have the same
  exotune installed; they need no access to DIR: each returns its chunk as Parquet bytes and the
  client writes the file). ``"local"`` / ``"local:N"`` starts an in-process ``LocalCluster`` with
  N (default ``workers`` or the CPU count) single-threaded worker processes for convenience;
  any other scheduler address (e.g. ``inproc://…`` of a ``LocalCluster(processes=False)``) is
  passed to ``Client`` as is.

A chunk that raises is never dropped: its error is printed, recorded in the manifest, the other
chunks still run, and :class:`SweepError` is raised at the end (the CLI exits with code 1).
Rerunning the command retries the failed chunks. Memory stays bounded: the parent holds at most
the in-flight chunks' results (local processes: none).
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import math
import os
import sys
import time
import traceback
from typing import Any

import click
import numpy as np

from ..version import __version__
from ..analysis.core import analyze_batch
from ..config.design import batch_config, check_analysis_filters, design_from_mapping, hash_mapping, read_yaml
from ..errors import ConfigError
from ..jsonio import to_jsonable, write_atomic

__all__ = [
    "run_sweep",
    "load_results",
    "load_manifest",
    "load_spec",
    "SweepPlan",
    "SweepError",
    "chunk_points",
    "DEFAULT_CHUNK_SIZE",
]

DEFAULT_CHUNK_SIZE = 10000
MANIFEST = "manifest.json"
CHUNK_DIR = "chunks"
FORMAT = "exotune-sweep"
FORMAT_VERSION = 1
_SPEC_KEYS = ("base", "axes", "chunk_size", "verify_points")
_AXIS_KEYS = ("start", "stop", "num", "scale")
_MAX_POINTS = 2**62
MAX_VERIFY_POINTS = 1000  # spec key verify_points (the single-design report uses 64)
MAX_AXIS_VALUES = 100_000  # per axis: the values are listed in the manifest (a 10⁵ × 10⁵ grid is fine)
_FEISTEL_ROUNDS = 6
_MANIFEST_MIN_INTERVAL_S = 2.0


class SweepError(click.ClickException):
    """Some chunks of a sweep failed (their errors are in the manifest). Exit code 1.

    A :class:`click.ClickException` so that ``exotune sweep`` prints one line
    ``exotune: error: …`` and exits non-zero without a traceback."""

    exit_code = 1

    def __init__(self, message: str, failed: list[int] | None = None, manifest: dict | None = None):
        super().__init__(message)
        self.failed = list(failed or [])
        self.manifest = manifest

    def show(self, file=None) -> None:  # pragma: no cover - exercised through the CLI
        click.echo(f"exotune: error: {self.format_message()}", err=True)


# ---------------------------------------------------------------------------------------------
# Spec parsing and validation
# ---------------------------------------------------------------------------------------------
def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))


def _number(field: str, v: Any) -> float:
    if not _is_number(v):
        kind = "null" if v is None else f"the string {v!r}" if isinstance(v, str) else type(v).__name__
        raise ConfigError(field, f"expected a number, got {kind}")
    try:
        x = float(v)
    except OverflowError:
        raise ConfigError(field, f"the integer {str(v)[:12]}… ({len(str(v))} digits) is too large for a float") from None
    if not math.isfinite(x):
        raise ConfigError(field, f"must be a finite number, got {x!r}")
    return x


def _axis_values(path: str, spec: Any) -> tuple[list[float], str]:
    field = f"axes.{path}"
    if isinstance(spec, list):
        if not spec:
            raise ConfigError(field, "an axis list needs at least one value")
        if len(spec) > MAX_AXIS_VALUES:
            raise ConfigError(field, f"{len(spec)} values; an axis has at most {MAX_AXIS_VALUES}")
        vals = [_number(f"{field}[{i}]", v) for i, v in enumerate(spec)]
        seen = {}
        for i, v in enumerate(vals):
            if v in seen:
                raise ConfigError(f"{field}[{i}]", f"duplicate value {v:g} (also at index {seen[v]})")
            seen[v] = i
        return vals, "list"
    if isinstance(spec, dict):
        unknown = [k for k in spec if k not in _AXIS_KEYS]
        if unknown:
            raise ConfigError(f"{field}.{unknown[0]}", f"unknown key (allowed: {', '.join(_AXIS_KEYS)})")
        for k in ("start", "stop", "num"):
            if k not in spec:
                raise ConfigError(f"{field}.{k}", "required key is missing ({start, stop, num[, scale]})")
        start = _number(f"{field}.start", spec["start"])
        stop = _number(f"{field}.stop", spec["stop"])
        num = spec["num"]
        if isinstance(num, (bool, np.bool_)) or not isinstance(num, (int, np.integer)):
            if isinstance(num, float) and num.is_integer():
                num = int(num)
            else:
                raise ConfigError(f"{field}.num", f"expected an integer >= 1, got {num!r}")
        num = int(num)
        if num < 1:
            raise ConfigError(f"{field}.num", f"must be >= 1, got {num}")
        if num > MAX_AXIS_VALUES:
            raise ConfigError(f"{field}.num", f"{num} values; an axis has at most {MAX_AXIS_VALUES} "
                                             "(a grid of several axes can still have up to 2^62 points)")
        scale = spec.get("scale", "lin")
        if scale not in ("lin", "log"):
            raise ConfigError(f"{field}.scale", f"must be 'lin' or 'log', got {scale!r}")
        if num > 1 and start == stop:
            raise ConfigError(field, f"start = stop = {start:g} with num = {num} gives duplicate values")
        if scale == "log":
            for k, v in (("start", start), ("stop", stop)):
                if not v > 0:
                    raise ConfigError(f"{field}.{k}", f"must be > 0 for scale: log, got {v:g}")
            vals = np.geomspace(start, stop, num) if num > 1 else np.array([start])
        else:
            vals = np.linspace(start, stop, num) if num > 1 else np.array([start])
        out = [float(v) for v in vals]
        if len(set(out)) < len(out):  # start and stop a few ulps apart
            raise ConfigError(field, f"{num} values from {start!r} to {stop!r} are not distinct in floating point")
        return out, scale
    kind = "null" if spec is None else type(spec).__name__
    raise ConfigError(field, f"expected a list of values or a mapping {{start, stop, num, scale}}, got {kind}")


def _int_option(field: str, v: Any, minimum: int) -> int:
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)):
        raise ConfigError(field, f"expected an integer >= {minimum}, got {v!r}")
    if int(v) < minimum:
        raise ConfigError(field, f"must be >= {minimum}, got {int(v)}")
    return int(v)


def load_base(base, root: str):
    """The ``base`` of a sweep or optimization spec: a design file path (relative to ``root``) or
    an inline design mapping → (validated DesignConfig, source path or None). Errors name
    ``base``."""
    if isinstance(base, str):
        base_path = base if os.path.isabs(base) else os.path.join(root, base)
        try:
            base_map = read_yaml(base_path)
        except ConfigError as e:
            raise ConfigError(f"base ({e.field})", e.reason) from None
        try:
            return design_from_mapping(base_map, source=base_path), base_path
        except ConfigError as e:
            raise ConfigError(f"base ({base}): {e.field}", e.reason) from None
    if isinstance(base, dict):
        try:
            return design_from_mapping(base, source="<inline base>"), None
        except ConfigError as e:
            raise ConfigError(f"base.{e.field}", e.reason) from None
    raise ConfigError("base", f"expected a design file path or a mapping, got {'null' if base is None else type(base).__name__}")


def load_spec(spec, sample: int | None = None, seed: int | None = None, chunk_size: int | None = None) -> "SweepPlan":
    """Read and validate a sweep spec (a file path or a mapping) into a :class:`SweepPlan`.

    ``sample``/``seed``/``chunk_size`` are the command-line options (``chunk_size`` overrides the
    spec's). A ``base`` path in a mapping is relative to the current directory. Raises
    :class:`ConfigError` for every problem.
    """
    if isinstance(spec, (str, os.PathLike)):
        spec_path = os.fspath(spec)
        mapping = read_yaml(spec_path)
        root = os.path.dirname(os.path.abspath(spec_path))
        source = spec_path
    elif isinstance(spec, dict):
        mapping, root, source = spec, os.getcwd(), None
    else:
        raise ConfigError("<spec>", f"expected a spec file path or a mapping, got {type(spec).__name__}")
    unknown = [k for k in mapping if k not in _SPEC_KEYS]
    if unknown:
        raise ConfigError(str(unknown[0]), f"unknown key in a sweep spec (allowed: {', '.join(_SPEC_KEYS)})")
    if "base" not in mapping:
        raise ConfigError("base", "required key is missing (a design file path or an inline design mapping)")
    cfg, base_source = load_base(mapping["base"], root)
    check_analysis_filters(cfg.implementation, "base.")

    if "axes" not in mapping:
        raise ConfigError("axes", "required key is missing (a mapping of dotted parameter paths to values)")
    axes_in = mapping["axes"]
    if not isinstance(axes_in, dict):
        raise ConfigError("axes", f"expected a mapping of dotted parameter paths to values, got {type(axes_in).__name__}")
    if not axes_in:
        raise ConfigError("axes", "at least one axis is required")
    axes: dict[str, dict] = {}
    for path, aspec in axes_in.items():
        if not isinstance(path, str):
            raise ConfigError(f"axes.{path}", "an axis name must be a dotted parameter path (a string)")
        vals, scale = _axis_values(path, aspec)
        try:  # unknown / non-sweepable paths and rule violations (α < 1, Nyquist, …)
            batch_config(cfg, {path: np.asarray(vals)})
        except ConfigError as e:
            raise ConfigError(f"axes.{path}", e.reason) from None
        axes[path] = {"values": vals, "scale": scale}

    if chunk_size is None:
        chunk_size = mapping.get("chunk_size", DEFAULT_CHUNK_SIZE)
        chunk_size = _int_option("chunk_size", chunk_size, 1)
    else:
        chunk_size = _int_option("chunk_size", chunk_size, 1)

    shape = tuple(len(a["values"]) for a in axes.values())
    total = 1
    for n in shape:
        total *= n
        if total > _MAX_POINTS:
            raise ConfigError("axes", f"the grid has more than 2^62 points ({' × '.join(map(str, shape))})")
    if sample is not None:
        sample = _int_option("sample", sample, 1)
        if sample > total:
            raise ConfigError("sample", f"{sample} exceeds the number of grid points ({total})")
        seed = 0 if seed is None else _int_option("seed", seed, 0)
    elif seed is not None:
        raise ConfigError("seed", "only meaningful together with --sample")

    verify = _int_option("verify_points", mapping.get("verify_points", 0), 0)
    if verify > MAX_VERIFY_POINTS:
        raise ConfigError("verify_points", f"{verify} exact counts per family and design; at most {MAX_VERIFY_POINTS}")
    normalized = {
        "base": cfg.raw,
        "axes": axes,
        "chunk_size": chunk_size,
        "sample": sample,
        "seed": seed,
    }
    if verify:  # only present when used, so existing spec hashes are unchanged
        normalized["verify_points"] = verify
    return SweepPlan(normalized, cfg=cfg, source=source, base_source=base_source)


# ---------------------------------------------------------------------------------------------
# The plan: index arithmetic from row position to design point
# ---------------------------------------------------------------------------------------------
class SweepPlan:
    """A validated sweep: normalized spec, its hash, grid shape and the row → point mapping."""

    def __init__(self, normalized: dict, cfg=None, source: str | None = None, base_source: str | None = None):
        self.spec = normalized
        self.hash = hash_mapping(normalized)
        self.cfg = cfg if cfg is not None else design_from_mapping(normalized["base"], source="<sweep base>")
        self.source = source
        self.base_source = base_source
        self.paths = list(normalized["axes"])
        self.values = [np.asarray(normalized["axes"][p]["values"], dtype=float) for p in self.paths]
        self.shape = tuple(v.size for v in self.values)
        self.grid_points = int(np.prod(self.shape, dtype=object))
        self.sample = normalized.get("sample")
        self.seed = normalized.get("seed")
        self.n_points = self.grid_points if self.sample is None else int(self.sample)
        self.chunk_size = int(normalized["chunk_size"])
        self.n_chunks = -(-self.n_points // self.chunk_size)
        self._keys = None
        if self.sample is not None:
            ss = np.random.SeedSequence([int(self.seed), 0x5EE9])
            self._keys = ss.generate_state(_FEISTEL_ROUNDS, dtype=np.uint64)

    def chunk_range(self, index: int) -> tuple[int, int]:
        if not 0 <= index < self.n_chunks:
            raise IndexError(f"chunk {index} out of range (0..{self.n_chunks - 1})")
        start = index * self.chunk_size
        return start, min(start + self.chunk_size, self.n_points)

    def grid_index(self, positions: np.ndarray) -> np.ndarray:
        """Grid point (C-order flat index) of each dataset row position."""
        pos = np.asarray(positions, dtype=np.int64)
        if self.sample is None:
            return pos.copy()
        return _permute(pos, self.grid_points, self._keys)

    def points(self, positions: np.ndarray) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        g = self.grid_index(positions)
        idx = np.unravel_index(g, self.shape)
        return g, {p: v[i] for p, v, i in zip(self.paths, self.values, idx)}


def _feistel(y: np.ndarray, half: int, keys) -> np.ndarray:
    mask = np.uint64((1 << half) - 1)
    h = np.uint64(half)
    L = y >> h
    R = y & mask
    m1 = np.uint64(0x9E3779B97F4A7C15)
    m2 = np.uint64(0xBF58476D1CE4E5B9)
    m3 = np.uint64(0x94D049BB133111EB)
    for k in keys:
        x = (R ^ np.uint64(k)) * m1
        x ^= x >> np.uint64(30)
        x *= m2
        x ^= x >> np.uint64(27)
        x *= m3
        x ^= x >> np.uint64(31)
        L, R = R, (L ^ x) & mask
    return (L << h) | R


def _permute(x: np.ndarray, M: int, keys) -> np.ndarray:
    """Seeded pseudo-random bijection of [0, M) applied to ``x`` (Feistel network + cycle walking)."""
    if M == 1:
        return np.zeros_like(x)
    bits = max(2, int(M - 1).bit_length())
    bits += bits % 2
    half = bits // 2
    y = x.astype(np.uint64)
    with np.errstate(over="ignore"):
        y = _feistel(y, half, keys)
        out = y >= np.uint64(M)
        while out.any():
            y[out] = _feistel(y[out], half, keys)
            out = y >= np.uint64(M)
    return y.astype(np.int64)


def chunk_points(plan: SweepPlan, index: int) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """(grid indices, {axis path: values}) of the rows of chunk ``index``."""
    start, stop = plan.chunk_range(index)
    return plan.points(np.arange(start, stop, dtype=np.int64))


# ---------------------------------------------------------------------------------------------
# Chunk computation (runs in workers)
# ---------------------------------------------------------------------------------------------
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


def _np_arrow(v: np.ndarray, kind: str):
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


def _arrow_column(name: str, v, n: int):
    if isinstance(v, np.ndarray):
        if v.shape != (n,):
            raise ValueError(f"column {name!r} has shape {v.shape}, expected ({n},)")
        k = v.dtype.kind
        if k in "biuf":
            return _np_arrow(v, {"u": "i"}.get(k, k))
        if k == "O":
            v = v.tolist()
        else:
            raise TypeError(f"column {name!r}: unsupported dtype {v.dtype}")
    if isinstance(v, (list, tuple)):
        if len(v) != n:
            raise ValueError(f"column {name!r} has {len(v)} entries, expected {n}")
        return _nested_float_lists(v)
    raise TypeError(f"column {name!r}: unsupported type {type(v).__name__}")


def _nested_float_lists(rows):
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
    lists = pa.ListArray.from_arrays(_np_arrow(inner, "i32"), _np_arrow(values, "f"))
    return pa.ListArray.from_arrays(_np_arrow(outer, "i32"), lists)


def _compute_table(plan: SweepPlan, index: int):
    import pyarrow as pa

    g, vals = chunk_points(plan, index)
    n = g.size
    cfg = batch_config(plan.cfg, vals)
    cols = analyze_batch(cfg, verify=int(plan.spec.get("verify_points", 0)))
    for k in [k for k in cols if k.endswith("_edges")]:
        del cols[k]  # per-edge details of box families (objects): single-design reports only
    for k in [k for k in cols if k.endswith("_verification_mismatches")]:
        cols[k] = np.array([len(m) for m in cols[k]], dtype=np.int64)  # count per design
    names, arrays = ["point_index"], [_np_arrow(g, "i")]
    for p in plan.paths:
        names.append(p)
        arrays.append(_np_arrow(vals[p], "f"))
    for k, v in cols.items():
        if k in names:
            raise ValueError(f"analysis column {k!r} clashes with an axis column")
        names.append(k)
        arrays.append(_arrow_column(k, v, n))
    meta = {b"exotune.spec_hash": plan.hash.encode(), b"exotune.chunk": str(index).encode(),
            b"exotune.version": __version__.encode()}
    schema = pa.schema([pa.field(nm, a.type) for nm, a in zip(names, arrays)], metadata=meta)
    return pa.Table.from_arrays(arrays, schema=schema)


def _table_bytes(table) -> bytes:
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


def _schema_list(schema) -> list[list[str]]:
    return [[f.name, _type_str(f.type)] for f in schema]


def _chunk_file(out_dir: str, index: int) -> str:
    return os.path.join(out_dir, CHUNK_DIR, f"part-{index:06d}.parquet")


def _chunk_task(spec: dict, spec_hash: str, index: int, out_dir: str | None) -> dict:
    """Compute chunk ``index``; write it to ``out_dir`` (or return the Parquet bytes when
    ``out_dir`` is None, for remote Dask workers). Never raises: errors come back as text."""
    t0 = time.perf_counter()
    try:
        plan = _plan_from_spec(spec, spec_hash)
        table = _compute_table(plan, index)
        data = _table_bytes(table)
        res = {"index": index, "rows": table.num_rows, "schema": _schema_list(table.schema), "error": None}
        if out_dir is None:
            res["data"] = data
        else:
            write_atomic(_chunk_file(out_dir, index), data)
    except Exception as e:  # reported by the parent, never dropped
        msg = " ".join(f"{type(e).__name__}: {e}".split())
        return {"index": index, "rows": 0, "schema": None, "error": msg,
                "traceback": traceback.format_exc(), "seconds": time.perf_counter() - t0}
    res["seconds"] = time.perf_counter() - t0
    return res


# ---------------------------------------------------------------------------------------------
# Manifest and directory state
# ---------------------------------------------------------------------------------------------
def _now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")


def load_manifest(out_dir) -> dict:
    """The manifest of a sweep directory (ConfigError when missing/unreadable)."""
    import json

    path = os.path.join(os.fspath(out_dir), MANIFEST)
    try:
        with open(path, encoding="utf-8") as fh:
            m = json.load(fh)
    except FileNotFoundError:
        raise ConfigError(os.fspath(out_dir), "not a sweep directory (no manifest.json)") from None
    except (OSError, ValueError) as e:
        raise ConfigError(path, f"cannot read the sweep manifest: {e}") from None
    if not isinstance(m, dict) or m.get("format") != FORMAT:
        raise ConfigError(path, "not an exotune sweep manifest")
    _check_manifest(m, path)
    return m


def _check_manifest(m: dict, path: str) -> None:
    """The fields that resuming and reporting rely on, with their types (a manifest edited or
    damaged by hand is refused with the field named, never a traceback later)."""
    is_int = lambda v: isinstance(v, int) and not isinstance(v, bool)  # noqa: E731
    need = {"spec": (lambda v: isinstance(v, dict), "a mapping"), "spec_hash": (lambda v: isinstance(v, str), "a string"),
            "chunks": (lambda v: isinstance(v, list), "a list"), "n_points": (is_int, "an integer"),
            "n_chunks": (is_int, "an integer"), "chunk_size": (is_int, "an integer")}
    for key, (ok_type, what) in need.items():
        v = m.get(key)
        if not ok_type(v):
            raise ConfigError(f"{path}: {key}", f"expected {what}, got {type(v).__name__} (damaged manifest; "
                                                f"use a new directory)")
    damaged = "(damaged manifest; use a new directory)"
    axes, spec_axes = m.get("axes"), m["spec"].get("axes")
    if not (isinstance(axes, list) and axes and all(isinstance(a, dict) and isinstance(a.get("path"), str) for a in axes)):
        raise ConfigError(f"{path}: axes", f"expected a non-empty list of {{path, …}} {damaged}")
    if not isinstance(spec_axes, dict) or [a["path"] for a in axes] != list(spec_axes):
        raise ConfigError(f"{path}: spec.axes", f"must hold the manifest's axes, in order {damaged}")
    for p, a in spec_axes.items():
        vals = a.get("values") if isinstance(a, dict) else None
        if not (isinstance(vals, list) and vals and all(_is_number(v) for v in vals)):
            raise ConfigError(f"{path}: spec.axes.{p}.values", f"expected a non-empty list of numbers {damaged}")
    for i, c in enumerate(m["chunks"]):
        if not (isinstance(c, dict) and is_int(c.get("index")) and isinstance(c.get("file"), str)
                and isinstance(c.get("status"), str)):
            raise ConfigError(f"{path}: chunks[{i}]", "expected a mapping with index, file and status "
                                                       "(damaged manifest; use a new directory)")
        if os.path.isabs(c["file"]) or ".." in c["file"].replace("\\", "/").split("/"):
            raise ConfigError(f"{path}: chunks[{i}].file", f"must be a path inside the sweep directory, got {c['file']!r}")


def _write_manifest(out_dir: str, manifest: dict) -> None:
    import json

    manifest["updated"] = _now()
    text = json.dumps(to_jsonable(manifest), indent=1, ensure_ascii=False, allow_nan=False)
    write_atomic(os.path.join(out_dir, MANIFEST), text + "\n")


def _chunk_ok(path: str, rows: int, spec_hash: str, schema: list | None) -> bool:
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
        if _schema_list(arrow) != schema:
            return False
    return True


@contextlib.contextmanager
def _dir_lock(out_dir: str):
    try:
        import fcntl
    except ImportError:  # pragma: no cover - non-POSIX
        yield
        return
    fh = open(os.path.join(out_dir, ".lock"), "a+")
    try:
        try:
            fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            raise ConfigError(out_dir, "another exotune sweep is running in this directory") from None
        yield
    finally:
        fh.close()


def _spec_diff(a: dict, b: dict) -> list[str]:
    keys = sorted(set(a) | set(b))
    return [k for k in keys if hash_mapping(a.get(k)) != hash_mapping(b.get(k))]


_ENGINE_PACKAGES = ("numerics", "model", "config", "analysis")


def engine_hash() -> str:
    """SHA-256 of the source of the packages that compute the results: a resumed sweep refuses to
    mix chunks computed by different analysis code (the version string alone is not enough)."""
    import hashlib
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    h = hashlib.sha256()
    for pkg in _ENGINE_PACKAGES:
        for f in sorted((root / pkg).rglob("*.py")):
            h.update(f.relative_to(root).as_posix().encode() + b"\0" + f.read_bytes())
    return h.hexdigest()


def _model_note(plan: SweepPlan) -> str:
    note = ("continuous-time analysis with the exact delay e^{-sT} (SPEC §5): every column is the "
            "exact continuous verdict or metric")
    fs = plan.cfg.implementation.sample_rate_hz
    if fs:
        note += (f"; the base design sets sample_rate_hz = {fs:g} Hz, used here only to validate the "
                 "cutoffs against Nyquist — run `exotune analyze` with it on a chosen design for the "
                 "sampled-data check (the zero-order hold costs about half a sample of extra delay)")
    return note


def _new_manifest(plan: SweepPlan) -> dict:
    axes = []
    for p, v in zip(plan.paths, plan.values):
        axes.append({"path": p, "num": int(v.size), "min": float(v.min()), "max": float(v.max()),
                     "scale": plan.spec["axes"][p]["scale"]})
    now = _now()
    return {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "exotune_version": __version__,
        "engine_hash": engine_hash(),
        "spec_hash": plan.hash,
        "spec": plan.spec,
        "spec_source": plan.source,
        "base_source": plan.base_source,
        "axes": axes,
        "grid_shape": list(plan.shape),
        "grid_points": plan.grid_points,
        "sampling": (
            {"method": "full grid, C order over the axes as listed (last axis fastest)"}
            if plan.sample is None
            else {"method": "uniform sample without replacement: row i = grid point π_seed(i), "
                            "π a seeded Feistel permutation of the grid index space",
                  "sample": plan.sample, "seed": plan.seed}
        ),
        "model": _model_note(plan),
        "n_points": plan.n_points,
        "chunk_size": plan.chunk_size,
        "n_chunks": plan.n_chunks,
        "columns": None,
        "column_notes": {
            "point_index": "C-order flat index of the grid point",
            "intervals": "list<list<double>> columns hold [[lo, hi], ...] (stable intervals, bands) or "
                         "[[value, freq_hz], ...] (critical values)",
            "non_finite": "inf: unbounded (no crossover / bandwidth never reached); NaN: undefined "
                          "(e.g. DOB margins without a DOB)",
            "gains": "torque units (SPEC §4): K1 [N·m/rad], B1 [N·m·s/rad], K2 [–], B2 [s], K2_hat [–], B2_hat [s]",
        },
        "status": "running",
        "chunks": [],
        "timings": {},
        "runs": [],
        "created": now,
        "updated": now,
    }


# ---------------------------------------------------------------------------------------------
# Execution backends
# ---------------------------------------------------------------------------------------------
@contextlib.contextmanager
def _single_threaded_blas_env():
    keys = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
    old = {k: os.environ.get(k) for k in keys}
    for k in keys:
        os.environ.setdefault(k, "1")
    try:
        yield
    finally:
        for k, v in old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def _run_inprocess(plan, out_dir, todo, on_result):
    for i in todo:
        on_result(_chunk_task(plan.spec, plan.hash, i, out_dir))


def _worker_init(parent_pid: int) -> None:
    """Sweep worker start-up: never outlive the sweep. Linux kills the worker with the parent
    (``PR_SET_PDEATHSIG``); elsewhere, and as a second line, a daemon thread exits once the
    parent is gone (re-parented). Without this a ``kill -9`` of ``exotune sweep`` left its idle
    workers blocked on their pipe for ever, each holding ~200 MB."""
    import threading

    if sys.platform.startswith("linux"):
        with contextlib.suppress(Exception):
            import ctypes
            import signal

            ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL), 0, 0, 0)  # PR_SET_PDEATHSIG
    if os.getppid() != parent_pid:  # the parent died before prctl took effect
        os._exit(1)

    def watch():
        while os.getppid() == parent_pid:
            time.sleep(0.5)
        os._exit(1)

    threading.Thread(target=watch, name="exotune-parent-watch", daemon=True).start()


@contextlib.contextmanager
def _sigterm_as_exit():
    """SIGTERM (``kill PID``) ends the sweep like Ctrl-C: the manifest records "interrupted" and
    the worker pool is shut down (only the main thread can install a handler)."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def on_term(signum, frame):
        print("exotune sweep: terminated (SIGTERM); rerun the same command to resume", file=sys.stderr)
        raise SystemExit(128 + signum)

    old = signal.signal(signal.SIGTERM, on_term)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)


def _run_processes(plan, out_dir, todo, on_result, workers):
    import concurrent.futures as cf
    import multiprocessing as mp
    from concurrent.futures.process import BrokenProcessPool

    window = 2 * workers
    it = iter(todo)
    with _single_threaded_blas_env():
        ex = cf.ProcessPoolExecutor(max_workers=workers, mp_context=mp.get_context("spawn"),
                                    initializer=_worker_init, initargs=(os.getpid(),))
        try:
            pending: dict = {}

            def submit_next():
                i = next(it, None)
                if i is not None:
                    pending[ex.submit(_chunk_task, plan.spec, plan.hash, i, out_dir)] = i

            for _ in range(window):
                submit_next()
            while pending:
                done, _ = cf.wait(list(pending), return_when=cf.FIRST_COMPLETED)
                for fut in done:
                    i = pending.pop(fut)
                    try:
                        res = fut.result()
                    except BrokenProcessPool as e:
                        res = {"index": i, "rows": 0, "schema": None, "seconds": 0.0,
                               "error": f"worker process died (BrokenProcessPool: {e})"}
                    except Exception as e:  # pragma: no cover - _chunk_task does not raise
                        res = {"index": i, "rows": 0, "schema": None, "seconds": 0.0,
                               "error": f"{type(e).__name__}: {e}"}
                    on_result(res)
                    submit_next()
        except BaseException:
            ex.shutdown(wait=False, cancel_futures=True)
            raise
        ex.shutdown(wait=True)


def _dask_client(address: str, workers: int | None):
    try:
        from distributed import Client, LocalCluster
    except ImportError as e:  # pragma: no cover - dask[distributed] is a dependency
        raise ConfigError("dask", f"dask.distributed is not installed ({e})") from None
    cluster = None
    if address == "local" or address.startswith("local:"):
        n = workers or os.cpu_count() or 1
        if address.startswith("local:"):
            try:
                n = int(address.split(":", 1)[1])
            except ValueError:
                raise ConfigError("dask", f"expected 'local' or 'local:N', got {address!r}") from None
            if n < 1:
                raise ConfigError("dask", f"local:N needs N >= 1, got {n}")
        with _single_threaded_blas_env():
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None)
        client = Client(cluster)
    else:
        try:
            client = Client(address, timeout="20s")
        except (OSError, TimeoutError, ValueError) as e:
            raise ConfigError("dask", f"cannot connect to the Dask scheduler at {address!r}: {e}") from None
    return client, cluster


def _run_dask(plan, out_dir, todo, on_result, address, workers):
    from distributed import as_completed

    client, cluster = _dask_client(address, workers)
    try:
        try:
            nthreads = sum(client.nthreads().values()) or 1
        except Exception:  # pragma: no cover
            nthreads = workers or 1
        window = 2 * nthreads
        it = iter(todo)
        ac = as_completed()
        index_of = {}

        def submit_next():
            i = next(it, None)
            if i is not None:
                fut = client.submit(_chunk_task, plan.spec, plan.hash, i, None, pure=False)
                index_of[fut.key] = i
                ac.add(fut)

        for _ in range(window):
            submit_next()
        for fut in ac:
            i = index_of.pop(fut.key)
            try:
                res = fut.result()
            except Exception as e:
                res = {"index": i, "rows": 0, "schema": None, "seconds": 0.0,
                       "error": " ".join(f"Dask task failed: {type(e).__name__}: {e}".split())}
            fut.release()
            del fut
            data = res.pop("data", None)
            if res.get("error") is None and data is not None:
                try:
                    write_atomic(_chunk_file(out_dir, i), data)
                except OSError as e:
                    res["error"] = f"cannot write the chunk file: {e}"
            del data
            on_result(res)
            submit_next()
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


# ---------------------------------------------------------------------------------------------
# run_sweep
# ---------------------------------------------------------------------------------------------
def run_sweep(
    spec_path,
    out_dir,
    workers: int | None = None,
    dask_address: str | None = None,
    sample: int | None = None,
    seed: int | None = None,
    chunk_size: int | None = None,
    progress: bool = True,
) -> dict:
    """Run (or resume) the sweep ``spec_path`` into ``out_dir`` (SPEC §6); returns the manifest.

    See the module docstring for the spec format, the directory layout and the backends. Raises
    :class:`ConfigError` for bad input (before anything is written) and :class:`SweepError` when
    chunks failed (after all other chunks ran; the manifest records the errors).
    """
    plan = load_spec(spec_path, sample=sample, seed=seed, chunk_size=chunk_size)
    if workers is not None:
        workers = _int_option("workers", workers, 1)
    if dask_address is not None and (not isinstance(dask_address, str) or not dask_address.strip()):
        raise ConfigError("dask", f"expected a scheduler address, got {dask_address!r}")
    out_dir = os.fspath(out_dir)
    if os.path.exists(out_dir) and not os.path.isdir(out_dir):
        raise ConfigError(out_dir, "exists and is not a directory")

    manifest = None
    if os.path.exists(os.path.join(out_dir, MANIFEST)):
        old = load_manifest(out_dir)
        _check_compatible(out_dir, old, plan)
    elif os.path.isdir(os.path.join(out_dir, CHUNK_DIR)) and any(
        n.startswith("part-") for n in os.listdir(os.path.join(out_dir, CHUNK_DIR))
    ):
        raise ConfigError(out_dir, "holds chunk files but no manifest.json; use a new directory")

    try:
        os.makedirs(os.path.join(out_dir, CHUNK_DIR), exist_ok=True)
    except OSError as e:
        raise ConfigError(out_dir, f"cannot create the output directory: {e.strerror or e}") from None

    with _dir_lock(out_dir):
        if os.path.exists(os.path.join(out_dir, MANIFEST)):
            manifest = load_manifest(out_dir)
            _check_compatible(out_dir, manifest, plan)
        else:
            manifest = _new_manifest(plan)
        return _execute(plan, out_dir, manifest, workers, dask_address, progress)


def _check_compatible(out_dir: str, old: dict, plan: SweepPlan) -> None:
    if old.get("spec_hash") != plan.hash:
        diff = _spec_diff(old.get("spec") or {}, plan.spec)
        what = f"; differs in: {', '.join(diff)}" if diff else ""
        raise ConfigError(
            out_dir,
            f"{out_dir} holds a sweep of a different spec (hash {str(old.get('spec_hash'))[:12]}…, this spec "
            f"{plan.hash[:12]}…{what}); use a new directory",
        )
    if old.get("engine_hash") not in (None, engine_hash()):
        raise ConfigError(
            out_dir,
            f"{out_dir} holds a sweep made by different analysis code (engine hash "
            f"{str(old.get('engine_hash'))[:12]}…, this is {engine_hash()[:12]}…); results must not be mixed: "
            "use a new directory",
        )
    if old.get("exotune_version") != __version__:
        raise ConfigError(
            out_dir,
            f"{out_dir} holds a sweep made by exotune {old.get('exotune_version')} (this is {__version__}); "
            "results of different versions must not be mixed: use a new directory",
        )


def _execute(plan: SweepPlan, out_dir: str, manifest: dict, workers, dask_address, progress) -> dict:
    from tqdm import tqdm

    chunk_dir = os.path.join(out_dir, CHUNK_DIR)
    for name in os.listdir(chunk_dir):  # leftovers of killed writers (we hold the lock)
        if name.startswith(".tmp-"):
            with contextlib.suppress(OSError):
                os.unlink(os.path.join(chunk_dir, name))

    old_entries = {c["index"]: c for c in manifest.get("chunks", []) if isinstance(c, dict) and "index" in c}
    schema = manifest.get("columns")
    entries, todo = [], []
    for i in range(plan.n_chunks):
        a, b = plan.chunk_range(i)
        rel = f"{CHUNK_DIR}/part-{i:06d}.parquet"
        e = {"index": i, "file": rel, "rows": b - a, "status": "pending", "seconds": None, "error": None}
        if _chunk_ok(os.path.join(out_dir, rel), b - a, plan.hash, schema):
            prev = old_entries.get(i, {})
            e["status"] = "done"
            e["seconds"] = prev.get("seconds")
        else:
            todo.append(i)
        entries.append(e)
    manifest["chunks"] = entries
    manifest["status"] = "running"
    if schema is None:  # killed before the manifest recorded the schema: take it from a finished chunk
        import pyarrow.parquet as pq

        for e in entries:
            if e["status"] == "done":
                manifest["columns"] = _schema_list(pq.read_schema(os.path.join(out_dir, e["file"])))
                break
    n_skip = plan.n_chunks - len(todo)

    if dask_address is not None:
        backend = "dask"
    elif workers == 1 or len(todo) <= 1:
        backend = "in-process"
    else:
        backend = "local-processes"
    n_workers = workers or os.cpu_count() or 1
    if backend == "local-processes":
        n_workers = min(n_workers, len(todo))
    run = {"started": _now(), "finished": None, "backend": backend,
           "workers": (1 if backend == "in-process" else n_workers if backend == "local-processes" else None),
           "dask_address": dask_address, "chunks_skipped": n_skip, "chunks_computed": 0,
           "chunks_failed": 0, "points_computed": 0, "wall_s": None, "designs_per_s": None}
    manifest.setdefault("runs", []).append(run)
    _write_manifest(out_dir, manifest)

    done_points = sum(e["rows"] for e in entries if e["status"] == "done")
    if progress:
        where = f"Dask at {dask_address}" if backend == "dask" else (
            "in-process" if backend == "in-process" else f"{n_workers} local processes")
        resumed = f"; resuming: {n_skip} of {plan.n_chunks} chunks already done" if n_skip else ""
        print(f"exotune sweep: {plan.n_points} designs in {plan.n_chunks} chunks of {plan.chunk_size} "
              f"({where}){resumed}", file=sys.stderr)
    bar = tqdm(total=plan.n_points, initial=done_points, unit="design", file=sys.stderr,
               disable=not progress, dynamic_ncols=True, smoothing=0.05, desc="sweep")
    t0 = time.perf_counter()
    failures: list[tuple[int, str]] = []
    last_write = [time.monotonic()]

    def on_result(res: dict) -> None:
        i = res["index"]
        e = entries[i]
        e["seconds"] = res.get("seconds")
        err = res.get("error")
        if err is None:
            if res["rows"] != e["rows"]:
                err = f"chunk has {res['rows']} rows, expected {e['rows']}"
            elif manifest.get("columns") is None:
                manifest["columns"] = res["schema"]
            elif res["schema"] != manifest["columns"]:
                err = "chunk schema differs from the sweep's schema"
            if err is not None:
                with contextlib.suppress(OSError):
                    os.unlink(os.path.join(out_dir, e["file"]))
        if err is None:
            e["status"], e["error"] = "done", None
            run["chunks_computed"] += 1
            run["points_computed"] += e["rows"]
        else:
            e["status"], e["error"] = "failed", err
            if res.get("traceback"):
                e["traceback"] = res["traceback"]
            run["chunks_failed"] += 1
            failures.append((i, err))
            tqdm.write(f"exotune: chunk {i} failed: {err}", file=sys.stderr)
        bar.update(e["rows"])
        now = time.monotonic()
        if now - last_write[0] >= _MANIFEST_MIN_INTERVAL_S:
            _finish_timings(manifest, run, t0, final=False)
            _write_manifest(out_dir, manifest)
            last_write[0] = now

    try:
        with _sigterm_as_exit():
            _dispatch(plan, out_dir, todo, on_result, backend, dask_address, workers, n_workers)
    except BaseException:
        bar.close()
        manifest["status"] = "interrupted"
        _finish_timings(manifest, run, t0, final=True)
        with contextlib.suppress(Exception):
            _write_manifest(out_dir, manifest)
        raise
    bar.close()
    manifest["status"] = "failed" if failures else "complete"
    _finish_timings(manifest, run, t0, final=True)
    _write_manifest(out_dir, manifest)
    if progress and not failures:
        rate = run["designs_per_s"]
        print(f"exotune sweep: complete — {run['points_computed']} designs computed in {run['wall_s']:.1f} s"
              + (f" ({rate:.0f} designs/s)" if rate else "") + f"; results in {out_dir}", file=sys.stderr)
    if failures:
        first_i, first_err = failures[0]
        idx = ", ".join(str(i) for i, _ in failures[:10]) + (" …" if len(failures) > 10 else "")
        raise SweepError(
            f"{len(failures)} of {plan.n_chunks} chunks failed (chunks {idx}; first error, chunk {first_i}: "
            f"{first_err}); errors are recorded in {os.path.join(out_dir, MANIFEST)}; rerun the same command "
            "to retry them",
            failed=[i for i, _ in failures],
            manifest=manifest,
        )
    return manifest


def _dispatch(plan, out_dir, todo, on_result, backend, dask_address, workers, n_workers) -> None:
    if not todo:
        return
    if backend == "dask":
        _run_dask(plan, out_dir, todo, on_result, dask_address, workers)
    elif backend == "in-process":
        _run_inprocess(plan, out_dir, todo, on_result)
    else:
        _run_processes(plan, out_dir, todo, on_result, n_workers)


def _finish_timings(manifest: dict, run: dict, t0: float, final: bool) -> None:
    wall = time.perf_counter() - t0
    run["wall_s"] = wall
    run["designs_per_s"] = run["points_computed"] / wall if wall > 0 else None
    if final:
        run["finished"] = _now()
    secs = [c["seconds"] for c in manifest["chunks"] if c.get("status") == "done" and c.get("seconds") is not None]
    manifest["timings"] = {
        "wall_s_total": sum((r.get("wall_s") or 0.0) for r in manifest["runs"]),
        "wall_s_last_run": wall,
        "designs_per_s_last_run": run["designs_per_s"],
        "chunk_compute_s_total": float(sum(secs)),
        "chunk_s_mean": float(np.mean(secs)) if secs else None,
        "chunk_s_max": float(np.max(secs)) if secs else None,
        "points_done": sum(c["rows"] for c in manifest["chunks"] if c.get("status") == "done"),
        "note": "per-chunk seconds are in chunks[].seconds (compute + write, in the worker)",
    }


# ---------------------------------------------------------------------------------------------
# Reading results
# ---------------------------------------------------------------------------------------------
def read_tables(out_dir: str, columns=None, allow_partial: bool = False):
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

    ``columns`` selects columns (default all). ``list<list<double>>`` columns become Python lists
    of ``[a, b]`` lists (``nested="list"``, the format of :func:`~exotune.analysis.analyze_batch`)
    or are left as pandas/pyarrow objects (``nested="raw"``). Raises ConfigError for an incomplete
    sweep unless ``allow_partial``.
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
