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
        When ``directory`` is empty, when one of the files already exists (nothing is written
        then) or when the directory or a file cannot be written (nothing is left then: the files
        and the directories made are removed again).

    Examples
    --------
    >>> import tempfile
    >>> [p.name for p in write_templates(tempfile.mkdtemp())]
    ['design.yaml', 'sweep.yaml', 'optimize.yaml']
    """
    if not os.fspath(directory):  # Path("") is the current directory, and the next step read "/design.yaml"
        raise ConfigError("directory", "an empty path (give a directory; '.' for the current one)")
    d = Path(directory)
    if d.exists() and not d.is_dir():
        raise ConfigError(str(d), "exists and is not a directory")
    taken = [n for n in TEMPLATES if (d / n).exists() or (d / n).is_symlink()]
    if taken:
        raise ConfigError(str(d / taken[0]), "already exists; exotune init never overwrites a file (choose another directory)")
    texts = {n: template_text(n) for n in TEMPLATES}
    missing = []  # the directories made here, deepest first: removed again when a write fails
    p = d.absolute()
    while not os.path.lexists(p) and p != p.parent:
        missing.append(p)
        p = p.parent
    tmps, written = [d / f".{n}.tmp-{os.getpid()}" for n in TEMPLATES], []
    try:
        d.mkdir(parents=True, exist_ok=True)
        for n, tmp in zip(TEMPLATES, tmps):  # every file complete before any is in place
            tmp.write_text(texts[n], encoding="utf-8")
        for n, tmp in zip(TEMPLATES, tmps):
            os.replace(tmp, d / n)
            written.append(d / n)
    except OSError as e:  # all or none: a full disk on the second file leaves no first one behind
        for q in tmps + written:
            try:
                q.unlink()
            except OSError:
                pass
        for q in missing:
            try:
                q.rmdir()
            except OSError:
                break
        raise ConfigError(str(d), f"cannot write output: {e.strerror or e}") from None
    return written
