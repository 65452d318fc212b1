"""The typed model of a controller file (:class:`exotune.controllerfile.model.ControllerFile`,
docs/controller-file.md): built by one function from the validated mapping, it gives that mapping
back unchanged (writing it back is byte-identical), its typed fields are the file's values, a
malformed file is refused with the same error (field and reason) as before the model existed, and
no module outside the model spells the file's ``"value"`` key.
"""

from __future__ import annotations

import ast
import copy
import dataclasses
from pathlib import Path

import numpy as np
import pytest
import yaml

from exotune.config import read_yaml
from exotune.controllerfile import (ControllerFile, Runtime, as_controller_file, build_export, checked_controller,
                                    checked_controller_file, design_at_rate, export_design, load_controller,
                                    load_controller_file, write_controller)
from exotune.controllerfile.fileio import discrete_from_file, schedule_entry_doc
from exotune.controllerfile.certify import check_built_from_design, golden_problems
from exotune.errors import ConfigError

ROOT = Path(__file__).resolve().parents[2]
PKG = ROOT / "exotune"


def _shipped_controller_files() -> list[Path]:
    """Every controller file under examples/ and results/ (YAML whose schema is exotune.controller/1)."""
    out = []
    for d in ("examples", "results"):
        for p in sorted((ROOT / d).rglob("*.yaml")):
            if "schema: exotune.controller/1" in p.read_text(encoding="utf-8", errors="replace"):
                out.append(p)
    return out


@pytest.fixture(scope="module")
def exported(tmp_path_factory) -> Path:
    """A freshly exported controller file (the scheduled example at 1 kHz: DOB, gain schedule)."""
    out = tmp_path_factory.mktemp("model") / "scheduled.yaml"
    export_design(ROOT / "examples" / "scheduled.yaml", 1000.0, out)
    return out


def _fast_doc(precision: str | None = None) -> dict:
    """A valid controller document without the (slow) sampled-data predictions."""
    raw = read_yaml(ROOT / "examples" / "scheduled.yaml")
    if precision:
        raw["implementation"]["precision"] = precision
    doc = build_export(design_at_rate(raw, 1000.0), 1000.0, analyses=False)
    doc["predicted"] = {}
    for e in (doc.get("gain_schedule") or {}).get("entries", []):
        e["predicted_sampled"] = {}
    return yaml.safe_load(yaml.safe_dump(doc, sort_keys=False, allow_unicode=True))


@pytest.fixture(scope="module")
def doc64() -> dict:
    return _fast_doc()


@pytest.fixture(scope="module")
def doc32() -> dict:
    return _fast_doc("float32")


def test_the_shipped_controller_files_are_found():
    assert _shipped_controller_files(), "no controller file under examples/ or results/"


@pytest.mark.parametrize("path", _shipped_controller_files(), ids=lambda p: p.relative_to(ROOT).as_posix())
def test_shipped_file_round_trips_byte_identically(path, tmp_path):
    cf = load_controller_file(path)
    assert cf.to_dict() == load_controller(path)
    write_controller(cf.to_dict(), tmp_path / "back.yaml")
    assert (tmp_path / "back.yaml").read_bytes() == path.read_bytes()


def test_exported_file_round_trips_byte_identically(exported, tmp_path):
    cf = load_controller_file(exported)
    assert cf.to_dict() == load_controller(exported)
    assert ControllerFile.from_dict(cf.to_dict()) == cf
    write_controller(cf.to_dict(), tmp_path / "back.yaml")
    assert (tmp_path / "back.yaml").read_bytes() == exported.read_bytes()


def _quantities(section: dict) -> tuple[dict, dict]:
    return ({k: q["value"] for k, q in section.items() if isinstance(q, dict)},
            {k: q["unit"] for k, q in section.items() if isinstance(q, dict)})


