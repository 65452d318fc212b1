"""Non-parametric frequency responses of the plant from a measured log, beside the identified
model's, and the parameters read off them at each frequency.

Each transfer function is estimated with the applied motor torque z = τ_m as instrument (H1 =
P_zy/P_zz for each measured signal y, Welch-averaged with Hann windows, half overlap): the ratio
of two such responses is the transfer between two measured signals without the bias a noisy
input signal gives H1 (errors in variables) and without the feedback through the spring:

    motor   θ_m / (τ_m + τ_s) = 1/(J_m s² + B_m s)      = H_zθm / (1 + H_zτs)
    spring  τ_s / (θ_j − θ_m) = K_s                      = H_zτs / H_z(θj−θm)
    joint   θ_j / (τ_c − τ_s) = 1/(J_j s²)               = H_zθj / H_z(τc−τs)
    cuff    τ_c / (θ_h − θ_j) = K_c                      = H_zτc / H_z(θh−θj)

A held command (``tau_cmd``) reaches the sampled outputs through the hold, (1 − e^{−jωT})/(jωT);
the motor's response (not a ratio in which it cancels) is divided by it. The random error of an
H1 estimate with coherence γ² over n_d averages is √(1 − γ²)/(|γ|√(2 n_d)) relative (Bendat &
Piersol; 1σ of the magnitude, radians of the phase); a ratio adds its two in quadrature and its
coherence is the smaller of the two.

At each frequency the model's equation is solved for its parameters (1/H = −J_m ω² + jB_m ω
gives J_m(ω) and B_m(ω); K_s(ω) = Re H; …). With the right model they are constant, within the
random error; friction, a wrong delay or an unmodelled mode make them vary. Over the coherent
band, the largest departure from the estimate beyond 2.58 standard deviations is the model
error the frequency response measures (docs/identification.md#honest-uncertainty).

References
----------
docs/identification.md#validation.
"""

from __future__ import annotations

import math

import numpy as np

from .validresult import CONFIDENCE_Z, MIN_COHERENCE, FrequencyResponse, LocalParameter

__all__ = ["frequency_responses", "applied_torque", "segment_length"]

MIN_SEGMENT = 256
AVERAGES = 8  # at least this many independent segments
PERIODIC_AVERAGES = 4  # segments of whole periods of a periodic command: at least this many
_SEGMENTS = 4  # Welch segments transformed at a time (memory: a few segments of every signal)


def applied_torque(log, delay_samples: int) -> np.ndarray:
    """τ_m as applied: the ``tau_m`` column, or ``tau_cmd`` delayed by ``delay_samples``.

    Parameters
    ----------
    log : MeasuredLog
        The log.
    delay_samples : int
        Delay [samples] of ``tau_cmd``.

    Returns
    -------
    numpy.ndarray
        τ_m [N·m] per sample (zeros before the first command arrives).
    """
    S = log.signals
    if "tau_m" in S:
        return np.asarray(S["tau_m"], float)
    u = np.asarray(S["tau_cmd"], float)
    return np.concatenate([np.zeros(delay_samples), u[: u.size - delay_samples]]) if delay_samples else u


