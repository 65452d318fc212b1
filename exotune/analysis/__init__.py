"""Robust stability and performance analysis of an exoskeleton design (continuous time, exact delay).

The modules, lowest first (each imports only the ones above it):

``batch_result``        the typed records of a batch analysis (BatchAnalysis; ``to_columns()``: the sweep columns)
``charfun``             the closed-loop characteristic function Δ = Δ00 + z Δ10 + z_e Δ01 + z z_e Δ11 (paper §II model, Fig. 3 controller)
``counting``            exact right-half-plane root counts (argument principle), batched
``brackets``            refinement of crossing brackets, compiled or numpy
``intervals``           exact stable intervals of an impedance family (human, environment)
``operator_passivity`` phase excess and non-passive bands of C7 = Δ10/Δ00 (paper §IV-A)
``dob``                 margins of the disturbance-observer loop
``amplification_ratio`` DC value, bandwidth and minimum phase of C6/C5 (paper §II-D)
``latency``             the one latency-margin engine: every loop's first destabilizing extra delay, batched
``batch``               every metric for a batch of designs (the sweep columns)
``latency_margin``      one design's latency margin (``latency`` for a batch of one, checked by exact verdicts)
``plant_margin``        the plant-uncertainty margin (certified lower, witnessed upper bound)
``kyp``                 KYP passivity certificates of the rational models of C7 (cvxpy)
``design``              the single-design report (``exotune analyze``), with its margins
``design_summary``      the numbers of ``exotune design`` (nominal transfer functions as ``numerics.poly.Rational``)
``crosscheck``          an independent root search (Padé + Newton) on the verdicts
"""

from .amplification_ratio import amplification
from .batch import GAIN_NAMES, analyze_batch
from .batch_result import BatchAnalysis
from .charfun import CharTerms, amplification_qps, char_terms, strip_qps, trim_poly
from .counting import RootCounter, coupled_stable, free_stability, rhp_count
from .crosscheck import pade_crosscheck, pade_stable
from .design import METRIC_UNITS, VERIFY_POINTS, analyze_design, analyze_with_margins, kyp_certificates
from .design_summary import design_report
from .dob import dob_margins
from .intervals import MAX_FAMILY_PIECES, family_intervals
from .latency_margin import LatencyMargin, LoopMargin, latency_margin
from .plant_margin import LoopPlantMargin, PlantMargin, PlantWitness, plant_loops, plant_uncertainty_margin
from .kyp import (
    KypCertificate,
    admittance_certificate,
    certificates_dict,
    compliance_certificate,
    nominal_shortage,
    operator_certificates,
)
from .operator_passivity import BAND_MIN_EXCESS_DEG, c7_response, passivity
from .sea import sea_report

__all__ = [
    "LoopPlantMargin",
    "PlantMargin",
    "PlantWitness",
    "plant_loops",
    "plant_uncertainty_margin",
    "LatencyMargin",
    "LoopMargin",
    "analyze_with_margins",
    "latency_margin",
    "CharTerms",
    "char_terms",
    "amplification_qps",
    "trim_poly",
    "strip_qps",
    "RootCounter",
    "rhp_count",
    "free_stability",
    "coupled_stable",
    "family_intervals",
    "MAX_FAMILY_PIECES",
    "passivity",
    "c7_response",
    "BAND_MIN_EXCESS_DEG",
    "dob_margins",
    "amplification",
    "analyze_batch",
    "BatchAnalysis",
    "GAIN_NAMES",
    "analyze_design",
    "kyp_certificates",
    "METRIC_UNITS",
    "VERIFY_POINTS",
    "KypCertificate",
    "admittance_certificate",
    "certificates_dict",
    "compliance_certificate",
    "operator_certificates",
    "nominal_shortage",
    "pade_crosscheck",
    "pade_stable",
    "design_report",
    "sea_report",
]
