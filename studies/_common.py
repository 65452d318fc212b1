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
from exotune.sweeps import TqdmProgress, load_manifest, load_results, make_report, run_sweep, value_runs  # noqa: E402


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
    manifest = run_sweep(HERE / spec, data, workers=args.workers, progress=progress)
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
    import io

    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    write_atomic(path, buf.getvalue())


def plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as p

    return p
