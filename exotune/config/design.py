"""Strict loading and validation of design files (SPEC §9) and SEA files (``exotune sea``).

Design file sections (SPEC §2–§4, §9): ``plant``, ``design``, ``implementation``, ``humans``,
``environment``. Validation is strict (SPEC §8): unknown keys, missing parameters, non-numbers,
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
                                        SPEC §3 (denominator s + B̃1) becomes a pure integrator
                                        in the controller (unbounded output for a constant cuff
                                        torque, and C7 gets a double integrator).
design ``zeta`` ζ, ``zeta_hat`` ζ̂       > 0
implementation ``delay_s`` T            ≥ 0 [s] (default 0)
implementation ``sample_rate_hz``       null (continuous-time analysis, default) or > 0 [Hz];
                                        delay_s · sample_rate_hz ≤ 1000 (one state per sample)
filter ``cutoff_hz``                    > 0 [Hz], and < sample_rate_hz/2 (Nyquist) when a
                                        sample rate is set
filter ``damping``                      > 0
implementation ``structure``            ``default`` | ``full_filter`` (see exotune.controller)
range ``[lo, hi]``                      two numbers, 0 < lo ≤ hi (lo = hi is a single value);
                                        a single number v is accepted as [v, v]
human/environment ``damping``           ≥ 0 (default 0) [N·m·s/rad]
complex_stiffness ``eta`` η             0 ≤ η < 10
====================================  =======================================================

Human families (SPEC §2): ``mass`` (``inertia`` range, ``damping``), ``spring`` (``stiffness``
range, ``damping``), ``msd`` (``inertia``, ``damping``, ``stiffness``: each a number or a range,
at least one a range — several make a box; missing ones are 0, but the inertia must be > 0), ``complex_stiffness``
(``stiffness`` range, ``eta``). Environments: ``locked``, ``free``, ``spring`` (``stiffness``
range, ``damping``), ``mass`` (``inertia`` range, ``damping``).

YAML is read with a safe loader only (PyYAML's SafeLoader with YAML 1.2 floats, so ``1e-3`` is a
number); duplicate keys (which PyYAML would otherwise silently resolve to the last value) are
rejected.

Batches (:func:`batch_config`) override plant, design and implementation parameters by dotted path
with 1-D arrays; human and environment families are *not* overridable (they are the uncertainty
sets every design point is checked against, so they are shared by the whole batch).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import re
from dataclasses import dataclass, replace
from typing import Annotated, Any, Callable, Literal, Optional

import numpy as np
import yaml
from pydantic import BaseModel, BeforeValidator, ConfigDict, ValidationError, field_validator

from ..model.controller import STRUCTURES, FirstOrderFilter, Implementation, SecondOrderFilter
from ..errors import ConfigError
from ..model.humans import EnvModel, HumanFamily
from ..model.plant import Plant
from ..model.shaping import DesignParams, SeaGains

__all__ = [
    "DesignConfig",
    "SeaConfig",
    "load_design",
    "design_from_mapping",
    "load_sea",
    "sea_from_mapping",
    "batch_config",
    "hash_mapping",
    "read_yaml",
    "OVERRIDABLE",
    "HUMAN_KINDS",
    "ENV_KINDS",
]

HUMAN_KINDS = ("mass", "spring", "msd", "complex_stiffness")
ENV_KINDS = ("locked", "free", "spring", "mass")


# --------------------------------------------------------------------------------------------
# Public result types
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class DesignConfig:
    """A validated design file (SPEC §9).

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


@dataclass(frozen=True)
class SeaConfig:
    """A validated SEA file for ``exotune sea``: the plant and full-state SEA gains (paper §II-B)."""

    plant: Plant
    gains: SeaGains
    raw: dict | None = None
    source: str | None = None


# --------------------------------------------------------------------------------------------
# Number and range validators (uniform, human-readable reasons)
# --------------------------------------------------------------------------------------------
def _fmt(x: Any) -> str:
    if isinstance(x, float):
        return repr(x) if not math.isfinite(x) else f"{x:g}"
    if isinstance(x, str):
        return repr(x)
    if x is None:
        return "null"
    if isinstance(x, bool):
        return "true" if x else "false"
    return repr(x)


