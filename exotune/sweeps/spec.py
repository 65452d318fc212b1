"""Reading and validating a sweep spec into a :class:`~exotune.sweeps.plan.SweepPlan`.

The spec format (``base``, ``axes``, ``chunk_size``, ``verify_points``, ``plant_margin``) and every validation rule
are described in the :mod:`exotune.sweeps` package docstring; every problem is a
:class:`~exotune.errors.ConfigError` naming the field.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from ..config import batch_config, design_from_mapping, read_yaml
from ..config.validate import check_analysis_filters, fmt_value, kind_of, number_field
from ..errors import ConfigError
from .plan import SweepPlan

__all__ = ["load_spec", "load_base", "is_number", "int_option", "DEFAULT_CHUNK_SIZE", "MAX_CHUNK_SIZE",
           "MAX_VERIFY_POINTS", "MAX_AXIS_VALUES"]

DEFAULT_CHUNK_SIZE = 10000
_SPEC_KEYS = ("base", "axes", "chunk_size", "verify_points", "plant_margin", "sampled")
DEFAULT_PLANT_MARGIN_BUDGET = 150_000  # interval evaluations per loop and certification attempt
_AXIS_KEYS = ("start", "stop", "num", "scale")
_MAX_POINTS = 2**62
MAX_VERIFY_POINTS = 1000  # spec key verify_points (the single-design report uses 64)
# a chunk is analysed as one batch in memory (a few chunks in flight): 100 times the default at most
MAX_CHUNK_SIZE = 1_000_000
MAX_AXIS_VALUES = 100_000  # per axis: the values are listed in the manifest (a 10⁵ × 10⁵ grid is fine)


# ---------------------------------------------------------------------------------------------
# Spec parsing and validation
# ---------------------------------------------------------------------------------------------
def is_number(v: Any) -> bool:
    """True for an int or float (numpy scalars included), False for bools and everything else.

    Parameters
    ----------
    v : Any
        The value.

    Returns
    -------
    bool
        Whether ``v`` is a number.
    """
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))


def _shown(v) -> str:
    """A value where an integer belongs, as an error shows it: a float as a float (``1.0``, not
    ``1``), a long integer or text cut short (:func:`~exotune.config.validate.fmt_value`)."""
    if isinstance(v, (float, np.floating)):
        return repr(float(v))
    return fmt_value(v.item() if isinstance(v, np.generic) else v)


def _axis_values(path: str, spec: Any) -> tuple[list[float], str]:
    field = f"axes.{path}"
    if isinstance(spec, tuple) or (isinstance(spec, np.ndarray) and spec.ndim == 1):
        spec = list(spec)  # the library's sequences of values (a file's list is a list)
    if isinstance(spec, list):
        if not spec:
            raise ConfigError(field, "an axis list needs at least one value")
        if len(spec) > MAX_AXIS_VALUES:
            raise ConfigError(field, f"{len(spec)} values; an axis has at most {MAX_AXIS_VALUES}")
        vals = [number_field(f"{field}[{i}]", v) for i, v in enumerate(spec)]
        seen = {}
        for i, v in enumerate(vals):
            if v in seen:
                raise ConfigError(f"{field}[{i}]", f"duplicate value {v:g} (also at index {seen[v]})")
            seen[v] = i
        return vals, "list"
    if isinstance(spec, dict):
        unknown = [k for k in spec if k not in _AXIS_KEYS]
        if unknown:
            raise ConfigError(f"{field}.{unknown[0]}", f"unknown key (allowed: {', '.join(_AXIS_KEYS)})")
        for k in ("start", "stop", "num"):
            if k not in spec:
                raise ConfigError(f"{field}.{k}", "required key is missing ({start, stop, num[, scale]})")
        start = number_field(f"{field}.start", spec["start"])
        stop = number_field(f"{field}.stop", spec["stop"])
        num = spec["num"]
        if isinstance(num, (bool, np.bool_)) or not isinstance(num, (int, np.integer)):
            if isinstance(num, float) and num.is_integer():
                num = int(num)
            else:
                raise ConfigError(f"{field}.num", f"expected an integer >= 1, got {_shown(num)}")
        num = int(num)
        if num < 1:
            raise ConfigError(f"{field}.num", f"must be >= 1, got {num}")
        if num > MAX_AXIS_VALUES:
            raise ConfigError(f"{field}.num", f"{fmt_value(num)} values; an axis has at most {MAX_AXIS_VALUES} "
                                             "(a grid of several axes can still have up to 2^62 points)")
        scale = spec.get("scale", "lin")
        if scale not in ("lin", "log"):
            raise ConfigError(f"{field}.scale", f"must be 'lin' or 'log', got {scale!r}")
        if num > 1 and start == stop:
            raise ConfigError(field, f"start = stop = {start:g} with num = {num} gives duplicate values")
        if scale == "log":
            for k, v in (("start", start), ("stop", stop)):
                if not v > 0:
                    raise ConfigError(f"{field}.{k}", f"must be > 0 for scale: log, got {v:g}")
            vals = np.geomspace(start, stop, num) if num > 1 else np.array([start])
        else:
            vals = np.linspace(start, stop, num) if num > 1 else np.array([start])
        out = [float(v) for v in vals]
        if len(set(out)) < len(out):  # start and stop a few ulps apart
            raise ConfigError(field, f"{num} values from {start!r} to {stop!r} are not distinct in floating point")
        return out, scale
    raise ConfigError(field, f"expected a list of values or a mapping {{start, stop, num, scale}}, got {kind_of(spec)}")


def _plant_margin_option(v: Any) -> dict | None:
    """The spec key ``plant_margin``: false/absent (no columns), true (default budget) or a
    mapping ``{budget: N}`` (interval evaluations per loop and certification attempt)."""
    if isinstance(v, np.bool_):
        v = bool(v)
    if v is False or v is None:
        return None
    if v is True:
        return {"budget": DEFAULT_PLANT_MARGIN_BUDGET}
    if not isinstance(v, dict):
        raise ConfigError("plant_margin", f"expected true, false or a mapping {{budget: N}}, got {v!r}")
    unknown = [k for k in v if k != "budget"]
    if unknown:
        raise ConfigError(f"plant_margin.{unknown[0]}", "unknown key (allowed: budget)")
    return {"budget": int_option("plant_margin.budget", v.get("budget", DEFAULT_PLANT_MARGIN_BUDGET), 1000)}


def _sampled_option(v: Any, cfg) -> bool:
    """The spec key ``sampled``: true adds the exact sampled-data columns (the base must set
    ``implementation.sample_rate_hz``; docs/sweep-spec.md#sampled-data-columns)."""
    if isinstance(v, np.bool_):
        v = bool(v)
    if v is None or v is False:
        return False
    if v is not True:
        raise ConfigError("sampled", f"expected true or false, got {v!r}")
    from .sampledcols import sampled_refusal

    why = sampled_refusal(cfg)
    if why:
        raise ConfigError("sampled", why)
    return True


def int_option(field: str, v: Any, minimum: int, in_file: bool = False) -> int:
    """``v`` as an integer >= ``minimum`` (bools refused); ConfigError naming ``field`` otherwise.

    Parameters
    ----------
    field : str
        Field path named by the error.
    v : Any
        The value read from the spec.
    minimum : int
        The smallest accepted value.
    in_file : bool, optional
        ``field`` is the spec's key although a keyword has the same name (``ConfigError.in_file``).

    Returns
    -------
    int
        The value.

    Raises
    ------
    exotune.errors.ConfigError
        When ``v`` is not an integer or is below ``minimum``.
    """
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)):
        raise ConfigError(field, f"expected an integer >= {minimum}, got {_shown(v)}", in_file=in_file)
    if int(v) < minimum:
        raise ConfigError(field, f"must be >= {minimum}, got {fmt_value(int(v))}", in_file=in_file)
    return int(v)


