"""The hysteretic human in a controller file's decision: checked in continuous time.

A hysteretic human, k(1 + jη sign ω), is not rational: the sampled-data loop has no
finite-dimensional model of it, and certify's exact sampled-data analysis skips the family. The
file's controller is the one its design section builds (certify refuses a file where it is not,
unless the file declares itself hand-tuned), so the family is analysed on the continuous-time loop
of that design with the exact delay, as ``exotune analyze`` does. A family that is not robust there
refuses the file: the runtime's sampled-data loop tolerates less (about half a sample of delay), not
more. A robust one is reported as checked in continuous time only, which is all a finite-dimensional
analysis can say of it. A hand-tuned file has no continuous design to analyse: the family is
reported as not checked.

References
----------
docs/method.md#one-model-of-record; docs/controller-file.md (certify).
"""

from __future__ import annotations

from .model import ControllerFile, as_controller_file

__all__ = ["hysteretic_problems", "CONTINUOUS_CHECK_MODEL"]

CONTINUOUS_CHECK_MODEL = ("continuous time, exact delay, the file's design section (a hysteretic human is not "
                          "rational: the sampled-data loop has no finite-dimensional model of it)")


def hysteretic_problems(doc: ControllerFile | dict, sa: dict, where: str = "") -> list[str]:
    """Check the hysteretic families that the sampled-data analysis ``sa`` skipped on the
    continuous-time loop of the file's design; record each check in its entry of ``sa`` (key
    ``continuous_check``) and return why they refuse the file.

    Parameters
    ----------
    doc : ControllerFile or dict
        The controller file (or a gain-schedule entry's view of it).
    sa : dict
        Its sampled-data analysis (:func:`~exotune.controllerfile.certify.sampled_analysis`), whose
        skipped hysteretic entries get a ``continuous_check``: ``model``, ``checked`` and, when
        checked, ``robust``, ``conclusive`` and ``stable_intervals`` [N·m/rad].
    where : str, optional
        A prefix for the problems (a gain-schedule entry).

    Returns
    -------
    list of str
        One line per hysteretic family not robust (or inconclusive) in continuous time.

    References
    ----------
    Paper §IV (coupled stability with the person); docs/method.md#one-model-of-record.
    """
    from ..analysis import analyze_batch
    from ..config import design_from_mapping
    from ..numerics.engine import numpy_engine

    cf = as_controller_file(doc)
    idx = [i for i, h in enumerate(sa["humans"]) if "skipped" in h and h.get("kind") == "complex_stiffness"]
    if not idx:
        return []
    if cf.provenance.hand_tuned is True or cf.implementation is None:
        for i in idx:
            sa["humans"][i]["continuous_check"] = {
                "model": CONTINUOUS_CHECK_MODEL, "checked": False,
                "reason": "a hand-tuned controller has no continuous design to analyse the family on"}
        return []
    mapping = {"plant": cf.plant.values(), "design": cf.design.values(), "implementation": cf.implementation.mapping,
               "humans": [cf.certify.humans[i] for i in idx], "environment": []}
    with numpy_engine():
        fams = analyze_batch(design_from_mapping(mapping)).humans
    problems = []
    for i, fam in zip(idx, fams):
        h = sa["humans"][i]
        check = {"model": CONTINUOUS_CHECK_MODEL, "checked": True, "robust": bool(fam.robust[0]),
                 "conclusive": bool(fam.conclusive[0]), "stable_intervals": [list(iv) for iv in fam.stable_intervals[0]]}
        h["continuous_check"] = check
        if check["robust"]:
            continue
        lo, hi = h["range"]
        if not check["conclusive"]:
            why = "inconclusive (treated as not stable)"
        elif check["stable_intervals"]:
            why = "stable only on " + ", ".join(f"[{a:.6g}, {b:.6g}]" for a, b in check["stable_intervals"]) + f" {h['unit']}"
        else:
            why = "stable nowhere in the range"
        problems.append(f"{where}{h['kind']} {h['parameter']} [{lo:g}, {hi:g}] {h['unit']}: not robust in the "
                        f"continuous-time analysis of the file's design ({why}); the sampled-data loop cannot check "
                        "a hysteretic human, so nothing certifies it")
    return problems