def _to_number(v: Any) -> float:
    """A finite real number (int or float, not bool/str), else ValueError with a clear reason."""
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
        if isinstance(v, str):
            try:
                float(v)
            except ValueError:
                raise ValueError(f"expected a number, got the string {v!r}") from None
            raise ValueError(f"expected a number, got the string {v!r} (a quoted number? remove the quotes)")
        if v is None:
            raise ValueError("expected a number, got null")
        if isinstance(v, bool):
            raise ValueError(f"expected a number, got {_fmt(v)}")
        if isinstance(v, (list, tuple)):
            raise ValueError(f"expected a number, got a list {v!r}")
        if isinstance(v, dict):
            raise ValueError("expected a number, got a mapping")
        raise ValueError(f"expected a number, got {type(v).__name__}")
    try:
        x = float(v)
    except OverflowError:
        raise ValueError(f"the integer {str(v)[:12]}… ({len(str(v))} digits) is too large for a float") from None
    if not math.isfinite(x):
        raise ValueError(f"must be a finite number, got {_fmt(x)}")
    return x


def _bound_check(x: float, gt=None, ge=None, lt=None) -> None:
    if gt is not None and not x > gt:
        raise ValueError(f"must be > {gt:g}, got {_fmt(x)}")
    if ge is not None and not x >= ge:
        raise ValueError(f"must be >= {ge:g}, got {_fmt(x)}")
    if lt is not None and not x < lt:
        raise ValueError(f"must be < {lt:g}, got {_fmt(x)}")


def _number(gt=None, ge=None, lt=None) -> Callable[[Any], float]:
    def check(v: Any) -> float:
        x = _to_number(v)
        _bound_check(x, gt=gt, ge=ge, lt=lt)
        return x

    return check


def _range(v: Any) -> tuple[float, float]:
    """``[lo, hi]`` with 0 < lo <= hi; a single number v means [v, v]."""
    if isinstance(v, (list, tuple)):
        if len(v) != 2:
            raise ValueError(f"a range must be a list [lo, hi] of two numbers, got {len(v)} item(s)")
        out = []
        for name, item in zip(("lo", "hi"), v):
            try:
                out.append(_to_number(item))
            except ValueError as e:
                raise ValueError(f"range {name}: {e}") from None
        lo, hi = out
        if not lo > 0:
            raise ValueError(f"range lo must be > 0, got {_fmt(lo)}")
        if lo > hi:
            raise ValueError(f"malformed range: lo = {lo:g} > hi = {hi:g}")
        return (lo, hi)
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        x = _to_number(v)
        if not x > 0:
            raise ValueError(f"must be > 0, got {_fmt(x)}")
        return (x, x)
    if isinstance(v, str) or v is None or isinstance(v, (bool, dict)):
        raise ValueError(f"expected a range [lo, hi] (or a single number), got {_fmt(v) if not isinstance(v, dict) else 'a mapping'}")
    raise ValueError(f"expected a range [lo, hi], got {type(v).__name__}")


def _range_or_number(v: Any):
    """For msd parameters: a list is a range (tuple), a number is a fixed value (float >= 0)."""
    if isinstance(v, (list, tuple)):
        return _range(v)
    x = _to_number(v)
    if not x >= 0:
        raise ValueError(f"must be >= 0, got {_fmt(x)}")
    return x


Pos = Annotated[float, BeforeValidator(_number(gt=0.0))]
NonNeg = Annotated[float, BeforeValidator(_number(ge=0.0))]
Alpha = Annotated[float, BeforeValidator(_number(ge=1.0))]
Real = Annotated[float, BeforeValidator(_number())]
Eta = Annotated[float, BeforeValidator(_number(ge=0.0, lt=10.0))]
Range = Annotated[tuple[float, float], BeforeValidator(_range)]


def _felt_damping(v: Any) -> float:
    x = _to_number(v)
    if not x > 0:
        raise ValueError(
            f"must be > 0, got {_fmt(x)} (B̂_m = 0 makes B̃1 = 0: C4 gets a double pole at s = 0 "
            "and the cuff compensator G_v an integrator)"
        )
    return x


