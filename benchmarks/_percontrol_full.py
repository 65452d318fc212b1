"""A per-design python-control workflow that produces the *same outputs* as exotune's §5 analysis.

``_percontrol.per_design`` is the minimal workflow (pole checks at 50 + 50 trial values and the DOB
margins): it answers a coarser question than exotune. This module answers the questions a sweep
row answers, the way an engineer would with python-control, one design at a time, using the
independent state-space reference of the tests (tests/reference_model.py, Padé(8) delay):

* ``free_stable``, ``locked_stable``: closed-loop eigenvalues (rigid-body pole tolerated);
* each rational human family of the design file (mass, spring): stable intervals — eigenvalues at
  50 log-spaced trial values, then every verdict change bisected (log scale) to 1e-9 relative,
  as exotune's critical values are exact;
* passivity: ``control.frequency_response`` of C7 = θ_h/τ_h (cuff free) on 2 000 log-spaced
  frequencies (0.01 Hz – 10 kHz): max phase excess over [−180°, 0°] and the non-passive bands;
* DOB margins: ``control.stability_margins`` of L_dob (as in ``_percontrol``);
* amplification: C6/C5 = (C7 − 1/K_c)/C5 from the same frequency response (C5 = θ_j/τ_env), DC value,
  first −3 dB frequency bisected to 1e-9 relative, minimum phase from the zeros of the rational
  (Padé) numerator C7 − 1/K_c and the poles of C5.

Still in python-control's favour: the complex-stiffness (hysteretic) family is not rational, so it
is skipped here (exotune analyses it); the frequency grid is fixed (exotune's is adaptive and
catches near-undamped resonances a fixed grid steps over); the delay is a Padé approximant.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

import control  # noqa: F401  (the workflow is python-control's; imported for clarity)

from _percontrol import PADE_ORDER, dob_margins
from reference_model import (  # noqa: E402
    closed_loop_poles,
    closed_loop_system,
    free_rigid_body_tolerant_max_real,
    has_rigid_body_mode,
    reference_gains,
    reference_gc,
)

N_TRIAL = 50
RTOL = 1e-9
W = 2 * np.pi * np.geomspace(0.01, 1e4, 2000)
FAMILIES = (("mass", "inertia", 1e-3, 1.0), ("spring", "stiffness", 1.0, 1e4))  # examples/paper.yaml


def _stable(plant, gains, ri, human=None, env="free") -> bool:
    p = closed_loop_poles(plant, gains, ri, human, env, PADE_ORDER)
    rigid = has_rigid_body_mode(gains, human, env)
    return free_rigid_body_tolerant_max_real(p, rigid, check=False) < 0


def _intervals(stable_at, lo: float, hi: float):
    v = np.geomspace(lo, hi, N_TRIAL)
    s = [stable_at(x) for x in v]
    bounds = [lo]
    for i in range(N_TRIAL - 1):
        if s[i] != s[i + 1]:
            a, b = v[i], v[i + 1]
            while b / a - 1.0 > RTOL:
                m = math.sqrt(a * b)
                if stable_at(m) == s[i]:
                    a = m
                else:
                    b = m
            bounds.append(math.sqrt(a * b))
    bounds.append(hi)
    # the verdict of each piece is the verdict at its trial values
    out, j = [], 0
    for i in range(len(bounds) - 1):
        while j < N_TRIAL - 1 and v[j] < bounds[i]:
            j += 1
        if s[min(j, N_TRIAL - 1)]:
            out.append([bounds[i], bounds[i + 1]])
    return out


def per_design_full(plant: dict, design: dict, impl: dict) -> dict:
    gains = reference_gains(plant, design)
    gains["Gc"] = reference_gc(plant, design, impl["gv"], impl["fd"])
    ri = {"T": impl["T"], "dob": impl["dob"]}
    out = {"free_stable": _stable(plant, gains, ri), "locked_stable": _stable(plant, gains, ri, env="locked")}
    for kind, param, lo, hi in FAMILIES:
        out[f"{kind}_stable_intervals"] = _intervals(lambda x: _stable(plant, gains, ri, {"kind": kind, param: x}), lo, hi)
    # passivity and amplification from one frequency response of the cuff-free closed loop
    sys = closed_loop_system(plant, gains, ri, None, "free", PADE_ORDER)
    o, i = sys.output_labels, sys.input_labels
    c7_sys = sys[o.index("theta_h"), i.index("tau_h")]
    c5_sys = sys[o.index("theta_j"), i.index("tau_env")]
    c7 = np.ravel(control.frequency_response(c7_sys, W).complex)
    ph = np.degrees(np.angle(c7))
    out["passivity_max_phase_excess_deg"] = float(np.max(np.where(ph > 0, np.minimum(ph, 180.0 - ph), 0.0)))
    inside = np.imag(c7) > 0
    edges = np.nonzero(np.diff(inside.astype(int)))[0]
    out["passivity_nonpassive_band_hz"] = [float(W[e] / (2 * np.pi)) for e in edges]
    Kc = plant["K_c"]

    def amp(w):
        a = np.ravel(control.frequency_response(c7_sys, np.atleast_1d(w)).complex)
        b = np.ravel(control.frequency_response(c5_sys, np.atleast_1d(w)).complex)
        return (a - 1.0 / Kc) / b

    r = np.abs((c7 - 1.0 / Kc) / np.ravel(control.frequency_response(c5_sys, W).complex))
    dc = float(r[0])
    below = np.nonzero(r < dc / math.sqrt(2))[0]
    bw = math.inf
    if below.size and below[0] > 0:
        a, b = W[below[0] - 1], W[below[0]]
        while b / a - 1.0 > RTOL:
            m = math.sqrt(a * b)
            if abs(amp(m)[0]) >= dc / math.sqrt(2):
                a = m
            else:
                b = m
        bw = math.sqrt(a * b) / (2 * np.pi)
    out["amplification_dc"], out["amplification_bandwidth_hz"] = dc, bw
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        z = control.ss2tf(c7_sys - control.ss([], [], [], 1.0 / Kc)).zeros()
        p5 = control.ss2tf(c5_sys).poles()
    rhp = lambda r: np.real(r) > 1e-9 * max(1.0, float(np.max(np.abs(r), initial=1.0)))  # noqa: E731
    out["amplification_minimum_phase"] = not (rhp(z).any() or rhp(p5).any())
    out["dob_margins"] = dob_margins(impl)
    return out
