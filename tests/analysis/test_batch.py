"""exotune.analysis.batch: a batch analysis is independent of its chunking and equals the
analyses of its designs one by one."""

from __future__ import annotations

import numpy as np

from exotune.analysis.batch import analyze_batch
from exotune.config import batch_config
from tests.paper_design import paper_design

A = np.array([2.0, 5.0, 8.0, 20.0, 60.0])
COLS = ("free_stable", "locked_stable", "amplification_dc", "amplification_bandwidth_hz",
        "passivity_max_phase_excess_deg")


def test_chunking_does_not_change_the_result():
    cfg = batch_config(paper_design(), {"design.amplification": A})
    whole = analyze_batch(cfg)
    parts = analyze_batch(cfg, max_chunk=2)
    assert whole.n == parts.n == A.size
    for c in COLS:
        np.testing.assert_allclose(np.asarray(parts.column(c), float), np.asarray(whole.column(c), float),
                                   rtol=1e-9, equal_nan=True)


def test_a_batch_equals_its_designs_one_by_one():
    cfg = paper_design()
    batch = analyze_batch(batch_config(cfg, {"design.amplification": A[[0, 2, 4]]}))
    for i, a in enumerate(A[[0, 2, 4]]):
        one = analyze_batch(batch_config(cfg, {"design.amplification": np.array([a])}))
        for c in COLS:
            np.testing.assert_allclose(float(np.asarray(batch.column(c), float)[i]),
                                       float(np.asarray(one.column(c), float)[0]), rtol=1e-9)
    np.testing.assert_allclose(batch.column("amplification_dc"), A[[0, 2, 4]], rtol=1e-6)
