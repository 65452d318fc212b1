"""The golden test of the C port (``exotune_golden_test.c``): scenarios run by the reference
runtime, with a tolerance per output derived from a bound on its rounding.

Every controller of the file (the nominal one and each gain-schedule entry) runs two scenarios:

* no clamp: the file's golden inputs from the zero state, then every input fault from a non-zero
  state (NaN and ±infinity on each signal: refused, state unchanged), then random inputs of the
  golden inputs' sizes, then a finite input of 1.7e308 on each signal (an overflow fault, or
  accepted where the controller does not amplify that signal: then its bound is infinite and
  only the return code is checked);
* a clamp of half the largest unclamped command: random inputs (a warm-up), the input faults, more
  random inputs; the clamp engages from a non-zero state.

Then the schedule look-up (``exotune_controller_for_angle``) at every entry, between entries,
far outside them and at NaN and ±infinity (a fault), and the argument checks.

The tolerance of output k is ``2 (n + 4) u S_k + 1e-90 N·m``: u = 2^-53 the unit roundoff, S_k the
sum of the magnitudes of every term the step adds up for that output (each product gain·input,
each section's b0·x and state, weighted by the magnitude of the feed-through that carries it to
the command, divided by |1 - g|, plus |τ_cmd|), n the number of those terms. That bounds the
rounding of one output computed from given states, in Python and in C (hence the 2); the states
themselves are the same doubles in a conforming build (the same operations in the same order, no
contraction, no excess precision), so nothing accumulates. 1e-90 N·m covers the port's flush of
magnitudes below 1e-100 to zero (docs/deploying.md#step-contract). A coefficient changed by 1e-12
of itself moves some output by far more than this tolerance (tests/controllerfile/test_cgolden.py
checks every coefficient).

References
----------
docs/deploying.md#golden-test; docs/controller-file.md#c-runtime.
"""

from __future__ import annotations

import math

import numpy as np

from .cstep import SIGNALS, ascii_text, c_double, controllers_of
from .model import ControllerFile, as_controller_file, nearest_index
from .runtime import Runtime

__all__ = ["GoldenRow", "golden_rows", "golden_program", "step_terms", "tolerance", "ABS_TOLERANCE_NM", "HUGE_INPUT",
           "fault_inputs", "lookup_rows", "OP_INIT", "OP_STEP", "OP_ANGLE", "OP_SWITCH"]

UNIT_ROUNDOFF = 2.0 ** -53
ABS_TOLERANCE_NM = 1e-90  # covers the port's flush of magnitudes below 1e-100 (cstep.FLUSH_BELOW)
HUGE_INPUT = 1.7e308
OP_INIT, OP_STEP, OP_ANGLE, OP_SWITCH = 0, 1, 2, 3
OK, FAULT_INPUT, FAULT_OVERFLOW, FAULT_ANGLE, ERR_ARGUMENT = 0, 1, 2, 3, 4


class GoldenRow(tuple):
    """(op, arg, inputs, rc, out, tol): one line of the golden table (see :func:`golden_rows`; op 3,
    :data:`OP_SWITCH`: ``exotune_switch`` to controller arg in mode inputs[0], expect rc)."""

    __slots__ = ()

    def __new__(cls, op, arg, inputs, rc, out=0.0, tol=0.0):
        return super().__new__(cls, (op, arg, tuple(float(x) for x in inputs), rc, float(out), float(tol)))


def _filter_terms(f, x: float) -> tuple[float, int]:
    """Σ over sections of (|b0·x_in| + |z0|) times the magnitude of the later sections' b0 (what
    carries the section's output to the filter's), and the number of terms, for the filter's output
    at input x from its current state."""
    total, n, carry = 0.0, 0, 1.0
    terms = []
    for (b0, _b1, _b2, _a1, _a2), (z0, _z1) in zip(f.coefficients, f.z.tolist()):
        terms.append(abs(b0 * x) + abs(z0))
        x = b0 * x + z0
    for (b0, *_r), t in zip(reversed(f.coefficients), reversed(terms)):
        total += t * carry
        carry *= abs(b0)
        n += 2
    return total, n


