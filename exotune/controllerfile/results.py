"""Typed results of the controller-file layer: the exported file and its certificate.

References
----------
docs/api.md#typed-results; docs/controller-file.md (the file and its certification).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..errors import printable
from ..record import Record, Result
from .model import as_controller_file

__all__ = ["ExportedController", "Certificate", "GeneratedC"]


@dataclass(frozen=True)
class ExportedController(Record):
    """An exported controller file (docs/controller-file.md): its document (``to_dict()``), its
    sample rate [Hz] and where it was written (``path``; None for a document not written)."""

    sample_rate_hz: float | None = None
    path: str | None = None

    @classmethod
    def from_document(cls, doc, path=None) -> "ExportedController":
        """The typed view of a controller-file document ``doc`` written to ``path``.

        Parameters
        ----------
        doc : dict or ControllerFile
            The controller file (its mapping is kept as the record).
        path : str or os.PathLike, optional
            Where it was written; None for a document kept in memory.

        Returns
        -------
        ExportedController
            The view (its sample rate [Hz] read from ``doc``).
        """
        cf = as_controller_file(doc)
        return cls(doc if isinstance(doc, dict) else cf.to_dict(), float(cf.sample_rate_hz),
                   None if path is None else str(path))

    def to_text(self) -> str:
        """The file's YAML text.

        Returns
        -------
        str
            The YAML text.
        """
        import yaml

        return yaml.safe_dump(self.to_dict(), sort_keys=False, allow_unicode=True)

    def summary(self) -> str:
        """The one line ``exotune export`` prints: where the file went, its rate, filters,
        sampled-data verdicts and latency margin (:func:`exotune.text.export.format_export`).

        Returns
        -------
        str
            The line.
        """
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
        """The typed view of a certification report ``rec``.

        Parameters
        ----------
        rec : dict
            The report (``certified``, ``problems``, …).

        Returns
        -------
        Certificate
            The view: ``certified`` and ``reasons`` (the report's problems).
        """
        return cls(rec, bool(rec["certified"]), tuple(str(r) for r in rec.get("problems") or ()))

    def to_text(self) -> str:
        """The text report of ``exotune certify``.

        Returns
        -------
        str
            The report.
        """
        from ..text.certify import format_certify

        return format_certify(self.to_dict())


@dataclass(frozen=True)
class GeneratedC(Result):
    """``exotune codegen``: the C99 port of a controller file written into ``directory``
    (``files``), its controllers (1 + gain-schedule entries) and second-order sections, the
    compiler flags it is checked with, the sha256 of the controller file's bytes and its
    certification (``certified``, ``reasons``), which the code carries
    (docs/deploying.md#traceability)."""

    directory: Path
    files: tuple[str, ...]
    controllers: int
    sections: int
    flags: str
    sha256: str = ""
    certified: bool = False
    reasons: tuple[str, ...] = ()

    def to_dict(self) -> dict:
        """The ``exotune codegen --json`` object.

        Returns
        -------
        dict
            ``directory``, ``files``, ``controllers``, ``sections``, ``compile_flags``,
            ``source_sha256``, ``certified`` and ``reasons``.
        """
        return {"directory": str(self.directory), "files": list(self.files), "controllers": self.controllers,
                "sections": self.sections, "compile_flags": self.flags, "source_sha256": self.sha256,
                "certified": self.certified, "reasons": list(self.reasons)}

    def to_text(self) -> str:
        """The lines ``exotune codegen`` prints: what was written and how to check it on the target.

        Returns
        -------
        str
            The two or three lines.
        """
        d = self.directory
        text = (f"wrote {', '.join(self.files)} to {d} ({self.controllers} controller"
                f"{'' if self.controllers == 1 else 's'}, {self.sections} sections)\n"
                f"check on the target: cc {self.flags} -o exotune_golden_test {d / self.files[1]} "
                f"{d / self.files[2]} -lm && ./exotune_golden_test\n"
                f"source sha256 {self.sha256}: "
                + ("certified (exotune certify passed)" if self.certified else
                   "NOT CERTIFIED (--allow-uncertified; the code says so): it must not drive a joint"))
        return printable(text, keep="\n")  # a directory name cannot drive the terminal
