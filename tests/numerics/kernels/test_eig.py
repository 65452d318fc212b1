"""The compiled eigenvalue kernel (exotune.numerics.kernels.eig) against LAPACK (numpy.linalg.eigvals)
and against what an eigenvalue solver guarantees whatever the conditioning: a small backward error
for every computed value, the trace, exact conjugate pairs; on the sampled-data loop matrices of the
sweep, and on the classical hard cases (a cyclic permutation that stalls the standard shift, Jordan
blocks, badly scaled matrices)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import linear_sum_assignment

from exotune.numerics.kernels import AVAILABLE

from campaign_designs import CLUSTER_AT_Z1_10KHZ

pytestmark = pytest.mark.skipif(not AVAILABLE, reason="numba not installed: LAPACK solves every matrix")

EPS = np.finfo(float).eps


def _solve(M):
    from exotune.numerics.kernels.eig import eigvals_stack

    return eigvals_stack(np.asarray(M, float))


def _backward_errors(A, lam):
    """σ_min(A − λI) / ‖A‖_F of each computed λ: the smallest relative perturbation of A that makes
    λ an exact eigenvalue (independent of the eigenvalue's conditioning)."""
    n = A.shape[0]
    scale = max(np.linalg.norm(A), 1e-300)
    return np.array([np.linalg.svd(A - l * np.eye(n), compute_uv=False)[-1] / scale for l in lam])


def _matched_distance(a, b):
    """The largest distance of a one-to-one matching of the two spectra that minimizes the total."""
    D = np.abs(a[:, None] - b[None, :])
    r, c = linear_sum_assignment(D)
    return D[r, c].max(initial=0.0)


def _check_guarantees(A, lam):
    n = A.shape[0]
    assert lam.shape == (n,)
    assert np.all(np.isfinite(lam))
    assert np.max(_backward_errors(A, lam), initial=0.0) <= 50.0 * n * EPS
    scale = max(np.abs(A).sum(), 1.0)
    assert abs(lam.sum() - np.trace(A)) <= 1e3 * n * EPS * scale
    # complex eigenvalues come in exact conjugate pairs
    cplx = lam[lam.imag != 0]
    assert np.array_equal(np.sort_complex(cplx), np.sort_complex(np.conj(cplx)))


@settings(max_examples=60, deadline=None)
@given(n=st.integers(1, 24), seed=st.integers(0, 2**31 - 1), log_scale=st.floats(-8, 8))
def test_random_matrices_match_lapack(n, seed, log_scale):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n)) * 10.0 ** log_scale
    lam, ok = _solve(A[None])
    assert ok.all()
    _check_guarantees(A, lam[0])
    ref = np.linalg.eigvals(A)
    # Gaussian matrices are well conditioned enough for the two solvers to agree closely
    assert _matched_distance(lam[0], ref) <= 1e-8 * np.linalg.norm(A)


@settings(max_examples=40, deadline=None)
@given(n=st.integers(2, 16), seed=st.integers(0, 2**31 - 1), spread=st.integers(1, 12))
def test_badly_scaled_similarity_keeps_the_eigenvalues(n, seed, spread):
    """D A D⁻¹ with D spanning up to 10^12 has A's eigenvalues (balancing undoes the scaling)."""
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n))
    d = 10.0 ** rng.uniform(-spread / 2, spread / 2, n)
    B = (d[:, None] * A) / d[None, :]
    lam, ok = _solve(B[None])
    assert ok.all()
    assert _matched_distance(lam[0], np.linalg.eigvals(A)) <= 1e-7 * np.linalg.norm(A)


@pytest.mark.parametrize("n", [2, 3, 5, 8, 13])
def test_cyclic_permutation_needs_the_exceptional_shift(n):
    """The cyclic shift's eigenvalues are the n-th roots of unity; the standard double shift makes
    no progress on it without the exceptional shifts."""
    P = np.roll(np.eye(n), 1, axis=0)
    lam, ok = _solve(P[None])
    assert ok.all()
    want = np.exp(2j * np.pi * np.arange(n) / n)
    assert _matched_distance(lam[0], want) <= 1e-12