def load_base(base, root: str):
    """The ``base`` of a sweep or optimization spec: a design file path (relative to ``root``) or
    an inline design mapping → (validated DesignConfig, source path or None). Errors name
    ``base``.

    Parameters
    ----------
    base : str or dict
        The spec's ``base``: a design file path or an inline design.
    root : str
        The directory relative paths are resolved against (the spec's).

    Returns
    -------
    cfg : DesignConfig
        The validated base design.
    source : str or None
        Its path, None for an inline design.

    Raises
    ------
    exotune.errors.ConfigError
        When the base cannot be read or does not validate (the field prefixed by ``base``).
    """
    if isinstance(base, str):
        base_path = base if os.path.isabs(base) else os.path.join(root, base)
        try:
            base_map = read_yaml(base_path)
        except ConfigError as e:
            raise ConfigError(f"base ({e.field})", e.reason) from None
        try:
            return design_from_mapping(base_map, source=base_path), base_path
        except ConfigError as e:
            raise ConfigError(f"base ({base}): {e.field}", e.reason) from None
    if isinstance(base, dict):
        try:
            return design_from_mapping(base, source="<inline base>"), None
        except ConfigError as e:
            raise ConfigError(f"base.{e.field}", e.reason) from None
    raise ConfigError("base", f"expected a design file path or a mapping, got {kind_of(base)}")


