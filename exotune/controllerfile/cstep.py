"""The C text of the runtime's port (``exotune codegen``): the step, the schedule switch and the
checks of the build, and the helpers the generators share (C literals, ASCII comments, the
controllers of a file in the reference runtime's order).

The step is the reference runtime's (:mod:`exotune.controllerfile.runtime`) operation for
operation, with two additions that never change a result by more than 1e-100 of a signal's unit
(docs/deploying.md#step-contract):

* inputs, section states and the bumpless offset of magnitude below ``EXOTUNE_FLUSH_BELOW``
  (1e-100) are set to zero, so that no operation of the step ever meets a subnormal number and the
  step takes the same time whatever the data (x86 and many FPUs take 10-100 times longer on
  subnormals; a decaying filter state otherwise settles into them);
* a switch between gain-schedule entries either resets the states or is bumpless: between
  controllers of the same layout each section's state is mapped through its direct-form-II state
  (the last two values of the signal the section's denominator filters, which does not depend on
  its numerator: for sections with the same poles the new section is then exactly as if it had run
  all along on the same input), and the difference between the old controller's command and the
  new one's (both for the last accepted inputs) becomes an offset added to the command that decays
  by ``EXOTUNE_BUMPLESS_DECAY`` per sample.

References
----------
docs/deploying.md; docs/controller-file.md#c-runtime.
"""

from __future__ import annotations

import math

from ..sampled import Measured
from .model import ControllerFile, as_controller_file
from .runtime import Runtime

__all__ = ["SIGNALS", "RETURN_CODES", "FLUSH_BELOW", "BUMPLESS_TAU_S", "c_double", "ascii_text", "controllers_of",
           "layouts_of", "state_maps", "CHECKS_C", "STEP_C", "START_C",
           "FAST_MATH_C", "BUILD_INFO_C", "ANGLE_C", "SCHEDULE_C", "SAVE_C", "RESTORE_C",
           "peek_clamp_c"]

SIGNALS = tuple(Measured)  # theta_m, omega_m, tau_s, dtau_s, tau_c: the order of exotune_inputs

# every return code of the generated API: (macro, value, meaning) -- the header documents each
RETURN_CODES = (
    ("EXOTUNE_OK", 0, "success"),
    ("EXOTUNE_FAULT_INPUT", 1, "exotune_step / exotune_start: an input is NaN or infinite; refused, state and "
                               "*tau_cmd unchanged (a sensor fault: command zero torque and latch it)"),
    ("EXOTUNE_FAULT_OVERFLOW", 2, "exotune_step / exotune_start / exotune_switch: the command, a state or the "
                                  "bumpless offset would overflow (finite inputs too large); refused, state and "
                                  "*tau_cmd unchanged"),
    ("EXOTUNE_FAULT_ANGLE", 3, "exotune_controller_for_angle / exotune_schedule: the joint angle is NaN or infinite; "
                               "*controller and the state unchanged (keep the running controller, latch the fault)"),
    ("EXOTUNE_ERR_ARGUMENT", 4, "a null pointer, a controller index outside 0..EXOTUNE_N_CONTROLLERS-1, a negative, "
                                "NaN or infinite limit_nm, an unknown switch mode, EXOTUNE_SWITCH_BUMPLESS between "
                                "controllers of different layouts, or a state exotune_init did not set up (its magic "
                                "is not EXOTUNE_STATE_MAGIC: zeroed or never initialized); nothing changed"),
    ("EXOTUNE_ERR_FLOAT_ENV", 5, "exotune_init: the self-check of the floating-point environment failed (NaN not "
                                 "detected, infinity not detected, or rounding not to nearest: a build with "
                                 "finite-math or unsafe-math optimizations, or a changed rounding mode); the "
                                 "state is not initialized and must not be stepped"),
)

