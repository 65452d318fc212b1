"""Design-file and SEA-file validation (docs/cli.md "bad input", §9 format) and the JSON helpers.

Every error path must raise ConfigError naming the field as a dotted path and a reason.
"""

from __future__ import annotations

import copy
import json
import math
import os
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import given, settings, strategies as st

from exotune.config import (
    OVERRIDABLE,
    DesignConfig,
    batch_config,
    design_from_mapping,
    load_design,
    load_sea,
    sea_from_mapping,
)
from exotune.config.design import hash_mapping
from exotune.errors import ConfigError
from exotune.model.humans import EnvModel, HumanFamily
from exotune.jsonio import to_jsonable, write_atomic

ROOT = Path(__file__).resolve().parents[2]
PAPER = ROOT / "examples" / "paper.yaml"
SEA = ROOT / "examples" / "sea.yaml"


@pytest.fixture()
def base() -> dict:
    with open(PAPER, encoding="utf-8") as fh:
        return yaml.safe_load(fh)


@pytest.fixture(scope="module")
def cfg() -> DesignConfig:
    return load_design(PAPER)


def err(mapping) -> ConfigError:
    with pytest.raises(ConfigError) as ei:
        design_from_mapping(mapping)
    e = ei.value
    assert str(e) == f"{e.field}: {e.reason}"
    assert "\n" not in str(e)
    return e


# ------------------------------------------------------------------------------------------ ok
def test_paper_example_loads(cfg):
    p, d, i = cfg.plant, cfg.design, cfg.implementation
    assert (p.motor_inertia, p.motor_damping, p.sea_stiffness, p.joint_inertia, p.cuff_stiffness) == (
        0.44, 17.9, 1180.0, 0.29, 300.0)
    assert (d.amplification, d.felt_inertia, d.felt_damping, d.zeta, d.zeta_hat) == (8.0, 0.25, 1.0, 0.7, 0.7)
    assert i.delay_s == 0.001 and i.sample_rate_hz is None and i.structure == "default"
    assert (i.gv_filter.cutoff_hz, i.gv_filter.damping) == (80.0, 0.7)
    assert i.derivative_filter.cutoff_hz == 100.0
    assert (i.dob.cutoff_hz, i.dob.damping) == (60.0, 0.7)
    assert i.velocity_filter is None
    assert cfg.humans == (
        HumanFamily("mass", "inertia", 0.001, 1.0, damping=0.0),
        HumanFamily("spring", "stiffness", 1.0, 10000.0, damping=0.0),
        HumanFamily("complex_stiffness", "stiffness", 10.0, 1000.0, eta=0.2),
    )
    assert cfg.environment == (EnvModel("locked"),)
    assert cfg.source == str(PAPER)
    json.dumps(cfg.raw)  # JSON-serializable
    assert cfg.raw["humans"][0] == {"kind": "mass", "inertia": [0.001, 1.0], "damping": 0.0}


def test_defaults_and_normalization(base):
    m = {"plant": base["plant"], "design": base["design"]}
    c = design_from_mapping(m)
    assert c.humans == () and c.environment == ()
    i = c.implementation
    assert i.delay_s == 0.0 and i.sample_rate_hz is None
    assert i.gv_filter is None and i.derivative_filter is None and i.dob is None and i.velocity_filter is None
    assert c.raw["implementation"]["structure"] == "default"
    # null sections are the defaults too
    c2 = design_from_mapping({**m, "implementation": None, "humans": None, "environment": None})
    assert c2.implementation == i and c2.humans == ()


def test_scalar_range_and_kinds(base):
    base["humans"] = [
        {"kind": "mass", "inertia": 0.1},  # a scalar is [v, v]
        {"kind": "msd", "inertia": 0.1, "stiffness": [10, 200], "damping": 0.5},
        {"kind": "msd", "inertia": [0.05, 0.2]},
        {"kind": "spring", "stiffness": [3, 3]},
    ]
    base["environment"] = [
        {"kind": "free"},
        {"kind": "spring", "stiffness": [100, 1000], "damping": 1.0},
        {"kind": "mass", "inertia": [0.1, 2.0]},
    ]
    base["implementation"]["velocity_filter"] = {"cutoff_hz": 200}
    base["implementation"]["structure"] = "full_filter"
    c = design_from_mapping(base)
    h = c.humans
    assert h[0] == HumanFamily("mass", "inertia", 0.1, 0.1)
    assert h[1] == HumanFamily("msd", "stiffness", 10.0, 200.0, inertia=0.1, damping=0.5, stiffness=0.0)
    assert h[2] == HumanFamily("msd", "inertia", 0.05, 0.2)
    assert h[3].range == (3.0, 3.0)
    assert c.raw["humans"][1] == {"kind": "msd", "inertia": 0.1, "damping": 0.5, "stiffness": [10.0, 200.0]}
    assert c.environment == (
        EnvModel("free"),
        EnvModel("spring", "stiffness", 100.0, 1000.0, 1.0),
        EnvModel("mass", "inertia", 0.1, 2.0, 0.0),
    )
    assert c.implementation.velocity_filter.cutoff_hz == 200.0
    assert c.implementation.structure == "full_filter"


