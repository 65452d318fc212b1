"""Benchmark: cost per design of the two margins (issue 14), against a python-control per-point
reference.

    python benchmarks/margins.py [--designs 6] [--seed 0] [--no-latency] [--no-box] [--budget 150000]

Designs: examples/scheduled.yaml (its transmission schedule ignored: plant section only), the same
with an msd box human (12 edge loops) and random designs around it (amplification, felt inertia/damping, delay, DOB cutoff or none, lightest
human inertia, sometimes an environment spring), kept when robust at the nominal plant. Per
design it prints

* ``latency_margin`` time [s] and value [ms];
* ``plant_uncertainty_margin`` time [s], certified lower and witnessed upper bounds, their ratio,
  the interval evaluations spent and the critical loop;
* the python-control reference: one closed-loop eigenvalue computation (block-diagram
  interconnection of plant, PD blocks, DOB with the nominal model, 10th-order Padé delay) for one
  plant of the box, free exoskeleton — and the margin's cost expressed in such points.

A vertex search alone with python-control (32 vertices × 33 members × 4 loops × ~12 bisection
steps ≈ 50 000 points) answers only the upper bound, with a Padé delay.
"""

from __future__ import annotations

import os

for _k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_k, "1")

import argparse  # noqa: E402
import copy  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))  # the independent python-control reference model

import exotune  # noqa: E402
from exotune.analysis.batch import analyze_batch  # noqa: E402
from exotune.analysis.latency_margin import latency_margin  # noqa: E402
from exotune.analysis.plant_margin import plant_uncertainty_margin  # noqa: E402
from exotune.config import design_from_mapping  # noqa: E402
from exotune.model.controller import build_controller  # noqa: E402


def random_design(rng, base: dict):
    """A random design around examples/scheduled.yaml (no transmission schedule)."""
    m = copy.deepcopy(base)
    m.pop("transmission", None)
    m["design"].update(amplification=float(rng.uniform(2, 10)), felt_inertia=float(rng.uniform(0.1, 0.5)),
                       felt_damping=float(rng.uniform(0.5, 3)))
    m["implementation"]["delay_s"] = float(rng.uniform(2e-4, 1.5e-3))
    no_dob = rng.random() < 0.3
    m["implementation"]["dob"] = None if no_dob else {"cutoff_hz": float(rng.uniform(20, 80)), "damping": 0.7}
    m["humans"][0]["inertia"] = [float(rng.uniform(0.02, 0.2)), 1.0]
    if rng.random() < 0.3:
        m["environment"] = [{"kind": "locked"}, {"kind": "spring", "stiffness": [10.0, 5000.0], "damping": 1.0}]
    return design_from_mapping(m)


def box_design(base: dict):
    """scheduled.yaml with an msd box human (inertia × damping × stiffness: 12 edge loops) and an
    environment mass family."""
    m = copy.deepcopy(base)
    m.pop("transmission", None)
    m["humans"] = [{"kind": "msd", "inertia": [0.05, 1.0], "damping": [0.5, 5.0], "stiffness": [10.0, 500.0]}]
    m["environment"] = [{"kind": "locked"}, {"kind": "mass", "inertia": [0.01, 2.0], "damping": 0.5}]
    return design_from_mapping(m)


def robust(res) -> bool:
    return bool(res.loops_ok()[0])


def pc_free_loop_eigs(q, cs, dob_model, order=10):
    """python-control reference for one plant q = (J_m, B_m, K_s, J_j, K_c): closed-loop
    eigenvalues of the free exoskeleton (tests/reference_model.py, the tests' construction)."""
    from reference_model import free_loop_eigs_mismatched_dob

    return free_loop_eigs_mismatched_dob(q, cs, dob_model, order)


