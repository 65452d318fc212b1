"""The float32 C99 port of a float32 controller file (``exotune codegen`` of a file with
``implementation.precision: float32``).

The generated ``exotune_controller.c`` runs each controller's stored float32 **realization**
(docs/controller-file.md#precision: static gains, delta-operator sections [β0, β1, β2, α1, α2],
the DOB's loop divisor) in ``float`` arithmetic, operation for operation and in the order of
:class:`~exotune.controllerfile.precision.Float32Runtime`, the float32 reference that computed
the file's golden vectors and that ``certify`` analyses exactly:

* each input (a ``double``, the API of the float64 port) of magnitude ``EXOTUNE_INPUT_LIMIT``
  (2^128 - 2^103) or more, NaN or infinite is ``EXOTUNE_FAULT_INPUT``: it would round to infinity
  in float (checked in double before the conversion, which is then always defined); otherwise it is
  converted to float (round to nearest) and set to zero below ``EXOTUNE_FLUSH_BELOW``
  (fl32(1e-30));
* static gains, sensed filters, the DOB's algebraic loop ``u = (rest + h) / loop_divisor``, the
  clamp, the loop filters; every sum left to right as the reference's; new section states below
  ``EXOTUNE_FLUSH_BELOW`` are zero;
* a command or state that is not finite: ``EXOTUNE_FAULT_OVERFLOW``, states restored.

Every coefficient is written as a float literal with the ``f`` suffix and 9 significant digits
(``%.9g``), which names the float32 value exactly (checked: it parses back to it). In a build with
float arithmetic evaluated in float (``FLT_EVAL_METHOD`` 0, an ``#error`` otherwise) and no fused
multiply-add contraction (``-ffp-contract=off``, the default of GCC in ``-std=c99``; checked at
run time by ``exotune_init``), each operation is one IEEE single operation rounded to nearest, the
same as numpy's float32 scalars: the port's outputs are the reference's bit for bit, and its golden
test (:mod:`exotune.controllerfile.cgolden32`) compares them exactly.

A switch between gain-schedule entries resets the state (``EXOTUNE_SWITCH_RESET``); the float64
port's bumpless transfer is not part of the float32 port: ``EXOTUNE_SWITCH_BUMPLESS`` returns
``EXOTUNE_ERR_ARGUMENT`` and changes nothing (``EXOTUNE_HAS_BUMPLESS`` 0), so that firmware asking
for it never gets a silent reset (a jump of the command).

References
----------
docs/deploying.md#precision; docs/controller-file.md#precision.
"""

from __future__ import annotations

from decimal import Decimal
from fractions import Fraction

import numpy as np

from ..errors import ConfigError
from .cgolden32 import controllers32, golden_program32, golden_rows32
from .cheader import HeaderParts, c_table, controller_tables, header_text, source_head
from .cstep import ANGLE_C, BUILD_INFO_C, FAST_MATH_C, RESTORE_C, SAVE_C, SCHEDULE_C, c_double, peek_clamp_c
from .model import ControllerFile, as_controller_file
from .precision import FLUSH32, INPUT_LIMIT32, step_order

__all__ = ["c_float", "generate32", "RETURN_CODES32", "MIN_COEFFICIENT32", "FLUSH_BELOW32"]

FLUSH_BELOW32 = float(np.float32(FLUSH32))  # the float32 value the port's states (and inputs) are compared with
# a nonzero coefficient below this magnitude would make its product with a flushed-size value subnormal
MIN_COEFFICIENT32 = float(np.finfo(np.float32).tiny) / FLUSH_BELOW32

