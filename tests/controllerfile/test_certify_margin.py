"""The latency margins of the controller file (docs/controller-file.md#latency-margin):

* ``predicted.latency_margin`` is the continuous margin of the design as exported
  (:func:`exotune.analysis.latency_margin.latency_margin`), ``requirements.latency_margin_s`` defaults to one sample;
* certify's sampled-data margin is ≥ 0, below the continuous one by about half a sample (the
  zero-order hold) or less, and checked against an independent sampled-data model written here
  (plant from the physical equations, ZOH and fractional delay by ``scipy.signal.cont2discrete``,
  the controller from the file's sos filters by ``scipy.signal.sos2tf``/``tf2ss``): stable at
  T + ΔT(1 − 1e-3), unstable at T + ΔT(1 + 1e-3) for the critical member;
* a requirement above the margin fails certify naming both numbers (exit 1 through the CLI);
* files without the new sections (written before them) still load and certify.
"""

from __future__ import annotations

import copy
import math
import re
from pathlib import Path

import numpy as np
import pytest
import scipy.signal
import yaml
from click.testing import CliRunner

from exotune.analysis.latency_margin import latency_margin
from exotune.cli import cli
from exotune.config import read_yaml
from exotune.controllerfile import design_at_rate, export_design, load_controller, validate_controller
from exotune.controllerfile.certify import certify
from exotune.controllerfile.export import requirements_section
from exotune.controllerfile.latency import requirement_problems
from exotune.errors import ConfigError

ROOT = Path(__file__).resolve().parents[2]
FS = 1000.0


def _raw() -> dict:
    """examples/scheduled.yaml without its transmission (one controller: a quicker export/certify)."""
    raw = read_yaml(ROOT / "examples" / "scheduled.yaml")
    raw.pop("transmission", None)
    return raw


@pytest.fixture(scope="module")
def design(tmp_path_factory):
    p = tmp_path_factory.mktemp("margin") / "design.yaml"
    p.write_text(yaml.safe_dump(_raw(), sort_keys=False), encoding="utf-8")
    return p


@pytest.fixture(scope="module")
def exported(design):
    out = design.parent / "ctl.yaml"
    doc = export_design(design, FS, out).to_dict()
    return out, doc


@pytest.fixture(scope="module")
def certified(exported):
    return certify(load_controller(exported[0])).to_dict()


def test_predicted_margin_is_the_continuous_margin(exported):
    doc = exported[1]
    m = latency_margin(design_at_rate(_raw(), FS))
    pm = doc["predicted"]["latency_margin"]
    assert pm["extra_delay_s"] == m.extra_delay_s
    assert pm["extra_delay_samples"] == pytest.approx(m.extra_delay_s * FS, rel=1e-12)
    assert pm["critical"]["loop"] == m.critical.loop and pm["critical"]["value"] == m.critical.value
    assert pm["units"]["extra_delay_s"] == "s"
    assert doc["requirements"]["latency_margin_s"] == 1.0 / FS  # default: one sample period
    assert "one sample period" in doc["requirements"]["source"]


def test_sampled_margin_below_continuous_by_at_most_about_half_a_sample(exported, certified):
    lm = certified["latency_margin"]
    cont = exported[1]["predicted"]["latency_margin"]["extra_delay_s"]
    assert certified["certified"], certified["problems"]
    assert lm["confirmed"] is True
    assert lm["predicted_continuous_s"] == cont and lm["required_s"] == 1.0 / FS
    assert 0.0 <= lm["extra_delay_s"] <= cont
    assert (cont - lm["extra_delay_s"]) * FS <= 0.6  # the ZOH costs about half a sample
    assert lm["extra_delay_samples"] == pytest.approx(lm["extra_delay_s"] * FS, rel=1e-12)
    assert lm["critical"]["loop"] == "human0_mass" and lm["critical"]["parameter"] == "inertia"


# ------------------------------------------------------------------------------------------
# an independent sampled-data model (nothing from exotune.sampled / exotune.controllerfile)
# ------------------------------------------------------------------------------------------
SIGNALS = ("theta_m", "omega_m", "tau_s", "dtau_s", "tau_c")


