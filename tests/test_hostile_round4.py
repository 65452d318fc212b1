"""Hostile inputs, round 4: messages and file integrity of the single-file commands.

Each regression runs the command line in-process (click's CliRunner) and asserts the error
contract: exit code 2, the field named as the user wrote it (option or file key path), the reason,
no traceback, nothing written. The sweep-directory findings are in
tests/sweeps/test_hostile_round4_sweeps.py.

* F7  an output path longer than PATH_MAX: refused up front naming ``-o``, no directory made;
  the atomic writer removes the parents it made when the write fails.
* F10 an inconclusive minimum-phase verdict of C6/C5 reads "unknown", not "NO".
* F12 pydantic's wording ("Input should be a valid string") mapped to exotune's.
* F13 a refused value printed with the digits that show why (10000.0000001, not 10000, beside
  the range [1, 1e4]).
* F14 ``--require-latency-margin-s`` bounded to the accepted delays [0, 1] s.
* F18 terminal escapes in the user's strings (file keys, file names, JSON strings) shown escaped.
* F20 a file with 5 000 unknown keys: ten problems listed, then how many more.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
import yaml
from click.testing import CliRunner

from exotune.cli import cli
from exotune.config.validate import LIMITS
from exotune.errors import MAX_MORE_LINES, printable
from exotune.jsonio import dumps, write_atomic
from exotune.options import MAX_LATENCY_REQUIREMENT_S
from exotune.text.analysis import format_report

ROOT = Path(__file__).resolve().parents[1]
PAPER = ROOT / "examples" / "paper.yaml"
SCHEDULED = ROOT / "examples" / "scheduled.yaml"


def _run(args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def _refused(res, field: str, *contains: str) -> str:
    """Exit 2, one first line ``exotune: error: <field>: …`` holding ``contains``, no traceback."""
    assert res.exit_code == 2, (res.exit_code, res.output, res.exception)
    first = res.stderr.splitlines()[0]
    assert first.startswith(f"exotune: error: {field}: "), first
    for c in contains:
        assert c in first, first
    assert "Traceback" not in res.output and "Traceback" not in res.stderr
    return first


def _design(tmp_path: Path, edit, name: str = "design.yaml") -> Path:
    d = yaml.safe_load(PAPER.read_text(encoding="utf-8"))
    edit(d)
    p = tmp_path / name
    p.write_text(yaml.safe_dump(d, allow_unicode=True, sort_keys=False), encoding="utf-8")
    return p


def _files(d: Path) -> set[str]:
    return {os.path.relpath(os.path.join(r, n), d) for r, ds, ns in os.walk(d) for n in ds + ns}


# --------------------------------------------------------------------------------------- F7
def test_an_output_path_longer_than_path_max_is_refused_naming_the_option(tmp_path):
    """`export -o <5 000 characters of nested directories>` made 20 directories and then failed
    with a bare "File name too long"; the API raised an OSError. Now the path is refused before
    any work, naming -o and both lengths, and nothing is made."""
    deep = tmp_path / "x" / "/".join(["d" * 200] * 25) / "controller.yaml"
    assert len(os.fsencode(str(deep))) > os.pathconf(tmp_path, "PC_PATH_MAX")
    before = _files(tmp_path)
    first = _refused(_run(["export", SCHEDULED, "--sample-rate-hz", "1000", "-o", deep]), "-o",
                     "the path is too long for the file system", f"{len(os.fsencode(str(deep)))} bytes")
    assert len(first) < 400
    assert _files(tmp_path) == before  # no parent directory left behind


def test_the_atomic_writer_removes_the_parents_it_made_when_the_write_fails(tmp_path):
    """The library writer (every output goes through it) made the missing parents with
    os.makedirs and left them when the file could not be written."""
    deep = tmp_path / "y" / "/".join(["d" * 200] * 25) / "out.txt"
    with pytest.raises(OSError) as e:
        write_atomic(deep, "text")
    assert e.value.filename == str(deep)  # the destination named, not a temporary file
    assert not (tmp_path / "y").exists()


# -------------------------------------------------------------------------------------- F10
def _report(amplification: dict) -> str:
    """The analyze text of a minimal result with this amplification entry."""
    r = {"model": "m", "delay_s": 0.001, "structure": "default", "gains": {}, "units": {},
         "free_stable": True, "free": {"rigid_body_roots": 1}, "locked_stable": True, "environment": [],
         "humans": [], "passivity": {"max_phase_excess_deg": 0.0, "nonpassive_band_hz": []}, "dob": None,
         "amplification": amplification, "J_m_hat_over_J_j": 6.9, "warnings": []}
    return format_report(r)


def test_an_inconclusive_minimum_phase_verdict_is_unknown_not_no():
    """The zero count of C6/C5 undecided (motor_damping 1e7 N·m·s/rad: AmplificationBatch.conclusive
    False) printed "minimum phase NO" — a verdict never made."""
    line = next(x for x in _report({"dc": 8.0, "bandwidth_hz": 0.32, "minimum_phase": False,
                                    "conclusive": False}).splitlines() if x.startswith("Amplification"))
    assert line.endswith("minimum phase: unknown (root count inconclusive)") and "NO" not in line
    decided = {False: "minimum phase NO", True: "minimum phase yes"}
    for mp, text in decided.items():
        for extra in ({}, {"conclusive": True}):  # a result without the flag reads as before
            out = _report({"dc": 8.0, "bandwidth_hz": 5.5, "minimum_phase": mp, **extra})
            assert text in out and "unknown" not in out


# -------------------------------------------------------------------------------------- F12
@pytest.mark.parametrize("value, kind", [(5, "the number 5"), ([1, 2], "a list"), ({"a": 1}, "a mapping"),
                                         (True, "a boolean")])
def test_a_wrong_type_reads_in_exotunes_wording_not_pydantics(tmp_path, value, kind):
    """`requirements.source: 5` read "Input should be a valid string" (pydantic's sentence)."""
    p = _design(tmp_path, lambda d: d.update(requirements={"latency_margin_s": 0.001, "source": value}))
    res = _run(["design", p])
    _refused(res, "requirements.source", f"expected a string, got {kind}")
    assert "Input should" not in res.stderr


def test_a_controller_file_error_reads_in_exotunes_wording(tmp_path):
    """A quoted number in a controller file read "Input should be a valid number"."""
    p = tmp_path / "controller.yaml"
    p.write_text("schema: exotune.controller/1\nsample_rate_hz: {value: '1000', unit: Hz}\n", encoding="utf-8")
    res = _run(["certify", p])
    _refused(res, "sample_rate_hz.value", "expected a number, got the string '1000'", "remove the quotes")
    assert "Input should" not in res.stderr


# -------------------------------------------------------------------------------------- F13
@pytest.mark.parametrize("section, key, value, bound", [
    ("design", "amplification", 10000.0000001, "[1, 1e4]"),
    ("design", "zeta", 1000.0001, "[0.001, 1000]"),
    ("implementation", "delay_s", 1.0000000001, "[0, 1] s"),
    ("design", "amplification", 0.99999999, "must be >= 1"),
])
def test_a_refused_value_is_printed_with_the_digits_that_show_why(tmp_path, section, key, value, bound):
    """10000.0000001 printed as "10000" beside the range [1, 1e4] read as a contradiction."""
    p = _design(tmp_path, lambda d: d[section].update({key: value}))
    first = _refused(_run(["design", p]), f"{section}.{key}", bound)
    shown = first.rsplit("got ", 1)[1].split(" ")[0]
    assert float(shown) == value  # the exact value: visibly out of the range


def test_a_value_far_out_keeps_its_short_form(tmp_path):
    p = _design(tmp_path, lambda d: d["design"].update(amplification=2e4))
    _refused(_run(["design", p]), "design.amplification", "got 20000 ")


def test_a_sweep_axis_value_just_out_of_range_is_printed_exactly(tmp_path):
    spec = tmp_path / "spec.yaml"
    spec.write_text(yaml.safe_dump({"base": str(PAPER), "axes": {"design.amplification": [2.0, 10000.0000001]}}))
    _refused(_run(["sweep", spec, "-o", tmp_path / "out"]), "axes.design.amplification",
             "value 10000.0000001 at index 1", "[1, 1e4]")
    assert not (tmp_path / "out").exists()


# -------------------------------------------------------------------------------------- F14
@pytest.mark.parametrize("text", ["1e308", "1.0000001", "-1", "2"])
def test_a_latency_requirement_beyond_the_accepted_delays_is_refused(tmp_path, text):
    """`--require-latency-margin-s 1e308` was written into the controller file ("required inf
    ms"): no analysis checks an extra delay beyond the accepted delays [0, 1] s."""
    out = tmp_path / "c.yaml"
    _refused(_run(["export", SCHEDULED, "-o", out, "--require-latency-margin-s", text]), "--require-latency-margin-s",
             "must be in [0, 1] s", repr(text))
    assert _files(tmp_path) == set()


def test_the_requirement_bound_is_the_accepted_range_of_delays():
    lo, lo_open, hi, unit = LIMITS["delay"]
    assert (lo, lo_open, unit) == (0.0, False, "s") and MAX_LATENCY_REQUIREMENT_S == hi


# -------------------------------------------------------------------------------------- F18
OSC = "\x1b]0;PWNED\x07"  # retitles a terminal
CSI = "\x1b[2J"  # clears it
C1 = "\x9b31m"  # an 8-bit CSI
RLO = "\u202e"  # right-to-left override


def _raw_controls(text: str) -> list[str]:
    return [c for c in (OSC, CSI, "\x1b", "\x07", "\x9b", RLO) if c in text]


def test_terminal_escapes_in_a_key_are_shown_escaped_in_the_error(tmp_path):
    p = _design(tmp_path, lambda d: d.update({f"{OSC}{CSI}{C1}{RLO}key": 1}))
    res = _run(["design", p])
    first = _refused(res, printable(f"{OSC}{CSI}{C1}{RLO}key"), "unknown key")
    assert first.startswith("exotune: error: \\x1b]0;PWNED\\x07\\x1b[2J\\x9b31m\\u202ekey: ")
    assert not _raw_controls(res.stderr)


def test_terminal_escapes_in_a_file_name_are_shown_escaped_in_the_report(tmp_path):
    p = _design(tmp_path, lambda d: None, name=f"{OSC}{RLO}design.yaml")
    res = _run(["design", p])
    assert res.exit_code == 0, res.output
    head = res.stdout.splitlines()[0]
    assert head.endswith("\\x1b]0;PWNED\\x07\\u202edesign.yaml") and not _raw_controls(res.stdout)
    res = _run(["design", p, "--json"])
    assert res.exit_code == 0 and not _raw_controls(res.stdout)
    assert json.loads(res.stdout)["source"].endswith(f"{OSC}{RLO}design.yaml")  # the same JSON value


def test_json_escapes_the_control_characters_it_used_to_keep():
    text = dumps({"s": f"a{C1}\x7f{RLO}≤"})
    assert not _raw_controls(text) and "\x7f" not in text and "≤" in text
    assert json.loads(text) == {"s": f"a{C1}\x7f{RLO}≤"}


def test_terminal_escapes_in_the_analyze_text_are_escaped():
    """A design's requirements.source is quoted by analyze's text: its controls escaped there too."""
    out = format_report({"model": f"m {OSC}", "delay_s": 0.001, "structure": "default", "gains": {}, "units": {},
              "free_stable": True, "free": {"rigid_body_roots": 1}, "locked_stable": True, "environment": [],
              "humans": [], "passivity": {"max_phase_excess_deg": 0.0, "nonpassive_band_hz": []}, "dob": None,
              "amplification": {"dc": 8.0, "bandwidth_hz": 5.0, "minimum_phase": True}, "J_m_hat_over_J_j": 6.9,
              "warnings": [f"from {CSI}{RLO}"]})
    assert not _raw_controls(out) and "\\x1b]0;PWNED\\x07" in out and "\n" in out


# -------------------------------------------------------------------------------------- F20
def test_five_thousand_unknown_keys_list_ten_problems_and_count_the_rest(tmp_path):
    p = _design(tmp_path, lambda d: d.update({f"u{i}": i for i in range(5000)}))
    res = _run(["design", p])
    _refused(res, "u0", "unknown key")
    lines = res.stderr.strip().splitlines()
    assert len(lines) == MAX_MORE_LINES + 1 == 11
    assert lines[1].startswith("u1: unknown key") and lines[9].startswith("u9: unknown key")
    assert lines[-1] == "… and 4 990 more problems"


def test_a_few_problems_are_all_listed(tmp_path):
    p = _design(tmp_path, lambda d: d.update({f"u{i}": i for i in range(MAX_MORE_LINES)}))
    lines = _run(["design", p]).stderr.strip().splitlines()
    assert len(lines) == MAX_MORE_LINES and not any("more problems" in x for x in lines)


def test_library_text_views_escape_terminal_controls_too():
    """The command line escaped control characters from files, but `to_text()` from Python returned
    them raw in the verdicts' requirement source and the SEA report's source."""
    import exotune
    from exotune.text.verdicts import format_verdicts

    r = exotune.analyze("examples/scheduled.yaml")
    sd = r.to_dict()["sampled_data"]
    sd["requirements"]["source"] = "evil \x1b]0;pwned\x07 source"
    text = "\n".join(format_verdicts(sd))
    assert "\x1b" not in text and "\x07" not in text and "\\x1b" in text
