"""exotune.optimization.peak: the peak of |C6/C5(jω)| over its DC value against a dense frequency
sweep of the amplification built by the paper's system algebra (exotune.model.plant.seven_systems
on the implemented blocks; designs without DOB) or of its quasi-polynomial ratio (with DOB)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from exotune.config import batch_config
from exotune.optimization.peak import amplification_peak
from tests.paper_design import paper_design
from tests.system_algebra import amplification_magnitude

F = np.geomspace(1e-4, 1e5, 300_001)


def _cfg(dob, **design):
    cfg = paper_design() if dob else paper_design(dob=None)
    return dataclasses.replace(cfg, design=dataclasses.replace(cfg.design, **design)) if design else cfg


def _sweep(cfg):
    return amplification_magnitude(cfg, F)


@pytest.mark.parametrize("dob,design", [(False, {}), (False, {"zeta_hat": 0.3}), (True, {}),
                                        (True, {"amplification": 30.0, "zeta_hat": 0.4})])
def test_peak_against_a_dense_sweep(dob, design):
    cfg = _cfg(dob, **design)
    db, hz = amplification_peak(cfg)
    mag = _sweep(cfg)
    ref = 20 * np.log10(mag.max() / mag[0])
    assert db[0] >= ref - 1e-6  # the refined peak is at least every sampled value
    assert db[0] == pytest.approx(max(ref, 0.0), abs=1e-4)
    if ref > 1e-3:
        assert hz[0] == pytest.approx(F[np.argmax(mag)], rel=1e-3)
    else:
        assert hz[0] == 0.0


def test_a_batch_equals_its_designs():
    cfg = paper_design()
    a = np.array([4.0, 8.0, 30.0])
    db, hz = amplification_peak(batch_config(cfg, {"design.amplification": a}))
    assert db.shape == hz.shape == (3,)
    for i, al in enumerate(a):
        d1, h1 = amplification_peak(_cfg(True, amplification=al))
        assert db[i] == pytest.approx(d1[0], rel=1e-9, abs=1e-12)
        assert hz[i] == pytest.approx(h1[0], rel=1e-9, abs=1e-12)
    assert np.all(db >= 0)
