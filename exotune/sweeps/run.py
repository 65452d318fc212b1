"""Running (or resuming) a sweep: :func:`run_sweep` and :class:`SweepError`."""

from __future__ import annotations

import contextlib
import os
import time
from typing import Callable

import numpy as np

from ..errors import ConfigError, RunFailed
from .backends import connect_dask, dispatch, stop_signals
from .integrity import count_failed_designs, scan_chunks
from .manifest import (MANIFEST, check_compatible, dir_lock, load_manifest, new_manifest, refuse_link, utc_now,
                       write_manifest)
from .plan import SweepPlan
from .progress import SweepProgress, as_progress
from .result import SweepResult
from .spec import int_option, load_spec
from .store import CHUNK_DIR

__all__ = ["run_sweep", "SweepError"]

_MANIFEST_MIN_INTERVAL_S = 2.0


class SweepError(RunFailed):
    """Some chunks of a sweep failed (their errors are in the manifest). Exit code 1.

    A :class:`~exotune.errors.RunFailed`: the command line prints one line ``exotune: error: …``
    and exits with code 1, without a traceback. ``failed`` lists the indices of the failed chunks,
    ``manifest`` is the manifest as written."""

    def __init__(self, message: str, failed: list[int] | None = None, manifest: dict | None = None):
        super().__init__(message)
        self.failed = list(failed or [])
        self.manifest = manifest


def run_sweep(
    spec_path,
    out_dir,
    workers: int | None = None,
    dask_address: str | None = None,
    sample: int | None = None,
    seed: int | None = None,
    chunk_size: int | None = None,
    progress: SweepProgress | Callable[[str], None] | None = None,
) -> SweepResult:
    """Run (or resume) the sweep ``spec_path`` into ``out_dir``; returns the sweep
    (:class:`~exotune.sweeps.result.SweepResult`: ``to_dict()`` is the manifest, ``table()`` the rows).

    See the :mod:`exotune.sweeps` package docstring for the spec format, the directory layout and
    the backends.

    Parameters
    ----------
    spec_path : str, os.PathLike or dict
        The sweep spec: a YAML file or a mapping (see :func:`~exotune.sweeps.spec.load_spec`).
    out_dir : str or os.PathLike
        The sweep directory; an existing directory of the same sweep is resumed.
    workers : int, optional
        Local worker processes (default: the CPU count; 1 = in-process).
    dask_address : str, optional
        A Dask scheduler address, ``"local"`` or ``"local:N"``.
    sample, seed : int, optional
        A uniform random sample of ``sample`` grid points, seeded by ``seed`` (default 0).
    chunk_size : int, optional
        Design points per chunk (overrides the spec's ``chunk_size``).
    progress : SweepProgress or callable, optional
        Receives the sweep's messages and progress (:class:`~exotune.sweeps.progress.TqdmProgress`
        for a terminal); a function receives each line of text; ``None`` or ``False``: a silent
        sweep (the library never writes to the terminal itself).

    Returns
    -------
    SweepResult
        ``to_dict()``: the manifest as written to ``out_dir/manifest.json``; ``table()``: the rows.

    Raises
    ------
    ConfigError
        Bad input, before anything is written.
    SweepError
        Some chunks failed (after all other chunks ran; the manifest records the errors).
    KeyboardInterrupt
        Ctrl-C (SIGINT); ``SystemExit(143)`` for SIGTERM. Either way the workers are stopped, the
        finished chunks kept, the manifest records "interrupted" and ``progress`` is told how many
        chunks are done and how to resume (rerun the same call); ``exotune sweep`` exits 130 or 143.

    References
    ----------
    docs/sweep-spec.md (keys, output directory, resuming, parallelism).
    """
    progress = as_progress(progress)
    plan = load_spec(spec_path, sample=sample, seed=seed, chunk_size=chunk_size)
    if workers is not None:
        workers = int_option("workers", workers, 1)
    if dask_address is not None and (not isinstance(dask_address, str) or not dask_address.strip()):
        raise ConfigError("dask_address", f"expected a scheduler address, got {dask_address!r}")
    out_dir = os.fspath(out_dir)
    if os.path.exists(out_dir) and not os.path.isdir(out_dir):
        raise ConfigError(out_dir, "exists and is not a directory")
    for name in (MANIFEST, CHUNK_DIR, ".lock"):
        refuse_link(os.path.join(out_dir, name))
    chunk_dir = os.path.join(out_dir, CHUNK_DIR)
    if os.path.lexists(chunk_dir) and not os.path.isdir(chunk_dir):  # the path in the way, before any work
        raise ConfigError(chunk_dir, "exists and is not a directory (the sweep keeps its chunk files in a directory "
                                     "of this name); move it away or choose another output directory")

    if os.path.lexists(os.path.join(out_dir, MANIFEST)):
        old = load_manifest(out_dir)
        check_compatible(out_dir, old, plan)
    elif os.path.isdir(os.path.join(out_dir, CHUNK_DIR)) and any(
        n.startswith("part-") for n in os.listdir(os.path.join(out_dir, CHUNK_DIR))
    ):
        raise ConfigError(out_dir, "holds chunk files but no manifest.json; use a new directory")

    dask = connect_dask(dask_address, workers) if dask_address is not None else None  # before anything is written
    try:
        try:
            os.makedirs(chunk_dir, exist_ok=True)
        except OSError as e:  # name the directory that could not be made (out_dir, or a parent of it)
            where = e.filename if isinstance(e.filename, str) else out_dir
            raise ConfigError(where, f"cannot create the output directory: {e.strerror or e}") from None
        refuse_link(os.path.join(out_dir, CHUNK_DIR))

        with dir_lock(out_dir):
            if os.path.lexists(os.path.join(out_dir, MANIFEST)):
                manifest = load_manifest(out_dir)
                check_compatible(out_dir, manifest, plan)
            else:
                manifest = new_manifest(plan)
            return SweepResult.from_manifest(_execute(plan, out_dir, manifest, workers, dask, progress), out_dir)
    finally:
        if dask is not None:
            dask.close()


