"""A motor-position reference in a simulation (``Scenario.reference_rad``: the paper's DOB test of
Fig. 9 ran position-control SEA gains on a slow sinusoidal position input): the runtime adds the
reference's feedforward before the DOB's loop solve, the motor tracks the reference, and the DOB
still estimates the friction."""

from __future__ import annotations

import copy
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from exotune.config import load_design
from exotune.controllerfile import Runtime, build_export
from exotune.simulation import SCENARIOS, Nonlinearities, run_scenario, simulate

ROOT = Path(__file__).resolve().parents[2]
K_S = 1180.0  # examples/paper.yaml


@pytest.fixture(scope="module")
def position_doc():
    """The paper controller with the paper's position-control gains and no cuff path."""
    doc = build_export(load_design(ROOT / "examples" / "paper.yaml"), 1000.0, analyses=False)
    g = doc["controller"]["gains"]
    g["theta_m"] = {"gain": -69480.0, "unit": "N·m/rad"}
    g["omega_m"] = {"gain": -1387.0, "unit": "N·m·s/rad"}
    g["tau_s"] = {"gain": -41690.0 / K_S, "unit": "1"}
    g["dtau_s"] = {"gain": -1183.0 / K_S, "unit": "s"}
    doc["controller"]["filters"] = [f for f in doc["controller"]["filters"] if f["input"] != "tau_c"]
    return doc


def _scenario(coulomb: float = 0.0, duration: float = 6.0):
    return replace(SCENARIOS["dob-friction"], name="position", push_nm=0.0, push_hz=0.0, duration_s=duration,
                   nonlinear=Nonlinearities(coulomb_nm=coulomb), compare_without_dob=False,
                   reference_rad=0.5, reference_hz=0.25)


@settings(max_examples=30, deadline=None)
@given(ff=st.floats(-1e3, 1e3, allow_nan=False), seed=st.integers(0, 1000))
def test_feedforward_enters_before_the_dob_loop_solve(position_doc, ff, seed):
    """From equal states, a feedforward f changes the command by f/(1 − g) (g the DOB loop's
    feed-through) and the DOB's loop filters see the changed command."""
    rng = np.random.default_rng(seed)
    a, b = Runtime(position_doc), Runtime(position_doc)
    for _ in range(5):  # the same non-zero state
        y = dict(zip(("theta_m", "omega_m", "tau_s", "dtau_s", "tau_c"), rng.normal(size=5)))
        assert a.step(y) == b.step(y)
    y = dict(zip(("theta_m", "omega_m", "tau_s", "dtau_s", "tau_c"), rng.normal(size=5)))
    ua, ub = a.step(y, ff), b.step(y)
    assert ua - ub == pytest.approx(ff / (1.0 - a.loop_feedthrough), rel=1e-9, abs=1e-9)
    if abs(ff) >= 1.0:  # well above the states' rounding
        assert [f.z.tolist() for f in a.loop] != [f.z.tolist() for f in b.loop]


def test_default_feedforward_changes_nothing(position_doc):
    a, b = Runtime(position_doc), Runtime(position_doc)
    y = {"theta_m": 0.1, "omega_m": -0.2, "tau_s": 3.0, "dtau_s": 1.0, "tau_c": 0.5}
    assert a.step(y) == b.step(y, 0.0)


def test_reference_is_a_cosine_swing_from_rest():
    sc = _scenario()
    assert sc.reference(0.0) == (0.0, 0.0)
    r, w = sc.reference(2.0)  # half a period of 0.25 Hz: the top of the swing
    assert r == pytest.approx(1.0) and abs(w) < 1e-12
    assert SCENARIOS["dob-friction"].reference(1.0) == (0.0, 0.0)


def test_position_controller_tracks_the_reference(position_doc):
    sim = simulate(position_doc, _scenario())
    s = sim["series"]
    ref = np.array([_scenario().reference(t)[0] for t in s["t"]])
    late = s["t"] >= 1.0
    err = np.max(np.abs(s["theta_m"][late] - ref[late]))
    assert err < 0.01 * np.ptp(ref)  # a stiff position loop: under 1 % of the 1 rad swing
    assert sim["fast_samples"] == 0  # the linear recursion has no reference input: every sample stepped


def test_dob_estimates_friction_under_position_control(position_doc):
    rep = run_scenario(position_doc, _scenario(coulomb=2.0)).to_dict()
    fe = rep["friction_estimate"]
    assert fe["rms_friction"]["value"] == pytest.approx(2.0, rel=0.02)
    assert fe["relative_error"]["value"] < 0.12
    assert rep["summary"]["loop_spectral_radius"]["value"] < 1.0
    assert math.isfinite(rep["summary"]["envelope_growth_rate"]["value"])


def test_without_a_reference_the_fast_path_still_runs(position_doc):
    sc = replace(_scenario(), reference_rad=0.0, duration_s=0.5)
    d = copy.deepcopy(position_doc)
    assert simulate(d, sc)["fast_samples"] > 0
