"""exotune.controllerfile.verdicts: the verdicts of record of a design with a sample rate agree with
``certify`` of the file ``export`` writes for the same design (examples/scheduled.yaml at 1 kHz,
without its transmission: one controller), and with the spectral radius of the loop matrix built
here; ``analyze_of_record`` carries them beside the continuous analysis."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest

from exotune.config import read_yaml
from exotune.controllerfile import build_export, design_at_rate
from exotune.controllerfile.fileio import discrete_from_file, plant_from_file
from exotune.controllerfile.certify import certify
from exotune.controllerfile.verdicts import SampledVerdicts, analyze_of_record, design_verdicts
from exotune.errors import ConfigError
from exotune.sampled import closed_loop_matrix, plant_ss

ROOT = Path(__file__).resolve().parents[2]
FS = 1000.0


def _raw() -> dict:
    raw = read_yaml(ROOT / "examples" / "scheduled.yaml")
    raw.pop("transmission", None)
    return raw


@pytest.fixture(scope="module")
def cfg():
    return design_at_rate(_raw(), FS)


@pytest.fixture(scope="module")
def verdicts(cfg):
    return design_verdicts(cfg)


@pytest.fixture(scope="module")
def certified(cfg):
    return certify(build_export(cfg, FS)).to_dict()


def test_verdicts_agree_with_certify_of_the_exported_file(verdicts, certified):
    assert isinstance(verdicts, SampledVerdicts)
    assert certified["certified"] is True, certified["problems"]
    assert verdicts.certifiable is True and verdicts.problems == ()
    assert verdicts.sample_rate_hz == FS and verdicts.delay_s == pytest.approx(certified["delay_s"], rel=1e-12)
    sa, ref = verdicts.analysis, certified["sampled"]
    for k in ("free_stable", "locked_stable"):
        assert sa[k] is ref[k] is True
    for k in ("free_spectral_radius", "locked_spectral_radius"):
        assert sa[k] == pytest.approx(ref[k], rel=1e-12)
    for a, b in zip(sa["humans"], ref["humans"]):
        assert a.get("stable_intervals") == b.get("stable_intervals") and a.get("robust") == b.get("robust")
    assert verdicts.robust is True
    assert verdicts.latency_margin_s == pytest.approx(certified["latency_margin"]["extra_delay_s"], rel=2e-3)
    assert verdicts.required_latency_margin_s == pytest.approx(certified["latency_margin"]["required_s"], rel=1e-12)
    d = verdicts.to_dict()
    assert d["certifiable"] is True and d["latency_margin"]["met"] is True
    assert d["delay_samples"] == pytest.approx(verdicts.delay_s * FS, rel=1e-12)


def test_locked_spectral_radius_is_the_loop_matrix(cfg, verdicts):
    doc = build_export(cfg, FS, analyses=False)
    A, B, C = plant_ss(plant_from_file(doc), None, "locked")
    lam = np.linalg.eigvals(closed_loop_matrix(A, B, C, discrete_from_file(doc)))
    assert verdicts.analysis["locked_spectral_radius"] == pytest.approx(float(np.max(np.abs(lam))), rel=1e-9)


def test_requirement_above_the_margin_is_a_problem(cfg, verdicts):
    v = design_verdicts(cfg, require_latency_margin_s=2 * verdicts.latency_margin_s)
    assert not v.certifiable and any("latency margin" in p for p in v.problems)
    assert v.to_dict()["latency_margin"]["met"] is False


def test_no_rate_is_refused_and_analyze_of_record_without_rate_has_no_verdicts():
    from exotune.config import design_from_mapping

    raw = _raw()
    raw["implementation"].pop("sample_rate_hz", None)
    c = design_from_mapping(raw)
    with pytest.raises(ConfigError, match="sample_rate_hz"):
        design_verdicts(c)
    assert getattr(analyze_of_record(c), "sampled", None) is None


def test_analyze_of_record_carries_the_verdicts(cfg, verdicts):
    r = analyze_of_record(cfg)
    assert r.sampled is not None
    assert r.sampled.analysis["free_spectral_radius"] == pytest.approx(verdicts.analysis["free_spectral_radius"], rel=1e-12)
    assert r.sampled.latency_margin_s == pytest.approx(verdicts.latency_margin_s, rel=2e-3)
