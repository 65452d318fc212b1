"""The base of exotune's typed results (docs/api.md#typed-results).

Every command's result is a frozen dataclass built by the layer that computes it (the analysis,
the controller file, the sweep, the optimizer, the simulation) and re-exported by
:mod:`exotune.results`. Its views are methods: :meth:`Result.to_dict` (the command's ``--json``
object), :meth:`Result.to_json`, :meth:`Result.to_text` (the text report) and, where the command
draws, ``plot(ax=None)``. The text and plot views import their layers only when called.

Two kinds of result share this base:

- a result built from typed fields (:class:`exotune.analysis.results.DesignAnalysis` and its parts)
  assembles ``to_dict`` from those fields;
- a :class:`Record` is a document that is itself the product — a controller file, a sweep
  manifest, a certificate, an optimization or simulation report — and keeps it whole next to the
  typed headline fields read from it.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from typing import Any, Mapping

__all__ = ["Result", "Record", "opt_float"]


class Result:
    """Views shared by every typed result: ``to_dict`` (defined by each result), ``to_json``,
    ``to_text`` and ``str``."""

    __slots__ = ()

    def to_dict(self) -> dict:  # pragma: no cover - every result defines it
        """The result as the command's ``--json`` object (every result defines it).

        Returns
        -------
        dict
            The JSON-ready object.
        """
        raise NotImplementedError

    def to_json(self) -> str:
        """The command's ``--json`` output (strict JSON: ``Infinity``/``NaN`` as strings).

        Returns
        -------
        str
            The JSON text.
        """
        from .jsonio import dumps

        return dumps(self.to_dict())

    def to_text(self) -> str:
        """The command's text report (the JSON object where a result has no text view).

        Returns
        -------
        str
            The report.
        """
        return self.to_json()

    def __str__(self) -> str:
        return self.to_text()


@dataclass(frozen=True)
class Record(Result):
    """A result whose product is a document: ``record`` is that document (the ``--json``
    object), the typed fields of a subclass are read from it when the result is built."""

    record: Mapping[str, Any] = field(repr=False, compare=False)

    def to_dict(self) -> dict:
        """The result as the command's ``--json`` object (a deep copy: editing it changes nothing here).

        Returns
        -------
        dict
            The record.
        """
        return copy.deepcopy(dict(self.record))


def opt_float(x) -> float | None:
    """``None`` stays ``None``; anything else becomes a Python float.

    Parameters
    ----------
    x : Any
        None or a number.

    Returns
    -------
    float or None
        The value.
    """
    return None if x is None else float(x)
