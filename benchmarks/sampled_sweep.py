"""Benchmark: the sweep's exact sampled-data columns (``sampled: true``), per design, against
``exotune certify``'s per-design analysis (sampled_analysis + sampled_latency_margin) in the same
process, and — with ``--compare`` — their agreement (verdicts, interval ends, margin).

    python benchmarks/sampled_sweep.py [--designs 40] [--rate 1000] [--seed 0] [--certify 4] [--compare]

Designs: random around examples/scheduled.yaml (plant section, the mass and spring humans, a
one-sample delay by default: ``--delay-samples 1``), amplification, ζ̂ and the G_v cutoff drawn at
random. One core (BLAS limited to one thread). The last line is the benchmark line::

    sampled columns: X ms/design at R Hz (N designs); certify: Y ms/design (M designs); ratio Y/X

``--compare`` (slow: certify on every design, margins tightened to 1e-6) runs the agreement check of
tests/sweeps/test_sampled_columns.py on ``--designs`` designs (use it for 10³).
"""

from __future__ import annotations

import os

for _k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_k, "1")

import argparse  # noqa: E402
import copy  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def _designs(n: int, fs: float, delay_samples: float, seed: int):
    from exotune.config import batch_config, design_from_mapping, load_design

    raw = copy.deepcopy(load_design(ROOT / "examples" / "scheduled.yaml").raw)
    raw.pop("transmission", None)
    raw["humans"] = raw["humans"][:2]
    raw["implementation"]["sample_rate_hz"] = fs
    raw["implementation"]["delay_s"] = delay_samples / fs
    rng = np.random.default_rng(seed)
    axes = {"design.amplification": rng.uniform(2.0, 14.0, n), "design.zeta_hat": rng.uniform(0.3, 1.2, n),
            "implementation.gv_filter.cutoff_hz": rng.uniform(40.0, min(200.0, 0.4 * fs), n)}
    return raw, axes, batch_config(design_from_mapping(raw), axes)


def _doc(raw, axes, i, fs):
    from exotune.config import design_from_mapping
    from exotune.controllerfile.export import build_export

    r = copy.deepcopy(raw)
    for path, v in axes.items():
        *sec, key = path.split(".")
        d = r
        for s in sec:
            d = d[s]
        d[key] = float(v[i])
    return build_export(design_from_mapping(r), fs, analyses=False)


def _certify(doc):
    from exotune.controllerfile import latency
    from exotune.controllerfile.certify import sampled_analysis
    from exotune.controllerfile.fileio import position_feedback

    sa = sampled_analysis(doc)
    return sa, latency.sampled_latency_margin(doc, sa, position_feedback(doc["controller"]), sampled_analysis)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--designs", type=int, default=40)
    ap.add_argument("--rate", type=float, default=1000.0)
    ap.add_argument("--delay-samples", type=float, default=1.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--certify", type=int, default=4, help="designs certify analyses for the ratio")
    ap.add_argument("--compare", action="store_true")
    a = ap.parse_args()
    from exotune.analysis import analyze_batch
    from exotune.sweeps.sampledcols import sampled_columns

    raw, axes, b = _designs(a.designs, a.rate, a.delay_samples, a.seed)
    cols = analyze_batch(b, latency=True)
    t = time.perf_counter()
    sc = sampled_columns(b, cols)
    ours = (time.perf_counter() - t) / a.designs
    ncert = a.designs if a.compare else min(a.certify, a.designs)
    if a.compare:
        from exotune.controllerfile import latency

        latency.REL = 1e-6  # a tighter reference than certify's 1e-3
    t = time.perf_counter()
    refs = [_certify(_doc(raw, axes, i, a.rate)) for i in range(ncert)]
    theirs = (time.perf_counter() - t) / max(ncert, 1)
    if a.compare:
        bad = 0
        for i, (sa, lm) in enumerate(refs):
            for j, h in enumerate(sa["humans"]):
                if "skipped" in h:
                    continue
                got = sc[f"sampled_human{j}_{h['kind']}_robust"][i]
                near = any(abs(x - 1.0) < 1e-6 for x in (sa["free_spectral_radius"], sa["locked_spectral_radius"]))
                if bool(got) != bool(h["robust"]) and not near:
                    bad += 1
                    print(f"design {i}: human{j} robust {got} (certify {h['robust']})")
            m, r = sc["sampled_latency_margin_samples"][i], lm["extra_delay_samples"]
            if r is not None and not abs(m - r) <= 1e-4 * abs(r):
                bad += 1
                print(f"design {i}: margin {m:.9g} samples (certify {r:.9g})")
        print(f"agreement: {a.designs - bad} of {a.designs} designs")
    robust = float(np.mean(sc["sampled_latency_margin_samples"] > 0))
    print(f"sampled columns: {ours * 1e3:.1f} ms/design at {a.rate:g} Hz ({a.designs} designs, {robust:.0%} with a margin > 0); "
          f"certify: {theirs * 1e3:.1f} ms/design ({ncert} designs); ratio {theirs / ours:.2f}")


if __name__ == "__main__":
    main()
