"""The float32 C port (issue 25, "Done when"): a float32 controller file (examples/scheduled.yaml
exported with ``implementation.precision: float32``) generates C that compiles clean with -Werror and
the pedantic warnings, whose golden test passes with every output exactly the float32 reference's
(precision.Float32Runtime); a coefficient changed by one float32 ulp (and by 1e-6 of itself) fails
it; fast-math builds do not compile; FMA contraction is refused at init; NaN and out-of-float inputs
are faults; subnormal inputs and states are flushed; a bumpless switch is refused (a reset is
explicit); ``exotune codegen`` writes the port of an exported float32 file end to end."""

from __future__ import annotations

import copy
import hashlib
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from exotune.cli import cli
from exotune.config import read_yaml
from exotune.controllerfile import build_export, c_sources, design_at_rate, load_controller
from exotune.controllerfile.ccode import C_FLAGS
from exotune.controllerfile.ccode32 import MIN_COEFFICIENT32, RETURN_CODES32, c_float
from exotune.controllerfile.cgolden32 import golden_rows32
from exotune.controllerfile.cstep import RETURN_CODES
from exotune.controllerfile.precision import FLUSH32, INPUT_LIMIT32, Float32Runtime, step_order
from exotune.errors import ConfigError
from tests.controllerfile.test_cgolden import PERTURB_HOOK as PERTURB_HOOK64, PERTURB_MAIN as PERTURB_MAIN64
from tests.controllerfile.test_chardening import HARNESS as HARNESS64

ROOT = Path(__file__).resolve().parents[2]
CC = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
needs_cc = pytest.mark.skipif(CC is None, reason="no C compiler on this machine")
SIGNALS = ("theta_m", "omega_m", "tau_s", "dtau_s", "tau_c")
WARN = ["-Wall", "-Wextra", "-pedantic", "-Werror", "-Wconversion", "-Wdouble-promotion", "-Wshadow"]
FLT_MIN = float(np.finfo(np.float32).tiny)


def _derived(text: str, edits: list[tuple[str, str]]) -> str:
    """``text`` with each (old, new) replaced, every old present (the float64 tests' C, adapted)."""
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new)
    return text


# the float64 hardening harness (stdin: "init C L", "switch C MODE", "schedule A MODE", "step" + 5 inputs)
# plus "setz K J V" (set a state, as float) and, after a step's rc, output and number of subnormal
# states, every state (hex)
HARNESS = _derived(HARNESS64, [
    ("        } else {\n            exotune_inputs y;",
     "        } else if (strcmp(word, \"setz\") == 0) {\n            int k = (int)num(), j = (int)num();\n"
     "            st.z[k][j] = (float)num();\n        } else {\n            exotune_inputs y;"),
    ('printf("%d %.17g %d\\n", rc, u, sub);',
     'printf("%d %.17g %d", rc, u, sub);\n            for (k = 0; k < EXOTUNE_MAX_SECTIONS; ++k)\n'
     '                printf(" %a %a", (double)st.z[k][0], (double)st.z[k][1]);\n            printf("\\n");')])

# the float64 golden test's perturbation hook on the float32 tables (appended by the test to a copy of
# exotune_controller.c whose tables are made writable): a pointer to the k-th coefficient
PERTURB_HOOK = _derived(PERTURB_HOOK64, [("double", "float"), ("->b0", "->beta0"), ("->b1", "->beta1"),
                                         ("->b2", "->beta2"), ("->a1", "->alpha1"), ("->a2", "->alpha2"),
                                         ("CONTROLLERS[k].g", "CONTROLLERS[k].divisor")])

