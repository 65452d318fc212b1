"""loop_spectra (stacked matrix exponentials and eigenvalue problems) against the point-wise
loop_eigenvalues, and certify's family intervals with and without the batched base grid."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from exotune.config import load_design
from exotune.controllerfile import continuation
from exotune.model.controller import build_controller
from exotune.sampled import discretize, loop_eigenvalues, loop_spectra

EXAMPLE = "examples/paper.yaml"


def _loop(delay_s: float, rate: float):
    import dataclasses

    cfg = load_design(EXAMPLE)
    impl = dataclasses.replace(cfg.implementation, delay_s=delay_s)
    cs, _ = build_controller(cfg.plant, cfg.design, impl)
    return cfg.plant, discretize(cs, cfg.plant, rate)


@settings(max_examples=15, deadline=None)
@given(delay_samples=st.sampled_from([0.0, 0.37, 1.0, 2.5]),
       members=st.lists(st.floats(1e-4, 5.0), min_size=1, max_size=6))
def test_loop_spectra_is_bitwise_the_pointwise_spectrum(delay_samples, members):
    """Human inertias (one state structure), a stiffness without mass (another), and the cuff
    free, in one call: each result equals loop_eigenvalues exactly (same exponential, same LAPACK
    call per matrix); the rigid-body eigenvalue is dropped where nothing grounds the loop."""
    rate = 1000.0
    plant, ctrl = _loop(delay_samples / rate, rate)
    humans = [{"inertia": m, "damping": 0.5} for m in members] + [{"stiffness": 40.0 * members[0]}, None]
    got = loop_spectra(plant, ctrl, False, humans)
    for h, lam in zip(humans, got):
        ref = loop_eigenvalues(plant, ctrl, False, h)
        assert np.array_equal(lam, ref)


def test_loop_spectra_environment_list():
    plant, ctrl = _loop(0.001, 1000.0)
    envs = [{"stiffness": k, "damping": 1.0} for k in (10.0, 300.0, 5000.0)]
    got = loop_spectra(plant, ctrl, True, [None] * 3, envs)
    for e, lam in zip(envs, got):
        assert np.array_equal(lam, loop_eigenvalues(plant, ctrl, True, None, e))


@pytest.mark.parametrize("lo, hi", [(1e-3, 2.0), (0.0, 400.0)])
def test_stable_intervals_same_with_batched_base_grid(lo, hi):
    """The prefetched base grid and derivative steps change nothing in the intervals or the
    search's record (log-spaced and linear grids)."""
    plant, ctrl = _loop(0.0017, 1000.0)
    key = "inertia" if lo > 0 else "stiffness"

    def one(v):
        return loop_eigenvalues(plant, ctrl, False, {key: v, "damping": 0.5})

    calls = []

    def many(vs):
        calls.append(len(vs))
        return loop_spectra(plant, ctrl, False, [{key: v, "damping": 0.5} for v in vs])

    a = continuation.stable_intervals(one, lo, hi, 48)
    b = continuation.stable_intervals(one, lo, hi, 48, spectra=many)
    assert a == b
    assert calls == [96]
