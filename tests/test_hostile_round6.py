"""Hostile inputs, round 6: controller files edited after export (``certify``, ``codegen``), the
edges of sweep and optimization specs, resumed sweep directories with foreign files, and
identification logs whose header or time column lies.

Each row runs the command line in-process (click's CliRunner) and asserts the error contract of
docs/cli.md: exit code 2, one first line ``exotune: error: <field>: <reason>`` naming the field
(file key path, option or path) and the reason, no traceback, no Python repr of an exception,
nothing written. ``codegen --allow-uncertified`` must refuse every file ``certify`` refuses as
invalid. Earlier rounds: tests/test_hostile_inputs.py, tests/test_hostile_round4.py,
tests/test_hostile_round5.py, tests/controllerfile/test_tamper.py, tests/sweeps/test_integrity.py.

* H1  a float32 realization holding a value float32 does not hold (hand-edited, hand-tuned or
  not): certify analysed the value as written while the target runs its float32 rounding — a
  CERTIFIED verdict for another controller than the one executed; 1e39 read "the command
  overflows float32".
* H2  the ``dob`` summary's Q cutoff/damping, or a filter's ``prewarp_hz`` or ``continuous`` block,
  edited (1e-320): CERTIFIED, the file's account of its filters false; ``requirements.latency_margin_s:
  1e308``: "latency margin 1.62 ms < required inf ms" (a design file and ``--require-latency-margin-s``
  accept [0, 1] s).
* H2b ``codegen`` stamped the C with the sha256 of the file as read after the load: a file rewritten
  in between was stamped with bytes never certified.
* H3  ``optimize`` with ``budget: 10^400``: an OverflowError traceback; ``budget: 10^9`` ran.
* H4  a sweep axis ``num`` (or ``verify_points``) of 400 digits echoed whole; ``chunk_size: 10^30``
  accepted (one chunk is analysed in memory at once).
* H5  a resumed sweep whose ``chunks/`` holds a chunk file beyond its chunks (another sweep's):
  kept, so ``pandas.read_parquet(DIR/chunks)`` mixed its rows in; a directory where a chunk file
  belongs: exit 1 with a Python ``FileExistsError: [Errno 17]`` and "a device, FIFO or socket".
* H6  identification logs: ``t [s]`` / ``T`` headers read "unknown column" only; a time column
  whose rate drifts by 20 % over the log passed the step check and was identified at the mean
  rate.
"""

from __future__ import annotations

import copy
import json
import shutil
import struct
from pathlib import Path

import numpy as np
import pytest
import yaml

from cli_refusal import files, refused, run

ROOT = Path(__file__).resolve().parents[1]
PAPER = ROOT / "examples" / "paper.yaml"
SHIPPED = ROOT / "results" / "pipeline" / "controller_1khz.yaml"


_run, _refused, _files = run, refused, files


def _is_float32(x: float) -> bool:
    """Independent of numpy: the IEEE single-precision round trip of the struct module."""
    try:
        return struct.unpack("<f", struct.pack("<f", x))[0] == x
    except OverflowError:
        return False


# ------------------------------------------------------------------------------ controller files
@pytest.fixture(scope="module")
def c64():
    if not SHIPPED.exists():
        pytest.skip("no shipped controller file")
    return yaml.safe_load(SHIPPED.read_text(encoding="utf-8"))


@pytest.fixture(scope="module")
def c32(c64):
    """The shipped file as a float32 file: its float32 realizations added (as export adds them)."""
    from exotune.controllerfile.precision import add_realizations

    d = copy.deepcopy(c64)
    d["implementation"]["precision"] = "float32"
    add_realizations(d)
    return d


def _write(tmp_path: Path, d: dict, name: str = "c.yaml") -> Path:
    p = tmp_path / name
    p.write_text(yaml.safe_dump(d, sort_keys=False, allow_unicode=True), encoding="utf-8")
    return p


def _both_refuse(tmp_path: Path, p: Path, field: str, *contains: str) -> None:
    """certify and ``codegen --allow-uncertified`` refuse the file alike, and nothing is written."""
    before = _files(tmp_path)
    first = _refused(["certify", p], field, *contains)
    assert _refused(["codegen", p, "-o", tmp_path / "c_src", "--allow-uncertified"], field) == first
    assert _files(tmp_path) == before


