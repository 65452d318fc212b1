"""The optimization spec of ``exotune optimize``: objectives, constraints, validation.

References
----------
docs/optimize-spec.md (the spec file); paper §IV (coupled stability), §IV-A (passivity).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np

from ..config.validate import fmt_value, number_field
from ..errors import ConfigError

__all__ = ["OBJECTIVES", "CONSTRAINTS", "DEFAULT_LATENCY_MARGIN_S", "LATENCY_CHECKS", "MAX_BUDGET", "OptimizeSpec",
           "load_optimize_spec", "default_budget", "optimized_design_mapping"]

#: objective name → (what: a dotted parameter path or an analyze_batch column, sense, unit)
OBJECTIVES = {
    "amplification": ("design.amplification", "max", "1"),
    "felt_inertia": ("design.felt_inertia", "min", "kg·m²"),
    # "felt compliance": the operator feels C7 ≈ 1/(Ĵ_m/α s² + B̂_m/α s) at low frequency, so
    # the most compliant (lightest-feeling) exoskeleton has the smallest felt inertia
    "felt_compliance": ("design.felt_inertia", "min", "kg·m² (felt inertia, minimized)"),
    "amplification_bandwidth_hz": ("amplification_bandwidth_hz", "max", "Hz"),
    "dob_delay_margin_s": ("dob_delay_margin_s", "max", "s"),
    "passivity_max_phase_excess_deg": ("passivity_max_phase_excess_deg", "min", "deg"),
    # the latency margin (exotune.analysis.latency_margin): a verdict ladder during the search, exact at the end
    "latency_margin_s": ("latency_margin_s", "max", "s"),
}
#: bound constraints: name → (column, ">=" | "<=", unit)
CONSTRAINTS = {
    "max_phase_excess_deg": ("passivity_max_phase_excess_deg", "<=", "deg"),
    "dob_phase_margin_deg": ("dob_phase_margin_deg", ">=", "deg"),
    "dob_gain_margin_db": ("dob_gain_margin_db", ">=", "dB"),
    "dob_delay_margin_s": ("dob_delay_margin_s", ">=", "s"),
    "amplification_bandwidth_hz": ("amplification_bandwidth_hz", ">=", "Hz"),
    "amplification_peak_db": ("amplification_peak_db", "<=", "dB"),
    "latency_margin_s": ("latency_margin_s", ">=", "s"),
}
#: recognized names whose computation is not available yet (a clear ConfigError)
PENDING = {"plant_uncertainty_margin": "the plant-uncertainty margin is not implemented yet"}
#: the measures of the disturbance observer (constraint or objective name → what it is): undefined
#: without one (``implementation.dob: null``), so a spec asking for one is refused up front
DOB_MEASURES = {"dob_phase_margin_deg": "DOB phase margin", "dob_gain_margin_db": "DOB gain margin",
                "dob_delay_margin_s": "DOB delay margin"}
NO_DOB = "the base design has no disturbance observer (implementation.dob: null)"
BOOL = ("robust", "free_stable", "locked_stable", "nominal_passive")
BOOL_DEFAULT = {"robust": True, "free_stable": True, "locked_stable": True, "nominal_passive": False}
KEYS = ("base", "objective", "free", "constraints", "seed", "budget")
#: the largest seed (numpy's generators take 0 … 2**32 − 1)
MAX_SEED = 2**32 - 1
#: the largest budget (exact analyses; the default is 1500 per free parameter): beyond it a budget is
#: a typo, and 10^400 cannot even be scaled as a float
MAX_BUDGET = 1_000_000
#: default latency margin without a sample rate [s] (with one: one sample period)
DEFAULT_LATENCY_MARGIN_S = 0.0005
#: extra delays m·k/K (k = 1..K) checked per candidate for the constraint latency_margin_s ≥ m
LATENCY_CHECKS = 3


@dataclass(frozen=True)
class OptimizeSpec:
    """A validated optimization problem (:func:`load_optimize_spec`).

    ``constraints["latency_margin_s"]`` is always present (0: no latency margin required);
    ``latency_default`` says where its value comes from when the spec did not set it;
    ``latency_deltas`` are the extra delays [s] checked per candidate (empty: m·k/K, k = 1..K)."""

    cfg: object  # DesignConfig of the base
    free: dict  # path → (lo, hi, "log"|"lin")
    objective: str
    constraints: dict  # name → bound (float) or bool
    seed: int = 0
    budget: int = 3000
    source: str | None = None
    raw: dict = field(default_factory=dict)
    latency_default: str | None = None
    latency_deltas: tuple = ()

    def checked_delays(self) -> np.ndarray:
        """The extra delays [s] at which the delay-sensitive verdicts must hold (latency margin)."""
        m = float(self.constraints.get("latency_margin_s", 0.0))
        if m <= 0:
            return np.zeros(0)
        if self.latency_deltas:
            return np.asarray(self.latency_deltas, float)
        return m * np.arange(1, LATENCY_CHECKS + 1) / LATENCY_CHECKS


def default_budget(n_free: int) -> int:
    """Default number of exact analyses: 1500 per free parameter, at least 3000.

    Parameters
    ----------
    n_free : int
        Number of free parameters.

    Returns
    -------
    int
        The budget (exact analyses).
    """
    return max(3000, 1500 * int(n_free))


def _read(spec):
    from ..config import read_yaml

    if isinstance(spec, (str, os.PathLike)):
        mapping = read_yaml(os.fspath(spec))
        root, source = os.path.dirname(os.path.abspath(os.fspath(spec))), os.fspath(spec)
    elif isinstance(spec, dict):
        mapping, root, source = spec, os.getcwd(), None
    else:
        raise ConfigError("<spec>", f"expected a spec file path or a mapping, got {type(spec).__name__}")
    if not isinstance(mapping, dict):
        raise ConfigError(source or "<spec>", "expected a mapping at the top level")
    for k in mapping:
        if k not in KEYS:
            raise ConfigError(str(k), f"unknown key in an optimization spec (allowed: {', '.join(KEYS)})", in_file=True)
    if "base" not in mapping:
        raise ConfigError("base", "required key is missing (a design file path or an inline design mapping)")
    return mapping, root, source


def _free(cfg, free_in) -> dict:
    from ..config import OVERRIDABLE, batch_config

    if not isinstance(free_in, dict) or not free_in:
        raise ConfigError("free", "required: a mapping of dotted parameter paths to bounds [lo, hi]")
    free = {}
    for path, b in free_in.items():
        f = f"free.{path}"
        if path not in OVERRIDABLE:
            raise ConfigError(f, "unknown or non-overridable parameter (the paths of sweep axes)")
        scale = None
        if isinstance(b, dict):
            extra = set(b) - {"lo", "hi", "scale"}
            if extra:
                raise ConfigError(f"{f}.{sorted(extra)[0]}", "unknown key (allowed: lo, hi, scale)")
            if "lo" not in b or "hi" not in b:
                raise ConfigError(f, "needs lo and hi")
            lo, hi, scale = number_field(f"{f}.lo", b["lo"]), number_field(f"{f}.hi", b["hi"]), b.get("scale")
            if scale not in (None, "lin", "log"):
                raise ConfigError(f"{f}.scale", f"expected lin or log, got {scale!r}")
        elif isinstance(b, (list, tuple, np.ndarray)) and np.ndim(b) == 1 and len(b) == 2:
            lo, hi = number_field(f"{f}[0]", b[0]), number_field(f"{f}[1]", b[1])
        else:
            raise ConfigError(f, f"expected bounds [lo, hi] or {{lo, hi, scale}}, got {b!r}")
        if not lo < hi:
            raise ConfigError(f, f"lower bound {lo:g} must be below the upper bound {hi:g}")
        try:
            batch_config(cfg, {path: np.array([lo, hi])})
        except ConfigError as e:
            raise ConfigError(f, e.reason) from None
        if scale == "log" and lo <= 0:
            raise ConfigError(f"{f}.scale", "log scale needs a positive lower bound")
        if scale is None:
            scale = "log" if lo > 0 and hi / lo > 10 else "lin"
        free[path] = (lo, hi, scale)
    return free


def _constraints(cfg, cons_in) -> tuple[dict, str | None]:
    cons_in = {} if cons_in is None else cons_in  # an empty `constraints:` key: the defaults
    if not isinstance(cons_in, dict):
        raise ConfigError("constraints", f"expected a mapping of constraint names to bounds, got {cons_in!r}")
    cons = dict(BOOL_DEFAULT)
    for k, v in cons_in.items():
        if k in BOOL:
            if not _is_flag(v):
                raise ConfigError(f"constraints.{k}", f"expected true or false, got {v!r}")
            cons[k] = bool(v)
        elif k in CONSTRAINTS:
            cons[k] = number_field(f"constraints.{k}", v)
            if k == "max_phase_excess_deg" and cons[k] < 0:
                raise ConfigError(f"constraints.{k}", f"must be >= 0 (the phase excess is never negative), got {v!r}")
            if k == "amplification_bandwidth_hz" and cons[k] < 0:
                raise ConfigError(f"constraints.{k}", f"must be >= 0 Hz (a bandwidth is never negative, so a negative "
                                                      f"bound constrains nothing), got {v!r}")
            if k == "amplification_peak_db" and cons[k] < 0:
                raise ConfigError(f"constraints.{k}", f"must be >= 0 dB (the peak is measured over the DC value, so "
                                                      f"it is never below 0 dB and no design could meet it), got {v!r}")
            if k == "latency_margin_s" and cons[k] < 0:
                raise ConfigError(f"constraints.{k}", f"must be >= 0 s (0 disables the latency margin), got {v!r}")
            if k in DOB_MEASURES and cons[k] <= 0:
                # an unstable DOB loop reports PM ≤ 0, GM ≤ 0 dB and a delay margin of 0
                # (docs/method.md#dob-margins): only a positive bound refuses it
                raise ConfigError(f"constraints.{k}", f"must be > 0 {CONSTRAINTS[k][2]}: an unstable DOB loop has "
                                                      f"a {DOB_MEASURES[k]} <= 0, so a bound <= 0 would accept it "
                                                      f"(a small positive bound asks for a stable DOB loop), got {v!r}")
        elif k in PENDING:
            raise ConfigError(f"constraints.{k}", f"not available yet: {PENDING[k]}")
        else:
            raise ConfigError(f"constraints.{k}", f"unknown constraint (known: {', '.join(BOOL + tuple(CONSTRAINTS))})")
    if cons["robust"] and not cfg.humans:
        raise ConfigError("constraints.robust", "the base design has no human families to be robust against")
    if cfg.implementation.dob is None:
        for k in cons:
            if k in DOB_MEASURES:
                raise ConfigError(f"constraints.{k}", f"{NO_DOB}, so its {DOB_MEASURES[k]} is undefined: remove the "
                                                      "constraint or give the base design an implementation.dob filter")
    how = None
    if "latency_margin_s" not in cons:
        # the default keeps a margin only where every delay-sensitive verdict is required
        if cons["free_stable"] and cons["locked_stable"] and (cons["robust"] or not cfg.humans):
            fs = cfg.implementation.sample_rate_hz
            if fs:
                cons["latency_margin_s"], how = 1.0 / float(fs), f"default: one sample period at {float(fs):g} Hz"
            else:
                cons["latency_margin_s"], how = DEFAULT_LATENCY_MARGIN_S, "default: 0.5 ms (no sample rate set)"
        else:
            cons["latency_margin_s"], how = 0.0, "default: none (a stability constraint is disabled)"
    return cons, how


def _check_latency_room(cfg, free: dict, m: float) -> None:
    """``latency_margin_s ≥ m`` is checked at the delays T + m·k/K: the largest, T + m, must be a
    delay the analysis accepts (at most 1 s) for every candidate's T."""
    from ..analysis.latency import delay_limit

    t_max = float(np.max(np.asarray(cfg.implementation.delay_s, dtype=float)))
    if "implementation.delay_s" in free:
        t_max = max(t_max, float(free["implementation.delay_s"][1]))
    hi = delay_limit()
    if m > 0 and t_max + m > hi:
        raise ConfigError("constraints.latency_margin_s",
                          f"{m:g} s is checked at delays up to T + {m:g} s = {t_max + m:g} s, beyond the {hi:g} s "
                          f"an analysis accepts: at most {max(hi - t_max, 0.0):g} s with this design's delay "
                          f"(docs/optimize-spec.md#constraints)")