FeltDamping = Annotated[float, BeforeValidator(_felt_damping)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


# --------------------------------------------------------------------------------------------
# Schema
# --------------------------------------------------------------------------------------------
class PlantIn(_Strict):
    motor_inertia: Pos
    motor_damping: NonNeg
    sea_stiffness: Pos
    joint_inertia: Pos
    cuff_stiffness: Pos


class SeaPlantIn(PlantIn):
    cuff_stiffness: Pos = 300.0


class DesignIn(_Strict):
    amplification: Alpha
    felt_inertia: Pos
    felt_damping: FeltDamping
    zeta: Pos
    zeta_hat: Pos


class Filter2In(_Strict):
    cutoff_hz: Pos
    damping: Pos


class Filter1In(_Strict):
    cutoff_hz: Pos


class ImplementationIn(_Strict):
    delay_s: NonNeg = 0.0
    sample_rate_hz: Optional[Pos] = None
    gv_filter: Optional[Filter2In] = None
    derivative_filter: Optional[Filter1In] = None
    dob: Optional[Filter2In] = None
    velocity_filter: Optional[Filter1In] = None
    structure: str = "default"

    @field_validator("structure", mode="before")
    @classmethod
    def _structure(cls, v):
        if not isinstance(v, str) or v not in STRUCTURES:
            raise ValueError(f"must be one of {', '.join(sorted(STRUCTURES))}, got {_fmt(v)}")
        return v


class TransmissionIn(_Strict):
    """Joint-angle dependent transmission (paper §VI gain scheduling): at ``joint_angle_rad[i]``
    the transmission Jacobian is ``ratio[i]`` times the one the plant section is reflected with,
    so the joint-reflected motor inertia, motor damping and SEA stiffness scale with ratio²."""

    joint_angle_rad: list[Real]
    ratio: list[Pos]

    @field_validator("joint_angle_rad")
    @classmethod
    def _angles(cls, v):
        if len(v) < 2:
            raise ValueError(f"at least two joint angles are needed for a schedule, got {len(v)}")
        if any(b <= a for a, b in zip(v, v[1:])):
            raise ValueError("joint angles must be strictly increasing")
        return v

    @field_validator("ratio")
    @classmethod
    def _ratios(cls, v, info):
        n = len(info.data.get("joint_angle_rad") or [])
        if n and len(v) != n:
            raise ValueError(f"one ratio per joint angle: {n} angle(s), {len(v)} ratio(s)")
        return v


class DesignFileIn(_Strict):
    plant: PlantIn
    design: DesignIn
    implementation: Optional[ImplementationIn] = None
    humans: Optional[list[Any]] = None
    environment: Optional[list[Any]] = None
    transmission: Optional[TransmissionIn] = None


class HumanMassIn(_Strict):
    kind: Literal["mass"]
    inertia: Range
    damping: NonNeg = 0.0


class HumanSpringIn(_Strict):
    kind: Literal["spring"]
    stiffness: Range
    damping: NonNeg = 0.0


class HumanMsdIn(_Strict):
    kind: Literal["msd"]
    inertia: Annotated[Any, BeforeValidator(_range_or_number)] = None
    damping: Annotated[Any, BeforeValidator(_range_or_number)] = None
    stiffness: Annotated[Any, BeforeValidator(_range_or_number)] = None


class HumanComplexIn(_Strict):
    kind: Literal["complex_stiffness"]
    stiffness: Range
    eta: Eta


class EnvLockedIn(_Strict):
    kind: Literal["locked"]


class EnvFreeIn(_Strict):
    kind: Literal["free"]


class EnvSpringIn(_Strict):
    kind: Literal["spring"]
    stiffness: Range
    damping: NonNeg = 0.0


class EnvMassIn(_Strict):
    kind: Literal["mass"]
    inertia: Range
    damping: NonNeg = 0.0


_HUMAN_MODELS = {"mass": HumanMassIn, "spring": HumanSpringIn, "msd": HumanMsdIn, "complex_stiffness": HumanComplexIn}
_ENV_MODELS = {"locked": EnvLockedIn, "free": EnvFreeIn, "spring": EnvSpringIn, "mass": EnvMassIn}


class SeaGainsIn(_Strict):
    K1: Real
    B1: Real
    K2: Real
    B2: Real
    units: str

    @field_validator("units", mode="before")
    @classmethod
    def _units(cls, v):
        if v not in ("deflection", "torque"):
            raise ValueError(
                f"must be 'deflection' (paper eq. extracted: K2 [N·m/rad], B2 [N·m·s/rad]) or "
                f"'torque' (K2 [–], B2 [s]), got {_fmt(v)}"
            )
        return v


class SeaFileIn(_Strict):
    plant: SeaPlantIn
    gains: SeaGainsIn


# --------------------------------------------------------------------------------------------
# ValidationError -> ConfigError
# --------------------------------------------------------------------------------------------
def _join(prefix: str, loc: tuple) -> str:
    out = prefix
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out = f"{out}.{part}" if out else str(part)
    return out


def _unwrap(ann):
    """Optional[X] / list[X] / Annotated[X, ...] -> X (for walking the schema by error location)."""
    import typing

    while True:
        origin = typing.get_origin(ann)
        if origin is typing.Annotated:
            ann = typing.get_args(ann)[0]
        elif origin in (typing.Union, getattr(__import__("types"), "UnionType", None)):
            args = [a for a in typing.get_args(ann) if a is not type(None)]
            if len(args) != 1:
                return ann
            ann = args[0]
        elif origin in (list, tuple):
            args = typing.get_args(ann)
            if not args:
                return ann
            ann = args[0]
        else:
            return ann


def _model_at(model: type[BaseModel], loc: tuple):
    cur: Any = model
    for part in loc:
        if isinstance(part, int):
            continue
        if not (isinstance(cur, type) and issubclass(cur, BaseModel)) or part not in cur.model_fields:
            return None
        cur = _unwrap(cur.model_fields[part].annotation)
    return cur if isinstance(cur, type) and issubclass(cur, BaseModel) else None


def _kind_of(v: Any) -> str:
    if v is None:
        return "null"
    if isinstance(v, bool):
        return "a boolean"
    if isinstance(v, (int, float)):
        return f"the number {_fmt(v)}"
    if isinstance(v, str):
        return f"the string {v!r}"
    if isinstance(v, list):
        return "a list"
    if isinstance(v, dict):
        return "a mapping"
    return type(v).__name__


def _convert(err: ValidationError, model: type[BaseModel], prefix: str) -> ConfigError:
    errors = err.errors(include_url=False)
    e = errors[0]
    loc = tuple(e.get("loc", ()))
    field = _join(prefix, loc) or prefix or "<input>"
    typ = e.get("type", "")
    ctx = e.get("ctx") or {}
    if typ == "extra_forbidden":
        parent = _model_at(model, loc[:-1])
        allowed = ", ".join(parent.model_fields) if parent is not None else ""
        reason = "unknown key" + (f" (allowed keys: {allowed})" if allowed else "")
    elif typ == "missing":
        reason = "required parameter is missing"
    elif typ == "value_error":
        reason = str(ctx.get("error", e.get("msg", "invalid value")))
    elif typ in ("model_type", "model_attributes_type", "dict_type"):
        reason = f"expected a mapping, got {_kind_of(e.get('input'))}"
    elif typ == "list_type":
        reason = f"expected a list, got {_kind_of(e.get('input'))}"
    elif typ == "literal_error":
        reason = f"must be {ctx.get('expected', '')}, got {_fmt(e.get('input'))}"
    else:
        reason = e.get("msg", "invalid value")
    if len(errors) > 1:
        reason += f" (and {len(errors) - 1} more error{'s' if len(errors) > 2 else ''})"
    return ConfigError(field, reason)


def _validate(model: type[BaseModel], data: Any, prefix: str = ""):
    try:
        return model.model_validate(data)
    except ValidationError as err:
        raise _convert(err, model, prefix) from None


# --------------------------------------------------------------------------------------------
# YAML reading
# --------------------------------------------------------------------------------------------
def _check_duplicate_keys(node, path: str = "") -> None:
    if isinstance(node, yaml.MappingNode):
        seen: dict[Any, int] = {}
        for k, v in node.value:
            key = k.value if isinstance(k, yaml.ScalarNode) else None
            sub = _join(path, (str(key),)) if key is not None else path
            if key is not None:
                if key in seen:
                    raise ConfigError(
                        sub, f"duplicate key (line {k.start_mark.line + 1}; first at line {seen[key] + 1})"
                    )
                seen[key] = k.start_mark.line
            _check_duplicate_keys(v, sub)
    elif isinstance(node, yaml.SequenceNode):
        for i, v in enumerate(node.value):
            _check_duplicate_keys(v, f"{path}[{i}]")


class _Loader(yaml.SafeLoader):
    """PyYAML's safe loader with the YAML 1.2 core schema for numbers and booleans.

    PyYAML follows YAML 1.1: an exponent needs a decimal point and a signed exponent (``1e3``,
    ``1e-3`` and even ``1.0e3`` load as *strings*), ``0300`` is octal (192), ``1:30`` is
    sexagesimal (90), ``1_000`` is 1000 and ``yes``/``on``/``off`` are booleans. Engineers write
    delays as ``1e-3`` and may pad numbers with zeros; YAML 1.2 (and JSON) read ``1e-3`` as a
    float, ``0300`` as 300, and ``yes``, ``1:30``, ``1_000`` as strings (which validation then
    refuses, naming the field), and so does exotune. Only the implicit resolvers of int, float
    and bool and the int constructor change: no new tags, no object construction (still a safe
    loader)."""

    def construct_yaml_int(self, node):
        v = self.construct_scalar(node)
        if v.startswith("0o"):
            return int(v[2:], 8)
        if v.startswith("0x"):
            return int(v[2:], 16)
        return int(v, 10)


_YAML11 = ("tag:yaml.org,2002:float", "tag:yaml.org,2002:int", "tag:yaml.org,2002:bool")
_Loader.yaml_implicit_resolvers = {
    ch: [r for r in rs if r[0] not in _YAML11]
    for ch, rs in yaml.SafeLoader.yaml_implicit_resolvers.items()
}
_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:bool", re.compile(r"^(?:true|True|TRUE|false|False|FALSE)$"), list("tTfF"))
_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:int", re.compile(r"^(?:[-+]?[0-9]+|0o[0-7]+|0x[0-9a-fA-F]+)$"), list("-+0123456789"))
_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(
        r"""^(?:[-+]?(?:\.[0-9]+|[0-9]+\.[0-9]*)(?:[eE][-+]?[0-9]+)?
        |[-+]?[0-9]+[eE][-+]?[0-9]+
        |[-+]?\.(?:inf|Inf|INF)
        |\.(?:nan|NaN|NAN))$""",
        re.X,
    ),
    list("-+0123456789."),
)
_Loader.add_constructor("tag:yaml.org,2002:int", _Loader.construct_yaml_int)


