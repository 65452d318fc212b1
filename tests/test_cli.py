"""The command-line contract (docs/cli.md): outputs with units, JSON conventions, and the error
contract (one line naming the field, exit code 2, no traceback, nothing written)."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from exotune import __version__
from exotune.cli import cli

ROOT = Path(__file__).resolve().parents[1]
PAPER = ROOT / "examples" / "paper.yaml"
SEA = ROOT / "examples" / "sea.yaml"


def run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=False)


def bad_design(tmp_path, old, new, name="bad.yaml") -> Path:
    text = PAPER.read_text(encoding="utf-8")
    assert old in text
    p = tmp_path / name
    p.write_text(text.replace(old, new, 1), encoding="utf-8")
    return p


def assert_input_error(res, field):
    assert res.exit_code == 2, res.output
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, res.stderr
    assert lines[0].startswith(f"exotune: error: {field}: "), lines[0]
    assert "Traceback" not in res.output
    assert res.stdout == ""


# ------------------------------------------------------------------------------ exotune design
@pytest.fixture(scope="module")
def design_json():
    res = run("design", PAPER, "--json")
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout)


def test_design_gains_match_spec_formulas(design_json):
    """Independent evaluation of the docs/method.md#double-compliance-shaping formulas for the §9 example."""
    J_m, B_m, K_s, K_c = 0.44, 17.9, 1180.0, 300.0  # the gains do not depend on J_j
    a, fi, fd, z, zh = 8.0, 0.25, 1.0, 0.7, 0.7
    Jh, Bh = a * fi, a * fd
    K2t, B1t = K_s / Jh, Bh / Jh
    B2t = 2 * z * math.sqrt(K_s / Jh)
    expect = {
        "K1": 0.0,
        "B1": J_m * B1t - B_m,
        "K2": J_m / Jh - 1,
        "B2": (B2t - B1t) * J_m / K_s,
        "K2_hat": a - 1,
        "B2_hat": (2 * zh * math.sqrt(a * K_c * Jh) - Bh) / K_c,
    }
    g = design_json["gains"]
    assert set(g) == set(expect)
    for k, v in expect.items():
        assert g[k] == pytest.approx(v, rel=1e-12, abs=1e-12), k
    assert g["K1"] == 0.0 and g["K2_hat"] == 7.0
    assert g["B1"] == pytest.approx(0.44 * 4.0 - 17.9)
    assert design_json["gain_convention"] == "torque"
    assert set(design_json["units"]) == set(expect)
    assert design_json["units"]["K1"] == "N·m/rad" and design_json["units"]["B2"].startswith("s")
    sh = design_json["shape"]
    assert sh == pytest.approx({"K1_tilde": 0.0, "B1_tilde": B1t, "K2_tilde": K2t, "B2_tilde": B2t,
                                "J_m_hat": Jh, "B_m_hat": Bh})
    assert set(design_json["shape_units"]) >= set(sh)


def test_design_poles_and_zeros(design_json):
    tfs = design_json["transfer_functions"]
    assert set(tfs) == {"C4", "C5", "C5_hat", "C7_nominal", "G_v"}
    for tf in tfs.values():
        assert tf["units"] and tf["poles"] is not None
        for r in tf["poles"] + tf["zeros"]:
            assert set(r) == {"re", "im", "natural_frequency_hz", "damping_ratio"}
    # C4 zeros: s² + 2ζ√(K_s/Ĵ_m) s + K_s/Ĵ_m -> f_n = √590/2π, ζ = 0.7
    for r in tfs["C4"]["zeros"]:
        assert r["natural_frequency_hz"] == pytest.approx(math.sqrt(590.0) / (2 * math.pi))
        assert r["damping_ratio"] == pytest.approx(0.7)
    # C4 poles: s (s + B̃1) -> 0 and −4 rad/s; the root at 0 has no damping ratio (null)
    poles = sorted((p["re"], p["im"]) for p in tfs["C4"]["poles"])
    assert poles == [pytest.approx((-4.0, 0.0)), pytest.approx((0.0, 0.0))]
    assert [p["damping_ratio"] for p in tfs["C4"]["poles"] if p["re"] == 0.0] == [None]
    # C5 poles: roots of J_j s² (s² + B̃2 s + K̃2) + K_s (s² + B̃1 s) (descending for np.roots)
    B2t = 1.4 * math.sqrt(590.0)
    den = np.polyadd(0.29 * np.array([1.0, B2t, 590.0, 0.0, 0.0]), 1180.0 * np.array([1.0, 4.0, 0.0]))
    want = np.sort_complex(np.roots(den))
    got = np.sort_complex(np.array([p["re"] + 1j * p["im"] for p in tfs["C5"]["poles"]]))
    np.testing.assert_allclose(got, want, atol=1e-9)
    # G_v: the common root at s = 0 is cancelled exactly -> proper denominator s + B̃1
    assert [(p["re"], p["im"]) for p in tfs["G_v"]["poles"]] == [pytest.approx((-4.0, 0.0))]
    # C7 zeros: s² + 2ζ̂√(αK_c/Ĵ_m) s + αK_c/Ĵ_m (erratum fixed), ω_n² = 1200
    for r in tfs["C7_nominal"]["zeros"]:
        assert r["natural_frequency_hz"] == pytest.approx(math.sqrt(1200.0) / (2 * math.pi))
        assert r["damping_ratio"] == pytest.approx(0.7)


