"""exotune — robust stability analysis and tuning of strength-amplification exoskeletons.

Implements the "double compliance shaping" method of Thomas, Coholich & Sentis (paper §IV;
docs/index.md). The public API is the Python twin of each command (docs/api.md)::

    import exotune
    r = exotune.analyze("examples/paper.yaml")
    print(r)          # the text report; r.to_dict() is `exotune analyze --json`
    r.plot()

Importing the package is deliberately cheap: the numerics, python-control, plotting and the CLI
are imported only when used.
"""

from __future__ import annotations

from .version import __version__

__all__ = [
    "__version__",
    "init",
    "load_design",
    "design",
    "sea",
    "analyze",
    "sweep",
    "report",
    "optimize",
    "export",
    "certify",
    "codegen",
    "identify",
    "excite",
    "simulate",
    "ConfigError",
    "ExotuneError",
]

_API = {"init", "load_design", "design", "sea", "analyze", "sweep", "report", "optimize", "export", "certify", "codegen", "identify", "excite", "simulate"}


def __getattr__(name: str):
    if name in _API:
        from . import api

        return getattr(api, name)
    if name in ("ConfigError", "ExotuneError", "RunFailed"):
        from . import errors

        return getattr(errors, name)
    raise AttributeError(f"module 'exotune' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
