"""exotune.sweeps.manifest: a new sweep's manifest, its round trip through the file, the checks
that refuse a damaged or edited manifest (naming the field), the directory lock and the
compatibility of a resumed sweep."""

import copy
import json
import os
import re
from pathlib import Path

import pytest

from exotune.errors import ConfigError
from exotune.sweeps.manifest import (FORMAT, FORMAT_VERSION, MANIFEST, check_compatible, chunk_rel, dir_lock,
                                     engine_hash, load_manifest, new_manifest, refuse_link, try_lock, utc_now,
                                     write_manifest)
from exotune.sweeps.spec import load_spec
from exotune.version import __version__

ROOT = Path(__file__).resolve().parents[2]
PAPER = str(ROOT / "examples" / "paper.yaml")


@pytest.fixture(scope="module")
def plan():
    return load_spec({"base": PAPER, "axes": {"design.amplification": [2.0, 4.0, 8.0],
                                              "implementation.delay_s": {"start": 0.0, "stop": 0.002, "num": 2}},
                      "chunk_size": 4})


def test_new_manifest_describes_the_plan(plan):
    m = new_manifest(plan)
    assert (m["format"], m["format_version"], m["exotune_version"]) == (FORMAT, FORMAT_VERSION, __version__)
    assert m["spec_hash"] == plan.hash and m["spec"] == plan.spec
    assert m["axes"] == [{"path": "design.amplification", "num": 3, "min": 2.0, "max": 8.0, "scale": "list"},
                         {"path": "implementation.delay_s", "num": 2, "min": 0.0, "max": 0.002, "scale": "lin"}]
    assert m["grid_shape"] == [3, 2] and m["grid_points"] == 6 and m["n_points"] == 6
    assert (m["chunk_size"], m["n_chunks"], m["status"], m["chunks"]) == (4, 2, "running", [])
    assert m["sampling"]["method"].startswith("full grid")
    assert m["model"].startswith("continuous-time analysis")
    sampled = new_manifest(load_spec({"base": PAPER, "axes": {"design.amplification": [2.0, 4.0]}}, sample=1, seed=3))
    assert sampled["sampling"]["sample"] == 1 and sampled["sampling"]["seed"] == 3


def test_write_and_load_round_trip(plan, tmp_path):
    m = new_manifest(plan)
    m["chunks"] = [{"index": 1, "file": chunk_rel(1), "status": "done"}]
    write_manifest(str(tmp_path), m)
    assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\+00:00", m["updated"])
    back = load_manifest(tmp_path)
    assert back == json.loads(json.dumps(m))
    assert chunk_rel(1) == "chunks/part-000001.parquet"


def _write(tmp_path, m):
    (tmp_path / MANIFEST).write_text(json.dumps(m), encoding="utf-8")


def _edit(plan, fn):
    m = copy.deepcopy(new_manifest(plan))
    m["chunks"] = [{"index": 0, "file": chunk_rel(0), "status": "done"}]
    fn(m)
    return m


@pytest.mark.parametrize("edit, field, reason", [
    (lambda m: m.pop("spec_hash"), "spec_hash", "expected a string"),
    (lambda m: m.update(n_points=True), "n_points", "expected an integer"),
    (lambda m: m.update(axes=[]), "axes", "non-empty list"),
    (lambda m: m["axes"].reverse(), "spec.axes", "in order"),
    (lambda m: m["spec"]["axes"]["design.amplification"].update(values=["x"]), "spec.axes.design.amplification.values",
     "list of numbers"),
    (lambda m: m["chunks"].append(7), "chunks[1]", "index, file and status"),
    (lambda m: m["chunks"][0].update(file="/etc/passwd"), "chunks[0].file", "inside the sweep directory"),
    (lambda m: m["spec"]["axes"]["design.amplification"]["values"].pop(), "spec.axes.design.amplification.values",
     "2 values, but the sweep's axis design.amplification has 3"),
    (lambda m: m.update(grid_shape=[2, 3]), "grid_shape", "does not match the axes"),
    (lambda m: m["spec"].update(chunk_size=5), "spec", "does not have the recorded spec_hash"),
    (lambda m: m.update(n_chunks=3), "n_points", "do not match the spec"),
    (lambda m: m["chunks"].append({"index": 0, "file": chunk_rel(0), "status": "done"}), "chunks[1]", "listed twice"),
    (lambda m: m["chunks"][0].update(index=2, file=chunk_rel(2)), "chunks[0].index", "is not a chunk of this sweep"),
    (lambda m: m["chunks"][0].update(file=chunk_rel(1)), "chunks[0].file", "but chunk 0 is"),
])
def test_damaged_or_edited_manifests_are_refused_naming_the_field(plan, tmp_path, edit, field, reason):
    _write(tmp_path, _edit(plan, edit))
    with pytest.raises(ConfigError) as ei:
        load_manifest(tmp_path)
    assert ei.value.field == f"{tmp_path / MANIFEST}: {field}"
    assert reason in ei.value.reason


