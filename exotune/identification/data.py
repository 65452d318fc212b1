"""A log of measured signals for plant identification: a CSV file with a header row naming the
columns (SI units, joint-reflected, the sign conventions of docs/method.md#physical-model), one
row per sample at a constant rate; lines starting with ``#`` are comments (the rig's notes).

References
----------
docs/identification.md#the-log.
"""

from __future__ import annotations

import csv
import decimal
import io
import math
import os
import re
import stat
from dataclasses import dataclass

import numpy as np

from ..config.validate import excerpt, in_limits, limit_text
from ..errors import ConfigError
from ..units import fmt_num

__all__ = ["COLUMNS", "MIN_SAMPLES", "MAX_LOG_BYTES", "MAX_SIGNAL", "JITTER", "DRIFT", "MeasuredLog", "read_log",
           "log_from_columns", "same_samples", "sample_rate"]

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
REQUIRED = ("theta_m", "tau_s")  # and t, unless the sample rate is given
MIN_SAMPLES = 200
MAX_LOG_BYTES = 256 << 20  # 256 MiB: ~10^6 rows of eight columns
JITTER = 0.1  # a step may differ from the median step by this fraction (time-stamp jitter)
DRIFT = 0.5  # in samples: a time stamp may stray this far from the straight line through the stamps
DELAY_TOLERANCE = 1e-4  # in samples: --delay-s must be a whole number of samples within this
# the largest magnitude of a signal sample [rad or N·m]: far beyond any joint (a value beyond it is
# a wrong unit or corrupt data), and small enough that the filters' and regressions' sums of
# squares cannot overflow
MAX_SIGNAL = 1e9


@dataclass(frozen=True)
class MeasuredLog:
    """Sampled signals at ``sample_rate_hz`` [Hz] (``signals``: column → array, SI units; ``t``
    relative to its first sample). A log with ``tau_cmd`` (a command held between samples) keeps
    it as logged: it is applied ``delay_samples`` samples later (``None``: to be estimated,
    ``--delay-s auto``). ``rate_source``: "t" (the time column's mean step) or "given";
    ``time_rate_hz``: with a given rate, the rate of the log's time column (None without one)."""

    sample_rate_hz: float
    signals: dict
    source: str = "<log>"
    delay_samples: int | None = 0
    rate_source: str = "t"
    time_rate_hz: float | None = None  # the time column's rate when the rate is given (None: not both)

    @property
    def samples(self) -> int:
        return int(self.signals["theta_m"].size)

    @property
    def tau_m_held(self) -> bool:
        return "tau_cmd" in self.signals


def same_samples(a: MeasuredLog, b: MeasuredLog) -> bool:
    """Whether two logs hold the same measured samples (the same columns, every one but the time
    column equal value for value): the same run given twice, whatever the files' names.

    Parameters
    ----------
    a, b : MeasuredLog
        The logs.

    Returns
    -------
    bool
        True when every measured signal is the same.
    """
    return (a.samples == b.samples and set(a.signals) == set(b.signals)
            and all(np.array_equal(a.signals[c], b.signals[c]) for c in a.signals if c != "t"))


def _check_time(t: np.ndarray) -> float:
    """The step [s] of a time column relative to its first sample (a straight line fitted to the
    stamps); the stamps strictly increasing (a repeated or reordered sample is named first) and
    every step within :data:`JITTER` of the median step (dropped samples are refused wherever they
    are, whatever the magnitude of t). Samples count from 0, the first row of data."""
    dt = np.diff(t)
    back = np.flatnonzero(~(dt > 0))
    if back.size:
        k = int(back[0])
        d = float(dt[k])
        why = f"not increasing at sample {k + 1} " + (f"(the time of sample {k} again)" if d == 0 else
                                                      f"(step {fmt_num(d)} s from sample {k})")
        raise ConfigError("t", why + ": the rows must be in time order")
    step = float(np.median(dt))
    bad = np.flatnonzero(np.abs(dt - step) > JITTER * step)
    if bad.size:
        k = int(bad[0])
        d = float(dt[k])
        if d > 1.5 * step:
            why = (f"about {round(d / step) - 1} sample(s) missing after sample {k} (step {fmt_num(d)} s, median "
                   f"{fmt_num(step)} s)")
        else:
            why = f"step {fmt_num(d)} s after sample {k} is not the median step {fmt_num(step)} s within {JITTER:.0%}"
        raise ConfigError("t", why + ": a constant rate is needed")
    i = np.arange(t.size) - (t.size - 1) / 2.0
    # the least-squares step (jitter averages out), on the stamps scaled to order one: stamps 1e300
    # apart must not overflow the sums (the rate check then names the step)
    scale = float(np.max(np.abs(t))) or 1.0
    u = t / scale
    return float(np.dot(i, u - u.mean()) / np.dot(i, i)) * scale