# the return codes of cstep.RETURN_CODES (same names and values), described for the float32 port
RETURN_CODES32 = (
    ("EXOTUNE_OK", 0, "success"),
    ("EXOTUNE_FAULT_INPUT", 1, "exotune_step / exotune_start: an input is NaN, infinite or of magnitude "
                               "EXOTUNE_INPUT_LIMIT or more (it would be infinite in float); refused, state and "
                               "*tau_cmd unchanged (a sensor fault: command zero torque and latch it)"),
    ("EXOTUNE_FAULT_OVERFLOW", 2, "exotune_step / exotune_start: the command or a state would overflow float "
                                  "(finite inputs too large); refused, state and *tau_cmd unchanged"),
    ("EXOTUNE_FAULT_ANGLE", 3, "exotune_controller_for_angle / exotune_schedule: the joint angle is NaN or infinite; "
                               "*controller and the state unchanged (keep the running controller, latch the fault)"),
    ("EXOTUNE_ERR_ARGUMENT", 4, "a null pointer, a controller index outside 0..EXOTUNE_N_CONTROLLERS-1, a limit_nm "
                                "neither 0 nor within FLT_MIN..FLT_MAX, a switch mode other than "
                                "EXOTUNE_SWITCH_RESET (EXOTUNE_SWITCH_BUMPLESS included: not in the float32 port), "
                                "or a state exotune_init did not set up (its magic is not EXOTUNE_STATE_MAGIC: "
                                "zeroed or never initialized); nothing changed"),
    ("EXOTUNE_ERR_FLOAT_ENV", 5, "exotune_init: the self-check of the floating-point environment failed (NaN not "
                                 "detected, infinity not detected, float not rounded to nearest in float, or a*b + c "
                                 "contracted into a fused multiply-add: a build with finite-math, unsafe-math or "
                                 "-ffp-contract=fast, or a changed rounding mode); the state is not initialized and "
                                 "must not be stepped"),
)


def c_float(x: float) -> str:
    """A C float literal (``f`` suffix) naming the float32 value of ``x`` exactly: the shortest of
    6 to 9 significant digits whose decimal value lies strictly inside the value's rounding
    interval (checked in exact rational arithmetic), so that a compiler rounding the literal to
    float (directly, or through double) gives the value; 9 digits always do.

    Parameters
    ----------
    x : float
        The value (rounded to float32).

    Returns
    -------
    str
        The literal, e.g. ``"0.1f"``.

    Raises
    ------
    ValueError
        When the float32 value is not finite.
    """
    v = np.float32(x)
    if not np.isfinite(v):
        raise ValueError(f"a controller coefficient is not finite in float32: {x!r}")
    exact = Fraction(float(v))
    with np.errstate(over="ignore"):  # next to ±FLT_MAX: ±2^128, where rounding overflows
        lo, hi = (Fraction(float(n)) if np.isfinite(n) else Fraction(int(np.sign(n)) * 2 ** 128)
                  for n in (np.nextafter(v, np.float32(-np.inf)), np.nextafter(v, np.float32(np.inf))))
    lo, hi = (exact + lo) / 2, (exact + hi) / 2
    for digits in range(6, 10):
        s = f"{float(v):.{digits}g}"
        if lo < Fraction(Decimal(s)) < hi:
            return (s if any(c in s for c in ".e") else s + ".0") + "f"
    raise ValueError(f"no literal names the float32 value {float(v)!r}")  # never: 9 digits suffice


