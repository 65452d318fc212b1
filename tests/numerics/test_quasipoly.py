"""exotune.numerics.quasipoly.count_rhp: RHP zero counts of Δ(s) = P0(s) + P1(s) e^{−sT} (docs/method.md#analyses-and-metrics).

Independent truths used here:

* polynomials (T = 0) built from *placed* roots (np.poly), so the RHP count is known by
  construction (every root has |Re| ≥ 1e-3·|root|);
* retarded quasi-polynomials against the Padé rationalization P0·d + P1·n (orders 12 and 16 must
  agree, no Padé root within 1e-6 relative of the axis). The delay is drawn so that every RHP
  zero lies where Padé 12 is accurate: in Re s ≥ 0 both |e^{−sT}| ≤ 1 and |n/d| ≤ 1, so any RHP
  zero (exact or Padé) satisfies |P0(s)| ≤ |P1(s)|, i.e. |s| < R with R the Cauchy-type radius
  beyond which |P0| > |P1| on the whole RHP; T is chosen with R·T ≤ 10, where the [12/12] Padé
  error of e^{−x} is < 1e-6;
* the near-undamped trap: a root pair at −σ ± j·548 rad/s with σ down to 1e-9 rad/s, where a
  naive dense-grid unwrap of arg Δ silently miscounts;
* exact imaginary-axis roots must give conclusive = False;
* the hysteretic (complex-coefficient) rows with the regularized value v0 at ω = 0, for
  oscillators whose count follows by hand from the phase path of Δ(jω), ω ≥ 0.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, example, given, settings
from hypothesis import strategies as st
from numpy.polynomial import polynomial as P

from exotune.numerics.quasipoly import QP, count_rhp

from reference_model import pade_qp_roots

SETTINGS = settings(deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])


def _count(p0, p1, T, v0=None):
    """count_rhp on a single row -> (N, conclusive) as Python scalars."""
    p0 = np.atleast_2d(np.asarray(p0))
    p1 = np.atleast_2d(np.asarray(p1))
    N, ok = count_rhp(QP(p0, p1, np.array([float(T)])), v0=None if v0 is None else np.atleast_1d(v0))
    return int(N[0]), bool(ok[0])


# ---------------------------------------------------------------------------------------------
# root placement strategies
# ---------------------------------------------------------------------------------------------
def _root_groups(min_mag_exp: float, max_mag_exp: float):
    """One real root or one conjugate pair: (magnitude, |Re|/|root| in [1e-3, 1], sign, is_pair)."""
    return st.tuples(
        st.floats(min_mag_exp, max_mag_exp),
        st.one_of(st.floats(1e-3, 1.0), st.just(1e-3), st.floats(1e-3, 2e-3)),
        st.sampled_from([-1.0, 1.0]),
        st.booleans(),
    )


def _roots_from_groups(groups, max_deg: int) -> np.ndarray:
    roots: list[complex] = []
    for e, ratio, sgn, pair in groups:
        mag = 10.0**e
        if pair and len(roots) + 2 <= max_deg and ratio < 1.0:
            re = sgn * mag * ratio
            im = mag * math.sqrt(1.0 - ratio * ratio)
            roots += [complex(re, im), complex(re, -im)]
        elif len(roots) + 1 <= max_deg:
            roots.append(complex(sgn * mag, 0.0))
    return np.asarray(roots, complex)


def _ascending(roots: np.ndarray, scale: float = 1.0) -> np.ndarray:
    return scale * np.real(np.poly(roots))[::-1].copy() if roots.size else np.array([scale])


# ---------------------------------------------------------------------------------------------
# (a) polynomials with placed roots
# ---------------------------------------------------------------------------------------------
@SETTINGS
@given(
    groups=st.lists(_root_groups(-2.0, 3.0), min_size=1, max_size=10),
    scale_exp=st.floats(-3.0, 3.0),
    sign=st.sampled_from([-1.0, 1.0]),
)
def test_polynomial_count_equals_placed_rhp_roots(groups, scale_exp, sign):
    roots = _roots_from_groups(groups, 10)
    assume(1 <= roots.size <= 10)
    p0 = _ascending(roots, sign * 10.0**scale_exp)
    # the float coefficients must still carry the placed half-plane pattern (guards against a
    # cluster whose float roots moved by > 1e-3 relative; essentially never triggers)
    fr = P.polyroots(p0)
    assume(np.sum(fr.real > 0) == np.sum(roots.real > 0))
    N, ok = _count(p0, [0.0], 0.0)
    assert ok
    assert N == int(np.sum(roots.real > 0))


def test_polynomial_batch_with_mixed_degrees():
    """One vectorized call over 400 rows of degrees 1..10 (zero-padded high coefficients) gives
    the placed counts row by row, including roots at exactly 1e-3 relative damping."""
    rng = np.random.default_rng(20240501)
    rows, truth = [], []
    for _ in range(400):
        deg = int(rng.integers(1, 11))
        r: list[complex] = []
        while len(r) < deg:
            mag = 10.0 ** rng.uniform(-2, 3)
            ratio = 1e-3 if rng.random() < 0.3 else 10.0 ** rng.uniform(-3, 0)
            sgn = rng.choice([-1.0, 1.0])
            if deg - len(r) >= 2 and rng.random() < 0.6 and ratio < 1:
                r += [complex(sgn * mag * ratio, mag * math.sqrt(1 - ratio**2))]
                r += [r[-1].conjugate()]
            else:
                r.append(complex(sgn * mag, 0.0))
        r = np.asarray(r)
        rows.append(_ascending(r, rng.choice([-1.0, 1.0]) * 10.0 ** rng.uniform(-3, 3)))
        truth.append(int(np.sum(r.real > 0)))
    p0 = np.zeros((len(rows), 11))
    for i, c in enumerate(rows):
        p0[i, : c.size] = c
    N, ok = count_rhp(QP(p0, np.zeros((len(rows), 1)), np.zeros(len(rows))))
    assert ok.all()
    np.testing.assert_array_equal(N, truth)


# ---------------------------------------------------------------------------------------------
# (b) retarded quasi-polynomials against Padé
# ---------------------------------------------------------------------------------------------
def _rhp_radius(p0, p1) -> float:
    """R with |P0(s)| > |P1(s)| for every |s| ≥ R (|c_n| r^n − Σ_{k<n}|c_k| r^k − Σ|d_k| r^k > 0;
    divided by r^n the left side increases with r, so the positive root is the threshold)."""
    n = len(p0) - 1
    a = -np.abs(np.asarray(p0, float)).copy()
    a[n] = -a[n]
    a[: len(p1)] -= np.abs(np.asarray(p1, float))
    r = P.polyroots(a)
    r = r[(np.abs(r.imag) < 1e-9 * np.abs(r)) & (r.real > 0)].real
    return float(r.max())


@settings(SETTINGS, max_examples=200)
@given(
    g0=st.lists(_root_groups(-1.0, 1.5), min_size=1, max_size=8),
    g1=st.lists(_root_groups(-1.0, 1.5), min_size=0, max_size=7),
    gain_exp=st.floats(-1.0, 1.5),
    sign=st.sampled_from([-1.0, 1.0]),
    t_frac=st.floats(0.02, 1.0),
)
def test_quasipolynomial_count_matches_pade(g0, g1, gain_exp, sign, t_frac):
    r0 = _roots_from_groups(g0, 8)
    n = r0.size
    assume(n >= 1)
    r1 = _roots_from_groups(g1, n - 1)
    p0 = _ascending(r0)
    typ = float(np.mean(np.abs(r0)))
    p1 = _ascending(r1, sign * 10.0**gain_exp * typ ** (n - r1.size))
    R = _rhp_radius(p0, p1)
    T = t_frac * 10.0 / R
    ra, rb = pade_qp_roots(p0, p1, T, 12), pade_qp_roots(p0, p1, T, 16)
    na, nb = int(np.sum(ra.real > 0)), int(np.sum(rb.real > 0))
    with np.errstate(divide="ignore", invalid="ignore"):
        near = min(np.min(np.abs(ra.real) / np.abs(ra)), np.min(np.abs(rb.real) / np.abs(rb)))
    # (a NaN ratio, i.e. a root at 0, also fails this); a root within 1e-8·typ of s = 0 is on the
    # axis for the Padé computation's rounding (e.g. Δ(0) = 7e-15 puts the exact root at −2e-15
    # while the Padé polynomial's root comes out at +1e-13), so such draws are skipped too
    far = min(np.min(np.abs(ra)), np.min(np.abs(rb))) > 1e-8 * typ
    assume(na == nb and near > 1e-6 and far)
    N, ok = _count(p0, p1, T)
    assert ok
    assert N == na


@pytest.mark.parametrize(
    "p0,p1,T,expected",
    [
        # first-order loops with a dominant delayed term: several RHP zeros whose phase winds
        # many times between two adjacent samples of a coarse grid (the aliasing trap)
        ([2.0, 1.0], [10.0], 1.0, 4),
        ([1.0, 1.0], [20.0], 1.0, 6),
        ([-4.98174273, 1.0], [18.43379907], 1.1040629608847858, 6),
        ([0.5, 1.0], [30.0], 0.5, 6),
        ([0.0, 1.0], [3.0], 1.0, 2),
        ([0.0, 1.0], [1.0], 1.0, 0),
    ],
)
def test_delay_dominated_first_order(p0, p1, T, expected):
    """Δ = s + a + g e^{−sT}: the expected counts are confirmed here by Padé 16 and 24 and a
    Newton refinement of each RHP Padé root on the exact Δ (|Δ| at the refined root ≤ 1e-9·g)."""
    p0, p1 = np.asarray(p0), np.asarray(p1)
    f = lambda s: P.polyval(s, p0) + P.polyval(s, p1) * np.exp(-s * T)
    fp = lambda s: P.polyval(s, P.polyder(p0)) + (P.polyval(s, P.polyder(p1)) - T * P.polyval(s, p1)) * np.exp(-s * T)
    for order in (16, 24):
        r = pade_qp_roots(p0, p1, T, order)
        rhp = r[r.real > 0]
        assert rhp.size == expected
        for z in rhp:
            for _ in range(30):
                z = z - f(z) / fp(z)
            assert abs(f(z)) <= 1e-9 * max(1.0, abs(p1[0])) and z.real > 1e-3
    N, ok = _count(p0, p1, T)
    assert ok
    assert N == expected


# ---------------------------------------------------------------------------------------------
# (c) the near-undamped trap
# ---------------------------------------------------------------------------------------------
W0 = 548.0  # rad/s (≈ 87 Hz)
SIGMAS = [1e-5, -1e-5, 1e-7, -1e-7, 1e-8, -1e-8, 1e-9, -1e-9]


def _trap(sigma: float, variant: str):
    """Δ = (s² + 2σ s + ω0²)(s + 1)(s + 50) [+ P1 e^{−sT}]; returns (p0, p1, T, true count)."""
    q = P.Polynomial([W0 * W0, 2.0 * sigma, 1.0])
    p0 = (q * P.Polynomial([1.0, 1.0]) * P.Polynomial([50.0, 1.0])).coef
    if variant == "polynomial":
        return p0, np.zeros(1), 0.0, (2 if sigma < 0 else 0)
    if variant == "shared":
        # Δ = q(s)·[(s+1)(s+50) + 10 e^{−0.01 s}]: q's roots are exact roots of Δ, and the bracket
        # has no RHP zero (Rouché: |(s+1)(s+50)| ≥ 50 > 10 ≥ |10 e^{−sT}| on Re s ≥ 0)
        return p0, (10.0 * q).coef, 0.01, (2 if sigma < 0 else 0)
    # a generic small delayed term (not sharing the factor): the pair moves by ~1e-9 rad/s; the
    # true root is found by Newton on the exact quasi-polynomial and decides the truth
    p1 = np.array([3e-3, 1e-3])
    T = 1e-3
    f = lambda s: P.polyval(s, p0) + P.polyval(s, p1) * np.exp(-s * T)
    fp = lambda s: P.polyval(s, P.polyder(p0)) + (P.polyval(s, P.polyder(p1)) - T * P.polyval(s, p1)) * np.exp(-s * T)
    z = complex(-sigma, math.sqrt(W0 * W0 - sigma * sigma))
    for _ in range(20):
        z = z - f(z) / fp(z)
    assert abs(z.imag - W0) < 1e-3 and abs(z.real + sigma) < 1e-8
    return p0, p1, T, (2 if z.real > 0 else 0)


@pytest.mark.parametrize("variant", ["polynomial", "shared", "generic"])
@pytest.mark.parametrize("sigma", SIGMAS)
def test_near_undamped_pair(sigma, variant):
    p0, p1, T, truth = _trap(sigma, variant)
    if abs(sigma) >= 1e-7:  # the perturbation of the generic variant is far below these σ
        assert truth == (2 if sigma < 0 else 0)
    N, ok = _count(p0, p1, T)
    assert ok
    assert N == truth


def _naive_count(p0, p1, T) -> int:
    """The trap: np.unwrap of arg Δ on a fixed 200 000-point log grid from 1e-2 to 1e5 rad/s."""
    w = np.geomspace(1e-2, 1e5, 200_000)
    s = 1j * w
    v = P.polyval(s, p0) + P.polyval(s, p1) * np.exp(-s * T)
    th = np.unwrap(np.angle(v))
    n = len(p0) - 1
    tail = np.angle(p0[-1] * 1j**n / v[-1])  # |Δ/(c_n (jω)^n) − 1| ≪ 1 at 1e5 rad/s
    head = np.angle(v[0] / P.polyval(0.0, p0 + np.pad(p1, (0, len(p0) - len(p1)))))
    return int(round((n * np.pi / 2 - (th[-1] - th[0]) - tail - head) / np.pi))


def test_naive_unwrap_falls_into_the_trap():
    """Documents why the adaptive method is needed: the dense fixed grid (spacing ≈ 0.044 rad/s
    at 548 rad/s) is right for σ = ±1e-5 but silently wrong for some smaller σ — it steps over
    the π phase jump of the pair and np.unwrap takes the wrong branch — while count_rhp is right
    for all of them (test_near_undamped_pair)."""
    wrong = []
    for variant in ("polynomial", "shared", "generic"):
        for sigma in SIGMAS:
            p0, p1, T, truth = _trap(sigma, variant)
            naive = _naive_count(p0, p1, T)
            if abs(sigma) >= 1e-5:
                assert naive == truth  # the naive method is not simply broken
            if naive != truth:
                wrong.append((variant, sigma, naive, truth))
    assert wrong, "expected the naive unwrap to miscount at least one near-undamped case"
    # the stable pair with σ = +1e-8 is reported unstable by the naive method
    assert ("polynomial", 1e-8, 2, 0) in wrong


# ---------------------------------------------------------------------------------------------
# (d) zeros exactly on the imaginary axis
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "p0,p1,T",
    [
        ([W0**2, W0**2, 1.0, 1.0], [0.0], 0.0),  # (s² + ω0²)(s + 1)
        ([W0**2, W0**2, 1.0, 1.0], [0.5 * W0**2, 0.0, 0.5], 0.01),  # (s² + ω0²)[(s + 1) + ½e^{−sT}]
        ([2.0, 0.0, 1.0], [0.0], 0.0),  # s² + 2: roots ±j√2 (exact coefficients)
        ([0.0, 1.0, 1.0], [0.0], 0.0),  # s (s + 1): root at s = 0
        ([0.0, 1.0], [0.0], 0.0),  # s
        ([0.0, 1.0], [np.pi / 2], 1.0),  # s + (π/2) e^{−s}: root at s = jπ/2 (to rounding)
    ],
)
def test_root_on_axis_is_inconclusive(p0, p1, T):
    _, ok = _count(p0, p1, T)
    assert not ok


def test_axis_root_neighbours_are_conclusive():
    """Just off the boundary of s + g e^{−s} (critical gain π/2) the count is conclusive and right."""
    assert _count([0.0, 1.0], [np.pi / 2 * (1 - 1e-6)], 1.0) == (0, True)
    assert _count([0.0, 1.0], [np.pi / 2 * (1 + 1e-6)], 1.0) == (2, True)


# ---------------------------------------------------------------------------------------------
# (e) complex-coefficient rows (hysteretic human) with the regularized value v0 at ω = 0
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "a,eta,expected",
    [
        # Δ(jω) = k − ω² + j(kη − aω) for ω > 0, Δ(0) := k (the real, regularized value).
        # Phase path from arg k = 0: if Im Δ > 0 where Re Δ = 0 (ω = √k), i.e. kη > a√k, the
        # phase rises through +π/2 to π (Δθ = π, N = (2·π/2 − π)/π = 0); otherwise it falls
        # through −π/2 to −π (Δθ = −π, N = 2).
        (0.0, 0.2, 0),  # hysteretic oscillator m s² + k(1 + jη): dissipative, stable
        (0.0, 0.5, 0),
        (0.0, -0.2, 2),  # negative hysteretic damping: active, two RHP zeros
        (1.0, 0.2, 0),  # negative viscous damping a = 1 beaten by hysteretic kη = 20 > a√k = 10
        (1.0, 0.05, 2),  # kη = 5 < a√k = 10: unstable
        (-1.0, 0.0, 0),  # plain s² + s + k (complex dtype, zero imaginary part)
    ],
)
def test_hysteretic_oscillator_with_v0(a, eta, expected):
    k = 100.0
    p0 = np.array([k * (1 + 1j * eta), -a, 1.0], complex)
    N, ok = _count(p0, np.zeros(1, complex), 0.0, v0=np.array([k]))
    assert ok
    assert N == expected


def test_hysteretic_oscillator_with_delay_and_v0():
    """Δ = s² + k(1 + jη) + ε e^{−sT}, v0 = k + ε: for ω > 0, Im Δ(jω) = kη − ε sin ωT keeps the
    sign of η (kη = ±20 ≫ ε = 0.5) while Re Δ = k + ε cos ωT − ω² goes from k + ε to −∞, so the
    hand argument of the undelayed oscillator holds: N = 0 for η > 0, N = 2 for η < 0."""
    k = 100.0
    for eta, expected in ((0.2, 0), (-0.2, 2)):
        p0 = np.array([k * (1 + 1j * eta), 0.0, 1.0], complex)
        N, ok = _count(p0, np.array([0.5 + 0j]), 0.01, v0=np.array([k + 0.5]))
        assert ok and N == expected


@SETTINGS
@given(
    g0=st.lists(_root_groups(-1.0, 1.0), min_size=1, max_size=6),
    g1=st.lists(_root_groups(-1.0, 1.0), min_size=0, max_size=5),
    gain_exp=st.floats(-1.0, 1.0),
    t_frac=st.floats(0.05, 1.0),
)
def test_complex_path_with_real_data_equals_real_path(g0, g1, gain_exp, t_frac):
    """A real quasi-polynomial passed as complex rows with v0 = Δ(0) counts the same as the real
    row (the hysteretic code path, with a delay)."""
    r0 = _roots_from_groups(g0, 6)
    r1 = _roots_from_groups(g1, max(r0.size - 1, 0))
    assume(r0.size >= 1)
    p0 = _ascending(r0)
    p1 = _ascending(r1, 10.0**gain_exp * float(np.mean(np.abs(r0))) ** (r0.size - r1.size))
    T = t_frac * 10.0 / _rhp_radius(p0, p1)
    Nr, okr = _count(p0, p1, T)
    assume(okr)
    v0 = p0[0] + p1[0]
    Nc, okc = _count(p0.astype(complex), p1.astype(complex), T, v0=np.array([v0]))
    assert okc
    assert Nc == Nr


# About 4 of 5 draws fail the assume() calls (the samples straddle 0, or the vertex is not next to
# the middle sample), so the health check's limit of 50 filtered draws before the first 10 valid
# ones is within reach: the draws also depend on which local modules are loaded (Hypothesis adds
# their numeric literals to its choices), so the check failed in some `pytest -n 2` workers
# (FailedHealthCheck filter_too_much: 8 valid, 50 filtered) and passed alone. The filtering is
# intended, as in the other property tests of this file (SETTINGS); the property is still asserted
# on 300 valid draws.
@settings(SETTINGS, max_examples=300)
@given(h1=st.floats(1e-6, 1.0), h2=st.floats(1e-6, 1.0), vertex=st.floats(0.0, 1.0), depth=st.floats(1e-9, 10.0),
       curv=st.floats(1e-3, 1e3), sign=st.sampled_from([1.0, -1.0]))
# the bound attained (exact in binary): ρ = 1/15, the vertex −h1/2 level with −h1 and 0, the
# minimum just below 0; middle/rise = 225/64 = 1/(4ρ(1 + ρ)) (a fixed factor 2 misses it)
@example(h1=0.9375, h2=0.0625, vertex=0.46875, depth=1e-9, curv=1.0, sign=1.0)
@example(h1=0.9375, h2=0.0625, vertex=0.46875, depth=1e-9, curv=1.0, sign=-1.0)
def test_the_uneven_dip_net_catches_every_parabola_of_the_other_sign(h1, h2, vertex, depth, curv, sign):
    """A parabola sampled at −h1, 0, h2 whose middle sample is the nearest to 0 and whose minimum
    between the outer samples has the other sign is a candidate with the factor of dip_rise, for
    any spacing (the bound 1/(4ρ(1 + ρ)) it keeps four times)."""
    from exotune.numerics.quasipoly import dip_candidates, dip_rise

    xv = -h1 + vertex * (h1 + h2)  # the vertex, anywhere between the outer samples
    f = lambda x: sign * (curv * (x - xv) ** 2 - depth)  # noqa: E731
    uq, up, un = f(-h1), f(0.0), f(h2)
    s = np.sign(up)
    assume(s == sign and sign * uq > 0 and sign * un > 0)  # all three samples of one sign
    assume(sign * up <= sign * uq and sign * up < sign * un)  # the middle one nearest to 0
    cand, sg = dip_candidates(np.array([uq]), np.array([up]), np.array([un]), rise=dip_rise(h1, h2))
    assert cand[0] and sg[0] == sign
    # the fixed factor of evenly spaced samples misses some of them: the spacing matters
    assert dip_rise(h1, h2) >= 2.0


def test_dip_rise_values():
    from exotune.numerics.quasipoly import dip_rise

    np.testing.assert_allclose(dip_rise(np.array([1.0, 1.0, 0.1, 1.0]), np.array([1.0, 0.1, 1.0, 0.01])),
                               [2.0, 1 / (0.1 * 1.1), 1 / (0.1 * 1.1), 1 / (0.01 * 1.01)], rtol=1e-15)
    assert np.isinf(dip_rise(0.0, 1.0)) and np.isinf(dip_rise(0.0, 0.0))


def test_a_minimum_deep_in_the_longer_cell_is_missed_by_a_fixed_factor_and_found_with_dip_rise():
    """(x + 0.5)² − 0.01 sampled at −1, 0 and 0.05: the samples are 0.24, 0.24, 0.2925 (rise
    0.0525 from the middle, 0.24 to go), the minimum −0.01 lies in the longer cell."""
    from exotune.numerics.quasipoly import dip_candidates, dip_rise

    f = lambda x: (x + 0.5) ** 2 - 0.01  # noqa: E731
    u = [np.array([f(x)]) for x in (-1.0, 0.0, 0.05)]
    assert not dip_candidates(*u, rise=2.0)[0][0]
    assert dip_candidates(*u, rise=dip_rise(1.0, 0.05))[0][0]
