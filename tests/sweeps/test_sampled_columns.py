"""The sweep's ``sampled: true`` columns (docs/sweep-spec.md#sampled-data-columns) against
``exotune certify``'s own analysis of the exported file, design by design.

* the batched controller has the exported file's transfer function (another realization: cascades
  of sections paired differently, the three DOB blocks as one), and its position-feedback test;
* on 50 random designs (fractional and whole-sample delays), verdicts agree (designs whose certify
  spectral radius lies within 1e-6 of 1 are excluded), interval ends within 1e-6 relative
  (certify's intervals computed directly by ``exotune.controllerfile.certify.sampled_analysis`` on
  the exported file);
* the latency margin within 1e-4 relative of certify's margin of the exported file (the same
  engine, exotune.sampled.families.latency_margin, on the file's own realization, to 1e-9 relative
  of its probes' first crossing, then certify's full check); the reference runs in two processes;
* the spec key is refused without a sample rate, and a sweep with it writes the columns and a
  report that maps them.
"""

from __future__ import annotations

import copy
import multiprocessing
from pathlib import Path

import numpy as np
import pytest
import yaml

from exotune.analysis import analyze_batch
from exotune.config import batch_config, design_from_mapping, load_design
from exotune.controllerfile.certify import sampled_analysis
from exotune.controllerfile.export import build_export
from exotune.controllerfile.fileio import discrete_from_file, position_feedback
from exotune.controllerfile.latency import sampled_latency_margin
from exotune.errors import ConfigError
from exotune.sampled.batch import BatchLoops
from exotune.plots.sweep_report import make_report
from exotune.sweeps import load_results, run_sweep
from exotune.sweeps.sampledcols import sampled_columns

ROOT = Path(__file__).resolve().parents[2]
FS = 1000.0


def _base() -> dict:
    raw = copy.deepcopy(load_design(ROOT / "examples" / "scheduled.yaml").raw)
    raw.pop("transmission", None)
    return raw


def _random_axes(n: int, seed: int) -> dict:
    rng = np.random.default_rng(seed)
    return {"design.amplification": rng.uniform(2.0, 14.0, n), "implementation.delay_s": rng.uniform(0.0003, 0.0025, n),
            "design.zeta_hat": rng.uniform(0.3, 1.2, n), "implementation.gv_filter.cutoff_hz": rng.uniform(40.0, 200.0, n)}


def _row_doc(raw: dict, axes: dict, i: int) -> dict:
    r = copy.deepcopy(raw)
    for path, v in axes.items():
        *sec, key = path.split(".")
        d = r
        for s in sec:
            d = d[s]
        d[key] = float(v[i])
    return build_export(design_from_mapping(r), FS, analyses=False)


def _tf(Ac, Bc, Cc, Dc, z):
    """τ_cmd per unit of each measured signal at the points ``z``."""
    n = Ac.shape[0]
    return np.array([Cc @ np.linalg.solve(zi * np.eye(n) - Ac, Bc) + Dc for zi in z])


def test_controller_is_the_exported_one():
    raw = _base()
    axes = _random_axes(4, 1)
    b = batch_config(design_from_mapping(raw), axes)
    bl = BatchLoops(b, FS, 4)
    z = np.exp(1j * np.pi * np.array([1e-3, 0.01, 0.1, 0.5, 0.9]))
    for i in range(4):
        doc = _row_doc(raw, axes, i)
        ref = discrete_from_file(doc)
        nz = int(bl.nz[i])
        got = _tf(bl.Ac[i, :nz, :nz], bl.Bc[i, :nz], bl.Cc[i, :nz], bl.Dc[i], z)
        want = _tf(ref.Ac, ref.Bc, ref.Cc[0], ref.Dc[0], z)
        assert np.allclose(got, want, rtol=1e-8, atol=1e-10 * np.max(np.abs(want)))
        assert nz < ref.Ac.shape[0]  # the DOB's three blocks are one
        assert bool(bl.position_feedback[i]) == position_feedback(doc["controller"])


def _near(x: float, tol: float = 1e-6) -> bool:
    return abs(x - 1.0) < tol


def _certify_row(args):
    raw, axes, i = args
    doc = _row_doc(raw, axes, i)
    sa = sampled_analysis(doc)
    return sa, sampled_latency_margin(doc, sa, position_feedback(doc["controller"]), sampled_analysis)