# its main: each nonzero coefficient multiplied by 1 + 1e-6 ("REL k rc"), then moved by one ulp ("ULP k rc")
PERTURB_MAIN = _derived(PERTURB_MAIN64, [
    ("#include <stdio.h>", "#include <math.h>\n#include <stdio.h>"), ("double", "float"), ("x == 0.0", "x == 0.0f"),
    ('*p = x * (1.0 + 1e-12);\n        printf("PERTURBED %d %d\\n", k, golden_main());',
     '*p = x * (1.0f + 1e-6f);\n        printf("REL %d %d\\n", k, golden_main());\n'
     '        *p = nextafterf(x, 2.0f * x);\n        printf("ULP %d %d\\n", k, golden_main());')])


def _design32(tmp: Path) -> Path:
    raw = yaml.safe_load((ROOT / "examples" / "scheduled.yaml").read_text())
    raw["implementation"]["precision"] = "float32"
    p = tmp / "design32.yaml"
    p.write_text(yaml.safe_dump(raw))
    return p


@pytest.fixture(scope="module")
def doc32(tmp_path_factory):
    """examples/scheduled.yaml with implementation.precision: float32, exported at 1 kHz (no analyses):
    six controllers (nominal and five gain-schedule entries), 30 delta-form sections."""
    raw = read_yaml(_design32(tmp_path_factory.mktemp("d32")))
    doc = build_export(design_at_rate(raw, 1000.0), 1000.0, analyses=False)
    assert doc["implementation"]["precision"] == "float32" and doc["controller"]["realization"]
    return doc


@pytest.fixture(scope="module")
def src32(doc32):
    """``c_sources(doc32)``, generated once for the tests that only read it (the generator is a
    deterministic function of the document)."""
    return c_sources(doc32)


def _build(d: Path, files: dict, extra: dict, main: str, flags=(), warn=True) -> Path:
    for name, text in {**files, **extra}.items():
        (d / name).write_text(text, encoding="ascii")
    exe = d / "a.out"
    subprocess.run([CC, *C_FLAGS.split(), *(WARN if warn else ()), *flags, "-o", str(exe),
                    str(d / "exotune_controller.c"), str(d / main), "-lm"], check=True, capture_output=True, text=True)
    return exe


@pytest.fixture(scope="module")
def harness(src32, tmp_path_factory):
    return _build(tmp_path_factory.mktemp("h32"), src32, {"harness.c": HARNESS}, "harness.c")


def _run(exe: Path, lines: list[str]) -> list[str]:
    out = subprocess.run([str(exe)], input="\n".join(lines) + "\n", capture_output=True, text=True, check=True)
    return out.stdout.splitlines()


def _step(x) -> str:
    return "step " + " ".join(repr(float(v)) for v in x)


def _parse(line: str):
    """(rc, output, subnormal states, states) of a harness step line."""
    f = line.split()
    return int(f[0]), float(f[1]), int(f[2]), [float.fromhex(v) for v in f[3:]]


def _sanitizers() -> list[str]:
    """-fsanitize=address,undefined when this compiler links it, else nothing."""
    flags = ["-fsanitize=address,undefined", "-fno-sanitize-recover=all"]
    res = subprocess.run([CC, *flags, "-x", "c", "-o", "/dev/null", "-"], input="int main(void){return 0;}",
                         capture_output=True, text=True)
    return flags if res.returncode == 0 else []


