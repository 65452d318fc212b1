"""Property test of the whole analysis pipeline: scaling every torque by c (all inertias, dampings,
stiffnesses of plant, design and human/environment families × c) leaves the closed loop unchanged
(K2, B2, K̂2, B̂2 are torque ratios), so every verdict is the same, every interval scales by c, and
the frequency-domain metrics are identical. Also: intervals are sorted, disjoint and in range."""

from __future__ import annotations

import dataclasses

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from exotune.analysis import analyze_batch
from exotune.config import load_design
from exotune.model.humans import EnvModel, HumanFamily

ROOT = __import__("pathlib").Path(__file__).resolve().parents[2]
BASE = load_design(ROOT / "examples" / "paper.yaml")


def _scaled(cfg, c):
    p = cfg.plant
    plant = dataclasses.replace(p, motor_inertia=p.motor_inertia * c, motor_damping=p.motor_damping * c,
                                sea_stiffness=p.sea_stiffness * c, joint_inertia=p.joint_inertia * c,
                                cuff_stiffness=p.cuff_stiffness * c)
    d = cfg.design
    design = dataclasses.replace(d, felt_inertia=d.felt_inertia * c, felt_damping=d.felt_damping * c)
    humans = tuple(dataclasses.replace(h, lo=h.lo * c, hi=h.hi * c, inertia=h.inertia * c, damping=h.damping * c,
                                       stiffness=h.stiffness * c) for h in cfg.humans)
    env = tuple(dataclasses.replace(e, lo=e.lo * c, hi=e.hi * c, damping=e.damping * c) if e.lo is not None else e
                for e in cfg.environment)
    return dataclasses.replace(cfg, plant=plant, design=design, humans=humans, environment=env)


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    c=st.floats(1e-3, 1e3),
    alpha=st.floats(1.0, 25.0),
    zeta_hat=st.floats(0.3, 1.3),
    delay=st.floats(0.0, 0.004),
    kc=st.floats(50.0, 3000.0),
)
def test_torque_scaling_invariance(c, alpha, zeta_hat, delay, kc):
    cfg = dataclasses.replace(
        BASE,
        plant=dataclasses.replace(BASE.plant, cuff_stiffness=kc),
        design=dataclasses.replace(BASE.design, amplification=alpha, zeta_hat=zeta_hat),
        implementation=dataclasses.replace(BASE.implementation, delay_s=delay),
        humans=BASE.humans + (HumanFamily("msd", "damping", 0.0, 50.0, inertia=0.05, stiffness=30.0),
                              HumanFamily("spring", "stiffness", 1.0, 1e4, damping=2.0)),
        environment=(EnvModel("locked"), EnvModel("spring", "stiffness", 10.0, 1e5, damping=1.0)),
    )
    a = analyze_batch(cfg).to_columns()
    b = analyze_batch(_scaled(cfg, c)).to_columns()
    for k in a:
        x, y = a[k], b[k]
        if k.endswith("_stable_intervals"):
            for u, v in zip(x, y):
                assert len(u) == len(v), (k, u, v)
                for (u0, u1), (v0, v1) in zip(u, v):
                    assert np.isclose(v0, c * u0, rtol=1e-6) and np.isclose(v1, c * u1, rtol=1e-6), (k, u, v)
                for lo_hi in (u,):
                    flat = [z for iv in lo_hi for z in iv]
                    assert flat == sorted(flat)  # sorted and disjoint
        elif k.endswith("_critical"):
            continue  # values scale, frequencies equal: covered by the intervals
        elif k in ("K1", "B1"):
            assert np.allclose(y, c * x, rtol=1e-9, atol=1e-12), k
        elif isinstance(x, np.ndarray) and x.dtype.kind == "b":
            assert np.array_equal(x, y), k
        elif isinstance(x, np.ndarray):
            assert np.allclose(x, y, rtol=1e-6, atol=1e-9, equal_nan=True), (k, x, y)
        else:  # frequency bands (passivity): identical
            for u, v in zip(x, y):
                assert len(u) == len(v), (k, u, v)
                for iu, iv in zip(u, v):
                    assert np.allclose(iu, iv, rtol=1e-6), (k, u, v)