def segment_length(n: int) -> int:
    """Welch segment: the largest power of two with :data:`AVERAGES` segments in ``n`` samples.

    Parameters
    ----------
    n : int
        Samples of the log.

    Returns
    -------
    int
        Segment length [samples], at least ``MIN_SEGMENT``.
    """
    return int(max(MIN_SEGMENT, 2 ** int(math.floor(math.log2(max(n // AVERAGES, 2))))))


def command_period(z: np.ndarray, start: int = 0, checks: int = 32) -> int | None:
    """The period [samples] of a command that repeats exactly from sample ``start`` on (a
    multisine of ``exotune excite``, logged as it was played), or None: the first sample's value
    recurring at P with z[start + P:] equal to z[start:] shifted (at most ``checks`` candidates)."""
    x = z[start:]
    if x.size < 8:
        return None
    for P in (np.flatnonzero(x[1: x.size // 2 + 1] == x[0]) + 1)[:checks]:
        if P >= 2 and np.array_equal(x[P:], x[:-P]):
            return int(P)
    return None


def _segmentation(z: np.ndarray, start: int, n: int):
    """(segment length, step, first sample, averages, bin stride) of the spectra. Welch's Hann
    segments of a power of two samples with half overlap; for an exactly periodic command of P
    samples, segments of m ≥ 2 whole periods (at least :data:`MIN_SEGMENT` samples), half overlap,
    read at the lines only (every m-th bin): a Hann window spreads a line over its two neighbouring
    bins only, so no line leaks into another's bin (Hann segments of arbitrary length mix
    neighbouring lines, which biases a response that changes between them), and a disturbance
    that is not periodic (the person's own torque) still leaks little; the first period (the
    plant's transient) left out where at least :data:`PERIODIC_AVERAGES` segments remain."""
    P = command_period(z, start)
    if P is not None:
        m = max(2, 2 * int(math.ceil(MIN_SEGMENT / (2 * P))))  # even: the half-overlap step is whole periods
        seg = m * P
        first = start + P if (n - start - P) // seg >= PERIODIC_AVERAGES else start
        if (n - first) // seg >= PERIODIC_AVERAGES:
            nseg = (n - first - seg) // (seg // 2) + 1
            return seg, seg // 2, first, nseg, (n - first) // seg, m
    nper = segment_length(n)
    step = nper - nper // 2
    return nper, step, 0, (n - nper) // step + 1, n // nper, 1


def _segments_fft(x: np.ndarray, nper: int, step: int, window: np.ndarray) -> np.ndarray:
    """The spectra of the segments of ``x`` (length ``nper`` every ``step`` samples, mean removed,
    windowed), as rows: scipy.signal.welch's segments for a Hann window and half overlap."""
    import scipy.fft

    frames = np.lib.stride_tricks.sliding_window_view(np.asarray(x, float), nper)[::step]
    F = frames - frames.mean(axis=1, keepdims=True)
    F *= window
    return scipy.fft.rfft(F, axis=1, workers=2)


def _h1(z, ys, fs, segmentation):
    """H1 from z to each y (``ys``: functions of a sample range making that part of each signal),
    its coherence, and the frequencies: averages over the Hann-windowed segments
    ``segmentation`` (length, step, first sample, count; :func:`_segmentation`) of their spectra
    (Welch's, constant detrend, as scipy.signal.csd), each signal transformed once,
    :data:`_SEGMENTS` segments at a time (float64: the responses span decades)."""
    import scipy.signal

    nper, step, first, nseg, _nd, _every = segmentation
    window = scipy.signal.get_window("hann", nper)
    nf = nper // 2 + 1
    pzz = np.zeros(nf)
    pzy, pyy = [np.zeros(nf, complex) for _ in ys], [np.zeros(nf) for _ in ys]
    for a in range(0, nseg, _SEGMENTS):
        lo, hi = first + a * step, first + (min(a + _SEGMENTS, nseg) - 1) * step + nper
        Z = _segments_fft(z[lo:hi], nper, step, window)
        pzz += np.sum(Z.real ** 2 + Z.imag ** 2, axis=0)
        for j, y in enumerate(ys):
            Y = _segments_fft(y(lo, hi), nper, step, window)
            pzy[j] += np.sum(np.conj(Z) * Y, axis=0)
            pyy[j] += np.sum(Y.real ** 2 + Y.imag ** 2, axis=0)
    out = []
    with np.errstate(divide="ignore", invalid="ignore"):
        for a, b in zip(pzy, pyy):
            out.append((a / pzz, np.abs(a) ** 2 / (pzz * b)))
    return np.fft.rfftfreq(nper, 1.0 / fs), out


def _error(g2, nd):
    g2 = np.clip(np.nan_to_num(g2), 1e-12, 1.0)
    return np.sqrt(1 - g2) / np.sqrt(g2 * 2 * nd)


def _local(key, sym, unit, values, sigma, estimate, f, coherent) -> LocalParameter:
    excess = np.where(coherent, np.maximum(np.abs(values - estimate) - CONFIDENCE_Z * sigma, 0.0), 0.0)
    excess = np.nan_to_num(excess) / abs(estimate) if estimate else np.zeros_like(excess)
    if excess.size < 2:
        return LocalParameter(key, sym, unit, values, sigma, float(estimate), 0.0, math.nan)
    i = int(np.argsort(excess)[-2])  # the second largest: a departure seen in at least two bins, not one outlier
    return LocalParameter(key, sym, unit, values, sigma, float(estimate), float(excess[i]), float(f[i]))


def frequency_responses(log, est) -> tuple[FrequencyResponse, ...]:
    """The motor, spring, joint and cuff frequency responses ``log``'s columns allow (module
    docstring), with the model of the estimate ``est`` (a :class:`PlantEstimate`) and the
    parameters read off each; frequencies up to a quarter of the sample rate.

    Parameters
    ----------
    log : MeasuredLog
        The log.
    est : PlantEstimate
        The estimate (its parameters and delay).

    Returns
    -------
    tuple of FrequencyResponse
        The motor response first, then spring, joint and cuff where the columns allow them.
    """
    S, fs = log.signals, log.sample_rate_hz
    delay = int(est.delay["samples"]) if est.delay else 0
    z = applied_torque(log, delay)
    n = z.size
    segmentation = _segmentation(z, delay if log.tau_m_held else 0, n)
    nd, every = segmentation[4], segmentation[5]
    val = {p.key: p.value for p in est.parameters}
    def column(c):
        return lambda lo, hi: S[c][lo:hi]

    def difference(a, b):
        return lambda lo, hi: S[a][lo:hi] - S[b][lo:hi]

    series = {"theta_m": column("theta_m"), "tau_s": column("tau_s")}  # each made a block at a time
    if "theta_j" in S:
        series["theta_j"], series["sea_x"] = column("theta_j"), difference("theta_j", "theta_m")
    if "tau_c" in S:
        series["tau_c"], series["joint_u"] = column("tau_c"), difference("tau_c", "tau_s")
    if "theta_h" in S and "theta_j" in S and "tau_c" in S:
        series["cuff_x"] = difference("theta_h", "theta_j")
    names = list(series)
    rate = np.gradient(z) * fs
    f, h = _h1(z - z.mean(), [series[k] for k in names] + [lambda lo, hi: rate[lo:hi]], fs, segmentation)
    H = dict(zip(names, h))
    # the instrument's power centroid in each bin: a strong line between bins is read at its own frequency
    with np.errstate(invalid="ignore"):
        f_eff = np.arcsin(np.clip(np.abs(h[-1][0]) / fs, 0, 1)) * fs / (2 * np.pi)
    if every > 1:  # a periodic command's lines lie on their bins (and a bin without one stays there)
        f_eff = f
    keep = (f > 0) & (f <= fs / 4) & np.isfinite(f_eff) & (f_eff > 0) & (np.arange(f.size) % every == 0)
    f = f_eff[keep]
    order = np.argsort(f)
    f = f[order]
    H = {k: (v[0][keep][order], v[1][keep][order]) for k, v in H.items()}
    w = 2 * np.pi * f
    out = []
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        hold = (1 - np.exp(-1j * w / fs)) / (1j * w / fs) if log.tau_m_held else np.ones_like(w, complex)
        (ha, ga), (hb, gb) = H["theta_m"], H["tau_s"]
        ha, hb = ha / hold, hb / hold
        G = ha / (1 + hb)
        eps = np.sqrt(_error(ga, nd) ** 2 + (np.abs(hb) * _error(gb, nd) / np.abs(1 + hb)) ** 2)
        out.append(_motor(f, G, np.minimum(ga, gb), eps, val, nd))
        for name, (num, den), (key, sym, unit), dyn, io in (
                ("spring", ("tau_s", "sea_x"), ("sea_stiffness", "K_s", "N·m/rad"), False, ("θ_j − θ_m", "τ_s", "N·m/rad")),
                ("joint", ("theta_j", "joint_u"), ("joint_inertia", "J_j", "kg·m²"), True, ("τ_c − τ_s", "θ_j", "rad/(N·m)")),
                ("cuff", ("tau_c", "cuff_x"), ("cuff_stiffness", "K_c", "N·m/rad"), False, ("θ_h − θ_j", "τ_c", "N·m/rad"))):
            if num not in H or den not in H or key not in val:
                continue
            (hn, gn), (hd, gd) = H[num], H[den]
            G = hn / hd
            coh, eps = np.minimum(gn, gd), np.sqrt(_error(gn, nd) ** 2 + _error(gd, nd) ** 2)
            coherent = coh >= MIN_COHERENCE
            if dyn:
                inv = 1 / G
                loc = _local(key, sym, unit, -inv.real / w ** 2, eps * np.abs(inv) / w ** 2, val[key], f, coherent)
                model = 1 / (val[key] * (1j * w) ** 2)
            else:
                loc = _local(key, sym, unit, G.real, eps * np.abs(G), val[key], f, coherent)
                model = np.full(w.shape, val[key], complex)
            out.append(FrequencyResponse(name, io[0], io[1], io[2], f, G, coh, eps, model, (loc,), nd))
    return tuple(out)


def _motor(f, G, coh, eps, val, nd) -> FrequencyResponse:
    w = 2 * np.pi * f
    coherent = coh >= MIN_COHERENCE
    inv = 1 / G
    local = []
    if "motor_inertia" in val:
        local.append(_local("motor_inertia", "J_m", "kg·m²", -inv.real / w ** 2, eps * np.abs(inv) / w ** 2,
                            val["motor_inertia"], f, coherent))
    if "motor_damping" in val:
        local.append(_local("motor_damping", "B_m", "N·m·s/rad", inv.imag / w, eps * np.abs(inv) / w,
                            val["motor_damping"], f, coherent))
    jm, bm = val.get("motor_inertia", math.nan), val.get("motor_damping", math.nan)
    model = 1 / (jm * (1j * w) ** 2 + bm * 1j * w)
    return FrequencyResponse("motor", "τ_m + τ_s", "θ_m", "rad/(N·m)", f, G, coh, eps, model, tuple(local), nd)
