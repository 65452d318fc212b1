"""exotune.controllerfile.certify: the sampled-data verdicts of a controller file against the loop
matrix built here from the same file (exotune.sampled.closed_loop_matrix, the rigid-body z = 1 of the
ungrounded free loop removed by hand), a tampered gain refused naming its field, and the certificate
of a file whose predictions are its own (examples/scheduled.yaml at 1 kHz, tests/controllerfile/conftest.py)."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from exotune.controllerfile.fileio import discrete_from_file, plant_from_file
from exotune.controllerfile.certify import (certify, check_built_from_design, design_mismatches, position_feedback,
                                            sampled_analysis, sampled_problems)
from exotune.errors import ConfigError
from exotune.sampled import closed_loop_matrix, plant_ss


def _radius(doc, human=None, env="free"):
    """Spectral radius of the file's loop, built directly; one eigenvalue at z = 1 dropped when nothing grounds it."""
    A, B, C = plant_ss(plant_from_file(doc), human, env)
    lam = np.linalg.eigvals(closed_loop_matrix(A, B, C, discrete_from_file(doc)))
    grounded = (env == "locked" or position_feedback(doc["controller"])
                or bool(human and human.get("stiffness")))
    if not grounded:
        i = int(np.argmin(np.abs(lam - 1.0)))
        assert abs(lam[i] - 1.0) < 1e-7
        lam = np.delete(lam, i)
    return float(np.max(np.abs(lam)))


@pytest.fixture(scope="module")
def analysis(scheduled_doc):
    return sampled_analysis(scheduled_doc)


def test_free_and_locked_verdicts_are_the_spectral_radius_of_the_loop_matrix(scheduled_doc, analysis):
    assert scheduled_doc["gains"]["K1"]["value"] == 0.0  # ungrounded free loop: z = 1 removed
    rf, rl = _radius(scheduled_doc), _radius(scheduled_doc, env="locked")
    assert analysis["free_spectral_radius"] == pytest.approx(rf, rel=1e-9)
    assert analysis["locked_spectral_radius"] == pytest.approx(rl, rel=1e-9)
    assert analysis["free_stable"] is (rf < 1) and analysis["locked_stable"] is (rl < 1)


def test_family_intervals_agree_with_direct_eigenvalues(scheduled_doc, analysis):
    fams = {h["kind"]: h for h in analysis["humans"]}
    assert "skipped" in fams["complex_stiffness"]  # hysteretic damping: no finite-dimensional model
    for kind, key in (("mass", "inertia"), ("spring", "stiffness")):
        h = fams[kind]
        lo, hi = h["range"]
        inside = lambda v: any(a * (1 - 1e-9) <= v <= b * (1 + 1e-9) for a, b in h["stable_intervals"])  # noqa: E731
        for v in np.geomspace(lo, hi, 7):
            r = _radius(scheduled_doc, {key: float(v), "damping": 0.0})
            assert (r < 1) == inside(v), (kind, v, r, h["stable_intervals"])
        assert h["robust"] is (h["stable_intervals"] == [[lo, hi]])
    assert sampled_problems(analysis) == []


def test_file_with_its_own_predictions_certifies(scheduled_doc, analysis):
    """The fixture leaves the predictions empty (certify then refuses, naming them); filled with
    the analysis' own numbers the file certifies, with the same verdicts."""
    rep = certify(scheduled_doc).to_dict()
    assert rep["certified"] is False
    assert any("predicted" in p for p in rep["problems"])
    assert rep["golden"]["max_abs_error"]["value"] == 0.0
    d = copy.deepcopy(scheduled_doc)
    d["predicted"]["sampled"] = copy.deepcopy(rep["sampled"])
    for e, r in zip(d["gain_schedule"]["entries"], rep["gain_schedule"]):
        e["predicted_sampled"] = copy.deepcopy(r["sampled"])
    rep2 = certify(d).to_dict()
    assert rep2["certified"] is True, rep2["problems"]
    assert rep2["sampled"]["free_spectral_radius"] == pytest.approx(_radius(d), rel=1e-9)
    assert rep2["latency_margin"]["extra_delay_s"] >= rep2["latency_margin"]["required_s"]


def test_tampered_gain_is_refused_naming_the_field(scheduled_doc):
    assert design_mismatches(scheduled_doc) == []
    d = copy.deepcopy(scheduled_doc)
    d["gains"]["B1"]["value"] *= 1.5
    with pytest.raises(ConfigError, match="B1"):
        check_built_from_design(d)
    with pytest.raises(ConfigError, match="B1"):
        certify(d)


def test_the_schedule_entry_that_runs_the_file_itself_reuses_an_identical_analysis(scheduled_doc):
    """certify and export analyse the file's own loop once: the gain-schedule entry at ratio 1 runs
    the file's plant, gains and controller (``runs_the_file_itself``) and takes the file's own
    analysis (``decision_and_nominal``). Only that entry is recognised, one ulp of a gain makes it
    another loop, and the analysis it takes equals a fresh analysis of its own view."""
    from exotune.controllerfile import ControllerFile
    from exotune.controllerfile.certify import decision_and_nominal, runs_the_file_itself, sampled_analysis

    entries = scheduled_doc["gain_schedule"]["entries"]
    flags = [runs_the_file_itself(scheduled_doc, e) for e in entries]
    assert flags == [e["ratio"] == 1.0 for e in entries]
    own = entries[flags.index(True)]
    for key in ("B1", "K2_hat"):
        moved = copy.deepcopy(own)
        moved["gains"][key]["value"] = float(np.nextafter(moved["gains"][key]["value"], np.inf))
        assert not runs_the_file_itself(scheduled_doc, moved)
    moved = copy.deepcopy(own)
    moved["plant"]["sea_stiffness"]["value"] *= 1.0 + 1e-15
    assert not runs_the_file_itself(scheduled_doc, moved)

    cf = ControllerFile.from_dict(copy.deepcopy(scheduled_doc))
    _sa, _lm, _problems, (nominal_sa, _nominal_lm) = decision_and_nominal(cf)
    fresh = sampled_analysis(cf.entry_view(cf.gain_schedule.entries[flags.index(True)]))
    assert repr(fresh) == repr(nominal_sa)
