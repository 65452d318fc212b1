"""Sampled-data latency margin of a controller file (``exotune certify``, docs/controller-file.md#latency-margin).

The margin is the largest extra delay ΔT ≥ 0 for which the file's sampled-data loop — its plant,
gains and sos filters, at its rate, with the total delay T + ΔT (fractional samples, exact zero-order
hold, :mod:`exotune.sampled`) — stays stable: the free and locked loops, every environment range and
every rational human family over its whole range, exactly the checks ``certify`` makes at the file's
own delay.

Method: cheap eigenvalue verdicts first, at a few *probe* loops per delay (free, locked, both ends of
each family, ``SCAN`` log-spaced interior members, and the critical member of the file's predicted
continuous margin when it has one). The bracket starts at the predicted continuous margin ΔT_c (the
zero-order hold costs about half a sample: ΔT_c − T_s/2 and ΔT_c are tried first), else grows from
half a sample; it is bisected to ``REL`` relative. The result ΔT is then confirmed by certify's full
family check (:func:`exotune.controllerfile.certify.sampled_analysis`) at T + ΔT(1 − REL); if a member
between the probes is unstable there, it becomes a probe and the search restarts. At T + ΔT(1 + REL)
at least one probe (the critical member) is unstable. The predicted continuous margin is untrusted:
it only chooses where to look first.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..numerics.threads import one_blas_thread
from ..sampled import loop_eigenvalues
from ..units import PARAM_UNITS
from .fileio import discrete_from_file, plant_from_file
from .model import ControllerFile, as_controller_file

__all__ = ["REL", "SCAN", "sampled_latency_margin", "requirement_problems"]

REL = 1e-3  # relative resolution of the margin (bisection and the confirming checks)
SCAN = 16  # interior members probed per family besides its ends
MAX_SAMPLES = 200.0  # the largest total delay [samples] a controller file may carry
ROUNDS = 4  # restarts with new probes when the full check finds an unstable member between them


@dataclasses.dataclass(frozen=True)
class _Probe:
    loop: str
    human: dict | None = None
    env: str | dict = "free"
    parameter: str | None = None
    value: float | None = None
    unit: str | None = None


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


def _families(cf: ControllerFile):
    """(loop name, builder v → (human, env), parameter, unit, lo, hi) of every checked family."""
    from ..config import parse_env, parse_human

    out = []
    for i, item in enumerate(cf.certify.humans):
        fam, _ = parse_human(i, item)
        if fam.kind == "complex_stiffness" or fam.box:
            continue
        fixed = {k: v for k, v in fam.fixed().items() if k in ("inertia", "damping", "stiffness")}
        out.append((f"human{i}_{fam.kind}", lambda v, f=fixed, q=fam.param: ({**f, q: v}, "free"),
                    fam.param, fam.unit, fam.lo, fam.hi))
    for i, item in enumerate(cf.certify.environment):
        env, _ = parse_env(i, item)
        if env.kind in ("spring", "mass"):
            out.append((f"env{i}_{env.kind}", lambda v, e=env: (None, {e.param: v, "damping": e.damping}),
                        env.param, PARAM_UNITS[env.param], env.lo, env.hi))
    return out


def _probes(cf: ControllerFile, hint_loop, hint_value, scan: int) -> list[_Probe]:
    """Probe loops: free, locked and, per family, its ends, ``scan`` interior members and the hinted member."""
    out = [_Probe("free"), _Probe("locked", env="locked")]
    for name, build, q, unit, lo, hi in _families(cf):
        vals = list(np.geomspace(lo, hi, scan + 2) if lo > 0 else np.linspace(lo, hi, scan + 2))
        if name == hint_loop and hint_value is not None and lo <= hint_value <= hi:
            vals.insert(0, hint_value)
        for v in vals:
            h, e = build(float(v))
            out.append(_Probe(name, h, e, q, float(v), unit))
    return out


def _gap_probes(cf: ControllerFile, sa: dict) -> list[_Probe]:
    """Members in the unstable gaps of every family that ``sa`` finds not robust."""
    fams = {name: (build, q, unit) for name, build, q, unit, _lo, _hi in _families(cf)}
    out = []
    names = [n for n in fams if n.startswith("human")] + [n for n in fams if n.startswith("env")]
    entries = [h for h in sa["humans"] if "skipped" not in h and "not_certifiable" not in h] + sa["environment"]
    for name, h in zip(names, entries):
        if h.get("robust"):
            continue
        lo, hi = h["range"]
        edges = [lo] + [x for iv in h["stable_intervals"] for x in iv] + [hi]
        build, q, unit = fams[name]
        for a, b in zip(edges[0::2], edges[1::2]):
            if b > a:
                v = math.sqrt(a * b) if a > 0 else 0.5 * (a + b)
                hm, e = build(v)
                out.append(_Probe(name, hm, e, q, v, unit))
    return out


def _nominal_ok(sa: dict) -> bool:
    fams = [h for h in sa["humans"] + sa["environment"] if "skipped" not in h]
    return (sa["free_stable"] and sa["locked_stable"] and all(h.get("robust") for h in fams)
            and not any(h.get("unresolved") for h in fams))


def _first_unstable(plant, ctrl, grounded: bool, probes, delay: float, worst: bool = True, hot: list | None = None):
    """The probe with the largest spectral radius ≥ 1 at the total delay ``delay``, or None.

    The spectral radius alone decides (one eigenvalue problem per probe): a radius ≥ 1 is never a
    stable verdict whatever the rounding estimate (:func:`exotune.sampled.loop_verdict`), and a
    radius < 1 never names a probe, so ``loop_verdict``'s rounding trials would not change the
    answer. ``worst=False`` (a bisection only asks whether some probe is unstable) returns the first
    unstable probe found, starting with the one found last (``hot``: a one-element list, updated)."""
    c = dataclasses.replace(ctrl, delay_s=delay)
    if not worst:
        start = hot[0] if hot and hot[0] < len(probes) else 0
        for k in list(range(start, len(probes))) + list(range(start)):
            if _radius(plant, c, grounded, probes[k]) >= 1.0:
                if hot:
                    hot[0] = k
                return probes[k]
        return None
    found, rho_w = None, 1.0
    for p in probes:
        rho = _radius(plant, c, grounded, p)
        if rho >= rho_w:
            found, rho_w = p, rho
    return found


def _radius(plant, ctrl, grounded: bool, p: _Probe) -> float:
    """Spectral radius of a probe's sampled-data loop (the rigid-body z = 1 of an ungrounded one excluded)."""
    lam = loop_eigenvalues(plant, ctrl, grounded, p.human, p.env)
    return float(np.max(np.abs(lam))) if lam.size else 0.0