_UNIT_IN_NAME = re.compile(r"^\s*([A-Za-z_]+)\s*(?:\[[^\]]*\]|\([^)]*\)|\{[^}]*\})\s*$")


def _unknown_column(c) -> str:
    """Why a column name is not known, in words: a unit written into the name (``t [s]``,
    ``theta_m (rad)``) or another case (``T``) is named as such."""
    known = f"known: {', '.join(COLUMNS)}"
    m = _UNIT_IN_NAME.match(c) if isinstance(c, str) else None
    base = m.group(1) if m else c
    match = next((k for k in COLUMNS if isinstance(base, str) and k == base.lower()), None)
    if m and match:
        return (f"unknown column: a column name carries no unit: name it {match} (its unit is fixed: "
                f"{COLUMNS[match][0]}, docs/identification.md#the-log)")
    if match:
        return f"unknown column; did you mean {match}? (names are lower case; {known})"
    return f"unknown column ({known})"


def _check_drift(t: np.ndarray, step: float) -> None:
    """Refuse time stamps that stray more than :data:`DRIFT` samples from the straight line fitted
    to them (``step`` its slope): a rate that drifts over the log (each step may still be within
    :data:`JITTER` of the median) puts the late samples whole samples away from where a constant
    rate puts them."""
    i = np.arange(t.size) - (t.size - 1) / 2.0
    scale = float(np.max(np.abs(t))) or 1.0
    u = t / scale
    off = (u - u.mean() - (step / scale) * i) / (step / scale)  # in samples
    k = int(np.argmax(np.abs(off)))
    if abs(off[k]) > DRIFT:
        raise ConfigError("t", f"the sample rate drifts: sample {k} is {fmt_num(abs(off[k]), 3)} samples "
                               f"{'after' if off[k] > 0 else 'before'} its time at the log's mean rate "
                               f"{fmt_num(1.0 / step)} Hz (more than {DRIFT:g}): a constant rate is needed (or "
                               "give the rate, `sample_rate_hz`, if only the time stamps drift)")


def _column(c: str, v) -> np.ndarray:
    """The column ``c`` as a 1-D float array (long double kept): refused, naming the column, when
    it is not numbers (complex values, None or text among them are named, not read as NaN), holds
    a value that is not finite, or a signal value beyond :data:`MAX_SIGNAL`."""
    try:
        a = np.asarray(v)
        if a.dtype.kind == "c":
            raise ConfigError(c, "not a column of real numbers (complex values)")
        if a.dtype.kind == "O":  # None or text among numbers: named, not read as NaN
            k = next((i for i, x in enumerate(a.ravel()) if isinstance(x, (bool, np.bool_))
                      or not isinstance(x, (int, float, np.integer, np.floating))), None)
            if k is not None:
                raise ConfigError(c, f"sample {k} is {a.ravel()[k]!r}: every value must be a finite number")
        if a.dtype != np.longdouble:
            a = np.asarray(v, dtype=float)
    except (TypeError, ValueError):
        raise ConfigError(c, "not a column of numbers") from None
    if a.ndim != 1 or a.dtype.kind != "f":
        raise ConfigError(c, "not a column of numbers")
    bad = np.flatnonzero(~np.isfinite(a))
    if bad.size:
        raise ConfigError(c, f"sample {int(bad[0])} is {float(a[bad[0]])!r}: every value must be a finite number")
    if c != "t" and a.size:
        big = np.flatnonzero(np.abs(a) > MAX_SIGNAL)
        if big.size:
            unit = COLUMNS[c][0]
            raise ConfigError(c, f"sample {int(big[0])} is {float(a[big[0]]):.6g} {unit}: beyond ±{MAX_SIGNAL:.0e} "
                              f"{unit}, not a measured {COLUMNS[c][1].split(' (')[0]} (check the units, "
                              "docs/identification.md#the-log)")
    return a