def test_literals_are_the_realizations_floats(doc32, src32):
    """Every coefficient literal of the float32 port is a float literal that parses to the
    realization's float32 value, in the order the reference steps them."""
    src = src32["exotune_controller.c"]
    lits = re.findall(r"[-+0-9.eE]+f\b", src.split("SECTIONS[")[1].split("};")[0])
    ctrls = [doc32["controller"]] + [e["controller"] for e in doc32["gain_schedule"]["entries"]]
    want = []
    for c in ctrls:
        K = step_order(c["realization"])
        want += [x for _s, secs in K["sensed"] for row in secs for x in row]
        want += [x for secs in K["loop"] for row in secs for x in row]
    assert [float(np.float32(float(s[:-1]))) for s in lits] == want
    h = src32["exotune_controller.h"]
    assert "#define EXOTUNE_PRECISION_BITS 32" in h and "#define EXOTUNE_HAS_BUMPLESS 0" in h
    assert f"#define EXOTUNE_FLUSH_BELOW {c_float(FLUSH32)}" in h
    defined = dict(re.findall(r"#define (EXOTUNE_(?:OK|FAULT_[A-Z]+|ERR_[A-Z_]+)) (\d+)  /\* \S", h))
    assert defined == {name: str(v) for name, v, _what in RETURN_CODES}
    assert [(n, v) for n, v, _w in RETURN_CODES32] == [(n, v) for n, v, _w in RETURN_CODES]
    src = src32["exotune_controller.c"].split("exotune_build_info[]")[1]
    returned = set(re.findall(r"return (EXOTUNE_[A-Z_]+);", src))
    assert returned == set(defined)  # every code is returned somewhere
    assert not re.findall(r"return -?\d+;", src.split("int exotune_init")[1])  # never a bare number
    for text in src32.values():
        assert max(text.encode("utf-8")) < 128


def test_float_literals_round_trip():
    """c_float names the float32 value exactly, for any float32 (random magnitudes, the extremes)."""
    rng = np.random.default_rng(5)
    xs = list(rng.standard_normal(3000) * 10.0 ** rng.integers(-45, 38, 3000))
    xs += [0.0, 1.0, 2.0, FLT_MIN, 1e-45, float(np.finfo(np.float32).max), -float(np.finfo(np.float32).max)]
    for x in xs:
        s = c_float(x)
        assert s.endswith("f") and ("." in s or "e" in s)
        assert np.float32(float(s[:-1])) == np.float32(x), (x, s)


def test_input_limit_is_where_float_conversion_overflows():
    below = np.nextafter(INPUT_LIMIT32, 0.0)
    with np.errstate(over="ignore"):
        assert np.isinf(np.float32(INPUT_LIMIT32)) and np.float32(below) == np.finfo(np.float32).max


@needs_cc
def test_golden_test_passes_exactly_with_werror(doc32, src32, tmp_path):
    """-std=c99 -O2 -ffp-contract=off, the pedantic warnings, -Werror and (where available) the
    sanitizers: the golden test passes, every output exactly the float32 reference's; its rows after
    each controller's first init are the flushed inputs (command 0) then the file's golden inputs
    with the file's golden outputs."""
    exe = _build(tmp_path, src32, {}, "exotune_golden_test.c", flags=_sanitizers())
    res = subprocess.run([str(exe)], capture_output=True, text=True)
    assert res.returncode == 0 and res.stdout.rstrip().endswith("OK"), res.stdout + res.stderr
    assert "every output exact" in res.stdout
    rows = golden_rows32(doc32)
    assert all(r[5] == 0.0 for r in rows)
    outs = [doc32["golden"]["tau_cmd"]["values"]] + [e["golden_tau_cmd"]["values"]
                                                     for e in doc32["gain_schedule"]["entries"]]
    inits = [i for i, r in enumerate(rows) if r[0] == 0 and r[3] == 0 and r[2][0] == 0.0]
    assert [rows[i][1] for i in inits] == list(range(6))
    n = len(outs[0])
    for c, i in enumerate(inits):
        tiny = rows[i + 1:i + 7]
        assert all(r[3] == 0 and r[4] == 0.0 and 0 < max(map(abs, r[2])) < FLUSH32 for r in tiny)
        assert [r[4] for r in rows[i + 7:i + 7 + n]] == outs[c]  # exactly
    kinds = {(r[0], r[3]) for r in rows}
    assert {(1, 1), (1, 2), (3, 0), (3, 4), (2, 3), (0, 4)} <= kinds  # faults, a switch, a refused bumpless


