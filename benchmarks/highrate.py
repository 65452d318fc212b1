"""Benchmark: export, certify and simulate at high sample rates (issue 15: "100 kHz export and
simulate under 30 s", "10 kHz runs within 2x of a plain linear simulation").

    python benchmarks/highrate.py [--rates 10000 100000] [--skip-export]

Per rate it prints

* ``export`` of examples/scheduled.yaml (the file and its five gain-schedule entries, every
  sampled-data analysis) and ``certify`` of the written file: seconds and the verdict;
* ``simulate`` of examples/paper.yaml, every scenario: seconds, and the ratio to a *plain linear
  simulation* of the same number of samples run in the same process — python-control's
  ``forced_response`` of the scenario's linearized sampled-data loop (the exact ZOH plant, the
  delay line and the file's controller as one discrete state space; dob-friction and saturation
  run twice, with and without the DOB / the clamp, so their reference runs twice too). The
  reference knows nothing of friction, backlash or saturation; it is the floor a per-sample
  nonlinear simulation is measured against.

Timings are wall-clock on whatever machine runs this; compare ratios, not seconds.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import exotune  # noqa: E402
from exotune.controllerfile import build_export, design_at_rate, discrete_from_file, plant_from_file  # noqa: E402
from exotune.config import load_design  # noqa: E402
from exotune.sampled.loop import closed_loop_matrix, plant_ss  # noqa: E402
from exotune.simulation.scenarios import SCENARIOS  # noqa: E402

RUNS = {"dob-friction": 2, "saturation": 2}  # scenarios that simulate twice (with and without)


def reference_seconds(doc: dict, scenario, samples: int) -> float:
    """python-control forced_response of the scenario's linear sampled-data loop over ``samples``."""
    import control

    plant, ctrl = plant_from_file(doc), discrete_from_file(doc)
    A, B, C = plant_ss(plant, scenario.human, "locked" if scenario.locked else "free")
    M = closed_loop_matrix(A, B, C, ctrl)
    n = M.shape[0]
    Bin = np.zeros((n, 1))
    Bin[0, 0] = 1.0  # one input: its column does not change the cost
    sys_d = control.ss(M, Bin, np.eye(n)[:1], np.zeros((1, 1)), 1.0 / ctrl.sample_rate_hz)
    u = np.ones(samples)
    t0 = time.perf_counter()
    control.forced_response(sys_d, U=u)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rates", type=float, nargs="+", default=[10000.0, 100000.0])
    ap.add_argument("--skip-export", action="store_true")
    a = ap.parse_args()
    for fs in a.rates:
        print(f"== {fs:g} Hz")
        if not a.skip_export:
            with tempfile.TemporaryDirectory() as d:
                out = Path(d) / "c.yaml"
                t0 = time.perf_counter()
                exotune.export(ROOT / "examples" / "scheduled.yaml", fs, out)
                t1 = time.perf_counter()
                cert = exotune.certify(out)
                t2 = time.perf_counter()
            print(f"export scheduled.yaml   {t1 - t0:7.2f} s")
            print(f"certify                 {t2 - t1:7.2f} s   certified: {cert.certified}")
        doc = build_export(design_at_rate(load_design(ROOT / "examples" / "paper.yaml").raw, fs), fs, analyses=False)
        for name, sc in SCENARIOS.items():
            t0 = time.perf_counter()
            run = exotune.simulate(ROOT / "examples" / "paper.yaml", name, sample_rate_hz=fs)
            t = time.perf_counter() - t0
            ref = RUNS.get(name, 1) * reference_seconds(doc, sc, int(round(sc.duration_s * fs)))
            verdict = run.to_dict()["summary"].get("verdict")
            print(f"simulate {name:14s} {t:7.2f} s   linear python-control reference {ref:6.2f} s   "
                  f"ratio {t / ref:5.2f}   verdict {verdict}")


if __name__ == "__main__":
    main()