FLUSH_BELOW = 1e-100  # inputs, states and the bumpless offset below this magnitude are zero in the port
BUMPLESS_TAU_S = 0.02  # [s] time constant of the decay of the bumpless offset


def c_double(x: float) -> str:
    """A C double literal equal to ``x`` (``repr``: the shortest string that round-trips).

    Parameters
    ----------
    x : float
        The value.

    Returns
    -------
    str
        The literal.

    Raises
    ------
    ValueError
        When ``x`` is not finite.
    """
    x = float(x)
    if not math.isfinite(x):
        raise ValueError(f"a controller coefficient is not finite: {x!r}")
    s = repr(x)
    return s if any(c in s for c in ".en") else s + ".0"


# readable ASCII for the non-ASCII characters of units and names (others become "?")
_TRANSLIT = {"\u00b7": ".", "\u22c5": ".", "\u00b2": "^2", "\u00b3": "^3", "\u00b9": "^1", "\u2070": "^0",
             "\u2074": "^4", "\u2075": "^5", "\u2076": "^6", "\u2077": "^7", "\u2078": "^8", "\u2079": "^9",
             "\u207b": "^-", "\u2212": "-", "\u2013": "-", "\u2014": "-", "\u00b0": "deg", "\u00b5": "u",
             "\u00d7": "x", "\u00f7": "/", "\u2264": "<=", "\u2265": ">=", "\u2248": "~", "\u00b1": "+-",
             "\u2026": "...", "\u2192": "->", "\u221e": "inf", "\u2018": "'", "\u2019": "'", "\u201c": "'",
             "\u201d": "'", "\u00df": "ss", "\u2126": "Ohm"}
_GREEK = ("alpha beta gamma delta epsilon zeta eta theta iota kappa lambda mu nu xi omicron pi rho sigma sigma tau "
          "upsilon phi chi psi omega").split()
for _i, _name in enumerate(_GREEK):  # U+03B1... lower case (U+03C2 final sigma), U+0391... upper case
    _TRANSLIT[chr(0x3B1 + _i)] = _name
    if _i != 17:
        _TRANSLIT[chr(0x391 + _i)] = _name.capitalize()


def _safe_char(c: str) -> str:
    if c == "\\":
        return "/"
    if c == '"':
        return "'"
    if " " <= c <= "~":
        return c
    if ord(c) < 0x20 or 0x7F <= ord(c) <= 0x9F or c in "\u2028\u2029\u0085":
        return " "  # control characters (CR, LF, TAB, NUL, VT, FF, ...): a C comment or string stays one line
    return _TRANSLIT.get(c, "?")


def ascii_text(s) -> str:
    """``s`` fit for a C comment or string: every character mapped to printable ASCII first
    (control characters to a space, ``\\`` to ``/``, ``"`` to ``'``, common unit and Greek
    characters spelled out -- ``kg·m²`` is ``kg.m^2``, ``θ`` is ``theta`` -- anything else to ``?``),
    then every ``*/``, ``/*`` and ``??`` (a trigraph) broken by a space, until none is left.

    Parameters
    ----------
    s : Any
        The text (converted with ``str``).

    Returns
    -------
    str
        The printable-ASCII text: it can neither end a comment, open one, end a string literal,
        continue a line nor form a trigraph.
    """
    out = "".join(_safe_char(c) for c in str(s))
    prev = None
    while prev != out:
        prev = out
        out = out.replace("*/", "* /").replace("/*", "/ *").replace("??", "? ?")
    return out


def controllers_of(doc: ControllerFile | dict) -> list[tuple[str, float | None, Runtime]]:
    """(label, joint angle [rad] or None, reference runtime): the nominal controller, then every
    gain-schedule entry, each as the reference runtime runs it (its gains, its sensed filters and
    its loop filters, in its order).

    Parameters
    ----------
    doc : dict
        The validated controller file's mapping.

    Returns
    -------
    list of tuple
        ``(label, joint angle [rad] or None, Runtime)`` per controller.
    """
    cf = as_controller_file(doc)
    out = [("nominal", None, Runtime(cf))]
    for e in cf.schedule_entries:
        out.append((f"joint angle {e.joint_angle_rad!r} rad", float(e.joint_angle_rad), Runtime(cf.entry_view(e))))
    return out


