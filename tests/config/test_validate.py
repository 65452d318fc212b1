"""One number validator, one wording: a design file, a sweep spec and an optimize spec refuse the
same bad number with the same reason (:func:`exotune.config.validate.number_field`)."""

from __future__ import annotations

import copy
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from exotune.config import design_from_mapping, load_design
from exotune.config.validate import number_field
from exotune.errors import ConfigError
from exotune.optimization.spec import load_optimize_spec
from exotune.sweeps.spec import load_spec

ROOT = Path(__file__).resolve().parents[2]
BASE = str(ROOT / "examples" / "paper.yaml")
BAD = [("0.7", "expected a number, got the string '0.7' (a quoted number? remove the quotes)"),
       ("abc", "expected a number, got the string 'abc'"),
       (None, "expected a number, got null"),
       (True, "expected a number, got true"),
       ([1.0], "expected a number, got a list [1.0]"),
       (float("nan"), "must be a finite number, got nan"),
       (10 ** 400, "is too large for a float")]


@pytest.mark.parametrize("value, reason", BAD)
def test_number_field_reason_and_field(value, reason):
    with pytest.raises(ConfigError) as e:
        number_field("a.b", value)
    assert e.value.field == "a.b"
    assert reason in str(e.value)


@given(st.one_of(st.integers(-10 ** 12, 10 ** 12), st.floats(allow_nan=False, allow_infinity=False)))
def test_number_field_accepts_every_finite_real(x):
    assert number_field("f", x) == float(x)


@pytest.mark.parametrize("value, reason", BAD[:4])
def test_design_sweep_and_optimize_specs_word_a_bad_number_alike(value, reason):
    raw = copy.deepcopy(load_design(BASE).raw)
    raw["design"]["zeta"] = value
    with pytest.raises(ConfigError) as design_err:
        design_from_mapping(raw)
    with pytest.raises(ConfigError) as sweep_err:
        load_spec({"base": BASE, "axes": {"design.zeta": [0.5, value]}})
    with pytest.raises(ConfigError) as opt_err:
        load_optimize_spec({"base": BASE, "free": {"design.zeta": [value, 1.0]}})
    assert sweep_err.value.field == "axes.design.zeta[1]"
    assert opt_err.value.field.endswith("[0]")
    for e in (design_err, sweep_err, opt_err):
        assert reason in str(e.value), str(e.value)
