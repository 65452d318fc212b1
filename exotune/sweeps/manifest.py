"""The manifest of a sweep directory (``DIR/manifest.json``) and the directory's state: creating,
reading, checking and writing the manifest, the directory lock, and the compatibility check of a
resumed sweep (same spec, same analysis code, same exotune version).

The manifest's fields are described in the :mod:`exotune.sweeps` package docstring.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import os

from ..version import __version__
from ..config.design import hash_mapping
from ..errors import ConfigError
from ..jsonio import to_jsonable, write_atomic
from .plan import SweepPlan
from .spec import is_number

__all__ = ["MANIFEST", "FORMAT", "FORMAT_VERSION", "utc_now", "load_manifest", "write_manifest", "dir_lock",
           "engine_hash", "new_manifest", "check_compatible", "chunk_rel", "refuse_link", "try_lock", "lock_held",
           "sweep_running"]

MANIFEST = "manifest.json"
MAX_MANIFEST_BYTES = 64 << 20  # 64 MiB: ~2·10^5 chunk entries with their checksums
FORMAT = "exotune-sweep"
FORMAT_VERSION = 1
#: the states of a sweep (``status``) and of each of its chunks (``chunks[].status``)
STATUSES = ("running", "complete", "interrupted", "incomplete", "failed")
CHUNK_STATUSES = ("pending", "done", "failed")


def utc_now() -> str:
    """The current time, UTC, ISO 8601 to the second (manifest timestamps).

    Returns
    -------
    str
        ISO 8601 timestamp with its ``+00:00`` offset.
    """
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")


def load_manifest(out_dir) -> dict:
    """The manifest of a sweep directory, checked (:func:`_check_manifest`): ConfigError when it is
    missing, unreadable, too large or too deeply nested (the guarded JSON reader), a symbolic link,
    of another ``format_version``, damaged (a field of the wrong type, an unknown ``status``), or
    edited by hand (its spec no longer has the recorded spec hash).

    Parameters
    ----------
    out_dir : str or os.PathLike
        The sweep directory.

    Returns
    -------
    dict
        The manifest (``manifest.json``).

    Raises
    ------
    exotune.errors.ConfigError
        When the directory holds no readable, intact manifest of a sweep.
    """
    from ..config.yamlio import read_json_guarded

    path = os.path.join(os.fspath(out_dir), MANIFEST)
    if os.path.islink(path):
        raise ConfigError(path, "is a symbolic link; a sweep directory holds its own files only (use a new directory)")
    if not os.path.lexists(path):
        raise ConfigError(os.fspath(out_dir), "not a sweep directory (no manifest.json)")
    m = read_json_guarded(path, "sweep manifest", max_bytes=MAX_MANIFEST_BYTES)
    if not isinstance(m, dict) or m.get("format") != FORMAT:
        raise ConfigError(path, "not an exotune sweep manifest")
    _check_manifest(m, path)
    return m


def _shown(v) -> str:
    """A manifest's value as an error quotes it: its JSON type and a short excerpt."""
    from ..config.validate import excerpt

    kind = {str: "the string", bool: "the boolean", type(None): "null"}.get(type(v), type(v).__name__)
    return kind if v is None else f"{kind} {excerpt(repr(v))}"