def _parts32() -> HeaderParts:
    arithmetic = (" * float32 port: float arithmetic on the file's float32 realization (delta-operator sections),\n"
                  " * bit-identical to its float32 reference in a build with FLT_EVAL_METHOD 0 and no contraction.\n")
    constants = (f"#define EXOTUNE_PRECISION_BITS 32  /* float arithmetic (the file's implementation.precision) */\n"
                 f"#define EXOTUNE_FLUSH_BELOW {c_float(FLUSH32)}  /* converted inputs and states below this magnitude "
                 f"are zero: constant step time */\n"
                 f"#define EXOTUNE_INPUT_LIMIT {c_double(INPUT_LIMIT32)}  /* an input of this magnitude or more is "
                 f"infinite in float: EXOTUNE_FAULT_INPUT */\n"
                 "#define EXOTUNE_HAS_BUMPLESS 0  /* EXOTUNE_SWITCH_BUMPLESS is refused (EXOTUNE_ERR_ARGUMENT) */\n")
    modes = ("#define EXOTUNE_SWITCH_RESET 0     /* the new controller starts from the zero state */\n"
             "#define EXOTUNE_SWITCH_BUMPLESS 1  /* float64 port only: here EXOTUNE_ERR_ARGUMENT, nothing changed */\n")
    state = """typedef struct {
    unsigned int magic; /* EXOTUNE_STATE_MAGIC once exotune_init succeeded; anything else: not initialized */
    int controller;     /* which controller runs (0: nominal); -1: not initialized */
    float limit_nm;     /* clamp of the command [N.m] before the DOB sees it; 0: none */
    float z[EXOTUNE_MAX_SECTIONS][2];  /* section states (s1, s2) of the running controller, delta form */
} exotune_state;
"""
    init_doc = """/* Zero state (then call exotune_start with the first reading), controller
 * 0...EXOTUNE_N_CONTROLLERS-1, limit_nm > 0 clamps (rounded to float; between FLT_MIN and FLT_MAX)
 * or 0 (no clamp); checks the floating-point environment. EXOTUNE_OK,
 * EXOTUNE_ERR_ARGUMENT (nothing changed) or EXOTUNE_ERR_FLOAT_ENV (the state cannot be stepped). */"""
    switch_doc = """/* Run controller `controller` from the next step, from the zero state: mode EXOTUNE_SWITCH_RESET.
 * EXOTUNE_SWITCH_BUMPLESS is not part of the float32 port (EXOTUNE_HAS_BUMPLESS 0): EXOTUNE_ERR_ARGUMENT,
 * nothing changed. EXOTUNE_OK or EXOTUNE_ERR_ARGUMENT. */"""
    return HeaderParts(arithmetic, constants, RETURN_CODES32, modes, state, init_doc, switch_doc)


# compile-time checks of the build, at the top of the float32 exotune_controller.c
CHECKS32_C = FAST_MATH_C + r'''#if !defined(FLT_EVAL_METHOD) || FLT_EVAL_METHOD != 0
#error "the float32 exotune_controller.c needs float arithmetic evaluated in float (FLT_EVAL_METHOD 0): only then is it the certified float32 controller bit for bit (docs/deploying.md#precision)"
#endif
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#endif
'''

# exotune_start of the float32 port: each section at the steady state of its constant input (delta form:
# d2 = 0 gives y = beta2/alpha2 x, d1 = 0 gives s2 = alpha1 y - beta1 x, and s1 = y - beta0 x)
START32_C = r'''/* the states of filter f at the steady state of the constant input x (the float64 port's bumpless
 * start); a section with a pole at z = 1 (alpha2 = 0) and x != 0 has none: the filter starts at zero */
static void filter_steady(const exo_section *S, const exo_filter *f, float (*z)[2], float x)
{
    int k;
    for (k = f->first; k < f->first + f->count; ++k) {
        const exo_section *c = &S[k];
        float y;
        if (c->alpha2 == 0.0f) {
            if (x != 0.0f) {
                for (k = f->first; k < f->first + f->count; ++k)
                    z[k][0] = z[k][1] = 0.0f;
                return;
            }
            y = 0.0f;
        } else {
            y = c->beta2 / c->alpha2 * x;
        }
        z[k][0] = flush(y - c->beta0 * x);
        z[k][1] = flush(c->alpha1 * y - c->beta1 * x);
        x = y;
    }
}

int exotune_start(exotune_state *st, const exotune_inputs *y)
{
    const exo_controller *c;
    const exo_section *S;
    double in[5];
    float v[5], z[EXOTUNE_MAX_SECTIONS][2], tau0;
    int i, k;
    if (!state_ok(st) || y == 0)
        return EXOTUNE_ERR_ARGUMENT;
    c = &CONTROLLERS[st->controller];
    S = &SECTIONS[c->sec0];
    in[0] = y->theta_m; in[1] = y->omega_m; in[2] = y->tau_s; in[3] = y->dtau_s; in[4] = y->tau_c;
    for (i = 0; i < 5; ++i) {
        if (!(fabs(in[i]) < EXOTUNE_INPUT_LIMIT))  /* NaN, infinite, or infinite in float */
            return EXOTUNE_FAULT_INPUT;
        v[i] = flush((float)in[i]);
    }
    tau0 = clamp(-v[2], st->limit_nm);  /* the motor at rest against the spring: zero disturbance estimate */
    for (k = 0; k < EXOTUNE_MAX_SECTIONS; ++k)
        z[k][0] = z[k][1] = 0.0f;
    for (i = 0; i < c->n_sensed + c->n_loop; ++i) {
        const exo_filter *f = &FILTERS[c->filter0 + i];
        filter_steady(S, f, z, i < c->n_sensed ? v[f->signal] : tau0);
    }
    for (k = 0; k < c->n_sections; ++k) {
        if (!isfinite(z[k][0]) || !isfinite(z[k][1]))
            return EXOTUNE_FAULT_OVERFLOW;
    }
    for (k = 0; k < EXOTUNE_MAX_SECTIONS; ++k) {
        st->z[k][0] = z[k][0];
        st->z[k][1] = z[k][1];
    }
    return EXOTUNE_OK;
}

'''