def point_cost(cfg, reps: int = 20) -> float:
    """Seconds per python-control reference point (median of ``reps`` random plants of the box)."""
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    q0 = np.array([float(getattr(cfg.plant, f)) for f in
                   ("motor_inertia", "motor_damping", "sea_stiffness", "joint_inertia", "cuff_stiffness")])
    rng = np.random.default_rng(0)
    ts = []
    for _ in range(reps):
        q = q0 * (1 + rng.uniform(-0.2, 0.2, 5))
        t = time.perf_counter()
        pc_free_loop_eigs(q, cs, (q0[0], q0[1]))
        ts.append(time.perf_counter() - t)
    return float(np.median(ts))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--designs", type=int, default=6, help="random robust designs besides the example")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--budget", type=int, default=150_000)
    ap.add_argument("--no-latency", action="store_true", help="skip the latency margin")
    ap.add_argument("--no-box", action="store_true", help="skip the design with an msd box human (12 edges)")
    a = ap.parse_args(argv)
    warnings.simplefilter("ignore")
    base_cfg = exotune.load_design(ROOT / "examples" / "scheduled.yaml")
    rng = np.random.default_rng(a.seed)
    designs = [("scheduled.yaml", base_cfg)]
    if not a.no_box:
        designs.append(("msd-box", box_design(base_cfg.raw)))
    extra = len(designs) - 1
    while len(designs) < a.designs + 1 + extra:
        cfg = random_design(rng, base_cfg.raw)
        if robust(analyze_batch(cfg)):
            designs.append((f"random{len(designs)}", cfg))
    print(f"{'design':<15} {'latency s':>9} {'ΔT ms':>8} {'plant s':>8} {'lower':>8} {'upper':>8} {'ratio':>7} "
          f"{'evals':>8} {'critical':<26} {'pc pt ms':>8} {'≈ pc pts':>8}")
    tot_l = tot_p = 0.0
    ratios = []
    for name, cfg in designs:
        with np.errstate(all="ignore"):
            cols = analyze_batch(cfg)
            tl, lm = 0.0, None
            if not a.no_latency:
                t = time.perf_counter()
                lm = latency_margin(cfg, nominal=cols)
                tl = time.perf_counter() - t
            t = time.perf_counter()
            pm = plant_uncertainty_margin(cfg, nominal=cols, budget=a.budget)
            tp = time.perf_counter() - t
        pc = point_cost(cfg)
        tot_l += tl
        tot_p += tp
        ratios.append(pm.ratio)
        crit = pm.witness.loop if pm.witness else "-"
        dt = f"{lm.extra_delay_s * 1e3:8.4g}" if lm is not None else f"{'-':>8}"
        print(f"{name:<15} {tl:9.2f} {dt} {tp:8.2f} {pm.lower:8.4g} {pm.upper:8.4g} {pm.ratio:7.4f} "
              f"{pm.evaluations:8d} {crit:<26} {pc * 1e3:8.2f} {tp / pc:8.0f}", flush=True)
    n = len(designs)
    print(f"mean per design: latency {tot_l / n:.2f} s, plant {tot_p / n:.2f} s; "
          f"worst upper/lower {max(ratios):.4f}")
    sweep_column_cost(base_cfg, a.seed)
    return 0


def sweep_column_cost(base_cfg, seed: int, n: int = 4096) -> None:
    """The sweep column ``latency_margin_s``: one batch of ``n`` random designs around the example
    analysed with and without it (compiled engine, after a warm-up), per design and as a ratio."""
    from exotune.config import batch_config

    rng = np.random.default_rng(seed)
    vals = {"design.amplification": rng.uniform(2.0, 12.0, n), "design.zeta_hat": rng.uniform(0.3, 1.4, n),
            "implementation.delay_s": rng.uniform(0.0, 0.004, n)}
    b = batch_config(base_cfg, vals)
    with np.errstate(all="ignore"):
        analyze_batch(b, latency=True)  # warm-up (JIT)
        t = time.perf_counter()
        analyze_batch(b)
        t0 = time.perf_counter() - t
        t = time.perf_counter()
        cols = analyze_batch(b, latency=True)
        t1 = time.perf_counter() - t
    robust_n = int(np.count_nonzero(cols.latency_margin_s > 0))
    print(f"sweep column latency_margin_s: {n} designs ({robust_n} robust), analysis {t0 / n * 1e6:.0f} µs/design, "
          f"with the column {t1 / n * 1e6:.0f} µs/design: ×{t1 / t0:.2f} "
          f"(≈ {(t1 - t0) / max(robust_n, 1) * 1e6:.0f} µs per robust design)")


if __name__ == "__main__":
    raise SystemExit(main())
