"""exotune.analysis.counting: right-half-plane root counts against independent references —
numpy.roots for delay-free polynomials, the closed-form critical delay of s + a + b e^{−sT}, and
the coupled verdicts of the paper design at zero delay against the roots of its polynomial."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from exotune.analysis.charfun import char_terms
from exotune.analysis.counting import RootCounter, coupled_stable, free_stability, rhp_count
from exotune.model.controller import build_controller
from exotune.numerics.quasipoly import QP
from tests.paper_design import paper_design


def _rhp_by_numpy(p):
    p = np.trim_zeros(np.asarray(p, float), "b")
    return int(np.sum(np.roots(p[::-1]).real > 0))


@settings(max_examples=40, deadline=None)
@given(roots=st.lists(st.tuples(st.floats(-5.0, 5.0), st.floats(0.0, 5.0)), min_size=1, max_size=3))
def test_delay_free_counts_equal_numpy_roots(roots):
    # polynomials with roots away from the imaginary axis (|Re| ≥ 0.05)
    poly = np.array([1.0])
    for re, im in roots:
        re = re if abs(re) >= 0.05 else math.copysign(0.05, re or 1.0)
        if im < 0.05:
            poly = np.convolve(poly, [1.0, -re])  # descending: s − re
        else:
            poly = np.convolve(poly, [1.0, -2 * re, re * re + im * im])
    asc = poly[::-1][None, :]
    n, r, ok = rhp_count(QP(asc, np.zeros((1, 1)), 0.0))
    assert ok[0] and r[0] == 0
    assert int(n[0]) == _rhp_by_numpy(asc[0])


def test_rigid_body_roots_are_divided_out_first():
    # s² (s + 1)(s − 2): two exact roots at 0, one in the RHP
    asc = np.convolve(np.convolve([1.0, 0.0, 0.0], [1.0, 1.0]), [1.0, -2.0])[::-1][None, :]
    n, r, ok = rhp_count(QP(asc, np.zeros((1, 1)), 0.0))
    assert ok[0] and int(r[0]) == 2 and int(n[0]) == 1


@pytest.mark.parametrize("a,b", [(1.0, 3.0), (2.0, 5.0), (-0.5, 4.0)])
@pytest.mark.parametrize("engine", ["numpy", None])
def test_the_critical_delay_of_a_first_order_delay_equation(a, b, engine):
    """s + a + b e^{−sT} with b > |a| is stable exactly for T < arccos(−a/b)/√(b² − a²)
    (a > −b: stable at T = 0); past it one pair of roots has crossed to the RHP."""
    w = math.sqrt(b * b - a * a)
    Tc = math.acos(-a / b) / w
    T = np.array([0.5, 0.95, 1.05, 1.5]) * Tc
    c = RootCounter()
    h = c.add(np.tile([[a, 1.0]], (4, 1)), np.tile([[b]], (4, 1)), T)
    c.run(engine=engine)
    n, r, ok = c.result(h)
    assert ok.all() and (r == 0).all()
    np.testing.assert_array_equal(n, [0, 0, 2, 2])


@settings(max_examples=20, deadline=None)
@given(a=st.floats(0.5, 10.0), frac=st.floats(0.0, 0.95), T=st.floats(0.0, 2.0))
def test_a_dominant_real_term_is_stable_for_every_delay(a, frac, T):
    """|b| < a: s + a + b e^{−sT} has no RHP root for any T ≥ 0."""
    for b in (frac * a, -frac * a):
        n, r, ok = rhp_count(QP(np.array([[a, 1.0]]), np.array([[b]]), T))
        assert ok[0] and n[0] == 0 and r[0] == 0


def test_both_engines_agree_on_a_batch():
    rng = np.random.default_rng(3)
    P0 = np.column_stack([rng.uniform(-2, 5, 30), rng.uniform(0.5, 3, 30), np.ones(30)])
    P1 = np.column_stack([rng.uniform(-4, 4, 30), rng.uniform(-1, 1, 30)])
    T = rng.uniform(0.0, 1.0, 30)
    out = []
    for engine in ("numpy", None):
        c = RootCounter()
        h = c.add(P0, P1, T)
        c.run(engine=engine)
        out.append(c.result(h))
    ok = out[0][2] & out[1][2]
    assert ok.mean() > 0.9
    np.testing.assert_array_equal(out[0][0][ok], out[1][0][ok])


@pytest.mark.parametrize("human,env", [(None, None), ({"stiffness": 300.0, "damping": 2.0}, None),
                                       ({"inertia": 0.3}, {"stiffness": 1e3, "damping": 1.0}),
                                       ({"stiffness": 50.0}, "locked")])
def test_coupled_verdicts_at_zero_delay_equal_the_roots_of_the_polynomial(human, env):
    cfg = paper_design(dob=None, delay_s=0.0)
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    got = coupled_stable(cfg.plant, cs, 1, human=human, env=env)
    ct = char_terms(cfg.plant, cs, 1)
    z = lambda d: np.array([d.get("stiffness", 0.0), d.get("damping", 0.0), d.get("inertia", 0.0)])  # noqa: E731
    P = lambda k: ct.qp(k).p0[0] if not ct.qp(k).p1.size else np.polynomial.polynomial.polyadd(  # noqa: E731
        ct.qp(k).p0[0], ct.qp(k).p1[0])
    mul = np.polynomial.polynomial.polymul
    add = np.polynomial.polynomial.polyadd
    zh = z(human) if human else np.zeros(1)
    if env == "locked":
        poly = add(P("01"), mul(zh, P("11")))
    else:
        ze = z(env) if env else np.zeros(1)
        poly = add(add(P("00"), mul(zh, P("10"))), add(mul(ze, P("01")), mul(mul(zh, ze), P("11"))))
    poly = np.asarray(poly, float)
    r = int(np.argmax(np.abs(poly) > 0))  # exact zero low-order coefficients: rigid-body roots
    assert int(got["rigid_body_roots"][0]) == r
    assert bool(got["conclusive"][0])
    assert int(got["n_rhp"][0]) == _rhp_by_numpy(poly[r:])
    assert bool(got["stable"][0]) == (got["n_rhp"][0] == 0 and r <= (0 if env == "locked" else 1))


def test_free_stability_of_the_paper_design_and_of_a_destabilizing_delay():
    cfg = paper_design()
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    v = free_stability(char_terms(cfg.plant, cs, 1))
    assert v["stable"][0] and v["conclusive"][0] and v["rigid_body_roots"][0] <= 1
    cfg = paper_design(delay_s=0.2)
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    v = free_stability(char_terms(cfg.plant, cs, 1))
    assert not v["stable"][0] and v["n_rhp"][0] > 0


# Extreme designs (the paper example's parameters scaled by up to 10⁴ either way) on which the
# engines once disagreed about whether a verdict was conclusive: the numpy reference gave a count a
# budget of 100 000 leaves (the frequency sets' budget) instead of 200 000 evaluations, and its
# family sub-interval counts no shared budget per family (docs/benchmarks.md#work-budgets).
_LONG_WINDING = {  # free, locked and amplification counts of about 10⁵ evaluations each
    "plant.motor_inertia": 0.0012778699540307108, "plant.motor_damping": 4794.385795964856,
    "plant.sea_stiffness": 593.2398609717865, "plant.joint_inertia": 1.6697971080861416,
    "plant.cuff_stiffness": 17223630.08521481, "design.amplification": 1.1574959041315844,
    "design.felt_inertia": 0.5078638392320824, "design.felt_damping": 3806.0003058581715,
    "design.zeta": 0.6141940968213624, "design.zeta_hat": 18.983109013154156,
    "implementation.delay_s": 0.0035549255028860883}
_FAMILY_OVER_BUDGET = {  # the spring family's sub-interval counts need more than their shared budget
    "plant.motor_inertia": 0.00010131685239030305, "plant.motor_damping": 0.7944039963770619,
    "plant.sea_stiffness": 0.15677674762966032, "plant.joint_inertia": 4.8040274936434046e-05,
    "plant.cuff_stiffness": 3871.5750804310255, "design.amplification": 127.47459641543331,
    "design.felt_inertia": 0.40854135214500986, "design.felt_damping": 0.006023196344337474,
    "design.zeta": 0.010440169650284426, "design.zeta_hat": 0.019258027097804952,
    "implementation.delay_s": 0.1403082333312994}


def test_both_engines_spend_the_same_work_budgets_on_extreme_designs():
    """The same verdict and the same conclusive flag in both engines: the long winding's counts
    fit the counts' budget of evaluations (conclusive, unstable: it has right-half-plane roots,
    e.g. 5.150 ± 14.32j found by a high-order Padé approximation refined by Newton's method on the
    exact characteristic function), and the spring family spends its shared budget in both."""
    from exotune.analysis.batch import analyze_batch
    from exotune.config import batch_config, load_design
    from exotune.numerics.engine import numpy_engine

    base = load_design("examples/paper.yaml")
    cfg = batch_config(base, {k: np.array([_LONG_WINDING[k], _FAMILY_OVER_BUDGET[k]]) for k in _LONG_WINDING})
    with np.errstate(all="ignore"):
        a = analyze_batch(cfg).to_columns()
        with numpy_engine():
            b = analyze_batch(cfg).to_columns()
    assert a["free_conclusive"][0] and not a["free_stable"][0]
    assert a["locked_conclusive"][0] and a["amplification_conclusive"][0]
    assert not a["human1_spring_conclusive"][1]
    for k in a:
        if k.endswith(("_stable", "_robust", "_conclusive")):
            np.testing.assert_array_equal(np.asarray(a[k]), np.asarray(b[k]), err_msg=k)
