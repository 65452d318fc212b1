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

from ..errors import ConfigError, combine_errors

__all__ = [
    "excerpt",
    "fmt_value",
    "fmt_outside",
    "to_number",
    "number_field",
    "range_pair",
    "range_or_number",
    "kind_of",
    "join_path",
    "did_you_mean",
    "validate_model",
    "pydantic_reason",
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
    "LIMITS",
    "fmt_limit",
    "limit_text",
    "in_limits",
    "check_limit",
    "Inertia",
    "Damping",
    "Stiffness",
    "Amplification",
    "DampingRatio",
    "Delay",
    "Frequency",
    "SeaGain",
    "Ratio",
    "Angle",
    "InertiaRange",
    "StiffnessRange",
    "MsdInertia",
    "MsdDamping",
    "MsdStiffness",
]

FILTER_KEYS = ("gv_filter", "derivative_filter", "dob", "velocity_filter")  # the optional filters of an implementation


# --------------------------------------------------------------------------------------------
# Number and range validators (uniform, human-readable reasons)
# --------------------------------------------------------------------------------------------
EXCERPT_CHARS = 80  # error messages quote at most this many characters of a user's text


def excerpt(text: str, limit: int = EXCERPT_CHARS) -> str:
    """``text`` cut to ``limit`` characters (an ellipsis and the total length mark a cut), so an
    error never prints a whole file (``base: /etc/passwd`` read as a YAML string).

    Parameters
    ----------
    text : str
        A text taken from the user's input.
    limit : int
        The most characters kept.

    Returns
    -------
    str
        The excerpt.
    """
    text = str(text)
    if len(text) <= limit:
        return text
    return f"{text[:limit]}… ({len(text)} characters)"


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
        return repr(x) if len(x) <= EXCERPT_CHARS else f"{x[:EXCERPT_CHARS]!r}… ({len(x)} characters)"
    if x is None:
        return "null"
    if isinstance(x, bool):
        return "true" if x else "false"
    return excerpt(repr(x))


def to_number(v: Any) -> float:
    """A finite real number (int or float, not bool/str), else ValueError with a clear reason.

    Parameters
    ----------
    v : Any
        The value read from a file.

    Returns
    -------
    float
        The value as a finite float.

    Raises
    ------
    ValueError
        When ``v`` is not an int or float (a bool, a string, null, a list, a mapping), is not
        finite, or is an integer too large for a float.
    """
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
        if isinstance(v, str):
            try:
                float(v)
            except ValueError:
                raise ValueError(f"expected a number, got the string {fmt_value(v)}") from None
            raise ValueError(f"expected a number, got the string {fmt_value(v)} (a quoted number? remove the quotes)")
        if v is None:
            raise ValueError("expected a number, got null")
        if isinstance(v, bool):
            raise ValueError(f"expected a number, got {fmt_value(v)}")
        if isinstance(v, (list, tuple)):
            raise ValueError(f"expected a number, got a list {excerpt(repr(v))}")
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


def number_field(field: str, v: Any) -> float:
    """:func:`to_number` for a spec's field: a finite real number, else a
    :class:`~exotune.errors.ConfigError` naming ``field`` with :func:`to_number`'s reason (the one
    wording of every file exotune reads: design, sweep spec, optimize spec).

    Parameters
    ----------
    field : str
        Dotted field path named by the error (e.g. ``design.amplification``).
    v : Any
        The value read from the file.

    Returns
    -------
    float
        The value as a finite float.

    Raises
    ------
    exotune.errors.ConfigError
        When ``v`` is not a finite real number.
    """
    try:
        return to_number(v)
    except ValueError as e:
        raise ConfigError(field, str(e)) from None


def fmt_outside(x: float, accepted) -> str:
    """``x`` as a message refusing it shows it: :func:`fmt_value`'s short form, unless that form
    reads as an accepted value (10000.0000001 printed ``10000`` beside the range ``[1, 1e4]``), then
    the shortest text that reads back exactly (``repr``: ``10000.0000001``), which shows why it is
    refused.

    Parameters
    ----------
    x : float
        The refused value.
    accepted : callable
        ``accepted(v)`` is True for a value the check accepts.

    Returns
    -------
    str
        The value's text.

    References
    ----------
    docs/design-file.md#errors; docs/design-file.md#input-limits-and-accepted-ranges.

    Examples
    --------
    >>> fmt_outside(10000.0000001, lambda v: 1 <= v <= 1e4)
    '10000.0000001'
    >>> fmt_outside(2e4, lambda v: 1 <= v <= 1e4)
    '20000'
    """
    text = fmt_value(x)
    if isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x):
        try:
            shown = float(text)
        except ValueError:
            return text
        if accepted(shown):
            return repr(float(x))
    return text


