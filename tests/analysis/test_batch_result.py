"""The typed result of analyze_batch (exotune.analysis.batch_result): its columns are the sweep's
schema (names, order, types), a row is the design analysed alone, chunks join into the whole."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest

from exotune.analysis import BatchAnalysis, analyze_batch
from exotune.analysis.batch_result import GAIN_NAMES, FamilyBatch
from exotune.config import batch_config, design_from_mapping, design_row, read_yaml

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def _mapping() -> dict:
    """The scheduled example with every kind of loop: a one-parameter family, an msd box, a spring
    and a mass environment range, a locked and a free output."""
    m = read_yaml(EXAMPLES / "scheduled.yaml")
    m.pop("transmission", None)
    m = copy.deepcopy(m)
    m["humans"] = [{"kind": "mass", "inertia": [0.01, 1.0], "damping": 0.3},
                   {"kind": "msd", "inertia": [0.02, 0.5], "damping": [0.5, 5.0], "stiffness": 300.0}]
    m["environment"] = [{"kind": "spring", "stiffness": [100.0, 5000.0], "damping": 1.0}, {"kind": "locked"},
                        {"kind": "free"}, {"kind": "mass", "inertia": [0.01, 2.0], "damping": 0.0}]
    return m


@pytest.fixture(scope="module")
def batch():
    cfg = design_from_mapping(_mapping())
    rng = np.random.default_rng(5)
    n = 9
    b = batch_config(cfg, {"design.amplification": rng.uniform(2.0, 12.0, n),
                           "design.zeta_hat": rng.uniform(0.3, 1.4, n),
                           "implementation.delay_s": rng.uniform(2e-4, 3e-3, n)})
    return b, analyze_batch(b, verify=8, latency=True)


def _same(a: dict, b: dict) -> None:
    """Two column dicts identical: keys in order, arrays bit for bit (dtype included), lists equal."""
    assert list(a) == list(b)
    for k in a:
        x, y = a[k], b[k]
        assert type(x) is type(y), k
        if isinstance(x, np.ndarray):
            assert x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes(), k
        else:
            assert repr(x) == repr(y), k


HUMAN = ("robust", "stable_intervals", "conclusive", "critical")
FIXED_HEAD = ["free_stable", "free_rigid_body_roots", "free_conclusive"]
FIXED_TAIL = ["passivity_conclusive", "passivity_max_phase_excess_deg", "passivity_nonpassive_band_hz",
              "dob_phase_margin_deg", "dob_gain_margin_db", "dob_delay_margin_s", "dob_crossover_hz", "dob_stable",
              "amplification_dc", "amplification_bandwidth_hz", "amplification_minimum_phase",
              "amplification_conclusive", "locked_stable", "locked_conclusive"]


def test_analyze_batch_returns_a_batch_analysis(batch):
    b, res = batch
    assert isinstance(res, BatchAnalysis) and res.n == 9
    assert isinstance(analyze_batch(design_from_mapping(_mapping())), BatchAnalysis)
    assert all(isinstance(h, FamilyBatch) for h in res.humans)
    assert [e.kind for e in res.environment] == ["spring", "locked", "free", "mass"]


def test_to_columns_order_and_types(batch):
    """The sweep's Parquet schema: the column order and types of docs/sweep-spec.md#columns."""
    _, res = batch
    cols = res.to_columns()
    want = (FIXED_HEAD
            + [f"human0_mass_{s}" for s in HUMAN] + ["human0_mass_verification_mismatches"]
            + [f"human1_msd_{s}" for s in HUMAN] + ["human1_msd_edges", "human1_msd_verification_mismatches"]
            + ["env0_spring_robust", "env0_spring_stable_intervals", "env1_locked_stable", "env2_free_stable",
               "env3_mass_robust", "env3_mass_stable_intervals"]
            + FIXED_TAIL + ["latency_margin_s", *GAIN_NAMES])
    assert list(cols) == want
    for k, v in cols.items():
        if k.endswith(("_stable", "_robust", "_conclusive", "_minimum_phase")):
            assert isinstance(v, np.ndarray) and v.dtype == bool and v.shape == (9,), k
        elif k == "free_rigid_body_roots":
            assert v.dtype == np.int64
        elif k.endswith(("_intervals", "_critical", "_edges", "_mismatches", "_band_hz")):
            assert isinstance(v, list) and len(v) == 9, k
        else:
            assert isinstance(v, np.ndarray) and v.dtype == np.float64 and v.shape == (9,), k
    # the locked and free environments are the locked and free loops' verdicts
    assert np.array_equal(cols["env1_locked_stable"], cols["locked_stable"])
    assert np.array_equal(cols["env2_free_stable"], cols["free_stable"])
    # without verification, latency and box: no such columns
    plain = analyze_batch(design_from_mapping(read_yaml(EXAMPLES / "paper.yaml"))).to_columns()
    kinds = ("mass", "spring", "complex_stiffness")
    assert list(plain) == (FIXED_HEAD + [f"human{i}_{k}_{s}" for i, k in enumerate(kinds) for s in HUMAN]
                           + ["env0_locked_stable"] + FIXED_TAIL + list(GAIN_NAMES))


def test_column_is_the_named_column(batch):
    _, res = batch
    cols = res.to_columns()
    for k in ("dob_phase_margin_deg", "human1_msd_robust", "latency_margin_s", "K2_hat"):
        assert res.column(k) is cols[k]
    with pytest.raises(KeyError):
        res.column("no_such_column")


def test_a_row_is_the_design_analysed_alone(batch):
    """Vectorized and one at a time: row(i) of the batch equals analyze_batch of design i alone."""
    b, res = batch
    for i in (0, 4, 8):
        alone = analyze_batch(design_row(b, i), verify=8, latency=True)
        assert alone.n == 1 and res.row(i).n == 1
        _same(res.row(i).to_columns(), alone.to_columns())


def test_chunks_join_into_the_whole(batch):
    b, res = batch
    _same(analyze_batch(b, max_chunk=4, verify=8, latency=True).to_columns(), res.to_columns())
    parts = [res.take(slice(0, 2)), res.take(slice(2, 7)), res.take(np.array([7, 8]))]
    _same(BatchAnalysis.concat(parts).to_columns(), res.to_columns())


def test_loop_verdicts_are_the_named_columns(batch):
    """loop(name) and loops_ok(): the loops of the latency margin by their report names."""
    _, res = batch
    cols = res.to_columns()
    assert res.loop("free") is res.free
    assert res.loop("human1_msd_edge3") is res.humans[1]
    assert np.array_equal(res.loop("env0_spring").verdict, cols["env0_spring_robust"])
    assert np.array_equal(res.loop("env1_locked").verdict, cols["locked_stable"])
    with pytest.raises(KeyError):
        res.loop("human7_mass")
    keys = [k for k in cols
            if k == "free_stable" or (k.startswith(("human", "env")) and k.endswith(("_robust", "_stable")))]
    assert np.array_equal(res.loops_ok(), np.logical_and.reduce([cols[k] for k in keys]))
    assert np.array_equal(res.latency_margin_s > 0, res.loops_ok() & (res.latency_margin_s > 0))
    conclusive = [k for k in cols if k.endswith("_conclusive")]
    assert np.array_equal(res.all_conclusive(), np.logical_and.reduce([cols[k] for k in conclusive]))
    assert res.gain_values(2) == {k: float(cols[k][2]) for k in GAIN_NAMES}
