"""Precision as a certified property (docs/controller-file.md#precision): a float32 file exports
with a delta-form realization of exactly representable float32 coefficients, certify analyses that
realization exactly (its state space against the file's sos transfer function, its golden vectors in
float32), the rounding bound holds against float32 simulation vs float64 on random inputs, and
``certify --precision float32`` answers for a float64 file without changing it.
"""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest
import yaml

from exotune.config import read_yaml
from exotune.controllerfile import export_design, load_controller
from exotune.controllerfile.certify import certify
from exotune.controllerfile.export import build_export, design_at_rate
from exotune.controllerfile.fileio import discrete_from_file
from exotune.controllerfile.precision import Float32Runtime, delta_row, linearize
from exotune.controllerfile.roundoff import roundoff_bound
from exotune.controllerfile.runtime import Runtime
from exotune.controllerfile.target import runtime_of
from exotune.errors import ConfigError
from exotune.sampled import Measured

ROOT = Path(__file__).resolve().parents[2]
SCHEDULED = ROOT / "examples" / "scheduled.yaml"
PAPER = ROOT / "examples" / "paper.yaml"


def _design32(tmp_path, src=SCHEDULED, **impl):
    raw = yaml.safe_load(Path(src).read_text())
    raw["implementation"].update(precision="float32", **impl)
    p = tmp_path / "d32.yaml"
    p.write_text(yaml.safe_dump(raw))
    return p


@pytest.fixture(scope="module")
def file32(tmp_path_factory):
    d = tmp_path_factory.mktemp("p32")
    out = d / "c32.yaml"
    export_design(_design32(d), None, out)
    return out


def _is_f32(x: float) -> bool:
    return float(np.float32(x)) == x


def test_float32_export_stores_representable_delta_coefficients(file32):
    doc = load_controller(file32)
    assert doc["implementation"]["precision"] == "float32"
    ctrls = [doc["controller"]] + [e["controller"] for e in doc["gain_schedule"]["entries"]]
    for c in ctrls:
        r = c["realization"]
        assert r["form"] == "delta_df2t"
        vals = list(r["gains"].values()) + [r["loop_divisor"]]
        vals += [x for f in r["filters"] for row in f["sections"] for x in row]
        assert all(_is_f32(v) for v in vals)
        assert [f["name"] for f in r["filters"]] == [f["name"] for f in c["filters"]]
        dm = {f["name"]: f["sections"] for f in r["filters"]}
        assert dm["dob_motor"][0][2] == 0.0  # the zero at z = 1 (J_m s² + B_m s) is kept exactly
        for name in ("dob_spring", "dob_command"):
            assert dm[name][0][2] == dm[name][0][4]  # Q's unit DC gain (the DOB's integral action) kept exactly


def test_realization_state_space_is_the_sos_transfer_function_to_float32_accuracy(file32):
    doc = load_controller(file32)
    c32 = discrete_from_file(doc)
    f64 = copy.deepcopy(doc)
    for c in [f64["controller"]] + [e["controller"] for e in f64["gain_schedule"]["entries"]]:
        c.pop("realization")
    c64 = discrete_from_file(f64)
    h32 = np.vstack([c32.Dc] + [c32.Cc @ np.linalg.matrix_power(c32.Ac, k) @ c32.Bc for k in range(60)])
    h64 = np.vstack([c64.Dc] + [c64.Cc @ np.linalg.matrix_power(c64.Ac, k) @ c64.Bc for k in range(60)])
    # per input, within float32's relative precision of that input's largest response (the feed-through)
    assert np.all(np.abs(h32 - h64) <= 1e-6 * np.max(np.abs(h64), axis=0))


def test_linearization_matches_the_float32_step_in_exact_arithmetic(file32):
    """The state space certify analyses is the step as executed: the linear map it builds, run
    on the same inputs, stays within the rounding bound of the float32 step's outputs."""
    doc = load_controller(file32)
    L = linearize(doc["controller"]["realization"])
    rng = np.random.default_rng(3)
    ins = {s: rng.uniform(-1, 1, 150) * a for s, a in zip(Measured, (0.5, 5.0, 20.0, 500.0, 10.0))}
    z = np.zeros(L["states"])
    exact = []
    for k in range(150):
        y = np.array([ins[s][k] for s in Measured])
        exact.append(float((L["C"] @ z + L["D"] @ y)[0]))
        z = L["A"] @ z + L["B"] @ y
    got = Float32Runtime(doc).run(ins)
    amp = {s: float(np.max(np.abs(v))) for s, v in ins.items()}
    b = roundoff_bound(doc, amp, 150)
    assert np.max(np.abs(got - np.array(exact))) <= b["arithmetic"]["value"]


