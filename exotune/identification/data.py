"""A log of measured signals for plant identification: a CSV file with a header row naming the
columns (SI units, joint-reflected, the sign conventions of docs/method.md#physical-model), one
row per sample at a constant rate.

References
----------
docs/identification.md#the-log.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError

__all__ = ["COLUMNS", "MIN_SAMPLES", "MAX_LOG_BYTES", "MeasuredLog", "read_log", "log_from_columns"]

# column → (unit, meaning); t, theta_m and tau_s are required, and tau_m or tau_cmd
COLUMNS = {
    "t": ("s", "sample time"),
    "tau_m": ("N·m", "motor torque as applied (after the delay)"),
    "tau_cmd": ("N·m", "motor torque command (applied after --delay-s)"),
    "theta_m": ("rad", "motor angle"),
    "tau_s": ("N·m", "SEA spring torque"),
    "theta_j": ("rad", "joint angle (for K_s and J_j)"),
    "tau_c": ("N·m", "cuff torque (for J_j and K_c)"),
    "theta_h": ("rad", "human-side cuff angle (for K_c)"),
}
REQUIRED = ("t", "theta_m", "tau_s")
MIN_SAMPLES = 200
MAX_LOG_BYTES = 256 << 20  # 256 MiB: ~10^6 rows of eight columns


@dataclass(frozen=True)
class MeasuredLog:
    """Sampled signals at ``sample_rate_hz`` [Hz] (``signals``: column → array, SI units);
    ``tau_m_held``: the motor torque is a command held between samples (logged as ``tau_cmd``)."""

    sample_rate_hz: float
    signals: dict
    source: str = "<log>"
    tau_m_held: bool = False

    @property
    def samples(self) -> int:
        return int(self.signals["t"].size)


def log_from_columns(columns: dict, source: str = "<log>", delay_s: float = 0.0) -> MeasuredLog:
    """Check measured columns (name → sequence of numbers) and make a :class:`MeasuredLog`: known
    names only, the required ones present, equal lengths, finite numbers, at least
    :data:`MIN_SAMPLES` samples at a constant rate; ``tau_cmd`` is shifted by ``delay_s`` [s]
    (a whole number of samples) into ``tau_m``.

    Raises
    ------
    ConfigError
        Naming the column and the reason.
    """
    unknown = [c for c in columns if c not in COLUMNS]
    if unknown:
        raise ConfigError(unknown[0], f"unknown column (known: {', '.join(COLUMNS)})")
    for c in REQUIRED:
        if c not in columns:
            raise ConfigError(c, f"missing column ({COLUMNS[c][1]} [{COLUMNS[c][0]}])")
    if ("tau_m" in columns) == ("tau_cmd" in columns):
        raise ConfigError("tau_m", "give exactly one of tau_m (applied motor torque) and tau_cmd (the command, "
                          "applied after --delay-s)")
    sig = {}
    for c, v in columns.items():
        try:
            a = np.asarray(v, dtype=float)
        except (TypeError, ValueError):
            raise ConfigError(c, "not a column of numbers") from None
        if a.ndim != 1:
            raise ConfigError(c, "not a column of numbers")
        bad = np.flatnonzero(~np.isfinite(a))
        if bad.size:
            raise ConfigError(c, f"sample {int(bad[0])} is {a[bad[0]]!r}: every value must be a finite number")
        sig[c] = a
    n = sig["t"].size
    if any(a.size != n for a in sig.values()):
        raise ConfigError("t", "the columns have different lengths")
    if n < MIN_SAMPLES:
        raise ConfigError("t", f"{n} samples: at least {MIN_SAMPLES} are needed")
    dt = np.diff(sig["t"])
    Ts = float(np.median(dt))
    if not Ts > 0 or np.max(np.abs(dt - Ts)) > 1e-6 * Ts + 1e-12 * abs(float(sig["t"][-1])):
        k = int(np.argmax(np.abs(dt - Ts)))
        raise ConfigError("t", f"not uniformly sampled, increasing (step {float(dt[k]):.6g} s after sample {k}, "
                          f"median {Ts:.6g} s)")
    if not (isinstance(delay_s, (int, float)) and math.isfinite(delay_s) and delay_s >= 0):
        raise ConfigError("--delay-s", f"{delay_s!r} is not a delay ≥ 0 s")
    if "tau_cmd" in sig:
        d = delay_s / Ts
        k = int(round(d))
        if abs(d - k) > 1e-6 * max(1.0, d):
            raise ConfigError("--delay-s", f"{delay_s!r} s is {d:.6g} samples at {1 / Ts:g} Hz: identification needs "
                              "a whole number of samples (log the applied torque as tau_m otherwise)")
        if k >= n - MIN_SAMPLES:
            raise ConfigError("--delay-s", f"{k} samples leave fewer than {MIN_SAMPLES} samples")
        cmd = sig.pop("tau_cmd")
        sig = {c: a[k:] for c, a in sig.items()}  # τ_m[i] = τ_cmd[i − k]
        sig["tau_m"] = cmd[: n - k]
        return MeasuredLog(1.0 / Ts, sig, source, tau_m_held=True)
    return MeasuredLog(1.0 / Ts, sig, source)


def read_log(path, delay_s: float = 0.0) -> MeasuredLog:
    """Read a measured log (CSV: a header row of column names, then one row of numbers per
    sample) through the guarded reader and check it (:func:`log_from_columns`).

    Parameters
    ----------
    path : str or os.PathLike
        The CSV file (at most :data:`MAX_LOG_BYTES`).
    delay_s : float
        The delay [s] between ``tau_cmd`` and the applied torque (when the log has ``tau_cmd``).

    Returns
    -------
    MeasuredLog

    Raises
    ------
    ConfigError
        The file, a column or a row, and the reason.

    References
    ----------
    docs/identification.md#the-log.
    """
    from ..config.yamlio import read_guarded

    raw = read_guarded(path, "measured log", max_bytes=MAX_LOG_BYTES)
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise ConfigError(str(path), "not UTF-8 text (a CSV log is expected)") from None
    rows = [r for r in csv.reader(io.StringIO(text)) if r and any(x.strip() for x in r)]
    if not rows:
        raise ConfigError(str(path), "empty: a header row and one row per sample are expected")
    header = [h.strip() for h in rows[0]]
    if len(set(header)) != len(header):
        dup = next(h for h in header if header.count(h) > 1)
        raise ConfigError(dup, "column named twice")
    cols = {h: [] for h in header}
    for i, r in enumerate(rows[1:], start=2):
        if len(r) != len(header):
            raise ConfigError(f"{path}:{i}", f"{len(r)} values, the header names {len(header)} columns")
        for h, x in zip(header, r):
            try:
                cols[h].append(float(x))
            except ValueError:
                raise ConfigError(f"{path}:{i}", f"{h} = {x.strip()[:40]!r} is not a number") from None
    return log_from_columns(cols, str(path), delay_s)
