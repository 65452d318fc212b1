"""Export of the runtime controller file (docs/controller-file.md ``exotune export``).

The file is what a real-time runtime loads: at ``sample_rate_hz`` it reads the sampled signals
θ_m [rad], θ̇_m [rad/s], τ_s [N·m], τ̇_s [N·m/s], τ_c [N·m] and computes (docs/method.md#controller)

    τ_cmd[k] = Σ_signals gain · signal[k] + Σ_filters filter(input)[k]

with every filter a cascade of second-order sections in scipy's ``sos`` convention (rows
[b0, b1, b2, a0, a1, a2], a0 = 1, direct form II transposed). One filter, ``dob_command``, acts on
τ_cmd[k] itself: the DOB's algebraic loop (Tustin gives Q a feed-through). A cascade's output is
affine in its input, y = g·x + h (g = Π b0 of its sections, h its output for x = 0), so the runtime
solves τ_cmd = (rest + h)/(1 − g) and then advances the cascade with x = τ_cmd
(:mod:`exotune.runtime`). The blocks are those of :func:`exotune.sampled.controller_blocks`, each
discretized by the bilinear transform prewarped at its cutoff (:func:`exotune.sampled.loop.default_prewarp`),
here through zeros/poles (``scipy.signal.bilinear_zpk`` → ``zpk2sos``); the analysis side
(:func:`exotune.sampled.discretize`) goes through state space, and the tests check that both agree.

Every number carries its unit ({value, unit}, or a ``unit`` next to a list). The file also holds
the plant, the design, the delay it was designed for, the predicted metrics (continuous docs/method.md#analyses-and-metrics
analysis and the sampled-data intervals that ``exotune certify`` recomputes from this file), the
human/environment families to certify against, golden input/output vectors of the reference
runtime, and provenance. Its JSON Schema ships as ``exotune/schemas/controller.schema.json``
(generated from :class:`~exotune.controllerfile.schema.ControllerSchema`; a test keeps them equal).
"""

from __future__ import annotations

import datetime as _dt
import math
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ConfigError
from ..sampled import Measured
from .build import controller_section, quantity, reflected_mapping
from .certify import decision_and_nominal, refuse_excess_work, runs_the_file_itself, sampled_analysis, schedule_section
from .latency import schedule_minimum
from .fileio import schedule_entry_doc, write_controller
from .precision import add_realizations, realization
from .target import runtime_of
from .results import ExportedController
from .schema import DESIGN_UNITS, PLANT_UNITS, SCHEMA_VERSION, SIGNAL_UNITS, validate_controller

__all__ = [
    "build_export",
    "predicted_latency_margin",
    "latency_hint",
    "requirements_section",
    "export_design",
    "design_at_rate",
    "check_sample_rate",
    "reflected_mapping",
]



_q = quantity


