"""``exotune certify CONTROLLER.yaml`` (docs/controller-file.md): the sampled-data analysis of an exported file.

Everything comes from the file itself — its plant, its gains and sos filters (rebuilt as one state
space by :func:`exotune.export.discrete_from_file`), its sample rate and delay — never from the
design it was exported from, so an edited or corrupted file is analysed as it is. The plant
(+ human, + environment) is discretized exactly with a zero-order hold and the (possibly
fractional) delay (:mod:`exotune.sampled`); a verdict at one parameter value is exact (eigenvalues
of the sampled-data loop, |λ| < 1, the rigid-body z = 1 of an ungrounded structure excluded).

Intervals of stable human parameters: eigenvalue continuation with step control
(:mod:`exotune.controllerfile.continuation`).

The file is **certified** when the free and the locked loops are stable, every rational human
family is stable over its whole range, the golden vectors are reproduced by the reference runtime
and the file's own predicted sampled intervals match the recomputed ones, and its sampled-data
latency margin (:mod:`exotune.controllerfile.latency`) is at least the file's
``requirements.latency_margin_s`` when it has one.
"""

from __future__ import annotations

import math

import numpy as np

from ..numerics.threads import one_blas_thread
from ..sampled import loop_eigenvalues, loop_spectra, loop_verdict
from ..units import PARAM_UNITS, fmt_distinct
from .build import close
from .cellbound import loop_cell
from .continuation import MAX_DEPTH, POINTS, covers_range, stable_intervals
from .fileio import position_feedback
from .hysteretic import hysteretic_problems, hysteretic_problems_many
from .latency import requirement_problems, sampled_latency_margin, schedule_minimum
from .model import ControllerFile, as_controller_file
from .results import Certificate

__all__ = ["POINTS", "sampled_analysis", "sampled_decision", "sampled_problems", "schedule_section", "stable_intervals", "position_feedback",
           "decision_and_nominal", "runs_the_file_itself", "certify", "design_mismatches", "check_built_from_design", "hand_tuned", "golden_problems",
           "prediction_mismatches", "float32_realization_check"]

def _human_dict(fam, v: float) -> dict:
    h = {k: val for k, val in fam.fixed().items() if k in ("inertia", "damping", "stiffness")}
    h[fam.param] = v
    return h


def _in_certify(parse, i, item):
    """A family of the file's ``certify`` section, errors naming ``certify.…``."""
    from ..errors import ConfigError

    try:
        return parse(i, item)
    except ConfigError as e:
        raise ConfigError(f"certify.{e.field}", e.reason) from None


