"""exotune.model.controller: the filters, the controller blocks (hand-derived), the structures."""

import numpy as np
import pytest

from exotune.model.controller import (STRUCTURES, FirstOrderFilter, Implementation, SecondOrderFilter,
                                      build_controller, first_order_lowpass, second_order_lowpass)
from exotune.model.plant import Plant
from exotune.model.shaping import DesignParams, double_compliance_shaping

PLANT = Plant(0.44, 17.9, 1180.0, 0.29, 300.0)
DESIGN = DesignParams(8.0, 0.25, 1.0, 0.7, 0.7)
S = 1j * np.geomspace(0.5, 5e3, 60)


def test_second_order_lowpass_frequency_response():
    f = SecondOrderFilter(cutoff_hz=50.0, damping=0.3)
    w = 2 * np.pi * 50.0
    ref = w**2 / (S**2 + 2 * 0.3 * w * S + w**2)
    assert np.allclose(second_order_lowpass(f)(S), ref, rtol=1e-12)
    # at the cutoff |F| = 1/(2ζ)
    assert abs(second_order_lowpass(f)(np.array([1j * w]))[0]) == pytest.approx(1 / 0.6, rel=1e-12)


def test_first_order_lowpass_batch():
    f = FirstOrderFilter(cutoff_hz=np.array([10.0, 100.0]))
    r = first_order_lowpass(f)
    w = 2 * np.pi * np.array([10.0, 100.0])
    assert np.allclose(r(np.array([[1j * w[0]], [1j * w[1]]])), [[1 / (1 + 1j)], [1 / (1 + 1j)]], rtol=1e-12)
    assert np.allclose(r(np.array([[0.0], [0.0]])), 1.0)


IMPL = Implementation(delay_s=0.001, gv_filter=SecondOrderFilter(80.0, 0.7), derivative_filter=FirstOrderFilter(200.0),
                      dob=SecondOrderFilter(20.0, 0.7))


def test_default_blocks_by_hand():
    cs, ds = build_controller(PLANT, DESIGN, IMPL)
    g, sh = ds.gains, ds.shape
    assert np.allclose(cs.motor_position(S), -(g.K1 + g.B1 * S), rtol=1e-12)
    assert np.allclose(cs.spring_torque(S), g.K2 + g.B2 * S, rtol=1e-12)
    wv, wd = 2 * np.pi * 80.0, 2 * np.pi * 200.0
    Fv = wv**2 / (S**2 + 1.4 * wv * S + wv**2)
    Fd = wd / (S + wd)
    Gc = (0.44 / ds.J_m_hat) * (1 + (0.29 / 1180.0) * Fv * S * (S**2 + sh.B2_tilde * S + sh.K2_tilde) / (S + sh.B1_tilde)) \
        * (g.K2_hat + g.B2_hat * S * Fd)
    assert np.allclose(cs.cuff_torque(S), Gc, rtol=1e-10)
    wq = 2 * np.pi * 20.0
    assert np.allclose(cs.dob_q(S), wq**2 / (S**2 + 1.4 * wq * S + wq**2), rtol=1e-12)
    assert float(cs.delay_s) == 0.001 and cs.name == "default" and cs.gains == ds.gains
    assert set(cs.blocks()) == {"theta_m", "tau_s", "tau_c"}


def test_full_filter_is_the_filtered_ideal_cuff_path():
    cs, ds = build_controller(PLANT, DESIGN, Implementation(gv_filter=SecondOrderFilter(80.0, 0.7),
                                                             derivative_filter=FirstOrderFilter(200.0),
                                                             structure="full_filter"))
    g, sh = ds.gains, ds.shape
    wv, wd = 2 * np.pi * 80.0, 2 * np.pi * 200.0
    Fv = wv**2 / (S**2 + 1.4 * wv * S + wv**2)
    Fd = wd / (S + wd)
    Gv = (0.44 / ds.J_m_hat) * (1 + (0.29 / 1180.0) * S * (S**2 + sh.B2_tilde * S + sh.K2_tilde) / (S + sh.B1_tilde))
    assert np.allclose(cs.cuff_torque(S), Fv * Fd * Gv * (g.K2_hat + g.B2_hat * S), rtol=1e-10)
    assert cs.dob_q is None


