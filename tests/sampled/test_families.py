"""exotune.sampled.families: a family's sampled-data stable intervals and the sampled-data latency
margin of a batch, against point-wise bisection on the loop model of exotune.sampled.loop; the
margin's bracketing (first_crossing, shared by the sweep and certify) on synthetic monotone probes."""

import copy
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from exotune.config import batch_config, design_from_mapping
from exotune.model.controller import build_controller
from exotune.sampled.batch import BatchLoops, Loop
from exotune.sampled.families import MARGIN_REL, family_check, family_loops, first_crossing, latency_margin
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
    margin = latency_margin(bl, [0, 1], [(MASS, lo, hi, chk["critical"])]).extra_delay_s
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


class _Monotone:
    """Synthetic probes: ρ_q(ΔT) = exp(k_q (ΔT − t_q)) per design, unstable from t_q on (the
    verdict exact: ΔT < t_q); the predicate "some probe unstable at ΔT" turns true at min_q t_q."""

    def __init__(self, t: np.ndarray, k: np.ndarray):
        self.t, self.k = t, k

    def __len__(self):
        return self.t.shape[1]

    def all(self, idx, x):
        with np.errstate(over="ignore"):
            return np.exp(self.k[idx] * (x[:, None] - self.t[idx])), x[:, None] < self.t[idx]

    def one(self, idx, which, x):
        with np.errstate(over="ignore"):
            return np.exp(self.k[idx, which] * (x - self.t[idx, which])), x < self.t[idx, which]


TS = 1e-3


@settings(max_examples=150, deadline=None)
@given(st.data())
def test_first_crossing_brackets_the_first_unstable_delay(data):
    """lo < hi, no probe unstable at lo, some at hi, hi/lo − 1 ≤ rel — for random thresholds from
    far below half a sample to beyond the cap (then hi = inf and lo = cap), with no hint, a good
    one or a wrong one."""
    n, P = data.draw(st.integers(1, 4)), data.draw(st.integers(1, 5))
    floats = lambda a, b, m: np.array(data.draw(st.lists(st.floats(a, b), min_size=m, max_size=m)))  # noqa: E731
    t = TS * 10.0 ** floats(-2.5, 2.7, n * P).reshape(n, P)  # 0.003 samples … 500 samples
    k = 10.0 ** floats(0.5, 4.5, n * P).reshape(n, P)  # ρ grows e-fold over 0.03 … 300 samples
    cap = 200 * TS - TS * floats(0.0, 3.0, n)
    rel = data.draw(st.sampled_from([MARGIN_REL, 1e-6, 1e-3]))
    kind = data.draw(st.sampled_from(["none", "nan", "near", "any"]))
    first = t.min(axis=1)
    hint = {"none": None, "nan": np.full(n, np.nan), "near": first * 10.0 ** floats(-0.5, 0.5, n),
            "any": floats(-0.01, 0.5, n)}[kind]
    idx = np.arange(n)
    lo, hi, _slope = first_crossing(_Monotone(t, k), idx, hint, TS, cap, rel)
    for i in range(n):
        if first[i] > cap[i]:
            assert hi[i] == np.inf and lo[i] == cap[i]
            continue
        assert 0.0 < lo[i] < hi[i] and lo[i] < first[i] <= hi[i]  # predicate false at lo, true at hi
        assert hi[i] / lo[i] - 1.0 <= rel


def test_family_loops_of_a_design(design):
    loops = family_loops(design.humans, design.environment)
    names = [loop.name for loop, _lo, _hi in loops]
    assert names == ["human0_mass", "human1_spring"]  # the hysteretic human has no sampled-data loop
    (mass, lo, hi), (spring, _a, _b) = loops
    assert (mass.param, lo, hi) == ("inertia", 0.001, 1.0) and mass.human["damping"] == 0.0
    assert spring.param == "stiffness" and spring.env == "free" and spring.env_param is None