def test_design_approximation(design_json):
    ap = design_json["approximation"]
    f = ap["valid_below_hz"]
    assert isinstance(f, float) and 0 < f < 10
    assert ap["J_m_hat_over_J_j"] == pytest.approx(2.0 / 0.29)
    # independent check of the crossing: |C5/Ĉ5 − 1| = 0.1 at f
    B2t = 1.4 * math.sqrt(590.0)

    def e(fr):
        s = 2j * math.pi * fr
        c5 = (s * s + B2t * s + 590.0) / (0.29 * s * s * (s * s + B2t * s + 590.0) + 1180.0 * (s * s + 4.0 * s))
        c5h = 1.0 / (2.0 * s * s + 8.0 * s)
        return abs(c5 / c5h - 1.0)

    assert e(f) == pytest.approx(0.1, abs=1e-7)
    assert all(e(x) < 0.1 for x in np.geomspace(f / 1e4, f * 0.999, 200))
    # J_j/(Ĵ_m + J_j) = 12.7 % > 10 %: the approximation warning must be raised (docs/method.md#double-compliance-shaping)
    assert any("J_m_hat/J_j" in w and "12.7" in w for w in design_json["warnings"])


def test_design_text_has_units():
    res = run("design", PAPER)
    assert res.exit_code == 0
    out = res.stdout
    for s in ("K2_hat", "N·m/rad", "N·m·s/rad", "torque units", "rad/s", "Hz", "Approximation", "|C5(jω)/Ĉ5(jω) − 1| < 0.1"):
        assert s in out, s


def test_design_plots(tmp_path):
    d = tmp_path / "plots"
    res = run("design", PAPER, "--plots", d)
    assert res.exit_code == 0, res.output
    names = sorted(os.listdir(d))
    assert {"bode_C4.png", "bode_C5.png", "bode_C5_hat.png", "bode_C7_nominal.png", "bode_G_v.png"} <= set(names)
    for n in names:
        assert (d / n).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_design_warning_when_assumptions_fail(tmp_path):
    p = bad_design(tmp_path, "felt_inertia: 0.25", "felt_inertia: 0.05", "warn.yaml")  # Ĵ_m/J_j = 1.4
    res = run("design", p, "--json")
    assert res.exit_code == 0
    assert any("J_m_hat/J_j" in w for w in json.loads(res.stdout)["warnings"])


# ------------------------------------------------------------------------------ error contract
@pytest.mark.parametrize(
    "old,new,field",
    [
        ("amplification: 8.0", "amplification: 0.5", "design.amplification"),
        ("motor_inertia: 0.44", "motor_inertia: -0.44", "plant.motor_inertia"),
        ("felt_damping: 1.0", "felt_damping: .nan", "design.felt_damping"),
        ("zeta: 0.7", "zeta: 0.7\n  zeta_tilde: 1.0", "design.zeta_tilde"),
        ("  joint_inertia: 0.29       # J_j   kg·m²\n", "", "plant.joint_inertia"),
        ("sample_rate_hz: null", "sample_rate_hz: 150", "implementation.gv_filter.cutoff_hz"),
        ("inertia: [0.001, 1.0]", "inertia: [1.0, 0.001]", "humans[0].inertia"),
        ("stiffness: [1.0, 10000.0]", "stiffness: [1.0]", "humans[1].stiffness"),
    ],
)
@pytest.mark.parametrize("command", ["design", "analyze"])
def test_bad_input_exit_2(tmp_path, old, new, field, command):
    p = bad_design(tmp_path, old, new)
    plots = tmp_path / "plots"
    res = run(command, p, "--json", "--plots", plots)
    assert_input_error(res, field)
    assert not plots.exists()