@one_blas_thread
def sampled_analysis(doc: ControllerFile | dict, points: int = POINTS, proof: bool = True) -> dict:
    """Free/locked verdicts and the stable intervals of every rational human family and every
    environment spring/mass range of the file's ``certify`` section, for the file's controller.
    Every accepted cell is proven stable (:func:`~exotune.controllerfile.cellbound.loop_cell`);
    ``proof=False`` accepts cells on step control alone (the latency margin's confirmation at a
    nearly critical delay, where a proof would need very small cells).

    Parameters
    ----------
    doc : ControllerFile or dict
        The validated controller file.
    points : int, optional
        Grid members per family range.
    proof : bool, optional
        Prove every accepted cell stable (False: step control alone).

    Returns
    -------
    dict
        ``model``, ``free_stable`` and ``locked_stable`` (None: inconclusive), their spectral radii
        and rounding bounds, and ``humans`` and ``environment``: per family its kind, parameter,
        unit, range, ``stable_intervals``, ``robust`` and the search's details (or ``skipped`` /
        ``not_certifiable``).

    Raises
    ------
    exotune.errors.ConfigError
        When an entry of the ``certify`` section does not validate, or the loop matrix overflows.
    """
    from ..config import parse_env, parse_human
    from .fileio import discrete_from_file, plant_from_file

    cf = as_controller_file(doc)
    plant = plant_from_file(cf)
    ctrl = discrete_from_file(cf)
    grounded = position_feedback(cf.controller)
    spec = lambda human=None, env="free": loop_eigenvalues(plant, ctrl, grounded, human, env)  # noqa: E731
    specs = lambda humans, env="free": loop_spectra(plant, ctrl, grounded, humans, env)  # noqa: E731
    verdict = lambda human=None, env="free": loop_verdict(plant, ctrl, grounded, human, env)[0]  # noqa: E731
    cell = lambda member: ((lambda a, b: loop_cell(plant, ctrl, grounded, member, a, b, math.sqrt(a * b)))  # noqa: E731
                           if proof else None)
    free, rho, err = loop_verdict(plant, ctrl, grounded)
    locked, rho_l, err_l = loop_verdict(plant, ctrl, grounded, env="locked")
    out = {
        "model": ("plant discretized exactly (zero-order hold, delay of "
                  f"{cf.delay_s * cf.sample_rate_hz:.6g} samples), the file's controller"),
        "free_stable": free,  # None: inconclusive (the spectral radius is within rounding of 1)
        "free_spectral_radius": rho,
        "free_spectral_radius_rounding": err,
        "locked_stable": locked,
        "locked_spectral_radius": rho_l,
        "locked_spectral_radius_rounding": err_l,
        "humans": [],
        "environment": [],
    }
    for i, item in enumerate(cf.certify.humans):
        fam, _ = _in_certify(parse_human, i, item)
        entry = {"kind": fam.kind, "parameter": fam.param, "unit": fam.unit, "range": [fam.lo, fam.hi]}
        if fam.kind == "complex_stiffness":
            entry["skipped"] = "hysteretic damping is not rational: it has no finite-dimensional sampled-data model"
            out["humans"].append(entry)
            continue
        if fam.box:
            # no edge theorem holds for the sampled-data loop (its matrix depends on the human
            # through a matrix exponential): a box cannot be certified from its edges
            entry["not_certifiable"] = ("a box of several uncertain msd parameters: the sampled-data check certifies "
                                        "one-parameter families only; split it (fix all but one parameter per family)")
            entry["box"] = {q: [a, b] for q, a, b in fam.box}
            out["humans"].append(entry)
            continue
        ivs, info = stable_intervals(lambda v, fam=fam: spec(human=_human_dict(fam, v)), fam.lo, fam.hi, points,
                                     lambda v, fam=fam: verdict(human=_human_dict(fam, v)),
                                     cell(lambda v, fam=fam: (_human_dict(fam, v), "free")),
                                     lambda vs, fam=fam: specs([_human_dict(fam, v) for v in vs]))
        entry.update(info, stable_intervals=ivs, robust=(ivs == [[fam.lo, fam.hi]] and not info["unresolved"]))
        out["humans"].append(entry)
    for i, item in enumerate(cf.certify.environment):
        env, _ = _in_certify(parse_env, i, item)
        if env.kind not in ("spring", "mass"):
            continue
        ivs, info = stable_intervals(lambda v, e=env: spec(env={e.param: v, "damping": e.damping}), env.lo, env.hi, points,
                                     lambda v, e=env: verdict(env={e.param: v, "damping": e.damping}),
                                     cell(lambda v, e=env: (None, {e.param: v, "damping": e.damping})),
                                     lambda vs, e=env: specs([None] * len(vs), [{e.param: v, "damping": e.damping} for v in vs]))
        out["environment"].append({"kind": env.kind, "parameter": env.param,
                                   "unit": PARAM_UNITS[env.param],
                                   "range": [env.lo, env.hi], **info, "stable_intervals": ivs,
                                   "robust": ivs == [[env.lo, env.hi]] and not info["unresolved"],
                                   "note": "cuff free, environment at the joint"})
    return out


def _golden_ok(out: np.ndarray, ref: np.ndarray) -> bool:
    """True when runtime outputs reproduce golden outputs (1e-9 of their scale)."""
    scale = float(np.max(np.abs(ref))) if ref.size else 1.0
    return bool(np.max(np.abs(out - ref)) <= 1e-9 * max(scale, 1.0)) if ref.size else True


def _same_intervals(a, b: list, rtol: float = 1e-6) -> bool:
    """The file's predicted intervals ``a`` (untrusted: anything malformed is a mismatch, never an
    error) against the recomputed ``b``."""
    num = lambda x: isinstance(x, (int, float)) and not isinstance(x, bool)  # noqa: E731
    if not isinstance(a, list) or len(a) != len(b):
        return False
    if not all(isinstance(p, list) and len(p) == 2 and all(num(x) for x in p) for p in a):
        return False
    return all(close(x, y, rtol) for p, q in zip(a, b) for x, y in zip(p, q))


def _entries(x) -> list:
    """A predicted family list of the file (untrusted): its dict entries, [None] for the others."""
    return [e if isinstance(e, dict) else None for e in x] if isinstance(x, list) else []


