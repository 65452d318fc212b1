"""exotune.simulation.plant: the physical joint — its affine modes against the nonlinear equations,
exact intervals against scipy's integrator, the dead zone and friction, the measured signals."""

import numpy as np
import pytest
import scipy.integrate

from exotune.simulation.plant import FRICTION_LINEAR, MIN_HUMAN_INERTIA, JointPlant
from exotune.simulation.scenarios import Nonlinearities

PLANT = {"motor_inertia": 0.44, "motor_damping": 17.9, "sea_stiffness": 1180.0, "joint_inertia": 0.29,
         "cuff_stiffness": 300.0}
HUMAN = {"inertia": 0.5, "damping": 2.0, "stiffness": 30.0}


def _rand_states(rng, k=5):
    return rng.normal(size=(k, 6)) * [0.01, 1.0, 0.01, 1.0, 0.01, 1.0]


@pytest.mark.parametrize("locked", [False, True])
@pytest.mark.parametrize("nl", [Nonlinearities(), Nonlinearities(coulomb_nm=2.0), Nonlinearities(backlash_rad=0.004)])
def test_affine_mode_equals_the_nonlinear_equations_inside_the_mode(locked, nl):
    p = JointPlant(PLANT, HUMAN, locked, nl)
    rng = np.random.default_rng(0)
    for x in _rand_states(rng, 20):
        if locked:
            x[2] = x[3] = 0.0
        mode = p.mode(x)
        if mode is None:
            continue  # friction near zero velocity: not affine
        A, B = p.affine(mode)
        u = np.array([3.0, -1.0, 1.0])
        assert np.allclose(A @ x + B @ u, p.deriv(x, 3.0, -1.0), rtol=1e-12, atol=1e-9), (mode, x)


def test_an_exact_interval_equals_a_fine_integration():
    p = JointPlant(PLANT, HUMAN, False, Nonlinearities())
    x0 = np.array([0.01, 0.0, -0.005, 0.2, 0.02, 0.0])
    y = p.advance(x0, 5.0, -2.0, 0.01)
    ref = scipy.integrate.solve_ivp(lambda _t, z: p.deriv(z, 5.0, -2.0), (0, 0.01), x0, method="DOP853",
                                    rtol=1e-12, atol=1e-14).y[:, -1]
    assert np.allclose(y, ref, rtol=1e-9, atol=1e-12)
    assert p.nonlinear_intervals == 0
    assert p.advance(x0, 5.0, -2.0, 0.0) is x0


def test_leaving_a_mode_integrates_the_nonlinear_equations():
    p = JointPlant(PLANT, HUMAN, True, Nonlinearities(coulomb_nm=2.0))
    x0 = np.array([0.0, 0.5 * FRICTION_LINEAR * p.eps, 0.0, 0.0, 0.0, 0.0])  # slow: friction not saturated
    assert p.mode(x0) is None
    y = p.advance(x0, 0.0, 0.0, 0.001)
    ref = scipy.integrate.solve_ivp(lambda _t, z: p.deriv(z, 0.0, 0.0), (0, 0.001), x0, method="Radau",
                                    rtol=1e-10, atol=1e-14).y[:, -1]
    assert p.nonlinear_intervals == 1
    assert np.allclose(y, ref, rtol=1e-6, atol=1e-10)


def test_signals_with_backlash_and_friction():
    p = JointPlant(PLANT, HUMAN, False, Nonlinearities(coulomb_nm=2.0, backlash_rad=0.004))
    x = np.array([0.0, 1.0, 0.003, 0.5, 0.01, 0.0])  # deflection 3 mm-rad: beyond the 2 mrad half gap
    assert p.region(x) == 1 and p.tau_s(x) == pytest.approx(1180.0 * 0.001)
    assert p.dtau_s(x) == pytest.approx(1180.0 * (0.5 - 1.0))
    gap = x.copy()
    gap[2] = 0.001
    assert p.region(gap) == 0 and p.tau_s(gap) == 0.0 and p.dtau_s(gap) == 0.0
    assert p.tau_c(x) == pytest.approx(300.0 * (0.01 - 0.003))
    assert p.friction(x) == pytest.approx(2.0 * np.tanh(1.0 / p.eps))
    m = p.measure(x)
    assert set(m) == {"theta_m", "omega_m", "tau_s", "dtau_s", "tau_c"} and m["omega_m"] == 1.0
    assert p.in_mode(np.array([x, gap]), (1, 1)).tolist() == [True, False]


def test_a_locked_output_and_the_human_limit():
    p = JointPlant(PLANT, HUMAN, True, Nonlinearities())
    x = np.array([0.01, 0.0, 0.5, 0.5, 0.02, 0.0])  # θ_j ignored when locked
    assert p.deflection(x) == -0.01 and p.tau_c(x) == pytest.approx(300.0 * 0.02)
    with pytest.raises(ValueError, match="finite inertia"):
        JointPlant(PLANT, {"inertia": MIN_HUMAN_INERTIA / 10}, False, Nonlinearities())
