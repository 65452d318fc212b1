"""exotune.sampled: the exact sampled-data model (zero-order hold, fractional delay, the Tustin
controller) and its stability verdicts (:mod:`.loop`)."""

from .loop import (
    CHECK_POINTS,
    Block,
    DiscreteController,
    Measured,
    assemble,
    check_design,
    closed_loop_matrix,
    controller_blocks,
    default_prewarp,
    discretize,
    loop_eigenvalues,
    loop_stable,
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
    "loop_eigenvalues",
    "tustin",
    "prewarped",
    "zoh_fractional",
    "default_prewarp",
    "check_design",
    "CHECK_POINTS",
]
