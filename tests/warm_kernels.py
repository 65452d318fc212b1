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


def _batch(name: str):
    from exotune.config import batch_config, load_design

    cfg = load_design(ROOT / "examples" / f"{name}.yaml")
    return batch_config(cfg, {"design.amplification": np.array([4.0, 8.0])})


def latency() -> None:
    """The latency column's kernel: the analysis it needs runs on the numpy engine (nothing to
    compile), then the margins on the compiled one."""
    from exotune.analysis import analyze_batch
    from exotune.analysis.charfun import char_terms
    from exotune.analysis.latency import batch_latency_margin
    from exotune.model.controller import build_controller
    from exotune.numerics.engine import numpy_engine

    for name in ("paper", "scheduled"):
        cfg = _batch(name)
        with numpy_engine():
            ok = analyze_batch(cfg).loops_ok()
        cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
        batch_latency_margin(char_terms(cfg.plant, cs, 2), cfg.humans, cfg.environment, ok)


def passivity() -> None:
    """The passivity kernels: the human side's frequency set on the numpy engine, then the
    passivity analysis on the compiled one."""
    from exotune.analysis.charfun import char_terms
    from exotune.analysis.intervals import FamilySide
    from exotune.analysis.operator_passivity import passivity as passivity_of
    from exotune.model.controller import build_controller
    from exotune.numerics.engine import numpy_engine

    for name in ("paper", "scheduled"):
        cfg = _batch(name)
        cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
        side = FamilySide(char_terms(cfg.plant, cs, 2), "00", "10", [e for f in cfg.humans for e in f.edges()])
        with numpy_engine():
            side.compute_leaves((0.0, 0.0, 0.0))
        passivity_of(side)


def continuous() -> None:
    """The latency column's kernel (:func:`latency`), then the continuous-time batch analysis
    (sweeps, optimize), whose passivity kernels the other process compiles first: by the time
    this one reaches them they are in the cache."""
    from exotune.analysis import analyze_batch

    latency()
    for name in ("paper", "scheduled"):
        analyze_batch(_batch(name))


def sampled() -> None:
    """The passivity kernels (:func:`passivity`), then the sampled-data loops of a batch (the
    sweep's ``sampled: true`` columns): about the other process's compilation time."""
    from exotune.sweeps.sampledcols import sampled_columns

    passivity()
    sampled_columns(_batch("scheduled"), SimpleNamespace(n=2, latency_margin_s=None))


if __name__ == "__main__":
    {"continuous": continuous, "sampled": sampled}[sys.argv[1]]()
