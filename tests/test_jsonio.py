"""exotune.jsonio: JSON conventions (inf as strings, NaN as null, numpy, dataclasses) and the
all-or-nothing output writes."""

import dataclasses
import enum
import json
import os
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from exotune.errors import ConfigError
from exotune.jsonio import check_outputs, dumps, to_jsonable, write_atomic, write_outputs


class _Color(enum.Enum):
    RED = "red"


@dataclasses.dataclass
class _Point:
    x: float
    tags: tuple


def test_to_jsonable_conventions():
    obj = {
        "inf": float("inf"), "ninf": -np.inf, "nan": np.nan, "f32": np.float32(0.25), "i64": np.int64(7),
        "b": np.bool_(True), "c": 1 + 2j, "arr": np.array([[1.0, np.inf], [np.nan, 2.0]]),
        "tuple": (1, "a"), "set": {3, 1, 2}, "dc": _Point(1.5, (1, 2)), "enum": _Color.RED,
        "path": Path("a/b.yaml"), 3: None,
    }
    out = to_jsonable(obj)
    assert out == {
        "inf": "inf", "ninf": "-inf", "nan": None, "f32": 0.25, "i64": 7, "b": True,
        "c": {"re": 1.0, "im": 2.0}, "arr": [[1.0, "inf"], [None, 2.0]], "tuple": [1, "a"],
        "set": [1, 2, 3], "dc": {"x": 1.5, "tags": [1, 2]}, "enum": "red", "path": "a/b.yaml", "3": None,
    }
    assert type(out["i64"]) is int and type(out["b"]) is bool and type(out["f32"]) is float


def test_to_jsonable_refuses_unknown_objects():
    with pytest.raises(TypeError, match="object"):
        to_jsonable(object())
    with pytest.raises(TypeError, match="of type type"):
        to_jsonable(_Point)  # a dataclass type, not an instance


@given(st.floats(allow_nan=False, allow_infinity=False, width=64))
def test_finite_floats_round_trip_exactly(x):
    assert json.loads(dumps({"x": x}))["x"] == x


def test_dumps_is_strict_indented_and_keeps_unicode():
    text = dumps({"unit": "N·m/rad", "v": [np.inf]})
    assert json.loads(text) == {"unit": "N·m/rad", "v": ["inf"]}
    assert "N·m/rad" in text and "\n  " in text and "Infinity" not in text


def test_write_atomic_creates_parents_and_leaves_no_temporary(tmp_path):
    p = tmp_path / "a" / "b" / "out.json"
    write_atomic(p, "héllo")
    assert p.read_bytes() == "héllo".encode("utf-8")
    write_atomic(p, b"\x00\x01")
    assert p.read_bytes() == b"\x00\x01"
    assert sorted(os.listdir(p.parent)) == ["out.json"]
    umask = os.umask(0)
    os.umask(umask)
    assert (p.stat().st_mode & 0o777) == 0o666 & ~umask


def test_write_atomic_error_names_the_destination(tmp_path):
    d = tmp_path / "isdir"
    d.mkdir()
    (d / "x").write_text("keep")
    with pytest.raises(OSError) as ei:
        write_atomic(d, "data")  # a directory cannot be replaced by a file
    assert str(d) in str(ei.value)
    assert (d / "x").read_text() == "keep" and sorted(os.listdir(tmp_path)) == ["isdir"]


def test_write_outputs_writes_a_directory_with_sub_paths(tmp_path):
    dest = tmp_path / "new" / "out"
    write_outputs(dirs={dest: {"a.txt": b"A", "sub/b.txt": "B"}})
    assert (dest / "a.txt").read_bytes() == b"A" and (dest / "sub" / "b.txt").read_text() == "B"
    write_outputs(dirs={dest: {"a.txt": b"A2", "sub/c.txt": "C", "new/d.txt": "D"}})  # replaces, keeps the rest
    assert (dest / "a.txt").read_bytes() == b"A2" and (dest / "sub" / "b.txt").read_text() == "B"
    assert (dest / "sub" / "c.txt").read_text() == "C" and (dest / "new" / "d.txt").read_text() == "D"
    assert not [n for n in os.listdir(dest) if n.startswith(".exotune-stage-")]