def _scan_chunks(plan: SweepPlan, out_dir: str, manifest: dict) -> list[int]:
    """Check every chunk file against the manifest and the spec (:func:`~exotune.sweeps.integrity.scan_chunks`:
    valid unrecorded chunks are recorded, bad ones recomputed) and return the chunks to compute;
    remove leftovers of killed writers (the caller holds the lock)."""
    chunk_dir = os.path.join(out_dir, CHUNK_DIR)
    for name in os.listdir(chunk_dir):
        if name.startswith(".tmp-") and not os.path.islink(os.path.join(chunk_dir, name)):
            with contextlib.suppress(OSError):
                os.unlink(os.path.join(chunk_dir, name))
    scan_chunks(out_dir, manifest, plan, strict=False)
    manifest["status"] = "running"
    return [e["index"] for e in manifest["chunks"] if e["status"] != "done"]


def _new_run(plan: SweepPlan, todo: list[int], workers, dask) -> tuple[dict, int]:
    """The manifest's record of this run (backend, workers, counters; timings filled in later) and
    the number of local worker processes."""
    dask_address = None if dask is None else dask.address
    if dask_address is not None:
        backend = "dask"
    elif workers == 1 or len(todo) <= 1:
        backend = "in-process"
    else:
        backend = "local-processes"
    n_workers = workers or os.cpu_count() or 1
    if backend == "local-processes":
        n_workers = min(n_workers, len(todo))
    run = {"started": utc_now(), "finished": None, "backend": backend,
           "workers": (1 if backend == "in-process" else n_workers if backend == "local-processes" else None),
           "dask_address": dask_address, "chunks_skipped": plan.n_chunks - len(todo), "chunks_computed": 0,
           "chunks_failed": 0, "points_computed": 0, "wall_s": None, "designs_per_s": None}
    return run, n_workers


def _start_text(plan: SweepPlan, run: dict, n_workers: int) -> str:
    backend, n_skip = run["backend"], run["chunks_skipped"]
    where = f"Dask at {run['dask_address']}" if backend == "dask" else (
        "in-process" if backend == "in-process" else f"{n_workers} local processes")
    resumed = f"; resuming: {n_skip} of {plan.n_chunks} chunks already done" if n_skip else ""
    return (f"exotune sweep: {plan.n_points} designs in {plan.n_chunks} chunks of {plan.chunk_size} "
            f"({where}){resumed}")


class _Recorder:
    """``on_result`` of the backends: records each chunk's status record in the manifest (and
    rewrites it at most every ``_MANIFEST_MIN_INTERVAL_S``), reports failures and progress."""

    def __init__(self, out_dir: str, manifest: dict, run: dict, progress: SweepProgress, t0: float):
        self.out_dir, self.manifest, self.run, self.progress, self.t0 = out_dir, manifest, run, progress, t0
        self.failures: list[tuple[int, str]] = []
        self.last_write = time.monotonic()

    def __call__(self, res: dict) -> None:
        manifest, run = self.manifest, self.run
        i = res["index"]
        e = manifest["chunks"][i]
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
                    os.unlink(os.path.join(self.out_dir, e["file"]))
        if err is None:
            e["status"], e["error"] = "done", None
            e["sha256"], e["spec_hash"] = res.get("sha256"), self.manifest["spec_hash"]
            e.pop("traceback", None)
            e.pop("failed_designs", None)
            if res.get("failed_rows"):
                e["failed_designs"] = [{"point_index": r["point_index"], "reason": r["reason"]} for r in res["failed_rows"]]
                r = res["failed_rows"][0]
                self.progress.message("design_failed", f"exotune: chunk {i}: {len(res['failed_rows'])} design(s) failed, "
                                                       f"kept as rows without results (first: design {r['point_index']}: "
                                                       f"{r['reason']})")
            run["chunks_computed"] += 1
            run["points_computed"] += e["rows"]
        else:
            e["status"], e["error"] = "failed", err
            if res.get("traceback"):
                e["traceback"] = res["traceback"]
            run["chunks_failed"] += 1
            self.failures.append((i, err))
            self.progress.message("chunk_failed", f"exotune: chunk {i} failed: {err}")
        self.progress.advance(e["rows"])
        now = time.monotonic()
        if now - self.last_write >= _MANIFEST_MIN_INTERVAL_S:
            _finish_timings(manifest, run, self.t0, final=False)
            write_manifest(self.out_dir, manifest)
            self.last_write = now


