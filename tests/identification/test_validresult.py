"""exotune.identification.validresult: the validation's typed results (fits, 99 % bands, residual
tests, CSV) on small hand-made values."""

import csv
import io
import math

import numpy as np
import pytest

from exotune.identification.validresult import (CONFIDENCE_Z, MIN_COHERENCE, FrequencyResponse, LocalParameter,
                                                ModelError, OutputFit, ResidualTest, Validation)


def _fr(name="motor"):
    f = np.array([1.0, 10.0])
    return FrequencyResponse(name, "τ_m", "θ_m", "rad/(N·m)", f, np.array([2.0 + 0j, -1j]),
                             np.array([0.95, 0.5]), np.array([0.1, 2.0]), np.array([2.0 + 0.1j, -1.1j]),
                             (LocalParameter("motor_inertia", "J_m", "kg·m²", np.array([0.4, 0.5]),
                                             np.array([0.01, 0.1]), 0.44, 0.02, 10.0),), 8)


def test_output_fit():
    fit = OutputFit("θ_m", "τ_m, τ_s", 12.5, 1000, "held-out log")
    assert fit.fit_percent == 87.5
    assert fit.to_dict() == {"output": "θ_m", "inputs": "τ_m, τ_s", "nrmse_percent": 12.5, "fit_percent": 87.5,
                             "samples": 1000, "data": "held-out log"}


def test_frequency_response_band_and_coherent_bins():
    fr = _fr()
    assert fr.coherent.tolist() == [True, False] and MIN_COHERENCE == 0.9
    low, high, z = fr.band()
    # 99 %: z = 2.58·relative error (the phase half-width at most π)
    assert z.tolist() == pytest.approx([CONFIDENCE_Z * 0.1, math.pi])
    assert low.tolist() == pytest.approx([2.0 * math.exp(-0.258), 1.0 * math.exp(-math.pi)])
    assert high.tolist() == pytest.approx([2.0 * math.exp(0.258), 1.0 * math.exp(math.pi)])
    d = fr.to_dict()
    assert d["coherent_bins"] == 1 and d["averages"] == 8 and d["local_parameters"][0]["estimate"] == 0.44


def test_csv_rows_by_hand():
    rows = _fr().csv_rows()
    assert rows[0][:4] == ["transfer", "frequency_hz", "measured_magnitude", "measured_phase_deg"]
    r = rows[2]  # 10 Hz: measured −j (magnitude 1, −90°), model −1.1j
    assert r[0] == "motor" and r[1] == 10.0 and r[2] == pytest.approx(1.0) and r[3] == pytest.approx(-90.0)
    assert r[6] == pytest.approx(180.0)  # the phase band capped at π
    assert r[8] == pytest.approx(1.1) and r[9] == pytest.approx(-90.0) and r[10] == "rad/(N·m)"


def test_residual_test_whiteness_and_independence():
    auto = np.array([1.0] + [0.01] * 19 + [0.2])  # 1 of 20 lags beyond the bound: 5 %, still white
    t = ResidualTest("θ_m", "τ_m", np.arange(21), auto, 0.1, np.arange(-2, 3), np.array([0.0, 0.1, 0.2, 0.05, 0.0]),
                     0.15, 0)
    assert t.white is True and t.independent is False
    t2 = ResidualTest("θ_m", "τ_m", np.arange(21), np.r_[1.0, [0.2] * 20], 0.1, np.arange(1), np.zeros(1), 0.1, 0)
    assert t2.white is False and t2.independent is True
    d = t.to_dict()
    assert d["cross_lags"] == [-2, -1, 0, 1, 2] and d["autocorrelation"][-1] == 0.2 and type(d["peak_lag"]) is int


def test_validation_views():
    v = Validation("held-out log", True, (OutputFit("θ_m", "τ_m", 10.0, 100, "held-out log"),), (_fr("motor"), _fr("joint")),
                   (), (ModelError("motor_inertia", 0.05, "frequency response"),), ("a warning",))
    assert v.model_error("motor_inertia").relative == 0.05 and v.model_error("sea_stiffness") is None
    d = v.to_dict()
    assert d["model_errors"] == {"motor_inertia": {"relative": 0.05, "source": "frequency response"}}
    assert d["warnings"] == ["a warning"] and d["held_out"] is True and len(d["frequency_responses"]) == 2
    rows = list(csv.reader(io.StringIO(v.to_csv())))
    assert len(rows) == 1 + 2 + 2  # one header, two frequencies per response
    assert rows[0][0] == "transfer" and [r[0] for r in rows[1:]] == ["motor", "motor", "joint", "joint"]
    assert float(rows[1][2]) == 2.0