# Command-line usage errors: one line naming the option (or argument), exit code 2, nothing written.
USAGE_ERRORS = [
    # (case, arguments ({out} is a path inside tmp_path), named option, words of the reason)
    ("workers-zero", ["sweep", "spec.yaml", "-o", "{out}", "--workers", "0"], "--workers", "0 is not in the range x>=1"),
    ("seed-negative", ["optimize", "spec.yaml", "-o", "{out}/d.yaml", "--seed", "-1"], "--seed",
     "-1 is not in the range 0<=x<=4294967295"),
    ("seed-2**32", ["optimize", "spec.yaml", "-o", "{out}/d.yaml", "--seed", "4294967296"], "--seed",
     "4294967296 is not in the range 0<=x<=4294967295"),
    ("seed-underscore", ["optimize", "spec.yaml", "-o", "{out}/d.yaml", "--seed", "1_0"], "--seed",
     "'1_0' is not a valid integer"),
    ("workers-underscore", ["sweep", "spec.yaml", "-o", "{out}", "--workers", "1_0"], "--workers",
     "'1_0' is not a valid integer"),
    ("rate-underscore", ["export", PAPER, "-o", "{out}/c.yaml", "--sample-rate-hz", "1_000"], "--sample-rate-hz",
     "expected a number of Hz, got '1_000'"),
    ("duration-underscore", ["simulate", PAPER, "--scenario", "light-mass", "--sample-rate-hz", "1000",
                             "--duration", "1_0", "--plots", "{out}"], "--duration", "expected a number, got '1_0'"),
    ("missing-sample-rate", ["export", PAPER, "-o", "{out}/c.yaml"], "--sample-rate-hz",
     "the design sets no implementation.sample_rate_hz"),
    ("unknown-scenario", ["simulate", PAPER, "--scenario", "moonwalk", "--plots", "{out}"], "--scenario",
     "'moonwalk' is not one of"),
    ("bad-inertia", ["simulate", PAPER, "--scenario", "light-mass", "--human-inertia", "abc", "--plots", "{out}"],
     "--human-inertia", "'abc'"),
    ("unknown-command", ["moonwalk", PAPER, "--plots", "{out}"], "moonwalk", "no such command"),
    ("missing-argument", ["design"], "DESIGN.yaml", "missing required argument"),
    ("unknown-option", ["design", PAPER, "--plot", "{out}"], "--plot", "no such option (did you mean --plots?)"),
    ("option-without-value", ["design", PAPER, "--plots"], "--plots", "requires an argument"),
]


@pytest.mark.parametrize("args,option,reason", [c[1:] for c in USAGE_ERRORS], ids=[c[0] for c in USAGE_ERRORS])
def test_usage_error_one_line(tmp_path, args, option, reason):
    out = tmp_path / "out"
    res = run(*[str(a).format(out=out) for a in args])
    assert res.exit_code == 2, res.output
    lines = res.stderr.strip().splitlines()
    assert lines == [lines[0]] and lines[0].startswith(f"exotune: error: {option}: "), res.stderr
    assert reason in lines[0], lines[0]
    assert "Usage:" not in res.output and "Traceback" not in res.output
    assert res.stdout == ""
    assert list(tmp_path.iterdir()) == []


