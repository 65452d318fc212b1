"""Reading a sweep back: the verified manifest (:func:`verified_manifest`), the finished chunks as
one Arrow table (:func:`read_tables`) or a :class:`pandas.DataFrame` (:func:`load_results`).

Reading verifies every chunk against the manifest (:mod:`exotune.sweeps.integrity`) and records
valid chunks the manifest missed; a manifest left ``running`` by a killed run (no run holds the
directory lock) becomes ``interrupted`` (or ``complete`` when every chunk is on disk), and a
``complete`` one whose chunk files are missing becomes ``incomplete`` (rerunning the sweep
computes them).
"""

from __future__ import annotations

import contextlib
import os

from ..errors import ConfigError
from .integrity import scan_chunks
from .manifest import MANIFEST, chunk_rel, load_manifest, sweep_running, try_lock, write_manifest
from .plan import SweepPlan
from .result import chunk_list
from .store import CHUNK_DIR

__all__ = ["verified_manifest", "read_tables", "load_results", "check_results_left"]


def plan_of(out_dir: str, m: dict) -> SweepPlan:
    """The :class:`SweepPlan` of a loaded manifest (its spec is validated again)."""
    try:
        return SweepPlan(m["spec"])
    except ConfigError as e:
        raise ConfigError(f"{os.path.join(out_dir, MANIFEST)}: spec.base.{e.field}", e.reason) from None
    except (KeyError, TypeError, ValueError) as e:
        raise ConfigError(f"{os.path.join(out_dir, MANIFEST)}: spec", f"damaged manifest ({type(e).__name__}: "
                                                                      f"{str(e)[:120]}); use a new directory") from None


def verified_manifest(out_dir) -> dict:
    """The manifest of a sweep directory with every chunk verified, the valid chunks on disk
    recorded and its status made to agree with them (``complete`` only when every chunk is on disk;
    written back when no run holds the directory and it is writable).

    Parameters
    ----------
    out_dir : str or os.PathLike
        The sweep directory.

    Returns
    -------
    dict
        The manifest; ``chunks`` has one entry per chunk, in order.

    Raises
    ------
    ConfigError
        Not a sweep directory, a damaged or edited manifest, a symbolic link, or a chunk file that
        is not the one recorded (naming the chunk).

    References
    ----------
    docs/sweep-spec.md (integrity, reconciliation).
    """
    out_dir = os.fspath(out_dir)
    m = load_manifest(out_dir)
    plan = plan_of(out_dir, m)
    res = scan_chunks(out_dir, m, plan, strict=True)
    changed = res["changed"]
    all_done = all(c["status"] == "done" for c in m["chunks"])
    if m.get("status") == "complete" and not all_done:  # a chunk file removed after the sweep completed
        m["status"] = "incomplete"
        changed = True
    lock = try_lock(out_dir)
    if lock is None:
        return m
    try:
        if m.get("status") == "running" or (m.get("status") in ("interrupted", "incomplete") and all_done):
            m["status"] = "complete" if all_done else "interrupted"
            changed = True
        if changed:
            with contextlib.suppress(OSError):
                write_manifest(out_dir, m)
    finally:
        lock.close()
    return m


def check_results_left(out_dir) -> None:
    """Refuse, naming the missing chunks, a sweep that finished chunks but whose chunk files are
    all gone (the ``chunks`` directory deleted, or every file in it): it is ``incomplete`` — as a
    sweep that lost some of its chunk files is (:func:`verified_manifest` records it so) — and
    nothing is left to read. A sweep that never finished a chunk passes (the reader says so).

    Parameters
    ----------
    out_dir : str or os.PathLike
        The sweep directory.

    Raises
    ------
    ConfigError
        ``<out_dir>: the sweep is incomplete (… chunks missing: …) …``; ``<out_dir>: the sweep
        appears to be still running …`` when a run holds the directory and no chunk file is there
        yet; not a sweep directory or a damaged manifest
        (:func:`~exotune.sweeps.manifest.load_manifest`).

    References
    ----------
    docs/sweep-spec.md (reconciliation).
    """
    out_dir = os.fspath(out_dir)
    m = load_manifest(out_dir)
    if any(os.path.lexists(os.path.join(out_dir, chunk_rel(i))) for i in range(m["n_chunks"])):
        return  # some chunk file is there: the reader reads it (or names what is wrong with it)
    if sweep_running(out_dir, m):
        raise ConfigError(out_dir, f"the sweep appears to be still running (its manifest says running and a run holds "
                                   f"the directory's lock) and has finished none of its {m['n_chunks']} chunks yet; "
                                   "run `exotune report` again once it has finished some", in_file=True)
    finished = [c["index"] for c in m["chunks"] if c["status"] == "done"]
    if not finished and m["status"] != "incomplete":
        return  # no chunk ever finished
    m = verified_manifest(out_dir)  # records the sweep as incomplete, as a lost chunk file does
    missing = list(range(m["n_chunks"]))
    chunk_dir = os.path.join(out_dir, CHUNK_DIR)
    gone = "" if os.path.isdir(chunk_dir) else f"; the directory {chunk_dir} is gone"
    # the field is a directory, never a keyword: `-o out` must not be read as the option -o
    raise ConfigError(out_dir, f"the sweep is incomplete ({len(missing)} of {m['n_chunks']} chunks missing: "
                               f"{chunk_list(missing)}{gone}), so no finished chunk is left to report; rerun "
                               f"`exotune sweep` with the same spec and -o {out_dir} to compute them, then report "
                               "again", in_file=True)


