"""Benchmark: designs/s of exotune's vectorized ``analyze_batch`` vs a per-design python-control
workflow, in the same process.

    python benchmarks/analyze.py [--designs 2000] [--control-designs 20] [--seed 0]

exotune: ``analyze_batch`` on N random designs around examples/paper.yaml (every docs/method.md#analyses-and-metrics metric:
free stability, exact stable intervals of the three human families, locked output, passivity of
C7, DOB margins with the exact delay, amplification). two python-control
per-design workflows on a sample of the designs: the minimal one (benchmarks/_percontrol.py:
free-cuff poles, coupled poles for 50 inertias and 50 springs, Padé delay, and
``control.stability_margins`` of L_dob) and the one producing the same outputs as exotune
(benchmarks/_percontrol_full.py: intervals bisected to 1e-9, passivity, amplification, locked).
Prints the rates and both ratios.
"""

from __future__ import annotations

import os

for _k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_k, "1")

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

import numpy as np  # noqa: E402

from _percontrol import measure_rate, per_design  # noqa: E402
from _percontrol_full import per_design_full  # noqa: E402

from exotune.analysis import analyze_batch  # noqa: E402
from exotune.config import batch_config, load_design  # noqa: E402


def random_designs(n: int, seed: int):
    rng = np.random.default_rng(seed)
    lu = lambda a, b: np.exp(rng.uniform(np.log(a), np.log(b), n))  # noqa: E731
    return {
        "design.amplification": lu(1.5, 20.0),
        "design.zeta": rng.uniform(0.4, 1.1, n),
        "design.zeta_hat": rng.uniform(0.4, 1.1, n),
        "implementation.delay_s": rng.uniform(0.0, 0.003, n),
        "implementation.gv_filter.cutoff_hz": lu(40.0, 200.0),
        "implementation.dob.cutoff_hz": lu(20.0, 120.0),
        "plant.cuff_stiffness": lu(100.0, 2000.0),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--designs", type=int, default=2000)
    ap.add_argument("--control-designs", type=int, default=20)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()

    base = load_design(HERE.parent / "examples" / "paper.yaml")
    cfg = batch_config(base, random_designs(args.designs, args.seed))
    analyze_batch(batch_config(base, random_designs(8, args.seed + 1)))  # warm-up (imports, caches)
    # each side's best of two runs, interleaved (this shared machine's speed drifts)
    n_c = min(args.control_designs, args.designs)
    t_ex = rate_c = rate_f = None
    for _ in range(2):
        t0 = time.perf_counter()
        res = analyze_batch(cfg)
        t = time.perf_counter() - t0
        t_ex = t if t_ex is None else min(t_ex, t)
        rate_c = max(rate_c or 0.0, measure_rate(per_design, cfg, n_c))
        rate_f = max(rate_f or 0.0, measure_rate(per_design_full, cfg, n_c))
    rate_ex = args.designs / t_ex

    print(f"exotune {__import__('exotune').__version__}, python {sys.version.split()[0]}, {os.cpu_count()} CPUs "
          f"(all measured on one core, in this process)")
    print(f"exotune analyze_batch          : {args.designs:6d} designs in {t_ex:8.3f} s = {rate_ex:10.1f} designs/s "
          f"({1e3 / rate_ex:.3f} ms/design; every docs/method.md#analyses-and-metrics metric, exact intervals, exact delay)")
    print(f"python-control, minimal       : {n_c:6d} designs, {rate_c:10.2f} designs/s "
          f"({1e3 / rate_c:.1f} ms/design; 101 eigen-solves + stability_margins, Padé(8) delay)")
    print(f"python-control, same outputs  : {n_c:6d} designs, {rate_f:10.2f} designs/s "
          f"({1e3 / rate_f:.1f} ms/design; benchmarks/_percontrol_full.py)")
    print(f"ratio                          : exotune is {rate_ex / rate_c:.0f}× the minimal workflow, "
          f"{rate_ex / rate_f:.0f}× the same-outputs workflow")
    robust = np.mean(res.humans[0].robust), np.mean(res.humans[1].robust)
    print(f"(sanity: fraction robust — human0 mass {robust[0]:.3f}, human1 spring {robust[1]:.3f})")


if __name__ == "__main__":
    main()