def test_write_outputs_rolls_back_sub_paths_when_a_rename_fails(tmp_path, monkeypatch):
    """Two files of one name in two sub-directories, both replaced, then a later rename fails:
    both old contents are put back (each kept under its own name) and the new sub-directory goes."""
    dest = tmp_path / "out"
    (dest / "s1").mkdir(parents=True)
    (dest / "s2").mkdir()
    (dest / "s1" / "x.txt").write_text("old1")
    (dest / "s2" / "x.txt").write_text("old2")
    real = os.replace
    calls = []

    def failing(src, dst):
        calls.append(dst)
        if str(dst).endswith("z.txt"):
            raise OSError(28, "No space left on device")
        return real(src, dst)

    monkeypatch.setattr(os, "replace", failing)
    with pytest.raises(ConfigError, match="No space left"):
        write_outputs(dirs={dest: {"s1/x.txt": "new1", "s2/x.txt": "new2", "s3/z.txt": "Z"}})
    monkeypatch.setattr(os, "replace", real)
    assert (dest / "s1" / "x.txt").read_text() == "old1" and (dest / "s2" / "x.txt").read_text() == "old2"
    assert sorted(os.listdir(dest)) == ["s1", "s2"]
    assert any(str(c).endswith("z.txt") for c in calls)


def test_write_outputs_producer_failure_leaves_nothing(tmp_path):
    dest = tmp_path / "p" / "q" / "out"

    def produce(tmp):
        Path(tmp, "half.txt").write_text("x")
        raise RuntimeError("plot failed")

    with pytest.raises(RuntimeError, match="plot failed"):
        write_outputs(dirs={dest: produce})
    assert os.listdir(tmp_path) == []  # not even the created parents


def test_write_outputs_producer_os_error_becomes_a_config_error_naming_dest(tmp_path):
    dest = tmp_path / "out"
    dest.mkdir()
    (dest / "old.txt").write_text("old")

    def produce(tmp):
        raise PermissionError(13, "Permission denied")

    with pytest.raises(ConfigError) as ei:
        write_outputs(dirs={dest: produce})
    assert ei.value.field == str(dest) and "cannot write output: Permission denied" in ei.value.reason
    assert os.listdir(dest) == ["old.txt"]


def test_check_outputs_refuses_overwriting_an_input(tmp_path):
    inp = tmp_path / "design.yaml"
    inp.write_text("x")
    with pytest.raises(ConfigError) as ei:
        check_outputs([inp, {"not": "a file"}], outputs={"-o": str(inp)})
    assert ei.value.field == str(inp) and "-o" in ei.value.reason and "input" in ei.value.reason
    link = tmp_path / "link.yaml"
    link.symlink_to(inp)
    with pytest.raises(ConfigError, match="same file as the input"):
        check_outputs([inp], outputs={"-o": link})


def test_check_outputs_refuses_two_outputs_at_one_path_and_empty_paths(tmp_path):
    p = tmp_path / "o.json"
    with pytest.raises(ConfigError, match="the --pareto output is the same path as the -o output"):
        check_outputs(outputs={"-o": p, "--pareto": p})
    with pytest.raises(ConfigError) as ei:
        check_outputs(outputs={"-o": ""})
    assert ei.value.field == "-o" and ei.value.reason == "an empty path"


def test_check_outputs_file_vs_directory(tmp_path):
    f = tmp_path / "f.txt"
    f.write_text("x")
    with pytest.raises(ConfigError, match="is a directory; -o needs a file path"):
        check_outputs(outputs={"-o": tmp_path})
    with pytest.raises(ConfigError, match="is a directory"):
        check_outputs(outputs={"-o": str(tmp_path / "new") + "/"})
    with pytest.raises(ConfigError, match=r"not a directory \(--plots needs a directory\)"):
        check_outputs(out_dirs={"--plots": f})
    with pytest.raises(ConfigError, match="is not a directory"):
        check_outputs(outputs={"-o": f / "below" / "x.json"})  # a file in the way
    check_outputs([f], outputs={"-o": tmp_path / "new" / "x.json", "--none": None}, out_dirs={"--plots": tmp_path})