# the functions of the float32 exotune_controller.c after its tables
STEP32_C = BUILD_INFO_C + r'''
/* zero below EXOTUNE_FLUSH_BELOW: no subnormal state or input enters the arithmetic (constant step time) */
static float flush(float v)
{
    return fabsf(v) < EXOTUNE_FLUSH_BELOW ? 0.0f : v;
}

/* NaN and infinity detected, float rounded to nearest in float, a*b + c not fused into one rounding
 * ((1 + 2^-12)^2 - (1 + 2^-11) is 0 in float, 2^-24 when fused): what the port and its golden test assume */
static int float_env_ok(void)
{
    volatile float nan_ = NAN, inf_ = INFINITY, one = 1.0f, eps = FLT_EPSILON, p_ = 1.000244140625f,
                   q_ = -1.00048828125f;
    float a = nan_, b = inf_, p = p_, q = q_;
    return isnan(a) && !isfinite(a) && isinf(b) && !isfinite(b) && one + 0.5f * eps == one
           && one + 0.75f * eps == one + eps && -one - 0.75f * eps == -one - eps && p * p + q == 0.0f;
}

/* a state exotune_init set up (a zeroed or garbage state is refused: EXOTUNE_ERR_ARGUMENT) */
static int state_ok(const exotune_state *st)
{
    return st != 0 && st->magic == EXOTUNE_STATE_MAGIC && st->controller >= 0 && st->controller < EXOTUNE_N_CONTROLLERS;
}

static int mode_ok(int mode)
{
    return mode == EXOTUNE_SWITCH_RESET;  /* EXOTUNE_SWITCH_BUMPLESS: not in the float32 port */
}

int exotune_init(exotune_state *st, int controller, double limit_nm)
{
    int i;
    if (st == 0 || controller < 0 || controller >= EXOTUNE_N_CONTROLLERS
        || !(limit_nm == 0.0 || (limit_nm >= (double)FLT_MIN && limit_nm <= (double)FLT_MAX)))
        return EXOTUNE_ERR_ARGUMENT;
    st->magic = 0u;
    st->controller = -1;
    if (!float_env_ok())
        return EXOTUNE_ERR_FLOAT_ENV;
    st->magic = EXOTUNE_STATE_MAGIC;
    st->controller = controller;
    st->limit_nm = (float)limit_nm;
    for (i = 0; i < EXOTUNE_MAX_SECTIONS; ++i)
        st->z[i][0] = st->z[i][1] = 0.0f;
    return EXOTUNE_OK;
}

''' + ANGLE_C + r'''/* one delta-operator section (docs/controller-file.md#precision), in the reference's order */
static float section_step(const exo_section *c, float *s, float x)
{
    float y = c->beta0 * x + s[0];
    float d1 = (c->beta1 * x - c->alpha1 * y) + s[1];
    float d2 = c->beta2 * x - c->alpha2 * y;
    s[0] = flush(s[0] + d1);
    s[1] = flush(s[1] + d2);
    return y;
}

/* one step of a filter (sections S[f->first...], states z[f->first...]) */
static float filter_step(const exo_section *S, const exo_filter *f, float (*z)[2], float x)
{
    int k;
    for (k = f->first; k < f->first + f->count; ++k)
        x = section_step(&S[k], z[k], x);
    return x;
}

''' + peek_clamp_c("float", "0.0f", "beta0") + r'''
int exotune_switch(exotune_state *st, int controller, int mode)
{
    int k;
    if (!state_ok(st) || controller < 0 || controller >= EXOTUNE_N_CONTROLLERS || !mode_ok(mode))
        return EXOTUNE_ERR_ARGUMENT;  /* EXOTUNE_SWITCH_BUMPLESS included: not in the float32 port */
    for (k = 0; k < EXOTUNE_MAX_SECTIONS; ++k)
        st->z[k][0] = st->z[k][1] = 0.0f;
    st->controller = controller;
    return EXOTUNE_OK;
}

''' + SCHEDULE_C + START32_C + r'''int exotune_step(exotune_state *st, const exotune_inputs *y, double *tau_cmd)
{
    const exo_controller *c;
    const exo_section *S;
    double in[5];
    float v[5], saved[EXOTUNE_MAX_SECTIONS][2], rest = 0.0f, fsum = 0.0f, h = 0.0f, u;
    int i, k, ok;
    if (!state_ok(st) || y == 0 || tau_cmd == 0)
        return EXOTUNE_ERR_ARGUMENT;
    c = &CONTROLLERS[st->controller];
    S = &SECTIONS[c->sec0];
    in[0] = y->theta_m; in[1] = y->omega_m; in[2] = y->tau_s; in[3] = y->dtau_s; in[4] = y->tau_c;
    for (i = 0; i < 5; ++i) {
        if (!(fabs(in[i]) < EXOTUNE_INPUT_LIMIT))  /* NaN, infinite, or infinite in float */
            return EXOTUNE_FAULT_INPUT;
        v[i] = flush((float)in[i]);
    }
''' + SAVE_C + r'''    for (i = 0; i < c->n_gains; ++i)
        rest = rest + GAINS[c->gain0 + i].gain * v[GAINS[c->gain0 + i].signal];
    for (i = 0; i < c->n_sensed; ++i) {
        const exo_filter *f = &FILTERS[c->filter0 + i];
        fsum = fsum + filter_step(S, f, st->z, v[f->signal]);
    }
    rest = rest + fsum;
    for (i = 0; i < c->n_loop; ++i)
        h = h + filter_peek(S, &FILTERS[c->filter0 + c->n_sensed + i], st->z, 0.0f);
    u = clamp((rest + h) / c->divisor, st->limit_nm);
    for (i = 0; i < c->n_loop; ++i)
        filter_step(S, &FILTERS[c->filter0 + c->n_sensed + i], st->z, u);
''' + RESTORE_C + r'''    *tau_cmd = (double)u;
    return EXOTUNE_OK;
}'''