# --------------------------------------------------------------------------------------------
# the file's contents
# --------------------------------------------------------------------------------------------
def _golden_inputs(n: int = 200, fs: float = 1000.0, seed: int = 20251122) -> dict[str, np.ndarray]:
    """Deterministic, broadband test signals in realistic ranges (steps, sines, noise)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fs
    step = (np.arange(n) >= n // 10).astype(float)
    sig = {
        "theta_m": 0.1 * step + 0.05 * np.sin(2 * np.pi * 3.0 * t) + 0.002 * rng.standard_normal(n),
        "omega_m": 0.5 * np.cos(2 * np.pi * 3.0 * t) + 0.05 * rng.standard_normal(n),
        "tau_s": 5.0 * step + 2.0 * np.sin(2 * np.pi * 7.0 * t) + 0.1 * rng.standard_normal(n),
        "dtau_s": 80.0 * np.cos(2 * np.pi * 7.0 * t) + 5.0 * rng.standard_normal(n),
        "tau_c": 2.0 * step + 1.0 * np.sin(2 * np.pi * 11.0 * t) + 0.05 * rng.standard_normal(n),
    }
    return sig




def _gain_schedule(cfg, fs: float, doc: dict, analyses: bool = True, nominal: tuple | None = None) -> dict:
    """The gain schedule's entries; ``nominal``: the file's own analysis and margin as computed
    (:func:`~exotune.controllerfile.certify.decision_and_nominal`), copied for an entry that runs
    the file's own loop instead of analysed again."""
    import copy

    from ..config import design_from_mapping

    tr = cfg.raw["transmission"]
    entries = []
    for angle, ratio in zip(tr["joint_angle_rad"], tr["ratio"]):
        cfg_i = design_from_mapping(reflected_mapping(cfg.raw, ratio))
        gains_sig, filters, six = controller_section(cfg_i, fs)
        entry = {
            "joint_angle_rad": float(angle),
            "ratio": float(ratio),
            "plant": {k: _q(v, PLANT_UNITS[k]) for k, v in cfg_i.raw["plant"].items()},
            "gains": six,
            "controller": {"gains": gains_sig, "filters": filters},
        }
        if doc["controller"].get("realization") is not None:  # float32: each entry's own realization
            entry["controller"]["realization"] = realization(entry["controller"],
                                                             f"gain_schedule.entries[{len(entries)}].controller")
        if analyses and nominal is not None and runs_the_file_itself(doc, entry):
            entry["predicted_sampled"] = copy.deepcopy(nominal[0])  # the file's own loop: its analysis
        elif analyses:
            entry["predicted_sampled"] = sampled_analysis(schedule_entry_doc(doc, entry))
        entries.append(entry)
    return {"variable": "joint_angle_rad", "unit": "rad", "entries": entries}


def _predicted(cfg) -> dict:
    """The continuous docs/method.md#analyses-and-metrics metrics of the design (exotune.analysis), with units."""
    import dataclasses

    from ..analysis import analyze_design
    from ..analysis.kyp import SHORTAGE_UNIT

    # continuous metrics only: the sampled-data intervals are computed once, by certify's own
    # analysis of the file (predicted.sampled), not a second time inside analyze_design
    cont = dataclasses.replace(cfg, implementation=dataclasses.replace(cfg.implementation, sample_rate_hz=None))
    r = analyze_design(cont)
    humans = [{"kind": h.kind, "parameter": h.parameter, "unit": h.unit, "range": list(h.range),
               "stable_intervals": None if h.stable_intervals is None else [list(iv) for iv in h.stable_intervals],
               "robust": h.robust} for h in r.humans]
    pas, dob, amp = r.passivity, r.dob, r.amplification
    return {
        "model": "continuous time, exact delay (exotune analyze)",
        "free_stable": r.free_stable,
        "locked_stable": r.locked_stable,
        "humans": humans,
        "passivity": {"max_phase_excess_deg": _q(pas.max_phase_excess_deg, "deg"),
                      "nonpassive_band_hz": {"value": [list(b) for b in pas.nonpassive_band_hz], "unit": "Hz"},
                      "kyp": {name: (c if name == "error" else
                                     {"model": c.model, "passive": c.passive, "shortage": _q(c.shortage, SHORTAGE_UNIT)})
                              for name, c in pas.kyp.items()}},
        "dob": None if dob is None else {
            "gain_margin_db": _q(dob.gain_margin_db, "dB"),
            "phase_margin_deg": _q(dob.phase_margin_deg, "deg"),
            "delay_margin_s": _q(dob.delay_margin_s, "s"),
        },
        "amplification": {"dc": _q(amp.dc, "1"), "bandwidth_hz": _q(amp.bandwidth_hz, "Hz")},
    }