def _bound_check(x: float, gt=None, ge=None, lt=None) -> None:
    if gt is not None and not x > gt:
        raise ValueError(f"must be > {gt:g}, got {fmt_outside(x, lambda v: v > gt)}")
    if ge is not None and not x >= ge:
        raise ValueError(f"must be >= {ge:g}, got {fmt_outside(x, lambda v: v >= ge)}")
    if lt is not None and not x < lt:
        raise ValueError(f"must be < {lt:g}, got {fmt_outside(x, lambda v: v < lt)}")


# --------------------------------------------------------------------------------------------
# Accepted magnitudes (physically meaningful, and safe for every kernel)
# --------------------------------------------------------------------------------------------
#: The accepted range of each kind of number: ``kind -> (lo, lo_open, hi, unit)``, i.e. the
#: interval ``[lo, hi]`` (``(lo, hi]`` when ``lo_open``). SI units, joint-reflected. Values
#: outside are refused at validation, naming the field and the range
#: (docs/design-file.md#input-limits-and-accepted-ranges); inside, no kernel overflows.
LIMITS: dict[str, tuple[float, bool, float, str]] = {
    "inertia": (1e-9, False, 1e6, "kg·m²"),
    "damping": (0.0, False, 1e7, "N·m·s/rad"),
    "felt_damping": (1e-6, False, 1e7, "N·m·s/rad"),
    "stiffness": (1e-6, False, 1e9, "N·m/rad"),
    "amplification": (1.0, False, 1e4, "–"),
    "damping_ratio": (1e-3, False, 1e3, "–"),
    "delay": (0.0, False, 1.0, "s"),
    "frequency": (1e-3, False, 1e7, "Hz"),
    "sea_gain": (-1e9, False, 1e9, ""),  # K1, B1, K2, B2 of an SEA file, in their units
    "ratio": (1e-3, False, 1e3, "–"),
    "angle": (-100.0, False, 100.0, "rad"),
}


def fmt_limit(x: float) -> str:
    """A limit as the messages print it: ``0``, ``0.001``, ``1e-9``, ``1e6``, ``-1e9``.

    Parameters
    ----------
    x : float
        The limit.

    Returns
    -------
    str
        Its shortest form in the messages.
    """
    if x == 0:
        return "0"
    if 1e-3 <= abs(x) < 1e4:
        return f"{x:g}"
    m, e = f"{x:e}".split("e")
    m = m.rstrip("0").rstrip(".")
    return f"{m}e{int(e)}"


def limit_text(kind: str) -> str:
    """The accepted range of ``kind`` (a key of :data:`LIMITS`) as text: ``[1e-9, 1e6] kg·m²``.

    Parameters
    ----------
    kind : str
        A key of :data:`LIMITS` (``"inertia"``, ``"stiffness"``, …).

    Returns
    -------
    str
        The range in interval notation (``(`` for an open lower end) followed by the unit.
    """
    lo, lo_open, hi, unit = LIMITS[kind]
    return f"{'(' if lo_open else '['}{fmt_limit(lo)}, {fmt_limit(hi)}] {unit}".rstrip()


def in_limits(x: float, kind: str) -> bool:
    """Whether ``x`` lies in the accepted range of ``kind`` (:data:`LIMITS`).

    Parameters
    ----------
    x : float
        The value, in the unit of ``kind``.
    kind : str
        A key of :data:`LIMITS`.

    Returns
    -------
    bool
        True when ``x`` is within the range (the lower end excluded when it is open).
    """
    lo, lo_open, hi, _unit = LIMITS[kind]
    return (x > lo if lo_open else x >= lo) and x <= hi


