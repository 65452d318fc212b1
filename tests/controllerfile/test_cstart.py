"""Safety of the generated C beyond the step: the bumpless start (``exotune_start``) against the
reference's (:func:`exotune.simulation.engine.bumpless_start`), the state's magic (a zeroed state is
refused), the switch mode checked on every call, a bumpless switch between controllers of different
layouts refused, file text that cannot inject C, and the size limit of codegen."""

from __future__ import annotations

import copy
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from exotune.cli import cli
from exotune.controllerfile import Runtime, c_sources
from exotune.controllerfile.ccode import (C_FLAGS, MAX_SCHEDULE_ENTRIES, MAX_SECTIONS_PER_CONTROLLER, check_size)
from exotune.errors import ConfigError
from exotune.simulation.engine import bumpless_start

CC = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
needs_cc = pytest.mark.skipif(CC is None, reason="no C compiler on this machine")
SIGNALS = ("theta_m", "omega_m", "tau_s", "dtau_s", "tau_c")
OK, FAULT_INPUT, FAULT_OVERFLOW, ERR_ARGUMENT = 0, 1, 2, 4

HARNESS = r"""
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "exotune_controller.h"
/* stdin commands: init C L | start 5 inputs | step 5 inputs | switch C M | sched Q M | zero */
static exotune_state st;
static int read5(exotune_inputs *y)
{
    char t[5][64];
    if (scanf("%63s %63s %63s %63s %63s", t[0], t[1], t[2], t[3], t[4]) != 5) return 0;
    y->theta_m = strtod(t[0], 0); y->omega_m = strtod(t[1], 0); y->tau_s = strtod(t[2], 0);
    y->dtau_s = strtod(t[3], 0); y->tau_c = strtod(t[4], 0);
    return 1;
}
int main(void)
{
    char word[16];
    while (scanf("%15s", word) == 1) {
        exotune_inputs y;
        double u = 0.0, a;
        int c, m, k;
        if (!strcmp(word, "init")) {
            if (scanf("%d %lf", &c, &a) != 2) return 3;
            printf("%d\n", exotune_init(&st, c, a));
        } else if (!strcmp(word, "start")) {
            if (!read5(&y)) return 3;
            printf("%d", exotune_start(&st, &y));
            for (k = 0; k < EXOTUNE_MAX_SECTIONS; ++k)
                printf(" %.17g %.17g", (double)st.z[k][0], (double)st.z[k][1]);
            printf("\n");
        } else if (!strcmp(word, "step")) {
            if (!read5(&y)) return 3;
            c = exotune_step(&st, &y, &u);
            printf("%d %.17g\n", c, u);
        } else if (!strcmp(word, "switch")) {
            if (scanf("%d %d", &c, &m) != 2) return 3;
            c = exotune_switch(&st, c, m);
            printf("%d %d\n", c, st.controller);
        } else if (!strcmp(word, "sched")) {
            if (scanf("%lf %d", &a, &m) != 2) return 3;
            c = exotune_schedule(&st, a, m);
            printf("%d %d\n", c, st.controller);
        } else if (!strcmp(word, "zero")) {
            y.theta_m = y.omega_m = y.tau_s = y.dtau_s = y.tau_c = 0.0;
            memset(&st, 0, sizeof st);
            printf("%d %d %d %d %d\n", exotune_step(&st, &y, &u), exotune_start(&st, &y), exotune_switch(&st, 0, 0),
                   exotune_schedule(&st, 0.0, 0), exotune_step(0, &y, &u));
        } else {
            return 3;
        }
    }
    return 0;
}
"""


def _build(tmp: Path, files: dict[str, str], *defines: str) -> Path:
    for name, text in {**files, "harness.c": HARNESS}.items():
        (tmp / name).write_text(text, encoding="ascii")
    exe = tmp / "h.out"
    cmd = [CC, *C_FLAGS.split(), *defines, "-Wall", "-Wextra", "-pedantic", "-Werror", "-o", str(exe),
           str(tmp / "exotune_controller.c"), str(tmp / "harness.c"), "-lm"]
    subprocess.run(cmd, check=True, capture_output=True, text=True)
    return exe


