"""Hostile and malformed inputs (issue 16): every loader × attack, extreme numbers, typos and
outputs that would overwrite an input. Each row runs the command line in-process and asserts the
error contract: exit code 2, one stderr line ``exotune: error: <field or file>: …`` (plus the
listed further lines of a multi-error file), no traceback, no RuntimeWarning, nothing written.

A 60 s alarm guards every run, so a loader that blocks (a FIFO, ``/dev/zero``) fails its row
instead of hanging the suite.
"""

from __future__ import annotations

import errno
import os
import signal
import warnings
from pathlib import Path

import pytest
import yaml
from click.testing import CliRunner

from exotune.cli import cli
from exotune.config.yamlio import MAX_DEPTH, MAX_JSON_BYTES, MAX_YAML_BYTES

from disk_faults import full_disk_after

ROOT = Path(__file__).resolve().parents[1]
PAPER = ROOT / "examples" / "paper.yaml"
SEA = ROOT / "examples" / "sea.yaml"
LIMIT_S = 60  # a hang guard, not a speed test: a loaded 2-core CI machine runs analyze --plots in ~20 s


# ----------------------------------------------------------------------------------- harness
class _Hang(Exception):
    pass


def _alarm(_sig, _frame):
    raise _Hang(f"the command did not finish within {LIMIT_S} s")


def run_cli(args):
    """Run ``exotune ARGS`` in-process under a time limit; return (result, warnings caught)."""
    old = signal.signal(signal.SIGALRM, _alarm) if hasattr(signal, "SIGALRM") else None
    if old is not None:
        signal.alarm(LIMIT_S)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            res = CliRunner().invoke(cli, [str(a) for a in args])
    finally:
        if old is not None:
            signal.alarm(0)
            signal.signal(signal.SIGALRM, old)
    if isinstance(res.exception, _Hang):
        pytest.fail(f"exotune {' '.join(map(str, args))}: hangs")
    return res, caught


def listing(d: Path) -> dict:
    """Every file and directory under ``d`` (hidden ones included) with its size and mtime."""
    out = {}
    for root, dirs, names in os.walk(d):
        for nm in dirs:
            out[os.path.relpath(os.path.join(root, nm), d) + "/"] = None
        for nm in names:
            p = os.path.join(root, nm)
            st = os.lstat(p)
            out[os.path.relpath(p, d)] = (st.st_size, st.st_mtime_ns)
    return out


def assert_contract(res, caught, field: str, contains: str = "", more: int = 0):
    """Exit 2, the first stderr line ``exotune: error: <field>…``, ``more`` further lines."""
    assert res.exit_code == 2, (res.exit_code, res.output, res.exception)
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 + more, res.stderr
    assert lines[0].startswith(f"exotune: error: {field}"), lines[0]
    assert contains in lines[0], lines[0]
    assert all(len(line) < 400 for line in lines), "an error quotes more than a short excerpt"
    assert "Traceback" not in res.output and "RuntimeWarning" not in res.output
    assert not [w for w in caught if issubclass(w.category, RuntimeWarning)], [str(w.message) for w in caught]
    assert res.stdout == ""