def test_sample_rate_below_nyquist_ok(base):
    base["implementation"]["sample_rate_hz"] = 1000
    c = design_from_mapping(base)
    assert c.implementation.sample_rate_hz == 1000.0


# ------------------------------------------------------------------------- field error paths
def _set(path, value):
    def mod(m):
        cur = m
        keys = path.split(".")
        for k in keys[:-1]:
            cur = cur[int(k)] if isinstance(cur, list) else cur[k]
        last = keys[-1]
        if isinstance(cur, list):
            cur[int(last)] = value
        else:
            cur[last] = value
    return mod


def _del(path):
    def mod(m):
        cur = m
        keys = path.split(".")
        for k in keys[:-1]:
            cur = cur[int(k)] if isinstance(cur, list) else cur[k]
        del cur[keys[-1]]
    return mod


def _append(section, item):
    def mod(m):
        m.setdefault(section, []).append(item)
    return mod


CASES = [
    # unknown key at each level
    ("top-level unknown", _set("extra", 1), "extra", "unknown key"),
    ("plant unknown", _set("plant.motor_mass", 1.0), "plant.motor_mass", "unknown key"),
    ("design unknown", _set("design.alpha", 2.0), "design.alpha", "unknown key"),
    ("implementation unknown", _set("implementation.latency", 0.0), "implementation.latency", "unknown key"),
    ("filter unknown", _set("implementation.gv_filter.order", 2), "implementation.gv_filter.order", "unknown key"),
    ("dob unknown", _set("implementation.dob.q", 2), "implementation.dob.q", "unknown key"),
    ("derivative unknown", _set("implementation.derivative_filter.damping", 0.7),
     "implementation.derivative_filter.damping", "unknown key"),
    ("human unknown", _set("humans.0.mass", 1.0), "humans[0].mass", "unknown key"),
    ("complex unknown", _set("humans.2.damping", 1.0), "humans[2].damping", "unknown key"),
    ("env unknown", _set("environment.0.stiffness", [1, 2]), "environment[0].stiffness", "unknown key"),
    # missing required parameter
    ("missing plant key", _del("plant.sea_stiffness"), "plant.sea_stiffness", "missing"),
    ("missing cuff stiffness", _del("plant.cuff_stiffness"), "plant.cuff_stiffness", "missing"),
    ("missing design key", _del("design.zeta_hat"), "design.zeta_hat", "missing"),
    ("missing section", _del("design"), "design", "missing"),
    ("missing filter cutoff", _del("implementation.gv_filter.cutoff_hz"), "implementation.gv_filter.cutoff_hz", "missing"),
    ("missing filter damping", _del("implementation.dob.damping"), "implementation.dob.damping", "missing"),
    ("missing human range", _del("humans.0.inertia"), "humans[0].inertia", "missing"),
    ("missing eta", _del("humans.2.eta"), "humans[2].eta", "missing"),
    ("missing kind", _del("humans.1.kind"), "humans[1].kind", "missing"),
    ("missing env range", _append("environment", {"kind": "spring"}), "environment[1].stiffness", "missing"),
    # signs and bounds
    ("negative inertia", _set("plant.motor_inertia", -0.44), "plant.motor_inertia", "> 0"),
    ("zero joint inertia", _set("plant.joint_inertia", 0), "plant.joint_inertia", "> 0"),
    ("negative damping", _set("plant.motor_damping", -1), "plant.motor_damping", ">= 0"),
    ("zero sea stiffness", _set("plant.sea_stiffness", 0.0), "plant.sea_stiffness", "> 0"),
    ("zero cuff stiffness", _set("plant.cuff_stiffness", 0.0), "plant.cuff_stiffness", "> 0"),
    ("alpha < 1", _set("design.amplification", 0.5), "design.amplification", ">= 1"),
    ("felt inertia 0", _set("design.felt_inertia", 0.0), "design.felt_inertia", "> 0"),
    ("felt damping 0", _set("design.felt_damping", 0.0), "design.felt_damping", "integrator"),
    ("zeta 0", _set("design.zeta", 0.0), "design.zeta", "> 0"),
    ("zeta_hat negative", _set("design.zeta_hat", -0.7), "design.zeta_hat", "> 0"),
    ("negative delay", _set("implementation.delay_s", -0.001), "implementation.delay_s", ">= 0"),
    ("zero sample rate", _set("implementation.sample_rate_hz", 0), "implementation.sample_rate_hz", "> 0"),
    ("zero cutoff", _set("implementation.gv_filter.cutoff_hz", 0.0), "implementation.gv_filter.cutoff_hz", "> 0"),
    ("zero filter damping", _set("implementation.dob.damping", 0.0), "implementation.dob.damping", "> 0"),
    ("negative human damping", _set("humans.0.damping", -1.0), "humans[0].damping", ">= 0"),
    ("eta too big", _set("humans.2.eta", 10.0), "humans[2].eta", "< 10"),
    ("eta negative", _set("humans.2.eta", -0.1), "humans[2].eta", ">= 0"),
    ("bad structure", _set("implementation.structure", "fancy"), "implementation.structure", "default, full_filter"),
    # NaN / inf / non-numbers
    ("nan", _set("design.amplification", float("nan")), "design.amplification", "finite"),
    ("inf", _set("plant.sea_stiffness", float("inf")), "plant.sea_stiffness", "finite"),
    ("-inf", _set("implementation.delay_s", float("-inf")), "implementation.delay_s", "finite"),
    ("nan in range", _set("humans.1.stiffness", [1.0, float("nan")]), "humans[1].stiffness", "finite"),
    ("string number", _set("design.zeta", "0.7"), "design.zeta", "string"),
    ("quoted 1e3 string", _set("plant.sea_stiffness", "1e3"), "plant.sea_stiffness", "quoted"),
    ("bool", _set("design.zeta", True), "design.zeta", "expected a number"),
    ("null value", _set("design.zeta", None), "design.zeta", "null"),
    ("list for number", _set("design.zeta", [0.7]), "design.zeta", "expected a number"),
    # Nyquist
    ("gv above nyquist", _set("implementation.sample_rate_hz", 150.0), "implementation.gv_filter.cutoff_hz", "Nyquist"),
    # malformed ranges
    ("range lo > hi", _set("humans.0.inertia", [1.0, 0.001]), "humans[0].inertia", "lo = 1 > hi = 0.001"),
    ("range length 3", _set("humans.1.stiffness", [1, 2, 3]), "humans[1].stiffness", "two numbers"),
    ("range length 1", _set("humans.1.stiffness", [1]), "humans[1].stiffness", "two numbers"),
    ("range strings", _set("humans.1.stiffness", ["a", "b"]), "humans[1].stiffness", "string"),
    ("range string", _set("humans.1.stiffness", "1..10"), "humans[1].stiffness", "range"),
    ("range zero lo", _set("humans.0.inertia", [0.0, 1.0]), "humans[0].inertia", "lo must be > 0"),
    ("scalar range negative", _set("humans.0.inertia", -1.0), "humans[0].inertia", "> 0"),
    ("range mapping", _set("humans.0.inertia", {"lo": 1, "hi": 2}), "humans[0].inertia", "mapping"),
    ("env range bad", _append("environment", {"kind": "mass", "inertia": [2, 1]}), "environment[1].inertia", "lo = 2 > hi = 1"),
    # msd
    ("msd zero ranges", _append("humans", {"kind": "msd", "inertia": 0.1, "stiffness": 2}),
     "humans[3]", "at least one of inertia/damping/stiffness must be a range"),
    ("msd box bad range", _append("humans", {"kind": "msd", "inertia": [0.1, 0.2], "stiffness": [3, 2]}),
     "humans[3].stiffness", "lo = 3 > hi = 2"),
    ("msd missing inertia", _append("humans", {"kind": "msd", "stiffness": [1, 2]}), "humans[3].inertia", "inertia > 0"),
    ("msd zero inertia", _append("humans", {"kind": "msd", "inertia": 0, "stiffness": [1, 2]}), "humans[3].inertia", "got 0"),
    ("msd negative stiffness", _append("humans", {"kind": "msd", "inertia": 0.1, "stiffness": -1, "damping": [1, 2]}),
     "humans[3].stiffness", ">= 0"),
    # kinds and shapes of sections
    ("unknown human kind", _set("humans.0.kind", "robot"), "humans[0].kind", "unknown human model"),
    ("unknown env kind", _set("environment.0.kind", "wall"), "environment[0].kind", "unknown environment model"),
    ("human not a mapping", _append("humans", 3), "humans[3]", "expected a mapping"),
    ("humans not a list", _set("humans", {"kind": "mass"}), "humans", "expected a list"),
    ("plant not a mapping", _set("plant", [0.44]), "plant", "expected a mapping"),
    ("filter not a mapping", _set("implementation.gv_filter", 80.0), "implementation.gv_filter", "expected a mapping"),
    ("locked extra", _set("environment.0", {"kind": "locked", "stiffness": 1}), "environment[0].stiffness", "unknown key"),
]


