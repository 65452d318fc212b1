"""exotune.sweeps.plan: row → grid point arithmetic (C order for a full grid, a seeded bijection
with --sample) and chunking."""

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from exotune.sweeps.plan import SweepPlan, chunk_points
from exotune.sweeps.spec import load_spec

ROOT = Path(__file__).resolve().parents[2]
PAPER = str(ROOT / "examples" / "paper.yaml")
AXES = {"design.amplification": [2.0, 4.0, 8.0], "implementation.delay_s": [0.0, 0.001, 0.002, 0.003, 0.004]}


@pytest.fixture(scope="module")
def full():
    return load_spec({"base": PAPER, "axes": AXES, "chunk_size": 4})


def test_full_grid_is_c_order_over_the_axes_as_listed(full):
    assert full.shape == (3, 5) and full.grid_points == full.n_points == 15
    assert full.paths == list(AXES) and full.n_chunks == 4  # ceil(15 / 4)
    g, vals = full.points(np.arange(15))
    assert g.tolist() == list(range(15))
    # last axis fastest: row 7 = (amplification index 1, delay index 2)
    assert vals["design.amplification"][7] == 4.0 and vals["implementation.delay_s"][7] == 0.002
    expected = [(a, d) for a in AXES["design.amplification"] for d in AXES["implementation.delay_s"]]
    assert list(zip(vals["design.amplification"], vals["implementation.delay_s"])) == expected


def test_chunks_cover_the_rows_once(full):
    ranges = [full.chunk_range(i) for i in range(full.n_chunks)]
    assert ranges == [(0, 4), (4, 8), (8, 12), (12, 15)]
    idx, vals = chunk_points(full, 3)
    assert idx.tolist() == [12, 13, 14] and vals["implementation.delay_s"].tolist() == [0.002, 0.003, 0.004]
    with pytest.raises(IndexError, match=r"chunk 4 out of range \(0..3\)"):
        full.chunk_range(4)
    with pytest.raises(IndexError):
        full.chunk_range(-1)


def test_plan_hash_depends_on_the_normalized_spec_only(full):
    again = SweepPlan(full.spec, cfg=full.cfg)
    assert again.hash == full.hash and len(full.hash) == 64
    other = load_spec({"base": PAPER, "axes": AXES, "chunk_size": 5})
    assert other.hash != full.hash


def _sample_plan(n, seed, axes=AXES):
    return load_spec({"base": PAPER, "axes": axes, "chunk_size": 3}, sample=n, seed=seed)


def test_sample_is_a_uniform_draw_without_replacement():
    plan = _sample_plan(15, 7)  # every grid point: a permutation
    g = plan.grid_index(np.arange(15))
    assert sorted(g.tolist()) == list(range(15))
    assert g.tolist() != list(range(15))
    part = _sample_plan(6, 7)
    assert part.n_points == 6 and part.n_chunks == 2
    # the first rows of a smaller sample are those of the larger one (same permutation)
    assert part.grid_index(np.arange(6)).tolist() == g[:6].tolist()
    assert _sample_plan(6, 8).grid_index(np.arange(6)).tolist() != g[:6].tolist()


@settings(max_examples=30)
@given(st.integers(1, 5000), st.integers(0, 2**31))
def test_permutation_is_a_bijection_of_the_grid(m, seed):
    plan = SweepPlan.__new__(SweepPlan)  # the arithmetic alone, on a grid of m points
    plan.sample, plan.grid_points = m, m
    plan._keys = np.random.SeedSequence([seed, 0x5EE9]).generate_state(6, dtype=np.uint64)
    g = plan.grid_index(np.arange(m))
    assert g.min() >= 0 and g.max() < m and np.unique(g).size == m


def test_sample_rows_are_reproducible_chunk_by_chunk():
    plan = _sample_plan(10, 3)
    rows = np.concatenate([chunk_points(plan, i)[0] for i in range(plan.n_chunks)])
    assert rows.tolist() == plan.grid_index(np.arange(10)).tolist()
