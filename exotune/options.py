"""Numbers, flags and paths given on the command line or as keywords of the API twins of the
commands: one parser per kind of value, one message style — the option's (or keyword's) name, the
reason, the value as typed (docs/cli.md)."""

from __future__ import annotations

import math
import os
import re

from .errors import ConfigError

__all__ = ["number_value", "latency_requirement_value", "flag_value", "path_value", "NUMBER_TEXT", "INTEGER_TEXT",
           "MAX_LATENCY_REQUIREMENT_S"]

#: A number's text as a YAML 1.2 file writes a decimal number (core schema: ``2.5``, ``1e3``,
#: ``-0.5``, ``.5``, ``3.``), surrounding blanks aside. Python's ``float`` also reads ``1_000``,
#: non-ASCII digits and ``infinity``, which a design file refuses: so does the command line.
NUMBER_TEXT = re.compile(r"[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?")
#: An integer's text (YAML 1.2 core schema, decimal).
INTEGER_TEXT = re.compile(r"[-+]?[0-9]+")
#: The spellings of a non-finite number (``nan``, ``inf``, ``-.inf``, ``Infinity``, …).
_NON_FINITE_TEXT = re.compile(r"[-+]?\.?(?:inf|infinity|nan)", re.IGNORECASE)
_HINT = "(write it as a design file does: ASCII digits, an optional '.' and exponent, no '_')"
#: The largest latency-margin requirement [s]: the top of the accepted range of delays
#: (``exotune.config.validate.LIMITS["delay"]``, also that of a design file's
#: ``requirements.latency_margin_s``; not imported: the options are below the configuration layer).
MAX_LATENCY_REQUIREMENT_S = 1.0


#: The most characters of an option's text an error quotes (a 5 000-digit number is cut).
_SHOWN_CHARS = 40


def _shown(text) -> str:
    """An option's value as an error quotes it: its repr, a long text cut to its first
    40 characters and its length."""
    if isinstance(text, (str, bytes)) and len(text) > _SHOWN_CHARS:
        return f"{text[:_SHOWN_CHARS]!r}… ({len(text)} characters)"
    return repr(text)


def _number_text(name: str, text, noun: str) -> None:
    """Refuse the text of a number that YAML 1.2 would not read as one (``1_000``, ``١٠``)."""
    s = _text(text).strip(" \t\r\n")
    if NUMBER_TEXT.fullmatch(s):
        return
    if _NON_FINITE_TEXT.fullmatch(s):
        raise ConfigError(name, f"must be a finite number, got {_shown(text)}")
    try:
        float(s)
    except (TypeError, ValueError, OverflowError):
        raise ConfigError(name, f"expected {noun}, got {_shown(text)}") from None
    raise ConfigError(name, f"expected {noun}, got {_shown(text)} {_HINT}")


def _text(text) -> str:
    return text.decode("utf-8", "replace") if isinstance(text, bytes) else text


def _is_bool(value) -> bool:
    """A bool, or a numpy boolean scalar (``np.True_``): a flag, never a number."""
    return isinstance(value, bool) or (getattr(getattr(value, "dtype", None), "kind", None) == "b"
                                       and getattr(value, "shape", None) == ())


def number_value(name: str, text, positive: bool = False, noun: str = "a number", strings: bool = True) -> float:
    """``text`` as a finite float (> 0 when ``positive``); :class:`ConfigError` naming ``name``
    otherwise. ``noun`` words the expected value ("a number of Hz").

    Parameters
    ----------
    name : str
        The option or field named by the error.
    text : Any
        The value (a string or a number). A bool is refused (it is an int, but not a number anyone
        means).
    positive : bool, optional
        Require a value > 0.
    noun : str, optional
        What the error says was expected.
    strings : bool, optional
        Accept the number's text (``"2.5"``): the command line's values are strings. False for a
        keyword the command line converts before the call (only numbers then).

    Returns
    -------
    float
        The value.

    Raises
    ------
    exotune.errors.ConfigError
        When the value is a bool (or, unless ``strings``, a string), is not a finite number, or is
        not positive when required. A string must be a number as YAML 1.2 writes it (``1_000``,
        non-ASCII digits and ``infinity`` are refused although Python's ``float`` reads them).

    Examples
    --------
    >>> number_value("--duration", "2.5", positive=True)
    2.5
    """
    if _is_bool(text) or (not strings and isinstance(text, (str, bytes))):
        raise ConfigError(name, f"expected {noun}, got {_shown(text)}")
    if isinstance(text, (str, bytes)):
        _number_text(name, text, noun)
    try:
        v = float(text)
    except (TypeError, ValueError, OverflowError):
        raise ConfigError(name, f"expected {noun}, got {_shown(text)}") from None
    if not math.isfinite(v):
        big = isinstance(text, (str, bytes)) and not _NON_FINITE_TEXT.fullmatch(_text(text).strip(" \t\r\n"))
        raise ConfigError(name, f"must be a finite number, got {_shown(text)}"
                                + (" (beyond the largest floating-point number, about 1.8e308)" if big else ""))
    if positive and not v > 0:
        raise ConfigError(name, f"must be > 0, got {_shown(text)}")
    return v


