"""``exotune simulate``: nonlinear time-domain runs of the runtime controller on the joint.

The exported runtime controller is stepped once per sample (:mod:`.engine`); the joint is
integrated exactly where it is linear and by a stiff-safe adaptive integrator across nonlinear
events (:mod:`.plant`); a run is judged by the growth rate of its oscillation envelope, with the
linearized sampled-data loop's spectral radius beside it (:mod:`.verdict`); the scenarios
(:mod:`.scenarios`) each measure what they name (:mod:`.report`).
"""

from ..lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        "simulate": "engine",
        "run_scenario": "report",
        "Scenario": "scenarios",
        "SCENARIOS": "scenarios",
        "Nonlinearities": "scenarios",
        "STARTS": "engine",
        "JointPlant": "plant",
        "load_for_simulation": "load",
        "at_joint_angle": "load",
        "schedule_entry": "load",
    },
)
