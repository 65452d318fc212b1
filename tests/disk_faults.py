"""A full disk for the tests of "nothing half-written": every atomic write of exotune goes
through :func:`exotune.jsonio.write_atomic`, so failing it from the n-th call on is a disk that
fills up in the middle of a run."""

from __future__ import annotations

import errno
import os


def full_disk_after(monkeypatch, after: int) -> list:
    """Make the ``after``-th and later atomic writes fail with ENOSPC; returns the list of the
    paths written (or tried), in order."""
    import exotune.jsonio as jsonio

    real, calls = jsonio.write_atomic, []

    def write(path, data):
        calls.append(path)
        if len(calls) > after:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), os.fspath(path))
        real(path, data)

    monkeypatch.setattr(jsonio, "write_atomic", write)
    return calls