def _tables32(ctrls) -> dict:
    """Flat tables of every controller's realization in the order the reference steps it
    (:func:`~exotune.controllerfile.precision.step_order`)."""
    gains, filters, sections, rows = [], [], [], []
    for _label, _angle, real in ctrls:
        K = step_order(real)
        g0, f0, s0 = len(gains), len(filters), len(sections)
        gains += K["gains"]
        for signal, secs in [*K["sensed"], *((-1, secs) for secs in K["loop"])]:
            filters.append((signal, len(sections) - s0, len(secs)))
            sections.extend(secs)
        rows.append((g0, len(gains) - g0, f0, len(K["sensed"]), len(K["loop"]), s0, len(sections) - s0, K["divisor"]))
    small = [x for _s, g in gains for x in (g,)] + [x for c in sections for x in c]
    small = [x for x in small if x != 0.0 and abs(x) < MIN_COEFFICIENT32]
    if small:
        raise ConfigError("controller.realization", f"a float32 coefficient of magnitude {abs(small[0]):.3g} < "
                          f"{MIN_COEFFICIENT32:.3g}: the float32 port's constant step time needs every nonzero "
                          "coefficient at least that large (its product with a value at the flush threshold would "
                          "be subnormal)")
    return {"gains": gains, "filters": filters, "sections": sections, "controllers": rows}