@needs_cc
def test_a_coefficient_changed_by_1e_6_fails_the_golden_test(src32, tmp_path):
    """Every nonzero coefficient of the port (168: section beta/alpha, static gains, loop divisors),
    one at a time, multiplied by 1 + 1e-6: the compiled golden test fails each time, and passes
    unperturbed. Moved by one float32 ulp (6e-8..1.2e-7 of itself), 152 of the 168 fail it (measured:
    159 at 2 ulps, 162 at 4, all at 8, i.e. <= 9.5e-7); the rest are small terms (a beta2 of 8e-5,
    a beta0 of 0.03) whose one-ulp change is rounded away in every one of the golden outputs."""
    files = src32
    for name, text in {**files, "hook.c": '#include "exotune_controller.c"\n' + PERTURB_HOOK,
                       "m.c": PERTURB_MAIN}.items():
        (tmp_path / name).write_text(text, encoding="ascii")
    # the tables made writable (no const), the golden test's main renamed: three objects, one program
    for src, define in (("hook.c", "-Dconst="), ("exotune_golden_test.c", "-Dmain=golden_main"), ("m.c", "-DM")):
        subprocess.run([CC, *C_FLAGS.split(), define, "-c", "-o", str(tmp_path / (src + ".o")), str(tmp_path / src)],
                       check=True, capture_output=True, cwd=tmp_path)
    exe = tmp_path / "p"
    subprocess.run([CC, "-o", str(exe), *(str(tmp_path / f"{f}.o") for f in ("hook.c", "exotune_golden_test.c", "m.c")),
                    "-lm"], check=True, capture_output=True)
    out = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout
    assert "BASE 0" in out
    rel, ulp = re.findall(r"REL (\d+) (\d+)", out), re.findall(r"ULP (\d+) (\d+)", out)
    table = files["exotune_controller.c"].split("SECTIONS[")[1].split("};")[0]
    n_coef = sum(1 for row in re.findall(r"\{([^{}]*)\}", table) for x in row.split(",")
                 if float(x.strip().rstrip("f")) != 0.0)
    assert len(rel) == len(ulp) >= n_coef + 6 + 12  # section coefficients, the 6 divisors, the gains
    assert [k for k, rc in rel if rc != "1"] == []
    assert sum(rc == "1" for _k, rc in ulp) >= 0.85 * len(ulp)


@needs_cc
def test_fast_math_builds_do_not_compile(src32, tmp_path):
    """-ffast-math, -Ofast and -ffinite-math-only: the float32 port refuses to compile (#error)."""
    for name, text in src32.items():
        (tmp_path / name).write_text(text, encoding="ascii")
    errors = [subprocess.run([CC, "-std=c99", *flags, "-c", "-o", str(tmp_path / "x.o"),
                              str(tmp_path / "exotune_controller.c")], capture_output=True, text=True).stderr
              for flags in (["-O2", "-ffast-math"], ["-Ofast"], ["-O2", "-ffinite-math-only"])]
    assert all("#error" in e and "must not be built with -ffast-math" in e for e in errors), errors


def _has_fma() -> bool:
    try:
        return " fma " in Path("/proc/cpuinfo").read_text() + " "
    except OSError:
        return False


@needs_cc
@pytest.mark.skipif(not _has_fma(), reason="no FMA on this CPU (x86 -mfma)")
def test_fma_contraction_is_refused_at_init(src32, harness, tmp_path):
    """Built with FMA and -ffp-contract=fast (GCC's default outside ISO C mode), the step's a*b + c
    would be fused (other bits than the certified float32 controller): exotune_init's self-check
    sees it and returns EXOTUNE_ERR_FLOAT_ENV; the state cannot be stepped."""
    probe = subprocess.run([CC, "-mfma", "-x", "c", "-c", "-o", "/dev/null", "-"], input="int x;",
                           capture_output=True, text=True)
    if probe.returncode != 0:
        pytest.skip("this compiler has no -mfma")
    ok = _run(harness, ["init 0 0"])  # the same sources and flags without FMA: the module's build
    d = tmp_path / "fma"
    d.mkdir()
    exe = _build(d, src32, {"harness.c": HARNESS}, "harness.c", flags=["-mfma", "-ffp-contract=fast"])
    bad = _run(exe, ["init 0 0", _step([0.01, 0.1, 1.0, 10.0, 1.0])])
    assert ok == ["0"] and bad[0] == "5" and bad[1].split()[0] == "4"  # EXOTUNE_ERR_FLOAT_ENV, then ERR_ARGUMENT