def _check_manifest(m: dict, path: str) -> None:
    """The fields that resuming and reporting rely on, with their types (a manifest edited or
    damaged by hand is refused with the field named, never a traceback later)."""
    is_int = lambda v: isinstance(v, int) and not isinstance(v, bool)  # noqa: E731
    need = {"spec": (lambda v: isinstance(v, dict), "a mapping"), "spec_hash": (lambda v: isinstance(v, str), "a string"),
            "chunks": (lambda v: isinstance(v, list), "a list"), "n_points": (is_int, "an integer"),
            "n_chunks": (is_int, "an integer"), "chunk_size": (is_int, "an integer")}
    damaged = "(damaged manifest; use a new directory)"
    v = m.get("format_version")
    if not is_int(v):
        raise ConfigError(f"{path}: format_version", f"expected the integer {FORMAT_VERSION}, got "
                                                     f"{'nothing' if v is None else _shown(v)} {damaged}")
    if v != FORMAT_VERSION:
        raise ConfigError(f"{path}: format_version", f"{v} is not a manifest format this exotune ({__version__}) reads "
                                                     f"(it reads {FORMAT_VERSION}): "
                          + ("the sweep was written by a newer exotune; read it with that version, or rerun the "
                             "sweep into a new directory" if v > FORMAT_VERSION else damaged))
    for key, (ok_type, what) in need.items():
        v = m.get(key)
        if not ok_type(v):
            raise ConfigError(f"{path}: {key}", f"expected {what}, got {type(v).__name__} (damaged manifest; "
                                                f"use a new directory)")
    if not isinstance(m.get("status"), str) or m["status"] not in STATUSES:
        raise ConfigError(f"{path}: status", f"expected one of {', '.join(STATUSES)}, got {_shown(m.get('status'))} "
                                             f"{damaged}")
    axes, spec_axes = m.get("axes"), m["spec"].get("axes")
    if not (isinstance(axes, list) and axes and all(isinstance(a, dict) and isinstance(a.get("path"), str) for a in axes)):
        raise ConfigError(f"{path}: axes", f"expected a non-empty list of {{path, …}} {damaged}")
    if not isinstance(spec_axes, dict) or [a["path"] for a in axes] != list(spec_axes):
        raise ConfigError(f"{path}: spec.axes", f"must hold the manifest's axes, in order {damaged}")
    for p, a in spec_axes.items():
        vals = a.get("values") if isinstance(a, dict) else None
        if not (isinstance(vals, list) and vals and all(is_number(v) for v in vals)):
            raise ConfigError(f"{path}: spec.axes.{p}.values", f"expected a non-empty list of numbers {damaged}")
    for i, c in enumerate(m["chunks"]):
        if not (isinstance(c, dict) and is_int(c.get("index")) and isinstance(c.get("file"), str)
                and isinstance(c.get("status"), str)):
            raise ConfigError(f"{path}: chunks[{i}]", "expected a mapping with index, file and status "
                                                       "(damaged manifest; use a new directory)")
        if c["status"] not in CHUNK_STATUSES:
            raise ConfigError(f"{path}: chunks[{i}].status", f"expected one of {', '.join(CHUNK_STATUSES)}, got "
                                                              f"{_shown(c['status'])} {damaged}")
        if os.path.isabs(c["file"]) or ".." in c["file"].replace("\\", "/").split("/"):
            raise ConfigError(f"{path}: chunks[{i}].file", f"must be a path inside the sweep directory, got {c['file']!r}")
    _check_integrity(m, path)


def chunk_rel(index: int) -> str:
    """The path of chunk ``index`` relative to the sweep directory (``chunks/part-XXXXXX.parquet``).

    Parameters
    ----------
    index : int
        Chunk index (from 0).

    Returns
    -------
    str
        The relative path.
    """
    return f"chunks/part-{index:06d}.parquet"


