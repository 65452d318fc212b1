"""exotune.identification.validate: the identified plant simulated from a log's measured inputs
(against the log it generated), NRMSE by its definition, the residual test against numpy's
correlations, and validate_plant's views."""

import math

import numpy as np
import pytest

from exotune.identification.data import log_from_columns
from exotune.identification.estimate import identify_plant
from exotune.identification.validate import nrmse_percent, residual_test, simulate_outputs, validate_plant

from identification.simulated_logs import TRUE, held_logs

FS = 1000.0


@pytest.fixture(scope="module")
def logs():
    a, b = held_logs(2, FS, 10.0, delay=1, noise=False, seed0=11)
    return log_from_columns(a, delay_s="0.001"), log_from_columns(b, delay_s="0.001")


def test_noise_free_outputs_are_reproduced_by_the_true_plant(logs):
    log = logs[0]
    outs = {o[0]: o for o in simulate_outputs(log, dict(TRUE), 1, 10.0)}
    assert set(outs) == {"θ_m", "θ_j", "τ_s", "τ_c"}
    for name, (_o, inputs, y, ysim, free, _u) in outs.items():
        nrmse, e = nrmse_percent(y, ysim, free)
        assert nrmse < 1e-3, (name, nrmse)  # exact discretization: only the initial state is fitted
    assert outs["θ_m"][1] == "τ_m (τ_cmd delayed, held), τ_s"
    assert np.array_equal(outs["τ_s"][3], TRUE["sea_stiffness"] * (log.signals["theta_j"] - log.signals["theta_m"]))


def test_a_wrong_parameter_shows_in_the_fit(logs):
    wrong = {**TRUE, "motor_inertia": 1.2 * TRUE["motor_inertia"]}
    _o, _i, y, ysim, free, _u = next(simulate_outputs(logs[0], wrong, 1, 10.0))
    assert nrmse_percent(y, ysim, free)[0] > 1.0


def test_nrmse_by_its_definition():
    y = np.array([1.0, 2.0, 3.0, 4.0])
    ysim = np.array([1.0, 2.5, 3.0, 3.0])
    nrmse, e = nrmse_percent(y, ysim, None)
    assert nrmse == pytest.approx(100 * np.linalg.norm(y - ysim) / np.linalg.norm(y - y.mean()))
    assert np.array_equal(e, y - ysim)
    assert math.isnan(nrmse_percent(np.ones(4), np.zeros(4), None)[0])


def test_residual_test_against_numpy_correlations():
    rng = np.random.default_rng(0)
    n = 20000
    u = rng.normal(size=n)
    e = 0.5 * np.roll(u, 3) + rng.normal(size=n)  # correlated with the input at lag 3
    t = residual_test("θ_m", "τ_m", e, u, lags=10)
    ref_auto = [np.dot(e[: n - k], e[k:]) / np.dot(e, e) for k in range(11)]
    assert np.allclose(t.autocorrelation, ref_auto, atol=2e-4)
    assert t.auto_bound == pytest.approx(2.58 / math.sqrt(n), rel=1e-6)
    # the documented convention: positive lag = the input leads, e(t) against u(t − lag)
    ec, uc = e - e.mean(), u - u.mean()
    ref_cross = [np.dot(ec[max(L, 0): n + min(L, 0)], uc[max(-L, 0): n - max(L, 0)]) / np.sqrt(np.dot(ec, ec) * np.dot(uc, uc))
                 for L in range(-10, 11)]
    assert t.cross_lags.tolist() == list(range(-10, 11))
    assert np.allclose(t.cross_correlation, ref_cross, atol=2e-4)
    assert t.peak_lag == 3 and t.cross_correlation[13] > 0.4 and not t.independent
    white = residual_test("θ_m", "τ_m", rng.normal(size=n), u, lags=10)
    assert white.white and white.independent


def test_validate_plant_on_a_held_out_log(logs):
    est = identify_plant(logs[0])
    out = validate_plant(est, logs[0], validation_log=logs[1])
    assert out.parameters == est.parameters  # the estimate, with its validation
    v = out.validation
    assert v.held_out and {f.output for f in v.fits} == {"θ_m", "θ_j", "τ_s", "τ_c"}
    assert all(f.nrmse_percent < 0.01 and f.data.startswith("held-out log") for f in v.fits)
    assert [fr.name for fr in v.frequency_responses] == ["motor", "spring", "joint", "cuff"]
    assert {t.output for t in v.residual_tests} >= {"θ_m"}
    assert v.to_dict()["held_out"] is True
