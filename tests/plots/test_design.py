"""exotune.plots.design: the Bode figures of ``exotune design`` draw the curves they are given
(magnitude and phase against frequency), compute nothing and render PNG bytes. (``design_plots``
is being changed to take the computed figures: tested when that lands.)"""

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from exotune.plots import design, style  # noqa: E402

PNG = b"\x89PNG\r\n\x1a\n"
F = np.geomspace(0.1, 100.0, 30)
CURVES = [("C5", F, -20 * np.log10(F), -90 + 0 * F), ("C5_hat", F, -20 * np.log10(F) + 1, -80 + 0 * F)]


@pytest.fixture
def figures(monkeypatch):
    monkeypatch.setattr(style, "png", lambda fig, **kw: fig)  # the figure instead of its PNG


def test_bode_png_draws_magnitude_and_phase(figures):
    fig = design.bode_png(CURVES, "C5 against Ĉ5", "rad/(N·m)")
    mag, ph = fig.axes
    assert [ln.get_label() for ln in mag.get_lines()] == ["C5", "C5_hat"]
    for (label, f, m, p), lm, lp in zip(CURVES, mag.get_lines(), ph.get_lines()):
        assert np.allclose(lm.get_xdata(), f) and np.allclose(lm.get_ydata(), m) and np.allclose(lp.get_ydata(), p)
    assert mag.get_xscale() == "log" and mag.get_title() == "C5 against Ĉ5"
    assert mag.get_ylabel() == "magnitude |·| [dB re 1 rad/(N·m)]" and ph.get_ylabel() == "phase ∠ [deg]"
    assert ph.get_xlabel() == "frequency f [Hz]"
    assert mag.get_legend() is not None
    assert design.bode_png(CURVES[:1], "C5", "rad/(N·m)").axes[0].get_legend() is None  # one curve: no legend


def test_bode_png_renders_a_png():
    assert design.bode_png(CURVES, "C5", "rad/(N·m)").startswith(PNG)