def _check_pairs(table, path: str, index: int) -> None:
    """ConfigError naming the chunk file and the column when a ``list<list<double>>`` column of
    chunk ``index`` holds an entry that is not a pair ([lo, hi] of an interval, [value, frequency]
    of a critical value): a file whose checksum matches its manifest entry, yet not as exotune
    writes it (both edited)."""
    import pyarrow as pa
    import pyarrow.compute as pc

    for name, col in zip(table.column_names, table.columns):
        if not (pa.types.is_list(col.type) and pa.types.is_list(col.type.value_type)):
            continue
        for arr in col.chunks:
            inner = pc.list_flatten(arr)
            lens = pc.fill_null(pc.list_value_length(inner), -1).to_numpy(zero_copy_only=False)
            bad = lens[lens != 2]
            if bad.size:
                got = "a null entry" if bad[0] < 0 else f"an entry of {int(bad[0])} values"
                raise ConfigError(path, f"column {name} holds entries that are not [lo, hi] pairs ({got}); this is "
                                        f"not chunk {index} as exotune writes it (the file and its "
                                        "manifest entry were edited) — delete the file and rerun `exotune sweep` with "
                                        "the same spec to recompute it")


def read_tables(out_dir: str, columns=None, allow_partial: bool = False, manifest: dict | None = None):
    """(manifest, the finished chunks concatenated as one Arrow table or None, missing chunk indices);
    ConfigError for a bad chunk (:func:`verified_manifest`, skipped when the caller passes the
    ``manifest`` it returned), or for missing chunks unless ``allow_partial``.

    Parameters
    ----------
    out_dir : str or os.PathLike
        The sweep directory.
    columns : list of str or None, optional
        The columns to read; None for all.
    allow_partial : bool, optional
        Read the finished chunks of an incomplete sweep instead of refusing it.
    manifest : dict or None, optional
        The manifest, already verified; None to verify it here.

    Returns
    -------
    manifest : dict
        The manifest.
    table : pyarrow.Table or None
        The finished chunks' rows, None when no chunk is finished.
    missing : list of int
        Indices of the chunks not finished.

    Raises
    ------
    exotune.errors.ConfigError
        When a chunk is damaged or unreadable, or chunks are missing and ``allow_partial`` is False.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    out_dir = os.fspath(out_dir)
    m = verified_manifest(out_dir) if manifest is None else manifest
    tables, missing = [], []
    for c in m["chunks"]:
        path = os.path.join(out_dir, c["file"])
        if c.get("status") != "done":
            missing.append(c["index"])
            continue
        try:
            table = pq.read_table(path, columns=columns)
        except (OSError, pa.ArrowException) as e:
            raise ConfigError(path, f"unreadable chunk ({' '.join(str(e).split())}); rerun "
                                    "`exotune sweep` with the same spec to recompute it") from None
        _check_pairs(table, path, c["index"])
        tables.append(table)
    if missing and not allow_partial:
        if sweep_running(out_dir, m):
            raise ConfigError(out_dir, f"the sweep appears to be still running (its manifest says running and a run "
                                       f"holds the directory's lock): {len(missing)} of {len(m['chunks'])} chunks are "
                                       f"not finished yet ({chunk_list(missing)}); read it again once it has finished, "
                                       "or read the finished chunks with allow_partial=True")
        raise ConfigError(
            out_dir, f"the sweep is incomplete ({len(missing)} of {len(m['chunks'])} chunks missing); rerun "
                     f"`exotune sweep` with the same spec to compute {chunk_list(missing)}"
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
    docs/sweep-spec.md#output-directory, docs/sweep-spec.md#columns.
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
