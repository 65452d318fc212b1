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

import math

import numpy as np

from .model import ControllerFile, as_controller_file

__all__ = ["hysteretic_problems", "CONTINUOUS_CHECK_MODEL"]

CONTINUOUS_CHECK_MODEL = ("continuous time, exact delay, the file's design section (a hysteretic human is not "
                          "rational: the sampled-data loop has no finite-dimensional model of it)")


def hysteretic_problems(doc: ControllerFile | dict, sa: dict, where: str = "", margin: dict | None = None) -> list[str]:
    """Check the hysteretic families that the sampled-data analysis ``sa`` skipped on the
    continuous-time loop of the file's design; record each check in its entry of ``sa`` (key
    ``continuous_check``) and return why they refuse the file. With the file's sampled-data
    latency ``margin``, the families are also checked at the margin's total delay: one that is
    not robust there bounds the margin of record by its own continuous-time latency margin
    (``margin`` is updated in place, with a ``bound`` entry), since nothing else measures how much
    delay the loop with that human tolerates.

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
    margin : dict or None, optional
        The file's sampled-data latency margin
        (:func:`~exotune.controllerfile.latency.sampled_latency_margin`), bounded in place.

    Returns
    -------
    list of str
        One line per hysteretic family not robust (or inconclusive) in continuous time.

    References
    ----------
    Paper §IV (coupled stability with the person); docs/method.md#one-model-of-record.
    """
    from ..analysis import analyze_batch
    from ..config import batch_config, design_from_mapping
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
    cfg = design_from_mapping(mapping)
    dT = None if margin is None else margin.get("extra_delay_s")
    probe = dT is not None and math.isfinite(dT) and dT > 0.0
    with numpy_engine():
        fams = analyze_batch(batch_config(cfg, {"implementation.delay_s": np.array([cf.delay_s, cf.delay_s + dT])})
                             if probe else cfg).humans
    problems = []
    if probe and all(f.robust[0] for f in fams) and not all(f.robust[1] for f in fams):
        _bound_margin(cfg, idx, margin, float(cf.sample_rate_hz))
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


def _bound_margin(cfg, idx: list[int], margin: dict, fs: float) -> None:
    """Lower the sampled-data ``margin`` to the smallest continuous-time latency margin of the
    hysteretic families (``cfg`` holds only them, ``idx`` their places in the file's list) when it
    is smaller, naming that family as critical and keeping the sampled figure under ``bound``."""
    from ..analysis.latency_margin import latency_margin
    from ..numerics.engine import numpy_engine

    with numpy_engine():
        lm = latency_margin(cfg)
    fams = [(j, m) for j, m in enumerate(lm.loops) if m.parameter is not None and m.loop.startswith("human")]
    if not fams:
        return
    j, m = min(fams, key=lambda jm: jm[1].extra_delay_s)
    if not m.extra_delay_s < margin["extra_delay_s"]:
        return
    k = int(m.loop[len("human"):].split("_", 1)[0])
    name = f"human{idx[k]}_complex_stiffness"
    margin["bound"] = {
        "model": "continuous time, exact delay (a hysteretic human has no sampled-data model)",
        "loop": name, "sampled_extra_delay_s": margin["extra_delay_s"], "verified": lm.verified,
        "note": "the hysteretic family's continuous-time margin is smaller than the sampled-data margin of the "
                "rational loops; the runtime's sampled loop typically tolerates about half a sample less than the "
                "continuous one, so this bound is not conservative by construction"}
    margin.update(extra_delay_s=float(m.extra_delay_s), extra_delay_samples=float(m.extra_delay_s) * fs, confirmed=lm.verified,
                  critical={"loop": name, "parameter": m.parameter, "value": m.value, "unit": m.unit})