@pytest.mark.parametrize("name,mod,field,reason", CASES, ids=[c[0] for c in CASES])
def test_config_errors(base, name, mod, field, reason):
    m = copy.deepcopy(base)
    mod(m)
    e = err(m)
    assert e.field == field, str(e)
    assert reason in e.reason, str(e)


def test_unknown_key_lists_allowed(base):
    base["design"]["alpha"] = 3
    e = err(base)
    assert "amplification" in e.reason and "zeta_hat" in e.reason


def test_dob_above_nyquist_named(base):
    base["implementation"]["gv_filter"] = None
    base["implementation"]["derivative_filter"] = None
    base["implementation"]["sample_rate_hz"] = 100.0  # dob cutoff 60 Hz > 50 Hz
    e = err(base)
    assert e.field == "implementation.dob.cutoff_hz" and "50 Hz" in e.reason


def test_cutoff_exactly_at_nyquist_rejected(base):
    base["implementation"]["sample_rate_hz"] = 200.0  # derivative filter at 100 Hz == Nyquist
    e = err(base)
    assert e.field == "implementation.derivative_filter.cutoff_hz"


def test_top_level_not_mapping():
    e = err([1, 2])
    assert "mapping" in e.reason


# ------------------------------------------------------------------------- file-level errors
def test_unreadable_file(tmp_path):
    p = tmp_path / "nope.yaml"
    with pytest.raises(ConfigError) as ei:
        load_design(p)
    assert ei.value.field == str(p) and "cannot read file" in ei.value.reason


