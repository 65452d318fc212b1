"""Shared driver of the studies: run the sweep (bulk Parquet data in a scratch directory, never in
the repository), write the generic ``exotune report`` into ``results/<study>/`` and let the study
add its own figures and ``study.md``.

Every study script accepts:
  --data DIR      scratch root for the sweep data (default $EXOTUNE_STUDY_DATA or
                  $TMPDIR/exotune-studies); the sweep goes to DIR/<study>
  --results DIR   results root (default <repo>/results); outputs go to DIR/<study>
  --workers N     local worker processes (default 2)
  --resume        keep existing sweep data in DIR/<study> and resume (default: start afresh so that
                  the results always come from the current code)
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from exotune.jsonio import write_atomic  # noqa: E402
from exotune.plots.sweep_report import make_report  # noqa: E402
from exotune.sweeps import TqdmProgress, load_manifest, load_results, run_sweep  # noqa: E402
from exotune.sweeps.summary import value_runs  # noqa: E402


def parse_args(name: str, doc: str):
    ap = argparse.ArgumentParser(prog=f"studies/{name}.py", description=doc)
    ap.add_argument("--data", default=os.environ.get("EXOTUNE_STUDY_DATA",
                                                     os.path.join(tempfile.gettempdir(), "exotune-studies")))
    ap.add_argument("--results", default=str(ROOT / "results"))
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--resume", action="store_true")
    return ap.parse_args()


def run_study(name: str, spec: str, doc: str, extra) -> Path:
    """Sweep ``studies/<spec>``, report into results/<name>/, then ``extra(df, manifest, out)``."""
    args = parse_args(name, doc)
    data = Path(args.data) / name
    if data.exists() and not args.resume:
        if not (data / "manifest.json").exists():
            sys.exit(f"{data} exists and is not a sweep directory; refusing to delete it")
        shutil.rmtree(data)
    t0 = time.perf_counter()
    progress = TqdmProgress(sys.stderr) if sys.stderr.isatty() else None
    manifest = run_sweep(HERE / spec, data, workers=args.workers, progress=progress).to_dict()
    t_sweep = time.perf_counter() - t0
    out = Path(args.results) / name
    if out.exists():
        shutil.rmtree(out)
    make_report(data, out)
    df = load_results(data)
    extra(df, load_manifest(data), out)
    run = manifest["runs"][-1]
    print(f"{name}: {manifest['n_points']} designs ({run['points_computed']} computed now, "
          f"{run['chunks_skipped']} chunks resumed) in {t_sweep:.1f} s, {args.workers} workers; results in {out}")
    return out


def robust_of(df) -> np.ndarray:
    from exotune.sweeps import robust_mask

    cols = {c: df[c].to_numpy() for c in df.columns}
    return robust_mask({c: v for c, v in cols.items() if c == "free_stable" or (
        (c.startswith("human") and c.endswith("_robust")) or (c.startswith("env") and (c.endswith("_stable") or c.endswith("_robust"))))})[0]


def runs(values, ok) -> str:
    """Consecutive runs of values where ok, e.g. '1.5 … 4.4, 9.4 … 20'."""
    return value_runs(values, ok, digits=3)


def write_study_md(out: Path, lines: list, manifest: dict) -> None:
    """study.md with the provenance footer (spec hash, exotune version), written atomically."""
    lines = list(lines) + ["", f"Spec hash `{manifest['spec_hash']}`, exotune {manifest['exotune_version']}."]
    write_atomic(out / "study.md", "\n".join(lines) + "\n")


def save_png(fig, path: Path) -> None:
    """Render with the shared look (exotune.plots.style: dpi, nothing cut off) and write atomically."""
    import matplotlib.pyplot as plt

    from exotune.plots.style import png

    data = png(fig)
    plt.close(fig)
    write_atomic(path, data)


def key_metrics(df, manifest: dict) -> dict:
    """{column: (values in display units, colour-bar label, log, cmap)} of the report's key metrics
    present in ``df``: the DOB margins, the phase excess, the bandwidth and the per-family lightest
    stable inertia / stiffest stable spring (exotune.sweeps.metrics)."""
    import pyarrow as pa

    from exotune.sweeps.metrics import METRICS, derived_metrics

    out = {}
    for c, (_title, unit, factor, _worst, cmap) in METRICS.items():
        if c in df.columns:
            v = df[c].to_numpy(dtype=float) * factor
            if not np.all(np.isnan(v)):
                out[c] = (v, f"{c} [{unit}]", False, cmap)
    cols = [c for c in df.columns if c.endswith("_stable_intervals")]
    for k, (v, info) in derived_metrics(pa.Table.from_pandas(df[cols], preserve_index=False), manifest).items():
        out[k] = (np.asarray(v, float) * info["factor"], f"{k} [{info['unit']}]", info["log"], info["cmap"])
    return out


def slice_grid(df, values: np.ndarray, xcol: str, xs, ycol: str, ys, where) -> np.ndarray:
    """grid[iy, ix] of ``values`` over ``xcol`` × ``ycol`` for the rows selected by ``where``."""
    g = np.full((len(ys), len(xs)), np.nan)
    ix = np.searchsorted(np.asarray(xs), df[xcol].to_numpy())
    iy = np.searchsorted(np.asarray(ys), df[ycol].to_numpy())
    g[iy[where], ix[where]] = values[where]
    return g


def replace_report_figure(out: Path, old: str, new: str, why: str) -> None:
    """Remove the generic report's ``old`` figure and point its line in summary.md to ``new``
    (the study's informative replacement), saying why."""
    (out / old).unlink(missing_ok=True)
    md = out / "summary.md"
    lines = md.read_text().splitlines()
    for i, line in enumerate(lines):
        if line.startswith(f"- [{old}]"):
            lines[i] = f"- [{new}]({new}): replaces `{old}` ({why})"
    write_atomic(md, "\n".join(lines) + "\n")


def plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as p

    return p
