"""The compiled phase-sum kernel (numba) and the numpy reference implementation of the adaptive
argument principle give the same RHP counts and the same conclusiveness on real design tasks."""

from __future__ import annotations

import numpy as np
import pytest

from exotune.numerics import kernels as _fastphase
from exotune.analysis.counting import RootCounter
from exotune.analysis.charfun import amplification_qps, char_terms
from exotune.analysis.intervals import FamilySide
from exotune.config import batch_config, load_design
from exotune.model.controller import build_controller
from exotune.numerics.quasipoly import QP, count_rhp, log_grid, omega_max, phase_sums

ROOT = __import__("pathlib").Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.skipif(not _fastphase.AVAILABLE, reason="numba not installed")


def _tasks(n=150, seed=5):
    base = load_design(ROOT / "examples" / "paper.yaml")
    rng = np.random.default_rng(seed)
    cfg = batch_config(base, {
        "design.amplification": np.exp(rng.uniform(0.0, np.log(30.0), n)),
        "design.zeta": rng.uniform(0.2, 1.5, n),
        "implementation.delay_s": rng.uniform(0.0, 0.006, n),
        "plant.cuff_stiffness": np.exp(rng.uniform(np.log(30.0), np.log(5000.0), n)),
    })
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    ct = char_terms(cfg.plant, cs, n)
    num, den = amplification_qps(cfg.plant, cs, n)
    c = RootCounter()
    for q in (ct.qp("00"), ct.qp("01"), num, den):
        c.add(q.p0, q.p1, q.T)
    side = FamilySide(ct, "00", "10", base.humans)
    side.submit(c)
    return c


def test_numba_and_numpy_phase_sums_agree():
    c = _tasks()
    w0 = max(i[0].shape[-1] for i in c.items)
    w1 = max(i[1].shape[-1] for i in c.items)
    cplx = any(np.iscomplexobj(i[0]) for i in c.items)
    pad = lambda x, w: np.pad(x, ((0, 0), (0, w - x.shape[-1]))).astype(complex if cplx else float)
    P0 = np.concatenate([pad(i[0], w0) for i in c.items])
    P1 = np.concatenate([pad(i[1], w1) for i in c.items])
    T = np.concatenate([np.broadcast_to(i[2], i[0].shape[:1]) for i in c.items])
    from exotune.numerics.poly import strip_common_low_zeros

    _, (P0, P1) = strip_common_low_zeros(P0, P1)
    q = QP(P0, P1, T)
    wmax = omega_max(P0, P1)
    valid = np.isfinite(wmax)
    grid = log_grid(np.where(valid, wmax, 1.0), decades=6, per_decade=2)
    s_nb, r_nb = phase_sums(q, grid, valid, engine="numba")
    s_np, r_np = phase_sums(q, grid, valid, engine="numpy")
    assert len(s_nb) > 500
    assert np.array_equal(r_nb, r_np)
    ok = r_nb & valid
    assert ok.mean() > 0.95
    # the same accepted intervals in a different summation order: equal to rounding
    assert np.allclose(s_nb[ok], s_np[ok], rtol=0, atol=1e-9)


