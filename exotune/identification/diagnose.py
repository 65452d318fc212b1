"""The delay of a held command and the model errors a fitting log shows (docs/identification.md#warnings).

**Delay.** Given, it is checked against its neighbours: the motor equation is fitted at 0, d − 1,
d and d + 1 samples (one set of normal equations, four right-hand sides). With ``--delay-s auto``
every whole number of samples up to 20 ms is screened at once: the normal equations' right-hand
sides and ‖y_d‖² of every delay are cross-correlations of the columns with the filtered command
(FFTs, per log), so the residual of each delay costs a few products, not a regression; the best
and its neighbours are then fitted explicitly.

**Model errors.** A neighbouring delay with a smaller motor-equation residual, Coulomb friction
significant in the motor equation when it is not modelled, errors in variables in the static
equations (the reverse regression, measurement noise on the other side, disagreeing beyond 3
standard errors), and in the dynamic ones (the inertia's regressor s²H[θ] reversed: the angle
sensor's noise amplified by the filter biases the inertia low; the difference, plus 3 standard
errors, is a model error from half a standard error on, and a warning beyond 3). Differences below
:data:`ROUNDING` (relative) are the regressions' rounding and never reported.

References
----------
docs/identification.md#options, docs/identification.md#warnings.
"""

from __future__ import annotations

import math

import numpy as np

from .regress import Design, NotExcited
from .result import UNCERTAINTY_SIGMAS

__all__ = ["fit_delays", "screen_delays", "diagnose", "regression", "ROUNDING"]

ROUNDING = 1e-8  # a relative difference of two regressions below this is their rounding, not a model error


def regression(sig, eq, fixed, delay: int = 0):
    """(left-hand side per log, free columns, the free parameters) of one equation (``eq`` as in
    :mod:`exotune.identification.estimate`), the fixed parameters moved to the left.

    Parameters
    ----------
    sig : FilteredLogs
        The filtered signals of the logs.
    eq : tuple
        The equation: (parameters, needed columns, unit, text, regressors, left-hand side name).
    fixed : dict of str to float
        Fixed parameter values (SI units), by key.
    delay : int, optional
        Delay [samples] of the held command.

    Returns
    -------
    y : tuple of numpy.ndarray
        The left-hand side per log.
    cols : list
        The free parameters' columns, each a tuple of per-log arrays.
    free : list of tuple
        The free parameters (key, symbol, unit).
    """
    pars, _needs, _unit, _text, regs, yname = eq
    y = lhs(sig, yname, delay)
    free, cols = [], []
    for par, (e, k) in zip(pars, regs):
        c = sig.get(e, k)
        if par[0] in fixed:
            y = tuple(a - fixed[par[0]] * b for a, b in zip(y, c))
        else:
            free.append(par)
            cols.append(c)
    return y, cols, free


def lhs(sig, name: str, delay: int) -> tuple:
    """A left-hand side per log: ``motor_y`` is H[τ_s] + H[τ_m] as applied after ``delay``."""
    if name == "motor_y":
        return tuple(a + b for a, b in zip(sig.get("tau_s"), sig.applied(delay)))
    return sig.get(name)


def fit_delays(sig, design, y_base_fn, delays) -> dict:
    """{delay: (RMS residual, estimates)} of the motor equation at each delay (``y_base_fn(d)``:
    its left-hand side).

    Parameters
    ----------
    sig : FilteredLogs
        The filtered signals of the logs.
    design : Design
        The motor equation's regression.
    y_base_fn : callable
        ``y_base_fn(d)``: the left-hand side per log at a delay of d samples.
    delays : iterable of int
        The delays [samples] to fit.

    Returns
    -------
    dict
        Delay [samples] → (RMS residual [N·m], estimates); a delay whose fit is not excited is left
        out.
    """
    out = {}
    for d in delays:
        try:
            fit = design.fit(y_base_fn(d))
        except NotExcited:
            continue
        out[d] = (fit.rms(), fit.beta)
    return out