def _reference32(doc, X, z0=None, limit=None):
    """Float32Runtime's outputs (or None: refused) for X from states z0 (default zero)."""
    rt = Float32Runtime(doc, limit_nm=limit)
    if z0 is not None:
        rt.z = [[np.float32(a), np.float32(b)] for a, b in z0]
    out = []
    for x in X:
        try:
            out.append(rt.step(dict(zip(SIGNALS, map(float, x)))))
        except ValueError:
            out.append(None)
    return out, rt


@needs_cc
def test_nan_and_out_of_float_inputs_are_faults_that_change_nothing(doc32, harness):
    """NaN, infinities and doubles that are infinite in float: EXOTUNE_FAULT_INPUT, the state
    unchanged (the next outputs are the reference's without those rows, exactly); FLT_MAX itself
    is a float: accepted or an overflow fault, as the reference says."""
    rng = np.random.default_rng(11)
    X = rng.standard_normal((60, 5)) * np.array([0.05, 2.0, 20.0, 500.0, 5.0])
    bad = {10: (2, float("nan")), 20: (0, float("inf")), 30: (4, -1e300), 40: (1, INPUT_LIMIT32),
           50: (3, -3.5e38)}
    for k, (i, v) in bad.items():
        X[k, i] = v
    out = [_parse(line) for line in _run(harness, ["init 0 0"] + [_step(x) for x in X])[1:]]
    assert [k for k, o in enumerate(out) if o[0] == 1] == sorted(bad)
    ref, _rt = _reference32(doc32, np.delete(X, sorted(bad), axis=0))
    got = [o[1] for k, o in enumerate(out) if k not in bad]
    assert got == ref  # bit for bit
    big = [np.nextafter(INPUT_LIMIT32, 0.0), 0.0, 0.0, 0.0, 0.0]
    o = _parse(_run(harness, ["init 0 0", _step(big)])[1])
    r, _rt = _reference32(doc32, [big])
    assert (o[0], o[1] if o[0] == 0 else None) == ((0, r[0]) if r[0] is not None else (2, None))


@needs_cc
def test_subnormal_inputs_and_states_are_flushed(doc32, harness):
    """States set to float subnormals and tiny values, then zero, subnormal (float and double) and
    threshold inputs: after every step no state is subnormal, and outputs and states are the
    reference's (which flushes the same) bit for bit."""
    n_sec = sum(len(s) for _i, s in step_order(doc32["controller"]["realization"])["sensed"])
    n_sec += sum(len(s) for s in step_order(doc32["controller"]["realization"])["loop"])
    rng = np.random.default_rng(2)
    z0 = rng.choice([1e-40, -1e-42, 1.4e-45, -5e-39, 2e-31, -9e-31, 1e-30, 0.0], size=(n_sec, 2))
    z0 = [[float(np.float32(a)), float(np.float32(b))] for a, b in z0]
    assert any(0 < abs(v) < FLT_MIN for row in z0 for v in row)
    X = np.zeros((40, 5))
    X[10:20] = rng.choice([1e-40, -1e-44, 5e-324, -1e-310, 3e-39, 1e-31], size=(10, 5))
    X[20:25] = float(np.float32(1e-30))
    lines = ["init 0 0"] + [f"setz {k} {j} {v!r}" for k, row in enumerate(z0) for j, v in enumerate(row)]
    out = [_parse(line) for line in _run(harness, lines + [_step(x) for x in X])[1:]]
    ref, rt = _reference32(doc32, X, z0)
    assert [o[0] for o in out] == [0] * len(X) and all(o[2] == 0 for o in out)
    assert [o[1] for o in out] == ref
    assert out[-1][3][:2 * n_sec] == [float(v) for row in rt.z for v in row]
    assert out[0][1] == 0.0 or any(v != 0.0 for v in out[0][3])  # the states were live, not all flushed at once


