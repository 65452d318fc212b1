"""exotune.jsonio.write_outputs: the outputs of one run (identify, excite, optimize) written all or
none — a failure while staging changes nothing and leaves no directory made for it; a failure
while publishing puts back what the earlier renames replaced."""

from __future__ import annotations

import errno
import os

import pytest

from exotune.errors import ConfigError
from exotune.jsonio import write_outputs


def test_files_and_a_directory_are_written_and_replace_what_was_there(tmp_path):
    a, d = tmp_path / "a.yaml", tmp_path / "plots"
    a.write_text("old")
    d.mkdir()
    (d / "keep.txt").write_text("kept")
    (d / "x.png").write_bytes(b"old png")
    write_outputs({a: "new"}, {d: {"x.png": b"png", "y.csv": "1,2\n"}})
    assert a.read_text() == "new" and (d / "x.png").read_bytes() == b"png" and (d / "y.csv").read_text() == "1,2\n"
    assert sorted(os.listdir(d)) == ["keep.txt", "x.png", "y.csv"] and sorted(os.listdir(tmp_path)) == ["a.yaml", "plots"]


def test_a_failing_rename_puts_back_what_the_earlier_ones_replaced(tmp_path, monkeypatch):
    """The second rename fails: the first file gets its old content back, the directory made for
    the plots is removed, nothing else is left."""
    a, b, d = tmp_path / "a.yaml", tmp_path / "b.csv", tmp_path / "new" / "plots"
    a.write_text("old a")
    real = os.replace

    def replace(src, dst):
        if os.fspath(dst) == os.fspath(b):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), os.fspath(dst))
        real(src, dst)

    monkeypatch.setattr(os, "replace", replace)
    with pytest.raises(ConfigError) as e:
        write_outputs({a: "new a", b: "new b"}, {d: {"x.png": b"png"}})
    assert str(e.value) == f"{b}: cannot write output: No space left on device"
    monkeypatch.setattr(os, "replace", real)
    assert a.read_text() == "old a" and sorted(os.listdir(tmp_path)) == ["a.yaml"]
    write_outputs({a: "new a", b: "new b"}, {d: {"x.png": b"png"}})
    assert a.read_text() == "new a" and b.read_text() == "new b" and (d / "x.png").read_bytes() == b"png"


def test_a_failing_stage_changes_nothing(tmp_path, monkeypatch):
    """A full disk while staging the directory's second file: the file staged before it is not
    published, the parents made for the outputs are removed."""
    import exotune.jsonio as jsonio

    real, calls = jsonio.write_atomic, []

    def write(path, data):
        calls.append(path)
        if len(calls) > 2:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), os.fspath(path))
        real(path, data)

    monkeypatch.setattr(jsonio, "write_atomic", write)
    a, d = tmp_path / "deep" / "a.yaml", tmp_path / "deeper" / "plots"
    with pytest.raises(ConfigError) as e:
        write_outputs({a: "a"}, {d: {"x.png": b"1", "y.png": b"2"}})
    assert str(e.value).startswith(f"{d}: cannot write output: ")
    assert os.listdir(tmp_path) == []
