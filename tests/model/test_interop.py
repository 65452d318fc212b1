"""exotune.model.interop: the nominal transfer functions as python-control objects."""

from pathlib import Path

import control
import numpy as np
import pytest

import exotune
from exotune.model.interop import ascending, descending, nominal_transfer_functions_control

ROOT = Path(__file__).resolve().parents[2]


def test_nominal_transfer_functions_of_the_paper_design():
    cfg = exotune.load_design(ROOT / "examples" / "paper.yaml")
    tfs = nominal_transfer_functions_control(cfg)
    assert sorted(tfs) == ["C4", "C5", "C5_hat", "C7_nominal", "G_v"]
    assert all(isinstance(t, control.TransferFunction) for t in tfs.values())
    p, d = cfg.plant, cfg.design
    J_hat = float(d.amplification) * float(d.felt_inertia)
    B_hat = float(d.amplification) * float(d.felt_damping)
    s = 1j * np.geomspace(0.1, 1e3, 30)
    assert np.allclose(tfs["C5_hat"](s), 1 / (J_hat * s**2 + B_hat * s), rtol=1e-10)
    # eq. (16): C7 = (s² + 2ζ̂√(αK_c/Ĵ_m) s + αK_c/Ĵ_m)/(K_c (s² + B̂_m/Ĵ_m s)); at low frequency the
    # operator feels the felt damping alone: C7 → α/(B̂_m s) = 1/(felt_damping·s)
    low = 1j * np.array([1e-4])
    assert tfs["C7_nominal"](low)[0] == pytest.approx(1 / (float(d.felt_damping) * low[0]), rel=1e-3)
    # at high frequency the cuff alone: C7 → 1/K_c
    assert tfs["C7_nominal"](1e7j) == pytest.approx(1 / float(p.K_c), rel=1e-3)
    # G_v = (J_m/Ĵ_m)[1 + …s²…] → J_m/Ĵ_m at DC
    assert tfs["G_v"](1e-6j) == pytest.approx(float(p.J_m) / J_hat, rel=1e-6)  # (K̃1 = 0: 0/0 at s = 0)


def test_reexported_conversions():
    assert descending([1.0, 2.0, 0.0]).tolist() == [2.0, 1.0]
    assert ascending([2.0, 1.0]).tolist() == [1.0, 2.0]
