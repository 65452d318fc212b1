"""The C99 port of the runtime (exotune.controllerfile.ccode, ``exotune codegen``), checked against
the reference runtime: compiled with the machine's C compiler, the port's golden test passes, and a
harness driven with random inputs, a clamp, gain-schedule entries and faults gives the reference
runtime's outputs (to rounding: no assertion depends on the exact bits a compiler produces)."""

from __future__ import annotations

import copy
import hashlib
import math
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from exotune.cli import cli
from exotune.config import read_yaml
from exotune.controllerfile import (Runtime, SosFilter, build_export, c_sources, design_at_rate, export_design,
                                   write_controller)
from exotune.controllerfile.ccode import C_FLAGS
from exotune.controllerfile.cgolden import golden_rows
from exotune.errors import ConfigError

ROOT = Path(__file__).resolve().parents[2]
CC = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
needs_cc = pytest.mark.skipif(CC is None, reason="no C compiler on this machine")

HARNESS = r"""
#include <stdio.h>
#include <stdlib.h>
#include "exotune_controller.h"
/* stdin: "angle A" lines (print the controller for A) or "run C L N" then N rows of 5 inputs */
int main(void)
{
    char word[16];
    while (scanf("%15s", word) == 1) {
        if (word[0] == 'a') {
            char t[64];
            int c = -7, rc;
            if (scanf("%63s", t) != 1) return 3;
            rc = exotune_controller_for_angle(strtod(t, 0), &c);
            printf("%d %d\n", rc, c);
        } else {
            int c, n, k;
            double lim;
            exotune_state st;
            if (scanf("%d %lf %d", &c, &lim, &n) != 3) return 3;
            printf("%d\n", exotune_init(&st, c, lim));
            for (k = 0; k < n; ++k) {
                char t[5][64];
                exotune_inputs y;
                double u = 0.0;
                int rc;
                if (scanf("%63s %63s %63s %63s %63s", t[0], t[1], t[2], t[3], t[4]) != 5) return 3;
                y.theta_m = strtod(t[0], 0); y.omega_m = strtod(t[1], 0); y.tau_s = strtod(t[2], 0);
                y.dtau_s = strtod(t[3], 0); y.tau_c = strtod(t[4], 0);
                rc = exotune_step(&st, &y, &u);
                printf("%d %.17g\n", rc, u);
            }
        }
    }
    return 0;
}
"""

SIGNALS = ("theta_m", "omega_m", "tau_s", "dtau_s", "tau_c")


@pytest.fixture(scope="module")
def scheduled():
    """examples/scheduled.yaml at 1 kHz: a DOB, a velocity filter and five gain-schedule entries."""
    raw = read_yaml(ROOT / "examples" / "scheduled.yaml")
    return build_export(design_at_rate(raw, 1000.0), 1000.0, analyses=False)


def _compile(tmp: Path, doc: dict, extra: dict[str, str], main: str) -> Path:
    for name, text in {**c_sources(doc), **extra}.items():
        (tmp / name).write_text(text, encoding="utf-8")
    exe = tmp / "a.out"
    cmd = [CC, *C_FLAGS.split(), "-Wall", "-Wextra", "-pedantic", "-Werror", "-o", str(exe),
           str(tmp / "exotune_controller.c"), str(tmp / main), "-lm"]
    subprocess.run(cmd, check=True, capture_output=True, text=True)
    return exe


def test_coefficients_are_the_files_doubles(scheduled):
    """Every coefficient literal of the port parses back to the file's double (no compiler needed)."""
    src = c_sources(scheduled)["exotune_controller.c"]
    block = src.split("SECTIONS[")[1].split("};")[0]
    rows = [[float(x) for x in re.findall(r"[-+0-9.eE]+(?:inf)?", line.split("{")[1])]
            for line in block.splitlines()[1:] if "{" in line]
    want = []
    for c in [scheduled["controller"]] + [{**scheduled["controller"], **e["controller"]}
                                          for e in scheduled["gain_schedule"]["entries"]]:
        filters = [f for f in c["filters"] if f["input"] != "tau_cmd"] + [f for f in c["filters"] if f["input"] == "tau_cmd"]
        for f in filters:
            want += [list(r) for r in SosFilter(f["sos"]).coefficients]
    assert rows == want  # exact: 17 significant digits round-trip
    assert "#define EXOTUNE_N_CONTROLLERS 6" in c_sources(scheduled)["exotune_controller.h"]


@needs_cc
def test_golden_test_passes_and_checks_the_files_vectors(scheduled, tmp_path):
    """The generated golden test passes with -Werror and the pedantic warnings; its first rows per
    controller are the file's golden inputs with the file's golden outputs (to their bounds)."""
    exe = _compile(tmp_path, scheduled, {}, "exotune_golden_test.c")
    res = subprocess.run([str(exe)], capture_output=True, text=True)
    assert res.returncode == 0 and res.stdout.rstrip().endswith("OK"), res.stdout
    rows = golden_rows(scheduled)
    outs = [scheduled["golden"]["tau_cmd"]["values"]]
    outs += [e["golden_tau_cmd"]["values"] for e in scheduled["gain_schedule"]["entries"]]
    inits = [i for i, r in enumerate(rows) if r[0] == 0 and r[3] == 0 and r[2][0] == 0.0]
    assert [rows[i][1] for i in inits] == list(range(6))
    for c, i in enumerate(inits):
        got = rows[i + 1:i + 201]
        assert all(r[0] == 1 and r[3] == 0 for r in got)
        assert all(abs(r[4] - want) <= r[5] for r, want in zip(got, outs[c]))


