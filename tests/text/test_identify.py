"""exotune.text.identify: the validation lines under the identify report, on a small typed validation."""

import numpy as np

from exotune.identification.validresult import FrequencyResponse, LocalParameter, OutputFit, ResidualTest, Validation
from exotune.text.identify import validation_text


def _validation(held_out=True):
    f = np.array([1.0, 2.0, 5.0, 10.0])
    local = (LocalParameter("motor_inertia", "J_m", "kg·m²", f, f, 0.44, 0.0, 5.0),
             LocalParameter("motor_damping", "B_m", "N·m·s/rad", f, f, 17.9, 0.123, 7.5))
    fr = FrequencyResponse("motor", "τ_m", "θ_m", "rad/(N·m)", f, np.ones(4, complex), np.array([0.5, 0.95, 0.99, 0.8]),
                           np.full(4, 0.01), np.ones(4, complex), local, 8)
    rt = ResidualTest("θ_m", "τ_m", np.arange(3), np.array([1.0, 0.01, 0.02]), 0.05, np.arange(-1, 2),
                      np.array([0.0, 0.3, 0.0]), 0.1, 0)
    fit = OutputFit("θ_m", "τ_m, τ_s", 4.56, 5000, "fold 1/3")
    return Validation("log.csv", held_out, (fit,), (fr,), (rt,), (), ("check the units",))


def test_validation_lines():
    assert validation_text(_validation()).splitlines() == [
        "  validation on log.csv",
        "    simulated θ_m from τ_m, τ_s: NRMSE 4.56 % (fit 95.4 %), 5000 samples, fold 1/3",
        "    frequency response motor (τ_m → θ_m): coherent (γ² ≥ 0.9) in 2 bins, 2–5 Hz; J_m within its band, "
        "B_m departs 12 % at 7.5 Hz",
        "    residuals of θ_m: white (bound ±0.05), correlated with τ_m (largest at lag 0 samples, bound ±0.1)",
        "  warning: check the units",
    ]


def test_fitting_log_says_so():
    first = validation_text(_validation(held_out=False)).splitlines()[0]
    assert first == ("  validation on log.csv (the fitting log: residual tests and frequency responses only; "
                     "--validate or --folds for held-out fits)")


def test_a_response_without_coherent_bins_says_so_in_words():
    """A constant θ_m log printed "coherent (γ² ≥ 0.9) in 0 bins, none; " (a dangling separator)."""
    f = np.array([1.0, 2.0])
    fr = FrequencyResponse("motor", "τ_m", "θ_m", "rad/(N·m)", f, np.ones(2, complex), np.array([0.1, 0.2]),
                           np.full(2, 0.01), np.ones(2, complex), (), 8)
    line = validation_text(Validation("log.csv", False, (), (fr,), (), (), ())).splitlines()[1]
    assert line == ("    frequency response motor (τ_m → θ_m): no coherent bin (γ² ≥ 0.9): nothing to compare with "
                    "the model")