def load_yaml_text(text: str):
    """Parse YAML text with exotune's safe loader (:class:`_Loader`, a ``yaml.SafeLoader``
    subclass: what ``yaml.safe_load`` does, with YAML 1.2 numbers and booleans)."""
    loader = _Loader(text)
    try:
        return loader.get_single_data()
    finally:
        loader.dispose()


def read_yaml(path) -> dict:
    """Read a YAML mapping from ``path`` with exotune's safe loader (YAML 1.2 numbers, duplicate
    keys rejected; file-level errors -> :class:`ConfigError` naming the file)."""
    name = os.fspath(path)
    try:
        with open(name, "rb") as fh:
            data = fh.read()
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise ConfigError(name, f"cannot read file: not UTF-8 text ({e.reason} at byte {e.start})") from None
    except OSError as e:
        raise ConfigError(name, f"cannot read file: {e.strerror or e}") from None
    try:
        _check_duplicate_keys(yaml.compose(text, Loader=_Loader))
        mapping = load_yaml_text(text)
    except ConfigError:
        raise
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(e, "problem", None) or str(e)
        raise ConfigError(name, f"invalid YAML: {problem}{where}") from None
    except (ValueError, KeyError, AttributeError, TypeError, OverflowError) as e:
        # an explicit tag whose text does not fit it (``!!bool maybe``, ``!!timestamp abc``,
        # ``!!int 0b11``): PyYAML's constructors raise plain Python errors
        raise ConfigError(name, f"invalid YAML: a value does not fit its explicit tag ({type(e).__name__}: {e})") from None
    if not isinstance(mapping, dict):
        raise ConfigError(name, f"expected a YAML mapping at the top level, got {_kind_of(mapping)}")
    return mapping


