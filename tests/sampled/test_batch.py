"""exotune.sampled.batch: the batched sampled-data loops against the point-wise model of
exotune.sampled.loop (same spectral radii up to rounding), and expm_stack against scipy."""

import copy
from dataclasses import replace

import numpy as np
import pytest
import scipy.linalg

from exotune.config import batch_config, design_from_mapping
from exotune.model.controller import build_controller
from exotune.sampled.loop import default_prewarp, discretize, loop_eigenvalues, sampled_verdict
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


@pytest.mark.parametrize("delay", [0.0, 0.001, 0.0013])
@pytest.mark.parametrize("human, env, loop, v", [
    (None, "free", Loop("free"), None),
    (None, "locked", Loop("locked", env="locked"), None),
    ({"inertia": 0.02, "damping": 0.0}, "free", Loop("h", human={"damping": 0.0}, param="inertia"), 0.02),
    (None, {"stiffness": 400.0, "damping": 1.0}, Loop("e", env_param="stiffness", env_damping=1.0), 400.0),
])
def test_a_batch_of_one_given_controller_has_its_loop_eigenvalues(delay, human, env, loop, v):
    """BatchLoops.of_controller (the latency margin of a controller file): the spectra of
    loop_eigenvalues on the same plant and discrete controller, whole and fractional delays, the
    rigid-body eigenvalue set aside as it does (no position feedback declared here)."""
    cfg = paper_design(sample_rate_hz=FS)
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    ctrl = replace(discretize(cs, cfg.plant, FS, default_prewarp(cfg.implementation)), delay_s=delay)
    for grounded in (True, False):
        bl = BatchLoops.of_controller(cfg.plant, ctrl, grounded)
        assert bl.n == 1 and bl.delay.tolist() == [delay] and bl.Ts == 1.0 / FS
        rho, eig, _st = bl.spectra(np.array([0]), loop, None if v is None else np.array([v]), rounding=False)
        want = loop_eigenvalues(cfg.plant, ctrl, grounded, human, env)
        assert rho[0] == pytest.approx(np.max(np.abs(want)), rel=1e-9)
        got, want = eig[0][np.abs(eig[0]) > 1e-6], want[np.abs(want) > 1e-6]  # the unread command's 0 aside
        assert got.size == want.size  # the same spectrum (repeated DOB poles: to rounding's ε^(1/3))
        assert np.max(np.min(np.abs(got[:, None] - want[None, :]), axis=1)) < 1e-6
        assert np.max(np.min(np.abs(want[:, None] - got[None, :]), axis=1)) < 1e-6


@pytest.mark.parametrize("engine", ["compiled", "numpy"])
def test_verdicts_within_the_rounding_band_are_certifys(batch, engine):
    """Loops whose spectral radius lies within 1e-6 of 1 (on both sides of a latency boundary of
    the locked loop) are decided by the rounding estimate as the point-wise spectral_verdict decides
    them (inconclusive is not stable) — on both engines, the early stop of the estimate included —
    except that within 1e-12 of 1 the zero-order hold's rounding (expm_rounding, which
    spectral_verdict on a bare matrix cannot know) may only turn "stable" into "not stable"."""
    from contextlib import nullcontext

    from exotune.numerics.engine import numpy_engine
    from exotune.sampled.loop import spectral_verdict

    bl = BatchLoops(batch[1], FS)
    loop = Loop("locked", env="locked")
    des = np.array([0])
    with numpy_engine() if engine == "numpy" else nullcontext():
        lo, hi = 0.0, 0.05
        assert bl.spectra(des, loop, delay=bl.delay[des] + hi)[0][0] > 1.0
        for _ in range(80):  # the extra delay where the locked loop's radius crosses 1
            mid = 0.5 * (lo + hi)
            if bl.spectra(des, loop, delay=bl.delay[des] + mid, rounding=False)[0][0] < 1.0:
                lo = mid
            else:
                hi = mid
        slope = (bl.spectra(des, loop, delay=bl.delay[des] + hi * 1.001, rounding=False)[0][0] - 1.0) / (hi * 1e-3)
        offsets = np.array([-5e-7, -5e-9, -1e-12, 0.0, 1e-12, 5e-9, 5e-7]) / slope
        delays = bl.delay[0] + hi + offsets
        rho, _eig, stable = bl.spectra(np.zeros(offsets.size, np.int64), loop, delay=delays)
        assert np.all(np.abs(rho - 1.0) < 1e-6)
        assert (rho < 1.0).any() and (rho > 1.0).any()
        ((_pos, M),) = bl.matrices(np.zeros(offsets.size, np.int64), loop, np.zeros(offsets.size), delays)
        want = [spectral_verdict(m)[0] is True for m in M]
    clear = np.abs(offsets) > 1e-9 / slope
    assert stable[clear].tolist() == np.asarray(want)[clear].tolist(), (rho - 1.0, stable)
    assert not (stable & ~np.asarray(want)).any(), (rho - 1.0, stable)
    assert any(want) and not all(want)
    assert not stable[rho >= 1.0].any()