def log_from_columns(columns: dict, source: str = "<log>", delay_s="0", sample_rate_hz: float | None = None) -> MeasuredLog:
    """Check measured columns (name → sequence of numbers) and make a :class:`MeasuredLog`: known
    names only, the required ones present, equal lengths, finite numbers, at least
    :data:`MIN_SAMPLES` samples at a constant rate (each step within :data:`JITTER` of the median
    step, judged after subtracting the first time stamp, so epoch time stamps and µs jitter pass
    and a dropped sample does not). ``sample_rate_hz`` [Hz] overrides the time column's rate (the
    ``t`` column may then be absent). ``delay_s`` [s]: from ``tau_cmd`` to the applied torque, a
    whole number of samples, or ``"auto"`` (estimated by :func:`identify_plant`).

    Parameters
    ----------
    columns : dict
        Column name → sequence of numbers (SI units: t [s], angles [rad], torques [N·m]).
    source : str, optional
        What the columns are (a file path), named by the estimate.
    delay_s : str or float, optional
        Delay [s] of ``tau_cmd``, or ``"auto"``.
    sample_rate_hz : float or None, optional
        Sample rate [Hz]; None to take it from the ``t`` column.

    Returns
    -------
    MeasuredLog
        The checked log (time stamps from 0, its rate and where the rate came from, the delay).

    Raises
    ------
    ConfigError
        Naming the column (or option) and the reason.
    """
    unknown = [c for c in columns if c not in COLUMNS]
    if unknown:
        raise ConfigError(unknown[0], _unknown_column(unknown[0]))
    for c in REQUIRED + (("t",) if sample_rate_hz is None else ()):
        if c not in columns:
            raise ConfigError(c, f"missing column ({COLUMNS[c][1]} [{COLUMNS[c][0]}])")
    if ("tau_m" in columns) == ("tau_cmd" in columns):
        raise ConfigError("tau_m", "give exactly one of tau_m (applied motor torque) and tau_cmd (the command, "
                          "applied after --delay-s)")
    sig = {c: _column(c, v) for c, v in columns.items()}
    n = sig["theta_m"].size
    if any(a.size != n for a in sig.values()):
        raise ConfigError("t" if "t" in sig else "theta_m", "the columns have different lengths")
    if n < MIN_SAMPLES:
        raise ConfigError("t" if "t" in sig else "theta_m",
                          f"{n} sample{'' if n == 1 else 's'}: at least {MIN_SAMPLES} are needed")
    if "t" in sig:
        sig["t"] = np.asarray(sig["t"] - sig["t"][0], dtype=float)  # exact for nearby floats, epoch stamps too
        step = _check_time(sig["t"])
    time_rate = None
    if sample_rate_hz is not None:
        fs, rate_source = sample_rate(sample_rate_hz), "given"
        time_rate = 1.0 / step if "t" in sig else None
        sig["t"] = np.arange(n) / fs
    else:
        fs, rate_source = 1.0 / step, "t"
        if not in_limits(fs, "frequency"):
            raise ConfigError("t", f"a step of {fmt_num(step)} s is a sample rate of {fmt_num(fs)} Hz, outside "
                              f"{limit_text('frequency')}: is t in seconds? (or give the rate, `sample_rate_hz`)")
        _check_drift(sig["t"], step)
    at = f"{fmt_num(fs)} Hz ({source})"
    delay = None
    if isinstance(delay_s, str) and delay_s.strip().lower() == "auto":
        if "tau_cmd" not in sig:
            raise ConfigError("delay_s", "auto estimates the delay of a tau_cmd column; this log has tau_m")
    else:
        try:
            d_s = float(delay_s) if not isinstance(delay_s, bool) else None  # a bool is not a delay
        except (TypeError, ValueError, OverflowError):
            d_s = None
        if d_s is None:
            raise ConfigError("delay_s", f"{delay_s!r} is neither a delay [s] nor auto")
        if not (math.isfinite(d_s) and d_s >= 0):
            raise ConfigError("delay_s", f"{delay_s!r} is not a delay ≥ 0 s")
        d = d_s * fs
        if not math.isfinite(d):
            raise ConfigError("delay_s", f"{delay_s!r} s is more samples at {at} than a number can hold")
        delay = int(round(d))
        if "tau_cmd" in sig and abs(d - delay) > DELAY_TOLERANCE * max(1.0, d):
            raise ConfigError("delay_s", f"{delay_s!r} s is {d:.6g} samples at {at}: identification needs "
                              "a whole number of samples (log the applied torque as tau_m otherwise)")
        if "tau_cmd" in sig and delay >= n - MIN_SAMPLES:
            raise ConfigError("delay_s", f"{delay} samples at {at} leave fewer than {MIN_SAMPLES} samples of its {n}")
        if "tau_cmd" not in sig:
            delay = 0
    return MeasuredLog(fs, sig, source, delay, rate_source, time_rate)