def _check_controller(c, raw: dict) -> None:
    assert c.gains == {s: g["gain"] for s, g in raw["gains"].items()}
    assert list(c.gains) == list(raw["gains"])  # the file's order: the runtime sums in it
    assert c.gain_units == {s: g["unit"] for s, g in raw["gains"].items()}
    assert [f.name for f in c.filters] == [f["name"] for f in raw["filters"]]
    for f, r in zip(c.filters, raw["filters"]):
        assert (f.input, f.input_unit, f.output_unit, f.unit) == (r["input"], r["input_unit"], r["output_unit"], r["unit"])
        assert (f.discretization, f.description, f.prewarp_hz) == (r["discretization"], r.get("description"), r.get("prewarp_hz"))
        assert f.continuous == r.get("continuous")
        assert [list(row) for row in f.sos] == r["sos"]
    real = raw.get("realization")
    if real is None:
        assert c.realization is None
        return
    R = c.realization
    assert (R.precision, R.form, R.note, R.loop_divisor) == (real["precision"], real["form"], real.get("note"),
                                                             real["loop_divisor"])
    assert R.gains == real["gains"]
    assert [(f.name, f.input, [list(s) for s in f.sections]) for f in R.filters] == \
        [(f["name"], f["input"], f["sections"]) for f in real["filters"]]


