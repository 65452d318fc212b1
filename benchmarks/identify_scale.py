"""Benchmark: ``exotune identify`` on a long, fast log (issue 26 item 7: "a 60 s, 10 kHz log in
≤ 2 s and ≤ 300 MB").

    python benchmarks/identify_scale.py [--seconds 60] [--rate 10000] [--repeat 2] [--keep LOG.csv]

The log is simulated here, independently of exotune's identification code: the plant of
tests/identification/simulated_logs.py (the paper's motor and SEA, a person on the cuff) driven
by a held command (a 25-line multisine plus broadband noise, applied one sample after it is
logged) and the person's own torque, discretized exactly with a zero-order hold and run mode by
mode through ``scipy.signal.lfilter`` (``command_log``); sensor noise at the documented level (encoders 2e-6 rad,
torque sensors 0.02 N·m). It is written as CSV with every column the identification reads
(t, tau_cmd, theta_m, tau_s, theta_j, tau_c, theta_h), as the rig would log it.

Each measurement runs in a fresh child process (so that its peak RSS is its own, not the
simulation's) and prints:

* ``identify_file``: the whole command as ``exotune identify LOG.csv --delay-s 1e-4`` runs it
  (read, identify, validate), wall seconds and CPU seconds, the first call in the process (after
  the imports: numpy, scipy.signal, pyarrow; they are the start-up of every exotune process);
* then the same work again by parts: ``read`` (:func:`exotune.identification.read_log`),
  ``identify`` (:func:`exotune.identification.identify_plant`: every equation, the delay's
  neighbours, the friction and errors-in-variables diagnostics) and ``validate``
  (:func:`exotune.identification.validate_plant` on the fitting log: residual tests and frequency
  responses, as every ``exotune identify`` run does);

then the peak RSS of the child during ``identify_file`` (VmHWM of /proc/self/status: ``resource.getrusage``'s ru_maxrss
would carry the parent's peak over the spawn), its peak RSS after the imports
(the baseline every exotune process pays), and in a second child the peak of the allocations
``tracemalloc`` sees during ``identify_file`` (numpy arrays included). Last, the estimates
against the truth in standard errors. Timings are wall-clock on whatever machine runs this.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

TARGET_S, TARGET_MB = 2.0, 300.0


def simulate(seconds: float, fs: float, seed: int = 0) -> dict:
    """The columns of a held-command log (module docstring)."""
    from identification.simulated_logs import command_log

    rng = np.random.default_rng(seed)
    t = np.arange(int(round(seconds * fs))) / fs
    f = np.geomspace(0.3, 40.0, 25)
    ph = rng.uniform(0, 2 * np.pi, f.size)
    cmd = 0.5 * rng.standard_normal(t.size)
    for fk, pk in zip(f, ph):
        cmd += 0.6 * np.sin(2 * np.pi * fk * t + pk)
    return command_log(cmd, fs, delay=1, noise=True, seed=seed)


def write_csv(path: Path, cols: dict) -> None:
    """The log as the rig writes it: 17 significant digits, t with 7 decimals."""
    import pandas as pd

    df = pd.DataFrame({k: v for k, v in cols.items()})
    df.to_csv(path, index=False, float_format="%.17g")


def peak_rss_mb() -> float:
    """This process's peak resident set [MiB]: VmHWM of /proc/self/status (Linux; the process's own
    memory: ``getrusage``'s ru_maxrss keeps the parent's peak across the spawn), else ru_maxrss."""
    try:
        with open("/proc/self/status") as fh:
            return next(int(line.split()[1]) for line in fh if line.startswith("VmHWM:")) / 1024.0
    except (OSError, StopIteration):
        import resource

        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def child(path: str, mode: str) -> None:
    """One measurement in this (fresh) process; prints one JSON line."""
    import exotune.identification as ident
    from exotune.identification import identify_file, identify_plant, read_log, validate_plant
    import pyarrow.compute  # noqa: F401  (imports, as scipy.signal's, are the process's start-up: out of the timing)
    import pyarrow.csv  # noqa: F401
    import scipy.signal  # noqa: F401

    out = {"baseline_mb": peak_rss_mb()}
    if mode == "tracemalloc":
        import tracemalloc

        tracemalloc.start()
        identify_file(path, delay_s=1e-4)
        out["tracemalloc_peak_mb"] = tracemalloc.get_traced_memory()[1] / 2 ** 20
        tracemalloc.stop()
    else:
        w0, c0 = time.perf_counter(), time.process_time()
        r = identify_file(path, delay_s=1e-4)  # the command's work: read, identify, validate (first call)
        out.update(file_s=time.perf_counter() - w0, file_cpu_s=time.process_time() - c0, samples=r.samples,
                   estimates={p.key: (p.value, p.std_error) for p in r.parameters}, warnings=list(r.to_dict()["warnings"]))
        out["peak_rss_mb"] = peak_rss_mb()
        del r
        t0 = time.perf_counter()
        log = read_log(path, delay_s=1e-4)
        t1 = time.perf_counter()
        est = identify_plant(log)
        t2 = time.perf_counter()
        validate_plant(est, log)
        out.update(read_s=t1 - t0, identify_s=t2 - t1, validate_s=time.perf_counter() - t2)
        del ident
    out.setdefault("peak_rss_mb", peak_rss_mb())
    print(json.dumps(out))


def run_child(path: Path, mode: str) -> dict:
    res = subprocess.run([sys.executable, __file__, "--child", str(path), "--mode", mode], capture_output=True, text=True,
                         check=True)
    return json.loads(res.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--rate", type=float, default=10000.0)
    ap.add_argument("--repeat", type=int, default=2, help="timing runs (each in a fresh process); the fastest counts")
    ap.add_argument("--keep", default=None, metavar="LOG.csv", help="keep the simulated log here")
    ap.add_argument("--child", default=None, help=argparse.SUPPRESS)
    ap.add_argument("--mode", default="time", help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.child:
        child(a.child, a.mode)
        return
    from identification.simulated_logs import TRUE

    with tempfile.TemporaryDirectory() as d:
        path = Path(a.keep) if a.keep else Path(d) / "log.csv"
        t0 = time.perf_counter()
        cols = simulate(a.seconds, a.rate)
        write_csv(path, cols)
        del cols
        print(f"log: {a.seconds:g} s at {a.rate:g} Hz, 7 columns, {path.stat().st_size / 2 ** 20:.0f} MiB CSV "
              f"(simulated and written in {time.perf_counter() - t0:.1f} s)")
        runs = [run_child(path, "time") for _ in range(max(1, a.repeat))]
        best = min(runs, key=lambda r: r["file_s"])
        mem = run_child(path, "tracemalloc")
    for r in runs:
        print(f"identify_file {r['file_s']:.2f} s wall ({r['file_cpu_s']:.2f} s CPU), peak RSS {r['peak_rss_mb']:.0f} MiB "
              f"(after the imports {r['baseline_mb']:.0f} MiB); again, by parts: read {r['read_s']:.2f} s, identify "
              f"{r['identify_s']:.2f} s, validate {r['validate_s']:.2f} s")
    print(f"tracemalloc peak during identify_file: {mem['tracemalloc_peak_mb']:.0f} MiB")
    print(f"{best['samples']} samples fitted; estimate − truth, in standard errors:")
    for k, (v, se) in best["estimates"].items():
        print(f"  {k}: {v:.6g} ± {se:.3g} ({(v - TRUE[k]) / se:+.2f} SE)")
    for w in best["warnings"]:
        print(f"  warning: {w}")
    ok_t, ok_m = best["file_s"] <= TARGET_S, max(r["peak_rss_mb"] for r in runs) <= TARGET_MB
    print(f"target ≤ {TARGET_S:g} s: {'met' if ok_t else 'NOT met'} ({best['file_s']:.2f} s); "
          f"≤ {TARGET_MB:g} MB peak RSS: {'met' if ok_m else 'NOT met'} ({max(r['peak_rss_mb'] for r in runs):.0f} MiB)")


if __name__ == "__main__":
    main()
