"""exotune.model.humans: the human/environment families, their box edges and the linear split
Z(s) = Z0(s) + p φ(s)."""

import itertools

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from exotune.model.humans import EnvModel, HumanFamily, family_split


def _z(kind, params, eta=0.0, w=3.0):
    """Z(jω) of a human by the module docstring's table (independent of family_split)."""
    s = 1j * w
    m, b, k = params.get("inertia", 0.0), params.get("damping", 0.0), params.get("stiffness", 0.0)
    return {"spring": k + b * s, "mass": m * s * s + b * s, "msd": m * s * s + b * s + k,
            "complex_stiffness": k * (1 + 1j * eta) + b * s}[kind]


CASES = [("spring", "stiffness"), ("mass", "inertia"), ("msd", "inertia"), ("msd", "damping"), ("msd", "stiffness"),
         ("complex_stiffness", "stiffness")]


@pytest.mark.parametrize("kind, param", CASES)
@given(p=st.floats(0.0, 1e3), m=st.floats(0.0, 10.0), b=st.floats(0.0, 50.0), k=st.floats(0.0, 1e3))
def test_family_split_is_linear_in_the_ranged_parameter(kind, param, p, m, b, k):
    fixed = {"inertia": m, "damping": b, "stiffness": k}
    z0, phi, factor = family_split(kind, param, fixed, eta=0.2)
    assert phi.tolist().count(1.0) == 1 and phi.sum() == 1.0
    w = 3.0
    s = 1j * w
    powers = np.array([1.0, s, s * s])
    z = z0 @ powers + p * factor * (phi @ powers)
    params = {**fixed, param: p}
    assert z == pytest.approx(_z(kind, params, eta=0.2, w=w), rel=1e-12, abs=1e-9)


def test_family_split_ignores_parameters_the_kind_has_not():
    z0, phi, factor = family_split("spring", "stiffness", {"inertia": 5.0, "damping": 2.0, "stiffness": 9.0})
    assert z0.tolist() == [0.0, 2.0, 0.0] and phi.tolist() == [1.0, 0.0, 0.0] and factor == 1.0
    z0, _, _ = family_split("mass", "inertia", {"inertia": 5.0, "damping": 2.0, "stiffness": 9.0})
    assert z0.tolist() == [0.0, 2.0, 0.0]
    _, _, f = family_split("complex_stiffness", "stiffness", {}, eta=0.3)
    assert f == 1 + 0.3j


def test_human_family_properties():
    h = HumanFamily("msd", "stiffness", 10.0, 500.0, inertia=0.1, damping=2.0)
    assert h.range == (10.0, 500.0) and h.unit == "N·m/rad"
    assert h.fixed() == {"inertia": 0.1, "damping": 2.0, "stiffness": 0.0}
    assert h.edges() == [h]
    assert HumanFamily("mass", "inertia", 0.0, 1.0).unit == "kg·m²"


def test_box_edges_are_every_edge_of_the_box_once():
    h = HumanFamily("msd", "stiffness", 10.0, 500.0, inertia=0.1, damping=2.0,
                    box=(("inertia", 0.05, 0.2), ("damping", 1.0, 3.0)))
    edges = h.edges()
    assert len(edges) == 3 * 4  # a 3-D box: 3 directions × 4 corners of the other two
    ranges = {"stiffness": (10.0, 500.0), "inertia": (0.05, 0.2), "damping": (1.0, 3.0)}
    corners = set(itertools.product(*ranges.values()))
    seen = set()
    for e in edges:
        assert e.box == () and e.kind == "msd" and e.range == ranges[e.param]
        for end in e.range:
            vals = {**e.fixed(), e.param: end}
            assert tuple(vals[q] for q in ranges) in corners  # each end is a corner of the box
        seen.add((e.param, tuple(sorted(e.fixed().items()))))
    assert len(seen) == 12


def test_env_model_defaults():
    assert EnvModel("locked") == EnvModel("locked", None, None, None, 0.0)
    e = EnvModel("spring", "stiffness", 100.0, 1e4)
    assert (e.kind, e.param, e.lo, e.hi) == ("spring", "stiffness", 100.0, 1e4)
    with pytest.raises(Exception):
        e.lo = 0.0  # frozen
