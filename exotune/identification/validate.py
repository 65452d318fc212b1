"""Validation of an identified plant on data it was not fitted on (``exotune identify --validate
LOG2.csv``, ``--folds K``): the identified plant's equations simulated from the log's measured
inputs and compared with its measured outputs (NRMSE), the residual tests of those simulation
errors, and the frequency responses of :mod:`exotune.identification.frf`.

Simulated outputs (docs/identification.md#validation):

    motor   θ_m  from τ_m (or τ_cmd, delayed and held) and the measured τ_s:  (J_m s² + B_m s) θ_m = τ_m + τ_s [− F_c sign(θ̇_m)]
    drive   θ_j  from τ_m and the measured τ_c, through the spring (needs J_m, B_m, K_s, J_j)
    spring  τ_s  from θ_j − θ_m:  K_s (θ_j − θ_m)
    cuff    τ_c  from θ_h − θ_j:  K_c (θ_h − θ_j)

The dynamic ones are simulated exactly in modal form (each mode a first-order recursion through
``scipy.signal.lfilter``: the exact zero-order hold of a held command, the exact first-order hold
of a measured signal), the equivalent of ``scipy.signal.dlsim`` of the discretized model without
its per-sample Python loop. The unknown initial state and the sensor offsets are fitted, as
MATLAB's ``compare`` does: the simulation error's projection onto the model's free responses (a
constant, a ramp from a torque offset, e^{λt} for each mode) is removed. With friction
estimated, sign(θ̇_m) comes from the measured motor angle.

References
----------
docs/identification.md#validation.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ConfigError
from ..numerics.threads import one_blas_thread
from .data import MIN_SAMPLES, MeasuredLog
from .filters import velocity_sign
from .frf import applied_torque, frequency_responses
from .validresult import CONFIDENCE_Z, ModelError, OutputFit, ResidualTest, Validation

__all__ = ["validate_plant", "check_folds", "simulate_outputs", "residual_test", "nrmse_percent", "FreeResponses", "LAGS"]

LAGS = 25  # residual tests at lags 0…25 (cross-correlation −25…25), as MATLAB's resid


def _mode_response(lam: complex, u: np.ndarray, T: float, hold: str) -> np.ndarray:
    """z' = λ z + u, from the zero state, sampled exactly for ``u`` held ("zoh") or linear
    between samples ("foh"); real arithmetic for a real λ."""
    import scipy.signal

    a = lam * T
    e = np.exp(a)
    if abs(a) < 1e-6:
        g, g1 = T * (1 + a / 2 + a * a / 6), T * (0.5 + a / 6 + a * a / 24)
    else:
        g, g1 = T * np.expm1(a) / a, T * (np.expm1(a) - a) / (a * a)
    b = [0.0, g] if hold == "zoh" else [g1, g - g1]
    if np.imag(lam) == 0:
        return scipy.signal.lfilter(np.real(b), [1.0, -np.real(e)], u)
    return scipy.signal.lfilter(np.asarray(b, complex), [1.0, -e], u.astype(complex))


def _simulate(A, B, c, inputs, fs, t):
    """Output c·x of ẋ = A x + Σ B[:, j] u_j (``inputs``: (u_j, hold)) from the zero state, and
    the free responses (constant, ramp, e^{λt}: :class:`FreeResponses`) to project out; None if
    A is not diagonalizable.
    One recursion per mode and kind of hold (the inputs of one hold summed first); a complex
    pair's second mode is the first's conjugate."""
    lam, V = np.linalg.eig(A)
    if np.linalg.cond(V) > 1e8:
        return None, None
    G, cv = np.linalg.solve(V, B), c @ V
    y = np.zeros(t.size)
    for i, li in enumerate(lam):
        if li.imag < 0 and np.any(np.isclose(lam[:i], np.conj(li), rtol=1e-12, atol=0)):
            continue  # the conjugate of a mode already run: its output is the conjugate
        pair = 2.0 if li.imag > 0 else 1.0
        for hold in ("zoh", "foh"):
            js = [j for j, (_u, h) in enumerate(inputs) if h == hold and G[i, j] != 0 and cv[i] != 0]
            if not js:
                continue
            drive = sum(G[i, j] * inputs[j][0] for j in js)
            if li.imag == 0:
                drive = np.real(drive) if np.all(np.isreal(G[i, js])) else drive
            z = _mode_response(li, drive, 1 / fs, hold)
            y += pair * np.real(cv[i] * z)
    modes = [li for li in lam if abs(li) > 1e-9 * max(1.0, np.max(np.abs(lam))) and li.imag >= 0]
    return y, FreeResponses(t.size, fs, tuple(modes))


class FreeResponses:
    """The free responses of a simulated model over ``n`` samples at ``fs``: a constant, a ramp
    (t − t̄; unless ``ramp`` is False) and, per mode λ (Im λ ≥ 0), e^{λt} (its real and imaginary
    parts), each scaled to unit maximum; made a block of samples at a time (never as n×k
    columns)."""

    BLOCK = 1 << 16

    def __init__(self, n: int, fs: float, modes=(), ramp: bool = True):
        self.n, self.fs, self.modes, self.ramp = n, fs, tuple(modes), ramp
        T = (n - 1) / fs
        peaks = [max(1.0, math.exp(min(li.real * T, 700.0))) for li in self.modes]
        self.scale = [1.0] + ([max(T / 2, 1e-300)] if ramp else []) + [
            p for li, p in zip(self.modes, peaks) for _ in range(2 if li.imag > 0 else 1)]
        with np.errstate(under="ignore", over="ignore"):
            self.base = [np.exp(li * np.arange(min(self.BLOCK, n)) / fs) for li in self.modes]

    def block(self, lo: int, hi: int) -> np.ndarray:
        """The columns at samples lo…hi−1, as rows (k, hi − lo): e^{λt} as e^{λ t_lo}·e^{λ(t − t_lo)},
        the second factor computed once for all blocks."""
        t = np.arange(lo, hi) / self.fs
        rows = [np.ones_like(t)] + ([t - (self.n - 1) / (2 * self.fs)] if self.ramp else [])
        for li, base in zip(self.modes, self.base):
            with np.errstate(under="ignore", over="ignore"):
                ex = base[: hi - lo] * np.exp(li * lo / self.fs)
            rows += [ex.real] + ([ex.imag] if li.imag > 0 else [])
        return np.array(rows) / np.asarray(self.scale)[:, None]

    def project_out(self, e: np.ndarray) -> None:
        """Remove from ``e`` (in place) its least-squares projection onto the free responses: the
        normal equations (SVD, rank-deficient directions dropped as lstsq does), refined once when
        they are ill-conditioned."""
        k = len(self.scale)
        G, b = np.zeros((k, k)), np.zeros(k)
        spans = [(lo, min(lo + self.BLOCK, self.n)) for lo in range(0, self.n, self.BLOCK)]
        for lo, hi in spans:
            F = self.block(lo, hi)
            G += F @ F.T
            b += F @ e[lo:hi]
        if not np.all(np.isfinite(G)):
            return
        c = np.linalg.lstsq(G, b, rcond=1e-13)[0]
        d = 1.0 / np.sqrt(np.maximum(np.diag(G), 1e-300))
        lam = np.linalg.eigvalsh(G * np.outer(d, d))
        if not lam[0] > 0 or lam[-1] / lam[0] > 1e4:
            b = np.zeros(k)
            for lo, hi in spans:
                F = self.block(lo, hi)
                b += F @ (e[lo:hi] - c @ F)
            c = c + np.linalg.lstsq(G, b, rcond=1e-13)[0]
        for lo, hi in spans:
            e[lo:hi] -= c @ self.block(lo, hi)


def nrmse_percent(y, y_sim, free) -> tuple[float, np.ndarray]:
    """100·‖y − ŷ‖/‖y − ȳ‖ after the error's projection onto the free responses
    (:class:`FreeResponses`, or None), and that error.

    Parameters
    ----------
    y : numpy.ndarray
        The measured output.
    y_sim : numpy.ndarray
        The simulated output.
    free : FreeResponses or None
        The free responses projected out of the error; None for none.

    Returns
    -------
    nrmse : float
        The normalized error [%] (NaN for a constant output).
    e : numpy.ndarray
        The error after the projection.
    """
    e = y - y_sim
    if free is not None:
        free.project_out(e)
    d = float(np.linalg.norm(y - y.mean()))
    return (100.0 * float(np.linalg.norm(e)) / d if d > 0 else math.nan), e


def simulate_outputs(log: MeasuredLog, val: dict, delay: int, filter_hz: float):
    """(output, inputs text, measured, simulated, free responses, input for the residual test)
    of each output the log's columns and the parameters ``val`` (key → value) allow
    (``filter_hz``: the identification's corner, for sign(θ̇_m) as the friction term had it); a
    generator: one output's arrays at a time.

    Parameters
    ----------
    log : MeasuredLog
        The log.
    val : dict of str to float
        Parameter values (SI units), by key.
    delay : int
        Delay [samples] of ``tau_cmd``.
    filter_hz : float
        The identification's filter corner [Hz].

    Yields
    ------
    tuple
        ``(output, inputs text, measured, simulated, FreeResponses, input)``.
    """
    S, fs = log.signals, log.sample_rate_hz
    t = np.arange(log.samples) / fs
    tau_m = applied_torque(log, delay)
    hold = "zoh" if log.tau_m_held else "foh"
    fric = []
    if "coulomb_friction" in val:
        fric = [(-val["coulomb_friction"] * velocity_sign(S["theta_m"], fs, filter_hz), "foh")]
    tm_in = "τ_m (τ_cmd delayed, held)" if log.tau_m_held else "τ_m"
    if {"motor_inertia", "motor_damping"} <= set(val):
        jm, bm = val["motor_inertia"], val["motor_damping"]
        y, free = _simulate(np.array([[0, 1], [0, -bm / jm]]), np.array([[0, 0, 0], [1 / jm, 1 / jm, 1 / jm]]),
                            np.array([1.0, 0.0]), [(tau_m, hold), (S["tau_s"], "foh")] + fric, fs, t)
        yield "θ_m", f"{tm_in}, τ_s", S["theta_m"], y, free, tau_m
        y = free = None
        if {"sea_stiffness", "joint_inertia"} <= set(val) and "tau_c" in S and "theta_j" in S:
            ks, jj = val["sea_stiffness"], val["joint_inertia"]
            A = np.array([[0, 1, 0, 0], [-ks / jm, -bm / jm, ks / jm, 0], [0, 0, 0, 1], [ks / jj, 0, -ks / jj, 0]])
            B = np.zeros((4, 3))
            B[1, 0] = B[1, 2] = 1 / jm
            B[3, 1] = 1 / jj
            y, free = _simulate(A, B, np.array([0.0, 0, 1, 0]), [(tau_m, hold), (S["tau_c"], "foh")] + fric, fs, t)
            if y is not None:
                yield "θ_j", f"{tm_in}, τ_c (through the spring)", S["theta_j"], y, free, tau_m
            y = free = None
    for key, col, x, text in (("sea_stiffness", "tau_s", ("theta_j", "theta_m"), "θ_j − θ_m"),
                              ("cuff_stiffness", "tau_c", ("theta_h", "theta_j"), "θ_h − θ_j")):
        if key in val and col in S and all(c in S for c in x):
            dx = S[x[0]] - S[x[1]]
            yield col.replace("tau_", "τ_"), text, S[col], val[key] * dx, FreeResponses(dx.size, fs, ramp=False), dx


def residual_test(output: str, input_name: str, e: np.ndarray, u: np.ndarray, lags: int = LAGS,
                  input_stats=None) -> ResidualTest:
    """Autocorrelation of ``e`` (lags 0…M, bound 2.58/√N) and its cross-correlation with ``u``
    (lags −M…M, bound 2.58·√(Σ_k ρ_e(k) ρ_u(k))/√N for coloured signals, summed over |k| < N/20).
    Correlations by float32 FFTs of the signals scaled to unit maximum (the bounds are ~1e-2, the
    FFTs' error ~1e-6), of length ≥ N + N/20 (no wrap at any lag used); ``input_stats``: a cache
    for ``u``'s spectrum and autocorrelation (under ``input_name``) when several outputs share an
    input.

    Parameters
    ----------
    output : str
        The output's name.
    input_name : str
        The input's name.
    e : numpy.ndarray
        The simulation error.
    u : numpy.ndarray
        The input.
    lags : int, optional
        Largest lag M [samples] reported.
    input_stats : dict or None, optional
        The cache of input spectra; None for none.

    Returns
    -------
    ResidualTest
        The correlations, their bounds and the lag of the largest cross-correlation.
    """
    n = e.size
    e = e - e.mean()  # (a copy: the caller's error is left as it is)
    K = max(lags, n // 20)
    m = _fast(n + K + 1)
    see = float(np.dot(e, e))
    U, ruu, suu = _input_spectrum(u, m, K, input_stats, input_name)
    if see == 0 or suu == 0:
        z = np.zeros(lags + 1)
        return ResidualTest(output, input_name, np.arange(lags + 1), z, CONFIDENCE_Z / math.sqrt(n),
                            np.arange(-lags, lags + 1), np.zeros(2 * lags + 1), math.inf, 0)
    E, se = _rfft32(e, m)
    ree = _irfft(E.real * E.real + E.imag * E.imag, m, K) * (se * se / see)
    reu = _irfft(U * np.conj(E), m, lags + 1, lags) * (se / math.sqrt(see))  # Σ e(k) u(k + τ): the input leads at τ < 0
    k = np.r_[np.arange(K), np.arange(-K + 1, 0)]
    bound = CONFIDENCE_Z * math.sqrt(max(float(np.sum(ree[np.abs(k)] * ruu[np.abs(k)])), 1.0) / n)
    cl = np.arange(-lags, lags + 1)
    cross = reu[-cl]  # positive lag: e(t) against u(t − lag) = reu at −lag, the input leading
    peak = int(cl[int(np.argmax(np.abs(cross)))])
    return ResidualTest(output, input_name, np.arange(lags + 1), ree[: lags + 1], CONFIDENCE_Z / math.sqrt(n),
                        cl, cross, bound, peak)


def _fast(n: int) -> int:
    import scipy.fft

    return int(scipy.fft.next_fast_len(n, real=True))


def _rfft32(x: np.ndarray, m: int):
    import scipy.fft

    s = float(np.max(np.abs(x))) or 1.0
    return scipy.fft.rfft((x / s).astype(np.float32), m, workers=2), s


def _irfft(X: np.ndarray, m: int, keep: int, negative: int = 0) -> np.ndarray:
    """The inverse transform's lags 0…keep−1 (and −negative…−1 at the end, as a circular array
    of keep + negative values: index −k is lag −k)."""
    import scipy.fft

    out = scipy.fft.irfft(X, m, workers=2)
    return np.concatenate([out[:keep], out[m - negative:]]).astype(float) if negative else out[:keep].astype(float)


def _input_spectrum(u: np.ndarray, m: int, K: int, cache, name: str):
    """(spectrum scaled by its norm, normalized autocorrelation at lags 0…K−1, Σu²) of the
    centred input, cached in ``cache`` under its name."""
    key = (name, m, K)
    if cache is not None and key in cache:
        return cache[key]
    u = u - u.mean()
    suu = float(np.dot(u, u))
    if suu == 0:
        out = (None, None, 0.0)
    else:
        U, su = _rfft32(u, m)
        ruu = _irfft(U.real * U.real + U.imag * U.imag, m, K) * (su * su / suu)
        out = (U * np.float32(su / math.sqrt(suu)), ruu, suu)
    if cache is not None:
        cache[key] = out
    return out


def _slice(log: MeasuredLog, a: int, b: int) -> MeasuredLog:
    return MeasuredLog(log.sample_rate_hz, {k: v[a:b] for k, v in log.signals.items()}, log.source,
                       log.delay_samples, log.rate_source)


def _values(est) -> dict:
    return {p.key: p.value for p in est.parameters}


def _fold_values(log, est, a, b, refit) -> dict | None:
    """The parameters fitted on the log without samples a…b: each remaining part identified on
    its own (``refit``), combined by inverse-variance weighting (fixed parameters kept)."""
    parts = []
    for lo, hi in ((0, a), (b, log.samples)):
        try:
            parts.append(refit(_slice(log, lo, hi)))
        except ConfigError:
            continue
    if not parts:
        return None
    out = {}
    for key, v in _values(est).items():
        got = [(p[key].value, p[key].std_error) for p in parts if key in {q.key for q in p.parameters}]
        if est[key].fixed or not got:
            out[key] = v
        else:
            w = np.array([1 / max(s, 1e-300) ** 2 for _v, s in got])
            out[key] = float(np.dot(w, [x for x, _s in got]) / w.sum())
    return out


def _kfold(log, est, folds, refit, delay) -> list[OutputFit]:
    n = log.samples
    edges = np.linspace(0, n, folds + 1).astype(int)
    by_output: dict[str, list] = {}
    for i in range(folds):
        a, b = int(edges[i]), int(edges[i + 1])
        val = _fold_values(log, est, a, b, refit)
        if val is None:
            continue
        for name, inputs, y, ys, free, _u in simulate_outputs(_slice(log, a, b), val, delay, est.filter_hz):
            by_output.setdefault(name, [inputs, []])[1].append((nrmse_percent(y, ys, free)[0], b - a))
    return [OutputFit(name, inputs, float(np.mean([x for x, _n in v])), int(sum(m for _x, m in v)),
                      f"{folds}-fold (NRMSE {min(x for x, _n in v):.3g}–{max(x for x, _n in v):.3g} %)")
            for name, (inputs, v) in by_output.items()]


def check_folds(folds, samples: int | None = None) -> int:
    """The number of folds of a k-fold cross-validation: a whole number (an ``int`` or a numpy
    integer, not a bool) of at least 2, each fold holding at least twice the minimum log of
    ``samples`` when given.

    Parameters
    ----------
    folds : Any
        The value given (``--folds``, ``folds=``).
    samples : int, optional
        The log's samples; None: the folds' length is not checked.

    Returns
    -------
    int
        The number of folds.

    Raises
    ------
    ConfigError
        Field ``folds``: not an integer, below 2, or folds shorter than twice the minimum log.
    """
    if isinstance(folds, (bool, np.bool_)) or not isinstance(folds, (int, np.integer)):
        raise ConfigError("folds", f"must be a whole number of folds (an integer ≥ 2), got {folds!r}")
    k = int(folds)
    if k < 2:
        raise ConfigError("folds", f"{k}: at least 2 folds are needed")
    if samples is not None and samples // k < MIN_SAMPLES * 2:
        raise ConfigError("folds", f"{k}: at least 2 folds of {2 * MIN_SAMPLES} samples each are needed "
                          f"({samples} samples make at most {samples // (2 * MIN_SAMPLES)})")
    return k


@one_blas_thread
def validate_plant(est, log: MeasuredLog, validation_log: MeasuredLog | None = None, folds: int | None = None,
                   refit=None):
    """Validate the estimate ``est`` (a :class:`PlantEstimate` identified from ``log``): on
    ``validation_log`` (another log: simulated outputs, residual tests and frequency responses
    there) or by ``folds``-fold cross-validation on ``log`` (contiguous blocks; residual tests and
    frequency responses on ``log`` itself), or neither (residual tests and frequency responses of
    the fitting log). ``refit``: MeasuredLog → PlantEstimate, the identification to repeat on each
    fold's remaining parts (as ``est`` was made: ``identify_plant`` with its keywords). Returns
    ``est`` with its ``validation`` (model errors: each parameter's departure on the frequency
    responses, docs/identification.md#honest-uncertainty).

    Parameters
    ----------
    est : PlantEstimate
        The estimate.
    log : MeasuredLog
        The fitting log.
    validation_log : MeasuredLog or None, optional
        A held-out log; None for none.
    folds : int or None, optional
        Folds of the cross-validation; None for none.
    refit : callable or None, optional
        The identification to repeat on each fold (needed with ``folds``).

    Returns
    -------
    PlantEstimate
        ``est`` with its ``validation``: output fits, residual tests, frequency responses, model
        errors and warnings.

    Raises
    ------
    ConfigError
        ``--folds`` below 2 or leaving blocks shorter than the minimum log.
    """
    import dataclasses

    delay = int(est.delay["samples"]) if est.delay else 0
    data = validation_log if validation_log is not None else log
    if validation_log is not None and validation_log.tau_m_held != log.tau_m_held:
        raise ConfigError("validate", "the validation log must log the motor torque as the fitting log does "
                          "(tau_m or tau_cmd)")
    tests, fits, stats = [], [], {}
    for name, inputs, y, ys, free, u in simulate_outputs(data, _values(est), delay, est.filter_hz):
        pct, e = nrmse_percent(y, ys, free)
        ys = free = None
        if validation_log is not None:
            fits.append(OutputFit(name, inputs, pct, y.size, "held-out log " + validation_log.source))
        tests.append(residual_test(name, "τ_m" if inputs.startswith("τ_m") else inputs, e, u, input_stats=stats))
    if folds is not None:
        folds = check_folds(folds, log.samples)
        if refit is None:
            raise ConfigError("folds", "k-fold validation needs the identification to repeat (refit)")
        fits += _kfold(log, est, folds, refit, delay)
    frs = frequency_responses(data, est)
    errors = [ModelError(p.key, p.relative_excess, f"the measured {fr.name} frequency response departs by "
                         f"{100 * p.relative_excess:.2g} % beyond its 99 % band at {p.at_hz:.3g} Hz")
              for fr in frs for p in fr.local if p.relative_excess > 0]
    warnings = []
    for tst in tests:
        if tst.output == "θ_m" and not tst.independent and tst.peak_lag != 0:
            warnings.append(f"delay or unmodelled dynamics? the motor-angle simulation error is correlated with "
                            f"{tst.input_name} beyond its 99 % bound (largest at lag {tst.peak_lag} samples)")
    for m in errors:
        if m.relative > 3 * est[m.key].relative_std_error:
            warnings.append(f"{est[m.key].symbol}: {m.source}: model error")
    held_out = validation_log is not None or folds is not None
    v = Validation(data.source, held_out, tuple(fits), frs, tuple(tests), tuple(errors), tuple(warnings))
    return dataclasses.replace(est, validation=v)
