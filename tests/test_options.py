"""exotune.options: numbers given on the command line, one message style naming the option."""

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from exotune.errors import ConfigError
from exotune.options import flag_value, number_value, path_value


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


@pytest.mark.parametrize("value", [True, False, np.True_, np.bool_(False)])
def test_a_bool_is_not_a_number(value):
    """A bool is an int, but ``duration=True`` is a mistake, not one second."""
    with pytest.raises(ConfigError) as ei:
        number_value("duration", value, positive=True, noun="a number of seconds")
    assert ei.value.field == "duration" and ei.value.reason == f"expected a number of seconds, got {value!r}"


def test_strings_only_where_the_command_line_passes_them():
    assert number_value("--duration", "2.5") == 2.5  # the command line's values are text
    for text in ("2.5", b"2.5"):
        with pytest.raises(ConfigError) as ei:
            number_value("duration", text, strings=False)
        assert ei.value.field == "duration" and "expected a number" in ei.value.reason
    assert number_value("duration", 2, strings=False) == 2.0 and number_value("x", np.float32(0.5), strings=False) == 0.5


def test_an_integer_too_large_for_a_float_is_refused():
    with pytest.raises(ConfigError) as ei:
        number_value("duration", 10 ** 400)
    assert ei.value.field == "duration" and ei.value.reason.startswith("expected a number")


@pytest.mark.parametrize("value", ["no", "yes", "", 1, 0, None, 1.0, [True], np.array([True, False])])
def test_a_flag_is_true_or_false_only(value):
    with pytest.raises(ConfigError) as ei:
        flag_value("cross_check", value)
    assert ei.value.field == "cross_check" and ei.value.reason.startswith("expected True or False, got ")


def test_flags_that_are_bools_pass():
    assert flag_value("friction", True) is True and flag_value("friction", False) is False
    assert flag_value("friction", np.True_) is True


@pytest.mark.parametrize("value", [3, 2.5, ["out"], ("a", "b"), b"out", {"path": "x"}])
def test_a_path_is_a_str_or_path_like(value):
    with pytest.raises(ConfigError) as ei:
        path_value("plots", value)
    assert ei.value.field == "plots" and ei.value.reason.startswith(f"expected a path (str or os.PathLike), got "
                                                                    f"{type(value).__name__}")


def test_paths_that_are_paths_pass():
    assert path_value("out", "a.yaml") == "a.yaml" and path_value("out", Path("a")) == Path("a")
    assert path_value("plots", None) is None
    with pytest.raises(ConfigError) as ei:
        path_value("out", None, required=True)
    assert ei.value.field == "out" and ei.value.reason == "expected a path (str or os.PathLike), got NoneType None"


@pytest.mark.parametrize("text", ["1_000", "1_000.5", "1e1_0", "١٠٠٠", "１０", "0x10", "1,5", "1 000"])
def test_a_number_yaml_would_not_read_is_refused(text):
    """``--sample-rate-hz 1_000`` was 1000 (Python's ``float`` reads ``1_000`` and non-ASCII
    digits) while a design file refuses ``1_000``: the command line's numbers are now the numbers
    YAML 1.2 reads, and the error names the option and the value as typed."""
    with pytest.raises(ConfigError) as ei:
        number_value("--sample-rate-hz", text, positive=True, noun="a number of Hz")
    assert ei.value.field == "--sample-rate-hz"
    assert ei.value.reason.startswith(f"expected a number of Hz, got {text!r}")


@pytest.mark.parametrize("text", ["Infinity", "-inf", ".inf", "-.inf", ".nan", "NaN"])
def test_the_non_finite_spellings_say_finite(text):
    with pytest.raises(ConfigError) as ei:
        number_value("--duration", text)
    assert ei.value.reason == f"must be a finite number, got {text!r}"


@pytest.mark.parametrize("text, value", [("1000", 1000.0), ("+1e3", 1000.0), (".5", 0.5), ("3.", 3.0),
                                         ("-2.5E-3", -2.5e-3), ("0300", 300.0), ("\t7\n", 7.0)])
def test_the_numbers_yaml_reads_pass(text, value):
    assert number_value("--x", text) == value
