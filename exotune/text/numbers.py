"""Numbers and units as exotune's text views write them (the number formatter itself,
:func:`exotune.units.fmt_num`, sits in the lowest layer so that every view shares it)."""

from __future__ import annotations


from ..units import fmt_num

__all__ = ["fmt_num", "unit_text", "count_text", "interval_text", "sampled_verdict_word"]


def unit_text(unit: str) -> str:
    """A unit as the text views print it: dimensionless ``"1"`` becomes ``"–"``.

    Parameters
    ----------
    unit : str
        A unit string of the JSON results (``"1"`` and ``"1 (explanation)"`` mean dimensionless).

    Returns
    -------
    str
        ``"–"`` (or ``"– (explanation)"``) for a dimensionless unit, else ``unit`` unchanged.

    References
    ----------
    docs/cli.md#output.

    Examples
    --------
    >>> unit_text("1"), unit_text("1 (relative)"), unit_text("1/s")
    ('–', '– (relative)', '1/s')
    """
    if unit == "1":
        return "–"
    if isinstance(unit, str) and unit.startswith("1 ("):
        return "–" + unit[1:]
    return unit


def count_text(n, noun: str, digits: int = 4) -> str:
    """A count with its noun, singular for exactly one: ``"1 sample"``, ``"2.5 samples"``.

    Parameters
    ----------
    n : int or float
        The count.
    noun : str
        The singular noun (the plural adds "s").
    digits : int
        Significant digits of :func:`fmt_num`.

    Returns
    -------
    str
        The count and the noun.

    References
    ----------
    docs/cli.md#output.

    Examples
    --------
    >>> count_text(1.0, "sample"), count_text(3, "sample")
    ('1 sample', '3 samples')
    """
    return f"{fmt_num(n, digits)} {noun}{'' if n == 1 else 's'}"


def interval_text(intervals, unit: str, digits: int = 6, empty: str = "none") -> str:
    """Intervals with their unit: ``"[a, b], [c, d] unit"``.

    Parameters
    ----------
    intervals : sequence of (float, float)
        The intervals.
    unit : str
        Their unit (passed through :func:`unit_text`).
    digits : int
        Significant digits.
    empty : str
        The text without intervals.

    Returns
    -------
    str
        The intervals joined by ", " followed by the unit, or ``empty``.

    References
    ----------
    docs/cli.md#output.
    """
    if not intervals:
        return empty
    u = unit_text(unit)
    return ", ".join(f"[{a:.{digits}g}, {b:.{digits}g}]" for a, b in intervals) + (f" {u}" if u else "")


def sampled_verdict_word(stable) -> str:
    """"stable", "UNSTABLE" or, for a verdict that rounding cannot decide (None), "inconclusive
    (spectral radius within rounding of 1)" (docs/method.md#sampled-data).

    Parameters
    ----------
    stable : bool or None
        The verdict (None: inconclusive).

    Returns
    -------
    str
        The word.

    Examples
    --------
    >>> sampled_verdict_word(True), sampled_verdict_word(False)
    ('stable', 'UNSTABLE')
    """
    if stable is None:
        return "inconclusive (spectral radius within rounding of 1)"
    return "stable" if stable else "UNSTABLE"
