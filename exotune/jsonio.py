"""JSON conventions of exotune's outputs (SPEC §8) and atomic file writes.

* :func:`to_jsonable` turns results into plain JSON types: numpy scalars/arrays become Python
  numbers/lists, dataclasses become objects (their fields), tuples become lists, complex numbers
  become ``{"re": …, "im": …}``. **Infinite floats are written as the strings ``"inf"`` /
  ``"-inf"``; NaN (an undefined quantity) is written as ``null``.** Every other float is written
  with full (round-trip) precision.
* :func:`write_atomic` writes a file through a temporary file in the same directory followed by
  :func:`os.replace`, so a reader never sees a half-written output (SPEC §6, §8: "nothing
  half-written").
"""

from __future__ import annotations

import dataclasses
import enum
import math
import os
import tempfile
from pathlib import PurePath
from typing import Any

import numpy as np

__all__ = ["to_jsonable", "write_atomic"]


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
