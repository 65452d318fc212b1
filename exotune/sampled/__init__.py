"""exotune.sampled: the exact sampled-data model (zero-order hold, fractional delay, the Tustin
controller) and its stability verdicts (:mod:`.loop`)."""

from ..lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        "Measured": "loop",
        "plant_ss": "loop",
        "Block": "loop",
        "controller_blocks": "loop",
        "DiscreteController": "loop",
        "discretize": "loop",
        "assemble": "loop",
        "closed_loop_matrix": "loop",
        "sampled_stable": "loop",
        "loop_stable": "loop",
        "loop_verdict": "loop",
        "loop_eigenvalues": "loop",
        "loop_spectra": "loop",
        "check_design": "check",
        "SampledCheck": "check",
        "SampledFamilyCheck": "check",
        "Disagreement": "check",
        "Boundary": "check",
    },
)
