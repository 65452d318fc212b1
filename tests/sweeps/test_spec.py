"""exotune.sweeps.spec: reading and validating a sweep spec; every error names its field."""

from pathlib import Path

import numpy as np
import pytest
import yaml

from exotune.errors import ConfigError
from exotune.sweeps.spec import DEFAULT_CHUNK_SIZE, int_option, is_number, load_base, load_spec

ROOT = Path(__file__).resolve().parents[2]
PAPER = str(ROOT / "examples" / "paper.yaml")


def _spec(**kw):
    s = {"base": PAPER, "axes": {"design.amplification": [2.0, 8.0]}}
    s.update(kw)
    return s


def test_axis_forms_expand_as_documented():
    plan = load_spec(_spec(axes={"design.amplification": {"start": 1.0, "stop": 100.0, "num": 3, "scale": "log"},
                                 "implementation.delay_s": {"start": 0.0, "stop": 0.004, "num": 5},
                                 "design.zeta_hat": {"start": 0.7, "stop": 0.9, "num": 1}}))
    ax = plan.spec["axes"]
    assert ax["design.amplification"]["values"] == pytest.approx([1.0, 10.0, 100.0], rel=1e-12)
    assert ax["design.amplification"]["scale"] == "log"
    assert ax["implementation.delay_s"]["values"] == pytest.approx([0.0, 0.001, 0.002, 0.003, 0.004])
    assert ax["implementation.delay_s"]["scale"] == "lin"
    assert ax["design.zeta_hat"]["values"] == [0.7]  # num 1: start
    assert plan.chunk_size == DEFAULT_CHUNK_SIZE and plan.sample is None and plan.seed is None


def test_spec_file_base_is_relative_to_the_spec(tmp_path):
    (tmp_path / "d").mkdir()
    (tmp_path / "d" / "base.yaml").write_text(Path(PAPER).read_text(encoding="utf-8"), encoding="utf-8")
    p = tmp_path / "d" / "spec.yaml"
    p.write_text(yaml.safe_dump({"base": "base.yaml", "axes": {"design.amplification": [3.0]}, "chunk_size": 7}))
    plan = load_spec(p, chunk_size=2)
    assert plan.chunk_size == 2 and plan.source == str(p) and plan.base_source == str(tmp_path / "d" / "base.yaml")


@pytest.mark.parametrize("spec, field, reason", [
    (_spec(extra=1), "extra", "unknown key in a sweep spec"),
    ({"axes": {"design.amplification": [2.0]}}, "base", "required key is missing"),
    (_spec(axes={}), "axes", "at least one axis is required"),
    (_spec(axes=[1]), "axes", "expected a mapping"),
    (_spec(axes={"design.amplification": []}), "axes.design.amplification", "at least one value"),
    (_spec(axes={"design.amplification": [2.0, 2.0]}), "axes.design.amplification[1]", "duplicate value 2"),
    (_spec(axes={"design.amplification": {"start": 1, "stop": 2}}), "axes.design.amplification.num", "missing"),
    (_spec(axes={"design.amplification": {"start": 1, "stop": 2, "num": 2.5}}), "axes.design.amplification.num",
     "expected an integer"),
    (_spec(axes={"design.amplification": {"start": 1, "stop": 2, "num": 0}}), "axes.design.amplification.num",
     "must be >= 1"),
    (_spec(axes={"design.amplification": {"start": 1, "stop": 2, "num": 2, "scale": "exp"}}),
     "axes.design.amplification.scale", "'lin' or 'log'"),
    (_spec(axes={"implementation.delay_s": {"start": 0, "stop": 0.01, "num": 2, "scale": "log"}}),
     "axes.implementation.delay_s.start", "must be > 0 for scale: log"),
    (_spec(axes={"design.amplification": {"start": 2, "stop": 2, "num": 3}}), "axes.design.amplification",
     "duplicate values"),
    (_spec(axes={"design.amplification": {"start": 1, "stop": 2, "num": 2, "step": 1}}),
     "axes.design.amplification.step", "unknown key"),
    (_spec(axes={"design.amplification": [0.5]}), "axes.design.amplification", ""),  # α < 1: the design rules
    (_spec(axes={"humans": [1.0]}), "axes.humans", ""),  # not sweepable
    (_spec(axes={"design.amplification": "x"}), "axes.design.amplification", "got the string 'x'"),
    (_spec(chunk_size=0), "chunk_size", "must be >= 1"),
    (_spec(chunk_size=True), "chunk_size", "expected an integer"),
    (_spec(verify_points=5000), "verify_points", "at most 1000"),
    (_spec(plant_margin="yes"), "plant_margin", "expected true, false or a mapping"),
    (_spec(plant_margin={"budget": 10}), "plant_margin.budget", "must be >= 1000"),
    (_spec(sampled="yes"), "sampled", "expected true or false"),
    (_spec(base=3), "base", "expected a design file path or a mapping, got the number 3"),
])
def test_bad_specs_name_the_field(spec, field, reason):
    with pytest.raises(ConfigError) as ei:
        load_spec(spec)
    assert ei.value.field == field
    assert reason in ei.value.reason


def test_sample_and_seed_options():
    with pytest.raises(ConfigError) as ei:
        load_spec(_spec(), sample=3)
    assert ei.value.field == "sample" and "exceeds the number of grid points (2)" in ei.value.reason
    with pytest.raises(ConfigError) as ei:
        load_spec(_spec(), seed=1)
    assert ei.value.field == "seed"
    plan = load_spec(_spec(), sample=2)
    assert plan.seed == 0 and plan.n_points == 2


def test_optional_keys_are_in_the_normalized_spec_only_when_used():
    plain = load_spec(_spec())
    assert "verify_points" not in plain.spec and "plant_margin" not in plain.spec and "sampled" not in plain.spec
    used = load_spec(_spec(verify_points=4, plant_margin=True))
    assert used.spec["verify_points"] == 4 and used.spec["plant_margin"] == {"budget": 150_000}
    assert used.hash != plain.hash


def test_load_base_errors_name_base(tmp_path):
    with pytest.raises(ConfigError) as ei:
        load_base(str(tmp_path / "missing.yaml"), str(tmp_path))
    assert ei.value.field.startswith("base (")
    with pytest.raises(ConfigError) as ei:
        load_base({"plant": {}}, str(tmp_path))
    assert ei.value.field.startswith("base.")
    cfg, src = load_base(PAPER, "/")
    assert src == PAPER and float(cfg.design.amplification) == 8.0


def test_is_number_and_int_option():
    assert is_number(1) and is_number(2.5) and is_number(np.float32(1)) and is_number(np.int8(3))
    assert not is_number(True) and not is_number(np.bool_(False)) and not is_number("1") and not is_number(None)
    assert int_option("x", np.int64(5), 1) == 5
    with pytest.raises(ConfigError, match="x: must be >= 2, got 1"):
        int_option("x", 1, 2)
    with pytest.raises(ConfigError, match="x: expected an integer >= 0, got 1.0"):
        int_option("x", 1.0, 0)
