"""Compile numba's on-disk cache of the analysis kernels before the suite's workers start
(tests/conftest.py runs ``python tests/warm_kernels.py continuous`` and ``… sampled`` side by
side, once, under ``pytest -n``): on a fresh checkout every worker, and every command a test starts
in a child process before the cache exists, would otherwise compile the same kernels again (about
a minute and a half of CPU each on a 2-core machine). Whatever this misses compiles when first used,
as before; failures here only cost that time (the suite decides nothing from this script)."""

from __future__ import annotations

import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def continuous() -> None:
    """The continuous-time batch analysis with its latency column (sweeps, optimize)."""
    from exotune.analysis import analyze_batch
    from exotune.config import batch_config, load_design

    for name in ("paper", "scheduled"):
        cfg = load_design(ROOT / "examples" / f"{name}.yaml")
        analyze_batch(batch_config(cfg, {"design.amplification": np.array([4.0, 8.0])}), latency=True)


def sampled() -> None:
    """The sampled-data loops of a batch (the sweep's ``sampled: true`` columns), without the
    continuous analysis (compiled by the other process)."""
    from exotune.config import batch_config, load_design
    from exotune.sweeps.sampledcols import sampled_columns

    cfg = load_design(ROOT / "examples" / "scheduled.yaml")
    cfg = batch_config(cfg, {"design.amplification": np.array([4.0, 8.0])})
    sampled_columns(cfg, SimpleNamespace(n=2, latency_margin_s=None))


if __name__ == "__main__":
    {"continuous": continuous, "sampled": sampled}[sys.argv[1]]()