@pytest.mark.parametrize("n, value", [(2, 1.0), (4, 0.5), (6, -0.9)])
def test_jordan_block_is_solved_to_its_backward_error(n, value):
    """A defective eigenvalue moves by ε^(1/n) under rounding: only the backward error is guaranteed."""
    J = value * np.eye(n) + np.diag(np.ones(n - 1), 1)
    lam, ok = _solve(J[None])
    assert ok.all()
    _check_guarantees(J, lam[0])
    assert np.max(np.abs(lam[0] - value)) <= 10.0 * EPS ** (1.0 / n)


def test_trivial_and_degenerate_stacks():
    lam, ok = _solve(np.zeros((3, 4, 4)))
    assert ok.all() and np.all(lam == 0)
    lam, ok = _solve(np.diag([3.0, -1.0, 2.0])[None])
    assert ok.all() and sorted(lam[0].real) == [-1.0, 2.0, 3.0] and np.all(lam[0].imag == 0)
    lam, ok = _solve(np.array([[[2.5]]]))
    assert ok.all() and lam[0, 0] == 2.5
    lam, ok = _solve(np.array([[[0.0, -4.0], [1.0, 0.0]]]))  # ±2j exactly
    assert ok.all() and np.allclose(np.sort_complex(lam[0]), [-2j, 2j], rtol=0, atol=1e-15)
    lam, ok = _solve(np.zeros((0, 5, 5)))
    assert lam.shape == (0, 5) and ok.shape == (0,)
    lam, ok = _solve(np.zeros((2, 0, 0)))
    assert lam.shape == (2, 0) and ok.all()


def test_non_finite_matrices_are_left_to_the_caller():
    M = np.stack([np.eye(3), np.eye(3), np.eye(3)])
    M[1, 0, 2] = np.nan
    M[2, 1, 1] = np.inf
    lam, ok = _solve(M)
    assert ok.tolist() == [True, False, False]
    assert np.all(lam[0] == 1.0) and np.all(np.isnan(lam[1:]))


def test_overflowing_iteration_is_reported_not_done():
    """Entries near the float maximum overflow inside the iteration: the matrix is not done (the
    caller solves it with LAPACK), never given NaN or infinite eigenvalues as a result."""
    A = np.array([[1e308, 1e308, 0.0], [1e308, -1e308, 1e308], [0.0, 1e308, 1e308]])
    B = np.array([[1.0, 2.0], [3.0, 4.0]]) * 1e307  # finite eigenvalues, products overflow inside
    for M in (A, B):
        lam, ok = _solve(M[None])
        if ok[0]:  # a result is only reported when every eigenvalue is finite and satisfies λ's trace
            assert np.all(np.isfinite(lam[0]))
            assert abs(np.sum(lam[0] / 1e300).real - np.trace(M / 1e300)) <= 1e-12 * np.abs(M / 1e300).sum()
        else:  # not done: no partial result is left in the row
            assert np.all(np.isnan(lam[0]))
    # the overflowing 2x2 scaled down: the same eigenvalues, scaled back, as LAPACK's
    lam, ok = _solve((B * 1e-300)[None])
    assert ok[0]
    ref = np.sort_complex(np.linalg.eigvals(B * 1e-300))
    assert np.allclose(np.sort_complex(lam[0]), ref, rtol=1e-13)


def test_sampled_loop_matrices_of_a_batch_match_lapack():
    """The loop matrices the sweep's sampled columns solve (free, human mass and spring members,
    whole and fractional delays): every eigenvalue as LAPACK's, to rounding."""
    from exotune.config import batch_config
    from exotune.sampled.batch import BatchLoops, Loop

    from paper_design import paper_design

    cfg = paper_design(sample_rate_hz=1000.0)
    n = 6
    b = batch_config(cfg, {"design.amplification": np.linspace(2.0, 15.0, n),
                           "implementation.delay_s": np.array([0.0, 0.0005, 0.001, 0.0017, 0.002, 0.0043])})
    bl = BatchLoops(b, 1000.0)
    des = np.arange(n)
    loops = [(Loop("free"), np.zeros(n)),
             (Loop("h", human={"damping": 0.0}, param="inertia"), np.geomspace(1e-5, 0.1, n)),
             (Loop("h", human={"damping": 2.0}, param="stiffness"), np.geomspace(10.0, 1e5, n))]
    solved = 0
    for loop, v in loops:
        for _pos, M in bl.matrices(des, loop, v, bl.delay[des]):
            lam, ok = _solve(M)
            assert ok.all()
            ref = np.linalg.eigvals(M)
            for i in range(M.shape[0]):
                _check_guarantees(M[i], lam[i])
                # loop eigenvalues can be clustered (repeated DOB poles): ε^(1/3)-level agreement
                assert _matched_distance(lam[i], ref[i]) <= 1e-5
                solved += 1
    assert solved == 3 * n