def test_directory_is_unreadable(tmp_path):
    with pytest.raises(ConfigError) as ei:
        load_design(tmp_path)
    assert "cannot read file" in ei.value.reason


def test_invalid_yaml(tmp_path):
    p = tmp_path / "bad.yaml"
    p.write_text("plant: {motor_inertia: 0.44\ndesign: [\n", encoding="utf-8")
    with pytest.raises(ConfigError) as ei:
        load_design(p)
    assert ei.value.field == str(p) and "invalid YAML" in ei.value.reason and "line" in ei.value.reason


def test_yaml_python_tags_rejected(tmp_path):
    p = tmp_path / "evil.yaml"
    p.write_text("plant: !!python/object/apply:os.system ['true']\n", encoding="utf-8")
    with pytest.raises(ConfigError) as ei:
        load_design(p)
    assert "invalid YAML" in ei.value.reason


@pytest.mark.parametrize("text,what", [("- 1\n- 2\n", "a list"), ("", "null"), ("42\n", "number"), ("hello\n", "string")])
def test_not_a_mapping(tmp_path, text, what):
    p = tmp_path / "x.yaml"
    p.write_text(text, encoding="utf-8")
    with pytest.raises(ConfigError) as ei:
        load_design(p)
    assert ei.value.field == str(p) and "mapping" in ei.value.reason and what in ei.value.reason


def test_duplicate_key(tmp_path):
    text = PAPER.read_text(encoding="utf-8").replace("  zeta: 0.7 ", "  zeta: 0.7\n  zeta: 0.9 ", 1)
    p = tmp_path / "dup.yaml"
    p.write_text(text, encoding="utf-8")
    with pytest.raises(ConfigError) as ei:
        load_design(p)
    assert ei.value.field == "design.zeta" and "duplicate key" in ei.value.reason


def test_not_utf8(tmp_path):
    p = tmp_path / "latin1.yaml"
    p.write_bytes("plant: {motor_inertia: 0.44}  # J\xe9\n".encode("latin-1"))
    with pytest.raises(ConfigError) as ei:
        load_design(p)
    assert "UTF-8" in ei.value.reason


def test_yaml_nan_and_inf_literals(tmp_path):
    text = PAPER.read_text(encoding="utf-8")
    for lit, field in ((".nan", "design.amplification"), (".inf", "design.amplification")):
        p = tmp_path / "n.yaml"
        p.write_text(text.replace("amplification: 8.0", f"amplification: {lit}"), encoding="utf-8")
        with pytest.raises(ConfigError) as ei:
            load_design(p)
        assert ei.value.field == field and "finite" in ei.value.reason