def screen_delays(sig, design, y_fixed, max_delay: int) -> int:
    """The whole number of samples 0…``max_delay`` with the smallest motor-equation residual:
    y_d = ``y_fixed`` (per log, H[τ_s] less the fixed terms) + H[τ_cmd] delayed by d; every delay's
    residual from cross-correlations (module docstring).

    Parameters
    ----------
    sig : FilteredLogs
        The filtered signals of the logs.
    design : Design
        The motor equation's regression.
    y_fixed : tuple of numpy.ndarray
        Per log, H[τ_s] less the fixed terms.
    max_delay : int
        The largest delay [samples] screened.

    Returns
    -------
    int
        The best delay [samples].
    """
    import scipy.fft

    D = max_delay
    rss = np.zeros(D + 1)
    b = np.zeros((D + 1, design.unknowns))
    lags = np.arange(D, -1, -1)  # delay d is lag D − d of u
    for i, (M, y0, s) in enumerate(zip(design.modes, y_fixed, sig.skips)):
        n, K = y0.size, M.shape[1]
        u = sig.command(i)[s - D: s + n]  # u[t + D − d]: the command applied d samples late, at kept row t
        m = int(scipy.fft.next_fast_len(n + D + 1, real=True))
        U = scipy.fft.rfft(u, m)
        rows = np.vstack([c / d for c, d in zip(design.cols[i], design.div)] + [y0[None]])
        C = scipy.fft.irfft(np.conj(scipy.fft.rfft(rows, m, axis=1)) * U, m, axis=1)[:, lags]  # (p + 1, D + 1)
        cu = np.concatenate([[0.0], np.cumsum(u)])
        cu2 = np.concatenate([[0.0], np.cumsum(u * u)])
        windows = np.lib.stride_tricks.sliding_window_view(u, K)[lags]  # (D + 1, K)
        shifted = np.column_stack([C[:-1].T, cu[lags + n] - cu[lags], windows @ M.T])  # Xᵀ(S_d h)
        b[:, design.index(i)] += design.dot(i, y0)[None] + shifted
        rss += float(np.dot(y0, y0)) + 2 * C[-1] + (cu2[lags + n] - cu2[lags])
    rss -= np.einsum("di,ij,dj->d", b, design.Ginv, b)
    return int(np.argmin(rss))


def diagnose(name: str, fitted: dict, sig, friction_eq, fixed, friction: bool, delay: int, lag: int, min_t: float,
             delay_info, eq=None) -> tuple[list, list]:
    """Model errors the fitting logs show in the equation ``name`` just identified (module
    docstring); ``fitted``: its parameters (key → ParameterEstimate). Returns the warnings and
    (key, relative parameter change, cause) of each.

    Parameters
    ----------
    name : str
        The equation: ``"motor"``, ``"sea"``, ``"joint"`` or ``"cuff"``.
    fitted : dict
        Its parameters, key → ParameterEstimate.
    sig : FilteredLogs
        The filtered signals of the logs.
    friction_eq : tuple
        The motor equation with Coulomb friction.
    fixed : dict of str to float
        Fixed parameter values (SI units).
    friction : bool
        Whether friction was identified.
    delay : int
        Delay [samples] of the held command.
    lag : int
        Lag window [samples] of the standard errors.
    min_t : float
        Standard errors beyond which friction counts as significant.
    delay_info : dict or None
        The delay's residuals (with ``better_delay`` when a neighbour fits better).
    eq : tuple, optional
        The equation as fitted (for the reverse regression of a dynamic equation's inertia);
        None: not checked.

    Returns
    -------
    warnings : list of str
        The warnings.
    errors : list of tuple
        ``(key, relative parameter change, cause)`` per warning.
    """
    warnings, errors = [], []
    value = {k: p.value for k, p in fitted.items() if not p.fixed}
    if name == "motor":
        better = (delay_info or {}).get("better_delay")
        if better:
            warnings.append(f"wrong delay? the motor-equation residual is smaller with a delay of {better['samples']} "
                            f"samples ({better['rms_residual']:.3g} N·m against {delay_info['rms_residual']:.3g} N·m): "
                            "check --delay-s, or use --delay-s auto")
            errors += [(k, v, f"a delay of {better['samples']} samples fits the motor equation better")
                       for k, v in better["shift"].items() if k in value]
        if not friction and value:
            w, e = _friction(sig, friction_eq, fixed, delay, lag, value, min_t)
            warnings += w
            errors += e
    if name in ("motor", "joint") and eq is not None and value:
        w, e = _noisy_inertia(fitted, value, sig, eq, fixed, delay)
        warnings += w
        errors += e
    key = {"sea": "sea_stiffness", "cuff": "cuff_stiffness"}.get(name)
    if key in value:
        y, x = (sig.get("tau_s"), sig.get("sea_x")) if name == "sea" else (sig.get("tau_c"), sig.get("cuff_x"))
        try:
            rev = 1.0 / Design([y], sig.modes()).fit(x).beta[0]
        except NotExcited:
            return warnings, errors
        rel, se = abs(rev / value[key] - 1), fitted[key].relative_std_error
        if rel > 3 * se and rel > ROUNDING:
            sym = fitted[key].symbol
            warnings.append(f"sensor noise or bias? {sym} from the reverse regression is {rev:.6g} against {value[key]:.6g} "
                            f"({100 * rel:.2g} %, {rel / se:.0f} standard errors): noise on the measured angles "
                            f"biases {sym} low, noise on the torque high")
            errors.append((key, rel, "errors in variables (the reverse regression differs)"))
    return warnings, errors


