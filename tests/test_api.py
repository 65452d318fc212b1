"""The public API (exotune/__init__.py, exotune/api.py, exotune/results.py) and its python-control
interop, checked against the command line's JSON and against python-control built independently
from the physical equations."""

from __future__ import annotations

import doctest
import importlib
import json
import math
import subprocess
import sys
from pathlib import Path

import control
import numpy as np
import pytest

from click.testing import CliRunner

import exotune
from exotune.cli import cli
from exotune.errors import ConfigError

ROOT = Path(__file__).resolve().parents[1]
PAPER = ROOT / "examples" / "paper.yaml"
SCHED = ROOT / "examples" / "scheduled.yaml"


@pytest.fixture(scope="module")
def sched_export(tmp_path_factory):
    """examples/scheduled.yaml exported at 1 kHz, once for the tests that only read the file (an
    export is most of a test's time: every test that changes or writes a file uses its tmp_path)."""
    return exotune.export(SCHED, 1000.0, tmp_path_factory.mktemp("sched") / "c.yaml")


@pytest.fixture(scope="module")
def sched_export_run(sched_export):
    """``simulate`` of that exported controller (locked-output, 0.6 s), once for the tests comparing
    another form of the same controller with it (each run certifies the file first)."""
    return exotune.simulate(sched_export, "locked-output", duration=0.6)


@pytest.fixture(scope="module")
def paper_export(tmp_path_factory):
    """examples/paper.yaml exported at 1 kHz (it does not certify: written anyway), once for the tests
    that only read it."""
    out = tmp_path_factory.mktemp("paper") / "c.yaml"
    return exotune.export(PAPER, 1000.0, out, allow_uncertified=True), out


def _cli_json(*args) -> dict:
    p = subprocess.run([sys.executable, "-m", "exotune", *args, "--json"], capture_output=True, text=True, cwd=ROOT)
    assert p.returncode in (0, 1), p.stderr
    return json.loads(p.stdout)


