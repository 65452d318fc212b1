"""exotune.identification.estimate: the plant parameters from a simulated log (independent
simulation, tests/identification/simulated_logs.py), known parameters fixed, several logs together."""

import pytest

from exotune.errors import ConfigError
from exotune.identification.data import log_from_columns
from exotune.identification.estimate import DEFAULT_FILTER_HZ, identify_file, identify_plant, parse_fix

from identification.simulated_logs import TRUE, held_logs, smooth_logs

FS = 1000.0


@pytest.fixture(scope="module")
def smooth():
    return [log_from_columns(c, source=f"smooth{i}") for i, c in enumerate(smooth_logs(2, FS, 6.0, noise=False))]


def test_noise_free_log_gives_the_plant(smooth):
    est = identify_plant(smooth[0])
    for key, value in TRUE.items():
        assert est[key].value == pytest.approx(value, rel=1e-6), key
        assert est[key].std_error >= 0
    assert est.filter_hz == min(DEFAULT_FILTER_HZ, FS / 100)  # at most a hundredth of the sample rate
    assert est.complete and est.source == "smooth0"
    assert {f.equation.split()[0] for f in est.fits} >= {"J_m", "τ_s", "J_j", "τ_c"}


def test_fixed_parameters_are_reported_as_given(smooth):
    est = identify_plant(smooth[0], fix=["B_m=17.9", "cuff_stiffness=300"])
    assert est["motor_damping"].fixed and est["motor_damping"].value == 17.9 and est["motor_damping"].std_error == 0
    assert est["motor_inertia"].value == pytest.approx(TRUE["motor_inertia"], rel=1e-6)
    assert est["cuff_stiffness"].fixed


def test_two_logs_together(smooth):
    est = identify_plant(smooth)
    assert est.samples > identify_plant(smooth[0]).samples
    assert est["joint_inertia"].value == pytest.approx(TRUE["joint_inertia"], rel=1e-6)


def test_logs_identified_together_must_agree(smooth):
    other = log_from_columns({k: v for k, v in smooth_logs(1, 2 * FS, 3.0, noise=False)[0].items()}, source="fast")
    with pytest.raises(ConfigError, match="need one rate"):
        identify_plant([smooth[0], other])
    with pytest.raises(ConfigError, match="no log to identify"):
        identify_plant([])


def test_noisy_held_command_with_its_delay():
    cols = held_logs(1, FS, 20.0, delay=2)[0]
    est = identify_plant(log_from_columns(cols, delay_s="0.002"))
    for key in ("motor_inertia", "motor_damping", "sea_stiffness"):
        p = est[key]
        assert abs(p.value - TRUE[key]) < 5 * p.std_error + 1e-3 * TRUE[key], key
    assert est.delay["samples"] == 2 and not est.delay["estimated"]


def test_parse_fix():
    assert parse_fix(["J_m=0.5", "sea_stiffness = 1000", "f_c=0.2"]) == {"motor_inertia": 0.5, "sea_stiffness": 1000.0,
                                                                        "coulomb_friction": 0.2}
    assert parse_fix({"K_c": "250"}) == {"cuff_stiffness": 250.0}
    with pytest.raises(ConfigError) as ei:
        parse_fix(["gear=3"])
    assert ei.value.field == "fix" and "'gear' is not a plant parameter" in ei.value.reason
    with pytest.raises(ConfigError, match="'J_m' has no value: give it as NAME=VALUE"):
        parse_fix(["J_m"])
    with pytest.raises(ConfigError, match="the value must be a number"):
        parse_fix(["J_m=x"])
    with pytest.raises(ConfigError, match="finite number"):
        parse_fix(["J_m=inf"])
    # the design file's rule of each parameter
    for bad, why in (("J_m=-1", "motor_inertia must be > 0 kg·m²"), ("K_s=0", "sea_stiffness must be > 0 N·m/rad"),
                     ("J_j=0", "joint_inertia must be > 0"), ("K_c=-3", "cuff_stiffness must be > 0"),
                     ("B_m=-0.1", "motor_damping must be >= 0 N·m·s/rad"), ("F_c=-1", "coulomb_friction must be >= 0")):
        with pytest.raises(ConfigError) as ei:
            parse_fix([bad])
        assert ei.value.field == "fix" and why in ei.value.reason, bad
    assert parse_fix(["B_m=0", "F_c=0"]) == {"motor_damping": 0.0, "coulomb_friction": 0.0}


def test_a_fixed_parameter_is_kept_when_the_log_cannot_fit_its_equation(smooth):
    """A datasheet K_s beside a log without theta_j: reported as fixed (not dropped), not listed
    as missing, and the other equations identified as without it."""
    sig = {k: v for k, v in smooth[0].signals.items() if k in ("t", "theta_m", "tau_s", "tau_m")}
    log = log_from_columns(sig, source="motor-only")
    est = identify_plant(log, fix=["K_s=1180"])
    assert est["sea_stiffness"].fixed and est["sea_stiffness"].value == 1180.0
    assert "sea_stiffness" not in dict(est.missing)
    assert est["motor_inertia"].value == pytest.approx(TRUE["motor_inertia"], rel=1e-6)
    plain = identify_plant(log)
    assert "sea_stiffness" in dict(plain.missing) and "sea_stiffness" not in {p.key for p in plain.parameters}


def test_identify_file_reads_the_csv(smooth, tmp_path):
    p = tmp_path / "log.csv"
    sig = smooth[0].signals
    names = list(sig)
    p.write_text(",".join(names) + "\n" + "\n".join(",".join(repr(float(sig[k][i])) for k in names)
                                                  for i in range(smooth[0].samples)) + "\n")
    est = identify_file(p)
    assert est.source == str(p) and est["sea_stiffness"].value == pytest.approx(TRUE["sea_stiffness"], rel=1e-6)


@pytest.mark.parametrize("fix, reason", [
    (1.0, "expected a mapping {NAME: VALUE} or a list of 'NAME=VALUE' strings, got float 1.0"),
    ("J_m=0.44", "a list of 'NAME=VALUE' strings, got str 'J_m=0.44'"),  # not its characters one by one
    ({"J_m": True}, "J_m=True: the value must be a number"),
    ({1: 2.0}, "'1' is not a plant parameter"),
])
def test_fix_of_the_wrong_kind_is_refused_naming_fix(fix, reason):
    with pytest.raises(ConfigError) as ei:
        parse_fix(fix)
    assert ei.value.field == "fix" and reason in ei.value.reason
    assert parse_fix(None) == {} and parse_fix(()) == {} and parse_fix(iter(["K_s=1000"])) == {"sea_stiffness": 1000.0}


def test_a_bool_filter_corner_is_refused(smooth):
    with pytest.raises(ConfigError) as ei:
        identify_plant(smooth[0], filter_hz=True)
    assert ei.value.field == "filter_hz"