def _unresolved(sa: dict, where: str) -> list[str]:
    """Problems for the cells of stable values whose eigenvalue paths were not resolved."""
    out = []
    for h in sa["humans"] + sa["environment"]:
        cells = h.get("unresolved") or []
        if cells:
            a, b = cells[0]
            if h.get("proofs_spent"):
                why = ("their members are stable by their eigenvalues, but the proof that every member of a cell is "
                       "stable failed until its budget was spent: the loop is not proven stable there, which is not "
                       "a finding of instability (stiff dynamics, e.g. a fast damped human pole against the sample "
                       "period, make the cell bound loose; docs/method.md#guarantees)")
            elif h.get("budget_spent"):
                why = (f"the refinement budget of {h['refinement_budget']} values for a {h['loop_states']}-state loop "
                       "is spent: eigenvalues that move faster than the step control can follow — at a high sample "
                       "rate every eigenvalue is near the unit circle (certify at a lower rate); repeated poles (e.g. "
                       "filter sections that repeat or cancel) move as a root of the perturbation")
            else:
                why = "at the finest step: an eigenvalue within a hair of the unit circle and moving fast, a marginal design"
            count = h.get("unresolved_cells", len(cells))
            count = count if isinstance(count, int) and count >= len(cells) else len(cells)
            out.append(f"{where}{h['kind']} {h['parameter']}: eigenvalue paths not resolved in {count} cell(s), "
                       f"first [{a:.6g}, {b:.6g}] {h['unit']} ({why})")
    return out


_SIX = ("K1", "B1", "K2", "B2", "K2_hat", "B2_hat")
_GAIN_RTOL = 1e-9  # the file's gains are the recomputed ones to the last bits (same formulas)
_DC_RTOL = 1e-6  # a Tustin filter keeps its DC gain up to rounding


def _dc_gain(sos) -> float:
    num, den = 1.0, 1.0
    for b0, b1, b2, _a0, a1, a2 in sos:
        num *= b0 + b1 + b2
        den *= 1.0 + a1 + a2
    return num / den if den != 0.0 else math.inf


def _one_controller(design: dict, view: ControllerFile, where: str) -> list[str]:
    """Mismatches of one controller (its plant, six gains and filters) against the design."""
    from ..model.shaping import DesignParams, double_compliance_shaping

    plant = view.plant.to_plant()
    ds = double_compliance_shaping(plant, DesignParams(**{k: np.asarray(v) for k, v in design.items()}))
    want = {k: float(np.ravel(getattr(ds.gains, k))[0]) for k in _SIX}
    have = {k: getattr(view.gains, k) for k in _SIX}
    out = [f"{where}gains.{k}: the file has {have[k]!r}, its design section and plant give {want[k]!r}"
           for k in _SIX if not close(float(have[k]), want[k], _GAIN_RTOL)]
    dc = {"cuff_path": plant.J_m / float(np.ravel(ds.J_m_hat)[0]) * want["K2_hat"],
          "motor_position": -want["K1"], "spring_torque": want["K2"]}
    for i, f in enumerate(view.controller.filters):
        if f.name in dc and not close(_dc_gain(f.sos), dc[f.name], _DC_RTOL):
            out.append(f"{where}controller.filters[{i}] ({f.name}): DC gain {_dc_gain(f.sos):.6g}, its design "
                       f"section and plant give {dc[f.name]:.6g}")
    return out


def design_mismatches(doc: ControllerFile | dict) -> list[str]:
    """Where the controller of a file differs from the one its design section and plant build.

    The six gains of double compliance shaping are recomputed from ``design`` and ``plant`` (and
    from each gain-schedule entry's plant) and compared with the file's six-gain summaries (which
    the file checks tie to the static gains); the DC gains of the filters that carry them (the cuff
    path: J_m/Ĵ_m · K̂2 for either controller structure; the motor-position and spring-torque
    filters of a velocity filter: −K1 and K2) are compared with the recomputed ones.

    Parameters
    ----------
    doc : ControllerFile or dict
        A validated controller file.

    Returns
    -------
    list of str
        One line per mismatch (empty: the controller was built from the design section).

    References
    ----------
    Paper §IV (double compliance shaping: the gains from α, Ĵ_m/α, B̂_m/α, ζ, ζ̂ and the plant);
    docs/controller-file.md (certify: the design check).
    """
    cf = as_controller_file(doc)
    design = {k: float(v) for k, v in cf.design.values().items()}
    out = _one_controller(design, cf, "")
    for j, e in enumerate(cf.schedule_entries):
        out += _one_controller(design, cf.entry_view(e), f"gain_schedule.entries[{j}].")
    if cf.implementation is not None:
        from .build import implementation_mismatches

        out += implementation_mismatches(cf)
    return out


