"""The installed version of exotune (``pyproject.toml`` is the source of truth)."""

from __future__ import annotations

try:
    from importlib.metadata import PackageNotFoundError, version as _dist_version

    try:
        __version__ = _dist_version("exotune")
    except PackageNotFoundError:  # running from a source tree that is not installed
        __version__ = "0.7.0"
except ImportError:  # pragma: no cover - importlib.metadata is stdlib on every supported Python
    __version__ = "0.7.0"

__all__ = ["__version__"]
