"""The figure data of one design analysis: every array ``exotune analyze --plots`` draws.

Figures never compute (docs/architecture.md): :func:`analysis_figures` computes, once, from the
design and its analysis, the typed record :class:`AnalysisFigures` — the compliances, the human
loops' Nyquist curves, the DOB loop, the amplification at two delays, the latency boundaries and
C7 — and :mod:`exotune.plots.analysis` only draws its fields. Frequencies are in [Hz], responses
complex arrays on those frequencies.

References
----------
docs/cli.md#analyze; docs/architecture.md.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from .latency_margin import LatencyBoundary

__all__ = [
    "ComplianceResponses",
    "NyquistCurve",
    "NyquistCritical",
    "HumanLoop",
    "DobLoop",
    "AmplificationRun",
    "AmplificationAtDelays",
    "C7Response",
    "AnalysisFigures",
    "analysis_figures",
]

Interval = tuple[float, float]


@dataclass(frozen=True)
class ComplianceResponses:
    """C5 = Δ01/Δ00 (cuff free), C7 = Δ10/Δ00 (operator side) [rad/(N·m)] and the amplification
    A = C6/C5 [1], complex, at ``f_hz`` [Hz], with the exact delay and the implemented filters."""

    f_hz: np.ndarray
    C5: np.ndarray
    C7: np.ndarray
    A: np.ndarray


@dataclass(frozen=True)
class NyquistCurve:
    """The loop L(jω) = Z_h(jω)·C7(jω) [1] (complex, ω > 0 on 0.01 Hz – 10 kHz) of one member:
    its parameter ``value`` [the family's unit], ``role`` ("critical", "stable", "end", "mid"),
    ``state`` ("critical", "stable" or "UNSTABLE", from the exact intervals) and the real parts
    [1] of its crossings of the negative real axis."""

    value: float
    role: str
    state: str
    L: np.ndarray
    crossings: np.ndarray


@dataclass(frozen=True)
class NyquistCritical:
    """A critical member: its ``value`` [the family's unit], where L = −1 at ``frequency_hz`` [Hz],
    and L(jω_c) [1] there (complex)."""

    value: float
    frequency_hz: float
    L: complex


@dataclass(frozen=True)
class HumanLoop:
    """One panel of ``nyquist_humans.png``: a one-parameter human family (an msd box: one edge).

    ``kind``, ``parameter``, ``unit``, ``range`` and ``stable_intervals`` [unit] as the analysis
    reports them; ``fixed`` the other parameters (SI units), ``eta`` the loss factor [1] of a
    complex stiffness, ``edge`` None or ``{"index", "count", "at"}`` (the corner values of the
    other ranged parameters), ``curves`` the members drawn, ``critical`` the points L = −1."""

    kind: str
    parameter: str
    unit: str
    range: Interval
    stable_intervals: tuple[Interval, ...]
    fixed: Mapping[str, float]
    eta: float
    edge: Mapping[str, Any] | None
    curves: tuple[NyquistCurve, ...]
    critical: tuple[NyquistCritical, ...]


@dataclass(frozen=True)
class DobLoop:
    """The disturbance-observer loop (paper Fig. 4) at ``f_hz`` [Hz] with the modelled delay
    ``delay_s`` [s]: the complex Q [1], L = Q e^{−jωT}/(1 − Q) [1] and CL = L/(1 + L) [1], the
    continuous phase of L ``phase_L_deg`` [deg]; ``crossover`` ``(f_c [Hz], L(jω_c), phase there
    [deg], nearest −180° + k·360° [deg])`` at the analysed gain crossover or None;
    ``phase_crossover`` the index into ``f_hz`` of the −180° crossing with the largest |L|, or
    None; the Q filter's ``cutoff_hz`` [Hz] and ``damping`` [1]."""

    f_hz: np.ndarray
    delay_s: float
    Q: np.ndarray
    L: np.ndarray
    CL: np.ndarray
    phase_L_deg: np.ndarray
    crossover: tuple[float, complex, float, float] | None
    phase_crossover: int | None
    cutoff_hz: float
    damping: float


@dataclass(frozen=True)
class AmplificationRun:
    """C6/C5 ``A`` [1] (complex) at one delay ``delay_s`` [s] (``configured``: the design's own),
    with its verdicts: ``minimum_phase``, the −3 dB ``bandwidth_hz`` [Hz] and ``locked_stable``
    (None where unknown)."""

    delay_s: float
    configured: bool
    A: np.ndarray
    minimum_phase: bool | None
    bandwidth_hz: float | None
    locked_stable: bool | None


@dataclass(frozen=True)
class AmplificationAtDelays:
    """C6/C5 at the configured delay and at max(2T, T + 2 ms) (paper Fig. 5), at ``f_hz`` [Hz]."""

    f_hz: np.ndarray
    runs: tuple[AmplificationRun, ...]


@dataclass(frozen=True)
class C7Response:
    """The operator-side compliance C7 [rad/(N·m)] (complex) at ``f_hz`` [Hz] (default grid of
    :func:`exotune.analysis.responses.c7_frequency_response`: 800 points, 0.01 Hz – 1 kHz)."""

    f_hz: np.ndarray
    C7: np.ndarray


@dataclass(frozen=True)
class AnalysisFigures:
    """Everything the analysis figures of one design draw (``exotune analyze --plots``).

    Attributes
    ----------
    result : Mapping
        The analysis as ``exotune analyze --json`` reports it (verdicts, margins, critical
        members and bands written on the figures).
    name : str
        The design's file name ("design" without one).
    amplification : float
        The designed amplification α [1].
    delay_s : float
        The modelled delay T [s].
    structure : str
        The controller structure.
    compliances : ComplianceResponses
        C5, C7 and C6/C5 (``bode_compliances.png``).
    human_loops : tuple of HumanLoop
        One per one-parameter family or box edge (``nyquist_humans.png``; empty without humans).
    dob : DobLoop or None
        The DOB loop (``dob_loop.png``; None without a DOB).
    amplification_at_delays : AmplificationAtDelays
        C6/C5 at two delays (``amplification.png``).
    latency_boundaries : tuple of LatencyBoundary
        Each human member's first destabilizing extra delay [s] (``latency_boundary.png``).
    latency_margin_s : float or None
        The design's latency margin [s] drawn on it (None when not computed).
    c7 : C7Response
        C7 on the default grid (:meth:`exotune.analysis.DesignAnalysis.plot`).
    """

    result: Mapping[str, Any]
    name: str
    amplification: float
    delay_s: float
    structure: str
    compliances: ComplianceResponses
    human_loops: tuple[HumanLoop, ...]
    dob: DobLoop | None
    amplification_at_delays: AmplificationAtDelays
    latency_boundaries: tuple[LatencyBoundary, ...]
    latency_margin_s: float | None
    c7: C7Response


def _human_loop(lp: dict) -> HumanLoop:
    h = lp["h"]
    return HumanLoop(
        kind=h["kind"], parameter=h["parameter"], unit=h["unit"], range=tuple(h["range"]),
        stable_intervals=tuple(tuple(iv) for iv in h.get("stable_intervals") or []),
        fixed=dict(lp["fixed"]), eta=lp["eta"], edge=lp.get("edge"),
        curves=tuple(NyquistCurve(v, role, state, L, x) for v, role, state, L, x in lp["curves"]),
        critical=tuple(NyquistCritical(float(c["value"]), float(c["frequency_hz"]), complex(Lc))
                       for c, Lc in lp["critical"]),
    )


def _dob_loop(cfg, result: dict) -> DobLoop | None:
    from .plot_data import dob_loop

    q = cfg.implementation.dob
    if q is None:
        return None
    r = dob_loop(cfg, result)
    return DobLoop(r["f"], r["T"], r["Q"], r["L"], r["CL"], r["phL"], r["crossover"], r["phase_crossover"],
                   float(np.asarray(q.cutoff_hz)), float(np.asarray(q.damping)))


def analysis_figures(cfg, analysis) -> AnalysisFigures:
    """Compute the figure data of one analysed design (nothing is analysed again).

    Parameters
    ----------
    cfg : exotune.config.design.DesignConfig
        The analysed design.
    analysis : DesignAnalysis
        Its analysis (:func:`exotune.analysis.analyze_design` or the verdicts of record); the
        figures use its critical frequencies, stable intervals, margins and verdicts.

    Returns
    -------
    AnalysisFigures
        The arrays of every figure of ``exotune analyze --plots``.

    References
    ----------
    docs/cli.md#analyze; paper Fig. 4 (the DOB loop and its Q filter) and Fig. 5 (the amplification at two delays).
    """
    from .latency_margin import latency_boundaries
    from .plot_data import amplification_at_delays, compliance_responses, human_loops

    result = analysis.to_dict()
    r = compliance_responses(cfg, result)
    f_amp, runs = amplification_at_delays(cfg, result)
    humans = result.get("humans") or []
    if humans:
        intervals = [h.get("stable_intervals") for h in humans]  # the analysis's own: not analysed again
        boundaries = tuple(latency_boundaries(cfg, intervals=intervals))
    else:
        boundaries = ()
    margin = ((result.get("margins") or {}).get("latency") or {}).get("extra_delay_s")
    f7, C7 = analysis.c7_response
    return AnalysisFigures(
        result=result,
        name=os.path.basename(cfg.source) if getattr(cfg, "source", None) else "design",
        amplification=float(np.asarray(cfg.design.amplification)),
        delay_s=float(np.asarray(cfg.implementation.delay_s)),
        structure=result.get("structure", cfg.implementation.structure),
        compliances=ComplianceResponses(r["f"], r["C5"], r["C7"], r["A"]),
        human_loops=tuple(_human_loop(lp) for lp in human_loops(cfg, result)) if humans else (),
        dob=_dob_loop(cfg, result),
        amplification_at_delays=AmplificationAtDelays(f_amp, tuple(
            AmplificationRun(run["T"], run["configured"], run["A"], run["minimum_phase"], run["bandwidth_hz"],
                             run["locked_stable"]) for run in runs)),
        latency_boundaries=boundaries,
        latency_margin_s=margin,
        c7=C7Response(f7, C7),
    )
