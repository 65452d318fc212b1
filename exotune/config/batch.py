"""Batches of designs for sweeps: a validated design with parameters replaced by 1-D arrays.

Batches (:func:`batch_config`) override plant, design and implementation parameters by dotted path
with 1-D arrays; human and environment families are *not* overridable (they are the uncertainty
sets every design point is checked against, so they are shared by the whole batch).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from ..errors import ConfigError
from ..model.plant import Plant
from ..model.shaping import DesignParams
from .design import DesignConfig
from .validate import FILTER_KEYS, check_delay_samples, fmt_outside, fmt_value, limit_text, LIMITS

__all__ = [
    "design_row",
    "continuous", "OVERRIDABLE", "OVERRIDE_LIMITS", "batch_config"]


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

#: The accepted range (a key of :data:`exotune.config.validate.LIMITS`) of each overridable path.
OVERRIDE_LIMITS: dict[str, str] = {
    "plant.motor_inertia": "inertia",
    "plant.motor_damping": "damping",
    "plant.sea_stiffness": "stiffness",
    "plant.joint_inertia": "inertia",
    "plant.cuff_stiffness": "stiffness",
    "design.amplification": "amplification",
    "design.felt_inertia": "inertia",
    "design.felt_damping": "felt_damping",
    "design.zeta": "damping_ratio",
    "design.zeta_hat": "damping_ratio",
    "implementation.delay_s": "delay",
    "implementation.gv_filter.cutoff_hz": "frequency",
    "implementation.gv_filter.damping": "damping_ratio",
    "implementation.derivative_filter.cutoff_hz": "frequency",
    "implementation.dob.cutoff_hz": "frequency",
    "implementation.dob.damping": "damping_ratio",
    "implementation.velocity_filter.cutoff_hz": "frequency",
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
        raise ConfigError(path, f"value {fmt_value(float(arr[i]))} at index {i} is not a finite number")
    op, bound = OVERRIDABLE[path]
    ok = arr > bound if op == ">" else arr >= bound
    bad = np.flatnonzero(~ok)
    if bad.size:
        i = int(bad[0])
        neg = "<=" if op == ">" else "<"
        shown = fmt_outside(float(arr[i]), (lambda v: v > bound) if op == ">" else (lambda v: v >= bound))
        raise ConfigError(path, f"value {shown} at index {i} is {neg} {bound:g} (must be {op} {bound:g})")
    kind = OVERRIDE_LIMITS[path]
    lo, lo_open, hi, _unit = LIMITS[kind]
    bad = np.flatnonzero(~(((arr > lo) if lo_open else (arr >= lo)) & (arr <= hi)))
    if bad.size:
        i = int(bad[0])
        shown = fmt_outside(float(arr[i]), lambda v: ((v > lo) if lo_open else (v >= lo)) and v <= hi)
        raise ConfigError(path, f"value {shown} at index {i} is out of the accepted range "
                                f"{limit_text(kind)} (docs/design-file.md#input-limits-and-accepted-ranges)")
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
    With no overrides N = 1. (One function: the checks of the override values need the whole
    set of overrides, and the construction below reuses them.)

    Parameters
    ----------
    cfg : DesignConfig
        The base design.
    overrides : dict of str to numpy.ndarray
        Values per overridable dotted path, each of the same length N, in the field's unit.

    Returns
    -------
    DesignConfig
        The batch: per-design numbers as float arrays of length N.

    Raises
    ------
    exotune.errors.ConfigError
        When a path is not overridable, the lengths differ, a value breaks a design-file rule (a
        limit, the Nyquist limit of a cutoff, the delay's sample count), or a filter parameter is
        overridden while the base design has no such filter.
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
    for key in FILTER_KEYS:
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


def design_row(cfg: DesignConfig, i: int) -> DesignConfig:
    """Design ``i`` of a batch (:func:`batch_config`) as a single design: every per-design array
    replaced by its i-th value (a float). ``raw`` still describes the batch's base design.

    Parameters
    ----------
    cfg : DesignConfig
        A batch (:func:`batch_config`).
    i : int
        Index of the design in the batch.

    Returns
    -------
    DesignConfig
        The single design.

    Examples
    --------
    >>> import numpy as np
    >>> from exotune.config import load_design
    >>> b = batch_config(load_design("examples/scheduled.yaml"), {"design.amplification": np.array([4.0, 6.0])})
    >>> design_row(b, 1).design.amplification
    6.0
    """
    import dataclasses

    def take(obj):
        if obj is None or not dataclasses.is_dataclass(obj):
            return obj
        kw = {}
        for f in dataclasses.fields(obj):
            v = getattr(obj, f.name)
            if isinstance(v, np.ndarray) and v.ndim == 1:
                kw[f.name] = float(v[i])
            elif dataclasses.is_dataclass(v):
                kw[f.name] = take(v)
        return dataclasses.replace(obj, **kw)

    return replace(cfg, plant=take(cfg.plant), design=take(cfg.design), implementation=take(cfg.implementation))


def continuous(cfg):
    """``cfg`` with its sample rate removed (``implementation.sample_rate_hz`` None): the
    continuous-time analysis of the same design, whose delays are not limited to a number of
    samples — for margins that probe delays beyond the design's own (docs/method.md#latency-margin).

    Parameters
    ----------
    cfg : DesignConfig
        A design or a batch.

    Returns
    -------
    DesignConfig
        ``cfg`` itself when it has no sample rate, else a copy without one.

    Examples
    --------
    >>> from exotune.config import load_design
    >>> continuous(load_design("examples/scheduled.yaml")).implementation.sample_rate_hz is None
    True
    """
    import dataclasses

    if cfg.implementation.sample_rate_hz is None:
        return cfg
    return dataclasses.replace(cfg, implementation=dataclasses.replace(cfg.implementation, sample_rate_hz=None))