def sample_rate(value) -> float:
    """A given sample rate [Hz] (``sample_rate_hz``, ``--sample-rate-hz``): a number (a numpy
    scalar too; not its text) within the design file's accepted range of frequencies
    (docs/design-file.md#input-limits-and-accepted-ranges), so that the filters designed from it
    are sound.

    Parameters
    ----------
    value : Any
        The rate given.

    Returns
    -------
    float
        The rate [Hz].

    Raises
    ------
    ConfigError
        Field ``sample_rate_hz``: not a number > 0, or out of the accepted range.
    """
    from ..options import number_value

    fs = number_value("sample_rate_hz", value, positive=True, noun="a sample rate [Hz]", strings=False)
    if not in_limits(fs, "frequency"):
        raise ConfigError("sample_rate_hz", f"{fmt_num(fs)} Hz is outside the accepted range of rates "
                          f"{limit_text('frequency')} (docs/design-file.md#input-limits-and-accepted-ranges)")
    return fs


def read_log(path, delay_s="0", sample_rate_hz: float | None = None) -> MeasuredLog:
    """Read a measured log (CSV: a header row of column names, then one row of numbers per
    sample; lines starting with ``#`` are comments, skipped, above the header or between rows)
    through the guarded reader and check it (:func:`log_from_columns`).

    The rows are parsed by pyarrow's CSV reader (multi-threaded, in C; a 60 s log at 10 kHz in
    about 0.3 s), the time column as text and taken relative to its first stamp in decimal
    arithmetic when its magnitude would cost float64 digits (epoch stamps); a file that reader
    does not take as it is (spaces around a number, a ragged or non-numeric row, a header naming
    an unknown or repeated column, …) is read again row by row, which names the row and the value.

    Parameters
    ----------
    path : str or os.PathLike
        The CSV file (at most :data:`MAX_LOG_BYTES`).
    delay_s : float or "auto"
        The delay [s] between ``tau_cmd`` and the applied torque (when the log has ``tau_cmd``).
    sample_rate_hz : float, optional
        The sample rate [Hz], overriding the time column (which may then be absent).

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
    cols = _fast_columns(path)
    if cols is None:
        from ..config.yamlio import read_guarded

        cols = _row_columns(read_guarded(path, "measured log", max_bytes=MAX_LOG_BYTES), path)
    return log_from_columns(cols, str(path), delay_s, sample_rate_hz)


EXACT_TIME_BELOW = 2.0 ** 22  # |t| [s] below which float64 stamps keep 1e-9 s: no decimal arithmetic needed
READ_BLOCK = 4 << 20  # bytes of text parsed at a time


def _fast_columns(path) -> dict | None:
    """The columns of a well-formed CSV log, parsed by pyarrow block by block (:data:`READ_BLOCK`
    bytes of text at a time, in C, on every core) straight into the arrays that hold them: memory
    about the columns' size, never the whole text. None: let the guarded row-by-row reader judge the
    file (a missing or irregular file, a header or row pyarrow does not take as it is)."""
    try:
        import pyarrow as pa
    except ImportError:  # pragma: no cover - a dependency
        return None
    try:
        st = os.stat(path)
        if not stat.S_ISREG(st.st_mode) or st.st_size > MAX_LOG_BYTES:
            return None
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0))
        with os.fdopen(fd, "rb") as fh:
            if not stat.S_ISREG(os.fstat(fh.fileno()).st_mode):
                return None
            line = fh.readline(1 << 16).decode("utf-8-sig")
            while line.lstrip().startswith("#"):  # comment lines above the header
                line = fh.readline(1 << 16).decode("utf-8")
            header = [h.strip() for h in next(csv.reader([line.rstrip("\r\n")]), [])]
            if not header or len(set(header)) != len(header) or any(h not in COLUMNS for h in header):
                return None
            body = fh.tell()
            cols = _parse_blocks(fh, header, {h: pa.float64() for h in header}, st.st_size - body)
            if "t" in cols and cols["t"].size and np.all(np.isfinite(cols["t"])):
                if np.max(np.abs(cols["t"])) >= EXACT_TIME_BELOW:  # epoch stamps: again, as text, in decimal
                    fh.seek(body)
                    cols["t"] = _parse_blocks(fh, header, {"t": pa.string()}, st.st_size - body)["t"]
                else:
                    cols["t"] -= cols["t"][0]
        return cols
    except (OSError, UnicodeDecodeError, StopIteration, csv.Error, pa.ArrowException, ValueError,
            decimal.InvalidOperation):
        return None


def _parse_blocks(fh, header, types, size) -> dict:
    """The columns ``types`` (name → pyarrow type: float64, or string for an exact relative time)
    of the CSV rows from ``fh`` (after the header), parsed :data:`READ_BLOCK` bytes at a time into
    preallocated arrays (grown if the first block's row length underestimates them)."""
    import pyarrow as pa
    import pyarrow.csv as pacsv

    pool = pa.system_memory_pool()  # plain malloc: each block's buffers are reused by the next
    ropt = pacsv.ReadOptions(column_names=header, block_size=1 << 20)
    copt = pacsv.ConvertOptions(column_types=types, include_columns=list(types), null_values=[],
                                strings_can_be_null=False, quoted_strings_can_be_null=False)
    out, n, rest, t0 = {}, 0, b"", None
    while True:
        chunk = fh.read(READ_BLOCK)
        data = rest + chunk
        if chunk:
            cut = data.rfind(b"\n") + 1
            data, rest = data[:cut], data[cut:]
        if not data.strip():
            if chunk:
                continue
            break
        table = pacsv.read_csv(pa.BufferReader(data), read_options=ropt, convert_options=copt, memory_pool=pool)
        k = table.num_rows
        if not out:
            cap = int(size / max(len(data), 1) * k * 1.02) + 16
            out = {h: np.empty(cap) for h in types}
        if n + k > out[next(iter(types))].size:
            out = {h: np.resize(a, int((n + k) * 1.25)) for h, a in out.items()}
        for h, typ in types.items():
            if typ == pa.string():
                values, t0 = _decimal_time(table.column(h), t0)
                out[h][n: n + k] = values
            else:
                j = n
                for c in table.column(h).chunks:
                    out[h][j: j + len(c)] = _float64_values(c)
                    j += len(c)
        n += k
        if not chunk:
            break
    return {h: (out[h][:n] if h in out else np.empty(0)) for h in types}  # (a view: a copy would cost a pass)


def _float64_values(a) -> np.ndarray:
    """The values of a pyarrow float64 array without nulls, as a numpy view of its buffer (not
    ``to_numpy``, which imports pandas: half a second and 40 MB)."""
    if a.null_count:
        raise ValueError("null values")
    return np.frombuffer(a.buffers()[1], dtype=np.float64, count=len(a), offset=a.offset * 8)


def _decimal_time(t, t0):
    """Time stamps (pyarrow strings) relative to the first one ``t0`` (a decimal string; None:
    this block's first) in decimal arithmetic, as float64: pyarrow's decimal128, else Python's."""
    import pyarrow as pa
    import pyarrow.compute as pc

    t0 = t[0].as_py().strip() if t0 is None else t0
    try:
        d = pc.cast(t, pa.decimal128(28, 18))
        rel = pc.cast(pc.subtract(d, pa.scalar(decimal.Decimal(t0), pa.decimal128(28, 18))), pa.float64())
        return np.concatenate([_float64_values(c) for c in rel.chunks]) if rel.num_chunks else np.empty(0), t0
    except pa.ArrowException:
        base = decimal.Decimal(t0)
        return np.array([float(decimal.Decimal(x.strip()) - base) for x in t.to_pylist()]), t0


def _number_text(x: str) -> bool:
    """Whether a cell's text is a number as a design file writes one (YAML 1.2 decimal, surrounding
    blanks aside) or a spelt-out non-finite value (``nan``, ``inf``: refused afterwards, named)."""
    from ..options import NUMBER_TEXT

    t = x.strip()
    return bool(NUMBER_TEXT.fullmatch(t)) or t.lstrip("+-").lower() in ("inf", "infinity", "nan")


def _is_number(x: str) -> bool:
    try:
        float(x)
    except ValueError:
        return False
    return True


def _row_columns(raw: bytes, path) -> dict:
    """The columns of a CSV log read row by row (every cell through ``float``), naming the line
    and the value that is not a number; blank lines and comment lines (starting with ``#``) are
    skipped."""
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise ConfigError(str(path), "not UTF-8 text (a CSV log is expected)") from None
    reader = csv.reader(io.StringIO(text))
    try:
        rows = [(reader.line_num, r) for r in reader  # blank lines and comment lines (# …) skipped
                if r and any(x.strip() for x in r) and not r[0].lstrip().startswith("#")]
    except csv.Error as e:  # a field beyond the csv module's limit (131072 characters), a NUL in a quoted field, …
        raise ConfigError(f"{path}:{reader.line_num}", f"not a CSV log ({excerpt(str(e), 60)}): a header row and "
                          "one row of numbers per sample are expected") from None
    if not rows:
        raise ConfigError(str(path), "empty: a header row and one row per sample are expected")
    line, header = rows[0][0], [h.strip() for h in rows[0][1]]
    if all(_is_number(h) for h in header):
        raise ConfigError(f"{path}:{line}", f"a row of numbers, not a header: the first line (after # comments) "
                          f"names the columns ({', '.join(COLUMNS)})")
    if "" in header:
        i = header.index("")
        if i and not any(header[i:]):
            raise ConfigError(f"{path}:{line}", f"the header row ends with an empty column (a trailing ',' after "
                              f"{header[i - 1]!r}): remove the trailing comma from every row")
        raise ConfigError(f"{path}:{line}", f"column {i + 1} of the header row has no name (two commas in a row?): "
                          f"name every column ({', '.join(COLUMNS)})")
    other = _delimiter(header[0]) if len(header) == 1 and header[0] not in COLUMNS else None
    if other is not None:
        raise ConfigError(f"{path}:{line}", f"not comma-separated: the header row {header[0][:50]!r} is split by "
                          f"{other}; a log is CSV, with ',' between the values")
    if len(set(header)) != len(header):
        dup = next(h for h in header if header.count(h) > 1)
        raise ConfigError(dup, "column named twice")
    cols = {h: [] for h in header}
    t0 = None
    for i, r in rows[1:]:
        if len(r) != len(header):
            raise ConfigError(f"{path}:{i}", f"{len(r)} values, the header names {len(header)} columns")
        for h, x in zip(header, r):
            try:
                if not _number_text(x):  # Python reads '1_0' (10) and non-ASCII digits; a design file does not
                    raise ValueError(x)
                v = float(x)
                if h == "t" and math.isfinite(v):  # relative to the first stamp, in decimal: epoch stamps keep their µs
                    t0 = decimal.Decimal(x.strip()) if t0 is None else t0
                    v = float(decimal.Decimal(x.strip()) - t0)
                cols[h].append(v)
            except (ValueError, decimal.InvalidOperation):
                other = _delimiter(x)
                hint = "" if other is None else f" (split by {other}: a log is CSV, with ',' between the values)"
                if not hint and _is_number(x):  # '1_0', '١٠': Python's float reads them, a design file does not
                    hint = " (write it as a design file does: ASCII digits, an optional '.' and exponent, no '_')"
                raise ConfigError(f"{path}:{i}", f"{h} = {x.strip()[:40]!r} is not a number{hint}") from None
    return cols


_DELIMITERS = ((";", "';' (semicolons)"), ("\t", "tabs"), ("|", "'|'"))


def _delimiter(text: str) -> str | None:
    """The other delimiter a cell or a header name holds (a log written with ';', tabs, '|' or
    spaces between its values), as the messages name it; None when it holds none."""
    for d, name in _DELIMITERS:
        if d in text.strip():
            return name
    parts = text.split()
    if len(parts) > 1 and (all(p in COLUMNS for p in parts) or all(_is_number(p) for p in parts)):
        return "spaces"
    return None