def _plant_with_mass(doc: dict, m: float):
    """x = [θ_m, ω_m, θ_j, ω_j, θ_h, ω_h], input τ_m, outputs SIGNALS (a human mass m on the cuff)."""
    p = {k: v["value"] for k, v in doc["plant"].items()}
    Jm, Bm, Ks = p["motor_inertia"], p["motor_damping"], p["sea_stiffness"]
    Jj, Kc = p["joint_inertia"], p["cuff_stiffness"]
    A = np.zeros((6, 6))
    A[0, 1] = A[2, 3] = A[4, 5] = 1.0
    A[1, :3] = [-Ks / Jm, -Bm / Jm, Ks / Jm]  # J_m θ̈_m = −B_m θ̇_m + K_s(θ_j − θ_m) + τ_m
    A[3, [0, 2, 4]] = [Ks / Jj, -(Ks + Kc) / Jj, Kc / Jj]  # J_j θ̈_j = K_c(θ_h − θ_j) − K_s(θ_j − θ_m)
    A[5, [2, 4]] = [Kc / m, -Kc / m]  # m θ̈_h = −K_c(θ_h − θ_j)
    B = np.zeros((6, 1))
    B[1, 0] = 1.0 / Jm
    e = np.eye(6)
    C = np.vstack([e[0], e[1], Ks * (e[2] - e[0]), Ks * (e[3] - e[1]), Kc * (e[4] - e[2])])
    return A, B, C


def _zoh(A, B, dt):
    if dt <= 0.0:
        return np.eye(A.shape[0]), np.zeros_like(B)
    Ad, Bd, *_ = scipy.signal.cont2discrete((A, B, np.zeros((1, A.shape[0])), np.zeros((1, 1))), dt, method="zoh")
    return Ad, Bd


def independent_radius(doc: dict, m: float, delay: float, rigid: bool = True) -> float:
    """Spectral radius of the file's sampled-data loop with a human mass ``m`` and total delay ``delay``
    (``rigid``: without the eigenvalue nearest z = 1)."""
    A, B, C = _plant_with_mass(doc, m)
    Ts = 1.0 / doc["sample_rate_hz"]["value"]
    d = int(math.floor(delay / Ts + 1e-12))
    f = delay / Ts - d
    Pa, Ga = _zoh(A, B, (1.0 - f) * Ts)  # the newer command, applied for the last (1 − f) T_s
    Pb, Gb = _zoh(A, B, f * Ts)  # the older one, for the first f T_s
    filt = []
    for fl in doc["controller"]["filters"]:
        b, a = scipy.signal.sos2tf(np.asarray(fl["sos"], float))
        filt.append((scipy.signal.tf2ss(b, a), fl["input"]))
    n, nz, ns = 6, sum(ss[0].shape[0] for ss, _ in filt), d + 1
    N = n + nz + ns
    tau = np.zeros(N)  # τ_cmd[k] as a linear form of the loop state
    static = doc["controller"]["gains"]
    for i, s in enumerate(SIGNALS):
        tau[:n] += static.get(s, {"gain": 0.0})["gain"] * C[i]
    g_cmd, off = 0.0, n
    for (Af, Bf, Cf, Df), inp in filt:
        k = Af.shape[0]
        tau[off:off + k] += Cf[0]
        if inp == "tau_cmd":
            g_cmd += Df[0, 0]
        else:
            tau[:n] += Df[0, 0] * C[SIGNALS.index(inp)]
        off += k
    tau /= 1.0 - g_cmd
    M = np.zeros((N, N))
    s0 = n + nz  # shift state j holds τ_cmd[k − 1 − j]
    new = tau if d == 0 else np.eye(N)[s0 + d - 1]
    M[:n, :n] = Pa @ Pb
    M[:n] += np.outer((Pa @ Gb)[:, 0], np.eye(N)[s0 + d]) + np.outer(Ga[:, 0], new)
    off = n
    for (Af, Bf, Cf, Df), inp in filt:
        k = Af.shape[0]
        M[off:off + k, off:off + k] += Af
        M[off:off + k] += np.outer(Bf[:, 0], tau if inp == "tau_cmd" else np.r_[C[SIGNALS.index(inp)], np.zeros(N - n)])
        off += k
    M[s0] = tau
    for j in range(1, ns):
        M[s0 + j, s0 + j - 1] = 1.0
    lam = np.linalg.eigvals(M)
    if rigid:  # no position feedback and a mass on the cuff: the rigid-body mode z = 1
        lam = np.delete(lam, int(np.argmin(np.abs(lam - 1.0))))
    return float(np.max(np.abs(lam)))


def test_sampled_margin_against_an_independent_model(exported, certified):
    doc = exported[1]
    lm = certified["latency_margin"]
    T, dT, m = doc["delay_s"]["value"], lm["extra_delay_s"], lm["critical"]["value"]
    assert "theta_m" not in doc["controller"]["gains"]  # ungrounded: the rigid-body mode z = 1 is excused
    assert abs(independent_radius(doc, m, T, rigid=False) - 1.0) < 1e-9
    assert independent_radius(doc, m, T) < 1.0
    assert independent_radius(doc, m, T + dT * (1 - 1e-3)) < 1.0
    assert independent_radius(doc, m, T + dT * (1 + 1e-3)) > 1.0
    # and the ends of the family stay stable just below the margin
    assert independent_radius(doc, 1.0, T + dT * (1 - 1e-3)) < 1.0