def layouts_of(ctrls) -> list[int]:
    """Per controller, a layout number: controllers with the same filters on the same signals with
    the same numbers of sections share it (a bumpless switch carries their states over).

    Parameters
    ----------
    ctrls : list of tuple
        The controllers, as :func:`controllers_of` gives them.

    Returns
    -------
    list of int
        The layout number of each (from 0).
    """
    seen: dict[tuple, int] = {}
    out = []
    for _label, _angle, rt in ctrls:
        key = (tuple((s, len(f.coefficients)) for s, f in rt.filters), tuple(len(f.coefficients) for f in rt.loop))
        out.append(seen.setdefault(key, len(seen)))
    return out


def state_maps(coef) -> tuple[float, ...]:
    """(M, W) of a section (b0, b1, b2, a1, a2), row by row: its DF-II-transposed state is
    M·(w[k], w[k-1]), w the signal its denominator filters (w[k] = x[k] - a1 w[k-1] - a2 w[k-2],
    y = b0 w[k] + b1 w[k-1] + b2 w[k-2]); W = M^-1, or zero when M is singular or its condition
    number exceeds 1e10 (a numerator sharing a root with the denominator: the section then starts
    a bumpless switch from the zero state).

    Parameters
    ----------
    coef : sequence of float
        The section ``(b0, b1, b2, a1, a2)`` (a0 = 1).

    Returns
    -------
    tuple of float
        The eight entries of M then W, row by row.
    """
    import numpy as np

    b0, b1, b2, a1, a2 = coef
    M = np.array([[b1 - b0 * a1, b2 - b0 * a2], [b2 - a2 * b0, a1 * b2 - a2 * b1]])
    ok = np.all(np.isfinite(M)) and np.linalg.cond(M) < 1e10
    W = np.linalg.inv(M) if ok else np.zeros((2, 2))
    return tuple(float(x) for x in [*M.ravel(), *W.ravel()])


# compile-time checks of the build, at the top of exotune_controller.c
FAST_MATH_C = r'''#if defined(__FAST_MATH__) || (defined(__FINITE_MATH_ONLY__) && __FINITE_MATH_ONLY__) || defined(_M_FP_FAST)
#error "exotune_controller.c must not be built with -ffast-math, -ffinite-math-only or /fp:fast: the NaN and overflow guards would be optimized away (docs/deploying.md)"
#endif
'''
CHECKS_C = FAST_MATH_C + r'''#if defined(FLT_EVAL_METHOD) && FLT_EVAL_METHOD > 0
#error "exotune_controller.c needs double arithmetic evaluated in double (FLT_EVAL_METHOD 0): on x87 build with -msse2 -mfpmath=sse (docs/deploying.md)"
#endif
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#endif
#ifndef EXOTUNE_BUMPLESS_DECAY
#error "EXOTUNE_BUMPLESS_DECAY is defined in exotune_controller.h"
#endif
'''

def peek_clamp_c(real: str, zero: str, b0: str, note: str = "") -> str:
    """The C of ``filter_peek`` (a filter's output for an input without advancing its state: the
    DOB loop's h) and ``clamp`` in the arithmetic ``real`` (``double`` or ``float``; ``zero`` its
    0 literal, ``b0`` the sections' feed-through field).

    Parameters
    ----------
    real : str
        The C type, ``"double"`` or ``"float"``.
    zero : str
        Its zero literal (``"0.0"``, ``"0.0f"``).
    b0 : str
        Name of the sections' feed-through field.
    note : str, optional
        Text appended to the first comment.

    Returns
    -------
    str
        The C source of the two functions.
    """
    return f"""/* the filter's output for input x without advancing its state{note} */
static {real} filter_peek(const exo_section *S, const exo_filter *f, {real} (*z)[2], {real} x)
{{
    int k;
    for (k = f->first; k < f->first + f->count; ++k)
        x = S[k].{b0} * x + z[k][0];
    return x;
}}

static {real} clamp({real} u, {real} limit_nm)
{{
    if (limit_nm > {zero} && isfinite(u))  /* anti-windup: the DOB sees the applied command */
        u = u > limit_nm ? limit_nm : (u < -limit_nm ? -limit_nm : u);
    return u;
}}
"""


