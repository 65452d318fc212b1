"""exotune.plots.simulate: the figure of a simulation draws the series of its runs (given, not
computed) with physical names, the motor limit, and the verdict in the title."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from exotune.plots.simulate import RUN_LABELS, plot_simulation, simulation_figure  # noqa: E402

T = np.linspace(0.0, 1.0, 50)


def _series(k=1.0):
    return {"t": T, "tau_s": -k * T, "tau_c": 0.5 * T, "tau_m": 2 * T, "theta_h": 0.01 * T, "theta_j": 0.004 * T}


def _rep(locked, scenario="locked-output", runs=None):
    return {"scenario": scenario, "sample_rate_hz": 1000.0, "design_alpha": 8.0,
            "nonlinearities": {"saturation_nm": 40.0},
            "summary": {"verdict": "decaying", "envelope_growth_rate": {"value": -1.5, "unit": "1/s"}},
            "runs": runs or {"controller": {"locked": locked, "series": _series()}}}


def test_locked_output_panels():
    fig = simulation_figure(_rep(True))
    top, bottom = fig.axes
    spring, amp = top.get_lines()
    assert np.allclose(spring.get_ydata(), T) and np.allclose(amp.get_ydata(), 7.0 * 0.5 * T)  # −τ_s, (α−1)·τ_c
    assert spring.get_label() == "spring torque −τ_s (exported controller)"
    tau_m, *limits = bottom.get_lines()
    assert np.allclose(tau_m.get_ydata(), 2 * T)
    assert sorted(ln.get_ydata()[0] for ln in limits) == [-40.0, 40.0]
    assert top.get_ylabel() == "torque [N·m]" and bottom.get_xlabel() == "time t [s]"
    assert fig._suptitle.get_text() == ("exotune simulate — locked-output at 1000 Hz: decaying "
                                        "(envelope growth -1.5 1/s)")
    plt.close(fig)


def test_free_output_into_a_given_ax():
    fig, ax = plt.subplots()
    runs = {"controller": {"locked": False, "series": _series()},
            "without_backlash": {"locked": False, "series": _series(2.0)}}
    assert simulation_figure(_rep(False, "backlash", runs), ax=ax) is fig
    a, b = ax.get_lines()
    assert np.allclose(a.get_ydata(), 0.006 * T)  # the cuff deflection θ_h − θ_j
    assert a.get_label() == "cuff deflection θ_h − θ_j (with backlash)"
    assert b.get_label() == f"cuff deflection θ_h − θ_j ({RUN_LABELS['without_backlash']})"
    assert ax.get_title().startswith("exotune simulate — backlash at 1000 Hz: decaying")
    assert len(fig.axes) == 1
    plt.close(fig)


def test_plot_simulation_names_the_png():
    files = plot_simulation(_rep(True))
    assert list(files) == ["simulate_locked-output.png"] and files["simulate_locked-output.png"][:4] == b"\x89PNG"
    plt.close("all")


def test_the_title_names_what_decided_the_verdict():
    """h8 item 3: a verdict the eigenvalues decided is not titled with the envelope's growth (which
    said the opposite); an inconclusive run says it was too short."""
    rep = _rep(False, "light-mass")
    rep["summary"] = {"verdict": "growing", "verdict_basis": "spectral_radius",
                      "envelope_growth_rate": {"value": -34.25, "unit": "1/s"},
                      "loop_spectral_radius": {"value": 1.00311, "unit": "1"}}
    fig = simulation_figure(rep)
    assert fig._suptitle.get_text() == ("exotune simulate — light-mass at 1000 Hz: growing "
                                        "(loop spectral radius 1.00311 > 1)")
    rep["summary"].update(verdict="inconclusive", verdict_basis="none")
    fig2 = simulation_figure(rep)
    assert fig2._suptitle.get_text().endswith(": inconclusive (run too short to judge)")
    plt.close("all")
