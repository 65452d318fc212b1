"""Exceptions raised for bad user input (docs/cli.md: "one clear message naming the field and the
reason").

:class:`ConfigError` carries the offending field as a dotted path into the input file
(``design.amplification``, ``humans[0].inertia``, ``implementation.gv_filter.cutoff_hz``) or, for
file-level problems (unreadable file, invalid YAML), the file name. ``str(err)`` is
``"<field>: <reason>"``, which the CLI prints as ``exotune: error: <field>: <reason>``.
"""

from __future__ import annotations

__all__ = ["ExotuneError", "ConfigError", "RunFailed", "combine_errors"]


MAX_FIELD_CHARS = 300  # the longest field (a path) an error line carries
MAX_REASON_CHARS = 1000  # the longest reason


def _cap(text: str, limit: int) -> str:
    return text if len(text) <= limit else f"{text[:limit]}… (cut; {len(text)} characters)"


class ExotuneError(Exception):
    """Base of every error exotune reports to its user. The command line prints ``str(error)`` as
    one line ``exotune: error: …`` and exits with :attr:`exit_code`, without a traceback."""

    exit_code = 2


class RunFailed(ExotuneError):
    """A run that was set up correctly but did not complete (e.g. failed sweep chunks). Exit code 1."""

    exit_code = 1

    def __init__(self, message: str):
        super().__init__(" ".join(str(message).split()))


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
        self.field = _cap(" ".join(str(field).split()), MAX_FIELD_CHARS)
        self.reason = _cap(" ".join(str(reason).split()), MAX_REASON_CHARS)
        self.more = [_cap(" ".join(str(m).split()), MAX_FIELD_CHARS + MAX_REASON_CHARS) for m in more]
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
