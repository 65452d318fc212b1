"""exotune.analysis.responses: the implemented C7(jω) of a design against the paper's system
algebra (Table II, exotune.model.plant.seven_systems on the implemented blocks), and the nominal
responses against their closed forms (Ĉ5 = 1/(Ĵ_m s² + B̂_m s))."""

from __future__ import annotations

import numpy as np
import pytest

from exotune.analysis.responses import c7_frequency_response, nominal_frequency_responses
from tests.paper_design import paper_design
from tests.system_algebra import implemented_systems


def test_the_default_grid_spans_0p01_hz_to_1_khz():
    f, H = c7_frequency_response(paper_design())
    assert f.shape == H.shape == (800,)
    assert f[0] == pytest.approx(0.01) and f[-1] == pytest.approx(1000.0)
    assert np.all(np.diff(f) > 0) and np.iscomplexobj(H)
    f2, R = nominal_frequency_responses(paper_design())
    np.testing.assert_array_equal(f2, f)
    assert sorted(R) == ["C4", "C5", "C5_hat", "C7_nominal", "G_v"]


@pytest.mark.parametrize("delay", [0.0, 0.002])
def test_c7_equals_the_papers_system_algebra(delay):
    cfg = paper_design(dob=None, delay_s=delay)
    f = np.geomspace(0.05, 2000.0, 200)
    f_out, H = c7_frequency_response(cfg, f)
    np.testing.assert_array_equal(f_out, f)
    S = implemented_systems(cfg, delay)
    np.testing.assert_allclose(H, np.ravel(S["S7"].C(2j * np.pi * f)), rtol=1e-8)


def test_nominal_felt_compliance_is_the_virtual_motor():
    cfg = paper_design()
    f = np.geomspace(0.01, 100.0, 50)
    _, R = nominal_frequency_responses(cfg, f)
    s = 2j * np.pi * f
    a = float(cfg.design.amplification)
    ref = 1.0 / (a * float(cfg.design.felt_inertia) * s**2 + a * float(cfg.design.felt_damping) * s)
    np.testing.assert_allclose(R["C5_hat"], ref, rtol=1e-9)


def test_the_nominal_responses_ignore_the_implementation():
    f = np.geomspace(0.01, 10.0, 40)
    _, R = nominal_frequency_responses(paper_design(dob=None, delay_s=0.0), f)
    _, R2 = nominal_frequency_responses(paper_design(), f)
    for k in R:
        np.testing.assert_allclose(R2[k], R[k], rtol=1e-12)