def check_limit(x: float, kind: str) -> float:
    """``x`` if it lies in the accepted range of ``kind``, else ValueError naming the range.

    Parameters
    ----------
    x : float
        A finite number.
    kind : str
        A key of :data:`LIMITS` (``"inertia"``, ``"frequency"``, …).

    Returns
    -------
    float
        ``x``.

    References
    ----------
    docs/design-file.md#input-limits-and-accepted-ranges.
    """
    if not in_limits(x, kind):
        raise ValueError(f"out of the accepted range: must be in {limit_text(kind)}, got "
                         f"{fmt_outside(x, lambda v: in_limits(v, kind))} "
                         "(docs/design-file.md#input-limits-and-accepted-ranges)")
    return x


def _number(gt=None, ge=None, lt=None, limit: str | None = None) -> Callable[[Any], float]:
    def check(v: Any) -> float:
        x = to_number(v)
        _bound_check(x, gt=gt, ge=ge, lt=lt)
        if limit is not None:
            check_limit(x, limit)
        return x

    return check


def range_pair(v: Any, limit: str | None = None) -> tuple[float, float]:
    """``[lo, hi]`` with 0 < lo <= hi (both within the accepted range of ``limit``, a key of
    :data:`LIMITS`, when given); a single number v means [v, v].

    Parameters
    ----------
    v : Any
        A list ``[lo, hi]`` of two numbers, or a single number.
    limit : str or None, optional
        A key of :data:`LIMITS` whose range both ends must lie in; None for no limit.

    Returns
    -------
    tuple of float
        ``(lo, hi)``, in the unit of the field.

    Raises
    ------
    ValueError
        When ``v`` is not a range or number, an end is not a finite number, lo ≤ 0, lo > hi, or an
        end lies outside the range of ``limit``.
    """
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
            shown = (f"{lo:g}", f"{hi:g}") if f"{lo:g}" != f"{hi:g}" else (repr(lo), repr(hi))
            raise ValueError(f"malformed range: lo = {shown[0]} > hi = {shown[1]}")
        if limit is not None:
            for name, x in (("lo", lo), ("hi", hi)):
                try:
                    check_limit(x, limit)
                except ValueError as e:
                    raise ValueError(f"range {name}: {e}") from None
        return (lo, hi)
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        x = to_number(v)
        if not x > 0:
            raise ValueError(f"must be > 0, got {fmt_value(x)}")
        if limit is not None:
            check_limit(x, limit)
        return (x, x)
    if isinstance(v, str) or v is None or isinstance(v, (bool, dict)):
        raise ValueError(f"expected a range [lo, hi] (or a single number), got {fmt_value(v) if not isinstance(v, dict) else 'a mapping'}")
    raise ValueError(f"expected a range [lo, hi], got {type(v).__name__}")


def range_or_number(v: Any, limit: str | None = None):
    """For msd parameters: a list is a range (tuple), a number is a fixed value (float >= 0;
    a nonzero one within the accepted range of ``limit``, a key of :data:`LIMITS`, when given).

    Parameters
    ----------
    v : Any
        A list ``[lo, hi]`` (a range) or a single number (a fixed value).
    limit : str or None, optional
        A key of :data:`LIMITS`; None for no limit.

    Returns
    -------
    tuple of float or float
        ``(lo, hi)`` for a list (:func:`range_pair`), else the fixed value (≥ 0).

    Raises
    ------
    ValueError
        When the range is malformed, the number is not finite or negative, or a value lies outside
        the range of ``limit``.
    """
    if isinstance(v, (list, tuple)):
        return range_pair(v, limit)
    x = to_number(v)
    if not x >= 0:
        raise ValueError(f"must be >= 0, got {fmt_value(x)}")
    if limit is not None and x != 0:
        check_limit(x, limit)
    return x


def _ranged(limit: str):
    return lambda v: range_pair(v, limit)


def _range_or_number(limit: str):
    return lambda v: range_or_number(v, limit)


