"""Integrity of a sweep directory: every chunk file against its manifest entry, and the manifest
reconciled with the chunks on disk.

Each finished chunk's entry records the SHA-256 of its file (``sha256``), its row count
(``rows``) and the spec hash it was computed for (``spec_hash``). :func:`scan_chunks` checks every
chunk file of a sweep against them and against the spec:

* a link (the ``chunks`` directory or a chunk file being a symbolic link) is always refused: no
  read, write or delete goes through it;
* a recorded chunk whose file differs (checksum), is truncated, holds another sweep's rows
  (spec hash in its metadata), another chunk's rows (chunk index, design indices) or the wrong
  number of rows is an error naming the chunk when reading (``report``, :func:`load_results`) and
  is recomputed when resuming (the file is replaced by the right one);
* a chunk file that is valid but not recorded (a run killed, or out of disk space, between
  writing the chunk and writing the manifest) is verified against the spec — row count, spec
  hash, chunk index and the design indices of every row — and recorded as done;
* an entry marked done without the checksum of its file (:func:`records_checksums`: exotune
  records it for every chunk it finishes since 0.7) is an edited manifest: an error naming
  ``chunks[i].sha256`` when reading, recomputed when resuming — the row-by-row check would accept
  a chunk whose results were edited.

References
----------
docs/sweep-spec.md (integrity fields, resuming, reconciliation).
"""

from __future__ import annotations

import hashlib
import os
import re

import numpy as np

from ..errors import ConfigError
from .manifest import MANIFEST, chunk_rel, refuse_link
from .plan import SweepPlan
from .store import CHUNK_DIR, failed_rows_of, schema_list

__all__ = ["sha256_file", "chunk_problem", "records_checksums", "scan_chunks", "count_failed_designs", "CHECKSUMS_SINCE"]

_BLOCK = 1 << 20


def sha256_file(path: str) -> str:
    """SHA-256 (hex) of a file's bytes.

    Parameters
    ----------
    path : str
        The file.

    Returns
    -------
    str
        The 64 hex digits.
    """
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(_BLOCK), b""):
            h.update(block)
    return h.hexdigest()


