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
as ``exotune certify`` computes it), its growth rate f_s·ln ρ and its dominant oscillation
(:class:`LoopSpectrum`). The run's verdict (:func:`judge`) weighs the two: an envelope needs
``MIN_PERIODS`` periods of the dominant oscillation to be judged (a shorter run is
``inconclusive``), and a loop with ρ > 1 is never ``decaying`` — where the envelope and the
eigenvalues disagree, the eigenvalue verdict wins.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..controllerfile import ControllerFile, as_controller_file
from ..controllerfile.certify import position_feedback
from ..controllerfile.fileio import discrete_from_file, plant_from_file
from ..sampled import loop_eigenvalues

__all__ = ["MARGINAL_TOL", "FIT_FRACTION", "FLOOR", "MIN_PERIODS", "VERDICTS", "envelope_growth", "classify",
           "LoopSpectrum", "spectrum_of", "loop_spectrum", "loop_spectral_radius", "judge", "dominant_frequency"]

MARGINAL_TOL = 0.05  # [1/s] |σ| below this: marginal
FIT_FRACTION = 0.5  # the envelope is fitted over this last part of the run
FLOOR = 1e-10  # an oscillation below FLOOR × its peak is at rounding level: decayed
MIN_PERIODS = 2.0  # an envelope is judged over at least this many periods of the loop's dominant oscillation
VERDICTS = ("decaying", "marginal", "growing", "inconclusive")  # the first three from the least to the most severe


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
    above = a > floor  # (a mask: one byte per sample, not the indices' eight)
    last = a.size - int(np.argmax(above[::-1])) if above.any() else 0  # after the last sample above the floor
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


def _rate(rho: float, fs: float) -> float | None:
    return fs * math.log(rho) if rho > 0 and math.isfinite(rho) else None


def _by_tolerance(rate: float | None) -> str:
    if rate is None or abs(rate) <= MARGINAL_TOL:
        return "marginal"
    return "growing" if rate > 0 else "decaying"


@dataclass(frozen=True)
class LoopSpectrum:
    """The linearized sampled-data loop's spectral radius and its dominant oscillation.

    Attributes
    ----------
    spectral_radius : float
        ρ = max |λ| [–] over the loop's eigenvalues (0 for a loop without eigenvalues).
    sample_rate_hz : float
        The loop's sample rate f_s [Hz].
    oscillation_hz : float or None
        Frequency |arg λ|·f_s/2π [Hz] of the dominant oscillation: the oscillatory eigenvalue
        (complex, or real and negative) of largest modulus, among those that stay above ``FLOOR``
        for half a period (a heavily damped pair is no oscillation an envelope would show);
        None when the loop has none (or is not known).
    oscillation_modulus : float or None
        Its |λ| [–].
    """

    spectral_radius: float
    sample_rate_hz: float
    oscillation_hz: float | None = None
    oscillation_modulus: float | None = None

    @property
    def growth_rate_per_s(self) -> float | None:
        """f_s·ln ρ [1/s] (None when ρ is 0 or not finite)."""
        return _rate(self.spectral_radius, self.sample_rate_hz)

    @property
    def oscillation_period_s(self) -> float | None:
        """The dominant oscillation's period [s], or None."""
        return 1.0 / self.oscillation_hz if self.oscillation_hz else None

    @property
    def needed_run_s(self) -> float | None:
        """The shortest run [s] whose envelope can be judged: ``MIN_PERIODS`` dominant periods (None:
        no oscillation to wait for)."""
        period = self.oscillation_period_s
        return MIN_PERIODS * period if period is not None else None

    @property
    def verdict(self) -> str:
        """The loop's own verdict: ``growing`` / ``decaying`` / ``marginal`` by its growth rate
        f_s·ln ρ against ``MARGINAL_TOL``."""
        return _by_tolerance(self.growth_rate_per_s)


