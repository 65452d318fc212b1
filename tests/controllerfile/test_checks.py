"""Controller files that ``certify`` used to accept (found by fuzzing in session 6).

Two of them were certified although the controller in the file is unstable:

* an msd *box* human family was skipped (the sampled loop has no edge theorem): now the file is
  not certified, with the reason;
* the rigid-body eigenvalue z = 1 was excused from the descriptive ``gains.K1`` (0) with an
  absolute tolerance of 1e-7, so a tiny positive position feedback in the controller itself —
  an eigenvalue at 1 + 7e-8, a real unstable mode — passed. Now the controller's own θ_m path
  decides whether the structure is grounded.

The others: quoted numbers and booleans taken as numbers, units never checked, redundant
sections contradicting the controller, predictions that were not compared, an empty golden
vector, singular DOB loops giving tracebacks, and a runtime that let one NaN poison its states.
"""

from __future__ import annotations

import copy
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from exotune.controllerfile.certify import certify, position_feedback, sampled_analysis
from exotune.controllerfile.continuation import stable_intervals
from exotune.cli import cli
from exotune.errors import ConfigError
from exotune.controllerfile import build_export, check_controller_file, load_controller, validate_controller
from exotune.controllerfile.runtime import Runtime

ROOT = Path(__file__).resolve().parents[2]
PAPER = ROOT / "examples" / "paper.yaml"


def _design(**humans):
    raw = yaml.safe_load(PAPER.read_text())
    raw["humans"] = humans.get("humans", [{"kind": "mass", "inertia": [0.02, 1.0], "damping": 0.0},
                                          {"kind": "spring", "stiffness": [1.0, 10000.0], "damping": 0.0}])
    return raw


def _export(raw, fs=1000.0) -> dict:
    from exotune.controllerfile import design_at_rate

    return build_export(design_at_rate(raw, fs), fs)


def _write(tmp_path: Path, doc: dict, name="c.yaml") -> Path:
    p = tmp_path / name
    p.write_text(yaml.safe_dump(doc, sort_keys=False, allow_unicode=True))
    return p


def _refresh(doc: dict) -> dict:
    """Make an edited controller self-consistent: golden outputs and sampled predictions
    recomputed from the file's own controller (what a careless or hostile tool would do)."""
    ins = {s: np.asarray(v["values"], float) for s, v in doc["golden"]["inputs"].items()}
    doc["golden"]["tau_cmd"]["values"] = [float(x) for x in Runtime(doc).run(ins)]
    doc["predicted"]["sampled"] = sampled_analysis(doc)
    return yaml.safe_load(yaml.safe_dump(doc, sort_keys=False, allow_unicode=True))


def _certify(tmp_path, doc):
    res = CliRunner().invoke(cli, ["certify", str(_write(tmp_path, doc))])
    assert res.exception is None or isinstance(res.exception, SystemExit), repr(res.exception)
    assert "Traceback" not in res.output
    return res


@pytest.fixture(scope="module")
def doc1k():
    doc = _export(_design())
    assert certify(copy.deepcopy(doc)).to_dict()["certified"]
    return doc


def test_box_family_is_not_certified():
    raw = _design(humans=[{"kind": "mass", "inertia": [0.02, 1.0], "damping": 0.0},
                          {"kind": "msd", "inertia": [0.001, 1.0], "stiffness": [1.0, 100.0], "damping": 0.0}])
    rep = certify(_export(raw)).to_dict()
    assert not rep["certified"]
    assert any("box" in p and "not certified" in p for p in rep["problems"]), rep["problems"]


def test_position_feedback_comes_from_the_controller(doc1k):
    c = copy.deepcopy(doc1k["controller"])
    assert not position_feedback(c)  # the DOB's θ_m filter has a zero at z = 1, no static θ_m gain
    c["gains"]["theta_m"] = {"gain": 1e-4, "unit": "N·m/rad"}
    assert position_feedback(c)
    c["gains"]["theta_m"]["gain"] = 0.0
    assert not position_feedback(c)
    c["filters"].append({**c["filters"][0], "name": "pos", "input": "theta_m", "sos": [[1e-6, 0.0, 0.0, 1.0, 0.0, 0.0]]})
    assert position_feedback(c)


