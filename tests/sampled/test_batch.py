"""exotune.sampled.batch: the batched sampled-data loops against the point-wise model of
exotune.sampled.loop (same spectral radii up to rounding), and expm_stack against scipy."""

import copy

import numpy as np
import pytest
import scipy.linalg

from exotune.config import batch_config, design_from_mapping
from exotune.model.controller import build_controller
from exotune.sampled.loop import default_prewarp, sampled_verdict
from exotune.sampled.batch import BatchLoops, Loop, expm_stack

from paper_design import paper_design

FS = 1000.0


def test_expm_stack_equals_scipy():
    rng = np.random.default_rng(0)
    M = rng.normal(size=(6, 5, 5)) * np.array([1e-3, 0.1, 1.0, 5.0, 30.0, 200.0])[:, None, None]
    E = expm_stack(M)
    for k in range(M.shape[0]):
        assert np.allclose(E[k], scipy.linalg.expm(M[k]), rtol=1e-10, atol=1e-12 * np.abs(E[k]).max())
    assert expm_stack(np.zeros((0, 3, 3))).shape == (0, 3, 3)


def test_loop_structure_and_grounding():
    v = np.array([0.0, 2.0])
    assert Loop("free").structure() == (False, False)
    assert Loop("h", human={"inertia": 0.0, "damping": 1.0}, param="stiffness").structure() == (False, True)
    assert Loop("h", human={"damping": 0.0}, param="inertia").structure() == (True, False)
    assert Loop("locked", env="locked").grounded(v).tolist() == [True, True]
    assert Loop("h", human={}, param="stiffness").grounded(v).tolist() == [False, True]
    assert Loop("h", human={"stiffness": 5.0}, param="inertia").grounded(v).tolist() == [True, True]
    assert Loop("e", env_param="stiffness").grounded(v).tolist() == [False, True]
    assert Loop("e", env_param="inertia").grounded(v).tolist() == [False, False]


@pytest.fixture(scope="module")
def batch():
    cfg = paper_design(sample_rate_hz=FS)
    amps, delays = np.array([2.0, 8.0, 15.0]), np.array([0.0005, 0.001, 0.0023])
    return cfg, batch_config(cfg, {"design.amplification": amps, "implementation.delay_s": delays}), amps, delays


def _pointwise(cfg, amp, delay, human=None, env="free"):
    raw = copy.deepcopy(cfg.raw)
    raw["design"]["amplification"] = float(amp)
    raw["implementation"]["delay_s"] = float(delay)
    c = design_from_mapping(raw)
    cs, _ = build_controller(c.plant, c.design, c.implementation)
    return sampled_verdict(c.plant, cs, FS, human, env, prewarp=default_prewarp(c.implementation))


@pytest.mark.parametrize("loop, v, human, env", [
    (Loop("free"), None, None, "free"),
    (Loop("locked", env="locked"), None, None, "locked"),
    (Loop("h", human={"damping": 0.0}, param="inertia"), 0.004, {"inertia": 0.004, "damping": 0.0}, "free"),
    (Loop("h", human={"damping": 0.0}, param="stiffness"), 3000.0, {"stiffness": 3000.0, "damping": 0.0}, "free"),
])
def test_spectral_radii_equal_the_pointwise_loops(batch, loop, v, human, env):
    cfg, b, amps, delays = batch
    bl = BatchLoops(b, FS)
    assert bl.n == 3
    des = np.arange(3)
    rho, eig, stable = bl.spectra(des, loop, None if v is None else np.full(3, v))
    for i in range(3):
        ok, rho_i, _ = _pointwise(cfg, amps[i], delays[i], human, env)
        assert rho[i] == pytest.approx(rho_i, rel=1e-8), i
        assert stable[i] == bool(ok)
        assert np.max(np.abs(eig[i])) <= rho[i] * (1 + 1e-12)


def test_split_delay_in_whole_samples_and_a_fraction(batch):
    bl = BatchLoops(batch[1], FS)
    d, f = bl.split_delay(np.array([0.0005, 0.001, 0.0023]))
    assert d.tolist() == [0, 1, 2]
    assert np.allclose(f, [0.5, 0.0, 0.3])