# ------------------------------------------------------------------------------------- batches
def test_batch_config_shapes(cfg):
    a = np.array([2.0, 4.0, 8.0, 16.0])
    b = batch_config(cfg, {"design.amplification": a, "implementation.gv_filter.cutoff_hz": [50, 60, 70, 80],
                           "plant.cuff_stiffness": np.full(4, 500.0)})
    assert isinstance(b, DesignConfig)
    for x in (b.plant.motor_inertia, b.plant.cuff_stiffness, b.design.amplification, b.design.zeta,
              b.implementation.delay_s, b.implementation.gv_filter.cutoff_hz, b.implementation.gv_filter.damping,
              b.implementation.derivative_filter.cutoff_hz, b.implementation.dob.damping):
        assert isinstance(x, np.ndarray) and x.shape == (4,) and x.dtype == float
    np.testing.assert_array_equal(b.design.amplification, a)
    np.testing.assert_array_equal(b.plant.cuff_stiffness, 500.0)
    np.testing.assert_array_equal(b.design.zeta, 0.7)
    assert b.implementation.velocity_filter is None and b.implementation.sample_rate_hz is None
    assert b.humans == cfg.humans and b.raw == cfg.raw
    # the batch works with the vectorized shaping code
    from exotune.model.shaping import double_compliance_shaping

    ds = double_compliance_shaping(b.plant, b.design)
    np.testing.assert_allclose(ds.gains.K2_hat, a - 1.0)


def test_batch_config_no_overrides(cfg):
    b = batch_config(cfg, {})
    assert b.design.amplification.shape == (1,)


def test_every_overridable_path_accepts_valid_values(cfg):
    for path in OVERRIDABLE:
        if path.startswith("implementation.velocity_filter"):
            continue
        values = np.array([0.5, 1.5]) + (1.0 if path == "design.amplification" else 0.0)
        if path == "implementation.delay_s":
            values = values * 1e-3  # delays are accepted up to 1 s
        b = batch_config(cfg, {path: values})
        assert b.design.zeta.shape == (2,), path


@pytest.mark.parametrize(
    "overrides,field,reason",
    [
        ({"design.alpha": [1.0]}, "design.alpha", "unknown"),
        ({"plant.motor_mass": [1.0]}, "plant.motor_mass", "unknown"),
        ({"humans[0].inertia": [1.0]}, "humans[0].inertia", "not overridable"),
        ({"environment[0].stiffness": [1.0]}, "environment[0].stiffness", "not overridable"),
        ({"implementation.sample_rate_hz": [1000.0]}, "implementation.sample_rate_hz", "not overridable"),
        ({"design.amplification": np.array([2.0, 3.0, 4.0, 0.5])}, "design.amplification", "value 0.5 at index 3 is < 1"),
        ({"plant.motor_inertia": [1.0, -1.0]}, "plant.motor_inertia", "value -1 at index 1 is <= 0"),
        ({"design.zeta": [0.5, np.nan]}, "design.zeta", "value nan at index 1 is not a finite number"),
        ({"implementation.delay_s": [np.inf]}, "implementation.delay_s", "not a finite number"),
        ({"implementation.delay_s": [[0.0, 0.001]]}, "implementation.delay_s", "1-D"),
        ({"implementation.delay_s": []}, "implementation.delay_s", "non-empty"),
        ({"design.zeta": ["a", "b"]}, "design.zeta", "real numbers"),
        ({"design.zeta": [0.5, 0.7], "design.zeta_hat": [0.5, 0.6, 0.7]}, "design.zeta_hat", "same length"),
        ({"implementation.velocity_filter.cutoff_hz": [100.0]}, "implementation.velocity_filter.cutoff_hz", "null"),
    ],
)
def test_batch_config_errors(cfg, overrides, field, reason):
    with pytest.raises(ConfigError) as ei:
        batch_config(cfg, overrides)
    assert ei.value.field == field, str(ei.value)
    assert reason in ei.value.reason, str(ei.value)


def test_batch_config_nyquist(base):
    base["implementation"]["sample_rate_hz"] = 1000.0
    c = design_from_mapping(base)
    with pytest.raises(ConfigError) as ei:
        batch_config(c, {"implementation.dob.cutoff_hz": [100.0, 499.0, 500.0]})
    assert ei.value.field == "implementation.dob.cutoff_hz" and "index 2" in ei.value.reason


# ------------------------------------------------------------------------------------------- SEA
def test_load_sea_example():
    s = load_sea(SEA)
    assert s.gains.units == "deflection" and s.gains.K1 == 69480.0 and s.gains.B2 == -1183.0
    assert s.plant.cuff_stiffness == 300.0  # default