def predicted_latency_margin(cfg) -> dict:
    """The continuous latency margin of the design as exported
    (:func:`exotune.analysis.latency_margin.latency_margin`, exact delay, at the export rate for the
    sample count), for ``predicted.latency_margin``.

    Parameters
    ----------
    cfg : DesignConfig
        The design at the export rate (:func:`design_at_rate`).

    Returns
    -------
    dict
        ``extra_delay_s`` [s] and ``extra_delay_samples`` (None when no extra delay destabilizes),
        ``critical`` (loop, parameter, value, unit, frequency_hz), ``verified``, ``note``, ``units``.

    References
    ----------
    docs/method.md#latency-margin; docs/controller-file.md#latency-margin.
    """
    from ..analysis.latency_margin import latency_margin

    return latency_hint(latency_margin(cfg))


def latency_hint(m) -> dict:
    """A continuous :class:`~exotune.analysis.LatencyMargin` as a controller file's
    ``predicted.latency_margin`` (where the sampled-data margin's search starts; untrusted).

    Parameters
    ----------
    m : LatencyMargin
        The continuous latency margin of the design.

    Returns
    -------
    dict
        ``model``, ``extra_delay_s`` [s] (None when unbounded), ``extra_delay_samples``,
        ``critical`` (loop, parameter, value, unit, frequency [Hz]), ``verified``, ``note`` and
        ``units``.
    """
    fin = math.isfinite(m.extra_delay_s)
    c = m.critical
    return {
        "model": "continuous time, exact delay (exotune analyze)",
        "extra_delay_s": float(m.extra_delay_s) if fin else None,
        "extra_delay_samples": float(m.extra_delay_samples) if fin and m.extra_delay_samples is not None else None,
        "critical": None if c is None else {"loop": c.loop, "parameter": c.parameter, "value": c.value,
                                            "unit": c.unit, "frequency_hz": c.frequency_hz},
        "verified": m.verified,
        "note": m.note,
        "units": {"extra_delay_s": "s", "extra_delay_samples": "samples", "frequency_hz": "Hz"},
    }


def requirements_section(fs: float, require_latency_margin_s: float | None = None,
                         design_requirements: dict | None = None) -> dict:
    """The ``requirements`` section: the latency margin the file must keep. The command line's
    ``--require-latency-margin-s`` wins; else the design's own ``requirements`` section (written by
    ``exotune optimize`` with the margin it was asked for); else one sample period 1/fs. 0 disables
    the requirement.

    Parameters
    ----------
    fs : float
        Sample rate [Hz].
    require_latency_margin_s : float, optional
        Required extra delay [s] (``--require-latency-margin-s``).
    design_requirements : dict, optional
        The design file's ``requirements`` section ({latency_margin_s, source}).

    Returns
    -------
    dict
        ``{latency_margin_s, unit, source}``.

    References
    ----------
    docs/controller-file.md#latency-margin; docs/design-file.md#requirements.
    """
    if require_latency_margin_s is None:
        dm = (design_requirements or {}).get("latency_margin_s")
        if dm is not None:
            src = (design_requirements or {}).get("source")
            return {"latency_margin_s": float(dm), "unit": "s",
                    "source": "the design's requirements section" + (f" ({src})" if src else "")}
        return {"latency_margin_s": 1.0 / fs, "unit": "s", "source": "default: one sample period (1/sample_rate_hz)"}
    try:
        v = float(require_latency_margin_s)
    except (TypeError, ValueError):
        raise ConfigError("require_latency_margin_s", f"expected a number of seconds, got {require_latency_margin_s!r}") from None
    if not (math.isfinite(v) and v >= 0):
        raise ConfigError("require_latency_margin_s", f"must be a finite number of seconds ≥ 0, got {v:g}")
    return {"latency_margin_s": v, "unit": "s",
            "source": "--require-latency-margin-s (0: no requirement)" if v == 0 else "--require-latency-margin-s"}


def implementation_section(raw: dict, fs: float) -> dict:
    """The design file's ``implementation`` section as exported (units in the key names, as in a
    design file; ``sample_rate_hz`` the file's rate): with ``plant`` and ``design`` it rebuilds the
    whole controller, which ``certify`` does and compares with the file's."""
    import copy

    impl = copy.deepcopy(raw.get("implementation") or {})
    impl["sample_rate_hz"] = float(fs)
    return impl


