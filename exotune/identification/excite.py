"""The excitation for an identification experiment (``exotune excite``): a periodic multisine
command for the rig's motor, with Schroeder's phases, written in the log format ``exotune identify``
reads (columns ``t`` [s] and ``tau_cmd`` [N·m]).

One period of N = round(T·fs) samples holds the lines k·Δf, Δf = fs/N (the frequency resolution,
1/period), for the harmonics k chosen in the band [f_lo, f_hi]: every one (``all``), the odd ones
(``odd``), the odd ones less one chosen at random in each group of three consecutive odd lines
(``random-odd``, seeded: the lines left out show the nonlinear distortion, Pintelon & Schoukens),
or :data:`LOG_LINES_PER_DECADE` per decade (``log``: each line 10^(1/20) above the last, or the
next harmonic where that is closer). Each line has the same amplitude and
the phase Schroeder (1970) gives a flat power spectrum,

    φ_k = −2π Σ_{l < k} (k − l) p_l,   p_l = 1/K for each of the K lines (0 elsewhere),

that is −π m(m+1)/K for the m-th of K consecutive lines (m = 0, 1, …): the lines' sum then sweeps
through the band once per period like a chirp: a crest factor (peak/RMS) of 1.76 for 20
consecutive lines and 1.88 for 396 (random phases: 2.8 on average for 20 lines). Sparse selections
fare worse with the same formula (odd 2.05, random-odd 2.85, log 3.2 over 5–400 harmonics); the
crest factor is reported. The period is built exactly by an inverse FFT, so over whole periods
the signal's spectrum is zero off the chosen lines; the periods are repeated sample for sample.
The amplitude is the peak or the RMS of the sampled command (what the motor is sent).

References
----------
docs/identification.md#excite; M. R. Schroeder, "Synthesis of low-peak-factor signals and
binary sequences with low autocorrelation", IEEE Trans. Inform. Theory 16 (1970).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError
from ..record import Result
from ..version import __version__
from .data import MAX_SIGNAL

__all__ = ["Excitation", "schroeder_multisine", "write_excitation", "sidecar_path", "SELECTIONS",
           "LOG_LINES_PER_DECADE", "MAX_SAMPLES", "DEFAULT_DURATION_S"]

SELECTIONS = ("all", "odd", "random-odd", "log")
LOG_LINES_PER_DECADE = 20
MAX_SAMPLES = 10_000_000  # ~400 MB of CSV; identify reads at most 256 MiB
DEFAULT_DURATION_S = 20.0  # without --periods or --duration-s: whole periods making at least this (≥ 2)
_REL = 1e-9  # a line on a band edge counts as inside


@dataclass(frozen=True)
class Excitation(Result):
    """A periodic multisine command (``exotune excite``): ``period`` (one period of ``tau_cmd``,
    N·m, ``period_samples`` samples at ``sample_rate_hz``) repeated ``periods`` times; the
    ``harmonics`` k of the lines (frequency k·resolution_hz) with their Schroeder ``phases_rad``,
    each of amplitude ``line_amplitude_nm``; ``amplitude_nm`` the ``amplitude_kind`` ("peak" or
    "rms") asked for; ``selection`` and ``seed`` of the lines; the band asked for [Hz]; where it
    was written (``path``, the CSV, and ``sidecar``, its description), if it was."""

    sample_rate_hz: float
    period_samples: int
    periods: int
    f_lo_hz: float
    f_hi_hz: float
    harmonics: tuple[int, ...]
    phases_rad: tuple[float, ...]
    line_amplitude_nm: float
    amplitude_nm: float
    amplitude_kind: str
    selection: str
    seed: int | None
    period: np.ndarray
    path: str | None = None
    sidecar: str | None = None

    @property
    def period_s(self) -> float:
        return self.period_samples / self.sample_rate_hz

    @property
    def resolution_hz(self) -> float:
        """The frequency resolution, 1/period [Hz]."""
        return self.sample_rate_hz / self.period_samples

    @property
    def samples(self) -> int:
        return self.period_samples * self.periods

    @property
    def duration_s(self) -> float:
        return self.samples / self.sample_rate_hz

    @property
    def lines_hz(self) -> np.ndarray:
        return np.asarray(self.harmonics, float) * self.resolution_hz

    @property
    def peak_nm(self) -> float:
        return float(np.max(np.abs(self.period)))

    @property
    def rms_nm(self) -> float:
        return float(np.sqrt(np.mean(self.period ** 2)))

    @property
    def crest_factor(self) -> float:
        """Peak over RMS of the sampled command [–]."""
        return self.peak_nm / self.rms_nm

    def signal(self) -> tuple[np.ndarray, np.ndarray]:
        """``(t [s], tau_cmd [N·m])`` over every period."""
        return np.arange(self.samples) / self.sample_rate_hz, np.tile(self.period, self.periods)

    def to_csv(self) -> str:
        """The command as a log ``exotune identify`` reads: a header ``t,tau_cmd``, one row per
        sample (shortest round-trip decimals)."""
        t, u = self.signal()
        return "t,tau_cmd\n" + "".join(f"{a!r},{b!r}\n" for a, b in zip(t.tolist(), u.tolist()))

    def to_dict(self) -> dict:
        return {
            "format": "exotune excitation",
            "exotune_version": __version__,
            "file": self.path,
            "sidecar": self.sidecar,
            "columns": {"t": {"unit": "s", "meaning": "sample time"},
                        "tau_cmd": {"unit": "N·m", "meaning": "motor torque command, held between samples"}},
            "signal": "multisine, Schroeder (1970) phases",
            "sample_rate_hz": self.sample_rate_hz,
            "band_hz": [self.f_lo_hz, self.f_hi_hz],
            "period_s": self.period_s,
            "period_samples": self.period_samples,
            "periods": self.periods,
            "samples": self.samples,
            "duration_s": self.duration_s,
            "resolution_hz": self.resolution_hz,
            "selection": self.selection,
            "seed": self.seed,
            "lines": len(self.harmonics),
            "harmonics": list(self.harmonics),
            "line_frequencies_hz": [float(f) for f in self.lines_hz],
            "phases_rad": list(self.phases_rad),
            "line_amplitude_nm": self.line_amplitude_nm,
            "amplitude": {"value": self.amplitude_nm, "kind": self.amplitude_kind, "unit": "N·m"},
            "peak_nm": self.peak_nm,
            "rms_nm": self.rms_nm,
            "crest_factor": self.crest_factor,
            "units": {"sample_rate_hz": "Hz", "band_hz": "Hz", "period_s": "s", "duration_s": "s",
                      "resolution_hz": "Hz", "line_frequencies_hz": "Hz", "phases_rad": "rad",
                      "line_amplitude_nm": "N·m", "peak_nm": "N·m", "rms_nm": "N·m", "crest_factor": "–"},
        }

    def to_text(self) -> str:
        from ..text.excite import excitation_text

        return excitation_text(self)


def sidecar_path(path) -> str:
    """The sidecar of an excitation file: ``EXC.json`` beside ``EXC.csv``.

    Parameters
    ----------
    path : str or os.PathLike
        The excitation's CSV path.

    Returns
    -------
    str
        The JSON path.
    """
    return os.path.splitext(os.fspath(path))[0] + ".json"


def _number(name: str, value, positive: bool = True) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise ConfigError(name, f"expected a number, got {value!r}")
    v = float(value)
    if not math.isfinite(v) or (positive and not v > 0):
        raise ConfigError(name, f"must be a finite number > 0, got {value!r}")
    return v


def _schroeder_phases(harmonics: np.ndarray) -> np.ndarray:
    """φ_k = −2π Σ_{l<k} (k − l)/K over the K chosen harmonics (flat power), wrapped to (−π, π]."""
    k = harmonics.astype(float)
    K = k.size
    csum = np.concatenate([[0.0], np.cumsum(k)[:-1]])  # Σ_{l<k} l over the chosen harmonics
    phi = -2.0 * np.pi * (np.arange(K) * k - csum) / K
    return -np.remainder(-phi + np.pi, 2 * np.pi) + np.pi


def _select(k_lo: int, k_hi: int, selection: str, seed: int | None) -> np.ndarray:
    ks = np.arange(k_lo, k_hi + 1)
    if selection == "all":
        return ks
    if selection == "log":  # each line 10^(1/20) above the last, or the next harmonic where that is closer
        r, out = 10 ** (1 / LOG_LINES_PER_DECADE), [k_lo]
        while True:
            k = max(out[-1] + 1, int(round(out[-1] * r)))
            if k > k_hi:
                return np.asarray(out)
            out.append(k)
    odd = ks[ks % 2 == 1]
    if selection == "odd" or odd.size < 3:
        return odd
    rng = np.random.default_rng(0 if seed is None else seed)
    groups = odd[: odd.size - odd.size % 3].reshape(-1, 3)
    drop = groups[np.arange(groups.shape[0]), rng.integers(0, 3, groups.shape[0])]
    return np.setdiff1d(odd, drop)


def _periods(period_samples: int, fs: float, periods, duration_s, period_given: bool = False) -> int:
    if periods is not None and duration_s is not None:
        raise ConfigError("duration_s", "give `periods` or `duration_s`, not both")
    T = period_samples / fs
    if periods is not None:
        if isinstance(periods, bool) or not isinstance(periods, (int, np.integer)) or periods < 1:
            raise ConfigError("periods", f"must be a whole number ≥ 1, got {periods!r}")
        n = int(periods)
    elif duration_s is not None:
        d = _number("duration_s", duration_s)
        whole = math.floor(d / T * (1 + _REL)) if d / T * (1 + _REL) <= MAX_SAMPLES else None
        if whole is None:  # more periods than samples written (``1e308`` s would overflow an int)
            raise ConfigError("duration_s", f"{d:g} s at {fs:g} Hz is more than {MAX_SAMPLES} samples: at most "
                                            f"{MAX_SAMPLES} samples are written")
        n = int(whole)
        if n < 1:
            raise ConfigError("duration_s", f"{d:g} s is shorter than one period ({T:.6g} s)")
    else:
        n = max(2, int(math.ceil(DEFAULT_DURATION_S / T * (1 - _REL))))
    if n * period_samples > MAX_SAMPLES:
        # a count beyond any file (``--duration-s 1e308``: 309 digits) in its short form
        count = f"{n}" if n < 10**9 else f"about 10^{int(n.bit_length() * math.log10(2))}"
        what = f"{count} period{'' if n == 1 else 's'} of {period_samples} samples"
        if periods is not None or duration_s is not None:
            raise ConfigError("periods" if periods is not None else "duration_s",
                              f"{what}: at most {MAX_SAMPLES} samples are written")
        # the default length: name what makes it too long (the rate, or a period too long for two)
        field = "sample_rate_hz" if n > 2 else ("period_s" if period_given else "f_lo_hz")
        raise ConfigError(field, f"the default length, whole periods making {DEFAULT_DURATION_S:g} s (at least 2), "
                                 f"is {what} at {fs:g} Hz: at most {MAX_SAMPLES} samples are written; give "
                                 "fewer `periods` or a shorter `duration_s`")
    return n


MIN_AMPLITUDE_NM = 1e-9  # [N·m] the smallest amplitude of a command (far below any actuator's resolution)


def schroeder_multisine(sample_rate_hz, f_lo_hz, f_hi_hz, *, peak_nm=None, rms_nm=None, period_s=None,
                        periods=None, duration_s=None, lines: str = "all", seed: int | None = None) -> Excitation:
    """A Schroeder-phased multisine command over [``f_lo_hz``, ``f_hi_hz``] (module docstring).

    Parameters
    ----------
    sample_rate_hz : float
        The rig's sample rate [Hz]: the command is held between samples.
    f_lo_hz, f_hi_hz : float
        The band [Hz]: 0 < f_lo < f_hi < fs/2 (the Nyquist frequency).
    peak_nm, rms_nm : float
        The amplitude [N·m]: the peak or the RMS of the sampled command (exactly one).
    period_s : float, optional
        The period [s], rounded to whole samples (default 1/f_lo, rounded down to whole samples so
        that the first line is at or above f_lo): the frequency resolution is its inverse; it must
        hold a line in the band.
    periods : int, optional
        How many periods (default: whole periods making 20 s, at least two).
    duration_s : float, optional
        Instead of ``periods``: the whole periods within this duration [s].
    lines : {"all", "odd", "random-odd", "log"}
        Which harmonics of 1/period in the band are excited.
    seed : int, optional
        The draw of ``random-odd`` (default 0); refused for the other selections.

    Returns
    -------
    Excitation

    Raises
    ------
    ConfigError
        Naming the keyword (``f_hi_hz``, ``period_s``, …) and the reason (``exotune excite`` names
        the option instead: ``--f-hi-hz``).

    Examples
    --------
    >>> e = schroeder_multisine(1000.0, 1.0, 20.0, peak_nm=2.0, periods=3)
    >>> len(e.harmonics), e.resolution_hz, round(e.peak_nm, 12), e.crest_factor < 2
    (20, 1.0, 2.0, True)
    """
    fs = _number("sample_rate_hz", sample_rate_hz)
    lo = _number("f_lo_hz", f_lo_hz)
    hi = _number("f_hi_hz", f_hi_hz)
    if hi >= fs / 2:
        raise ConfigError("f_hi_hz", f"{hi:g} Hz is not below the Nyquist frequency {fs / 2:g} Hz (half of "
                          f"`sample_rate_hz` {fs:g})")
    if lo >= hi:
        raise ConfigError("f_lo_hz", f"{lo:g} Hz must be below `f_hi_hz` ({hi:g} Hz)")
    if (peak_nm is None) == (rms_nm is None):
        raise ConfigError("peak_nm", "give the amplitude as exactly one of `peak_nm` and `rms_nm` [N·m]")
    kind, amp = ("peak", _number("peak_nm", peak_nm)) if peak_nm is not None else ("rms", _number("rms_nm", rms_nm))
    if amp > MAX_SIGNAL:  # identify refuses a logged torque beyond it (check the units)
        raise ConfigError(f"{kind}_nm", f"{amp:.6g} N·m is beyond {MAX_SIGNAL:.0e} N·m (check the units)")
    if amp < MIN_AMPLITUDE_NM:  # (its samples' squares would underflow: the RMS and crest factor undefined)
        raise ConfigError(f"{kind}_nm", f"{amp:.6g} N·m is below {MIN_AMPLITUDE_NM:.0e} N·m: no actuator resolves "
                                        "it (check the units)")
    if lines not in SELECTIONS:
        raise ConfigError("lines", f"{lines!r}: one of {', '.join(SELECTIONS)}")
    if seed is not None and lines != "random-odd":
        raise ConfigError("seed", f"only `lines` random-odd draws at random (`lines` is {lines})")
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0):
        raise ConfigError("seed", f"must be a whole number ≥ 0, got {seed!r}")
    T = 1.0 / lo if period_s is None else _number("period_s", period_s)
    if not T * fs <= MAX_SAMPLES:  # also a period that overflows to inf samples
        raise ConfigError("period_s" if period_s is not None else "f_lo_hz",
                          f"a period of {T * fs:.6g} samples: at most {MAX_SAMPLES}")
    # the default period 1/f_lo is rounded down to whole samples: its first line, fs/N, is then at
    # or above f_lo (rounded up it fell below the band: 1.5 Hz at 1000 Hz gave 667 samples, 1.49925 Hz)
    N = int(round(T * fs)) if period_s is not None else int(math.floor(T * fs * (1 + _REL)))
    df = fs / N if N > 0 else math.inf
    k_lo, k_hi = int(math.ceil(lo / df * (1 - _REL))), min(int(math.floor(hi / df * (1 + _REL))), (N - 1) // 2)
    if N < 3 or k_hi < max(k_lo, 1):
        raise ConfigError("period_s" if period_s is not None else "f_lo_hz",
                          f"a period of {N / fs:.6g} s ({N} samples) resolves {df:.6g} Hz: no line k/period "
                          f"lies in [{lo:g}, {hi:g}] Hz; give a longer `period_s`")
    ks = _select(max(k_lo, 1), k_hi, lines, seed)
    if ks.size == 0:
        raise ConfigError("lines", f"no {lines} line in [{lo:g}, {hi:g}] Hz at the resolution {df:.6g} Hz; "
                          "give a longer `period_s` or `lines` all")
    n_periods = _periods(N, fs, periods, duration_s, period_s is not None)
    phases = _schroeder_phases(ks)
    X = np.zeros(N // 2 + 1, complex)
    X[ks] = 0.5 * N * np.exp(1j * phases)  # cos(2π k n/N + φ_k), unit amplitude
    x = np.fft.irfft(X, N)
    scale = amp / (np.max(np.abs(x)) if kind == "peak" else math.sqrt(float(np.mean(x * x))))
    return Excitation(fs, N, n_periods, lo, hi, tuple(int(k) for k in ks), tuple(float(p) for p in phases),
                      float(scale), amp, kind, lines, seed, x * scale)


def write_excitation(exc: Excitation, out) -> Excitation:
    """Write ``exc`` as CSV to ``out`` and its description (units, lines, phases, crest factor)
    as JSON to :func:`sidecar_path`, both or neither
    (:func:`~exotune.jsonio.write_outputs`: a file they replace is kept when
    either cannot be written). Returns ``exc`` with its ``path``.

    Parameters
    ----------
    exc : Excitation
        The excitation.
    out : str or os.PathLike
        The CSV path.

    Returns
    -------
    Excitation
        ``exc`` with ``path`` and ``sidecar`` set.

    Raises
    ------
    exotune.errors.ConfigError
        When ``out`` is its own sidecar path (a ``.json`` name), or a file cannot be written
        (``<path>: cannot write output: <reason>``; then neither is).
    """
    import dataclasses

    from ..jsonio import dumps
    from ..jsonio import write_outputs

    out = os.fspath(out)
    side = sidecar_path(out)
    if os.path.abspath(side) == os.path.abspath(out):
        raise ConfigError("-o", f"{out}: the excitation is written as CSV (EXC.csv) beside its sidecar EXC.json")
    exc = dataclasses.replace(exc, path=out, sidecar=side)
    write_outputs({out: exc.to_csv(), side: dumps(exc.to_dict()) + "\n"})
    return exc
