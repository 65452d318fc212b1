"""Sampled-data latency margin of a controller file (``exotune certify``, docs/controller-file.md#latency-margin).

The margin is the largest extra delay ΔT ≥ 0 for which the file's sampled-data loop — its plant,
gains and sos filters, at its rate, with the total delay T + ΔT (fractional samples, exact zero-order
hold, :mod:`exotune.sampled`) — stays stable: the free and locked loops, every environment range and
every rational human family over its whole range, exactly the checks ``certify`` makes at the file's
own delay.

Method: the one sampled-data latency-margin engine, that of the sweep's sampled-data columns
(:func:`exotune.sampled.families.latency_margin`), on a batch of one design — the file's own
realization (:func:`~exotune.controllerfile.fileio.discrete_from_file`: its rounded coefficients,
the float32 realization of a float32 file; :meth:`exotune.sampled.batch.BatchLoops.of_controller`).
Its probe loops are the free and locked loops, both ends of each family and the critical member of
the file's predicted continuous margin when it has one; the bracket starts at that margin ΔT_c (the
zero-order hold costs about half a sample: ΔT_c − T_s/2 and ΔT_c are tried first), else grows from
half a sample; the first probe to cross is followed by the Illinois method to 1e-9 relative; a
batched family check at ΔT(1 − 1e-3) adds the members it finds unstable as probes. The result ΔT
is then confirmed by certify's full family check (:func:`exotune.controllerfile.certify.sampled_analysis`)
at T + ΔT(1 − ``REL``); if a member between the probes is unstable there, it becomes a probe and the
engine runs again (at most ``ROUNDS`` times). At T + ΔT(1 + ``REL``) at least one probe (the
critical member) is unstable. The predicted continuous margin is untrusted: it only chooses where
to look first.
"""

from __future__ import annotations

import math

import numpy as np

from ..numerics.threads import one_blas_thread
from ..sampled.batch import BatchLoops
from ..sampled.families import MAX_SAMPLES, MARGIN_REL, family_loops, latency_margin
from ..units import PARAM_UNITS
from .continuation import covers_range
from .fileio import discrete_from_file, plant_from_file
from .model import ControllerFile, as_controller_file

__all__ = ["REL", "sampled_latency_margin", "requirement_problems", "schedule_minimum"]

REL = 1e-3  # the certificate's resolution: the full check at ΔT(1 − REL), a probe unstable at ΔT(1 + REL)
ROUNDS = 4  # engine runs with new probes when the full check finds an unstable member between them


def _num(x) -> float | None:
    ok = isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) and x >= 0
    return float(x) if ok else None


def _hint(cf: ControllerFile):
    """(ΔT_c [s], critical loop, critical member value) of the file's predicted continuous margin
    (untrusted: anything malformed is None)."""
    pm = cf.predicted.latency_margin
    if not isinstance(pm, dict):
        return None, None, None
    crit = pm.get("critical") if isinstance(pm.get("critical"), dict) else {}
    return _num(pm.get("extra_delay_s")), crit.get("loop"), _num(crit.get("value"))


def _families(cf: ControllerFile, hint_loop, hint_value) -> list:
    """(loop, lo, hi, critical member (1,)) of every checked family of the file: the hinted member
    for the hinted family, else none (NaN)."""
    from ..config import parse_env, parse_human

    humans = [parse_human(i, item)[0] for i, item in enumerate(cf.certify.humans)]
    envs = [parse_env(i, item)[0] for i, item in enumerate(cf.certify.environment)]
    return [(loop, lo, hi, np.array([hint_value if loop.name == hint_loop and hint_value is not None
                                     and lo <= hint_value <= hi else np.nan]))
            for loop, lo, hi in family_loops(humans, envs)]


