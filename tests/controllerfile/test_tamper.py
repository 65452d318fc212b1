"""`certify` recomputes the controller from the file's design section and plant: a file whose
design section was edited after export (or whose controller was swapped) is refused with one line
naming the field (exit 2), unless it declares a hand-tuned controller — then the report says that
only the controller is certified (issue 16)."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from exotune.cli import cli
from exotune.config import read_yaml
from exotune.controllerfile import build_export, design_at_rate
from exotune.controllerfile.certify import certify, check_built_from_design, design_mismatches
from exotune.errors import ConfigError
from exotune.model.shaping import DesignParams, double_compliance_shaping

ROOT = Path(__file__).resolve().parents[2]
PAPER = ROOT / "examples" / "paper.yaml"


@pytest.fixture(scope="module")
def doc():
    raw = read_yaml(PAPER)
    d = build_export(design_at_rate(raw, 1000.0), 1000.0)
    assert design_mismatches(d) == []
    return d


def _write(tmp_path: Path, d: dict) -> Path:
    p = tmp_path / "c.yaml"
    p.write_text(yaml.safe_dump(d, sort_keys=False, allow_unicode=True))
    return p


def set_design(key, value):
    def fn(d):
        d["design"][key]["value"] = value
    return fn


def set_plant(key, value):
    def fn(d):
        d["plant"][key]["value"] = value
    return fn


def alpha_with_consistent_summary(d):
    """α edited and the six-gain summary and static gains rewritten to match it: only the cuff
    filter (built for α = 8) still betrays the edit."""
    from exotune.controllerfile.fileio import plant_from_file

    d["design"]["amplification"]["value"] = 20.0
    des = {k: np.asarray(q["value"]) for k, q in d["design"].items()}
    g = double_compliance_shaping(plant_from_file(d), DesignParams(**des)).gains
    for k in ("K1", "B1", "K2", "B2", "K2_hat", "B2_hat"):
        d["gains"][k]["value"] = float(np.ravel(getattr(g, k))[0])
    c = d["controller"]["gains"]
    c["omega_m"]["gain"], c["tau_s"]["gain"], c["dtau_s"]["gain"] = (
        -d["gains"]["B1"]["value"], d["gains"]["K2"]["value"], d["gains"]["B2"]["value"])


def swap_cuff_filter(d):
    f = next(f for f in d["controller"]["filters"] if f["name"] == "cuff_path")
    f["sos"][0] = [2.0 * x for x in f["sos"][0][:3]] + f["sos"][0][3:]


CASES = [
    (set_design("amplification", 20.0), "design.amplification", "K2_hat = 7.0 is that of amplification 8.0, not 20.0"),
    (set_design("felt_inertia", 0.3), "design", "gains.B1"),
    (set_design("zeta_hat", 0.9), "design", "gains.B2_hat"),
    (set_plant("sea_stiffness", 1500.0), "design", "gains.B2"),
    (alpha_with_consistent_summary, "design", "cuff_path"),
    (swap_cuff_filter, "design", "cuff_path"),
]


@pytest.mark.parametrize("tamper,field,what", CASES, ids=lambda x: getattr(x, "__name__", None) or str(x))
def test_controller_not_built_from_its_design_is_refused(doc, tmp_path, tamper, field, what):
    d = copy.deepcopy(doc)
    tamper(d)
    with pytest.raises(ConfigError) as e:
        check_built_from_design(d)
    assert e.value.field == field and what in e.value.reason, str(e.value)
    res = CliRunner().invoke(cli, ["certify", str(_write(tmp_path, d))])
    assert res.exit_code == 2, res.output
    assert res.stderr.startswith(f"exotune: error: {field}: the controller in this file was not built from its "
                                 "design, plant and implementation sections") and res.stderr.count("\n") == 1, res.stderr


def test_hand_tuned_file_is_certified_for_its_controller_only(doc, tmp_path):
    d = copy.deepcopy(doc)
    d["design"]["amplification"]["value"] = 20.0  # the design section no longer describes the controller
    d["provenance"]["hand_tuned"] = True
    check_built_from_design(d)  # no error: declared hand-tuned
    rep = certify(copy.deepcopy(d)).to_dict()
    assert rep["scope"].startswith("controller only") and rep["method"].startswith("hand-tuned controller")
    res = CliRunner().invoke(cli, ["certify", str(_write(tmp_path, d))])
    assert res.exit_code == (0 if rep["certified"] else 1), res.output  # analysed: no design check refusal
    assert "hand-tuned controller (provenance.hand_tuned: true): this certifies only the controller" in res.output


def test_hand_tuned_must_be_a_boolean(doc):
    d = copy.deepcopy(doc)
    d["provenance"]["hand_tuned"] = "yes"
    with pytest.raises(ConfigError, match="expected true or false") as e:
        check_built_from_design(d)
    assert e.value.field == "provenance.hand_tuned"


def test_untouched_export_has_no_scope_note(doc):
    rep = certify(copy.deepcopy(doc)).to_dict()
    assert "scope" not in rep and not rep["method"].startswith("hand-tuned")


def _res(tmp_path, d):
    res = CliRunner().invoke(cli, ["certify", str(_write(tmp_path, d))])
    assert res.exception is None or isinstance(res.exception, SystemExit), repr(res.exception)
    return res


def test_a_filter_that_keeps_its_dc_gain_but_not_its_dynamics_is_refused(doc, tmp_path):
    """The DOB's Q filter on τ_s re-tuned in the file with its DC gain kept (b0 and b1 moved by
    opposite amounts: b(1) and a(z) unchanged): the six gains and the filters' DC gains still match
    the design, only the rebuild from the implementation section tells."""
    d = copy.deepcopy(doc)
    f = next(x for x in d["controller"]["filters"] if x["name"] == "dob_spring")
    sos = np.asarray(f["sos"], float)
    delta = 0.05 * abs(sos[0, 0])
    sos[0, 0] -= delta
    sos[0, 1] += delta
    f["sos"] = sos.tolist()
    res = _res(tmp_path, d)
    assert res.exit_code == 2 and "exotune: error: implementation:" in res.output
    assert "controller.filters[dob_spring] is not the filter the implementation section builds" in res.output


def test_an_edited_implementation_section_is_refused(doc, tmp_path):
    d = copy.deepcopy(doc)
    d["implementation"]["dob"]["cutoff_hz"] = 45.0
    res = _res(tmp_path, d)
    assert res.exit_code == 2 and "implementation section builds" in res.output
    d = copy.deepcopy(doc)
    d["implementation"]["delay_s"] = 0.002
    res = _res(tmp_path, d)
    assert res.exit_code == 2 and "implementation.delay_s" in res.output
    d = copy.deepcopy(doc)
    d["implementation"]["gv_filter"]["cutoff_hz"] = -5.0  # invalid: the design-file rules name the field
    res = _res(tmp_path, d)
    assert res.exit_code == 2 and "implementation.gv_filter.cutoff_hz" in res.output


def test_a_file_without_an_implementation_section_still_certifies(doc):
    d = copy.deepcopy(doc)
    del d["implementation"]  # files written before the section existed
    assert design_mismatches(d) == []
    rep = certify(d).to_dict()
    assert rep["certified"] == certify(copy.deepcopy(doc)).to_dict()["certified"]
    # ... but its report says what was not checked
    assert "only by their DC gains" in rep["scope"] and rep["method"].startswith("no implementation section")


@pytest.mark.parametrize("key,value", [("delay_s", "x"), ("sample_rate_hz", "x"), ("delay_s", [1]),
                                       ("sample_rate_hz", True)])
def test_a_non_number_in_the_implementation_timing_names_its_field(doc, tmp_path, key, value):
    """It was reported as "design: cannot rebuild the controller (ValueError: could not convert
    string to float)"."""
    d = copy.deepcopy(doc)
    d["implementation"][key] = value
    res = _res(tmp_path, d)
    assert res.exit_code == 2 and f"exotune: error: implementation.{key}:" in res.output, res.output
    assert "Traceback" not in res.output
