"""Figures of ``exotune simulate`` runs: physical names and units on every axis, a symmetric-log
axis where values span decades (a growing run), legends in words, the motor limit drawn."""

from __future__ import annotations

import numpy as np

from . import style

__all__ = ["plot_simulation", "simulation_figure", "RUN_LABELS"]

RUN_LABELS = {"controller": "exported controller", "without_dob": "without the DOB",
              "without_clamp": "runtime without its clamp: windup", "frictionless": "no friction, reference",
              "without_backlash": "no backlash, reference",
              "with_controller_file": "exported controller"}


_MAIN_LABEL = {"without_backlash": "with backlash", "frictionless": "with friction and the DOB",
               "without_clamp": "runtime with its clamp"}


def _label(key: str, runs=()) -> str:
    if key == "controller":
        for other, text in _MAIN_LABEL.items():
            if other in runs:
                return text
    return RUN_LABELS.get(key, key.replace("_", " "))


def _symlog_if_decades(ax, *arrays) -> None:
    """Symmetric-log y axis when the values span more than three decades (a growing run); the
    linear band is the run's initial scale (its first 5 %)."""
    style.symlog_if_decades(ax, *arrays, which="y", decades=3.0)


def _locked(axs, rep, alpha):
    for key, sim in rep["runs"].items():
        s, lab = sim["series"], _label(key, rep["runs"])
        axs[0].plot(s["t"], -s["tau_s"], label=f"spring torque −τ_s ({lab})")
        axs[0].plot(s["t"], (alpha - 1.0) * s["tau_c"], "--", label=f"(α − 1)·τ_c, α = {alpha:g} ({lab})")
        axs[1].plot(s["t"], s["tau_m"], label=f"motor torque τ_m ({lab})")
    lim = rep["nonlinearities"]["saturation_nm"]
    if np.isfinite(lim):
        for sgn in (1, -1):
            axs[1].axhline(sgn * lim, color="k", lw=0.8, ls=":", label="motor limit" if sgn > 0 else None)
    _symlog_if_decades(axs[1], *[r["series"]["tau_m"] for r in rep["runs"].values()])
    _symlog_if_decades(axs[0], *[l.get_ydata() for l in axs[0].get_lines()])
    axs[0].set_ylabel("torque [N·m]")
    axs[1].set_ylabel("motor torque τ_m [N·m]")


def _free(axs, rep):
    for key, sim in rep["runs"].items():
        s, lab = sim["series"], _label(key, rep["runs"])
        if rep["scenario"] == "dob-friction":
            axs[0].plot(s["t"], s["theta_j"], label=f"joint angle θ_j ({lab})")
        else:
            axs[0].plot(s["t"], s["theta_h"] - s["theta_j"], label=f"cuff deflection θ_h − θ_j ({lab})")
        if "friction_estimate" in s:
            axs[1].plot(s["t"], s["friction"], label="true friction F_c·tanh(θ̇_m/ε)")
            axs[1].plot(s["t"], s["friction_estimate"], "--", label="DOB's estimate")
        elif rep["scenario"] != "dob-friction":
            axs[1].plot(s["t"], s["tau_m"], label=f"motor torque τ_m ({lab})")
    _symlog_if_decades(axs[0], *[l.get_ydata() for l in axs[0].get_lines()])
    axs[0].set_ylabel("joint angle θ_j [rad]" if rep["scenario"] == "dob-friction" else "cuff deflection [rad]")
    axs[1].set_ylabel("friction torque [N·m]" if rep["scenario"] == "dob-friction" else "motor torque τ_m [N·m]")
    if rep["scenario"] != "dob-friction":
        _symlog_if_decades(axs[1], *[r["series"]["tau_m"] for r in rep["runs"].values()])


def plot_simulation(rep: dict) -> dict[str, bytes]:
    """PNG figure of a scenario's runs (:func:`exotune.simulation.run_scenario`).

    Locked output: the spring torque −τ_s against (α − 1)·τ_c (the amplification test of the
    paper's time-domain figure) and the motor torque with its limit. Free output: the cuff
    deflection (or, with friction, the joint angle with and without the DOB and the frictionless
    reference) and the motor torque (or the true friction and the DOB's estimate).

    Parameters
    ----------
    rep : dict
        A scenario report with its ``runs``.

    Returns
    -------
    dict
        ``{"simulate_<scenario>.png": bytes}``.

    References
    ----------
    Paper §V (time-domain amplification and friction tests); docs/cli.md#simulate.
    """
    fig = simulation_figure(rep)
    return {f"simulate_{rep['scenario']}.png": style.png(fig)}


def simulation_figure(rep: dict, ax=None):
    """The figure of :func:`plot_simulation` as a matplotlib ``Figure``: two panels, or, given
    ``ax``, the first panel only (the cuff deflection, the joint angle with friction, or −τ_s
    against (α − 1)·τ_c for a locked output) drawn into that Axes. Computes nothing.

    Parameters
    ----------
    rep : dict
        The simulation's report (``SimulationRun.to_dict()`` with its series).
    ax : matplotlib.axes.Axes or None, optional
        Where to draw the first panel; None for a new two-panel figure.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.

    Examples
    --------
    >>> import exotune
    >>> run = exotune.simulate("examples/scheduled.yaml", "locked-output", duration=0.2)
    >>> len(run.plot().axes)
    2
    """
    if ax is not None:
        fig, axs = ax.figure, [ax, _Sink()]
    else:
        fig = style.new_figure((8, 6.5))
        axs = fig.subplots(2, 1, sharex=True)
    sm = rep["summary"]
    if rep["runs"] and next(iter(rep["runs"].values()))["locked"]:
        alpha = float(rep.get("design_alpha") or sm.get("delivered_amplification", {}).get("design_alpha") or 1.0)
        _locked(axs, rep, alpha)
    else:
        _free(axs, rep)
    axs[-1].set_xlabel("time t [s]")
    for a in axs:
        style.grid(a, which="major")
        a.legend(fontsize=7)
    g = sm["envelope_growth_rate"]["value"]
    basis = sm.get("verdict_basis", "envelope")
    if basis == "spectral_radius":  # the eigenvalues decided, not the envelope
        why = f" (loop spectral radius {sm['loop_spectral_radius']['value']:.6g} > 1)"
    elif basis == "none":
        why = " (run too short to judge)"
    else:
        why = f" (envelope growth {g:.3g} 1/s)" if g is not None and np.isfinite(g) else ""
    title = f"exotune simulate — {rep['scenario']} at {rep['sample_rate_hz']:g} Hz: {sm['verdict']}{why}"
    if ax is not None:
        ax.set_xlabel("time t [s]")
        ax.set_title(title, fontsize=9)
    else:
        fig.suptitle(title, fontsize=10)
    return fig


class _Sink:
    """Stands in for the second panel when only the first is drawn (into a caller's ``ax``):
    every drawing call is accepted and ignored."""

    def __getattr__(self, name):
        return lambda *a, **k: []
