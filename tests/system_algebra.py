"""The paper's system algebra on a design's implemented controller blocks: the independent
reference that several test files compare the characteristic-function route with.

Table II's seven systems (Propositions 1–4 composed as exact frequency responses,
exotune.model.plant.seven_systems) built from the blocks G_θ, G_s, G_c that
exotune.model.controller.build_controller implements (filters included; no DOB: the algebra has
no observer)."""

from __future__ import annotations

import numpy as np

from exotune.analysis.charfun import amplification_qps
from exotune.model.controller import build_controller
from exotune.model.plant import Tf, seven_systems


def implemented_systems(cfg, delay_s: float | None = None) -> dict:
    """S1 … S7 of one design's implemented blocks, with its delay (or ``delay_s`` [s])."""
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    tf = lambda r: Tf.rational(np.atleast_2d(r.num)[0], np.atleast_2d(r.den)[0])  # noqa: E731
    T = float(cfg.implementation.delay_s) if delay_s is None else float(delay_s)
    return seven_systems(cfg.plant, tf(cs.motor_position), tf(cs.spring_torque), tf(cs.cuff_torque), delay_s=T)


def amplification_magnitude(cfg, f_hz) -> np.ndarray:
    """|C6/C5|(j2πf) of one design: by the system algebra without a DOB, else by the ratio of the
    amplification's quasi-polynomials (the observer is outside the algebra)."""
    w = 2 * np.pi * np.asarray(f_hz, dtype=float)
    if cfg.implementation.dob is None:
        S = implemented_systems(cfg)
        return np.abs(np.ravel(S["S6"].C(1j * w)) / np.ravel(S["S5"].C(1j * w)))
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    num, den = amplification_qps(cfg.plant, cs, 1)
    rows = np.zeros(w.size, int)
    return np.abs(num.eval(rows, w, deriv=False)[0] / den.eval(rows, w, deriv=False)[0])
