"""The golden test of the C port and its traceability (issue 25, items 3 and 4): the golden table
covers every controller from a non-zero state, the clamp, every fault path and the schedule
look-up with tolerances from a rounding bound; a coefficient changed by 1e-12 of itself makes the
compiled golden test fail, for every coefficient of the port; codegen refuses a file that does not
certify unless told, and the code names the file (sha256), the exotune version and the verdict."""

from __future__ import annotations

import hashlib
import math
import re
import shutil
import subprocess
from pathlib import Path

import pytest
from click.testing import CliRunner

from exotune import api
from exotune.cli import cli
from exotune.config import read_yaml
from exotune.controllerfile import build_export, c_sources, design_at_rate, export_design
from exotune.controllerfile.ccode import C_FLAGS
from exotune.controllerfile.cgolden import HUGE_INPUT, golden_rows
from exotune.errors import RunFailed
from exotune.version import __version__

ROOT = Path(__file__).resolve().parents[2]
CC = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
needs_cc = pytest.mark.skipif(CC is None, reason="no C compiler on this machine")

# appended by the test (not by codegen) to a copy of exotune_controller.c whose tables are made
# writable: a pointer to the k-th coefficient the step uses (sections, gains, loop feed-throughs)
PERTURB_HOOK = r"""
double *exo_test_coefficient(int k);
double *exo_test_coefficient(int k)
{
    int ns = (int)(sizeof SECTIONS / sizeof SECTIONS[0]), ng = (int)(sizeof GAINS / sizeof GAINS[0]);
    if (k < 5 * ns) {
        exo_section *s = &SECTIONS[k / 5];
        switch (k % 5) {
        case 0: return &s->b0;
        case 1: return &s->b1;
        case 2: return &s->b2;
        case 3: return &s->a1;
        default: return &s->a2;
        }
    }
    k -= 5 * ns;
    if (k < ng)
        return &GAINS[k].gain;
    k -= ng;
    return k < EXOTUNE_N_CONTROLLERS ? &CONTROLLERS[k].g : 0;
}
"""

PERTURB_MAIN = r"""
#include <stdio.h>
double *exo_test_coefficient(int k);
int golden_main(void);
int main(void)
{
    int k;
    double *p;
    printf("BASE %d\n", golden_main());
    for (k = 0; (p = exo_test_coefficient(k)) != 0; ++k) {
        double x = *p;
        if (x == 0.0)
            continue;
        *p = x * (1.0 + 1e-12);
        printf("PERTURBED %d %d\n", k, golden_main());
        *p = x;
    }
    return 0;
}
"""


@pytest.fixture(scope="module")
def scheduled():
    raw = read_yaml(ROOT / "examples" / "scheduled.yaml")
    return build_export(design_at_rate(raw, 1000.0), 1000.0, analyses=False)


def test_golden_table_covers_every_path(scheduled):
    rows = golden_rows(scheduled)
    inits = [i for i, r in enumerate(rows) if r[0] == 0 and r[3] == 0]
    assert [rows[i][1] for i in inits] == [c for c in range(6) for _ in (0, 1)]  # each controller twice
    ends = inits[1:] + [min(i for i, r in enumerate(rows) if r[0] == 2)]
    for j, (a, b) in enumerate(zip(inits, ends)):
        seg = rows[a + 1:b]
        limit = rows[a][2][0]
        codes = [r[3] for r in seg]
        assert codes.count(1) == 15  # NaN, +inf, -inf on each signal
        first_fault = codes.index(1)
        assert first_fault >= 30 and any(r[4] != 0.0 for r in seg[:first_fault])  # faults from a non-zero state
        assert codes[first_fault + 15:].count(0) >= 20  # and the controller goes on
        if j % 2 == 0:
            assert limit == 0.0 and 2 in codes  # a finite input that overflows
        else:
            assert limit > 0 and any(r[3] == 0 and abs(r[4]) == limit for r in seg)  # the clamp engages
            assert all(abs(r[4]) <= limit for r in seg if r[3] == 0)
    angles = [r for r in rows if r[0] == 2]
    assert sorted({r[1] for r in angles if r[3] == 0}) == [1, 2, 3, 4, 5]
    assert [r[3] for r in angles].count(3) == 3  # NaN and infinite angles: EXOTUNE_FAULT_ANGLE
    assert [r for r in rows if r[3] == 4]  # argument checks
    # the tolerances come from the rounding bound, far below the old 1e-9 of the scale
    # (after an accepted input of 1.7e308 the bound may be infinite: only the return code counts)
    steps = [r for r in rows if r[0] == 1 and r[3] == 0 and max(map(abs, r[2])) < HUGE_INPUT]
    scale = max(abs(r[4]) for r in steps)
    assert max(r[5] for r in steps) < 1e-11 * scale and all(r[5] > 0 for r in steps)