# --------------------------------------------------------------------------------------------
# Design files
# --------------------------------------------------------------------------------------------
def parse_human(i: int, item: Any) -> tuple[HumanFamily, dict]:
    where = f"humans[{i}]"
    if not isinstance(item, dict):
        raise ConfigError(where, f"expected a mapping {{kind: ..., ...}}, got {_kind_of(item)}")
    if "kind" not in item:
        raise ConfigError(f"{where}.kind", f"required parameter is missing (one of {', '.join(HUMAN_KINDS)})")
    kind = item["kind"]
    if not isinstance(kind, str) or kind not in _HUMAN_MODELS:
        raise ConfigError(f"{where}.kind", f"unknown human model {_fmt(kind)} (one of {', '.join(HUMAN_KINDS)})")
    m = _validate(_HUMAN_MODELS[kind], item, where)
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
            + ("it is missing" if m.inertia is None else f"got {_fmt(vals['inertia'])}")
            + " (use kind: spring for a massless human)",
        )
    lo, hi = vals[p]
    fixed = {q: (float(v) if not isinstance(v, tuple) else float(v[0])) for q, v in vals.items() if q != p}
    box = tuple((q, float(vals[q][0]), float(vals[q][1])) for q in ranged[1:])
    fam = HumanFamily("msd", p, lo, hi, **fixed, box=box)
    raw = {"kind": "msd", **{q: ([v[0], v[1]] if isinstance(v, tuple) else float(v)) for q, v in vals.items()}}
    return fam, raw