@pytest.mark.parametrize("which", ["exported", "doc32"])
def test_typed_fields_are_the_raw_values(which, request):
    """Every typed field against the mapping, key by key (the one place besides the model that
    spells the file's keys)."""
    if which == "exported":
        raw = load_controller(request.getfixturevalue("exported"))
    else:
        raw = request.getfixturevalue("doc32")
    cf = checked_controller_file(copy.deepcopy(raw))
    assert cf.schema == raw["schema"]
    assert (cf.sample_rate_hz, cf.sample_rate.value_hz, cf.sample_rate.unit) == (
        raw["sample_rate_hz"]["value"], raw["sample_rate_hz"]["value"], raw["sample_rate_hz"]["unit"])
    assert cf.sample_rate.to_dict() == raw["sample_rate_hz"]
    d = raw["delay_s"]
    assert (cf.delay_s, cf.delay.unit, cf.delay.samples, cf.delay.note) == (d["value"], d["unit"], d.get("samples"), d.get("note"))
    for sec, typed in (("plant", cf.plant), ("design", cf.design)):
        values, units = _quantities(raw[sec])
        assert typed.values() == values and list(typed.values()) == list(values)
        assert typed.units == units
        for k, v in values.items():
            assert getattr(typed, k) == v
    assert cf.plant.to_plant().motor_inertia == raw["plant"]["motor_inertia"]["value"]
    values, units = _quantities(raw["gains"])
    assert {k: getattr(cf.gains, k) for k in values} == values and cf.gains.units == units
    assert cf.gains.convention == raw["gains"].get("convention")
    assert cf.signals == raw["signals"]
    _check_controller(cf.controller, raw["controller"])
    assert cf.controller.equation == raw["controller"]["equation"]
    dob = raw["dob"]
    assert (cf.dob.q_cutoff_hz, cf.dob.q_cutoff_unit, cf.dob.q_damping, cf.dob.q_damping_unit) == (
        dob["q_cutoff_hz"]["value"], dob["q_cutoff_hz"]["unit"], dob["q_damping"]["value"], dob["q_damping"]["unit"])
    assert list(cf.dob.filters) == dob["filters"]
    sched = raw["gain_schedule"]
    assert (cf.gain_schedule.variable, cf.gain_schedule.unit) == (sched["variable"], sched["unit"])
    assert len(cf.schedule_entries) == len(sched["entries"])
    for e, r in zip(cf.schedule_entries, sched["entries"]):
        assert (e.joint_angle_rad, e.ratio) == (r["joint_angle_rad"], r["ratio"])
        assert e.plant.values() == _quantities(r["plant"])[0]
        assert {k: getattr(e.gains, k) for k in _quantities(r["gains"])[0]} == _quantities(r["gains"])[0]
        _check_controller(e.controller, r["controller"])
        assert e.predicted_sampled == r["predicted_sampled"]
        assert (list(e.golden_tau_cmd), e.golden_tau_cmd_unit) == (r["golden_tau_cmd"]["values"], r["golden_tau_cmd"]["unit"])
        assert e.to_dict() == r
        view = cf.entry_view(e)
        assert view.to_dict() == schedule_entry_doc(raw, r)
        assert view == as_controller_file(schedule_entry_doc(raw, r))
    assert cf.gain_schedule.nearest(sched["entries"][1]["joint_angle_rad"] + 1e-6) == cf.schedule_entries[1]
    # beyond the table: its end entries, also where |q − angle| rounds to a tie (it gave entry 0 for 1e308)
    assert cf.gain_schedule.nearest(1e308) == cf.schedule_entries[-1]
    assert cf.gain_schedule.nearest(-1e308) == cf.schedule_entries[0]
    tr = raw["transmission"]
    assert (list(cf.transmission.joint_angle_rad), list(cf.transmission.ratio)) == (tr["joint_angle_rad"], tr["ratio"])
    assert cf.gain_schedule_note == raw["gain_schedule_note"]
    assert (list(cf.certify.humans), list(cf.certify.environment)) == (raw["certify"]["humans"], raw["certify"]["environment"])
    req = raw["requirements"]
    assert (cf.requirements.latency_margin_s, cf.requirements.unit, cf.requirements.source) == (
        req["latency_margin_s"], req.get("unit", "s"), req.get("source"))
    assert cf.requirements.to_dict() == req
    p = raw["predicted"]
    assert (cf.predicted.continuous, cf.predicted.latency_margin, cf.predicted.sampled,
            cf.predicted.sampled_latency_margin) == (p.get("continuous"), p.get("latency_margin"), p.get("sampled"),
                                                     p.get("sampled_latency_margin"))
    g = raw["golden"]
    assert {s: list(v) for s, v in cf.golden.inputs.items()} == {s: v["values"] for s, v in g["inputs"].items()}
    assert list(cf.golden.inputs) == list(g["inputs"])
    assert cf.golden.input_units == {s: v["unit"] for s, v in g["inputs"].items()}
    assert (list(cf.golden.tau_cmd), cf.golden.tau_cmd_unit, cf.golden.note) == (
        g["tau_cmd"]["values"], g["tau_cmd"]["unit"], g.get("note"))
    pr = raw["provenance"]
    assert (cf.provenance.exotune_version, cf.provenance.source, cf.provenance.input_sha256, cf.provenance.created_utc,
            cf.provenance.hand_tuned, list(cf.provenance.uncertified), cf.provenance.allow_uncertified) == (
        pr.get("exotune_version"), pr.get("source"), pr.get("input_sha256"), pr.get("created_utc"),
        pr.get("hand_tuned", False), pr.get("uncertified") or [], bool(pr.get("allow_uncertified")))
    assert cf.provenance.to_dict() == pr
    impl = raw["implementation"]
    assert (cf.implementation.mapping, cf.implementation.delay_s, cf.implementation.sample_rate_hz,
            cf.implementation.precision) == (impl, impl.get("delay_s"), impl.get("sample_rate_hz"), impl.get("precision"))


def test_the_model_is_frozen_and_owns_its_mapping(doc64):
    raw = copy.deepcopy(doc64)
    cf = ControllerFile.from_dict(raw)
    with pytest.raises(dataclasses.FrozenInstanceError):
        cf.sample_rate = None  # type: ignore[misc]
    raw["delay_s"]["value"] = 0.5  # the caller's mapping changes later: the model does not
    raw["controller"]["filters"][0]["sos"][0][0] = 7.0
    assert cf.delay_s == doc64["delay_s"]["value"] and cf.to_dict() == doc64
    out = cf.to_dict()
    out["plant"]["motor_inertia"]["value"] = 1.0  # nor does an edit of what to_dict gave
    assert cf.to_dict() == doc64
    assert as_controller_file(cf) is cf


