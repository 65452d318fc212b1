"""The per-design python-control workflow the benchmarks compare against.

For one design (plain dicts, no exotune code): the gains and the default G_c,impl from the docs/method.md#controller, docs/method.md#double-compliance-shaping
formulas (tests/reference_model.py), then

* free-cuff closed-loop poles (state space with an 8th-order Padé delay, python-control ``ss``);
* coupled closed-loop poles for a log grid of 50 human inertias (1e-3 … 1 kg·m²) and 50 human
  spring stiffnesses (1 … 1e4 N·m/rad);
* ``control.stability_margins`` of L_dob(s) = Q(s) e^{−sT}/(1 − Q(s)) (Padé delay).

This answers a coarser question than exotune (trial values on a grid instead of exact stable
intervals, a Padé delay instead of the exact one), so the rate comparison favours python-control.
"""

from __future__ import annotations

import math
import sys
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
for p in (ROOT, ROOT / "tests"):
    if str(p) not in sys.path:
        sys.path.insert(0, str(p))

import control  # noqa: E402

from reference_model import closed_loop_poles, reference_gains, reference_gc  # noqa: E402

INERTIAS = np.logspace(-3, 0, 50)
SPRINGS = np.logspace(0, 4, 50)
PADE_ORDER = 8


def design_dicts(cfg, i: int | None = None):
    """(plant, design, impl) dicts of design i of a (batch) DesignConfig."""
    def g(x):
        x = np.asarray(x, dtype=float)
        return float(x if x.ndim == 0 else x[i])

    pl = cfg.plant
    plant = dict(J_m=g(pl.J_m), B_m=g(pl.B_m), K_s=g(pl.K_s), J_j=g(pl.J_j), K_c=g(pl.K_c))
    d = cfg.design
    design = dict(amplification=g(d.amplification), felt_inertia=g(d.felt_inertia), felt_damping=g(d.felt_damping),
                  zeta=g(d.zeta), zeta_hat=g(d.zeta_hat))
    im = cfg.implementation
    impl = dict(
        T=g(im.delay_s),
        gv=dict(cutoff_hz=g(im.gv_filter.cutoff_hz), damping=g(im.gv_filter.damping)),
        fd=dict(cutoff_hz=g(im.derivative_filter.cutoff_hz)),
        dob=None if im.dob is None else dict(cutoff_hz=g(im.dob.cutoff_hz), damping=g(im.dob.damping)),
    )
    return plant, design, impl


def dob_margins(impl: dict):
    """``control.stability_margins`` (gm, pm, wcg, wcp) of L_dob = Q/(1 − Q)·Padé(e^{−sT}); None
    without a DOB."""
    if impl["dob"] is None:
        return None
    wq = 2 * math.pi * impl["dob"]["cutoff_hz"]
    zq = impl["dob"]["damping"]
    Q = control.tf([wq * wq], [1.0, 2 * zq * wq, wq * wq])
    L = control.minreal(Q / (1 - Q), verbose=False)
    if impl["T"] > 0:
        L = L * control.tf(*control.pade(impl["T"], PADE_ORDER))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return tuple(control.stability_margins(L)[:4])


def per_design(plant: dict, design: dict, impl: dict) -> dict:
    gains = reference_gains(plant, design)
    gains["Gc"] = reference_gc(plant, design, impl["gv"], impl["fd"])
    ri = {"T": impl["T"], "dob": impl["dob"]}
    free = closed_loop_poles(plant, gains, ri, None, "free", PADE_ORDER)
    mass = [closed_loop_poles(plant, gains, ri, {"kind": "mass", "inertia": m}, "free", PADE_ORDER) for m in INERTIAS]
    spring = [closed_loop_poles(plant, gains, ri, {"kind": "spring", "stiffness": k}, "free", PADE_ORDER) for k in SPRINGS]
    margins = dob_margins(impl)
    return {
        "free_max_re": float(np.max(np.delete(free, np.argmin(np.abs(free))).real)),
        "mass_stable": [bool(np.max(p.real) < 0) for p in mass],
        "spring_stable": [bool(np.max(p.real) < 0) for p in spring],
        "dob_margins": margins,
    }


def measure_rate(fn, cfg, m: int) -> float:
    """designs/s of ``fn(plant, design, impl)`` over the first ``m`` designs of a batch config (one
    warm-up call first)."""
    import time

    fn(*design_dicts(cfg, 0))
    t0 = time.perf_counter()
    for i in range(m):
        fn(*design_dicts(cfg, i))
    return m / (time.perf_counter() - t0)