def test_the_structures_agree_when_the_filters_are_far_away():
    far = dict(gv_filter=SecondOrderFilter(1e6, 0.7), derivative_filter=FirstOrderFilter(1e6))
    a, _ = build_controller(PLANT, DESIGN, Implementation(**far))
    b, _ = build_controller(PLANT, DESIGN, Implementation(**far, structure="full_filter"))
    low = 1j * np.geomspace(0.1, 10.0, 10)
    assert np.allclose(a.cuff_torque(low), b.cuff_torque(low), rtol=1e-4)
    # DC gain of the cuff path: (J_m/Ĵ_m)·K̂2
    assert a.cuff_torque(np.array([0.0]))[0].real == pytest.approx(0.44 / 2.0 * 7.0, rel=1e-12)


def test_velocity_filter_replaces_ideal_derivatives():
    impl = Implementation(gv_filter=SecondOrderFilter(80.0), derivative_filter=FirstOrderFilter(200.0),
                          velocity_filter=FirstOrderFilter(30.0))
    cs, ds = build_controller(PLANT, DESIGN, impl)
    g = ds.gains
    w = 2 * np.pi * 30.0
    Fvel = w / (S + w)
    assert np.allclose(cs.motor_position(S), -(g.K1 + g.B1 * S * Fvel), rtol=1e-12)
    assert np.allclose(cs.spring_torque(S), g.K2 + g.B2 * S * Fvel, rtol=1e-12)


def test_errors_name_what_is_missing():
    with pytest.raises(ValueError, match="unknown controller structure 'nope'"):
        build_controller(PLANT, DESIGN, Implementation(gv_filter=SecondOrderFilter(80.0),
                                                        derivative_filter=FirstOrderFilter(200.0), structure="nope"))
    for structure in STRUCTURES:
        with pytest.raises(ValueError, match="implementation.gv_filter and implementation.derivative_filter"):
            build_controller(PLANT, DESIGN, Implementation(structure=structure))


def test_to_control_gives_python_control_blocks():
    cs, _ = build_controller(PLANT, DESIGN, IMPL)
    blocks = cs.to_control()
    assert set(blocks) == {"G_theta", "G_s", "G_c", "Q", "delay_s"}
    assert blocks["delay_s"] == 0.001
    s = 1j * np.array([1.0, 30.0, 400.0])
    for key, mine in [("G_theta", cs.motor_position), ("G_s", cs.spring_torque), ("G_c", cs.cuff_torque),
                      ("Q", cs.dob_q)]:
        assert np.allclose(blocks[key](s), mine(s), rtol=1e-9), key


def test_batched_design_gives_batched_blocks():
    design = DesignParams(np.array([4.0, 8.0]), 0.25, 1.0, 0.7, 0.7)
    impl = Implementation(delay_s=np.array([0.001, 0.002]), gv_filter=SecondOrderFilter(80.0),
                          derivative_filter=FirstOrderFilter(200.0))
    cs, _ = build_controller(PLANT, design, impl)
    one, _ = build_controller(PLANT, DesignParams(4.0, 0.25, 1.0, 0.7, 0.7), impl)
    s = np.array([[5j], [5j]])
    v = cs.cuff_torque(s)
    assert v.shape == (2, 1) and v[0, 0] == pytest.approx(one.cuff_torque(s)[0, 0], rel=1e-12)
    assert not np.isclose(v[0, 0], v[1, 0])
    assert cs.to_control(1)["delay_s"] == 0.002
    assert double_compliance_shaping(PLANT, design).gains.K2_hat.tolist() == [3.0, 7.0]