def _bisect(unstable, lo: float, hi: float | None, hint: float | None, Ts: float, cap: float):
    """Bracket [lo, hi] (``unstable(ΔT)`` None at lo, a probe at hi), bisected to REL relative;
    hi None when no extra delay up to ``cap`` destabilizes a probe."""
    if hint is not None and hi is None:
        for x in (hint - 0.5 * Ts, hint):
            if lo < x < cap:
                if unstable(x) is None:
                    lo = x
                else:
                    hi = x
                    break
    while hi is None:
        x = min(lo + max(0.5 * Ts, lo), cap)
        if unstable(x) is not None:
            hi = x
        elif x >= cap:
            return lo, None
        else:
            lo = x
    while hi - lo > 0.5 * REL * hi:
        m = 0.5 * (lo + hi)
        if unstable(m) is None:
            lo = m
        else:
            hi = m
    return lo, hi


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
    Ts = 1.0 / fs
    predicted, hint_loop, hint_value = _hint(cf)
    hint = start = predicted if predicted else None  # a bracket start only when positive
    req = None if cf.requirements is None else cf.requirements.latency_margin_s
    out = {"extra_delay_s": 0.0, "extra_delay_samples": 0.0, "critical": None, "predicted_continuous_s": predicted,
           "required_s": req, "confirmed": None,
           "units": {"extra_delay_s": "s", "extra_delay_samples": "samples", "required_s": "s"}}
    if not _nominal_ok(sa):
        out["method"] = "not stable at the file's delay: margin 0"
        return out
    plant, ctrl = plant_from_file(cf), discrete_from_file(cf)
    probes = _probes(cf, hint_loop, hint_value, 0)  # free, locked, family ends, the predicted critical member
    scan = _probes(cf, None, None, SCAN)
    hot = [0]
    unstable = lambda dT, ps=probes, worst=False: _first_unstable(plant, ctrl, grounded, ps, T + dT, worst, hot)  # noqa: E731
    cap = MAX_SAMPLES * Ts - T
    lo, hi, sa_lo = 0.0, None, None
    for _ in range(ROUNDS):
        lo, hi = _bisect(unstable, lo, hi, hint, Ts, cap)
        if hi is None:
            out.update(extra_delay_s=None, extra_delay_samples=None, confirmed=False,
                       method=f"no probe unstable up to {MAX_SAMPLES:g} samples of total delay")
            return out
        dT = 0.5 * (lo + hi)
        x = dT * (1 - REL)
        sa_lo = None
        p = unstable(x, scan, True)  # interior members of every family, then certify's full check
        if p is None:
            sa_lo = analysis(cf.with_delay(T + x))
            if _nominal_ok(sa_lo):
                break
        new = [p] if p is not None else _gap_probes(cf, sa_lo)
        if not new:
            break
        probes += new
        hi, hint = x, None
        if lo > 0 and unstable(lo) is not None:  # the old lower end fails for a new probe
            lo, hi = 0.0, lo
    ok = sa_lo is not None and _nominal_ok(sa_lo)
    crit = unstable(dT * (1 + REL), worst=True)
    out.update(extra_delay_s=dT, extra_delay_samples=dT * fs, confirmed=bool(ok and crit is not None),
               critical=None if crit is None else {"loop": crit.loop, "parameter": crit.parameter,
                                                   "value": crit.value, "unit": crit.unit},
               method=(f"sampled-data eigenvalues at probe members per delay, bisected to {REL:g} relative from "
                       + ("the file's predicted continuous margin" if start is not None else "half a sample up")
                       + "; certify's full family check stable at ΔT(1 − "
                       f"{REL:g}), the critical member unstable at ΔT(1 + {REL:g}); the main controller only "
                       "(gain-schedule entries not included)"))
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
    if not req or m is None or m >= req:
        return []
    return [f"latency margin {m * 1e3:.3g} ms ({lm['extra_delay_samples']:.3g} samples) < required {req * 1e3:.3g} ms"]