def _is_int(v) -> bool:
    """An integer: a Python or numpy one (``np.int64(3)``), never a bool (``True``, ``np.True_``)."""
    return isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))


def _is_flag(v) -> bool:
    """A yes/no value: a bool or a numpy bool (``np.True_``)."""
    return isinstance(v, (bool, np.bool_))


def _shown(v) -> str:
    """A value as an error about an integer shows it: numpy scalars as their Python value, a float
    as a float (``1.0``, not ``1``)."""
    if isinstance(v, (float, np.floating)):
        return repr(float(v))
    if isinstance(v, np.generic):
        v = v.item()
    return fmt_value(v)


def _seed(s, in_file: bool) -> int:
    """The search's seed: an integer (numpy's included) in [0, :data:`MAX_SEED`] (the seeds
    numpy's generators take), else :class:`ConfigError` on ``seed`` (``in_file``: the spec's key,
    not the keyword)."""
    if not _is_int(s) or not 0 <= int(s) <= MAX_SEED:
        huge = _is_int(s) and int(s).bit_length() > 256  # (its decimal text may be too long to print)
        got = f"an integer of {int(s).bit_length()} bits" if huge else _shown(s)
        raise ConfigError("seed", f"expected an integer from 0 to {MAX_SEED} (2**32 − 1), got {got}", in_file=in_file)
    return int(s)