def _realization_values(real: dict):
    yield from real["gains"].values()
    for f in real["filters"]:
        for row in f["sections"]:
            yield from row
    yield real["loop_divisor"]


def test_an_exported_realization_holds_float32_values_only(c32):
    from exotune.controllerfile.fileio import checked_controller_file

    assert all(_is_float32(x) for x in _realization_values(c32["controller"]["realization"]))
    checked_controller_file(copy.deepcopy(c32))  # loads


def _edit_section(d, value):
    d["controller"]["realization"]["filters"][0]["sections"][0][1] = value


def _edit_gain(d, value):
    d["controller"]["realization"]["gains"]["omega_m"] = value


def _edit_divisor(d, value):
    d["controller"]["realization"]["loop_divisor"] = value


@pytest.mark.parametrize("hand_tuned", [False, True], ids=["exported", "hand-tuned"])
@pytest.mark.parametrize("edit, field", [
    (_edit_section, "controller.realization.filters[0].sections[0][1]"),
    (_edit_gain, "controller.realization.gains.omega_m"),
    (_edit_divisor, "controller.realization.loop_divisor"),
], ids=["section", "gain", "loop-divisor"])
def test_a_realization_value_float32_does_not_hold_is_refused(c32, tmp_path, edit, field, hand_tuned):
    """H1: the value nearest the original that is not a float32 value (one float64 ulp away)."""
    d = copy.deepcopy(c32)
    d["provenance"]["hand_tuned"] = hand_tuned
    path = field.split(".")[2:]
    real = d["controller"]["realization"]
    old = (real["filters"][0]["sections"][0][1] if path[0].startswith("filters") else
           real["gains"]["omega_m"] if path[0] == "gains" else real["loop_divisor"])
    new = float(np.nextafter(old, np.inf))
    assert _is_float32(old) and not _is_float32(new)
    edit(d, new)
    _both_refuse(tmp_path, _write(tmp_path, d), field, f"{new!r} is not a float32 value",
                 f"float32 holds {old!r}")


def test_a_realization_value_beyond_float32_is_refused(c32, tmp_path):
    d = copy.deepcopy(c32)
    d["provenance"]["hand_tuned"] = True
    _edit_section(d, 1e39)
    assert not _is_float32(1e39)
    _both_refuse(tmp_path, _write(tmp_path, d), "controller.realization.filters[0].sections[0][1]",
                 "does not fit in float32")


@pytest.mark.parametrize("key, src, value", [("q_damping", "damping", 1e-320), ("q_cutoff_hz", "cutoff_hz", 61.0)])
def test_a_dob_summary_that_is_not_the_implementations_is_refused(c64, tmp_path, key, src, value):
    """H2: the filters (rebuilt from the implementation section) unchanged, the summary edited."""
    d = copy.deepcopy(c64)
    d["dob"][key]["value"] = value
    _both_refuse(tmp_path, _write(tmp_path, d), f"dob.{key}.value", f"implementation section's dob.{src}",
                 repr(float(c64["implementation"]["dob"][src])))


@pytest.mark.parametrize("edit", [
    lambda d: d["controller"]["filters"][0].update(prewarp_hz=1e-320),
    lambda d: d["controller"]["filters"][0]["continuous"]["num"].__setitem__(0, 5.0),
    lambda d: d["controller"]["filters"][0]["continuous"].update(den="x"),
], ids=["prewarp", "continuous-num", "continuous-den-text"])
def test_a_filters_stated_origin_that_is_not_the_implementations_is_refused(c64, tmp_path, edit):
    """The sos untouched (the runtime runs it), the prewarp frequency or the continuous block the
    file says it came from edited: CERTIFIED, the file's account of its filter false."""
    d = copy.deepcopy(c64)
    edit(d)
    _both_refuse(tmp_path, _write(tmp_path, d), "implementation",
                 "controller.filters[cuff_path]: prewarp_hz or continuous block not the implementation section's")