def test_usage_error_subprocess(tmp_path):
    """The console script prints the same single line (no usage block, no traceback)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    r = subprocess.run(_exotune_cmd() + ["optimize", "spec.yaml", "-o", str(tmp_path / "d.yaml"), "--seed", "-1"],
                       capture_output=True, text=True, env=env, timeout=60)
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.strip().splitlines() == ["exotune: error: --seed: -1 is not in the range 0<=x<=4294967295."]
    assert list(tmp_path.iterdir()) == []


def test_no_arguments_prints_help():
    """``exotune`` alone still prints the help (not an error line)."""
    res = CliRunner().invoke(cli, [])
    assert "Usage:" in res.output and "design" in res.output


@pytest.mark.parametrize("command", ["design", "sea", "analyze"])
def test_unreadable_file(tmp_path, command):
    p = tmp_path / "missing.yaml"
    res = run(command, p)
    assert_input_error(res, str(p))
    assert "cannot read file" in res.stderr


def test_invalid_yaml(tmp_path):
    p = tmp_path / "broken.yaml"
    p.write_text("plant: [1,\n", encoding="utf-8")
    res = run("design", p)
    assert_input_error(res, str(p))
    assert "invalid YAML" in res.stderr


def test_sea_bad_input(tmp_path):
    p = tmp_path / "sea.yaml"
    p.write_text(SEA.read_text(encoding="utf-8").replace("units: deflection", "units: newtons"), encoding="utf-8")
    assert_input_error(run("sea", p, "--json"), "gains.units")


def test_version():
    res = run("--version")
    assert res.exit_code == 0 and __version__ in res.stdout


def _exotune_cmd():
    exe = Path(sys.executable).with_name("exotune")
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "exotune.cli"]


def test_subprocess_error_contract(tmp_path):
    p = bad_design(tmp_path, "amplification: 8.0", "amplification: 0.5")
    plots = tmp_path / "plots"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    for cmd in (_exotune_cmd(), [sys.executable, "-m", "exotune"]):
        r = subprocess.run(cmd + ["design", str(p), "--json", "--plots", str(plots)],
                           capture_output=True, text=True, env=env, timeout=60)
        assert r.returncode == 2, r.stderr
        assert r.stdout == ""
        assert r.stderr.strip().splitlines() == ["exotune: error: design.amplification: must be >= 1, got 0.5"]
        assert not plots.exists()


def test_subprocess_design_json():
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    r = subprocess.run(_exotune_cmd() + ["design", str(PAPER), "--json"], capture_output=True, text=True,
                       env=env, timeout=60)
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert d["gains"]["K1"] == 0.0 and d["gains"]["K2_hat"] == 7.0


# --------------------------------------------------------------------------------- exotune sea
@pytest.fixture(scope="module")
def sea_json():
    res = run("sea", SEA, "--json")
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout)


def _sea_shape(K1, B1, K2, B2, J_m=0.44, B_m=17.9, K_s=1180.0):
    """Paper eq. (hyper_params), deflection units."""
    return K1 / J_m, (B_m + B1) / J_m, (K_s + K1 + K2) / J_m, (B_m + B1 + B2) / J_m


def test_sea_fields(sea_json):
    K1t, B1t, K2t, B2t = _sea_shape(69480.0, 1387.0, -41690.0, -1183.0)
    assert sea_json["shape"] == pytest.approx({"K1_tilde": K1t, "B1_tilde": B1t, "K2_tilde": K2t, "B2_tilde": B2t})
    assert sea_json["low_frequency_stiffness"] == pytest.approx(1180.0 * K1t / K2t)
    assert sea_json["passivity"]["passive"] is False
    assert sea_json["passivity"]["failed_conditions"] == ["B2 >= 0"]
    assert sea_json["c5_stable"] is True
    for k in ("low_frequency_stiffness", "resonance_hz", "max_phase_deg", "max_phase_hz"):
        assert k in sea_json["units"]
    assert sea_json["gains_torque"]["K2"] == pytest.approx(-41690.0 / 1180.0)

    # resonance: brute force over a fine grid of |C5(jω)| (paper eq. (10)
    w = np.geomspace(1.0, 1e4, 400001)
    s = 1j * w
    num = s * s + B2t * s + K2t
    c5 = np.abs(num / (0.29 * s * s * num + 1180.0 * (s * s + B1t * s + K1t)))
    i = int(np.argmax(c5))
    assert 0 < i < len(w) - 1
    assert sea_json["resonance_hz"] == pytest.approx(w[i] / (2 * np.pi), rel=1e-4)
    assert sea_json["resonance_peak_compliance"] == pytest.approx(c5[i], rel=1e-8)
    # max phase of C4: brute force
    c4 = num / (1180.0 * (s * s + B1t * s + K1t))
    ph = np.degrees(np.angle(c4))
    j = int(np.argmax(ph))
    assert sea_json["max_phase_deg"] == pytest.approx(ph[j], abs=1e-6)
    assert sea_json["max_phase_deg"] >= ph[j] - 1e-9
    assert sea_json["max_phase_hz"] == pytest.approx(w[j] / (2 * np.pi), rel=1e-3)
    assert sea_json["max_phase_deg"] > 0  # not passive at high frequency, consistent with B2 < 0


def test_sea_torque_units_equivalent(tmp_path, sea_json):
    p = tmp_path / "sea_t.yaml"
    p.write_text(
        "plant: {motor_inertia: 0.44, motor_damping: 17.9, sea_stiffness: 1180.0, joint_inertia: 0.29}\n"
        f"gains: {{units: torque, K1: 69480.0, B1: 1387.0, K2: {-41690.0 / 1180.0!r}, B2: {-1183.0 / 1180.0!r}}}\n",
        encoding="utf-8",
    )
    res = run("sea", p, "--json")
    assert res.exit_code == 0
    d = json.loads(res.stdout)
    for k in ("low_frequency_stiffness", "resonance_hz", "max_phase_deg"):
        assert d[k] == pytest.approx(sea_json[k], rel=1e-9)


def test_sea_k1_zero(tmp_path):
    """A passive SEA with K1 = 0: zero static stiffness, phase within [−180°, 0°]."""
    p = tmp_path / "sea0.yaml"
    # shape: K̃1 = 0, B̃1 = 20, K̃2 = 2000, B̃2 = 80 (B̃2 > B̃1: passive)
    J_m, B_m, K_s = 0.44, 17.9, 1180.0
    g = dict(K1=0.0, B1=J_m * 20 - B_m, K2=J_m * 2000 - K_s, B2=J_m * (80 - 20))
    p.write_text(
        "plant: {motor_inertia: 0.44, motor_damping: 17.9, sea_stiffness: 1180.0, joint_inertia: 0.29}\n"
        "gains: {units: deflection, " + ", ".join(f"{k}: {v!r}" for k, v in g.items()) + "}\n",
        encoding="utf-8",
    )
    res = run("sea", p, "--json")
    assert res.exit_code == 0, res.output
    d = json.loads(res.stdout)
    assert d["low_frequency_stiffness"] == 0.0
    assert d["c5_rigid_body_mode"] is True and d["c5_stable"] is True
    assert d["passivity"]["passive"] is True
    assert d["max_phase_deg"] <= 1e-9
    assert d["min_phase_deg"] >= -180.0
    text = run("sea", p).stdout
    assert "K1 = 0" in text and "N·m/rad" in text


def test_sea_text():
    res = run("sea", SEA)
    assert res.exit_code == 0
    for s in ("N·m/rad", "Hz", "deg", "B2 >= 0", "NOT passive"):
        assert s in res.stdout, s


# -------------------------------------------------------------------------------- wrappers
def test_analyze_json():
    res = run("analyze", PAPER, "--json")
    assert res.exit_code == 0, res.output
    d = json.loads(res.stdout)
    for k in ("gains", "units", "free_stable", "humans", "passivity", "dob", "amplification"):
        assert k in d


def test_sweep_and_report_registered():
    res = run("--help")
    for c in ("design", "analyze", "sea", "sweep", "report"):
        assert c in res.stdout
    res = run("sweep", "--help")
    for opt in ("--workers", "--dask", "--sample", "--seed", "--chunk-size", "-o"):
        assert opt in res.stdout


def test_no_help_shows_an_unbounded_range_as_none():
    """``exotune sweep --help`` showed ``--seed S … [x<=None]`` (click's range text of an integer
    option without bounds; so did ``excite --periods`` and ``--seed``): every integer option now
    shows its real range, or none."""
    for name in cli.list_commands(None):
        text = run(name, "--help").stdout
        assert "None]" not in text and "x<=None" not in text, name
    flat = " ".join(run("sweep", "--help").stdout.split())
    assert "--seed S Seed for --sample (default 0). [x>=0]" in flat


def test_readme_quickstart_and_ci_agree():
    """The README opens with its title, then the two commands (the install uses the lock file);
    .ci/run installs from the same lock, builds the docs strictly and runs the README's test
    command; the README stays short and cites the product's docs, never an internal spec."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(text.encode("utf-8")) <= 10240
    assert "SPEC §" not in text
    lines = text.splitlines()
    assert lines[0].startswith("# ")
    fence = next(i for i, ln in enumerate(lines) if ln.startswith("```"))
    install, test_cmd = lines[fence + 1], lines[fence + 2]
    assert install.startswith("python3 -m venv .venv")
    assert "pip install -c constraints.txt -e '.[test]'" in install
    assert install.endswith("exotune analyze examples/paper.yaml")
    assert test_cmd == "python -m pytest -n auto tests"
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    assert "set -euo pipefail" in ci
    assert any("pip install -c constraints.txt -e '.[test,docs]'" in ln for ln in ci)
    assert any(ln.strip().startswith("mkdocs build --strict") for ln in ci)
    assert test_cmd in [ln.strip() for ln in ci]
    assert os.access(ROOT / ".ci" / "run", os.X_OK)
    assert (ROOT / "constraints.txt").is_file()


