"""exotune.identification.diagnose: the delay screen (cross-correlations) against explicit
regressions at every delay, the regression of one equation, and the wording of a wrong-delay warning."""

import numpy as np
import pytest

from exotune.identification.data import log_from_columns
from exotune.identification.diagnose import diagnose, fit_delays, regression, screen_delays
from exotune.identification.regress import Design
from exotune.identification.result import ParameterEstimate
from exotune.identification.signals import FilteredLogs

from identification.simulated_logs import TRUE, held_logs

FS, FH = 1000.0, 10.0
MOTOR = ([("motor_inertia", "J_m", "kg·m²"), ("motor_damping", "B_m", "N·m·s/rad")], ("theta_m", "tau_s", "tau_m"),
         "N·m", "J_m θ̈_m + B_m θ̇_m = τ_s + τ_m", [("theta_m", 2), ("theta_m", 1)], "motor_y")
SKIP = 40  # samples dropped: the filter's transient, and room for the screened delays


@pytest.fixture(scope="module")
def sig():
    logs = [log_from_columns(c, delay_s="auto") for c in held_logs(2, FS, 8.0, delay=3, seed0=7)]
    return FilteredLogs(logs, FH, [SKIP, SKIP])


def test_regression_moves_fixed_parameters_to_the_left(sig):
    y, cols, free = regression(sig, MOTOR, {}, 3)
    assert [f[0] for f in free] == ["motor_inertia", "motor_damping"] and len(cols) == 2 and len(y) == 2
    y2, cols2, free2 = regression(sig, MOTOR, {"motor_damping": 17.9}, 3)
    assert [f[0] for f in free2] == ["motor_inertia"]
    assert np.allclose(y2[0], y[0] - 17.9 * sig.get("theta_m", 1)[0])
    fit = Design(cols2, sig.modes()).fit(y2)
    assert fit.beta[0] == pytest.approx(TRUE["motor_inertia"], rel=0.01)


def test_the_screen_finds_the_delay_the_explicit_fits_find(sig):
    y0, cols, _free = regression(sig, MOTOR, {}, 0)
    design = Design(cols, sig.modes())
    y_fixed = tuple(a - b for a, b in zip(y0, sig.applied(0)))
    fits = fit_delays(sig, design, lambda d: tuple(a + b for a, b in zip(y_fixed, sig.applied(d))), range(0, 11))
    assert sorted(fits) == list(range(11))
    best = min(fits, key=lambda d: fits[d][0])
    assert best == 3
    assert screen_delays(sig, design, y_fixed, 10) == best
    assert fits[3][1] == pytest.approx([TRUE["motor_inertia"], TRUE["motor_damping"]], rel=0.01)


def test_wrong_delay_warning_names_the_better_delay(sig):
    fitted = {"motor_inertia": ParameterEstimate("motor_inertia", "J_m", 0.44, 0.001, "kg·m²"),
              "motor_damping": ParameterEstimate("motor_damping", "B_m", 17.9, 0.1, "N·m·s/rad", fixed=True)}
    info = {"rms_residual": 0.5, "better_delay": {"samples": 4, "rms_residual": 0.1,
                                                  "shift": {"motor_inertia": 0.03, "motor_damping": 0.2}}}
    warnings, errors = diagnose("motor", fitted, sig, None, {}, True, 3, 10, 5.0, info)
    assert warnings == ["wrong delay? the motor-equation residual is smaller with a delay of 4 samples (0.1 N·m "
                        "against 0.5 N·m): check --delay-s, or use --delay-s auto"]
    assert errors == [("motor_inertia", 0.03, "a delay of 4 samples fits the motor equation better")]  # not the fixed one
    assert diagnose("motor", fitted, sig, None, {}, True, 3, 10, 5.0, {"rms_residual": 0.5}) == ([], [])
