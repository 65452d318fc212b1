"""exotune.errors: one-line ``field: reason`` messages, exit codes, pickling, combining."""

import pickle

import pytest

from exotune.errors import MAX_FIELD_CHARS, MAX_REASON_CHARS, ConfigError, ExotuneError, RunFailed, combine_errors


def test_config_error_names_the_field_then_the_reason():
    e = ConfigError("humans[0].inertia", "must be positive")
    assert str(e) == "humans[0].inertia: must be positive"
    assert (e.field, e.reason, e.more) == ("humans[0].inertia", "must be positive", [])
    assert isinstance(e, ExotuneError) and e.exit_code == 2


def test_config_error_without_field_is_the_reason_alone():
    assert str(ConfigError("", "no input given")) == "no input given"


def test_messages_are_one_line():
    e = ConfigError("design.\namplification", "must be\n  a number\tand finite", more=["a:\n b"])
    assert str(e) == "design. amplification: must be a number and finite"
    assert e.more == ["a: b"]
    assert "\n" not in str(e)


def test_long_fields_and_reasons_are_cut_and_say_so():
    e = ConfigError("f" * (MAX_FIELD_CHARS + 50), "r" * (MAX_REASON_CHARS + 7))
    assert e.field.startswith("f" * MAX_FIELD_CHARS)
    assert e.field.endswith(f"(cut; {MAX_FIELD_CHARS + 50} characters)")
    assert e.reason.endswith(f"(cut; {MAX_REASON_CHARS + 7} characters)")
    assert len(e.reason) < MAX_REASON_CHARS + 40
    short = ConfigError("f" * MAX_FIELD_CHARS, "ok")  # at the limit: kept whole
    assert short.field == "f" * MAX_FIELD_CHARS


def test_run_failed_exits_1_with_a_one_line_message():
    e = RunFailed("3 chunks failed:\n  chunk 1\n  chunk 2")
    assert e.exit_code == 1 and isinstance(e, ExotuneError)
    assert str(e) == "3 chunks failed: chunk 1 chunk 2"


def test_config_error_survives_pickling_with_its_fields():
    e = ConfigError("plant.cuff_stiffness", "must be positive", more=["x: y"])
    back = pickle.loads(pickle.dumps(e))
    assert type(back) is ConfigError
    assert (back.field, back.reason, back.more, back.in_file) == (e.field, e.reason, e.more, False)
    assert str(back) == str(e)
    f = pickle.loads(pickle.dumps(ConfigError("seed", "bad", in_file=True)))
    assert f.in_file is True and str(f) == "seed: bad"


def test_combine_errors_keeps_the_first_errors_origin():
    assert combine_errors([ConfigError("seed", "x", in_file=True), ConfigError("b", "y")]).in_file is True
    assert combine_errors([ConfigError("seed", "x"), ConfigError("b", "y", in_file=True)]).in_file is False


def test_combine_errors_keeps_the_first_and_lists_the_rest_in_order():
    a = ConfigError("a", "bad a", more=["a2: also bad"])
    b = ConfigError("b", "bad b", more=["b2: worse"])
    c = ConfigError("c", "bad c")
    out = combine_errors([a, b, c])
    assert (out.field, out.reason) == ("a", "bad a")
    assert out.more == ["a2: also bad", "b: bad b", "b2: worse", "c: bad c"]
    assert str(combine_errors([c])) == "c: bad c" and combine_errors([c]).more == []


def test_combine_errors_needs_at_least_one():
    with pytest.raises(ValueError):
        combine_errors([])
