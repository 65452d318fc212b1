"""exotune — robust stability analysis and tuning of strength-amplification exoskeletons.

Implements the "double compliance shaping" method of Thomas, Coholich & Sentis (paper §IV) and
the product contract in SPEC.md. Importing the package is deliberately cheap: submodules
(numerics, plotting, the CLI) are imported only when used.
"""

from __future__ import annotations

try:  # the installed distribution is the source of truth (pyproject.toml)
    from importlib.metadata import PackageNotFoundError, version as _dist_version

    try:
        __version__ = _dist_version("exotune")
    except PackageNotFoundError:  # running from a source tree that is not installed
        __version__ = "0.6.0"
except ImportError:  # pragma: no cover - importlib.metadata is stdlib on every supported Python
    __version__ = "0.6.0"

__all__ = ["__version__"]