def test_tiny_positive_position_feedback_is_not_certified(doc1k, tmp_path):
    """τ_cmd += 1e-4 N·m/rad · θ_m (positive feedback): one real eigenvalue just outside the unit
    circle. It used to be excused as the rigid-body mode (|λ − 1| ≤ 1e-7, K1 read from the summary)."""
    doc = copy.deepcopy(doc1k)
    doc["controller"]["gains"]["theta_m"] = {"gain": 1e-4, "unit": "N·m/rad"}
    doc["gains"]["K1"]["value"] = -1e-4  # the summary agrees (τ_cmd = −K1 θ_m …)
    doc["provenance"]["hand_tuned"] = True  # no longer the design's controller: certify the controller only
    doc = _refresh(doc)
    check_controller_file(doc)
    sa = doc["predicted"]["sampled"]
    assert not sa["free_stable"] and sa["free_spectral_radius"] > 1.0
    res = _certify(tmp_path, doc)
    assert res.exit_code == 1 and "NOT CERTIFIED" in res.output.upper()
    # a negative (stabilizing) position gain grounds the structure: all eigenvalues inside
    doc["controller"]["gains"]["theta_m"]["gain"] = -1e-4
    doc["gains"]["K1"]["value"] = 1e-4
    doc = _refresh(doc)
    assert doc["predicted"]["sampled"]["free_stable"]


def _set(path, value):
    def f(d):
        *head, last = path
        for k in head:
            d = d[k]
        d[last] = value
    return f


def _dup_filter_name(d):
    d["controller"]["filters"][1]["name"] = d["controller"]["filters"][0]["name"]


def _two_cmd_filters(d):
    f = [x for x in d["controller"]["filters"] if x["input"] == "tau_cmd"][0]
    f["sos"] = [[0.5, 0.0, 0.0, 1.0, 0.0, 0.0]]
    d["controller"]["filters"].append({**f, "name": "dob_command_2"})


MALFORMED = [
    (_set(("sample_rate_hz", "value"), "1000"), "sample_rate_hz.value"),
    (_set(("delay_s", "value"), False), "delay_s.value"),
    (_set(("controller", "gains", "tau_s", "gain"), "-0.78"), "controller.gains.tau_s.gain"),
    (_set(("controller", "gains", "tau_s", "gain"), True), "controller.gains.tau_s.gain"),
    (_set(("plant", "motor_inertia", "unit"), "g·m²"), "plant.motor_inertia.unit"),
    (_set(("controller", "gains", "tau_s", "unit"), "furlongs"), "controller.gains.tau_s.unit"),
    (_set(("golden", "inputs", "theta_m", "unit"), "deg"), "golden.inputs.theta_m.unit"),
    (_set(("signals", "inputs", "theta_m"), "deg"), "signals"),
    (_set(("delay_s", "samples"), 7.0), "delay_s.samples"),
    (_set(("gains", "B1", "value"), 100.0), "gains.B1.value"),
    (_set(("design", "amplification", "value"), -5.0), "design.amplification.value"),
    (_set(("dob", "filters"), ["nonexistent"]), "dob.filters[0]"),
    (_dup_filter_name, "controller.filters[1].name"),
    (_two_cmd_filters, "controller.filters"),
    (_set(("golden", "tau_cmd", "values"), []), "golden.tau_cmd.values"),
    # second round of fuzzing
    (_set(("golden", "inputs", "tau_c", "values"), [0.0] * 50), "golden.inputs.tau_c.values"),
    (_set(("dob",), None), "dob"),
    (_set(("dob", "q_cutoff_hz", "unit"), "kHz"), "dob.q_cutoff_hz.unit"),
    (_set(("dob", "filters"), []), "dob.filters"),
]


@pytest.mark.parametrize("mutate, field", MALFORMED, ids=[f for _, f in MALFORMED])
def test_malformed_controller_file_is_an_input_error(doc1k, tmp_path, mutate, field):
    doc = copy.deepcopy(doc1k)
    mutate(doc)
    with pytest.raises(ConfigError) as e:
        load_controller(_write(tmp_path, doc))
    assert e.value.field.startswith(field), (e.value.field, str(e.value))
    res = _certify(tmp_path, doc)
    assert res.exit_code == 2 and res.stderr.startswith(f"exotune: error: {field}"), res.stderr


