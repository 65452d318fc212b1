"""MkDocs hook: keep ``mkdocs build --strict`` usable while modules move.

A ``::: exotune.x.y`` block (mkdocstrings) whose module file does not exist in the source tree is
replaced by a note instead of failing the build. Every block whose module exists is rendered
normally, so a real docstring problem still fails a strict build.
"""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
BLOCK = re.compile(r"^::: *(exotune(?:\.[A-Za-z_][A-Za-z0-9_]*)*) *$", re.MULTILINE)


def _exists(dotted: str) -> bool:
    path = ROOT.joinpath(*dotted.split("."))
    return path.with_suffix(".py").is_file() or (path / "__init__.py").is_file()


def on_page_markdown(markdown: str, **kwargs) -> str:
    def sub(m: re.Match) -> str:
        if _exists(m.group(1)):
            return m.group(0)
        return f'!!! note "Not yet available"\n    The reference of `{m.group(1)}` appears here once the module exists.'

    return BLOCK.sub(sub, markdown)