# ----------------------------------------------------------------------------------- attacks
def _bomb(p: Path):
    lines = ['a0: &a0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    lines += [f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 10) + "]" for i in range(1, 10)]
    p.write_text("\n".join(lines) + "\n")


def _deep_list(p: Path):
    p.write_text("plant: " + "[" * 20000 + "]" * 20000 + "\n")


def _deep_map(p: Path):
    p.write_text("plant: " + "{a: " * 3000 + "1" + "}" * 3000 + "\n")


def _recursive(p: Path):
    p.write_text("plant: &x [1, *x]\n")


def _huge(p: Path):
    with open(p, "wb") as fh:  # sparse: costs no disk
        fh.truncate(MAX_YAML_BYTES + 1)


def _junk(p: Path):
    p.write_bytes(bytes(range(256)) * 64)


def _nul(p: Path):
    p.write_bytes(b"plant:\n  motor_inertia: 0.44\x00\n")


def _directory(p: Path):
    p.mkdir()


def _fifo(p: Path):
    if not hasattr(os, "mkfifo"):
        pytest.skip("no os.mkfifo on this platform")
    os.mkfifo(p)


def _dev_zero(p: Path):
    if not os.path.exists("/dev/zero"):
        pytest.skip("no /dev/zero on this platform")
    os.symlink("/dev/zero", p)


ATTACKS = {
    "alias-bomb": (_bomb, "aliases"),
    "deep-list": (_deep_list, f"{MAX_DEPTH} levels"),
    "deep-mapping": (_deep_map, f"{MAX_DEPTH} levels"),
    "recursive-alias": (_recursive, "recursive alias"),
    "huge-file": (_huge, "too large"),
    "binary-junk": (_junk, "cannot read file"),
    "nul-bytes": (_nul, "NUL"),
    "directory": (_directory, "a directory"),
    "fifo": (_fifo, "FIFO"),
    "dev-zero": (_dev_zero, "character device"),
}

# loader -> command line with {f} for the attacked file, {t} for the test directory
LOADERS = {
    "design": ["design", "{f}"],
    "analyze": ["analyze", "{f}"],
    "sea": ["sea", "{f}"],
    "export": ["export", "{f}", "--sample-rate-hz", "1000", "-o", "{t}/out.yaml"],
    "certify": ["certify", "{f}"],
    "simulate": ["simulate", "{f}", "--scenario", "locked-output"],
    "sweep-spec": ["sweep", "{f}", "-o", "{t}/sweep"],
    "optimize-spec": ["optimize", "{f}", "-o", "{t}/out.yaml"],
}


@pytest.mark.parametrize("attack", list(ATTACKS))
@pytest.mark.parametrize("loader", list(LOADERS))
def test_loader_attack(tmp_path, loader, attack):
    make, contains = ATTACKS[attack]
    f = tmp_path / "in.yaml"
    make(f)
    before = listing(tmp_path)
    args = [a.format(f=f, t=tmp_path) for a in LOADERS[loader]]
    res, caught = run_cli(args)
    assert_contract(res, caught, str(f), contains)
    assert listing(tmp_path) == before


def _json_deep(p: Path):
    p.write_text("[" * 100000 + "]" * 100000)


def _json_huge(p: Path):
    with open(p, "wb") as fh:  # sparse; above any manifest limit (the sweep's own is 64 MiB)
        fh.truncate(max(MAX_JSON_BYTES, 1 << 30) + 1)


MANIFEST_ATTACKS = {
    "deep-brackets": (_json_deep, f"{MAX_DEPTH} levels"),
    "huge-file": (_json_huge, "too large"),
    "directory": (_directory, ""),
    "fifo": (_fifo, ""),
    "dev-zero": (_dev_zero, ""),
}


@pytest.mark.parametrize("attack", list(MANIFEST_ATTACKS))
def test_manifest_attack(tmp_path, attack):
    """``report`` reads a sweep manifest through the guarded JSON reader."""
    make, contains = MANIFEST_ATTACKS[attack]
    d = tmp_path / "sweep"
    d.mkdir()
    make(d / "manifest.json")
    before = listing(tmp_path)
    res, caught = run_cli(["report", d])
    assert_contract(res, caught, str(d / "manifest.json"), contains)
    assert listing(tmp_path) == before


# -------------------------------------------------------------------------- extreme numbers
def _edited(tmp_path: Path, src: Path, old: str, new: str) -> Path:
    text = src.read_text(encoding="utf-8")
    assert old in text
    p = tmp_path / "in.yaml"
    p.write_text(text.replace(old, new, 1), encoding="utf-8")
    return p


NUMBERS = [
    ("design", PAPER, "felt_inertia: 0.25", "felt_inertia: 1.0e-300", "design.felt_inertia", "[1e-9, 1e6] kg·m²"),
    ("sea", SEA, "B1: 1387.0", "B1: 1.0e308", "gains.B1", "[-1e9, 1e9]"),
    ("analyze", PAPER, "sea_stiffness: 1180.0", "sea_stiffness: 1.0e300", "plant.sea_stiffness", "[1e-6, 1e9] N·m/rad"),
    ("analyze", PAPER, "motor_inertia: 0.44", "motor_inertia: 1.0e-200", "plant.motor_inertia", "[1e-9, 1e6]"),
    ("design", PAPER, "motor_damping: 17.9", "motor_damping: 1.0e30", "plant.motor_damping", "[0, 1e7] N·m·s/rad"),
    ("design", PAPER, "amplification: 8.0", "amplification: 1.0e9", "design.amplification", "[1, 1e4]"),
    ("design", PAPER, "delay_s: 0.001", "delay_s: 50.0", "implementation.delay_s", "[0, 1] s"),
    ("design", PAPER, "cutoff_hz: 80.0", "cutoff_hz: 1.0e12", "implementation.gv_filter.cutoff_hz", "[0.001, 1e7] Hz"),
    ("design", PAPER, "zeta: 0.7", "zeta: 1.0e300", "design.zeta", "[0.001, 1000]"),
    ("design", PAPER, "inertia: [0.001, 1.0]", "inertia: [1.0e-300, 1.0]", "humans[0].inertia", "range lo"),
    ("design", PAPER, "stiffness: [1.0, 10000.0]", "stiffness: [1.0, 1.0e300]", "humans[1].stiffness", "range hi"),
    ("export", PAPER, "cuff_stiffness: 300.0", "cuff_stiffness: 1.0e-300", "plant.cuff_stiffness", "[1e-6, 1e9]"),
]


@pytest.mark.parametrize("cmd,src,old,new,field,rng", NUMBERS, ids=[r[4] for r in NUMBERS])
def test_extreme_numbers(tmp_path, cmd, src, old, new, field, rng):
    p = _edited(tmp_path, src, old, new)
    args = [cmd, p] + (["--sample-rate-hz", "1000", "-o", tmp_path / "c.yaml"] if cmd == "export" else [])
    before = listing(tmp_path)
    res, caught = run_cli(args)
    assert_contract(res, caught, f"{field}: ", rng)
    assert "accepted range" in res.stderr
    assert listing(tmp_path) == before


def test_extreme_number_in_a_controller_file(tmp_path):
    src = ROOT / "results" / "pipeline" / "controller_1khz.yaml"
    if not src.exists():
        pytest.skip("no shipped controller file")
    doc = yaml.safe_load(src.read_text(encoding="utf-8"))
    doc["plant"]["motor_inertia"]["value"] = 1.0e-200
    p = tmp_path / "c.yaml"
    p.write_text(yaml.safe_dump(doc, sort_keys=False, allow_unicode=True), encoding="utf-8")
    res, caught = run_cli(["certify", p])
    assert_contract(res, caught, "plant.motor_inertia.value: ", "[1e-9, 1e6] kg·m²")


def test_extreme_sweep_axis_value(tmp_path):
    spec = tmp_path / "s.yaml"
    spec.write_text(f"base: {PAPER}\naxes:\n  plant.motor_inertia: [1.0e-200, 0.44]\n")
    res, caught = run_cli(["sweep", spec, "-o", tmp_path / "out"])
    assert_contract(res, caught, "axes.plant.motor_inertia: ", "accepted range")
    assert not (tmp_path / "out").exists()


# ---------------------------------------------------------------------------------- typos
def test_typo_is_named_with_a_suggestion_and_every_error_listed(tmp_path):
    p = _edited(tmp_path, PAPER, "motor_inertia: 0.44", "motor_inertai: 0.44")
    res, caught = run_cli(["design", p])
    assert_contract(res, caught, "plant.motor_inertai: unknown key; did you mean motor_inertia?", more=1)
    assert res.stderr.strip().splitlines()[1] == "plant.motor_inertia: required parameter is missing"


def test_several_errors_one_line_each(tmp_path):
    text = PAPER.read_text(encoding="utf-8")
    text = text.replace("felt_inertia: 0.25", "felt_intertia: 0.25").replace("zeta_hat: 0.7", "zeta_hat: -1")
    text = text.replace("{kind: spring, stiffness: [1.0, 10000.0]", "{kind: spring, stiffness: [10.0, 1.0]")
    p = tmp_path / "in.yaml"
    p.write_text(text, encoding="utf-8")
    res, caught = run_cli(["analyze", p])
    assert_contract(res, caught, "design.felt_intertia: unknown key; did you mean felt_inertia?", more=3)
    rest = res.stderr.strip().splitlines()[1:]
    assert rest[0].startswith("design.felt_inertia: required")
    assert rest[1].startswith("design.zeta_hat: must be > 0")
    assert rest[2].startswith("humans[1].stiffness: malformed range")


def test_unknown_key_without_a_close_match_lists_the_allowed_keys(tmp_path):
    p = _edited(tmp_path, PAPER, "motor_inertia: 0.44", "motor_inertia: 0.44\n  wheel_count: 3")
    res, caught = run_cli(["design", p])
    assert_contract(res, caught, "plant.wheel_count: unknown key (allowed keys: motor_inertia")


# ---------------------------------------------------------------------- the wrong kind of file
def _controller_like(tmp_path: Path) -> Path:
    p = tmp_path / "c.yaml"
    p.write_text("schema: exotune.controller/1\nplant: {}\n")
    return p


WRONG_KIND = [
    (["design", SEA], str(SEA), "this is an SEA file: use `exotune sea"),
    (["analyze", SEA], str(SEA), "this is an SEA file: use `exotune sea"),
    (["certify", PAPER], str(PAPER), "this is a design file: export it first with `exotune export"),
    (["certify", SEA], str(SEA), "this is an SEA file"),
    (["sea", PAPER], str(PAPER), "this is a design file: use `exotune design"),
    (["analyze", "CONTROLLER"], "CONTROLLER", "this is a controller file"),
]


@pytest.mark.parametrize("args,field,contains", WRONG_KIND, ids=[" ".join(map(str, a[0][:2])) for a in WRONG_KIND])
def test_wrong_kind_of_file_names_the_command(tmp_path, args, field, contains):
    if "CONTROLLER" in args:
        c = _controller_like(tmp_path)
        args, field = [str(c) if a == "CONTROLLER" else a for a in args], str(c)
    res, caught = run_cli(args)
    assert_contract(res, caught, f"{field}: ", contains)


# ---------------------------------------------------------------------------------- outputs
def _copy(src: Path, dst: Path) -> Path:
    dst.write_bytes(src.read_bytes())
    return dst


def _optimize_spec(tmp_path: Path) -> Path:
    spec = tmp_path / "o.yaml"
    spec.write_text(f"base: {PAPER}\nfree:\n  design.amplification: [2.0, 4.0]\n")
    return spec


OUTPUTS = {
    "export -o input": lambda t: (["export", "--allow-uncertified", _copy(PAPER, t / "in.yaml"), "--sample-rate-hz", "1000", "-o",
                                   t / "in.yaml"], "-o "),
    "export -o ./input": lambda t: (["export", "--allow-uncertified", _copy(PAPER, t / "in.yaml"), "--sample-rate-hz", "1000", "-o",
                                     f"{t}/./in.yaml"], "-o "),
    "export -o hard link": lambda t: (["export", "--allow-uncertified", _copy(PAPER, t / "in.yaml"), "--sample-rate-hz", "1000", "-o",
                                       (os.link(t / "in.yaml", t / "h.yaml"), t / "h.yaml")[1]], "-o "),
    "export -o symlink": lambda t: (["export", "--allow-uncertified", _copy(PAPER, t / "in.yaml"), "--sample-rate-hz", "1000", "-o",
                                     (os.symlink(t / "in.yaml", t / "s.yaml"), t / "s.yaml")[1]], "-o "),
    "export -o directory": lambda t: (["export", "--allow-uncertified", PAPER, "--sample-rate-hz", "1000", "-o",
                                       (os.mkdir(t / "d"), t / "d")[1]], "-o "),
    "export -o under a file": lambda t: (["export", "--allow-uncertified", PAPER, "--sample-rate-hz", "1000", "-o",
                                          _copy(PAPER, t / "f.yaml") / "c.yaml"], "-o "),
    "optimize -o spec": lambda t: (["optimize", _optimize_spec(t), "-o", t / "o.yaml"], "-o "),
    "optimize -o base": lambda t: (["optimize", (_copy(PAPER, t / "b.yaml"), (t / "o.yaml").write_text(
        "base: b.yaml\nfree:\n  design.amplification: [2.0, 4.0]\n"), t / "o.yaml")[2], "-o", t / "b.yaml"], "-o "),
    "optimize --pareto spec": lambda t: (["optimize", _optimize_spec(t), "-o", t / "out.yaml", "--pareto",
                                          t / "o.yaml"], "--pareto "),
    "optimize --pareto = -o": lambda t: (["optimize", _optimize_spec(t), "-o", t / "out.yaml", "--pareto",
                                          t / "out.yaml"], "--pareto "),
    "optimize --pareto DIR/": lambda t: (["optimize", _optimize_spec(t), "-o", t / "out.yaml", "--pareto",
                                          f"{t}/pdir/"], "--pareto "),
    "optimize --pareto existing dir": lambda t: (["optimize", _optimize_spec(t), "-o", t / "out.yaml", "--pareto",
                                                  (os.mkdir(t / "pd"), t / "pd")[1]], "--pareto "),
    "design --plots onto the input": lambda t: (["design", _copy(PAPER, t / "in.yaml"), "--plots", t / "in.yaml"],
                                                "--plots "),
    "analyze --plots onto a file": lambda t: (["analyze", PAPER, "--plots", _copy(PAPER, t / "x.yaml")], "--plots "),
    "export -o a FIFO": lambda t: (["export", "--allow-uncertified", PAPER, "--sample-rate-hz", "1000", "-o",
                                    (os.mkfifo(t / "fifo"), t / "fifo")[1]], "-o "),
    "design --plots into a directory holding the input under a figure's name": lambda t: (
        ["design", _copy(PAPER, t / "bode_C4.png"), "--plots", t], "--plots "),
    "sweep -o onto the spec": lambda t: (["sweep", (t / "s.yaml", (t / "s.yaml").write_text(
        f"base: {PAPER}\naxes:\n  design.amplification: [2.0, 4.0]\n"))[0], "-o", t / "s.yaml"], "-o "),
}


@pytest.mark.parametrize("case", list(OUTPUTS))
def test_output_refused_before_any_work(tmp_path, case):
    args, option = OUTPUTS[case](tmp_path)
    path = str(args[args.index(option.strip()) + 1])
    before = listing(tmp_path)
    res, caught = run_cli(args)
    assert_contract(res, caught, f"{path}: ", option.strip())
    assert listing(tmp_path) == before


@pytest.mark.parametrize("existing", [False, True])
def test_design_plots_full_disk_leaves_nothing(tmp_path, monkeypatch, existing):
    plots = tmp_path / "plots"
    if existing:
        plots.mkdir()
        (plots / "keep.txt").write_text("x")
    full_disk_after(monkeypatch, 2)
    before = listing(tmp_path)
    res, caught = run_cli(["design", PAPER, "--plots", plots])
    assert_contract(res, caught, f"{plots}: cannot write output")
    assert listing(tmp_path) == before
    assert plots.exists() == existing


def test_analyze_plots_failure_leaves_nothing(tmp_path, monkeypatch):
    import exotune.plots.analysis as pa

    def write_some_then_fail(figs, out):
        Path(out, "first.png").write_bytes(b"png")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), os.path.join(out, "second.png"))

    monkeypatch.setattr(pa, "write_analysis_plots", write_some_then_fail)
    plots = tmp_path / "a" / "plots"
    res, caught = run_cli(["analyze", PAPER, "--plots", plots])
    assert_contract(res, caught, f"{plots}: cannot write output")
    assert os.listdir(tmp_path) == []


