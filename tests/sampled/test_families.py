"""exotune.sampled.families: a family's sampled-data stable intervals and the sampled-data latency
margin of a batch, against point-wise bisection on the loop model of exotune.sampled.loop."""

import copy
import math

import numpy as np
import pytest

from exotune.config import batch_config, design_from_mapping
from exotune.model.controller import build_controller
from exotune.sampled.batch import BatchLoops, Loop
from exotune.sampled.families import family_check, latency_margin
from exotune.sampled.loop import default_prewarp, sampled_stable, sampled_verdict

from paper_design import paper_design

FS = 1000.0
MASS = Loop("h", human={"damping": 0.0}, param="inertia")


@pytest.fixture(scope="module")
def design():
    return paper_design(sample_rate_hz=FS)


def _stable(cfg, human=None, env="free", extra_delay=0.0):
    impl = cfg.implementation
    if extra_delay:
        from dataclasses import replace
        impl = replace(impl, delay_s=float(impl.delay_s) + extra_delay)
    cs, _ = build_controller(cfg.plant, cfg.design, impl)
    return sampled_stable(cfg.plant, cs, FS, human, env, prewarp=default_prewarp(impl))[0]


def _bisect(pred, a, b, steps=50):
    """The switch of pred between a (pred(a)) and b (not pred(b)), geometric bisection."""
    assert pred(a) != pred(b)
    sa = pred(a)
    for _ in range(steps):
        m = math.sqrt(a * b)
        a, b = (m, b) if pred(m) == sa else (a, m)
    return math.sqrt(a * b)


def test_light_mass_boundary_matches_pointwise_bisection(design):
    bl = BatchLoops(batch_config(design, {}), FS)
    chk = family_check(bl, [0], MASS, 0.001, 1.0)
    (ivs,) = chk["stable_intervals"]
    assert len(ivs) == 1 and ivs[0][1] == 1.0 and not chk["robust"][0]
    ref = _bisect(lambda m: _stable(design, {"inertia": m, "damping": 0.0}), 0.002, 0.02)
    assert ivs[0][0] == pytest.approx(ref, rel=1e-6)
    # the critical member: the largest spectral radius of the members evaluated, as the point-wise loop has it
    owner, v, rho = chk["points"]
    assert chk["critical_radius"][0] == pytest.approx(rho.max()) and chk["critical_radius"][0] > 1.0
    assert 0.001 <= chk["critical"][0] < ivs[0][0]
    cs, _ = build_controller(design.plant, design.design, design.implementation)
    rho_pw = sampled_verdict(design.plant, cs, FS, {"inertia": chk["critical"][0], "damping": 0.0},
                             prewarp=default_prewarp(design.implementation))[1]
    assert chk["critical_radius"][0] == pytest.approx(rho_pw, rel=1e-8)
    assert chk["unresolved"] == [[]] and chk["evaluations"] > 0


def test_a_robust_family(design):
    bl = BatchLoops(batch_config(design, {}), FS)
    chk = family_check(bl, [0], MASS, 0.05, 1.0)
    assert chk["stable_intervals"] == [[[0.05, 1.0]]] and chk["robust"].tolist() == [True]
    assert chk["critical_radius"][0] < 1.0


def test_latency_margin_is_where_a_probe_loop_turns_unstable(design):
    b = batch_config(design, {"design.amplification": np.array([4.0, 8.0])})
    bl = BatchLoops(b, FS)
    lo, hi = 0.05, 1.0  # a robust mass family
    chk = family_check(bl, [0, 1], MASS, lo, hi)
    assert chk["robust"].all()
    margin = latency_margin(bl, [0, 1], [(MASS, lo, hi, chk["critical"])])
    assert np.all(np.isfinite(margin)) and np.all(margin > 0)
    for i, amp in enumerate((4.0, 8.0)):
        raw = copy.deepcopy(design.raw)
        raw["design"]["amplification"] = amp
        cfg = design_from_mapping(raw)
        probes = [(None, "free"), (None, "locked"), ({"inertia": lo, "damping": 0.0}, "free"),
                  ({"inertia": hi, "damping": 0.0}, "free"), ({"inertia": chk["critical"][i], "damping": 0.0}, "free")]
        ok = lambda extra: all(_stable(cfg, h, e, extra) for h, e in probes)  # noqa: E731
        assert ok(margin[i] * 0.999)
        assert not ok(margin[i] * 1.001)
