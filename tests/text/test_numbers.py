"""exotune.text.numbers: units, counts, intervals and sampled verdict words as the text views write them."""

import pytest

from exotune.text.numbers import count_text, fmt_num, interval_text, sampled_verdict_word, unit_text
from exotune.units import fmt_num as units_fmt_num


@pytest.mark.parametrize("unit, text", [("1", "–"), ("1 (N·m/N·m)", "– (N·m/N·m)"), ("1/s", "1/s"),
                                        ("N·m/rad", "N·m/rad"), ("", ""), ("10", "10")])
def test_unit_text(unit, text):
    assert unit_text(unit) == text


def test_count_text_singular_only_for_exactly_one():
    assert count_text(1, "sample") == "1 sample"
    assert count_text(1.0, "sample") == "1 sample"
    assert count_text(0, "chunk") == "0 chunks"
    assert count_text(2.5, "sample") == "2.5 samples"
    assert count_text(1.00004, "sample", digits=4) == "1 samples"  # not exactly one: plural
    assert count_text(123456, "design", digits=3) == "1.23e+05 designs"


def test_interval_text():
    assert interval_text([(0.5, 2.0), (3.0, 1e4)], "N·m/rad") == "[0.5, 2], [3, 10000] N·m/rad"
    assert interval_text([(1.23456789, 2.0)], "1", digits=3) == "[1.23, 2] –"
    assert interval_text([(1.0, 2.0)], "") == "[1, 2]"
    assert interval_text([], "Hz") == "none"
    assert interval_text([], "Hz", empty="nowhere") == "nowhere"


def test_sampled_verdict_word():
    assert sampled_verdict_word(True) == "stable"
    assert sampled_verdict_word(False) == "UNSTABLE"
    assert sampled_verdict_word(None) == "inconclusive (spectral radius within rounding of 1)"


def test_fmt_num_is_the_one_formatter():
    assert fmt_num is units_fmt_num