def hand_tuned(doc: ControllerFile | dict) -> bool:
    """Whether the file declares a hand-tuned controller (``provenance.hand_tuned: true``); any
    other value than true/false is a ConfigError.

    Parameters
    ----------
    doc : ControllerFile or dict
        The controller file.

    Returns
    -------
    bool
        The declaration (False when absent).

    Raises
    ------
    exotune.errors.ConfigError
        When ``provenance.hand_tuned`` is not a boolean.
    """
    from ..errors import ConfigError

    v = as_controller_file(doc).provenance.hand_tuned
    if not isinstance(v, bool):
        raise ConfigError("provenance.hand_tuned", f"expected true or false, got {v!r}")
    return v


def check_built_from_design(doc: ControllerFile | dict) -> None:
    """Refuse (ConfigError) a file whose controller was not built from its design section and plant
    (:func:`design_mismatches`), unless it declares itself hand-tuned (:func:`hand_tuned`).

    Parameters
    ----------
    doc : ControllerFile or dict
        A validated controller file.

    Raises
    ------
    ConfigError
        Naming ``design.amplification`` when the controller's K̂2 is that of another α, else
        ``design``.

    References
    ----------
    docs/controller-file.md (certify: the design check).
    """
    from ..errors import ConfigError

    cf = as_controller_file(doc)
    if hand_tuned(cf):
        return
    try:
        bad = design_mismatches(cf)
    except (KeyError, TypeError, ValueError, ZeroDivisionError, FloatingPointError) as e:
        raise ConfigError("design", f"cannot rebuild the controller from the design section and plant ({type(e).__name__}: "
                                    f"{str(e)[:120]})") from None
    if not bad:
        return
    alpha = float(cf.design.amplification)
    k2_hat = float(cf.gains.K2_hat)
    field = "implementation" if all("implementation" in b for b in bad) else "design"
    if not close(k2_hat + 1.0, alpha, _GAIN_RTOL):  # K̂2 = α − 1: the controller names the α it was built for
        field = "design.amplification"
        bad = [f"its K2_hat = {k2_hat!r} is that of amplification {k2_hat + 1.0!r}, not {alpha!r}"] + bad
    more = f"; and {len(bad) - 2} more" if len(bad) > 2 else ""
    raise ConfigError(field, f"the controller in this file was not built from its design, plant and implementation sections "
                             f"({'; '.join(bad[:2])}{more}); export the file again from its design, or declare a "
                             "hand-tuned controller with provenance.hand_tuned: true (certify then certifies only "
                             "the controller)")


_HAND_TUNED_NOTE = ("hand-tuned controller (provenance.hand_tuned: true): this certifies only the controller as it is "
                    "in the file, not that it implements the file's design section; ")


_NO_IMPLEMENTATION_NOTE = ("no implementation section (a file written before exotune 0.7.0): the filters' dynamics are "
                           "not checked against the design, only their DC gains; ")


def certify(doc: ControllerFile | dict, precision: str | None = None) -> Certificate:
    """Re-run the sampled-data analysis of a validated controller file and check its golden
    vectors and predictions (see the module docstring). An overflowing controller (e.g. a gain of
    1e308) fails on its verdicts and golden vectors, without numpy's warnings on the terminal.

    ``precision`` (``certify --precision``): analyse the file as if exported for that arithmetic
    (:func:`~exotune.controllerfile.precision.with_precision`; the file is not changed, its
    sampled-data predictions, made for its own precision, are not compared). A float32 file (or
    ``precision="float32"``) is analysed with its float32 realization, its golden vectors run in
    float32, and the report gains ``precision``: the rounding bound
    (:func:`~exotune.controllerfile.roundoff.roundoff_bound`).

    A file whose controller was not built from its design section and plant is refused first
    (:func:`check_built_from_design`, a ConfigError: exit 2), unless it declares itself hand-tuned:
    its report then says that only the controller is certified (``scope``, and the method line).

    Returns a :class:`~exotune.controllerfile.results.Certificate`: ``certified``, ``reasons`` and
    the whole report (``to_dict()``, the ``exotune certify --json`` object).

    Parameters
    ----------
    doc : ControllerFile or dict
        The validated controller file.
    precision : str or None, optional
        ``"float64"`` or ``"float32"``; None for the file's own.

    Returns
    -------
    Certificate
        The verdict and the report.

    Raises
    ------
    exotune.errors.ConfigError
        When the controller was not built from the file's design section and plant (and the file
        is not hand-tuned), or a section of the file is invalid.
    """
    from .precision import precision_of
    from .target import with_precision

    cf = as_controller_file(doc)
    own = precision_of(cf)
    asked = own if precision is None else precision
    if asked != own:
        cf = with_precision(cf, asked)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        check_built_from_design(cf)
        rep = _certify(cf, predictions=asked == own)
    if asked == "float32":
        _float32_section(cf, rep, asked != own)
    if hand_tuned(cf):
        rep["scope"] = "controller only (hand-tuned: the design section is not checked against the controller)"
        rep["method"] = _HAND_TUNED_NOTE + rep["method"]
    elif cf.implementation is None:
        rep["scope"] = ("controller and its six gains; the filters only by their DC gains (no implementation section: "
                        "a file written before exotune 0.7.0; export it again to have every filter checked)")
        rep["method"] = _NO_IMPLEMENTATION_NOTE + rep["method"]
    return Certificate.from_report(rep)


