"""exotune.simulation.engine: a run of a controller file — the fast linear stretches equal stepping
the runtime, a bumpless start is a steady state, the DOB stripped, the options checked."""

import numpy as np
import pytest

from exotune.controllerfile import Runtime
from exotune.errors import ConfigError
from exotune.simulation.engine import STARTS, bumpless_start, check_start, simulate, strip_dob
from exotune.simulation.scenarios import SCENARIOS

from paper_design import paper_controller


@pytest.fixture(scope="module")
def doc():
    return paper_controller(1000.0, delay_s=0.0015)


@pytest.mark.parametrize("name", ["locked-output", "light-mass"])
def test_fast_stretches_equal_stepping_the_runtime(doc, name):
    fast = simulate(doc, SCENARIOS[name], duration_s=0.4)
    slow = simulate(doc, SCENARIOS[name], duration_s=0.4, fast=False)
    assert fast["fast_samples"] > 0 and slow["fast_samples"] == 0
    assert fast["series"]["t"].size == slow["series"]["t"].size == 400
    for key in ("theta_m", "tau_s", "tau_c", "tau_cmd", "tau_m"):
        a, b = fast["series"][key], slow["series"][key]
        assert np.allclose(a, b, rtol=1e-9, atol=1e-9 * max(1.0, float(np.max(np.abs(b))))), key
    assert fast["sample_rate_hz"] == 1000.0 and fast["delay_samples"] == pytest.approx(1.5)
    assert fast["locked"] == (name == "locked-output") and fast["diverged"] is None


def test_the_push_and_the_limit_are_applied(doc):
    sim = simulate(doc, SCENARIOS["saturation"], duration_s=1.2)
    s = sim["series"]
    assert np.allclose(s["push"][s["t"] < 0.05], 0.0) and np.allclose(s["push"][(s["t"] >= 0.05) & (s["t"] < 1.0)], 20.0)
    assert np.max(np.abs(s["tau_m"])) <= 40.0 * (1 + 1e-12)  # the motor limit


def test_bumpless_start_is_a_steady_state(doc):
    """Every filter starts at the steady state of its constant input (its measurement, or the held
    command for the DOB's loop filters): stepping it with that input leaves its state as it is."""
    rt = Runtime(doc)
    y0 = {"theta_m": 0.01, "omega_m": 0.0, "tau_s": 2.0, "dtau_s": 0.0, "tau_c": 2.0}
    tau0, note = bumpless_start(rt, y0)
    assert note == ""
    assert tau0 == pytest.approx(-2.0)  # the motor at rest against the spring: no disturbance estimate
    pairs = [(f, y0[s]) for s, f in rt.filters] + [(f, tau0) for f in rt.loop]
    assert pairs
    for f, x in pairs:
        before = np.array(f.z, dtype=float)
        f.step(x)
        assert np.allclose(np.array(f.z, dtype=float), before, rtol=1e-12, atol=1e-12)


def test_strip_dob_removes_its_filters(doc):
    bare = strip_dob(doc)
    assert len(Runtime(bare).loop) == 0 and len(Runtime(doc).loop) > 0
    names = [f["name"] for f in doc["controller"]["filters"]]
    assert doc["controller"]["filters"] and [f["name"] for f in doc["controller"]["filters"]] == names  # unchanged
    a = simulate(doc, SCENARIOS["light-mass"], without_dob=True, duration_s=0.2)
    b = simulate(bare, SCENARIOS["light-mass"], duration_s=0.2)
    assert np.allclose(a["series"]["theta_h"], b["series"]["theta_h"], rtol=1e-12, atol=1e-15)


def test_options_are_checked_and_progress_reported(doc):
    for bad in ("warm", 1, None):
        with pytest.raises(ConfigError) as ei:
            simulate(doc, SCENARIOS["light-mass"], start=bad)
        assert ei.value.field == "start" and ei.value.reason == f"must be one of bumpless, zero, got {bad!r}"
    assert check_start("zero") == "zero"
    assert STARTS == ("bumpless", "zero")
    seen = []
    simulate(doc, SCENARIOS["light-mass"], duration_s=0.2, progress=seen.append)
    assert seen and seen[-1] == 1.0 and seen == sorted(seen)
