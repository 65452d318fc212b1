"""``exotune init`` templates: shipped in the package, valid for their commands, never overwriting."""

from __future__ import annotations

import pytest
import yaml

from exotune.errors import ConfigError
from exotune.starter import TEMPLATES, template_text, write_templates


def test_templates_are_written_and_load(tmp_path):
    from exotune.config import load_design

    paths = write_templates(tmp_path / "new")
    assert [p.name for p in paths] == list(TEMPLATES)
    cfg = load_design(paths[0])
    assert cfg.design.amplification == 8.0 and cfg.implementation.sample_rate_hz == 1000.0
    for p in paths[1:]:
        doc = yaml.safe_load(p.read_text())
        assert doc["base"] == "design.yaml"
    # every template explains itself: comments name the docs page and units
    for n in TEMPLATES:
        t = template_text(n)
        assert "docs/" in t and t.count("#") > 5


def test_sweep_and_optimize_templates_validate(tmp_path):
    from exotune.optimization import load_optimize_spec

    write_templates(tmp_path)
    spec = load_optimize_spec(tmp_path / "optimize.yaml")
    assert spec is not None


def test_never_overwrites(tmp_path):
    (tmp_path / "sweep.yaml").write_text("mine\n")
    with pytest.raises(ConfigError) as e:
        write_templates(tmp_path)
    assert "sweep.yaml" in str(e.value) and "already exists" in str(e.value)
    assert not (tmp_path / "design.yaml").exists()  # nothing half-written
    assert (tmp_path / "sweep.yaml").read_text() == "mine\n"


def test_unknown_template_and_file_in_the_way(tmp_path):
    with pytest.raises(ConfigError):
        template_text("nope.yaml")
    f = tmp_path / "f"
    f.write_text("x")
    with pytest.raises(ConfigError, match="not a directory"):
        write_templates(f)


def test_init_command(tmp_path):
    from click.testing import CliRunner

    from exotune.cli import cli

    r = CliRunner().invoke(cli, ["init", str(tmp_path / "proj")])
    assert r.exit_code == 0, r.output
    assert sorted(p.name for p in (tmp_path / "proj").iterdir()) == ["design.yaml", "optimize.yaml", "sweep.yaml"]
    assert "next: exotune analyze" in r.output
    again = CliRunner().invoke(cli, ["init", str(tmp_path / "proj")])
    assert again.exit_code == 2 and "already exists" in again.output
