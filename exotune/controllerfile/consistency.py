"""Whether a controller file is consistent with its own loop: certify's consistency checks alone.

``exotune certify`` decides whether a file may run on a joint; part of its report says whether the
file is *consistent*: its golden vectors are reproduced by the reference runtime, and its predicted
sampled-data results (free and locked verdicts and spectral radii, every family's stable intervals,
for the file and for each gain-schedule entry) are those of its own plant, controller, sample rate
and delay (docs/controller-file.md#certify). ``exotune simulate`` refuses an inconsistent file (an
edited gain or rate would make the simulation describe another controller than the file claims),
but it simulates an unstable consistent one: it needs the consistency checks, not the decision, so
it does not pay for the latency-margin searches, the hysteretic humans' continuous-time checks and
the float32 rounding bound that only the decision needs.

The checks are certify's own functions (:func:`~exotune.controllerfile.certify.golden_problems`,
:func:`~exotune.controllerfile.certify.sampled_analysis`,
:func:`~exotune.controllerfile.certify.prediction_mismatches`), in certify's order, so the
mismatches listed are certify's ``prediction_mismatches`` item for item.
"""

from __future__ import annotations

import numpy as np

from .certify import (check_built_from_design, float32_realization_check, golden_problems, prediction_mismatches,
                      refuse_excess_work, runs_the_file_itself, sampled_analysis)
from .model import ControllerFile, as_controller_file

__all__ = ["consistency_problems"]


def consistency_problems(doc: ControllerFile | dict) -> tuple[list[str], list[str]]:
    """certify's consistency checks of a controller file, without its decision.

    Parameters
    ----------
    doc : ControllerFile or dict
        The validated controller file.

    Returns
    -------
    mismatches : list of str
        The predicted fields that differ from the sampled-data analysis of the file's own loop
        (each gain-schedule entry's first, then the file's; certify's ``prediction_mismatches``).
    golden : list of str
        One line per controller (the file's, each entry's) that does not reproduce its golden
        vectors (certify's golden-vector problems).

    Raises
    ------
    exotune.errors.ConfigError
        Where certify refuses the file as input: a controller not built from the file's design and
        plant (unless hand-tuned), more work than the file's size allows, golden inputs that
        overflow the controller, a float32 realization that is not the file's.

    References
    ----------
    docs/controller-file.md#certify.
    """
    from .precision import precision_of

    cf = as_controller_file(doc)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        check_built_from_design(cf)
        refuse_excess_work(cf)
        golden, _, _ = golden_problems(cf)
        sa = sampled_analysis(cf)
        mism = []
        if cf.gain_schedule is not None:
            top = cf.to_dict()
            for e in cf.gain_schedule.entries:
                sa_e = sa if runs_the_file_itself(top, e.to_dict()) else sampled_analysis(cf.entry_view(e))
                mism += prediction_mismatches(e.predicted_sampled, sa_e,
                                              f"gain_schedule[{e.joint_angle_rad:g} rad].predicted_sampled")
        mism += prediction_mismatches(cf.predicted.sampled, sa, "predicted.sampled")
    if precision_of(cf) == "float32":
        float32_realization_check(cf)
    return mism, golden
