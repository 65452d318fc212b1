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
``gain_schedule``       every gain-schedule entry of a batch (paper §IV gain scheduling): one batch of N·E designs
``latency_margin``      one design's latency margin (``latency`` for a batch of one, checked by exact verdicts)
``plant_margin``        the plant-uncertainty margin (certified lower, witnessed upper bound)
``kyp``                 KYP passivity certificates of the rational models of C7 (SDP, Clarabel)
``design``              the single-design report (``exotune analyze``), with its margins
``design_summary``      the numbers of ``exotune design`` (nominal transfer functions as ``numerics.poly.Rational``)
``crosscheck``          an independent root search (Padé + Newton) on the verdicts

The package exports (lazily) the drivers that take a design and their typed results; the building
blocks (``char_terms``, ``RootCounter``, ``family_intervals``, …) are imported from their modules
(docs/architecture.md#public-names).
"""

from ..lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        "analyze_design": "design",
        "analyze_with_margins": "design",
        "kyp_certificates": "design",
        "analyze_batch": "batch",
        "BatchAnalysis": "batch_result",
        "GAIN_NAMES": "batch_result",
        "LatencyMargin": "latency_margin",
        "LoopMargin": "latency_margin",
        "plant_uncertainty_margin": "plant_margin",
        "PlantMargin": "plant_margin",
        "PlantWitness": "plant_margin",
        "LoopPlantMargin": "plant_margin",
        "operator_certificates": "kyp",
        "KypCertificate": "kyp",
        "pade_crosscheck": "crosscheck",
        "design_report": "design_summary",
        "sea_report": "sea",
    },
)