def test_analyze_with_sample_rate_text_and_json(tmp_path):
    """`exotune analyze` on a design with sample_rate_hz: the text report has the sampled-data
    section and the destabilization warning; --json is strict JSON with a `sampled_data` object."""
    p = bad_design(tmp_path, "sample_rate_hz: null", "sample_rate_hz: 1000", name="fs.yaml")
    res = run("analyze", p)
    assert res.exit_code == 0, res.output
    head = res.stdout.splitlines()[3]  # the verdicts of record come first
    assert head.startswith("Sampled-data verdicts of record at 1000 Hz"), res.stdout
    assert "NOT CERTIFIABLE" in res.stdout and "NOT robust" in res.stdout
    res = run("analyze", p, "--json")
    assert res.exit_code == 0, res.output
    d = json.loads(res.stdout, parse_constant=lambda c: pytest.fail(f"non-JSON constant {c}"))
    sd = d["sampled_data"]
    assert sd["sample_rate_hz"] == 1000.0 and sd["free_stable"] is True and sd["certifiable"] is False
    assert [h["kind"] for h in sd["humans"]] == ["mass", "spring", "complex_stiffness"]
    mass = sd["humans"][0]
    assert mass["robust"] is False and 0.001 < mass["stable_intervals"][0][0] < 0.1  # light masses destabilize
    assert d["margins"]["model_of_record"] == "sampled-data at 1000 Hz"
    assert d["margins"]["latency"]["extra_delay_s"] == 0.0  # not robust at the nominal delay


