"""JSON conventions of exotune's outputs (docs/cli.md) and atomic file writes.

* :func:`to_jsonable` turns results into plain JSON types: numpy scalars/arrays become Python
  numbers/lists, dataclasses become objects (their fields), tuples become lists, complex numbers
  become ``{"re": …, "im": …}``. **Infinite floats are written as the strings ``"inf"`` /
  ``"-inf"``; NaN (an undefined quantity) is written as ``null``.** Every other float is written
  with full (round-trip) precision.
* :func:`write_atomic` writes a file through a temporary file in the same directory followed by
  :func:`os.replace`, so a reader never sees a half-written output (docs/sweep-spec.md, docs/cli.md: "nothing
  half-written").
* :func:`write_outputs` writes the outputs of one run — files, directories of files, or what a
  producer writes into a directory — all or none: everything is staged next to its destination
  and renamed into place only when all of it is written (a failing run leaves nothing behind).
* :func:`check_outputs` refuses, before any work, an output that is (the same file as) an
  input, a file output that names a directory, or an output that cannot be written (permission
  bits, and a file created and removed again where it will go).
* :func:`dumps` is the JSON text of every ``--json`` output.
"""

from __future__ import annotations

import dataclasses
import enum
import errno
import fnmatch
import json
import math
import os
import re
import shutil
import tempfile
from pathlib import PurePath
from typing import Any

import numpy as np

__all__ = ["to_jsonable", "dumps", "write_atomic", "write_outputs", "check_outputs"]


def _float(x: float):
    if math.isnan(x):
        return None
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return float(x)