def step_terms(rt: Runtime, vals: dict) -> tuple[float, int]:
    """(S, n) of the command the runtime computes for ``vals`` from its current state, before its
    step (see the module docstring; :func:`tolerance` adds |τ_cmd|).

    Parameters
    ----------
    rt : Runtime
        The reference runtime, in its current state.
    vals : dict
        The five signals' values (θ_m [rad], θ̇_m [rad/s], τ_s [N·m], τ̇_s [N·m/s], τ_c [N·m]).

    Returns
    -------
    S : float
        Sum of the absolute values of the command's terms [N·m], divided by the DOB loop's divisor.
    n : int
        Number of terms.
    """
    s, n = 0.0, 0
    for sig, g in rt.gains.items():
        s += abs(g * vals[sig])
        n += 1
    for sig, f in rt.filters:
        t, m = _filter_terms(f, vals[sig])
        s, n = s + t, n + m
    for f in rt.loop:
        t, m = _filter_terms(f, 0.0)
        s, n = s + t, n + m
    return s / abs(1.0 - rt.loop_feedthrough), n


def tolerance(terms: tuple[float, int], u: float) -> float:
    """The tolerance [N·m] of a command ``u`` whose terms are ``terms`` (:func:`step_terms`).

    Parameters
    ----------
    terms : tuple of (float, int)
        ``(S, n)`` of the command (:func:`step_terms`).
    u : float
        The command [N·m].

    Returns
    -------
    float
        The tolerance [N·m].
    """
    s, n = terms
    return 2.0 * (n + 4) * UNIT_ROUNDOFF * (s + abs(u)) + ABS_TOLERANCE_NM


def _run(rt: Runtime, X) -> list[GoldenRow]:
    rows = []
    for x in X:
        vals = dict(zip(SIGNALS, (float(v) for v in x)))
        bad = not all(math.isfinite(v) for v in vals.values())
        terms = None if bad else step_terms(rt, vals)
        try:
            u = rt.step(vals)
        except ValueError:
            rows.append(GoldenRow(OP_STEP, 0, x, FAULT_INPUT if bad else FAULT_OVERFLOW))
            continue
        rows.append(GoldenRow(OP_STEP, 0, x, OK, u, tolerance(terms, u)))
    return rows


def fault_inputs() -> list[list[float]]:
    """NaN, +infinity and -infinity on each signal in turn (the others 0).

    Returns
    -------
    list of list of float
        Fifteen input vectors of the five signals.
    """
    out = []
    for i in range(5):
        for bad in (math.nan, math.inf, -math.inf):
            x = [0.0] * 5
            x[i] = bad
            out.append(x)
    return out


def golden_rows(doc: ControllerFile | dict, seed: int = 20250) -> list[GoldenRow]:
    """The golden table of a controller file (see the module docstring): ``(op, arg, inputs, rc,
    out, tol)`` rows, ``op`` 0 init (arg: controller, inputs[0]: limit [N·m]), 1 step (inputs: the
    five signals; rc the expected return code; out [N·m] and tol [N·m] when rc is 0), 2 schedule
    look-up (inputs[0]: joint angle [rad]; arg: the expected controller when rc is 0).

    Parameters
    ----------
    doc : dict
        The validated controller file's mapping (with its ``golden`` inputs).
    seed : int, optional
        Seed of the random inputs.

    Returns
    -------
    list of GoldenRow
        The table, each controller's rows in turn, then :func:`lookup_rows`.
    """
    doc = as_controller_file(doc)
    ins = doc.golden.inputs
    G = np.array([ins[s] for s in SIGNALS], dtype=float).T
    scale = np.array([max(float(np.max(np.abs(G[:, i]))), 1e-3) for i in range(5)])
    rng = np.random.default_rng(seed)
    rows: list[GoldenRow] = []
    ctrls = controllers_of(doc)
    for c, (_label, angle, _rt) in enumerate(ctrls):
        R1, R2, R3 = (rng.standard_normal((m, 5)) * scale for m in (40, 60, 30))
        huge = [[HUGE_INPUT if j == i else 0.0 for j in range(5)] for i in range(5)]
        rt = Runtime(doc, joint_angle_rad=angle)
        rows.append(GoldenRow(OP_INIT, c, [0.0] * 5, OK))
        run = _run(rt, [*G, *fault_inputs(), *R1, *huge])
        rows += run
        limit = 0.5 * max(abs(r[4]) for r in run[:-5] if r[3] == OK)  # the commands of ordinary inputs
        rt = Runtime(doc, limit_nm=limit, joint_angle_rad=angle)
        rows.append(GoldenRow(OP_INIT, c, [limit] + [0.0] * 4, OK))
        rows += _run(rt, [*R2, *fault_inputs(), *R3])
    return rows + lookup_rows([a for _l, a, _r in ctrls[1:]])