def build_export(cfg, sample_rate_hz: float, source: str | None = None, input_hash: str | None = None,
                 now: _dt.datetime | None = None, require_latency_margin_s: float | None = None,
                 analyses: bool = True) -> dict:
    """The controller file of a validated single design ``cfg`` at ``sample_rate_hz``
    (the configuration must already carry that sample rate: see :func:`exotune.cli` export);
    ``require_latency_margin_s``: see :func:`requirements_section`.

    ``analyses=False`` builds only what the runtime executes (controller, gain schedule, plant,
    delay, golden vectors) for an in-memory simulation: no predictions (``predicted`` is None, no
    ``predicted_sampled`` per schedule entry) — the sampled-data analysis of a 100 kHz file takes
    minutes, a simulation needs none of it. Such a document is not a controller file to write.

    Parameters
    ----------
    cfg : DesignConfig
        The validated design, with ``implementation.sample_rate_hz`` equal to ``sample_rate_hz``.
    sample_rate_hz : float
        Sample rate [Hz].
    source : str or None, optional
        The design file's path, for the provenance.
    input_hash : str or None, optional
        SHA-256 of the design, for the provenance.
    now : datetime.datetime or None, optional
        The export time stamped in the provenance; None for the current time.
    require_latency_margin_s : float or None, optional
        The latency margin [s] the file must keep (:func:`requirements_section`).
    analyses : bool, optional
        Run the sampled-data analyses and store their predictions.

    Returns
    -------
    dict
        The controller file's mapping.

    Raises
    ------
    exotune.errors.ConfigError
        When the controller cannot be built or written (e.g. a coefficient that does not fit the
        target precision), or an active time budget is spent.
    """
    from ..version import __version__

    fs = float(sample_rate_hz)
    g = lambda x: float(np.ravel(x)[0])  # noqa: E731
    raw = cfg.raw
    delay = g(cfg.implementation.delay_s)
    gains_sig, filters, gains = controller_section(cfg, fs)
    doc: dict[str, Any] = {
        "schema": SCHEMA_VERSION,
        "sample_rate_hz": _q(fs, "Hz"),
        "delay_s": {"value": delay, "unit": "s", "samples": delay * fs,
                    "note": "total measured-to-applied latency the controller was designed and certified for"},
        "plant": {k: _q(v, PLANT_UNITS[k]) for k, v in raw["plant"].items()},
        "design": {k: _q(v, DESIGN_UNITS[k]) for k, v in raw["design"].items()},
        "implementation": implementation_section(raw, fs),
        "gains": {**gains, "convention": "torque units (docs/method.md#double-compliance-shaping): K2, B2 act on τ_s, K2_hat, B2_hat on τ_c"},
        "signals": {"inputs": {s: SIGNAL_UNITS[s] for s in Measured}, "output": {"tau_cmd": "N·m"}},
        "controller": {
            "equation": "tau_cmd[k] = sum(gain * signal[k]) + sum(filter(input)[k]); sos rows [b0, b1, b2, a0, a1, a2] "
                        "(scipy convention, a0 = 1), direct form II transposed; the filter on tau_cmd closes an "
                        "algebraic loop: tau_cmd = (rest + h)/(1 - g) with g = prod(b0), h = its output for input 0",
            "gains": gains_sig,
            "filters": filters,
        },
        "dob": None if cfg.implementation.dob is None else {
            "q_cutoff_hz": _q(g(cfg.implementation.dob.cutoff_hz), "Hz"),
            "q_damping": _q(g(cfg.implementation.dob.damping), "1"),
            "filters": [f["name"] for f in filters if f["name"].startswith("dob_")],
        },
        "gain_schedule": None,
        "gain_schedule_note": ("no transmission model in the design file: the gains are constant over the joint "
                               "angle"),
        "transmission": raw.get("transmission"),
        "certify": {"humans": raw["humans"], "environment": raw["environment"]},
    }
    if (raw.get("implementation") or {}).get("precision") == "float32":
        add_realizations(doc)  # what a float32 target executes, analysed exactly (docs/controller-file.md#precision)
    doc["requirements"] = requirements_section(fs, require_latency_margin_s, getattr(cfg, "requirements", None))
    doc["predicted"] = None
    problems: list[str] = []
    if analyses:
        refuse_excess_work(doc, entries=len((raw.get("transmission") or {}).get("ratio") or []))  # before any analysis
        doc["predicted"] = {"continuous": _predicted(cfg), "latency_margin": predicted_latency_margin(cfg)}
        # certify's own decision on this very document (docs/method.md#one-model-of-record)
        sa, lm, problems, nominal = decision_and_nominal(doc)
        doc["predicted"]["sampled"] = sa
        doc["predicted"]["sampled_latency_margin"] = lm
    if raw.get("transmission"):
        doc["gain_schedule"] = _gain_schedule(cfg, fs, doc, analyses, nominal if analyses else None)
        if analyses:  # certify's own decision on every entry (docs/method.md#one-model-of-record)
            entries, sched_problems, _ = schedule_section(
                doc, [e["predicted_sampled"] for e in doc["gain_schedule"]["entries"]], nominal=nominal)
            problems += sched_problems
            doc["predicted"]["sampled_latency_margin"] = schedule_minimum(doc["predicted"]["sampled_latency_margin"],
                                                                          entries)
        doc["gain_schedule_note"] = (
            "paper §IV (gain scheduling): the gains are recomputed from the joint-reflected J_m, B_m, K_s at each scheduled joint angle "
            "(transmission ratio r: J_m, B_m, K_s scale with r²), so the compliance the human feels stays the "
            "same; each entry is a complete controller, certified frozen at its angle (LTI) — the time-varying "
            "schedule itself has no stability guarantee (paper); the reference runtime uses the nearest entry")
    ins = _golden_inputs(fs=fs)
    out = runtime_of(doc).run(ins)  # float32 files: in float32 arithmetic, the C port's operations
    for e in (doc["gain_schedule"] or {}).get("entries", []):
        e["golden_tau_cmd"] = {"unit": "N·m", "values": [float(x) for x in runtime_of(schedule_entry_doc(doc, e)).run(ins)]}
    doc["golden"] = {"note": "reference-runtime outputs (exotune.runtime) for these inputs from the zero state",
                     "inputs": {s: {"unit": SIGNAL_UNITS[s], "values": [float(x) for x in v]} for s, v in ins.items()},
                     "tau_cmd": {"unit": "N·m", "values": [float(x) for x in out]}}
    doc["provenance"] = {
        "exotune_version": __version__,
        "source": None if source is None else Path(source).name,
        "input_sha256": input_hash,
        "created_utc": (now or _dt.datetime.now(_dt.timezone.utc)).replace(microsecond=0).isoformat(),
    }
    if analyses:
        if not [h for h in doc["predicted"]["sampled"]["humans"] if "skipped" not in h]:
            problems.append("the design names no rational human family to certify against (humans)")
        if problems:  # why certify would refuse it (export_design writes it only when allowed)
            doc["provenance"]["uncertified"] = list(problems)
        validate_controller(doc)
    return doc