def test_base_file_contents_are_not_printed(tmp_path):
    """``base: <some text file>`` quotes a short excerpt of it at most."""
    secret = tmp_path / "secret.txt"
    secret.write_text("\n".join(f"user{i}:x:{i}:{i}:SECRET-LINE-{i}:/home/u{i}:/bin/sh" for i in range(200)))
    for cmd, extra in (("sweep", ["-o", tmp_path / "out"]), ("optimize", ["-o", tmp_path / "out.yaml"])):
        spec = tmp_path / "spec.yaml"
        body = "axes:\n  design.amplification: [2.0]\n" if cmd == "sweep" else "free:\n  design.amplification: [2.0, 4.0]\n"
        spec.write_text(f"base: {secret}\n{body}")
        res, caught = run_cli([cmd, spec] + extra)
        assert_contract(res, caught, "base")
        assert res.stderr.count("SECRET-LINE") <= 3, res.stderr


def test_valid_files_still_load():
    """The guarded path reads every shipped example and study (their designs stay valid)."""
    from exotune.config import load_design, load_sea, read_yaml

    assert load_design(PAPER).raw["design"]["amplification"] == 8.0
    load_design(ROOT / "examples" / "scheduled.yaml")
    load_sea(SEA)
    for p in sorted((ROOT / "studies").glob("*.yaml")):
        m = read_yaml(p)
        if "plant" in m:
            load_design(p)


