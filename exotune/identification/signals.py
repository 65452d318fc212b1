"""The filtered signals of the identification, for one log or several identified together.

Each log is filtered on its own, from the zero state, at its own sample rate
(:mod:`exotune.identification.filters`: H, sH, s²H of the measured signals with a first-order
hold, the held command exactly and through the hold's sinc² factor); its first ``skip`` samples
(the filters' transient, at least the delay) are dropped. A signal is returned as a tuple of
per-log arrays (views of the filtered arrays where possible): the regressions stack the logs'
rows but never filter, delay or correlate across a log boundary. Only the filter outputs a
regression asks for are computed, each once.

References
----------
docs/identification.md#method.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ConfigError
from .filters import held_svf, svf_order, velocity_sign

__all__ = ["FilteredLogs", "transient_modes", "TRANSIENT_END"]

# expression → the log columns it is made of (for the overflow message) and how
_DERIVED = {"sea_x": ("theta_j", "theta_m", -1.0), "joint_y": ("tau_c", "tau_s", -1.0),
            "cuff_x": ("theta_h", "theta_j", -1.0)}


TRANSIENT_END = 60.0  # ωt beyond which the transients are taken as 0: (ωt)²·e^{−ωt} < 4e-23


def transient_modes(skip: int, samples: int, fs: float, fh: float) -> np.ndarray:
    """The filters' start-up transients e^{−ωt}, ωt·e^{−ωt}, (ωt)²·e^{−ωt} at the kept samples
    while ωt ≤ :data:`TRANSIENT_END` (they are below 4e-23 after), as rows (3, K).

    Parameters
    ----------
    skip : int
        First kept sample.
    samples : int
        Samples of the log.
    fs : float
        Sample rate [Hz].
    fh : float
        Filter corner [Hz].

    Returns
    -------
    numpy.ndarray
        The three transients (3, K) at the kept samples, K ≥ 0.
    """
    w = 2 * math.pi * fh / fs
    end = min(samples, int(math.floor(TRANSIENT_END / w)) + 1)
    wt = w * np.arange(skip, max(end, skip))
    e = np.exp(-wt)
    return np.stack([e, wt * e, wt * wt * e])


class FilteredLogs:
    """Filtered signals of ``logs`` (MeasuredLog, all with the same columns) with the filter
    corner ``fh`` [Hz], each log's first ``skips[i]`` samples dropped. :meth:`get` (a tuple of
    per-log arrays), :meth:`applied` (the motor torque as applied, for a delay), :meth:`modes`
    (per log: the filters' start-up transients)."""

    def __init__(self, logs, fh: float, skips):
        self.logs, self.fh, self.skips = list(logs), float(fh), [int(s) for s in skips]
        self.held = self.logs[0].tau_m_held
        self._cache: dict = {}

    @property
    def samples(self) -> int:
        return int(sum(log.samples - s for log, s in zip(self.logs, self.skips)))

    def _raw(self, log, expr: str) -> np.ndarray:
        S = log.signals
        if expr == "fric":
            return velocity_sign(S["theta_m"], log.sample_rate_hz, self.fh)
        if expr in _DERIVED:
            a, b, sign = _DERIVED[expr]
            return S[a] + sign * S[b]
        return S[expr]

    def _filtered(self, i: int, expr: str, k: int) -> np.ndarray:
        """s^k·H[expr] of log ``i`` over all its samples (cached)."""
        key = (i, expr, k)
        if key not in self._cache:
            log = self.logs[i]
            with np.errstate(over="ignore", invalid="ignore"):
                if expr == "tau_cmd":
                    out = held_svf(np.asarray(log.signals["tau_cmd"], float), log.sample_rate_hz, self.fh)
                else:
                    out = svf_order(np.asarray(self._raw(log, expr), float), log.sample_rate_hz, self.fh, k)
            if not np.all(np.isfinite(out)):
                col = _DERIVED.get(expr, (expr,))[0]
                raise ConfigError(col, "values too large for the filters (they overflow): check the units")
            self._cache[key] = out
        return self._cache[key]

    def get(self, expr: str, k: int = 0) -> tuple:
        """s^k·H[expr] of every log at its kept samples; ``expr`` a column name or ``fric``
        (sign(θ̇_m)), ``sea_x`` (θ_j − θ_m), ``joint_y`` (τ_c − τ_s), ``cuff_x`` (θ_h − θ_j)."""
        return tuple(self._filtered(i, expr, k)[s:] for i, s in enumerate(self.skips))

    def applied(self, delay: int) -> tuple:
        """H[τ_m] as applied: the ``tau_m`` column, or the held ``tau_cmd`` applied ``delay``
        samples later (filtered from the zero state, then shifted within its log)."""
        if not self.held:
            return self.get("tau_m")
        out = []
        for i, (log, s) in enumerate(zip(self.logs, self.skips)):
            h = self._filtered(i, "tau_cmd", 0)
            out.append(h[s - delay: log.samples - delay])
        return tuple(out)

    def command(self, i: int) -> np.ndarray:
        """H_held[τ_cmd] of log ``i`` over all its samples (for the delay screen)."""
        return self._filtered(i, "tau_cmd", 0)

    def modes(self) -> list:
        """Per log the filters' start-up transients at its first kept samples, (3, K_log)
        (:func:`transient_modes`; a sensor offset through the filter, H[1], is a constant plus
        these)."""
        key = ("modes",)
        if key not in self._cache:
            self._cache[key] = [transient_modes(s, log.samples, log.sample_rate_hz, self.fh)
                                for log, s in zip(self.logs, self.skips)]
        return self._cache[key]

    def drop(self, expr: str) -> None:
        """Forget the filtered ``expr`` (memory)."""
        for key in [k for k in self._cache if len(k) == 3 and k[1] == expr]:
            del self._cache[key]
