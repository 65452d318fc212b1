"""exotune.numerics.kernels.rigid: the compiled deflation of the rigid-body eigenvalue z = 1 against
the numpy reference (exotune.sampled.rigid on the numpy engine) and against what the deflation
must give whatever the implementation, checked from the definitions:

* the same ok mask; scalings, bases and deflated matrices equal to rounding;
* the deflated matrix's eigenvalues are the full matrix's (numpy.linalg.eigvals) less the one
  nearest 1, each within its condition number's rounding;
* Q₂ has orthonormal columns orthogonal to the rigid vector [D⁻¹x; w] (w: any solution of
  (M_b − I)v = 0, here the nullspace vector of M − I from an SVD);
* matrices whose structural vector is no eigenvector at 1 (perturbed, grounded, no eigenvalue
  at 1, non-finite) are refused by both.

On random matrices with a known eigenvector at 1 and on the loop matrices of ungrounded
sampled-data loops (exotune.sampled.batch.BatchLoops.matrices, as the sweep builds them)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
from scipy.optimize import linear_sum_assignment

from exotune.config import batch_config
from exotune.numerics.engine import compiled, numpy_engine
from exotune.numerics.kernels.common import AVAILABLE
from exotune.sampled.batch import BatchLoops, Loop
from exotune.sampled.loop import rigid_plant_vector
from exotune.sampled.rigid import RIGID_ULPS, deflate, rigid_deflation

from paper_design import paper_design

pytestmark = pytest.mark.skipif(not AVAILABLE, reason="numba is not installed")

EPS = np.finfo(float).eps


def _compiled(M, x):
    from exotune.numerics.kernels.rigid import rigid_deflation_stack

    return rigid_deflation_stack(M, x, RIGID_ULPS)


def _reference(M, x):
    with numpy_engine():
        return rigid_deflation(M, x)


def _synthetic(rng, N: int, n: int, spread: float = 4.0):
    """M = S V diag(λ) V⁻¹ S⁻¹ with λ_0 = 1 whose eigenvector's plant part is x (1 on the even
    states, 0 on the odd ones), the other λ random inside the unit disc (some complex pairs),
    rows and columns scaled over 10^±spread as loop matrices are."""
    x = np.array([1.0 if i % 2 == 0 else 0.0 for i in range(n)])
    lam = rng.uniform(-0.95, 0.95, N - 1)
    blocks = [np.array([[1.0]])]
    i = 0
    while i < N - 1:
        if i + 1 < N - 1 and rng.uniform() < 0.4:  # a complex pair a ± jb as a real 2×2 block
            a, b = 0.7 * lam[i], 0.5 * abs(lam[i + 1]) + 0.05
            blocks.append(np.array([[a, b], [-b, a]]))
            i += 2
        else:
            blocks.append(np.array([[lam[i]]]))
            i += 1
    V = rng.normal(size=(N, N))
    sc = 10.0 ** rng.uniform(-spread, spread, N)
    V[:n, 0] = x / sc[:n]
    M = sc[:, None] * (V @ scipy.linalg.block_diag(*blocks) @ np.linalg.inv(V)) / sc[None, :]
    return M, x


def _check_agreement(M, x):
    """Compiled and reference deflations of the stack agree: the same ok mask, scalings, bases and
    deflated matrices to rounding. Returns the compiled outputs."""
    ok, s, Q2, D = _compiled(M, x)
    ok_r, s_r, Q2_r, D_r = _reference(M, x)
    assert ok.tolist() == ok_r.tolist()
    m = int(ok.sum())
    N = M.shape[1]
    assert s.shape == (m, N) and Q2.shape == (m, N, N - 1) and D.shape == (m, N - 1, N - 1)
    assert np.allclose(s, s_r, rtol=1e-15, atol=0.0)  # the same powers of two (dgebal's rule)
    assert np.all(np.abs(Q2 - Q2_r) <= 1e-10)
    scale = np.linalg.norm(D_r, axis=(1, 2))[:, None, None]
    assert np.all(np.abs(D - D_r) <= 1e-11 * scale)
    return ok, s, Q2, D


def _conditioned_eigenvalues(M):
    """numpy.linalg.eigvals of M and a rounding scale per eigenvalue, 1e3·κ_i·ε·‖M_b‖_F
    (κ_i = 1/|y_iᴴx_i| from unit left and right eigenvectors of the balanced M_b) + 1e-13."""
    w = np.linalg.eigvals(M)
    Mb = scipy.linalg.matrix_balance(M, permute=False)[0]
    wb, vl, vr = scipy.linalg.eig(Mb, left=True, right=True)
    kappa = 1.0 / np.maximum(np.abs(np.sum(vl.conj() * vr, axis=0)), 1e-300)
    r, c = linear_sum_assignment(np.abs(w[:, None] - wb[None, :]))
    tol = np.empty(w.size)
    tol[r] = 1e3 * kappa[c] * EPS * np.linalg.norm(Mb) + 1e-13
    return w, tol


def _check_spectrum(M, x, s, Q2, D):
    """The deflated spectrum is the full one less the eigenvalue nearest 1; Q₂ orthonormal and
    orthogonal to the (SVD) nullspace vector of M_b − I."""
    N = M.shape[0]
    w, tol = _conditioned_eigenvalues(M)
    i = int(np.argmin(np.abs(w - 1.0)))
    assert abs(w[i] - 1.0) <= max(tol[i], 1e-6)
    w, tol = np.delete(w, i), np.delete(tol, i)
    got = np.linalg.eigvals(D)
    r, c = linear_sum_assignment(np.abs(w[:, None] - got[None, :]))
    assert r.size == N - 1
    assert np.all(np.abs(w[r] - got[c]) <= np.maximum(tol[r], 1e-9 * np.abs(w[r]))), \
        (np.abs(w[r] - got[c]) / tol[r]).max()
    assert np.allclose(Q2.T @ Q2, np.eye(N - 1), rtol=0.0, atol=20 * N * EPS)
    Mb = M * (s[None, :] / s[:, None])
    null = np.linalg.svd(Mb - np.eye(N))[2][-1]  # the balanced eigenvector at 1, unit norm
    assert np.linalg.norm(Q2.T @ null) <= 1e-8
    assert np.allclose(null[:x.size] / null[np.argmax(x)], x / s[:x.size] * s[np.argmax(x)], rtol=1e-6, atol=1e-9)


@pytest.mark.parametrize("seed", range(8))
def test_random_stacks_agree_with_the_reference(seed):
    rng = np.random.default_rng(seed)
    N = int(rng.integers(5, 17))
    n = int(rng.choice([1, 2, 4]))
    Ms, xs = zip(*(_synthetic(rng, N, n) for _ in range(5)))
    M = np.stack(Ms)
    ok, s, Q2, D = _check_agreement(M, xs[0])
    assert ok.all()
    for j in range(M.shape[0]):
        _check_spectrum(M[j], xs[0], s[j], Q2[j], D[j])


def test_refused_matrices_are_refused_by_both():
    """A stack mixing accepted matrices with refused ones: a random matrix (no eigenvalue at 1), a
    perturbed one (its structural vector off by far more than rounding), a non-finite one, and a
    plant vector that is not the eigenvector's: ok masks identical, outputs compacted in order."""
    rng = np.random.default_rng(11)
    good = [_synthetic(rng, 10, 4)[0] for _ in range(3)]
    x = np.array([1.0, 0.0, 1.0, 0.0])
    moved = good[1].copy()
    moved[:, 0] += 1e-6 * np.abs(moved[:, 0]) * rng.normal(size=10)  # a column x meets: M x moves
    bad = good[2].copy()
    bad[5, 3] = np.nan
    M = np.stack([good[0], rng.normal(size=(10, 10)), moved, good[1], bad, good[2]])
    ok, s, Q2, D = _check_agreement(M, x)
    assert ok.tolist() == [True, False, False, True, False, True]
    for j, g in enumerate((good[0], good[1], good[2])):
        _check_spectrum(g, x, s[j], Q2[j], D[j])
    ok_w, *_ = _check_agreement(M, np.array([1.0, 0.0, 0.0, 0.0]))  # θ_j left behind: no eigenvector
    assert not ok_w.any()