def test_geometric_splitting_gives_the_same_phase_sums_with_fewer_evaluations():
    """Counts split wide intervals at their geometric mean (quasipoly.adaptive_leaves
    geometric=True, the compiled kernel likewise): the same accepted-phase totals as midpoint
    splitting, hence the same counts, from fewer evaluations."""
    from exotune.numerics.poly import strip_common_low_zeros
    from exotune.numerics.quasipoly import adaptive_leaves

    c = _tasks(n=60, seed=9)
    items = [i for i in c.items if not np.iscomplexobj(i[0])]
    w0 = max(i[0].shape[-1] for i in items)
    w1 = max(i[1].shape[-1] for i in items)
    pad = lambda x, w: np.pad(x, ((0, 0), (0, w - x.shape[-1])))  # noqa: E731
    P0 = np.concatenate([pad(i[0], w0) for i in items])
    P1 = np.concatenate([pad(i[1], w1) for i in items])
    T = np.concatenate([np.broadcast_to(i[2], i[0].shape[:1]) for i in items])
    _, (P0, P1) = strip_common_low_zeros(P0, P1)
    q = QP(P0, P1, T)
    wmax = omega_max(P0, P1)
    valid = np.isfinite(wmax)
    grid = log_grid(np.where(valid, wmax, 1.0), decades=6, per_decade=2)
    sums, leaves = {}, {}
    for geo in (False, True):
        lv = adaptive_leaves(lambda idx, w: [q.eval(idx, w)], q.n, grid, valid, geometric=geo)
        steps = np.angle(lv["vb"][0] / lv["va"][0])
        sums[geo] = (np.bincount(lv["task"], weights=steps, minlength=q.n), lv["resolved"])
        leaves[geo] = lv["task"].size
    ok = sums[True][1] & sums[False][1] & valid
    assert ok.mean() > 0.95 and ok.sum() > 200
    assert np.allclose(sums[True][0][ok], sums[False][0][ok], rtol=0, atol=1e-9)
    assert leaves[True] < 0.97 * leaves[False]
    # the compiled kernel (geometric) agrees with the numpy reference run with midpoints
    s_nb, r_nb = phase_sums(q, grid, valid, engine="numba")
    assert np.allclose(s_nb[ok & r_nb], sums[False][0][ok & r_nb], rtol=0, atol=1e-9)


def test_trap_counts_with_kernel():
    """The near-undamped resonance (σ = ±1e-7 at 548 rad/s) is resolved by the compiled kernel too."""
    for sigma, expected in ((1e-7, 0), (-1e-7, 2)):
        P = np.polynomial.polynomial
        res = P.polyfromroots([-sigma + 548j, -sigma - 548j]).real
        p = P.polymul(res, P.polyfromroots([-1.0, -50.0]).real)
        p1 = 5.0 * res  # the resonance is a factor of both: its roots are exact, the rest stays stable
        q = QP(p[None, :], p1[None, :], np.array([1e-3]))
        N, ok = count_rhp(q)
        assert ok[0] and N[0] == expected


def test_analyze_batch_same_with_both_engines(monkeypatch):
    """Every metric of analyze_batch is the same with the compiled kernels and the numpy reference."""
    from exotune.analysis import analyze_batch

    base = load_design(ROOT / "examples" / "paper.yaml")
    rng = np.random.default_rng(9)
    n = 120
    cfg = batch_config(base, {
        "design.amplification": np.exp(rng.uniform(0.0, np.log(25.0), n)),
        "design.zeta_hat": rng.uniform(0.3, 1.2, n),
        "implementation.delay_s": rng.uniform(0.0, 0.005, n),
        "plant.cuff_stiffness": np.exp(rng.uniform(np.log(50.0), np.log(3000.0), n)),
    })
    a = analyze_batch(cfg).to_columns()
    monkeypatch.setenv("EXOTUNE_NUMPY_ONLY", "1")
    b = analyze_batch(cfg).to_columns()
    assert a.keys() == b.keys()
    for k in a:
        x, y = a[k], b[k]
        if isinstance(x, np.ndarray) and x.dtype.kind == "b":
            assert np.array_equal(x, y), k
        elif isinstance(x, np.ndarray):
            assert np.allclose(x, y, rtol=1e-7, atol=1e-12, equal_nan=True), k
        else:
            assert len(x) == len(y), k
            for u, v in zip(x, y):
                u, v = np.asarray(u, float), np.asarray(v, float)
                assert u.shape == v.shape and np.allclose(u, v, rtol=1e-7), (k, u, v)


def test_omega_max_compiled_equals_numpy():
    """The compiled tail bound equals the numpy one (rows with zeros, degree drops, P0 ≡ 0,
    non-retarded rows → inf, complex coefficients)."""
    from exotune.numerics.quasipoly import omega_max

    rng = np.random.default_rng(3)
    seen_inf = seen_finite = False
    for _ in range(100):
        q0 = rng.normal(size=(40, 7)) * (rng.random((40, 7)) < 0.7)
        q1 = rng.normal(size=(40, 5)) * (rng.random((40, 5)) < 0.6)
        if rng.random() < 0.3:
            q0 = q0 + 1j * rng.normal(size=q0.shape) * (q0 != 0)
        x, y = omega_max(q0, q1, engine="numba"), omega_max(q0, q1, engine="numpy")
        assert np.array_equal(np.isinf(x), np.isinf(y))
        f = np.isfinite(y)
        assert np.allclose(x[f], y[f], rtol=1e-13, atol=0)
        seen_inf |= bool(np.isinf(y).any())
        seen_finite |= bool(f.any())
    assert seen_inf and seen_finite  # both branches exercised


