"""Strict loading and validation of design files (docs/design-file.md) and SEA files (``exotune sea``).

Design file sections (docs/method.md#physical-model, docs/method.md#controller, docs/method.md#double-compliance-shaping, docs/design-file.md): ``plant``, ``design``, ``implementation``, ``humans``,
``environment``. Validation is strict (docs/cli.md): unknown keys, missing parameters, non-numbers,
NaN/inf and out-of-range values are all errors, reported as a :class:`~exotune.errors.ConfigError`
naming the field as a dotted path (``design.amplification``, ``humans[0].inertia``) and the reason.

Rules (all numbers must be finite; YAML booleans and strings are not numbers):

====================================  =======================================================
plant ``motor_inertia`` J_m             > 0 [kg·m²]
plant ``motor_damping`` B_m             ≥ 0 [N·m·s/rad]
plant ``sea_stiffness`` K_s             > 0 [N·m/rad]
plant ``joint_inertia`` J_j             > 0 [kg·m²]
plant ``cuff_stiffness`` K_c            > 0 [N·m/rad] (required in design files; SEA files
                                        default to 300)
design ``amplification`` α              ≥ 1
design ``felt_inertia`` Ĵ_m/α           > 0 [kg·m²]
design ``felt_damping`` B̂_m/α           > 0 [N·m·s/rad] — *strictly*: B̂_m = 0 gives B̃1 = 0, so
                                        C4 gets a double pole at s = 0 and the reduced G_v of
                                        docs/method.md#controller (denominator s + B̃1) becomes a pure integrator
                                        in the controller (unbounded output for a constant cuff
                                        torque, and C7 gets a double integrator).
design ``zeta`` ζ, ``zeta_hat`` ζ̂       > 0
implementation ``delay_s`` T            ≥ 0 [s] (default 0)
implementation ``sample_rate_hz``       null (continuous-time analysis, default) or > 0 [Hz];
                                        delay_s · sample_rate_hz ≤ 200 (one state per sample)
filter ``cutoff_hz``                    > 0 [Hz], and < sample_rate_hz/2 (Nyquist) when a
                                        sample rate is set
filter ``damping``                      > 0
implementation ``structure``            ``default`` | ``full_filter`` (see exotune.controller)
range ``[lo, hi]``                      two numbers, 0 < lo ≤ hi (lo = hi is a single value);
                                        a single number v is accepted as [v, v]
human/environment ``damping``           ≥ 0 (default 0) [N·m·s/rad]
complex_stiffness ``eta`` η             0 ≤ η < 10
====================================  =======================================================

Besides these sign rules, every number must lie within the accepted range of its kind
(:data:`exotune.config.validate.LIMITS`: inertias in [1e-9, 1e6] kg·m², stiffnesses in
[1e-6, 1e9] N·m/rad, frequencies in [0.001, 1e7] Hz, delays in [0, 1] s, …;
docs/design-file.md#input-limits-and-accepted-ranges).

Human families (docs/method.md#physical-model): ``mass`` (``inertia`` range, ``damping``), ``spring`` (``stiffness``
range, ``damping``), ``msd`` (``inertia``, ``damping``, ``stiffness``: each a number or a range,
at least one a range — several make a box; missing ones are 0, but the inertia must be > 0), ``complex_stiffness``
(``stiffness`` range, ``eta``). Environments: ``locked``, ``free``, ``spring`` (``stiffness``
range, ``damping``), ``mass`` (``inertia`` range, ``damping``).

Batches (:func:`exotune.config.batch.batch_config`) override plant, design and implementation
parameters by dotted path with 1-D arrays; YAML is read by :mod:`exotune.config.yamlio`.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import ConfigError, combine_errors
from ..model.controller import FirstOrderFilter, Implementation, SecondOrderFilter
from ..model.humans import EnvModel, HumanFamily
from ..model.plant import Plant
from ..model.shaping import DesignParams, SeaGains
from .schema import (
    ENV_KINDS,
    ENV_MODELS,
    HUMAN_KINDS,
    HUMAN_MODELS,
    DesignFileIn,
    ImplementationIn,
    SeaFileIn,
)
from ..units import fmt_num
from .validate import FILTER_KEYS, LIMITS, check_delay_samples, fmt_outside, fmt_value, in_limits, kind_of, limit_text, validate_model
from .yamlio import read_yaml

__all__ = [
    "DesignConfig",
    "SeaConfig",
    "load_design",
    "design_from_mapping",
    "load_sea",
    "sea_from_mapping",
    "parse_human",
    "parse_env",
    "hash_mapping",
    "refuse_other_kind",
]


# --------------------------------------------------------------------------------------------
# Public result types
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class DesignConfig:
    """A validated design file (docs/design-file.md).

    ``raw`` is the validated, normalized mapping (defaults filled in, ranges as ``[lo, hi]``
    lists, every number a float); it is JSON-serializable and is what :func:`hash_mapping`
    hashes for provenance. For a batch (:func:`batch_config`) it still describes the base design.
    """

    plant: Plant
    design: DesignParams
    implementation: Implementation
    humans: tuple[HumanFamily, ...]
    environment: tuple[EnvModel, ...]
    raw: dict
    source: str | None = None
    uncertainty: dict | None = None  # relative range per plant parameter (None: weight 1 each)
    requirements: dict | None = None  # {latency_margin_s [s] or None, source} (docs/design-file.md#requirements)


@dataclass(frozen=True)
class SeaConfig:
    """A validated SEA file for ``exotune sea``: the plant and full-state SEA gains (paper §II-B)."""

    plant: Plant
    gains: SeaGains
    raw: dict | None = None
    source: str | None = None


# --------------------------------------------------------------------------------------------
# Design files
# --------------------------------------------------------------------------------------------
def parse_human(i: int, item: Any) -> tuple[HumanFamily, dict]:
    """One entry of a design file's ``humans`` list (docs/design-file.md) as a human family.

    Parameters
    ----------
    i : int
        Index of the entry in ``humans``, for the field paths of errors.
    item : Any
        The entry read from the file: a mapping with ``kind`` (mass, spring, complex_stiffness or
        msd) and its parameters (inertia [kg·m²], damping [N·m·s/rad], stiffness [N·m/rad], eta [–]).

    Returns
    -------
    family : HumanFamily
        The family: its varied parameter and range, the fixed parameters, a box's other ranges.
    raw : dict
        The normalized entry for the design's ``raw`` mapping.

    Raises
    ------
    exotune.errors.ConfigError
        When the entry is not a mapping, its kind is missing or unknown, a parameter does not
        validate, or an msd entry has no range or no inertia where one is needed.
    """
    where = f"humans[{i}]"
    if not isinstance(item, dict):
        raise ConfigError(where, f"expected a mapping {{kind: ..., ...}}, got {kind_of(item)}")
    if "kind" not in item:
        raise ConfigError(f"{where}.kind", f"required parameter is missing (one of {', '.join(HUMAN_KINDS)})")
    kind = item["kind"]
    if not isinstance(kind, str) or kind not in HUMAN_MODELS:
        raise ConfigError(f"{where}.kind", f"unknown human model {fmt_value(kind)} (one of {', '.join(HUMAN_KINDS)})")
    m = validate_model(HUMAN_MODELS[kind], item, where)
    if kind == "mass":
        lo, hi = m.inertia
        return (
            HumanFamily("mass", "inertia", lo, hi, damping=m.damping),
            {"kind": kind, "inertia": [lo, hi], "damping": m.damping},
        )
    if kind == "spring":
        lo, hi = m.stiffness
        return (
            HumanFamily("spring", "stiffness", lo, hi, damping=m.damping),
            {"kind": kind, "stiffness": [lo, hi], "damping": m.damping},
        )
    if kind == "complex_stiffness":
        lo, hi = m.stiffness
        return (
            HumanFamily("complex_stiffness", "stiffness", lo, hi, eta=m.eta),
            {"kind": kind, "stiffness": [lo, hi], "eta": m.eta},
        )
    # msd: one range (an exact 1-D family) or several (a box, analysed through its edges)
    vals = {p: (0.0 if getattr(m, p) is None else getattr(m, p)) for p in ("inertia", "damping", "stiffness")}
    ranged = [p for p, v in vals.items() if isinstance(v, tuple)]
    if not ranged:
        raise ConfigError(
            where,
            "at least one of inertia/damping/stiffness must be a range [lo, hi] for kind msd, got none",
        )
    p = ranged[0]
    if p != "inertia" and not vals["inertia"] > 0:
        raise ConfigError(
            f"{where}.inertia",
            "kind msd needs an inertia > 0 (a number or a range); "
            + ("it is missing" if m.inertia is None else f"got {fmt_value(vals['inertia'])}")
            + " (use kind: spring for a massless human)",
        )
    lo, hi = vals[p]
    fixed = {q: (float(v) if not isinstance(v, tuple) else float(v[0])) for q, v in vals.items() if q != p}
    box = tuple((q, float(vals[q][0]), float(vals[q][1])) for q in ranged[1:])
    fam = HumanFamily("msd", p, lo, hi, **fixed, box=box)
    raw = {"kind": "msd", **{q: ([v[0], v[1]] if isinstance(v, tuple) else float(v)) for q, v in vals.items()}}
    return fam, raw


def parse_env(i: int, item: Any) -> tuple[EnvModel, dict]:
    """One entry of a design file's ``environment`` list (docs/design-file.md) as an environment model.

    Parameters
    ----------
    i : int
        Index of the entry in ``environment``, for the field paths of errors.
    item : Any
        The entry read from the file: a mapping with ``kind`` (locked, free, spring or mass) and
        its range (stiffness [N·m/rad] or inertia [kg·m²]) and damping [N·m·s/rad].

    Returns
    -------
    model : EnvModel
        The environment model (its varied parameter and range; none for locked and free).
    raw : dict
        The normalized entry for the design's ``raw`` mapping.

    Raises
    ------
    exotune.errors.ConfigError
        When the entry is not a mapping, its kind is missing or unknown, or a parameter does not
        validate.
    """
    where = f"environment[{i}]"
    if not isinstance(item, dict):
        raise ConfigError(where, f"expected a mapping {{kind: ..., ...}}, got {kind_of(item)}")
    if "kind" not in item:
        raise ConfigError(f"{where}.kind", f"required parameter is missing (one of {', '.join(ENV_KINDS)})")
    kind = item["kind"]
    if not isinstance(kind, str) or kind not in ENV_MODELS:
        raise ConfigError(f"{where}.kind", f"unknown environment model {fmt_value(kind)} (one of {', '.join(ENV_KINDS)})")
    m = validate_model(ENV_MODELS[kind], item, where)
    if kind in ("locked", "free"):
        return EnvModel(kind), {"kind": kind}
    p = "stiffness" if kind == "spring" else "inertia"
    lo, hi = getattr(m, p)
    return EnvModel(kind, p, lo, hi, damping=m.damping), {"kind": kind, p: [lo, hi], "damping": m.damping}


def _check_nyquist(impl: ImplementationIn) -> None:
    fs = impl.sample_rate_hz
    if fs is None:
        return
    check_delay_samples(impl.delay_s, fs, "implementation.sample_rate_hz")
    for key in FILTER_KEYS:
        f = getattr(impl, key)
        if f is not None and not f.cutoff_hz < fs / 2.0:
            raise ConfigError(
                f"implementation.{key}.cutoff_hz",
                f"{f.cutoff_hz:g} Hz is not below the Nyquist frequency {fs / 2.0:g} Hz "
                f"(implementation.sample_rate_hz = {fs:g} Hz)",
            )


#: The plant parameters a transmission ratio r reflects (× r²), with the kind of their accepted range.
REFLECTED = (("motor_inertia", "motor inertia", "inertia"), ("motor_damping", "motor damping", "damping"),
             ("sea_stiffness", "SEA stiffness", "stiffness"))


def _ratio_window(plant) -> tuple[str, str]:
    """The transmission ratios [–] this plant accepts: within :data:`LIMITS` ``ratio``, and keeping
    every reflected parameter (× ratio²) within its range; both ends as text, rounded inwards to
    four significant digits (so that a ratio written as printed is accepted)."""
    lo, _open, hi, _unit = LIMITS["ratio"]
    for key, _what, kind in REFLECTED:
        x = float(getattr(plant, key))
        a, _open, b, _unit = LIMITS[kind]
        if x > 0:
            lo, hi = max(lo, math.sqrt(a / x)), min(hi, math.sqrt(b / x))

    def inward(v: float, up: bool) -> str:
        q = 10.0 ** (math.floor(math.log10(v)) - 3)
        n = round(v / q, 6)  # (1e-3 / 1e-6 is 1000.0000000000001)
        return fmt_num((math.ceil(n) if up else math.floor(n)) * q, 4)

    return inward(lo, True), inward(hi, False)


def _transmission_errors(plant, transmission) -> list[ConfigError]:
    """One error per ``transmission.ratio`` entry that reflects the motor inertia, motor damping or
    SEA stiffness (the plant's × ratio², as the gain schedule uses them) out of its accepted range
    (docs/design-file.md#input-limits-and-accepted-ranges): the ratio is named, not the plant field
    the analysis would otherwise refuse."""
    errors = []
    for i, r in enumerate(transmission.ratio):
        for key, what, kind in REFLECTED:
            x = float(getattr(plant, key))
            if in_limits(x * r * r, kind):
                continue
            unit = LIMITS[kind][3]
            lo, hi = _ratio_window(plant)
            # enough digits to show why it is out (2.0000001 is not "2" beside a window ending at 2)
            rs = fmt_outside(float(r), lambda v, x=x, kind=kind: in_limits(x * v * v, kind))
            xs = fmt_outside(x * r * r, lambda v, kind=kind: in_limits(v, kind))
            errors.append(ConfigError(
                f"transmission.ratio[{i}]",
                f"the {what} at ratio {rs}, plant.{key} × ratio² = {fmt_num(x)} {unit} × {rs}² = "
                f"{xs} {unit}, is out of the accepted range {limit_text(kind)} (the motor inertia, "
                f"motor damping and SEA stiffness scale with ratio²; with this plant the ratios must lie in "
                f"[{lo}, {hi}] (–); docs/design-file.md#input-limits-and-accepted-ranges)"))
            break
    return errors


def _implementation(impl: ImplementationIn) -> Implementation:
    def f2(f):
        return None if f is None else SecondOrderFilter(f.cutoff_hz, f.damping)

    def f1(f):
        return None if f is None else FirstOrderFilter(f.cutoff_hz)

    return Implementation(
        delay_s=impl.delay_s,
        sample_rate_hz=impl.sample_rate_hz,
        gv_filter=f2(impl.gv_filter),
        derivative_filter=f1(impl.derivative_filter),
        dob=f2(impl.dob),
        velocity_filter=f1(impl.velocity_filter),
        structure=impl.structure,
    )


def refuse_other_kind(mapping: Any, expected: str, source: str | None) -> None:
    """Refuse a file of another kind than ``expected`` with the command that fits it.

    Parameters
    ----------
    mapping : Any
        The file's top-level mapping.
    expected : str
        ``"design"`` (``design``, ``analyze``, ``export``), ``"sea"`` (``sea``) or
        ``"controller"`` (``certify``).
    source : str or None
        The file's name, for the message and the suggested command.

    Raises
    ------
    exotune.errors.ConfigError
        ``<file>: this is an SEA file: use `exotune sea <file>``` and the like.

    References
    ----------
    docs/cli.md (which command reads which file).
    """
    if not isinstance(mapping, dict):
        return
    name = source or "<input>"
    kind = ("controller" if "schema" in mapping else "sea" if "gains" in mapping and "design" not in mapping
            else "design" if "design" in mapping and "gains" not in mapping else None)
    if kind is None or kind == expected:
        return
    hint = {
        "controller": "this is a controller file (written by `exotune export`): use `exotune certify` or "
                      "`exotune simulate` on it",
        "sea": f"this is an SEA file: use `exotune sea {name}`",
        "design": (f"this is a design file: export it first with `exotune export {name} --sample-rate-hz F "
                   "-o CONTROLLER.yaml`, then certify the controller file" if expected == "controller"
                   else f"this is a design file: use `exotune design {name}` or `exotune analyze {name}`"),
    }[kind]
    raise ConfigError(name, hint)


def _attempt(errors: list, fn, *args):
    """``fn(*args)``, or None with its :class:`ConfigError` appended to ``errors``."""
    try:
        return fn(*args)
    except ConfigError as e:
        errors.append(e)
        return None


def _entries(mapping: dict, key: str, validated) -> list:
    """The ``humans``/``environment`` entries to parse: the validated list, or (the top level
    being invalid) the raw list when it is one, so that their errors are listed too."""
    if validated is not None:
        return list(getattr(validated, key) or [])
    items = mapping.get(key)
    return list(items) if isinstance(items, list) else []


def design_from_mapping(mapping: dict, source: str | None = None) -> DesignConfig:
    """Validate a design mapping (docs/design-file.md) and build the model objects.

    Every error of the file is reported: the :class:`ConfigError` raised names the first, its
    ``more`` lines the others (top-level fields, then the humans and environments).

    Parameters
    ----------
    mapping : dict
        The design file's content.
    source : str or None, optional
        Where it was read from (its path), kept in the result and named by top-level errors.

    Returns
    -------
    DesignConfig
        The validated design: plant, design parameters, implementation, humans, environments, the
        normalized ``raw`` mapping, uncertainty and requirements.

    Raises
    ------
    exotune.errors.ConfigError
        For every problem of the mapping (the first one's field and reason, the others in ``more``),
        including gains that are not finite.
    """
    if not isinstance(mapping, dict):
        raise ConfigError(source or "<design>", f"expected a mapping at the top level, got {kind_of(mapping)}")
    refuse_other_kind(mapping, "design", source)
    errors: list[ConfigError] = []
    top = _attempt(errors, validate_model, DesignFileIn, mapping)
    impl_in = None
    if top is not None:
        impl_in = top.implementation if top.implementation is not None else ImplementationIn()
        _attempt(errors, _check_nyquist, impl_in)
        if top.transmission is not None:
            errors.extend(_transmission_errors(top.plant, top.transmission))
    humans, humans_raw, envs, envs_raw = [], [], [], []
    for i, item in enumerate(_entries(mapping, "humans", top)):
        parsed = _attempt(errors, parse_human, i, item)
        if parsed is not None:
            humans.append(parsed[0])
            humans_raw.append(parsed[1])
    for i, item in enumerate(_entries(mapping, "environment", top)):
        parsed = _attempt(errors, parse_env, i, item)
        if parsed is not None:
            envs.append(parsed[0])
            envs_raw.append(parsed[1])
    if errors:
        raise combine_errors(errors)
    p, d = top.plant, top.design
    plant = Plant(p.motor_inertia, p.motor_damping, p.sea_stiffness, p.joint_inertia, p.cuff_stiffness)
    design = DesignParams(d.amplification, d.felt_inertia, d.felt_damping, d.zeta, d.zeta_hat)
    raw = {
        "plant": p.model_dump(),
        "design": d.model_dump(),
        # precision only when given, so that existing implementation sections and spec hashes are unchanged
        "implementation": impl_in.model_dump(exclude={"precision"} if impl_in.precision is None else None),
        "humans": humans_raw,
        "environment": envs_raw,
    }
    if top.transmission is not None:  # only when given, so that existing spec hashes are unchanged
        raw["transmission"] = top.transmission.model_dump()
    unc = None
    if top.uncertainty is not None:  # likewise
        raw["uncertainty"] = top.uncertainty.model_dump()
        given = {k: v for k, v in raw["uncertainty"].items() if v is not None}
        if given and not any(v > 0 for v in given.values()):
            raise ConfigError("uncertainty", "every given relative range is 0: at least one plant parameter must be uncertain")
        unc = {k: given.get(k, 0.0) for k in raw["uncertainty"]} if given else None
    req = None
    if top.requirements is not None:  # likewise
        raw["requirements"] = {k: v for k, v in top.requirements.model_dump().items() if v is not None}
        req = dict(raw["requirements"])
    _check_gains_finite(plant, design)
    return DesignConfig(plant, design, _implementation(impl_in), tuple(humans), tuple(envs), raw, source, unc, req)


def _check_gains_finite(plant, design) -> None:
    """Extreme but valid numbers (e.g. ζ = 1e300) can overflow a gain of the shaping (docs/method.md#double-compliance-shaping): the
    design is refused rather than analysed with infinite gains."""
    from ..model.shaping import double_compliance_shaping

    with np.errstate(over="ignore", invalid="ignore"):
        g = double_compliance_shaping(plant, design).gains
    for k in ("K1", "B1", "K2", "B2", "K2_hat", "B2_hat"):
        v = float(np.ravel(getattr(g, k))[0])
        if not math.isfinite(v):
            raise ConfigError("design", f"the shaping gives the gain {k} = {v!r} (docs/method.md#double-compliance-shaping): the plant and design "
                                        "numbers are too extreme for floating point")


def load_design(path) -> DesignConfig:
    """Read and validate a design file (docs/design-file.md). Every problem raises :class:`ConfigError`.

    Parameters
    ----------
    path : str or os.PathLike
        The design file (YAML or JSON).

    Returns
    -------
    DesignConfig
        The validated design.

    Raises
    ------
    exotune.errors.ConfigError
        When the file cannot be read or parsed, or does not validate.
    """
    name = os.fspath(path)
    return design_from_mapping(read_yaml(name), source=name)


# --------------------------------------------------------------------------------------------
# SEA files
# --------------------------------------------------------------------------------------------
def sea_from_mapping(mapping: dict, source: str | None = None) -> SeaConfig:
    """Validate an SEA mapping ``{plant: {...}, gains: {K1, B1, K2, B2, units}}``.

    ``units`` is required: ``deflection`` (paper eq. (9), K2 [N·m/rad], B2 [N·m·s/rad]) or
    ``torque`` (K2 [–], B2 [s]); the two differ by the factor K_s (docs/method.md#double-compliance-shaping), so guessing is unsafe.

    Parameters
    ----------
    mapping : dict
        The SEA file's content.
    source : str or None, optional
        Where it was read from (its path).

    Returns
    -------
    SeaConfig
        The validated plant and SEA gains.

    Raises
    ------
    exotune.errors.ConfigError
        When the mapping is not a mapping, is a file of another kind, or does not validate.

    References
    ----------
    Paper eq. (9) (the SEA gains in deflection units).
    """
    if not isinstance(mapping, dict):
        raise ConfigError(source or "<sea>", f"expected a mapping at the top level, got {kind_of(mapping)}")
    refuse_other_kind(mapping, "sea", source)
    top = validate_model(SeaFileIn, mapping)
    p, g = top.plant, top.gains
    plant = Plant(p.motor_inertia, p.motor_damping, p.sea_stiffness, p.joint_inertia, p.cuff_stiffness)
    gains = SeaGains(g.K1, g.B1, g.K2, g.B2, g.units)
    return SeaConfig(plant, gains, {"plant": p.model_dump(), "gains": g.model_dump()}, source)


def load_sea(path) -> SeaConfig:
    """Read and validate an SEA file (for ``exotune sea``). Raises :class:`ConfigError`.

    Parameters
    ----------
    path : str or os.PathLike
        The SEA file (YAML or JSON).

    Returns
    -------
    SeaConfig
        The validated plant and SEA gains.

    Raises
    ------
    exotune.errors.ConfigError
        When the file cannot be read or parsed, or does not validate.
    """
    name = os.fspath(path)
    return sea_from_mapping(read_yaml(name), source=name)


# --------------------------------------------------------------------------------------------
# Provenance
# --------------------------------------------------------------------------------------------
def hash_mapping(mapping: Any) -> str:
    """SHA-256 (hex) of the canonical JSON of ``mapping`` (sorted keys, no whitespace, exotune's
    JSON conventions for numpy types and non-finite floats).

    Parameters
    ----------
    mapping : Any
        A JSON-serializable object (numpy values allowed).

    Returns
    -------
    str
        The 64 hex digits of the SHA-256.
    """
    from ..jsonio import to_jsonable

    text = json.dumps(to_jsonable(mapping), sort_keys=True, separators=(",", ":"), ensure_ascii=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()
