"""exotune.controllerfile.roundoff: the rounding bound of a float32 controller. The ℓ1 sums of
impulse responses (:func:`impulse_l1`) against ``scipy.signal.dimpulse``; the bound is linear in
the input amplitudes, grows with the horizon, and holds: the float32 runtime against the float64
reference on random inputs within the amplitudes, from the zero state, stays below it."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal
from hypothesis import given, settings
from hypothesis import strategies as st

from exotune.controllerfile.precision import Float32Runtime
from exotune.controllerfile.roundoff import DEFAULT_AMPLITUDES, UNIT_ROUNDOFF, impulse_l1, roundoff_bound
from exotune.controllerfile.runtime import Runtime
from exotune.sampled import Measured


@settings(max_examples=25, deadline=None)
@given(st.integers(1, 4), st.integers(1, 3), st.integers(0, 2**32 - 1))
def test_impulse_l1_is_the_sum_of_dimpulse(n, m, seed):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n, n))
    A *= 0.9 / max(np.max(np.abs(np.linalg.eigvals(A))), 1e-3)
    B, C, D = rng.normal(size=(n, m)), rng.normal(size=(2, n)), rng.normal(size=(2, m))
    N = 30
    acc, sq = impulse_l1(A, B, C, D, N, squares=True)
    assert acc.shape == (2, m)
    for i in range(m):
        _, (h,) = scipy.signal.dimpulse((A, B[:, [i]], C, D[:, [i]], 1.0), n=N)
        np.testing.assert_allclose(acc[:, i], np.abs(h).sum(0), rtol=1e-10)
        np.testing.assert_allclose(sq[:, i], (h * h).sum(0), rtol=1e-10)


def test_bound_parts_add_up_and_are_positive(scheduled_doc32):
    b = roundoff_bound(scheduled_doc32)
    assert b["arithmetic"]["value"] > 0 and b["coefficients"]["value"] >= 0
    assert b["total"]["value"] == pytest.approx(b["arithmetic"]["value"] + b["coefficients"]["value"], rel=1e-15)
    assert b["horizon"]["samples"] == 100  # 0.1 s at 1 kHz
    assert b["unit_roundoff"] == UNIT_ROUNDOFF == 2.0 ** -24
    assert sum(loc["points"] for loc in b["by_location"]) == b["rounding_points"]
    assert sum(loc["bound"]["value"] for loc in b["by_location"]) == pytest.approx(b["arithmetic"]["value"], rel=1e-12)
    shares = [loc["bound"]["value"] for loc in b["by_location"]]
    assert shares == sorted(shares, reverse=True)
    assert b["arithmetic_rms_estimate"]["value"] < b["arithmetic"]["value"]


@settings(max_examples=5, deadline=None)
@given(st.floats(0.1, 10.0))
def test_bound_is_linear_in_the_amplitudes(scheduled_doc32, k):
    b1 = roundoff_bound(scheduled_doc32, horizon_samples=40)
    bk = roundoff_bound(scheduled_doc32, {s: k * a for s, a in DEFAULT_AMPLITUDES.items()}, horizon_samples=40)
    for part in ("arithmetic", "coefficients", "total"):
        assert bk[part]["value"] == pytest.approx(k * b1[part]["value"], rel=1e-9)


def test_bound_grows_with_the_horizon(scheduled_doc32):
    vals = [roundoff_bound(scheduled_doc32, horizon_samples=n)["total"]["value"] for n in (5, 20, 80)]
    assert vals[0] <= vals[1] <= vals[2]


def test_bound_holds_against_float32_simulation(scheduled_doc32):
    n = 100
    b = roundoff_bound(scheduled_doc32, horizon_samples=n)["total"]["value"]
    # the float64 controller of the same file: its sos (no realization)
    doc64 = {**scheduled_doc32, "controller": {k: v for k, v in scheduled_doc32["controller"].items()
                                               if k != "realization"}}
    rng = np.random.default_rng(11)
    worst = 0.0
    for _ in range(3):
        ins = {s: DEFAULT_AMPLITUDES[s] * rng.uniform(-1, 1, n) for s in Measured}
        err = np.abs(Float32Runtime(scheduled_doc32).run(ins) - Runtime(doc64).run(ins))
        worst = max(worst, float(np.max(err)))
    assert 0 < worst <= b