def test_report_says_where_it_wrote_and_sweep_says_workers_unused(tmp_path):
    """Issue 17: ``exotune report DIR`` prints where it wrote (its --help says the default place);
    a sweep with a single chunk says --workers is not used; the per-axis columns' names carry the
    unit of their values (``dob_delay_margin_ms … [ms]``, not ``dob_delay_margin_s … [ms]``)."""
    import yaml

    spec = tmp_path / "spec.yaml"
    spec.write_text(yaml.safe_dump({"base": str(PAPER), "axes": {"design.amplification": [2.0, 8.0]}}))
    out = tmp_path / "sw"
    res = CliRunner().invoke(cli, ["sweep", str(spec), "-o", str(out), "--workers", "2"])
    assert res.exit_code == 0, res.output
    notes = [ln for ln in res.stderr.splitlines() if "--workers 2 not used" in ln]
    assert len(notes) == 1 and "in-process" in notes[0], res.stderr
    res = run("report", out)
    assert res.exit_code == 0, res.output
    assert res.stdout == f"wrote report to {out / 'report'} (1 map, summary.md)\n"
    with open(out / "report" / "axis_design.amplification.csv", encoding="utf-8") as fh:
        head = fh.readline()
    assert '"dob_delay_margin_ms_min [ms]"' in head and "dob_delay_margin_s_" not in head
    md = (out / "report" / "summary.md").read_text(encoding="utf-8")
    assert "dob_delay_margin_ms min [ms]" in md and "`dob_delay_margin_ms` | ms" in md
    assert "dob_delay_margin_s" not in md
    helptext = run("report", "--help").stdout
    assert "DIR/report" in " ".join(helptext.split())


