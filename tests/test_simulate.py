"""exotune simulate: the nonlinear time-domain model checked against independent paths — without
nonlinearities it must reproduce the exact sampled-data model (matrix exponential, shift
registers) sample by sample; the locked-output amplification must match the design's α and the
frequency-domain DC amplification; the light-mass verdicts must match certify's eigenvalues."""

from __future__ import annotations

import copy
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from exotune.cli import cli
from exotune.config.design import design_from_mapping, load_design
from exotune.controllerfile.export import build_export, discrete_from_file, plant_from_file
from exotune.sampled.loop import closed_loop_matrix, plant_ss
from exotune.simulate import SCENARIOS, Nonlinearities, _deadzone, run_scenario, simulate

ROOT = Path(__file__).resolve().parents[1]


def _doc(delay=0.001, fs=1000.0):
    raw = copy.deepcopy(load_design(ROOT / "examples" / "paper.yaml").raw)
    raw["implementation"].update(sample_rate_hz=fs, delay_s=delay)
    return build_export(design_from_mapping(raw), fs)


@pytest.fixture(scope="module")
def doc():
    return _doc()


@pytest.mark.parametrize("delay", [0.001, 0.0015])
def test_linear_run_equals_exact_sampled_data_model(delay):
    d = _doc(delay=delay)
    sc = replace(SCENARIOS["light-mass"], human={"inertia": 0.02, "damping": 0.1}, duration_s=0.4)
    sim = simulate(d, sc, substeps=20)["series"]
    A, B, C = plant_ss(plant_from_file(d), sc.human, "free")
    M = closed_loop_matrix(A, B, C, discrete_from_file(d))
    z = np.zeros(M.shape[0])
    z[4] = sc.theta_h0  # states θ_m, ω_m, θ_j, ω_j, θ_h, ω_h, controller…, shift register
    traj = []
    for _ in range(sim["t"].size):
        traj.append(z[[0, 2, 4]].copy())
        z = M @ z
    traj = np.array(traj)
    got = np.stack([sim["theta_m"], sim["theta_j"], sim["theta_h"]], axis=1)
    scale = np.max(np.abs(traj))
    assert scale > 1e-3
    np.testing.assert_allclose(got, traj, rtol=0, atol=1e-6 * scale)


def test_locked_output_delivers_alpha(doc):
    rep = run_scenario(doc, "locked-output")
    a = rep["summary"]["delivered_amplification"]["value"]
    assert a == pytest.approx(8.0, rel=0.01)
    assert not rep["summary"]["diverged"]


def test_dob_rejects_motor_friction(doc):
    rep = run_scenario(doc, replace(SCENARIOS["dob-friction"], duration_s=2.0), substeps=10)
    s = rep["friction_sensitivity"]
    assert s["with_dob"]["value"] < 0.1 * s["without_dob"]["value"]
    assert s["without_dob"]["value"] > 0.05  # friction does matter without the DOB


def test_saturation_is_respected_without_windup(doc):
    rep = run_scenario(doc, "saturation")
    sm = rep["summary"]
    assert sm["peak_motor_torque"]["value"] <= 40.0 + 1e-12
    assert sm["peak_command"]["value"] <= 40.0 + 1e-12  # the runtime clamps before its DOB
    assert not sm["diverged"]


