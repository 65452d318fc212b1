"""exotune.controllerfile.continuation: stable intervals of a one-parameter family by eigenvalue
continuation. On families whose spectral radius is known in closed form, the interval ends are the
roots of ρ(v) = 1 (to the bisection's 1e-10 relative), a narrow window of instability between two
grid values is found, and a family stable over its whole range gives the whole range."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from exotune.controllerfile.continuation import EDGE_SLIVER, POINTS, stable_intervals


def _pair(r: float, th: float = 0.7) -> np.ndarray:
    return np.array([r * np.exp(1j * th), r * np.exp(-1j * th), 0.3])


@settings(max_examples=15, deadline=None)
@given(st.floats(0.8, 3.0))
def test_the_end_is_the_root_of_the_spectral_radius(c):
    """ρ(v) = v / c: stable exactly for v < c on [0.5, 4]."""
    ivs, info = stable_intervals(lambda v: _pair(v / c), 0.5, 4.0)
    assert len(ivs) == 1
    a, b = ivs[0]
    assert a == pytest.approx(0.5, rel=1e-12)
    assert b == pytest.approx(c, rel=1e-9)
    assert info["points"] == POINTS and not info["unresolved"]


def test_a_window_of_instability_is_cut_out_at_its_roots():
    """ρ(v) = 0.5 + 0.6·exp(−(ln(v/1.5)/w)²): unstable where the bump exceeds 0.5, i.e.
    |ln(v/1.5)| < w·sqrt(ln 1.2); with w = 0.2 the window is ≈ 17 % wide (a few grid cells).
    (A window narrower than a cell is step control's blind spot; the cell proof finds it:
    tests/controllerfile/test_certify_rigorous.py.)"""
    w = 0.2
    rho = lambda v: 0.5 + 0.6 * math.exp(-((math.log(v / 1.5) / w) ** 2))  # noqa: E731
    ivs, info = stable_intervals(lambda v: _pair(rho(v)), 0.2, 20.0)
    half = w * math.sqrt(math.log(1.2))
    lo, hi = 1.5 * math.exp(-half), 1.5 * math.exp(half)
    assert len(ivs) == 2
    assert ivs[0][0] == pytest.approx(0.2, rel=1e-12) and ivs[1][1] == pytest.approx(20.0, rel=1e-12)
    assert ivs[0][1] == pytest.approx(lo, rel=1e-8)
    assert ivs[1][0] == pytest.approx(hi, rel=1e-8)


def test_a_stable_family_is_stable_over_its_range():
    ivs, _ = stable_intervals(lambda v: _pair(0.9 - 0.5 / (1 + v)), 0.1, 10.0)
    assert ivs == [[pytest.approx(0.1), pytest.approx(10.0)]]


def test_an_unstable_family_has_no_interval():
    ivs, _ = stable_intervals(lambda v: _pair(1.2 + 0.1 * v), 0.1, 10.0)
    assert ivs == []


def test_batched_spectra_give_the_same_result():
    f = lambda v: _pair(v / 2.0)  # noqa: E731
    one, _ = stable_intervals(f, 0.5, 4.0)
    many, _ = stable_intervals(f, 0.5, 4.0, spectra=lambda vs: [f(v) for v in vs])
    assert np.allclose(one, many, rtol=1e-12)


def test_a_cell_bound_that_refuses_leaves_cells_unproven():
    """With a cell bound that never proves, no stable cell is accepted on step control alone."""
    ivs, info = stable_intervals(lambda v: _pair(0.5), 1.0, 2.0, points=8, cell_bound=lambda a, b: (False, -1.0))
    assert info["proof"] == "cell bound"
    assert ivs == [] or info["unresolved"]
    ok, info2 = stable_intervals(lambda v: _pair(0.5), 1.0, 2.0, points=8, cell_bound=lambda a, b: (True, 0.5))
    assert ok == [[pytest.approx(1.0), pytest.approx(2.0)]] and info2["proven_cells"] >= 1


def test_unresolved_cells_are_listed_up_to_a_cap_and_counted():
    """A family whose eigenvalue sits on the unit circle's edge everywhere leaves every cell
    unresolved: the info lists the first MAX_LISTED of them and counts all (an exported controller
    file must stay within the size certify reads)."""
    from exotune.controllerfile.continuation import MAX_LISTED

    # |λ| = 1 − 1e-9 over the whole range, moving fast along the circle: no cell resolves
    ivs, info = stable_intervals(lambda v: np.array([(1 - 1e-9) * np.exp(1j * 40.0 * v)]), 1.0, 2.0, points=48)
    assert info["unresolved_cells"] > MAX_LISTED
    assert len(info["unresolved"]) == MAX_LISTED
    assert info["unresolved"] == sorted(info["unresolved"])


def _windows_family(windows, edge):
    """One eigenvalue, 0.5 (stable) except 1.5 inside the open windows (c, c + w) and for v ≥ ``edge``;
    the cell bound is an honest oracle (proven exactly when the cell holds no unstable member)."""
    def unstable(v):
        return any(c < v < c + w for c, w in windows) or (edge is not None and v >= edge)

    def cell_bound(a, b):
        return (not any(a < c + w and b > c for c, w in windows) and (edge is None or b < edge), 0.5)

    return unstable, (lambda v: np.array([1.5 if unstable(v) else 0.5])), cell_bound


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.floats(1.0, 4.9), st.floats(1e-4, 0.3)), max_size=4),
       st.one_of(st.none(), st.floats(1.2, 4.9)), st.integers(2, 12), st.sampled_from([0.0, 1.0]))
def test_no_unstable_member_inside_a_reported_interval(windows, edge, points, lo):
    """Soundness with an honest cell proof, whatever the grid: every unstable member inside a
    reported stable interval lies in a listed unresolved cell or within EDGE_SLIVER (relative)
    of the interval's end — windows between a stable grid value and an interval end included
    (the stable side of every end is checked; docs/controller-file.md#certification); on a
    log-spaced grid (lo > 0) and a linear one (lo = 0)."""
    unstable, spectrum, cell_bound = _windows_family(windows, edge)
    ivs, info = stable_intervals(spectrum, lo, 5.0, points=points, cell_bound=cell_bound)
    assert info["unresolved_cells"] <= len(info["unresolved"])  # (never capped here) all listed
    probes = [c + f * w for c, w in windows for f in (1e-3, 0.5, 1 - 1e-3)] + list(np.linspace(lo, 5.0, 4001))
    for v in (v for v in probes if unstable(v)):
        for a, b in ivs:
            if a <= v <= b:
                near_end = min(v - a, b - v) <= EDGE_SLIVER * v
                in_cell = any(x <= v <= y for x, y in info["unresolved"])
                assert near_end or in_cell, (v, ivs, info["unresolved"])


def test_a_window_between_a_grid_value_and_an_interval_end_is_found():
    """The grid [1, √2, 2] sees stable, stable, unstable; the end bisected in [√2, 2] is 1.9 and
    the window (1.45, 1.47) lies between √2 and it: the march over the end's stable side finds
    it, and the interval ends at the window (the stable part beyond it is not claimed)."""
    _, spectrum, cell_bound = _windows_family([(1.45, 0.02)], 1.9)
    ivs, info = stable_intervals(spectrum, 1.0, 2.0, points=3, cell_bound=cell_bound)
    assert len(ivs) == 1 and ivs[0][0] == 1.0 and ivs[0][1] == pytest.approx(1.45, rel=1e-9)
    assert info["edge_cells"] > 0 and not info["unresolved"]


def test_an_end_whose_side_is_not_checked_ends_where_the_check_ended(monkeypatch):
    """With no march budget left, the stable side of the end (between √2 and the end 1.9) is
    not claimed: the interval ends at the last accepted value, √2, and the side is an
    unresolved cell."""
    import exotune.controllerfile.continuation as cont

    monkeypatch.setattr(cont, "MARCH_STEPS", 0)
    _, spectrum, cell_bound = _windows_family([], 1.9)
    ivs, info = stable_intervals(spectrum, 1.0, 2.0, points=3, cell_bound=cell_bound)
    assert ivs == [[1.0, pytest.approx(math.sqrt(2.0), rel=1e-15)]]
    assert len(info["unresolved"]) == 1 and info["unresolved"][0][0] == pytest.approx(math.sqrt(2.0))
    assert info["unresolved"][0][1] == pytest.approx(1.9, rel=1e-9)