def _gap_probes(fams: list, sa: dict) -> list:
    """Probes (loop, member (1,)) in the unstable gaps of every family that ``sa`` finds not robust."""
    out = []
    entries = [h for h in sa["humans"] if "skipped" not in h and "not_certifiable" not in h] + sa["environment"]
    for (loop, *_r), h in zip(fams, entries):
        if h.get("robust"):
            continue
        lo, hi = h["range"]
        edges = [lo] + [x for iv in h["stable_intervals"] for x in iv] + [hi]
        for a, b in zip(edges[0::2], edges[1::2]):
            if b > a:
                out.append((loop, np.array([math.sqrt(a * b) if a > 0 else 0.5 * (a + b)])))
    return out


def _nominal_ok(sa: dict) -> bool:
    fams = [h for h in sa["humans"] + sa["environment"] if "skipped" not in h]
    return (sa["free_stable"] and sa["locked_stable"] and all(h.get("robust") for h in fams)
            and not any(h.get("unresolved") for h in fams))


def _critical(probes, dT: float) -> dict | None:
    """The probe of largest spectral radius ≥ 1 at the extra delay ``dT`` (None: every probe stable)."""
    R, _S = probes.all(np.zeros(1, np.int64), np.array([dT]))
    k = int(np.argmax(R[0]))
    if R[0, k] < 1.0:
        return None
    loop, v = probes.loops[k]
    q = loop.param or loop.env_param
    return {"loop": loop.name, "parameter": q, "value": None if v is None else float(v[0]),
            "unit": None if q is None else PARAM_UNITS[q]}


@one_blas_thread
def sampled_latency_margin(doc: ControllerFile | dict, sa: dict, grounded: bool, analysis) -> dict:
    """The sampled-data latency margin of a controller file (module docstring).

    Parameters
    ----------
    doc : ControllerFile or dict
        A validated controller file.
    sa : dict
        Its sampled-data analysis at its own delay (``analysis(doc)``).
    grounded : bool
        Whether its controller feeds back the motor position
        (:func:`exotune.controllerfile.certify.position_feedback`).
    analysis : callable
        certify's full family check, ``analysis(doc) → dict`` (:func:`exotune.controllerfile.certify.sampled_analysis`).

    Returns
    -------
    dict
        ``extra_delay_s`` (None: no extra delay up to 200 samples of total delay destabilizes),
        ``extra_delay_samples``, ``critical`` (loop, parameter, value, unit), ``predicted_continuous_s``
        (the file's own prediction, reported, not trusted), ``required_s``, ``confirmed``, ``method``, ``units``.

    References
    ----------
    docs/controller-file.md#latency-margin; paper Fig. 5 (a delay in the actuator path destabilizes the
    amplification loop).
    """
    cf = as_controller_file(doc)
    fs, T = float(cf.sample_rate_hz), float(cf.delay_s)
    predicted, hint_loop, hint_value = _hint(cf)
    req = None if cf.requirements is None else cf.requirements.latency_margin_s
    out = {"extra_delay_s": 0.0, "extra_delay_samples": 0.0, "critical": None, "predicted_continuous_s": predicted,
           "required_s": req, "confirmed": None,
           "units": {"extra_delay_s": "s", "extra_delay_samples": "samples", "required_s": "s"}}
    if not _nominal_ok(sa):
        fams = [h for h in sa["humans"] + sa["environment"] if "skipped" not in h]
        unproven = (sa["free_stable"] and sa["locked_stable"]
                    and all(h.get("robust") or (h.get("unresolved") and covers_range(h)) for h in fams))
        out["method"] = ("not proven stable at the file's delay (unresolved cells, see the problems): margin 0"
                         if unproven else "not stable at the file's delay: margin 0")
        return out
    bl = BatchLoops.of_controller(plant_from_file(cf), discrete_from_file(cf), grounded)
    fams = _families(cf, hint_loop, hint_value)
    hint = np.array([predicted if predicted else np.nan])  # a bracket start only when positive
    extra, sa_lo = [], None
    for _ in range(ROUNDS):
        m = latency_margin(bl, [0], fams, hint, extra)
        dT = float(m.extra_delay_s[0])
        if not math.isfinite(dT):
            out.update(extra_delay_s=None, extra_delay_samples=None, confirmed=False,
                       checked_up_to_s=max(MAX_SAMPLES / fs - T, 0.0),
                       method=f"no probe unstable up to {MAX_SAMPLES:g} samples of total delay")
            out["units"]["checked_up_to_s"] = "s"
            return out
        sa_lo = analysis(cf.with_delay(T + dT * (1 - REL)))
        new = [] if _nominal_ok(sa_lo) else _gap_probes(fams, sa_lo)
        if not new:
            break
        extra += new
    crit = _critical(m.probes, dT * (1 + REL))
    out.update(extra_delay_s=dT, extra_delay_samples=dT * fs, confirmed=bool(_nominal_ok(sa_lo) and crit is not None),
               critical=crit,
               method=(f"the sampled-data latency-margin engine of the sweep on the file's own realization: "
                       "eigenvalues of probe loops, the first crossing followed to "
                       f"{MARGIN_REL:g} relative from "
                       + ("the file's predicted continuous margin" if predicted else "half a sample up")
                       + f", members a family check finds unstable at ΔT(1 − {REL:g}) added as probes; certify's "
                       f"full family check stable at ΔT(1 − {REL:g}), the critical member unstable at ΔT(1 + {REL:g}); "
                       "the main controller; each gain-schedule entry has its own"))
    return out