def load_optimize_spec(spec, seed: int | None = None) -> OptimizeSpec:
    """Read and validate an optimization spec (a YAML path or a mapping).

    Parameters
    ----------
    spec : str, os.PathLike or dict
        The spec (docs/optimize-spec.md); a ``base`` path is relative to the spec file.
    seed : int, optional
        Overrides the spec's ``seed`` (the command line's ``--seed``); from 0 to 2**32 − 1, as the
        spec's.

    Returns
    -------
    OptimizeSpec
        With the latency-margin default resolved (one sample period when the base design has
        ``implementation.sample_rate_hz``, else 0.5 ms; ``latency_margin_s: 0`` disables it) and
        the default budget (1500 analyses per free parameter, at least 3000).

    Raises
    ------
    ConfigError
        For every problem, naming the field.

    References
    ----------
    docs/optimize-spec.md; paper §IV (coupled stability).
    """
    from ..sweeps.spec import load_base

    mapping, root, source = _read(spec)
    s = _seed(mapping.get("seed", 0) if seed is None else seed, in_file=seed is None)  # before any work
    cfg, _ = load_base(mapping["base"], root)
    objective = mapping.get("objective", "amplification")
    if not isinstance(objective, str) or objective not in OBJECTIVES:
        raise ConfigError("objective", f"unknown objective {objective!r} (known: {', '.join(OBJECTIVES)})")
    if objective in DOB_MEASURES and cfg.implementation.dob is None:
        raise ConfigError("objective", f"{objective}: {NO_DOB}, so its {DOB_MEASURES[objective]} is undefined: "
                                       "choose another objective or give the base design an implementation.dob filter")
    free = _free(cfg, mapping.get("free"))
    what = OBJECTIVES[objective][0]
    if what.startswith(("design.", "plant.", "implementation.")) and what not in free:
        raise ConfigError("objective", f"{objective} is the parameter {what}: list it under free with its bounds")
    cons, how = _constraints(cfg, mapping.get("constraints"))
    _check_latency_room(cfg, free, cons["latency_margin_s"])
    budget = mapping.get("budget", default_budget(len(free)))
    if not _is_int(budget) or budget < 50:
        raise ConfigError("budget", f"expected an integer ≥ 50, got {_shown(budget)}")
    if budget > MAX_BUDGET:
        raise ConfigError("budget", f"{_shown(budget)} exact analyses; at most {MAX_BUDGET} (the default is 1500 "
                                    "per free parameter)")
    budget = int(budget)
    raw = {"objective": objective, "free": {p: list(v) for p, v in free.items()}, "constraints": cons,
           "seed": s, "budget": budget}
    return OptimizeSpec(cfg, free, objective, cons, s, budget, source, raw, how)


def optimized_design_mapping(spec: OptimizeSpec, result: dict) -> dict:
    """The base design mapping with the optimized values (``result["x"]``) written in.

    Parameters
    ----------
    spec : OptimizeSpec
        The optimization problem.
    result : dict
        The optimization's result: ``x`` (path → value) and ``latency_margin`` (with
        ``required_s`` [s]) when there is one.

    Returns
    -------
    dict
        A deep copy of the base design's ``raw`` mapping, with its ``requirements`` section when the
        latency margin asked travels with it.
    """
    import copy

    raw = copy.deepcopy(spec.cfg.raw)
    for path, v in result["x"].items():
        node = raw
        keys = path.split(".")
        for k in keys[:-1]:
            node = node[k]
        node[keys[-1]] = float(v)
    lm = result.get("latency_margin")
    if lm is not None and (spec.cfg.implementation.sample_rate_hz or spec.latency_default is None):
        # the margin asked of optimize travels with the design: export and certify hold it to it
        # (docs/design-file.md#requirements); without a rate only a margin the spec set explicitly
        raw["requirements"] = {"latency_margin_s": float(lm["required_s"]),
                               "source": "exotune optimize (" + (spec.latency_default or "the spec's constraints") + ")"}
    return raw