@needs_cc
def test_a_coefficient_changed_by_1e_12_fails_the_golden_test(scheduled, tmp_path):
    """Every nonzero coefficient of the port (section b0…a2, static gains, loop feed-throughs), one
    at a time multiplied by 1 + 1e-12: the compiled golden test fails each time (and passes
    unperturbed). One build: the test makes the copy's tables writable and calls the golden test's
    main once per coefficient."""
    files = c_sources(scheduled)
    src = files["exotune_controller.c"]
    for table in ("exo_gain GAINS", "exo_section SECTIONS", "exo_controller CONTROLLERS"):
        assert f"static const {table}" in src
        src = src.replace(f"static const {table}", f"static {table}")
    (tmp_path / "exotune_controller.h").write_text(files["exotune_controller.h"], encoding="ascii")
    (tmp_path / "c.c").write_text(src + PERTURB_HOOK, encoding="ascii")
    (tmp_path / "g.c").write_text(files["exotune_golden_test.c"].replace("int main(void)", "int golden_main(void)"),
                                  encoding="ascii")
    (tmp_path / "m.c").write_text(PERTURB_MAIN, encoding="ascii")
    exe = tmp_path / "p"
    subprocess.run([CC, *C_FLAGS.split(), "-o", str(exe), *(str(tmp_path / f) for f in ("c.c", "g.c", "m.c")), "-lm"],
                   check=True, capture_output=True)
    out = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout
    assert "BASE 0" in out
    results = re.findall(r"PERTURBED (\d+) (\d+)", out)
    n_coef = sum(1 for c in re.findall(r"\{([^{}]*)\}", src.split("SECTIONS[")[1].split("};")[0])
                 for x in c.split(",") if float(x) != 0.0)
    assert len(results) >= n_coef + 6  # every nonzero section coefficient, the gains, the six g
    undetected = [k for k, rc in results if rc != "1"]
    assert not undetected


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """A certified controller file (examples/scheduled.yaml at 1 kHz) and one that does not
    certify (examples/paper.yaml at 1 kHz: latency margin below the requirement)."""
    d = tmp_path_factory.mktemp("ctl")
    export_design(ROOT / "examples" / "scheduled.yaml", 1000.0, d / "ok.yaml")
    export_design(ROOT / "examples" / "paper.yaml", 1000.0, d / "bad.yaml", allow_uncertified=True)
    return d


def test_codegen_refuses_an_uncertified_file_unless_allowed(files, tmp_path):
    bad = files / "bad.yaml"
    res = CliRunner().invoke(cli, ["codegen", str(bad), "-o", str(tmp_path / "c")])
    assert res.exit_code == 1 and "does not certify" in res.output and "latency margin" in res.output
    assert "--allow-uncertified" in res.output and not (tmp_path / "c").exists()
    with pytest.raises(RunFailed):
        api.codegen(bad, tmp_path / "c2")
    assert not (tmp_path / "c2").exists()
    res = CliRunner().invoke(cli, ["codegen", str(bad), "-o", str(tmp_path / "c"), "--allow-uncertified"])
    assert res.exit_code == 0 and "NOT CERTIFIED" in res.output
    h = (tmp_path / "c" / "exotune_controller.h").read_text(encoding="ascii")
    sha = hashlib.sha256(bad.read_bytes()).hexdigest()
    assert "#define EXOTUNE_CERTIFIED 0" in h and f'#define EXOTUNE_SOURCE_SHA256 "{sha}"' in h
    assert '#define EXOTUNE_CERTIFICATION "UNCERTIFIED' in h and "latency margin" in h  # the reasons, in a comment
    g = api.codegen(bad, tmp_path / "c3", allow_uncertified=True)
    assert not g.certified and g.sha256 == sha and g.reasons and g.to_dict()["certified"] is False


@needs_cc
def test_golden_test_prints_what_it_came_from(files, tmp_path):
    ok = files / "ok.yaml"
    g = api.codegen(ok, tmp_path)
    sha = hashlib.sha256(ok.read_bytes()).hexdigest()
    assert g.certified and g.sha256 == sha and g.to_dict()["source_sha256"] == sha
    h = (tmp_path / "exotune_controller.h").read_text(encoding="ascii")
    assert "#define EXOTUNE_CERTIFIED 1" in h and f'#define EXOTUNE_VERSION "{__version__}"' in h
    exe = tmp_path / "g"
    subprocess.run([CC, *C_FLAGS.split(), "-Wall", "-Wextra", "-pedantic", "-Werror", "-o", str(exe),
                    str(tmp_path / "exotune_controller.c"), str(tmp_path / "exotune_golden_test.c"), "-lm"], check=True)
    res = subprocess.run([str(exe)], capture_output=True, text=True)
    assert res.returncode == 0 and res.stdout.rstrip().endswith("OK")
    assert f"source sha256 {sha}, exotune {__version__}, certification CERTIFIED" in res.stdout
    assert f"exotune_controller sha256={sha} exotune={__version__} certification=CERTIFIED" in res.stdout
    assert "WARNING" not in res.stdout
    # the string is in the object code too: `strings` on a firmware image finds the file it runs
    assert f"sha256={sha}".encode() in exe.read_bytes()
    assert not math.isnan(g.sections)