def export_design(design_file, sample_rate_hz: float | None, out, require_latency_margin_s: float | None = None,
                  time_budget_s: float | None = None, allow_uncertified: bool = False) -> ExportedController:
    """``exotune export``: validate the design at its rate (cutoffs below Nyquist), build the
    controller file, decide on it exactly as ``certify`` does (its sampled-data verdicts, family
    intervals and latency margin against its ``requirements``) and write it atomically as YAML.

    Parameters
    ----------
    design_file : path
        The design file.
    sample_rate_hz : float or None
        Runtime rate [Hz]; None takes the design's ``implementation.sample_rate_hz``.
    out : path
        The controller file to write.
    require_latency_margin_s : float, optional
        The ``requirements.latency_margin_s`` [s] certify enforces (None: the design's
        ``requirements`` section, else one sample period; 0: none).
    time_budget_s : float, optional
        [s] (default 600): work beyond it is refused before it starts when its lower bound
        exceeds it, and stopped when it runs over (:mod:`exotune.numerics.timebudget`).
    allow_uncertified : bool
        Write a file that fails its own requirements anyway (recorded in ``provenance``).

    Returns
    -------
    ExportedController
        The written file (``to_dict()`` is the document).

    Raises
    ------
    RunFailed
        The controller fails certify's checks (exit 1; nothing written) and ``allow_uncertified`` is false.

    References
    ----------
    docs/controller-file.md; docs/method.md#one-model-of-record.
    """
    import hashlib

    from ..config import read_yaml
    from ..errors import RunFailed
    from ..numerics.timebudget import check_budget_option, time_budget

    budget = check_budget_option(time_budget_s)
    raw = read_yaml(design_file)
    if sample_rate_hz is None:
        impl = raw.get("implementation") if isinstance(raw, dict) else None
        sample_rate_hz = impl.get("sample_rate_hz") if isinstance(impl, dict) else None
        if sample_rate_hz is None:
            raise ConfigError("sample_rate_hz", "the design sets no implementation.sample_rate_hz: give the runtime's "
                                                  "rate (e.g. `sample_rate_hz`=1000)")
    cfg = design_at_rate(raw, sample_rate_hz, str(design_file))
    fs = float(cfg.implementation.sample_rate_hz)
    digest = hashlib.sha256(Path(design_file).read_bytes()).hexdigest()
    with time_budget(budget, f"exporting at {fs:g} Hz", "lower `sample_rate_hz`"):
        doc = build_export(cfg, fs, source=str(design_file), input_hash=digest,
                           require_latency_margin_s=require_latency_margin_s)
    problems = doc["provenance"].get("uncertified") or []
    if problems and not allow_uncertified:
        raise RunFailed(f"not written: {out} would not certify — {'; '.join(problems[:3])}"
                        + (f"; and {len(problems) - 3} more" if len(problems) > 3 else "")
                        + " (`allow_uncertified` writes it anyway)")
    if problems:
        doc["provenance"]["allow_uncertified"] = True
    write_controller(doc, out)
    return ExportedController.from_document(doc, out)