@needs_cc
@pytest.mark.parametrize("controller,limit", [(0, 0.0), (0, 5.0), (3, 0.0), (5, 2.0)])
def test_port_steps_as_the_reference_runtime(scheduled, tmp_path, controller, limit):
    """Random inputs (scaled to the signals' sizes), a clamp or none, a scheduled entry: the port's
    outputs are the reference runtime's to rounding; a non-finite input is a fault that leaves the
    state unchanged (the next outputs still agree)."""
    exe = _compile(tmp_path, scheduled, {"harness.c": HARNESS}, "harness.c")
    rng = np.random.default_rng(7 + controller)
    n = 400
    X = rng.standard_normal((n, 5)) * np.array([0.05, 2.0, 20.0, 500.0, 5.0])
    X[100, 2] = math.nan
    X[250, 4] = math.inf
    entries = scheduled["gain_schedule"]["entries"]
    angle = None if controller == 0 else entries[controller - 1]["joint_angle_rad"]
    rt = Runtime(scheduled, limit_nm=limit or None, joint_angle_rad=angle)
    ref, fault = [], []
    for row in X:
        try:
            ref.append(rt.step(dict(zip(SIGNALS, row))))
            fault.append(0)
        except ValueError:
            ref.append(math.nan)
            fault.append(1)
    stdin = f"run {controller} {limit!r} {n}\n" + "\n".join(" ".join(repr(float(x)) for x in r) for r in X) + "\n"
    out = subprocess.run([str(exe)], input=stdin, capture_output=True, text=True, check=True).stdout.split("\n")
    assert out[0] == "0"
    rc = np.array([int(line.split()[0]) for line in out[1:n + 1]])
    u = np.array([float(line.split()[1]) for line in out[1:n + 1]])
    assert rc.tolist() == fault and fault[100] == fault[250] == 1 and sum(fault) == 2
    ok = rc == 0
    ref = np.array(ref)
    scale = max(1.0, float(np.max(np.abs(ref[ok]))))
    np.testing.assert_allclose(u[ok], ref[ok], rtol=0, atol=1e-12 * scale)
    if limit:
        assert np.max(np.abs(u[ok])) <= limit and np.any(np.abs(u[ok]) == limit)


@needs_cc
def test_controller_for_angle_is_the_nearest_entry(scheduled, tmp_path):
    exe = _compile(tmp_path, scheduled, {"harness.c": HARNESS}, "harness.c")
    angles = [e["joint_angle_rad"] for e in scheduled["gain_schedule"]["entries"]]
    queries = [-10.0, angles[0], (angles[1] + angles[2]) / 2, angles[-1] + 0.01, 1e9]
    queries += [math.nan, math.inf, -math.inf]
    out = subprocess.run([str(exe)], input="".join(f"angle {q!r}\n" for q in queries), capture_output=True,
                         text=True, check=True).stdout.split("\n")
    want = [f"0 {1 + min(range(len(angles)), key=lambda i: abs(angles[i] - q))}" for q in queries[:5]]
    assert out[:8] == want + ["3 -7"] * 3  # a non-finite angle: EXOTUNE_FAULT_ANGLE, *controller untouched


def test_codegen_command_writes_all_files_or_refuses(tmp_path):
    ctl = tmp_path / "c.yaml"
    doc = export_design(ROOT / "examples" / "scheduled.yaml", 1000.0, ctl).to_dict()
    res = CliRunner().invoke(cli, ["codegen", str(ctl), "-o", str(tmp_path / "c")])
    assert res.exit_code == 0, res.output
    sha = hashlib.sha256(ctl.read_bytes()).hexdigest()
    trace = {"sha256": sha, "certified": True, "verdict": "CERTIFIED", "reasons": ()}
    assert {p.name: p.read_text(encoding="ascii") for p in (tmp_path / "c").iterdir()} == c_sources(doc, trace)
    assert "6 controllers, 30 sections" in res.output and "-ffp-contract=off" in res.output
    assert f"source sha256 {sha}: certified" in res.output
    # a file whose golden vectors its controller does not reproduce: refused, nothing written
    bad = copy.deepcopy(doc)
    bad["golden"]["tau_cmd"]["values"][10] += 1.0
    write_controller(bad, tmp_path / "bad.yaml")
    res = CliRunner().invoke(cli, ["codegen", str(tmp_path / "bad.yaml"), "-o", str(tmp_path / "none")])
    assert res.exit_code == 2 and res.output.startswith("exotune: error: golden:") and not (tmp_path / "none").exists()
    # a design file is not a controller file
    res = CliRunner().invoke(cli, ["codegen", str(ROOT / "examples" / "paper.yaml"), "-o", str(tmp_path / "d")])
    assert res.exit_code == 2 and "export it first" in res.output and not (tmp_path / "d").exists()


def test_write_c_sources_refuses_a_non_finite_coefficient_path(scheduled):
    """A coefficient that is not finite cannot be written as a C literal (the schema refuses such a
    file before; the generator refuses too rather than print 'inf')."""
    bad = copy.deepcopy(scheduled)
    bad["controller"]["filters"][0]["sos"][0][1] = math.inf
    with pytest.raises((ValueError, ConfigError)):
        c_sources(bad)
