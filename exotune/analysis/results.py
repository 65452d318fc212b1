"""Typed results of the analysis layer: ``exotune design``, ``exotune sea`` and ``exotune analyze``.

:class:`DesignAnalysis` and its parts (:class:`FamilyResult`, :class:`EnvironmentResult`,
:class:`PassivityResult`, :class:`DobMargins`, :class:`Amplification`) are built field by field
by :func:`exotune.analysis.analyze_design` from the one-design batch; their ``to_dict`` assembles
the ``exotune analyze --json`` object from those fields. :class:`DesignSummary` and
:class:`SeaReport` keep the report of ``exotune design`` / ``exotune sea`` whole
(:class:`exotune.record.Record`).

References
----------
docs/api.md#typed-results; docs/method.md#analyses-and-metrics.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any, Mapping

from ..record import Record, Result, opt_float
if TYPE_CHECKING:  # the sampled-data model imports scipy.signal (a second): only for the annotation
    from ..sampled import SampledCheck
    from .latency_margin import LatencyMargin
    from .plant_margin import PlantMargin
from .kyp import certificates_dict
from ..units import GAIN_UNITS_TORQUE, METRIC_UNITS

__all__ = [
    "DesignSummary",
    "SeaReport",
    "FamilyResult",
    "EnvironmentResult",
    "PassivityResult",
    "DobMargins",
    "Amplification",
    "DesignAnalysis",
    "ScheduleEntry",
    "ANALYSIS_MODEL",
    "RIGID_BODY_NOTE",
    "BOX_METHOD",
]

ANALYSIS_MODEL = ("continuous-time, exact delay e^{-sT} (docs/method.md#controller); verdicts by the argument "
                  "principle on the closed-loop characteristic quasi-polynomial")
RIGID_BODY_NOTE = ("the rigid-body root at s = 0 (K1 = 0, cuff free) is physical and removed exactly "
                   "(docs/method.md#double-compliance-shaping)")
BOX_METHOD = "Edge Theorem: the box is robustly stable iff each of its edges is (exact intervals per edge)"

Interval = tuple[float, float]


def _pairs(xs) -> tuple[Interval, ...]:
    return tuple((a, b) for a, b in xs)


def _lists(pairs) -> list[list[float]]:
    return [[a, b] for a, b in pairs]


# ---------------------------------------------------------------------------------------------
# design, sea
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class DesignSummary(Record):
    """``exotune design``: the six gains (torque units, ``units``), the shape, the nominal transfer
    functions and warnings of a design (paper §IV; docs/method.md#double-compliance-shaping)."""

    gains: Mapping[str, float] = field(default_factory=dict)
    units: Mapping[str, str] = field(default_factory=dict)
    approximation_valid_below_hz: float | None = None
    warnings: tuple[str, ...] = ()
    config: Any = field(default=None, repr=False, compare=False)

    @classmethod
    def from_record(cls, rec: dict, config=None) -> "DesignSummary":
        """The summary of the report ``rec`` of :func:`exotune.analysis.design_report` (``config``:
        the design it came from, for :meth:`transfer_functions`)."""
        return cls(rec, dict(rec["gains"]), dict(rec["units"]), opt_float(rec["approximation"]["valid_below_hz"]),
                   tuple(rec["warnings"]), config)

    def transfer_functions(self) -> dict:
        """The nominal C4, C5, Ĉ5, C7 and G_v (zero delay, no filters, no DOB) as
        ``control.TransferFunction`` objects (descending coefficients, as python-control).

        Returns
        -------
        dict
            ``{"C4", "C5", "C5_hat", "C7_nominal", "G_v"}`` → ``control.TransferFunction``
            (compliances in rad/(N·m); G_v dimensionless).

        References
        ----------
        Paper §II-B–§II-D, eqs. (8), (10)–(12) and (16); docs/method.md#double-compliance-shaping.
        """
        from ..model.interop import nominal_transfer_functions_control

        return nominal_transfer_functions_control(self.config)

    def to_text(self) -> str:
        from ..text.design import format_design

        return format_design(self.to_dict())

    @cached_property
    def frequency_responses(self) -> tuple:
        """The nominal transfer functions' frequency responses that :meth:`plot` draws, computed
        once (:func:`exotune.analysis.responses.nominal_frequency_responses`; not in ``to_dict``).

        Returns
        -------
        (numpy.ndarray, dict)
            The frequencies [Hz] (800, 0.01 Hz – 1 kHz) and name → complex response (compliances
            in rad/(N·m); G_v in [1]).
        """
        from .responses import nominal_frequency_responses

        return nominal_frequency_responses(self.config)

    def plot(self, ax=None):
        """Bode magnitude of the nominal transfer functions; returns the matplotlib ``Figure``."""
        from ..plots.figures import bode_magnitude

        f, responses = self.frequency_responses
        curves = [(name, f, H) for name, H in responses.items()]
        return bode_magnitude(curves, ax=ax, title="nominal transfer functions (design)")


@dataclass(frozen=True)
class SeaReport(Record):
    """``exotune sea``: a plain SEA compliance-shaping controller (paper §II-B) — its gains in both
    conventions, the closed-loop compliance C5's poles and resonance, the passivity conditions."""

    c5_stable: bool | None = None
    passive: bool | None = None
    low_frequency_stiffness: float | None = None
    resonance_hz: float | None = None

    @classmethod
    def from_record(cls, rec: dict) -> "SeaReport":
        """The typed view of the report ``rec`` of :func:`exotune.analysis.sea_report`."""
        return cls(rec, bool(rec["c5_stable"]), bool(rec["passivity"]["passive"]),
                   opt_float(rec["low_frequency_stiffness"]), opt_float(rec["resonance_hz"]))

    def to_text(self) -> str:
        from ..text.sea import format_sea

        return format_sea(self.to_dict())


# ---------------------------------------------------------------------------------------------
# analyze
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class BoxEdge:
    """One edge of a box human family (Edge Theorem): ``parameter`` ranges over ``range`` with the
    other box parameters held ``at`` a corner; ``stable_intervals`` in the parameter's unit."""

    parameter: str
    range: Interval
    at: Mapping[str, float]
    stable_intervals: tuple[Interval, ...]

    def to_dict(self) -> dict:
        return {"parameter": self.parameter, "range": list(self.range), "at": dict(self.at),
                "stable_intervals": _lists(self.stable_intervals)}


@dataclass(frozen=True)
class FamilyResult(Result):
    """One human family: the exact stable member intervals of its ranged ``parameter`` (in
    ``unit``) over ``range``, ``robust`` (stable over the whole range), ``conclusive``, the critical
    members (value, crossing frequency [Hz]) and the spot check of the intervals at
    ``verified_points`` members. A box family (``box``: every ranged parameter) is judged by its
    ``edges`` and has no ``stable_intervals`` (None).

    References
    ----------
    docs/method.md#analyses-and-metrics (human families, Edge Theorem).
    """

    kind: str
    parameter: str
    unit: str
    range: Interval
    fixed: Mapping[str, float]
    stable_intervals: tuple[Interval, ...] | None
    robust: bool
    conclusive: bool
    critical: tuple[tuple[float, float], ...] = ()
    verified_points: int = 0
    verification_mismatches: tuple[float, ...] = ()
    box: Mapping[str, Interval] | None = None
    edges: tuple[BoxEdge, ...] | None = None

    def __repr__(self) -> str:
        if self.box is not None:
            where = f"box {', '.join(self.box)}, {len(self.edges or ())} edges"
        else:
            where = "stable " + (" ∪ ".join(f"[{a:.6g}, {b:.6g}]" for a, b in self.stable_intervals) or "nowhere")
        flags = ("robust" if self.robust else "not robust") + ("" if self.conclusive else ", inconclusive")
        return (f"FamilyResult({self.kind} {self.parameter} in [{self.range[0]:.6g}, {self.range[1]:.6g}] {self.unit}: "
                f"{where} ({flags}))")

    @property
    def lowest_stable_value_below_range_top(self) -> float | None:
        """The lower end of the stable interval that reaches the top of the range (e.g. the
        lightest stable inertia), None when no interval reaches it or for a box."""
        top = [a for a, b in self.stable_intervals or () if b == self.range[1]]
        return top[0] if top else None

    def to_dict(self) -> dict:
        d = {
            "kind": self.kind,
            "parameter": self.parameter,
            "unit": self.unit,
            "range": list(self.range),
            "fixed": dict(self.fixed),
            "stable_intervals": None if self.stable_intervals is None else _lists(self.stable_intervals),
            "robust": self.robust,
            "conclusive": self.conclusive,
            "critical": [{"value": p, "frequency_hz": f} for p, f in self.critical],
            "verified_points": self.verified_points,
            "verification_mismatches": list(self.verification_mismatches),
        }
        if self.box is not None:
            d["box"] = {k: list(v) for k, v in self.box.items()}
            d["method"] = BOX_METHOD
            d["edges"] = [e.to_dict() for e in self.edges or ()]
        elif self.stable_intervals:
            d["lowest_stable_value_below_range_top"] = self.lowest_stable_value_below_range_top
        return d


@dataclass(frozen=True)
class EnvironmentResult(Result):
    """One environment model: ``locked`` and ``free`` are single loops (``robust`` is their
    stability); a ranged one (``spring``…) has the stable intervals of ``parameter`` over ``range``.

    References
    ----------
    docs/design-file.md#environment; docs/method.md#analyses-and-metrics.
    """

    kind: str
    robust: bool
    parameter: str | None = None
    range: Interval | None = None
    stable_intervals: tuple[Interval, ...] | None = None

    @property
    def ranged(self) -> bool:
        return self.range is not None

    def to_dict(self) -> dict:
        if not self.ranged:
            return {"kind": self.kind, "stable": self.robust}
        return {"kind": self.kind, "parameter": self.parameter, "range": list(self.range),
                "stable_intervals": _lists(self.stable_intervals or ()), "robust": self.robust}


@dataclass(frozen=True)
class PassivityResult(Result):
    """Passivity of the operator-side compliance C7 (paper §IV-A, Fig. 5): the maximum phase
    excess of s·C7 over ±90° [deg], the non-passive bands [Hz] and the KYP certificates of its
    rational models (``kyp``: ``nominal`` and ``delay_free`` → :class:`exotune.analysis.KypCertificate`,
    or ``error`` → why they were not computed; docs/method.md#analyses-and-metrics)."""

    max_phase_excess_deg: float
    nonpassive_band_hz: tuple[Interval, ...] = ()
    kyp: Mapping[str, Any] = field(default_factory=dict, repr=False, compare=False)  # name → KypCertificate (or "error" → text)

    @property
    def passive(self) -> bool:
        return self.max_phase_excess_deg <= 0.0

    def to_dict(self) -> dict:
        return {"max_phase_excess_deg": self.max_phase_excess_deg,
                "nonpassive_band_hz": _lists(self.nonpassive_band_hz), "kyp": certificates_dict(self.kyp)}


@dataclass(frozen=True)
class DobMargins(Result):
    """Margins of the DOB Q-filter loop: gain [dB], phase [deg], delay [s], crossover [Hz]."""

    gain_margin_db: float
    phase_margin_deg: float
    delay_margin_s: float
    crossover_hz: float
    stable: bool

    def to_dict(self) -> dict:
        return {"gain_margin_db": self.gain_margin_db, "phase_margin_deg": self.phase_margin_deg,
                "delay_margin_s": self.delay_margin_s, "crossover_hz": self.crossover_hz, "stable": self.stable}


@dataclass(frozen=True)
class Amplification(Result):
    """Delivered amplification |C6/C5| (paper §II-D): DC value [–], −3 dB bandwidth [Hz] and
    whether C6/C5 is minimum phase; ``conclusive`` is False when the zero count of C6/C5 was not
    decided (``minimum_phase`` is then False, and unknown)."""

    dc: float
    bandwidth_hz: float
    minimum_phase: bool
    conclusive: bool = True

    def to_dict(self) -> dict:
        return {"dc": self.dc, "bandwidth_hz": self.bandwidth_hz, "minimum_phase": self.minimum_phase,
                "conclusive": self.conclusive}


@dataclass(frozen=True)
class ScheduleEntry(Result):
    """The design rescheduled at one joint angle of its ``transmission`` table (paper §IV gain scheduling: J_m,
    B_m, K_s × ratio², gains recomputed): whether it is robust, the loops that are not
    (``not_robust``, column names), its six gains (torque units) and its human families' stable
    intervals."""

    joint_angle_rad: float
    ratio: float
    robust: bool
    not_robust: tuple[str, ...]
    gains: Mapping[str, float]
    human_stable_intervals: Mapping[str, tuple[Interval, ...]]
    #: its continuous latency margin [s] (None: not computed; :func:`exotune.analysis.analyze_with_margins` computes it)
    latency_margin_s: float | None = None

    def to_dict(self) -> dict:
        return {"joint_angle_rad": self.joint_angle_rad, "ratio": self.ratio, "robust": self.robust,
                "not_robust": list(self.not_robust), "gains": dict(self.gains),
                "human_stable_intervals": {k: _lists(v) for k, v in self.human_stable_intervals.items()},
                "latency_margin_s": self.latency_margin_s}


@dataclass(frozen=True)
class DesignAnalysis(Result):
    """``exotune analyze``: every verdict and metric of one design (docs/method.md#analyses-and-metrics).

    ``robust`` is true when the cuff-free exoskeleton, every environment and every human family
    are stable over their whole ranges. ``margins`` holds the latency and plant-uncertainty
    margins (:class:`exotune.analysis.LatencyMargin`, :class:`exotune.analysis.PlantMargin`) when
    they were computed (:func:`exotune.analysis.analyze_with_margins`); ``sampled_data`` is the
    :class:`exotune.sampled.SampledCheck` at the design's sample rate (None without one),
    ``gain_schedule`` one :class:`ScheduleEntry` per joint angle of a ``transmission`` table, and
    ``cross_check`` the Padé cross-check's record (``analyze(..., cross_check=True)``).

    ``sampled`` holds the verdicts of record of a design with a sample rate
    (:class:`exotune.controllerfile.verdicts.SampledVerdicts`, set by ``exotune analyze``): the
    sampled-data loop of the exported controller, as ``certify`` judges it. Then ``to_dict()``'s
    ``margins.latency`` is the sampled-data margin (the continuous one beside it as
    ``margins.latency_continuous``), ``sampled_data`` the exact sampled-data intervals, and the
    top-level verdicts and intervals stay the continuous analysis's, labelled so
    (docs/method.md#one-model-of-record).
    """

    structure: str
    delay_s: float
    gains: Mapping[str, float]
    free_stable: bool
    free_rigid_body_roots: int
    locked_stable: bool
    humans: tuple[FamilyResult, ...]
    environment: tuple[EnvironmentResult, ...]
    passivity: PassivityResult
    dob: DobMargins | None
    amplification: Amplification
    J_m_hat_over_J_j: float
    warnings: tuple[str, ...] = ()
    sampled_data: SampledCheck | None = field(default=None, repr=False, compare=False)
    gain_schedule: tuple[ScheduleEntry, ...] | None = field(default=None, repr=False, compare=False)
    margins: tuple["LatencyMargin", "PlantMargin"] | None = None
    cross_check: Mapping[str, Any] | None = field(default=None, repr=False, compare=False)
    config: Any = field(default=None, repr=False, compare=False)
    sampled: Any = field(default=None, repr=False, compare=False)

    units = GAIN_UNITS_TORQUE
    metric_units = METRIC_UNITS

    @property
    def robust(self) -> bool:
        return bool(self.free_stable) and all(bool(x.robust) for x in self.humans + self.environment)

    def __repr__(self) -> str:
        parts = [f"robust={self.robust}", f"free_stable={self.free_stable}", f"locked_stable={self.locked_stable}",
                 f"humans={list(self.humans)!r}",
                 f"passivity max excess {self.passivity.max_phase_excess_deg:.4g} deg"]
        if self.dob is not None:
            parts.append(f"DOB phase margin {self.dob.phase_margin_deg:.4g} deg")
        parts.append(f"amplification {self.amplification.dc:.6g} –, {self.amplification.bandwidth_hz:.4g} Hz")
        if self.margins is not None:
            parts.append(f"latency margin {self.margins[0].extra_delay_s * 1e3:.4g} ms")
        if self.sampled is not None:
            parts.append(f"sampled at {self.sampled.sample_rate_hz:g} Hz: robust={self.sampled.robust}, latency margin "
                         f"{self.sampled.latency_margin_s * 1e3:.4g} ms, certifiable={self.sampled.certifiable}")
        elif self.sampled_data is not None:
            parts.append(f"sampled at {self.sampled_data.sample_rate_hz:g} Hz")
        if self.warnings:
            parts.append(f"{len(self.warnings)} warning{'' if len(self.warnings) == 1 else 's'}")
        return "DesignAnalysis(" + ", ".join(parts) + ")"

    @property
    def latency_margin(self):
        """The :class:`exotune.analysis.LatencyMargin` (None when margins were not computed)."""
        return None if self.margins is None else self.margins[0]

    @property
    def plant_margin(self):
        """The :class:`exotune.analysis.PlantMargin` (None when margins were not computed)."""
        return None if self.margins is None else self.margins[1]

    @property
    def latency_margin_s(self) -> float | None:
        """The extra delay the design tolerates [s] (None when margins were not computed): the
        sampled-data loop's when the verdicts of record were computed (``sampled``), else the
        continuous one."""
        if self.sampled is not None:
            return self.sampled.latency_margin_s
        return None if self.margins is None else float(self.margins[0].extra_delay_s)

    @property
    def continuous_latency_margin_s(self) -> float | None:
        """The continuous-time latency margin [s] (None when margins were not computed)."""
        return None if self.margins is None else float(self.margins[0].extra_delay_s)

    def to_dict(self) -> dict:
        """The ``exotune analyze --json`` object (docs/cli.md#exotune-analyze)."""
        d = {}
        if self.margins is not None:
            d["margins"] = {"latency": self.margins[0].to_dict(), "plant_uncertainty": self.margins[1].to_dict()}
            if self.sampled is not None:
                sd = self.sampled.to_dict()
                cont = {**d["margins"]["latency"], "model": "continuous time, exact delay"}
                d["margins"] = {"model_of_record": f"sampled-data at {self.sampled.sample_rate_hz:g} Hz",
                                "latency": {**sd["latency_margin"], "delay_s": self.sampled.delay_s},
                                "latency_continuous": cont, "plant_uncertainty": d["margins"]["plant_uncertainty"]}
        d.update({
            "model": ANALYSIS_MODEL if self.sampled is None else
            ANALYSIS_MODEL + f" (the continuous figures; the verdicts of record at {self.sampled.sample_rate_hz:g} Hz are "
                             "under margins and sampled_data)",
            "structure": self.structure,
            "delay_s": self.delay_s,
            "gain_convention": "torque",
            "gains": dict(self.gains),
            "units": dict(self.units),
            "free_stable": self.free_stable,
            "free": {"stable": self.free_stable, "rigid_body_roots": self.free_rigid_body_roots, "note": RIGID_BODY_NOTE},
            "locked_stable": self.locked_stable,
            "humans": [h.to_dict() for h in self.humans],
            "environment": [e.to_dict() for e in self.environment],
            "passivity": self.passivity.to_dict(),
            "dob": None if self.dob is None else self.dob.to_dict(),
            "amplification": self.amplification.to_dict(),
            "J_m_hat_over_J_j": self.J_m_hat_over_J_j,
            "sampled_data": (self.sampled.to_dict() if self.sampled is not None else
                             None if self.sampled_data is None else self.sampled_data.to_dict()),
            "gain_schedule": None if self.gain_schedule is None else [e.to_dict() for e in self.gain_schedule],
            "metric_units": dict(self.metric_units),
            "warnings": list(self.warnings),
        })
        if self.cross_check is not None:
            d["cross_check"] = copy.deepcopy(dict(self.cross_check))
        return d

    def to_text(self) -> str:
        from ..text.analysis import format_report

        return format_report(self.to_dict())

    @cached_property
    def c7_response(self) -> tuple:
        """The operator-side compliance C7 that :meth:`plot` draws, computed once
        (:func:`exotune.analysis.responses.c7_frequency_response` on its default grid; not in
        ``to_dict``).

        Returns
        -------
        (numpy.ndarray, numpy.ndarray)
            The frequencies [Hz] (800, 0.01 Hz – 1 kHz) and C7 [rad/(N·m)] (complex).
        """
        from .responses import c7_frequency_response

        return c7_frequency_response(self.config)

    def plot(self, ax=None):
        """Bode plot of the operator-side compliance C7 with its non-passive bands shaded and the
        passivity limits drawn; returns the matplotlib ``Figure``."""
        from ..plots.figures import compliance_phase

        f, H = self.c7_response
        return compliance_phase(f, H, self.passivity.nonpassive_band_hz, ax=ax,
                                title="operator-side compliance C7 (paper Fig. 5)")