def refuse_excess_work(doc: ControllerFile | dict, entries: int | None = None) -> None:
    """Inside a :func:`~exotune.numerics.timebudget.time_budget` (export, certify): refuse, before
    the sampled-data analysis starts, a file whose base work alone — ``POINTS`` eigenvalue
    problems per family, for the file and each of its ``entries`` gain-schedule entries (default:
    those of the file), the loop matrix with a human attached — exceeds the budget."""
    from ..numerics.timebudget import active_budget, refuse_if_over
    from ..sampled.loop import closed_loop_matrix, plant_ss
    from .fileio import discrete_from_file, plant_from_file

    b = active_budget()
    if b is None:
        return
    cf = as_controller_file(doc)
    A, B, C = plant_ss(plant_from_file(cf), {"inertia": 1.0, "damping": 0.0, "stiffness": 1.0}, "free")
    states = closed_loop_matrix(A, B, C, discrete_from_file(cf)).shape[0]
    fams = sum(1 for h in cf.certify.humans  # design-file form (exotune.config.parse_human)
               if isinstance(h, dict) and h.get("kind") != "complex_stiffness")
    fams += sum(1 for e in cf.certify.environment
                if isinstance(e, dict) and e.get("kind") in ("spring", "mass"))
    if entries is None:
        entries = len(cf.schedule_entries)
    refuse_if_over((1 + entries) * (2 + fams * POINTS), states, *b)


def golden_problems(doc: ControllerFile | dict) -> tuple[list[str], int, float]:
    """(problems, samples, max error [N·m]) of the golden vectors through the reference runtime,
    for the file's controller and each gain-schedule entry's.

    Parameters
    ----------
    doc : ControllerFile or dict
        The validated controller file.

    Returns
    -------
    problems : list of str
        One per controller that does not reproduce its golden vectors.
    samples : int
        Length of the golden vectors.
    max_error : float
        Largest error of the nominal controller's commands [N·m].
    """
    cf = as_controller_file(doc)
    ins = {s: np.asarray(v, float) for s, v in cf.golden.inputs.items()}
    ref = np.asarray(cf.golden.tau_cmd, float)
    if len({len(v) for v in ins.values()} | {len(ref)}) != 1:
        return ["golden vectors have different lengths"], int(ref.size), math.inf
    problems = []
    out = _run_golden(cf, ins, "controller")
    err = float(np.max(np.abs(out - ref))) if ref.size else 0.0
    if not _golden_ok(out, ref):
        problems.append(f"the reference runtime does not reproduce the golden vectors (max error {err:.3g} N·m)")
    for e in cf.schedule_entries:
        ref_e = np.asarray(e.golden_tau_cmd, float)
        run_e = _run_golden(cf.entry_view(e), ins, f"gain_schedule[{e.joint_angle_rad:g} rad].controller")
        if ref_e.size != ref.size or not _golden_ok(run_e, ref_e):
            problems.append("the reference runtime does not reproduce the golden vectors of the gain schedule "
                            f"entry at {e.joint_angle_rad:g} rad")
    return problems, int(ref.size), err