def test_not_a_sweep_directory(tmp_path):
    with pytest.raises(ConfigError) as ei:
        load_manifest(tmp_path)
    assert ei.value.field == str(tmp_path) and "no manifest.json" in ei.value.reason
    _write(tmp_path, {"format": "something else"})
    with pytest.raises(ConfigError, match="not an exotune sweep manifest"):
        load_manifest(tmp_path)
    os.remove(tmp_path / MANIFEST)
    (tmp_path / "real.json").write_text("{}")
    os.symlink(tmp_path / "real.json", tmp_path / MANIFEST)
    with pytest.raises(ConfigError, match="is a symbolic link"):
        load_manifest(tmp_path)


def test_the_directory_lock_admits_one_run(tmp_path):
    with dir_lock(str(tmp_path)):
        assert try_lock(str(tmp_path)) is None
        with pytest.raises(ConfigError) as ei:
            with dir_lock(str(tmp_path)):
                pass
        assert ei.value.field == str(tmp_path) and "another exotune sweep is running" in ei.value.reason
    fh = try_lock(str(tmp_path))
    assert fh is not None
    fh.close()


def test_refuse_link(tmp_path):
    (tmp_path / "f").write_text("x")
    refuse_link(str(tmp_path / "f"))
    os.symlink(tmp_path / "f", tmp_path / "l")
    with pytest.raises(ConfigError, match="is a symbolic link; a report directory must hold its own files"):
        refuse_link(str(tmp_path / "l"), "a report directory")


def test_check_compatible(plan, tmp_path):
    m = new_manifest(plan)
    check_compatible(str(tmp_path), m, plan)
    other = load_spec({"base": PAPER, "axes": {"design.amplification": [2.0, 4.0, 8.0],
                                               "implementation.delay_s": {"start": 0.0, "stop": 0.002, "num": 2}},
                       "chunk_size": 5})
    with pytest.raises(ConfigError, match="holds a sweep of a different spec .*differs in: chunk_size"):
        check_compatible(str(tmp_path), m, other)
    with pytest.raises(ConfigError, match="different analysis code"):
        check_compatible(str(tmp_path), {**m, "engine_hash": "0" * 64}, plan)
    with pytest.raises(ConfigError, match="made by exotune 0.0.1"):
        check_compatible(str(tmp_path), {**m, "exotune_version": "0.0.1"}, plan)


def test_engine_hash_and_time():
    h = engine_hash()
    assert re.fullmatch(r"[0-9a-f]{64}", h) and engine_hash() == h
    assert utc_now().endswith("+00:00")


@pytest.mark.parametrize("edit, field, reason", [
    (lambda m: m.update(format_version=2), "format_version",
     "2 is not a manifest format this exotune (" + __version__ + ") reads (it reads 1): the sweep was written by a "
     "newer exotune"),
    (lambda m: m.update(format_version="1"), "format_version", "expected the integer 1, got the string '1'"),
    (lambda m: m.update(format_version=True), "format_version", "expected the integer 1, got the boolean True"),
    (lambda m: m.pop("format_version"), "format_version", "expected the integer 1, got nothing"),
    (lambda m: m.update(format_version=0), "format_version", "0 is not a manifest format"),
    (lambda m: m.update(status=5), "status", "expected one of running, complete, interrupted, incomplete, failed, got int 5"),
    (lambda m: m.update(status="finished"), "status", "got the string 'finished'"),
    (lambda m: m.update(status=None), "status", "got null"),
    (lambda m: m["chunks"][0].update(status="ok"), "chunks[0].status", "expected one of pending, done, failed"),
], ids=["version-2", "version-string", "version-bool", "version-missing", "version-0", "status-int",
        "status-unknown", "status-null", "chunk-status"])
def test_an_unknown_format_version_or_status_is_refused_naming_the_field(plan, tmp_path, edit, field, reason):
    """A manifest with ``format_version: 2`` or ``status: 5`` was read as if it were this format
    and state (the report written, exit 0). Both are refused, naming the field."""
    _write(tmp_path, _edit(plan, edit))
    with pytest.raises(ConfigError) as ei:
        load_manifest(tmp_path)
    assert ei.value.field == f"{tmp_path / MANIFEST}: {field}"
    assert reason in ei.value.reason
    for status in ("running", "complete", "interrupted", "incomplete", "failed"):  # the known states pass
        _write(tmp_path, _edit(plan, lambda m: m.update(status=status)))
        assert load_manifest(tmp_path)["status"] == status


@pytest.mark.parametrize("name", ["compute.py", "sampledcols.py"])
def test_engine_hash_covers_the_sweep_modules_that_compute_columns(name, monkeypatch):
    """A change of the sweep's column code (the chunk table, the sampled-data and gain-schedule
    columns) is a different engine: a resumed sweep must not mix its chunks with older ones."""
    import pathlib

    before = engine_hash()
    real = pathlib.Path.read_bytes

    def edited(self):
        data = real(self)
        return data + b"\n# edited\n" if self.name == name and self.parent.name == "sweeps" else data

    monkeypatch.setattr(pathlib.Path, "read_bytes", edited)
    assert engine_hash() != before