def test_views_of_the_file(doc64):
    cf = ControllerFile.from_dict(doc64)
    late = cf.with_delay(0.0025)
    assert late.delay_s == 0.0025 and late.delay.samples == 0.0025 * cf.sample_rate_hz
    assert late.to_dict()["delay_s"] == {**doc64["delay_s"], "value": 0.0025, "samples": 0.0025 * cf.sample_rate_hz}
    assert late.controller == cf.controller and cf.delay_s == doc64["delay_s"]["value"]
    bare = cf.without_dob()
    assert bare.dob is None and not any(f.name.startswith("dob_") for f in bare.controller.filters)
    assert [f.name for f in bare.controller.filters] == [f["name"] for f in doc64["controller"]["filters"]
                                                         if not f["name"].startswith("dob_")]


def test_functions_take_the_model_or_the_mapping(doc64, doc32):
    for doc in (doc64, doc32):
        cf = ControllerFile.from_dict(doc)
        a, b = discrete_from_file(cf), discrete_from_file(doc)
        for m in ("Ac", "Bc", "Cc", "Dc"):
            np.testing.assert_array_equal(getattr(a, m), getattr(b, m))
        ins = {s: np.asarray(v["values"], float) for s, v in doc["golden"]["inputs"].items()}
        np.testing.assert_array_equal(Runtime(cf).run(ins), Runtime(doc).run(ins))
        assert golden_problems(cf) == golden_problems(doc)
        check_built_from_design(cf)


def _set(path, value):
    def f(d):
        for k in path[:-1]:
            d = d[k]
        d[path[-1]] = value(d) if callable(value) else value
    return f


def _first_gain_unit(d):
    d["controller"]["gains"][next(iter(d["controller"]["gains"]))]["unit"] = "x"


def _singular_loop(d):
    cmd = [f for f in d["controller"]["filters"] if f["input"] == "tau_cmd"][0]
    d["controller"]["filters"].append({**cmd, "name": "dob_extra", "sos": [[1.0 - cmd["sos"][0][0], 0.0, 0.0, 1.0, 0.0, 0.0]]})


def _scaled(path, factor):
    def f(d):
        for k in path[:-1]:
            d = d[k]
        d[path[-1]] *= factor
    return f


def _copied(path_from, path_to):
    def f(d):
        v = d
        for k in path_from:
            v = v[k]
        _set(path_to, copy.deepcopy(v))(d)
    return f


