"""exotune.record: the views every typed result shares (to_dict, to_json, to_text, str)."""

import json
from dataclasses import FrozenInstanceError, dataclass

import numpy as np
import pytest

from exotune.record import Record, Result, opt_float


@dataclass(frozen=True)
class _Doc(Record):
    title: str = ""


def test_record_to_dict_is_a_deep_copy():
    doc = {"a": {"b": [1, 2]}, "c": 3}
    r = _Doc(record=doc, title="t")
    out = r.to_dict()
    assert out == doc
    out["a"]["b"].append(99)
    assert doc["a"]["b"] == [1, 2] and r.to_dict()["a"]["b"] == [1, 2]


def test_to_json_is_strict_json_of_to_dict():
    r = _Doc(record={"x": float("inf"), "y": float("nan"), "z": np.float64(0.1), "w": np.arange(3)})
    text = r.to_json()
    assert "Infinity" not in text and "NaN" not in text
    assert json.loads(text) == {"x": "inf", "y": None, "z": 0.1, "w": [0, 1, 2]}


def test_to_text_and_str_default_to_the_json():
    r = _Doc(record={"k": 1})
    assert r.to_text() == r.to_json() == str(r)


def test_record_is_frozen_and_not_compared_by_document():
    r = _Doc(record={"k": 1}, title="a")
    with pytest.raises(FrozenInstanceError):
        r.title = "b"
    assert _Doc(record={"k": 1}, title="a") == _Doc(record={"k": 2}, title="a")
    assert "record" not in repr(r)


def test_a_result_uses_its_own_to_dict():
    class Two(Result):
        def to_dict(self):
            return {"two": 2}

    assert json.loads(Two().to_json()) == {"two": 2}
    assert str(Two()) == Two().to_json()


def test_opt_float():
    assert opt_float(None) is None
    v = opt_float(np.float32(1.5))
    assert type(v) is float and v == 1.5
    assert type(opt_float(3)) is float