def _check_integrity(m: dict, path: str) -> None:
    """The manifest against itself: the spec has the recorded spec hash (``spec.axes`` edited or
    relabelled by hand is refused), the axes, grid and chunk counts agree with the spec (a
    shortened axis is named), and every chunk entry names its own file, once."""
    tampered = "(the manifest was edited; use a new directory or rerun `exotune sweep` into a new one)"
    spec = m["spec"]
    for i, a in enumerate(m["axes"]):
        vals = spec["axes"][a["path"]]["values"]
        if a.get("num") != len(vals):
            raise ConfigError(f"{path}: spec.axes.{a['path']}.values",
                              f"{len(vals)} values, but the sweep's axis {a['path']} has {a.get('num')!r} (axes[{i}].num) "
                              f"{tampered}")
    shape = [len(spec["axes"][p]["values"]) for p in spec["axes"]]
    if m.get("grid_shape") is not None and m.get("grid_shape") != shape:
        raise ConfigError(f"{path}: grid_shape", f"{m.get('grid_shape')!r} does not match the axes ({shape}) {tampered}")
    if hash_mapping(spec) != m["spec_hash"]:
        raise ConfigError(f"{path}: spec", f"does not have the recorded spec_hash {m['spec_hash'][:12]}… (its axes, "
                                           f"base or options were changed after the sweep was made) {tampered}")
    grid = 1
    for n in shape:
        grid *= n
    want_points = grid if spec.get("sample") is None else spec.get("sample")
    if m["n_points"] != want_points or m["chunk_size"] != spec.get("chunk_size") or m["chunk_size"] < 1 \
            or m["n_chunks"] != -(-m["n_points"] // m["chunk_size"]):
        raise ConfigError(f"{path}: n_points", f"n_points {m['n_points']}, chunk_size {m['chunk_size']} and n_chunks "
                                               f"{m['n_chunks']} do not match the spec {tampered}")
    seen: dict[int, int] = {}
    for i, c in enumerate(m["chunks"]):
        if not 0 <= c["index"] < m["n_chunks"]:
            raise ConfigError(f"{path}: chunks[{i}].index", f"{c['index']} is not a chunk of this sweep "
                                                             f"(0 … {m['n_chunks'] - 1}) {tampered}")
        if c["index"] in seen:
            raise ConfigError(f"{path}: chunks[{i}]", f"chunk {c['index']} is listed twice (also chunks[{seen[c['index']]}]) "
                                                      f"{tampered}")
        seen[c["index"]] = i
        if c["file"].replace("\\", "/") != chunk_rel(c["index"]):
            raise ConfigError(f"{path}: chunks[{i}].file", f"{c['file']!r}, but chunk {c['index']} is "
                                                           f"{chunk_rel(c['index'])!r} {tampered}")


def write_manifest(out_dir: str, manifest: dict) -> None:
    """Stamp ``updated`` and write the manifest atomically as strict JSON.

    Parameters
    ----------
    out_dir : str
        The sweep directory.
    manifest : dict
        The manifest; its ``updated`` is set in place.
    """
    import json

    manifest["updated"] = utc_now()
    text = json.dumps(to_jsonable(manifest), indent=1, ensure_ascii=False, allow_nan=False)
    write_atomic(os.path.join(out_dir, MANIFEST), text + "\n")


@contextlib.contextmanager
def dir_lock(out_dir: str):
    """Hold ``DIR/.lock`` (an exclusive, non-blocking flock) for the duration of a run; a second
    run in the same directory is refused with a ConfigError.

    Parameters
    ----------
    out_dir : str
        The sweep directory.

    Yields
    ------
    None
        While the lock is held.

    Raises
    ------
    exotune.errors.ConfigError
        When another process holds the lock, or ``DIR/.lock`` is a symbolic link.
    """
    try:
        import fcntl
    except ImportError:  # pragma: no cover - non-POSIX
        yield
        return
    refuse_link(os.path.join(out_dir, ".lock"))
    fh = open(os.path.join(out_dir, ".lock"), "a+")
    try:
        try:
            fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            raise ConfigError(out_dir, "another exotune sweep is running in this directory") from None
        yield
    finally:
        fh.close()


def refuse_link(path: str, what: str = "a sweep directory") -> None:
    """ConfigError when ``path`` is a symbolic link: exotune never reads, writes or deletes through
    a link inside a sweep or report directory (it could point anywhere).

    Parameters
    ----------
    path : str
        The path to check.
    what : str, optional
        What the directory is, as the error names it.

    Raises
    ------
    exotune.errors.ConfigError
        When ``path`` is a symbolic link.
    """
    if os.path.islink(path):
        raise ConfigError(path, f"is a symbolic link; {what} must hold its own files and directories, "
                                "not links (exotune never writes or deletes through them)")


def try_lock(out_dir: str):
    """The open ``DIR/.lock`` file holding an exclusive lock, or None when another process holds it
    or the directory is not writable (a report then records nothing in the manifest).

    Parameters
    ----------
    out_dir : str
        The sweep directory.

    Returns
    -------
    file object or None
        The locked file (close it to release the lock), or None.
    """
    try:
        import fcntl
    except ImportError:  # pragma: no cover - non-POSIX
        return None
    path = os.path.join(out_dir, ".lock")
    if os.path.islink(path):
        return None
    try:
        fh = open(path, "a+")
    except OSError:
        return None
    try:
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        fh.close()
        return None
    return fh


def lock_held(out_dir) -> bool:
    """Whether a process holds the lock of the sweep directory ``out_dir`` (a sweep running
    there): a shared lock of ``DIR/.lock`` is tried and released at once, so the check needs no
    write permission and takes nothing from the run.

    Parameters
    ----------
    out_dir : str or os.PathLike
        The sweep directory.

    Returns
    -------
    bool
        True when another process holds ``DIR/.lock``; False when nobody does, the file is missing
        or a link, or locks are not available.

    References
    ----------
    docs/sweep-spec.md#integrity (the directory lock).
    """
    try:
        import fcntl
    except ImportError:  # pragma: no cover - non-POSIX
        return False
    path = os.path.join(os.fspath(out_dir), ".lock")
    if os.path.islink(path):
        return False
    try:
        fh = open(path, "rb")
    except OSError:
        return False
    with fh:
        try:
            fcntl.flock(fh.fileno(), fcntl.LOCK_SH | fcntl.LOCK_NB)
        except BlockingIOError:
            return True
        except OSError:
            return False
        fcntl.flock(fh.fileno(), fcntl.LOCK_UN)
    return False


def sweep_running(out_dir, m: dict | None = None) -> bool:
    """Whether a sweep appears to be running in ``out_dir``: its manifest says ``running`` and a
    process holds the directory's lock (a manifest left ``running`` by a killed run is not).

    Parameters
    ----------
    out_dir : str or os.PathLike
        The sweep directory.
    m : dict, optional
        Its manifest, already loaded; None to read it (False when it cannot be read).

    Returns
    -------
    bool
        True while a run holds the directory.

    References
    ----------
    docs/sweep-spec.md#integrity; docs/cli.md#report.
    """
    if m is None:
        try:
            m = load_manifest(out_dir)
        except (ConfigError, OSError):
            return False
    return m.get("status") == "running" and lock_held(out_dir)


def _spec_diff(a: dict, b: dict) -> list[str]:
    keys = sorted(set(a) | set(b))
    return [k for k in keys if hash_mapping(a.get(k)) != hash_mapping(b.get(k))]


_ENGINE_PACKAGES = ("numerics", "model", "config", "sampled", "analysis")
#: the sweep's own modules that compute columns (the chunk's table, the sampled-data and
#: gain-schedule columns)
_ENGINE_FILES = ("sweeps/compute.py", "sweeps/sampledcols.py")


def engine_hash() -> str:
    """SHA-256 of the source of the packages and sweep modules that compute the results: a resumed
    sweep refuses to mix chunks computed by different analysis code (the version string alone is
    not enough).

    Returns
    -------
    str
        The 64 hex digits of the SHA-256.
    """
    import hashlib
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    h = hashlib.sha256()
    files = [f for pkg in _ENGINE_PACKAGES for f in sorted((root / pkg).rglob("*.py"))]
    for f in files + [root / p for p in _ENGINE_FILES]:
        h.update(f.relative_to(root).as_posix().encode() + b"\0" + f.read_bytes())
    return h.hexdigest()


def _model_note(plan: SweepPlan) -> str:
    note = ("continuous-time analysis with the exact delay e^{-sT} (docs/method.md#analyses-and-metrics): every column is the "
            "exact continuous verdict or metric")
    fs = plan.cfg.implementation.sample_rate_hz
    if fs and plan.spec.get("sampled"):
        note += (f"; the sampled_* columns are the exact sampled-data verdicts at {fs:g} Hz (zero-order hold, "
                 "fractional delay, the controller as `exotune export` writes it; docs/sweep-spec.md#sampled-data-columns)")
    elif fs:
        note += (f"; the base design sets sample_rate_hz = {fs:g} Hz, used here only to validate the "
                 "cutoffs against Nyquist — run `exotune analyze` with it on a chosen design for the "
                 "sampled-data check (the zero-order hold costs about half a sample of extra delay)")
    return note


def new_manifest(plan: SweepPlan) -> dict:
    """The manifest of a new sweep of ``plan`` (no chunk done yet, status ``running``).

    Parameters
    ----------
    plan : SweepPlan
        The sweep's plan (spec, axes, sampling, chunking).

    Returns
    -------
    dict
        The manifest to write.
    """
    axes = []
    for p, v in zip(plan.paths, plan.values):
        axes.append({"path": p, "num": int(v.size), "min": float(v.min()), "max": float(v.max()),
                     "scale": plan.spec["axes"][p]["scale"]})
    now = utc_now()
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
            "gains": "torque units (docs/method.md#double-compliance-shaping): K1 [N·m/rad], B1 [N·m·s/rad], K2 [–], B2 [s], K2_hat [–], B2_hat [s]",
        },
        "status": "running",
        "chunks": [],
        "timings": {},
        "runs": [],
        "created": now,
        "updated": now,
    }


def check_compatible(out_dir: str, old: dict, plan: SweepPlan) -> None:
    """Refuse (ConfigError) to resume a sweep directory holding a different spec, made by different
    analysis code (engine hash) or by another exotune version.

    Parameters
    ----------
    out_dir : str
        The sweep directory, as the errors name it.
    old : dict
        The manifest found there.
    plan : SweepPlan
        The plan of this run.

    Raises
    ------
    exotune.errors.ConfigError
        When the spec hash, engine hash or exotune version differs.
    """
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
