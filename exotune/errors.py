"""Exceptions raised for bad user input (docs/cli.md: "one clear message naming the field and the
reason").

:class:`ConfigError` carries the offending field as a dotted path into the input file
(``design.amplification``, ``humans[0].inertia``, ``implementation.gv_filter.cutoff_hz``) or, for
file-level problems (unreadable file, invalid YAML), the file name. ``str(err)`` is
``"<field>: <reason>"``, which the CLI prints as ``exotune: error: <field>: <reason>``.
"""

from __future__ import annotations

import re

__all__ = ["ExotuneError", "ConfigError", "RunFailed", "combine_errors", "printable", "MAX_MORE_LINES"]


MAX_FIELD_CHARS = 300  # the longest field (a path) an error line carries
MAX_REASON_CHARS = 1000  # the longest reason
MAX_MORE_LINES = 10  # the further problems an error lists (then "… and N more")

#: what a terminal could act on in a user's text: C0 controls (ESC starts ANSI/OSC sequences, BEL,
#: backspace, CR), DEL, C1 controls (8-bit CSI/OSC) and the bidirectional overrides and isolates
#: that reorder what is displayed
_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f\u061c\u200e\u200f\u202a-\u202e\u2066-\u2069]")


def _escape(m: re.Match) -> str:
    o = ord(m.group(0))
    return f"\\x{o:02x}" if o <= 0xFF else f"\\u{o:04x}"


def printable(text: str, keep: str = "") -> str:
    r"""``text`` with every control character a terminal could act on shown escaped (ESC as
    ``\x1b``, a right-to-left override as ``\u202e``): a file name, key or string of a user's
    file printed in a message or report cannot move the cursor, retitle or recolour the terminal,
    or reorder what is shown.

    Parameters
    ----------
    text : str
        The text to print.
    keep : str, optional
        Control characters left as they are (``"\n"`` for a report's line breaks).

    Returns
    -------
    str
        The text, with the other control characters as ``\xNN`` / ``\uNNNN``.

    References
    ----------
    docs/cli.md#outputs; docs/design-file.md#errors.

    Examples
    --------
    >>> printable("\x1b[31mred\x1b[0m")
    '\\x1b[31mred\\x1b[0m'
    """
    text = str(text)
    if keep:
        return _CONTROL.sub(lambda m: m.group(0) if m.group(0) in keep else _escape(m), text)
    return _CONTROL.sub(_escape, text)


def _cap(text: str, limit: int) -> str:
    return text if len(text) <= limit else f"{text[:limit]}… (cut; {len(text)} characters)"


def _line(text) -> str:
    """One line of an error: blanks collapsed, control characters escaped."""
    return printable(" ".join(str(text).split()))


class ExotuneError(Exception):
    """Base of every error exotune reports to its user. The command line prints ``str(error)`` as
    one line ``exotune: error: …`` and exits with :attr:`exit_code`, without a traceback."""

    exit_code = 2


class RunFailed(ExotuneError):
    """A run that was set up correctly but did not complete (e.g. failed sweep chunks). Exit code 1."""

    exit_code = 1

    def __init__(self, message: str):
        super().__init__(_line(message))


class ConfigError(ExotuneError):
    """Invalid user input: ``field`` (dotted path or file name) and a human-readable ``reason``.
    Exit code 2.

    ``more`` lists the file's further problems, each ``"<field>: <reason>"`` on one line: the
    command line prints ``str(error)`` as its first line ``exotune: error: …`` and then one line
    per item of ``more`` (docs/cli.md#errors).

    ``in_file`` marks a field that is a key of an input file even though a keyword of the same
    name exists (a sweep spec's ``chunk_size`` beside ``chunk_size=``/``--chunk-size``, an optimize
    spec's ``seed`` beside ``seed=``/``--seed``): the command line then names the file's key, not
    the option the user did not give."""

    def __init__(self, field: str, reason: str, more=(), in_file: bool = False):
        # keep every message on one line (the CLI contract is a one-line error), and short: an
        # error never quotes a whole input file
        self.field = _cap(_line(field), MAX_FIELD_CHARS)
        self.reason = _cap(_line(reason), MAX_REASON_CHARS)
        self.more = [_cap(_line(m), MAX_FIELD_CHARS + MAX_REASON_CHARS) for m in more]
        self.in_file = bool(in_file)
        super().__init__(self.field, self.reason)

    def __str__(self) -> str:
        return f"{self.field}: {self.reason}" if self.field else self.reason

    def __reduce__(self):  # picklable across process pools (sweeps)
        return (type(self), (self.field, self.reason, tuple(self.more), self.in_file))


def combine_errors(errors) -> ConfigError:
    """One :class:`ConfigError` for several: the first, with the others (and their own ``more``)
    as its ``more`` lines.

    Parameters
    ----------
    errors : sequence of ConfigError
        At least one error, in the order they are to be printed.

    Returns
    -------
    ConfigError
        The first error's field and reason; ``more`` holds every other line.
    """
    first, *rest = errors
    more = list(first.more)
    for e in rest:
        more.append(str(e))
        more.extend(e.more)
    return ConfigError(first.field, first.reason, more, in_file=first.in_file)