@pytest.fixture(scope="module")
def loops():
    """Paper loops at 1 kHz with and without a DOB (whose 1/(1 − Q) puts a controller pole at
    z = 1: I − M22 singular, only the least-squares solution fixes w), whole and fractional
    delays."""
    out = []
    for dob in (True, False):
        cfg = paper_design(sample_rate_hz=1000.0, **({} if dob else {"dob": None}))
        amps = np.array([2.0, 6.0, 10.0, 14.0])
        delays = np.array([0.0, 0.0007, 0.001, 0.0023])
        out.append(BatchLoops(batch_config(cfg, {"design.amplification": amps, "implementation.delay_s": delays}),
                              1000.0))
    return out


def _stacks(bl: BatchLoops, loop: Loop, v):
    des = np.repeat(np.arange(bl.n), 2)
    vals = np.zeros(des.size) if v is None else np.full(des.size, v) * np.tile([1.0, 3.0], bl.n)
    x = rigid_plant_vector((loop.env == "locked", loop.human is not None, *loop.structure()))
    return [M for _pos, M in bl.matrices(des, loop, vals, bl.delay[des])], x


@pytest.mark.parametrize("loop, v", [
    (Loop("free"), None),
    (Loop("h", human={"damping": 0.0}, param="inertia"), 0.05),
    (Loop("h", human={"inertia": 0.0}, param="damping"), 2.0),
    (Loop("e", env_param="inertia", env_damping=1.0), 0.3),
])
def test_ungrounded_loops_agree_with_the_reference_and_the_full_spectrum(loops, loop, v):
    for bl in loops:
        stacks, x = _stacks(bl, loop, v)
        for M in stacks:
            ok, s, Q2, D = _check_agreement(M, x)
            assert ok.all()
            for j in range(M.shape[0]):
                _check_spectrum(M[j], x, s[j], Q2[j], D[j])
            # deflate (the rounding trials' projection) on the same matrices gives the deflated ones
            from exotune.numerics.kernels.rigid import deflate_stack

            again = deflate_stack(M, s, Q2)
            assert np.all(np.abs(again - D) <= 1e-14 * np.linalg.norm(D, axis=(1, 2))[:, None, None])
            with numpy_engine():
                ref = deflate(M, s, Q2)
            assert np.all(np.abs(again - ref) <= 1e-13 * np.linalg.norm(ref, axis=(1, 2))[:, None, None])


