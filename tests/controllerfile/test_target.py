"""exotune.controllerfile.target: the runtime a target executes (float32 realization or float64
reference) and a file converted to another precision. Converting a float64 export to float32
gives the realization and golden outputs an export made for float32 has; converting back gives
the float64 runtime's outputs; an unknown precision is refused naming the option."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from exotune.controllerfile.model import ControllerFile
from exotune.controllerfile.precision import Float32Runtime
from exotune.controllerfile.runtime import Runtime
from exotune.controllerfile.target import runtime_of, with_precision
from exotune.errors import ConfigError


def _golden_inputs(doc):
    return {s: np.asarray(v["values"], float) for s, v in doc["golden"]["inputs"].items()}


def test_runtime_of_follows_the_realization(scheduled_doc, scheduled_doc32):
    assert type(runtime_of(scheduled_doc)) is Runtime
    assert type(runtime_of(scheduled_doc32)) is Float32Runtime


def test_runtime_of_reproduces_each_files_golden_vector(scheduled_doc, scheduled_doc32):
    for doc in (scheduled_doc, scheduled_doc32):
        out = runtime_of(doc).run(_golden_inputs(doc))
        np.testing.assert_allclose(out, doc["golden"]["tau_cmd"]["values"], rtol=1e-12, atol=0)


def test_runtime_of_passes_limit_and_angle(scheduled_doc):
    ins = _golden_inputs(scheduled_doc)
    free = runtime_of(scheduled_doc).run(ins)
    lim = 0.5 * float(np.max(np.abs(free)))
    assert np.max(np.abs(runtime_of(scheduled_doc, limit_nm=lim).run(ins))) <= lim * (1 + 1e-15)
    e = scheduled_doc["gain_schedule"]["entries"][-1]
    got = runtime_of(scheduled_doc, joint_angle_rad=e["joint_angle_rad"]).run(ins)
    np.testing.assert_allclose(got, e["golden_tau_cmd"]["values"], rtol=1e-12, atol=0)


def test_float64_to_float32_is_the_float32_export(scheduled_doc, scheduled_doc32):
    conv = with_precision(copy.deepcopy(scheduled_doc), "float32")
    assert isinstance(conv, ControllerFile)
    d = conv.to_dict()
    assert d["implementation"]["precision"] == "float32"
    assert d["controller"]["realization"] == scheduled_doc32["controller"]["realization"]
    np.testing.assert_allclose(d["golden"]["tau_cmd"]["values"], scheduled_doc32["golden"]["tau_cmd"]["values"],
                               rtol=1e-12, atol=0)
    for e, e32 in zip(d["gain_schedule"]["entries"], scheduled_doc32["gain_schedule"]["entries"]):
        assert e["controller"]["realization"] == e32["controller"]["realization"]
        np.testing.assert_allclose(e["golden_tau_cmd"]["values"], e32["golden_tau_cmd"]["values"], rtol=1e-12, atol=0)
    assert "realization" not in scheduled_doc["controller"]  # the input is not changed


def test_float32_to_float64_drops_the_realization(scheduled_doc, scheduled_doc32):
    d = with_precision(copy.deepcopy(scheduled_doc32), "float64").to_dict()
    assert d["implementation"]["precision"] == "float64"
    assert "realization" not in d["controller"]
    assert all("realization" not in e["controller"] for e in d["gain_schedule"]["entries"])
    np.testing.assert_allclose(d["golden"]["tau_cmd"]["values"], scheduled_doc["golden"]["tau_cmd"]["values"],
                               rtol=1e-12, atol=0)
    # and the float32 golden outputs differ from these (by rounding, not by much)
    g32 = np.asarray(scheduled_doc32["golden"]["tau_cmd"]["values"])
    g64 = np.asarray(d["golden"]["tau_cmd"]["values"])
    assert not np.array_equal(g32, g64)
    np.testing.assert_allclose(g32, g64, rtol=1e-3, atol=1e-3 * np.max(np.abs(g64)))


def test_unknown_precision_is_refused(scheduled_doc):
    with pytest.raises(ConfigError, match="^precision: "):
        with_precision(scheduled_doc, "float16")