# exotune_step's copy of the running controller's states, and its overflow check that restores them
SAVE_C = r'''    for (k = 0; k < c->n_sections; ++k) {
        saved[k][0] = st->z[k][0];
        saved[k][1] = st->z[k][1];
    }
'''
RESTORE_C = r'''    ok = isfinite(u);
    for (k = 0; k < c->n_sections; ++k)
        ok = ok && isfinite(st->z[k][0]) && isfinite(st->z[k][1]);
    if (!ok) {
        for (k = 0; k < c->n_sections; ++k) {
            st->z[k][0] = saved[k][0];
            st->z[k][1] = saved[k][1];
        }
        return EXOTUNE_FAULT_OVERFLOW;
    }
'''

# shared by both ports (exotune.controllerfile.ccode32): the build-info string, the schedule look-up, the
# schedule switch
BUILD_INFO_C = r'''
const char exotune_build_info[] = "exotune_controller sha256=" EXOTUNE_SOURCE_SHA256 " exotune=" EXOTUNE_VERSION
    " certification=" EXOTUNE_CERTIFICATION;
'''
ANGLE_C = r'''int exotune_controller_for_angle(double joint_angle_rad, int *controller)
{
    int i, best = 0;
    double d = 0.0, a = joint_angle_rad, lo, hi;
    if (controller == 0)
        return EXOTUNE_ERR_ARGUMENT;
    if (!isfinite(joint_angle_rad))
        return EXOTUNE_FAULT_ANGLE;
    lo = hi = ANGLES[0];
    for (i = 1; i < EXOTUNE_N_CONTROLLERS - 1; ++i) {
        lo = ANGLES[i] < lo ? ANGLES[i] : lo;
        hi = ANGLES[i] > hi ? ANGLES[i] : hi;
    }
    a = a < lo ? lo : (a > hi ? hi : a);  /* beyond the table: its end entry, even where distances tie */
    for (i = 1; i < EXOTUNE_N_CONTROLLERS; ++i) {  /* the first nearest entry, as the reference runtime */
        double e = fabs(ANGLES[i - 1] - a);
        if (best == 0 || e < d) {
            best = i;
            d = e;
        }
    }
    *controller = best;
    return EXOTUNE_OK;
}

'''
SCHEDULE_C = r'''int exotune_schedule(exotune_state *st, double joint_angle_rad, int mode)
{
    int c = 0, rc;
    const double hysteresis = EXOTUNE_SCHEDULE_HYSTERESIS_RAD;
    if (!state_ok(st) || !mode_ok(mode) || !(hysteresis >= 0.0))  /* checked whether or not the entry changes */
        return EXOTUNE_ERR_ARGUMENT;
    rc = exotune_controller_for_angle(joint_angle_rad, &c);
    if (rc != EXOTUNE_OK || c == st->controller)
        return rc;
    if (st->controller >= 1 && st->controller < EXOTUNE_N_CONTROLLERS) {
        /* hysteresis: keep the running entry until the angle is EXOTUNE_SCHEDULE_HYSTERESIS_RAD past the
         * midpoint between it and the nearest one (their distances then differ by twice that) */
        double a = joint_angle_rad, lo = ANGLES[0], hi = ANGLES[0];
        int i;
        for (i = 1; i < EXOTUNE_N_CONTROLLERS - 1; ++i) {
            lo = ANGLES[i] < lo ? ANGLES[i] : lo;
            hi = ANGLES[i] > hi ? ANGLES[i] : hi;
        }
        a = a < lo ? lo : (a > hi ? hi : a);  /* as exotune_controller_for_angle */
        if (fabs(ANGLES[st->controller - 1] - a) - fabs(ANGLES[c - 1] - a) <= 2.0 * hysteresis)
            return EXOTUNE_OK;
    }
    return exotune_switch(st, c, mode);
}

'''

