"""The contract of a refused input, checked the same way by every hostile-input round: exit code 2,
a first stderr line ``exotune: error: <field>: …`` holding the given words, a short message, no
traceback or raw OS error, nothing on stdout, no RuntimeWarning; and the files a run left behind."""

from __future__ import annotations

import os
import warnings
from pathlib import Path

from click.testing import CliRunner

from exotune.cli import cli


def run(args):
    """``exotune ARGS`` in-process; (result, RuntimeWarnings raised)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = CliRunner().invoke(cli, [str(a) for a in args])
    return res, [w for w in caught if issubclass(w.category, RuntimeWarning)]


def refused(args, field: str, *contains: str) -> str:
    """Run ``exotune ARGS`` and check the refusal contract (module docstring); the first line."""
    res, caught = run(args)
    assert res.exit_code == 2, (res.exit_code, res.output, res.exception)
    assert res.exception is None or isinstance(res.exception, SystemExit), repr(res.exception)
    first = res.stderr.splitlines()[0]
    assert first.startswith(f"exotune: error: {field}: "), first
    for c in contains:
        assert c in first, first
    assert len(res.stderr) < 400, "an error quotes more than a short excerpt"
    assert "Traceback" not in res.output and "Errno" not in res.output and res.stdout == ""
    assert not caught, [str(w.message) for w in caught]
    return first


def files(d: Path) -> set[str]:
    """Every file and directory under ``d``, relative to it."""
    return {os.path.relpath(os.path.join(r, n), d) for r, ds, ns in os.walk(d) for n in ds + ns}