ENTRY0, ENTRY1 = ("gain_schedule", "entries", 0), ("gain_schedule", "entries", 1)
# (base document, mutation): the float32 realization of entry 0 is moved into the float64 file by
# "f64_entry_has_realization" (see test_malformed_file_gives_the_same_error)
MUTATIONS = {
    "plant_unit": _set(("plant", "motor_inertia", "unit"), "g·m²"),
    "design_unit": _set(("design", "zeta", "unit"), "%"),
    "six_unit": _set(("gains", "K2_hat", "unit"), "N·m/rad"),
    "delay_samples": _set(("delay_s", "samples"), 7.0),
    "rate_limit": _set(("sample_rate_hz", "value"), 1e12),
    "plant_limit": _set(("plant", "motor_inertia", "value"), 1e9),
    "entry_plant_limit": _set(ENTRY0 + ("plant", "sea_stiffness", "value"), 1e15),
    "signals": _set(("signals", "output"), {"tau_cmd": "N.m"}),
    "gain_unit": _first_gain_unit,
    "filter_input_unit": _set(("controller", "filters", 0, "input_unit"), "deg"),
    "filter_dup": _set(("controller", "filters", 1, "name"), lambda c: "cuff_path"),
    "filter_empty_name": _set(("controller", "filters", 1, "name"), ""),
    "golden_unit": _set(("golden", "inputs", "tau_c", "unit"), "N.m"),
    "golden_short": _set(("golden", "tau_cmd", "values"), [0.0] * 5),
    "golden_len": _set(("golden", "inputs", "theta_m", "values"), lambda v: v["values"][:150]),
    "golden_out_unit": _set(("golden", "tau_cmd", "unit"), "Nm"),
    "dob_q_not_map": _set(("dob", "q_cutoff_hz"), 5),
    "dob_q_bool": _set(("dob", "q_damping", "value"), True),
    "dob_q_neg": _set(("dob", "q_damping", "value"), -1.0),
    "dob_q_unit": _set(("dob", "q_cutoff_hz", "unit"), "kHz"),
    "dob_filters_str": _set(("dob", "filters"), "dob_motor"),
    "dob_filters_empty": _set(("dob", "filters"), []),
    "dob_none": _set(("dob",), None),
    "dob_filters_unknown": _set(("dob", "filters"), ["nope"]),
    "transmission_none": _set(("transmission",), None),
    "schedule_none": _set(("gain_schedule",), None),
    "entry_dup_angle": _copied(ENTRY0 + ("joint_angle_rad",), ENTRY1 + ("joint_angle_rad",)),
    "transmission_ratio_len": _set(("transmission", "ratio"), lambda t: t["ratio"][:-1]),
    "entry_ratio": _scaled(ENTRY0 + ("ratio",), 1.5),
    "entry_plant": _scaled(ENTRY1 + ("plant", "motor_inertia", "value"), 1.01),
    "entry_plant_unit": _set(ENTRY1 + ("plant", "joint_inertia", "unit"), "kg"),
    "entry_filter_unit": _set(ENTRY0 + ("controller", "filters", 0, "unit"), "x"),
    "entry_K1": _set(ENTRY0 + ("gains", "K1", "value"), 123.0),
    "entry_K2": _set(ENTRY0 + ("gains", "K2", "value"), 123.0),
    "entry_golden_unit": _set(ENTRY0 + ("golden_tau_cmd", "unit"), "Nm"),
    "K2_mismatch": _set(("gains", "K2", "value"), 0.123),
    "B1_mismatch": _set(("gains", "B1", "value"), 0.123),
    "precision_bad": _set(("implementation", "precision"), "float16"),
    "loop_singular": _singular_loop,
    "schema_str": _set(("sample_rate_hz", "value"), "1000"),
    "schema_extra": _set(("extra_key",), 1),
    "schema_missing": lambda d: d.pop("golden"),
}
MUTATIONS32 = {
    "f32_entry_missing": lambda d: d["gain_schedule"]["entries"][0]["controller"].pop("realization"),
    "f32_top_missing": lambda d: d["controller"].pop("realization"),
    "f32_as64": _set(("implementation", "precision"), "float64"),
}
CERTIFY = {  # refused by certify's design check (after loading)
    "hand_tuned_str": _set(("provenance", "hand_tuned"), "yes"),
    "hand_tuned_null": _set(("provenance", "hand_tuned"), None),
    "amplification": _set(("design", "amplification", "value"), 20.0),
    "impl_delay": _set(("implementation", "delay_s"), 0.002),
    "impl_cutoff": _set(ENTRY0 + ("controller", "filters", 0, "sos", 0, 1), 0.5),
}

