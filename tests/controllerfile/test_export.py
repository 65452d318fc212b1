"""Export / reference runtime / certify (docs/controller-file.md), each checked against an independent path:

* the file's sos filters (bilinear transform through zeros and poles) against the analysis-side
  discrete controller (exotune.sampled.loop.discretize: tf2ss + cont2discrete), as impulse responses;
* the reference runtime (sections stepped one by one, the DOB's algebraic loop solved per sample)
  against the closed-form state space of the same file, and, without DOB, against
  ``scipy.signal.sosfilt``;
* certify's verdicts (eigenvalues) against a time-domain simulation of the runtime in the loop with
  the exactly discretized plant, and its intervals against ``exotune analyze``'s sampled-data
  check (different code: grid + bisection around the continuous ends);
* the file round trip (YAML, safe loader) reproducing the golden vectors bit for bit, and edits
  of the file being caught.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
import scipy.signal
import yaml

from exotune.analysis import analyze_design
from exotune.controllerfile.certify import certify, sampled_analysis
from exotune.config import design_from_mapping, load_design
from exotune.model.controller import build_controller
from exotune.controllerfile import build_export, export_design, load_controller
from exotune.controllerfile.fileio import discrete_from_file, plant_from_file
from exotune.controllerfile.runtime import Runtime
from exotune.errors import ConfigError
from exotune.sampled.loop import Measured, default_prewarp, discretize, plant_ss, zoh_fractional

ROOT = Path(__file__).resolve().parents[2]
PAPER = ROOT / "examples" / "paper.yaml"


def _cfg(fs=1000.0, delay=None, dob=True, humans=None, **impl):
    raw = copy.deepcopy(load_design(PAPER).raw)
    raw["implementation"]["sample_rate_hz"] = fs
    if delay is not None:
        raw["implementation"]["delay_s"] = delay
    if not dob:
        raw["implementation"]["dob"] = None
    raw["implementation"].update(impl)
    if humans is not None:
        raw["humans"] = humans
    return design_from_mapping(raw)


@pytest.fixture(scope="module")
def paper_doc():
    cfg = _cfg()
    return cfg, build_export(cfg, 1000.0)


@pytest.fixture(scope="module")
def paper_cert(paper_doc):
    """certify's report of the unedited paper_doc, computed once for the tests that read it (certify
    leaves the document as it is)."""
    return certify(paper_doc[1]).to_dict()


def _ss_response(d, inputs: dict) -> np.ndarray:
    """τ_cmd of a DiscreteController for input sequences (closed form: loop solved in Cc, Dc)."""
    n = len(inputs["theta_m"])
    z = np.zeros(d.Ac.shape[0])
    out = np.empty(n)
    for k in range(n):
        y = np.array([inputs[s][k] for s in Measured])
        out[k] = (d.Cc @ z + d.Dc @ y).item()
        z = d.Ac @ z + d.Bc @ y
    return out


def _impulses(n=60):
    ins = {s: np.zeros(n) for s in Measured}
    for i, s in enumerate(Measured):
        ins[s][3 * i] = 1.0
    return ins


@pytest.mark.parametrize("dob", [True, False])
def test_file_filters_equal_the_analysis_discretization(dob):
    """(The file's controller section only: built without the sampled-data predictions, which
    are computed from it afterwards and play no part here.)"""
    cfg = _cfg(dob=dob)
    doc = build_export(cfg, 1000.0, analyses=False)
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    ref = discretize(cs, cfg.plant, 1000.0, default_prewarp(cfg.implementation))
    ins = _impulses()
    a, b = _ss_response(ref, ins), _ss_response(discrete_from_file(doc), ins)
    assert np.max(np.abs(a)) > 1.0  # the responses are not trivially zero
    np.testing.assert_allclose(b, a, rtol=0, atol=1e-10 * np.max(np.abs(a)))
    # the DOB's three filters exist exactly when the design has a DOB
    names = [f["name"] for f in doc["controller"]["filters"]]
    assert ("dob_command" in names) == dob
    assert "cuff_path" in names


def test_runtime_matches_state_space_and_golden(paper_doc):
    _, doc = paper_doc
    ins = {s: np.asarray(v["values"]) for s, v in doc["golden"]["inputs"].items()}
    rt = Runtime(doc).run(ins)
    ss = _ss_response(discrete_from_file(doc), ins)
    scale = np.max(np.abs(ss))
    assert scale > 1.0
    np.testing.assert_allclose(rt, ss, rtol=0, atol=1e-10 * scale)
    np.testing.assert_array_equal(rt, np.asarray(doc["golden"]["tau_cmd"]["values"]))


def test_runtime_without_dob_is_gains_plus_sosfilt():
    """(The file's controller and golden inputs only: built without the sampled-data predictions.)"""
    doc = build_export(_cfg(dob=False), 1000.0, analyses=False)
    ins = {s: np.asarray(v["values"]) for s, v in doc["golden"]["inputs"].items()}
    c = doc["controller"]
    ref = sum(g["gain"] * ins[s] for s, g in c["gains"].items())
    ref = ref + sum(scipy.signal.sosfilt(np.asarray(f["sos"]), ins[f["input"]]) for f in c["filters"])
    np.testing.assert_allclose(Runtime(doc).run(ins), ref, rtol=0, atol=1e-10 * np.max(np.abs(ref)))


def test_gains_in_file_are_the_torque_unit_gains(paper_doc):
    cfg, doc = paper_doc
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    g = doc["controller"]["gains"]
    # τ_cmd = −K1 θ_m − B1 θ̇_m + K2 τ_s + B2 τ̇_s + …  (ideal sampled velocities)
    assert g["omega_m"]["gain"] == pytest.approx(-float(np.ravel(cs.gains.B1)[0]), rel=1e-12)
    assert g["tau_s"]["gain"] == pytest.approx(float(np.ravel(cs.gains.K2)[0]), rel=1e-12)
    assert g["dtau_s"]["gain"] == pytest.approx(float(np.ravel(cs.gains.B2)[0]), rel=1e-12)
    assert doc["gains"]["B1"]["unit"] == "N·m·s/rad" and g["omega_m"]["unit"] == "N·m·s/rad"


def test_round_trip_through_yaml_reproduces_golden_bit_for_bit(tmp_path):
    out = tmp_path / "ctl.yaml"
    doc = export_design(PAPER, 1000.0, out, allow_uncertified=True).to_dict()
    loaded = load_controller(out)
    assert loaded["controller"] == doc["controller"]
    ins = {s: np.asarray(v["values"]) for s, v in loaded["golden"]["inputs"].items()}
    np.testing.assert_array_equal(Runtime.from_file(out).run(ins), np.asarray(loaded["golden"]["tau_cmd"]["values"]))
    assert loaded["provenance"]["source"] == "paper.yaml"  # no directories of this machine
    assert len(loaded["provenance"]["input_sha256"]) == 64


def _boundary(rep_humans, kind="mass"):
    h = next(h for h in rep_humans if h["kind"] == kind)
    return h["stable_intervals"]


def test_certify_intervals_agree_with_analyze_sampled_check(paper_doc):
    cfg, doc = paper_doc
    sa = doc["predicted"]["sampled"]
    lo_cert = _boundary(sa["humans"])[0][0]
    rep = analyze_design(cfg).to_dict()["sampled_data"]
    b = next(h for h in rep["humans"] if h["kind"] == "mass")["boundaries"]
    lo_an = next(x["sampled"] for x in b if x["sampled"] is not None)
    assert lo_cert == pytest.approx(lo_an, rel=1e-6)
    # and the sampled boundary lies above the continuous one (the ZOH costs phase)
    assert lo_cert > analyze_design(load_design(PAPER)).to_dict()["humans"][0]["stable_intervals"][0][0]
    assert sa["free_stable"] == rep["free_stable"] and sa["locked_stable"] == rep["locked_stable"]


def _simulate_growth(doc, human: dict | None, env="free", n=4000) -> float:
    """Run the reference runtime in closed loop with the exactly discretized plant (ZOH, delay in
    whole samples + fraction as in the file); returns the late growth factor per sample of |x|."""
    plant = plant_from_file(doc)
    A, B, C = plant_ss(plant, human, env)
    fs, T = doc["sample_rate_hz"]["value"], doc["delay_s"]["value"]
    q = T * fs
    d = int(math.floor(q + 1e-9))
    f = q - d if q - d > 1e-9 else 0.0
    Phi, G0, G1 = zoh_fractional(A, B, 1.0 / fs, f)
    rt = Runtime(doc)
    x = np.zeros(A.shape[0])
    x[0] = 1e-3  # θ_m offset
    past = [0.0] * (d + 1)  # τ_cmd[k−1], …, τ_cmd[k−d−1]
    norms = []
    for k in range(n):
        y = C @ x
        u = rt.step(dict(zip(Measured, y)))
        cur = u if d == 0 else past[d - 1]
        old = past[d]
        x = Phi @ x + G0[:, 0] * cur + G1[:, 0] * old
        past = [u] + past[:-1]
        norms.append(np.linalg.norm(y[1:]) + abs(u))  # rates and torques (the rigid-body offset is z = 1)
    a, b = np.mean(norms[n // 2: n // 2 + 200]), np.mean(norms[-200:])
    return (b / max(a, 1e-300)) ** (1.0 / (n - 200 - n // 2))


def test_certify_verdicts_match_time_domain_runtime_simulation(paper_doc):
    _, doc = paper_doc
    plant = plant_from_file(doc)
    ctrl = discrete_from_file(doc)
    from exotune.sampled.loop import loop_stable

    lo = _boundary(doc["predicted"]["sampled"]["humans"])[0][0]
    for m, expect in ((lo * 0.7, False), (lo * 1.5, True), (0.5, True)):
        human = {"inertia": m}
        st, rho = loop_stable(plant, ctrl, False, human)
        assert st == expect
        g = _simulate_growth(doc, human)
        # the simulated growth per sample tracks the spectral radius (stable: decays, unstable: grows)
        assert (g < 1.0) == expect
        assert g == pytest.approx(rho, abs=2e-3)


def test_fractional_delay_export_certifies_like_analyze():
    cfg = _cfg(fs=1000.0, delay=0.0015)
    doc = build_export(cfg, 1000.0)
    assert doc["delay_s"]["samples"] == pytest.approx(1.5)
    lo_cert = _boundary(doc["predicted"]["sampled"]["humans"])[0][0]
    b = next(h for h in analyze_design(cfg).to_dict()["sampled_data"]["humans"] if h["kind"] == "mass")["boundaries"]
    lo_an = next(x["sampled"] for x in b if x["sampled"] is not None)
    assert lo_cert == pytest.approx(lo_an, rel=1e-6)
    # more latency, heavier lightest stable inertia than at 1 sample
    assert lo_cert > 0.0055


def test_certify_catches_an_edited_file(paper_doc, paper_cert):
    _, doc = paper_doc
    assert paper_cert["prediction_mismatches"] == []
    bad = copy.deepcopy(doc)
    bad["controller"]["gains"]["omega_m"]["gain"] *= 1.5  # someone retuned B1 by hand
    with pytest.raises(ConfigError) as e:  # not the controller its sections build
        certify(copy.deepcopy(bad))
    assert e.value.field == "implementation" and "controller.gains.omega_m" in e.value.reason
    bad["provenance"]["hand_tuned"] = True  # declared: analysed as it is, and its golden vectors fail
    rep = certify(bad).to_dict()
    assert not rep["certified"]
    assert any("golden" in p for p in rep["problems"])
    bad2 = copy.deepcopy(doc)
    bad2["sample_rate_hz"]["value"] = 500.0  # a runtime at half the rate is a different loop
    with pytest.raises(ConfigError) as e:
        certify(copy.deepcopy(bad2))
    assert "implementation.sample_rate_hz 1000.0 is not the file's sample_rate_hz 500.0" in e.value.reason
    bad2["provenance"]["hand_tuned"] = True
    rep2 = certify(bad2).to_dict()
    assert rep2["prediction_mismatches"], rep2["problems"]


def test_certified_when_every_family_is_stable():
    humans = [{"kind": "mass", "inertia": [0.01, 1.0], "damping": 0.0},
              {"kind": "spring", "stiffness": [1.0, 10000.0], "damping": 0.0}]
    doc = build_export(_cfg(humans=humans), 1000.0)
    rep = certify(doc).to_dict()
    assert rep["certified"], rep["problems"]
    assert all(h["robust"] for h in rep["sampled"]["humans"])


def test_sampled_analysis_is_deterministic_and_uses_the_file_only(paper_doc):
    _, doc = paper_doc
    a = sampled_analysis(doc)
    b = sampled_analysis(yaml.safe_load(yaml.safe_dump(doc, allow_unicode=True)))
    assert a == b


def test_certify_refinement_finds_a_narrow_window_between_grid_values(monkeypatch):
    """A synthetic loop whose lightly damped oscillatory pair leaves the unit circle only in a
    window ~2 % wide, centred between two grid values (grid spacing ≈ 7.5 %), with the *same*
    eigenvalues at both grid values: the plain grid misses it; the step control of the refinement
    (the eigenvalue's speed × cell length exceeds its distance to the circle) finds it and the
    bisection pins its ends."""
    from exotune.controllerfile import continuation as C

    lo, hi = 1e-3, 1.0
    grid = np.geomspace(lo, hi, C.POINTS)
    w0 = math.sqrt(grid[40] * grid[41])

    def spectrum(v):
        r = 1.005 - 0.5 * abs(math.log(v / w0))
        return np.array([r * np.exp(0.5j), r * np.exp(-0.5j), 0.3])

    ivs, info = C.stable_intervals(spectrum, lo, hi)
    e = 0.01  # |log(v/w0)| where r = 1
    assert len(ivs) == 2 and info["refined_points"] > 0
    assert ivs[0][1] == pytest.approx(w0 * math.exp(-e), rel=1e-8)
    assert ivs[1][0] == pytest.approx(w0 * math.exp(e), rel=1e-8)
    assert info["unresolved"] == []
    monkeypatch.setattr(C, "CHORD", math.inf)
    ivs0, _ = C.stable_intervals(spectrum, lo, hi)
    assert ivs0 == [[lo, hi]]  # without the refinement the window is missed


def test_certify_refinement_follows_a_fast_eigenvalue_and_reports_unresolved_cells(monkeypatch):
    """An eigenvalue that runs along the circle at radius 0.999 while the parameter moves across
    one grid cell needs many halvings (its motion per cell ≫ its 1e-3 distance to the circle);
    a window where it steps out for 0.05 % of the range is found. With a depth limit too small,
    the cell is reported unresolved instead of being silently trusted."""
    from exotune.controllerfile import continuation as C

    lo, hi = 1.0, 10.0
    grid = np.geomspace(lo, hi, C.POINTS)
    c = math.sqrt(grid[50] * grid[51])

    def spectrum(v):
        u = math.log(v / c)
        r = 0.999 + 0.002 * math.exp(-(u / 2e-4) ** 2)  # |λ| > 1 only for |u| ≲ 1.7e-4
        return np.array([r * np.exp(40j * u), r * np.exp(-40j * u), 0.5])

    monkeypatch.setattr(C, "MAX_REFINED", 10**6)  # ~10 halvings in every cell: beyond the default budget
    ivs, info = C.stable_intervals(spectrum, lo, hi)
    assert len(ivs) == 2, ivs
    assert ivs[0][1] < c < ivs[1][0] and ivs[1][0] / ivs[0][1] < 1.0 + 1e-3
    monkeypatch.setattr(C, "MAX_DEPTH", 2)
    ivs2, info2 = C.stable_intervals(spectrum, lo, hi)
    assert info2["unresolved"], info2


def _scheduled(ratios=(0.8, 1.0, 1.3), mass_lo=0.01, analyses=True):
    raw = copy.deepcopy(load_design(PAPER).raw)
    raw["implementation"]["sample_rate_hz"] = 1000.0
    raw["humans"] = [{"kind": "mass", "inertia": [mass_lo, 1.0], "damping": 0.0}]
    raw["transmission"] = {"joint_angle_rad": [0.4 * i for i in range(len(ratios))], "ratio": list(ratios)}
    return raw, build_export(design_from_mapping(raw), 1000.0, analyses=analyses)


def test_gain_schedule_recomputes_gains_from_the_reflected_plant():
    """(The schedule's gains, plants and controllers only: built without the sampled-data
    predictions, which are computed from them afterwards and play no part here.)"""
    from exotune.model.shaping import double_compliance_shaping

    raw, doc = _scheduled(analyses=False)
    cfg = design_from_mapping({k: v for k, v in raw.items() if k != "transmission"})
    for e in doc["gain_schedule"]["entries"]:
        r2 = e["ratio"] ** 2
        plant = dataclasses.replace(cfg.plant, motor_inertia=cfg.plant.J_m * r2, motor_damping=cfg.plant.B_m * r2,
                                    sea_stiffness=cfg.plant.K_s * r2)
        g = double_compliance_shaping(plant, cfg.design).gains
        for k in ("K1", "B1", "K2", "B2", "K2_hat", "B2_hat"):
            assert e["gains"][k]["value"] == pytest.approx(float(np.ravel(getattr(g, k))[0]), rel=1e-12, abs=1e-15)
        assert e["plant"]["sea_stiffness"]["value"] == pytest.approx(cfg.plant.K_s * r2)
    nominal = next(e for e in doc["gain_schedule"]["entries"] if e["ratio"] == 1.0)
    assert nominal["controller"]["filters"] == doc["controller"]["filters"]
    assert nominal["controller"]["gains"] == doc["controller"]["gains"]


def test_runtime_follows_the_schedule_and_certify_checks_every_entry():
    from exotune.controllerfile.fileio import schedule_entry_doc

    raw, doc = _scheduled(ratios=(1.0, 2.0), mass_lo=0.006)
    ins = {s: np.asarray(v["values"]) for s, v in doc["golden"]["inputs"].items()}
    e2 = doc["gain_schedule"]["entries"][1]
    a = Runtime(doc, joint_angle_rad=0.35).run(ins)  # nearest entry: 0.4 rad, ratio 2
    b = Runtime(schedule_entry_doc(doc, e2)).run(ins)
    np.testing.assert_array_equal(a, b)
    assert np.max(np.abs(a - Runtime(doc).run(ins))) > 1e-3 * np.max(np.abs(a))
    rep = certify(doc).to_dict()
    # nominal robust, the ratio-2 entry not: the schedule entry is what fails certification
    assert rep["sampled"]["humans"][0]["robust"]
    assert [e["robust"] for e in rep["gain_schedule"]] == [True, False]
    assert not rep["certified"] and any("gain schedule at joint angle 0.4" in p for p in rep["problems"])
    # an entry edited by hand is no longer the controller its implementation section builds ...
    bad = copy.deepcopy(doc)
    bad["gain_schedule"]["entries"][0]["controller"]["gains"]["tau_s"]["gain"] *= 0.7
    with pytest.raises(ConfigError) as e:
        certify(copy.deepcopy(bad))
    assert e.value.field == "implementation" and "gain_schedule.entries[0].controller.gains.tau_s" in e.value.reason
    # ... and, declared hand-tuned, no longer matches its prediction
    bad["provenance"]["hand_tuned"] = True
    rep_bad = certify(bad).to_dict()
    assert not rep_bad["certified"] and any("gain schedule entry at 0 rad" in p for p in rep_bad["problems"])


def test_scheduled_file_validates_against_the_shipped_schema():
    jsonschema = pytest.importorskip("jsonschema")
    import json

    from exotune.controllerfile import schema_path

    _, doc = _scheduled(ratios=(0.9, 1.1))
    jsonschema.validate(json.loads(json.dumps(doc)), json.loads(schema_path().read_text()))


@pytest.mark.parametrize("tr, field", [
    ({"joint_angle_rad": [0.0, 1.0, 1.0], "ratio": [1, 1, 1]}, "transmission.joint_angle_rad"),
    ({"joint_angle_rad": [0.0, 1.0], "ratio": [1.0]}, "transmission.ratio"),
    ({"joint_angle_rad": [0.0, 1.0], "ratio": [1.0, 0.0]}, "transmission.ratio[1]"),
    ({"joint_angle_rad": [0.0], "ratio": [1.0]}, "transmission.joint_angle_rad"),
    ({"joint_angle_rad": [0.0, 1.0], "ratio": [1.0, 1.0], "jacobian": 2}, "transmission.jacobian"),
])
def test_transmission_section_is_validated(tr, field):
    raw = copy.deepcopy(load_design(PAPER).raw)
    raw["transmission"] = tr
    with pytest.raises(ConfigError) as e:
        design_from_mapping(raw)
    assert e.value.field == field


def test_no_transmission_keeps_the_mapping_and_its_hash():
    from exotune.config.design import hash_mapping

    cfg = load_design(PAPER)
    assert "transmission" not in cfg.raw  # sweep spec hashes of existing runs are unchanged
    raw = copy.deepcopy(cfg.raw)
    raw["transmission"] = {"joint_angle_rad": [0.0, 1.0], "ratio": [1.0, 1.1]}
    assert hash_mapping(design_from_mapping(raw).raw) != hash_mapping(cfg.raw)


def test_analyze_checks_every_scheduled_angle_like_export():
    """analyze's continuous check of the schedule (one batch over the angles) agrees with the
    single-design analysis of each reflected design, and its gains with the export's entries."""
    from exotune.controllerfile.export import reflected_mapping

    raw = copy.deepcopy(load_design(PAPER).raw)
    raw["humans"] = [{"kind": "mass", "inertia": [0.0048, 1.0], "damping": 0.0}]
    raw["transmission"] = {"joint_angle_rad": [0.0, 1.0, 2.0], "ratio": [0.5, 1.0, 2.0]}
    rep = analyze_design(design_from_mapping(raw)).to_dict()
    assert len(rep["gain_schedule"]) == 3
    for e in rep["gain_schedule"]:
        single = analyze_design(design_from_mapping(reflected_mapping(raw, e["ratio"]))).to_dict()
        assert e["robust"] == (single["humans"][0]["robust"] and single["free_stable"] and single["locked_stable"])
        for k, v in single["gains"].items():
            assert e["gains"][k] == pytest.approx(v, rel=1e-12, abs=1e-15)
    assert any(not e["robust"] for e in rep["gain_schedule"]) == any("joint angle" in w for w in rep["warnings"])


def test_shipped_scheduled_example_certifies():
    cfg = load_design(ROOT / "examples" / "scheduled.yaml")
    rep = certify(build_export(cfg, 1000.0)).to_dict()
    assert rep["certified"], rep["problems"]
    assert len(rep["gain_schedule"]) == 5 and all(e["robust"] for e in rep["gain_schedule"])


def test_certify_fails_on_unresolved_eigenvalue_paths(paper_doc, paper_cert, monkeypatch):
    """A cell of stable values whose eigenvalue paths the step control cannot resolve is a
    certification problem, not silently trusted (forced here by a zero tolerance and no halving)."""
    from exotune.controllerfile import continuation as C

    _, doc = paper_doc
    assert not any("not resolved" in p for p in paper_cert["problems"])  # certify unpatched
    monkeypatch.setattr(C, "CHORD", 0.0)
    monkeypatch.setattr(C, "MAX_DEPTH", 0)
    rep = certify(doc).to_dict()
    assert not rep["certified"]
    assert any("eigenvalue paths not resolved" in p for p in rep["problems"]), rep["problems"]


def test_export_carries_the_kyp_certificates(paper_doc):
    """The controller file's continuous predictions include the KYP passivity certificates (with
    units) of the design's nominal and delay-free C7, as `exotune analyze` computes them."""
    _, doc = paper_doc
    kyp = doc["predicted"]["continuous"]["passivity"]["kyp"]
    assert kyp["nominal"]["passive"] is True and kyp["nominal"]["shortage"] == {"value": 0.0, "unit": "rad/(N·m·s)"}
    assert kyp["delay_free"]["passive"] is False
    assert kyp["delay_free"]["shortage"]["value"] == pytest.approx(0.0599288, rel=1e-5)


def test_certify_refinement_budget_reports_unresolved_cells(monkeypatch):
    """The refinement has a bounded cost: past MAX_REFINED values the remaining unresolved cells
    are reported (and would fail certification), not refined forever."""
    from exotune.controllerfile import continuation as C

    def spectrum(v):  # an eigenvalue 1e-9 inside the circle, turning fast with the parameter
        u = math.log(v)
        return np.array([(1 - 1e-9) * np.exp(30j * u), (1 - 1e-9) * np.exp(-30j * u)])

    monkeypatch.setattr(C, "MAX_REFINED", 300)
    ivs, info = C.stable_intervals(spectrum, 1.0, 10.0)
    assert ivs == [[1.0, 10.0]] and info["refined_points"] <= 300 + C.MAX_DEPTH
    assert info["unresolved_cells"] >= C.POINTS - 1 and len(info["unresolved"]) == C.MAX_LISTED