def _sos(d, name):
    return next(f for f in d["controller"]["filters"] if f["name"] == name)["sos"]


def _set_sos(name, row, col, value):
    def edit(d):
        _sos(d, name)[row][col] = value
    return edit


def _sos_row(name, fn):
    def edit(d):
        fn(_sos(d, name)[0])
    return edit


# edits a runtime's loader must refuse whatever the provenance says (schema and consistency)
LOAD_REFUSALS = [
    (_set_sos("dob_spring", 0, 3, 0.0), "controller.filters[2].sos[0][3]", "a0 = 0.0: must be 1"),
    (_set_sos("dob_spring", 0, 3, 1.0000001), "controller.filters[2].sos[0][3]", "must be 1"),
    (_sos_row("dob_spring", list.pop), "controller.filters[2].sos[0][5]", "missing"),
    (_sos_row("dob_spring", lambda r: r.append(0.0)), "controller.filters[2].sos[0]", "at most 6"),
    (lambda d: next(f for f in d["controller"]["filters"] if f["name"] == "dob_spring").update(sos=[]),
     "controller.filters[2].sos", "at least 1"),
    (_set_sos("dob_spring", 0, 1, "0.05"), "controller.filters[2].sos[0][1]", "got the string '0.05'"),
    (_set_sos("dob_spring", 0, 1, 10**400), "controller.filters[2].sos[0][1]", "(401 digits) is too large"),
    (lambda d: d["sample_rate_hz"].update(value=2000.0), "delay_s.samples", "at 2000.0 Hz is 2.0"),
    (lambda d: d["sample_rate_hz"].update(value=-0.0), "sample_rate_hz.value", "must be > 0"),
    (lambda d: d["plant"]["motor_inertia"].update(value=1e-320), "plant.motor_inertia.value", "accepted range"),
    (lambda d: d["implementation"].update(precision="float32"), "controller.realization",
     "missing: a float32 file"),
    (lambda d: d["implementation"].update(precision="float16"), "implementation.precision", ""),
    (lambda d: d["requirements"].update(latency_margin_s=1e308), "requirements.latency_margin_s",
     "must be in [0, 1] s, got 1e+308 s"),
]


@pytest.mark.parametrize("hand_tuned", [False, True], ids=["exported", "hand-tuned"])
@pytest.mark.parametrize("edit, field, contains", LOAD_REFUSALS, ids=[r[1] + ":" + r[2][:12] for r in LOAD_REFUSALS])
def test_an_edited_controller_file_is_refused_by_certify_and_codegen(c64, tmp_path, edit, field, contains,
                                                                     hand_tuned):
    d = copy.deepcopy(c64)
    d["provenance"]["hand_tuned"] = hand_tuned
    edit(d)
    _both_refuse(tmp_path, _write(tmp_path, d), field, contains)


@pytest.mark.parametrize("old, new, field, contains", [
    ("schema: exotune.controller/1\n", "schema: exotune.controller/1\nsample_rate_hz: {value: 2000.0, unit: Hz}\n",
     "sample_rate_hz", "duplicate key"),
    ("  value: 1000.0\n  unit: Hz\n", "  <<: {value: 2000.0}\n  value: 1000.0\n  unit: Hz\n", "sample_rate_hz.value",
     "merged by <<"),
    ("  value: 1000.0\n  unit: Hz\n", "  value: .nan\n  unit: Hz\n", "sample_rate_hz.value", "finite"),
    ("  value: 1000.0\n  unit: Hz\n", "  value: !!python/object/apply:os.system ['echo x']\n  unit: Hz\n", "{f}",
     "could not determine a constructor"),
], ids=["duplicate-key", "merge-key", "nan", "python-tag"])
def test_yaml_tricks_in_a_controller_file_are_refused_by_certify_and_codegen(tmp_path, old, new, field, contains):
    if not SHIPPED.exists():
        pytest.skip("no shipped controller file")
    text = SHIPPED.read_text(encoding="utf-8")
    assert old in text
    p = tmp_path / "c.yaml"
    p.write_text(text.replace(old, new, 1), encoding="utf-8")
    _both_refuse(tmp_path, p, field.format(f=p), contains)