def test_check_outputs_protects_directories(tmp_path):
    chunks = tmp_path / "chunks"
    chunks.mkdir()
    with pytest.raises(ConfigError, match="inside .*chunks, which holds inputs"):
        check_outputs(outputs={"-o": chunks / "x.parquet"}, protected_dirs=[chunks])
    check_outputs(outputs={"-o": tmp_path / "chunks2.parquet"}, protected_dirs=[chunks])


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write anywhere")
def test_check_outputs_refuses_unwritable_parent(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        with pytest.raises(ConfigError, match="no permission to write into"):
            check_outputs(outputs={"-o": ro / "x.json"})
    finally:
        ro.chmod(0o700)


def test_check_outputs_refuses_a_name_too_long_for_the_file_system(tmp_path):
    """Caught before any work (it was found only when the file was written, after the run, and a
    first output was then already written); the temporary sibling's longer name counts too."""
    from exotune.errors import ConfigError
    from exotune.jsonio import TMP_NAME_EXTRA, check_outputs

    limit = os.pathconf(tmp_path, "PC_NAME_MAX")
    with pytest.raises(ConfigError) as e:
        check_outputs(outputs={"`out`": tmp_path / ("a" * 10000)})
    assert e.value.field == "out" and "too long" in str(e.value)
    with pytest.raises(ConfigError):
        check_outputs(outputs={"`out`": tmp_path / ("b" * (limit - TMP_NAME_EXTRA + 1))})
    check_outputs(outputs={"`out`": tmp_path / ("c" * (limit - TMP_NAME_EXTRA))})
    write_atomic(tmp_path / ("c" * (limit - TMP_NAME_EXTRA)), "ok")
    assert list(tmp_path.iterdir()) == [tmp_path / ("c" * (limit - TMP_NAME_EXTRA))]


def test_write_atomic_follows_a_link_and_refuses_devices_and_fifos(tmp_path):
    """A symbolic link keeps pointing at its target, which gets the new content; a FIFO (and a
    device such as /dev/null, where we run as root) is refused and left as it was, never replaced
    by a regular file."""
    target = tmp_path / "real.yaml"
    target.write_text("old\n")
    link = tmp_path / "link.yaml"
    link.symlink_to(target)
    write_atomic(link, "new\n")
    assert link.is_symlink() and target.read_text() == "new\n"
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    with pytest.raises(OSError, match="not a regular file"):
        write_atomic(fifo, "x")
    assert fifo.is_fifo()
    with pytest.raises(ConfigError, match="not a regular file"):
        check_outputs([], outputs={"-o": str(fifo)})
    with pytest.raises(ConfigError, match="not a regular file"):
        check_outputs([], outputs={"-o": os.devnull})
    assert fifo.is_fifo() and not os.path.isfile(os.devnull)
    assert list(tmp_path.iterdir()) and not [p for p in tmp_path.iterdir() if p.name.startswith(".tmp-")]


def test_check_outputs_refuses_a_directory_output_that_would_overwrite_an_input(tmp_path):
    """codegen writes exotune_controller.h into its directory: an input of that name there is
    refused; an input the command does not write (another name) is fine."""
    inp = tmp_path / "exotune_controller.h"
    inp.write_text("controller: …\n")
    with pytest.raises(ConfigError, match="would overwrite the input"):
        check_outputs([str(inp)], out_dirs={"-o": str(tmp_path)}, dir_names={"-o": ("*.c", "*.h")})
    other = tmp_path / "controller.yaml"
    other.write_text("controller: …\n")
    check_outputs([str(other)], out_dirs={"-o": str(tmp_path)}, dir_names={"-o": ("*.c", "*.h")})
    sub = tmp_path / "chunks"
    sub.mkdir()
    (sub / "spec.yaml").write_text("x\n")
    with pytest.raises(ConfigError, match="chunks/\\*"):
        check_outputs([str(sub / "spec.yaml")], out_dirs={"-o": str(tmp_path)}, dir_names={"-o": ("chunks/*",)})