def parse_env(i: int, item: Any) -> tuple[EnvModel, dict]:
    where = f"environment[{i}]"
    if not isinstance(item, dict):
        raise ConfigError(where, f"expected a mapping {{kind: ..., ...}}, got {_kind_of(item)}")
    if "kind" not in item:
        raise ConfigError(f"{where}.kind", f"required parameter is missing (one of {', '.join(ENV_KINDS)})")
    kind = item["kind"]
    if not isinstance(kind, str) or kind not in _ENV_MODELS:
        raise ConfigError(f"{where}.kind", f"unknown environment model {_fmt(kind)} (one of {', '.join(ENV_KINDS)})")
    m = _validate(_ENV_MODELS[kind], item, where)
    if kind in ("locked", "free"):
        return EnvModel(kind), {"kind": kind}
    p = "stiffness" if kind == "spring" else "inertia"
    lo, hi = getattr(m, p)
    return EnvModel(kind, p, lo, hi, damping=m.damping), {"kind": kind, p: [lo, hi], "damping": m.damping}


_FILTER_KEYS = ("gv_filter", "derivative_filter", "dob", "velocity_filter")


def check_delay_samples(delay_s: float, fs: float, field: str) -> None:
    """The exact sampled-data model (SPEC §5) represents the delay by ⌈T·f_s⌉ shift states, in dense
    matrices: more than MAX_DELAY_SAMPLES of them (e.g. 1 ms at 1 GHz: a million) is refused
    up front rather than running out of memory."""
    n = float(delay_s) * float(fs)
    if n > MAX_DELAY_SAMPLES:
        raise ConfigError(field, f"{fs:g} Hz makes the {float(delay_s) * 1e3:g} ms delay {n:.3g} samples; the "
                                 f"sampled-data model holds one state per sample (limit {MAX_DELAY_SAMPLES})")


MAX_DELAY_SAMPLES = 200  # the sampled-data model holds one shift state per sample of delay (dense eigenvalue
# problems: 200 samples already make a ~230-state loop, ~40 s for an export; 1 ms at 200 kHz)


def _check_nyquist(impl: ImplementationIn) -> None:
    fs = impl.sample_rate_hz
    if fs is None:
        return
    check_delay_samples(impl.delay_s, fs, "implementation.sample_rate_hz")
    for key in _FILTER_KEYS:
        f = getattr(impl, key)
        if f is not None and not f.cutoff_hz < fs / 2.0:
            raise ConfigError(
                f"implementation.{key}.cutoff_hz",
                f"{f.cutoff_hz:g} Hz is not below the Nyquist frequency {fs / 2.0:g} Hz "
                f"(implementation.sample_rate_hz = {fs:g} Hz)",
            )


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


def design_from_mapping(mapping: dict, source: str | None = None) -> DesignConfig:
    """Validate a design mapping (SPEC §9) and build the model objects. Raises ConfigError."""
    if not isinstance(mapping, dict):
        raise ConfigError(source or "<design>", f"expected a mapping at the top level, got {_kind_of(mapping)}")
    top = _validate(DesignFileIn, mapping)
    impl_in = top.implementation if top.implementation is not None else ImplementationIn()
    _check_nyquist(impl_in)
    humans_in = top.humans or []
    env_in = top.environment or []
    humans, humans_raw = [], []
    for i, item in enumerate(humans_in):
        fam, raw = parse_human(i, item)
        humans.append(fam)
        humans_raw.append(raw)
    envs, envs_raw = [], []
    for i, item in enumerate(env_in):
        env, raw = parse_env(i, item)
        envs.append(env)
        envs_raw.append(raw)
    p, d = top.plant, top.design
    plant = Plant(p.motor_inertia, p.motor_damping, p.sea_stiffness, p.joint_inertia, p.cuff_stiffness)
    design = DesignParams(d.amplification, d.felt_inertia, d.felt_damping, d.zeta, d.zeta_hat)
    raw = {
        "plant": p.model_dump(),
        "design": d.model_dump(),
        "implementation": impl_in.model_dump(),
        "humans": humans_raw,
        "environment": envs_raw,
    }
    if top.transmission is not None:  # only when given, so that existing spec hashes are unchanged
        raw["transmission"] = top.transmission.model_dump()
    _check_gains_finite(plant, design)
    return DesignConfig(plant, design, _implementation(impl_in), tuple(humans), tuple(envs), raw, source)


def check_analysis_filters(impl, prefix: str = "") -> None:
    """The analysis needs the G_v and derivative filters (SPEC §3): without them the cuff path
    G_v(s)(K̂2 + B̂2 s) is improper. ``prefix`` names where the implementation sits (``base.``)."""
    for key in ("gv_filter", "derivative_filter"):
        if getattr(impl, key) is None:
            raise ConfigError(f"{prefix}implementation.{key}",
                              "required for analysis: the ideal cuff path G_v(s)(K̂2 + B̂2 s) is improper (SPEC §3)")


