"""Chunked, resumable, parallel parameter sweeps (``exotune sweep``) and their reports (``exotune report``).

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
    plant_margin: true                    # optional: plant-uncertainty margin columns (costly;
                                          # or {budget: N}; docs/sweep-spec.md)

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
    ``format_version`` (1: a manifest of another version is refused), ``status`` (``running``,
    ``complete``, ``interrupted``, ``incomplete`` or ``failed``), the normalized spec (``base`` =
    the validated base design mapping, ``axes`` = explicit value lists), its SHA-256 ``spec_hash`` (canonical JSON of the normalized spec including the base
    design's content, the chunk size and ``sample``/``seed``), exotune's version, the numbers of
    points and chunks, the Parquet column schema, one entry per chunk (status ``done`` /
    ``pending`` / ``failed`` with the error text, rows, seconds; a finished chunk also its file's
    ``sha256``, its ``spec_hash`` and, when some of its designs failed, ``failed_designs``), the
    number of ``failed_designs``, per-run timings (wall time, designs/s, backend) and
    created/updated timestamps (UTC, ISO 8601). Written atomically.
``DIR/chunks/part-XXXXXX.parquet``
    chunk ``XXXXXX`` (rows ``[XXXXXX·chunk_size, …)``), written atomically (temporary file in the
    same directory, fsync, :func:`os.replace`). Columns: ``point_index`` (int64), one float64
    column per axis named by its dotted path, then every column returned by
    :func:`exotune.analysis.analyze_batch` — bool, int64, float64 (±inf allowed: an infinite
    delay margin or bandwidth; NaN: undefined, e.g. DOB margins without a DOB) and
    ``list<list<double>>`` for interval-valued metrics (``[[lo, hi], …]``) and critical values
    (``[[value, freq_hz], …]``). The Arrow types are fixed by the Python types of the columns, so
    every chunk has the same schema (checked against the manifest).

Resuming: rerunning the same command in an existing DIR skips every chunk whose file is the one
recorded in the manifest (checksum) or, when unrecorded (a run killed between the chunk and the
manifest), is verified against the spec (rows, spec hash, chunk index, design indices), and
computes the rest; chunking is deterministic, so the final dataset is identical to an
uninterrupted run. Integrity checks, symbolic links and reconciliation:
:mod:`~exotune.sweeps.integrity`. A DIR holding a sweep
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

A design whose analysis raises becomes a row without results (null analysis columns), its
reason recorded in the chunk's metadata and the manifest; the sweep then raises
:class:`SweepError` at the end (exit 1) naming the first failed design (see
:mod:`~exotune.sweeps.compute`). The ``--dask`` address is validated and connected before the
directory is created. A chunk that raises is never dropped: its error is reported (``progress.message("chunk_failed", …)``),
recorded in the manifest, the other chunks still run, and :class:`SweepError` is raised at the end (the CLI exits with code 1).
Rerunning the command retries the failed chunks. Memory stays bounded: the parent holds at most
the in-flight chunks' results (local processes: none).

Progress: :func:`run_sweep` never writes to the terminal; it reports through the
:class:`~exotune.sweeps.progress.SweepProgress` hooks it is given (``exotune sweep`` passes a
:class:`~exotune.sweeps.progress.TqdmProgress` on stderr).

Modules
-------
:mod:`~exotune.sweeps.spec` (spec validation), :mod:`~exotune.sweeps.plan` (row → design point),
:mod:`~exotune.sweeps.store` (Arrow/Parquet), :mod:`~exotune.sweeps.manifest` (manifest, lock,
engine hash), :mod:`~exotune.sweeps.integrity` (checksums, reconciliation),
:mod:`~exotune.sweeps.dataset` (reading a sweep back), :mod:`~exotune.sweeps.compute` (one chunk), :mod:`~exotune.sweeps.backends`
(in-process, processes, Dask), :mod:`~exotune.sweeps.run` (:func:`run_sweep`),
:mod:`~exotune.sweeps.progress`; the report: :mod:`~exotune.sweeps.metrics` (robustness and derived
metrics), :mod:`~exotune.sweeps.summary` (``summary.md`` and per-axis CSV); the report's figures and
the report itself are views: :mod:`exotune.plots.sweep` (heatmaps, profiles) and
:func:`exotune.plots.sweep_report.make_report` (``exotune report``, :func:`exotune.report`).
"""

from ..lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        "run_sweep": "run",
        "SweepResult": "result",
        "SweepReport": "result",
        "SweepError": "run",
        "SweepProgress": "progress",
        "TqdmProgress": "progress",
        "LineProgress": "progress",
        "load_spec": "spec",
        "SweepPlan": "plan",
        "DEFAULT_CHUNK_SIZE": "spec",
        "load_manifest": "manifest",
        "load_results": "dataset",
        "robust_mask": "metrics",
        "derived_metrics": "metrics",
    },
)