# (field, reason) of each malformed document, as exotune gave them before the typed model (commit
# 3353a20, the checks on the raw mapping): the model must not change a single error
BEFORE = {
    'plant_unit': ('plant.motor_inertia.unit',
        "unit 'g·m²', expected 'kg·m²' (exotune.controller/1 fixes every unit)"),
    'design_unit': ('design.zeta.unit',
        "unit '%', expected '1' (exotune.controller/1 fixes every unit)"),
    'six_unit': ('gains.K2_hat.unit',
        "unit 'N·m/rad', expected '1 (N·m/N·m)' (exotune.controller/1 fixes every unit)"),
    'delay_samples': ('delay_s.samples',
        '7.0 samples, but 0.001 s at 1000.0 Hz is 1.0'),
    'rate_limit': ('sample_rate_hz.value',
        'out of the accepted range: must be in [0.001, 1e7] Hz, got 1e+12 '
        '(docs/design-file.md#input-limits-and-accepted-ranges)'),
    'plant_limit': ('plant.motor_inertia.value',
        'out of the accepted range: must be in [1e-9, 1e6] kg·m², got 1e+09 '
        '(docs/design-file.md#input-limits-and-accepted-ranges)'),
    'entry_plant_limit': ('gain_schedule.entries[0].plant.sea_stiffness.value',
        'out of the accepted range: must be in [1e-6, 1e9] N·m/rad, got 1e+15 '
        '(docs/design-file.md#input-limits-and-accepted-ranges)'),
    'signals': ('signals',
        "must be {'inputs': {'theta_m': 'rad', 'omega_m': 'rad/s', 'tau_s': 'N·m', 'dtau_s': "
        "'N·m/s', 'tau_c': 'N·m'}, 'output': {'tau_cmd': 'N·m'}} (the runtime's signals and their "
        'units)'),
    'gain_unit': ('controller.gains.omega_m.unit',
        "unit 'x', expected 'N·m·s/rad' (exotune.controller/1 fixes every unit)"),
    'filter_input_unit': ('controller.filters[0].input_unit',
        "unit 'deg', expected 'N·m' (exotune.controller/1 fixes every unit)"),
    'filter_dup': ('controller.filters[1].name',
        "filter names must be non-empty and unique, got 'cuff_path'"),
    'filter_empty_name': ('controller.filters[1].name',
        "filter names must be non-empty and unique, got ''"),
    'golden_unit': ('golden.inputs.tau_c.unit',
        "unit 'N.m', expected 'N·m' (exotune.controller/1 fixes every unit)"),
    'golden_short': ('golden.tau_cmd.values',
        '5 samples; a golden vector has at least 10'),
    'golden_len': ('golden.inputs.theta_m.values',
        '150 samples, golden.tau_cmd has 200'),
    'golden_out_unit': ('golden.tau_cmd.unit',
        "unit 'Nm', expected 'N·m' (exotune.controller/1 fixes every unit)"),
    'dob_q_not_map': ('dob.q_cutoff_hz',
        'expected {value: a positive number, unit: ...}'),
    'dob_q_bool': ('dob.q_damping',
        'expected {value: a positive number, unit: ...}'),
    'dob_q_neg': ('dob.q_damping',
        'expected {value: a positive number, unit: ...}'),
    'dob_q_unit': ('dob.q_cutoff_hz.unit',
        "unit 'kHz', expected 'Hz' (exotune.controller/1 fixes every unit)"),
    'dob_filters_str': ('dob.filters',
        "expected the (non-empty) list of the DOB's filter names"),
    'dob_filters_empty': ('dob.filters',
        "expected the (non-empty) list of the DOB's filter names"),
    'dob_none': ('dob',
        "null, but controller runs the DOB filter 'dob_command' (on tau_cmd)"),
    'dob_filters_unknown': ('dob.filters[0]',
        "controller has no filter named 'nope'"),
    'transmission_none': ('transmission',
        'a gain schedule and a transmission table come together (one is missing)'),
    'schedule_none': ('gain_schedule',
        'a gain schedule and a transmission table come together (one is missing)'),
    'entry_dup_angle': ('gain_schedule.entries',
        'two entries have the same joint angle'),
    'transmission_ratio_len': ('transmission.ratio',
        'needs one ratio per joint angle'),
    'entry_ratio': ('gain_schedule.entries',
        "the entries' (joint angle, ratio) pairs must be the transmission table's"),
    'entry_plant': ('gain_schedule.entries[1].plant.motor_inertia.value',
        '0.40107099999999996, but the plant at ratio 0.95 has 0.3971 (× ratio²)'),
    'entry_plant_unit': ('gain_schedule.entries[1].plant.joint_inertia.unit',
        "unit 'kg', expected 'kg·m²' (exotune.controller/1 fixes every unit)"),
    'entry_filter_unit': ('gain_schedule.entries[0].controller.filters[0].unit',
        "unit 'x', expected '1 (N·m/N·m)' (exotune.controller/1 fixes every unit)"),
    'entry_K1': ('gain_schedule.entries[0].gains.K1.value',
        '123.0 disagrees with the controller, which runs 0.0 on theta_m (i.e. K1 = -0.0)'),
    'entry_K2': ('gain_schedule.entries[0].gains.K2.value',
        '123.0 disagrees with the controller, which runs -0.8410500000000001 on tau_s (i.e. K2 = '
        '-0.8410500000000001)'),
    'entry_golden_unit': ('gain_schedule.entries[0].golden_tau_cmd.unit',
        "unit 'Nm', expected 'N·m' (exotune.controller/1 fixes every unit)"),
    'K2_mismatch': ('gains.K2.value',
        '0.123 disagrees with the controller, which runs -0.78 on tau_s (i.e. K2 = -0.78)'),
    'B1_mismatch': ('gains.B1.value',
        '0.123 disagrees with the controller, which runs 16.139999999999997 on omega_m (i.e. B1 = '
        '-16.139999999999997)'),
    'precision_bad': ('implementation.precision',
        'must be float64 or float32 (the arithmetic of the target that runs the controller), got '
        "'float16'"),
    'loop_singular': ('controller.filters',
        "the DOB's algebraic loop is singular: the feed-throughs Π b0 of the filters on tau_cmd "
        'add up to 1.0 (must not be 1)'),
    'schema_str': ('sample_rate_hz.value',
        "expected a number, got the string '1000' (a quoted number? remove the quotes)"),
    'schema_extra': ('extra_key',
        'unknown field'),
    'schema_missing': ('golden',
        'missing field'),
    'f32_entry_missing': ('gain_schedule.entries[0].controller.realization',
        'missing: a float32 file (implementation.precision) carries the float32 realization of '
        'every controller'),
    'f32_top_missing': ('controller.realization',
        'missing: a float32 file (implementation.precision) carries the float32 realization of '
        'every controller'),
    'f32_as64': ('controller.realization',
        'present in a float64 file: set implementation.precision: float32, or remove it'),
    'f64_entry_has_realization': ('gain_schedule.entries[0].controller.realization',
        'present in a float64 file: set implementation.precision: float32, or remove it'),
    'hand_tuned_str': ('provenance.hand_tuned',
        "expected true or false, got 'yes'"),
    'hand_tuned_null': ('provenance.hand_tuned',
        'expected true or false, got None'),
    'amplification': ('design.amplification',
        'the controller in this file was not built from its design, plant and implementation '
        'sections (its K2_hat = 7.0 is that of amplification 8.0, not 20.0; gains.K2: the file '
        'has -0.78, its design section and plant give -0.912; and 47 more); export the file again '
        'from its design, or declare a hand-tuned controller with provenance.hand_tuned: true '
        '(certify then certifies only the controller)'),
    'impl_delay': ('implementation',
        'the controller in this file was not built from its design, plant and implementation '
        "sections (implementation.delay_s 0.002 is not the file's delay_s 0.001); export the file "
        'again from its design, or declare a hand-tuned controller with provenance.hand_tuned: '
        'true (certify then certifies only the controller)'),
    'impl_cutoff': ('design',
        'the controller in this file was not built from its design, plant and implementation '
        'sections (gain_schedule.entries[0].controller.filters[0] (cuff_path): DC gain 658.561, '
        'its design section and plant give 1.11265; '
        'gain_schedule.entries[0].controller.filters[cuff_path] is not the filter the '
        'implementation section builds); export the file again from its design, or declare a '
        'hand-tuned controller with provenance.hand_tuned: true (certify then certifies only the '
        'controller)'),}


