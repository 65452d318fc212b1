"""Plant identification (exotune.identification, ``exotune identify``) against logs of a plant
simulated here, independently of exotune: the plant's equations (paper eq. (5)) with a human on
the cuff, integrated by solve_ivp (smooth applied torque) or discretized exactly with a
zero-order hold (a held command, logged as tau_cmd with a delay)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg
import yaml
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from exotune.cli import cli
from exotune.config import design_from_mapping, read_yaml
from exotune.errors import ConfigError
from exotune.identification import identify_file, identify_plant, log_from_columns

from identification.simulated_logs import TRUE, plant_matrices
FS = 1000.0


def _matrices(p=TRUE):
    """States θ_m, θ̇_m, θ_j, θ̇_j, θ_h, θ̇_h; inputs τ_m, τ_h (human muscle torque)."""
    return plant_matrices(p)


def _excitation(seed: int):
    rng = np.random.default_rng(seed)
    f = np.geomspace(0.3, 40.0, 25)
    ph = rng.uniform(0, 2 * np.pi, f.size)
    tau_m = lambda t: 3.0 * np.sin(2 * np.pi * np.multiply.outer(np.atleast_1d(t), f) + ph).sum(-1) / 5  # noqa: E731
    tau_h = lambda t: 2.0 * np.sin(2 * np.pi * 0.7 * t) + np.sin(2 * np.pi * 2.3 * t + 1)  # noqa: E731
    return tau_m, tau_h


def _columns(x, t, p=TRUE):
    th_m, th_j, th_h = x[0], x[2], x[4]
    return {"t": t, "theta_m": th_m, "tau_s": p["sea_stiffness"] * (th_j - th_m), "theta_j": th_j,
            "tau_c": p["cuff_stiffness"] * (th_h - th_j), "theta_h": th_h}


def smooth_log(seconds=8.0, seed=1, p=TRUE):
    """A smooth applied torque, integrated to 1e-11 (DOP853), sampled at FS; starts at rest."""
    A, B = _matrices(p)
    tau_m, tau_h = _excitation(seed)
    t = np.arange(int(seconds * FS)) / FS
    sol = solve_ivp(lambda s, x: A @ x + B @ [tau_m(s)[0], tau_h(s)], (0, t[-1]), np.zeros(6), t_eval=t,
                    rtol=1e-11, atol=1e-13, method="DOP853")
    return {**_columns(sol.y, t, p), "tau_m": tau_m(t)}


def held_log(seconds=20.0, seed=2, delay=1, noise=True):
    """A command held between samples (exact zero-order-hold discretization), applied ``delay``
    samples after it is logged, with sensor noise (encoders 2e-6 rad, torques 0.02 N·m)."""
    A, B = _matrices()
    Ts = 1 / FS
    E = scipy.linalg.expm(np.block([[A, B], [np.zeros((2, 8))]]) * Ts)
    Ad, Bd = E[:6, :6], E[:6, 6:]
    rng = np.random.default_rng(seed)
    n = int(seconds * FS)
    t = np.arange(n) * Ts
    tau_m, tau_h = _excitation(seed)
    cmd = tau_m(t) + 0.5 * rng.standard_normal(n)  # a multisine and broadband noise as command
    x = np.zeros((6, n))
    for k in range(n - 1):
        applied = cmd[k - delay] if k >= delay else 0.0
        x[:, k + 1] = Ad @ x[:, k] + Bd @ [applied, tau_h(t[k])]
    cols = {**_columns(x, t), "tau_cmd": cmd}
    if noise:
        for c, s in (("theta_m", 2e-6), ("theta_j", 2e-6), ("theta_h", 2e-6), ("tau_s", 0.02), ("tau_c", 0.02)):
            cols[c] = cols[c] + s * rng.standard_normal(n)
    return cols


@pytest.fixture(scope="module")
def smooth():
    return smooth_log()


def test_noise_free_log_gives_the_plant(smooth):
    r = identify_plant(log_from_columns(smooth))
    assert {p.key for p in r.parameters} == set(TRUE) and not r.missing and r.physical
    for key, v in TRUE.items():
        assert r[key].value == pytest.approx(v, rel=1e-5), key
        assert r[key].std_error <= 1e-3 * v
    assert all(f.r2 > 0.99999 for f in r.fits)
    # the design sections: the estimates and 3-standard-error relative ranges
    sec = r.design_sections()
    assert sec["plant"] == {p.key: p.value for p in r.parameters}
    assert all(0 <= u < 1 for u in sec["uncertainty"].values())


def test_filter_corner_and_start_in_motion_do_not_bias(smooth):
    """Other filter corners, and a log cut to start in motion (no rest at t = 0: the filters'
    start-up transients are in the regression), give the same plant."""
    cut = {c: v[3000:] for c, v in smooth.items()}
    for cols, fh in ((smooth, 5.0), (smooth, 40.0), (cut, None)):
        r = identify_plant(log_from_columns(cols), filter_hz=fh)
        for key, v in TRUE.items():
            assert r[key].value == pytest.approx(v, rel=2e-5), (key, fh)


def test_noisy_held_command_log_with_delay():
    """A held command logged as tau_cmd one sample before it is applied, sensor noise: every
    estimate within 4 standard errors of the truth, and the standard errors are small."""
    r = identify_plant(log_from_columns(held_log(), delay_s=1 / FS))
    for key, v in TRUE.items():
        p = r[key]
        assert abs(p.value - v) <= 4 * p.std_error, (key, p.value, p.std_error)
        assert p.relative_std_error < 0.02, key
    # ignoring the delay biases the motor parameters well beyond their standard errors
    wrong = identify_plant(log_from_columns(held_log(), delay_s=0.0))
    assert abs(wrong["motor_inertia"].value - TRUE["motor_inertia"]) > 4 * wrong["motor_inertia"].std_error


def test_columns_decide_what_is_identified(smooth):
    motor_only = {c: smooth[c] for c in ("t", "theta_m", "tau_s", "tau_m")}
    r = identify_plant(log_from_columns(motor_only))
    assert [p.key for p in r.parameters] == ["motor_inertia", "motor_damping"]
    assert dict(r.missing) == {"sea_stiffness": "needs the column theta_j", "joint_inertia": "needs the columns theta_j, tau_c",
                               "cuff_stiffness": "needs the columns theta_h, theta_j, tau_c"}
    assert "cuff_stiffness: not identified (needs the columns theta_h, theta_j, tau_c)" in r.to_text()


@settings(max_examples=12, deadline=None)
@given(c=st.floats(0.01, 100.0), a=st.floats(0.01, 100.0))
def test_units_scale_the_estimates(smooth, c, a):
    """Torques × c and angles × a: inertias, damping and stiffnesses × c/a (the equations are
    homogeneous); the relative standard errors do not change."""
    short = {k: v[:3000] for k, v in smooth.items()}
    ref = identify_plant(log_from_columns(short))
    scaled = {k: (v if k == "t" else v * (a if k.startswith("theta") else c)) for k, v in short.items()}
    r = identify_plant(log_from_columns(scaled))
    for p in ref.parameters:
        assert r[p.key].value == pytest.approx(p.value * c / a, rel=1e-8)
        assert r[p.key].relative_std_error == pytest.approx(p.relative_std_error, rel=1e-4, abs=1e-12)


def _csv(path, cols):
    names = list(cols)
    rows = zip(*(cols[n] for n in names))
    path.write_text(",".join(names) + "\n" + "".join(",".join(repr(float(x)) for x in r) + "\n" for r in rows))
    return path


def test_cli_writes_sections_a_design_file_accepts(smooth, tmp_path):
    log = _csv(tmp_path / "log.csv", smooth)
    out = tmp_path / "plant.yaml"
    res = CliRunner().invoke(cli, ["identify", str(log), "-o", str(out)])
    assert res.exit_code == 0, res.output
    assert "motor_inertia (J_m): 0.44" in res.output and "kg·m²" in res.output
    sec = yaml.safe_load(out.read_text())
    raw = read_yaml("examples/paper.yaml")
    raw["plant"] = sec["plant"]
    raw["uncertainty"] = sec["uncertainty"]
    cfg = design_from_mapping(raw)
    assert cfg.plant.J_m == pytest.approx(0.44, rel=1e-5)
    js = CliRunner().invoke(cli, ["identify", str(log), "--json"])
    import json

    d = json.loads(js.output)
    assert d["parameters"]["sea_stiffness"]["unit"] == "N·m/rad" and d["physical"] is True


def test_cli_non_physical_estimate_exits_1_and_writes_nothing(smooth, tmp_path):
    flipped = dict(smooth, tau_s=-smooth["tau_s"])  # the other sign convention for the spring torque
    log = _csv(tmp_path / "log.csv", flipped)
    res = CliRunner().invoke(cli, ["identify", str(log), "-o", str(tmp_path / "p.yaml")])
    assert res.exit_code == 1 and "NOT A PLANT" in res.output and not (tmp_path / "p.yaml").exists()


@pytest.mark.parametrize("edit,field", [
    (lambda c: c.pop("theta_m"), "theta_m"),
    (lambda c: c.update(bogus=c["t"]), "bogus"),
    (lambda c: c.update(tau_cmd=c["tau_m"]), "tau_m"),
    (lambda c: c["t"].__setitem__(500, c["t"][500] + 0.3e-3), "t"),
    (lambda c: c["tau_s"].__setitem__(7, math.nan), "tau_s"),
    (lambda c: c.update({k: v[:100] for k, v in c.items()}), "t"),
    (lambda c: c.update({k: np.zeros_like(c["t"]) for k in c if k != "t"}), "theta_m"),
])
def test_bad_logs_name_the_column(smooth, edit, field):
    cols = {k: np.array(v, float) for k, v in smooth.items()}
    edit(cols)
    with pytest.raises(ConfigError) as e:
        identify_plant(log_from_columns(cols))
    assert e.value.field == field, str(e.value)


def test_bad_csv_files_are_one_line_errors(smooth, tmp_path):
    good = _csv(tmp_path / "ok.csv", {k: v[:400] for k, v in smooth.items()})
    lines = good.read_text().splitlines()
    cases = {
        "text.csv": lines[0] + "\n" + lines[1].replace(",", ",abc,", 1) + "\n",
        "ragged.csv": "\n".join(lines[:5] + [lines[5] + ",1.0"] + lines[6:]) + "\n",
        "dup.csv": lines[0].replace("theta_m", "t", 1) + "\n" + "\n".join(lines[1:]) + "\n",
        "empty.csv": "",
        "binary.csv": "\udcff",
    }
    for name, text in cases.items():
        p = tmp_path / name
        p.write_bytes(text.encode("utf-8", "surrogateescape"))
        res = CliRunner().invoke(cli, ["identify", str(p)])
        assert res.exit_code == 2 and res.output.startswith("exotune: error:") and res.output.count("\n") == 1, (name, res.output)
    for opt in (["--delay-s", "-1", "--filter-hz", "5"], ["--filter-hz", "0"], ["--filter-hz", "400"], ["--delay-s", "x"]):
        res = CliRunner().invoke(cli, ["identify", str(good), *opt])
        assert res.exit_code == 2 and res.output.startswith("exotune: error: --"), (opt, res.output)
    with pytest.raises(ConfigError):
        identify_file(tmp_path)  # a directory


def test_absurd_magnitudes_are_refused_without_numpy_warnings(smooth):
    import warnings

    for factor in (1e300, 1e-300):
        cols = {k: (v if k == "t" else np.asarray(v) * factor) for k, v in smooth.items()}
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            try:
                r = identify_plant(log_from_columns(cols))
            except ConfigError as e:
                assert e.field in ("theta_m", "tau_s", "tau_m", "theta_j", "tau_c", "theta_h"), str(e)
            else:  # the equations are homogeneous: a uniform scale leaves the estimates
                assert r["motor_inertia"].value == pytest.approx(TRUE["motor_inertia"], rel=1e-4)


@pytest.mark.parametrize("keep", [("t", "theta_m", "tau_s", "tau_m"), None])
def test_cli_writes_the_sections_for_every_column_subset(smooth, tmp_path, keep):
    """The written sections are plain numbers: a log with unmodelled Coulomb friction, whose
    uncertainty is the measured model error, once gave numpy scalars that the YAML writer refused,
    with a traceback."""
    cols = {k: v for k, v in smooth.items() if keep is None or k in keep}  # keep: the motor's side only
    cols["tau_m"] = np.asarray(cols["tau_m"]) + 0.02 * np.sign(np.gradient(np.asarray(cols["theta_m"])))
    log = _csv(tmp_path / "log.csv", cols)
    out = tmp_path / "plant.yaml"
    res = CliRunner().invoke(cli, ["identify", str(log), "-o", str(out)])
    assert res.exit_code == 0, res.output
    sec = yaml.safe_load(out.read_text())
    assert sec["plant"]["motor_inertia"] == pytest.approx(TRUE["motor_inertia"], rel=1e-3)
    assert all(type(v) is float for part in sec.values() for v in part.values())


def test_a_delay_that_overflows_a_sample_count_is_refused(smooth, tmp_path):
    log = _csv(tmp_path / "log.csv", smooth)
    res = CliRunner().invoke(cli, ["identify", str(log), "--delay-s", "1e308"])
    assert res.exit_code == 2 and res.output.startswith("exotune: error: --delay-s:"), res.output
    assert "Traceback" not in res.output


def test_design_sections_are_plain_numbers_when_the_model_error_dominates(smooth):
    """Unmodelled Coulomb friction makes the measured model error the damping's uncertainty (a
    numpy scalar): the sections must still be plain floats that the YAML writer takes."""
    cols = {k: v for k, v in smooth.items() if k in ("t", "theta_m", "tau_s", "tau_m")}
    cols["tau_m"] = np.asarray(cols["tau_m"]) + 0.02 * np.sign(np.gradient(np.asarray(cols["theta_m"])))
    r = identify_plant(log_from_columns(cols))
    assert "Coulomb friction" in r.uncertainty()["motor_damping"][1]
    sec = r.design_sections()
    assert all(type(v) is float for part in sec.values() for v in part.values())
    assert yaml.safe_load(yaml.safe_dump(sec)) == sec