def test_six_gain_check_is_not_skipped_by_a_filter_name(doc1k, tmp_path):
    """The six-gain summary is compared with the static gains unless the velocity-filter block
    that carries them exists on its own signal; renaming another filter does not switch it off."""
    doc = copy.deepcopy(doc1k)
    doc["controller"]["gains"]["tau_s"]["gain"] = -0.5  # the summary still says K2 = −0.78
    cuff = [f for f in doc["controller"]["filters"] if f["name"] == "cuff_path"][0]
    cuff["name"] = "spring_torque"  # on tau_c, not on tau_s
    with pytest.raises(ConfigError) as e:
        load_controller(_write(tmp_path, doc))
    assert e.value.field == "gains.K2.value"


def test_filter_prewarp_must_be_positive(doc1k):
    doc = copy.deepcopy(doc1k)
    doc["controller"]["filters"][0]["prewarp_hz"] = -5.0
    with pytest.raises(ConfigError, match="prewarp_hz"):
        validate_controller(doc)


PREDICTIONS = [
    (("humans", 0, "robust"), False, "predicted.sampled.humans[0].robust"),
    (("humans", 0, "range"), [5.0, 6.0], "predicted.sampled.humans[0].range"),
    (("free_spectral_radius",), 1.5, "predicted.sampled.free_spectral_radius"),
    (("free_stable",), False, "predicted.sampled.free_stable"),
    (("humans", 1, "stable_intervals"), [[1.0, 5000.0]], "predicted.sampled.humans[1].stable_intervals"),
]


def _delete_radius(d):
    del d["free_spectral_radius"]


def _predict_a_skipped_family(d):
    d["humans"].append({**d["humans"][0]})
    d["humans"][-1].update(kind="complex_stiffness", parameter="stiffness", skipped="x")


@pytest.mark.parametrize("edit, name", [
    (_delete_radius, "predicted.sampled.free_spectral_radius"),
    (lambda d: d["humans"][0].update(unresolved=[[0.5, 0.6]]), "predicted.sampled.humans[0].unresolved"),
])
def test_missing_or_extra_predictions_are_mismatches(doc1k, tmp_path, edit, name):
    doc = copy.deepcopy(doc1k)
    edit(doc["predicted"]["sampled"])
    rep = certify(load_controller(_write(tmp_path, doc))).to_dict()
    assert not rep["certified"] and name in rep["prediction_mismatches"], rep["prediction_mismatches"]


def test_prediction_for_a_skipped_family_is_a_mismatch(tmp_path):
    raw = _design(humans=[{"kind": "mass", "inertia": [0.02, 1.0], "damping": 0.0},
                          {"kind": "complex_stiffness", "stiffness": [10.0, 1000.0], "eta": 0.2}])
    doc = _export(raw)
    assert certify(copy.deepcopy(doc)).to_dict()["certified"]
    doc["predicted"]["sampled"]["humans"][1].update(robust=True, stable_intervals=[[10.0, 1000.0]])
    rep = certify(load_controller(_write(tmp_path, doc))).to_dict()
    assert "predicted.sampled.humans[1].robust" in rep["prediction_mismatches"], rep["prediction_mismatches"]


@pytest.mark.parametrize("path, value, name", PREDICTIONS, ids=[n for *_, n in PREDICTIONS])
def test_every_sampled_prediction_is_compared(doc1k, tmp_path, path, value, name):
    doc = copy.deepcopy(doc1k)
    d = doc["predicted"]["sampled"]
    for k in path[:-1]:
        d = d[k]
    d[path[-1]] = value
    rep = certify(load_controller(_write(tmp_path, doc))).to_dict()
    assert not rep["certified"] and name in rep["prediction_mismatches"], rep["prediction_mismatches"]


@pytest.fixture(scope="module")
def scheduled():
    from exotune.controllerfile import export_design

    import tempfile

    with tempfile.TemporaryDirectory() as d:
        return export_design(ROOT / "examples" / "scheduled.yaml", 1000.0, Path(d) / "c.yaml").to_dict()


