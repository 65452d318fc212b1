"""The one number formatter of exotune's text views."""

from __future__ import annotations

import math

__all__ = ["fmt_num"]


def fmt_num(x, digits=6) -> str:
    """A number as text with ``digits`` significant digits.

    Parameters
    ----------
    x : float, int, str or None
        The value; a string is returned as is.
    digits : int
        Significant digits (``format(x, ".{digits}g")``).

    Returns
    -------
    str
        ``"—"`` for None and NaN (undefined), ``"∞"``/``"−∞"`` for infinities, else the number.

    References
    ----------
    docs/cli.md#output (every printed number carries its unit next to it).

    Examples
    --------
    >>> fmt_num(3.14159265, 3), fmt_num(float("inf")), fmt_num(None)
    ('3.14', '∞', '—')
    """
    if x is None:
        return "—"
    if isinstance(x, str):
        return x
    if isinstance(x, float) and math.isinf(x):
        return "∞" if x > 0 else "−∞"
    if isinstance(x, float) and math.isnan(x):
        return "—"
    return f"{x:.{digits}g}"