# ------------------------------------------------------------------ every command × every file
@pytest.fixture(scope="module")
def shipped_files(tmp_path_factory):
    """The shipped examples and the templates ``exotune init`` writes."""
    d = tmp_path_factory.mktemp("init")
    res = CliRunner().invoke(cli, ["init", str(d)])
    assert res.exit_code == 0, res.output
    files = sorted((ROOT / "examples").glob("*.yaml")) + sorted(d.glob("*.yaml"))
    assert len(files) >= 6
    return files


def _computed_once(monkeypatch, cmd):
    """The library call behind ``exotune CMD`` made once per file and reused by its text and JSON
    views (the command line still parses, calls, renders and exits as a user's would; the
    analysis of a gain-scheduled example takes ~10 s)."""
    import exotune.api as api

    real, done = getattr(api, cmd), {}

    def once(source, *args, **kw):
        key = (str(source), repr(args), repr(sorted(kw.items())))
        if key not in done:
            try:
                done[key] = (True, real(source, *args, **kw))
            except Exception as e:  # noqa: BLE001 - replayed to the second view, as the command raised it
                done[key] = (False, e)
        ok, value = done[key]
        if ok:
            return value
        raise value

    monkeypatch.setattr(api, cmd, once)


@pytest.mark.parametrize("cmd", ["design", "sea", "analyze", "certify"])
def test_every_command_on_every_shipped_file(shipped_files, cmd, monkeypatch):
    """No traceback, ever: a result (exit 0/1) or the one-line contract naming the fitting command
    (exit 2), as text and as JSON. (``export`` and ``simulate`` of these files are covered by their
    own suites.)"""
    _computed_once(monkeypatch, cmd)
    for f in shipped_files:
        for as_json in (False, True):
            res, caught = run_cli([cmd, f] + (["--json"] if as_json else []))
            where = f"exotune {cmd} {f.name}{' --json' if as_json else ''}"
            assert res.exit_code in (0, 1, 2), (where, res.exit_code, res.exception)
            assert "Traceback" not in res.output, where
            assert not [w for w in caught if issubclass(w.category, RuntimeWarning)], where
            if res.exit_code == 2:
                assert res.stderr.startswith("exotune: error: "), (where, res.stderr)
                assert res.stdout == "", where