def test_every_case_has_its_error():
    assert set(BEFORE) == set(MUTATIONS) | set(MUTATIONS32) | set(CERTIFY) | {"f64_entry_has_realization"}


@pytest.mark.parametrize("name", sorted(BEFORE))
def test_malformed_file_gives_the_same_error(name, doc64, doc32, tmp_path):
    if name == "f64_entry_has_realization":
        doc = copy.deepcopy(doc64)
        doc["gain_schedule"]["entries"][0]["controller"]["realization"] = copy.deepcopy(
            doc32["gain_schedule"]["entries"][0]["controller"]["realization"])
    else:
        doc = copy.deepcopy(doc32 if name in MUTATIONS32 else doc64)
        {**MUTATIONS, **MUTATIONS32, **CERTIFY}[name](doc)
    with pytest.raises(ConfigError) as e:
        if name in CERTIFY:
            check_built_from_design(checked_controller_file(doc, "<t>"))
        else:
            checked_controller(doc, "<t>")
    assert (e.value.field, e.value.reason) == BEFORE[name]
    if name in MUTATIONS or name in MUTATIONS32:  # the same from a file on disk
        p = tmp_path / "c.yaml"
        p.write_text(yaml.safe_dump(doc, sort_keys=False, allow_unicode=True))
        with pytest.raises(ConfigError) as e2:
            load_controller_file(p)
        assert (e2.value.field, e2.value.reason) == BEFORE[name]