def chunk_problem(out_dir: str, plan: SweepPlan, m: dict, index: int, sha256: str | None) -> tuple[str | None, dict]:
    """What is wrong with the file of chunk ``index`` (None when it is this sweep's chunk) and, for
    a good file, ``{"sha256", "failed_rows"}``.

    Parameters
    ----------
    out_dir : str
        The sweep directory.
    plan : SweepPlan
        The sweep (expected rows and design indices of the chunk).
    m : dict
        The manifest (spec hash, column schema when known).
    index : int
        The chunk.
    sha256 : str or None
        The checksum recorded for the chunk; None: the file is checked row by row against the spec.

    Returns
    -------
    (str or None, dict)
        The problem, or None and the file's checksum and failed designs.

    Raises
    ------
    ConfigError
        The file is a symbolic link.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    path = os.path.join(out_dir, chunk_rel(index))
    refuse_link(path)
    if not os.path.isfile(path):
        return "not a regular file", {}
    digest = sha256_file(path)
    if sha256 is not None and digest != sha256:
        return (f"its SHA-256 {digest[:12]}… differs from the one recorded in the manifest ({str(sha256)[:12]}…): "
                "the file was changed or replaced"), {}
    a, b = plan.chunk_range(index)
    try:
        md = pq.read_metadata(path)
        arrow = md.schema.to_arrow_schema()
    except Exception as e:
        return f"unreadable chunk ({' '.join(str(e).split())[:200]})", {}
    kv = md.metadata or {}
    if kv.get(b"exotune.spec_hash") != m["spec_hash"].encode():
        got = (kv.get(b"exotune.spec_hash") or b"none").decode(errors="replace")[:12]
        return f"holds rows of another sweep (spec hash {got}…, this sweep {m['spec_hash'][:12]}…)", {}
    if kv.get(b"exotune.chunk") != str(index).encode():
        return f"holds the rows of chunk {(kv.get(b'exotune.chunk') or b'?').decode(errors='replace')[:12]}, not {index}", {}
    if md.num_rows != b - a:
        return f"has {md.num_rows} rows, chunk {index} has {b - a}", {}
    if m.get("columns") is not None and schema_list(arrow) != m["columns"]:
        return "its columns differ from the sweep's schema", {}
    if sha256 is None:  # not recorded: every row must be the design the spec puts there
        try:
            g = pq.read_table(path, columns=["point_index"]).column("point_index").to_numpy()
        except (OSError, pa.ArrowException, KeyError) as e:
            return f"unreadable chunk ({' '.join(str(e).split())[:200]})", {}
        if not np.array_equal(g, plan.grid_index(np.arange(a, b, dtype=np.int64))):
            return "its design indices (point_index) are not those of this chunk", {}
    return None, {"sha256": digest, "failed_rows": failed_rows_of(arrow), "schema": schema_list(arrow)}


def _entry(plan: SweepPlan, index: int) -> dict:
    a, b = plan.chunk_range(index)
    return {"index": index, "file": chunk_rel(index), "rows": b - a, "status": "pending", "seconds": None,
            "error": None, "sha256": None, "spec_hash": None}


def _done(e: dict, info: dict, spec_hash: str) -> None:
    e.update(status="done", error=None, sha256=info["sha256"], spec_hash=spec_hash)
    e.pop("traceback", None)
    e.pop("failed_designs", None)
    if info["failed_rows"]:
        e["failed_designs"] = [{"point_index": r.get("point_index"), "reason": r.get("reason")} for r in info["failed_rows"]]


#: the first exotune version whose manifests record every finished chunk's ``sha256``
CHECKSUMS_SINCE = (0, 7)


def records_checksums(m: dict) -> bool:
    """Whether the exotune that wrote the manifest ``m`` records the SHA-256 of every finished
    chunk (0.7.0 and later; an unreadable version counts as a recent one): an entry ``done``
    without it is then an edited manifest, never an older one.

    Parameters
    ----------
    m : dict
        The sweep's manifest.

    Returns
    -------
    bool
        True unless ``exotune_version`` is an older version (before 0.7.0).

    References
    ----------
    docs/sweep-spec.md#integrity.
    """
    v = m.get("exotune_version")
    try:
        return tuple(int(x) for x in str(v).split(".")[:2]) >= CHECKSUMS_SINCE
    except ValueError:
        return True


def scan_chunks(out_dir: str, m: dict, plan: SweepPlan, strict: bool) -> dict:
    """Check every chunk of the sweep against the manifest ``m`` and the spec, and rebuild
    ``m["chunks"]`` (one entry per chunk, in order) from what is on disk.

    Parameters
    ----------
    out_dir : str
        The sweep directory.
    m : dict
        The loaded manifest; its ``chunks`` (and ``columns`` when missing) are updated in place.
    plan : SweepPlan
        The sweep of the manifest.
    strict : bool
        True (reading): a bad chunk file is a ConfigError naming it. False (resuming): it is
        marked pending, to be recomputed.

    Returns
    -------
    dict
        ``reconciled`` (valid chunks found on disk that the manifest did not record as done),
        ``recompute`` (bad chunk files to compute again, resuming only), ``changed`` (anything
        differs from the manifest as loaded).

    Raises
    ------
    ConfigError
        A symbolic link in the directory, or (``strict``) a chunk file that is not this sweep's,
        or an entry marked done without its checksum.
    """
    chunk_dir = os.path.join(out_dir, CHUNK_DIR)
    refuse_link(chunk_dir)
    _refuse_strays(chunk_dir, plan)
    old = {c["index"]: c for c in m["chunks"]}
    where = {c["index"]: k for k, c in enumerate(m["chunks"])}
    signed = records_checksums(m)
    entries, reconciled, recompute = [], [], []
    for i in range(plan.n_chunks):
        prev = old.get(i)
        e = _entry(plan, i)
        if prev is not None:
            e["seconds"] = prev.get("seconds")
            if prev.get("status") == "failed":
                e.update(status="failed", error=prev.get("error"))
                if "traceback" in prev:
                    e["traceback"] = prev["traceback"]
        path = os.path.join(out_dir, e["file"])
        if not os.path.lexists(path):
            entries.append(e)
            continue
        recorded = prev is not None and prev.get("status") == "done" and isinstance(prev.get("sha256"), str)
        if signed and prev is not None and prev.get("status") == "done" and not recorded:
            # exotune records the checksum of every chunk it finishes: without it the file cannot be
            # verified (an edited chunk would pass the row-by-row check of an unrecorded one)
            if strict:
                raise ConfigError(f"{os.path.join(out_dir, MANIFEST)}: chunks[{where[i]}].sha256",
                                  f"chunk {i} is marked done without the SHA-256 of its file {e['file']} "
                                  f"(exotune {m.get('exotune_version')} records it for every finished chunk: the "
                                  "manifest was edited), so the file cannot be verified; rerun `exotune sweep` with "
                                  "the same spec to recompute the chunk")
            recompute.append(i)
            entries.append(e)
            continue
        if not os.path.islink(path) and not os.path.isfile(path):  # a directory, a FIFO: never read nor replaced
            kind = "a directory" if os.path.isdir(path) else "a special file (FIFO, device or socket)"
            raise ConfigError(path, f"{kind} where chunk {i}'s file belongs: exotune "
                                    "neither reads nor deletes it; remove it, then rerun `exotune sweep` with the "
                                    "same spec to compute the chunk")
        why, info = chunk_problem(out_dir, plan, m, i, prev.get("sha256") if recorded else None)
        if why is not None:
            if strict:
                raise ConfigError(path, f"{why}; this is not chunk {i} of this sweep — rerun `exotune sweep` with the "
                                        "same spec to recompute it")
            recompute.append(i)
        else:
            if m.get("columns") is None:
                m["columns"] = info["schema"]
            _done(e, info, m["spec_hash"])
            if not recorded:
                reconciled.append(i)
        entries.append(e)
    changed = m["chunks"] != entries
    m["chunks"] = entries
    return {"reconciled": reconciled, "recompute": recompute, "changed": changed}


_CHUNK_NAME = re.compile(r"part-(\d+)\.parquet")


def _refuse_strays(chunk_dir: str, plan: SweepPlan) -> None:
    """A chunk file the sweep does not have (an index beyond its chunks: left by another sweep, or
    copied in) is refused, naming it: ``pandas.read_parquet(DIR/chunks)`` would read its rows with
    the sweep's."""
    try:
        names = os.listdir(chunk_dir)
    except OSError:  # absent (nothing computed yet, or deleted): the chunks are missing, not stray
        return
    own = {os.path.basename(chunk_rel(i)) for i in range(plan.n_chunks)}
    stray = sorted(n for n in names if _CHUNK_NAME.fullmatch(n) and n not in own)
    if stray:
        raise ConfigError(os.path.join(chunk_dir, stray[0]),
                          f"not a chunk of this sweep (it has {plan.n_chunks} chunk{'s' if plan.n_chunks != 1 else ''}"
                          f", {os.path.basename(chunk_rel(0))} to {os.path.basename(chunk_rel(plan.n_chunks - 1))}"
                          f"{f'; {len(stray)} such files' if len(stray) > 1 else ''}): reading the directory "
                          "with pandas would mix its rows in; remove it (exotune does not delete it)")


def count_failed_designs(m: dict) -> tuple[int, list[dict]]:
    """(number of failed designs in the finished chunks, the first few as {point_index, reason}).

    Parameters
    ----------
    m : dict
        The sweep's manifest.

    Returns
    -------
    count : int
        Failed designs in the finished chunks.
    first : list of dict
        The first ten of them.
    """
    rows = [r for c in m["chunks"] if c.get("status") == "done" for r in (c.get("failed_designs") or [])]
    return len(rows), rows[:10]