def check_sample_rate(value, field: str = "sample_rate_hz") -> float:
    """A sample rate [Hz] from the command line: a positive, finite number (else ConfigError).

    Parameters
    ----------
    value : Any
        The option's value.
    field : str, optional
        The option named by the error.

    Returns
    -------
    float
        The sample rate [Hz].

    Raises
    ------
    exotune.errors.ConfigError
        When the value is not a positive, finite number.
    """
    from ..options import number_value

    return number_value(field, value, positive=True, noun="a number of Hz")


def design_at_rate(raw, sample_rate_hz, source: str | None = None):
    """Validate a design mapping with ``implementation.sample_rate_hz`` set to ``sample_rate_hz``
    (so every filter cutoff is checked against that Nyquist frequency).

    Parameters
    ----------
    raw : dict
        The design's mapping (e.g. ``DesignConfig.raw``).
    sample_rate_hz : Any
        The sample rate [Hz].
    source : str or None, optional
        The design file's path.

    Returns
    -------
    DesignConfig
        The validated design at that rate.

    Raises
    ------
    exotune.errors.ConfigError
        When the rate is not a positive number or the design does not validate at it (a cutoff at or
        above the Nyquist frequency).
    """
    from ..config import design_from_mapping

    fs = check_sample_rate(sample_rate_hz)
    if isinstance(raw, dict) and (raw.get("implementation") is None or isinstance(raw.get("implementation"), dict)):
        raw = {**raw, "implementation": {**(raw.get("implementation") or {}), "sample_rate_hz": fs}}
    return design_from_mapping(raw, source=source)
