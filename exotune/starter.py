"""``exotune init``: commented starting files shipped inside the package (docs/getting-started.md).

The templates (a design file, a sweep spec and an optimize spec that refer to it) live in
``exotune/data/templates``; :func:`write_templates` copies them into a directory, never
overwriting a file that is already there.
"""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path

from .errors import ConfigError

__all__ = ["TEMPLATES", "template_text", "write_templates"]

TEMPLATES = ("design.yaml", "sweep.yaml", "optimize.yaml")


def template_text(name: str) -> str:
    """The text of one shipped template (``design.yaml``, ``sweep.yaml`` or ``optimize.yaml``).

    Parameters
    ----------
    name : str
        The template's file name.

    Returns
    -------
    str
        Its text.

    Raises
    ------
    exotune.errors.ConfigError
        When ``name`` is not a shipped template.
    """
    if name not in TEMPLATES:
        raise ConfigError("template", f"unknown template {name!r}; one of {', '.join(TEMPLATES)}")
    return resources.files("exotune").joinpath("data", "templates", name).read_text(encoding="utf-8")


def write_templates(directory) -> list[Path]:
    """Write the three templates into ``directory`` (created if missing).

    Parameters
    ----------
    directory : path
        Where to write ``design.yaml``, ``sweep.yaml`` and ``optimize.yaml``.

    Returns
    -------
    list of pathlib.Path
        The files written.

    Raises
    ------
    ConfigError
        When one of the files already exists (nothing is written then) or the directory cannot
        be created.

    Examples
    --------
    >>> import tempfile
    >>> [p.name for p in write_templates(tempfile.mkdtemp())]
    ['design.yaml', 'sweep.yaml', 'optimize.yaml']
    """
    d = Path(directory)
    if d.exists() and not d.is_dir():
        raise ConfigError(str(d), "exists and is not a directory")
    taken = [n for n in TEMPLATES if (d / n).exists() or (d / n).is_symlink()]
    if taken:
        raise ConfigError(str(d / taken[0]), "already exists; exotune init never overwrites a file (choose another directory)")
    texts = {n: template_text(n) for n in TEMPLATES}
    try:
        d.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise ConfigError(str(d), e.strerror or str(e)) from None
    written = []
    for n in TEMPLATES:
        tmp = d / f".{n}.tmp-{os.getpid()}"
        tmp.write_text(texts[n], encoding="utf-8")
        os.replace(tmp, d / n)
        written.append(d / n)
    return written