@pytest.mark.parametrize(
    "mod,field,reason",
    [
        (lambda m: m["gains"].pop("units"), "gains.units", "missing"),
        (lambda m: m["gains"].update(units="newton"), "gains.units", "deflection"),
        (lambda m: m["gains"].update(K3=1.0), "gains.K3", "unknown key"),
        (lambda m: m["gains"].update(B1=float("nan")), "gains.B1", "finite"),
        (lambda m: m["plant"].update(joint_inertia=-1), "plant.joint_inertia", "> 0"),
        (lambda m: m.pop("gains"), "gains", "missing"),
        (lambda m: m.update(design={}), "design", "unknown key"),
    ],
)
def test_sea_errors(mod, field, reason):
    m = yaml.safe_load(SEA.read_text(encoding="utf-8"))
    mod(m)
    with pytest.raises(ConfigError) as ei:
        sea_from_mapping(m)
    assert ei.value.field == field and reason in ei.value.reason, str(ei.value)


# ------------------------------------------------------------------------------ hashing, JSON
def test_hash_mapping_canonical(cfg):
    h = hash_mapping(cfg.raw)
    assert len(h) == 64 and h == hash_mapping(copy.deepcopy(cfg.raw))
    reordered = {k: cfg.raw[k] for k in reversed(list(cfg.raw))}
    assert hash_mapping(reordered) == h
    other = copy.deepcopy(cfg.raw)
    other["design"]["amplification"] = 8.000001
    assert hash_mapping(other) != h
    assert hash_mapping({"x": np.float64(1.5)}) == hash_mapping({"x": 1.5})


def test_to_jsonable():
    from dataclasses import dataclass

    @dataclass
    class D:
        a: float
        b: tuple

    out = to_jsonable({"inf": math.inf, "ninf": -np.inf, "nan": np.nan, "arr": np.array([1.0, np.inf]),
                       "i": np.int64(3), "b": np.bool_(True), "t": (1, 2), "d": D(0.5, (np.float32(2.0),)),
                       "c": 1 + 2j, "p": Path("a/b")})
    assert out == {"inf": "inf", "ninf": "-inf", "nan": None, "arr": [1.0, "inf"], "i": 3, "b": True,
                   "t": [1, 2], "d": {"a": 0.5, "b": [2.0]}, "c": {"re": 1.0, "im": 2.0}, "p": "a/b"}
    json.dumps(out, allow_nan=False)
    with pytest.raises(TypeError):
        to_jsonable(object())


def test_write_atomic(tmp_path):
    p = tmp_path / "sub" / "out.json"
    write_atomic(p, "hello")
    write_atomic(p, b"bytes")
    assert p.read_bytes() == b"bytes"
    assert os.listdir(p.parent) == ["out.json"]  # no temp files left behind
    umask = os.umask(0)
    os.umask(umask)
    assert p.stat().st_mode & 0o777 == 0o666 & ~umask


def test_write_atomic_failure_leaves_nothing(tmp_path):
    p = tmp_path / "out.txt"
    with pytest.raises(TypeError):
        write_atomic(p, 123)  # not text or bytes
    assert os.listdir(tmp_path) == []


# ------------------------------------------------------------------------------- properties
finite_pos = st.floats(min_value=1e-6, max_value=1e6, allow_nan=False, allow_infinity=False)


@settings(max_examples=60, deadline=None)
@given(lo=finite_pos, hi=finite_pos)
def test_range_property(lo, hi):
    m = yaml.safe_load(PAPER.read_text(encoding="utf-8"))
    m["humans"] = [{"kind": "spring", "stiffness": [lo, hi]}]
    if lo <= hi:
        c = design_from_mapping(m)
        assert c.humans[0].range == (lo, hi)
    else:
        e = err(m)
        assert e.field == "humans[0].stiffness" and "lo" in e.reason



def test_msd_box_family(base):
    """Several ranged msd parameters make a box family (analysed through its edges)."""
    _append("humans", {"kind": "msd", "inertia": [0.05, 0.2], "stiffness": [1, 300], "damping": [0.5, 2]})(base)
    c = design_from_mapping(base)
    fam = c.humans[-1]
    assert (fam.param, fam.lo, fam.hi) == ("inertia", 0.05, 0.2)
    assert fam.box == (("damping", 0.5, 2.0), ("stiffness", 1.0, 300.0))
    edges = fam.edges()
    assert len(edges) == 12 and all(not e.box for e in edges)
    assert {e.param for e in edges} == {"inertia", "damping", "stiffness"}


