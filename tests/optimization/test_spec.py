"""exotune.optimization.spec: a bad entry of an optimization spec is refused naming its field
(docs/optimize-spec.md), and a valid one is read with its bounds, scales, defaults and seed."""

from __future__ import annotations

import copy
from pathlib import Path

import pytest

from exotune.config import load_design
from exotune.errors import ConfigError
from exotune.optimization.spec import DEFAULT_LATENCY_MARGIN_S, default_budget, load_optimize_spec

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def base():
    return copy.deepcopy(load_design(ROOT / "examples" / "paper.yaml").raw)


def _spec(base, **kw):
    s = {"base": copy.deepcopy(base), "objective": "amplification",
         "free": {"design.amplification": [1.5, 60.0], "design.zeta_hat": {"lo": 0.3, "hi": 1.2, "scale": "lin"}}}
    s.update(kw)
    return s


def test_a_valid_spec_is_read_with_its_bounds_scales_and_defaults(base):
    spec = load_optimize_spec(_spec(base))
    assert spec.objective == "amplification"
    lo, hi, scale = spec.free["design.amplification"]
    assert (lo, hi) == (1.5, 60.0) and scale in ("log", "lin")
    assert spec.free["design.zeta_hat"] == (0.3, 1.2, "lin")
    assert spec.budget == default_budget(2) == 3000 and spec.seed == 0
    assert default_budget(4) == 6000
    assert spec.constraints["latency_margin_s"] == pytest.approx(DEFAULT_LATENCY_MARGIN_S)
    assert load_optimize_spec(_spec(base, seed=3), seed=7).seed == 7  # the command line wins


def test_a_latency_margin_of_zero_checks_no_delay(base):
    spec = load_optimize_spec(_spec(base, constraints={"latency_margin_s": 0.0}))
    assert spec.checked_delays().size == 0
    spec = load_optimize_spec(_spec(base, constraints={"latency_margin_s": 0.002}))
    d = spec.checked_delays()
    assert d.size > 0 and d.max() == pytest.approx(0.002) and (d > 0).all()


@pytest.mark.parametrize("change,field", [
    (dict(objective="nonsense"), "objective"),
    (dict(free={"design.amplification": [60.0, 2.0]}), "free.design.amplification"),
    (dict(free={"design.amplification": {"lo": 1.0, "hi": 5.0, "step": 1}}), "free.design.amplification.step"),
    (dict(free={"design.amplification": {"lo": 1.0, "hi": 5.0, "scale": "exp"}}), "free.design.amplification.scale"),
    (dict(free={"design.amplification": {"lo": 1.0}}), "free.design.amplification"),
    (dict(free={"design.zeta_hat": {"lo": -1.0, "hi": 1.0, "scale": "log"}, "design.amplification": [1, 5]}),
     "free.design.zeta_hat"),  # a negative bound of a positive gain
    (dict(free={"design.no_such_gain": [1.0, 2.0]}), "free.design.no_such_gain"),
    (dict(free=None), "free"),
    (dict(constraints={"foo": 1.0}), "constraints.foo"),
    (dict(constraints={"max_phase_excess_deg": -1.0}), "constraints.max_phase_excess_deg"),
    (dict(constraints={"latency_margin_s": -1e-3}), "constraints.latency_margin_s"),
    # a bandwidth is never negative (a vacuous bound), a peak over the DC value never below 0 dB (unsatisfiable)
    (dict(constraints={"amplification_bandwidth_hz": -1.0}), "constraints.amplification_bandwidth_hz"),
    (dict(constraints={"amplification_peak_db": -0.5}), "constraints.amplification_peak_db"),
    (dict(constraints=[]), "constraints"),
    (dict(seed=-1), "seed"),
    (dict(seed=True), "seed"),
    (dict(budget=10), "budget"),
    (dict(extra_key=1), "extra_key"),
])
def test_a_bad_entry_is_refused_naming_its_field(base, change, field):
    with pytest.raises(ConfigError) as e:
        load_optimize_spec(_spec(base, **change))
    assert e.value.field == field


def test_bandwidth_and_peak_bounds_of_zero_are_accepted(base):
    """The edges of the accepted ranges: 0 Hz (any bandwidth) and 0 dB (no peak above DC)."""
    spec = load_optimize_spec(_spec(base, constraints={"amplification_bandwidth_hz": 0.0,
                                                       "amplification_peak_db": 0.0}))
    assert spec.constraints["amplification_bandwidth_hz"] == 0.0
    assert spec.constraints["amplification_peak_db"] == 0.0