@pytest.mark.parametrize("key, value", [("free_stable", False), ("locked_stable", False)])
def test_schedule_entry_predictions_are_compared(scheduled, tmp_path, key, value):
    doc = copy.deepcopy(scheduled)
    doc["gain_schedule"]["entries"][1]["predicted_sampled"][key] = value
    rep = certify(load_controller(_write(tmp_path, doc))).to_dict()
    assert any(m.startswith("gain_schedule[") and m.endswith(key) for m in rep["prediction_mismatches"]), rep


def test_schedule_entry_with_a_singular_dob_loop_is_an_input_error(scheduled, tmp_path):
    doc = copy.deepcopy(scheduled)
    f = [x for x in doc["gain_schedule"]["entries"][1]["controller"]["filters"] if x["input"] == "tau_cmd"][0]
    f["sos"] = [[1.0] + list(f["sos"][0][1:])] + [list(r) for r in f["sos"][1:]]
    for row in f["sos"][1:]:
        row[0] = 1.0
    with pytest.raises(ConfigError) as e:
        load_controller(_write(tmp_path, doc))
    assert e.value.field == "gain_schedule.entries[1].controller.filters"


def test_schedule_must_match_the_transmission_table(scheduled, tmp_path):
    doc = copy.deepcopy(scheduled)
    del doc["gain_schedule"]["entries"][2:]
    with pytest.raises(ConfigError, match="transmission"):
        load_controller(_write(tmp_path, doc))
    doc = copy.deepcopy(scheduled)
    doc["gain_schedule"] = None
    with pytest.raises(ConfigError) as e:
        load_controller(_write(tmp_path, doc))
    assert e.value.field == "gain_schedule"


def test_schedule_entry_plant_must_be_the_reflected_plant(scheduled, tmp_path):
    """A ratio-1 controller and plant pasted into the 1.25 entry certified although that
    controller is not robust on the real (× 1.5625) plant: the entry's plant must be the top-level
    plant with J_m, B_m, K_s × ratio²."""
    doc = copy.deepcopy(scheduled)
    e = doc["gain_schedule"]["entries"]
    one = [x for x in e if x["ratio"] == 1.0][0]
    other = [i for i, x in enumerate(e) if x["ratio"] != 1.0][-1]
    for k in ("plant", "gains", "controller"):
        e[other][k] = copy.deepcopy(one[k])
    with pytest.raises(ConfigError) as err:
        load_controller(_write(tmp_path, doc))
    assert err.value.field.startswith(f"gain_schedule.entries[{other}].plant.")


def test_schedule_entries_must_run_the_declared_dob(scheduled, tmp_path):
    doc = copy.deepcopy(scheduled)
    c = doc["gain_schedule"]["entries"][1]["controller"]
    c["filters"] = [f for f in c["filters"] if f["name"] != "dob_command"]
    with pytest.raises(ConfigError) as e:
        load_controller(_write(tmp_path, doc))
    assert e.value.field.startswith("dob.filters[")


def test_explicit_yaml_tags_and_huge_integers_are_input_errors(tmp_path):
    text = PAPER.read_text()
    for bad, field in (("!!bool maybe", str(tmp_path / "d.yaml")), ("!!timestamp abc", str(tmp_path / "d.yaml")),
                       ("1" + "0" * 400, "plant.motor_inertia")):
        f = tmp_path / "d.yaml"
        f.write_text(text.replace("motor_inertia: 0.44", f"motor_inertia: {bad}"))
        res = CliRunner().invoke(cli, ["analyze", str(f)])
        assert res.exit_code == 2 and res.stderr.startswith(f"exotune: error: {field}"), (bad, res.stderr, res.exception)


def test_runtime_refuses_an_overflowing_command(doc1k):
    """A finite input too large for floating point (1e308 N·m) used to turn every filter state
    into NaN for ever — with a torque limit, a latched full-scale command."""
    rt, ref = Runtime(doc1k, limit_nm=40.0), Runtime(doc1k, limit_nm=40.0)
    y = {"theta_m": 0.0, "omega_m": 0.0, "tau_s": 0.0, "dtau_s": 0.0, "tau_c": 1e308}
    with pytest.raises(ValueError, match="overflows"):
        rt.step(y)
    y["tau_c"] = 1.0
    assert [rt.step(y) for _ in range(5)] == [ref.step(y) for _ in range(5)]


