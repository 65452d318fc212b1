"""Benchmark: nanoseconds per ``exotune_step`` of the generated C ports, float64 and float32, on
adversarial inputs (issue 25 item 5), and their code size.

    python benchmarks/ctiming.py [--rate 1000] [--steps 200000] [--cc cc] [--cflags "-O2"] [--no-flush]

For examples/scheduled.yaml exported at ``--rate`` (six controllers: nominal and five gain-schedule
entries) it generates both ports (``implementation.precision`` float64, then float32), compiles each
with a small timing harness (``-std=c99 -ffp-contract=off`` and ``--cflags``) and prints, per port
and scenario, the time of one ``exotune_step`` (median, interquartile mean -- the mean of the
middle half, finer than the clock's granularity --, 99th percentile and maximum over
``--steps`` steps (the scenarios interleaved in blocks of 1000 steps, each with its own state, so
that a slower phase of a shared machine falls on all of them), each step timed alone, on x86 with the time-stamp counter calibrated against
``clock_gettime(CLOCK_MONOTONIC)``, elsewhere with that clock; the median cost of an empty timing
pair subtracted) and the return codes seen:

* ``normal``: random inputs of the sizes of the file's golden inputs;
* ``decay``: one impulse, then exact zeros (the states decay towards the subnormal range: flushed);
* ``subnormal``: double subnormals (5e-324 ... 1e-310) and float subnormals (1e-45 ... 1e-38);
* ``tiny``: values at 1 to 100 times the port's flush threshold (1e-100 / 1e-30), where products
  and sums of a step could still leave the normal range;
* ``huge``: 1e300 and, for float32, 3e38 (faults, or accepted where a signal is not amplified);
* ``nan``: NaN on one signal (a fault);
* ``switch``: ``exotune_schedule`` to another gain-schedule entry before every step (reset), and
  for float64 ``switch-bumpless`` (its state map and offset).

``--no-flush`` times the ports with their flush of tiny states and inputs removed from the generated
C (the function returns its argument), to show what the flush buys (not a build to deploy).

Then the size of each ``exotune_controller.o`` (``size -A``: .text, .rodata, .data, .bss) and the
tables per controller. Timings are wall-clock on whatever machine runs this (a shared machine is
noisy: compare the scenarios of one run, not runs); the maxima include the operating system's
interruptions.
"""

from __future__ import annotations

import argparse
import copy
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

