"""Hostile inputs, round 4: sweep directories (``exotune report``, resuming, ``load_results``).

* F11 a chunk whose interval column holds an entry that is not a [lo, hi] pair (its checksum
  recomputed into the manifest) is refused naming the chunk file and the column.
* F15 a report of a sweep still running (manifest ``running``, a run holding the directory's
  lock) says so, instead of telling the user to rerun ``exotune sweep``.
* F17 a manifest entry marked done without the SHA-256 of its file is refused (report) or
  recomputed (resume): an edited chunk no longer passes the row-by-row check of an unrecorded one.

Each refusal runs the command line in-process: exit code 2, the file or field named, no
traceback, no report written.
"""

from __future__ import annotations

import fcntl
import hashlib
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
import pytest
import yaml
from click.testing import CliRunner

from exotune.cli import cli
from exotune.errors import ConfigError
from exotune.sweeps import SweepReport, load_manifest, load_results, run_sweep
from exotune.sweeps.dataset import verified_manifest
from tests.sweeps.sweep_dirs import chunk_path as _chunk, copy_sweep as _copy, edit_manifest as _edit

ROOT = Path(__file__).resolve().parents[2]
PAPER = ROOT / "examples" / "paper.yaml"
AXES = {"design.amplification": [2.0, 8.0, 20.0], "implementation.delay_s": [0.0, 0.002]}  # 3 chunks of 2


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    d = tmp_path_factory.mktemp("round4")
    spec = d / "spec.yaml"
    spec.write_text(yaml.safe_dump({"base": str(PAPER), "axes": AXES, "chunk_size": 2}, sort_keys=False))
    run_sweep(spec, d / "ref", workers=1, progress=False)
    return spec, d / "ref"



def _rewrite(path: Path, name: str, fn) -> None:
    """Replace column ``name`` of a chunk by ``fn(its values as Python lists)``; the file's
    metadata (spec hash, chunk index) and schema are kept, as a careful hand edit would."""
    t = pq.read_table(path)
    i = t.column_names.index(name)
    t = t.set_column(i, t.schema.field(i), pa.array(fn(t.column(i).to_pylist()), type=t.schema.field(i).type))
    pq.write_table(t, path)


def _report(d: Path, out: Path):
    return CliRunner().invoke(cli, ["report", str(d), "-o", str(out)])


def _refused(res, field: str, *contains: str) -> str:
    assert res.exit_code == 2, (res.exit_code, res.output, res.exception)
    first = res.stderr.splitlines()[0]
    assert first.startswith(f"exotune: error: {field}: "), first
    assert all(c in first for c in contains), first
    assert "Traceback" not in res.output and "Traceback" not in res.stderr
    return first


# -------------------------------------------------------------------------------------- F11
def test_a_malformed_interval_column_names_its_chunk_file(swept, tmp_path):
    """A chunk edited to hold [lo, mid, hi] in an interval column, its checksum recomputed into
    the manifest: the report failed with "interval column with entries that are not [lo, hi]
    pairs", naming no chunk."""
    d = _copy(swept, tmp_path)
    col = next(c[0] for c in load_manifest(d)["columns"] if c[0].endswith("_stable_intervals"))
    _rewrite(_chunk(d, 1), col, lambda rows: [[[0.1, 0.2, 0.3]]] + rows[1:])
    digest = hashlib.sha256(_chunk(d, 1).read_bytes()).hexdigest()
    _edit(d, lambda m: m["chunks"][1].update(sha256=digest))
    _refused(_report(d, tmp_path / "rep"), str(_chunk(d, 1)), f"column {col}", "an entry of 3 values",
             "not chunk 1")
    assert not (tmp_path / "rep").exists()
    with pytest.raises(ConfigError) as e:
        load_results(d)
    assert e.value.field == str(_chunk(d, 1))


# -------------------------------------------------------------------------------------- F17
def test_a_done_entry_without_its_checksum_is_refused_and_recomputed(swept, tmp_path):
    """chunks[1] marked done without its sha256 accepted a chunk whose results were edited (the
    row-by-row check of an unrecorded chunk looks at the design indices only)."""
    spec, ref = swept
    d = _copy(swept, tmp_path)
    _rewrite(_chunk(d, 1), "free_stable", lambda rows: [not v for v in rows])  # forged verdicts
    _edit(d, lambda m: m["chunks"][1].pop("sha256"))
    _refused(_report(d, tmp_path / "rep"), f"{d / 'manifest.json'}: chunks[1].sha256",
             "chunk 1 is marked done without the SHA-256 of its file", "cannot be verified")
    assert not (tmp_path / "rep").exists()
    m = run_sweep(spec, d, workers=1, progress=False).to_dict()  # resuming recomputes it
    assert m["runs"][-1]["chunks_computed"] == 1 and m["status"] == "complete"
    assert _chunk(d, 1).read_bytes() == _chunk(ref, 1).read_bytes()
    assert load_manifest(d)["chunks"][1]["sha256"] == hashlib.sha256(_chunk(ref, 1).read_bytes()).hexdigest()


def test_an_older_manifest_without_checksums_is_still_verified_row_by_row(swept, tmp_path):
    """A manifest of exotune 0.6 (before the checksums) is checked against the spec and recorded."""
    d = _copy(swept, tmp_path)

    def older(m):
        m["exotune_version"] = "0.6.0"
        for c in m["chunks"]:
            c.pop("sha256")
            c.pop("spec_hash")
    _edit(d, older)
    m = verified_manifest(d)  # what report and load_results read first
    assert m["status"] == "complete" and all(isinstance(c["sha256"], str) for c in load_manifest(d)["chunks"])


# -------------------------------------------------------------------------------------- F15
def _running(d: Path, pending) -> None:
    def fn(m):
        for i in pending:
            m["chunks"][i].update(status="pending", sha256=None, spec_hash=None, seconds=None)
            _chunk(d, i).unlink()
        m["status"] = "running"
    _edit(d, fn)


def test_a_report_of_a_running_sweep_says_it_is_running(swept, tmp_path):
    """While a sweep ran, its report said "partial sweep … rerun `exotune sweep`": a second run
    in the directory would be refused (the lock), and none is needed."""
    d = _copy(swept, tmp_path)
    _running(d, [2])
    with open(d / ".lock", "a+") as fh:  # a run holds the directory
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        res = _report(d, tmp_path / "rep")
        assert res.exit_code == 0, res.output
        assert "appears to be still running" in res.stdout and "chunk 2 is not finished yet" in res.stdout
        assert "rerun" not in res.stdout
        md = (tmp_path / "rep" / "summary.md").read_text(encoding="utf-8")
        assert "partial report of a sweep still running" in md and "rerun" not in md
        assert load_manifest(d)["status"] == "running"  # a report never writes while a run holds the lock
        with pytest.raises(ConfigError, match="still running"):
            load_results(d)
    # the run is gone (killed): the sweep is interrupted, and resuming it is the advice
    assert verified_manifest(d)["status"] == "interrupted"
    text = SweepReport(tmp_path / "rep", ("summary.md",), (), (2,), str(d)).to_text()
    assert "rerun `exotune sweep` with the same spec" in text and "still running" not in text


def test_a_running_sweep_without_a_finished_chunk_is_refused_as_running(swept, tmp_path):
    d = _copy(swept, tmp_path)
    _running(d, [0, 1, 2])
    with open(d / ".lock", "a+") as fh:
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        _refused(_report(d, tmp_path / "rep"), str(d), "appears to be still running",
                 "has finished none of its 3 chunks yet")
    assert not (tmp_path / "rep").exists()
