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

* ``certify`` of the template (``exotune init``'s design.yaml) at 20 kHz with its 1 ms delay (20
  whole samples; ``--certify-rate`` changes the rate), CPU and wall seconds of a warm run, beside
  a *point-wise reference* in the same process: python-control's ZOH (``c2d``) of the plant, the
  delay as z^-d and the file's controller closed by ``control.feedback``, numpy eigenvalues, at the
  free and locked loops and certify's 96 log-spaced members of each rational human family — the
  verdicts alone, without certify's step control between the members, its interval ends, its
  rounding estimates or its latency margin (issue 23, item 5: "under 3 s").

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
from exotune.controllerfile import build_export, design_at_rate  # noqa: E402
from exotune.controllerfile.fileio import discrete_from_file, plant_from_file  # noqa: E402
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


def pointwise_reference(doc: dict) -> tuple[float, int, bool]:
    """(seconds, loops, every loop stable) of a point-wise check of a controller file with a
    whole-sample delay, built with python-control, not with exotune's loop assembly: the free and
    locked loops and certify's ``POINTS`` log-spaced members of each rational human family; the
    rigid-body z = 1 of an ungrounded loop set aside as certify does."""
    import control

    from exotune.config import parse_human
    from exotune.controllerfile.certify import POINTS, position_feedback

    plant, ctrl = plant_from_file(doc), discrete_from_file(doc)
    Ts, d = 1.0 / ctrl.sample_rate_hz, round(ctrl.delay_s * ctrl.sample_rate_hz)
    assert abs(d - ctrl.delay_s * ctrl.sample_rate_hz) < 1e-9, "the reference takes whole-sample delays only"
    K = control.ss(ctrl.Ac, ctrl.Bc, ctrl.Cc, ctrl.Dc, Ts)
    delay = control.ss(control.tf([1.0], [1.0] + [0.0] * d, Ts))
    loops = [(None, "free"), (None, "locked")]
    for i, item in enumerate(doc["certify"]["humans"]):
        fam, _ = parse_human(i, item)
        if fam.kind != "complex_stiffness" and not fam.box:
            fixed = {k: v for k, v in fam.fixed().items() if k in ("inertia", "damping", "stiffness")}
            loops += [({**fixed, fam.param: float(v)}, "free") for v in np.geomspace(fam.lo, fam.hi, POINTS)]
    feedback = position_feedback(doc["controller"])
    t0, ok = time.perf_counter(), True
    for human, env in loops:
        A, B, C = plant_ss(plant, human, env)
        P = control.c2d(control.ss(A, B, C, np.zeros((C.shape[0], 1))), Ts, "zoh")
        lam = np.linalg.eigvals(control.feedback(P * delay, K, sign=1).A)
        grounded = feedback or env == "locked" or (human or {}).get("stiffness", 0.0) > 0
        i = int(np.argmin(np.abs(lam - 1.0)))
        if not grounded and abs(lam[i] - 1.0) <= 1e-7:
            lam = np.delete(lam, i)
        ok = ok and bool(np.max(np.abs(lam)) < 1.0)
    return time.perf_counter() - t0, len(loops), ok


def certify_line(fs: float) -> None:
    """The template at ``fs`` (its 1 ms delay), exported, then certified (a warm run: CPU and
    wall seconds) beside :func:`pointwise_reference`."""
    from exotune.controllerfile import load_controller
    from exotune.starter import template_text

    with tempfile.TemporaryDirectory() as d:
        design, out = Path(d) / "design.yaml", Path(d) / "c.yaml"
        design.write_text(template_text("design.yaml").replace("sample_rate_hz: 1000.0", f"sample_rate_hz: {fs:g}"))
        exotune.export(design, fs, out)
        exotune.certify(out)  # imports and first-call costs out of the timing
        w0, c0 = time.perf_counter(), time.process_time()
        cert = exotune.certify(out)
        wall, cpu = time.perf_counter() - w0, time.process_time() - c0
        ref, loops, ok = pointwise_reference(load_controller(out))
    samples = cert.to_dict()["delay_s"] * fs
    print(f"certify template at {fs:g} Hz ({samples:g}-sample delay)   {cpu:6.2f} s CPU {wall:6.2f} s wall   "
          f"certified: {cert.certified}   point-wise python-control reference ({loops} loops) {ref:6.2f} s   "
          f"all stable: {ok}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rates", type=float, nargs="+", default=[10000.0, 100000.0])
    ap.add_argument("--skip-export", action="store_true")
    ap.add_argument("--certify-rate", type=float, default=20000.0)
    a = ap.parse_args()
    certify_line(a.certify_rate)
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