# ------------------------------------------------ optimize / sweep / report (hostile-input hunt F)
_NO_DOB_BASE = ("  plant: {motor_inertia: 0.44, motor_damping: 17.9, sea_stiffness: 1180.0, joint_inertia: 0.29, "
                "cuff_stiffness: 300.0}\n"
                "  design: {amplification: 8.0, felt_inertia: 0.25, felt_damping: 1.0, zeta: 0.7, zeta_hat: 0.7}\n"
                "  implementation: {delay_s: 0.001, gv_filter: {cutoff_hz: 80.0, damping: 0.7}, "
                "derivative_filter: {cutoff_hz: 100.0}, dob: null}\n"
                "  humans: [{kind: spring, stiffness: [1.0, 100.0]}]\n")


def _opt_spec(tmp_path, extra: str = "") -> Path:
    spec = tmp_path / "spec.yaml"
    spec.write_text("base:\n" + _NO_DOB_BASE + "free:\n  design.amplification: [2.0, 4.0]\nbudget: 50\n" + extra)
    return spec


def test_optimize_full_disk_on_the_pareto_front_leaves_nothing(tmp_path, monkeypatch):
    """``optimize -o O --pareto F`` with a full disk at F left O behind (exit 2): both or neither."""
    spec = _opt_spec(tmp_path)
    full_disk_after(monkeypatch, 1)
    before = listing(tmp_path)
    res, caught = run_cli(["optimize", spec, "-o", tmp_path / "out.yaml", "--pareto", tmp_path / "p.csv"])
    assert_contract(res, caught, f"{tmp_path / 'p.csv'}: cannot write output: No space left on device")
    assert listing(tmp_path) == before


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs Linux /proc (a directory that refuses new files)")
def test_optimize_pareto_that_cannot_be_created_is_refused_before_the_search(tmp_path, monkeypatch):
    """``--pareto /proc/x.csv``: exit 2 after the search with O left behind; now before it."""
    import exotune.optimization.runner as runner

    monkeypatch.setattr(runner, "optimize", lambda *a, **k: pytest.fail("the search ran"))
    spec = _opt_spec(tmp_path)
    before = listing(tmp_path)
    res, caught = run_cli(["optimize", spec, "-o", tmp_path / "out.yaml", "--pareto", "/proc/exotune-hF.csv"])
    assert_contract(res, caught, "/proc/exotune-hF.csv: cannot write output (--pareto): ")
    assert listing(tmp_path) == before


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs Linux /proc (a directory that refuses new files)")
@pytest.mark.parametrize("args, option", [
    (["analyze", PAPER, "--plots", "/proc/exotune-hP"], "--plots"),
    (["design", PAPER, "--plots", "/proc/exotune-hP"], "--plots"),
    (["export", PAPER, "--sample-rate-hz", "1000", "-o", "/proc/exotune-hP.yaml"], "-o"),
    (["simulate", ROOT / "examples" / "scheduled.yaml", "--scenario", "locked-output", "--plots", "/proc/exotune-hP"],
     "--plots"),
])
def test_every_output_that_cannot_be_created_is_refused_before_the_work(tmp_path, monkeypatch, args, option):
    """Only optimize probed its outputs before the work; the others refused ``/proc/x`` (writable
    by the permission bits as root) only when writing. The probe is now part of every command's
    output check: the line names the option, which the check before the work does."""
    monkeypatch.chdir(tmp_path)
    res, caught = run_cli(args)
    assert_contract(res, caught, f"{args[-1]}: cannot write output ({option}): ")
    assert listing(tmp_path) == {}