Pos = Annotated[float, BeforeValidator(_number(gt=0.0))]
NonNeg = Annotated[float, BeforeValidator(_number(ge=0.0))]
Alpha = Annotated[float, BeforeValidator(_number(ge=1.0))]
Real = Annotated[float, BeforeValidator(_number())]
Eta = Annotated[float, BeforeValidator(_number(ge=0.0, lt=10.0))]
Range = Annotated[tuple[float, float], BeforeValidator(range_pair)]
Inertia = Annotated[float, BeforeValidator(_number(gt=0.0, limit="inertia"))]
Damping = Annotated[float, BeforeValidator(_number(ge=0.0, limit="damping"))]
Stiffness = Annotated[float, BeforeValidator(_number(gt=0.0, limit="stiffness"))]
Amplification = Annotated[float, BeforeValidator(_number(ge=1.0, limit="amplification"))]
DampingRatio = Annotated[float, BeforeValidator(_number(gt=0.0, limit="damping_ratio"))]
Delay = Annotated[float, BeforeValidator(_number(ge=0.0, limit="delay"))]
Frequency = Annotated[float, BeforeValidator(_number(gt=0.0, limit="frequency"))]
SeaGain = Annotated[float, BeforeValidator(_number(limit="sea_gain"))]
Ratio = Annotated[float, BeforeValidator(_number(gt=0.0, limit="ratio"))]
Angle = Annotated[float, BeforeValidator(_number(limit="angle"))]
RelativeRange = Annotated[float, BeforeValidator(_number(ge=0.0, lt=1.0))]  # ±fraction of a plant parameter
InertiaRange = Annotated[tuple[float, float], BeforeValidator(_ranged("inertia"))]
StiffnessRange = Annotated[tuple[float, float], BeforeValidator(_ranged("stiffness"))]
MsdInertia = Annotated[Any, BeforeValidator(_range_or_number("inertia"))]
MsdDamping = Annotated[Any, BeforeValidator(_range_or_number("damping"))]
MsdStiffness = Annotated[Any, BeforeValidator(_range_or_number("stiffness"))]


def _felt_damping(v: Any) -> float:
    x = to_number(v)
    if not x > 0:
        raise ValueError(
            f"must be > 0, got {fmt_value(x)} (B̂_m = 0 makes B̃1 = 0: C4 gets a double pole at s = 0 "
            "and the cuff compensator G_v an integrator)"
        )
    return check_limit(x, "felt_damping")


FeltDamping = Annotated[float, BeforeValidator(_felt_damping)]


# --------------------------------------------------------------------------------------------
# ValidationError -> ConfigError
# --------------------------------------------------------------------------------------------
def kind_of(v: Any) -> str:
    """What a value is, for a reason: ``null``, ``a boolean``, ``the number 3``, ``the string 'x'``,
    ``a list``, ``a mapping`` (else the type's name).

    Parameters
    ----------
    v : Any
        The value read from a file.

    Returns
    -------
    str
        A short description of the value for an error reason.
    """
    if v is None:
        return "null"
    if isinstance(v, bool):
        return "a boolean"
    if isinstance(v, (int, float)):
        return f"the number {fmt_value(v)}"
    if isinstance(v, str):
        return f"the string {fmt_value(v)}"
    if isinstance(v, list):
        return "a list"
    if isinstance(v, dict):
        return "a mapping"
    if isinstance(v, (set, frozenset)):
        return "a set (YAML !!set)"
    if isinstance(v, (bytes, bytearray)):
        return "binary data (YAML !!binary)"
    import datetime

    if isinstance(v, (datetime.date, datetime.datetime)):
        return "a date (an unquoted YAML timestamp: quote it)"
    return type(v).__name__


def join_path(prefix: str, loc: tuple) -> str:
    """The dotted field path of ``loc`` (a pydantic error location) under ``prefix``:
    ``join_path("humans[0]", ("inertia",))`` is ``humans[0].inertia``, list indices in brackets.

    Parameters
    ----------
    prefix : str
        The path the location is under (``""`` for the top level).
    loc : tuple
        A pydantic error location: field names (str) and list indices (int).

    Returns
    -------
    str
        The dotted field path.
    """
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


def did_you_mean(key: Any, allowed) -> str:
    """``"; did you mean motor_inertia?"`` when ``key`` is close to one of ``allowed`` (difflib),
    else ``""``.

    Parameters
    ----------
    key : Any
        The unknown key (a non-string key gets no suggestion).
    allowed : iterable of str
        The keys accepted there.

    Returns
    -------
    str
        The suggestion, to append to a reason, or ``""``.
    """
    import difflib

    if not isinstance(key, str):
        return ""
    close = difflib.get_close_matches(key, list(allowed), n=1, cutoff=0.6)
    return f"; did you mean {close[0]}?" if close else ""