# Modules that may subscript with the literal "value". The model spells the controller file's keys;
# the others read the {value, unit} quantities of a JSON *report* (analysis, certify, optimize,
# simulate), not a controller file. Every other module reads a controller file through
# exotune.controllerfile.model.ControllerFile.
VALUE_KEY_ALLOWED = {
    "exotune/controllerfile/model.py": "builds ControllerFile from the validated mapping",
    "exotune/analysis/figure_data.py": "the analysis report's critical members",
    "exotune/analysis/plot_data.py": "the analysis report's critical members",
    "exotune/optimization/runner.py": "the optimize report's objective",
    "exotune/plots/analysis.py": "the analysis report's quantities",
    "exotune/plots/simulate.py": "the simulation report's summary",
    "exotune/text/analysis.py": "the analysis report's quantities",
    "exotune/text/certify.py": "the certify report's quantities",
    "exotune/text/margins.py": "the margins report's quantities",
    "exotune/text/optimize.py": "the optimize report's quantities",
    "exotune/text/simulate.py": "the simulation report's quantities",
}


def _value_subscripts(path: Path) -> list[int]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    return [n.lineno for n in ast.walk(tree)
            if isinstance(n, ast.Subscript) and isinstance(n.slice, ast.Constant) and n.slice.value == "value"]


def test_no_module_outside_the_model_subscripts_value():
    """``x["value"]`` (f-strings included) only where VALUE_KEY_ALLOWED says why: a renamed key of
    the controller file then breaks the model, not distant code no type checker sees."""
    bad = []
    for p in sorted(PKG.rglob("*.py")):
        rel = p.relative_to(ROOT).as_posix()
        if rel not in VALUE_KEY_ALLOWED:
            bad += [f"{rel}:{line}" for line in _value_subscripts(p)]
    assert not bad, "subscripts with \"value\" outside the model: " + ", ".join(bad)


def test_the_allowed_list_is_current():
    for rel in VALUE_KEY_ALLOWED:
        assert (ROOT / rel).exists(), f"{rel} no longer exists: remove it from VALUE_KEY_ALLOWED"
    assert _value_subscripts(PKG / "controllerfile" / "model.py")
