"""Integrity of sweep directories: chunk checksums, row counts and spec hashes in the manifest,
verified by `report` and on resume; tampered manifests and chunks, symbolic links, the manifest
reconciled with the chunks on disk (a run killed or out of space between a chunk and the
manifest), `--dask` addresses refused before anything is written, and failed designs kept as
rows without results (issue 16)."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from exotune.cli import cli
from exotune.errors import ConfigError
from exotune.plots.sweep_report import make_report
from exotune.sweeps import SweepError, load_manifest, load_results, run_sweep
from exotune.sweeps.backends import check_dask_address
from exotune.sweeps.integrity import sha256_file
from exotune.sweeps.dataset import verified_manifest
from tests.sweeps.sweep_dirs import chunk_path as _chunk, copy_sweep as _copy, edit_manifest as _edit

ROOT = Path(__file__).resolve().parents[2]
PAPER = ROOT / "examples" / "paper.yaml"
AXES = {"design.amplification": [2.0, 8.0, 20.0], "implementation.delay_s": [0.0, 0.002, 0.004]}


def _spec(tmp: Path, axes=None, name="spec.yaml") -> Path:
    p = tmp / name
    p.write_text(yaml.safe_dump({"base": str(PAPER), "axes": axes or AXES, "chunk_size": 2}, sort_keys=False))
    return p


@pytest.fixture(scope="module")
def sweeps(tmp_path_factory):
    """The 3 × 3 sweep (5 chunks of ≤ 2 rows) and a sweep of another spec (for foreign chunks)."""
    d = tmp_path_factory.mktemp("integrity")
    spec = _spec(d)
    run_sweep(spec, d / "ref", workers=1, progress=False)
    other = _spec(d, {"design.amplification": [3.0, 4.0], "implementation.delay_s": [0.001]}, "other.yaml")
    run_sweep(other, d / "other", workers=1, progress=False)
    return spec, d / "ref", d / "other", load_results(d / "ref")



# ---------------------------------------------------------------------------------------------
# tampering: one row per case; `report` exits 2 with one line naming the chunk or the field
def t_flip_byte(d, other):
    p = _chunk(d, 1)
    b = bytearray(p.read_bytes())
    b[len(b) // 2] ^= 0xFF
    p.write_bytes(bytes(b))


def t_truncated(d, other):
    p = _chunk(d, 1)
    p.write_bytes(p.read_bytes()[:200])


def t_two_entries_one_file(d, other):
    _edit(d, lambda m: m["chunks"][1].update(file=m["chunks"][0]["file"]))


def t_same_index_twice(d, other):
    _edit(d, lambda m: m["chunks"][1].update(index=0, file=m["chunks"][0]["file"]))


def t_entry_names_chunks_dir(d, other):
    _edit(d, lambda m: m["chunks"][0].update(file="chunks"))


def t_foreign_chunk_recorded(d, other):
    shutil.copy(_chunk(other, 0), _chunk(d, 0))


def t_foreign_chunk_unrecorded(d, other):
    _edit(d, lambda m: m["chunks"][0].update(status="pending", sha256=None))
    shutil.copy(_chunk(other, 0), _chunk(d, 0))


def t_other_chunk_unrecorded(d, other):
    _edit(d, lambda m: m["chunks"][1].update(status="pending", sha256=None))
    shutil.copy(_chunk(d, 0), _chunk(d, 1))


def t_symlinked_chunk(d, other):
    outside = d.parent / "outside.parquet"
    shutil.copy(_chunk(d, 2), outside)
    _chunk(d, 2).unlink()
    _chunk(d, 2).symlink_to(outside)


def t_chunks_dir_symlink(d, other):
    outside = d.parent / "elsewhere"
    shutil.move(str(d / "chunks"), outside)
    (d / "chunks").symlink_to(outside)


def t_manifest_symlink(d, other):
    outside = d.parent / "m.json"
    shutil.move(str(d / "manifest.json"), outside)
    (d / "manifest.json").symlink_to(outside)


def t_axes_relabelled(d, other):
    _edit(d, lambda m: m["spec"]["axes"]["design.amplification"].update(values=[20.0, 8.0, 2.0]))


def t_axis_shortened(d, other):
    _edit(d, lambda m: m["spec"]["axes"]["design.amplification"].update(values=[2.0, 8.0]))


def t_spec_hash_edited(d, other):
    _edit(d, lambda m: m.update(spec_hash="0" * 64))


def t_nested_brackets(d, other):
    (d / "manifest.json").write_text("[" * 100_000 + "]" * 100_000)


def t_entry_out_of_range(d, other):
    _edit(d, lambda m: m["chunks"][4].update(index=7, file="chunks/part-000007.parquet"))


TAMPER = [
    (t_flip_byte, "part-000001.parquet", "SHA-256"),
    (t_truncated, "part-000001.parquet", "SHA-256"),
    (t_two_entries_one_file, "chunks[1].file", "chunk 1 is"),
    (t_same_index_twice, "chunks[1]", "listed twice"),
    (t_entry_names_chunks_dir, "chunks[0].file", "'chunks'"),
    (t_foreign_chunk_recorded, "part-000000.parquet", "SHA-256"),
    (t_foreign_chunk_unrecorded, "part-000000.parquet", "another sweep"),
    (t_other_chunk_unrecorded, "part-000001.parquet", "rows of chunk 0"),
    (t_symlinked_chunk, "part-000002.parquet", "symbolic link"),
    (t_chunks_dir_symlink, "chunks", "symbolic link"),
    (t_manifest_symlink, "manifest.json", "symbolic link"),
    (t_axes_relabelled, "spec", "spec_hash"),
    (t_axis_shortened, "spec.axes.design.amplification.values", "2 values"),
    (t_spec_hash_edited, "spec", "spec_hash"),
    (t_nested_brackets, "manifest.json", "nested"),
    (t_entry_out_of_range, "chunks[4].index", "not a chunk"),
]


@pytest.mark.parametrize("tamper,where,what", TAMPER, ids=[t[0].__name__[2:] for t in TAMPER])
def test_tampered_sweep_is_refused_by_report(sweeps, tmp_path, tamper, where, what):
    d = _copy(sweeps, tmp_path)
    tamper(d, sweeps[2])
    res = CliRunner().invoke(cli, ["report", str(d), "-o", str(tmp_path / "rep")])
    assert res.exit_code == 2, (res.output, res.exception)
    err = res.stderr
    assert err.startswith("exotune: error: ") and err.count("\n") == 1, err
    assert where in err and what in err, err
    assert "Traceback" not in res.output and "out of bounds" not in err
    assert not (tmp_path / "rep").exists()  # nothing written


RESUME_REFUSED = [t_two_entries_one_file, t_entry_names_chunks_dir, t_symlinked_chunk, t_chunks_dir_symlink,
                  t_manifest_symlink, t_axes_relabelled, t_axis_shortened, t_nested_brackets]


@pytest.mark.parametrize("tamper", RESUME_REFUSED, ids=[t.__name__[2:] for t in RESUME_REFUSED])
def test_tampered_sweep_is_refused_on_resume(sweeps, tmp_path, tamper):
    """Structural tampering (manifest, links) stops a resumed sweep before it writes anything."""
    d = _copy(sweeps, tmp_path)
    tamper(d, sweeps[2])
    before = {p: p.lstat().st_mtime_ns for p in d.rglob("*")}
    with pytest.raises(ConfigError):
        run_sweep(sweeps[0], d, workers=1, progress=False)
    assert before == {p: p.lstat().st_mtime_ns for p in d.rglob("*")}


@pytest.mark.parametrize("tamper", [t_flip_byte, t_truncated, t_foreign_chunk_recorded, t_foreign_chunk_unrecorded,
                                    t_other_chunk_unrecorded], ids=lambda t: t.__name__[2:])
def test_damaged_chunk_is_recomputed_on_resume(sweeps, tmp_path, tamper):
    """A chunk file that is not the recorded one is computed again by resuming (what the report's
    error tells the user to do): the dataset is the uninterrupted one, byte for byte."""
    d = _copy(sweeps, tmp_path)
    tamper(d, sweeps[2])
    m = run_sweep(sweeps[0], d, workers=1, progress=False).to_dict()
    assert m["status"] == "complete" and m["runs"][-1]["chunks_computed"] == 1
    for i in range(5):
        assert sha256_file(_chunk(d, i)) == sha256_file(_chunk(sweeps[1], i)) == m["chunks"][i]["sha256"]


def test_manifest_records_checksums_rows_and_spec_hash(sweeps):
    m = load_manifest(sweeps[1])
    assert m["failed_designs"] == 0
    for i, c in enumerate(m["chunks"]):
        assert c["file"] == f"chunks/part-{i:06d}.parquet" and c["status"] == "done"
        assert c["sha256"] == sha256_file(_chunk(sweeps[1], i))
        assert c["spec_hash"] == m["spec_hash"] and c["rows"] == (2 if i < 4 else 1)


def test_report_refuses_a_report_symlink(sweeps, tmp_path):
    d = _copy(sweeps, tmp_path)
    target = tmp_path / "target"
    target.mkdir()
    (d / "report").symlink_to(target)
    res = CliRunner().invoke(cli, ["report", str(d)])
    assert res.exit_code == 2 and "symbolic link" in res.stderr and res.stderr.count("\n") == 1
    assert list(target.iterdir()) == []


def test_sweep_refuses_a_chunks_symlink_and_deletes_nothing_through_it(tmp_path):
    target = tmp_path / "target"
    target.mkdir()
    (target / ".tmp-keep").write_text("not exotune's")
    d = tmp_path / "new"
    d.mkdir()
    (d / "chunks").symlink_to(target)
    res = CliRunner().invoke(cli, ["sweep", str(_spec(tmp_path)), "-o", str(d), "--workers", "1"])
    assert res.exit_code == 2 and "symbolic link" in res.stderr
    assert sorted(os.listdir(target)) == [".tmp-keep"] and not (d / "manifest.json").exists()


# ---------------------------------------------------------------------------------------------
# reconciliation: chunks written but not recorded (killed / out of space before the manifest)
def _forget(d: Path, indices, status="running"):
    def fn(m):
        for i in indices:
            m["chunks"][i].update(status="pending", sha256=None, spec_hash=None, seconds=None)
        m["status"] = status
    _edit(d, fn)


def test_report_reconciles_unrecorded_chunks(sweeps, tmp_path):
    d = _copy(sweeps, tmp_path)
    _forget(d, [1, 2, 3, 4])
    out = make_report(d, tmp_path / "rep").directory
    md = (out / "summary.md").read_text(encoding="utf-8")
    assert "designs: 9 of 9" in md and "partial" not in md
    m = load_manifest(d)
    assert m["status"] == "complete" and all(c["status"] == "done" for c in m["chunks"])
    assert [c["sha256"] for c in m["chunks"]] == [c["sha256"] for c in load_manifest(sweeps[1])["chunks"]]


def test_running_manifest_is_reported_interrupted_with_correct_counts(sweeps, tmp_path):
    d = _copy(sweeps, tmp_path)
    _forget(d, [2, 3, 4])
    _chunk(d, 4).unlink()  # the run was killed before chunk 4 was written
    md = (make_report(d, tmp_path / "rep").directory / "summary.md").read_text(encoding="utf-8")
    assert "status: interrupted" in md and "designs: 8 of 9" in md and "1 chunk(s) missing" in md
    assert load_manifest(d)["status"] == "interrupted"


def test_a_complete_sweep_with_a_chunk_file_gone_is_incomplete_and_resumed(sweeps, tmp_path):
    """A chunk file deleted after the sweep completed: the report said both "status: complete" and
    "partial sweep: 1 chunk(s) missing" and wrote the manifest back "complete" with the chunk
    "pending". Now the status is "incomplete", the report names the chunk and says how to compute
    it, and rerunning the sweep computes that chunk alone (the same bytes as before)."""
    spec, ref = sweeps[0], sweeps[1]
    d = _copy(sweeps, tmp_path)
    _chunk(d, 3).unlink()
    res = CliRunner().invoke(cli, ["report", str(d), "-o", str(tmp_path / "rep")])
    assert res.exit_code == 0, res.output
    assert res.stdout.splitlines() == [
        f"wrote report to {tmp_path / 'rep'} (2 maps, summary.md)",
        f"partial sweep: chunk 3 missing; the report covers the finished chunks only; rerun `exotune sweep` with the "
        f"same spec and -o {d} to compute it, then `exotune report` again"]
    md = (tmp_path / "rep" / "summary.md").read_text(encoding="utf-8")
    assert "status: incomplete" in md and "status: complete" not in md and "designs: 7 of 9" in md
    assert "1 chunk(s) missing (chunk 3 of 5)" in md and "rerun `exotune sweep` with the same spec" in md
    m = load_manifest(d)
    assert m["status"] == "incomplete" and [c["status"] for c in m["chunks"]] == ["done"] * 3 + ["pending", "done"]
    rep = make_report(d, tmp_path / "rep2")
    assert rep.missing_chunks == (3,) and rep.to_dict()["missing_chunks"] == [3]

    m = run_sweep(spec, d, workers=1, progress=False).to_dict()
    assert m["status"] == "complete" and m["runs"][-1]["chunks_computed"] == 1 and m["runs"][-1]["chunks_skipped"] == 4
    assert _chunk(d, 3).read_bytes() == _chunk(ref, 3).read_bytes()
    rep = make_report(d, tmp_path / "rep3")
    md = (rep.directory / "summary.md").read_text(encoding="utf-8")
    assert "status: complete" in md and "partial" not in md and rep.missing_chunks == ()
    assert "\n" not in rep.to_text()


def test_an_incomplete_sweep_whose_chunk_is_back_is_complete(sweeps, tmp_path):
    d = _copy(sweeps, tmp_path)
    saved = _chunk(d, 1).read_bytes()
    _chunk(d, 1).unlink()
    assert verified_manifest(d)["status"] == "incomplete"
    _chunk(d, 1).write_bytes(saved)  # restored from a backup
    assert verified_manifest(d)["status"] == "complete" and load_manifest(d)["status"] == "complete"


def test_resume_records_unrecorded_chunks_without_recomputing(sweeps, tmp_path):
    d = _copy(sweeps, tmp_path)
    _forget(d, [0, 3])
    before = {i: _chunk(d, i).stat().st_mtime_ns for i in range(5)}
    m = run_sweep(sweeps[0], d, workers=1, progress=False).to_dict()
    assert m["runs"][-1]["chunks_skipped"] == 5 and m["runs"][-1]["chunks_computed"] == 0
    assert before == {i: _chunk(d, i).stat().st_mtime_ns for i in range(5)}
    assert [c["sha256"] for c in m["chunks"]] == [c["sha256"] for c in load_manifest(sweeps[1])["chunks"]]


def test_manifest_written_before_the_integrity_fields_is_verified_row_by_row(sweeps, tmp_path):
    """Entries without a checksum (manifests written before 0.7, which had none) are checked against
    the spec and recorded; a 0.7+ manifest without them is refused (tests/sweeps/test_hostile_round4_sweeps.py)."""
    d = _copy(sweeps, tmp_path)

    def old(m):
        m["exotune_version"] = "0.6.0"
        for c in m["chunks"]:
            c.pop("sha256")
            c.pop("spec_hash")

    _edit(d, old)
    m = verified_manifest(d)
    assert all(c["sha256"] == sha256_file(_chunk(d, c["index"])) for c in m["chunks"])


def test_report_while_a_sweep_holds_the_lock_writes_no_manifest(sweeps, tmp_path):
    import fcntl

    d = _copy(sweeps, tmp_path)
    _forget(d, [4])
    text = (d / "manifest.json").read_text()
    with open(d / ".lock", "a+") as fh:
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        m = verified_manifest(d)
    assert m["status"] == "running" and m["chunks"][4]["status"] == "done"
    assert (d / "manifest.json").read_text() == text


# ---------------------------------------------------------------------------------------------
# --dask: refused before the sweep directory exists
@pytest.mark.parametrize("address", ["local:0", "local:-1", "local:x", "local:", "nonsense", "tcp://host",
                                     "tcp://127.0.0.1:99999", "tcp://127.0.0.1:1", " "])
def test_bad_dask_address_fails_fast_and_creates_nothing(tmp_path, address):
    spec = _spec(tmp_path)
    out = tmp_path / "never"
    res = CliRunner().invoke(cli, ["sweep", str(spec), "-o", str(out), "--dask", address])
    assert res.exit_code == 2, (res.output, res.exception)
    assert res.stderr.startswith("exotune: error: --dask: ") and res.stderr.count("\n") == 1, res.stderr
    assert not out.exists()


def test_dask_address_forms():
    assert check_dask_address("local:3") == ("local", 3)
    assert check_dask_address("tcp://10.0.0.1:8786") == ("remote", None)
    assert check_dask_address("scheduler.example:8786") == ("remote", None)
    assert check_dask_address("inproc://10.0.0.1/123/1") == ("remote", None)
    with pytest.raises(ConfigError, match="local:N needs N >= 1"):
        check_dask_address("local:0")


# ---------------------------------------------------------------------------------------------
# failed designs: rows without results, the other rows of the chunk kept
def test_failing_design_is_a_failed_row(sweeps, tmp_path, monkeypatch):
    import exotune.sweeps.compute as sw

    spec, ref, _, df = sweeps
    real = sw.analyze_batch

    def flaky(cfg, *a, **k):
        hit = (np.asarray(cfg.implementation.delay_s) == 0.004) & (np.asarray(cfg.design.amplification) == 8.0)
        if np.any(hit):  # grid point 5 only; chunk 2 also holds point 4
            raise ZeroDivisionError("float division by zero")
        return real(cfg, *a, **k)

    monkeypatch.setattr(sw, "analyze_batch", flaky)
    out = tmp_path / "f"
    with pytest.raises(SweepError, match=r"1 of 9 designs failed \(first: design 5: ZeroDivisionError") as e:
        run_sweep(spec, out, workers=1, progress=False)
    assert e.value.exit_code == 1 and e.value.failed == []
    m = load_manifest(out)
    assert m["status"] == "complete" and m["failed_designs"] == 1
    assert m["chunks"][2]["failed_designs"] == [{"point_index": 5, "reason": "ZeroDivisionError: float division by zero"}]
    for i in (0, 1, 3, 4):  # chunks without a failing design: the same bytes as before
        assert sha256_file(_chunk(out, i)) == sha256_file(_chunk(ref, i))
    got = load_results(out)
    assert got["point_index"].tolist() == list(range(9))
    assert got.loc[5, "design.amplification"] == 8.0 and got.loc[5, "implementation.delay_s"] == 0.004
    assert np.isnan(got.loc[5, "dob_delay_margin_s"]) and got.loc[5, "free_stable"] is None
    import pyarrow.parquet as pq

    row4 = pq.read_table(_chunk(out, 2)).slice(0, 1).to_pylist()
    assert json.dumps(row4, default=str) == json.dumps(pq.read_table(_chunk(ref, 2)).slice(0, 1).to_pylist(), default=str)
    md = (make_report(out, tmp_path / "rep").directory / "summary.md").read_text(encoding="utf-8")
    assert "failed designs**: 1 design(s)" in md
    # the CLI: exit 1, one line; rerunning does not recompute (the chunk is done) and says so again
    res = CliRunner().invoke(cli, ["sweep", str(spec), "-o", str(out), "--workers", "1"])
    assert res.exit_code == 1 and "1 of 9 designs failed" in res.stderr and "Traceback" not in res.output
    assert load_manifest(out)["runs"][-1]["chunks_computed"] == 0
