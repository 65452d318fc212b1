"""exotune.sampled.rigid on synthetic matrices with a known spectrum (the loops themselves:
tests/sampled/test_rigid_deflation.py): a matrix V diag(λ) V⁻¹ with λ_0 = 1 and an eigenvector
whose first n entries are the given plant vector is deflated to a matrix whose eigenvalues are the
other λ_i; its balancing is LAPACK's (scipy.linalg.matrix_balance) and exact. The deflation runs on
both engines: the numpy reference and the compiled kernel (exotune.numerics.kernels.rigid, the
sweep's; compared with each other in tests/numerics/kernels/test_rigid.py)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
from scipy.optimize import linear_sum_assignment

from exotune.numerics.engine import compiled, numpy_engine
from exotune.numerics.kernels.common import AVAILABLE
from exotune.sampled.rigid import balancing, deflate, rigid_deflation, rigid_vectors


@pytest.fixture(params=["numpy", "numba"])
def engine(request):
    """Runs the test inside the numpy engine, or on the compiled one (skipped without numba)."""
    if request.param == "numpy":
        with numpy_engine():
            yield request.param
        return
    if not (AVAILABLE and compiled()):
        pytest.skip("the compiled engine is not in use (numba missing or EXOTUNE_NUMPY_ONLY)")
    yield request.param


def _synthetic(seed: int, N: int = 9, n: int = 4, spread: float = 4.0):
    """(M, x, the other eigenvalues): M = S V diag(λ) V⁻¹ S⁻¹ with rows and columns scaled over
    10^±spread (a badly scaled matrix, as loop matrices are), λ_0 = 1 whose eigenvector starts with x."""
    rng = np.random.default_rng(seed)
    lam = np.concatenate([[1.0], rng.uniform(-0.95, 0.95, N - 1)])
    V = rng.normal(size=(N, N))
    x = np.array([1.0, 0.0, 1.0, 0.0])[:n]
    sc = 10.0 ** rng.uniform(-spread, spread, N)
    V[:n, 0] = x / sc[:n]  # S V e_0 starts with x
    M = sc[:, None] * (V @ np.diag(lam) @ np.linalg.inv(V)) / sc[None, :]
    return M, x, lam[1:]


@pytest.mark.parametrize("seed", range(6))
def test_deflation_leaves_the_other_eigenvalues(seed, engine):
    M, x, others = _synthetic(seed)
    v, ok = rigid_vectors(M[None], x)
    assert ok[0]
    assert np.allclose(v[0, :4], x, rtol=0, atol=0)
    ok, s, Q2, Md = rigid_deflation(M[None], x)
    assert ok[0] and Q2.shape == (1, 9, 8) and Md.shape == (1, 8, 8)
    assert np.allclose(Q2[0].T @ Q2[0], np.eye(8), atol=1e-14)
    vb = v[0] / s[0]
    assert np.linalg.norm(Q2[0].T @ vb) <= 1e-14 * np.linalg.norm(vb)
    assert np.allclose(deflate(M[None], s, Q2), Md, rtol=1e-14, atol=1e-14 * np.abs(Md).max())
    got = np.linalg.eigvals(Md[0])
    r, c = linear_sum_assignment(np.abs(others[:, None] - got[None, :]))
    assert np.max(np.abs(others[r] - got[c])) < 1e-9


def test_no_eigenvector_no_deflation(engine):
    """A plant vector that is not the start of an eigenvector at 1 is refused, as is a matrix with
    no eigenvalue at 1 at all or a non-finite one."""
    M, x, _ = _synthetic(7)
    assert not rigid_vectors(M[None], np.array([1.0, 0.0, 0.0, 0.0]))[1][0]
    assert not rigid_vectors((0.5 * M)[None], x)[1][0]
    bad = M.copy()
    bad[3, 2] = np.inf
    ok, s, Q2, Md = rigid_deflation(np.stack([bad, M]), x)
    assert ok.tolist() == [False, True] and s.shape == (1, 9) and Q2.shape == (1, 9, 8) and Md.shape == (1, 8, 8)


def test_balancing_is_lapacks_and_exact():
    M, _x, _ = _synthetic(3, spread=6.0)
    s = balancing(M[None])[0]
    Mb, (sc, _) = scipy.linalg.matrix_balance(M, permute=False, separate=True)
    assert np.allclose(s, sc, rtol=1e-15)
    assert np.all(np.log2(s) == np.round(np.log2(s)))  # powers of two: the similarity is exact
    assert np.allclose(M * s[None, :] / s[:, None], Mb, rtol=1e-15, atol=0)
