"""Least-squares identification of the plant's parameters from a measured log, or from several
logs together.

Every signal x is passed through the state-variable filter H(s) = ω³/(s + ω)³ and through s·H and
s²·H (:mod:`exotune.identification.filters`: measured signals with a first-order hold, a held
command exactly and through the same sinc² factor), so the equations of the plant (paper eq. (5),
docs/method.md#physical-model) hold between filtered signals without differentiating a measured
signal:

    motor   H[τ_s + τ_m] = J_m · s²H[θ_m] + B_m · sH[θ_m] + c      (δ_f, friction, is left in the residual)
    SEA     H[τ_s]       = K_s · H[θ_j − θ_m] + c
    joint   H[τ_c − τ_s] = J_j · s²H[θ_j] + c
    cuff    H[τ_c]       = K_c · H[θ_h − θ_j] + c

(c: a sensor offset per equation, through H; H[1] is 1 plus a transient). A log starts in motion,
not at rest: the filters' start-up transients lie in the span of the filter's modes e^{−ωt},
t·e^{−ωt} and t²·e^{−ωt}, which enter each regression as three more columns; the first 5/ω seconds
are dropped besides. Several logs are identified together by stacking their equations' rows, each
log with its own offset and transients, filtered and delayed on its own
(:mod:`exotune.identification.signals`). Each equation is followed by its diagnostics
(:mod:`exotune.identification.diagnose`) and the filtered signals no later equation needs are
dropped, so memory stays a few signals above the log's. The
covariance of each equation's estimate is the sandwich of :mod:`exotune.identification.regress`
(the filtered residual's autocovariance over 30/ω); what the hold leaves (a relative
4·10⁻³·(ωT)³ + 10⁻⁷, :func:`~exotune.identification.filters.discretization_bound`) is added to the
dynamic equations' variances (J_m, B_m, J_j); the static equations (K_s, K_c) have none.

References
----------
docs/identification.md; paper eq. (5) (the plant's equations).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping

import numpy as np

from ..config.batch import OVERRIDABLE, OVERRIDE_LIMITS
from ..config.validate import excerpt, in_limits, limit_text
from ..errors import ConfigError
from ..numerics.threads import one_blas_thread
from ..units import fmt_num
from .data import MIN_SAMPLES, MeasuredLog, same_samples
from .diagnose import diagnose, fit_delays, lhs, regression, screen_delays
from .filters import discretization_bound, svf
from .regress import CORRELATION_TIME_CONSTANTS, Design, NotExcited
from .result import EquationFit, ParameterEstimate, PlantEstimate
from .signals import FilteredLogs
from .validresult import ModelError

__all__ = ["identify_plant", "identify_file", "parse_fix", "svf", "FRICTION", "MIN_T", "DEFAULT_FILTER_HZ",
           "TRANSIENT_TIME_CONSTANTS", "MIN_FIT_SAMPLES", "MAX_FILTER_FRACTION", "MIN_FILTER_FRACTION",
           "filter_corner", "check_like", "RATE_TOLERANCE"]

DEFAULT_FILTER_HZ = 20.0  # at most a hundredth of the sample rate
# The filter corner's accepted range, as fractions of the sample rate: at most fs/25 (ωT ≤ 0.25,
# where the discretization bound holds: the noise-free bias measured below 0.26 of it at 1-10 kHz;
# at fs/4, ωT = 1.57, it grows to 5.4e-3·(ωT)³, 2 %), at least fs/2500 (ωT ≥ 2.5e-3: below, the
# discrete filters' rounding leaves more than its 1e-7 share of the bound, 4e-7 at ωT = 1.3e-3)
MAX_FILTER_FRACTION = 25.0
MIN_FILTER_FRACTION = 2500.0
TRANSIENT_TIME_CONSTANTS = 5.0
MIN_FIT_SAMPLES = 500

# equation name → (parameters: key, symbol, unit), the columns it needs, offset unit, text
_EQUATIONS = {
    "motor": ((("motor_inertia", "J_m", "kg·m²"), ("motor_damping", "B_m", "N·m·s/rad")), ("theta_m", "tau_s", "tau_m"),
              "N·m", "J_m θ̈_m + B_m θ̇_m = τ_s + τ_m"),
    "sea": ((("sea_stiffness", "K_s", "N·m/rad"),), ("theta_j", "theta_m", "tau_s"), "N·m", "τ_s = K_s (θ_j − θ_m)"),
    "joint": ((("joint_inertia", "J_j", "kg·m²"),), ("theta_j", "tau_c", "tau_s"), "N·m", "J_j θ̈_j = τ_c − τ_s"),
    "cuff": ((("cuff_stiffness", "K_c", "N·m/rad"),), ("theta_h", "theta_j", "tau_c"), "N·m", "τ_c = K_c (θ_h − θ_j)"),
}
_DYNAMIC = ("motor", "joint")  # filtered derivatives: the hold's discretization term

# equation → (filtered left-hand side, [(filtered signal, power of s)] of its regressors)
_ROWS = {"motor": ("motor_y", [("theta_m", 2), ("theta_m", 1)]), "sea": ("tau_s", [("sea_x", 0)]),
         "joint": ("joint_y", [("theta_j", 2)]), "cuff": ("tau_c", [("cuff_x", 0)])}


FRICTION = ("coulomb_friction", "F_c", "N·m")  # δ_f = −F_c·sign(θ̇_m), paper eq. (15)
MIN_T = 5.0  # an estimate within 5 standard errors of zero (relative SE > 20 %) is not identified
MAX_DELAY_S = 0.02  # --delay-s auto searches whole samples up to this
_FIXABLE = {key: (key, sym, unit) for pars, *_ in _EQUATIONS.values() for key, sym, unit in pars}
_FIXABLE[FRICTION[0]] = FRICTION


def _number_text(text: str) -> bool:
    """Whether ``text`` is a number as a design file writes one (YAML 1.2, or inf/nan spelled out:
    those are refused afterwards as not finite)."""
    from ..options import NUMBER_TEXT

    t = text.strip()
    return bool(NUMBER_TEXT.fullmatch(t)) or t.lstrip("+-").lower() in ("inf", ".inf", "nan", ".nan", "infinity")


def _shown(value) -> str:
    """A ``--fix`` value as the messages quote it: its repr, a long text cut to an excerpt."""
    return repr(excerpt(value, 40)) if isinstance(value, str) else repr(value)


def parse_fix(fix) -> dict:
    """``{key: value}`` from a mapping or from ``NAME=VALUE`` strings (NAME a design-file key
    such as ``motor_damping`` or its symbol such as ``B_m``; ``coulomb_friction`` / ``F_c``).

    Parameters
    ----------
    fix : mapping, iterable of str, or None
        ``{name: value}`` or ``NAME=VALUE`` strings (a list or tuple of them), values in SI
        units; None: nothing fixed.

    Returns
    -------
    dict of str to float
        Design-file key → fixed value (SI units).

    Raises
    ------
    ConfigError
        Field ``fix``: neither a mapping nor a collection of strings (a number, a single string),
        an unknown name, a value that is not a finite number (a bool is not one), one the
        design file refuses (J_m, K_s, J_j, K_c ≤ 0; B_m or F_c < 0; outside the design file's
        accepted range, docs/design-file.md#input-limits-and-accepted-ranges), or a parameter given two
        different values (``J_m=1`` and ``motor_inertia=2``; the same value twice is accepted).
    """
    if fix is None:
        return {}
    if isinstance(fix, Mapping):
        items = [(str(k), v) for k, v in fix.items()]
    elif isinstance(fix, Iterable) and not isinstance(fix, (str, bytes)):
        items = [str(x).split("=", 1) if "=" in str(x) else (str(x), None) for x in fix]
    else:
        raise ConfigError("fix", f"expected a mapping {{NAME: VALUE}} or a list of 'NAME=VALUE' strings, got "
                          f"{type(fix).__name__} {fix!r}")
    by_symbol = {sym.lower(): key for key, sym, _u in _FIXABLE.values()}
    out, given = {}, {}
    for name, value in items:
        key = name.strip() if name.strip() in _FIXABLE else by_symbol.get(name.strip().lower())
        if key is None:
            raise ConfigError("fix", f"{excerpt(name, 40)!r} is not a plant parameter (known: {', '.join(_FIXABLE)} or their "
                              "symbols J_m, B_m, K_s, J_j, K_c, F_c), as NAME=VALUE")
        try:
            # text as a design file reads it (YAML 1.2 numbers: no '1_000'); a number as given
            v = None if isinstance(value, bool) or (isinstance(value, str) and not _number_text(value)) else float(value)
        except (TypeError, ValueError, OverflowError):
            v = None
        if value is None:  # 'motor_inertia' without '=VALUE' (it read "motor_inertia=None")
            raise ConfigError("fix", f"{excerpt(name, 40)!r} has no value: give it as NAME=VALUE (SI units), "
                                     f"e.g. {key}=1.0")
        if v is None:
            raise ConfigError("fix", f"{name}={_shown(value)}: the value must be a number (SI units)")
        if not math.isfinite(v):
            raise ConfigError("fix", f"{name}={_shown(value)}: the value must be a finite number")
        # the design file's rule for the parameter (docs/design-file.md); Coulomb friction ≥ 0
        op, bound = OVERRIDABLE.get(f"plant.{key}", (">=", 0.0))
        if not (v > bound if op == ">" else v >= bound):
            raise ConfigError("fix", f"{name}={_shown(value)}: {key} must be {op} {bound:g} {_FIXABLE[key][2]}")
        kind = OVERRIDE_LIMITS.get(f"plant.{key}")
        if kind is not None and not in_limits(v, kind):  # the range `exotune design` accepts
            raise ConfigError("fix", f"{name}={_shown(value)}: {key} must be in {limit_text(kind)}, the design file's "
                              "accepted range (docs/design-file.md#input-limits-and-accepted-ranges)")
        if key in out and out[key] != v:  # the same value twice (under two names) is no conflict
            unit = _FIXABLE[key][2]
            raise ConfigError("fix", f"{key} is fixed twice, to {fmt_num(out[key])} {unit} ({given[key]}) and to "
                              f"{fmt_num(v)} {unit} ({name.strip()}={str(value).strip()}): give it one value")
        out[key] = v
        given.setdefault(key, f"{name.strip()}={str(value).strip()}")
    return out


def _as_logs(log) -> list:
    """One log or several identified together: a list of MeasuredLog with the same columns, the
    same kind of motor torque, the same delay and one sample rate (within 1e-4)."""
    logs = [log] if isinstance(log, MeasuredLog) else list(log)
    if not logs:
        raise ConfigError("LOG.csv", "no log to identify")
    first = logs[0]
    for other in logs[1:]:
        check_like(first, other)
        if other.delay_samples != first.delay_samples:
            raise ConfigError("delay_s", f"{other.source} gives {other.delay_samples} samples of delay, "
                              f"{first.source} {first.delay_samples}")
    for j, other in enumerate(logs[1:], start=2):
        i = next((i for i, lg in enumerate(logs[: j - 1], start=1) if same_samples(lg, other)), None)
        if i is not None:
            what = "given twice" if logs[i - 1].source == other.source else f"the same samples as {logs[i - 1].source}"
            raise ConfigError(other.source, f"{what} (logs {i} and {j}): identified together, one run would count "
                              "twice and shrink the standard errors by √2 without new data; give each run once")
    return logs


RATE_TOLERANCE = 1e-4  # logs identified or validated together: one sample rate within this


def check_like(first: MeasuredLog, other: MeasuredLog, field: str | None = None) -> None:
    """Refuse a log that cannot go with ``first``: other columns, or another sample rate (beyond
    :data:`RATE_TOLERANCE`). ``field``: the option to name (``validate``); None names the log
    itself (a log identified together with ``first``).

    Parameters
    ----------
    first : MeasuredLog
        The first fitting log.
    other : MeasuredLog
        Another log (identified together with it, or validated on).
    field : str, optional
        The keyword that gave ``other`` (``"validate"``); None: ``other`` is a fitting log.

    Raises
    ------
    ConfigError
        Naming ``field`` (or the log), the log and what differs.
    """
    if set(other.signals) != set(first.signals):
        diff = ", ".join(sorted(set(other.signals) ^ set(first.signals)))
        if field is None:
            raise ConfigError(other.source, f"logs identified together need the same columns ({first.source} and "
                              f"{other.source} differ in {diff})")
        raise ConfigError(field, f"{other.source}: other columns than the fitting log {first.source} (they differ in "
                          f"{diff}): a validation log needs the fitting log's columns")
    if abs(other.sample_rate_hz / first.sample_rate_hz - 1) > RATE_TOLERANCE:
        if field is None:
            raise ConfigError(other.source, f"sample rate {other.sample_rate_hz:.8g} Hz, {first.source} has "
                              f"{first.sample_rate_hz:.8g} Hz: logs identified together need one rate")
        raise ConfigError(field, f"{other.source}: sample rate {other.sample_rate_hz:.8g} Hz, the fitting log "
                          f"{first.source} has {first.sample_rate_hz:.8g} Hz: a validation log needs the fitting "
                          "log's rate")


@one_blas_thread
def identify_plant(log, filter_hz: float | None = None, *, friction: bool = False,
                   fix=None) -> PlantEstimate:
    """Identify the plant parameters a measured log (or several logs together) determines, each
    equation on its own.

    Parameters
    ----------
    log : MeasuredLog or sequence of MeasuredLog
        The signals (:func:`exotune.identification.read_log`); several logs (same columns, one
        rate, one delay) are identified together: their equations' rows are stacked, each log
        filtered on its own with its own sensor offsets and start-up transients, nothing
        filtered or correlated across a log boundary. A log whose ``delay_samples`` is None
        (``--delay-s auto``) has its delay estimated (whole samples up to 20 ms, the one with
        the smallest motor-equation residual; one delay for every log).
    filter_hz : float, optional
        Corner of the state-variable filter [Hz] (default 20 Hz, at most a hundredth of the
        sample rate; accepted from fs/2500 to fs/25, :func:`filter_corner`): a higher corner
        weights the plant's faster modes, a lower one filters more sensor noise (which biases
        the inertias low, measured and written into the uncertainty) and discretizes more exactly.
    friction : bool
        Add Coulomb friction F_c·sign(θ̇_m) to the motor equation (the paper's δ_f) and estimate F_c.
    fix : mapping or iterable of "NAME=VALUE", optional
        Known parameters (:func:`parse_fix`): moved to the equations' left-hand sides. An
        equation whose parameters are all fixed is fitted for its offset and transients only:
        its fit (R², RMS residual) checks the fixed values, and it still gives a held command's
        delay.

    Returns
    -------
    PlantEstimate
        The estimates with standard errors, covariances and fits; the parameters the log's
        columns cannot give (``missing``) and those an equation could not identify
        (``not_identified``: no excitation, or not significant: within 5 SE of zero).

    Raises
    ------
    ConfigError
        A filter corner out of range or too low for the log, too short a log, a bad ``fix``,
        logs that cannot be identified together (different columns, rates or delays; the same
        samples twice), a log that excites no parameter at all, or an estimate outside the design
        file's accepted range (named with its value and the likely cause: the sample rate or the
        time column's unit, the angles' or torques' units).

    References
    ----------
    docs/identification.md; paper eq. (5).
    """
    fixed = parse_fix(fix)
    logs = _as_logs(log)
    first = logs[0]
    fs = first.sample_rate_hz
    fh = filter_corner(filter_hz, fs)
    shortest = min(lg.samples for lg in logs)
    auto = first.tau_m_held and first.delay_samples is None
    max_delay = min(int(math.ceil(MAX_DELAY_S * fs)), shortest // 10) if auto else (first.delay_samples or 0)
    skips = [_skip(lg, fh, max_delay, filter_hz is not None, len(logs) > 1) for lg in logs]
    sig = FilteredLogs(logs, fh, skips)
    lag = int(math.ceil(CORRELATION_TIME_CONSTANTS * fs / (2 * math.pi * fh)))
    with np.errstate(over="ignore", invalid="ignore", under="ignore"):
        eqs = _equations(friction)
        delay_info, delay = None, 0
        if first.tau_m_held:
            delay_info = _delay(sig, eqs["motor"], fixed, fs, auto, max_delay, min(min(skips), shortest // 10))
            delay = delay_info["samples"]
        est, warnings, errors = _identify(logs, sig, eqs, fixed, delay, delay_info, lag, friction)
    _check_ranges(est, first)
    return dataclasses.replace(est, warnings=tuple(warnings), notes=_rate_notes(logs),
                               model_errors=tuple(ModelError(k, v, why) for k, v, why in errors))


#: Below this rate [Hz] a log taken from its time column is noted as a possible millisecond column:
#: time scaled by 1000 is invisible in the data (the same log of a plant 1000 times slower, every
#: inertia 10⁶ times larger), and no exoskeleton's controller logs this slowly.
SLOW_LOG_HZ = 50.0


def _rate_notes(logs) -> tuple[str, ...]:
    """A note per log whose time column steps at another rate than the one given (the rate given
    is used, as documented: the time column may be in other units), and per log whose rate, taken
    from its time column, is below :data:`SLOW_LOG_HZ` (a time column in milliseconds read as
    seconds)."""
    out = []
    for lg in logs:
        tr, fs = lg.time_rate_hz, lg.sample_rate_hz
        if lg.rate_source == "t" and fs < SLOW_LOG_HZ:
            out.append(f"the time column t of {lg.source} steps {fmt_num(1.0 / fs)} s ({fmt_num(fs)} Hz), slower than "
                       f"any exoskeleton's controller logs: if t is in milliseconds the rate is {fmt_num(fs * 1e3)} Hz "
                       f"and every inertia here is 10⁶ times too large (give --sample-rate-hz)")
        if tr is not None and abs(tr / fs - 1) > RATE_TOLERANCE:
            out.append(f"the rate given, {fmt_num(fs)} Hz (--sample-rate-hz), is used, not the {fmt_num(tr)} Hz of the "
                       f"time column t of {lg.source}: right if t is not in seconds, else the estimates are off (the "
                       f"inertias by the square of the ratio {fmt_num(fs / tr, 4)})")
    return tuple(out)


def filter_corner(filter_hz, sample_rate_hz: float) -> float:
    """The state-variable filter's corner [Hz] for a log at ``sample_rate_hz``: ``filter_hz``
    checked, or (None) the default, :data:`DEFAULT_FILTER_HZ` but at most a hundredth of the rate
    (and at least fs/:data:`MIN_FILTER_FRACTION`).

    Parameters
    ----------
    filter_hz : float or None
        The corner asked for [Hz] (a number: a numpy scalar too, not its text), or None.
    sample_rate_hz : float
        The log's sample rate [Hz].

    Returns
    -------
    float
        The corner [Hz].

    Raises
    ------
    ConfigError
        Field ``filter_hz``: not a number > 0, above fs/:data:`MAX_FILTER_FRACTION` (ωT > 0.25: the
        discrete filters' bias exceeds the discretization bound the standard errors carry) or below
        fs/:data:`MIN_FILTER_FRACTION` (ωT < 2.5e-3: the discrete filters lose their accuracy).
    """
    from ..options import number_value

    fs = float(sample_rate_hz)
    lo, hi = fs / MIN_FILTER_FRACTION, fs / MAX_FILTER_FRACTION
    if filter_hz is None:
        return max(min(DEFAULT_FILTER_HZ, fs / 100), lo)
    fh = number_value("filter_hz", filter_hz, positive=True, noun="a filter corner [Hz]", strings=False)
    if fh > hi:
        raise ConfigError("filter_hz", f"{fmt_num(fh)} Hz is above {fmt_num(hi)} Hz, a {MAX_FILTER_FRACTION:g}th of "
                          f"the sample rate {fmt_num(fs)} Hz (ωT = 2π·f/fs = {2 * math.pi * fh / fs:.3g} > 0.25): the "
                          "discrete filters would bias the inertias beyond the bound their standard errors carry "
                          "(docs/identification.md#method)")
    if fh < lo:
        e = 10.0 ** (math.floor(math.log10(lo)) - 2)
        raise ConfigError("filter_hz", f"{fmt_num(fh)} Hz is too low for the discrete filters at {fmt_num(fs)} Hz "
                          f"(ωT = 2π·f/fs = {2 * math.pi * fh / fs:.3g} < 2.5e-3: they lose their accuracy): a corner "
                          f"of {fmt_num(math.ceil(lo / e) * e, 3)} Hz or more")
    return fh


# the design file's accepted range of each plant parameter (exotune.config), and what scales it:
# the time unit (inertias as its square, damping as itself) or the angles' and torques' units
_RANGE_CAUSE = {"motor_inertia": "time²", "motor_damping": "time", "joint_inertia": "time²",
                "sea_stiffness": None, "cuff_stiffness": None}


def _check_ranges(est, log) -> None:
    """Refuse an estimate outside the design file's accepted range (an inertia of 4.5e7 kg·m²:
    a wrong sample rate, a time column not in seconds, angles or torques in other units), naming
    the parameter, its value, the range and the likely cause: ``exotune design`` would refuse it."""
    for p in est.parameters:
        path = f"plant.{p.key}"
        if p.fixed or path not in OVERRIDE_LIMITS or not p.value > 0 or in_limits(p.value, OVERRIDE_LIMITS[path]):
            continue
        kind = OVERRIDE_LIMITS[path]
        scale = _RANGE_CAUSE.get(p.key)
        fs = fmt_num(log.sample_rate_hz)
        if scale is None:
            cause = "are the angles in rad and the torques in N·m? (docs/identification.md#the-log)"
        elif log.rate_source == "given":
            cause = (f"is the sample rate right? `sample_rate_hz` gave {fs} Hz, and {p.symbol} scales with "
                     f"{'the square of ' if scale == 'time²' else ''}the sample period")
        else:
            cause = (f"is the time column t in seconds? The rate taken from it is {fs} Hz, and {p.symbol} scales "
                     f"with {'the square of ' if scale == 'time²' else ''}the time unit (or give `sample_rate_hz`)")
        raise ConfigError(p.key, f"identified as {fmt_num(p.value)} {p.unit}, outside the design file's accepted range "
                          f"{limit_text(kind)} ({p.symbol}; docs/design-file.md#input-limits-and-accepted-ranges): "
                          f"{cause}")


def _skip(lg, fh: float, max_delay: int, given: bool, several: bool) -> int:
    """The samples of ``lg`` dropped at its start: the filter's transient (5 time constants at
    the corner ``fh`` [Hz]), at least ``max_delay``; refused when fewer than
    :data:`MIN_FIT_SAMPLES` would remain (naming the corner when it was ``given``, else the log)."""
    fs, n = lg.sample_rate_hz, lg.samples
    transient = TRANSIENT_TIME_CONSTANTS / (2 * math.pi * fh) * fs  # [samples]; inf for a subnormal corner
    if transient <= n and n - max(int(math.ceil(transient)), max_delay) >= MIN_FIT_SAMPLES:
        return max(int(math.ceil(transient)), max_delay)
    skip = max(math.ceil(transient) if math.isfinite(transient) else math.inf, max_delay)
    why = (f"{n} samples leave {max(n - skip, 0)} after the filter's transient ({fmt_num(skip)} samples at "
           f"{fmt_num(fh)} Hz): at least {MIN_FIT_SAMPLES} are needed")
    room = n - MIN_FIT_SAMPLES - 1  # the transient's samples that would leave enough (one for the rounding up)
    if given and room > max_delay:
        lowest = max(TRANSIENT_TIME_CONSTANTS * fs / (2 * math.pi * room), fs / MIN_FILTER_FRACTION)
        e = 10.0 ** (math.floor(math.log10(lowest)) - 2)
        lowest = math.ceil(lowest / e) * e  # three digits, rounded up
        if lowest <= fs / MAX_FILTER_FRACTION:
            raise ConfigError("filter_hz", f"{fmt_num(fh)} Hz is too low for {lg.source}: {why} (a corner of "
                              f"{fmt_num(lowest, 3)} Hz or more leaves them)")
    raise ConfigError("t", why + (f" ({lg.source})" if several else ""))


def _equations(friction: bool) -> dict:
    eqs = {name: (list(pars), needs, unit, text, list(_ROWS[name][1]), _ROWS[name][0])
           for name, (pars, needs, unit, text) in _EQUATIONS.items()}
    if friction:
        pars, needs, unit, _text, regs, y = eqs["motor"]
        eqs["motor"] = (pars + [FRICTION], needs, unit, "J_m θ̈_m + B_m θ̇_m + F_c sign(θ̇_m) = τ_s + τ_m",
                        regs + [("fric", 0)], y)
    return eqs


def _estimable(log, friction: bool) -> list:
    """The parameters the columns of ``log`` give (those of every equation whose columns it has)."""
    S = log.signals
    return [key for pars, needs, *_rest in _equations(friction).values()
            if all(c in S or (c == "tau_m" and "tau_cmd" in S) for c in needs) for key, _s, _u in pars]


def _delay(sig, eq, fixed, fs, auto, max_delay, reach) -> dict:
    """The delay of a held command: given, or (auto) the whole number of samples up to
    :data:`MAX_DELAY_S` with the smallest motor-equation residual; with the residuals it explains
    (the motor equation fitted at 0, the delay and its neighbours within ``reach``)."""
    y0, cols, free = regression(sig, eq, fixed, 0)
    held = sig.applied(0)
    y_fixed = tuple(a - b for a, b in zip(y0, held))  # H[τ_s] less the fixed terms
    try:
        design = Design(cols, sig.modes(), [a.size for a in y0])  # no column: J_m, B_m fixed, the residual only
    except NotExcited:
        design = None
    best = max_delay
    if auto and design is not None:
        best = screen_delays(sig, design, y_fixed, max_delay)
    delays = sorted({0, best} | ({best - 1, best + 1} & set(range(reach + 1 if not auto else max_delay + 1))))
    fits = {} if design is None else fit_delays(sig, design, lambda d: tuple(
        a + b for a, b in zip(y_fixed, sig.applied(d))), delays)
    rms = {d: f[0] for d, f in fits.items()}
    betas = {d: {key: float(v) for (key, _s, _u), v in zip(free, f[1])} for d, f in fits.items()}
    info = {"samples": best, "seconds": best / fs, "estimated": auto, "rms_residual": rms.get(best, math.nan),
            "rms_residual_without_delay": rms.get(0, math.nan), "unit": "N·m",
            "rms_residual_neighbours": {str(d): rms[d] for d in (best - 1, best + 1) if d in rms}}
    better = min((d for d in rms if abs(d - best) == 1), key=rms.get, default=None)
    if better is not None and rms[better] < rms[best]:
        info["better_delay"] = {"samples": better, "rms_residual": rms[better],
                                "shift": {k: abs(betas[better][k] / betas[best][k] - 1) for k in betas[best]}}
    return info


# the filtered signals each equation (with its diagnostics) is the last to use: dropped after it
_LAST_USE = {"motor": ("theta_m", "tau_cmd", "tau_m", "fric"), "sea": ("tau_s", "sea_x"), "joint": ("theta_j", "joint_y"),
             "cuff": ("tau_c", "cuff_x")}


def _identify(logs, sig, eqs, fixed, delay, delay_info, lag, friction) -> tuple:
    """The regressions of :func:`identify_plant` (``sig``: the filtered signals), each on its own
    and followed by its diagnostics (:func:`~exotune.identification.diagnose.diagnose`); each
    equation's filtered signals are dropped once no later one needs them. Returns the estimate,
    the warnings and the model errors."""
    params, fits, missing, failed, warnings, errors = [], [], [], [], [], []
    first = logs[0]
    S = first.signals
    fs, fh = first.sample_rate_hz, sig.fh
    disc = discretization_bound(fs, fh)
    attempted = 0
    friction_eq = _equations(True)["motor"]
    for name, eq in eqs.items():
        pars, needs, off_unit, text, _regs, _y = eq
        lacking = [c for c in needs if c not in S and not (c == "tau_m" and "tau_cmd" in S)]
        # a fixed parameter is known whether or not the log can fit its equation
        params += [ParameterEstimate(key, sym, fixed[key], 0.0, unit, fixed=True) for key, sym, unit in pars if key in fixed]
        if lacking:
            missing += [(key, f"needs the column{'s' if len(lacking) > 1 else ''} {', '.join(lacking)}")
                        for key, _s, _u in pars if key not in fixed]
            continue
        y, cols, free = regression(sig, eq, fixed, delay)
        attempted += bool(free)
        # every parameter fixed: the offset and transients alone are fitted, the residual reported
        y_eq = y if len(free) == len(pars) else lhs(sig, eq[5], delay)  # R² about the equation as written
        new, record, bad = _fit_equation(name, text, off_unit, needs, (y, y_eq), cols, free, sig, lag, disc)
        params += new
        fits += record
        failed += bad
        w, e = diagnose(name, {q.key: q for q in new}, sig, friction_eq, fixed, friction, delay, lag, MIN_T,
                        delay_info, eq=eq)
        warnings += w
        errors += e
        for expr in _LAST_USE[name]:
            sig.drop(expr)
    if attempted and not any(not q.fixed for q in params):
        key, why, column = failed[0]
        raise ConfigError(column, f"the log does not excite the plant ({key}: {why}): excite the joint over the "
                          "plant's bandwidth")
    est = PlantEstimate(tuple(params), tuple(fits), fs, sig.samples, float(fh), lag / fs, tuple(missing),
                        " + ".join(lg.source for lg in logs), first.rate_source,
                        tuple((k, why) for k, why, _c in failed), delay_info)
    return est, warnings, errors


def _fit_equation(name, text, off_unit, needs, ys, cols, free, sig, lag, disc) -> tuple[list, list, list]:
    """One equation's least squares: its parameters (those significant), its fit record, and the
    parameters it could not identify with the reason and the column to name. ``ys``: the
    left-hand side per log with the fixed terms moved to it, and as written (for R²); with no
    free parameter only the offset and transients are fitted (the fixed values' residual)."""
    y, y_eq = ys
    what = " and ".join(sym for _k, sym, _u in free)
    try:
        design = Design(cols, sig.modes(), [a.size for a in y])
        fit = design.fit(y)
    except NotExcited as e:
        return [], [], [(key, f"the log does not excite {what} ({e})", needs[0]) for key, _s, _u in free]
    p = len(free)
    cov = design.covariance(fit, lag) if p else np.zeros((0, 0))
    if name in _DYNAMIC:
        cov = cov + np.diag((disc * fit.beta) ** 2)
    params, failed = [], []
    for (key, sym, unit), v, e in zip(free, fit.beta, np.sqrt(np.diag(cov))):
        if key != FRICTION[0] and not abs(v) >= MIN_T * e:
            failed.append((key, f"not significant: {v:.3g} ± {e:.3g} {unit} (the log does not excite {sym})", needs[0]))
        else:
            params.append(ParameterEstimate(key, sym, float(v), float(e), unit))
    record = EquationFit(text, tuple(k for k, _s, _u in free), float(fit.nuisance[0][0]), off_unit,
                         _r2(y_eq, fit, sig.modes()), fit.rms(), "N·m", tuple(tuple(float(c) for c in row) for row in cov[:p, :p]))
    return params, [record], failed


def _r2(y, fit, modes) -> float:
    """R² of a fit, the start-up transients removed from the left-hand side, about each log's mean."""
    tss = 0.0
    for yi, c, M in zip(y, fit.nuisance, modes):
        y0 = yi.copy()
        y0[: M.shape[1]] -= c[1:] @ M
        y0 -= y0.mean()
        tss += float(np.dot(y0, y0))
    return 1.0 - fit.rss() / tss if tss > 0 else math.nan


def identify_file(log_path, out=None, delay_s="0", filter_hz: float | None = None,
                  sample_rate_hz: float | None = None, friction: bool = False, fix=None,
                  validate=None, folds: int | None = None, *, frf_csv=None, plots=None) -> PlantEstimate:
    """``exotune identify``: read a log, or several (:func:`exotune.identification.read_log`),
    identify the plant (:func:`identify_plant`; several logs together), validate it
    (:func:`~exotune.identification.validate.validate_plant`: on the first log, or on
    ``validate``) and write what was asked, all or none
    (:func:`~exotune.jsonio.write_outputs`): with ``out`` the ``plant`` and
    ``uncertainty`` sections it gives as YAML (the identified and fixed parameters, when every
    estimate is physical and at least one was identified), with ``frf_csv`` the measured
    frequency responses, with ``plots`` the figures and ``frequency_response.csv``.

    Parameters
    ----------
    log_path : str or os.PathLike, or a sequence of them
        The measured log (CSV, docs/identification.md#the-log), or several identified together
        (same columns, one rate, one delay).
    out : str or os.PathLike, optional
        The YAML file to write (sections to paste into a design file).
    delay_s : float or "auto"
        Delay [s] from ``tau_cmd`` to the applied torque (logs with ``tau_cmd``).
    filter_hz : float, optional
        Corner of the state-variable filter [Hz].
    sample_rate_hz : float, optional
        Sample rate [Hz], overriding the time column.
    friction : bool
        Estimate Coulomb friction in the motor equation.
    fix : mapping or iterable of "NAME=VALUE", optional
        Known parameters.
    validate : str or os.PathLike, optional
        A second log (same columns and rate) to validate on (:func:`~exotune.identification.validate.validate_plant`).
    folds : int, optional
        k-fold cross-validation on the log itself (contiguous blocks; one log only).
    frf_csv : str or os.PathLike, optional
        Also write the measured frequency responses there (CSV).
    plots : str or os.PathLike, optional
        Also write the Bode overlays, the residual tests (PNG) and ``frequency_response.csv``
        into this directory.

    Returns
    -------
    PlantEstimate

    Raises
    ------
    ConfigError
        Bad input (no log; ``folds`` not a whole number ≥ 2, or with several logs); a log that
        cannot go with the first (other columns, another rate); a ``validate`` log with other
        columns or another rate, or holding the same samples as a fitting log (not held out);
        ``out`` with every parameter the log's columns give fixed (nothing to write); an output
        that cannot be written (then none is).

    References
    ----------
    docs/identification.md.
    """
    import yaml

    from .data import read_log
    from ..jsonio import write_outputs

    fix = parse_fix(fix)  # bad input before the log is read
    from .validate import check_folds, validate_plant

    paths = [log_path] if isinstance(log_path, (str, bytes)) or hasattr(log_path, "__fspath__") else list(log_path)
    if not paths:
        raise ConfigError("LOG.csv", "no log to identify")
    if folds is not None:
        check_folds(folds)
        if len(paths) > 1:
            raise ConfigError("folds", "k-fold cross-validation cuts one log into blocks; with several logs, validate "
                              "on a log not fitted on (`validate` LOG.csv)")
    logs = [read_log(paths[0], delay_s=delay_s, sample_rate_hz=sample_rate_hz)]
    for p in paths[1:]:  # the first log's delay, in samples (checked once the rates are known to agree)
        logs.append(_with_delay(read_log(p, delay_s="0", sample_rate_hz=sample_rate_hz), logs[0], delay_s, None))
    other = None
    if validate is not None:
        other = _with_delay(read_log(validate, delay_s="0", sample_rate_hz=sample_rate_hz), logs[0], delay_s,
                            "validate")
    if folds is not None:
        check_folds(folds, logs[0].samples)
    left = [k for k in _estimable(logs[0], friction) if k not in fix and k != FRICTION[0]]
    if out is not None and not left:
        raise ConfigError("fix", f"every plant parameter the columns of {logs[0].source} give is fixed: nothing is "
                          "left to identify and write to `out` (without it, the fixed values' residuals are reported)")
    for lg in logs if other is not None else ():
        if same_samples(lg, other):
            raise ConfigError("validate", f"{other.source} holds the same samples as the fitting log {lg.source}: a "
                              "validation on it is not held out (give a run not fitted on, or `folds`)")
    est = identify_plant(logs, filter_hz=filter_hz, friction=friction, fix=fix)
    log = logs[0]
    del logs[1:]
    if other is not None and est.delay is not None:  # the delay found on the fitting log
        other = dataclasses.replace(other, delay_samples=est.delay["samples"])
        if est.delay["samples"] >= other.samples - MIN_SAMPLES:
            raise ConfigError("validate", f"{other.source}: {other.samples} samples, the delay of "
                              f"{est.delay['samples']} samples leaves fewer than {MIN_SAMPLES}")
    fh = est.filter_hz
    est = validate_plant(est, dataclasses.replace(log, delay_samples=est.delay["samples"]) if est.delay else log,
                         other, folds, lambda part: identify_plant(part, filter_hz=fh, friction=friction, fix=fix))
    files, dirs = {}, {}
    if out is not None and est.physical and any(not p.fixed for p in est.parameters):
        sec = est.design_sections()
        unc = est.uncertainty()
        head = (f"# exotune identify {est.source}: {est.samples} samples at {est.sample_rate_hz:g} Hz, filter "
                f"{est.filter_hz:g} Hz.\n# plant: the estimates (SI, joint-reflected); uncertainty: relative, the larger "
                f"of {est.to_dict()['uncertainty_sigmas']:g} standard errors and the model error measured:\n"
                + "".join(f"#   {k}: ±{100 * v:.3g} % ({why})\n" for k, (v, why) in unc.items())
                + "# Paste into a design file"
                + (f"; not identified: {', '.join(k for k, _ in est.missing + est.not_identified)}"
                   if est.missing or est.not_identified else "") + ".\n")
        files[out] = head + yaml.safe_dump(sec, sort_keys=False, allow_unicode=True)
    if frf_csv is not None:
        files[frf_csv] = est.validation.to_csv()
    if plots is not None:
        dirs[plots] = {**est.validation.plot(), "frequency_response.csv": est.validation.to_csv()}
    if files or dirs:
        write_outputs(files, dirs)
    return est


def _with_delay(lg: MeasuredLog, first: MeasuredLog, delay_s, field: str | None) -> MeasuredLog:
    """A further log (read without a delay) checked against the first (:func:`check_like`: columns,
    rate) and given the first log's delay in samples (``delay_s`` checked there): one delay for
    every log, whatever small difference of rate there is within :data:`RATE_TOLERANCE`."""
    check_like(first, lg, field)
    if not lg.tau_m_held:
        return lg
    d = first.delay_samples
    if d is not None and d >= lg.samples - MIN_SAMPLES:
        raise ConfigError(field or "delay_s", f"{lg.source}: {lg.samples} samples, a delay of {d} samples "
                          f"({delay_s} s) leaves fewer than {MIN_SAMPLES}")
    return dataclasses.replace(lg, delay_samples=d)