@needs_cc
def test_switch_resets_and_bumpless_is_refused(doc32, harness):
    """EXOTUNE_SWITCH_BUMPLESS: EXOTUNE_ERR_ARGUMENT and nothing changes (the controller and its
    states go on); EXOTUNE_SWITCH_RESET (and exotune_schedule with it): the new entry from the zero
    state, exactly its reference; a NaN joint angle is EXOTUNE_FAULT_ANGLE."""
    rng = np.random.default_rng(4)
    X = rng.standard_normal((30, 5)) * np.array([0.05, 2.0, 20.0, 500.0, 5.0])
    entries = doc32["gain_schedule"]["entries"]
    lines = ["init 1 0"] + [_step(x) for x in X[:10]] + ["switch 3 1"] + [_step(x) for x in X[10:20]]
    lines += ["schedule nan 0", f"schedule {entries[2]['joint_angle_rad']!r} 0"] + [_step(x) for x in X[20:]]
    out = _run(harness, lines)
    assert out[0] == "0" and out[11] == "4" and out[22] == "3 1" and out[23] == "0 3"
    rt = Float32Runtime(doc32, joint_angle_rad=entries[0]["joint_angle_rad"])
    ref = [rt.step(dict(zip(SIGNALS, map(float, x)))) for x in X[:20]]
    assert [_parse(line)[1] for line in out[1:11] + out[12:22]] == ref  # bumpless refused: controller 1 goes on
    rt = Float32Runtime(doc32, joint_angle_rad=entries[2]["joint_angle_rad"])
    assert [_parse(line)[1] for line in out[24:]] == [rt.step(dict(zip(SIGNALS, map(float, x)))) for x in X[20:]]


def test_a_coefficient_too_small_for_the_flush_is_refused(doc32):
    bad = copy.deepcopy(doc32)
    bad["controller"]["realization"]["filters"][0]["sections"][0][1] = float(np.float32(MIN_COEFFICIENT32 / 4))
    with pytest.raises(ConfigError, match="constant step time"):
        c_sources(bad)


@needs_cc
def test_codegen_of_an_exported_float32_file_end_to_end(tmp_path):
    """exotune export of a float32 design, exotune certify, exotune codegen (exit 0, the file's
    port with its sha256 and verdict), then the golden test built with -Werror passes."""
    design = _design32(tmp_path)
    ctl = tmp_path / "c32.yaml"
    r = CliRunner()
    res = r.invoke(cli, ["export", str(design), "--sample-rate-hz", "1000", "-o", str(ctl)])
    assert res.exit_code == 0, res.output
    assert r.invoke(cli, ["certify", str(ctl)]).exit_code == 0
    res = r.invoke(cli, ["codegen", str(ctl), "-o", str(tmp_path / "c")])
    assert res.exit_code == 0, res.output
    sha = hashlib.sha256(ctl.read_bytes()).hexdigest()
    trace = {"sha256": sha, "certified": True, "verdict": "CERTIFIED", "reasons": ()}
    files = {p.name: p.read_text(encoding="ascii") for p in (tmp_path / "c").iterdir()}
    assert files == c_sources(load_controller(ctl), trace)
    assert "6 controllers, 30 sections" in res.output and f"source sha256 {sha}: certified" in res.output
    exe = _build(tmp_path / "c", {}, {}, "exotune_golden_test.c")
    run = subprocess.run([str(exe)], capture_output=True, text=True)
    assert run.returncode == 0 and run.stdout.rstrip().endswith("OK") and "certification CERTIFIED" in run.stdout