@pytest.mark.parametrize("loop, v", [
    (Loop("h", human={"inertia": 0.05}, param="stiffness"), 300.0),
    (Loop("e", env_param="stiffness", env_damping=1.0), 800.0),
])
def test_grounded_loops_are_refused_by_both(loops, loop, v):
    """A spring to the ground: the structural vector (x of the ungrounded layout) is no eigenvector."""
    for bl in loops:
        stacks, _x = _stacks(bl, loop, v)
        x = rigid_plant_vector((False, loop.human is not None, *loop.structure()))
        for M in stacks:
            ok, *_ = _check_agreement(M, x)
            assert not ok.any()


def test_one_vector_per_matrix_and_the_public_switch(loops):
    """x given per matrix (k, n) as the single-loop path passes it, and rigid_deflation on the
    compiled engine (the sweep's) is the kernel."""
    stacks, x = _stacks(loops[0], Loop("free"), None)
    M = stacks[0]
    xs = np.repeat(x[None], M.shape[0], axis=0)
    xs[1] = [1.0, 0.0, 0.0, 0.0]  # this matrix's vector is wrong: refused alone
    ok, s, Q2, D = _compiled(M, xs)
    ok_r, *_ = _reference(M, xs)
    assert ok.tolist() == ok_r.tolist() == [j != 1 for j in range(M.shape[0])]
    ok2, s2, Q22, D2 = rigid_deflation(M, xs)
    assert ok2.tolist() == ok.tolist()
    # the kernel itself on the compiled engine; the numpy reference (to rounding) under EXOTUNE_NUMPY_ONLY
    tol = (1e-14 if compiled() else 1e-11) * np.linalg.norm(D, axis=(1, 2))[:, None, None]
    assert np.all(np.abs(D2 - D) <= tol)