def load_spec(spec, sample: int | None = None, seed: int | None = None, chunk_size: int | None = None) -> "SweepPlan":
    """Read and validate a sweep spec into a :class:`~exotune.sweeps.plan.SweepPlan`.

    Parameters
    ----------
    spec : str, os.PathLike or dict
        A spec file (a ``base`` path in it is relative to the file) or a mapping (a ``base`` path
        is relative to the current directory).
    sample, seed : int, optional
        ``--sample N --seed S``: a uniform random sample of N grid points (seed default 0).
    chunk_size : int, optional
        ``--chunk-size``: overrides the spec's ``chunk_size``.

    Returns
    -------
    SweepPlan
        The normalized spec, its hash and the row → design point mapping.

    Raises
    ------
    ConfigError
        For every problem, naming the field (``axes.<path>[.<key>]``, ``base``, ``sample``, …).

    References
    ----------
    docs/sweep-spec.md#keys.
    """
    if isinstance(spec, (str, os.PathLike)):
        spec_path = os.fspath(spec)
        mapping = read_yaml(spec_path)
        root = os.path.dirname(os.path.abspath(spec_path))
        source = spec_path
    elif isinstance(spec, dict):
        mapping, root, source = spec, os.getcwd(), None
    else:
        raise ConfigError("<spec>", f"expected a spec file path or a mapping, got {kind_of(spec)}")
    unknown = [k for k in mapping if k not in _SPEC_KEYS]
    if unknown:
        raise ConfigError(str(unknown[0]), f"unknown key in a sweep spec (allowed: {', '.join(_SPEC_KEYS)})", in_file=True)
    if "base" not in mapping:
        raise ConfigError("base", "required key is missing (a design file path or an inline design mapping)")
    cfg, base_source = load_base(mapping["base"], root)
    check_analysis_filters(cfg.implementation, "base.")

    if "axes" not in mapping:
        raise ConfigError("axes", "required key is missing (a mapping of dotted parameter paths to values)")
    axes_in = mapping["axes"]
    if not isinstance(axes_in, dict):
        raise ConfigError("axes", f"expected a mapping of dotted parameter paths to values, got {kind_of(axes_in)}")
    if not axes_in:
        raise ConfigError("axes", "at least one axis is required")
    axes: dict[str, dict] = {}
    for path, aspec in axes_in.items():
        if not isinstance(path, str):
            raise ConfigError(f"axes.{path}", "an axis name must be a dotted parameter path (a string)")
        vals, scale = _axis_values(path, aspec)
        try:  # unknown / non-sweepable paths and rule violations (α < 1, Nyquist, …)
            batch_config(cfg, {path: np.asarray(vals)})
        except ConfigError as e:
            raise ConfigError(f"axes.{path}", e.reason) from None
        axes[path] = {"values": vals, "scale": scale}

    # the spec's own key when the keyword of the same name was not given
    from_spec = chunk_size is None
    chunk_size = int_option("chunk_size", mapping.get("chunk_size", DEFAULT_CHUNK_SIZE) if from_spec else chunk_size, 1,
                            in_file=from_spec)
    if chunk_size > MAX_CHUNK_SIZE:
        raise ConfigError("chunk_size", f"{fmt_value(chunk_size)} design points per chunk; at most {MAX_CHUNK_SIZE} "
                                        "(a chunk is analysed in memory at once)", in_file=from_spec)

    shape = tuple(len(a["values"]) for a in axes.values())
    total = 1
    for n in shape:
        total *= n
        if total > _MAX_POINTS:
            raise ConfigError("axes", f"the grid has more than 2^62 points ({' × '.join(map(str, shape))})")
    if sample is not None:
        sample = int_option("sample", sample, 1)
        if sample > total:
            raise ConfigError("sample", f"{sample} exceeds the number of grid points ({total})")
        seed = 0 if seed is None else int_option("seed", seed, 0)
    elif seed is not None:
        raise ConfigError("seed", "only meaningful together with `sample`")

    verify = int_option("verify_points", mapping.get("verify_points", 0), 0)
    if verify > MAX_VERIFY_POINTS:
        raise ConfigError("verify_points", f"{fmt_value(verify)} exact counts per family and design; at most "
                                           f"{MAX_VERIFY_POINTS}")
    normalized = {
        "base": cfg.raw,
        "axes": axes,
        "chunk_size": chunk_size,
        "sample": sample,
        "seed": seed,
    }
    if verify:  # only present when used, so existing spec hashes are unchanged
        normalized["verify_points"] = verify
    pm = _plant_margin_option(mapping.get("plant_margin", False))
    if pm is not None:  # likewise
        normalized["plant_margin"] = pm
    if _sampled_option(mapping.get("sampled", False), cfg):  # likewise
        normalized["sampled"] = True
    return SweepPlan(normalized, cfg=cfg, source=source, base_source=base_source)