def test_runtime_refuses_non_finite_inputs(doc1k):
    rt = Runtime(doc1k, limit_nm=40.0)
    y = {"theta_m": 0.01, "omega_m": 0.0, "tau_s": 1.0, "dtau_s": 0.0, "tau_c": 0.5}
    ref = Runtime(doc1k, limit_nm=40.0)
    for bad in (math.nan, math.inf):
        with pytest.raises(ValueError, match="tau_c"):
            rt.step({**y, "tau_c": bad})
    # the refused samples changed nothing
    assert [rt.step(y) for _ in range(5)] == [ref.step(y) for _ in range(5)]
    for angle in (math.nan, math.inf):
        with pytest.raises(ValueError, match="joint_angle_rad"):
            Runtime(doc1k, joint_angle_rad=angle)


def test_refinement_budget_shrinks_with_the_loop_size():
    """A big loop (long delay at a high rate) gets the eigen-solver work of MAX_REFINED values of a
    REF_STATES-state loop: an unresolvable family stops after ≥ 50, not 20 000, values."""
    from exotune.controllerfile import continuation as cmod

    calls = []

    def spectrum(v):  # 400 eigenvalues a hair inside the circle, moving fast with v
        calls.append(v)
        return 0.9999999 * np.exp(1j * np.linspace(0.0, 3.0, 400) * (1.0 + 50.0 * math.log(v)))

    ivs, info = stable_intervals(spectrum, 1.0, 2.0, points=8)
    assert info["unresolved"] and info["refined_points"] <= max(50, int(cmod.MAX_REFINED * (cmod.REF_STATES / 400) ** 3))
    assert info["budget_spent"] and info["loop_states"] == 400
    assert ivs == [[1.0, 2.0]]  # every sampled value is stable: only the unresolved cells say otherwise


def test_overflowing_controller_is_an_input_error(doc1k, tmp_path):
    """A gain of 1e308 is a finite number, but the loop matrix overflows: exit 2 naming the
    controller (it was a bare LinAlgError message), no numpy warnings."""
    doc = copy.deepcopy(doc1k)
    doc["controller"]["gains"]["tau_s"]["gain"] = 1e308
    doc["gains"]["K2"]["value"] = 1e308
    doc["provenance"]["hand_tuned"] = True  # analyse the controller as it is (not the design's)
    res = _certify(tmp_path, doc)
    assert res.exit_code == 2 and res.stderr.startswith("exotune: error: controller: "), res.stderr
    assert "RuntimeWarning" not in res.stderr


def test_rigid_body_mode_at_rounding_level_is_inconclusive(doc1k, tmp_path):
    """τ_cmd += 1e-20 N·m/rad · θ_m: position feedback grounds the structure formally, so the
    rigid-body eigenvalue stays — at 1 − 4e-14, inside its rounding estimate. certify must say
    "inconclusive" (not "UNSTABLE", not "stable") and refuse to certify."""
    doc = copy.deepcopy(doc1k)
    doc["controller"]["gains"]["theta_m"] = {"gain": 1e-20, "unit": "N·m/rad"}
    doc["gains"]["K1"]["value"] = -1e-20
    doc["provenance"]["hand_tuned"] = True
    doc = _refresh(doc)
    sa = doc["predicted"]["sampled"]
    assert sa["free_stable"] is None
    assert abs(sa["free_spectral_radius"] - 1.0) <= sa["free_spectral_radius_rounding"]
    res = _certify(tmp_path, doc)
    assert res.exit_code == 1 and "NOT CERTIFIED" in res.output.upper()
    assert "inconclusive" in res.output and "free (cuff free): UNSTABLE" not in res.output


