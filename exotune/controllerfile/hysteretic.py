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

import copy
import json
import math
from dataclasses import dataclass

import numpy as np

from .model import ControllerFile, as_controller_file

__all__ = ["hysteretic_problems", "hysteretic_problems_many", "CONTINUOUS_CHECK_MODEL"]

CONTINUOUS_CHECK_MODEL = ("continuous time, exact delay, the file's design section (a hysteretic human is not "
                          "rational: the sampled-data loop has no finite-dimensional model of it)")


def hysteretic_problems(doc: ControllerFile | dict, sa: dict, where: str = "", margin: dict | None = None) -> list[str]:
    """Check the hysteretic families that the sampled-data analysis ``sa`` skipped on the
    continuous-time loop of the file's design; record each check in its entry of ``sa`` (key
    ``continuous_check``) and return why they refuse the file. With the file's sampled-data
    latency ``margin``, the families are also checked at the margin's total delay: one that is
    not robust there bounds the margin of record by its own continuous-time latency margin
    (``margin`` is updated in place, with a ``bound`` entry), since nothing else measures how much
    delay the loop with that human tolerates. A batch of one of :func:`hysteretic_problems_many`.

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
    return hysteretic_problems_many([(doc, sa, where)], margin)[0]


def hysteretic_problems_many(items: list, margin: dict | None = None) -> list[list[str]]:
    """:func:`hysteretic_problems` of several controller documents (a file and its gain-schedule
    entries' views), their continuous-time analyses run as one batch where their designs differ
    only in overridable numbers (the entries' reflected plants).

    Parameters
    ----------
    items : list of (ControllerFile or dict, dict, str)
        (document, its sampled-data analysis, prefix of its problems) per document.
    margin : dict or None, optional
        The sampled-data latency margin of the first document, bounded in place.

    Returns
    -------
    list of list of str
        The problems of each document, in the order of ``items``.

    References
    ----------
    Paper §IV (coupled stability with the person); docs/method.md#one-model-of-record.
    """
    rows, jobs = [], []  # rows: (mapping, delay [s]); jobs: (item, cf, idx, row of the file's delay)
    for k, (doc, sa, _where) in enumerate(items):
        cf = as_controller_file(doc)
        idx = [i for i, h in enumerate(sa["humans"]) if "skipped" in h and h.get("kind") == "complex_stiffness"]
        if not idx:
            continue
        if cf.provenance.hand_tuned is True or cf.implementation is None:
            for i in idx:
                sa["humans"][i]["continuous_check"] = {
                    "model": CONTINUOUS_CHECK_MODEL, "checked": False,
                    "reason": "a hand-tuned controller has no continuous design to analyse the family on"}
            continue
        mapping = {"plant": cf.plant.values(), "design": cf.design.values(), "implementation": cf.implementation.mapping,
                   "humans": [cf.certify.humans[i] for i in idx], "environment": []}
        jobs.append((k, cf, idx, len(rows)))
        rows.append((mapping, float(cf.delay_s)))
    dT = None if margin is None else margin.get("extra_delay_s")
    probe = bool(jobs) and jobs[0][0] == 0 and dT is not None and math.isfinite(dT) and dT > 0.0
    if probe:
        rows.append((rows[0][0], float(jobs[0][1].delay_s) + dT))
    fams = _analyze_rows(rows)
    out: list[list[str]] = [[] for _ in items]
    if probe and all(f.robust for f in fams[0]) and not all(f.robust for f in fams[-1]):
        from ..config import design_from_mapping

        _bound_margin(design_from_mapping(rows[0][0]), jobs[0][2], margin, float(jobs[0][1].sample_rate_hz))
    for k, _cf, idx, r in jobs:
        _doc, sa, where = items[k]
        out[k] = _problems(sa, idx, fams[r], where)
    return out


@dataclass(frozen=True)
class _Member:
    """One family's continuous verdicts in one design of :func:`_analyze_rows`."""

    robust: bool
    conclusive: bool
    stable_intervals: list


def _analyze_rows(rows: list) -> list[list[_Member]]:
    """The hysteretic families of each (mapping, delay) row on the numpy engine: rows whose mappings
    differ only in overridable numbers run as one batch (:func:`exotune.config.batch_config`)."""
    from ..analysis import analyze_batch
    from ..config import OVERRIDABLE, batch_config, design_from_mapping
    from ..numerics.engine import numpy_engine

    groups: dict = {}
    for r, (mapping, _delay) in enumerate(rows):
        key = json.dumps(_strip(mapping, OVERRIDABLE), sort_keys=True, default=str)
        groups.setdefault(key, []).append(r)
    out: list = [None] * len(rows)
    for members in groups.values():
        first = rows[members[0]][0]
        over = {path: np.array([_leaf(rows[r][0], path) for r in members], dtype=float)
                for path in OVERRIDABLE if _leaf(first, path) is not None and path != "implementation.delay_s"}
        over["implementation.delay_s"] = np.array([rows[r][1] for r in members])
        with numpy_engine():
            fams = analyze_batch(batch_config(design_from_mapping(first), over)).humans
        for j, r in enumerate(members):
            out[r] = [_Member(bool(f.robust[j]), bool(f.conclusive[j]), [list(iv) for iv in f.stable_intervals[j]])
                      for f in fams]
    return out


def _leaf(mapping: dict, path: str):
    """The number at a dotted ``path`` of a design mapping, or None when absent."""
    x = mapping
    for part in path.split("."):
        if not isinstance(x, dict) or x.get(part) is None:
            return None
        x = x[part]
    return x if isinstance(x, (int, float)) and not isinstance(x, bool) else None


def _strip(mapping: dict, paths) -> dict:
    """A copy of ``mapping`` without the numbers at ``paths`` (presence kept): the key of a batch."""
    out = copy.deepcopy(mapping)
    for path in paths:
        *head, last = path.split(".")
        x = out
        for part in head:
            x = x.get(part) if isinstance(x, dict) else None
        if isinstance(x, dict) and isinstance(x.get(last), (int, float)) and not isinstance(x.get(last), bool):
            x[last] = "number"
    return out


def _problems(sa: dict, idx: list[int], fams: list, where: str) -> list[str]:
    """Record the checks ``fams`` of the families ``idx`` of ``sa`` and word the refusals."""
    problems = []
    for i, fam in zip(idx, fams):
        h = sa["humans"][i]
        check = {"model": CONTINUOUS_CHECK_MODEL, "checked": True, "robust": fam.robust,
                 "conclusive": fam.conclusive, "stable_intervals": fam.stable_intervals}
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
