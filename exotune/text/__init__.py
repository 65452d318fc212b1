"""exotune.text: text views of exotune's results — every formatter, one number formatter
(``numbers``: :func:`fmt_num`, :func:`unit_text`).

One module per command or part: ``analysis``, ``margins``, ``verdicts``, ``kyp`` (``exotune
analyze``), ``design``, ``sea``, ``certify``, ``export``, ``optimize``, ``simulate``, ``identify``,
``excite``.
"""

from ..lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        "format_report": "analysis",
        "format_design": "design",
        "format_sea": "sea",
        "format_certify": "certify",
        "format_export": "export",
        "format_optimize": "optimize",
        "format_simulation": "simulate",
        "format_certificates": "kyp",
        "format_margins": "margins",
        "format_verdicts": "verdicts",
        "excitation_text": "excite",
        "validation_text": "identify",
        "fmt_num": "numbers",
        "unit_text": "numbers",
    },
)
