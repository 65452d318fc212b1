"""Numbers given on the command line (and to the API twins of the commands): one parser, one
message style — the option's name, the reason, the value as typed (docs/cli.md)."""

from __future__ import annotations

import math

from .errors import ConfigError

__all__ = ["number_value"]


def number_value(name: str, text, positive: bool = False, noun: str = "a number") -> float:
    """``text`` as a finite float (> 0 when ``positive``); :class:`ConfigError` naming ``name``
    otherwise. ``noun`` words the expected value ("a number of Hz").

    Parameters
    ----------
    name : str
        The option or field named by the error.
    text : Any
        The value (a string or a number).
    positive : bool, optional
        Require a value > 0.
    noun : str, optional
        What the error says was expected.

    Returns
    -------
    float
        The value.

    Raises
    ------
    exotune.errors.ConfigError
        When the value is not a finite number, or not positive when required.

    Examples
    --------
    >>> number_value("--duration", "2.5", positive=True)
    2.5
    """
    try:
        v = float(text)
    except (TypeError, ValueError):
        raise ConfigError(name, f"expected {noun}, got {text!r}") from None
    if not math.isfinite(v):
        raise ConfigError(name, f"must be a finite number, got {text!r}")
    if positive and not v > 0:
        raise ConfigError(name, f"must be > 0, got {text!r}")
    return v