def _noisy_inertia(fitted, value, sig, eq, fixed, delay) -> tuple[list, list]:
    """Errors in variables in a dynamic equation: its inertia's regressor s²H[θ] carries the
    angle sensor's noise amplified by the filter (∝ ω² up to the corner), which biases the
    inertia low (regression dilution). The regression reversed (s²H[θ] on the left-hand side and
    the other regressors) is biased the other way by the same noise, so the truth lies between
    the two; a difference beyond half a standard error is a model error of the difference plus
    :data:`~exotune.identification.result.UNCERTAINTY_SIGMAS` standard errors (the bracket and the
    estimate's own random error), and a warning beyond that many standard errors."""
    y, cols, free = regression(sig, eq, fixed, delay)
    if not free or free[0][0] not in ("motor_inertia", "joint_inertia") or free[0][0] not in value:
        return [], []
    try:
        a = Design([y] + cols[1:], sig.modes()).fit(cols[0]).beta
    except NotExcited:
        return [], []
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        rev = np.concatenate([[1.0 / a[0]], -a[1:] / a[0]])
    warnings, errors = [], []
    for (key, sym, _unit), b in zip(free, rev):
        if key not in value or key == "coulomb_friction":
            continue
        rel = abs(b / value[key] - 1) if math.isfinite(b) else math.inf
        se = fitted[key].relative_std_error
        if not (rel > se / 2 and rel > ROUNDING):
            continue
        k = UNCERTAINTY_SIGMAS
        errors.append((key, rel + k * se, f"errors in variables: the reverse regression differs by {100 * rel:.2g} %, "
                                          f"plus {k:g} SE"))
        if rel > k * se:
            warnings.append(f"sensor noise? {sym} from the reverse regression is {b:.6g} against {value[key]:.6g} "
                            f"({100 * rel:.2g} %, {rel / se:.0f} standard errors): noise on the measured angle, "
                            f"amplified by the filter's s², biases {sym} low; the written uncertainty covers the "
                            "difference (a lower --filter-hz passes less noise)")
    return warnings, errors


def _friction(sig, eq, fixed, delay, lag, value, min_t) -> tuple[list, list]:
    """The motor equation refitted with F_c·sign(θ̇_m): a warning and the parameter changes when
    F_c exceeds ``min_t`` standard errors."""
    y, cols, free = regression(sig, eq, fixed, delay)
    try:
        design = Design(cols, sig.modes())
        fit = design.fit(y)
    except NotExcited:
        return [], []
    i = [k for k, _s, _u in free].index("coulomb_friction")
    se = math.sqrt(design.covariance(fit, lag, which=[i])[0, 0])
    fc = float(fit.beta[i])
    if not fc > min_t * se:
        return [], []
    w = [f"friction? the motor-equation residual is correlated with sign(θ̇_m): Coulomb friction "
         f"F_c ≈ {fc:.3g} ± {se:.2g} N·m ({fc / se:.0f} standard errors); rerun with --friction"]
    e = [(k, abs(b / value[k] - 1), f"Coulomb friction of {fc:.3g} N·m, unmodelled")
         for (k, _s, _u), b in zip(free, fit.beta) if k in value]
    return w, e
