"""Typed results of the controller-file layer: the exported file and its certificate.

References
----------
docs/api.md#typed-results; docs/controller-file.md (the file and its certification).
"""

from __future__ import annotations

from dataclasses import dataclass

from ..record import Record

__all__ = ["ExportedController", "Certificate"]


@dataclass(frozen=True)
class ExportedController(Record):
    """An exported controller file (docs/controller-file.md): its document (``to_dict()``), its
    sample rate [Hz] and where it was written (``path``; None for a document not written)."""

    sample_rate_hz: float | None = None
    path: str | None = None

    @classmethod
    def from_document(cls, doc: dict, path=None) -> "ExportedController":
        """The typed view of a controller-file document ``doc`` written to ``path``."""
        return cls(doc, float(doc["sample_rate_hz"]["value"]), None if path is None else str(path))

    def to_text(self) -> str:
        """The file's YAML text."""
        import yaml

        return yaml.safe_dump(self.to_dict(), sort_keys=False, allow_unicode=True)

    def summary(self) -> str:
        """The one line ``exotune export`` prints: where the file went, its rate, filters,
        sampled-data verdicts and latency margin (:func:`exotune.text.export.format_export`)."""
        from ..text.export import format_export

        return format_export(self.to_dict(), self.path)


@dataclass(frozen=True)
class Certificate(Record):
    """``exotune certify``: the exact sampled-data verdicts of a controller file; ``certified`` is
    true only when every check passed (``reasons`` lists the ones that did not). ``to_dict()`` is
    the whole certification report (docs/controller-file.md#certification)."""

    certified: bool = False
    reasons: tuple[str, ...] = ()

    @classmethod
    def from_report(cls, rec: dict) -> "Certificate":
        """The typed view of a certification report ``rec``."""
        return cls(rec, bool(rec["certified"]), tuple(str(r) for r in rec.get("problems") or ()))

    def to_text(self) -> str:
        from ..text.certify import format_certify

        return format_certify(self.to_dict())