def spectrum_of(lam, sample_rate_hz: float) -> LoopSpectrum:
    """The :class:`LoopSpectrum` of the eigenvalues ``lam`` of a loop sampled at ``sample_rate_hz``.

    Parameters
    ----------
    lam : array_like
        The loop's eigenvalues (complex).
    sample_rate_hz : float
        f_s [Hz].

    Returns
    -------
    LoopSpectrum
        ρ and the dominant oscillation (the longest period among equally large moduli).

    Examples
    --------
    A pair that decays below ``FLOOR`` within half a period (here a real double root split by
    rounding) shows no oscillation; the next one decides:

    >>> lam = [0.9999 * np.exp(1e-6j), 0.9999 * np.exp(-1e-6j), 0.999 * np.exp(0.01j), 0.999 * np.exp(-0.01j), -0.5]
    >>> sp = spectrum_of(lam, 1000.0)
    >>> sp.spectral_radius, round(sp.oscillation_hz, 4), round(sp.oscillation_modulus, 12), round(sp.needed_run_s, 3)
    (0.9999, 1.5915, 0.999, 1.257)
    """
    lam = np.asarray(lam, dtype=complex).ravel()
    fs = float(sample_rate_hz)
    rho = float(np.max(np.abs(lam))) if lam.size else 0.0
    r, th = np.abs(lam), np.abs(np.angle(lam))
    with np.errstate(divide="ignore", invalid="ignore"):  # th = 0 or r = 0: no oscillation
        alive = (th > 0) & (r > 0) & (np.pi / th * np.log(np.where(r > 0, r, 1.0)) >= math.log(FLOOR))
    if not alive.any():
        return LoopSpectrum(rho, fs)
    top = float(np.max(r[alive]))
    pick = alive & (r >= top * (1.0 - 1e-9))  # a conjugate pair, or equal moduli: the slowest oscillation
    return LoopSpectrum(rho, fs, float(np.min(th[pick])) * fs / (2.0 * math.pi), top)


def loop_spectrum(doc: ControllerFile | dict, human: dict, locked: bool) -> LoopSpectrum:
    """The spectral radius and dominant oscillation of the linearized sampled-data loop (the
    file's plant and controller, ``human``, the output locked or free; the rigid-body z = 1 of an
    ungrounded loop excluded).

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
    LoopSpectrum
        ρ [–], f_s and the dominant oscillation.

    References
    ----------
    Paper §V; docs/method.md#sampled-data.
    """
    doc = as_controller_file(doc)
    lam = loop_eigenvalues(plant_from_file(doc), discrete_from_file(doc), position_feedback(doc.controller),
                           {k: float(v) for k, v in human.items()}, "locked" if locked else "free")
    return spectrum_of(lam, float(doc.sample_rate_hz))


def loop_spectral_radius(doc: ControllerFile | dict, human: dict, locked: bool) -> float:
    """Spectral radius of the linearized sampled-data loop (:func:`loop_spectrum`).

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
    return loop_spectrum(doc, human, locked).spectral_radius


def judge(envelope: str, run_s: float, spectrum: LoopSpectrum | None = None, died: bool = False,
          diverged: bool = False) -> tuple[str, str]:
    """The verdict of a run, and what decided it.

    A run stopped at the state bound is ``growing`` (``stopped``). A loop whose spectral radius
    exceeds 1 is never judged ``decaying``: when the run is too short for its envelope, or its
    envelope says less than the eigenvalues (``decaying`` or ``marginal`` against ``growing``),
    the loop's own verdict wins (``spectral_radius``). Otherwise a run shorter than
    ``MIN_PERIODS`` periods of the dominant oscillation, whose oscillation did not die out, is
    ``inconclusive`` (``none``): its envelope cannot tell growth from decay. Else the envelope's
    verdict stands (``envelope``).

    Parameters
    ----------
    envelope : str
        The envelope's verdict (:func:`classify`).
    run_s : float
        The run's length [s] (samples / rate).
    spectrum : LoopSpectrum or None, optional
        The linearized loop's (None: not known; the envelope alone decides).
    died : bool, optional
        Whether the oscillation decayed to rounding level (a decay the run itself shows).
    diverged : bool, optional
        Whether the run stopped at the state bound.

    Returns
    -------
    (str, str)
        The verdict (one of :data:`VERDICTS`) and its basis: ``stopped``, ``spectral_radius``,
        ``none`` or ``envelope``.

    Examples
    --------
    >>> growing = LoopSpectrum(1.00311, 1000.0, 44.3, 1.00311)
    >>> judge("decaying", 0.016, growing), judge("decaying", 0.016, LoopSpectrum(0.99, 1000.0, 44.3, 0.99))
    (('growing', 'spectral_radius'), ('inconclusive', 'none'))
    >>> judge("decaying", 10.0, LoopSpectrum(0.99, 1000.0, 44.3, 0.99))
    ('decaying', 'envelope')
    """
    if diverged:
        return "growing", "stopped"
    needed = spectrum.needed_run_s if spectrum is not None else None
    short = needed is not None and run_s < needed and not died
    if spectrum is not None and spectrum.spectral_radius > 1.0:
        own = spectrum.verdict  # ρ > 1: growing, or marginal within the tolerance; never decaying
        if short or VERDICTS.index(envelope) < VERDICTS.index(own):
            return own, "spectral_radius"
    elif short:
        return "inconclusive", "none"
    return envelope, "envelope"


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
