"""The verdicts of record of a design that sets a sample rate (docs/method.md#one-model-of-record).

When a design sets ``implementation.sample_rate_hz``, what decides — ``analyze``'s margins and
verdicts, ``optimize``'s final check, ``export``'s refusal — is the sampled-data loop the exported
controller runs: the controller exactly as ``export`` writes it (its static gains and Tustin ``sos``
filters, :func:`~exotune.controllerfile.export.build_export`), the plant and human discretized
exactly with the zero-order hold and the (fractional) delay, judged by ``certify``'s own decision
(:func:`~exotune.controllerfile.certify.sampled_decision`: free and locked verdicts, exact family
intervals by eigenvalue continuation, the sampled-data latency margin against the requirement).
The continuous-time figures stay beside them, labelled as such.

References
----------
docs/method.md#one-model-of-record; docs/controller-file.md#certification; paper §V (the 1 kHz runtime).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, Mapping

from ..record import Result

__all__ = ["SampledVerdicts", "design_verdicts", "analyze_of_record"]

MODEL = ("sampled-data loop of the exported controller (plant and human discretized exactly with the zero-order hold, "
         "fractional delay, the controller's gains and sos filters as export writes them; certify's analysis)")


@dataclass(frozen=True)
class SampledVerdicts(Result):
    """The sampled-data verdicts of record of one design at ``sample_rate_hz`` [Hz] with the total
    delay ``delay_s`` [s]: certify's sampled-data ``analysis`` (free and locked verdicts, exact
    family intervals), its ``latency_margin`` (extra delay [s] and [samples], critical member), the
    ``requirements`` it is held to and the ``problems`` that would make ``certify`` refuse the
    exported file (empty: it certifies, golden vectors and predictions holding by construction)."""

    sample_rate_hz: float
    delay_s: float
    analysis: Mapping[str, Any] = field(repr=False)
    latency_margin: Mapping[str, Any] = field(repr=False)
    requirements: Mapping[str, Any] = field(repr=False)
    problems: tuple[str, ...] = ()
    schedule: tuple[Mapping[str, Any], ...] = field(default=(), repr=False)

    @property
    def certifiable(self) -> bool:
        """True when ``certify`` would certify the exported controller (no problem)."""
        return not self.problems

    @property
    def robust(self) -> bool:
        """Free and locked loops stable and every checked family stable over its whole range."""
        sa = self.analysis
        fams = [h for h in list(sa["humans"]) + list(sa["environment"]) if "skipped" not in h]
        return bool(sa["free_stable"] and sa["locked_stable"] and all(h.get("robust") for h in fams))

    @property
    def latency_margin_s(self) -> float:
        """The sampled-data latency margin [s] (inf: no extra delay up to 200 samples destabilizes)."""
        m = self.latency_margin.get("extra_delay_s")
        return math.inf if m is None else float(m)

    @property
    def required_latency_margin_s(self) -> float:
        """The required latency margin [s] (0: none)."""
        return float(self.requirements.get("latency_margin_s") or 0.0)

    def to_dict(self) -> dict:
        """The ``sampled_data`` section of ``exotune analyze --json`` with a rate."""
        from .latency import requirement_problems

        lm = dict(self.latency_margin)
        req = self.required_latency_margin_s
        lm["model"] = "sampled-data (certify's)"
        lm["met"] = self.latency_margin_s >= req and not requirement_problems({**lm, "required_s": req})
        return {"model": MODEL, "sample_rate_hz": self.sample_rate_hz, "delay_s": self.delay_s,
                "delay_samples": self.delay_s * self.sample_rate_hz,
                "certifiable": self.certifiable, "robust": self.robust, "problems": list(self.problems),
                "requirements": dict(self.requirements), "latency_margin": lm,
                **{k: v for k, v in self.analysis.items() if k != "model"},
                "gain_schedule": [dict(e) for e in self.schedule] if self.schedule else None,
                "units": {"sample_rate_hz": "Hz", "delay_s": "s", "delay_samples": "samples"}}

    def to_text(self) -> str:
        from ..text.verdicts import format_verdicts

        return "\n".join(format_verdicts(self.to_dict()))


def design_verdicts(cfg, require_latency_margin_s: float | None = None, continuous_margin=None) -> SampledVerdicts:
    """The verdicts of record of a design with a sample rate (module docstring): the controller file
    ``export`` would write, decided on by ``certify``'s implementation.

    Parameters
    ----------
    cfg : DesignConfig
        One design with ``implementation.sample_rate_hz`` set.
    require_latency_margin_s : float, optional
        The required latency margin [s] (None: the design's ``requirements`` section, else one
        sample period; 0: none), as :func:`~exotune.controllerfile.export.requirements_section`.
    continuous_margin : LatencyMargin, optional
        The design's continuous latency margin when already computed (where the sampled-data
        margin's search starts; computed when absent).

    Returns
    -------
    SampledVerdicts

    References
    ----------
    docs/method.md#one-model-of-record.
    """
    from .certify import decision_and_nominal, schedule_section
    from .latency import schedule_minimum
    from .export import build_export, latency_hint, predicted_latency_margin
    from .model import ControllerFile
    from ..errors import ConfigError

    fs = cfg.implementation.sample_rate_hz
    if not fs:
        raise ConfigError("implementation.sample_rate_hz", "the verdicts of record need the runtime's sample rate")
    fs = float(fs)
    doc = build_export(cfg, fs, require_latency_margin_s=require_latency_margin_s, analyses=False)
    doc["predicted"] = {"latency_margin": (predicted_latency_margin(cfg) if continuous_margin is None
                                           else latency_hint(continuous_margin))}
    cf = ControllerFile.from_dict(doc)
    sa, lm, problems, nominal = decision_and_nominal(cf)
    schedule = ()
    if cf.gain_schedule is not None:
        entries, sched_problems, _ = schedule_section(cf, nominal=nominal)
        problems += sched_problems
        lm = schedule_minimum(lm, entries)
        schedule = tuple({k: v for k, v in e.items()} for e in entries)
    if not [h for h in sa["humans"] if "skipped" not in h]:
        problems.append("the design names no rational human family to certify against (humans)")
    return SampledVerdicts(fs, float(cf.delay_s), sa, lm, cf.requirements.to_dict(), tuple(problems), schedule)


def _disagreements(r, v: SampledVerdicts) -> list[str]:
    """Warnings where the continuous analysis ``r`` and the verdicts of record ``v`` differ."""
    fs = v.sample_rate_hz
    out = []
    sa = v.analysis
    for key, where in (("free_stable", "with the cuff free"), ("locked_stable", "with the output locked")):
        s = sa[key]
        if s is None:
            out.append(f"at {fs:g} Hz the sampled-data verdict {where} is inconclusive (spectral radius within rounding of 1)")
        elif s != bool(getattr(r, key)):
            out.append(f"at {fs:g} Hz the sampled-data loop is {'stable' if s else 'UNSTABLE'} {where}, unlike the "
                       "continuous analysis")
    hs = [h for h in sa["humans"] if "skipped" not in h and "not_certifiable" not in h]
    cont = [h for h in r.humans if h.kind != "complex_stiffness" and not h.box]
    for h, c in zip(hs, cont):
        if bool(h.get("robust")) != bool(c.robust):
            ivs = ", ".join(f"[{a:.5g}, {b:.5g}]" for a, b in h["stable_intervals"])
            where = f"{h['parameter']} stable on {ivs} {h['unit']}" if ivs else "no member stable"
            out.append(f"at {fs:g} Hz the sampled-data loop is {'robust' if h.get('robust') else 'NOT robust'} for the "
                       f"human {h['kind']} family ({where}), unlike the continuous "
                       "analysis")
    lc = r.latency_margin
    if (lc is not None and math.isfinite(lc.extra_delay_s) and math.isfinite(v.latency_margin_s)
            and abs(lc.extra_delay_s - v.latency_margin_s) * fs > 1e-3):
        gap = (lc.extra_delay_s - v.latency_margin_s) * fs
        out.append(f"the continuous latency margin ({lc.extra_delay_s * 1e3:.4g} ms) overstates the sampled-data "
                   f"runtime's ({v.latency_margin_s * 1e3:.4g} ms) by {gap:.3g} samples: the zero-order hold costs about "
                   "half a sample (docs/method.md#one-model-of-record)" if gap > 0 else
                   f"the sampled-data latency margin ({v.latency_margin_s * 1e3:.4g} ms) exceeds the continuous one "
                   f"({lc.extra_delay_s * 1e3:.4g} ms) by {-gap:.3g} samples")
    return out


def analyze_of_record(cfg):
    """``exotune analyze``: :func:`exotune.analysis.analyze_with_margins` and, when the design sets a
    sample rate, its verdicts of record (:func:`design_verdicts`: the sampled-data margins first,
    exact sampled-data family intervals instead of the continuous analysis's grid check), with the
    continuous figures beside them.

    Parameters
    ----------
    cfg : DesignConfig
        One design.

    Returns
    -------
    DesignAnalysis
        ``sampled`` holds the :class:`SampledVerdicts` (None without a sample rate).

    References
    ----------
    docs/method.md#one-model-of-record.
    """
    from ..analysis import analyze_with_margins

    if not cfg.implementation.sample_rate_hz:
        return analyze_with_margins(cfg)
    r = analyze_with_margins(cfg, sampled_check=False,
                             of_record=lambda c, lm: design_verdicts(c, continuous_margin=lm))
    return replace(r, warnings=tuple(r.warnings) + tuple(_disagreements(r, r.sampled)))