def requirement_problems(lm: dict) -> list[str]:
    """The certification problem when the sampled margin ``lm`` is below the file's requirement.

    Parameters
    ----------
    lm : dict
        The sampled-data latency margin (``required_s`` [s], ``extra_delay_s`` [s],
        ``extra_delay_samples``).

    Returns
    -------
    list of str
        One problem, or none.
    """
    req, m = lm.get("required_s"), lm.get("extra_delay_s")
    if m is None:  # no instability up to the probed delays: the requirement is met only within them
        up = lm.get("checked_up_to_s")
        if req and up is not None and req > up:
            return [f"latency margin not verified up to the required {req * 1e3:.3g} ms: no probe is unstable up to "
                    f"{up * 1e3:.3g} ms of extra delay ({MAX_SAMPLES:g} samples of total delay), beyond which "
                    "nothing is checked"]
        return []
    if not req or m >= req:
        return []
    return [f"latency margin {m * 1e3:.3g} ms ({lm['extra_delay_samples']:.3g} samples) < required {req * 1e3:.3g} ms"]


def schedule_minimum(lm: dict, entries: list) -> dict:
    """The latency margin of a file with a gain schedule: the smallest of its main controller's
    and its entries' (the runtime runs each of them), naming the entry when it is one.

    Parameters
    ----------
    lm : dict
        The main controller's :func:`sampled_latency_margin`.
    entries : list of dict
        The gain schedule's entries as :func:`exotune.controllerfile.certify.schedule_section`
        reports them (each with its ``latency_margin``, ``joint_angle_rad`` and ``ratio``).

    Returns
    -------
    dict
        ``lm`` when no entry has a smaller margin; else the entry's margin with
        ``gain_schedule_entry`` = {``joint_angle_rad``, ``ratio``} and ``main_controller_s`` [s]
        (the main controller's margin, None: not bounded). A margin of None (no extra delay up to
        200 samples destabilizes) is larger than any number.

    References
    ----------
    docs/controller-file.md#latency-margin; paper §IV (gain scheduling).
    """
    def key(m):
        v = m.get("extra_delay_s")
        return math.inf if v is None else float(v)

    worst = min(entries, key=lambda e: key(e["latency_margin"]), default=None)
    if worst is None or key(worst["latency_margin"]) >= key(lm):
        return lm
    out = dict(worst["latency_margin"])
    out["gain_schedule_entry"] = {"joint_angle_rad": worst["joint_angle_rad"], "ratio": worst["ratio"]}
    out["main_controller_s"] = lm.get("extra_delay_s")
    return out