def _check_gains_finite(plant, design) -> None:
    """Extreme but valid numbers (e.g. ζ = 1e300) can overflow a gain of the shaping (SPEC §4): the
    design is refused rather than analysed with infinite gains."""
    from ..model.shaping import double_compliance_shaping

    with np.errstate(over="ignore", invalid="ignore"):
        g = double_compliance_shaping(plant, design).gains
    for k in ("K1", "B1", "K2", "B2", "K2_hat", "B2_hat"):
        v = float(np.ravel(getattr(g, k))[0])
        if not math.isfinite(v):
            raise ConfigError("design", f"the shaping gives the gain {k} = {v!r} (SPEC §4): the plant and design "
                                        "numbers are too extreme for floating point")


def load_design(path) -> DesignConfig:
    """Read and validate a design file (SPEC §9). Every problem raises :class:`ConfigError`."""
    name = os.fspath(path)
    return design_from_mapping(read_yaml(name), source=name)


# --------------------------------------------------------------------------------------------
# SEA files
# --------------------------------------------------------------------------------------------
def sea_from_mapping(mapping: dict, source: str | None = None) -> SeaConfig:
    """Validate an SEA mapping ``{plant: {...}, gains: {K1, B1, K2, B2, units}}``.

    ``units`` is required: ``deflection`` (paper eq. extracted, K2 [N·m/rad], B2 [N·m·s/rad]) or
    ``torque`` (K2 [–], B2 [s]); the two differ by the factor K_s (SPEC §4), so guessing is unsafe.
    """
    if not isinstance(mapping, dict):
        raise ConfigError(source or "<sea>", f"expected a mapping at the top level, got {_kind_of(mapping)}")
    top = _validate(SeaFileIn, mapping)
    p, g = top.plant, top.gains
    plant = Plant(p.motor_inertia, p.motor_damping, p.sea_stiffness, p.joint_inertia, p.cuff_stiffness)
    gains = SeaGains(g.K1, g.B1, g.K2, g.B2, g.units)
    return SeaConfig(plant, gains, {"plant": p.model_dump(), "gains": g.model_dump()}, source)


def load_sea(path) -> SeaConfig:
    """Read and validate an SEA file (for ``exotune sea``). Raises :class:`ConfigError`."""
    name = os.fspath(path)
    return sea_from_mapping(read_yaml(name), source=name)


# --------------------------------------------------------------------------------------------
# Batches
# --------------------------------------------------------------------------------------------
#: Overridable dotted paths and their rule: (strict lower bound?, bound).
OVERRIDABLE: dict[str, tuple[str, float]] = {
    "plant.motor_inertia": (">", 0.0),
    "plant.motor_damping": (">=", 0.0),
    "plant.sea_stiffness": (">", 0.0),
    "plant.joint_inertia": (">", 0.0),
    "plant.cuff_stiffness": (">", 0.0),
    "design.amplification": (">=", 1.0),
    "design.felt_inertia": (">", 0.0),
    "design.felt_damping": (">", 0.0),
    "design.zeta": (">", 0.0),
    "design.zeta_hat": (">", 0.0),
    "implementation.delay_s": (">=", 0.0),
    "implementation.gv_filter.cutoff_hz": (">", 0.0),
    "implementation.gv_filter.damping": (">", 0.0),
    "implementation.derivative_filter.cutoff_hz": (">", 0.0),
    "implementation.dob.cutoff_hz": (">", 0.0),
    "implementation.dob.damping": (">", 0.0),
    "implementation.velocity_filter.cutoff_hz": (">", 0.0),
}


def _override_values(path: str, values: Any) -> np.ndarray:
    try:
        arr = np.asarray(values)
    except Exception as e:  # pragma: no cover - asarray rarely fails
        raise ConfigError(path, f"cannot convert the values to an array: {e}") from None
    if arr.dtype.kind not in "iuf":
        raise ConfigError(path, f"expected real numbers, got array of dtype {arr.dtype}")
    arr = arr.astype(float)
    if arr.ndim != 1 or arr.size == 0:
        raise ConfigError(path, f"expected a non-empty 1-D array, got shape {arr.shape}")
    bad = np.flatnonzero(~np.isfinite(arr))
    if bad.size:
        i = int(bad[0])
        raise ConfigError(path, f"value {_fmt(float(arr[i]))} at index {i} is not a finite number")
    op, bound = OVERRIDABLE[path]
    ok = arr > bound if op == ">" else arr >= bound
    bad = np.flatnonzero(~ok)
    if bad.size:
        i = int(bad[0])
        neg = "<=" if op == ">" else "<"
        raise ConfigError(path, f"value {arr[i]:g} at index {i} is {neg} {bound:g} (must be {op} {bound:g})")
    return arr