def to_jsonable(obj: Any) -> Any:
    """Recursively convert ``obj`` to JSON-ready Python objects (see the module docstring).

    Raises :class:`TypeError` for objects it does not know how to represent faithfully.

    Parameters
    ----------
    obj : Any
        The object: None, bool, str, numbers (numpy included; complex as ``{re, im}``), arrays,
        mappings, sequences, sets, dataclasses, enums or paths.

    Returns
    -------
    Any
        The JSON-ready object (non-finite floats as the module docstring says).

    Raises
    ------
    TypeError
        For an object of another type.
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
    On any error the temporary file is removed and ``path`` is left untouched. A symbolic link is
    followed (its target is replaced, the link kept); an existing path that is not a regular file
    (a device, a FIFO, a socket) is refused, never replaced.

    Parameters
    ----------
    path : str or os.PathLike
        The destination file.
    data : str or bytes
        The content.

    Raises
    ------
    OSError
        When the file cannot be written, or ``path`` exists and is not a regular file (naming
        ``path``).
    """
    path = os.fspath(path)
    if os.path.islink(path):  # replace the link's target, keep the link
        path = os.path.realpath(path)
    if os.path.exists(path) and not os.path.isfile(path):
        # a device, FIFO or socket: replacing it would destroy it (e.g. ``-o /dev/null`` as root)
        raise OSError(errno.EEXIST, "exists and is not a regular file (a device, FIFO or socket); outputs are "
                                    "written by replacing a file", path)
    if isinstance(data, str):
        data = data.encode("utf-8")
    parent = os.path.dirname(os.path.abspath(path))
    try:
        created = _make_parents(parent)
    except OSError as e:  # name the destination, not the directory that could not be made
        raise type(e)(e.errno, e.strerror, path) from None
    try:
        fd, tmp = tempfile.mkstemp(prefix=".tmp-" + os.path.basename(path) + ".", dir=parent)
    except OSError as e:  # name the destination, not the temporary file
        _remove_dirs(created)
        raise type(e)(e.errno, e.strerror, path) from None
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
        _remove_dirs(created)
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
        Strict JSON (no NaN/Infinity literals), indented by 2, non-ASCII characters kept — but for
        the control characters a terminal could act on (DEL, the C1 controls, the bidirectional
        overrides; ``json`` escapes the C0 ones), written as ``\\uNNNN`` escapes: the same JSON
        value, safe to print.

    References
    ----------
    docs/cli.md#json-output.
    """
    text = json.dumps(to_jsonable(obj), indent=2, ensure_ascii=False, allow_nan=False)
    return _JSON_CONTROL.sub(lambda m: f"\\u{ord(m.group(0)):04x}", text)


#: the characters ``json.dumps(ensure_ascii=False)`` leaves raw that a terminal could act on (they
#: occur only inside JSON strings, where a ``\uNNNN`` escape is the same character)
_JSON_CONTROL = re.compile(r"[\x7f-\x9f\u061c\u200e\u200f\u202a-\u202e\u2066-\u2069]")


def _umask() -> int:
    umask = os.umask(0)
    os.umask(umask)
    return umask


def _make_parents(path: str) -> list[str]:
    """Create the missing directories of ``path`` (itself included); return those created,
    deepest first (to remove them again when a write fails). When one cannot be made (a path
    too long for the file system, no permission), those made before it are removed again."""
    missing = []
    cur = os.path.abspath(path)
    while not os.path.isdir(cur):
        missing.append(cur)
        parent = os.path.dirname(cur)
        if parent == cur:
            break
        cur = parent
    made: list[str] = []
    try:
        for d in reversed(missing):
            try:
                os.mkdir(d)
            except FileExistsError:  # made meanwhile by another process: not ours to remove
                if os.path.isdir(d):
                    continue
                raise
            made.insert(0, d)
    except BaseException:
        _remove_dirs(made)
        raise
    return made


def _remove_dirs(dirs: list[str]) -> None:
    """Remove the directories ``dirs`` (deepest first) made by a failed write, when empty."""
    for d in dirs:
        try:
            os.rmdir(d)
        except OSError:
            pass


def _cannot_write(dest: str, e: OSError):
    from .errors import ConfigError

    return ConfigError(dest, f"cannot write output: {e.strerror or e}")


def write_outputs(files=None, dirs=None) -> None:
    """Write every output of one run, all or none: files and directories in several places (a
    controller and its Pareto front, a plant file, its frequency responses and its plots).

    Every file is first written completely (:func:`write_atomic`) into a staging directory
    beside its destination (inside an existing output directory: same file system, so that
    publishing is a rename, and its parent may be read-only); only when every output is staged
    are they renamed into place (a new directory in one rename). A failure while staging (a full
    disk, an unwritable directory, a producer that raises) leaves every destination as it was
    and removes the directories it made; a failure while renaming puts back what the earlier
    renames replaced.

    Parameters
    ----------
    files : dict, optional
        Destination file → content (str or bytes). A symbolic link is followed (its target
        replaced), as :func:`exotune.jsonio.write_atomic` does.
    dirs : dict, optional
        Destination directory → its content: {relative path → content} (sub-directories
        allowed), or a function called with an empty directory to write into (plots written by
        a library). The directory and its missing parents are created; files already there and
        not written are kept.

    Raises
    ------
    ConfigError
        ``<path>: cannot write output: <reason>``, naming the destination that failed; then no
        output is written or changed. An exception of a producer other than OSError is raised
        as it is, after the same clean-up.

    References
    ----------
    docs/cli.md#outputs.
    """
    items: list[tuple[str, str, str, str]] = []  # (kind, staged path, target, destination as given)
    stages: list[str] = []  # staging directories, removed at the end
    created: list[str] = []  # directories made here, deepest first
    published: list[tuple[str, str | None]] = []  # (target, what it replaced: a kept link, "new", "new dir")
    try:
        for dest, data in (files or {}).items():
            dest = os.fspath(dest)
            target = os.path.realpath(dest) if os.path.islink(dest) else dest
            try:
                parent = os.path.dirname(os.path.abspath(target))
                created = _make_parents(parent) + created
                stages.append(tempfile.mkdtemp(prefix=".exotune-stage-", dir=parent))
                staged = os.path.join(stages[-1], os.path.basename(target))
                write_atomic(staged, data)
            except OSError as e:
                raise _cannot_write(dest, e) from None
            items.append(("file", staged, target, dest))
        for dest, content in (dirs or {}).items():
            dest = os.fspath(dest)
            try:
                parent = os.path.dirname(os.path.abspath(dest))
                created = _make_parents(parent) + created
                stages.append(tempfile.mkdtemp(prefix=".exotune-stage-", dir=dest if os.path.isdir(dest) else parent))
                staged = os.path.join(stages[-1], "out")
                os.mkdir(staged)  # the usual permissions: renamed into place when the directory is new
                if callable(content):
                    content(staged)
                else:
                    for name, data in content.items():
                        write_atomic(os.path.join(staged, name), data)
            except OSError as e:
                raise _cannot_write(dest, e) from None
            items.append(("dir", staged, dest, dest))
        for kind, staged, target, dest in items:
            try:
                if kind == "dir" and not os.path.lexists(target):
                    os.rename(staged, target)
                    published.append((target, "new dir"))
                    continue
                for src, dst in ([(staged, target)] if kind == "file" else _tree_pairs(staged, target, published)):
                    keep = "new"
                    if os.path.isfile(dst):  # to put it back should a later rename fail
                        keep = os.path.join(os.path.dirname(staged), f".previous-{len(published)}")
                        try:
                            os.link(dst, keep)
                        except OSError:
                            keep = None
                    os.replace(src, dst)
                    published.append((dst, keep))
            except OSError as e:
                raise _cannot_write(dest, e) from None
    except BaseException:
        for target, keep in reversed(published):
            try:
                if keep == "new dir":
                    shutil.rmtree(target)
                elif keep == "new":
                    os.unlink(target)
                elif keep is not None:
                    os.replace(keep, target)
            except OSError:
                pass
        for d in stages:
            shutil.rmtree(d, ignore_errors=True)
        stages = []
        _remove_dirs(created)
        raise
    finally:
        for d in stages:
            shutil.rmtree(d, ignore_errors=True)


def _tree_pairs(staged: str, target: str, published: list):
    """(staged file, destination file) of every file under ``staged``, the sub-directories
    missing in ``target`` made on the way (recorded in ``published`` as new, for a rollback)."""
    for root, subdirs, names in os.walk(staged):
        rel = os.path.relpath(root, staged)
        into = target if rel == "." else os.path.join(target, rel)
        for sd in sorted(subdirs):
            d = os.path.join(into, sd)
            if not os.path.isdir(d):
                os.mkdir(d)
                published.append((d, "new dir"))
        for n in sorted(names):
            yield os.path.join(root, n), os.path.join(into, n)


def _same(a: str, b: str) -> bool:
    """Whether the paths ``a`` and ``b`` name the same file (same inode when both exist)."""
    try:
        if os.path.exists(a) and os.path.exists(b):
            return os.path.samefile(a, b)
    except OSError:
        pass
    return os.path.realpath(a) == os.path.realpath(b)


TMP_NAME_EXTRA = 14  # ".tmp-" + "." + mkstemp's 8 random characters: what a temporary name adds
#: what staging adds to an output's path: "/.exotune-stage-" + 8 random characters, and the temporary name
STAGE_PATH_EXTRA = 24 + TMP_NAME_EXTRA


def _check_parent(label: str, path: str) -> None:
    """The nearest existing ancestor of ``path`` (``path`` itself when it is an existing
    directory) must be a writable directory."""
    from .errors import ConfigError

    cur = os.path.abspath(path) if os.path.isdir(path) else os.path.dirname(os.path.abspath(path))
    while not os.path.lexists(cur):
        cur = os.path.dirname(cur)
    if not os.path.isdir(cur):
        raise ConfigError(path, f"cannot write output ({label}): {cur} is not a directory")
    if not os.access(cur, os.W_OK | os.X_OK):
        raise ConfigError(path, f"cannot write output ({label}): no permission to write into {cur}")
    try:  # a file system that refuses new files passes the permission bits (/proc, a read-only mount)
        fd, probe = tempfile.mkstemp(prefix=".exotune-probe-", dir=cur)
        os.close(fd)
        os.unlink(probe)
    except OSError as e:
        raise ConfigError(path, f"cannot write output ({label}): {e.strerror or e}") from None
    try:
        name_max = os.pathconf(cur, "PC_NAME_MAX")
    except (OSError, ValueError):
        name_max = 255
    try:
        path_max = os.pathconf(cur, "PC_PATH_MAX")
    except (OSError, ValueError):
        path_max = 4096
    size = len(os.fsencode(os.path.abspath(path)))
    if size + STAGE_PATH_EXTRA >= path_max:  # PATH_MAX counts the terminating NUL
        raise ConfigError(label.replace("`", ""), f"the path is too long for the file system ({size} bytes; at most "
                                                  f"{path_max - 1 - STAGE_PATH_EXTRA})")
    parts = [q for q in os.path.abspath(path).split(os.sep) if q]
    for k, part in enumerate(parts):
        # a file is written through a temporary sibling named ".tmp-<name>.<8 characters>"
        extra = TMP_NAME_EXTRA if k == len(parts) - 1 else 0
        if len(os.fsencode(part)) + extra > name_max:
            short = part if len(part) <= 40 else part[:20] + "…" + part[-12:]
            raise ConfigError(label.replace("`", ""), f"the name {short!r} is too long for the file system "
                                                      f"({len(os.fsencode(part))} bytes; at most {name_max - extra})")


def _refuse_inputs_inside(label: str, directory: str, inputs: list[str], names) -> None:
    """ConfigError when an input lies in ``directory`` under a name the command writes there."""
    from .errors import ConfigError

    real = os.path.realpath(directory)
    for inp in inputs:
        rel = os.path.relpath(os.path.realpath(inp), real)
        if rel.startswith(os.pardir) or os.path.isabs(rel):
            continue
        hit = next((pat for pat in names if fnmatch.fnmatch(rel, pat)), None)
        if hit is not None:
            raise ConfigError(directory, f"the {label} output directory would overwrite the input {inp} (it writes "
                                         f"{hit} files there); choose another directory or move the input")


def _inside(path: str, directory: str) -> bool:
    p, d = os.path.realpath(path), os.path.realpath(directory)
    return p == d or p.startswith(d.rstrip(os.sep) + os.sep)


def check_outputs(inputs=(), outputs=None, out_dirs=None, protected_dirs=(), dir_names=None) -> None:
    """Refuse, before any work, outputs that cannot be written or would overwrite an input.

    Parameters
    ----------
    inputs : sequence of str or os.PathLike
        The files (or directories) the command reads; other items (``None``, a mapping, a loaded
        object) are not files and are ignored.
    outputs : dict, optional
        Label → path of a *file* to write (``None``: not given). The API labels its outputs by
        keyword in backticks (``"`out`"``, ``"`pareto_csv`"``): the command line names the option
        that feeds the keyword instead (``-o``, ``--pareto``).
    out_dirs : dict, optional
        Label (``"`plots`"``) → path of a *directory* to write into (``None``: not given).
    protected_dirs : sequence of str or os.PathLike
        Directories no output may be in (a sweep's ``chunks``).
    dir_names : dict, optional
        Label of a directory output → the names (glob patterns, relative to the directory) of the
        files the command writes there: an input with such a name in that directory is refused.

    Raises
    ------
    exotune.errors.ConfigError
        ``<path>: …`` (the output's label in the reason) when an output is (or is the same file as,
        by inode) an input or another output, when a file output names a directory (an
        existing one, or a path ending in ``/``) or exists and is not a regular file (a device, a
        FIFO: outputs replace files), when a directory output is an existing file or would write
        over an input (``dir_names``), or when the nearest existing ancestor of an output is not a
        writable directory.

    References
    ----------
    docs/cli.md#outputs.
    """
    from .errors import ConfigError

    ins = [os.fspath(p) for p in inputs if isinstance(p, (str, os.PathLike))]  # a mapping or object: no file
    seen: list[tuple[str, str]] = []
    items = [(lbl, os.fspath(p), False) for lbl, p in (outputs or {}).items() if p is not None]
    items += [(lbl, os.fspath(p), True) for lbl, p in (out_dirs or {}).items() if p is not None]
    for label, path, is_dir in items:
        if not path:
            raise ConfigError(label.replace("`", ""), "an empty path")
        for inp in ins:
            if _same(path, inp):
                raise ConfigError(path, f"the {label} output is the same file as the input {inp}; refusing to "
                                        f"overwrite an input (choose another {label} path)")
        for other_label, other in seen:
            if _same(path, other):
                raise ConfigError(path, f"the {label} output is the same path as the {other_label} output")
        for d in protected_dirs:
            if _inside(path, os.fspath(d)):
                raise ConfigError(path, f"the {label} output is inside {os.fspath(d)}, which holds inputs; "
                                        "choose another path")
        if is_dir:
            if os.path.lexists(path) and not os.path.isdir(path):
                raise ConfigError(path, f"exists and is not a directory ({label} needs a directory)")
            _refuse_inputs_inside(label, path, ins, (dir_names or {}).get(label, ()))
        elif path.endswith(("/", os.sep)) or os.path.isdir(path):
            raise ConfigError(path, f"is a directory; {label} needs a file path")
        elif os.path.exists(path) and not os.path.isfile(path):
            raise ConfigError(path, f"exists and is not a regular file (a device, FIFO or socket); the {label} "
                                    "output is written by replacing a file, so give a file path")
        _check_parent(label, path)
        seen.append((label, path))