def test_yaml_12_floats(tmp_path):
    """Exponent forms load as numbers (YAML 1.2), where PyYAML's YAML 1.1 gives strings: the
    design file's ``delay_s: 1e-3`` is the number 0.001."""
    from exotune.config import load_design, load_yaml_text, read_yaml

    doc = load_yaml_text("a: 1e3\nb: 1e-3\nc: 1.0e3\nd: -2.5E+2\ne: .5e1\nf: 1000\ng: 1_000\nh: .inf\n"
                         "i: abc\nj: '1e3'\nk: 1.5\nl: 0x10\nm: 1e\nn: e3\n")
    assert doc == {"a": 1000.0, "b": 0.001, "c": 1000.0, "d": -250.0, "e": 5.0, "f": 1000, "g": "1_000",
                   "h": float("inf"), "i": "abc", "j": "1e3", "k": 1.5, "l": 16, "m": "1e", "n": "e3"}
    assert type(doc["f"]) is int and type(doc["a"]) is float
    text = (ROOT / "examples" / "paper.yaml").read_text().replace("delay_s: 0.001", "delay_s: 1e-3")
    assert "1e-3" in text
    f = tmp_path / "d.yaml"
    f.write_text(text)
    assert read_yaml(f)["implementation"]["delay_s"] == 0.001
    assert load_design(f).implementation.delay_s == 0.001


def test_yaml_12_integers_and_booleans(tmp_path):
    """YAML 1.1 (PyYAML) reads ``0300`` as octal 192, ``1:30`` as 90, ``0b11`` as 3, ``1_000`` as
    1000 and ``yes``/``on``/``off`` as booleans; exotune reads the YAML 1.2 core schema: 300, and
    strings for the rest (which validation refuses, naming the field). Found by fuzzing: a cuff
    stiffness written ``0300`` was exported as 192 N·m/rad."""
    from exotune.config import load_design, load_yaml_text

    doc = load_yaml_text("a: 0300\nb: 1:30\nc: yes\nd: on\ne: Off\nf: 0b11\ng: 0o17\nh: -0012\ni: +7\n"
                         "j: true\nk: FALSE\nl: y\nm: 190:20:30.15\n")
    assert doc == {"a": 300, "b": "1:30", "c": "yes", "d": "on", "e": "Off", "f": "0b11", "g": 15, "h": -12, "i": 7,
                   "j": True, "k": False, "l": "y", "m": "190:20:30.15"}
    text = (ROOT / "examples" / "paper.yaml").read_text()
    f = tmp_path / "d.yaml"
    f.write_text(text.replace("cuff_stiffness: 300.0", "cuff_stiffness: 0300"))
    assert load_design(f).plant.K_c == 300.0
    f.write_text(text.replace("cuff_stiffness: 300.0", "cuff_stiffness: 1:30"))
    with pytest.raises(ConfigError) as e:
        load_design(f)
    assert "plant.cuff_stiffness" in e.value.field


@given(st.floats(allow_nan=False, allow_infinity=False))
def test_yaml_float_repr_round_trip(x):
    """Python's float repr (``1e-05``, ``1e+16``) and PyYAML's own dump load back
    exactly, as floats."""
    from exotune.config import load_yaml_text

    for text in (f"v: {x!r}", yaml.safe_dump({"v": x})):
        v = load_yaml_text(text)["v"]
        assert isinstance(v, float) and (v == x), text


# --------------------------------------------------------------------- accepted ranges (limits)
LIMIT_FIELDS = [
    ("plant", "motor_inertia", "inertia"),
    ("plant", "joint_inertia", "inertia"),
    ("plant", "motor_damping", "damping"),
    ("plant", "sea_stiffness", "stiffness"),
    ("plant", "cuff_stiffness", "stiffness"),
    ("design", "amplification", "amplification"),
    ("design", "felt_inertia", "inertia"),
    ("design", "felt_damping", "felt_damping"),
    ("design", "zeta", "damping_ratio"),
    ("design", "zeta_hat", "damping_ratio"),
    ("implementation", "delay_s", "delay"),
]


@pytest.mark.parametrize("section,key,kind", LIMIT_FIELDS, ids=[f"{s}.{k}" for s, k, _ in LIMIT_FIELDS])
def test_limits_are_inclusive_and_refused_outside(base, section, key, kind):
    """Both ends of an accepted range load; a value beyond either end is refused naming the
    field and the range (docs/design-file.md#input-limits-and-accepted-ranges)."""
    from exotune.config.validate import LIMITS, limit_text

    lo, _open, hi, _unit = LIMITS[kind]
    for v in (lo, hi):
        m = copy.deepcopy(base)
        m[section][key] = v
        m["implementation"]["sample_rate_hz"] = None
        assert design_from_mapping(m).raw[section][key] == v
    for v in ([lo / 10] if lo > 0 and kind != "amplification" else []) + [hi * 10]:  # (α < 1: "must be >= 1")
        m = copy.deepcopy(base)
        m[section][key] = v
        e = err(m)
        assert e.field == f"{section}.{key}" and limit_text(kind) in e.reason, str(e)