@pytest.mark.parametrize("extra, field", [
    ("constraints:\n  dob_phase_margin_deg: 30\n", "constraints.dob_phase_margin_deg"),
    ("constraints:\n  dob_gain_margin_db: 6\n", "constraints.dob_gain_margin_db"),
    ("objective: dob_delay_margin_s\n", "objective"),
], ids=["phase-margin", "gain-margin", "objective"])
def test_optimize_dob_measure_without_a_dob_is_refused_up_front(tmp_path, monkeypatch, extra, field):
    """A DOB margin asked of a base with ``dob: null`` ran the whole search and exited 1 ("nan deg,
    needed >= 30 deg", or "the best one breaks: " with nothing after); exit 2 before the search."""
    import exotune.optimization.runner as runner

    monkeypatch.setattr(runner, "optimize", lambda *a, **k: pytest.fail("the search ran"))
    res, caught = run_cli(["optimize", _opt_spec(tmp_path, extra), "-o", tmp_path / "out.yaml"])
    assert_contract(res, caught, f"{field}: ", "no disturbance observer (implementation.dob: null)")
    assert not (tmp_path / "out.yaml").exists()


def test_api_numpy_seed_and_argument_types_are_named(tmp_path):
    """``optimize(seed=np.int64(1))`` was refused; ``simulate(progress=5)`` and ``init(None)``
    raised raw TypeErrors naming no argument."""
    import numpy as np

    import exotune
    from exotune.errors import ConfigError

    spec = {"base": str(ROOT / "examples" / "scheduled.yaml"), "free": {"design.amplification": [2.0, 12.0]},
            "budget": np.int64(50)}
    r = exotune.optimize(spec, tmp_path / "a.yaml", seed=np.int64(1))
    assert r.feasible and r.to_dict()["spec"]["seed"] == 1
    with pytest.raises(TypeError, match="^progress must be a function"):
        exotune.simulate(ROOT / "examples" / "scheduled.yaml", "locked-output", progress=5)
    with pytest.raises(ConfigError) as ei:
        exotune.init(None)
    assert ei.value.field == "directory" and "expected a path" in ei.value.reason


