"""``exotune simulate``: nonlinear time-domain runs of the runtime controller on the joint.

The exported runtime controller is stepped once per sample (:mod:`.engine`); the joint is
integrated exactly where it is linear and by a stiff-safe adaptive integrator across nonlinear
events (:mod:`.plant`); a run is judged by the growth rate of its oscillation envelope, with the
linearized sampled-data loop's spectral radius beside it (:mod:`.verdict`); the scenarios
(:mod:`.scenarios`) each measure what they name (:mod:`.report`).
"""

from .engine import STARTS, bumpless_start, simulate
from .load import at_joint_angle, check_consistent, check_human_inertia, load_for_simulation
from .plant import MIN_HUMAN_INERTIA, JointPlant
from .report import dob_estimate, run_scenario, summarize
from .scenarios import SCENARIOS, Nonlinearities, Scenario, deadzone
from .verdict import MARGINAL_TOL, classify, envelope_growth, loop_spectral_radius

__all__ = ["Nonlinearities", "Scenario", "SCENARIOS", "deadzone", "simulate", "run_scenario", "summarize",
           "bumpless_start", "STARTS", "JointPlant", "load_for_simulation", "at_joint_angle", "check_consistent", "MARGINAL_TOL",
           "classify", "envelope_growth", "loop_spectral_radius", "dob_estimate", "check_human_inertia", "MIN_HUMAN_INERTIA"]
