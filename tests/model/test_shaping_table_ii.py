"""paper Table II built from a plant and a design (exotune.model.shaping.table_ii) satisfies the docs/method.md#double-compliance-shaping
identities at zero delay, and the delay enters only through H1 (exactly)."""

import numpy as np

from exotune.model.plant import Plant
from exotune.model.shaping import DesignParams, double_compliance_shaping, table_ii

PLANT = Plant(0.44, 17.9, 1180.0, 0.29, 300.0)
DESIGN = DesignParams(8.0, 0.25, 1.0, 0.7, 0.7)


def test_identities_at_zero_delay():
    S = table_ii(PLANT, DESIGN)
    ds = double_compliance_shaping(PLANT, DESIGN)
    s = 1j * np.geomspace(0.1, 1e4, 300)
    target_c4 = (s**2 + ds.shape.B2_tilde * s + ds.shape.K2_tilde) / (PLANT.K_s * (s**2 + ds.shape.B1_tilde * s))
    assert np.allclose(S["S4"].C(s), target_c4, rtol=1e-9)
    # H5 G_v = Ĉ5: with G_c = G_v (K̂2 + B̂2 s), G_c H5 / (K̂2 + B̂2 s) = Ĉ5
    g = ds.gains
    Gv_H5 = (S["S6"].C(s) - S["S5"].C(s)) / (g.K2_hat + g.B2_hat * s)
    assert np.allclose(Gv_H5, S["S5_hat"].C(s), rtol=1e-8)
    low = 1j * np.array([1e-5, 1e-6])
    assert np.allclose(S["S6"].C(low) / S["S5"].C(low), 8.0, rtol=1e-4)
    assert np.allclose(S["S7"].C(s) - S["S6"].C(s), 1.0 / 300.0)


def test_delay_only_in_h1():
    S0 = table_ii(PLANT, DESIGN, 0.0)
    S1 = table_ii(PLANT, DESIGN, 0.002)
    s = 1j * np.geomspace(1.0, 1e3, 50)
    assert np.allclose(S1["S1"].C(s), S0["S1"].C(s))
    assert np.allclose(S1["S1"].H(s), S0["S1"].H(s) * np.exp(-0.002 * s))
    assert not np.allclose(S1["S7"].C(s), S0["S7"].C(s))
