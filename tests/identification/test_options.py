"""Model terms and options (issue 26, item 3): Coulomb friction, --delay-s auto, --fix, each
equation on its own with exit codes 0/1/2, a log without excitation refused."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from click.testing import CliRunner
from scipy.integrate import solve_ivp

from exotune.cli import cli
from exotune.errors import ConfigError
from exotune.identification import identify_plant, log_from_columns
from identification.simulated_logs import NOISE, TRUE, held_logs, plant_matrices

FC = 1.0  # Coulomb friction [N·m]


def _csv(path, cols):
    names = list(cols)
    path.write_text(",".join(names) + "\n" + "".join(",".join(repr(float(x)) for x in r) + "\n"
                                                      for r in zip(*(cols[n] for n in names))))
    return path


@pytest.fixture(scope="module")
def friction_log():
    """Smooth multisine torque on the plant with Coulomb friction F_c·tanh(θ̇_m/ε), ε = 1e-3 rad/s
    (solve_ivp), sampled at 1 kHz, sensor noise."""
    A, B = plant_matrices()
    fs, T = 1000.0, 8.0
    f = np.geomspace(0.3, 8.0, 12)
    ph = np.random.default_rng(7).uniform(0, 2 * np.pi, f.size)
    u = lambda t: 1.5 * np.sin(2 * np.pi * np.multiply.outer(np.atleast_1d(t), f) + ph).sum(-1)  # noqa: E731
    th = lambda t: 2.0 * np.sin(2 * np.pi * 0.7 * t)  # noqa: E731
    t = np.arange(int(T * fs)) / fs
    sol = solve_ivp(lambda s, x: A @ x + B[:, 0] * (u(s)[0] - FC * np.tanh(x[1] / 1e-3)) + B[:, 1] * th(s),
                    (0, t[-1]), np.zeros(6), t_eval=t, method="LSODA", rtol=1e-9, atol=1e-12, max_step=2e-3)
    x = sol.y
    rng = np.random.default_rng(8)
    cols = {"t": t, "theta_m": x[0], "tau_s": TRUE["sea_stiffness"] * (x[2] - x[0]), "tau_m": u(t)}
    for c in ("theta_m", "tau_s"):
        cols[c] = cols[c] + NOISE[c] * rng.standard_normal(t.size)
    return cols


def test_coulomb_friction_is_estimated_and_unbiases_the_damping(friction_log):
    plain = identify_plant(log_from_columns(friction_log))
    assert abs(plain["motor_damping"].value / TRUE["motor_damping"] - 1) > 0.03  # friction leaks into B_m
    r = identify_plant(log_from_columns(friction_log), friction=True)
    fc = r["coulomb_friction"]
    assert fc.value == pytest.approx(FC, rel=0.1) and fc.std_error < 0.1 * FC and fc.unit == "N·m"
    assert r["motor_damping"].value == pytest.approx(TRUE["motor_damping"], rel=0.02)
    assert r["motor_inertia"].value == pytest.approx(TRUE["motor_inertia"], rel=0.02)
    assert "coulomb_friction" not in r.design_sections()["plant"] and r.complete
    assert "F_c sign(θ̇_m)" in r.to_text()


def test_friction_term_on_a_log_without_friction_is_zero_within_its_error():
    cols = held_logs(1, 1000.0, 8.0)[0]
    r = identify_plant(log_from_columns(cols, delay_s=1e-3), friction=True)
    fc = r["coulomb_friction"]
    assert abs(fc.value) < 4 * fc.std_error and r.complete
    for k, v in TRUE.items():
        assert abs(r[k].value - v) < 4 * r[k].std_error, k


@pytest.mark.parametrize("delay", [0, 1, 3])
def test_delay_auto_finds_the_delay(delay):
    cols = held_logs(1, 1000.0, 6.0, delay=delay, seed0=delay)[0]
    r = identify_plant(log_from_columns(cols, delay_s="auto"))
    assert r.delay["samples"] == delay and r.delay["estimated"]
    assert r.delay["rms_residual"] <= min(r.delay["rms_residual_neighbours"].values())
    for k, v in TRUE.items():
        assert abs(r[k].value - v) < 4 * r[k].std_error, k
    assert f"delay: {delay} samples" in r.to_text()


def test_fix_known_parameters(tmp_path):
    cols = held_logs(1, 1000.0, 6.0)[0]
    r = identify_plant(log_from_columns(cols, delay_s=1e-3), fix=["B_m=17.9", "cuff_stiffness=300"])
    assert r["motor_damping"].fixed and r["motor_damping"].value == 17.9 and r["motor_damping"].std_error == 0
    assert abs(r["motor_inertia"].value - TRUE["motor_inertia"]) < 4 * r["motor_inertia"].std_error
    assert [f.parameters for f in r.fits][0] == ("motor_inertia",)
    assert "motor_damping (B_m): 17.9 N·m·s/rad (fixed)" in r.to_text() and r.complete
    log = _csv(tmp_path / "log.csv", cols)
    out = tmp_path / "p.yaml"
    res = CliRunner().invoke(cli, ["identify", str(log), "--delay-s", "0.001", "--fix", "K_s=1180", "-o", str(out)])
    assert res.exit_code == 0, res.output
    sec = yaml.safe_load(out.read_text())
    assert sec["plant"]["sea_stiffness"] == 1180 and sec["uncertainty"]["sea_stiffness"] == 0
    for bad in ("bogus=1", "J_m", "J_m=abc", "J_m=inf"):
        res = CliRunner().invoke(cli, ["identify", str(log), "--fix", bad, "-o", str(tmp_path / "q.yaml")])
        assert res.exit_code == 2 and res.output.startswith("exotune: error: --fix") and res.output.count("\n") == 1, res.output
        assert not (tmp_path / "q.yaml").exists()


def test_one_ill_posed_equation_does_not_discard_the_others(tmp_path):
    """A joint locked against a person (J_j → ∞: θ_j does not move) with a tau_c column: J_j is
    named as not identified, exit 1, and J_m, B_m, K_s, K_c are still written."""
    locked = dict(TRUE, joint_inertia=1e7)
    cols = held_logs(1, 1000.0, 6.0, p=locked)[0]
    r = identify_plant(log_from_columns(cols, delay_s=1e-3))
    assert dict(r.not_identified).keys() == {"joint_inertia"} and not r.complete
    for k in ("motor_inertia", "motor_damping", "sea_stiffness", "cuff_stiffness"):
        assert abs(r[k].value - TRUE[k]) < 4 * r[k].std_error, k
    log = _csv(tmp_path / "locked.csv", cols)
    out = tmp_path / "p.yaml"
    res = CliRunner().invoke(cli, ["identify", str(log), "--delay-s", "0.001", "-o", str(out)])
    assert res.exit_code == 1 and "joint_inertia: not identified (not significant" in res.output, res.output
    sec = yaml.safe_load(out.read_text())
    assert set(sec["plant"]) == {"motor_inertia", "motor_damping", "sea_stiffness", "cuff_stiffness"}
    assert "not identified: joint_inertia" in out.read_text()


def test_a_log_of_sensor_noise_is_refused_always(tmp_path):
    for seed in range(20):
        rng = np.random.default_rng(seed)
        n = 4000
        cols = {"t": np.arange(n) / 1000.0}
        for c, s in (("theta_m", 2e-6), ("tau_s", 0.02), ("tau_m", 0.02), ("theta_j", 2e-6), ("tau_c", 0.02),
                     ("theta_h", 2e-6)):
            cols[c] = s * rng.standard_normal(n)
        with pytest.raises(ConfigError) as e:
            identify_plant(log_from_columns(cols))
        assert "does not excite the plant" in str(e.value), seed
    res = CliRunner().invoke(cli, ["identify", str(_csv(tmp_path / "noise.csv", cols)), "-o", str(tmp_path / "p.yaml")])
    assert res.exit_code == 2 and res.output.count("\n") == 1 and not (tmp_path / "p.yaml").exists()


def test_delay_auto_needs_a_command(tmp_path):
    cols = held_logs(1, 1000.0, 2.0)[0]
    cols["tau_m"] = cols.pop("tau_cmd")
    with pytest.raises(ConfigError) as e:
        log_from_columns(cols, delay_s="auto")
    assert e.value.field == "delay_s"