def _greedy_reference(la, lb):
    """The matching rule written out plainly: each eigenvalue's nearest partner when those are all
    different, else repeatedly the nearest remaining pair (ties: first in row-major order)."""
    N = la.size
    with np.errstate(invalid="ignore", over="ignore"):
        diff = la[:, None] - lb[None, :]
        D = diff.real * diff.real + diff.imag * diff.imag  # nearest by squared distance, as the kernel ranks
    D[~np.isfinite(D)] = 1e300
    near = D.argmin(axis=1)
    if len(set(near.tolist())) == N:
        return near
    perm = np.zeros(N, int)
    D = D.copy()
    for _ in range(N):
        i, j = np.unravel_index(np.argmin(D), D.shape)
        perm[i] = j
        D[i, :] = np.inf
        D[:, j] = np.inf
    return perm


@settings(max_examples=60, deadline=None)
@given(n=st.integers(1, 12), seed=st.integers(0, 2**31 - 1), move=st.floats(1e-6, 3.0), ties=st.booleans())
def test_spectra_matching_follows_the_nearest_pair_rule(n, seed, move, ties):
    from exotune.numerics.kernels.eig import match_spectra

    rng = np.random.default_rng(seed)
    la = rng.standard_normal((4, n)) + 1j * rng.standard_normal((4, n))
    if ties:  # repeated values and conjugates: clashes and equal distances
        la = np.round(la, 0)
    lb = la[:, rng.permutation(n)] + move * (rng.standard_normal((4, n)) + 1j * rng.standard_normal((4, n)))
    lb[0, 0] = np.inf if n > 1 else lb[0, 0]
    perm = match_spectra(la, lb)
    for r in range(4):
        assert sorted(perm[r].tolist()) == list(range(n))  # one to one
        assert perm[r].tolist() == _greedy_reference(la[r], lb[r]).tolist()


# the campaign design with a cluster of eigenvalues at z = 1: campaign_designs.CLUSTER_AT_Z1_10KHZ


def test_eigenvalues_clustered_at_z_1_are_accurate():
    """Against 50-digit eigenvalues (mpmath): the largest moduli of the loop at members across the
    family, within 1e-9 (LAPACK's own error here is of the same order)."""
    mpmath = pytest.importorskip("mpmath")
    from exotune.config import batch_config, design_from_mapping
    from exotune.sampled.batch import BatchLoops
    from exotune.sampled.families import family_loops

    des = design_from_mapping(CLUSTER_AT_Z1_10KHZ)
    b = batch_config(des, {"design.amplification": np.array([CLUSTER_AT_Z1_10KHZ["design"]["amplification"]])})
    bl = BatchLoops(b, 10000.0)
    loop, lo, hi = family_loops(des.humans, des.environment)[0]
    v = np.geomspace(lo, hi, 40)[[4, 11, 23, 27]]
    [(_pos, M)] = bl.matrices(np.zeros(v.size, int), loop, v, np.full(v.size, bl.delay[0]))
    lam, ok = _solve(M)
    assert ok.all()
    for i in range(v.size):
        with mpmath.workdps(50):
            exact = np.array([complex(e) for e in mpmath.eig(mpmath.matrix(M[i].tolist()), left=False, right=False)])
        top = np.sort(np.abs(exact))[::-1][:4]
        assert top[0] == pytest.approx(1.0, abs=1e-12) and top[1] > 0.9999  # the cluster at z = 1
        assert _matched_distance(lam[i], exact) <= 1e-7  # the whole spectrum
        assert np.max(np.abs(np.sort(np.abs(lam[i]))[::-1][:4] - top)) <= 1e-9  # the moduli that decide