def lookup_rows(angles: list[float]) -> list[GoldenRow]:
    """The schedule look-up at every entry's angle ``angles`` (entries 1, 2, ...), between entries,
    far outside (the end entries) and at 0 (the first nearest entry), at NaN and ±infinity (a fault); then the
    argument checks of ``exotune_init`` (controller index, limit).

    Parameters
    ----------
    angles : list of float
        Joint angle [rad] of each gain-schedule entry (empty without a schedule).

    Returns
    -------
    list of GoldenRow
        The look-up and argument-check rows.
    """
    rows = []
    probes = list(angles) + [(a + b) / 2 for a, b in zip(angles, angles[1:])] + [-1e300, 1e300, 0.0]
    for q in probes:
        want = 0 if not angles else 1 + nearest_index(angles, q)
        rows.append(GoldenRow(OP_ANGLE, want, [q] + [0.0] * 4, OK))
    rows += [GoldenRow(OP_ANGLE, 0, [q] + [0.0] * 4, FAULT_ANGLE) for q in (math.nan, math.inf, -math.inf)]
    rows += [GoldenRow(OP_INIT, c, [lim] + [0.0] * 4, ERR_ARGUMENT)
             for c, lim in ((-1, 0.0), (len(angles) + 1, 0.0), (0, -1.0), (0, math.nan), (0, math.inf))]
    return rows


def _lit(x: float) -> str:
    if math.isnan(x):
        return "(double)NAN"
    if math.isinf(x):
        return "(double)INFINITY" if x > 0 else "-(double)INFINITY"
    return c_double(x)


