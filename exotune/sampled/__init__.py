"""exotune.sampled: the exact sampled-data model (zero-order hold, fractional delay, the Tustin
controller) and its stability verdicts (:mod:`.loop`)."""

from .check import CHECK_POINTS, Boundary, Disagreement, SampledCheck, SampledFamilyCheck, check_design
from .loop import (
    Block,
    DiscreteController,
    Measured,
    assemble,
    closed_loop_matrix,
    controller_blocks,
    default_prewarp,
    discretize,
    loop_eigenvalues,
    loop_stable,
    loop_verdict,
    spectral_verdict,
    plant_ss,
    prewarped,
    sampled_stable,
    tustin,
    zoh_fractional,
)

__all__ = [
    "Measured",
    "plant_ss",
    "Block",
    "controller_blocks",
    "DiscreteController",
    "discretize",
    "assemble",
    "closed_loop_matrix",
    "sampled_stable",
    "loop_stable",
    "loop_verdict",
    "spectral_verdict",
    "loop_eigenvalues",
    "tustin",
    "prewarped",
    "zoh_fractional",
    "default_prewarp",
    "check_design",
    "CHECK_POINTS",
    "SampledCheck",
    "SampledFamilyCheck",
    "Disagreement",
    "Boundary",
]