def test_public_names_and_cheap_import():
    for name in ("load_design", "design", "analyze", "sweep", "report", "optimize", "export", "certify", "codegen", "identify", "simulate"):
        assert name in exotune.__all__ and callable(getattr(exotune, name))
    code = "import sys, exotune; print(sorted(m for m in sys.modules if m.startswith(('exotune.', 'control', 'cvxpy', 'matplotlib'))))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True).stdout
    assert out.strip() == "['exotune.version']"
    # the API module and the analysis (a sweep worker's imports) load no sampled-data, controller-file
    # or simulation code and not scipy.signal (about a second each time a process starts)
    code = ("import sys, exotune.api, exotune.analysis, exotune.sweeps.compute; print(sorted(m for m in "
            "('scipy.signal', 'exotune.sampled', 'exotune.controllerfile', 'exotune.simulation') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True).stdout
    assert out.strip() == "[]"
    with pytest.raises(AttributeError):
        exotune.no_such_thing  # noqa: B018
    # no subpackage shadows an API function once imported (import exotune.<sub> sets the attribute)
    code = ("import importlib, pkgutil, exotune\n"
            "for m in pkgutil.walk_packages(exotune.__path__, 'exotune.'):\n"
            "    importlib.import_module(m.name)\n"
            "bad = [n for n in exotune.__all__ if n != '__version__' and not (callable(getattr(exotune, n)) "
            "and not isinstance(getattr(exotune, n), type(exotune)))]\n"
            "print(bad)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True).stdout
    assert out.strip() == "[]"


HEAVY = ("scipy.signal", "control", "matplotlib", "pyarrow", "pandas", "exotune.sampled", "exotune.controllerfile.ccode",
         "exotune.controllerfile.ccode32", "exotune.controllerfile.cgolden", "exotune.controllerfile.cgolden32",
         "exotune.controllerfile.cstep")


@pytest.mark.parametrize("fn, also", [("analyze", ("cvxpy", "scipy.stats")), ("design", ("cvxpy",))])
def test_a_continuous_design_imports_nothing_heavy(fn, also):
    """``exotune analyze`` and ``exotune design`` of a design without a sample rate (issue 24):
    no scipy.signal (a second to import: tf2ss is exotune.numerics.statespace's), python-control,
    matplotlib, pyarrow/pandas, sampled-data model or C code generator (the package namespaces
    are lazy: exotune.controllerfile.verdicts used to import them all), nor cvxpy (and scipy.stats
    through it, 1.8 s): analyze's KYP certificates are posed to Clarabel directly."""
    heavy = HEAVY + also
    code = (f"import json, sys, exotune.api; exotune.api.{fn}('examples/paper.yaml'); "
            f"print(json.dumps(sorted(m for m in sys.modules if m.startswith({tuple(h + '.' for h in heavy)!r}) "
            f"or m in {heavy!r})))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True).stdout
    assert json.loads(out) == []


def test_load_design_accepts_path_mapping_and_object():
    import yaml

    a = exotune.load_design(PAPER)
    b = exotune.load_design(str(PAPER))
    c = exotune.load_design(yaml.safe_load(PAPER.read_text()))
    assert exotune.load_design(a) is a
    assert a.design == b.design == c.design and a.plant == c.plant
    with pytest.raises(TypeError):
        exotune.load_design(3.0)
    with pytest.raises(ConfigError) as e:
        exotune.load_design({"plant": {}})
    assert str(e.value).startswith("plant")


def test_design_result_is_the_cli_json():
    d = exotune.design(PAPER)
    rec = d.to_dict()
    cli = _cli_json("design", str(PAPER))
    assert json.loads(d.to_json()) == cli
    assert d.gains == rec["gains"] and d.units["B2"].startswith("s")
    assert d.to_text().splitlines()[0] and "K2_hat" in d.to_text()
    rec["gains"]["K1"] = 99.0  # to_dict is a copy
    assert d.gains["K1"] != 99.0 and d.to_dict()["gains"]["K1"] != 99.0


def test_transfer_functions_against_python_control_closed_loop():
    """C5 (paper eq. (8)) from the design equals the joint compliance θ_j/τ_c of the python-control
    plant (Plant.to_control) closed by the nominal SEA law τ_m = −(K1 + B1 s)θ_m + (K2 + B2 s)τ_s."""
    d = exotune.design(PAPER)
    tfs = d.transfer_functions()
    assert set(tfs) == {"C4", "C5", "C5_hat", "C7_nominal", "G_v"}
    assert all(isinstance(t, control.TransferFunction) for t in tfs.values())
    P = exotune.load_design(PAPER).plant.to_control()
    assert P.ninputs == 2 and P.noutputs == 3 and P.nstates == 4
    g = d.gains
    s = control.TransferFunction.s
    Kth = -(g["K1"] + g["B1"] * s)
    Ktau = g["K2"] + g["B2"] * s
    G = control.ss2tf(P)
    # u = τ_m = Kth θ_m + Ktau τ_s with θ_m = G[0,0]u + G[0,1]τ_c, τ_s = G[2,0]u + G[2,1]τ_c
    loop = Kth * G[0, 0] + Ktau * G[2, 0]
    u_per_tc = (Kth * G[0, 1] + Ktau * G[2, 1]) / (1 - loop)
    C5_ref = G[1, 0] * u_per_tc + G[1, 1]
    w = np.geomspace(0.5, 2000.0, 40)
    ref = C5_ref(1j * w)
    got = tfs["C5"](1j * w)
    np.testing.assert_allclose(got, ref, rtol=1e-8)
    # descending coefficients, as python-control: the leading num/den coefficient is s^n
    num = np.ravel(tfs["C5_hat"].num[0][0])
    den = np.ravel(tfs["C5_hat"].den[0][0])
    assert num.tolist() == [1.0] and den[-1] == 0.0 and den[0] > 0  # 1/(Ĵ s² + B̂ s)


def test_controller_blocks_convert_exactly():
    from exotune.model.controller import build_controller

    cfg = exotune.load_design(PAPER)
    cs, _ = build_controller(cfg.plant, cfg.design, cfg.implementation)
    blocks = cs.to_control()
    assert blocks["delay_s"] == cfg.implementation.delay_s
    s = 2j * np.pi * np.geomspace(0.1, 400.0, 25)
    for key, r in (("G_theta", cs.motor_position), ("G_s", cs.spring_torque), ("G_c", cs.cuff_torque), ("Q", cs.dob_q)):
        np.testing.assert_allclose(blocks[key](s), np.ravel(r(s[None, :])), rtol=1e-12)


def test_analyze_result_matches_cli_and_carries_margins():
    r = exotune.analyze(PAPER)
    cli = _cli_json("analyze", str(PAPER))
    assert json.loads(r.to_json()) == cli  # to_dict keeps Python floats (nan, inf); JSON maps them
    assert r.free_stable is True and r.robust is False
    mass = next(h for h in r.humans if h.kind == "mass")
    assert mass.robust is False and mass.unit == "kg·m²" and mass.stable_intervals[0][1] == 1.0
    assert r.dob.phase_margin_deg == pytest.approx(51.2, abs=0.05)
    assert r.amplification.dc == pytest.approx(8.0, rel=1e-9)
    assert r.latency_margin_s == 0.0  # not robust at the nominal delay
    assert "latency" in r.to_text()


def test_plots_return_figures_and_draw_into_given_axes():
    from matplotlib.figure import Figure

    r = exotune.analyze(PAPER)
    fig = r.plot()
    assert isinstance(fig, Figure) and fig.axes
    fig2 = Figure()
    ax = fig2.add_subplot()
    assert r.plot(ax=ax) is fig2 and ax.lines
    assert isinstance(exotune.design(PAPER).plot(), Figure)


def test_sweep_optimize_and_simulation_results_plot(tmp_path):
    """plot() of the sweep, optimization and simulation results: a Figure, drawn into a given ax
    when one is passed; the sweep map's numbers are the worst case / fraction per cell. The
    optimization runs the smallest budget a spec accepts (50 evaluations): its plot and relative
    position are what is checked, not how good the optimum is."""
    from matplotlib.figure import Figure

    spec = {"base": str(ROOT / "examples" / "scheduled.yaml"),
            "axes": {"design.amplification": [4.0, 8.0, 60.0], "implementation.delay_s": [0.001, 0.003]}}
    s = exotune.sweep(spec, tmp_path / "s", workers=1)
    grid, xs, ys, xp, yp = s.map_data()
    df = s.table().to_pandas()
    assert (xp, yp) == ("design.amplification", "implementation.delay_s") and grid.shape == (2, 3)
    for iy, t in enumerate(ys):
        for ix, a in enumerate(xs):
            row = df[(df["design.amplification"] == a) & (df["implementation.delay_s"] == t)]
            # a gain-scheduled base: robust needs every entry too (docs/sweep-spec.md#gain-schedule)
            robust = bool((row["free_stable"] & row["human0_mass_robust"] & row["human1_spring_robust"]
                           & row["human2_complex_stiffness_robust"] & row["env0_locked_stable"]
                           & row["schedule_robust"]).iloc[0])
            assert grid[iy, ix] == float(robust)
            lm, *_ = s.map_data("latency_margin_s")
            assert lm[iy, ix] == row["latency_margin_s"].iloc[0]
    assert isinstance(s.plot(), Figure)
    fig = Figure()
    ax = fig.add_subplot()
    assert s.plot("latency_margin_s", ax=ax) is fig and ax.images

    o = exotune.optimize({"base": str(ROOT / "examples" / "scheduled.yaml"),
                          "free": {"design.amplification": [2.0, 12.0], "design.zeta_hat": [0.4, 1.2]},
                          "budget": 50}, tmp_path / "o.yaml", seed=1)
    rel = o.to_dict()["x_relative"]
    assert set(rel) == {"design.amplification", "design.zeta_hat"} and all(0.0 <= v <= 1.0 for v in rel.values())
    fig = o.plot()
    assert isinstance(fig, Figure) and fig.axes[0].collections  # the optimum's markers

    run = exotune.simulate(ROOT / "examples" / "scheduled.yaml", "locked-output", duration=0.2)
    assert len(run.plot().axes) == 2
    fig = Figure()
    ax = fig.add_subplot()
    assert run.plot(ax=ax) is fig and ax.lines and len(fig.axes) == 1


def test_export_then_certify_round_trip(tmp_path, paper_export):
    cf, out = paper_export
    assert out.exists() and cf.sample_rate_hz == 1000.0 and cf.path == str(out)
    c1 = exotune.certify(cf)
    c2 = exotune.certify(out)
    c3 = exotune.certify(cf.to_dict())
    assert c1.to_json() == c2.to_json() == c3.to_json()
    assert json.loads(c1.to_json()) == _cli_json("certify", str(out))
    assert c1.certified == c1.to_dict()["certified"]
    assert "certif" in c1.to_text().lower()
    assert c1.reasons == tuple(c1.to_dict()["problems"])
    # the export command's line is the file's summary view
    res = CliRunner().invoke(cli, ["export", "--allow-uncertified", str(PAPER), "--sample-rate-hz", "1000", "-o", str(tmp_path / "d.yaml")])
    assert res.exit_code == 0 and res.stdout.rstrip("\n") == cf.summary().replace(str(out), str(tmp_path / "d.yaml"))


def test_simulate_and_certify_accept_objects_and_validate_mappings(sched_export, sched_export_run):
    """simulate takes a path, the design's mapping, a loaded design or an exported controller (the
    same run each time); a controller mapping is validated as its file is, for certify and simulate."""
    from exotune.config import read_yaml
    from exotune.errors import ConfigError

    design = ROOT / "examples" / "scheduled.yaml"
    # 0.6 s: two periods of the locked loop's dominant 3.9 Hz oscillation (a shorter run is inconclusive)
    runs = [exotune.simulate(src, "locked-output", duration=0.6)
            for src in (design, read_yaml(design), exotune.load_design(design))]
    assert runs[0].to_json() == runs[1].to_json() == runs[2].to_json()
    cf = sched_export  # exotune.export(design, 1000.0, ...)
    from_file = sched_export_run  # exotune.simulate(cf, "locked-output", duration=0.6)
    from_doc = exotune.simulate(cf.to_dict(), "locked-output", duration=0.6)
    assert from_file.to_json() == from_doc.to_json()
    assert from_file.to_dict()["summary"]["verdict"] == runs[0].to_dict()["summary"]["verdict"] == "decaying"
    bad = cf.to_dict()
    bad["sample_rate_hz"] = 3
    for call in (lambda: exotune.certify(bad), lambda: exotune.simulate(bad, "locked-output")):
        with pytest.raises(ConfigError) as e:
            call()
        assert e.value.field == "sample_rate_hz"
    with pytest.raises(TypeError, match="controller file path"):
        exotune.certify(42)


def test_a_failed_certificate_lists_its_reasons(paper_export):
    """``Certificate.reasons`` read a key the record does not have and was always empty."""
    doc = paper_export[0].to_dict()  # a copy: the shared export is unchanged
    doc["requirements"]["latency_margin_s"] = 0.1  # 100 ms: far beyond this design's margin
    cert = exotune.certify(doc)
    assert not cert.certified and cert.reasons
    assert any("latency margin" in r for r in cert.reasons), cert.reasons
    assert cert.reasons == tuple(cert.to_dict()["problems"])
    assert all(r in cert.to_text() for r in cert.reasons[:1])


@pytest.mark.parametrize("cmd", [("sea", "examples/sea.yaml"), ("design", "examples/paper.yaml")])
def test_every_command_text_and_json_are_views_of_its_result(cmd):
    """The CLI prints ``to_text()`` / ``to_json()`` of the typed result (here: sea and design)."""
    from exotune.analysis import design_report, sea_report
    from exotune.config import load_design, load_sea
    from exotune.results import DesignSummary, SeaReport

    name, path = cmd
    if name == "sea":
        r = sea_report(load_sea(ROOT / path))
        assert isinstance(r, SeaReport)
        assert r.c5_stable is r.to_dict()["c5_stable"] and r.passive is r.to_dict()["passivity"]["passive"]
    else:
        r = design_report(load_design(ROOT / path))
        assert isinstance(r, DesignSummary)
    assert json.loads(r.to_json()) == _cli_json(name, str(ROOT / path))
    res = CliRunner().invoke(cli, [name, str(ROOT / path)])
    assert res.exit_code == 0 and res.stdout.rstrip("\n") == r.to_text().rstrip("\n")


def _modules_with_examples():
    import pkgutil

    out = []
    for m in pkgutil.walk_packages(exotune.__path__, "exotune."):
        if m.name.endswith("__main__"):
            continue
        mod = importlib.import_module(m.name)
        if doctest.DocTestFinder().find(mod) and any(t.examples for t in doctest.DocTestFinder().find(mod)):
            out.append(m.name)
    return out


EXAMPLE_MODULES = _modules_with_examples()


def test_the_public_api_has_examples():
    for mod in ("exotune.api", "exotune.model.interop", "exotune.analysis.latency_margin", "exotune.starter"):
        assert mod in EXAMPLE_MODULES
    # every API twin of a command shows how it is called
    for name in ("load_design", "design", "analyze", "sweep", "report", "optimize", "export", "certify", "codegen", "identify", "simulate"):
        assert ">>>" in (getattr(exotune, name).__doc__ or ""), name


@pytest.mark.parametrize("module", EXAMPLE_MODULES)
def test_docstring_examples_run(module, monkeypatch):
    """Every example in every docstring of the package runs and gives what it shows."""
    monkeypatch.chdir(ROOT)
    res = doctest.testmod(importlib.import_module(module), optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert res.failed == 0
    assert res.attempted > 0


def test_simulate_twin_takes_start_and_joint_angle():
    """api.simulate has the command's --start and --joint-angle (issue 24: the API is the CLI's twin)."""
    sched = ROOT / "examples" / "scheduled.yaml"
    cli_res = CliRunner().invoke(cli, ["simulate", str(sched), "--scenario", "locked-output", "--start", "zero",
                                       "--joint-angle", "1.0", "--json"])
    assert cli_res.exit_code == 0, cli_res.output
    r = exotune.simulate(sched, "locked-output", start="zero", joint_angle=1.0).to_dict()
    assert json.loads(cli_res.stdout)["summary"] == json.loads(json.dumps(r["summary"]))
    assert r["summary"]["start"] == "zero"
    other = exotune.simulate(sched, "locked-output", start="zero", joint_angle=2.0).to_dict()
    assert other["summary"] != r["summary"]  # another schedule entry (ratio 1.25, not 1): another plant


def test_output_checks_are_the_librarys(tmp_path):
    """The refusals of the command line (an output over an input, a plot directory that is a
    file) come from the library: a script gets them too, before any work, nothing written."""
    design = tmp_path / "d.yaml"
    design.write_text(PAPER.read_text())
    with pytest.raises(ConfigError, match="same file as the input"):
        exotune.export(design, 1000.0, design)
    afile = tmp_path / "f.txt"
    afile.write_text("x")
    with pytest.raises(ConfigError, match="`plots`"):
        exotune.analyze(design, plots=afile)
    with pytest.raises(ConfigError, match="`plots`"):
        exotune.design(design, plots=afile)
    assert design.read_text() == PAPER.read_text() and afile.read_text() == "x"


def test_api_writes_the_plots_the_command_writes(tmp_path):
    r = exotune.design(PAPER, plots=tmp_path / "p")
    assert sorted(p.suffix for p in (tmp_path / "p").iterdir()) and r.gains["K2_hat"] == pytest.approx(7.0)
    res = CliRunner().invoke(cli, ["design", str(PAPER), "--plots", str(tmp_path / "q")])
    assert res.exit_code == 0
    assert sorted(p.name for p in (tmp_path / "p").iterdir()) == sorted(p.name for p in (tmp_path / "q").iterdir())


def test_certify_time_budget_is_a_library_keyword(sched_export):
    c = sched_export  # examples/scheduled.yaml exported at 1 kHz
    with pytest.raises(ConfigError, match="time"):
        exotune.certify(c, time_budget_s=-1.0)
    assert exotune.certify(c, time_budget_s=600).certified


def test_analyze_stops_at_its_time_budget_and_writes_nothing(tmp_path):
    """h8: `exotune analyze` of a design at 10 MHz ran for minutes with no way to bound it; export
    and certify had a time budget. analyze takes one too (library keyword and option): spent, it is
    a ConfigError on time_budget_s (exit 2 naming --time-budget-s), and no plot is written."""
    with pytest.raises(ConfigError) as ei:
        exotune.analyze(ROOT / "examples" / "scheduled.yaml", time_budget_s=1e-3, plots=tmp_path / "p")
    assert ei.value.field == "time_budget_s" and "exceeded the time budget of 0.001 s" in ei.value.reason
    assert not (tmp_path / "p").exists()
    with pytest.raises(ConfigError, match="must be > 0"):
        exotune.analyze(ROOT / "examples" / "paper.yaml", time_budget_s=0.0)
    res = CliRunner().invoke(cli, ["analyze", str(ROOT / "examples" / "scheduled.yaml"), "--time-budget-s", "0.001"])
    assert res.exit_code == 2 and "--time-budget-s: analysing the design at 1000 Hz exceeded" in res.output
    assert exotune.analyze(ROOT / "examples" / "paper.yaml", time_budget_s=600).free_stable


def test_sea_accepts_a_path_a_mapping_and_a_loaded_file():
    """h8 item 7: exotune.sea(mapping) raised a bare TypeError (config/design.py) although the API
    takes a path, a mapping or a loaded object; the mapping is validated as the file is."""
    import yaml

    from exotune.config import load_sea

    path = ROOT / "examples" / "sea.yaml"
    want = exotune.sea(path).to_dict()
    assert exotune.sea(str(path)).to_dict() == want
    assert exotune.sea(load_sea(path)).to_dict() == want
    assert exotune.sea(yaml.safe_load(path.read_text())).to_dict() == {**want, "source": None}
    bad = yaml.safe_load(path.read_text())
    bad["gains"]["B1"] = 1e308
    _refused(lambda: exotune.sea(bad), "gains.B1", "[-1e9, 1e9]")
    with pytest.raises(TypeError, match="an SEA file path, a mapping or a SeaConfig"):
        exotune.sea(3.0)


def test_codegen_refuses_what_has_no_file_bytes_naming_source(tmp_path, sched_export):
    """h8 item 7: exotune.codegen(mapping | ControllerFile) raised a bare TypeError (yamlio.py): the
    generated C is stamped with the sha256 of the file's bytes, which only a file has. Refused as a
    ConfigError naming ``source`` and the reason, nothing written; a written export still works."""
    from exotune.controllerfile import load_controller_file

    c = sched_export  # examples/scheduled.yaml exported at 1 kHz (its file is only read)
    for src, what in ((c.to_dict(), "got a mapping"), (load_controller_file(c.path),
                                                         "got a loaded ControllerFile"),
                      (42, "got an object of type int")):
        e = _refused(lambda: exotune.codegen(src, tmp_path / "src"), "source", "codegen needs the controller file itself")
        assert what in e.reason and "sha256 of the file's bytes" in e.reason
    assert not (tmp_path / "src").exists()
    g = exotune.codegen(c, tmp_path / "src")
    assert g.certified and (tmp_path / "src" / "exotune_controller.c").exists()


def test_certify_and_simulate_accept_a_loaded_controller_file(sched_export, sched_export_run):
    """The controller file's loaded object (``load_controller_file``) is a loaded object too: certify
    and simulate refused it with a bare TypeError."""
    from exotune.controllerfile import load_controller_file

    c = sched_export  # examples/scheduled.yaml exported at 1 kHz
    cf = load_controller_file(c.path)
    assert exotune.certify(cf).to_dict() == exotune.certify(c).to_dict()
    assert (exotune.simulate(cf, "locked-output", duration=0.6).to_json()
            == sched_export_run.to_json())  # exotune.simulate(c, "locked-output", duration=0.6)


def test_sea_and_init_twins(tmp_path):
    assert exotune.sea(ROOT / "examples" / "sea.yaml").to_dict() == json.loads(
        CliRunner().invoke(cli, ["sea", str(ROOT / "examples" / "sea.yaml"), "--json"]).output)
    written = exotune.init(tmp_path)
    assert sorted(p.name for p in written) == ["design.yaml", "optimize.yaml", "sweep.yaml"]
    with pytest.raises(ConfigError):
        exotune.init(tmp_path)  # never overwrites


# ------------------------------------------------------------------------------------------
# Bad keywords: a ConfigError naming the keyword and why, before any work, nothing written
# ------------------------------------------------------------------------------------------
def _refused(call, field: str, why: str = "") -> ConfigError:
    with pytest.raises(ConfigError) as ei:
        call()
    assert ei.value.field == field and why in ei.value.reason, str(ei.value)
    return ei.value


@pytest.mark.parametrize("kw, field, why", [
    ({"scenario": "nope"}, "scenario", "unknown scenario 'nope'"),  # was a ValueError
    ({"scenario": ["locked-output"]}, "scenario", "unknown scenario"),  # was a TypeError
    ({"start": "warm"}, "start", "must be one of bumpless, zero"),  # was a ValueError
    ({"start": 0}, "start", "must be one of bumpless, zero"),
    ({"joint_angle": math.nan}, "joint_angle", "finite"),  # was run at an arbitrary schedule entry
    ({"joint_angle": math.inf}, "joint_angle", "finite"),
    ({"joint_angle": "1.0"}, "joint_angle", "expected a number"),  # was a TypeError
    ({"joint_angle": 100.0}, "joint_angle", "outside the gain schedule's joint angles [0, 2] rad"),  # ran at 2 rad
    ({"joint_angle": 1e308}, "joint_angle", "outside the gain schedule's joint angles [0, 2] rad"),
    ({"human_inertia": True}, "human_inertia", "expected a number"),  # was run with 1 kg·m²
    ({"human_inertia": "0.02"}, "human_inertia", "expected a number"),  # was a TypeError
    ({"duration": True}, "duration", "expected a number"),  # was a 1 s run
    ({"duration": "0.5"}, "duration", "expected a number"),
    ({"sample_rate_hz": True}, "sample_rate_hz", "expected a number of Hz"),
    ({"sample_rate_hz": 1e308}, "sample_rate_hz", "out of the accepted range"),  # was implementation.sample_rate_hz
    ({"plots": 3}, "plots", "expected a path"),  # was a TypeError
])
def test_simulate_refuses_bad_keywords_naming_them(tmp_path, kw, field, why):
    args = {"scenario": "locked-output", "duration": 0.5, **kw}
    _refused(lambda: exotune.simulate(SCHED, args.pop("scenario"), **args), field, why)
    assert list(tmp_path.iterdir()) == []


def test_simulate_takes_the_rate_as_the_command_line_gives_it():
    """The command line passes ``--sample-rate-hz`` as text: the API accepts a number's text there."""
    r = exotune.simulate(SCHED, "locked-output", sample_rate_hz="1000", duration=0.1)
    assert r.to_dict()["sample_rate_hz"] == 1000.0


@pytest.mark.parametrize("kw, field, why", [
    ({"sample_rate_hz": True}, "sample_rate_hz", "expected a number of Hz"),
    ({"sample_rate_hz": 1e308}, "sample_rate_hz", "out of the accepted range: must be in [0.001, 1e7] Hz"),
    ({"sample_rate_hz": 1e-9}, "sample_rate_hz", "out of the accepted range"),
    ({"require_latency_margin_s": True}, "require_latency_margin_s", "expected a number of seconds"),
    ({"time_budget_s": True}, "time_budget_s", "expected a number of seconds"),
    ({"allow_uncertified": "no"}, "allow_uncertified", "expected True or False"),
    ({"out": 5}, "out", "expected a path"),
])
def test_export_refuses_bad_keywords_naming_them(tmp_path, kw, field, why):
    args = {"sample_rate_hz": 1000.0, "out": tmp_path / "c.yaml", **kw}
    _refused(lambda: exotune.export(SCHED, **args), field, why)
    assert list(tmp_path.iterdir()) == []


def test_export_sample_rate_out_of_range_names_the_option_on_the_command_line(tmp_path):
    res = CliRunner().invoke(cli, ["export", str(SCHED), "--sample-rate-hz", "1e308", "-o", str(tmp_path / "c.yaml")])
    assert res.exit_code == 2 and res.stderr.startswith("exotune: error: --sample-rate-hz: out of the accepted range")
    assert list(tmp_path.iterdir()) == []


_OPT_SPEC = {"base": str(SCHED), "free": {"design.amplification": [2.0, 12.0]}, "budget": 50}
_SWEEP_SPEC = {"base": str(SCHED), "axes": {"design.amplification": [4.0, 8.0]}}


@pytest.mark.parametrize("call, field", [
    (lambda d: exotune.analyze(PAPER, cross_check="no"), "cross_check"),  # "no" was taken for yes
    (lambda d: exotune.analyze(PAPER, cross_check=1), "cross_check"),
    (lambda d: exotune.codegen(SCHED, d / "c", allow_uncertified="no"), "allow_uncertified"),
    (lambda d: exotune.identify(d / "log.csv", friction="no"), "friction"),
])
def test_flag_keywords_take_only_bools(tmp_path, call, field):
    _refused(lambda: call(tmp_path), field, "expected True or False")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("call, field", [
    (lambda d: exotune.init(5), "directory"),
    (lambda d: exotune.design(PAPER, plots=5), "plots"),
    (lambda d: exotune.analyze(PAPER, plots=["p"]), "plots"),
    (lambda d: exotune.sweep(_SWEEP_SPEC, 5), "out"),
    (lambda d: exotune.report(5), "sweep_dir"),
    (lambda d: exotune.report(d, out=[d]), "out"),
    (lambda d: exotune.optimize(_OPT_SPEC, 5), "out"),
    (lambda d: exotune.optimize(_OPT_SPEC, d / "o.yaml", pareto_csv=1.5), "pareto_csv"),
    (lambda d: exotune.codegen(SCHED, 5), "out"),
    (lambda d: exotune.identify(d / "log.csv", out=5), "out"),
    (lambda d: exotune.identify(d / "log.csv", validate=5), "validate"),
    (lambda d: exotune.identify(d / "log.csv", frf_csv=[1]), "frf_csv"),
    (lambda d: exotune.identify(d / "log.csv", plots=5), "plots"),
    (lambda d: exotune.excite(5, sample_rate_hz=1000.0, f_lo_hz=1.0, f_hi_hz=20.0, rms_nm=1.0, periods=2), "out"),
])
def test_path_keywords_take_only_paths(tmp_path, call, field):
    _refused(lambda: call(tmp_path), field, "expected a path (str or os.PathLike), got ")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("fix, why", [
    (1.0, "expected a mapping {NAME: VALUE} or a list of 'NAME=VALUE' strings, got float 1.0"),  # was a TypeError
    ("K_s=1000", "a list of 'NAME=VALUE' strings, got str"),
    ({"K_s": True}, "the value must be a number"),
])
def test_identify_fix_is_names_and_values(tmp_path, fix, why):
    _refused(lambda: exotune.identify(tmp_path / "log.csv", fix=fix), "fix", why)
    columns = {"t": [0.0, 0.001], "theta_m": [0.0, 0.0], "tau_s": [0.0, 0.0], "tau_m": [0.0, 0.0]}
    _refused(lambda: exotune.identify(columns, fix=fix), "fix", why)


def test_identify_outputs_of_a_mapping_name_the_keyword():
    columns = {"t": [0.0, 0.001], "theta_m": [0.0, 0.0], "tau_s": [0.0, 0.0], "tau_m": [0.0, 0.0]}
    _refused(lambda: exotune.identify(columns, frf_csv="f.csv"), "frf_csv", "only for a log file")


def test_sweep_dask_errors_name_the_keyword_and_the_command_line_names_the_option(tmp_path):
    _refused(lambda: exotune.sweep(_SWEEP_SPEC, tmp_path / "sw", dask_address="local:0"), "dask_address", "local:N")
    _refused(lambda: exotune.sweep(_SWEEP_SPEC, tmp_path / "sw", dask_address=5), "dask_address", "scheduler address")
    spec = tmp_path / "spec.yaml"
    spec.write_text(json.dumps(_SWEEP_SPEC))
    res = CliRunner().invoke(cli, ["sweep", str(spec), "-o", str(tmp_path / "sw"), "--dask", "local:0"])
    assert res.exit_code == 2 and res.stderr.splitlines()[-1] == "exotune: error: --dask: local:N needs N >= 1, got 0"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["spec.yaml"]


def test_analyze_budget_stops_a_stiff_continuous_design(tmp_path):
    """Hostile round 4, F4: a continuous design with a 10 MHz `gv_filter` of damping 1000 and a
    velocity filter ran for over 590 s with `--time-budget-s 20`: the plant-uncertainty margin's
    root counts (numpy engine, in a child process) never looked at the budget. Every adaptive
    frequency refinement now does, so the budget stops it (the design takes minutes otherwise);
    the hint no longer blames a sample rate the design does not have."""
    import yaml

    raw = yaml.safe_load((ROOT / "examples" / "paper.yaml").read_text())
    raw["implementation"]["gv_filter"] = {"cutoff_hz": 1.0e7, "damping": 1000}
    raw["implementation"]["velocity_filter"] = {"cutoff_hz": 200.0}
    raw["humans"][0]["inertia"][0] = 0.01
    src = tmp_path / "stiff.yaml"
    src.write_text(yaml.safe_dump(raw))
    with pytest.raises(ConfigError) as ei:
        exotune.analyze(src, time_budget_s=3.0)
    assert ei.value.field == "time_budget_s" and "analysing the design exceeded" in ei.value.reason
    assert "sample_rate_hz" not in ei.value.reason
