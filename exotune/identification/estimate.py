"""Least-squares identification of the plant's parameters from a measured log.

Every signal x is passed through the state-variable filter H(s) = ω³/(s + ω)³ and through s·H and
s²·H (:mod:`exotune.identification.filters`: measured signals with a first-order hold, a held
command exactly and through the same sinc² factor), so the equations of the plant (paper eq. (5),
docs/method.md#physical-model) hold between filtered signals without differentiating a measured
signal:

    motor   H[τ_s + τ_m] = J_m · s²H[θ_m] + B_m · sH[θ_m] + c      (δ_f, friction, is left in the residual)
    SEA     H[τ_s]       = K_s · H[θ_j − θ_m] + c
    joint   H[τ_c − τ_s] = J_j · s²H[θ_j] + c
    cuff    H[τ_c]       = K_c · H[θ_h − θ_j] + c

(c: a sensor offset per equation, through H). A log starts in motion, not at rest: the filters'
start-up transients lie in the span of the filter's modes e^{−ωt}, t·e^{−ωt} and t²·e^{−ωt}, which
enter each regression as three more columns; the first 5/ω seconds are dropped besides. The
covariance of each equation's estimate is the sandwich of :mod:`exotune.identification.regress`
(the filtered residual's autocovariance over 30/ω); what the hold leaves (a relative
10⁻³·(ωT)³ + 10⁻⁷, :func:`~exotune.identification.filters.discretization_bound`) is added to the
dynamic equations' variances (J_m, B_m, J_j); the static equations (K_s, K_c) have none.

References
----------
docs/identification.md; paper eq. (5).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..errors import ConfigError
from .data import MeasuredLog
from .filters import discretization_bound, held_svf, svf, velocity_sign
from .regress import CORRELATION_TIME_CONSTANTS, NotExcited, residual_covariance, solve
from .result import EquationFit, ParameterEstimate, PlantEstimate
from .validresult import ModelError

__all__ = ["identify_plant", "identify_file", "parse_fix", "svf", "FRICTION", "MIN_T", "DEFAULT_FILTER_HZ", "TRANSIENT_TIME_CONSTANTS", "MIN_FIT_SAMPLES"]

DEFAULT_FILTER_HZ = 20.0  # at most a hundredth of the sample rate
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


def parse_fix(fix) -> dict:
    """``{key: value}`` from a mapping or from ``NAME=VALUE`` strings (NAME a design-file key
    such as ``motor_damping`` or its symbol such as ``B_m``; ``coulomb_friction`` / ``F_c``).

    Raises
    ------
    ConfigError
        Field ``--fix``: an unknown name or a value that is not a finite number.
    """
    items = fix.items() if isinstance(fix, dict) else [str(x).split("=", 1) if "=" in str(x) else (str(x), None) for x in fix]
    by_symbol = {sym.lower(): key for key, sym, _u in _FIXABLE.values()}
    out = {}
    for name, value in items:
        key = name.strip() if name.strip() in _FIXABLE else by_symbol.get(name.strip().lower())
        if key is None:
            raise ConfigError("--fix", f"{name!r} is not a plant parameter (known: {', '.join(_FIXABLE)} or their "
                              "symbols J_m, B_m, K_s, J_j, K_c, F_c), as NAME=VALUE")
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise ConfigError("--fix", f"{name}={value!r}: the value must be a number (SI units)") from None
        if not math.isfinite(v):
            raise ConfigError("--fix", f"{name}={value!r}: the value must be a finite number")
        out[key] = v
    return out


def identify_plant(log: MeasuredLog, filter_hz: float | None = None, *, friction: bool = False,
                   fix=None) -> PlantEstimate:
    """Identify the plant parameters a measured log determines, each equation on its own.

    Parameters
    ----------
    log : MeasuredLog
        The signals (:func:`exotune.identification.read_log`); a log whose ``delay_samples`` is
        None (``--delay-s auto``) has its delay estimated (whole samples up to 20 ms, the one with
        the smallest motor-equation residual).
    filter_hz : float, optional
        Corner of the state-variable filter [Hz] (default 20 Hz, at most a hundredth of the
        sample rate): a higher corner weights the plant's faster modes, a lower one filters more
        sensor noise and discretizes more exactly.
    friction : bool
        Add Coulomb friction F_c·sign(θ̇_m) to the motor equation (the paper's δ_f) and estimate F_c.
    fix : mapping or iterable of "NAME=VALUE", optional
        Known parameters (:func:`parse_fix`): moved to the equations' left-hand sides.

    Returns
    -------
    PlantEstimate
        The estimates with standard errors, covariances and fits; the parameters the log's
        columns cannot give (``missing``) and those an equation could not identify
        (``not_identified``: no excitation, or not significant: within 3 SE of zero).

    Raises
    ------
    ConfigError
        A filter corner out of range, too short a log, a bad ``fix``, or a log that excites no
        parameter at all.

    References
    ----------
    docs/identification.md; paper eq. (5).
    """
    fixed = parse_fix(fix or {})
    fs = log.sample_rate_hz
    fh = min(DEFAULT_FILTER_HZ, fs / 100) if filter_hz is None else filter_hz
    if not (isinstance(fh, (int, float)) and math.isfinite(fh) and 0 < fh <= fs / 4):
        raise ConfigError("--filter-hz", f"{filter_hz!r}: the filter corner must be in (0, {fs / 4:g}] Hz "
                          "(a quarter of the sample rate)")
    auto = log.tau_m_held and log.delay_samples is None
    max_delay = min(int(math.ceil(MAX_DELAY_S * fs)), log.samples // 10) if auto else (log.delay_samples or 0)
    skip = max(int(math.ceil(TRANSIENT_TIME_CONSTANTS / (2 * math.pi * fh) * fs)), max_delay)
    n = log.samples - skip
    if n < MIN_FIT_SAMPLES:
        raise ConfigError("t", f"{log.samples} samples leave {max(n, 0)} after the filter's transient "
                          f"({skip} samples at {fh:g} Hz): at least {MIN_FIT_SAMPLES} are needed")
    S = log.signals
    cache: dict[str, tuple] = {}
    state = {"delay": max_delay}

    def f(expr: str, k: int) -> np.ndarray:
        if expr == "motor_y":  # a held command (tau_cmd) is filtered as held, the measured τ_s as measured
            return f("tau_s", 0) + f("tau_m", 0)
        if expr == "tau_m" and log.tau_m_held:  # the command, applied `delay` samples later (zero state: shift after)
            h, d = f("tau_cmd", 0), state["delay"]
            return np.concatenate([np.zeros(d), h[: log.samples - d]])[skip:]
        if expr not in cache:
            with np.errstate(over="ignore", invalid="ignore"):
                if expr == "tau_cmd":
                    out = (held_svf(S["tau_cmd"], fs, fh),)
                else:
                    a = {"one": lambda: np.ones(log.samples), "sea_x": lambda: S["theta_j"] - S["theta_m"],
                         "joint_y": lambda: S["tau_c"] - S["tau_s"], "cuff_x": lambda: S["theta_h"] - S["theta_j"],
                         "fric": lambda: velocity_sign(S["theta_m"], fs, fh)}.get(expr, lambda: S[expr])()
                    out = tuple(v[skip:] for v in svf(np.asarray(a, float), fs, fh, "foh"))
            if not all(np.all(np.isfinite(v)) for v in out):
                col = {"sea_x": "theta_j", "joint_y": "tau_c", "cuff_x": "theta_h"}.get(expr, expr)
                raise ConfigError(col, "values too large for the filters (they overflow): check the units")
            cache[expr] = out
        return cache[expr][k]

    with np.errstate(over="ignore", invalid="ignore"):
        eqs = _equations(friction)
        delay_info = None
        if log.tau_m_held:
            delay_info = _delay(log, f, state, eqs["motor"], fixed, skip, fs, fh, auto, max_delay)
        est = _identify(log, S, f, n, fs, fh, skip, eqs, fixed, delay_info)
        warnings, errors = _diagnose(est, f, fixed, _modes(skip, log.samples, fs, fh), friction)
    return dataclasses.replace(est, warnings=tuple(warnings),
                               model_errors=tuple(ModelError(k, v, why) for k, v, why in errors))


def _diagnose(est, f, fixed, modes, friction) -> tuple[list, list]:
    """Model errors the fitting log shows (docs/identification.md#warnings): a neighbouring delay
    with a smaller motor-equation residual, Coulomb friction significant in the motor equation
    when it is not modelled, and errors in variables in the static equations (the reverse
    regression, measurement noise on the other side, disagreeing beyond 3 standard errors).
    Returns the warnings and (key, relative parameter change, cause) of each."""
    warnings, errors = [], []
    value = {p.key: p.value for p in est.parameters if not p.fixed}
    lag = int(round(est.correlation_s * est.sample_rate_hz))
    better = (est.delay or {}).get("better_delay")
    if better:
        warnings.append(f"wrong delay? the motor-equation residual is smaller with a delay of {better['samples']} samples "
                        f"({better['rms_residual']:.3g} N·m against {est.delay['rms_residual']:.3g} N·m): check "
                        "--delay-s, or use --delay-s auto")
        errors += [(k, v, f"a delay of {better['samples']} samples fits the motor equation better")
                   for k, v in better["shift"].items() if k in value]
    if not friction and any({"motor_inertia", "motor_damping"} & set(ft.parameters) for ft in est.fits):
        y, X, free = _regression(f, _equations(True)["motor"], fixed, modes)
        try:
            beta = solve(X, y)
        except NotExcited:
            beta = None
        if beta is not None:
            i = [k for k, _s, _u in free].index(FRICTION[0])
            se = math.sqrt(residual_covariance(X, y - X @ beta, lag)[i, i])
            if beta[i] > MIN_T * se:
                warnings.append(f"friction? the motor-equation residual is correlated with sign(θ̇_m): Coulomb friction "
                                f"F_c ≈ {beta[i]:.3g} ± {se:.2g} N·m ({beta[i] / se:.0f} standard errors); rerun with --friction")
                errors += [(k, abs(b / value[k] - 1), f"Coulomb friction of {beta[i]:.3g} N·m, unmodelled")
                           for (k, _s, _u), b in zip(free, beta) if k in value]
    for fit in est.fits:
        if len(fit.parameters) != 1 or fit.parameters[0] not in ("sea_stiffness", "cuff_stiffness"):
            continue
        key = fit.parameters[0]
        y, x = (f("tau_s", 0), f("sea_x", 0)) if key == "sea_stiffness" else (f("tau_c", 0), f("cuff_x", 0))
        try:
            rev = 1.0 / solve(np.column_stack([y, np.ones_like(y), modes]), x)[0]
        except NotExcited:
            continue
        rel, se = abs(rev / value[key] - 1), est[key].relative_std_error
        if rel > 3 * se:
            sym = est[key].symbol
            warnings.append(f"sensor noise or bias? {sym} from the reverse regression is {rev:.6g} against {value[key]:.6g} "
                            f"({100 * rel:.2g} %, {rel / se:.0f} standard errors): noise on the measured angles "
                            f"biases {sym} low, noise on the torque high")
            errors.append((key, rel, "errors in variables (the reverse regression differs)"))
    return warnings, errors


def _equations(friction: bool) -> dict:
    eqs = {name: (list(pars), needs, unit, text, list(_ROWS[name][1]), _ROWS[name][0])
           for name, (pars, needs, unit, text) in _EQUATIONS.items()}
    if friction:
        pars, needs, unit, _text, regs, y = eqs["motor"]
        eqs["motor"] = (pars + [FRICTION], needs, unit, "J_m θ̈_m + B_m θ̇_m + F_c sign(θ̇_m) = τ_s + τ_m",
                        regs + [("fric", 0)], y)
    return eqs


def _regression(f, eq, fixed, modes):
    """(left-hand side, free regressors with offset and modes, the free parameters) of one
    equation, the fixed parameters moved to the left."""
    pars, _needs, _unit, _text, regs, yname = eq
    y = f(yname, 0).copy()
    free, cols = [], []
    for par, (e, k) in zip(pars, regs):
        if par[0] in fixed:
            y -= fixed[par[0]] * f(e, k)
        else:
            free.append(par)
            cols.append(f(e, k))
    return y, np.column_stack(cols + [f("one", 0), modes]), free


def _modes(skip, samples, fs, fh):
    wt = 2 * math.pi * fh * (np.arange(skip, samples) / fs)
    return np.column_stack([np.exp(-wt), wt * np.exp(-wt), wt * wt * np.exp(-wt)])  # the filters' start-up transients


def _delay(log, f, state, eq, fixed, skip, fs, fh, auto, max_delay) -> dict:
    """The delay of a held command: given, or (auto) the whole number of samples up to
    :data:`MAX_DELAY_S` with the smallest motor-equation residual; with the residuals it explains."""
    modes = _modes(skip, log.samples, fs, fh)
    rms, betas = {}, {}
    given = {0, max_delay} | ({max_delay - 1, max_delay + 1} & set(range(min(skip, log.samples // 10) + 1)))
    for d in (range(max_delay + 1) if auto else sorted(given)):
        state["delay"] = d
        y, X, free = _regression(f, eq, fixed, modes)
        try:
            beta = solve(X, y)
        except NotExcited:
            continue
        rms[d] = float(np.sqrt(np.mean((y - X @ beta) ** 2)))
        betas[d] = {key: float(v) for (key, _s, _u), v in zip(free, beta)}
    best = min(rms, key=rms.get) if (auto and rms) else max_delay
    state["delay"] = best
    info = {"samples": best, "seconds": best / fs, "estimated": auto, "rms_residual": rms.get(best, math.nan),
            "rms_residual_without_delay": rms.get(0, math.nan), "unit": "N·m",
            "rms_residual_neighbours": {str(d): rms[d] for d in (best - 1, best + 1) if d in rms}}
    better = min((d for d in rms if abs(d - best) == 1), key=rms.get, default=None)
    if better is not None and rms[better] < rms[best]:
        info["better_delay"] = {"samples": better, "rms_residual": rms[better],
                                "shift": {k: abs(betas[better][k] / betas[best][k] - 1) for k in betas[best]}}
    return info


def _identify(log, S, f, n, fs, fh, skip, eqs, fixed, delay_info) -> PlantEstimate:
    """The regressions of :func:`identify_plant` (``f``: the filtered signals), each on its own."""
    params, fits, missing, failed = [], [], [], []
    modes = _modes(skip, log.samples, fs, fh)
    lag = int(math.ceil(CORRELATION_TIME_CONSTANTS * fs / (2 * math.pi * fh)))
    disc = discretization_bound(fs, fh)
    attempted = 0
    for name, eq in eqs.items():
        pars, needs, off_unit, text, _regs, _y = eq
        lacking = [c for c in needs if c not in S and not (c == "tau_m" and "tau_cmd" in S)]
        if lacking:
            missing += [(key, f"needs the column{'s' if len(lacking) > 1 else ''} {', '.join(lacking)}")
                        for key, _s, _u in pars if key not in fixed]
            continue
        params += [ParameterEstimate(key, sym, fixed[key], 0.0, unit, fixed=True) for key, sym, unit in pars if key in fixed]
        y, Xf, free = _regression(f, eq, fixed, modes)
        if not free:
            continue
        attempted += 1
        what = " and ".join(sym for _k, sym, _u in free)
        try:
            full = solve(Xf, y)
        except NotExcited as e:
            failed += [(key, f"the log does not excite {what} ({e})", needs[0]) for key, _s, _u in free]
            continue
        r = y - Xf @ full
        p = len(free)
        cov = residual_covariance(Xf, r, lag)[:p, :p]
        if name in _DYNAMIC:
            cov = cov + np.diag((disc * full[:p]) ** 2)
        y0 = y - modes @ full[p + 1:]  # the start-up transient removed, for the fit
        tss = float(np.sum((y0 - y0.mean()) ** 2))
        r2 = 1.0 - float(np.sum(r * r)) / tss if tss > 0 else math.nan
        se = np.sqrt(np.diag(cov))
        for (key, sym, unit), v, e in zip(free, full[:p], se):
            if key != FRICTION[0] and not abs(v) >= MIN_T * e:
                failed.append((key, f"not significant: {v:.3g} ± {e:.3g} {unit} (the log does not excite {sym})", needs[0]))
            else:
                params.append(ParameterEstimate(key, sym, float(v), float(e), unit))
        fits.append(EquationFit(text, tuple(k for k, _s, _u in free), float(full[p]), off_unit, r2,
                                float(np.sqrt(np.mean(r * r))), "N·m", tuple(tuple(float(c) for c in row) for row in cov)))
    if attempted and not any(not q.fixed for q in params):
        key, why, column = failed[0]
        raise ConfigError(column, f"the log does not excite the plant ({key}: {why}): excite the joint over the "
                          "plant's bandwidth")
    return PlantEstimate(tuple(params), tuple(fits), fs, n, float(fh), lag / fs, tuple(missing), log.source,
                         log.rate_source, tuple((k, why) for k, why, _c in failed), delay_info)


def identify_file(log_path, out=None, delay_s="0", filter_hz: float | None = None,
                  sample_rate_hz: float | None = None, friction: bool = False, fix=None,
                  validate=None, folds: int | None = None) -> PlantEstimate:
    """``exotune identify``: read a log (:func:`exotune.identification.read_log`), identify the
    plant (:func:`identify_plant`) and, with ``out``, write the ``plant`` and ``uncertainty``
    sections it gives as YAML (atomically): the identified and fixed parameters, when every
    estimate is physical and at least one was identified.

    Parameters
    ----------
    log_path : str or os.PathLike
        The measured log (CSV, docs/identification.md#the-log).
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
        k-fold cross-validation on the log itself (contiguous blocks).

    Returns
    -------
    PlantEstimate

    Raises
    ------
    ConfigError
        Bad input.

    References
    ----------
    docs/identification.md.
    """
    import yaml

    from ..jsonio import write_atomic
    from .data import read_log

    fix = parse_fix(fix or {})  # bad input before the log is read
    from .validate import validate_plant

    log = read_log(log_path, delay_s=delay_s, sample_rate_hz=sample_rate_hz)
    other = None if validate is None else read_log(validate, delay_s=delay_s, sample_rate_hz=sample_rate_hz)
    est = identify_plant(log, filter_hz=filter_hz, friction=friction, fix=fix)
    if other is not None and est.delay is not None:  # the delay found on the fitting log
        other = dataclasses.replace(other, delay_samples=est.delay["samples"])
    fh = est.filter_hz
    est = validate_plant(est, dataclasses.replace(log, delay_samples=est.delay["samples"]) if est.delay else log,
                         other, folds, lambda part: identify_plant(part, filter_hz=fh, friction=friction, fix=fix))
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
        write_atomic(out, head + yaml.safe_dump(sec, sort_keys=False, allow_unicode=True))
    return est