def test_family_members_within_rounding_are_inconclusive_not_unstable():
    """A synthetic family whose spectral radius touches 1 within rounding on [2, 3]: those members
    are listed as inconclusive (not stable, not a wrong "UNSTABLE" interval end computed from noise),
    the rest of the range keeps its stable verdict."""
    from exotune.controllerfile.continuation import stable_intervals

    def spectrum(v):
        return np.array([0.5, 1.0 if 2.0 <= v <= 3.0 else 0.9])

    def verdict(v):
        return None if 2.0 <= v <= 3.0 else True

    ivs, info = stable_intervals(spectrum, 1.0, 10.0, points=24, verdict=verdict)
    assert info["inconclusive"] and all(2.0 <= v <= 3.0 for v in info["inconclusive"])
    assert ivs[0][0] == 1.0 and ivs[0][1] == pytest.approx(2.0, rel=1e-6)
    assert ivs[-1][1] == 10.0 and ivs[-1][0] == pytest.approx(3.0, rel=1e-6)
    _ivs, plain = stable_intervals(spectrum, 1.0, 10.0, points=24)  # without a verdict: the radius alone
    assert plain["inconclusive"] == []


def test_eigenvalue_speed_is_not_read_from_rounding_noise(monkeypatch):
    """Two slow real modes a hair inside the circle (as at 100 kHz: distance ~4e-5) hardly move over
    the range, but their computed values carry rounding noise (~2e-9: close real eigenvalues are
    ill-conditioned). A derivative taken over a
    1e-7 step read that noise as a speed hundreds of times the true one and spent the refinement
    budget on cells that need none; a step of FD_CELL of the grid spacing resolves every cell at once."""
    from exotune.controllerfile import continuation as C

    def spectrum(v):
        # deterministic noise, independent between nearby values (seeded by the bits of v)
        noise = 2e-9 * np.random.default_rng(int(np.float64(v).view(np.uint64))).uniform(-1.0, 1.0)
        return np.array([1.0 - 4e-5 - 1e-7 * math.log(v) + noise, 1.0 - 3.5e-5 + noise, 0.3 + 0.1j, 0.3 - 0.1j])

    ivs, info = C.stable_intervals(spectrum, 1e-3, 1.0)
    assert ivs == [[1e-3, 1.0]] and info["unresolved"] == [] and info["refined_points"] == 0
    monkeypatch.setattr(C, "FD_CELL", 0.0)  # the former 1e-7 relative step
    _ivs, noisy = C.stable_intervals(spectrum, 1e-3, 1.0)
    assert noisy["refined_points"] > 100  # the defect this guards against


def test_high_rate_family_is_resolved_and_converges_to_the_continuous_boundary():
    """At 100 kHz (a 116-state loop: a 1 ms delay is 100 samples) the light-mass family of the
    paper's design is resolved (it was unresolved: 63 cells, the budget spent) and its boundary lies
    within 0.5 % of the continuous-time one (the sampled-data loop tends to the continuous loop as
    the rate grows; the hold adds 5 µs of delay).

    Only the light-mass family is analysed: the file's certify section is cut to that family
    (sampled_analysis searches every family on its own, so its entry is the one the whole section
    gives, to the last bit); the spring family's search, two fifths of the sampled analysis' time,
    is read by no assertion here."""
    from exotune.analysis import analyze_design
    from exotune.config import load_design
    from exotune.controllerfile import design_at_rate

    doc = build_export(design_at_rate(load_design(PAPER).raw, 100000.0), 100000.0, analyses=False)
    doc["certify"] = {"humans": doc["certify"]["humans"][:1], "environment": []}
    mass = sampled_analysis(doc)["humans"][0]
    assert mass["kind"] == "mass" and mass["loop_states"] > 100
    assert not mass["budget_spent"]
    assert len(mass["stable_intervals"]) == 1 and mass["stable_intervals"][0][1] == 1.0
    # the cell proof's rounding allowance (complex eigenvectors of a 116-state loop) may leave the
    # last sliver before the bisected end unproven: then it is listed, at most a few 1e-6 wide, and
    # the interval starts where the proof reached (conservative), never inside the sliver
    lo = mass["stable_intervals"][0][0]
    for a, b in mass["unresolved"]:
        assert b == lo and (b - a) <= 5e-6 * b
    cont = analyze_design(load_design(PAPER)).to_dict()["humans"][0]["stable_intervals"]
    assert mass["stable_intervals"][0][0] == pytest.approx(cont[0][0], rel=5e-3)