HARNESS = r"""
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "exotune_controller.h"

static unsigned long long rng_state = 88172645463325252ULL;
static double uniform(void)  /* xorshift64: [0, 1) */
{
    rng_state ^= rng_state << 13; rng_state ^= rng_state >> 7; rng_state ^= rng_state << 17;
    return (double)(rng_state >> 11) * (1.0 / 9007199254740992.0);
}
static double gauss(void)
{
    double u = uniform() + 1e-12, v = uniform();
    return sqrt(-2.0 * log(u)) * cos(6.283185307179586 * v);
}
static double now_ns(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec * 1e9 + (double)t.tv_nsec;
}
#if defined(__x86_64__) || defined(__i386__)
#include <x86intrin.h>
#define TICKS() ((double)__rdtsc())  /* the time-stamp counter: ~1 ns resolution, calibrated below */
#else
#define TICKS() now_ns()
#endif
static double ns_per_tick(void)
{
    double t0 = now_ns(), c0 = TICKS(), t1, c1;
    do {
        t1 = now_ns();
        c1 = TICKS();
    } while (t1 - t0 < 5e7);
    return (t1 - t0) / (c1 - c0);
}
static int cmp(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}
static const double SCALE[5] = {SCALES};
static const double ANGLE[EXOTUNE_N_CONTROLLERS > 1 ? EXOTUNE_N_CONTROLLERS - 1 : 1] = {ANGLES_LIST};

/* the inputs of step k of a scenario */
static void inputs(const char *s, long k, double *x)
{
    int i;
    for (i = 0; i < 5; ++i) {
        double sign = uniform() < 0.5 ? -1.0 : 1.0;
        if (strcmp(s, "decay") == 0)
            x[i] = k == 0 ? SCALE[i] : 0.0;
        else if (strcmp(s, "subnormal") == 0)
            x[i] = sign * (k % 2 ? 5e-324 * (1.0 + 1e15 * uniform()) : 1.4e-45 * (1.0 + 8e6 * uniform()));
        else if (strcmp(s, "tiny") == 0)
            x[i] = sign * TINY * pow(100.0, uniform());
        else if (strcmp(s, "huge") == 0)
            x[i] = k % 2 ? sign * 1e300 : sign * 3e38;
        else if (strcmp(s, "nan") == 0)
            x[i] = i == (int)(k % 5) ? NAN : SCALE[i] * gauss();
        else
            x[i] = SCALE[i] * gauss();
    }
}

#define BLOCK 1000
/* argv: n, then the scenarios; they run interleaved, BLOCK steps each in turn (so that a slower phase of
 * a shared machine falls on all of them), each with its own state; one line per scenario */
int main(int argc, char **argv)
{
    long n = atol(argv[1]), k, done;
    int m = argc - 2, j;
    double *t = malloc(sizeof(double) * (size_t)(n * m)), over, x[5], u = 0.0, sink = 0.0;
    long *rc_count = calloc((size_t)(6 * m), sizeof(long));
    exotune_state *st = malloc(sizeof(exotune_state) * (size_t)m);
    double scale = ns_per_tick();
    if (t == 0 || rc_count == 0 || st == 0 || m < 1 || n < BLOCK)
        return 2;
    for (k = 0; k < n; ++k) {  /* the cost of an empty timing pair */
        double a = TICKS();
        t[k] = TICKS() - a;
    }
    qsort(t, (size_t)n, sizeof(double), cmp);
    over = t[n / 2];
    for (j = 0; j < m; ++j)
        if (exotune_init(&st[j], 0, 0.0) != EXOTUNE_OK)
            return 2;
    for (done = -n / 10 / BLOCK * BLOCK; done < n; done += BLOCK) {  /* a tenth of warm-up */
        for (j = 0; j < m; ++j) {
            const char *s = argv[2 + j];
            int mode = strcmp(s, "switch-bumpless") == 0 ? EXOTUNE_SWITCH_BUMPLESS : EXOTUNE_SWITCH_RESET;
            int switching = strncmp(s, "switch", 6) == 0;
            for (k = done; k < done + BLOCK; ++k) {
                exotune_inputs y;
                double a, b;
                int rc;
                inputs(s, k < 0 ? 1 : k, x);
                y.theta_m = x[0]; y.omega_m = x[1]; y.tau_s = x[2]; y.dtau_s = x[3]; y.tau_c = x[4];
                if (switching && EXOTUNE_N_CONTROLLERS > 1)
                    exotune_schedule(&st[j], ANGLE[(k + n) % (EXOTUNE_N_CONTROLLERS - 1)], mode);
                a = TICKS();
                rc = exotune_step(&st[j], &y, &u);
                b = TICKS();
                sink += u;
                if (k >= 0) {
                    t[j * n + k] = (b - a - over) * scale;
                    rc_count[6 * j + (rc >= 0 && rc < 6 ? rc : 5)]++;
                }
            }
        }
    }
    for (j = 0; j < m; ++j) {
        double *tj = t + j * n, iqm = 0.0;
        qsort(tj, (size_t)n, sizeof(double), cmp);
        for (k = n / 4; k < 3 * n / 4; ++k)  /* the interquartile mean: finer than the clock's granularity */
            iqm += tj[k] / (double)(3 * n / 4 - n / 4);
        printf("%s %.1f %.1f %.1f %.1f %ld %ld %ld\n", argv[2 + j], tj[n / 2], iqm, tj[(long)(0.99 * (double)n)],
               tj[n - 1], rc_count[6 * j], rc_count[6 * j + 1], rc_count[6 * j + 2]);
    }
    printf("%.3g\n", sink * 0.0);
    free(t);
    free(rc_count);
    free(st);
    return 0;
}
"""

SCENARIOS = ("normal", "decay", "subnormal", "tiny", "huge", "nan", "switch")


def _docs(rate: float) -> dict:
    """The float64 and float32 controller files of examples/scheduled.yaml at ``rate`` (no analyses)."""
    from exotune.config import read_yaml
    from exotune.controllerfile import build_export, design_at_rate

    raw = read_yaml(ROOT / "examples" / "scheduled.yaml")
    out = {}
    for precision in ("float64", "float32"):
        r = copy.deepcopy(raw)
        r["implementation"]["precision"] = precision
        out[precision] = build_export(design_at_rate(r, rate), rate, analyses=False)
    return out


FLUSH_LINES = ("return fabs(v) < EXOTUNE_FLUSH_BELOW ? 0.0 : v;", "return fabsf(v) < EXOTUNE_FLUSH_BELOW ? 0.0f : v;")