def latency_requirement_value(name: str, text, strings: bool = True) -> float:
    """A required latency margin [s] (``--require-latency-margin-s``): a number of seconds in
    [0, :data:`MAX_LATENCY_REQUIREMENT_S`] — the accepted range of a design file's
    ``requirements.latency_margin_s`` and of the total delays the analyses accept; 0: no
    requirement. A larger requirement (``1e308``) could never be checked: it is refused naming
    ``name``, never written into a controller file.

    Parameters
    ----------
    name : str
        The option or keyword named by the error.
    text : Any
        The value (the option's text, or a number).
    strings : bool, optional
        Accept the number's text (see :func:`number_value`).

    Returns
    -------
    float
        The requirement [s].

    Raises
    ------
    exotune.errors.ConfigError
        When the value is not a finite number of seconds in [0, 1].

    References
    ----------
    docs/design-file.md#input-limits-and-accepted-ranges; docs/controller-file.md (``requirements``).

    Examples
    --------
    >>> latency_requirement_value("--require-latency-margin-s", "0.002")
    0.002
    """
    v = number_value(name, text, noun="a number of seconds", strings=strings)
    if not 0.0 <= v <= MAX_LATENCY_REQUIREMENT_S:
        raise ConfigError(name, f"out of the accepted range: must be in [0, {MAX_LATENCY_REQUIREMENT_S:g}] s, got "
                                f"{_shown(text)} (the extra delay the loop must tolerate: the analyses accept total delays "
                                f"up to {MAX_LATENCY_REQUIREMENT_S:g} s, as a design file's "
                                "requirements.latency_margin_s does; docs/design-file.md#input-limits-and-accepted-ranges)")
    return v


def flag_value(name: str, value) -> bool:
    """A yes/no keyword (``cross_check``, ``allow_uncertified``, ``friction``): ``True`` or
    ``False`` only, so that a string such as ``"no"`` is not taken for yes.

    Parameters
    ----------
    name : str
        The keyword named by the error.
    value : Any
        The value given.

    Returns
    -------
    bool
        The value (a numpy boolean scalar as a bool).

    Raises
    ------
    exotune.errors.ConfigError
        When the value is not a bool.

    Examples
    --------
    >>> flag_value("cross_check", True)
    True
    """
    if not _is_bool(value):
        raise ConfigError(name, f"expected True or False, got {value!r}")
    return bool(value)


def path_value(name: str, value, required: bool = False):
    """A path keyword (``out``, ``plots``, ``validate``, …): a ``str`` or an ``os.PathLike``;
    None (not given) passes unless ``required``.

    Parameters
    ----------
    name : str
        The keyword named by the error.
    value : Any
        The value given.
    required : bool, optional
        Refuse None (a keyword without a default: the output of ``sweep``, ``optimize``, …).

    Returns
    -------
    str, os.PathLike or None
        The value, unchanged.

    Raises
    ------
    exotune.errors.ConfigError
        When the value is neither a string nor an ``os.PathLike`` (a number, a list, bytes; None
        when ``required``), or holds a NUL character (no file system accepts one).

    Examples
    --------
    >>> path_value("out", "controller.yaml")
    'controller.yaml'
    """
    if (required or value is not None) and not isinstance(value, (str, os.PathLike)):
        raise ConfigError(name, f"expected a path (str or os.PathLike), got {type(value).__name__} {value!r}")
    if value is not None and "\x00" in str(os.fspath(value)):  # the OS refuses it with a bare "embedded null byte"
        raise ConfigError(name, f"{_shown(os.fspath(value))}: a path cannot contain a NUL character")
    return value