def test_the_base_is_required_and_the_spec_must_be_a_mapping(base):
    s = _spec(base)
    del s["base"]
    with pytest.raises(ConfigError) as e:
        load_optimize_spec(s)
    assert e.value.field == "base"
    with pytest.raises(ConfigError):
        load_optimize_spec(42)


@pytest.mark.parametrize("seed, got", [(2**32, "4294967296"), (10**23, "100000000000000000000000"),
                                       (-1, "-1"), (10**400, "an integer of 1329 bits"), (1.5, "1.5")],
                         ids=["2**32", "1e23", "negative", "1e400", "float"])
def test_a_seed_outside_numpys_range_is_refused_up_front(base, seed, got):
    """``seed: 100000000000000000000000`` (or ``--seed 4294967296``) ran until numpy refused it
    with "Seed must be between 0 and 2**32 - 1", naming no field. Now the spec's key (or the
    keyword) is named with the range, before the base design is even read."""
    reason = f"expected an integer from 0 to 4294967295 (2**32 − 1), got {got}"
    with pytest.raises(ConfigError) as e:  # the spec's key
        load_optimize_spec(_spec({"not": "a design"}, seed=seed))
    assert (e.value.field, e.value.reason, e.value.in_file) == ("seed", reason, True)
    with pytest.raises(ConfigError) as e:  # the keyword (--seed)
        load_optimize_spec(_spec({"not": "a design"}), seed=seed)
    assert (e.value.field, e.value.reason, e.value.in_file) == ("seed", reason, False)
    assert load_optimize_spec(_spec(base), seed=2**32 - 1).seed == 2**32 - 1


@pytest.mark.parametrize("change, field, what", [
    (dict(constraints={"dob_phase_margin_deg": 30.0}), "constraints.dob_phase_margin_deg", "DOB phase margin"),
    (dict(constraints={"dob_gain_margin_db": 6.0}), "constraints.dob_gain_margin_db", "DOB gain margin"),
    (dict(constraints={"dob_delay_margin_s": 1e-3}), "constraints.dob_delay_margin_s", "DOB delay margin"),
    (dict(objective="dob_delay_margin_s"), "objective", "DOB delay margin"),
], ids=["phase", "gain", "delay", "objective"])
def test_a_dob_margin_without_a_dob_is_refused_up_front(base, change, field, what):
    """A DOB margin asked of a base design with ``dob: null`` ran the whole search on NaN and
    exited 1 ("dob_phase_margin_deg: nan deg, needed >= 30 deg", or "the best one breaks: " with
    nothing after for the objective). It is refused before the search, naming the constraint or
    the objective and why, as ``robust`` without human families is."""
    no_dob = copy.deepcopy(base)
    no_dob["implementation"]["dob"] = None
    with pytest.raises(ConfigError) as e:
        load_optimize_spec(_spec(no_dob, **change))
    assert e.value.field == field
    assert "no disturbance observer (implementation.dob: null)" in e.value.reason and what in e.value.reason
    assert load_optimize_spec(_spec(base, **change)).cfg.implementation.dob is not None  # with a DOB: accepted


def test_numpy_scalars_are_accepted_where_numbers_are(base):
    """``optimize(seed=np.int64(1))`` was refused ("expected an integer from 0 to …, got
    np.int64(1)"), as were a numpy budget, bounds given as an array and numpy flags: numpy's
    integers, floats and bools are taken for Python's (bools are still not integers)."""
    import numpy as np

    s = load_optimize_spec(_spec(base, free={"design.amplification": np.array([1.5, 60.0]),
                                             "design.zeta_hat": [np.float32(0.25), np.float64(1.2)]},
                                 budget=np.int64(60), seed=np.uint32(7),
                                 constraints={"nominal_passive": np.True_, "dob_phase_margin_deg": np.float64(20.0)}),
                           seed=np.int64(1))
    assert (s.seed, s.budget, s.constraints["nominal_passive"]) == (1, 60, True)
    assert type(s.seed) is int and type(s.budget) is int and type(s.constraints["nominal_passive"]) is bool
    assert s.free["design.amplification"][:2] == (1.5, 60.0) and s.free["design.zeta_hat"][0] == 0.25
    assert load_optimize_spec(_spec(base, seed=np.int64(3))).seed == 3
    for bad, got in ((np.int64(-1), "-1"), (np.True_, "true"), (np.float64(1.0), "1.0")):
        with pytest.raises(ConfigError) as e:
            load_optimize_spec(_spec(base), seed=bad)
        assert e.value.reason.endswith(f"got {got}")
    with pytest.raises(ConfigError, match="expected an integer ≥ 50, got 10"):
        load_optimize_spec(_spec(base, budget=np.int64(10)))
