"""JSON conventions of exotune's outputs (SPEC §8) and atomic file writes.

* :func:`to_jsonable` turns results into plain JSON types: numpy scalars/arrays become Python
  numbers/lists, dataclasses become objects (their fields), tuples become lists, complex numbers
  become ``{"re": …, "im": …}``. **Infinite floats are written as the strings ``"inf"`` /
  ``"-inf"``; NaN (an undefined quantity) is written as ``null``.** Every other float is written
  with full (round-trip) precision.
* :func:`write_atomic` writes a file through a temporary file in the same directory followed by
  :func:`os.replace`, so a reader never sees a half-written output (SPEC §6, §8: "nothing
  half-written").
* :func:`write_files` writes several outputs (each atomically) under one directory, and
  :func:`staged_dir` lets a producer write into a temporary directory whose files are copied to
  the destination only when the producer succeeds (a failing run leaves nothing behind).
* :func:`dumps` is the JSON text of every ``--json`` output.
"""

from __future__ import annotations

import dataclasses
import enum
import json
import math
import os
import shutil
import tempfile
from pathlib import PurePath
from typing import Any

import numpy as np

__all__ = ["to_jsonable", "dumps", "write_atomic", "write_files", "staged_dir"]


def _float(x: float):
    if math.isnan(x):
        return None
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return float(x)


def to_jsonable(obj: Any) -> Any:
    """Recursively convert ``obj`` to JSON-ready Python objects (see the module docstring).

    Raises :class:`TypeError` for objects it does not know how to represent faithfully.
    """
    if obj is None or isinstance(obj, (bool, str)):
        return obj
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        return _float(float(obj))
    if isinstance(obj, (complex, np.complexfloating)):
        return {"re": _float(float(obj.real)), "im": _float(float(obj.imag))}
    if isinstance(obj, np.ndarray):
        if obj.dtype == object:
            return [to_jsonable(x) for x in obj.tolist()]
        return to_jsonable(obj.tolist())
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, (set, frozenset)):
        return [to_jsonable(v) for v in sorted(obj, key=repr)]
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: to_jsonable(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, enum.Enum):
        return to_jsonable(obj.value)
    if isinstance(obj, PurePath):
        return str(obj)
    raise TypeError(f"cannot convert object of type {type(obj).__name__} to JSON")


def write_atomic(path, data: str | bytes) -> None:
    """Write ``data`` (text is UTF-8 encoded) to ``path`` atomically.

    The data go to a temporary file in the destination directory, are flushed and fsync'ed, and
    the file is moved into place with :func:`os.replace`. Missing parent directories are created.
    On any error the temporary file is removed and ``path`` is left untouched.
    """
    path = os.fspath(path)
    if isinstance(data, str):
        data = data.encode("utf-8")
    parent = os.path.dirname(os.path.abspath(path))
    os.makedirs(parent, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=".tmp-" + os.path.basename(path) + ".", dir=parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        # mkstemp creates 0600 files; give the output the usual permissions (0666 & ~umask)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException as e:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(e, OSError) and e.errno is not None:
            # name the destination, not the temporary file
            raise type(e)(e.errno, e.strerror, path) from None
        raise


def dumps(obj) -> str:
    """The JSON text of ``obj`` as every ``--json`` output prints it.

    Parameters
    ----------
    obj : object
        A result (converted by :func:`to_jsonable`).

    Returns
    -------
    str
        Strict JSON (no NaN/Infinity literals), indented by 2, non-ASCII characters kept.

    References
    ----------
    docs/cli.md#json-output.
    """
    return json.dumps(to_jsonable(obj), indent=2, ensure_ascii=False, allow_nan=False)


def write_files(dest, files: dict[str, bytes]) -> None:
    """Write ``files`` (relative path → content) under the directory ``dest``, each atomically.

    Parameters
    ----------
    dest : str or os.PathLike
        Destination directory (created with its missing parents).
    files : dict
        Relative path → bytes (or text).

    Raises
    ------
    exotune.errors.ConfigError
        ``<dest>: cannot write output: <reason>`` when a file cannot be written.

    References
    ----------
    docs/cli.md#outputs.
    """
    from .errors import ConfigError

    try:
        for rel, data in files.items():
            write_atomic(os.path.join(dest, rel), data)
    except OSError as e:
        raise ConfigError(dest, f"cannot write output: {e.strerror or e}") from None


def staged_dir(dest, produce) -> None:
    """Run ``produce(tmpdir)``; only if it succeeds, copy what it wrote into ``dest``.

    Parameters
    ----------
    dest : str or os.PathLike
        Destination directory. A failing producer leaves it untouched (not even created).
    produce : callable
        Called with the path of a fresh temporary directory, which is removed afterwards.

    References
    ----------
    docs/cli.md#outputs.
    """
    tmp = tempfile.mkdtemp(prefix="exotune-stage-")
    try:
        produce(tmp)
        files = {}
        for root, _dirs, names in os.walk(tmp):
            for nm in names:
                full = os.path.join(root, nm)
                with open(full, "rb") as fh:
                    files[os.path.relpath(full, tmp)] = fh.read()
        write_files(dest, files)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