def test_omega_max_compiled_equals_numpy_with_extreme_and_nonfinite_coefficients():
    """Coefficients over 60 decades, NaN and inf entries (an infinite coefficient below the
    leading one makes the bound infinite: the task is then inconclusive); both engines agree: the
    same NaN and inf entries, the finite bounds to a few ulps (not bit for bit: the compiler may
    fuse or reorder floating-point operations differently across numba/LLVM versions)."""
    from exotune.numerics.quasipoly import omega_max

    rng = np.random.default_rng(0)
    p0 = rng.normal(size=(2000, 9)) * 10.0 ** rng.integers(-30, 30, size=(2000, 9))
    p1 = rng.normal(size=(2000, 6)) * 10.0 ** rng.integers(-30, 30, size=(2000, 6))
    p0[::5, 3] = np.nan
    p0[1::7, 2] = np.inf
    p1[::11, 1] = np.inf
    p0[::13, -1] = 0.0
    with np.errstate(all="ignore"):
        x, y = omega_max(p0, p1, engine="numba"), omega_max(p0, p1, engine="numpy")
    np.testing.assert_array_equal(np.isnan(x), np.isnan(y))
    np.testing.assert_array_equal(np.isinf(x), np.isinf(y))
    np.testing.assert_allclose(x, y, rtol=1e-14, atol=0, equal_nan=True)
    inf_rows = np.arange(1, 2000, 7)
    inf_rows = inf_rows[~np.isnan(p0[inf_rows]).any(1)]
    assert inf_rows.size > 200 and np.isinf(x[inf_rows]).all()  # an inf below the leading term
    assert np.isfinite(x).sum() > 500


def test_compiled_counter_pipeline_equals_numpy_counter():
    """The compiled counting pipeline (strip s = 0 roots with the regularized twin, zero-delay fold,
    tail bound, phase sum, tail and ω = 0 terms) gives the numpy Counter's exact (N, r, conclusive)
    on every task of a real batch: free, locked, minimum phase, the mass/spring/hysteretic family
    representatives (complex coefficients), with and without delay."""
    from exotune.analysis import analyze_batch

    base = load_design(ROOT / "examples" / "paper.yaml")
    rng = np.random.default_rng(5)
    n = 300
    cfg = batch_config(base, {
        "design.amplification": np.exp(rng.uniform(0.0, np.log(25.0), n)),
        "implementation.delay_s": np.where(rng.random(n) < 0.2, 0.0, rng.uniform(0.0, 0.005, n)),
        "plant.cuff_stiffness": np.exp(rng.uniform(np.log(50.0), np.log(3000.0), n)),
    })
    captured = []
    orig = RootCounter.run

    def spy(self, engine=None):
        captured.append(self)
        return orig(self, engine)

    RootCounter.run = spy
    try:
        analyze_batch(cfg)
    finally:
        RootCounter.run = orig
    assert captured
    total = 0
    has_reg = False
    for c in captured:
        c.run("numba")
        got = (c.N.copy(), c.r.copy(), c.ok.copy())
        c.run("numpy")
        assert np.array_equal(got[0][c.ok], c.N[c.ok]) and np.array_equal(got[1], c.r) and np.array_equal(got[2], c.ok)
        total += c.n
        has_reg |= any(i[3] is not None for i in c.items)
    assert total > 5 * n and has_reg


def _human_leaves(n, rng, delay_lo, delay_hi):
    """(Δ00, Δ10, leaves) of the human side for n random variants of the paper design."""
    base = load_design(ROOT / "examples" / "paper.yaml")
    cfg = batch_config(base, {"design.amplification": np.exp(rng.uniform(0.0, np.log(30.0), n)),
                              "implementation.delay_s": rng.uniform(delay_lo, delay_hi, n)})
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    return FamilySide(char_terms(cfg.plant, cs, n), "00", "10", base.humans).compute_leaves((0.0, 0.0, 0.0))


