"""Exceptions raised for bad user input (SPEC §8: "one clear message naming the field and the
reason").

:class:`ConfigError` carries the offending field as a dotted path into the input file
(``design.amplification``, ``humans[0].inertia``, ``implementation.gv_filter.cutoff_hz``) or, for
file-level problems (unreadable file, invalid YAML), the file name. ``str(err)`` is
``"<field>: <reason>"``, which the CLI prints as ``exotune: error: <field>: <reason>``.
"""

from __future__ import annotations

__all__ = ["ExotuneError", "ConfigError", "RunFailed"]


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
    Exit code 2."""

    def __init__(self, field: str, reason: str):
        self.field = str(field)
        # keep every message on one line (the CLI contract is a one-line error)
        self.reason = " ".join(str(reason).split())
        super().__init__(self.field, self.reason)

    def __str__(self) -> str:
        return f"{self.field}: {self.reason}" if self.field else self.reason

    def __reduce__(self):  # picklable across process pools (sweeps)
        return (type(self), (self.field, self.reason))
