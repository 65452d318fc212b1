"""``exotune export`` / ``exotune certify`` from the outside (docs/controller-file.md, docs/cli.md), and the numerical
building blocks of the controller file checked against independent implementations:

* the shipped JSON Schema is the one generated from the pydantic model, an exported file validates
  against it with the ``jsonschema`` package, and edited files are refused by both validators
  (``validate_controller`` naming the dotted field);
* the CLI error contract (exit code 2, one line ``exotune: error: <field>: <reason>`` on stderr,
  no traceback, nothing written, an existing output left as it was);
* the happy path: every plant/design/gain number carries its unit, certify's verdicts and exit
  codes for the paper example (not robust) and for a restricted, robust design;
* property tests: ``sos_ss`` and the reference runtime's ``SosFilter`` against
  ``scipy.signal.sosfilt``, the affine identity ``step(x) = feedthrough·x + peek(0)`` the runtime
  uses for the DOB's algebraic loop, and ``tustin_sos`` against the continuous response at the
  prewarp frequency and against python-control's prewarped Tustin discretization.

Several tests are regressions of bugs found while writing this file (certify crashing on missing
keys, the schema not constraining sos rows, sos sections with a pole at z = 0 or tiny gains,
the wrong file named for an unwritable output, certify-section field names, deleted families).
"""

from __future__ import annotations

import copy
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.signal
import yaml
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

import exotune.controllerfile.export as export_mod
from exotune.cli import cli
from exotune.errors import ConfigError
from exotune.controllerfile import json_schema, schema_path, tustin_sos, validate_controller
from exotune.controllerfile.sos import sos_ss
from exotune.controllerfile.runtime import SosFilter

ROOT = Path(__file__).resolve().parents[1]
PAPER = ROOT / "examples" / "paper.yaml"
SHIPPED_SCHEMA = ROOT / "exotune" / "controllerfile" / "schemas" / "controller.schema.json"


def run(*args):
    # exceptions are caught by the runner so that an uncaught one shows up as res.exception
    return CliRunner().invoke(cli, [str(a) for a in args])


def clean_exit(res) -> bool:
    """True when the command ended through sys.exit / click (no uncaught exception)."""
    return res.exception is None or isinstance(res.exception, SystemExit)


def assert_input_error(res, field: str, out: Path | None = None) -> str:
    """docs/cli.md: exit 2, one stderr line ``exotune: error: <field>: <reason>``, no traceback, nothing
    on stdout and (when given) no output file. Returns the error line."""
    assert clean_exit(res), f"uncaught {res.exception!r}"
    assert res.exit_code == 2, (res.exit_code, res.output)
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, res.stderr
    line = lines[0]
    assert line.startswith("exotune: error: "), line
    assert line.startswith(f"exotune: error: {field}"), (field, line)
    # a reason follows the field
    assert len(line[len("exotune: error: "):].split(": ", 1)) == 2, line
    assert "Traceback" not in res.stderr and "Traceback" not in res.stdout
    assert res.stdout == ""
    if out is not None:
        assert not out.exists()
    return line


# ------------------------------------------------------------------------------------------
# fixtures: one export of the paper example per module (export takes seconds)
# ------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    out = tmp_path_factory.mktemp("export") / "paper_1000.yaml"
    res = run("export", "--allow-uncertified", PAPER, "--sample-rate-hz", "1000", "-o", out)
    assert res.exit_code == 0, (res.output, res.exception)
    assert out.is_file()
    return out, res


@pytest.fixture(scope="module")
def exported_doc(exported):
    with open(exported[0], encoding="utf-8") as fh:
        return yaml.safe_load(fh)


@pytest.fixture(scope="module")
def paper_certify_json(exported):
    res = run("certify", exported[0], "--json")
    assert clean_exit(res), res.exception
    return res


# ------------------------------------------------------------------------------------------
# 1. schema
# ------------------------------------------------------------------------------------------
def test_shipped_schema_is_the_generated_one():
    assert Path(schema_path()).resolve() == SHIPPED_SCHEMA.resolve()
    with open(SHIPPED_SCHEMA, encoding="utf-8") as fh:
        shipped = json.load(fh)
    assert shipped == json_schema()
    # and it is a schema of the controller file, not an empty placeholder
    assert "sample_rate_hz" in shipped["required"] and "controller" in shipped["properties"]


def _validator():
    jsonschema = pytest.importorskip("jsonschema")
    with open(SHIPPED_SCHEMA, encoding="utf-8") as fh:
        schema = json.load(fh)
    cls = jsonschema.validators.validator_for(schema)
    cls.check_schema(schema)
    return cls(schema)


