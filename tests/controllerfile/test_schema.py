"""exotune.controllerfile.schema: the controller file's format. A valid export passes; every
refusal names the field (dotted path) and the reason (missing, unknown, not a strict number, not
finite, wrong unit); the shipped JSON Schema is the model's (:func:`json_schema`) and
:func:`write_schema` writes exactly it."""

from __future__ import annotations

import copy
import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from exotune.controllerfile.schema import (SCHEMA_VERSION, SIGNAL_UNITS, ControllerSchema, json_schema, schema_path,
                                           validate_controller, write_schema)
from exotune.errors import ConfigError


def _refusal(doc) -> str:
    with pytest.raises(ConfigError) as e:
        validate_controller(doc, "ctl.yaml")
    return str(e.value)


def test_a_fresh_export_validates(scheduled_doc):
    m = validate_controller(copy.deepcopy(scheduled_doc))
    assert isinstance(m, ControllerSchema)
    assert scheduled_doc["schema"] == SCHEMA_VERSION == "exotune.controller/1"
    assert set(SIGNAL_UNITS) == {"theta_m", "omega_m", "tau_s", "dtau_s", "tau_c", "tau_cmd"}


def test_not_a_mapping_names_the_source():
    msg = _refusal([1, 2])
    assert "ctl.yaml" in msg and "mapping" in msg


def test_missing_field_is_named(scheduled_doc):
    doc = copy.deepcopy(scheduled_doc)
    del doc["sample_rate_hz"]
    msg = _refusal(doc)
    assert "sample_rate_hz" in msg and "missing field" in msg


def test_unknown_field_is_named(scheduled_doc):
    doc = copy.deepcopy(scheduled_doc)
    doc["plant"]["motor_inertia"]["typo"] = 1.0
    msg = _refusal(doc)
    assert "plant.motor_inertia.typo" in msg and "unknown field" in msg


@pytest.mark.parametrize("bad", ["1000", True, None])
def test_numbers_are_strict(scheduled_doc, bad):
    doc = copy.deepcopy(scheduled_doc)
    doc["sample_rate_hz"]["value"] = bad
    assert "sample_rate_hz.value" in _refusal(doc)


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -float("inf")])
def test_numbers_are_finite(scheduled_doc, bad):
    doc = copy.deepcopy(scheduled_doc)
    doc["plant"]["sea_stiffness"]["value"] = bad
    assert "plant.sea_stiffness.value" in _refusal(doc)


def test_wrong_unit_is_named(scheduled_doc):
    doc = copy.deepcopy(scheduled_doc)
    doc["sample_rate_hz"]["unit"] = "kHz"
    msg = _refusal(doc)
    assert "sample_rate_hz.unit" in msg


def test_wrong_schema_version_is_refused(scheduled_doc):
    doc = copy.deepcopy(scheduled_doc)
    doc["schema"] = "exotune.controller/2"
    assert "schema" in _refusal(doc)


@settings(max_examples=25, deadline=None)
@given(st.sampled_from(["schema", "sample_rate_hz", "delay_s", "plant", "controller", "golden"]))
def test_any_removed_required_section_is_named(scheduled_doc, key):
    doc = copy.deepcopy(scheduled_doc)
    del doc[key]
    msg = _refusal(doc)
    assert key in msg and "missing field" in msg


def test_shipped_json_schema_is_the_models():
    shipped = json.loads(schema_path().read_text(encoding="utf-8"))
    assert shipped == json_schema()
    assert shipped["$schema"].endswith("2020-12/schema")


def test_write_schema_writes_the_json_schema(tmp_path):
    out = tmp_path / "c.schema.json"
    write_schema(out)
    assert json.loads(out.read_text(encoding="utf-8")) == json_schema()
    assert out.read_text(encoding="utf-8") == schema_path().read_text(encoding="utf-8")


def test_json_schema_validates_an_export(scheduled_doc):
    jsonschema = pytest.importorskip("jsonschema")
    jsonschema.Draft202012Validator(json_schema()).validate(json.loads(json.dumps(scheduled_doc)))
    bad = copy.deepcopy(scheduled_doc)
    bad["extra"] = 1
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.Draft202012Validator(json_schema()).validate(json.loads(json.dumps(bad)))


@pytest.mark.parametrize("a0", [2.0, 0.5])
def test_an_unnormalized_section_names_its_row_and_the_a0_rule(scheduled_doc, a0):
    """A hand-edited a0 = 2 read "controller.filters.2.sos.0.3: Input should be less than or equal
    to 1": the path is now written as the file's fields, and the rule is a0 = 1."""
    doc = copy.deepcopy(scheduled_doc)
    row = list(doc["controller"]["filters"][1]["sos"][0])
    row[3] = a0
    doc["controller"]["filters"][1]["sos"][0] = row
    msg = _refusal(doc)
    assert msg.startswith("controller.filters[1].sos[0][3]: ") and "must be 1" in msg and repr(a0) in msg


@pytest.mark.parametrize("bad", [[1, 2], "abc", "A" * 64, 5])
def test_the_design_hash_must_be_a_sha256_digest(scheduled_doc, bad):
    doc = copy.deepcopy(scheduled_doc)
    doc["provenance"]["input_sha256"] = bad
    msg = _refusal(doc)
    assert msg.startswith("provenance.input_sha256: ") and "SHA-256" in msg
    doc["provenance"]["input_sha256"] = None  # a file exported from a mapping has none
    validate_controller(doc)
    doc["provenance"]["input_sha256"] = "0123456789abcdef" * 4
    validate_controller(doc)
