"""Precision as a certified property (docs/controller-file.md#precision): the controller a
single-precision target executes, and its exact state space.

A controller file may name its target arithmetic, ``implementation.precision: float64 | float32``
(default float64). For float32, ``export`` stores next to each controller's ``sos`` (the float64
Tustin design, which ``certify`` rebuilds and compares) its **realization**: the static gains and
every section in the delta-operator transposed direct form II (δ = z − 1), each coefficient
rounded to the nearest float32 (``controller.realization``). A section
H(z) = (b0 z² + b1 z + b2)/(z² + a1 z + a2) is, with z = 1 + δ,

    H = (β0 δ² + β1 δ + β2)/(δ² + α1 δ + α2),  β0 = b0, β1 = 2 b0 + b1, β2 = b0 + b1 + b2,
                                               α1 = 2 + a1, α2 = 1 + a1 + a2,

and runs as (states s1, s2; the operation order of the C port)

    y = β0·x + s1;  d1 = (β1·x − α1·y) + s2;  d2 = β2·x − α2·y;  s1 ← s1 + d1;  s2 ← s2 + d2.

Why: at 1-10 kHz the sections' poles and zeros sit within 0.03-0.0005 of z = 1, where the direct
form's coefficients (a1 ≈ −2, a2 ≈ 1, and b ≈ ±5e4 for the DOB's inverse motor model) lose the
pole/zero positions to cancellation: rounded to float32, ``dob_motor``'s zero at z = 1 (the s of
J_m s² + B_m s) moves off 1, a spurious DC position feedback, and the Q filters' unit DC gain (the
DOB's integral action) is lost. The δ coefficients carry those positions directly (α2 and β2 are
the DC terms), so rounding keeps them to float32's relative precision; a zero at z = 1 is β2 = 0
and a unit DC gain β2 = α2, both kept exactly (the same 1e-12 rule as
:func:`~exotune.controllerfile.fileio.position_feedback`). The states hold increments, not the
large cancelling products of the direct form.

The DOB's algebraic loop is solved with the stored divisor ``loop_divisor`` = fl32(1 − g),
g = Σ Π β0 of the filters on τ_cmd: u = (rest + h)/loop_divisor.

The step is written once (:func:`_step`) over an arithmetic: in float32 (the golden vectors,
:class:`Float32Runtime`, the C port's operations in its order) or linear in float64
(:func:`linearize`: the exact state space of the realization as executed, and every rounding point
as an extra input, for :mod:`exotune.controllerfile.roundoff`).

References
----------
R. H. Middleton, G. C. Goodwin, *Digital Control and Estimation: A Unified Approach* (1990),
the delta operator; docs/controller-file.md#precision; docs/deploying.md#precision.
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from ..errors import ConfigError
from ..sampled import Measured
from ..units import fmt_num
from .model import Controller, ControllerFile, Realization, as_controller_file

__all__ = ["PRECISIONS", "FORM", "FLUSH32", "INPUT_LIMIT32", "precision_of", "check_precision", "delta_row", "realization",
           "add_realizations", "realization_problems", "step_order", "Float32Runtime",
           "linearize", "discrete_from_realization", "realization_position_feedback"]

PRECISIONS = ("float64", "float32")
FORM = "delta_df2t"  # δ = z − 1, transposed direct form II (the module docstring)
FLUSH32 = 1e-30  # float32 port: inputs and states below this magnitude are zero (never a subnormal)
_FLUSH32_F = np.float32(FLUSH32)  # the comparisons are in float32, against this float32 value (the C port's literal)
# a double of this magnitude or more rounds to infinity in float32 (FLT_MAX + half its ulp, a tie rounded to the
# even infinity): an input fault in Float32Runtime and the C port, which checks it before converting
INPUT_LIMIT32 = 2.0 ** 128 - 2.0 ** 103
_ZERO_RTOL = 1e-12  # a DC zero / unit DC gain to this relative accuracy is kept exactly (fileio.position_feedback)


def check_precision(value, field: str = "implementation.precision") -> str:
    """``value`` when it is ``float64`` or ``float32``, else a ConfigError naming ``field``.

    Parameters
    ----------
    value : Any
        The precision given.
    field : str, optional
        Field path named by the error.

    Returns
    -------
    str
        ``"float64"`` or ``"float32"``.

    Raises
    ------
    exotune.errors.ConfigError
        When ``value`` is neither.
    """
    if not isinstance(value, str) or value not in PRECISIONS:
        raise ConfigError(field, f"must be float64 or float32 (the arithmetic of the target that runs the "
                                 f"controller), got {value!r}")
    return value


def precision_of(doc: ControllerFile | dict) -> str:
    """The file's target arithmetic: ``implementation.precision`` (absent or null: float64).
    A float32 file must carry a realization in every controller, a float64 file none.

    Parameters
    ----------
    doc : ControllerFile or dict
        The controller file.

    Returns
    -------
    str
        ``"float64"`` or ``"float32"``.

    Raises
    ------
    exotune.errors.ConfigError
        When the precision is invalid, or a controller's realization is missing (float32) or present
        (float64).
    """
    cf = as_controller_file(doc)
    p = None if cf.implementation is None else cf.implementation.precision
    p = "float64" if p is None else check_precision(p)
    ctrls = [("controller", cf.controller)] + [
        (f"gain_schedule.entries[{j}].controller", e.controller) for j, e in enumerate(cf.schedule_entries)]
    for where, c in ctrls:
        has = c.realization is not None
        if has != (p == "float32"):
            raise ConfigError(f"{where}.realization",
                              "missing: a float32 file (implementation.precision) carries the float32 realization of "
                              "every controller" if not has else
                              f"present in a {p} file: set implementation.precision: float32, or remove it")
        if has:
            _check_float32_values(c.realization, f"{where}.realization")
    return p


def _check_float32_values(real: Realization, where: str) -> None:
    """Every number of a realization must be a float32 value: the target (the C port,
    :class:`Float32Runtime`) rounds a coefficient to float32, while certify's state space
    (:func:`linearize`) takes it as written, so a value float32 does not hold would make certify
    analyse another controller than the one executed (a hand-edited file; an export writes
    float32 values only)."""
    values = [(f"{where}.gains.{s}", g) for s, g in real.gains.items()]
    for i, f in enumerate(real.filters):
        values += [(f"{where}.filters[{i}].sections[{r}][{k}]", x)
                   for r, row in enumerate(f.sections) for k, x in enumerate(row)]
    values.append((f"{where}.loop_divisor", real.loop_divisor))
    for field, x in values:
        v = _f32(x, field)
        if v != x:
            raise ConfigError(field, f"{x!r} is not a float32 value (float32 holds {v!r}): a float32 realization "
                                     "holds the coefficients the target executes, and certify analyses them as "
                                     "written; export the file again, or write the float32 value")


def _f32(x: float, where: str) -> float:
    with np.errstate(over="ignore"):
        v = float(np.float32(x))
    if not math.isfinite(v):
        raise ConfigError(where, f"the coefficient {x!r} does not fit in float32 (|x| > 3.4e38)")
    return v


def delta_row(row) -> tuple[list[float], bool]:
    """([β0, β1, β2, α1, α2] in float64, unit DC gain) of one sos row (a0 normalized): see the
    module docstring. β2 is exactly 0 for a zero at z = 1 (to 1e-12 of the numerator).

    Parameters
    ----------
    row : sequence of float
        One sos row ``[b0, b1, b2, a0, a1, a2]``.

    Returns
    -------
    coefficients : list of float
        ``[β0, β1, β2, α1, α2]`` (float64).
    unit_dc : bool
        Whether the section's DC gain β2/α2 is 1 (to 1e-9).
    """
    b0, b1, b2, a0, a1, a2 = (float(x) for x in row)
    b0, b1, b2, a1, a2 = b0 / a0, b1 / a0, b2 / a0, a1 / a0, a2 / a0
    beta2, alpha2 = b0 + b1 + b2, 1.0 + a1 + a2
    if abs(beta2) <= _ZERO_RTOL * (abs(b0) + abs(b1) + abs(b2)):
        beta2 = 0.0
    unit_dc = beta2 != 0.0 and abs(beta2 - alpha2) <= 1e-9 * abs(alpha2)
    return [b0, 2.0 * b0 + b1, beta2, 2.0 + a1, alpha2], unit_dc


def realization(controller: Controller | Mapping, where: str = "controller") -> dict:
    """The float32 realization of one controller section (its ``gains`` and ``filters``' sos):
    gains and δ-form sections rounded to float32, the loop divisor; every number a float32 value.

    Parameters
    ----------
    controller : Controller or Mapping
        A controller section of the file (``gains`` and ``filters`` with their ``sos``).
    where : str, optional
        Its field path, named by the errors.

    Returns
    -------
    dict
        The ``realization`` section: ``precision``, ``form``, ``note``, ``gains`` (signal →
        float32 gain), ``filters`` (name, input, δ-form ``sections``) and ``loop_divisor``.

    Raises
    ------
    exotune.errors.ConfigError
        When a coefficient does not fit in float32.
    """
    c = Controller.of(controller)
    gains = {s: _f32(g, f"{where}.gains.{s}") for s, g in c.gains.items()}
    filters = []
    for f in c.filters:
        secs = []
        for k, row in enumerate(f.sos):
            d, unit_dc = delta_row(row)
            r = [_f32(x, f"{where}.filters[{f.name}].sos[{k}]") for x in d]
            if unit_dc:
                r[2] = r[4]  # a unit DC gain (the Q filters: the DOB's integral action) kept exactly
            secs.append(r)
        filters.append({"name": f.name, "input": f.input, "sections": secs})
    g = 0.0
    for f in filters:
        if f["input"] == "tau_cmd":
            g += math.prod(s[0] for s in f["sections"])
    return {"precision": "float32", "form": FORM,
            "note": ("float32 values; sections [beta0, beta1, beta2, alpha1, alpha2] in delta = z - 1 form: "
                     "y = beta0*x + s1; d1 = (beta1*x - alpha1*y) + s2; d2 = beta2*x - alpha2*y; s1 += d1; "
                     "s2 += d2; tau_cmd = (rest + h)/loop_divisor (docs/controller-file.md#precision)"),
            "gains": gains, "filters": filters, "loop_divisor": _f32(1.0 - g, f"{where}.loop_divisor")}


def add_realizations(doc: dict) -> None:
    """Add the float32 realization to the file's controller and to each gain-schedule entry's.

    Parameters
    ----------
    doc : dict
        The controller file's mapping, changed in place.

    Raises
    ------
    exotune.errors.ConfigError
        When a coefficient does not fit in float32.
    """
    doc["controller"]["realization"] = realization(doc["controller"])
    for j, e in enumerate((doc.get("gain_schedule") or {}).get("entries") or []):
        e["controller"]["realization"] = realization(e["controller"], f"gain_schedule.entries[{j}].controller")


def realization_problems(doc: ControllerFile | dict) -> list[str]:
    """Where a float32 file's realizations differ from the ones its sos filters and gains give
    (:func:`realization`; exact comparison: both are float32 values).

    Parameters
    ----------
    doc : ControllerFile or dict
        The controller file.

    Returns
    -------
    list of str
        One problem per differing part (empty when every realization matches).
    """
    out = []
    cf = as_controller_file(doc)
    ctrls = [("controller", cf.controller)] + [
        (f"gain_schedule.entries[{j}].controller", cf.entry_view(e).controller) for j, e in enumerate(cf.schedule_entries)]
    for where, c in ctrls:
        have = c.realization
        if have is None:
            continue
        want = Realization.from_dict(realization(c, where))
        for k, a, b in (("precision", have.precision, want.precision), ("form", have.form, want.form),
                        ("gains", have.gains, want.gains), ("filters", have.filters, want.filters),
                        ("loop_divisor", have.loop_divisor, want.loop_divisor)):
            if a != b:
                out.append(f"{where}.realization.{k} is not the float32 realization of the file's {where} "
                           "(gains and sos)")
    return out


# ----------------------------------------------------------------------------------------------
# the step, once, over an arithmetic
# ----------------------------------------------------------------------------------------------
class _Compiled:
    """A realization as the step walks it: gains (signal index, g), sensed filters (signal index,
    sections), loop filters (sections), the divisor, the number of sections."""

    def __init__(self, real, cast=float):
        real = Realization.of(real)
        self.names = [f.name for f in real.filters if f.input != "tau_cmd"]
        self.names += [f.name for f in real.filters if f.input == "tau_cmd"]
        self.gains = [(Measured.index(s), cast(g)) for s, g in real.gains.items()]
        self.sensed = [(Measured.index(f.input), [tuple(cast(x) for x in r) for r in f.sections])
                       for f in real.filters if f.input != "tau_cmd"]
        self.loop = [[tuple(cast(x) for x in r) for r in f.sections]
                     for f in real.filters if f.input == "tau_cmd"]
        self.divisor = cast(real.loop_divisor)
        self.n_sections = sum(len(s) for _, s in self.sensed) + sum(len(s) for s in self.loop)
        if float(self.divisor) == 0.0:
            raise ValueError("the DOB's algebraic loop is singular (loop_divisor = 0)")


def _section(ar, c, s, x):
    y = ar.add(ar.mul(c[0], x), s[0])
    d1 = ar.add(ar.sub(ar.mul(c[1], x), ar.mul(c[3], y)), s[1])
    d2 = ar.sub(ar.mul(c[2], x), ar.mul(c[4], y))
    s[0] = ar.state(ar.add(s[0], d1))
    s[1] = ar.state(ar.add(s[1], d2))
    return y


def _step(ar, K: _Compiled, z: list, v: list):
    """One sample: τ_cmd from the converted inputs ``v`` (Measured order); the states ``z`` (one
    [s1, s2] per section: sensed filters, then loop filters) advance."""
    ar.at("inputs and static gains")
    rest = ar.zero
    for i, g in K.gains:
        rest = ar.add(rest, ar.mul(g, v[i]))
    fsum = ar.zero
    k = 0
    for (i, secs), name in zip(K.sensed, K.names):
        x = v[i]
        for n, c in enumerate(secs):
            ar.at(f"{name}[{n}]")
            x = _section(ar, c, z[k], x)
            k += 1
        fsum = ar.add(fsum, x)
    ar.at("DOB loop solve")
    rest = ar.add(rest, fsum)
    h = ar.zero
    j = k
    for secs in K.loop:
        x = ar.zero
        for c in secs:
            x = ar.add(ar.mul(c[0], x), z[j][0])
            j += 1
        h = ar.add(h, x)
    u = ar.clamp(ar.div(ar.add(rest, h), K.divisor))
    for secs, name in zip(K.loop, K.names[len(K.sensed):]):
        x = u
        for n, c in enumerate(secs):
            ar.at(f"{name}[{n}]")
            x = _section(ar, c, z[k], x)
            k += 1
    return u


def step_order(real: Realization | Mapping) -> dict:
    """The realization as the step walks it, in its order (the float32 C port's tables):
    ``gains`` [(signal index, g)], ``sensed`` [(signal index, sections)] and ``loop``
    [sections] filters, ``names`` (sensed, then loop filters) and ``divisor``; float32 values as
    Python floats.

    Parameters
    ----------
    real : Realization or Mapping
        A controller's ``realization`` section.

    Returns
    -------
    dict
        ``gains``, ``sensed``, ``loop``, ``names`` and ``divisor``, as described above.
    """
    K = _Compiled(real)
    return {"gains": K.gains, "sensed": K.sensed, "loop": K.loop, "names": K.names, "divisor": K.divisor}


class _Float32:
    """IEEE single arithmetic (numpy float32 scalars, round to nearest: the C port's operations)."""

    zero = np.float32(0.0)

    def __init__(self, limit_nm=None):
        self.limit = None if limit_nm is None else np.float32(limit_nm)

    @staticmethod
    def at(_where):
        return None

    @staticmethod
    def mul(a, b):
        return a * b

    @staticmethod
    def add(a, b):
        return a + b

    @staticmethod
    def sub(a, b):
        return a - b

    @staticmethod
    def div(a, b):
        return a / b

    @staticmethod
    def state(v):
        return v if abs(v) >= _FLUSH32_F or not math.isfinite(v) else np.float32(0.0)

    def clamp(self, u):
        if self.limit is not None and math.isfinite(u):
            u = min(self.limit, max(-self.limit, u))
        return u


class Float32Runtime:
    """Steps a float32 realization in float32 arithmetic, as the float32 C port does (golden
    vectors). Same contract as :class:`~exotune.controllerfile.runtime.Runtime`: a non-finite
    input, or one that overflows float32, or an overflowing command raises ``ValueError`` with
    the state unchanged (the C port's ``EXOTUNE_FAULT_INPUT`` for an input that is not finite in
    float32, i.e. NaN, infinite or of magnitude :data:`INPUT_LIMIT32` or more; ``EXOTUNE_FAULT_OVERFLOW``
    for the command). Inputs (after their conversion) and states below :data:`FLUSH32` (as float32)
    are zero."""

    def __init__(self, doc, limit_nm: float | None = None, joint_angle_rad: float | None = None):
        cf = as_controller_file(doc)
        if joint_angle_rad is not None and cf.schedule_entries:
            cf = cf.entry_view(cf.gain_schedule.nearest(joint_angle_rad))
        self.K = _Compiled(cf.controller.realization, np.float32)
        self.ar = _Float32(limit_nm)
        self.sample_rate_hz = float(cf.sample_rate_hz)
        self.reset()

    def reset(self) -> None:
        self.z = [[np.float32(0.0), np.float32(0.0)] for _ in range(self.K.n_sections)]

    def step(self, y: Mapping[str, float]) -> float:
        with np.errstate(over="ignore", invalid="ignore"):
            v = [np.float32(float(y[s])) for s in Measured]
        bad = [s for s, x in zip(Measured, v) if not math.isfinite(x)]
        if bad:
            raise ValueError(f"non-finite input {bad[0]} = {y[bad[0]]!r} in float32: refused, controller state unchanged")
        v = [x if abs(x) >= _FLUSH32_F else np.float32(0.0) for x in v]
        saved = [s[:] for s in self.z]
        with np.errstate(over="ignore", invalid="ignore"):
            u = _step(self.ar, self.K, self.z, v)
        if not (math.isfinite(u) and all(math.isfinite(a) and math.isfinite(b) for a, b in self.z)):
            self.z = saved
            raise ValueError(f"the command overflows float32 (tau_cmd = {fmt_num(u)} N·m): refused, controller state unchanged")
        return float(u)

    def run(self, inputs: Mapping[str, np.ndarray]) -> np.ndarray:
        n = len(next(iter(inputs.values())))
        return np.array([self.step({s: v[k] for s, v in inputs.items()}) for k in range(n)])


# ----------------------------------------------------------------------------------------------
# the realization as a linear system: exact state space and rounding points
# ----------------------------------------------------------------------------------------------
class _Linear:
    """Float64 arithmetic on linear forms (rows over [states, inputs, rounding errors]): each
    operation is a rounding point whose error enters as a new unit column; its value (before the
    error) is recorded."""

    def __init__(self, width: int, first_error: int):
        self.zero = np.zeros(width)
        self.eye = np.eye(width)
        self.next = first_error
        self.values: list[np.ndarray] = []
        self.where = "inputs and static gains"
        self.labels: list[str] = []

    def at(self, where):
        self.where = where

    def _point(self, v):
        self.values.append(v)
        self.labels.append(self.where)
        out = v + self.eye[self.next] if self.next < len(self.zero) else v
        self.next += 1
        return out

    def mul(self, c, x):
        return self._point(float(c) * x)

    def add(self, a, b):
        return self._point(a + b)

    def sub(self, a, b):
        return self._point(a - b)

    def div(self, a, c):
        return self._point(a / float(c))

    def cvt(self, v):
        return self._point(v)

    @staticmethod
    def state(v):
        return v

    @staticmethod
    def clamp(u):
        return u


def linearize(real: Realization | Mapping) -> dict:
    """The realization's step as a linear map of [states z (n), inputs y (5, Measured order),
    rounding errors e (p)]: ``A, B, E`` (z⁺ = A z + B y + E e), ``C, D, F`` (τ_cmd = C z + D y + F e),
    and ``V`` (p × (n + 5 + p)): the exact value at each rounding point (the inputs' conversion to
    float32 first). Exact up to float64 rounding of the few products and sums that form each
    entry (the coefficients are float32 values).

    Parameters
    ----------
    real : Realization or Mapping
        A controller's ``realization`` section.

    Returns
    -------
    dict
        ``A``, ``B``, ``E``, ``C``, ``D``, ``F``, ``V`` (numpy arrays), ``labels`` (one per rounding
        point), ``states`` (n) and ``points`` (p).
    """
    K = _Compiled(real)
    n, m = 2 * K.n_sections, len(Measured)
    count = _Linear(n + m, n + m)
    _run_linear(count, K, n, m)
    p = count.next - (n + m)
    ar = _Linear(n + m + p, n + m)
    z1, u = _run_linear(ar, K, n, m)
    Z = np.array(z1)  # (n, n + m + p)
    return {"A": Z[:, :n], "B": Z[:, n:n + m], "E": Z[:, n + m:], "C": u[None, :n], "D": u[None, n:n + m],
            "F": u[None, n + m:], "V": np.array(ar.values), "labels": ar.labels, "states": n, "points": p}


def _run_linear(ar: _Linear, K: _Compiled, n: int, m: int):
    z = [[ar.eye[2 * k], ar.eye[2 * k + 1]] for k in range(K.n_sections)]
    ar.at("inputs (conversion to float32)")
    v = [ar.cvt(ar.eye[n + i]) for i in range(m)]
    u = _step(ar, K, z, v)
    return [s for pair in z for s in pair], u


def discrete_from_realization(real: Realization | Mapping, sample_rate_hz: float, delay_s: float):
    """The float32 realization as one state space (:class:`exotune.sampled.DiscreteController`):
    the controller the certify analysis decides on, exactly as executed (:func:`linearize`).

    Parameters
    ----------
    real : Realization or Mapping
        A controller's ``realization`` section.
    sample_rate_hz : float
        Sample rate [Hz].
    delay_s : float
        Total latency [s].

    Returns
    -------
    DiscreteController
        The realization's state space (no rounding inputs).
    """
    from ..sampled.loop import DiscreteController

    L = linearize(real)
    return DiscreteController(L["A"], L["B"], L["C"], L["D"], float(sample_rate_hz), float(delay_s))


def realization_position_feedback(real: Realization | Mapping, rtol: float = 1e-12) -> bool:
    """:func:`~exotune.controllerfile.fileio.position_feedback` of the realization: its θ_m gain
    and the DC gains β2/α2 of its sections on θ_m.

    Parameters
    ----------
    real : Realization or Mapping
        A controller's ``realization`` section.
    rtol : float, optional
        Relative size below which the total DC gain on θ_m counts as zero.

    Returns
    -------
    bool
        Whether the realization feeds back the motor position.
    """
    real = Realization.of(real)
    total = float(real.gains.get("theta_m", 0.0))
    scale = abs(total)
    for f in real.filters:
        if f.input != "theta_m":
            continue
        num, den = 1.0, 1.0
        for _b0, _b1, b2, _a1, a2 in f.sections:
            num *= b2
            den *= a2
        if num == 0.0:
            continue
        if den == 0.0:
            return True
        total += num / den
        scale += abs(num / den)
    return abs(total) > rtol * max(scale, 1e-300) and total != 0.0
