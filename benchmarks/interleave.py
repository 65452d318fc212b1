"""Benchmark: the sweep's sampled-data columns of two source trees (two commits), timed in two
long-lived processes that take turns — the fair before/after comparison on a shared machine whose
speed drifts by ±30 % within minutes (a slow phase then hits both sides alike).

    git worktree add --detach ../before <commit>
    python benchmarks/interleave.py ../before . [--designs 300] [--rate 1000] [--runs 12]

Each process imports exotune from its tree, builds the same random designs as
``benchmarks/sampled_sweep.py`` (seed 0, one-sample delay), computes the columns once outside the
timing (imports, compiled kernels), then times ``sampled_columns`` once per turn (CPU time of the
process); the order within a turn alternates. The last line gives both sides' minimum and median
CPU ms per design and the median of the pairwise ratios (after / before).
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
from pathlib import Path

_WORKER = r'''
import os, sys
for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(k, "1")
sys.path.insert(0, sys.argv[1])
sys.path.insert(1, sys.argv[2])
import time
import sampled_sweep
from exotune.analysis import analyze_batch
from exotune.sweeps.sampledcols import sampled_columns
n, rate = int(sys.argv[3]), float(sys.argv[4])
_raw, _axes, cfg = sampled_sweep._designs(n, rate, 1.0, 0)
res = analyze_batch(cfg, latency=True)
sampled_columns(cfg, res)
print("ready", flush=True)
for _line in sys.stdin:
    t = time.process_time()
    sampled_columns(cfg, res)
    print((time.process_time() - t) / n * 1e3, flush=True)
'''


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("before", type=Path, help="source tree of the earlier commit (holds exotune/)")
    ap.add_argument("after", type=Path, help="source tree of the later commit")
    ap.add_argument("--designs", type=int, default=300)
    ap.add_argument("--rate", type=float, default=1000.0)
    ap.add_argument("--runs", type=int, default=12)
    a = ap.parse_args()
    here = str(Path(__file__).resolve().parent)
    procs = [subprocess.Popen([sys.executable, "-c", _WORKER, str(tree.resolve()), here, str(a.designs), str(a.rate)],
                              stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True) for tree in (a.before, a.after)]
    try:
        for p in procs:
            if p.stdout.readline().strip() != "ready":
                raise SystemExit("a worker failed to start")
        times: tuple[list, list] = ([], [])
        for r in range(a.runs):
            for i in ((0, 1) if r % 2 == 0 else (1, 0)):
                procs[i].stdin.write("go\n")
                procs[i].stdin.flush()
                times[i].append(float(procs[i].stdout.readline()))
    finally:
        for p in procs:
            p.stdin.close()
            p.wait()
    ratio = statistics.median(b / x for x, b in zip(*times))
    print(f"sampled columns, {a.designs} designs at {a.rate:g} Hz, {a.runs} interleaved runs (CPU ms/design): "
          f"before min {min(times[0]):.2f} median {statistics.median(times[0]):.2f}; after min {min(times[1]):.2f} "
          f"median {statistics.median(times[1]):.2f}; after/before: median of pairwise ratios {ratio:.3f}")


if __name__ == "__main__":
    main()