#: pydantic's error types of a number, an integer, a string and a yes/no value
_NUMBER_TYPES = ("float_type", "float_parsing", "int_type", "int_parsing", "int_from_float", "finite_number")
_BOUNDS = {"greater_than": ("gt", ">"), "greater_than_equal": ("ge", ">="), "less_than": ("lt", "<"),
           "less_than_equal": ("le", "<=")}


def _bound_text(x) -> str:
    return fmt_value(float(x)) if isinstance(x, (int, float)) and not isinstance(x, bool) else fmt_value(x)


def pydantic_reason(e: dict) -> str:
    """The reason of one pydantic validation error in exotune's wording ("expected a number, got
    the string 'x'", "must be >= 0, got -1", "expected a mapping, got a list"), never pydantic's
    own ("Input should be a valid string"): the one wording of every file exotune reads. Unknown
    and missing keys are worded by the callers.

    Parameters
    ----------
    e : dict
        One item of ``ValidationError.errors()`` (``type``, ``input``, ``ctx``, ``msg``).

    Returns
    -------
    str
        The reason, naming what was found.

    References
    ----------
    docs/design-file.md#errors; docs/controller-file.md.
    """
    typ = e.get("type", "")
    ctx = e.get("ctx") or {}
    inp = e.get("input")
    got = kind_of(inp)
    if typ == "value_error":
        return str(ctx.get("error", e.get("msg", "invalid value")))
    if typ in _NUMBER_TYPES:
        try:
            x = to_number(inp)
        except ValueError as err:  # to_number's reason: what was found instead of a number
            return str(err)
        if typ.startswith("int"):
            return f"expected an integer, got {fmt_value(x)}"
        if typ == "finite_number":
            return f"must be a finite number, got {fmt_value(x)}"
        return f"expected a number, got {got}"
    if typ in _BOUNDS:
        key, op = _BOUNDS[typ]
        bound = ctx.get(key)
        accepted = {">": lambda v: v > bound, ">=": lambda v: v >= bound, "<": lambda v: v < bound,
                    "<=": lambda v: v <= bound}[op]
        shown = fmt_outside(inp, accepted) if isinstance(bound, (int, float)) else fmt_value(inp)
        return f"must be {op} {_bound_text(bound)}, got {shown}"
    if typ in ("string_type", "string_sub_type", "string_unicode"):
        return f"expected a string, got {got}"
    if typ in ("bool_type", "bool_parsing"):
        return f"expected true or false, got {got}"
    if typ in ("model_type", "model_attributes_type", "dict_type", "mapping_type"):
        return f"expected a mapping, got {got}"
    if typ in ("list_type", "tuple_type", "set_type", "iterable_type"):
        return f"expected a list, got {got}"
    # a scalar is quoted; anything else (a YAML !!set, !!binary or date) is named, not repr'd
    scalar = fmt_value(inp) if inp is None or isinstance(inp, (str, int, float, bool)) else got
    if typ == "literal_error":
        return f"must be {ctx.get('expected', '')}, got {scalar}"
    if typ == "enum":
        return f"must be one of {ctx.get('expected', '')}, got {scalar}"
    if typ in ("too_short", "too_long"):
        n, actual = ctx.get("min_length" if typ == "too_short" else "max_length"), ctx.get("actual_length")
        return f"expected {'at least' if typ == 'too_short' else 'at most'} {n} item(s), got {actual}"
    if typ == "string_pattern_mismatch":
        return f"{scalar} does not have the expected form (pattern {ctx.get('pattern')})"
    if typ == "missing":
        return "required parameter is missing"
    if typ == "extra_forbidden":
        return "unknown key"
    # another check: pydantic's sentence in exotune's words ("Input should be X" -> "must be X")
    msg = str(e.get("msg", "invalid value"))
    if msg.startswith("Input should be "):
        msg = "must be " + msg[len("Input should be "):]
    return excerpt(f"{msg}, got {got}")


