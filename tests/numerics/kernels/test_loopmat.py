"""exotune.numerics.kernels.loopmat: the compiled assembly of the sampled-data loop matrices equals
the numpy reference (BatchLoops.matrices on the numpy engine) on every delay split, loop kind and
controller of a batch, and a hypothesis property over random blocks checks the block structure."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from exotune.config import batch_config
from exotune.numerics.engine import numpy_engine
from exotune.numerics.kernels.common import AVAILABLE
from exotune.sampled.batch import BatchLoops, Loop

from paper_design import paper_design

pytestmark = pytest.mark.skipif(not AVAILABLE, reason="numba is not installed")

FS = 1000.0


@pytest.fixture(scope="module")
def loops():
    cfg = paper_design(sample_rate_hz=FS)
    amps = np.array([2.0, 8.0, 15.0, 30.0])
    delays = np.array([0.0, 0.0005, 0.001, 0.0023])
    return BatchLoops(batch_config(cfg, {"design.amplification": amps, "implementation.delay_s": delays}), FS)


@pytest.mark.parametrize("loop, v", [
    (Loop("free"), None),
    (Loop("locked", env="locked"), None),
    (Loop("h", human={"damping": 0.0}, param="inertia"), 0.004),
    (Loop("h", human={"inertia": 0.0, "damping": 2.0}, param="stiffness"), 800.0),
    (Loop("e", env_param="stiffness", env_damping=1.0), 400.0),
])
@pytest.mark.parametrize("extra", [0.0, 0.0004, 0.002, 0.0037])
def test_compiled_assembly_equals_numpy(loops, loop, v, extra):
    des = np.repeat(np.arange(loops.n), 2)
    vals = None if v is None else np.full(des.size, v) * np.tile([1.0, 3.0], loops.n)
    vals = np.zeros(des.size) if vals is None else vals
    delay = loops.delay[des] + extra
    fast = loops.matrices(des, loop, vals, delay)
    with numpy_engine():
        ref = loops.matrices(des, loop, vals, delay)
    assert len(fast) == len(ref) > 0
    for (pf, Mf), (pr, Mr) in zip(fast, ref):
        assert pf.tolist() == pr.tolist()
        assert Mf.shape == Mr.shape
        scale = np.max(np.abs(Mr), axis=(1, 2), keepdims=True)
        assert np.all(np.abs(Mf - Mr) <= 1e-13 * scale)


@settings(max_examples=40, deadline=None)
@given(n=st.integers(1, 6), nz=st.integers(0, 5), d=st.integers(0, 3), frac=st.booleans(), seed=st.integers(0, 2**31))
def test_block_structure(n, nz, d, frac, seed):
    from exotune.numerics.kernels.loopmat import assemble_stack

    rng = np.random.default_rng(seed)
    k, m, D = 3, 5, 2
    Phi, G0, G1 = rng.normal(size=(k, n, n)), rng.normal(size=(k, n)), rng.normal(size=(k, n))
    C = rng.normal(size=(k, m, n))
    des = rng.integers(0, D, k)
    Ac, Bc = rng.normal(size=(D, nz + 1, nz + 1)), rng.normal(size=(D, nz + 1, m))
    Cc, Dc = rng.normal(size=(D, nz + 1)), rng.normal(size=(D, m))
    M = assemble_stack(Phi, G0, G1, C, des, Ac, Bc, Cc, Dc, nz, d, frac)
    s0, ns = n + nz, d + int(frac)
    assert M.shape == (k, s0 + ns, s0 + ns)
    for t in range(k):
        g = des[t]
        u = np.concatenate([Dc[g] @ C[t], Cc[g, :nz], np.zeros(ns)])
        rows = np.zeros((n, s0 + ns))
        rows[:, :n] = Phi[t]
        if d == 0:
            rows += np.outer(G0[t], u)
        else:
            rows[:, s0 + d - 1] += G0[t]
        if frac:
            rows[:, s0 + d] += G1[t]
        np.testing.assert_allclose(M[t, :n], rows, rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(M[t, n:s0, :n], Bc[g, :nz] @ C[t], rtol=1e-13, atol=1e-13)
        assert np.array_equal(M[t, n:s0, n:s0], Ac[g, :nz, :nz])
        assert not M[t, n:s0, s0:].any()
        if ns:
            np.testing.assert_allclose(M[t, s0], u, rtol=1e-13, atol=1e-13)
            assert np.array_equal(M[t, s0 + 1:, s0:-1], np.eye(ns - 1))
            assert not M[t, s0 + 1:, :s0].any() and not M[t, s0 + 1:, -1].any()