# exotune_start: the bumpless start of the reference (exotune.simulation.engine.bumpless_start)
START_C = r'''/* the states of filter f at the steady state of the constant input x, as the reference's bumpless
 * start; a section with a pole at z = 1 and x != 0 has none: the whole filter then starts at zero */
static void filter_steady(const exo_section *S, const exo_filter *f, double (*z)[2], double x)
{
    int k;
    for (k = f->first; k < f->first + f->count; ++k) {
        const exo_section *c = &S[k];
        double den = 1.0 + c->a1 + c->a2, y;
        if (fabs(den) <= 1e-12 * (1.0 + fabs(c->a1) + fabs(c->a2))) {
            if (x != 0.0) {
                for (k = f->first; k < f->first + f->count; ++k)
                    z[k][0] = z[k][1] = 0.0;
                return;
            }
            y = 0.0;
        } else {
            y = (c->b0 + c->b1 + c->b2) / den * x;
        }
        z[k][0] = flush(y - c->b0 * x);
        z[k][1] = flush(c->b2 * x - c->a2 * y);
        x = y;
    }
}

int exotune_start(exotune_state *st, const exotune_inputs *y)
{
    const exo_controller *c;
    const exo_section *S;
    double v[5], z[EXOTUNE_MAX_SECTIONS][2], tau0;
    int i, k;
    if (!state_ok(st) || y == 0)
        return EXOTUNE_ERR_ARGUMENT;
    c = &CONTROLLERS[st->controller];
    S = &SECTIONS[c->sec0];
    v[0] = y->theta_m; v[1] = y->omega_m; v[2] = y->tau_s; v[3] = y->dtau_s; v[4] = y->tau_c;
    for (i = 0; i < 5; ++i) {
        if (!isfinite(v[i]))
            return EXOTUNE_FAULT_INPUT;
        v[i] = flush(v[i]);
    }
    tau0 = clamp(-v[2], st->limit_nm);  /* the motor at rest against the spring: zero disturbance estimate */
    for (k = 0; k < EXOTUNE_MAX_SECTIONS; ++k)
        z[k][0] = z[k][1] = 0.0;
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
    st->offset_nm = 0.0;
    for (i = 0; i < 5; ++i)
        st->last[i] = v[i];
    st->has_last = 1;
    return EXOTUNE_OK;
}

'''