def _small_sweep(tmp_path) -> Path:
    spec = tmp_path / "sweep.yaml"
    spec.write_text(f"base: {PAPER}\naxes:\n  design.amplification: [2, 4, 6]\nchunk_size: 2\n")
    res = CliRunner().invoke(cli, ["sweep", str(spec), "-o", "out", "--workers", "1"])
    assert res.exit_code == 0, res.output
    return tmp_path / "out"


def test_report_with_the_chunks_directory_deleted_is_incomplete(tmp_path, monkeypatch):
    """``report out`` after ``out/chunks`` was deleted: "-o: the sweep has no results yet (no chunk
    finished)" — no -o given, three chunks done. Now: incomplete, the missing chunks named."""
    import shutil

    monkeypatch.chdir(tmp_path)
    out = _small_sweep(tmp_path)
    shutil.rmtree(out / "chunks")
    res, caught = run_cli(["report", "out"])
    assert_contract(res, caught, "out: the sweep is incomplete (2 of 2 chunks missing: chunks 0, 1; the directory "
                                 "out/chunks is gone)", "rerun `exotune sweep` with the same spec and -o out")
    assert not (out / "report").exists()


@pytest.mark.parametrize("key, value, field", [("format_version", 2, "format_version"), ("status", 5, "status")])
def test_report_refuses_an_unknown_manifest_format_or_status(tmp_path, monkeypatch, key, value, field):
    """A manifest with ``format_version: 2`` or ``status: 5`` was reported (exit 0)."""
    import json

    monkeypatch.chdir(tmp_path)
    out = _small_sweep(tmp_path)
    m = json.loads((out / "manifest.json").read_text())
    m[key] = value
    (out / "manifest.json").write_text(json.dumps(m))
    before = listing(tmp_path)
    res, caught = run_cli(["report", "out"])
    assert_contract(res, caught, f"{os.path.join('out', 'manifest.json')}: {field}: ")
    assert listing(tmp_path) == before


