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

import math

import numpy as np

from ..errors import ConfigError
from .data import MeasuredLog
from .filters import discretization_bound, held_svf, svf
from .regress import CORRELATION_TIME_CONSTANTS, NotExcited, residual_covariance, solve
from .result import EquationFit, ParameterEstimate, PlantEstimate

__all__ = ["identify_plant", "identify_file", "svf", "DEFAULT_FILTER_HZ", "TRANSIENT_TIME_CONSTANTS", "MIN_FIT_SAMPLES"]

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


def identify_plant(log: MeasuredLog, filter_hz: float | None = None) -> PlantEstimate:
    """Identify the plant parameters a measured log determines.

    Parameters
    ----------
    log : MeasuredLog
        The signals (:func:`exotune.identification.read_log`).
    filter_hz : float, optional
        Corner of the state-variable filter [Hz] (default 20 Hz, at most a hundredth of the
        sample rate): a higher corner weights the plant's faster modes, a lower one filters more
        sensor noise and discretizes more exactly.

    Returns
    -------
    PlantEstimate
        The estimates with standard errors, covariances and fits, and the parameters the log
        cannot give.

    Raises
    ------
    ConfigError
        A filter corner out of range, too short a log, or a log that does not excite a parameter.

    References
    ----------
    docs/identification.md; paper eq. (5).
    """
    fs = log.sample_rate_hz
    fh = min(DEFAULT_FILTER_HZ, fs / 100) if filter_hz is None else filter_hz
    if not (isinstance(fh, (int, float)) and math.isfinite(fh) and 0 < fh <= fs / 4):
        raise ConfigError("--filter-hz", f"{filter_hz!r}: the filter corner must be in (0, {fs / 4:g}] Hz "
                          "(a quarter of the sample rate)")
    delay = log.delay_samples or 0
    skip = max(int(math.ceil(TRANSIENT_TIME_CONSTANTS / (2 * math.pi * fh) * fs)), delay)
    n = log.samples - skip
    if n < MIN_FIT_SAMPLES:
        raise ConfigError("t", f"{log.samples} samples leave {max(n, 0)} after the filter's transient "
                          f"({skip} samples at {fh:g} Hz): at least {MIN_FIT_SAMPLES} are needed")
    S = log.signals
    cache: dict[str, tuple] = {}

    def f(expr: str, k: int) -> np.ndarray:
        if expr == "motor_y":  # a held command (tau_cmd) is filtered as held, the measured τ_s as measured
            return f("tau_s", 0) + f("tau_m", 0)
        if expr not in cache:
            a = {"one": lambda: np.ones(log.samples), "tau_m": lambda: S.get("tau_m"), "sea_x": lambda: S["theta_j"] - S["theta_m"],
                 "joint_y": lambda: S["tau_c"] - S["tau_s"], "cuff_x": lambda: S["theta_h"] - S["theta_j"]
                 }.get(expr, lambda: S[expr])()
            with np.errstate(over="ignore", invalid="ignore"):
                if expr == "tau_m" and log.tau_m_held:  # the command, applied delay_samples later (zero state: shift after)
                    h = held_svf(S["tau_cmd"], fs, fh)
                    out = (np.concatenate([np.zeros(delay), h[: log.samples - delay]])[skip:],)
                else:
                    out = tuple(v[skip:] for v in svf(np.asarray(a, float), fs, fh, "foh"))
            if not all(np.all(np.isfinite(v)) for v in out):
                col = {"sea_x": "theta_j", "joint_y": "tau_c", "cuff_x": "theta_h"}.get(expr, expr)
                raise ConfigError(col, "values too large for the filters (they overflow): check the units")
            cache[expr] = out
        return cache[expr][k]

    with np.errstate(over="ignore", invalid="ignore"):
        return _identify(log, S, f, n, fs, fh, skip)


def _identify(log, S, f, n, fs, fh, skip) -> PlantEstimate:
    """The regressions of :func:`identify_plant` (``f``: the filtered signals)."""
    params, fits, missing = [], [], []
    wt = 2 * math.pi * fh * (np.arange(skip, log.samples) / fs)
    modes = np.column_stack([np.exp(-wt), wt * np.exp(-wt), wt * wt * np.exp(-wt)])  # the filters' start-up transients
    lag = int(math.ceil(CORRELATION_TIME_CONSTANTS * fs / (2 * math.pi * fh)))
    disc = discretization_bound(fs, fh)
    for name, (pars, needs, off_unit, text) in _EQUATIONS.items():
        lacking = [c for c in needs if c not in S and not (c == "tau_m" and "tau_cmd" in S)]
        if lacking:
            missing += [(key, f"needs the column{'s' if len(lacking) > 1 else ''} {', '.join(lacking)}") for key, _s, _u in pars]
            continue
        yname, regs = _ROWS[name]
        y = f(yname, 0)
        X = np.column_stack([f(e, k) for e, k in regs] + [f("one", 0)])
        what = " and ".join(sym for _k, sym, _u in pars)
        Xf = np.column_stack([X, modes])
        try:
            full = solve(Xf, y)
        except NotExcited as e:
            raise ConfigError(needs[0], f"the log does not excite {what} ({e}): excite the joint over the "
                              "plant's bandwidth") from None
        r = y - Xf @ full
        p = len(pars)
        cov = residual_covariance(Xf, r, lag)[:p, :p]
        if name in _DYNAMIC:
            cov = cov + np.diag((disc * full[:p]) ** 2)
        beta = full[:p]
        y0 = y - modes @ full[X.shape[1]:]  # the start-up transient removed, for the fit
        tss = float(np.sum((y0 - y0.mean()) ** 2))
        r2 = 1.0 - float(np.sum(r * r)) / tss if tss > 0 else math.nan
        se = np.sqrt(np.diag(cov))
        for (key, sym, unit), v, e in zip(pars, beta, se):
            params.append(ParameterEstimate(key, sym, float(v), float(e), unit))
        fits.append(EquationFit(text, tuple(k for k, _s, _u in pars), float(full[p]), off_unit, r2,
                                float(np.sqrt(np.mean(r * r))), "N·m", tuple(tuple(float(c) for c in row) for row in cov)))
    return PlantEstimate(tuple(params), tuple(fits), fs, n, float(fh), lag / fs, tuple(missing), log.source,
                         log.rate_source)
def identify_file(log_path, out=None, delay_s="0", filter_hz: float | None = None,
                  sample_rate_hz: float | None = None) -> PlantEstimate:
    """``exotune identify``: read a log (:func:`exotune.identification.read_log`), identify the
    plant (:func:`identify_plant`) and, with ``out``, write the ``plant`` and ``uncertainty``
    sections it gives as YAML (atomically; only when every estimate is physical).

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

    est = identify_plant(read_log(log_path, delay_s=delay_s, sample_rate_hz=sample_rate_hz), filter_hz=filter_hz)
    if out is not None and est.physical:
        sec = est.design_sections()
        head = (f"# exotune identify {est.source}: {est.samples} samples at {est.sample_rate_hz:g} Hz, filter "
                f"{est.filter_hz:g} Hz.\n# plant: the estimates (SI, joint-reflected); uncertainty: "
                f"{est.to_dict()['uncertainty_sigmas']:g} standard errors, relative. Paste into a design file"
                + (f"; not identified: {', '.join(k for k, _ in est.missing)}" if est.missing else "") + ".\n")
        write_atomic(out, head + yaml.safe_dump(sec, sort_keys=False, allow_unicode=True))
    return est