def test_exported_file_validates_against_shipped_schema(exported_doc):
    v = _validator()
    errors = list(v.iter_errors(exported_doc))
    assert errors == [], [e.message for e in errors[:5]]
    validate_controller(exported_doc)  # and against the pydantic model


def _sos_row_5(d):
    d["controller"]["filters"][0]["sos"][0].pop()


def _sos_row_7(d):
    d["controller"]["filters"][0]["sos"][0].append(0.0)


def _sos_a0_2(d):
    d["controller"]["filters"][0]["sos"][0][3] = 2.0


def _sos_empty(d):
    d["controller"]["filters"][0]["sos"] = []


def _no_sample_rate(d):
    del d["sample_rate_hz"]


def _zero_sample_rate(d):
    d["sample_rate_hz"]["value"] = 0.0


def _unknown_top(d):
    d["tuning_notes"] = "hand edited"


def _negative_delay(d):
    d["delay_s"]["value"] = -0.001


def _bad_filter_input(d):
    d["controller"]["filters"][0]["input"] = "theta_j"


def _unit_missing(d):
    del d["plant"]["motor_inertia"]["unit"]


def _schema_version(d):
    d["schema"] = "exotune.controller/2"


def _golden_not_number(d):
    d["golden"]["tau_cmd"]["values"][3] = "x"


MUTATIONS = [
    # id, mutation, expected dotted field (prefix), jsonschema marks
    ("sos_row_5_numbers", _sos_row_5, "controller.filters[0].sos", []),
    ("sos_row_7_numbers", _sos_row_7, "controller.filters[0].sos", []),
    ("sos_a0_not_1", _sos_a0_2, "controller.filters[0].sos", []),
    ("sos_empty", _sos_empty, "controller.filters[0].sos", []),
    ("missing_sample_rate_hz", _no_sample_rate, "sample_rate_hz", []),
    ("zero_sample_rate", _zero_sample_rate, "sample_rate_hz.value", []),
    ("unknown_top_level_key", _unknown_top, "tuning_notes", []),
    ("negative_delay", _negative_delay, "delay_s.value", []),
    ("unknown_filter_input", _bad_filter_input, "controller.filters[0].input", []),
    ("quantity_without_unit", _unit_missing, "plant.motor_inertia.unit", []),
    ("wrong_schema_version", _schema_version, "schema", []),
    ("golden_value_not_number", _golden_not_number, "golden.tau_cmd.values", []),
]


@pytest.mark.parametrize("mutate, field", [pytest.param(m, f, id=i) for i, m, f, _ in MUTATIONS])
def test_mutated_document_refused_by_validate_controller(exported_doc, mutate, field):
    d = copy.deepcopy(exported_doc)
    mutate(d)
    with pytest.raises(ConfigError) as ei:
        validate_controller(d)
    err = ei.value
    assert err.field.startswith(field), (err.field, err.reason)
    assert err.reason and "\n" not in err.reason
    assert str(err) == f"{err.field}: {err.reason}"


@pytest.mark.parametrize("mutate", [pytest.param(m, id=i, marks=marks) for i, m, _, marks in MUTATIONS])
def test_mutated_document_refused_by_jsonschema(exported_doc, mutate):
    v = _validator()
    d = copy.deepcopy(exported_doc)
    mutate(d)
    assert not v.is_valid(d)


def test_mutations_leave_the_fixture_document_valid(exported_doc):
    # guard against the mutation tests passing because the base document is already invalid
    assert _validator().is_valid(exported_doc)
    validate_controller(exported_doc)


def test_validate_controller_refuses_non_mapping():
    for bad in ([], "schema: x", None, 3.0):
        with pytest.raises(ConfigError):
            validate_controller(bad)


# ------------------------------------------------------------------------------------------
# 2. CLI bad input
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("rate", ["0", "-3", "nan", "abc", "inf", "-0", "1e308", "1e-9", "2e7"])
def test_export_bad_sample_rate(tmp_path, rate):
    out = tmp_path / "ctl.yaml"
    res = run("export", "--allow-uncertified", PAPER, "--sample-rate-hz", rate, "-o", out)
    assert_input_error(res, "--sample-rate-hz", out)
    assert list(tmp_path.iterdir()) == []  # no temporary files either