def _run(exe: Path, lines: list[str]) -> list[list[float]]:
    out = subprocess.run([str(exe)], input="\n".join(lines) + "\n", capture_output=True, text=True, check=True)
    return [[float(x) for x in line.split()] for line in out.stdout.splitlines()]


def _vec(y: dict) -> str:
    return " ".join(repr(float(y[s])) for s in SIGNALS)


@pytest.fixture(scope="module")
def exe64(scheduled_doc, tmp_path_factory):
    if CC is None:
        pytest.skip("no C compiler on this machine")
    return _build(tmp_path_factory.mktemp("c64"), c_sources(scheduled_doc))


@pytest.fixture(scope="module")
def exe32(scheduled_doc32, tmp_path_factory):
    if CC is None:
        pytest.skip("no C compiler on this machine")
    return _build(tmp_path_factory.mktemp("c32"), c_sources(scheduled_doc32))


def _reference(doc, controller: int, limit: float, y0: dict) -> Runtime:
    entries = doc["gain_schedule"]["entries"]
    angle = None if controller == 0 else entries[controller - 1]["joint_angle_rad"]
    rt = Runtime(doc, limit_nm=limit or None, joint_angle_rad=angle)
    bumpless_start(rt, y0)
    return rt


@pytest.mark.parametrize("controller,limit", [(0, 0.0), (0, 5.0), (3, 0.0), (5, 40.0)])
def test_start_is_the_references_bumpless_start(scheduled_doc, exe64, controller, limit):
    """The states after exotune_start are the reference's (Runtime + bumpless_start) to rounding,
    and so are the commands that follow, for random inputs."""
    rng = np.random.default_rng(11 + controller)
    y0 = dict(zip(SIGNALS, rng.standard_normal(5) * np.array([0.5, 0.0, 20.0, 0.0, 5.0])))
    rt = _reference(scheduled_doc, controller, limit, y0)
    X = rng.standard_normal((60, 5)) * np.array([0.05, 2.0, 20.0, 500.0, 5.0])
    out = _run(exe64, [f"init {controller} {limit!r}", "start " + _vec(y0)]
               + ["step " + " ".join(repr(float(v)) for v in x) for x in X])
    assert out[0] == [OK] and out[1][0] == OK
    want = np.concatenate([f.z.ravel() for _s, f in rt.filters] + [f.z.ravel() for f in rt.loop])
    got = np.array(out[1][1:1 + len(want)])
    assert np.allclose(got, want, rtol=1e-13, atol=1e-13 * (1 + np.abs(want).max()))
    assert not np.any(out[1][1 + len(want):])  # the other controllers' rows stay zero
    ref = [rt.step(dict(zip(SIGNALS, x))) for x in X]
    got_u = [r[1] for r in out[2:]]
    assert all(r[0] == OK for r in out[2:])
    assert np.allclose(got_u, ref, rtol=1e-9, atol=1e-9 * max(1.0, max(map(abs, ref))))


def test_start_at_rest_gives_the_steady_command_no_spike(scheduled_doc, exe64):
    """theta_m = 0.5 rad at rest: with exotune_start the first command is the steady one (holding
    the input does not move it); without it the derivative filters see a step (a spike)."""
    y0 = {"theta_m": 0.5, "omega_m": 0.0, "tau_s": 0.0, "dtau_s": 0.0, "tau_c": 0.0}
    held = ["step " + _vec(y0)] * 200
    started = _run(exe64, ["init 0 0.0", "start " + _vec(y0)] + held)
    cold = _run(exe64, ["init 0 0.0"] + held)
    u = [r[1] for r in started[2:]]
    rt = _reference(scheduled_doc, 0, 0.0, y0)
    steady = rt.step(y0)
    assert u[0] == pytest.approx(steady, rel=1e-9, abs=1e-9)
    assert max(abs(x - u[0]) for x in u) <= 1e-6 * max(1.0, abs(u[0]))  # no transient at all
    assert abs(cold[1][1] - u[0]) > 100.0 * max(1.0, abs(u[0]))  # what the start prevents


