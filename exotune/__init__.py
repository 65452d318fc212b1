"""exotune — robust stability analysis and tuning of strength-amplification exoskeletons.

Implements the "double compliance shaping" method of Thomas, Coholich & Sentis (paper §IV) and
the product contract in SPEC.md. Importing the package is deliberately cheap: submodules
(numerics, plotting, the CLI) are imported only when used.
"""

from __future__ import annotations

from .version import __version__

__all__ = ["__version__"]