@pytest.mark.parametrize("rate, field", [
    ("100", "implementation.gv_filter.cutoff_hz"),       # gv_filter 80 Hz > Nyquist 50 Hz
    ("160", "implementation.gv_filter.cutoff_hz"),       # 80 Hz = Nyquist: not below it
    ("170", "implementation.derivative_filter.cutoff_hz"),  # 100 Hz > 85 Hz, gv 80 Hz fine
])
def test_export_cutoff_above_nyquist(tmp_path, rate, field):
    out = tmp_path / "ctl.yaml"
    res = run("export", "--allow-uncertified", PAPER, "--sample-rate-hz", rate, "-o", out)
    line = assert_input_error(res, field, out)
    assert "Nyquist" in line
    assert list(tmp_path.iterdir()) == []


def test_export_missing_design_file(tmp_path):
    missing = tmp_path / "no_such_design.yaml"
    out = tmp_path / "ctl.yaml"
    res = run("export", missing, "--sample-rate-hz", "1000", "-o", out)
    assert_input_error(res, str(missing), out)


def test_export_error_in_a_real_process_has_no_traceback(tmp_path):
    out = tmp_path / "ctl.yaml"
    p = subprocess.run([sys.executable, "-m", "exotune", "export", "--allow-uncertified", str(PAPER), "--sample-rate-hz", "abc",
                        "-o", str(out)], capture_output=True, text=True, cwd=tmp_path, timeout=120,
                       env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert p.returncode == 2, p.stderr
    assert p.stdout == ""
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("exotune: error: --sample-rate-hz: "), p.stderr
    assert not out.exists()


@pytest.mark.parametrize("args", [("--sample-rate-hz", "0"), ("--sample-rate-hz", "abc"), ("--sample-rate-hz", "100")],
                         ids=["zero", "text", "nyquist"])
def test_failing_export_leaves_existing_output_unchanged(tmp_path, args):
    out = tmp_path / "ctl.yaml"
    old = b"# an older controller file\nschema: exotune.controller/1\n"
    out.write_bytes(old)
    before = out.stat().st_mtime_ns
    res = run("export", "--allow-uncertified", PAPER, *args, "-o", out)
    assert res.exit_code == 2, res.output
    assert clean_exit(res)
    assert out.read_bytes() == old
    assert out.stat().st_mtime_ns == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ctl.yaml"]


def _write_doc(path: Path, doc) -> Path:
    path.write_text(yaml.safe_dump(doc, sort_keys=False, allow_unicode=True), encoding="utf-8")
    return path


def test_certify_file_with_missing_key(tmp_path, exported_doc):
    d = copy.deepcopy(exported_doc)
    del d["golden"]
    res = run("certify", _write_doc(tmp_path / "c.yaml", d))
    assert_input_error(res, "golden")


def test_certify_file_with_missing_nested_key(tmp_path, exported_doc):
    d = copy.deepcopy(exported_doc)
    del d["delay_s"]["value"]
    res = run("certify", _write_doc(tmp_path / "c.yaml", d))
    assert_input_error(res, "delay_s.value")


def test_certify_file_with_malformed_sos_row(tmp_path, exported_doc):
    d = copy.deepcopy(exported_doc)
    d["controller"]["filters"][1]["sos"][0] = d["controller"]["filters"][1]["sos"][0][:5]
    res = run("certify", _write_doc(tmp_path / "c.yaml", d))
    assert_input_error(res, "controller.filters[1].sos")


def test_certify_file_with_non_numeric_sos(tmp_path, exported_doc):
    d = copy.deepcopy(exported_doc)
    d["controller"]["filters"][0]["sos"][0][1] = "one"
    res = run("certify", _write_doc(tmp_path / "c.yaml", d))
    assert_input_error(res, "controller.filters[0].sos")


@pytest.mark.parametrize("content", [
    "schema: exotune.controller/1\ncontroller: [1, 2\n  filters: {\n",  # broken YAML syntax
    "this is not a controller file\n",                                   # a YAML scalar
    "- 1\n- 2\n",                                                        # a YAML list
], ids=["syntax", "scalar", "list"])
def test_certify_non_yaml_or_non_mapping_file(tmp_path, content):
    p = tmp_path / "c.yaml"
    p.write_text(content, encoding="utf-8")
    assert_input_error(run("certify", p), str(p))


def test_certify_binary_file(tmp_path):
    p = tmp_path / "c.yaml"
    p.write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00\xff\xfe\x00")
    assert_input_error(run("certify", p), str(p))


def test_certify_missing_file(tmp_path):
    p = tmp_path / "nothing.yaml"
    assert_input_error(run("certify", p), str(p))


@pytest.mark.parametrize("path, field", [
    pytest.param(("gains", "K1"), "gains.K1", id="gains.K1"),
    pytest.param(("plant", "motor_inertia"), "plant.motor_inertia", id="plant.motor_inertia"),
    pytest.param(("golden", "inputs", "theta_m"), "golden.inputs.theta_m", id="golden.inputs.theta_m"),
])
def test_certify_file_missing_key_the_analysis_needs(tmp_path, exported_doc, path, field):
    # keys the analysis indexes (sampled_analysis, plant_from_file, Runtime.step): refused up
    # front, not a KeyError traceback
    d = copy.deepcopy(exported_doc)
    node = d
    for k in path[:-1]:
        node = node[k]
    del node[path[-1]]
    res = run("certify", _write_doc(tmp_path / "c.yaml", d))
    assert_input_error(res, field)


def test_certify_gain_given_as_string(tmp_path, exported_doc):
    d = copy.deepcopy(exported_doc)
    d["gains"]["K1"] = "zero"
    res = run("certify", _write_doc(tmp_path / "c.yaml", d))
    assert_input_error(res, "gains.K1")


def test_export_to_a_directory_is_an_input_error(tmp_path, exported_doc, monkeypatch):
    # the document is built before anything is written; reuse the module's export to stay fast
    monkeypatch.setattr(export_mod, "build_export", lambda *a, **k: copy.deepcopy(exported_doc))
    out = tmp_path / "outdir"
    out.mkdir()
    res = run("export", "--allow-uncertified", PAPER, "--sample-rate-hz", "1000", "-o", out)
    assert_input_error(res, str(out))
    assert out.is_dir() and list(out.iterdir()) == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["outdir"]


def test_certify_names_the_certify_section_field(tmp_path, exported_doc):
    d = copy.deepcopy(exported_doc)
    d["certify"]["humans"][0] = {"kind": "mass", "inertia": [1.0, 0.1], "damping": 0.0}  # lo > hi
    res = run("certify", _write_doc(tmp_path / "c.yaml", d))
    assert_input_error(res, "certify.humans")


def test_certify_catches_a_narrowed_family(tmp_path, exported_doc):
    # narrowing the mass range to where the controller is stable would make the family robust,
    # but the recomputed intervals then differ from the file's predictions
    d = copy.deepcopy(exported_doc)
    d["certify"]["humans"][0]["inertia"] = [0.5, 1.0]
    res = run("certify", _write_doc(tmp_path / "c.yaml", d), "--json")
    assert clean_exit(res), res.exception
    assert res.exit_code == 1, res.output
    rep = json.loads(res.stdout)
    assert rep["certified"] is False
    assert rep["sampled"]["humans"][0]["robust"] is True
    assert "predicted.sampled.humans[0].stable_intervals" in rep["prediction_mismatches"]


def test_certify_catches_deleted_families(tmp_path, exported_doc):
    d = copy.deepcopy(exported_doc)
    assert len(d["predicted"]["sampled"]["humans"]) == 3
    d["certify"]["humans"] = []
    res = run("certify", _write_doc(tmp_path / "c.yaml", d))
    assert clean_exit(res), res.exception
    assert res.exit_code == 1, res.output
    assert "NOT CERTIFIED" in res.stdout


# ------------------------------------------------------------------------------------------
# 3. CLI happy path
# ------------------------------------------------------------------------------------------
def test_export_writes_quantities_with_units(exported, exported_doc):
    out, res = exported
    assert res.stderr == ""
    assert res.stdout.startswith(f"wrote {out}: 1000 Hz")
    assert out.read_text(encoding="utf-8").startswith("# exotune runtime controller file")
    doc = exported_doc
    assert doc["schema"] == "exotune.controller/1"
    assert doc["sample_rate_hz"] == {"value": 1000.0, "unit": "Hz"}
    assert doc["delay_s"]["value"] == pytest.approx(0.001) and doc["delay_s"]["unit"] == "s"
    assert doc["delay_s"]["samples"] == pytest.approx(1.0)
    design = yaml.safe_load(PAPER.read_text(encoding="utf-8"))
    for section in ("plant", "design", "gains"):
        assert isinstance(doc[section], dict) and doc[section], section
        for key, q in doc[section].items():
            if section == "gains" and key == "convention":
                assert isinstance(q, str) and "torque" in q
                continue
            assert isinstance(q, dict) and set(q) == {"value", "unit"}, (section, key, q)
            assert isinstance(q["value"], float) and math.isfinite(q["value"]), (section, key)
            assert isinstance(q["unit"], str) and q["unit"].strip(), (section, key)
    # the numbers are those of the design file …
    assert set(doc["plant"]) == set(design["plant"])
    for k, v in design["plant"].items():
        assert doc["plant"][k]["value"] == v
    for k, v in design["design"].items():
        assert doc["design"][k]["value"] == v
    assert doc["plant"]["motor_inertia"]["unit"] == "kg·m²"
    assert doc["plant"]["sea_stiffness"]["unit"] == "N·m/rad"
    # … and the gains those of `exotune design` (independent command), in the same units
    dres = run("design", PAPER, "--json")
    assert dres.exit_code == 0, dres.output
    dj = json.loads(dres.stdout)
    assert set(doc["gains"]) == set(dj["gains"]) | {"convention"}
    for k, v in dj["gains"].items():
        assert doc["gains"][k]["value"] == pytest.approx(v, rel=1e-12, abs=1e-12), k
        assert doc["gains"][k]["unit"].split()[0] == dj["units"][k].split()[0], k


def test_certify_paper_example_is_not_certified(exported):
    res = run("certify", exported[0])
    assert clean_exit(res), res.exception
    assert res.exit_code == 1, res.output
    assert res.stderr == ""
    out = res.stdout
    assert "NOT CERTIFIED" in out
    assert "\nCERTIFIED" not in out
    reasons = [ln for ln in out.splitlines() if ln.startswith("  - ")]
    assert any(ln.startswith("  - mass inertia in [0.001, 1]") and "stable only in" in ln for ln in reasons), out
    # the spring family is robust and is not a reason
    assert not any("spring" in ln for ln in reasons)
    assert "spring stiffness [1, 10000] N·m/rad: robust" in out


def test_certify_json_paper_example(paper_certify_json):
    res = paper_certify_json
    assert res.exit_code == 1, res.output
    rep = json.loads(res.stdout)  # exactly one JSON object, nothing else on stdout
    assert isinstance(rep, dict)
    assert {"certified", "sampled", "golden", "problems"} <= set(rep)
    assert rep["certified"] is False
    assert rep["problems"] and any("mass inertia" in p for p in rep["problems"])
    assert rep["golden"]["samples"] == 200
    assert rep["golden"]["max_abs_error"]["value"] <= 1e-9
    humans = {h["kind"]: h for h in rep["sampled"]["humans"]}
    assert humans["mass"]["robust"] is False and humans["spring"]["robust"] is True
    lo, hi = humans["mass"]["stable_intervals"][0]
    assert 0.001 < lo < 0.1 and hi == pytest.approx(1.0)
    assert rep["sampled"]["free_stable"] is True and rep["sampled"]["locked_stable"] is True


def test_certify_restricted_design_is_certified(tmp_path, paper_certify_json):
    rep = json.loads(paper_certify_json.stdout)
    lightest = next(h for h in rep["sampled"]["humans"] if h["kind"] == "mass")["stable_intervals"][0][0]
    lo = max(0.01, 2.0 * lightest)
    assert lo < 1.0
    raw = yaml.safe_load(PAPER.read_text(encoding="utf-8"))
    raw["humans"] = [{"kind": "mass", "inertia": [lo, 1.0], "damping": 0.0},
                     {"kind": "spring", "stiffness": [1.0, 10000.0], "damping": 0.0}]
    design = tmp_path / "robust.yaml"
    design.write_text(yaml.safe_dump(raw, sort_keys=False), encoding="utf-8")
    out = tmp_path / "robust_ctl.yaml"
    res = run("export", design, "--sample-rate-hz", "1000", "-o", out)
    assert res.exit_code == 0, (res.output, res.exception)
    cres = run("certify", out)
    assert clean_exit(cres), cres.exception
    assert cres.exit_code == 0, cres.output
    lines = cres.stdout.strip().splitlines()
    assert lines[-1] == "CERTIFIED"
    assert "NOT CERTIFIED" not in cres.stdout
    assert any(ln.strip().startswith("mass inertia") and ": robust;" in ln for ln in lines), cres.stdout
    assert any(ln.strip().startswith("spring stiffness") and ": robust;" in ln for ln in lines), cres.stdout


# ------------------------------------------------------------------------------------------
# 4. second-order sections: sos_ss and the runtime's SosFilter against scipy.signal.sosfilt
# ------------------------------------------------------------------------------------------
_coef = st.one_of(st.just(0.0), st.floats(-2.0, 2.0))
_radius = st.one_of(st.just(0.0), st.floats(0.0, 0.95))  # |pole| <= 0.95, poles at z = 0 included


@st.composite
def stable_section(draw):
    kind = draw(st.sampled_from(["complex", "two_real", "one_real"]))
    b = [draw(_coef), draw(_coef), draw(_coef)]
    if kind == "complex":
        r, th = draw(_radius), draw(st.floats(0.01, math.pi - 0.01))
        a = [1.0, -2.0 * r * math.cos(th), r * r]
    elif kind == "two_real":
        p1 = draw(_radius) * draw(st.sampled_from([-1.0, 1.0]))
        p2 = draw(_radius) * draw(st.sampled_from([-1.0, 1.0]))
        a = [1.0, -(p1 + p2), p1 * p2]
    else:  # first-order section, as zpk2sos writes it for an odd order
        p = draw(_radius) * draw(st.sampled_from([-1.0, 1.0]))
        a = [1.0, -p, 0.0]
        if draw(st.booleans()):
            b[2] = 0.0
    return b + a


sos_strategy = st.lists(stable_section(), min_size=1, max_size=3).map(np.array)
input_strategy = st.integers(0, 2**32 - 1).map(lambda seed: np.random.default_rng(seed).standard_normal(60))


def _simulate(A, B, C, D, u):
    x = np.zeros(A.shape[0])
    y = np.empty(len(u))
    for k, uk in enumerate(u):
        y[k] = (C @ x).item() + D.item() * uk
        x = A @ x + B[:, 0] * uk
    return y


def _assert_close(y, ref, rtol=1e-9):
    scale = float(np.max(np.abs(ref)))
    np.testing.assert_allclose(y, ref, rtol=0, atol=rtol * max(scale, 1e-300))


@settings(max_examples=150, deadline=None)
@given(sos=sos_strategy, u=input_strategy)
def test_sos_ss_simulates_like_sosfilt(sos, u):
    A, B, C, D = sos_ss(sos)
    n = A.shape[0]
    assert len(sos) <= n <= 2 * len(sos)
    assert A.shape == (n, n) and B.shape == (n, 1) and C.shape == (1, n) and D.shape == (1, 1)
    _assert_close(_simulate(A, B, C, D, u), scipy.signal.sosfilt(sos, u))


@settings(max_examples=150, deadline=None)
@given(sos=sos_strategy, u=input_strategy)
def test_sos_filter_steps_like_sosfilt(sos, u):
    f = SosFilter(sos)
    y = np.array([f.step(x) for x in u])
    ref = scipy.signal.sosfilt(sos, u)
    _assert_close(y, ref)
    # reset really returns to the zero state
    f.reset()
    _assert_close(np.array([f.step(x) for x in u]), ref)


@settings(max_examples=150, deadline=None)
@given(sos=sos_strategy, u=input_strategy)
def test_sos_filter_is_affine_feedthrough_plus_peek(sos, u):
    f = SosFilter(sos)
    assert f.feedthrough == pytest.approx(float(np.prod(sos[:, 0])), rel=1e-15, abs=0)
    ref = scipy.signal.sosfilt(sos, u)
    scale = max(float(np.max(np.abs(ref))), 1e-300)
    for k, x in enumerate(u):
        h = f.peek(0.0)
        assert f.peek(0.0) == h  # peek does not advance the state
        predicted = f.feedthrough * x + h
        assert f.peek(x) == pytest.approx(predicted, rel=0, abs=1e-12 * scale)
        y = f.step(x)
        assert y == pytest.approx(predicted, rel=0, abs=1e-12 * scale), k
        assert y == pytest.approx(ref[k], rel=0, abs=1e-9 * scale), k


def test_sos_ss_sections_with_poles_or_zeros_at_origin():
    # regression: the tf2ss-based sos_ss refused a2 = 0 with b2 != 0 ("improper section"), a
    # proper section (pole at z = 0) that SosFilter and sosfilt run fine; an FIR section too
    u = np.random.default_rng(1).standard_normal(30)
    for sos in (np.array([[1.0, 0.5, 0.25, 1.0, -0.5, 0.0]]),                   # (z² + z/2 + 1/4) / (z (z − 1/2))
                np.array([[0.25, 0.5, 0.25, 1.0, 0.0, 0.0], [1.0, -0.3, 0.0, 1.0, -0.9, 0.2]])):  # FIR, then IIR
        ref = scipy.signal.sosfilt(sos, u)
        f = SosFilter(sos)
        _assert_close(np.array([f.step(x) for x in u]), ref)
        _assert_close(_simulate(*sos_ss(sos), u), ref)


def test_sos_ss_section_of_tiny_gain():
    # regression: the tf2ss-based sos_ss dropped numerator coefficients <= 1e-14 (scipy's
    # normalize), e.g. the first section of a 4th-order low-pass 1/(1 + s/ω)^4 at 0.4 Hz sampled
    # at 4 kHz, where zpk2sos puts the whole gain (≈ 1e-14): its DC gain came out 0.75
    wn, fs = 2 * math.pi * 0.4, 4000.0
    sos = tustin_sos([1.0], np.poly([-wn] * 4)[::-1] / wn**4, fs, 0.4)
    assert abs(sos[0, 0]) < 1e-14
    u = np.ones(3000)  # a step: the output climbs towards the DC gain 1
    ref = scipy.signal.sosfilt(sos, u)
    assert 0.05 < ref[-1] < 1.0
    _assert_close(_simulate(*sos_ss(sos), u), ref, rtol=1e-8)


# ------------------------------------------------------------------------------------------
# 5. tustin_sos: exact at the prewarp frequency, equal to python-control's prewarped Tustin
# ------------------------------------------------------------------------------------------
@st.composite
def continuous_tf(draw, fmin_rel=None):
    """(num_asc, den_asc, fs, f_w): a random stable proper rational function of order 1–4, its
    poles and zeros of natural frequency in [0.5 Hz (or fmin_rel·fs), 0.4 fs]."""
    fs = draw(st.sampled_from([250.0, 1000.0, 4000.0]))
    order = draw(st.integers(1, 4))
    wmax = 2 * math.pi * 0.4 * fs
    wmin = 2 * math.pi * (0.5 if fmin_rel is None else fmin_rel * fs)
    logw = st.floats(math.log(wmin), math.log(wmax))

    def roots(count, left_only):
        out = []
        while len(out) < count:
            wn = math.exp(draw(logw))
            if count - len(out) >= 2 and draw(st.booleans()):
                z = draw(st.floats(0.1, 0.99))
                re = -z * wn if left_only or draw(st.booleans()) else z * wn
                im = wn * math.sqrt(1 - z * z)
                out += [complex(re, im), complex(re, -im)]
            else:
                out.append(-wn if left_only or draw(st.booleans()) else wn)
        return out

    poles = roots(order, left_only=True)
    zeros = roots(draw(st.integers(0, order)), left_only=False)
    k = draw(st.floats(0.1, 10.0)) * draw(st.sampled_from([-1.0, 1.0]))
    # normalize so that the response is O(1): H(s) = k Π(1 − s/z) / Π(1 − s/p)
    num_desc = np.real(np.poly(zeros)) / np.real(np.prod(-np.asarray(zeros))) * k if zeros else np.array([k])
    den_desc = np.real(np.poly(poles)) / np.real(np.prod(-np.asarray(poles)))
    f_w = draw(st.floats(0.01, 0.45)) * fs
    return num_desc[::-1].copy(), den_desc[::-1].copy(), fs, f_w


def _h_cont(num_asc, den_asc, w):
    s = 1j * w
    return np.polyval(num_asc[::-1], s) / np.polyval(den_asc[::-1], s)


@settings(max_examples=120, deadline=None)
@given(tf=continuous_tf())
def test_tustin_sos_exact_at_prewarp_frequency(tf):
    num, den, fs, f_w = tf
    sos = tustin_sos(num, den, fs, f_w)
    assert sos.ndim == 2 and sos.shape[1] == 6 and sos.shape[0] == (den.size - 1 + 1) // 2
    np.testing.assert_array_equal(sos[:, 3], 1.0)
    # the discrete filter is stable (Tustin maps the open left half plane into the unit disc)
    poles = np.concatenate([np.roots(row[3:]) for row in sos])
    assert np.all(np.abs(poles) < 1.0)
    w = 2 * math.pi * f_w
    _, hd = scipy.signal.sosfreqz(sos, worN=np.array([w / fs]))
    hc = _h_cont(num, den, w)
    np.testing.assert_allclose(hd[0], hc, rtol=1e-8)
    # elsewhere the prewarped bilinear transform is the continuous response on the warped axis,
    # H_d(e^{jω T}) = H(j Ω) with Ω = ω_w tan(ω T / 2) / tan(ω_w T / 2), up to Nyquist
    Ts = 1.0 / fs
    wd = 2 * math.pi * np.array([0.002, 0.05, 0.2, 0.35, 0.49]) * fs
    _, hd = scipy.signal.sosfreqz(sos, worN=wd * Ts)
    omega = w * np.tan(wd * Ts / 2) / math.tan(w * Ts / 2)
    np.testing.assert_allclose(hd, _h_cont(num, den, omega), rtol=1e-8)


# python-control returns an expanded polynomial in z, whose response near clustered poles close to
# z = 1 (slow poles at a high sample rate) is far less accurate than the sections' (the identity on
# the warped axis above holds to 1e-8 there): keep its poles at least 1 % of fs away from s = 0.
# (its companion-form state space is badly scaled for poles of thousands of rad/s: scipy's
# LinAlgWarning there is about scaling, the comparison below is what counts)
@pytest.mark.filterwarnings("ignore::scipy.linalg.LinAlgWarning")
@settings(max_examples=60, deadline=None)
@given(tf=continuous_tf(fmin_rel=0.01))
def test_tustin_sos_matches_python_control(tf):
    control = pytest.importorskip("control")
    num, den, fs, f_w = tf
    sos = tustin_sos(num, den, fs, f_w)
    Ts = 1.0 / fs
    lead = den[-1]  # monic denominator: the same function, better conditioned for python-control
    sysd = control.sample_system(control.tf(num[::-1] / lead, den[::-1] / lead), Ts, method="tustin",
                                 prewarp_frequency=2 * math.pi * f_w)
    freqs = np.array([0.003, 0.05, 0.17, 0.31]) * fs
    wd = 2 * math.pi * freqs / fs
    _, hd = scipy.signal.sosfreqz(sos, worN=wd)
    hc = np.array([complex(np.squeeze(sysd(np.exp(1j * x)))) for x in wd])
    np.testing.assert_allclose(hd, hc, rtol=1e-7)


def test_tustin_sos_without_prewarp_is_plain_bilinear():
    # first-order low-pass 1/(1 + s/ω_c): plain Tustin, against scipy.signal.bilinear
    wc, fs = 2 * math.pi * 50.0, 1000.0
    sos = tustin_sos([1.0], [1.0, 1.0 / wc], fs)
    b, a = scipy.signal.bilinear([1.0], [1.0 / wc, 1.0], fs)
    w = np.linspace(0.01, 3.0, 7)
    _, h_sos = scipy.signal.sosfreqz(sos, worN=w)
    _, h_ba = scipy.signal.freqz(b, a, worN=w)
    np.testing.assert_allclose(h_sos, h_ba, rtol=1e-12)
    # and without prewarping the response at ω_c is not the continuous one (warping is real)
    _, h_c = scipy.signal.sosfreqz(sos, worN=np.array([wc / fs]))
    assert abs(h_c[0] - 1.0 / (1.0 + 1j)) > 1e-3


def test_tustin_sos_refuses_an_improper_block():
    with pytest.raises(ValueError):
        tustin_sos([0.0, 0.0, 1.0], [1.0, 1.0], 1000.0, 10.0)


def _pred_interval_list(d):
    d["predicted"]["sampled"]["humans"][0]["stable_intervals"][0][0] = []


def _pred_interval_text(d):
    d["predicted"]["sampled"]["humans"][1]["stable_intervals"][0][1] = "abc"


def _pred_family_null(d):
    d["predicted"]["sampled"]["humans"][1] = None


def _pred_family_list(d):
    d["predicted"]["sampled"]["humans"][1] = [1, 2]


def _pred_families_number(d):
    d["predicted"]["sampled"]["humans"] = 1e300


def _pred_families_bool(d):
    d["predicted"]["sampled"]["humans"] = True


def _pred_intervals_missing(d):
    del d["predicted"]["sampled"]["humans"][0]["stable_intervals"]


@pytest.mark.parametrize("mutate", [_pred_interval_list, _pred_interval_text, _pred_family_null, _pred_family_list,
                                    _pred_families_number, _pred_families_bool, _pred_intervals_missing],
                         ids=lambda f: f.__name__)
def test_certify_malformed_predictions_fail_certification_cleanly(tmp_path, exported_doc, mutate):
    """The file's predicted section is free-form (informational), so certify must not trust its
    shape: a malformed prediction is a prediction mismatch (exit 1, named), never a traceback.
    (Found by fuzzing the shipped controller file.)"""
    d = copy.deepcopy(exported_doc)
    mutate(d)
    res = run("certify", _write_doc(tmp_path / "c.yaml", d), "--json")
    assert clean_exit(res), f"uncaught {res.exception!r}"
    assert res.exit_code == 1, res.output
    rep = json.loads(res.stdout)
    assert rep["certified"] is False
    assert any(m.startswith("predicted.sampled.humans") for m in rep["prediction_mismatches"]), rep["prediction_mismatches"]
