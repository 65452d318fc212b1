"""exotune.identification.regress: the regression over several logs (free parameters shared, an
offset and three transients per log) against numpy's least squares on the stacked matrix, its
refusals, the Parzen window and the covariance of white residuals."""

import numpy as np
import pytest

from exotune.identification.regress import Design, Fit, NotExcited, parzen

W = 50.0  # 1/s: the filters' transient rate


def _modes(t):
    e = np.exp(-W * t)
    return np.vstack([e, t * e, t * t * e])


def _logs(rng, sizes, beta, noise=0.0):
    free, modes, ys, blocks = [[], []], [], [], []
    for i, n in enumerate(sizes):
        t = np.arange(n) / 1000.0
        x1, x2 = rng.normal(size=n), np.sin(7 * t) + 0.3 * rng.normal(size=n)
        K = 200
        M = _modes(t[:K])
        nuis = np.array([0.5 + i, 3.0, -20.0, 100.0])
        y = beta[0] * x1 + beta[1] * x2 + nuis[0] + np.r_[nuis[1:] @ M, np.zeros(n - K)] + noise * rng.normal(size=n)
        free[0].append(x1)
        free[1].append(x2)
        modes.append(M)
        ys.append(y)
        blocks.append((x1, x2, np.ones(n), np.hstack([M, np.zeros((3, n - K))]).T))
    return free, modes, ys, blocks


def test_fit_recovers_shared_parameters_and_per_log_nuisance():
    rng = np.random.default_rng(0)
    beta = np.array([2.0, -3.0])
    free, modes, ys, _ = _logs(rng, (1500, 900), beta)
    fit = Design(free, modes).fit(ys)
    assert isinstance(fit, Fit) and fit.samples == 2400
    assert fit.beta == pytest.approx(beta, rel=1e-9)
    assert fit.nuisance[0] == pytest.approx([0.5, 3.0, -20.0, 100.0], rel=1e-6)
    assert fit.nuisance[1][0] == pytest.approx(1.5, rel=1e-9)
    assert fit.rms() < 1e-9


def test_fit_equals_numpy_lstsq_on_the_stacked_matrix():
    rng = np.random.default_rng(1)
    free, modes, ys, blocks = _logs(rng, (800, 600), np.array([1.0, 0.5]), noise=0.1)
    n = sum(b[0].size for b in blocks)
    X = np.zeros((n, 2 + 4 * len(blocks)))
    row = 0
    for i, (x1, x2, one, M) in enumerate(blocks):
        k = x1.size
        X[row:row + k, 0], X[row:row + k, 1] = x1, x2
        X[row:row + k, 2 + 4 * i] = one
        X[row:row + k, 3 + 4 * i: 6 + 4 * i] = M
        row += k
    ref, *_ = np.linalg.lstsq(X, np.concatenate(ys), rcond=None)
    fit = Design(free, modes).fit(ys)
    assert fit.beta == pytest.approx(ref[:2], rel=1e-9)
    assert fit.nuisance[1] == pytest.approx(ref[6:10], rel=1e-6, abs=1e-6)
    assert fit.rss() == pytest.approx(np.sum((np.concatenate(ys) - X @ ref) ** 2), rel=1e-9)


def test_refusals():
    rng = np.random.default_rng(2)
    free, modes, _, _ = _logs(rng, (500,), np.ones(2))
    with pytest.raises(NotExcited, match="identically zero"):
        Design([free[0], [np.zeros(500)]], modes)
    with pytest.raises(NotExcited, match="condition number"):
        Design([free[0], [2.0 * free[0][0]]], modes)  # two collinear columns
    with pytest.raises(NotExcited, match="overflow"):
        Design([free[0], [np.r_[np.inf, np.ones(499)]]], modes)
    assert issubclass(NotExcited, ValueError)


def test_parzen_window_by_its_formula():
    L = 9  # x = |lag|/10
    assert parzen(np.array([0, 5, 10, -5]), L).tolist() == pytest.approx([1.0, 0.25, 0.0, 0.25])
    x = 0.3
    assert parzen(np.array([3]), L)[0] == pytest.approx(1 - 6 * x**2 + 6 * x**3)
    x = 0.7
    assert parzen(np.array([7]), L)[0] == pytest.approx(2 * (1 - x) ** 3)
    w = parzen(np.arange(-20, 21), 20)  # its domain: |lag| ≤ L
    assert np.all(w > 0) and np.all(np.diff(w[20:]) < 0) and np.array_equal(w, w[::-1])


def test_covariance_of_white_residuals_is_the_textbook_one():
    rng = np.random.default_rng(3)
    n, sigma = 20000, 0.2
    x1, x2 = rng.normal(size=n), rng.normal(size=n)
    t = np.arange(n) / 1000.0
    M = _modes(t[:200])
    y = 1.5 * x1 - 0.5 * x2 + sigma * rng.normal(size=n)
    d = Design([[x1], [x2]], [M])
    fit = d.fit([y])
    C = d.covariance(fit, lag=10)
    X = np.column_stack([x1, x2, np.ones(n)])
    ref = sigma**2 * np.linalg.inv(X.T @ X)[:2, :2]
    assert C.shape == (2, 2)
    assert np.diag(C) == pytest.approx(np.diag(ref), rel=0.25)
    assert abs(fit.beta[0] - 1.5) < 5 * np.sqrt(C[0, 0])