def test_light_mass_verdicts_follow_certify(doc):
    lo = doc["predicted"]["sampled"]["humans"][0]["stable_intervals"][0][0]
    sc = replace(SCENARIOS["light-mass"], duration_s=1.5)
    for m, stable in ((0.8 * lo, False), (2.0 * lo, True)):
        sim = simulate(doc, replace(sc, human={"inertia": m}), substeps=10)
        w = sim["series"]["theta_h"] - sim["series"]["theta_j"]
        n = w.size
        late = np.max(np.abs(w[int(0.8 * n):] - np.mean(w[int(0.8 * n):])))
        early = np.max(np.abs(w[: n // 5]))
        assert (late < 0.1 * early) == stable, (m, late, early)


@settings(max_examples=60, deadline=None)
@given(st.floats(-1.0, 1.0), st.floats(0.0, 0.5))
def test_deadzone_properties(x, b):
    y = _deadzone(x, b)
    assert _deadzone(-x, b) == -y
    assert abs(y - x) <= b / 2 + 1e-15
    assert y == 0.0 or math.copysign(1, y) == math.copysign(1, x)
    assert (y == 0.0) == (abs(x) <= b / 2)


def test_backlash_and_friction_options_change_the_run(doc):
    sc = replace(SCENARIOS["locked-output"], duration_s=0.3)
    base = simulate(doc, sc, substeps=10)["series"]["tau_s"]
    bl = simulate(doc, replace(sc, nonlinear=Nonlinearities(backlash_rad=0.01)), substeps=10)["series"]["tau_s"]
    assert np.max(np.abs(bl - base)) > 1e-3 * np.max(np.abs(base))


def test_cli_simulate_errors_and_success(tmp_path):
    r = CliRunner()
    res = r.invoke(cli, ["simulate", str(ROOT / "examples" / "paper.yaml"), "--scenario", "locked-output"])
    assert res.exit_code == 2 and "--sample-rate-hz" in res.output and "Traceback" not in res.output
    res = r.invoke(cli, ["simulate", str(ROOT / "examples" / "paper.yaml"), "--scenario", "nope", "--sample-rate-hz", "1000"])
    assert res.exit_code == 2
    res = r.invoke(cli, ["simulate", str(ROOT / "examples" / "paper.yaml"), "--scenario", "saturation",
                         "--sample-rate-hz", "1000", "--plots", str(tmp_path / "p"), "--json"])
    assert res.exit_code == 0, res.output
    assert (tmp_path / "p" / "simulate_saturation.png").stat().st_size > 1000
    assert '"peak_motor_torque"' in res.output


@pytest.mark.parametrize("args,field", [
    (["examples/paper.yaml", "--sample-rate-hz", "1e9"], "implementation.sample_rate_hz"),  # 1e6 delay states
    (["results/pipeline/controller_1khz.yaml", "--sample-rate-hz", "2000"], "--sample-rate-hz"),
    (["results/pipeline/controller_1khz.yaml", "--human-inertia", "nan"], "--human-inertia"),
    (["results/pipeline/controller_1khz.yaml", "--joint-angle", "inf"], "--joint-angle"),
])
def test_cli_simulate_refuses_options_it_cannot_honour(args, field):
    """Found by fuzzing: a 1 GHz rate ran out of memory (MemoryError) building a million delay
    states; an option that a controller file overrides, or a NaN, was silently ignored."""
    res = CliRunner().invoke(cli, ["simulate", str(ROOT / args[0]), *args[1:], "--scenario", "light-mass"])
    assert res.exit_code == 2, res.output
    assert f"exotune: error: {field}" in res.output and "Traceback" not in res.output


def test_delay_sample_limit_in_design_and_controller_files(tmp_path):
    """The limit on shift states holds for design files (at their own rate) and for controller
    files (certify), with the field named."""
    import yaml

    from exotune.config.design import MAX_DELAY_SAMPLES
    from exotune.errors import ConfigError

    raw = yaml.safe_load((ROOT / "examples" / "paper.yaml").read_text())
    raw["implementation"]["sample_rate_hz"] = 1.01 * MAX_DELAY_SAMPLES / raw["implementation"]["delay_s"]
    with pytest.raises(ConfigError, match="implementation.sample_rate_hz"):
        design_from_mapping(raw)
    raw["implementation"]["sample_rate_hz"] = 0.99 * MAX_DELAY_SAMPLES / raw["implementation"]["delay_s"]
    design_from_mapping(raw)  # just under the limit: accepted
    ctrl = yaml.safe_load((ROOT / "results" / "pipeline" / "controller_1khz.yaml").read_text())
    ctrl["delay_s"]["value"] = 2.0  # 2000 samples at 1 kHz
    (tmp_path / "c.yaml").write_text(yaml.safe_dump(ctrl, allow_unicode=True))
    res = CliRunner().invoke(cli, ["certify", str(tmp_path / "c.yaml")])
    assert res.exit_code == 2 and "exotune: error: delay_s.value" in res.output, res.output


def test_cli_simulate_at_a_scheduled_joint_angle(tmp_path):
    import yaml

    raw = copy.deepcopy(load_design(ROOT / "examples" / "paper.yaml").raw)
    raw["implementation"]["sample_rate_hz"] = 1000.0
    raw["humans"] = [{"kind": "mass", "inertia": [0.01, 1.0], "damping": 0.0}]
    raw["transmission"] = {"joint_angle_rad": [0.0, 1.0], "ratio": [1.0, 2.0]}
    p = tmp_path / "d.yaml"
    p.write_text(yaml.safe_dump(raw))
    r = CliRunner()
    out = {}
    for angle in ("0.1", "0.9"):
        res = r.invoke(cli, ["simulate", str(p), "--scenario", "locked-output", "--joint-angle", angle, "--json"])
        assert res.exit_code == 0, res.output
        import json

        out[angle] = json.loads(res.output)["summary"]
    # the rescheduled controller keeps the amplification at both angles, with different peaks
    for s in out.values():
        assert s["delivered_amplification"]["value"] == pytest.approx(8.0, rel=0.01)
    assert out["0.1"]["peak_motor_torque"]["value"] != pytest.approx(out["0.9"]["peak_motor_torque"]["value"], rel=1e-3)
    res = r.invoke(cli, ["simulate", str(ROOT / "examples" / "paper.yaml"), "--scenario", "locked-output",
                         "--sample-rate-hz", "1000", "--joint-angle", "0.5"])
    assert res.exit_code == 2 and "--joint-angle" in res.output


def test_slow_divergence_is_reported(tmp_path):
    """A loop just outside the unit circle grows for the whole run without reaching the 1e6 state
    bound (found by fuzzing: the §9 design's light-mass run at 1 kHz — 5e-3 kg·m², below the sampled
    boundary 5.55e-3 — ended at 140 kN·m with ``diverged: False``). The late torque peak against the
    mid-run peak flags it; the same scenario with a heavier human does not."""
    from exotune.cli import cli
    from click.testing import CliRunner

    res = CliRunner().invoke(cli, ["simulate", str(ROOT / "examples" / "paper.yaml"), "--scenario", "light-mass", "--sample-rate-hz", "1000",
                                   "--json"])
    assert res.exit_code == 0, res.output
    import json

    sm = json.loads(res.stdout)["summary"]
    assert sm["diverged"] and not sm["oscillation_decays"]
    ok = CliRunner().invoke(cli, ["simulate", str(ROOT / "examples" / "paper.yaml"), "--scenario", "light-mass", "--sample-rate-hz", "1000",
                                  "--human-inertia", "0.02", "--json"])
    assert ok.exit_code == 0, ok.output
    assert not json.loads(ok.stdout)["summary"]["diverged"]