@pytest.mark.parametrize("k,factor,lo,hi", [(0, 1.0, 1.0, 1e4), (2, -1.0, 1e-3, 1.0), (0, 1 + 0.2j, 10.0, 1e3), (1, 1.0, 0.1, 10.0)])
def test_compiled_leaf_classification_equals_numpy(k, factor, lo, hi):
    """Crossing values and bracket / sub-sampling flags of every leaf: the compiled kernel equals the
    numpy reference, on real leaves and on planted degenerate ones (zeros, inf, nan, ω = 0)."""
    from exotune.analysis.intervals import SIN_NEAR, classify, classify_numpy

    rng = np.random.default_rng(3)
    _, _, lv = _human_leaves(60, rng, 0.0, 0.005)
    lv = {"a": lv["a"].copy(), "b": lv["b"].copy(), "task": lv["task"],
          "va": [lv["va"][0].copy(), lv["va"][1].copy()], "vb": [lv["vb"][0].copy(), lv["vb"][1].copy()]}
    m = lv["a"].size
    assert m > 1000
    idx = rng.choice(m, 40, replace=False)
    for j, i in enumerate(idx):  # planted degenerate values
        which = (lv["va"][0], lv["va"][1], lv["vb"][0], lv["vb"][1])[j % 4]
        which[i] = (0j, complex(np.inf, 1.0), complex(np.nan, 0.0), complex(0.0, -np.inf), 1e-320 + 0j)[j % 5]
    ga0, gb0, br0, sus0 = classify_numpy(lv, k, factor, lo, hi)
    ga1, gb1, br1, sus1 = classify(lv, k, factor, lo, hi)
    assert np.array_equal(br0, br1) and np.array_equal(sus0, sus1)
    # g = Im(x·conj f) may cancel: equal to the rounding of its two products (FMA or not)
    for g0, g1, x, v, w in ((ga0, ga1, lv["va"][0], lv["va"][1], lv["a"]), (gb0, gb1, lv["vb"][0], lv["vb"][1], lv["b"])):
        with np.errstate(all="ignore"):
            scale = np.abs(x) * np.abs(factor) * np.abs(v) * w**k
            fin = np.isfinite(scale) & np.isfinite(g0)
        assert np.all(np.abs(g0[fin] - g1[fin]) <= 1e-14 * scale[fin])
        assert np.array_equal(np.isfinite(g0), np.isfinite(g1))
    assert br0.any() or sus0.any()
    ga2, gb2, br2, sus2, deg = _fastphase.classify_leaves(lv, k, factor, lo, hi, SIN_NEAR)
    assert deg[idx].sum() >= 20  # the planted ones go through the numpy reference


def test_compiled_subsampling_equals_numpy(monkeypatch):
    """Brackets found by sub-sampling suspicious leaves (light masses near the real axis, delay
    ripple): the compiled pass returns the numpy reference's brackets (the same leaves, their ends to
    rounding: the compiler may fuse the interpolation's multiply-add)."""
    from exotune.analysis import intervals as A

    D0, D1, lv = _human_leaves(40, np.random.default_rng(4), 0.0005, 0.006)
    fam = load_design(ROOT / "examples" / "paper.yaml").humans[0]  # mass: κ ≈ K_c/ω² hugs the real axis
    _, _, _, sus = A.classify_numpy(lv, 2, -1.0, fam.lo, fam.hi)
    st, sa, sb = lv["task"][sus], lv["a"][sus], lv["b"][sus]
    assert st.size > 100
    got = A.subsample_brackets(D0, D1, 2, -1.0, st, sa, sb)
    monkeypatch.setenv("EXOTUNE_NUMPY_ONLY", "1")  # the numpy reference
    ref = A.subsample_brackets(D0, D1, 2, -1.0, st, sa, sb)
    assert ref[0].size > 0
    assert np.array_equal(got[0], ref[0])  # the same brackets
    for x, y in zip(got[1:3], ref[1:3]):
        np.testing.assert_allclose(x, y, rtol=1e-14, atol=0)
    for x, y in zip(got[3:], ref[3:]):  # g values: the reference g rounds (jω)² f Δ1 its own way
        assert np.allclose(x, y, rtol=1e-12, atol=0)


