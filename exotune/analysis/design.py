"""The single-design analysis: every metric of one design, as a JSON-ready report.

References
----------
docs/cli.md#exotune-analyze; docs/method.md#analyses-and-metrics.
"""

from __future__ import annotations

import numpy as np

from .batch import GAIN_NAMES, analyze_batch
from .intervals import MAX_FAMILY_PIECES
from .results import (Amplification, BoxEdge, DesignAnalysis, DobMargins, EnvironmentResult, FamilyResult, PassivityResult,
                      ScheduleEntry)
from ..units import METRIC_UNITS  # re-exported

__all__ = ["analyze_design", "kyp_certificates", "METRIC_UNITS", "VERIFY_POINTS"]


VERIFY_POINTS = 64


def analyze_design(cfg, sampled_check: bool = True) -> DesignAnalysis:
    """All docs/method.md#analyses-and-metrics metrics for one design, as a typed
    :class:`~exotune.analysis.results.DesignAnalysis` (its ``to_dict()`` is ``exotune analyze
    --json`` without the margins; :func:`exotune.analysis.analyze_with_margins` adds them).
    Overflow in an extreme design is reported through the inconclusive flags and warnings of
    the result, not as numpy's floating-point warnings. ``sampled_check=False`` leaves out the
    sampled-data grid check at the design's rate (``exotune analyze`` replaces it with the exact
    verdicts of record, :func:`exotune.controllerfile.verdicts.analyze_of_record`)."""
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        return _analyze_design(cfg, sampled_check)


def _human_result(cols, i: int, fam) -> FamilyResult:
    """The typed result of human family ``i`` (its columns of the one-design batch)."""
    key = f"human{i}_{fam.kind}"
    fixed = {k: v for k, v in {**fam.fixed(), **({"eta": fam.eta} if fam.kind == "complex_stiffness" else {})}.items()
             if k != fam.param}
    box = edges = None
    ivs = tuple((a, b) for a, b in cols[f"{key}_stable_intervals"][0])
    if fam.box:
        box = {fam.param: (fam.lo, fam.hi), **{q: (lo, hi) for q, lo, hi in fam.box}}
        fixed = {k: v for k, v in fam.fixed().items() if k not in box}
        ivs = None  # a box's stable set is not an interval
        edges = tuple(BoxEdge(e.param, (e.lo, e.hi), {q: getattr(e, q) for q in box if q != e.param},
                              tuple((a, b) for a, b in e_ivs))
                      for e, e_ivs in cols[f"{key}_edges"][0])
    return FamilyResult(
        kind=fam.kind, parameter=fam.param, unit=fam.unit, range=(fam.lo, fam.hi), fixed=fixed, stable_intervals=ivs,
        robust=bool(cols[f"{key}_robust"][0]), conclusive=bool(cols[f"{key}_conclusive"][0]),
        critical=tuple((p, f) for p, f in cols[f"{key}_critical"][0]), verified_points=VERIFY_POINTS,
        verification_mismatches=tuple(cols[f"{key}_verification_mismatches"][0]), box=box, edges=edges)


def _environment_results(cfg, cols) -> tuple[EnvironmentResult, ...]:
    """The typed results of the environment models."""
    env = []
    for i, e in enumerate(cfg.environment):
        key = f"env{i}_{e.kind}"
        if e.kind in ("locked", "free"):
            env.append(EnvironmentResult(e.kind, bool(cols[f"{key}_stable"][0])))
        else:
            env.append(EnvironmentResult(e.kind, bool(cols[f"{key}_robust"][0]), e.param, (e.lo, e.hi),
                                         tuple((a, b) for a, b in cols[f"{key}_stable_intervals"][0])))
    return tuple(env)


