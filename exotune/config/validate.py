"""Number validators, single-field checks and the translation of pydantic's errors into
:class:`~exotune.errors.ConfigError` (a dotted field path and a human-readable reason).

Every number of a design file goes through :func:`to_number` (finite int or float; booleans,
strings, null and lists are refused with a reason naming what was found) and a bound check; ranges
``[lo, hi]`` through :func:`range_pair`. The annotated types (:data:`Pos`, :data:`NonNeg`, …) attach
these validators to the fields of :mod:`exotune.config.schema`. :func:`validate_model` runs a schema
model and turns the first validation error into one ``ConfigError`` (the number of further errors
is appended to its reason).
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Callable

import numpy as np
from pydantic import BaseModel, BeforeValidator, ValidationError

from ..errors import ConfigError

__all__ = [
    "fmt_value",
    "to_number",
    "range_pair",
    "range_or_number",
    "kind_of",
    "join_path",
    "validate_model",
    "check_delay_samples",
    "check_analysis_filters",
    "MAX_DELAY_SAMPLES",
    "FILTER_KEYS",
    "Pos",
    "NonNeg",
    "Alpha",
    "Real",
    "Eta",
    "Range",
    "FeltDamping",
]

FILTER_KEYS = ("gv_filter", "derivative_filter", "dob", "velocity_filter")  # the optional filters of an implementation


# --------------------------------------------------------------------------------------------
# Number and range validators (uniform, human-readable reasons)
# --------------------------------------------------------------------------------------------
def fmt_value(x: Any) -> str:
    """A value as the error messages show it: ``g`` format for finite floats, ``repr`` for
    non-finite ones and strings, ``null``/``true``/``false`` for YAML's null and booleans.

    Parameters
    ----------
    x : Any
        The offending value.

    Returns
    -------
    str
        Its text in a :class:`~exotune.errors.ConfigError` reason.
    """
    if isinstance(x, float):
        return repr(x) if not math.isfinite(x) else f"{x:g}"
    if isinstance(x, str):
        return repr(x)
    if x is None:
        return "null"
    if isinstance(x, bool):
        return "true" if x else "false"
    return repr(x)


def to_number(v: Any) -> float:
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
            raise ValueError(f"expected a number, got {fmt_value(v)}")
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
        raise ValueError(f"must be a finite number, got {fmt_value(x)}")
    return x


def _bound_check(x: float, gt=None, ge=None, lt=None) -> None:
    if gt is not None and not x > gt:
        raise ValueError(f"must be > {gt:g}, got {fmt_value(x)}")
    if ge is not None and not x >= ge:
        raise ValueError(f"must be >= {ge:g}, got {fmt_value(x)}")
    if lt is not None and not x < lt:
        raise ValueError(f"must be < {lt:g}, got {fmt_value(x)}")


def _number(gt=None, ge=None, lt=None) -> Callable[[Any], float]:
    def check(v: Any) -> float:
        x = to_number(v)
        _bound_check(x, gt=gt, ge=ge, lt=lt)
        return x

    return check


def range_pair(v: Any) -> tuple[float, float]:
    """``[lo, hi]`` with 0 < lo <= hi; a single number v means [v, v]."""
    if isinstance(v, (list, tuple)):
        if len(v) != 2:
            raise ValueError(f"a range must be a list [lo, hi] of two numbers, got {len(v)} item(s)")
        out = []
        for name, item in zip(("lo", "hi"), v):
            try:
                out.append(to_number(item))
            except ValueError as e:
                raise ValueError(f"range {name}: {e}") from None
        lo, hi = out
        if not lo > 0:
            raise ValueError(f"range lo must be > 0, got {fmt_value(lo)}")
        if lo > hi:
            raise ValueError(f"malformed range: lo = {lo:g} > hi = {hi:g}")
        return (lo, hi)
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        x = to_number(v)
        if not x > 0:
            raise ValueError(f"must be > 0, got {fmt_value(x)}")
        return (x, x)
    if isinstance(v, str) or v is None or isinstance(v, (bool, dict)):
        raise ValueError(f"expected a range [lo, hi] (or a single number), got {fmt_value(v) if not isinstance(v, dict) else 'a mapping'}")
    raise ValueError(f"expected a range [lo, hi], got {type(v).__name__}")


def range_or_number(v: Any):
    """For msd parameters: a list is a range (tuple), a number is a fixed value (float >= 0)."""
    if isinstance(v, (list, tuple)):
        return range_pair(v)
    x = to_number(v)
    if not x >= 0:
        raise ValueError(f"must be >= 0, got {fmt_value(x)}")
    return x


Pos = Annotated[float, BeforeValidator(_number(gt=0.0))]
NonNeg = Annotated[float, BeforeValidator(_number(ge=0.0))]
Alpha = Annotated[float, BeforeValidator(_number(ge=1.0))]
Real = Annotated[float, BeforeValidator(_number())]
Eta = Annotated[float, BeforeValidator(_number(ge=0.0, lt=10.0))]
Range = Annotated[tuple[float, float], BeforeValidator(range_pair)]


def _felt_damping(v: Any) -> float:
    x = to_number(v)
    if not x > 0:
        raise ValueError(
            f"must be > 0, got {fmt_value(x)} (B̂_m = 0 makes B̃1 = 0: C4 gets a double pole at s = 0 "
            "and the cuff compensator G_v an integrator)"
        )
    return x


FeltDamping = Annotated[float, BeforeValidator(_felt_damping)]


# --------------------------------------------------------------------------------------------
# ValidationError -> ConfigError
# --------------------------------------------------------------------------------------------
def kind_of(v: Any) -> str:
    """What a value is, for a reason: ``null``, ``a boolean``, ``the number 3``, ``the string 'x'``,
    ``a list``, ``a mapping`` (else the type's name)."""
    if v is None:
        return "null"
    if isinstance(v, bool):
        return "a boolean"
    if isinstance(v, (int, float)):
        return f"the number {fmt_value(v)}"
    if isinstance(v, str):
        return f"the string {v!r}"
    if isinstance(v, list):
        return "a list"
    if isinstance(v, dict):
        return "a mapping"
    return type(v).__name__


def join_path(prefix: str, loc: tuple) -> str:
    """The dotted field path of ``loc`` (a pydantic error location) under ``prefix``:
    ``join_path("humans[0]", ("inertia",))`` is ``humans[0].inertia``, list indices in brackets."""
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


def _convert(err: ValidationError, model: type[BaseModel], prefix: str) -> ConfigError:
    errors = err.errors(include_url=False)
    e = errors[0]
    loc = tuple(e.get("loc", ()))
    field = join_path(prefix, loc) or prefix or "<input>"
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
        reason = f"expected a mapping, got {kind_of(e.get('input'))}"
    elif typ == "list_type":
        reason = f"expected a list, got {kind_of(e.get('input'))}"
    elif typ == "literal_error":
        reason = f"must be {ctx.get('expected', '')}, got {fmt_value(e.get('input'))}"
    else:
        reason = e.get("msg", "invalid value")
    if len(errors) > 1:
        reason += f" (and {len(errors) - 1} more error{'s' if len(errors) > 2 else ''})"
    return ConfigError(field, reason)


def validate_model(model: type[BaseModel], data: Any, prefix: str = ""):
    """``model.model_validate(data)``, its first error raised as a :class:`ConfigError` naming the
    field under ``prefix`` (e.g. ``humans[0]``)."""
    try:
        return model.model_validate(data)
    except ValidationError as err:
        raise _convert(err, model, prefix) from None


# --------------------------------------------------------------------------------------------
# Checks of single fields
# --------------------------------------------------------------------------------------------
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


def check_analysis_filters(impl, prefix: str = "") -> None:
    """The analysis needs the G_v and derivative filters (SPEC §3): without them the cuff path
    G_v(s)(K̂2 + B̂2 s) is improper. ``prefix`` names where the implementation sits (``base.``)."""
    for key in ("gv_filter", "derivative_filter"):
        if getattr(impl, key) is None:
            raise ConfigError(f"{prefix}implementation.{key}",
                              "required for analysis: the ideal cuff path G_v(s)(K̂2 + B̂2 s) is improper (SPEC §3)")