def sampled_problems(sa: dict) -> list[str]:
    """Why the file's own sampled-data analysis ``sa`` does not certify it (free/locked verdicts,
    families not robust, not certifiable or inconclusive, unresolved cells).

    Parameters
    ----------
    sa : dict
        The analysis (:func:`sampled_analysis`).

    Returns
    -------
    list of str
        The problems (empty: certified on these counts).
    """
    problems = []
    for key, what in (("free", "the free exoskeleton (cuff free)"), ("locked", "the locked-joint loop")):
        if sa[f"{key}_stable"] is None:
            problems.append(f"{what}: the sampled-data verdict is inconclusive (spectral radius "
                            f"{sa[f'{key}_spectral_radius']:.12g} within its rounding bound "
                            f"{sa[f'{key}_spectral_radius_rounding']:.2g} of 1)")
        elif not sa[f"{key}_stable"]:
            problems.append(f"{what} is unstable in the sampled-data loop")
    for h in sa["humans"] + sa["environment"]:
        if "skipped" in h:
            continue
        if "not_certifiable" in h:
            box = ", ".join(f"{q} [{a:g}, {b:g}]" for q, (a, b) in h["box"].items())
            problems.append(f"{h['kind']} {h['parameter']} [{h['range'][0]:g}, {h['range'][1]:g}] {h['unit']} × {box}: "
                            f"not certified — {h['not_certifiable']}")
            continue
        said_below = covers_range(h) and bool(h.get("unresolved") or h.get("inconclusive"))
        if not h["robust"] and not said_below:  # a covered range with unresolved cells: the reason is below
            problems.append(f"{h['kind']} {h['parameter']} in [{h['range'][0]:g}, {h['range'][1]:g}] {h['unit']}: "
                            + (f"stable only in {_fmt_ivs(h['stable_intervals'])}" if h["stable_intervals"]
                               else "no member is stable"))
        if h.get("inconclusive"):
            problems.append(f"{h['kind']} {h['parameter']}: the sampled-data verdict is inconclusive (spectral radius "
                            "within rounding of 1) at " + fmt_distinct(h["inconclusive"]) + f" {h['unit']}")
    return problems + _unresolved(sa, "")


def sampled_decision(doc: ControllerFile | dict, sa: dict | None = None) -> tuple[dict, dict, list[str]]:
    """certify's sampled-data decision on a controller document: (its sampled-data analysis
    :func:`sampled_analysis`, its sampled-data latency margin
    :func:`~exotune.controllerfile.latency.sampled_latency_margin`, the problems that refuse it —
    loops or families not stable, inconclusive or unresolved, the margin below
    ``requirements.latency_margin_s``). The one implementation behind ``certify``, ``export``'s
    refusal, ``analyze`` with a sample rate and ``optimize``'s final check (docs/method.md#one-model-of-record).

    Parameters
    ----------
    doc : ControllerFile or dict
        A controller document (a validated file, or one :func:`exotune.controllerfile.export.build_export` builds).
    sa : dict, optional
        Its :func:`sampled_analysis` when already computed.

    Returns
    -------
    (dict, dict, list of str)
    """
    return decision_and_nominal(doc, sa)[:3]


def decision_and_nominal(doc: ControllerFile | dict, sa: dict | None = None) -> tuple[dict, dict, list[str], tuple]:
    """:func:`sampled_decision`, and copies of its analysis and latency margin as computed, before
    the hysteretic check adds to them (the ``nominal`` of :func:`schedule_section`).

    Parameters
    ----------
    doc : ControllerFile or dict
        A controller document.
    sa : dict, optional
        Its :func:`sampled_analysis` when already computed.

    Returns
    -------
    (dict, dict, list of str, (dict, dict))
    """
    import copy

    cf = as_controller_file(doc)
    if sa is None:
        sa = sampled_analysis(cf)
    lm = sampled_latency_margin(cf, sa, position_feedback(cf.controller), lambda d: sampled_analysis(d, proof=False))
    nominal = (copy.deepcopy(sa), copy.deepcopy(lm))
    hyst = hysteretic_problems(cf, sa, margin=lm)  # first: it may bound the margin
    return sa, lm, sampled_problems(sa) + requirement_problems(lm) + hyst, nominal


def runs_the_file_itself(top: dict, entry: dict) -> bool:
    """Whether a gain-schedule entry (its mapping ``entry``) runs the file's own loop: its plant,
    six gains and complete controller are the top-level ones (``top``: the file's mapping) value for
    value, compared as their exact text (types, signed zeros and key order included) — the entry at
    transmission ratio 1 of an exported file. Its view (:meth:`ControllerFile.entry_view`) is then
    the file itself but for the six gains' ``convention`` note, so its sampled-data analysis and
    latency margin (deterministic functions of the view) are the file's.

    Parameters
    ----------
    top : dict
        The controller file's mapping.
    entry : dict
        One of its ``gain_schedule.entries`` (a mapping).

    Returns
    -------
    bool
        True when the entry's loop is the file's own.
    """
    def six(g):
        return {k: v for k, v in g.items() if k != "convention"} if isinstance(g, dict) else g

    return (repr(entry.get("plant")) == repr(top.get("plant"))
            and repr(six(entry.get("gains"))) == repr(six(top.get("gains")))
            and isinstance(entry.get("controller"), dict) and isinstance(top.get("controller"), dict)
            and repr({**top["controller"], **entry["controller"]}) == repr(top["controller"]))


