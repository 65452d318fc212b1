"""exotune.options: numbers given on the command line, one message style naming the option."""

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from exotune.errors import ConfigError
from exotune.options import number_value


@given(st.floats(allow_nan=False, allow_infinity=False))
def test_numbers_round_trip_from_their_text(x):
    assert number_value("--x", repr(x)) == x
    assert number_value("--x", x) == x


def test_positive_and_integers():
    assert number_value("--duration", "2.5", positive=True) == 2.5
    assert number_value("--n", 3) == 3.0 and type(number_value("--n", 3)) is float
    assert number_value("--x", " 1e-3 ") == 1e-3


@pytest.mark.parametrize("text, kw, reason", [
    ("abc", {}, "expected a number, got 'abc'"),
    (None, {"noun": "a number of Hz"}, "expected a number of Hz, got None"),
    ("nan", {}, "must be a finite number, got 'nan'"),
    (math.inf, {}, "must be a finite number, got inf"),
    ("0", {"positive": True}, "must be > 0, got '0'"),
    ("-2", {"positive": True}, "must be > 0, got '-2'"),
])
def test_errors_name_the_option_and_the_value_as_typed(text, kw, reason):
    with pytest.raises(ConfigError) as ei:
        number_value("--sample-rate-hz", text, **kw)
    assert ei.value.field == "--sample-rate-hz" and ei.value.reason == reason
    assert str(ei.value) == f"--sample-rate-hz: {reason}"