def _sampled_check(cfg, cols, humans, env, warnings: list):
    """The sampled-data check at the file's sample rate (None without one); its disagreements with
    the continuous verdicts are appended to ``warnings``."""
    sampled = None
    if cfg.implementation.sample_rate_hz:
        from ..sampled import check_design

        sampled = check_design(cfg, [h.stable_intervals for h in humans], [e.stable_intervals for e in env])
        fs = sampled.sample_rate_hz
        for name, verdict in (("free", sampled.free_stable), ("locked", sampled.locked_stable)):
            where = 'with the cuff free' if name == 'free' else 'with the output locked'
            if verdict is None:
                warnings.append(f"at {fs:g} Hz the sampled-data verdict {where} is inconclusive (spectral radius within "
                                "rounding of 1)")
            elif verdict != bool(cols[f"{name}_stable"][0]):
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

    from ..config import check_analysis_filters

    check_analysis_filters(cfg.implementation)
    cols = analyze_batch(cfg, verify=VERIFY_POINTS)
    ds = double_compliance_shaping(cfg.plant, cfg.design)
    g = lambda k: float(np.asarray(cols[k])[0])  # noqa: E731
    humans = tuple(_human_result(cols, i, fam) for i, fam in enumerate(cfg.humans))
    env = _environment_results(cfg, cols)
    dob = None
    if cfg.implementation.dob is not None:
        dob = DobMargins(g("dob_gain_margin_db"), g("dob_phase_margin_deg"), g("dob_delay_margin_s"),
                         g("dob_crossover_hz"), bool(cols["dob_stable"][0]))
    warnings = list(ds.warnings)
    sampled = _sampled_check(cfg, cols, humans, env, warnings) if sampled_check else None
    schedule = _schedule_check(cfg) if cfg.raw.get("transmission") else None
    for e in schedule or []:
        if not e.robust:
            warnings.append(f"at joint angle {e.joint_angle_rad:g} rad (transmission ratio {e.ratio:g}) the "
                            f"rescheduled design is not robust: {', '.join(e.not_robust)}")
    kyp = kyp_certificates(cfg)  # a non-passive nominal C7 is the B2_hat < 0 warning of shaping
    if not bool(cols["passivity_conclusive"][0]):
        warnings.append("the passivity analysis is inconclusive (a zero of Δ00 or Δ10 on the axis, or the "
                        "adaptive frequency search spent its per-task budget: extreme parameters)")
    if not all(bool(cols[k][0]) for k in cols if k.endswith("_conclusive")):
        warnings.append("some verdicts are inconclusive (a root on the imaginary axis within float resolution, an "
                        "adaptive search that spent its per-task budget, or a human range with more than "
                        f"{MAX_FAMILY_PIECES} critical values: extreme parameters): treated as NOT stable")
    return DesignAnalysis(
        structure=cfg.implementation.structure,
        delay_s=float(np.asarray(cfg.implementation.delay_s)),
        gains={k: g(k) for k in GAIN_NAMES},
        free_stable=bool(cols["free_stable"][0]),
        free_rigid_body_roots=int(cols["free_rigid_body_roots"][0]),
        locked_stable=bool(cols["locked_stable"][0]),
        humans=humans,
        environment=env,
        passivity=PassivityResult(g("passivity_max_phase_excess_deg"),
                                  tuple((a, b) for a, b in cols["passivity_nonpassive_band_hz"][0]), kyp),
        dob=dob,
        amplification=Amplification(g("amplification_dc"), g("amplification_bandwidth_hz"),
                                    bool(cols["amplification_minimum_phase"][0])),
        J_m_hat_over_J_j=float(ds.J_m_hat / cfg.plant.J_j),
        warnings=tuple(warnings),
        sampled_data=sampled,
        gain_schedule=None if schedule is None else tuple(schedule),
        config=cfg,
    )


def kyp_certificates(cfg) -> dict:
    """KYP passivity certificates of the rational models of C7 (:mod:`exotune.analysis.kyp`, cvxpy):
    name → :class:`~exotune.analysis.KypCertificate`; a missing or failing SDP solver is reported as
    ``{"error": text}``, not raised."""
    try:
        from .kyp import operator_certificates

        return operator_certificates(cfg)
    except (ImportError, ValueError, ArithmeticError, np.linalg.LinAlgError) as e:
        return {"error": f"KYP certificates not computed: {type(e).__name__}: {e}"}


def _schedule_check(cfg) -> list[ScheduleEntry]:
    """Continuous analysis of the design rescheduled at every joint angle of its ``transmission``
    section (paper §IV gain scheduling: J_m, B_m, K_s × ratio², gains recomputed; one batch over the angles)."""
    tr = cfg.raw["transmission"]
    r2 = np.asarray(tr["ratio"], float) ** 2
    g = lambda x: float(np.ravel(x)[0])  # noqa: E731
    from ..config import batch_config

    cols = analyze_batch(batch_config(cfg, {"plant.motor_inertia": g(cfg.plant.J_m) * r2,
                                            "plant.motor_damping": g(cfg.plant.B_m) * r2,
                                            "plant.sea_stiffness": g(cfg.plant.K_s) * r2}))
    fams = [k[: -len("_robust")] for k in cols if k.startswith(("human", "env")) and k.endswith("_robust")]
    out = []
    for i, (angle, ratio) in enumerate(zip(tr["joint_angle_rad"], tr["ratio"])):
        bad = [k for k in fams if not bool(cols[f"{k}_robust"][i])]
        bad += [k for k in ("free_stable", "locked_stable") if not bool(cols[k][i])]
        bad += [k for k in cols if k.startswith("env") and k.endswith("_stable") and not bool(cols[k][i])]
        out.append(ScheduleEntry(float(angle), float(ratio), not bad, tuple(bad),
                                 {k: float(cols[k][i]) for k in GAIN_NAMES},
                                 {k: tuple((a, b) for a, b in cols[f"{k}_stable_intervals"][i]) for k in fams
                                  if f"{k}_stable_intervals" in cols}))
    return out