def schedule_section(doc: ControllerFile | dict, analyses: list | None = None,
                     nominal: tuple[dict, dict] | None = None) -> tuple[list, list[str], list[str]]:
    """(report entries, problems, prediction mismatches) of the gain schedule's entries, each
    analysed as a controller of its own: its sampled-data verdicts, its hysteretic humans and its
    own sampled-data latency margin against the file's ``requirements.latency_margin_s`` (the
    runtime runs every entry, so each must meet the requirement; docs/controller-file.md#gain-schedule).

    Parameters
    ----------
    doc : ControllerFile or dict
        The validated controller file, with a gain schedule.
    analyses : list of dict, optional
        Each entry's :func:`sampled_analysis` when already computed (export's ``predicted_sampled``).
    nominal : (dict, dict), optional
        The file's own :func:`sampled_analysis` and sampled-data latency margin (:func:`sampled_decision`):
        an entry that runs the file's own plant, gains and controller (transmission ratio 1) takes
        copies of them instead of computing the same analyses again (the same values).

    Returns
    -------
    entries : list of dict
        Per entry: ``joint_angle_rad``, ``ratio``, ``robust``, ``not_robust``, its ``sampled``
        analysis and its ``latency_margin``
        (:func:`~exotune.controllerfile.latency.sampled_latency_margin`).
    problems : list of str
        The entries' problems.
    mismatches : list of str
        Where an entry's ``predicted_sampled`` differs from the analysis.
    """
    import copy

    cf = as_controller_file(doc)
    entries, problems, mism, hyst = [], [], [], []
    top = cf.to_dict() if nominal is not None else None
    for j, e in enumerate(cf.gain_schedule.entries):
        view = cf.entry_view(e)
        same = top is not None and runs_the_file_itself(top, e.to_dict())
        if analyses is not None:
            sa_e = analyses[j]
        else:
            sa_e = copy.deepcopy(nominal[0]) if same else sampled_analysis(view)
        where = f"gain schedule at joint angle {e.joint_angle_rad:g} rad: "
        hyst.append((view, sa_e, where))
        bad = [f"{h['kind']} {h['parameter']}" for h in sa_e["humans"] + sa_e["environment"]
               if "skipped" not in h and not h.get("robust")]
        bad += [k for k in ("free_stable", "locked_stable") if not sa_e[k]]
        if same and repr(sa_e) == repr(nominal[0]):  # the file's own loop and analysis: the file's margin
            lm_e = copy.deepcopy(nominal[1])
        else:
            lm_e = sampled_latency_margin(view, sa_e, position_feedback(view.controller),
                                          lambda d: sampled_analysis(d, proof=False))
        entries.append({"joint_angle_rad": e.joint_angle_rad, "ratio": e.ratio,
                        "robust": not bad, "not_robust": bad, "sampled": sa_e, "latency_margin": lm_e})
        problems += _unresolved(sa_e, where)
        if bad:
            problems.append(f"gain schedule at joint angle {e.joint_angle_rad:g} rad (ratio {e.ratio:g}): "
                            f"not stable for {', '.join(bad)}")
        elif lm_e.get("extra_delay_s") is not None:  # an unstable entry's margin 0 says nothing more
            problems += [where + p for p in requirement_problems(lm_e)]
        mism += prediction_mismatches(e.predicted_sampled, sa_e,
                                       f"gain_schedule[{e.joint_angle_rad:g} rad].predicted_sampled")
    for more in hysteretic_problems_many(hyst):  # one continuous-time batch for every entry
        problems += more
    return entries, problems, mism


def float32_realization_check(doc: ControllerFile) -> None:
    """Refuse a float32 file whose realization is not that of its sos and gains (an invalid file
    unless hand-tuned).

    Parameters
    ----------
    doc : ControllerFile
        A controller file analysed in float32.

    Raises
    ------
    exotune.errors.ConfigError
        Naming ``controller.realization``.
    """
    from ..errors import ConfigError
    from .precision import realization_problems

    bad = [] if hand_tuned(doc) else realization_problems(doc)
    if bad:
        raise ConfigError("controller.realization", f"{bad[0]}; export the file again from its design")


def _float32_section(doc: ControllerFile, rep: dict, asked: bool) -> None:
    """The float32 part of the report: the realization checked (:func:`float32_realization_check`),
    and the rounding bound."""
    from .roundoff import roundoff_bound

    float32_realization_check(doc)
    rep["precision"] = roundoff_bound(doc)
    if asked:
        rep["precision"]["asked"] = ("certify --precision float32: the file's float64 controller analysed as its "
                                     "float32 realization (the file is unchanged; its predictions are not compared)")