@pytest.mark.parametrize("fs", [1000.0, 10000.0])
def test_roundoff_bound_holds_against_float32_vs_float64_simulation(tmp_path, fs):
    raw = read_yaml(_design32(tmp_path))
    doc = build_export(design_at_rate(raw, fs), fs, analyses=False)
    amp = {"theta_m": 1.0, "omega_m": 10.0, "tau_s": 100.0, "dtau_s": 1e4, "tau_c": 50.0}
    n = 300
    b = roundoff_bound(doc, amp, n)
    assert b["total"]["value"] > 0 and b["rounding_points"] > 50
    assert b["by_location"][0]["bound"]["value"] <= b["arithmetic"]["value"]
    rng = np.random.default_rng(int(fs))
    worst = 0.0
    for _ in range(4):
        ins = {s: rng.uniform(-1, 1, n) * amp[s] for s in Measured}
        worst = max(worst, float(np.max(np.abs(Float32Runtime(doc).run(ins) - Runtime(doc).run(ins)))))
    assert 0.0 < worst <= b["total"]["value"]


def test_float32_file_certifies_with_golden_vectors_in_float32(file32):
    doc = load_controller(file32)
    ins = {s: np.asarray(v["values"]) for s, v in doc["golden"]["inputs"].items()}
    out = np.array([np.float32(x) for x in runtime_of(doc).run(ins)], dtype=float)
    assert list(out) == doc["golden"]["tau_cmd"]["values"]  # float32 values, reproduced bit for bit
    assert not np.array_equal(out, Runtime(doc).run(ins))  # and not the float64 runtime's
    cert = certify(doc)
    assert cert.certified, cert.reasons
    p = cert.to_dict()["precision"]
    assert p["precision"] == "float32" and p["total"]["unit"] == "N·m" and "asked" not in p
    assert "float32 (delta_df2t realization" in cert.to_text()


def test_certify_precision_float32_on_a_float64_file(tmp_path):
    out = tmp_path / "c64.yaml"
    export_design(SCHEDULED, None, out)
    before = out.read_bytes()
    doc = load_controller(out)
    cert = certify(doc, precision="float32")
    assert cert.certified, cert.reasons
    rep = cert.to_dict()
    assert rep["precision"]["asked"] and rep["prediction_mismatches"] == []
    assert "certify --precision float32" in cert.to_text()
    assert "precision" not in certify(doc).to_dict()
    assert out.read_bytes() == before
    with pytest.raises(ConfigError, match="^precision: "):
        certify(doc, precision="float16")


def test_tampered_realization_and_invalid_precision_are_refused(file32, tmp_path):
    doc = load_controller(file32)
    bad = copy.deepcopy(doc)
    bad["controller"]["realization"]["filters"][0]["sections"][0][1] = float(np.float32(
        bad["controller"]["realization"]["filters"][0]["sections"][0][1] * 1.001))
    with pytest.raises(ConfigError, match="controller.realization"):
        certify(bad)
    missing = copy.deepcopy(doc)
    del missing["gain_schedule"]["entries"][0]["controller"]["realization"]
    p = tmp_path / "m.yaml"
    p.write_text(yaml.safe_dump(missing, allow_unicode=True))
    with pytest.raises(ConfigError, match=r"entries\[0\].controller.realization"):
        load_controller(p)
    wrong = copy.deepcopy(doc)
    wrong["implementation"]["precision"] = "double"
    p.write_text(yaml.safe_dump(wrong, allow_unicode=True))
    with pytest.raises(ConfigError, match="implementation.precision"):
        load_controller(p)
    raw = read_yaml(SCHEDULED)
    raw["implementation"]["precision"] = "half"
    with pytest.raises(ConfigError, match="implementation.precision"):
        design_at_rate(raw, 1000.0)


def test_naive_float32_rounding_of_the_direct_form_breaks_dob_motor_at_10_khz(tmp_path):
    """The measurement behind the choice of the delta form: at 10 kHz the direct-form coefficients
    of dob_motor rounded to float32 lose its zero at z = 1 (a spurious DC position feedback of a few
    N·m/rad); the delta form keeps it (beta2 = 0)."""
    fs = 10000.0
    doc = build_export(design_at_rate(read_yaml(PAPER), fs), fs, analyses=False)
    sos = np.array(next(f["sos"] for f in doc["controller"]["filters"] if f["name"] == "dob_motor"))
    naive = sos.astype(np.float32).astype(float)
    dc = [(r[0] + r[1] + r[2]) / (1 + r[4] + r[5]) for r in naive]
    assert abs(dc[0]) > 1.0  # N·m/rad of position feedback that the design does not have
    assert delta_row(sos[0])[0][2] == 0.0
