"""The optimizer's DOB constraints (dob_phase_margin_deg, dob_gain_margin_db, dob_delay_margin_s)
are broken by every design whose closed DOB loop is unstable. Reference: the standard DOB loop
L = ω_q² e^{−sT}/(s (s + 2ζω_q)) is stable iff T < atan(2ζω_q/ω_c)/ω_c, ω_c the root of
|L(jω)| = 1 found here with mpmath; its continuous phase margin is 90° − atan(ω_c/(2ζω_q)) − ω_c T.

Found: the phase margin was wrapped into (−180°, 180°], so the paper's DOB (60 Hz, ζ = 0.7) with
T = 20 ms (continuous PM −214.9°) read +145.1° and met ``dob_phase_margin_deg: 30``."""

from __future__ import annotations

import copy
from pathlib import Path

import mpmath as mp
import numpy as np
import pytest

from exotune.config import load_design
from exotune.errors import ConfigError
from exotune.optimization.evaluate import column, evaluate
from exotune.optimization.spec import load_optimize_spec

BASE = copy.deepcopy(load_design(Path(__file__).resolve().parents[2] / "examples" / "paper.yaml").raw)
FQ, ZETA = BASE["implementation"]["dob"]["cutoff_hz"], BASE["implementation"]["dob"]["damping"]
NAMES = ("dob_phase_margin_deg", "dob_gain_margin_db", "dob_delay_margin_s")


def _spec(**constraints):
    return load_optimize_spec({"base": copy.deepcopy(BASE), "objective": "amplification", "budget": 50,
                               "free": {"design.amplification": [1.5, 60.0], "implementation.delay_s": [1e-4, 0.05]},
                               "constraints": {"robust": False, "free_stable": False, "locked_stable": False,
                                               "latency_margin_s": 0.0, **constraints}})


def _reference(T):
    """(stable, continuous PM [deg]) of the standard DOB loop at delay T, mpmath."""
    mp.mp.dps = 40
    wq = 2 * mp.pi * FQ
    a = 2 * ZETA * wq
    wc = mp.findroot(lambda w: w * w * (w * w + a * a) - wq**4, wq)
    pm0 = mp.atan(a / wc)
    return bool(T < pm0 / wc), float(mp.degrees(pm0 - wc * T))


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("bound", [0.0, -10.0])
def test_a_bound_that_would_accept_an_unstable_dob_loop_is_refused(name, bound):
    with pytest.raises(ConfigError) as e:
        _spec(**{name: bound})
    assert e.value.field == f"constraints.{name}" and "must be > 0" in e.value.reason
    assert "unstable DOB loop" in e.value.reason
    assert _spec(**{name: 1e-9}).constraints[name] == 1e-9


def test_unstable_dob_loops_break_every_dob_constraint():
    T = np.array([1e-3, 4e-3, 6e-3, 0.02, 0.045])
    spec = _spec(dob_phase_margin_deg=30.0, dob_gain_margin_db=1e-9, dob_delay_margin_s=1e-9)
    ev = evaluate(spec, np.stack([np.full(T.size, 8.0), T], axis=1))
    ref = [_reference(t) for t in T]
    stable = np.array([r[0] for r in ref])
    assert stable.tolist() == [True, True, False, False, False]
    np.testing.assert_array_equal(np.asarray(column(ev, "dob_stable"), bool), stable)
    # the wrapped PM of the 20 ms and 45 ms rows would be positive, the 20 ms one above the bound 30°
    wrapped = (np.array([r[1] for r in ref]) + 180.0) % 360.0 - 180.0
    assert wrapped[3] > 30 and wrapped[4] > 0
    for name in NAMES:
        broken = ev["broken"][name]
        assert broken[~stable].all(), name
    pm = np.asarray(column(ev, "dob_phase_margin_deg"), float)
    np.testing.assert_allclose(pm[stable], [r[1] for r, s in zip(ref, stable) if s], rtol=1e-9)
    np.testing.assert_array_equal(ev["broken"]["dob_phase_margin_deg"][stable], pm[stable] < 30.0)
    assert not ev["broken"]["dob_delay_margin_s"][stable].any()
    assert not ev["broken"]["dob_gain_margin_db"][stable].any()
    assert not ev["feasible"][~stable].any()


def test_a_latency_constraint_beyond_the_accepted_delays_is_refused_by_name():
    """Hostile round 4, F8: `latency_margin_s: 1.0` failed as "implementation.delay_s: value 1.001 at
    index 2 is out of the accepted range" (a field the spec does not have). It is now refused before
    the search, naming the constraint and the largest margin that fits; 0.9 s is accepted."""
    base = {"base": "examples/scheduled.yaml", "free": {"design.amplification": [2.0, 12.0]}, "budget": 50}
    with pytest.raises(ConfigError) as ei:
        load_optimize_spec({**base, "constraints": {"latency_margin_s": 1.0}})
    assert ei.value.field == "constraints.latency_margin_s" and "at most 0.999 s" in ei.value.reason
    spec = load_optimize_spec({**base, "constraints": {"latency_margin_s": 0.9}})
    assert spec.constraints["latency_margin_s"] == 0.9