def test_compiled_polynomial_product_equals_the_numpy_loop(monkeypatch):
    """poly.pmul runs compiled for large real batches; it accumulates in the numpy loop's order,
    so both give the same coefficients to rounding (a few ulps of the sum of |products|: not bit
    for bit, the compiler may fuse multiply-adds depending on the numba/LLVM version) and the exact
    structural zeros stay exactly zero."""
    from exotune.numerics import poly

    rng = np.random.default_rng(3)
    a = rng.normal(size=(300, 6)) * 10.0 ** rng.integers(-8, 8, size=(300, 6))
    b = rng.normal(size=(300, 4))
    a[:, 0] = 0.0  # a structural zero (rigid-body root) must stay exactly zero
    b[::7, 1] = 0.0
    fast = poly.pmul(a, b)
    fast_bc = poly.pmul(a, b[:1])  # a broadcast operand (one row for all designs)
    monkeypatch.setenv("EXOTUNE_NUMPY_ONLY", "1")
    slow = poly.pmul(a, b)
    slow_bc = poly.pmul(a, b[:1])
    assert fast.shape == slow.shape == (300, 9)
    scale = np.stack([np.convolve(np.abs(r), np.abs(s)) for r, s in zip(a, b)])
    scale_bc = np.stack([np.convolve(np.abs(r), np.abs(b[0])) for r in a])
    assert np.all(np.abs(fast - slow) <= 4 * np.finfo(float).eps * scale)
    assert np.all(np.abs(fast_bc - slow_bc) <= 4 * np.finfo(float).eps * scale_bc)
    assert np.all(fast[:, 0] == 0.0) and np.all(slow[:, 0] == 0.0)
    # the compiled kernel is what ran above (not numpy twice), and both are the true product
    assert np.array_equal(_fastphase.pmul_rows(a, b), fast)
    assert np.allclose(slow_bc, np.stack([np.convolve(r, b[0]) for r in a]), rtol=1e-13, atol=0)


def test_compiled_family_tail_bound_equals_numpy(monkeypatch):
    """The compiled family tail frequency (every p of a family's range) equals the numpy one on
    real designs, for the mass, spring and damper slots, ranges touching 0 and reversed signs."""
    from exotune.analysis.intervals import family_wmax
    from exotune.model.humans import family_split

    n = 300
    base = load_design(ROOT / "examples" / "paper.yaml")
    rng = np.random.default_rng(11)
    cfg = batch_config(base, {
        "design.amplification": np.exp(rng.uniform(0.0, np.log(30.0), n)),
        "implementation.delay_s": np.where(rng.random(n) < 0.2, 0.0, rng.uniform(0.0, 0.006, n)),
        "plant.cuff_stiffness": np.exp(rng.uniform(np.log(30.0), np.log(5000.0), n)),
    })
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    ct = char_terms(cfg.plant, cs, n)
    cases = [("mass", "inertia", 1e-6, 2.0, 0.0), ("spring", "stiffness", 0.0, 1e5, 0.0),
             ("msd", "damping", 0.1, 50.0, 0.0), ("complex_stiffness", "stiffness", 10.0, 1000.0, 0.2)]
    for kind, param, lo, hi, eta in cases:
        z0, phi, factor = family_split(kind, param, {"inertia": 0.01, "stiffness": 100.0, "damping": 1.0}, eta)
        D0, D1 = ct.combine("00", "10", z0)
        fast = family_wmax(D0, D1, phi, factor, lo, hi)
        with monkeypatch.context() as m:
            m.setenv("EXOTUNE_NUMPY_ONLY", "1")
            slow = family_wmax(D0, D1, phi, factor, lo, hi)
        assert np.array_equal(np.isinf(fast), np.isinf(slow)), kind
        f = np.isfinite(slow)
        assert f.sum() > n // 2, kind
        assert np.allclose(fast[f], slow[f], rtol=1e-12, atol=0), kind
