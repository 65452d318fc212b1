"""The single-design analysis: every metric of one design, as a JSON-ready report.

References
----------
docs/cli.md#exotune-analyze; docs/method.md#analyses-and-metrics.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .batch import analyze_batch
from .batch_result import BatchAnalysis, FamilyBatch
from .intervals import MAX_FAMILY_PIECES
from .results import (Amplification, BoxEdge, DesignAnalysis, DobMargins, EnvironmentResult, FamilyResult, PassivityResult,
                      ScheduleEntry)
from ..units import METRIC_UNITS  # re-exported

__all__ = ["analyze_design", "analyze_with_margins", "design_plant_margin", "kyp_certificates", "METRIC_UNITS", "VERIFY_POINTS"]


VERIFY_POINTS = 64


def analyze_design(cfg, sampled_check: bool = True) -> DesignAnalysis:
    """All docs/method.md#analyses-and-metrics metrics for one design, as a typed
    :class:`~exotune.analysis.results.DesignAnalysis` (its ``to_dict()`` is ``exotune analyze
    --json`` without the margins; :func:`exotune.analysis.analyze_with_margins` adds them).
    Overflow in an extreme design is reported through the inconclusive flags and warnings of
    the result, not as numpy's floating-point warnings. ``sampled_check=False`` leaves out the
    sampled-data grid check at the design's rate (``exotune analyze`` replaces it with the exact
    verdicts of record, :func:`exotune.controllerfile.verdicts.analyze_of_record`).

    Parameters
    ----------
    cfg : DesignConfig
        The validated design.
    sampled_check : bool
        Whether to run the sampled-data grid check at the design's sample rate.

    Returns
    -------
    DesignAnalysis
        Verdicts, stable intervals, passivity, DOB margins, amplification and warnings.

    References
    ----------
    docs/method.md#analyses-and-metrics.
    """
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        return _analyze_design(cfg, sampled_check)


def _human_result(h: FamilyBatch, fam) -> FamilyResult:
    """The typed result of one human family ``fam`` from its record ``h`` of the one-design batch."""
    fixed = {k: v for k, v in {**fam.fixed(), **({"eta": fam.eta} if fam.kind == "complex_stiffness" else {})}.items()
             if k != fam.param}
    box = edges = None
    ivs = tuple((a, b) for a, b in h.stable_intervals[0])
    if fam.box:
        box = {fam.param: (fam.lo, fam.hi), **{q: (lo, hi) for q, lo, hi in fam.box}}
        fixed = {k: v for k, v in fam.fixed().items() if k not in box}
        ivs = None  # a box's stable set is not an interval
        edges = tuple(BoxEdge(e.param, (e.lo, e.hi), {q: getattr(e, q) for q in box if q != e.param},
                              tuple((a, b) for a, b in e_ivs))
                      for e, e_ivs in h.edges[0])
    return FamilyResult(
        kind=fam.kind, parameter=fam.param, unit=fam.unit, range=(fam.lo, fam.hi), fixed=fixed, stable_intervals=ivs,
        robust=bool(h.robust[0]), conclusive=bool(h.conclusive[0]),
        critical=tuple((p, f) for p, f in h.critical[0]), verified_points=VERIFY_POINTS,
        verification_mismatches=tuple(h.verification_mismatches[0]), box=box, edges=edges)


def _environment_results(cfg, res: BatchAnalysis) -> tuple[EnvironmentResult, ...]:
    """The typed results of the environment models."""
    env = []
    for e, r in zip(cfg.environment, res.environment):
        if e.kind in ("locked", "free"):
            env.append(EnvironmentResult(e.kind, bool(r.stable[0])))
        else:
            env.append(EnvironmentResult(e.kind, bool(r.robust[0]), e.param, (e.lo, e.hi),
                                         tuple((a, b) for a, b in r.stable_intervals[0])))
    return tuple(env)


def _sampled_check(cfg, res: BatchAnalysis, humans, env, warnings: list):
    """The sampled-data check at the file's sample rate (None without one); its disagreements with
    the continuous verdicts are appended to ``warnings``."""
    sampled = None
    if cfg.implementation.sample_rate_hz:
        from ..sampled import check_design

        sampled = check_design(cfg, [h.stable_intervals for h in humans], [e.stable_intervals for e in env])
        fs = sampled.sample_rate_hz
        for verdict, continuous, where in ((sampled.free_stable, res.free.stable, "with the cuff free"),
                                           (sampled.locked_stable, res.locked.stable, "with the output locked")):
            if verdict is None:
                warnings.append(f"at {fs:g} Hz the sampled-data verdict {where} is inconclusive (spectral radius within "
                                "rounding of 1)")
            elif verdict != bool(continuous[0]):
                warnings.append(f"at {fs:g} Hz the sampled-data loop is {'stable' if verdict else 'UNSTABLE'} "
                                f"{where}, unlike the continuous analysis")
        for side, fams in (("human", sampled.humans), ("environment", sampled.environment)):
            for h in fams:
                for b in h.boundaries:
                    if b.unsafe:
                        lo_, hi_ = b.unsafe
                        warnings.append(f"at {fs:g} Hz the sampled-data loop is UNSTABLE for {side} {h.kind} "
                                        f"{h.parameter} in [{lo_:.5g}, {hi_:.5g}], where the continuous analysis says stable")
                if h.disagreements:
                    vals = ", ".join(f"{d.value:.4g}" for d in h.disagreements[:6])
                    warnings.append(f"at {fs:g} Hz the sampled-data loop disagrees with the continuous {side} {h.kind} "
                                    f"intervals at {h.parameter} = {vals}" + (" …" if len(h.disagreements) > 6 else ""))
    return sampled


def _analyze_design(cfg, sampled_check: bool = True) -> DesignAnalysis:
    from ..model.shaping import double_compliance_shaping

    from ..config.validate import check_analysis_filters

    check_analysis_filters(cfg.implementation)
    res = analyze_batch(cfg, verify=VERIFY_POINTS)
    ds = double_compliance_shaping(cfg.plant, cfg.design)
    humans = tuple(_human_result(h, fam) for h, fam in zip(res.humans, cfg.humans))
    env = _environment_results(cfg, res)
    dob = None
    if cfg.implementation.dob is not None:
        d = res.dob
        dob = DobMargins(float(d.gain_margin_db[0]), float(d.phase_margin_deg[0]), float(d.delay_margin_s[0]),
                         float(d.crossover_hz[0]), bool(d.stable[0]))
    warnings = list(ds.warnings)
    sampled = _sampled_check(cfg, res, humans, env, warnings) if sampled_check else None
    schedule = _schedule_check(cfg) if cfg.raw.get("transmission") else None
    for e in schedule or []:
        if not e.robust:
            warnings.append(f"at joint angle {e.joint_angle_rad:g} rad (transmission ratio {e.ratio:g}) the "
                            f"rescheduled design is not robust: {', '.join(e.not_robust)}")
    kyp = kyp_certificates(cfg)  # a non-passive nominal C7 is the B2_hat < 0 warning of shaping
    if not bool(res.passivity.conclusive[0]):
        warnings.append("the passivity analysis is inconclusive (a zero of Δ00 or Δ10 on the axis, or the "
                        "adaptive frequency search spent its per-task budget: extreme parameters)")
    if not bool(res.all_conclusive()[0]):
        warnings.append("some verdicts are inconclusive (a root on the imaginary axis within float resolution, an "
                        "adaptive search that spent its per-task budget, or a human range with more than "
                        f"{MAX_FAMILY_PIECES} critical values: extreme parameters): treated as NOT stable")
    return DesignAnalysis(
        structure=cfg.implementation.structure,
        delay_s=float(np.asarray(cfg.implementation.delay_s)),
        gains=res.gain_values(0),
        free_stable=bool(res.free.stable[0]),
        free_rigid_body_roots=int(res.free.rigid_body_roots[0]),
        locked_stable=bool(res.locked.stable[0]),
        humans=humans,
        environment=env,
        passivity=PassivityResult(float(res.passivity.max_phase_excess_deg[0]),
                                  tuple((a, b) for a, b in res.passivity.nonpassive_band_hz[0]), kyp),
        dob=dob,
        amplification=Amplification(float(res.amplification.dc[0]), float(res.amplification.bandwidth_hz[0]),
                                    bool(res.amplification.minimum_phase[0]),
                                    bool(res.amplification.conclusive[0])),
        J_m_hat_over_J_j=float(ds.J_m_hat / cfg.plant.J_j),
        warnings=tuple(warnings),
        sampled_data=sampled,
        gain_schedule=None if schedule is None else tuple(schedule),
        config=cfg,
    )


def analyze_with_margins(cfg, sampled_check: bool = True, of_record=None):
    """The single-design analysis (``exotune analyze``) with its margins: the latency margin of
    :func:`exotune.analysis.latency_margin.latency_margin` and the plant-uncertainty margin of
    :func:`exotune.analysis.plant_margin.plant_uncertainty_margin` (weights from the design's
    ``uncertainty`` section, 1 each when absent); ``to_dict()`` puts them first, as mappings with
    units.

    The plant-uncertainty margin is independent of the rest and about half the work: it runs in a
    child process beside the rest when the machine has two cores
    (:func:`exotune.numerics.beside.beside`; the same result as a serial run).

    Parameters
    ----------
    cfg : DesignConfig
        One design.
    sampled_check : bool, optional
        Passed to :func:`analyze_design` (False: no sampled-data grid check).
    of_record : callable, optional
        ``of_record(cfg, latency_margin)`` → the sampled-data verdicts of record
        (:func:`exotune.controllerfile.verdicts.design_verdicts`), computed while the
        plant-uncertainty margin runs and stored as ``sampled``.

    Returns
    -------
    DesignAnalysis
        :func:`exotune.analysis.analyze_design` with ``margins`` = (LatencyMargin, PlantMargin);
        its ``to_dict()`` is ``{"margins": {"latency": …, "plant_uncertainty": …}, …}`` followed
        by every key of the analysis.

    References
    ----------
    docs/method.md#latency-margin; docs/method.md#plant-uncertainty-margin; paper Fig. 5.
    """
    from ..numerics.beside import beside
    from .latency_margin import latency_margin, schedule_latency_margin
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        cols = analyze_batch(cfg)  # the nominal verdicts, shared by both margins
        # a design that is not robust at the nominal plant has k* = 0: its robust loops' own bounds
        # (seconds of work) are left to plant_uncertainty_margin(cfg) — analyze stays quick
        with beside("plant_uncertainty_margin", design_plant_margin, cfg, getattr(cfg, "uncertainty", None),
                    nominal=cols, loop_detail=False) as job:
            rec = analyze_design(cfg, sampled_check)
            lm, per_entry = schedule_latency_margin(cfg, latency_margin(cfg, nominal=cols))
            if per_entry and rec.gain_schedule is not None:
                rec = dataclasses.replace(rec, gain_schedule=tuple(
                    dataclasses.replace(e, latency_margin_s=m.extra_delay_s) for e, m in zip(rec.gain_schedule, per_entry)))
            if of_record is not None:
                rec = dataclasses.replace(rec, sampled=of_record(cfg, lm))
            pm = job.result()
    return dataclasses.replace(rec, margins=(lm, pm))


def design_plant_margin(cfg, weights=None, nominal=None, **kw):
    """The plant-uncertainty margin ``exotune analyze`` reports: the plant section's
    (:func:`~exotune.analysis.plant_margin.plant_uncertainty_margin`) and, with a gain schedule,
    the smallest over the entries (:func:`~exotune.analysis.plant_margin.schedule_plant_margin`).

    Parameters
    ----------
    cfg : DesignConfig
        One design.
    weights : None, sequence of 5 floats or mapping
        The relative plant uncertainty.
    nominal : BatchAnalysis, optional
        The design's own batch analysis, if computed.
    **kw
        Passed to both (``budget``, ``loop_detail``, …).

    Returns
    -------
    PlantMargin
        The margin.

    References
    ----------
    docs/method.md#plant-uncertainty-margin; paper §IV (gain scheduling).
    """
    from .plant_margin import plant_uncertainty_margin, schedule_plant_margin

    return schedule_plant_margin(cfg, plant_uncertainty_margin(cfg, weights, nominal=nominal, **kw), weights, **kw)


def kyp_certificates(cfg) -> dict:
    """KYP passivity certificates of the rational models of C7 (:mod:`exotune.analysis.kyp`, an SDP):
    name → :class:`~exotune.analysis.KypCertificate`; a missing or failing SDP solver is reported as
    ``{"error": text}``, not raised.

    Parameters
    ----------
    cfg : DesignConfig
        The validated design.

    Returns
    -------
    dict
        Model name → :class:`~exotune.analysis.KypCertificate`, or ``{"error": text}``.

    References
    ----------
    Paper §IV-A (passivity of the operator compliance C7); docs/method.md#passivity-of-the-operator-compliance.
    """
    try:
        from .kyp import operator_certificates

        return operator_certificates(cfg)
    except (ImportError, ValueError, ArithmeticError, np.linalg.LinAlgError) as e:
        return {"error": f"KYP certificates not computed: {type(e).__name__}: {e}"}


def _schedule_check(cfg) -> list[ScheduleEntry]:
    """Continuous analysis of the design rescheduled at every joint angle of its ``transmission``
    section (paper §IV gain scheduling: J_m, B_m, K_s × ratio², gains recomputed; one batch over
    the angles, :func:`~exotune.analysis.gain_schedule.analyze_schedule`)."""
    from .gain_schedule import analyze_schedule

    sched = analyze_schedule(cfg)
    res = sched.analysis
    # the names of the report: a family by its loop name, a single loop by its column name
    fams = [*zip(res.human_names(), res.humans),
            *((k, e) for k, e in zip(res.environment_names(), res.environment) if e.stable is None)]
    singles = [("free_stable", res.free.stable), ("locked_stable", res.locked.stable),
               *((f"{k}_stable", e.stable) for k, e in zip(res.environment_names(), res.environment)
                 if e.stable is not None)]
    out = []
    for i, (angle, ratio) in enumerate(zip(sched.joint_angle_rad, sched.ratio)):
        bad = [k for k, f in fams if not bool(f.robust[i])]
        bad += [k for k, stable in singles if not bool(stable[i])]
        out.append(ScheduleEntry(angle, ratio, not bad, tuple(bad), res.gain_values(i),
                                 {k: tuple((a, b) for a, b in f.stable_intervals[i]) for k, f in fams}))
    return out