def test_output_checks_name_the_keyword_in_the_api_and_the_option_on_the_command_line(tmp_path):
    """The output checks are the library's: a script is told of its keyword (`out`, `plots`),
    the command line of its option (-o, --plots); nothing is written either way."""
    import exotune
    from exotune.errors import ConfigError
    from exotune.starter import template_text

    design = tmp_path / "design.yaml"
    design.write_text(template_text("design.yaml"))
    before = design.read_text()
    with pytest.raises(ConfigError) as e:
        exotune.export(design, out=design)
    assert "the `out` output is the same file as the input" in e.value.reason
    with pytest.raises(ConfigError) as e:
        exotune.analyze(design, plots=design)
    assert "the `plots` output is the same file as the input" in e.value.reason
    res = CliRunner().invoke(cli, ["export", str(design), "-o", str(design)])
    assert res.exit_code == 2 and "the -o output is the same file as the input" in res.output
    assert "`" not in res.output
    res = CliRunner().invoke(cli, ["analyze", str(design), "--plots", str(design)])
    assert res.exit_code == 2 and "the --plots output is the same file as the input" in res.output
    assert design.read_text() == before and sorted(p.name for p in tmp_path.iterdir()) == ["design.yaml"]


def test_a_spec_key_named_like_an_option_is_named_as_the_spec_key(tmp_path):
    """A sweep spec's ``chunk_size`` and an optimize spec's ``seed`` share their names with the
    commands' --chunk-size and --seed: a bad value in the file names the file's key (the user
    gave no option), a bad option names the option, and the library says which keyword or key."""
    import exotune
    from exotune.errors import ConfigError
    from exotune.starter import template_text

    (tmp_path / "design.yaml").write_text(template_text("design.yaml"))
    sweep = tmp_path / "sweep.yaml"
    sweep.write_text("base: design.yaml\naxes:\n  design.amplification: [2.0, 3.0]\nchunk_size: 0\n")
    res = CliRunner().invoke(cli, ["sweep", str(sweep), "-o", str(tmp_path / "sw")])
    assert res.exit_code == 2 and res.output.startswith("exotune: error: chunk_size: must be >= 1, got 0"), res.output
    assert "--chunk-size" not in res.output and not (tmp_path / "sw").exists()
    with pytest.raises(ConfigError) as e:
        exotune.sweep(sweep, tmp_path / "sw")
    assert (e.value.field, e.value.in_file) == ("chunk_size", True)
    sweep.write_text("base: design.yaml\naxes:\n  design.amplification: [2.0, 3.0]\n")
    with pytest.raises(ConfigError) as e:
        exotune.sweep(sweep, tmp_path / "sw", chunk_size=0)
    assert (e.value.field, e.value.in_file) == ("chunk_size", False)
    assert not (tmp_path / "sw").exists()

    opt = tmp_path / "optimize.yaml"
    opt.write_text("base: design.yaml\nobjective: amplification\nfree:\n  design.amplification: [1.5, 40.0]\n"
                   "seed: -3\n")
    res = CliRunner().invoke(cli, ["optimize", str(opt), "-o", str(tmp_path / "best.yaml")])
    assert res.exit_code == 2, res.output
    assert res.output.startswith("exotune: error: seed: expected an integer from 0 to 4294967295 (2**32 − 1), "
                                 "got -3"), res.output
    assert "--seed" not in res.output and not (tmp_path / "best.yaml").exists()
    opt.write_text("base: design.yaml\nobjective: amplification\nfree:\n  design.amplification: [1.5, 40.0]\n")
    with pytest.raises(ConfigError) as e:
        exotune.optimize(opt, out=tmp_path / "best.yaml", seed=-2)
    assert (e.value.field, e.value.in_file) == ("seed", False)
    assert not (tmp_path / "best.yaml").exists()


@pytest.mark.parametrize("encoding, example", [("cp1252", "paper"), ("cp437", "paper"), ("latin-1", "scheduled")])
def test_an_8_bit_terminal_gets_the_report_with_symbols_spelled_out(encoding, example):
    """``PYTHONIOENCODING=cp1252 exotune analyze``: exit 2 "'charmap' codec can't encode character
    '≤'" and an empty stdout. Symbols the code page lacks are spelled in ASCII now. (The gain
    schedule's longer report, ~10 s to analyse, runs once, under latin-1: the code page with the
    fewest of the report's symbols.)"""
    env = dict(os.environ, PYTHONIOENCODING=encoding)
    res = subprocess.run([sys.executable, "-m", "exotune", "analyze", str(ROOT / "examples" / f"{example}.yaml")],
                         capture_output=True, env=env, timeout=600)
    assert res.returncode == 0, res.stderr.decode(encoding, "replace")
    out = res.stdout.decode(encoding)
    assert "latency margin" in out and ("k* <=" in out or "k* ≤" in out)  # cp437 has ≤, cp1252 and latin-1 not
    assert ("k* <=" in out) == (encoding != "cp437")
