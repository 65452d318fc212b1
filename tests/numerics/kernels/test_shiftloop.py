"""The compiled structured recursion of a simulated run with a delay line
(exotune.numerics.kernels.shiftloop) against the dense recursion w' = M w + N·push it replaces,
and end to end: a 50 kHz simulation (a 51-sample delay line) is the same with either."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from exotune.numerics.kernels import AVAILABLE

pytestmark = pytest.mark.skipif(not AVAILABLE, reason="numba not installed: only the dense numpy recursion exists")
EXAMPLES = Path(__file__).resolve().parents[3] / "examples"


def _dense(Phi, g_cur, g_old, g_push, BC, A, u_p, u_c, d):
    n_p, n_c, ns = Phi.shape[0], A.shape[0], d + 1
    N = n_p + n_c + ns
    u = np.concatenate([u_p, u_c, np.zeros(ns)])
    s0 = n_p + n_c
    cur = u if d == 0 else np.eye(N)[s0 + d - 1]
    old = np.eye(N)[s0 + d]
    M = np.zeros((N, N))
    M[:n_p, :n_p] = Phi
    M[:n_p] += np.outer(g_cur, cur) + np.outer(g_old, old)
    M[n_p:s0, :n_p] = BC
    M[n_p:s0, n_p:s0] = A
    M[s0] = u
    for j in range(1, ns):
        M[s0 + j, s0 + j - 1] = 1.0
    Np = np.zeros(N)
    Np[:n_p] = g_push
    return M, Np


@pytest.mark.parametrize("d", [0, 1, 7, 60])
def test_structured_equals_dense(d):
    from exotune.numerics.kernels.shiftloop import shift_loop_run

    rng = np.random.default_rng(d)
    n_p, n_c = 6, 5
    blocks = (0.3 * rng.standard_normal((n_p, n_p)), rng.standard_normal(n_p), rng.standard_normal(n_p),
              rng.standard_normal(n_p), 0.2 * rng.standard_normal((n_c, n_p)), 0.3 * rng.standard_normal((n_c, n_c)),
              0.1 * rng.standard_normal(n_p), 0.1 * rng.standard_normal(n_c))
    M, Np = _dense(*blocks, d)
    w0 = rng.standard_normal(M.shape[0])
    push = rng.standard_normal(300)
    ref = np.empty((push.size + 1, w0.size))
    ref[0] = w = w0
    for k in range(push.size):
        w = M @ w + Np * push[k]
        ref[k + 1] = w
    got = shift_loop_run(*blocks, d, w0, push)
    np.testing.assert_allclose(got, ref, rtol=1e-11, atol=1e-11 * np.max(np.abs(ref)))


def test_a_high_rate_simulation_is_the_same_on_both_recursions(monkeypatch):
    from exotune.simulation import load_for_simulation, run_scenario

    doc = load_for_simulation(EXAMPLES / "scheduled.yaml", 50000.0)
    # 0.6 s: at least two periods of the loop's 3.9 Hz dominant oscillation, so the run is judged
    fast = run_scenario(doc, "saturation", duration_s=0.6).full_report()["summary"]
    monkeypatch.setenv("EXOTUNE_NUMPY_ONLY", "1")
    dense = run_scenario(doc, "saturation", duration_s=0.6).full_report()["summary"]
    assert fast["verdict"] == dense["verdict"] != "inconclusive"
    for k in ("peak_motor_torque", "peak_command"):
        assert fast[k]["value"] == pytest.approx(dense[k]["value"], rel=1e-9), k