_MAIN = r'''
int main(void)
{
    exotune_state st;
    exotune_inputs y;
    int i, rc, bad = 0, worst = -1, fails = 0, checked = 0;
    double worst_ratio = 0.0;
    printf("exotune golden test: %s\n", exotune_build_info);
    printf("source sha256 %s, exotune %s, certification %s\n", EXOTUNE_SOURCE_SHA256, EXOTUNE_VERSION,
           EXOTUNE_CERTIFICATION);
    if (!EXOTUNE_CERTIFIED)
        printf("WARNING: this controller is not certified: it must not drive a joint\n");
    for (i = 0; i < NROWS; ++i) {
        const golden_row *r = &ROWS[i];
        double u = 0.0;
        int got = 0;
        switch (r->op) {
        case 0:
            rc = exotune_init(&st, r->arg, r->in[0]);
            break;
        case 1:
            y.theta_m = r->in[0]; y.omega_m = r->in[1]; y.tau_s = r->in[2]; y.dtau_s = r->in[3]; y.tau_c = r->in[4];
            rc = exotune_step(&st, &y, &u);
            if (rc == EXOTUNE_OK && r->rc == EXOTUNE_OK) {
                double err = fabs(u - r->out), ratio = err > 0.0 ? err / r->tol : 0.0;  /* tol 0: exact */
                ++checked;
                if (!(fabs(u - r->out) <= r->tol))
                    bad = 1;
                if (!(ratio <= worst_ratio)) {
                    worst_ratio = ratio;
                    worst = i;
                }
            }
            break;
        case 3:
            rc = exotune_switch(&st, r->arg, (int)r->in[0]);
            break;
        default:
            rc = exotune_controller_for_angle(r->in[0], &got);
            if (rc == EXOTUNE_OK && got != r->arg)
                bad = 1;
        }
        if (rc != r->rc || bad) {
            if (fails++ < 5)
                printf("row %d (op %d): return code %d (expected %d), output %.17g (expected %.17g, tolerance %.3g)\n",
                       i, r->op, rc, r->rc, u, r->out, r->tol);
            bad = 0;
        }
    }
    rc = exotune_step(0, &y, 0) == EXOTUNE_ERR_ARGUMENT && exotune_init(0, 0, 0.0) == EXOTUNE_ERR_ARGUMENT
         && exotune_start(0, &y) == EXOTUNE_ERR_ARGUMENT && exotune_start(&st, 0) == EXOTUNE_ERR_ARGUMENT
         && exotune_controller_for_angle(0.0, 0) == EXOTUNE_ERR_ARGUMENT
         && exotune_switch(&st, 0, 7) == EXOTUNE_ERR_ARGUMENT && exotune_switch(&st, -1, 0) == EXOTUNE_ERR_ARGUMENT;
    if (!rc && fails++ < 5)
        printf("an argument check did not return EXOTUNE_ERR_ARGUMENT\n");
    printf("%d rows, %d outputs within their rounding bounds (largest error %.3g of its bound", NROWS, checked,
           worst_ratio);
    printf(worst < 0 ? ": every output exact)\n" : ", row %d)\n", worst);
    printf(fails ? "FAILED: %d rows differ from the reference runtime\n" : "OK\n", fails);
    return fails ? 1 : 0;
}'''


ABOUT = (" * Every controller of the controller file through the C port, against the reference runtime:",
         " * the file's golden inputs from the zero state, every input fault from a non-zero state, random",
         " * inputs, overflowing inputs, a clamp that engages, the schedule look-up and the argument checks;",
         " * each output within a bound on its rounding. Exit 0 and 'OK': the build reproduces the controller.")


def golden_program(doc: ControllerFile | dict, rows: list[GoldenRow], about: tuple[str, ...] = ABOUT) -> str:
    """``exotune_golden_test.c`` for the golden table ``rows`` (:func:`golden_rows`); ``about``:
    the comment lines that say what it checks.

    Parameters
    ----------
    doc : ControllerFile or dict
        The controller file (its provenance names the source).
    rows : list of GoldenRow
        The golden table.
    about : tuple of str, optional
        Comment lines of the program's header.

    Returns
    -------
    str
        The C source.
    """
    L = ["/* exotune_golden_test.c - generated by exotune codegen (docs/deploying.md#golden-test).",
         *about,
         f" * Source: {ascii_text(as_controller_file(doc).provenance.source)} */",
         "#include <math.h>", "#include <stdio.h>", "#include \"exotune_controller.h\"", "",
         "typedef struct { int op; int arg; double in[5]; int rc; double out; double tol; } golden_row;",
         "/* op 0: exotune_init(arg, in[0]); op 1: exotune_step(in), expect rc and out +- tol;",
         " * op 2: exotune_controller_for_angle(in[0]), expect rc and controller arg;",
         " * op 3: exotune_switch(arg, mode in[0]), expect rc */",
         f"#define NROWS {len(rows)}",
         "static const golden_row ROWS[NROWS] = {"]
    for op, arg, x, rc, out, tol in rows:
        L.append(f"    {{{op}, {arg}, {{{', '.join(_lit(v) for v in x)}}}, {rc}, {_lit(out)}, {_lit(tol)}}},")
    L.append("};")
    L.append(_MAIN)
    return "\n".join(L) + "\n"
