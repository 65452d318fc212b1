"""Hostile inputs, round 5: the newer commands (identify, excite, simulate, init) and the library's
text views.

Each regression runs the command line in-process (click's CliRunner) and asserts the error
contract of docs/cli.md: exit code 2, one first line ``exotune: error: <field>: <reason>`` naming
the field (option, file key or path as given) and the reason, no traceback, no RuntimeWarning,
nothing written. Earlier rounds: tests/test_hostile_inputs.py, tests/test_hostile_round4.py,
tests/test_fuzz_regressions.py.

* G1  a CSV log with a field longer than the csv module's limit (131 072 characters): a raw
  ``_csv.Error`` traceback.
* G2  time stamps 1e300 s apart: an ``overflow encountered in dot`` RuntimeWarning, and a step
  printed as ∞ s.
* G3  a log cell ``1_0`` read as 10 (Python's float), where a design file refuses ``1_000``.
* G4  ``excite --duration-s 1e308`` with a short period: an OverflowError traceback; with a long
  one, a 309-digit period count in the message.
* G5  a 400- or 5 000-digit integer option: click's "is not a valid integer range", the value
  echoed whole (5 000 characters), a 400-digit seed accepted; a 5 000-character number or choice
  echoed whole.
* G6  an empty input path printed no field (``exotune: error: cannot read file: …``); a NUL in an
  input or output path printed only ``embedded null byte``.
* G7  ``init ''`` wrote into the current directory and printed ``next: exotune analyze
  /design.yaml``; a failed write left the first templates behind.
* G8  ``--fix motor_inertia`` (no ``=VALUE``) read ``motor_inertia=None: the value must be a number``.
* G9  ``simulate --joint-angle 2.0000000000000004`` read "2 rad is outside … [0, 2] rad".
* G10 ``simulate``/``export`` of an SEA file without a rate asked for ``--sample-rate-hz``.
* G11 ``to_text()``/``summary()`` of export, identify (and its validation) and excite returned a
  user's file name with its terminal controls raw (the command line escaped them; the library
  did not).
* G12 a design with a 100-angle transmission table exported a 1.2 MB controller file that
  ``certify`` (and ``simulate``, ``codegen``) refused to read: "too large (… the limit is 1 MiB)".
  The table is now bounded (``MAX_SCHEDULE_ENTRIES``) and the reader's limits hold the largest
  file that bound allows.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from cli_refusal import files, refused, run

ROOT = Path(__file__).resolve().parents[1]
SCHEDULED = ROOT / "examples" / "scheduled.yaml"
SEA = ROOT / "examples" / "sea.yaml"
OSC = "\x1b]0;PWNED\x07"  # retitles a terminal
RLO = "\u202e"  # right-to-left override
EXCITE = ["excite", "--sample-rate-hz", "1000", "--f-lo-hz", "1", "--f-hi-hz", "10", "--rms-nm", "1"]


_run, _refused, _files = run, refused, files


def _log(path: Path, seed: int = 5) -> Path:
    """A held-command log at 1 kHz, 3 s, one sample of delay (tests/identification/simulated_logs.py)."""
    from identification.simulated_logs import held_logs

    cols = held_logs(1, 1000.0, 3.0, seed0=seed)[0]
    names = list(cols)
    path.write_text(",".join(names) + "\n" + "".join(",".join(repr(float(x)) for x in r) + "\n"
                                                     for r in zip(*(cols[n] for n in names))))
    return path


def _edited_log(tmp_path: Path, edit) -> Path:
    """The log with its rows (lists of cells, the header first) edited by ``edit``."""
    rows = [r.split(",") for r in _log(tmp_path / "src.csv").read_text().splitlines()]
    edit(rows)
    p = tmp_path / "log.csv"
    p.write_text("\n".join(",".join(r) for r in rows) + "\n")
    (tmp_path / "src.csv").unlink()
    return p


# ---------------------------------------------------------------------------------------- G1
def test_a_log_field_beyond_the_csv_limit_is_refused_naming_the_line(tmp_path):
    p = _edited_log(tmp_path, lambda rows: rows[0].append("x" * 200_000))
    before = _files(tmp_path)
    _refused(["identify", p, "--delay-s", "0.001", "-o", tmp_path / "plant.yaml"], f"{p}:1", "not a CSV log",
             "field larger than field limit")
    assert _files(tmp_path) == before


# ---------------------------------------------------------------------------------------- G2
def test_time_stamps_1e300_apart_are_refused_without_an_overflow_warning(tmp_path):
    def stamps(rows):
        for i, r in enumerate(rows[1:]):
            r[0] = repr(i * 1e300)

    p = _edited_log(tmp_path, stamps)
    _refused(["identify", p, "--delay-s", "0.001"], "t", "a step of 1e+300 s is a sample rate of 1e-300 Hz",
             "is t in seconds?")


# ---------------------------------------------------------------------------------------- G3
@pytest.mark.parametrize("cell", ["1_0", "\u0661\u0660"])  # '1_0' and Arabic-Indic '10': float() reads 10
def test_a_log_cell_is_read_as_a_design_file_reads_numbers(tmp_path, cell):
    p = _edited_log(tmp_path, lambda rows: rows[101].__setitem__(1, cell))
    first = _refused(["identify", p, "--delay-s", "0.001"], f"{p}:102", f"theta_m = {cell!r} is not a number",
                     "no '_'")
    assert "theta_m" in first


# ---------------------------------------------------------------------------------------- G4
@pytest.mark.parametrize("f_lo, f_hi", [("100", "200"), ("1", "10")], ids=["short-period", "long-period"])
def test_an_absurd_excitation_duration_is_refused_in_a_short_line(tmp_path, f_lo, f_hi):
    args = ["excite", "-o", tmp_path / "exc.csv", "--sample-rate-hz", "1000", "--f-lo-hz", f_lo, "--f-hi-hz", f_hi,
            "--rms-nm", "1", "--duration-s", "1e308"]
    _refused(args, "--duration-s", "1e+308 s at 1000 Hz is more than 10000000 samples")
    assert _files(tmp_path) == set()


def test_a_huge_period_count_from_the_api_is_named_in_its_short_form(tmp_path):
    import exotune
    from exotune.errors import ConfigError

    with pytest.raises(ConfigError) as e:
        exotune.excite(tmp_path / "exc.csv", sample_rate_hz=1000, f_lo_hz=1, f_hi_hz=10, rms_nm=1, periods=10**5000)
    assert e.value.field == "periods" and "about 10^5000 periods" in e.value.reason and len(str(e.value)) < 200
    assert _files(tmp_path) == set()


# ---------------------------------------------------------------------------------------- G5
@pytest.mark.parametrize("digits", [400, 5000])
@pytest.mark.parametrize("option, extra", [("--periods", []), ("--seed", ["--lines", "random-odd"])])
def test_a_many_digit_integer_option_is_refused_with_an_excerpt(tmp_path, digits, option, extra):
    first = _refused(EXCITE + ["-o", tmp_path / "exc.csv", option, "9" * digits, *extra], option, "is too large",
                     f"({digits} characters)")
    assert "valid integer range" not in first
    assert _files(tmp_path) == set()


def test_a_many_digit_number_option_is_quoted_as_an_excerpt():
    _refused(["simulate", SCHEDULED, "--scenario", "light-mass", "--duration", "9" * 5000], "--duration",
             "must be a finite number", "(5000 characters)", "beyond the largest floating-point number")


def test_a_long_choice_value_is_quoted_as_an_excerpt():
    _refused(["simulate", SCHEDULED, "--scenario", "x" * 5000], "--scenario", "characters) is not one of")


# ---------------------------------------------------------------------------------------- G6
@pytest.mark.parametrize("command", [["design"], ["certify"], ["simulate", "--scenario", "light-mass"], ["identify"]])
def test_an_empty_input_path_is_named(command):
    _refused([command[0], "", *command[1:]], "''", "an empty path")


@pytest.mark.parametrize("args, field", [
    (["certify", "a\x00b"], "a\\x00b"),
    (["identify", "a\x00b"], "a\\x00b"),
    (["sweep", "a\x00b", "-o", "{t}/sweep"], "a\\x00b"),
    (["optimize", "a\x00b", "-o", "{t}/o.yaml"], "a\\x00b"),
    (["export", str(SCHEDULED), "-o", "{t}/a\x00b"], "-o"),
    (["design", str(SCHEDULED), "--plots", "{t}/a\x00b"], "--plots"),
    (["excite", "-o", "{t}/a\x00b", *EXCITE[1:]], "-o"),
    (["init", "{t}/a\x00b"], "directory"),
], ids=["certify", "identify", "sweep", "optimize", "export-o", "design-plots", "excite-o", "init"])
def test_a_nul_in_a_path_is_named(tmp_path, args, field):
    args = [a.replace("{t}", str(tmp_path)) for a in args]
    _refused(args, field, "a path cannot contain a NUL character")
    assert _files(tmp_path) == set()


def test_a_nul_in_a_specs_base_path_is_named(tmp_path):
    spec = tmp_path / "spec.yaml"
    spec.write_text('base: "a\\0b"\naxes:\n  design.amplification: [2.0]\n')
    _refused(["sweep", spec, "-o", tmp_path / "out"], f"base ({tmp_path}{os.sep}a\\x00b)",
             "a path cannot contain a NUL character")
    assert _files(tmp_path) == {"spec.yaml"}


# ---------------------------------------------------------------------------------------- G7
def test_init_refuses_an_empty_directory(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    _refused(["init", ""], "directory", "an empty path")
    assert _files(tmp_path) == set()


def test_init_writes_all_templates_or_none(tmp_path, monkeypatch):
    """A full disk on the second template left the first one (and the new directories) behind."""
    import errno

    real, calls = Path.write_text, []

    def write_text(self, *a, **k):
        calls.append(self)
        if len(calls) > 1:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(self))
        return real(self, *a, **k)

    monkeypatch.setattr(Path, "write_text", write_text)
    target = tmp_path / "new" / "dir"
    _refused(["init", target], str(target), "cannot write output: No space left on device")
    assert _files(tmp_path) == set()


# ---------------------------------------------------------------------------------------- G8
def test_a_fixed_parameter_without_a_value_is_named_as_such(tmp_path):
    first = _refused(["identify", _log(tmp_path / "log.csv"), "--delay-s", "0.001", "--fix", "motor_inertia"],
                     "--fix", "'motor_inertia' has no value: give it as NAME=VALUE")
    assert "None" not in first


# ---------------------------------------------------------------------------------------- G9
def test_a_joint_angle_just_beyond_the_schedule_is_printed_with_its_digits():
    first = _refused(["simulate", SCHEDULED, "--scenario", "light-mass", "--joint-angle", "2.0000000000000004"],
                     "--joint-angle", "2.0000000000000004 rad is outside the gain schedule's joint angles [0, 2] rad")
    assert " 2 rad is outside" not in first


# --------------------------------------------------------------------------------------- G10
@pytest.mark.parametrize("args", [["simulate", SEA, "--scenario", "light-mass"], ["export", SEA, "-o", "{t}/c.yaml"]],
                         ids=["simulate", "export"])
def test_an_sea_file_is_named_as_one_without_a_rate(tmp_path, args):
    args = [str(a).replace("{t}", str(tmp_path)) for a in args]
    first = _refused(args, str(SEA), "this is an SEA file: use `exotune sea")
    assert "--sample-rate-hz" not in first
    assert _files(tmp_path) == set()


# --------------------------------------------------------------------------------------- G11
def _raw_controls(text: str) -> list[str]:
    return [c for c in ("\x1b", "\x07", RLO) if c in text]


def test_library_text_views_of_identify_and_excite_escape_file_names(tmp_path):
    import exotune

    d = tmp_path / f"{OSC}{RLO}"
    d.mkdir()
    log, other = _log(d / f"log{OSC}.csv"), _log(d / f"val{OSC}.csv", seed=7)
    r = exotune.identify(log, delay_s=0.001, validate=other)
    for text in (r.to_text(), r.validation.to_text()):
        assert not _raw_controls(text) and "\\x1b]0;PWNED\\x07" in text and "\n" in text
    e = exotune.excite(d / f"exc{OSC}.csv", sample_rate_hz=1000, f_lo_hz=1, f_hi_hz=10, rms_nm=1, periods=2)
    assert not _raw_controls(e.to_text()) and "\\x1b]0;PWNED\\x07" in e.to_text()
    assert e.path == str(d / f"exc{OSC}.csv")  # the data keep the name as it is


def test_library_export_summary_escapes_the_output_name(tmp_path):
    import yaml

    import exotune

    design = yaml.safe_load(SCHEDULED.read_text(encoding="utf-8"))
    del design["transmission"]  # one controller: a faster export
    src = tmp_path / "design.yaml"
    src.write_text(yaml.safe_dump(design, sort_keys=False), encoding="utf-8")
    c = exotune.export(src, 1000.0, tmp_path / f"c{OSC}{RLO}.yaml")
    line = c.summary()
    assert not _raw_controls(line) and "c\\x1b]0;PWNED\\x07\\u202e.yaml" in line


# --------------------------------------------------------------------------------------- G12
def test_a_transmission_table_longer_than_the_bound_is_refused(tmp_path):
    import yaml

    from exotune.config.schema import MAX_SCHEDULE_ENTRIES

    d = yaml.safe_load(SCHEDULED.read_text(encoding="utf-8"))
    n = MAX_SCHEDULE_ENTRIES + 1
    d["transmission"] = {"joint_angle_rad": [0.005 * i for i in range(n)], "ratio": [1.0] * n}
    p = tmp_path / "design.yaml"
    p.write_text(yaml.safe_dump(d, sort_keys=False), encoding="utf-8")
    _refused(["design", p], "transmission.joint_angle_rad", f"at most {MAX_SCHEDULE_ENTRIES} joint angles, got {n}")


def _values(o) -> int:
    """The YAML nodes of a loaded document (a mapping's keys counted), as the reader counts them."""
    if isinstance(o, dict):
        return 1 + sum(1 + _values(v) for v in o.values())
    if isinstance(o, list):
        return 1 + sum(_values(v) for v in o)
    return 1


def test_the_reader_holds_the_largest_controller_file_a_design_may_export(tmp_path):
    """Two exports of the costliest kind of entry (float32 realizations, a velocity filter), with 2
    and 4 schedule entries, give the size of one entry (about 14 kB, 770 values); a file of the
    most entries a design may have, with 50 % to spare (inconclusive cells listed per family), is
    within the reader's limits."""
    import yaml

    import exotune
    from exotune.config.schema import MAX_SCHEDULE_ENTRIES
    from exotune.config.yamlio import MAX_YAML_BYTES, MAX_YAML_NODES, read_yaml

    d = yaml.safe_load(SCHEDULED.read_text(encoding="utf-8"))
    d["implementation"].update(precision="float32", velocity_filter={"cutoff_hz": 200.0})
    size, nodes = {}, {}
    for n in (2, 4):
        d["transmission"] = {"joint_angle_rad": [0.5 * i for i in range(n)], "ratio": [0.85 + 0.1 * i for i in range(n)]}
        src, out = tmp_path / f"d{n}.yaml", tmp_path / f"c{n}.yaml"
        src.write_text(yaml.safe_dump(d, sort_keys=False), encoding="utf-8")
        exotune.export(src, 1000.0, out, allow_uncertified=True)
        size[n], nodes[n] = out.stat().st_size, _values(read_yaml(out))
    per_entry, per_entry_nodes = (size[4] - size[2]) / 2, (nodes[4] - nodes[2]) / 2
    assert 10e3 < per_entry < 30e3 and 500 < per_entry_nodes < 2000  # the measurement itself is sane
    largest = size[2] + 1.5 * per_entry * (MAX_SCHEDULE_ENTRIES - 2)
    assert largest < MAX_YAML_BYTES, (largest, MAX_YAML_BYTES)
    assert nodes[2] + 1.5 * per_entry_nodes * (MAX_SCHEDULE_ENTRIES - 2) < MAX_YAML_NODES


def test_a_controller_file_over_the_old_limit_is_read(tmp_path):
    """1.2 MB of YAML (a 100-entry schedule's size) was refused at 1 MiB."""
    from exotune.config.yamlio import read_yaml

    p = tmp_path / "big.yaml"
    p.write_text("notes:\n" + "".join(f"  - '{i} {'x' * 1200}'\n" for i in range(1000)), encoding="utf-8")
    assert p.stat().st_size > 1.2e6
    assert len(read_yaml(p)["notes"]) == 1000


@pytest.mark.parametrize("value, named", [("!!set {a, b}", "a set (YAML !!set)"),
                                          ("!!binary aGVsbG8=", "binary data (YAML !!binary)"),
                                          ("2001-12-14", "a date (an unquoted YAML timestamp: quote it)")])
def test_controller_file_schema_of_an_odd_yaml_type_is_named_not_repred(tmp_path, value, named):
    """A YAML set, binary or timestamp where the schema string belongs is named in words (the
    message printed Python reprs: {'a', 'b'}, b'hello', datetime.date(2001, 12, 14))."""
    from click.testing import CliRunner

    from exotune.cli import cli

    f = tmp_path / "c.yaml"
    f.write_text(f"schema: {value}\n")
    res = CliRunner().invoke(cli, ["certify", str(f)])
    assert res.exit_code == 2 and "Traceback" not in res.output
    assert f"schema: must be 'exotune.controller/1', got {named}" in res.output
    assert "datetime" not in res.output and "b'" not in res.output and "{'" not in res.output


def test_library_views_of_codegen_and_report_neutralize_escapes(tmp_path):
    """The library's to_text() of codegen and report results shows an ESC in a directory name
    escaped, as the command line does."""
    from exotune.controllerfile.results import GeneratedC
    from exotune.sweeps.result import SweepReport
    from pathlib import Path

    d = Path("dir\x1b]0;x\x07")
    g = GeneratedC(directory=d, files=("a.h", "a.c", "t.c"), controllers=1, sections=3, flags="-O2",
                   sha256="0" * 64, certified=True)
    assert "\x1b" not in g.to_text() and "\\x1b" in g.to_text()
    r = SweepReport(directory=d, maps=(), missing_chunks=(), running=False, sweep_dir=None)
    assert "\x1b" not in r.to_text() and "\\x1b" in r.to_text()