def test_limits_apply_to_batches_and_ranges(cfg, base):
    with pytest.raises(ConfigError) as ei:
        batch_config(cfg, {"plant.motor_inertia": [0.44, 1e-200]})
    assert ei.value.field == "plant.motor_inertia" and "index 1" in ei.value.reason and "[1e-9, 1e6]" in ei.value.reason
    base["humans"] = [{"kind": "spring", "stiffness": [1.0, 1e300]}]
    e = err(base)
    assert e.field == "humans[0].stiffness" and e.reason.startswith("range hi: out of the accepted range")


def test_every_error_of_a_file_is_listed(base):
    base["plant"]["motor_inertai"] = base["plant"].pop("motor_inertia")
    base["design"]["zeta"] = -1
    base["humans"][0]["inertia"] = [2.0, 1.0]
    with pytest.raises(ConfigError) as ei:
        design_from_mapping(base)
    e = ei.value
    assert str(e) == "plant.motor_inertai: unknown key; did you mean motor_inertia?"
    assert e.more == ["plant.motor_inertia: required parameter is missing", "design.zeta: must be > 0, got -1",
                      "humans[0].inertia: malformed range: lo = 2 > hi = 1"]
    import pickle

    assert pickle.loads(pickle.dumps(e)).more == e.more


def test_wrong_kind_of_file(base):
    with pytest.raises(ConfigError, match="this is an SEA file: use `exotune sea x.yaml`"):
        design_from_mapping(yaml.safe_load(SEA.read_text(encoding="utf-8")), source="x.yaml")
    with pytest.raises(ConfigError, match="this is a design file"):
        sea_from_mapping(base, source="x.yaml")


# ------------------------------------------------------------------------ the guarded readers
def test_alias_bomb_and_recursion_refused_fast(tmp_path):
    import time

    from exotune.config import read_yaml

    p = tmp_path / "b.yaml"
    lines = ["a0: &a0 [1, 2, 3, 4, 5, 6, 7, 8, 9, 10]"]
    lines += [f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 10) + "]" for i in range(1, 10)]
    p.write_text("\n".join(lines))
    t = time.perf_counter()
    with pytest.raises(ConfigError, match="aliases are expanded"):
        read_yaml(p)
    assert time.perf_counter() - t < 5
    # a few aliases are fine, and a duplicate key under an alias is reported once, by its path
    p.write_text("a: &x {k: 1}\nb: *x\nc: [*x, *x]\n")
    assert read_yaml(p) == {"a": {"k": 1}, "b": {"k": 1}, "c": [{"k": 1}, {"k": 1}]}
    p.write_text("a: &x [1, *x]\n")
    with pytest.raises(ConfigError, match="recursive alias"):
        read_yaml(p)


def test_depth_limits_name_the_path(tmp_path):
    from exotune.config import read_yaml
    from exotune.config.yamlio import MAX_DEPTH, read_json_guarded

    p = tmp_path / "d.yaml"
    p.write_text("plant: " + "{a: " * 3000 + "1" + "}" * 3000)
    with pytest.raises(ConfigError) as ei:
        read_yaml(p)
    assert ei.value.field == str(p) and f"{MAX_DEPTH} levels" in ei.value.reason and "plant.a.a" in ei.value.reason
    ok = tmp_path / "ok.yaml"
    ok.write_text("a: " + "[" * (MAX_DEPTH - 1) + "]" * (MAX_DEPTH - 1))
    read_yaml(ok)
    j = tmp_path / "m.json"
    j.write_text('{"x": ' + "[" * 100 + "]" * 100 + "}")
    with pytest.raises(ConfigError) as ei:
        read_json_guarded(j, "sweep manifest")
    assert "cannot read the sweep manifest: nested more than" in ei.value.reason and "x[0][0]" in ei.value.reason
    j.write_text('{"x": [1, 2]}')
    assert read_json_guarded(j) == {"x": [1, 2]}


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this platform")
def test_non_regular_files_refused_without_reading(tmp_path):
    from exotune.config import read_yaml
    from exotune.config.yamlio import read_json_guarded

    f = tmp_path / "f.yaml"
    os.mkfifo(f)
    for reader in (read_yaml, read_json_guarded):
        with pytest.raises(ConfigError, match="FIFO"):
            reader(f)
        with pytest.raises(ConfigError, match="a directory"):
            reader(tmp_path)
    if os.path.exists("/dev/zero"):
        with pytest.raises(ConfigError, match="character device"):
            read_yaml("/dev/zero")


def test_errors_quote_a_short_excerpt(tmp_path):
    from exotune.config import read_yaml

    p = tmp_path / "t.yaml"
    p.write_text("\n".join(f"line{i}:x:{i}:SECRET" for i in range(500)))
    with pytest.raises(ConfigError) as ei:
        read_yaml(p)
    assert len(str(ei.value)) < 300 and str(ei.value).count("SECRET") <= 5  # an 80-character excerpt