def test_start_float32_follows_the_reference_start(scheduled_doc, exe32):
    """The float32 port's exotune_start: holding the first reading, its commands are the float64
    reference's after its bumpless start (to float32 rounding) from the first step on; at rest with
    theta_m = 0.5 rad the command does not move."""
    for y0 in ({"theta_m": 0.5, "omega_m": 0.0, "tau_s": 0.0, "dtau_s": 0.0, "tau_c": 0.0},
               {"theta_m": -0.2, "omega_m": 0.0, "tau_s": 12.0, "dtau_s": 0.0, "tau_c": 3.0}):
        out = _run(exe32, ["init 0 0.0", "start " + _vec(y0)] + ["step " + _vec(y0)] * 100)
        assert out[0] == [OK] and out[1][0] == OK
        u = [r[1] for r in out[2:]]
        rt = _reference(scheduled_doc, 0, 0.0, y0)
        ref = [rt.step(y0) for _ in u]
        scale = 1e-4 * max(1.0, max(map(abs, ref)))
        assert all(abs(x - r) <= scale for x, r in zip(u, ref)), (u[:3], ref[:3])
        if y0["tau_s"] == 0.0:
            assert max(abs(x - u[0]) for x in u) <= scale


@pytest.mark.parametrize("port", ["exe64", "exe32"])
def test_start_refuses_what_step_refuses(port, request):
    exe = request.getfixturevalue(port)
    nan = "nan 0 0 0 0"
    out = _run(exe, ["init 0 0.0", "start 0.1 0 3 0 1", f"start {nan}", "step 0.1 0 3 0 1"])
    assert out[2][0] == FAULT_INPUT and out[2][1:] == out[1][1:]  # the refused start changed nothing
    assert out[3] == _run(exe, ["init 0 0.0", "start 0.1 0 3 0 1", "step 0.1 0 3 0 1"])[2]
    assert _run(exe, ["init 0 0.0", "start 1e300 0 1e300 0 0"])[1][0] in (FAULT_INPUT, FAULT_OVERFLOW, OK)


@pytest.mark.parametrize("port", ["exe64", "exe32"])
def test_zeroed_state_is_refused(port, request):
    """A memset-to-zero state (never initialized) is EXOTUNE_ERR_ARGUMENT everywhere."""
    out = _run(request.getfixturevalue(port), ["zero"])
    assert out == [[ERR_ARGUMENT] * 5]


@pytest.mark.parametrize("port", ["exe64", "exe32"])
def test_switch_mode_is_checked_even_without_a_switch(port, request):
    """exotune_schedule with an unknown mode is refused whether or not the entry changes."""
    out = _run(request.getfixturevalue(port), ["init 1 0.0", "sched 0.0 99", "sched 2.0 99", "sched 0.0 0"])
    assert out[1] == [ERR_ARGUMENT, 1] and out[2] == [ERR_ARGUMENT, 1] and out[3][0] == OK


@needs_cc
def test_bumpless_switch_between_layouts_is_refused(scheduled_doc, tmp_path):
    """An entry whose filter has one more (identity) section has another layout: a bumpless switch to
    or from it is EXOTUNE_ERR_ARGUMENT (nothing changed); a reset switch works."""
    doc = copy.deepcopy(scheduled_doc)
    f = doc["gain_schedule"]["entries"][1]["controller"]["filters"][0]
    f["sos"] = [*f["sos"], [1.0, 0.0, 0.0, 1.0, 0.0, 0.0]]
    exe = _build(tmp_path, c_sources(doc))
    out = _run(exe, ["init 1 0.0", "step 0.1 0 1 0 0", "switch 2 1", "switch 3 1", "switch 2 1", "switch 2 0"])
    assert out[2] == [ERR_ARGUMENT, 1] and out[3] == [OK, 3] and out[4] == [ERR_ARGUMENT, 3] and out[5] == [OK, 2]