def test_certify_text_shows_the_margin(certified):
    from exotune.text.certify import format_certify

    txt = format_certify(certified)
    line = next(ln for ln in txt.splitlines() if "latency margin (sampled-data)" in ln)
    assert "critical human0_mass at inertia = 0.01 kg·m²" in line and "required 1 ms" in line


# ------------------------------------------------------------------------------------------
# requirements
# ------------------------------------------------------------------------------------------
def test_requirement_above_the_margin_fails_through_the_cli(design, certified):
    out = design.parent / "ctl_req.yaml"
    args = ["export", str(design), "--sample-rate-hz", "1000", "-o", str(out), "--require-latency-margin-s", "0.002"]
    res = CliRunner().invoke(cli, args)  # export refuses a file that fails its own requirement
    assert res.exit_code == 1 and not out.exists(), res.output
    ms = certified["latency_margin"]["extra_delay_s"] * 1e3
    assert f"latency margin {ms:.3g} ms ({ms:.3g} samples) < required 2 ms" in res.output, res.output
    res = CliRunner().invoke(cli, args + ["--allow-uncertified"])
    assert res.exit_code == 0, res.output
    assert "(required 2 ms)" in res.stdout and "WRITTEN UNCERTIFIED" in res.stdout
    doc = load_controller(out)
    assert doc["requirements"]["latency_margin_s"] == 0.002
    assert doc["provenance"]["allow_uncertified"] is True and doc["provenance"]["uncertified"]
    res = CliRunner().invoke(cli, ["certify", str(out)])
    assert res.exit_code == 1, res.output
    want = f"latency margin {ms:.3g} ms ({ms:.3g} samples) < required 2 ms"
    assert want in res.stdout, res.stdout
    assert re.search(r"NOT CERTIFIED:\n(  - .*\n)*  - latency margin", res.stdout)


def test_edited_requirement_passes_the_consistency_checks(exported, tmp_path):
    doc = copy.deepcopy(exported[1])
    doc["requirements"] = {"latency_margin_s": 0.0, "unit": "s", "source": "edited by hand"}
    p = tmp_path / "edited.yaml"
    p.write_text(yaml.safe_dump(doc, allow_unicode=True, sort_keys=False), encoding="utf-8")
    assert load_controller(p)["requirements"]["latency_margin_s"] == 0.0
    bad = copy.deepcopy(doc)
    bad["requirements"]["latency_margin_s"] = -1e-3
    with pytest.raises(ConfigError, match="requirements.latency_margin_s"):
        validate_controller(bad)


def test_zero_disables_and_bad_values_are_refused():
    assert requirements_section(FS, 0)["latency_margin_s"] == 0.0
    assert requirements_section(FS, "0.003")["latency_margin_s"] == 0.003
    assert requirement_problems({"required_s": 0.0, "extra_delay_s": 0.0, "extra_delay_samples": 0.0}) == []
    assert requirement_problems({"required_s": 1e-3, "extra_delay_s": None, "extra_delay_samples": None}) == []
    for bad in ("-1", "abc", "inf"):
        with pytest.raises(ConfigError, match="require_latency_margin_s"):
            requirements_section(FS, bad)


def test_file_without_the_new_sections_still_certifies(exported, tmp_path):
    doc = copy.deepcopy(exported[1])
    del doc["requirements"]
    del doc["predicted"]["latency_margin"]
    p = tmp_path / "legacy.yaml"
    p.write_text(yaml.safe_dump(doc, allow_unicode=True, sort_keys=False), encoding="utf-8")
    rep = certify(load_controller(p)).to_dict()
    assert rep["certified"], rep["problems"]
    lm = rep["latency_margin"]
    assert lm["predicted_continuous_s"] is None and lm["required_s"] is None and lm["confirmed"] is True
    assert lm["extra_delay_s"] > 0


def test_a_wrong_prediction_only_moves_the_start(exported, certified):
    from exotune.controllerfile.certify import position_feedback, sampled_analysis
    from exotune.controllerfile.latency import sampled_latency_margin

    doc = copy.deepcopy(exported[1])
    doc["predicted"]["latency_margin"]["extra_delay_s"] = 0.05  # edited: 25× the true margin
    doc["predicted"]["latency_margin"]["critical"]["value"] = 0.5
    lm = sampled_latency_margin(doc, certified["sampled"], position_feedback(doc["controller"]), sampled_analysis)
    assert lm["confirmed"] is True and lm["predicted_continuous_s"] == 0.05
    assert lm["extra_delay_s"] == pytest.approx(certified["latency_margin"]["extra_delay_s"], rel=2e-3)
