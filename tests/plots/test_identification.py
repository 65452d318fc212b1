"""exotune.plots.identification: the identification figures draw the given frequency responses
and residual tests (computing nothing) into the given axes and return the Figure."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from exotune.identification.validresult import FrequencyResponse, ResidualTest, Validation  # noqa: E402
from exotune.plots.identification import bode_overlay, residual_figure, validation_figures  # noqa: E402

PNG = b"\x89PNG\r\n\x1a\n"


def _fr(name="motor"):
    f = np.array([1.0, 2.0, 5.0, 10.0])
    model = 1.0 / (1j * 2 * np.pi * f * (0.5 * 1j * 2 * np.pi * f + 2.0))
    measured = model * np.array([1.1, 0.9, 1.0, 1.2])
    return FrequencyResponse(name, "τ_m", "θ_m", "rad/(N·m)", f, measured, np.array([0.99, 0.95, 0.5, 0.92]),
                             np.array([0.01, 0.02, 0.3, 0.05]), model, (), 12)


def _rt():
    return ResidualTest("θ_m", "τ_m", np.arange(4), np.array([1.0, 0.1, -0.05, 0.02]), 0.08, np.arange(-2, 3),
                        np.array([0.01, -0.02, 0.03, 0.0, 0.01]), 0.05, 0)


def test_bode_overlay_draws_measured_and_model_into_the_given_axes():
    fr = _fr()
    fig, axes = plt.subplots(3, 1)
    assert bode_overlay(fr, axes=axes) is fig
    am, ap, ac = axes
    by_label = {ln.get_label(): ln for ln in am.get_lines()}
    coherent = by_label["measured H1, γ² ≥ 0.9"].get_ydata()
    faint = by_label["measured, γ² < 0.9"].get_ydata()
    mag = np.abs(fr.measured)
    ok = fr.coherence >= 0.9
    assert np.allclose(coherent[ok], mag[ok]) and np.all(np.isnan(coherent[~ok]))
    assert np.allclose(faint[~ok], mag[~ok]) and np.all(np.isnan(faint[ok]))
    assert np.allclose(by_label["identified model"].get_ydata(), np.abs(fr.model))
    assert np.allclose(ac.get_lines()[0].get_ydata(), fr.coherence)
    # the model's phase, unwrapped, in degrees
    assert np.allclose(ap.get_lines()[-1].get_ydata(), np.degrees(np.unwrap(np.angle(fr.model))))
    assert am.get_title() == "motor: θ_m / (τ_m), 12 averages"
    assert "[rad/(N·m)]" in am.get_ylabel()
    plt.close(fig)


def test_residual_figure_draws_the_correlations_and_bounds():
    t = _rt()
    fig, axes = plt.subplots(2, 1)
    assert residual_figure(t, axes=axes) is fig
    stems = [c for c in axes[0].containers]
    assert len(stems) == 1
    assert np.allclose(stems[0].markerline.get_ydata(), t.autocorrelation)
    assert np.allclose(axes[1].containers[0].markerline.get_xdata(), t.cross_lags)
    band = axes[0].patches[0]
    assert np.isclose(band.get_y(), -0.08) and np.isclose(band.get_y() + band.get_height(), 0.08)
    assert "θ_m" in axes[0].get_ylabel() and "τ_m" in axes[1].get_ylabel()
    plt.close(fig)


def test_new_figures_without_axes():
    for fig in (bode_overlay(_fr()), residual_figure(_rt())):
        assert isinstance(fig, Figure)
        plt.close(fig)


def test_validation_figures_names_one_png_per_response_and_output():
    v = Validation("held-out log", True, (), (_fr("motor"), _fr("spring")), (_rt(),))
    files = validation_figures(v)
    assert sorted(files) == ["bode_motor.png", "bode_spring.png", "residuals_theta_m.png"]
    assert all(data.startswith(PNG) for data in files.values())
    plt.close("all")