def batch_config(cfg: DesignConfig, overrides: dict[str, np.ndarray]) -> DesignConfig:
    """A batch of N designs: ``cfg`` with parameters replaced by 1-D arrays of equal length N.

    ``overrides`` maps dotted paths of the design file (see :data:`OVERRIDABLE`, e.g.
    ``design.amplification``, ``implementation.gv_filter.cutoff_hz``, ``plant.cuff_stiffness``)
    to arrays. Every Plant/DesignParams/Implementation number of the result is a float array of
    length N (non-overridden values broadcast); ``sample_rate_hz`` and ``structure`` stay scalars
    shared by the batch. Values are validated with the design-file rules (including the Nyquist
    limit of filter cutoffs). Humans and environments are not overridable: they are the
    uncertainty sets shared by every design point. ``raw`` keeps describing the base design.
    With no overrides N = 1.
    """
    n: int | None = None
    first = None
    vals: dict[str, np.ndarray] = {}
    for path, values in overrides.items():
        if path not in OVERRIDABLE:
            head = path.split(".", 1)[0].split("[", 1)[0]
            if head in ("humans", "environment"):
                reason = "human and environment families are not overridable (they are shared by the whole batch)"
            elif path in ("implementation.sample_rate_hz", "implementation.structure"):
                reason = "not overridable (a batch shares one sample rate and one controller structure)"
            else:
                reason = "unknown or non-overridable parameter (overridable: " + ", ".join(OVERRIDABLE) + ")"
            raise ConfigError(path, reason)
        arr = _override_values(path, values)
        if n is None:
            n, first = arr.size, path
        elif arr.size != n:
            raise ConfigError(path, f"has {arr.size} values but {first} has {n}; all overrides need the same length")
        vals[path] = arr
    n = 1 if n is None else n

    impl = cfg.implementation
    fs = impl.sample_rate_hz
    if fs is not None and "implementation.delay_s" in vals:
        i = int(np.argmax(vals["implementation.delay_s"]))
        try:
            check_delay_samples(vals["implementation.delay_s"][i], fs, "implementation.delay_s")
        except ConfigError as e:
            raise ConfigError(e.field, f"value at index {i}: {e.reason}") from None
    for key in _FILTER_KEYS:
        sub = [p for p in vals if p.startswith(f"implementation.{key}.")]
        if sub and getattr(impl, key) is None:
            raise ConfigError(
                sub[0], f"implementation.{key} is null in the base design; give it a value there to sweep its parameters"
            )
        if fs is not None and f"implementation.{key}.cutoff_hz" in vals:
            arr = vals[f"implementation.{key}.cutoff_hz"]
            bad = np.flatnonzero(~(arr < fs / 2.0))
            if bad.size:
                i = int(bad[0])
                raise ConfigError(
                    f"implementation.{key}.cutoff_hz",
                    f"value {arr[i]:g} at index {i} is not below the Nyquist frequency {fs / 2.0:g} Hz",
                )

    def get(path: str, base) -> np.ndarray:
        if path in vals:
            return vals[path]
        return np.full(n, float(base))

    plant = Plant(**{k: get(f"plant.{k}", v) for k, v in cfg.plant.as_dict().items()})
    design = DesignParams(
        **{k: get(f"design.{k}", getattr(cfg.design, k)) for k in DesignParams.__dataclass_fields__}
    )

    def filt(key):
        f = getattr(impl, key)
        if f is None:
            return None
        kw = {k: get(f"implementation.{key}.{k}", getattr(f, k)) for k in type(f).__dataclass_fields__}
        return type(f)(**kw)

    new_impl = replace(
        impl,
        delay_s=get("implementation.delay_s", impl.delay_s),
        gv_filter=filt("gv_filter"),
        derivative_filter=filt("derivative_filter"),
        dob=filt("dob"),
        velocity_filter=filt("velocity_filter"),
    )
    return replace(cfg, plant=plant, design=design, implementation=new_impl)


# --------------------------------------------------------------------------------------------
# Provenance
# --------------------------------------------------------------------------------------------
def hash_mapping(mapping: Any) -> str:
    """SHA-256 (hex) of the canonical JSON of ``mapping`` (sorted keys, no whitespace, exotune's
    JSON conventions for numpy types and non-finite floats)."""
    from ..jsonio import to_jsonable

    text = json.dumps(to_jsonable(mapping), sort_keys=True, separators=(",", ":"), ensure_ascii=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()