def _certify(doc: ControllerFile, predictions: bool = True) -> dict:
    refuse_excess_work(doc)
    rep = {"schema": doc.schema, "sample_rate_hz": doc.sample_rate.to_dict(), "delay_s": doc.delay_s,
           "provenance": doc.provenance.to_dict()}
    problems, samples, err = golden_problems(doc)
    rep["golden"] = {"samples": samples, "max_abs_error": {"value": err, "unit": "N·m"}}
    rep["sampled"], rep["latency_margin"], decided, nominal = decision_and_nominal(doc)
    sa = rep["sampled"]
    problems += decided
    mism = []
    if doc.gain_schedule is not None:
        rep["gain_schedule"], sched_problems, mism = schedule_section(doc, nominal=nominal)
        problems += sched_problems
        rep["latency_margin"] = schedule_minimum(rep["latency_margin"], rep["gain_schedule"])
    if not [h for h in sa["humans"] if "skipped" not in h]:
        problems.append("the file names no rational human family to certify against (certify.humans)")
    mism += prediction_mismatches(doc.predicted.sampled, sa, "predicted.sampled")
    if not predictions:  # certify --precision: the predictions were made for the file's own precision
        mism = []
    if mism:
        problems.append("the file's predictions differ from this analysis: " + ", ".join(mism))
    rep["prediction_mismatches"] = mism
    rep["problems"] = problems
    rep["certified"] = not problems
    rep["method"] = (f"exact sampled-data eigenvalues at {POINTS} log-spaced values per family; step control "
                     f"(cells halved ≤ {MAX_DEPTH} times until every eigenvalue moves less than its distance to the "
                     "unit circle) proposes the cells, and each accepted span is proven stable as a whole (a Taylor "
                     "model of the loop matrix over the span and Gershgorin discs, docs/method.md#guarantees; an "
                     "unproven cell is unresolved); every verdict change bisected to 1e-10 relative and the stable side of "
                     "each interval end proven up to 1e-6 relative of it; hysteretic "
                     "humans are not rational and are skipped")
    return rep


_FAMILY_KEYS = ("kind", "parameter", "unit", "range", "robust", "stable_intervals", "unresolved", "skipped",
                "not_certifiable")


def prediction_mismatches(pred, sa: dict, where: str) -> list[str]:
    """Every sampled-data prediction of the file (``pred``: untrusted, anything malformed is a
    mismatch) against the recomputed ``sa``: the free and locked verdicts and spectral radii, and
    per family its identity, range, robust verdict and stable intervals.

    Parameters
    ----------
    pred : object
        The file's ``predicted.sampled`` (or an entry's ``predicted_sampled``), as read.
    sa : dict
        The :func:`sampled_analysis` of the same loop.
    where : str
        The field path that names a mismatch.

    Returns
    -------
    list of str
        The mismatching fields (``where`` + key), empty when the prediction is the analysis.
    """
    if not isinstance(pred, dict):
        return [f"{where} missing"]
    out = [f"{where}.{k}" for k in ("free_stable", "locked_stable") if pred.get(k) is not sa[k]]
    for k in ("free_spectral_radius", "locked_spectral_radius"):
        if not _same_intervals([[pred.get(k), pred.get(k)]], [[sa[k], sa[k]]]):
            out.append(f"{where}.{k}")
    for grp in ("humans", "environment"):
        p_g = _entries(pred.get(grp))
        if len(p_g) != len(sa[grp]):
            out.append(f"{where}.{grp} (the file predicts {len(p_g)} families, certify.{grp} has {len(sa[grp])})")
            continue
        for j, (p, h) in enumerate(zip(p_g, sa[grp])):
            if p is None:
                out.append(f"{where}.{grp}[{j}] (not a mapping)")
                continue
            for k in _FAMILY_KEYS:  # a key the analysis does not give must not be predicted either
                if k not in h:
                    ok = k not in p
                elif k in ("range", "stable_intervals", "unresolved"):
                    ok = _same_intervals(p.get(k) if k != "range" else [p.get(k)], h[k] if k != "range" else [h[k]])
                else:
                    ok = p.get(k) == h[k] and type(p.get(k)) is type(h[k])
                if not ok:
                    out.append(f"{where}.{grp}[{j}].{k}")
    return out


def _run_golden(doc: ControllerFile, ins: dict, where: str) -> np.ndarray:
    """The reference runtime on the golden inputs; a controller that overflows on them (a command
    too large for floating point) is a broken file: input error naming it."""
    from ..errors import ConfigError
    from .target import runtime_of

    try:
        return runtime_of(doc).run(ins)
    except ValueError as e:
        raise ConfigError(where, f"the reference runtime refuses the golden inputs: {e}") from None


def _fmt_ivs(ivs) -> str:
    return ", ".join(f"[{a:.6g}, {b:.6g}]" for a, b in ivs) if ivs else "nowhere"
