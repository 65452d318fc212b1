"""exotune.simulation.fastpath: the runtime read off as a linear system equals stepping the
reference runtime (superposition over random states and inputs), and a fast linear stretch is
the same recursion whichever engine runs it."""

import numpy as np
import pytest

from exotune.controllerfile import Runtime
from exotune.simulation.fastpath import (NP, SIGNALS, LinearLoop, runtime_input_column, runtime_matrices,
                                         runtime_state, set_runtime_state)
from exotune.simulation.plant import JointPlant
from exotune.simulation.scenarios import Nonlinearities

from paper_design import paper_controller


@pytest.fixture(scope="module")
def doc():
    return paper_controller(1000.0, delay_s=0.0015)


def test_state_vector_round_trip(doc):
    rt = Runtime(doc)
    z = np.random.default_rng(0).normal(size=runtime_state(rt).size)
    assert z.size > 0
    set_runtime_state(rt, z)
    assert np.array_equal(runtime_state(rt), z)


def test_matrices_reproduce_the_runtime_step(doc):
    A, B, C, D = runtime_matrices(doc)
    nz = A.shape[0]
    assert B.shape == (nz, len(SIGNALS)) and C.shape == (nz,) and D.shape == (len(SIGNALS),)
    rng = np.random.default_rng(1)
    rt = Runtime(doc)
    for _ in range(5):
        z, y = rng.normal(size=nz), rng.normal(size=len(SIGNALS)) * [0.1, 1.0, 10.0, 100.0, 5.0]
        set_runtime_state(rt, z)
        tau = rt.step(dict(zip(SIGNALS, y)))
        assert tau == pytest.approx(C @ z + D @ y, rel=1e-9, abs=1e-12)
        assert np.allclose(runtime_state(rt), A @ z + B @ y, rtol=1e-9, atol=1e-12)


def test_input_column_is_the_dob_loop_response_to_a_unit_command(doc):
    col = runtime_input_column(doc)
    rt = Runtime(doc)
    for f in rt.loop:
        f.step(1.0)
    assert np.array_equal(col, runtime_state(rt))
    assert np.any(col != 0.0)  # the paper design has a DOB


def test_linear_stretch_is_the_same_recursion_on_both_engines(doc):
    plant = JointPlant({k: v["value"] for k, v in doc["plant"].items()}, {"inertia": 0.5, "damping": 2.0}, False,
                       Nonlinearities())
    loop = LinearLoop(plant, doc, 1e-3, 0.5, 1)
    n = loop.M.shape[0]
    assert n == NP + loop.nz + loop.ns
    w0 = np.zeros(n)
    w0[6] = 1.0  # the constant 1 of the affine mode
    w0[4] = 0.01  # a cuff deflection
    push = np.sin(np.linspace(0.0, 3.0, 200))
    dense = loop.run(w0, push, engine="numpy")
    assert dense.shape == (201, n) and np.array_equal(dense[0], w0)
    assert np.allclose(dense[1], loop.M @ w0 + loop.Npush * push[0], rtol=1e-12, atol=1e-15)
    fast = loop.run(w0, push, engine="numba")
    assert np.allclose(fast, dense, rtol=1e-9, atol=1e-12)
