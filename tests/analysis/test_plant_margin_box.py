"""exotune.analysis.plant_margin_box: the vertex counts of a box equal the point-wise exact counts
(and the verdicts of an independent Padé root check), strip_rows and hull_distance on hand-made
cases with known answers, and certify_loop never certifying a box with an unstable vertex or interior
sample (hypothesis on small boxes of the free loop of examples/scheduled.yaml, whose plant margin is
about 0.74, so boxes on both sides of the boundary occur)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import exotune
from exotune.analysis.crosscheck import pade_stable
from exotune.analysis.plant_margin import loop_counts_at, plant_loops
from exotune.analysis.plant_margin_box import LoopModel, certify_loop, hull_distance, strip_rows
from exotune.model.controller import build_controller

SCHEDULED = "examples/scheduled.yaml"


@pytest.fixture(scope="module")
def loops():
    cfg = exotune.load_design(SCHEDULED)
    cs = build_controller(cfg.plant, cfg.design, cfg.implementation)[0]
    return {name: LoopModel(cs, cfg.plant, fam, k0, k1) for name, fam, k0, k1 in plant_loops(cfg)}


def _stable(N, r, ok, r0=1):
    return ok & (N == 0) & (r <= r0)


def test_box_points_are_the_vertices(loops):
    m = loops["free"]
    assert m.ndim == 5
    lo, hi = np.array([-0.1, -0.2, 0.0, 0.1, -0.3]), np.array([0.1, 0.2, 0.3, 0.2, 0.3])
    q, p = m.box_points(lo, hi)
    assert p is None and q.shape == (32, 5)
    want = {tuple(np.round(m.q0 * (1 + np.array(c)), 12)) for c in itertools.product(*zip(lo, hi))}
    assert {tuple(np.round(row, 12)) for row in q} == want


@pytest.mark.parametrize("k", [0.5, 0.9])
def test_vertex_counts_equal_pointwise_counts_and_pade(loops, k):
    m = loops["free"]
    q, _ = m.box_points(-k * np.ones(5), k * np.ones(5))
    N, r, ok = m.counts(q, None)
    for i in range(q.shape[0]):
        Ni, ri, oki = m.counts(q[i:i + 1], None)
        assert (Ni[0], ri[0], oki[0]) == (N[i], r[i], ok[i])
        _, P0, P1 = strip_rows(*m.coeffs(q[i:i + 1], None))
        stable, _ = pade_stable(P0[0], P1[0], m.T, 16, allowed_rigid=0)
        assert bool(_stable(N[i], r[i], ok[i])) == bool(stable), (k, q[i])
    assert _stable(N, r, ok).all() == (k == 0.5)  # margin ≈ 0.74


def test_family_vertex_counts_are_plant_major_member_minor(loops):
    name = next(n for n in loops if n.startswith("human0"))
    m = loops[name]
    assert m.ndim == 6
    lo = np.r_[-0.2 * np.ones(5), 0.01]  # the mass family: inertia in [0.01, 1] kg·m²
    hi = np.r_[0.2 * np.ones(5), 1.0]
    q, p = m.box_points(lo, hi)
    assert q.shape == (32, 5) and p.size == 2
    N, r, ok = m.counts(q, p)
    assert N.size == 64
    for i in (0, 7, 31):
        for j in range(2):
            Nij, rij, okij = m.counts(q[i:i + 1], p[j:j + 1])
            assert (Nij[0], rij[0], okij[0]) == (N[2 * i + j], r[2 * i + j], ok[2 * i + j])


def test_strip_rows_divides_common_zero_columns():
    P0 = np.array([[0.0, 0.0, 1.0, 2.0, 0.0], [0.0, 0.0, 3.0, 0.0, 0.0]])
    P1 = np.array([[0.0, 0.0, 0.0, 5.0], [0.0, 0.0, 4.0, 0.0]])
    r, A, B = strip_rows(P0, P1)
    assert r == 2
    np.testing.assert_array_equal(A, [[1.0, 2.0], [3.0, 0.0]])
    np.testing.assert_array_equal(B, [[0.0, 5.0], [4.0, 0.0]])
    r, _, _ = strip_rows(np.array([[1.0, 0.0]]), np.array([[0.0, 1.0]]))
    assert r == 0


def test_hull_distance_on_known_hulls():
    d = 0.7
    V = np.array([[d + 2j, d - 1j, d + 3.0 + 0.5j],   # segment x = d plus a point behind it: distance d
                  [1 + 0j, -1 + 0j, 1j],               # contains 0
                  [2 * np.exp(0.3j), 2 * np.exp(0.3j), 2 * np.exp(0.3j)]])  # one point: distance 2
    _, first = hull_distance(V)  # stops at the first separating direction: a positive lower bound
    assert 0 < first[0] <= d * (1 + 1e-12) and first[1] <= 0 and 0 < first[2] <= 2 * (1 + 1e-12)
    # a slack wider than every distance keeps Gilbert iterating until the bound converges
    with_slack, bound = hull_distance(V, slack=np.full(V.shape, 5.0))
    assert 0.99 * d <= bound[0] <= d * (1 + 1e-12)
    assert with_slack[0] == pytest.approx(bound[0] - 5.0, rel=1e-9)
    assert bound[1] <= 0
    assert bound[2] == pytest.approx(2.0, rel=1e-9)


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(c=st.lists(st.floats(-0.8, 0.8), min_size=5, max_size=5), h=st.floats(0.01, 0.15), seed=st.integers(0, 9))
def test_certify_loop_never_certifies_a_box_with_an_unstable_member(loops, c, h, seed):
    m = loops["free"]
    lo = np.clip(np.array(c) - h, -0.95, 0.95)
    hi = np.clip(np.array(c) + h, -0.95, 0.95)
    res = certify_loop(m, lo, hi, 1, 1500)
    q, _ = m.box_points(lo, hi)
    vertex_ok = _stable(*m.counts(q, None)).all()
    if not vertex_ok:
        assert not res.certified
    if res.certified:
        inner = lo + np.random.default_rng(seed).uniform(size=(8, 5)) * (hi - lo)
        assert not loop_counts_at(m, inner, None, 1).any()


def test_terms_computed_for_several_loops_at_once_give_each_loops_coefficients(loops):
    """The witness search computes the characteristic terms of every loop's plant rows in one call
    (the union of their terms) and hands each loop its rows: each loop's coefficient rows are the
    ones it computes alone (up to exact zero columns at the top, which the counts trim)."""
    from exotune.analysis.charfun import trim_poly
    from exotune.analysis.counting import RootCounter

    rng = np.random.default_rng(3)
    names = list(loops)
    qs = [loops[n].q0[None, :] * (1.0 + rng.uniform(-0.3, 0.3, (4 + i, 5))) for i, n in enumerate(names)]
    keys = tuple(sorted({k for n in names for k in loops[n].keys}))
    assert set(keys) >= {"00", "01", "10"}
    ct_all = loops[names[0]].terms(np.concatenate(qs), keys)
    start = 0
    for n, q in zip(names, qs):
        m = loops[n]
        members = None if m.fam is None else np.geomspace(max(m.fam.lo, 1e-3), m.fam.hi, 3)
        ct = ct_all.rows(slice(start, start + q.shape[0]))
        start += q.shape[0]
        for twin in ((False, True) if m.complex else (False,)):
            alone, shared = m.coeffs(q, members, real_twin=twin), m.coeffs(q, members, real_twin=twin, ct=ct)
            for a, b in zip(alone, shared):
                a, b = trim_poly(a), trim_poly(b)
                assert a.shape == b.shape, n
                np.testing.assert_allclose(b, a, rtol=1e-14, atol=0, err_msg=n)  # the same arithmetic
        c1, c2 = RootCounter(), RootCounter()
        h1, h2 = m.submit(c1, q, members), m.submit(c2, q, members, ct=ct)
        c1.run()
        c2.run()
        assert all(np.array_equal(x, y) for x, y in zip(c1.result(h1), c2.result(h2))), n