def _source32(doc: ControllerFile, ctrls, t: dict, trace: dict) -> str:
    L = source_head(doc, trace, CHECKS32_C) + [
        "/* per static gain: input signal (0 theta_m, 1 omega_m, 2 tau_s, 3 dtau_s, 4 tau_c), gain */",
        "typedef struct { int signal; float gain; } exo_gain;",
        "/* per filter: input signal (-1: tau_cmd, the DOB loop), first section (of its controller), sections */",
        "typedef struct { int signal; int first; int count; } exo_filter;",
        "/* per section, delta = z - 1: y = beta0 x + s1; s1 += (beta1 x - alpha1 y) + s2; s2 += beta2 x - alpha2 y */",
        "typedef struct { float beta0, beta1, beta2, alpha1, alpha2; } exo_section;",
        "/* per controller: first gain, gains, first filter, sensed filters, loop filters, first section,",
        " * sections, the DOB's loop divisor (tau_cmd = (rest + h) / divisor) */",
        "typedef struct { int gain0, n_gains, filter0, n_sensed, n_loop, sec0, n_sections; float divisor; } "
        "exo_controller;", ""]
    L += c_table("exo_gain", "GAINS", [f"{{{s}, {c_float(g)}}}" for s, g in t["gains"]], "{0, 0.0f}")
    L += c_table("exo_filter", "FILTERS", [f"{{{s}, {a}, {n}}}" for s, a, n in t["filters"]], "{0, 0, 0}")
    L += c_table("exo_section", "SECTIONS", [f"{{{', '.join(c_float(x) for x in c)}}}" for c in t["sections"]],
                 "{0.0f, 0.0f, 0.0f, 0.0f, 0.0f}")
    L += controller_tables(t["controllers"], [c[0] for c in ctrls], c_float, [c[1] for c in ctrls[1:]])
    L.append(STEP32_C)
    return "\n".join(L) + "\n"


def generate32(doc: ControllerFile | dict, trace: dict) -> tuple[dict[str, str], int, int]:
    """The float32 port of a float32 file: (files, number of controllers, number of sections), the
    files those of the float64 port (``exotune_controller.h``, ``.c``, ``exotune_golden_test.c``).

    Parameters
    ----------
    doc : ControllerFile or dict
        The validated float32 controller file.
    trace : dict
        Where the code came from: ``sha256`` of the file, ``certified``, ``verdict`` and ``reasons``.

    Returns
    -------
    files : dict of str to str
        File name → C source.
    controllers : int
        Number of controllers (nominal and schedule entries).
    sections : int
        Number of sections in the tables.
    """
    doc = as_controller_file(doc)
    ctrls = controllers32(doc)
    t = _tables32(ctrls)
    max_sections = max([1] + [row[6] for row in t["controllers"]])
    files = {
        "exotune_controller.h": header_text(doc, len(ctrls), max_sections, trace, _parts32()),
        "exotune_controller.c": _source32(doc, ctrls, t, trace),
        "exotune_golden_test.c": golden_program32(doc, golden_rows32(doc)),
    }
    return files, len(ctrls), len(t["sections"])
