"""Verdicts from the physics: the growth rate of a run's oscillation envelope.

The oscillation of a signal s is its sample-to-sample change Δs (a constant level, e.g. the
steady torque of a push, drops out exactly; the growth rate of an oscillation is that of its
differences). Over the last ``FIT_FRACTION`` of the run the envelope is followed from both sides
— the running maximum of |Δs| forward (which rises with a growing oscillation) and backward
(which falls with a decaying one) — and the sum of the least-squares slopes of their logarithms is
the growth rate σ [1/s]. With a periodic push (period P samples) the change over one period
s[k] − s[k − P] replaces Δs, so that the verdict says whether the run converges to a periodic
response. The run is ``growing`` when σ > ``MARGINAL_TOL``, ``decaying`` when
σ < −``MARGINAL_TOL`` and ``marginal`` (sustained: a limit cycle, a forced oscillation or a loop on
the stability boundary) otherwise — exactly one. An oscillation that falls below
``FLOOR`` × its peak (rounding level) has decayed. A run stopped at the state bound is growing.

Beside it, the linearized sampled-data loop's spectral radius ρ (the file's plant and
controller with the scenario's human, nonlinearities off: :func:`exotune.sampled.loop.loop_eigenvalues`,
as ``exotune certify`` computes it) and its growth rate f_s·ln ρ.
"""

from __future__ import annotations

import math

import numpy as np

from ..controllerfile import ControllerFile, as_controller_file
from ..controllerfile.certify import position_feedback
from ..controllerfile.fileio import discrete_from_file, plant_from_file
from ..sampled import loop_eigenvalues

__all__ = ["MARGINAL_TOL", "FIT_FRACTION", "FLOOR", "envelope_growth", "classify", "loop_spectral_radius",
           "dominant_frequency"]

MARGINAL_TOL = 0.05  # [1/s] |σ| below this: marginal
FIT_FRACTION = 0.5  # the envelope is fitted over this last part of the run
FLOOR = 1e-10  # an oscillation below FLOOR × its peak is at rounding level: decayed


def _slope(t: np.ndarray, v: np.ndarray) -> float:
    tc = t - t.mean()
    den = float(tc @ tc)
    return float(tc @ (v - v.mean()) / den) if den > 0 else 0.0


def envelope_growth(t: np.ndarray, s: np.ndarray, fraction: float = FIT_FRACTION,
                    lag: int = 1) -> tuple[float | None, float | None]:
    """Growth rate σ [1/s] of the oscillation envelope of ``s`` over the last ``fraction`` of the
    run, and whether the oscillation died out (fell below ``FLOOR`` × its peak).

    Parameters
    ----------
    t, s : ndarray
        Sample times [s] and the signal.
    fraction : float
        Part of the run fitted (its end).
    lag : int
        Samples between the compared values: 1 (the sample-to-sample change), or the period of
        a periodic push (the change over one period: does the run converge to a periodic
        response?).

    Returns
    -------
    (float or None, float or None)
        σ (None with fewer than 9 samples) and, when the oscillation died out (fell below
        ``FLOOR`` × its peak before the last quarter of the run), the time [s] it did, else None.

    References
    ----------
    docs/method.md#simulation.
    """
    lag = max(1, int(lag))
    if s.size < lag + 8:
        return None, None
    a = np.abs(s[lag:] - s[:-lag])
    tt = t[lag:]
    peak = float(np.max(a))
    if not math.isfinite(peak):
        return math.inf, None
    if peak == 0.0:
        return -math.inf, float(t[0])
    floor = FLOOR * peak
    above = np.flatnonzero(a > floor)
    last = int(above[-1]) + 1 if above.size else 0
    m = max(8, int(round(fraction * a.size)))
    died = last < a.size - m // 2
    stop = last if died else a.size
    lo = max(0, stop - m)
    seg, ts = a[lo:stop], tt[lo:stop]
    died_at = float(tt[stop - 1]) if died and stop else (float(t[0]) if died else None)
    if seg.size < 8:
        return -math.inf, died_at
    fwd = np.log(np.maximum(np.maximum.accumulate(seg), floor))
    bwd = np.log(np.maximum(np.maximum.accumulate(seg[::-1])[::-1], floor))
    return _slope(ts, fwd) + _slope(ts, bwd), died_at


def classify(growth: float | None, died, diverged: bool) -> str:
    """``growing`` / ``decaying`` / ``marginal`` (see the module docstring).

    Parameters
    ----------
    growth : float or None
        Growth rate σ [1/s] of the envelope (None: too short to fit).
    died : float or None
        Time [s] the oscillation died out, or None (False counts as None).
    diverged : bool
        Whether the run stopped at the state bound.

    Returns
    -------
    str
        The verdict.
    """
    if diverged:
        return "growing"
    if died is not None and died is not False:
        return "decaying"
    if growth is None or abs(growth) <= MARGINAL_TOL:
        return "marginal"
    return "growing" if growth > 0 else "decaying"


def loop_spectral_radius(doc: ControllerFile | dict, human: dict, locked: bool) -> float:
    """Spectral radius of the linearized sampled-data loop (the file's plant and controller,
    ``human``, the output locked or free; the rigid-body z = 1 of an ungrounded loop excluded).

    Parameters
    ----------
    doc : ControllerFile or dict
        The controller file.
    human : dict
        The human: inertia [kg·m²], damping [N·m·s/rad], stiffness [N·m/rad] (any subset).
    locked : bool
        Whether the output is locked.

    Returns
    -------
    float
        ρ [–] (0 for a loop without eigenvalues).

    References
    ----------
    Paper §V; docs/method.md#sampled-data.
    """
    doc = as_controller_file(doc)
    lam = loop_eigenvalues(plant_from_file(doc), discrete_from_file(doc), position_feedback(doc.controller),
                           {k: float(v) for k, v in human.items()}, "locked" if locked else "free")
    return float(np.max(np.abs(lam))) if lam.size else 0.0


def dominant_frequency(t: np.ndarray, s: np.ndarray) -> float:
    """Frequency [Hz] of the largest spectral peak of ``s`` (mean removed, Hann window).

    Parameters
    ----------
    t : numpy.ndarray
        Sample times [s], uniformly spaced.
    s : numpy.ndarray
        The signal.

    Returns
    -------
    float
        The frequency [Hz]; NaN with fewer than 16 samples.
    """
    if s.size < 16:
        return math.nan
    fs = 1.0 / (t[1] - t[0])
    w = np.hanning(s.size)
    spec = np.abs(np.fft.rfft((s - s.mean()) * w))
    spec[0] = 0.0
    i = int(np.argmax(spec))
    if 0 < i < spec.size - 1:  # parabolic interpolation of the log-magnitude peak
        a, b, c = np.log(spec[i - 1:i + 2] + 1e-300)
        den = a - 2 * b + c
        i = i + (0.5 * (a - c) / den if den else 0.0)
    return float(i * fs / s.size)