N_RANDOM = 50


@pytest.fixture(scope="module")
def compared():
    raw = _base()
    raw["humans"] = raw["humans"][:2]  # mass and spring (the hysteretic one has no sampled-data model)
    axes = _random_axes(N_RANDOM, 7)
    b = batch_config(design_from_mapping(raw), axes)
    sc = sampled_columns(b, analyze_batch(b, latency=True))
    ctx = multiprocessing.get_context("fork" if "fork" in multiprocessing.get_all_start_methods() else None)
    with ctx.Pool(2) as pool:
        refs = pool.map(_certify_row, [(raw, axes, i) for i in range(N_RANDOM)], chunksize=5)
    return sc, refs


def test_verdicts_and_intervals_agree_with_certify(compared):
    sc, refs = compared
    checked = 0
    for i, (sa, _lm) in enumerate(refs):
        for loop in ("free", "locked"):
            if not _near(sa[f"{loop}_spectral_radius"]):
                assert bool(sc[f"sampled_{loop}_stable"][i]) is sa[f"{loop}_stable"]
        for j, h in enumerate(sa["humans"]):
            if "skipped" in h:
                continue
            pre = f"sampled_human{j}_{h['kind']}"
            ivs, want = sc[f"{pre}_stable_intervals"][i], h["stable_intervals"]
            assert len(ivs) == len(want)
            for (a, b), (c, d) in zip(ivs, want):
                assert a == pytest.approx(c, rel=1e-6) and b == pytest.approx(d, rel=1e-6)
            assert bool(sc[f"{pre}_robust"][i]) == bool(h["robust"])
            lo, hi = h["range"]
            assert lo <= sc[f"{pre}_critical"][i] <= hi
            checked += 1
    assert checked >= len(refs)


def test_latency_margin_agrees_with_certify(compared):
    sc, refs = compared
    some = 0
    for i, (_sa, lm) in enumerate(refs):
        got = sc["sampled_latency_margin_samples"][i]
        if lm["extra_delay_samples"] is None:
            assert got == np.inf
            continue
        assert got == pytest.approx(lm["extra_delay_samples"], rel=1e-4)
        some += got > 0
    assert some > 0


def test_spec_key_needs_a_sample_rate(tmp_path):
    raw = _base()
    raw["implementation"].pop("sample_rate_hz")
    spec = {"base": raw, "axes": {"design.amplification": [4.0]}, "sampled": True}
    with pytest.raises(ConfigError) as e:
        run_sweep(spec, tmp_path / "out", workers=1, progress=False)
    assert e.value.field == "sampled" and "sample_rate_hz" in e.value.reason
    spec = {"base": _base(), "axes": {"design.amplification": [4.0]}, "sampled": "yes"}
    with pytest.raises(ConfigError) as e:
        run_sweep(spec, tmp_path / "out2", workers=1, progress=False)
    assert e.value.field == "sampled"


def test_sweep_writes_the_columns_and_the_report_maps_them(tmp_path):
    raw = _base()
    raw["humans"] = raw["humans"][:1]
    spec = tmp_path / "spec.yaml"
    spec.write_text(yaml.safe_dump({"base": raw, "axes": {"design.amplification": [3.0, 6.0]}, "sampled": True}))
    run_sweep(spec, tmp_path / "out", workers=1, progress=False)
    t = load_results(tmp_path / "out")
    for c in ("sampled_free_stable", "sampled_locked_stable", "sampled_human0_mass_robust", "sampled_human0_mass_critical",
              "sampled_human0_mass_stable_intervals", "sampled_latency_margin_samples"):
        assert c in t.columns, c
    m = np.asarray(t["sampled_latency_margin_samples"], float)
    cont = np.asarray(t["latency_margin_s"], float) * FS
    ok = np.asarray(t["sampled_human0_mass_robust"], bool)
    # the zero-order hold costs about half a sample: the sampled margin is below the continuous one
    assert np.all(m[ok & np.isfinite(cont)] < cont[ok & np.isfinite(cont)])
    rep = make_report(tmp_path / "out")
    md = (Path(rep.directory) / "summary.md").read_text()
    assert "sampled_latency_margin_samples" in md and "`sampled_human0_mass_robust`" in md
