"""exotune.simulation.scenarios: the scenarios' pushes and references, and the dead zone."""

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from exotune.simulation.scenarios import SCENARIOS, Nonlinearities, Scenario, deadzone


@given(st.floats(-1.0, 1.0), st.floats(0.0, 0.5))
def test_deadzone_is_odd_zero_inside_and_slope_one_outside(x, b):
    y = deadzone(x, b)
    assert deadzone(-x, b) == -y
    if abs(x) <= b / 2:
        assert y == 0.0
    else:
        assert y == pytest.approx(x - math.copysign(b / 2, x), abs=1e-15)
        assert abs(y) <= abs(x)


def test_deadzone_without_width_is_the_identity():
    assert deadzone(0.3, 0.0) == 0.3 and deadzone(-0.3, -1.0) == -0.3
    assert deadzone(0.01, 0.005) == pytest.approx(0.0075)


def test_step_push_from_push_at_until_release():
    sc = Scenario("s", "d", True, {"inertia": 0.5}, 5.0, 0.05, 1.0, release_at_s=0.5)
    assert [sc.push(t) for t in (0.0, 0.0499, 0.05, 0.3, 0.4999, 0.5, 0.9)] == [0.0, 0.0, 5.0, 5.0, 5.0, 0.0, 0.0]


def test_sine_push_starts_at_push_at():
    sc = Scenario("s", "d", False, {"inertia": 0.5}, 3.0, 0.1, 4.0, push_hz=0.5)
    assert sc.push(0.05) == 0.0
    assert sc.push(0.1) == pytest.approx(0.0, abs=1e-15)
    assert sc.push(0.1 + 0.5) == pytest.approx(3.0)  # a quarter period of 0.5 Hz
    assert sc.push(0.1 + 1.5) == pytest.approx(-3.0)


def test_reference_is_a_raised_cosine_and_its_rate():
    sc = Scenario("s", "d", False, {"inertia": 0.5}, 0.0, 0.0, 1.0, reference_rad=0.2, reference_hz=2.0)
    assert sc.reference(0.0) == (0.0, 0.0)
    th, om = sc.reference(0.25)  # half a period: the top, at rest
    assert th == pytest.approx(0.4) and om == pytest.approx(0.0, abs=1e-12)
    th, om = sc.reference(0.125)  # a quarter period: θ_ref = 0.2, rate 0.2·2π·2
    assert th == pytest.approx(0.2) and om == pytest.approx(0.2 * 4 * math.pi)
    assert SCENARIOS["locked-output"].reference(0.3) == (0.0, 0.0)


def test_the_scenarios_exercise_what_they_say():
    assert set(SCENARIOS) == {"locked-output", "dob-friction", "light-mass", "saturation", "backlash"}
    for name, sc in SCENARIOS.items():
        assert sc.name == name and sc.duration_s > 0 and sc.human.get("inertia", 0) > 0
    assert SCENARIOS["locked-output"].locked and not SCENARIOS["light-mass"].locked
    assert SCENARIOS["dob-friction"].nonlinear.coulomb_nm > 0 and SCENARIOS["dob-friction"].compare_without_dob
    assert math.isfinite(SCENARIOS["saturation"].nonlinear.saturation_nm)
    assert SCENARIOS["saturation"].push(1.0) == 0.0  # released at 1 s
    assert SCENARIOS["backlash"].nonlinear.backlash_rad > 0 and SCENARIOS["backlash"].theta_h0 > 0
    n = Nonlinearities()
    assert (n.coulomb_nm, n.backlash_rad, n.saturation_nm) == (0.0, 0.0, math.inf)
