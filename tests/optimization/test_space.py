"""exotune.optimization.space: unit coordinates of the search space (log or linear per parameter)
map the bounds to 0 and 1 exactly, round-trip, clip, and the archive records every evaluation."""

from __future__ import annotations

import copy
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from exotune.config import load_design
from exotune.optimization.spec import load_optimize_spec
from exotune.optimization.space import Archive, from_unit, to_unit

BASE = copy.deepcopy(load_design(Path(__file__).resolve().parents[2] / "examples" / "paper.yaml").raw)
SPEC = load_optimize_spec({"base": BASE, "objective": "amplification", "budget": 50,
                           "free": {"design.amplification": {"lo": 1.5, "hi": 60.0, "scale": "log"},
                                    "design.zeta_hat": {"lo": 0.3, "hi": 1.2, "scale": "lin"}}})
LO = np.array([1.5, 0.3])
HI = np.array([60.0, 1.2])


def test_bounds_map_to_the_unit_cube_exactly():
    np.testing.assert_array_equal(to_unit(SPEC, np.array([LO, HI])), [[0.0, 0.0], [1.0, 1.0]])
    np.testing.assert_array_equal(from_unit(SPEC, np.array([[0.0, 0.0], [1.0, 1.0]])), [LO, HI])


def test_log_and_linear_midpoints():
    X = from_unit(SPEC, np.array([[0.5, 0.5]]))[0]
    assert X[0] == pytest.approx(math.sqrt(1.5 * 60.0), rel=1e-12)  # geometric mean
    assert X[1] == pytest.approx(0.75, rel=1e-12)  # arithmetic mean


def test_unit_coordinates_are_clipped():
    X = from_unit(SPEC, np.array([[-0.5, 2.0], [1.5, -1.0]]))
    np.testing.assert_array_equal(X, [[1.5, 1.2], [60.0, 0.3]])


@settings(max_examples=50, deadline=None)
@given(u=st.lists(st.floats(0.0, 1.0), min_size=2, max_size=2))
def test_round_trip_from_unit(u):
    U = np.array([u])
    X = from_unit(SPEC, U)
    assert np.all(X >= LO) and np.all(X <= HI)
    np.testing.assert_allclose(to_unit(SPEC, X), U, rtol=1e-9, atol=1e-12)


@settings(max_examples=50, deadline=None)
@given(a=st.floats(1.5, 60.0), z=st.floats(0.3, 1.2))
def test_round_trip_to_unit(a, z):
    X = np.array([[a, z]])
    U = to_unit(SPEC, X)
    assert np.all(U >= -1e-12) and np.all(U <= 1 + 1e-12)
    np.testing.assert_allclose(from_unit(SPEC, U), X, rtol=1e-9)


@settings(max_examples=30, deadline=None)
@given(u=st.floats(0.0, 1.0), v=st.floats(0.0, 1.0))
def test_the_map_is_monotone_per_axis(u, v):
    lo, hi = min(u, v), max(u, v)
    X = from_unit(SPEC, np.array([[lo, lo], [hi, hi]]))
    assert np.all(X[0] <= X[1])


def test_the_archive_records_every_evaluation_with_its_verdicts():
    ar = Archive(SPEC)
    U = np.array([[0.1, 0.5], [0.9, 0.5]])
    ev = ar.evaluate(U)
    assert ev["X"].shape == (2, 2)
    np.testing.assert_allclose(ev["X"], from_unit(SPEC, U), rtol=1e-12)
    assert ev["feasible"].dtype == bool and ev["violation"].shape == (2,)
    np.testing.assert_array_equal(ev["feasible"], ev["violation"] == 0)
    # the objective is α itself (maximized)
    np.testing.assert_allclose(ev["objective"], ev["X"][:, 0], rtol=1e-12)