@needs_cc
def test_file_text_cannot_inject_c(scheduled_doc, tmp_path):
    """The review's injection through provenance.source (a backslash after '*', carriage returns)
    stays inside its comment: the macro is the generated one, the golden test passes; a design named
    arm*\u00df.yaml compiles."""
    for i, source in enumerate(["sched*\\\r#define EXOTUNE_BUMPLESS_DECAY 1.01\r/*.yaml", "arm*\u00df.yaml",
                                "x*\\\n#define EXOTUNE_N_CONTROLLERS 1\n??/\n/*", "kg\u00b7m\u00b2 \u03b8 */ \" \\"]):
        doc = copy.deepcopy(scheduled_doc)
        doc["provenance"]["source"] = source
        files = c_sources(doc)
        d = tmp_path / str(i)
        d.mkdir()
        for name, text in files.items():
            assert all(" " <= c <= "~" or c == "\n" for c in text), name
            (d / name).write_text(text, encoding="ascii")
        macros = subprocess.run([CC, "-E", "-dM", str(d / "exotune_controller.c")], capture_output=True, text=True,
                                check=True).stdout
        decay = re.search(r"#define EXOTUNE_BUMPLESS_DECAY (\S+)", macros).group(1)
        assert decay in files["exotune_controller.h"] and float(decay) < 1.0
        exe = d / "g.out"
        subprocess.run([CC, *C_FLAGS.split(), "-Wall", "-Wextra", "-pedantic", "-Werror", "-o", str(exe),
                        str(d / "exotune_controller.c"), str(d / "exotune_golden_test.c"), "-lm"],
                       check=True, capture_output=True, text=True)
        res = subprocess.run([str(exe)], capture_output=True, text=True)
        assert res.returncode == 0 and res.stdout.rstrip().endswith("OK")


def test_units_read_as_ascii_in_the_header(scheduled_doc):
    h = c_sources(scheduled_doc)["exotune_controller.h"]
    assert "/xb" not in h and "/u0" not in h


def test_codegen_refuses_oversized_files(scheduled_doc, tmp_path):
    """Too many sections in a controller, or too many schedule entries: a one-line ConfigError
    naming the field and the limit (exit 2), before any heavy work."""
    big = copy.deepcopy(scheduled_doc)
    f = big["controller"]["filters"][0]
    f["sos"] = [*f["sos"], *([[1.0, 0.0, 0.0, 1.0, 0.0, 0.0]] * MAX_SECTIONS_PER_CONTROLLER)]
    with pytest.raises(ConfigError, match=f"at most {MAX_SECTIONS_PER_CONTROLLER}") as e:
        check_size(big)
    assert e.value.field == "controller.filters"
    many = copy.deepcopy(scheduled_doc)
    entries = many["gain_schedule"]["entries"]
    many["gain_schedule"]["entries"] = [{**copy.deepcopy(entries[0]), "joint_angle_rad": 0.01 * i}
                                        for i in range(MAX_SCHEDULE_ENTRIES + 1)]
    with pytest.raises(ConfigError, match=f"at most {MAX_SCHEDULE_ENTRIES}") as e:
        check_size(many)
    assert e.value.field == "gain_schedule.entries"
    check_size(scheduled_doc)  # an exported file passes
    path = tmp_path / "big.yaml"
    path.write_text(yaml.safe_dump(big, sort_keys=False, allow_unicode=True), encoding="utf-8")
    res = CliRunner().invoke(cli, ["codegen", str(path), "-o", str(tmp_path / "out")])
    assert res.exit_code == 2, res.output
    assert "controller.filters" in res.output and str(MAX_SECTIONS_PER_CONTROLLER) in res.output
    assert not (tmp_path / "out").exists()


