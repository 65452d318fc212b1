"""exotune.controllerfile.consistency: certify's consistency checks alone (what ``simulate`` needs).

Checked against certify itself: on an exported file and on edited copies of it (predictions of the
file and of a gain-schedule entry, a golden command, a gain), ``consistency_problems`` lists exactly
the ``prediction_mismatches`` and golden-vector problems that ``certify`` reports, and refuses as
input exactly what certify refuses; ``simulate`` refuses the inconsistent copies naming the field.
"""

from __future__ import annotations

import copy
from pathlib import Path

import pytest

import exotune
from exotune.config import read_yaml
from exotune.controllerfile import build_export, design_at_rate
from exotune.controllerfile.certify import certify
from exotune.controllerfile.consistency import consistency_problems
from exotune.errors import ConfigError

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def exported() -> dict:
    """examples/scheduled.yaml exported at 1 kHz with its predictions (a gain schedule, a DOB)."""
    raw = read_yaml(ROOT / "examples" / "scheduled.yaml")
    return build_export(design_at_rate(raw, 1000.0), 1000.0)


def _edited(doc: dict) -> dict:
    """Predictions of the file and of the second entry changed, and one golden command of the first
    entry: inconsistent in three places, the plant and the controller untouched."""
    d = copy.deepcopy(doc)
    d["predicted"]["sampled"]["free_spectral_radius"] *= 1.01
    e = d["gain_schedule"]["entries"][1]["predicted_sampled"]
    e["locked_stable"] = not e["locked_stable"]
    d["gain_schedule"]["entries"][0]["golden_tau_cmd"]["values"][3] += 1.0
    return d


def test_an_exported_file_is_consistent(exported):
    assert consistency_problems(exported) == ([], [])


def test_the_problems_of_an_edited_file_are_certifys_item_for_item(exported):
    bad = _edited(exported)
    mism, golden = consistency_problems(bad)
    rep = certify(bad).to_dict()
    assert mism == rep["prediction_mismatches"]
    assert golden == [p for p in rep["problems"] if "golden vectors" in p]
    assert mism == ["gain_schedule[0.5 rad].predicted_sampled.locked_stable",
                    "predicted.sampled.free_spectral_radius"]
    assert len(golden) == 1 and "0 rad" in golden[0]


def test_a_file_without_predictions_mismatches_everywhere_certify_does(scheduled_doc):
    mism, golden = consistency_problems(scheduled_doc)
    assert golden == []
    assert len(mism) > 10 and mism == certify(scheduled_doc).to_dict()["prediction_mismatches"]


def test_what_certify_refuses_as_input_is_refused_alike(exported):
    d = copy.deepcopy(exported)
    d["gains"]["B2"]["value"] *= 1.001  # no longer built from the design section
    with pytest.raises(ConfigError) as c1:
        certify(d)
    with pytest.raises(ConfigError) as c2:
        consistency_problems(d)
    assert (c1.value.field, str(c1.value)) == (c2.value.field, str(c2.value))


def test_simulate_refuses_an_inconsistent_file_naming_the_first_mismatch(exported):
    bad = _edited(exported)
    bad["golden"] = exported["golden"]
    for e, e0 in zip(bad["gain_schedule"]["entries"], exported["gain_schedule"]["entries"]):
        e["golden_tau_cmd"] = e0["golden_tau_cmd"]
    with pytest.raises(ConfigError) as err:
        exotune.simulate(bad, "locked-output", duration=0.05)
    assert err.value.field == "gain_schedule[0.5 rad].predicted_sampled.locked_stable"
    assert "re-export" in str(err.value)
    only_golden = copy.deepcopy(exported)
    only_golden["golden"]["tau_cmd"]["values"][0] += 1.0
    with pytest.raises(ConfigError) as err:
        exotune.simulate(only_golden, "locked-output", duration=0.05)
    assert err.value.field == "golden.tau_cmd"
