"""exotune.units: the table of units, path_unit and fmt_num."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from exotune import units
from exotune.units import fmt_distinct, fmt_num, path_unit


@pytest.mark.parametrize("path, unit", [
    ("plant.motor_inertia", "kg·m²"),
    ("plant.sea_stiffness", "N·m/rad"),
    ("design.felt_damping", "N·m·s/rad"),
    ("design.amplification", "1"),
    ("implementation.delay_s", "s"),
    ("implementation.sample_rate_hz", "Hz"),
    ("implementation.gv_filter.cutoff_hz", "Hz"),
    ("implementation.dob.damping", "1"),
])
def test_path_unit(path, unit):
    assert path_unit(path) == unit


def test_dimensionless_is_written_as_asked():
    assert path_unit("design.zeta", "–") == "–"
    assert path_unit("plant.cuff_stiffness", "–") == "N·m/rad"  # only "1" is replaced


@pytest.mark.parametrize("path", ["humans.inertia", "plant.nothing", "implementation.gv_filter.order", "plant"])
def test_unknown_path_raises_key_error(path):
    with pytest.raises(KeyError):
        path_unit(path)


def test_every_unit_is_si_text():
    """Every table maps a name to a non-empty unit; torque gains and deflection gains agree on K1/B1."""
    tables = [getattr(units, n) for n in units.__all__ if n.endswith("_UNITS")]
    assert len(tables) >= 10
    for t in tables:
        assert t and all(isinstance(k, str) and isinstance(v, str) and v for k, v in t.items())
    for g in ("K1", "B1"):
        assert units.GAIN_UNITS_TORQUE[g] == units.GAIN_UNITS_DEFLECTION[g] == units.SIX_GAIN_UNITS[g]
    # the paper's deflection-convention K2 is a stiffness, exotune's torque-convention K2 is a ratio
    assert units.GAIN_UNITS_DEFLECTION["K2"].startswith("N·m/rad")
    assert units.GAIN_UNITS_TORQUE["K2"].startswith("1")


@pytest.mark.parametrize("x, digits, text", [
    (3.14159265, 3, "3.14"),
    (2.0, 6, "2"),
    (1234567.0, 3, "1.23e+06"),
    (np.float32(0.5), 6, "0.5"),
    (7, 6, "7"),
    (float("inf"), 6, "∞"),
    (-math.inf, 6, "−∞"),
    (float("nan"), 6, "—"),
    (None, 6, "—"),
    ("n/a", 6, "n/a"),
])
def test_fmt_num(x, digits, text):
    assert fmt_num(x, digits) == text


@given(st.floats(min_value=-1e300, max_value=1e300), st.integers(1, 17))
def test_fmt_num_round_trips_to_the_digits_asked(x, digits):
    back = float(fmt_num(x, digits))  # rounding to `digits` significant digits: relative error <= 5e-digits
    assert abs(back - x) <= 0.5 * 10.0 ** (1 - digits) * abs(x) * (1 + 1e-12)
    assert fmt_num(x, 17) == fmt_num(float(fmt_num(x, 17)), 17)  # 17 digits: exact round trip


def test_fmt_distinct_prints_bisected_members_apart_and_equal_ones_once():
    # four members bisected to 1e-10 relative printed "0.00555216" four times before
    vals = [0.0055521588146, 0.0055521588176, 0.0055521588191, 0.0055521588195]
    text = fmt_distinct(vals)
    assert text.split(", ") == ["0.0055521588146", "0.0055521588176", "0.0055521588191", "0.0055521588195"]
    assert fmt_distinct([2.0, 3.0, 2.0]) == "2 (×2), 3"
    assert fmt_distinct([0.5, 0.25]) == "0.5, 0.25"  # six digits suffice: no more are printed


@given(st.lists(st.floats(min_value=-1e300, max_value=1e300), min_size=1, max_size=8))
def test_fmt_distinct_lists_each_distinct_value_once_and_tells_them_apart(xs):
    items = fmt_distinct(xs).split(", ")
    distinct = list(dict.fromkeys(float(x) for x in xs))
    assert len(items) == len(distinct)
    shown = [float(i.split(" (×")[0]) for i in items]
    assert len(set(shown)) == len(shown)  # different values never print alike
    for v, s in zip(distinct, shown):
        assert abs(s - v) <= 0.5e-5 * abs(v) * (1 + 1e-12)