def test_sweep_with_a_file_named_chunks_names_it(tmp_path, monkeypatch):
    """``sweep -o out`` with a file ``out/chunks``: "-o: cannot create the output directory: File
    exists"; the path in the way is named now, nothing written."""
    monkeypatch.chdir(tmp_path)
    spec = tmp_path / "sweep.yaml"
    spec.write_text(f"base: {PAPER}\naxes:\n  design.amplification: [2.0]\n")
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "chunks").write_text("x\n")
    before = listing(tmp_path)
    res, caught = run_cli(["sweep", spec, "-o", "out", "--workers", "1"])
    assert_contract(res, caught, f"{os.path.join('out', 'chunks')}: exists and is not a directory")
    assert listing(tmp_path) == before


# ------------------------------------------------ identify / excite outputs (hostile-input hunt F)
def _identify_log(path: Path) -> Path:
    """A held-command log at 1 kHz (3 s, delay one sample) as CSV (tests/ is on the path: conftest)."""
    from identification.simulated_logs import held_logs

    cols = held_logs(1, 1000.0, 3.0, seed0=5)[0]
    names = list(cols)
    path.write_text(",".join(names) + "\n" + "".join(",".join(repr(float(x)) for x in r) + "\n"
                                                     for r in zip(*(cols[n] for n in names))))
    return path


@pytest.mark.parametrize("second", ["--frf-csv", "--plots"])
def test_identify_full_disk_on_a_later_output_leaves_nothing(tmp_path, monkeypatch, second):
    """``identify -o P --frf-csv F`` (or ``--plots D``) with a full disk at F: exit 2 and P stayed
    behind. All or none now, with the one message style of every command."""
    log = _identify_log(tmp_path / "log.csv")
    target = tmp_path / ("frf.csv" if second == "--frf-csv" else "plots")
    full_disk_after(monkeypatch, 1)
    before = listing(tmp_path)
    res, caught = run_cli(["identify", log, "--delay-s", "0.001", "-o", tmp_path / "plant.yaml", second, target])
    assert_contract(res, caught, f"{target}: cannot write output: No space left on device")
    assert listing(tmp_path) == before


def test_excite_full_disk_on_the_sidecar_keeps_the_previous_command(tmp_path, monkeypatch):
    out = tmp_path / "exc.csv"
    out.write_text("the previous command\n")
    full_disk_after(monkeypatch, 1)
    before = listing(tmp_path)
    res, caught = run_cli(["excite", "-o", out, "--sample-rate-hz", "1000", "--f-lo-hz", "1", "--f-hi-hz", "10",
                           "--rms-nm", "1", "--periods", "2"])
    assert_contract(res, caught, f"{tmp_path / 'exc.json'}: cannot write output: No space left on device")
    assert listing(tmp_path) == before


# ------------------------------------------- a field spelt like a keyword is not always that option
@pytest.mark.parametrize("command", ["sweep", "optimize", "analyze", "export"])
def test_a_file_key_spelt_like_an_option_is_named_as_the_key(tmp_path, monkeypatch, command):
    """A file with the unknown key ``out`` was reported as "-o: unknown key …" (the option the user
    gave, or did not give): the file's key is named."""
    monkeypatch.chdir(tmp_path)
    if command in ("sweep", "optimize"):
        body = f"base: {PAPER}\nout: 1\n" + ("axes:\n  design.amplification: [2.0]\n" if command == "sweep" else "")
    else:
        body = PAPER.read_text() + "\nout: 1\n"
    (tmp_path / "in.yaml").write_text(body)
    extra = {"sweep": ["-o", "res"], "optimize": ["-o", "res.yaml"], "analyze": [],
             "export": ["--sample-rate-hz", "1000", "-o", "res.yaml"]}[command]
    before = listing(tmp_path)
    res, caught = run_cli([command, "in.yaml", *extra])
    assert_contract(res, caught, "out: unknown key")
    assert listing(tmp_path) == before


def test_a_missing_keyword_is_named_as_its_option_and_a_typed_path_as_typed(tmp_path, monkeypatch):
    """The keyword the user did not give is the option (``--sample-rate-hz``); a directory typed
    as the argument of ``report`` and spelt ``out`` is the directory, not ``-o``."""
    monkeypatch.chdir(tmp_path)
    res, caught = run_cli(["export", PAPER, "-o", "c.yaml"])
    assert_contract(res, caught, "--sample-rate-hz: ")
    (tmp_path / "out").mkdir()
    res, caught = run_cli(["report", "out"])
    assert_contract(res, caught, "out: not a sweep directory")
