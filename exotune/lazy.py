"""Lazy package namespaces (PEP 562): the one helper behind every package ``__init__``.

A package's ``__init__`` names its public API — public name → the submodule that defines it — and
imports nothing::

    from ..lazy import attach

    __getattr__, __dir__, __all__ = attach(__name__, {"analyze_batch": "batch", ...})

``from exotune.analysis import analyze_batch`` then imports ``exotune.analysis.batch`` (and what it
imports) and nothing else: importing a package or one of its submodules never imports the sibling
submodules, so ``exotune analyze`` on a design without a sample rate loads no controller-file, C
code generator or sampled-data code (docs/architecture.md#public-names). The names a package does
not list are internal: they are imported from their module (``from exotune.analysis.counting
import RootCounter``).

A public name must not also be the name of a submodule of its package: importing the submodule
sets that attribute of the package to the module, which would then shadow the name
(``tests/test_lazy.py`` checks every package).
"""

from __future__ import annotations

import importlib
import sys
from typing import Callable, Mapping

__all__ = ["attach"]


def attach(package: str, names: Mapping[str, str]) -> tuple[Callable[[str], object], Callable[[], list], list]:
    """The module ``__getattr__``, ``__dir__`` and ``__all__`` of a package whose public names load
    on first use.

    Parameters
    ----------
    package : str
        The package's ``__name__`` (e.g. ``"exotune.analysis"``).
    names : Mapping[str, str]
        Public name → the submodule that defines it, relative to the package (``"batch"`` for
        ``exotune.analysis.batch``), in the order ``__all__`` lists them.

    Returns
    -------
    tuple
        ``(__getattr__, __dir__, __all__)``: ``__getattr__(name)`` imports the submodule of
        ``name``, caches the value as an attribute of the package and returns it (AttributeError
        for any other name); ``__dir__()`` the package's attributes and its public names, sorted;
        ``__all__`` the public names.

    Examples
    --------
    >>> import exotune.sampled as sampled
    >>> "check_design" in dir(sampled) and "check_design" in sampled.__all__
    True
    """
    table = dict(names)
    public = list(table)

    def __getattr__(name: str):
        try:
            submodule = table[name]
        except KeyError:
            raise AttributeError(f"module {package!r} has no attribute {name!r}") from None
        value = getattr(importlib.import_module(f"{package}.{submodule}"), name)
        setattr(sys.modules[package], name, value)  # the next look-up is a plain attribute
        return value

    def __dir__() -> list:
        return sorted(set(vars(sys.modules[package])) | set(public))

    return __getattr__, __dir__, public