def _build(d: Path, doc: dict, cc: str, cflags: list[str], tiny: float, no_flush: bool) -> Path:
    from exotune.controllerfile import c_sources
    from exotune.controllerfile.ccode import C_FLAGS

    for name, text in c_sources(doc).items():
        if no_flush and name.endswith(".c"):
            for line in FLUSH_LINES:
                text = text.replace(line, "return v;")
        (d / name).write_text(text, encoding="ascii")
    ins = doc["golden"]["inputs"]
    scales = [max(max(abs(v) for v in ins[s]["values"]), 1e-3) for s in ("theta_m", "omega_m", "tau_s", "dtau_s",
                                                                         "tau_c")]
    angles = [e["joint_angle_rad"] for e in (doc.get("gain_schedule") or {}).get("entries", [])] or [0.0]
    harness = (HARNESS.replace("SCALES", ", ".join(repr(s) for s in scales))
               .replace("ANGLES_LIST", ", ".join(repr(a) for a in angles)).replace("TINY", repr(tiny)))
    (d / "timing.c").write_text(harness, encoding="ascii")
    flags = [*C_FLAGS.split(), *cflags]
    subprocess.run([cc, *flags, "-c", "-o", str(d / "exotune_controller.o"), str(d / "exotune_controller.c")], check=True)
    subprocess.run([cc, *flags, "-o", str(d / "timing"), str(d / "timing.c"), str(d / "exotune_controller.o"), "-lm"],
                   check=True)
    return d / "timing"


def _size(obj: Path) -> dict[str, int]:
    """Bytes per section of an object file (``size -A``)."""
    out = subprocess.run(["size", "-A", str(obj)], capture_output=True, text=True, check=True).stdout
    sizes = {}
    for line in out.splitlines():
        m = re.match(r"(\.\S+)\s+(\d+)", line)
        if m:
            sizes[m.group(1)] = sizes.get(m.group(1), 0) + int(m.group(2))
    return {k: sum(v for s, v in sizes.items() if s == k or s.startswith(k + ".")) for k in (".text", ".rodata", ".data",
                                                                                            ".bss")}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rate", type=float, default=1000.0)
    ap.add_argument("--steps", type=int, default=200000)
    ap.add_argument("--cc", default="cc")
    ap.add_argument("--cflags", default="-O2", help="extra compiler flags (default -O2)")
    ap.add_argument("--no-flush", action="store_true", help="remove the flush of tiny values (to see what it buys)")
    a = ap.parse_args()
    docs = _docs(a.rate)
    print(f"examples/scheduled.yaml at {a.rate:g} Hz, {a.steps} timed steps per scenario, cc {a.cflags}"
          + (", FLUSH REMOVED" if a.no_flush else ""))
    print(f"{'port':8} {'scenario':16} {'median ns':>9} {'IQM ns':>7} {'p99 ns':>7} {'max ns':>8}   "
          "OK / FAULT_INPUT / FAULT_OVERFLOW")
    sizes = {}
    with tempfile.TemporaryDirectory() as tmp:
        for precision, doc in docs.items():
            d = Path(tmp) / precision
            d.mkdir()
            exe = _build(d, doc, a.cc, a.cflags.split(), 1e-100 if precision == "float64" else 1e-30, a.no_flush)
            scen = SCENARIOS + (("switch-bumpless",) if precision == "float64" else ())
            out = subprocess.run([str(exe), str(a.steps), *scen], capture_output=True, text=True, check=True).stdout
            for line in out.splitlines()[:-1]:
                s, med, iqm, p99, mx, ok, fin, fov = line.split()
                print(f"{precision:8} {s:16} {float(med):9.1f} {float(iqm):7.1f} {float(p99):7.1f} {float(mx):8.0f}   "
                      f"{ok} / {fin} / {fov}")
            n_ctrl = 1 + len((doc.get("gain_schedule") or {}).get("entries", []))
            sizes[precision] = (_size(d / "exotune_controller.o"), n_ctrl)
    print("\ncode size of exotune_controller.o [bytes]")
    for precision, (sz, n_ctrl) in sizes.items():
        print(f"{precision:8} .text {sz['.text']}, .rodata {sz['.rodata']} (tables and strings; {n_ctrl} controllers), "
              f".data {sz['.data']}, .bss {sz['.bss']}")


if __name__ == "__main__":
    main()