def _reason(e: dict, model: type[BaseModel]) -> str:
    loc = tuple(e.get("loc", ()))
    typ = e.get("type", "")
    if typ == "extra_forbidden":
        parent = _model_at(model, loc[:-1])
        allowed = list(parent.model_fields) if parent is not None else []
        hint = did_you_mean(loc[-1] if loc else None, allowed)
        if hint:
            return "unknown key" + hint
        return "unknown key" + (f" (allowed keys: {', '.join(allowed)})" if allowed else "")
    return pydantic_reason(e)


def _convert(err: ValidationError, model: type[BaseModel], prefix: str) -> ConfigError:
    """Every error of ``err`` as one :class:`ConfigError`: unknown keys first (a misspelt key
    also makes its correct spelling "missing"), then in pydantic's order; the first is the
    error, the others its ``more`` lines."""
    errors = err.errors(include_url=False)
    errors = sorted(errors, key=lambda e: e.get("type") != "extra_forbidden")  # stable
    out = []
    for e in errors:
        field = join_path(prefix, tuple(e.get("loc", ()))) or prefix or "<input>"
        out.append(ConfigError(field, _reason(e, model), in_file=True))  # a key of the file, never an option
    return combine_errors(out)


def validate_model(model: type[BaseModel], data: Any, prefix: str = ""):
    """``model.model_validate(data)``; its errors raised as one :class:`ConfigError` naming the
    first field under ``prefix`` (e.g. ``humans[0]``), the other errors in its ``more`` lines.

    Parameters
    ----------
    model : type of pydantic.BaseModel
        The input model of the section.
    data : Any
        The section read from the file.
    prefix : str, optional
        Field path of the section (e.g. ``humans[0]``), prefixed to the fields of the errors.

    Returns
    -------
    pydantic.BaseModel
        The validated ``model`` instance.

    Raises
    ------
    exotune.errors.ConfigError
        When the data does not validate: the first error's field and reason, the others in ``more``.
    """
    try:
        return model.model_validate(data)
    except ValidationError as err:
        raise _convert(err, model, prefix) from None


# --------------------------------------------------------------------------------------------
# Checks of single fields
# --------------------------------------------------------------------------------------------
def check_delay_samples(delay_s: float, fs: float, field: str) -> None:
    """The exact sampled-data model (docs/method.md#analyses-and-metrics) represents the delay by ⌈T·f_s⌉ shift states, in dense
    matrices: more than MAX_DELAY_SAMPLES of them (e.g. 1 ms at 1 GHz: a million) is refused
    up front rather than running out of memory.

    Parameters
    ----------
    delay_s : float
        Total delay [s].
    fs : float
        Sample rate [Hz].
    field : str
        Field path named by the error.

    Raises
    ------
    exotune.errors.ConfigError
        When the delay spans more than ``MAX_DELAY_SAMPLES`` samples.
    """
    n = float(delay_s) * float(fs)
    if n > MAX_DELAY_SAMPLES:
        shown = f"{n:.3g}" if float(f"{n:.3g}") > MAX_DELAY_SAMPLES else repr(n)  # 200.4 is not "200"
        raise ConfigError(field, f"{fs:g} Hz makes the {float(delay_s) * 1e3:g} ms delay {shown} samples; the "
                                 f"sampled-data model holds one state per sample (limit {MAX_DELAY_SAMPLES})")


MAX_DELAY_SAMPLES = 200  # the sampled-data model holds one shift state per sample of delay (dense eigenvalue
# problems: 200 samples already make a ~230-state loop, ~40 s for an export; 1 ms at 200 kHz)


def check_analysis_filters(impl, prefix: str = "") -> None:
    """The analysis needs the G_v and derivative filters (docs/method.md#controller): without them the cuff path
    G_v(s)(K̂2 + B̂2 s) is improper. ``prefix`` names where the implementation sits (``base.``).

    Parameters
    ----------
    impl : Implementation
        The implementation section (:class:`~exotune.model.controller.Implementation`).
    prefix : str, optional
        Field path prefix (``"base."`` in a spec), ``""`` in a design file.

    Raises
    ------
    exotune.errors.ConfigError
        When ``gv_filter`` or ``derivative_filter`` is missing (null).
    """
    for key in ("gv_filter", "derivative_filter"):
        if getattr(impl, key) is None:
            raise ConfigError(f"{prefix}implementation.{key}",
                              "required for analysis: the ideal cuff path G_v(s)(K̂2 + B̂2 s) is improper (docs/method.md#controller)")