# the functions of exotune_controller.c after its tables
STEP_C = (BUILD_INFO_C + r'''
/* zero below EXOTUNE_FLUSH_BELOW: no subnormal number ever enters the arithmetic (constant step time) */
static double flush(double v)
{
    return fabs(v) < EXOTUNE_FLUSH_BELOW ? 0.0 : v;
}

/* NaN and infinity detected, rounding to nearest: what the guards and the golden vectors assume */
static int float_env_ok(void)
{
    volatile double nan_ = (double)NAN, inf_ = (double)INFINITY, one = 1.0, eps = DBL_EPSILON;
    double a = nan_, b = inf_;
    return isnan(a) && !isfinite(a) && isinf(b) && !isfinite(b) && one + 0.5 * eps == one
           && one + 0.75 * eps == one + eps && -one - 0.75 * eps == -one - eps;
}

/* a state exotune_init set up (a zeroed or garbage state is refused: EXOTUNE_ERR_ARGUMENT) */
static int state_ok(const exotune_state *st)
{
    return st != 0 && st->magic == EXOTUNE_STATE_MAGIC && st->controller >= 0 && st->controller < EXOTUNE_N_CONTROLLERS;
}

static int mode_ok(int mode)
{
    return mode == EXOTUNE_SWITCH_RESET || mode == EXOTUNE_SWITCH_BUMPLESS;
}

int exotune_init(exotune_state *st, int controller, double limit_nm)
{
    int i;
    if (st == 0 || controller < 0 || controller >= EXOTUNE_N_CONTROLLERS || !isfinite(limit_nm) || !(limit_nm >= 0.0))
        return EXOTUNE_ERR_ARGUMENT;
    st->magic = 0u;
    st->controller = -1;
    if (!float_env_ok())
        return EXOTUNE_ERR_FLOAT_ENV;
    st->magic = EXOTUNE_STATE_MAGIC;
    st->controller = controller;
    st->has_last = 0;
    st->limit_nm = limit_nm;
    st->offset_nm = 0.0;
    for (i = 0; i < 5; ++i)
        st->last[i] = 0.0;
    for (i = 0; i < EXOTUNE_MAX_SECTIONS; ++i)
        st->z[i][0] = st->z[i][1] = 0.0;
    return EXOTUNE_OK;
}

''' + ANGLE_C + r'''/* one step of a filter (sections S[f->first...], states z[f->first...]), as SosFilter.step */
static double filter_step(const exo_section *S, const exo_filter *f, double (*z)[2], double x)
{
    int k;
    for (k = f->first; k < f->first + f->count; ++k) {
        const exo_section *c = &S[k];
        double *s = z[k];
        double y = c->b0 * x + s[0];
        s[0] = flush(c->b1 * x - c->a1 * y + s[1]);
        s[1] = flush(c->b2 * x - c->a2 * y);
        x = y;
    }
    return x;
}

''' + peek_clamp_c("double", "0.0", "b0", ", as SosFilter.peek") + r'''
/* controller c's command (before the clamp and the offset) for inputs v held, from states z */
static double controller_peek(const exo_controller *c, double (*z)[2], const double *v)
{
    const exo_section *S = &SECTIONS[c->sec0];
    double rest = 0.0, fsum = 0.0, h = 0.0;
    int i;
    for (i = 0; i < c->n_gains; ++i)
        rest += GAINS[c->gain0 + i].gain * v[GAINS[c->gain0 + i].signal];
    for (i = 0; i < c->n_sensed; ++i) {
        const exo_filter *f = &FILTERS[c->filter0 + i];
        fsum += filter_peek(S, f, z, v[f->signal]);
    }
    rest = rest + fsum;
    for (i = 0; i < c->n_loop; ++i)
        h += filter_peek(S, &FILTERS[c->filter0 + c->n_sensed + i], z, 0.0);
    return (rest + h) / (1.0 - c->g);
}

int exotune_switch(exotune_state *st, int controller, int mode)
{
    const exo_controller *o, *n;
    double z[EXOTUNE_MAX_SECTIONS][2], off = 0.0;
    int k, carry;
    if (!state_ok(st) || controller < 0 || controller >= EXOTUNE_N_CONTROLLERS || !mode_ok(mode))
        return EXOTUNE_ERR_ARGUMENT;
    o = &CONTROLLERS[st->controller];
    n = &CONTROLLERS[controller];
    if (mode == EXOTUNE_SWITCH_BUMPLESS && o->layout != n->layout)
        return EXOTUNE_ERR_ARGUMENT;  /* no state to carry over: switch with EXOTUNE_SWITCH_RESET */
    carry = mode == EXOTUNE_SWITCH_BUMPLESS;
    for (k = 0; k < EXOTUNE_MAX_SECTIONS; ++k)
        z[k][0] = z[k][1] = 0.0;
    for (k = 0; carry && k < n->n_sections; ++k) {  /* old state -> (w[k], w[k-1]) -> new state */
        const exo_map *mo = &MAPS[o->sec0 + k], *mn = &MAPS[n->sec0 + k];
        double w0 = mo->w00 * st->z[k][0] + mo->w01 * st->z[k][1];
        double w1 = mo->w10 * st->z[k][0] + mo->w11 * st->z[k][1];
        z[k][0] = flush(mn->m00 * w0 + mn->m01 * w1);
        z[k][1] = flush(mn->m10 * w0 + mn->m11 * w1);
    }
    if (mode == EXOTUNE_SWITCH_BUMPLESS && st->has_last) {
        /* the old controller's command for the last inputs, as applied (offset, clamp) ... */
        double before = clamp(controller_peek(o, st->z, st->last) + st->offset_nm, st->limit_nm);
        /* ... is the new one's at the switch: the difference decays by EXOTUNE_BUMPLESS_DECAY per sample */
        off = before - controller_peek(n, z, st->last);
        if (!isfinite(off))
            return EXOTUNE_FAULT_OVERFLOW;
    }
    for (k = 0; k < EXOTUNE_MAX_SECTIONS; ++k) {
        if (!isfinite(z[k][0]) || !isfinite(z[k][1]))
            return EXOTUNE_FAULT_OVERFLOW;
    }
    for (k = 0; k < EXOTUNE_MAX_SECTIONS; ++k) {
        st->z[k][0] = z[k][0];
        st->z[k][1] = z[k][1];
    }
    st->offset_nm = flush(off);
    if (mode == EXOTUNE_SWITCH_RESET)
        st->has_last = 0;
    st->controller = controller;
    return EXOTUNE_OK;
}

''' + SCHEDULE_C + START_C + r'''int exotune_step(exotune_state *st, const exotune_inputs *y, double *tau_cmd)
{
    const exo_controller *c;
    const exo_section *S;
    double v[5], saved[EXOTUNE_MAX_SECTIONS][2], rest = 0.0, fsum = 0.0, h = 0.0, u;
    int i, k, ok;
    if (!state_ok(st) || y == 0 || tau_cmd == 0)
        return EXOTUNE_ERR_ARGUMENT;
    c = &CONTROLLERS[st->controller];
    S = &SECTIONS[c->sec0];
    v[0] = y->theta_m; v[1] = y->omega_m; v[2] = y->tau_s; v[3] = y->dtau_s; v[4] = y->tau_c;
    for (i = 0; i < 5; ++i) {
        if (!isfinite(v[i]))
            return EXOTUNE_FAULT_INPUT;
        v[i] = flush(v[i]);
    }
''' + SAVE_C + r'''    for (i = 0; i < c->n_gains; ++i)
        rest += GAINS[c->gain0 + i].gain * v[GAINS[c->gain0 + i].signal];
    for (i = 0; i < c->n_sensed; ++i) {
        const exo_filter *f = &FILTERS[c->filter0 + i];
        fsum += filter_step(S, f, st->z, v[f->signal]);
    }
    rest = rest + fsum;
    for (i = 0; i < c->n_loop; ++i)
        h += filter_peek(S, &FILTERS[c->filter0 + c->n_sensed + i], st->z, 0.0);
    u = clamp((rest + h) / (1.0 - c->g) + st->offset_nm, st->limit_nm);
    for (i = 0; i < c->n_loop; ++i)
        filter_step(S, &FILTERS[c->filter0 + c->n_sensed + i], st->z, u);
''' + RESTORE_C + r'''    st->offset_nm = flush(st->offset_nm * EXOTUNE_BUMPLESS_DECAY);
    for (i = 0; i < 5; ++i)
        st->last[i] = v[i];
    st->has_last = 1;
    *tau_cmd = u;
    return EXOTUNE_OK;
}''')