def _execute(plan: SweepPlan, out_dir: str, manifest: dict, workers, dask,
             progress: SweepProgress) -> dict:
    todo = _scan_chunks(plan, out_dir, manifest)
    run, n_workers = _new_run(plan, todo, workers, dask)
    manifest.setdefault("runs", []).append(run)
    with stop_signals() as stop:
        write_manifest(out_dir, manifest)
        t0 = time.perf_counter()
        try:
            done_points = sum(e["rows"] for e in manifest["chunks"] if e["status"] == "done")
            progress.message("start", _start_text(plan, run, n_workers))
            if workers is not None and workers > 1 and run["backend"] == "in-process":
                progress.message("start", f"exotune sweep: --workers {workers} not used: a single chunk to compute "
                                          f"runs in-process (chunks of {plan.chunk_size} designs; a smaller "
                                          "--chunk-size spreads the designs over worker processes)")
            progress.start(plan.n_points, done_points)
            t0 = time.perf_counter()
            record = _Recorder(out_dir, manifest, run, progress, t0)
            dispatch(plan, out_dir, todo, record, run["backend"], dask, workers, n_workers)
        except BaseException as exc:  # Ctrl-C, SIGTERM, a full disk, …
            stop.hold()  # a second Ctrl-C does not cut the manifest short
            _record_stop(plan, out_dir, manifest, run, t0, progress, exc, stop.received)
            raise
    progress.close()
    failures = record.failures
    manifest["status"] = "failed" if failures else "complete"
    n_bad, first_bad = count_failed_designs(manifest)
    manifest["failed_designs"] = n_bad
    _finish_timings(manifest, run, t0, final=True)
    _write_final(out_dir, manifest)
    if not failures and n_bad:
        d = first_bad[0]
        raise SweepError(
            f"{n_bad} of {plan.n_points} designs failed (first: design {d['point_index']}: {d['reason']}); their rows "
            f"hold no results and their reasons are recorded in {os.path.join(out_dir, MANIFEST)} "
            "(chunks[].failed_designs); the other designs are complete",
            failed=[], manifest=manifest,
        )
    if not failures:
        rate = run["designs_per_s"]
        progress.message("complete", f"exotune sweep: complete — {run['points_computed']} designs computed in "
                                     f"{run['wall_s']:.1f} s" + (f" ({rate:.0f} designs/s)" if rate else "")
                                     + f"; results in {out_dir}")
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


def _record_stop(plan: SweepPlan, out_dir: str, manifest: dict, run: dict, t0: float, progress: SweepProgress,
                 exc: BaseException, signum: int | None) -> None:
    """A run that ends early: the manifest records "interrupted" (the finished chunks are kept and
    skipped when the same command is rerun), the progress bar is closed and a stop by Ctrl-C or
    SIGTERM is reported (``progress.message("interrupted" | "terminated", …)``, saying how to
    resume); an OSError (a full disk) becomes one line, :class:`RunFailed`."""
    import signal

    manifest["status"] = "interrupted"
    with contextlib.suppress(Exception):
        _finish_timings(manifest, run, t0, final=True)
    with contextlib.suppress(Exception):
        write_manifest(out_dir, manifest)
    with contextlib.suppress(Exception):
        progress.close()
    if isinstance(exc, OSError):  # e.g. no space left for the manifest: one line, the chunks are kept
        raise RunFailed(f"{exc.filename or out_dir}: {exc.strerror or exc}; the chunks written so far are kept "
                        "and recognized when you rerun the same command") from None
    if signum == signal.SIGTERM:
        kind, how = "terminated", "terminated (SIGTERM)"
    elif signum == signal.SIGINT or isinstance(exc, KeyboardInterrupt):
        kind, how = "interrupted", "interrupted (Ctrl-C)"
    else:
        return
    done = sum(e.get("status") == "done" for e in manifest["chunks"])
    progress.message(kind, f"exotune sweep: {how}: {done} of {plan.n_chunks} chunks done, kept in {out_dir} (manifest "
                           "status: interrupted); rerun the same command to resume")


def _write_final(out_dir: str, manifest: dict) -> None:
    """The final manifest write; a failure (no space left, …) is one line, exit 1 (the previous
    manifest stays in place, and the chunks on disk are recognized on the next run or report)."""
    try:
        write_manifest(out_dir, manifest)
    except OSError as e:
        raise RunFailed(f"{e.filename or out_dir}: cannot write the sweep manifest ({e.strerror or e}); the chunks "
                        "written so far are kept and recognized when you rerun the same command") from None


def _finish_timings(manifest: dict, run: dict, t0: float, final: bool) -> None:
    wall = time.perf_counter() - t0
    run["wall_s"] = wall
    run["designs_per_s"] = run["points_computed"] / wall if wall > 0 else None
    if final:
        run["finished"] = utc_now()
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
