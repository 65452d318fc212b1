"""Helpers of the sweep-directory tests: a private copy of a finished sweep, an edit of its
manifest, the path of a chunk (shared by test_integrity and the hostile-input tests)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path


def copy_sweep(swept, tmp_path: Path, name: str = "d") -> Path:
    """A copy of the finished sweep directory ``swept[1]`` under ``tmp_path/name``."""
    d = tmp_path / name
    shutil.copytree(swept[1], d)
    return d


def edit_manifest(d: Path, fn) -> None:
    """Apply ``fn`` to the manifest of the sweep directory ``d`` and write it back."""
    m = json.loads((d / "manifest.json").read_text())
    fn(m)
    (d / "manifest.json").write_text(json.dumps(m))


def chunk_path(d: Path, i: int) -> Path:
    """The Parquet file of chunk ``i`` of the sweep directory ``d``."""
    return d / "chunks" / f"part-{i:06d}.parquet"