@pytest.mark.skipif(shutil.which("clang") is None, reason="no clang on this machine")
def test_clang_builds_without_double_promotion(scheduled_doc, tmp_path):
    """glibc's NAN and INFINITY are float constants: the float64 port writes (double)NAN and
    (double)INFINITY, so clang's -Wdouble-promotion stays quiet."""
    files = c_sources(scheduled_doc)
    assert "(double)NAN" in files["exotune_golden_test.c"]
    for name, text in files.items():
        (tmp_path / name).write_text(text, encoding="ascii")
    subprocess.run(["clang", *C_FLAGS.split(), "-Wall", "-Wextra", "-pedantic", "-Wdouble-promotion", "-Wconversion",
                    "-Werror", "-o", str(tmp_path / "g.out"), str(tmp_path / "exotune_controller.c"),
                    str(tmp_path / "exotune_golden_test.c"), "-lm"], check=True, capture_output=True, text=True)


@pytest.mark.parametrize("port", ["exe64", "exe32"])
def test_schedule_has_hysteresis_at_entry_boundaries(scheduled_doc, port, request):
    """Angle noise at the boundary between two entries (0.25 rad between the entries at 0 and 0.5
    rad) switched on every sample: a BUMPLESS switch each time stacked command peaks of 50-57 N·m and
    RESET diverged (hostile-input round 4). exotune_schedule now keeps the running entry until the
    angle is EXOTUNE_SCHEDULE_HYSTERESIS_RAD past the midpoint (a tenth of the smallest spacing, at
    most 0.01 rad: 0.01 here); exotune_controller_for_angle stays the nearest entry."""
    from exotune.controllerfile.cheader import schedule_hysteresis_rad

    h = schedule_hysteresis_rad(scheduled_doc)
    angles = [e["joint_angle_rad"] for e in scheduled_doc["gain_schedule"]["entries"]]
    assert h == pytest.approx(min(0.01, 0.1 * min(np.diff(sorted(angles)))))
    mid = 0.5 * (angles[0] + angles[1])
    noise = [mid + d * h for d in (0.5, -0.5, 0.9, -0.9, 0.5)]
    out = _run(request.getfixturevalue(port),
               ["init 1 0.0"] + [f"sched {q!r} 0" for q in noise]
               + [f"sched {mid + 1.5 * h!r} 0", f"sched {mid - 0.5 * h!r} 0", f"sched {mid - 1.5 * h!r} 0",
                  f"sched {angles[-1] + 5.0!r} 0", "sched nan 0"])
    assert [o[1] for o in out[1:6]] == [1] * 5  # within the band: no switch, however often it crosses
    assert out[6] == [OK, 2] and out[7] == [OK, 2] and out[8] == [OK, 1]
    assert out[9] == [OK, len(angles)] and out[10] == [3, len(angles)]  # EXOTUNE_FAULT_ANGLE, unchanged


@needs_cc
def test_schedule_hysteresis_can_be_set_when_compiling(scheduled_doc, tmp_path):
    """-DEXOTUNE_SCHEDULE_HYSTERESIS_RAD=0 gives the nearest entry at every call; with a negative
    value exotune_schedule refuses every call (EXOTUNE_ERR_ARGUMENT, the controller unchanged)."""
    exe = _build(tmp_path, c_sources(scheduled_doc), "-DEXOTUNE_SCHEDULE_HYSTERESIS_RAD=0")
    mid = 0.25
    out = _run(exe, ["init 1 0.0", f"sched {mid + 1e-6!r} 1", f"sched {mid - 1e-6!r} 1"])
    assert out[1] == [OK, 2] and out[2] == [OK, 1]
    d = tmp_path / "neg"
    d.mkdir()
    exe = _build(d, c_sources(scheduled_doc), "-DEXOTUNE_SCHEDULE_HYSTERESIS_RAD=-1")
    assert _run(exe, ["init 1 0.0", "sched 1.0 1"])[1] == [ERR_ARGUMENT, 1]