def test_codegen_refuses_an_alias_bomb(tmp_path):
    """Round 1 ran the billion-laughs file through every loader but codegen."""
    p = tmp_path / "c.yaml"
    lines = ['a0: &a0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    lines += [f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 10) + "]" for i in range(1, 10)]
    p.write_text("\n".join(lines) + "\n")
    _both_refuse(tmp_path, p, str(p), "aliases")


def test_a_hand_tuned_filter_made_unstable_is_never_certified_nor_generated(c64, tmp_path):
    """A DOB filter with a2 = 1.5 (poles of product 1.5: one outside the unit circle), the file's
    golden outputs and predictions those of the original: certify analyses the edited loop and does
    not certify it (exit 1, the reasons named); codegen refuses it, --allow-uncertified or not (its
    golden vectors are not the runtime's), and writes nothing."""
    d = copy.deepcopy(c64)
    d["provenance"]["hand_tuned"] = True
    _sos(d, "dob_spring")[0][5] = 1.5
    poles = np.roots([1.0, *_sos(d, "dob_spring")[0][4:]])
    assert np.max(np.abs(poles)) > 1.0  # independent: the filter itself is unstable
    p = _write(tmp_path, d)
    res, _ = _run(["certify", p])
    assert res.exit_code == 1, res.output
    assert "CERTIFIED" not in res.stdout.replace("NOT CERTIFIED", "") and "Traceback" not in res.output
    for extra in ([], ["--allow-uncertified"]):  # the C golden test could not pass: refused even so
        _refused(["codegen", p, "-o", tmp_path / "c_src", *extra], "golden",
                 "the reference runtime does not reproduce the golden vectors")
    assert not (tmp_path / "c_src").exists()


def test_codegen_refuses_a_file_that_changes_while_it_is_certified(c64, tmp_path, monkeypatch):
    """The C was stamped with the sha256 of the file as read after the load: a file rewritten just
    after the load was stamped with bytes never certified. Now the file is read before the load and
    after the certification, and any difference refuses it (nothing written)."""
    import hashlib

    import exotune.controllerfile.fileio as fileio

    p = _write(tmp_path, c64)
    certified = hashlib.sha256(p.read_bytes()).hexdigest()
    real = fileio.load_controller_file

    def load_then_edit(path):
        doc = real(path)
        edited = copy.deepcopy(c64)
        edited["controller"]["gains"]["omega_m"]["gain"] = 1e6  # another controller, same path
        _write(tmp_path, edited)
        return doc

    monkeypatch.setattr(fileio, "load_controller_file", load_then_edit)
    _refused(["codegen", p, "-o", tmp_path / "c_src", "--allow-uncertified"], str(p),
             "the file changed while codegen read and certified it")
    assert hashlib.sha256(p.read_bytes()).hexdigest() != certified and not (tmp_path / "c_src").exists()


# -------------------------------------------------------------------------- optimize / sweep specs
def _opt_spec(tmp_path: Path, budget: str) -> Path:
    p = tmp_path / "spec.yaml"
    p.write_text(f"base: {PAPER}\nfree:\n  design.amplification: [2.0, 4.0]\nbudget: {budget}\n")
    return p


@pytest.mark.parametrize("budget, shown", [("1000000001", "1000000001 exact analyses"),
                                           ("9" * 400, "(400 characters) exact analyses")], ids=["1e9", "400-digits"])
def test_an_absurd_optimization_budget_is_refused_before_the_search(tmp_path, monkeypatch, budget, shown):
    """H3: 10^400 raised an OverflowError traceback from the search; 10^9 started it."""
    import exotune.optimization.runner as runner
    from exotune.optimization.spec import MAX_BUDGET

    monkeypatch.setattr(runner, "optimize", lambda *a, **k: pytest.fail("the search ran"))
    spec = _opt_spec(tmp_path, budget)
    _refused(["optimize", spec, "-o", tmp_path / "out.yaml"], "budget", shown, f"at most {MAX_BUDGET}")
    assert _files(tmp_path) == {"spec.yaml"}


def test_the_largest_budget_is_accepted(tmp_path):
    from exotune.optimization.spec import MAX_BUDGET, load_optimize_spec

    assert load_optimize_spec(_opt_spec(tmp_path, str(MAX_BUDGET))).budget == MAX_BUDGET


def _sweep_spec(tmp_path: Path, axes: str, more: str = "") -> Path:
    p = tmp_path / "spec.yaml"
    p.write_text(f"base: {PAPER}\naxes:\n{axes}{more}")
    return p


@pytest.mark.parametrize("axes, more, field, contains", [
    ("  design.amplification: {start: 2, stop: 3, num: " + "9" * 400 + "}\n", "", "axes.design.amplification.num",
     "(400 characters) values; an axis has at most 100000"),
    ("  design.amplification: [2.0]\n", "verify_points: " + "9" * 400 + "\n", "verify_points", "(400 characters)"),
    ("  design.amplification: [2.0]\n", "chunk_size: " + "9" * 30 + "\n", "chunk_size",
     "design points per chunk; at most 1000000"),
    ("  design.amplification: {start: 0.0, stop: 3, num: 3, scale: log}\n", "", "axes.design.amplification.start",
     "must be > 0 for scale: log"),
    ("  design.amplification: {start: 2, stop: .inf, num: 3}\n", "", "axes.design.amplification.stop", "finite"),
], ids=["num-400-digits", "verify-400-digits", "chunk-size-1e30", "log-through-0", "inf-stop"])
def test_sweep_spec_edges_are_refused_in_a_short_line(tmp_path, axes, more, field, contains):
    """H4."""
    spec = _sweep_spec(tmp_path, axes, more)
    _refused(["sweep", spec, "-o", tmp_path / "out"], field, contains)
    assert _files(tmp_path) == {"spec.yaml"}


def test_a_chunk_size_option_beyond_the_limit_names_the_option(tmp_path):
    from exotune.sweeps.spec import MAX_CHUNK_SIZE

    spec = _sweep_spec(tmp_path, "  design.amplification: [2.0]\n")
    _refused(["sweep", spec, "-o", tmp_path / "out", "--chunk-size", MAX_CHUNK_SIZE + 1], "--chunk-size",
             f"at most {MAX_CHUNK_SIZE}")
    assert _files(tmp_path) == {"spec.yaml"}


def test_a_descending_axis_is_swept_in_the_order_given(tmp_path):
    """start > stop is a valid axis: the values run from start to stop (reference: the
    arithmetic progression written out)."""
    from exotune.sweeps.spec import load_spec

    spec = _sweep_spec(tmp_path, "  design.amplification: {start: 8.0, stop: 2.0, num: 4}\n")
    values = load_spec(spec).spec["axes"]["design.amplification"]["values"]
    assert values == pytest.approx([8.0 - 2.0 * k for k in range(4)], rel=1e-15)


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    """Two finished sweeps of two chunks each: ``a`` (the one resumed) and ``b`` (another spec)."""
    from exotune.sweeps import run_sweep

    d = tmp_path_factory.mktemp("swept")
    out = {}
    for name, values in (("a", [2.0, 4.0, 6.0, 8.0]), ("b", [3.0, 5.0, 7.0, 9.0])):
        spec = d / f"{name}.yaml"
        spec.write_text(yaml.safe_dump({"base": str(PAPER), "axes": {"design.amplification": values},
                                        "chunk_size": 2}))
        run_sweep(spec, d / name, workers=1, progress=False)
        out[name] = (spec, d / name)
    return out


def _chunk(d: Path, i: int) -> Path:
    return d / "chunks" / f"part-{i:06d}.parquet"


def _copy_sweep(swept, tmp_path: Path) -> Path:
    d = tmp_path / "sweep"
    shutil.copytree(swept["a"][1], d)
    return d


def _snapshot(d: Path) -> dict:
    return {p: (p.lstat().st_mtime_ns, p.lstat().st_size) for p in d.rglob("*")}


@pytest.mark.parametrize("index", [2, 7])
def test_a_foreign_chunk_beyond_the_sweeps_chunks_is_refused_by_report_and_resume(swept, tmp_path, index):
    """H5: another sweep's chunk dropped into chunks/ under an index this sweep does not have was
    kept (report 0, resume 0): pandas.read_parquet(DIR/chunks) then read its rows with the sweep's."""
    import pyarrow.parquet as pq

    d = _copy_sweep(swept, tmp_path)
    stray = _chunk(d, index)
    shutil.copy(_chunk(swept["b"][1], 0), stray)
    mixed = pq.ParquetDataset(str(d / "chunks")).read().num_rows
    assert mixed == 6  # what a reader of the directory gets: the sweep's 4 rows and 2 foreign ones
    before = _snapshot(d)
    _refused(["report", d, "-o", tmp_path / "rep"], str(stray), "not a chunk of this sweep (it has 2 chunks",
             "remove it")
    assert not (tmp_path / "rep").exists()
    _refused(["sweep", swept["a"][0], "-o", d, "--workers", "1"], str(stray), "not a chunk of this sweep")
    assert _snapshot(d) == before


def test_a_directory_where_a_chunk_belongs_is_named_not_an_errno(swept, tmp_path):
    """H5: the resumed sweep failed the chunk (exit 1) with "FileExistsError: [Errno 17] … (a
    device, FIFO or socket)"; now both commands name the directory before any work."""
    d = _copy_sweep(swept, tmp_path)
    _chunk(d, 1).unlink()
    _chunk(d, 1).mkdir()
    before = _snapshot(d)
    for args in (["report", d, "-o", tmp_path / "rep"], ["sweep", swept["a"][0], "-o", d, "--workers", "1"]):
        _refused(args, str(_chunk(d, 1)), "a directory where chunk 1's file belongs", "remove it")
    assert _snapshot(d) == before and not (tmp_path / "rep").exists()


def test_other_files_in_the_chunks_directory_are_left_alone(swept, tmp_path):
    """Only files named like a chunk are strays; a note beside the chunks is not read."""
    d = _copy_sweep(swept, tmp_path)
    (d / "chunks" / "notes.txt").write_text("x\n")
    res, _ = _run(["report", d, "-o", tmp_path / "rep"])
    assert res.exit_code == 0, res.output


def test_a_manifest_with_a_foreign_checksum_is_still_refused_by_the_chunks_metadata(swept, tmp_path):
    """A foreign chunk copied in AND its checksum written into the manifest: the chunk's own
    metadata (spec hash) still tells; a resumed sweep recomputes it to the reference bytes."""
    from exotune.sweeps.integrity import sha256_file

    d = _copy_sweep(swept, tmp_path)
    shutil.copy(_chunk(swept["b"][1], 0), _chunk(d, 0))
    m = json.loads((d / "manifest.json").read_text())
    m["chunks"][0]["sha256"] = sha256_file(str(_chunk(d, 0)))
    (d / "manifest.json").write_text(json.dumps(m))
    _refused(["report", d, "-o", tmp_path / "rep"], str(_chunk(d, 0)), "holds rows of another sweep")
    res, _ = _run(["sweep", swept["a"][0], "-o", d, "--workers", "1"])
    assert res.exit_code == 0, res.output
    assert sha256_file(str(_chunk(d, 0))) == sha256_file(str(_chunk(swept["a"][1], 0)))


# -------------------------------------------------------------------------------- identify logs
def _log_columns(seed: int = 5) -> dict:
    from identification.simulated_logs import held_logs

    return {k: np.asarray(v, float) for k, v in held_logs(1, 1000.0, 3.0, seed0=seed)[0].items()}


def _write_log(path: Path, cols: dict, header=None) -> Path:
    names = list(cols)
    rows = zip(*(cols[n] for n in names))
    path.write_text(",".join(header or names) + "\n" + "".join(",".join(repr(float(x)) for x in r) + "\n" for r in rows))
    return path


@pytest.mark.parametrize("rename, field, contains", [
    (lambda n: f"{n} [s]" if n == "t" else n, "t [s]", "a column name carries no unit: name it t (its unit is fixed: s"),
    (lambda n: f"{n}(rad)" if n == "theta_m" else n, "theta_m(rad)", "name it theta_m (its unit is fixed: rad"),
    (lambda n: n.upper() if n == "tau_s" else n, "TAU_S", "did you mean tau_s?"),
], ids=["unit-in-brackets", "unit-in-parentheses", "upper-case"])
def test_a_header_with_units_or_another_case_is_named_as_such(tmp_path, rename, field, contains):
    """H6."""
    cols = _log_columns()
    log = _write_log(tmp_path / "log.csv", cols, header=[rename(n) for n in cols])
    _refused(["identify", log, "--delay-s", "0.001", "-o", tmp_path / "plant.yaml"], field, contains)
    assert _files(tmp_path) == {"log.csv"}


def test_columns_in_another_order_identify_the_same_plant(tmp_path):
    import exotune

    cols = _log_columns()
    a = exotune.identify(_write_log(tmp_path / "a.csv", cols), delay_s=0.001).to_dict()
    b = exotune.identify(_write_log(tmp_path / "b.csv", dict(reversed(list(cols.items())))), delay_s=0.001).to_dict()
    assert set(a["parameters"]) == set(b["parameters"]) and len(a["parameters"]) == 5
    for k, p in a["parameters"].items():
        assert b["parameters"][k]["value"] == pytest.approx(p["value"], rel=1e-12), k


def _drifting(cols: dict, drift: float) -> dict:
    """The log with its step growing linearly by the fraction ``drift`` from the first to the last."""
    t = cols["t"]
    n, dt = t.size, float(np.mean(np.diff(t)))
    out = dict(cols)
    out["t"] = t[0] + np.concatenate([[0.0], np.cumsum(dt * (1.0 + drift * np.arange(n - 1) / (n - 1)))])
    return out


def _samples_off_a_line(t: np.ndarray) -> float:
    """Independent reference: the largest distance of a stamp from the least-squares line, in steps."""
    k = np.arange(t.size)
    slope, icept = np.polyfit(k, t, 1)
    return float(np.max(np.abs(t - (slope * k + icept))) / slope)


def test_a_drifting_sample_rate_is_refused_naming_t(tmp_path):
    """H6: steps growing by 20 % over the log (each within 10 % of the median) passed the step
    check; the late samples are tens of samples from where a constant rate puts them."""
    from exotune.identification.data import DRIFT

    cols = _drifting(_log_columns(), 0.2)
    steps = np.diff(cols["t"])
    assert np.all(np.abs(steps - np.median(steps)) <= 0.1 * np.median(steps))  # the step check alone passes
    assert _samples_off_a_line(cols["t"]) > 10 * DRIFT
    log = _write_log(tmp_path / "log.csv", cols)
    _refused(["identify", log, "--delay-s", "0.001", "-o", tmp_path / "plant.yaml"], "t",
             "the sample rate drifts", "a constant rate is needed")
    assert _files(tmp_path) == {"log.csv"}


def test_a_drift_within_the_tolerance_and_a_given_rate_pass_the_time_check():
    from exotune.identification.data import DRIFT, log_from_columns

    cols = _log_columns()
    small = _drifting(cols, 2e-4)
    assert _samples_off_a_line(small["t"]) < DRIFT
    log = log_from_columns(small, delay_s="auto")
    assert log.sample_rate_hz == pytest.approx(1000.0, rel=1e-3)
    drifting = _drifting(cols, 0.2)  # the time stamps drift, the rate is given: the stamps are not used
    assert log_from_columns(drifting, delay_s="0.001", sample_rate_hz=1000.0).sample_rate_hz == 1000.0


@pytest.mark.parametrize("n, said", [(1, "1 sample: at least"), (2, "2 samples: at least"), (0, "0 samples: at least")])
def test_a_log_of_one_sample_is_refused_in_words(tmp_path, n, said):
    cols = {k: v[:n] for k, v in _log_columns().items()}
    log = _write_log(tmp_path / "log.csv", cols)
    _refused(["identify", log, "--delay-s", "0.001", "-o", tmp_path / "plant.yaml"], "t", said)
    assert _files(tmp_path) == {"log.csv"}
