"""Shared fixtures of the controller-file tests: small controller documents of examples/scheduled.yaml
at 1 kHz, built without the (slow) sampled-data predictions."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[2]


def fast_doc(precision: str | None = None, rate_hz: float = 1000.0) -> dict:
    """A valid controller document of examples/scheduled.yaml (DOB, gain schedule) at ``rate_hz``
    without the sampled-data predictions, as read back from YAML."""
    from exotune.config import read_yaml
    from exotune.controllerfile import build_export, design_at_rate

    raw = read_yaml(ROOT / "examples" / "scheduled.yaml")
    if precision:
        raw["implementation"]["precision"] = precision
    doc = build_export(design_at_rate(raw, rate_hz), rate_hz, analyses=False)
    doc["predicted"] = {}
    for e in (doc.get("gain_schedule") or {}).get("entries", []):
        e["predicted_sampled"] = {}
    return yaml.safe_load(yaml.safe_dump(doc, sort_keys=False, allow_unicode=True))


@pytest.fixture(scope="session")
def scheduled_doc() -> dict:
    """examples/scheduled.yaml exported at 1 kHz (float64), predictions left empty."""
    return fast_doc()


@pytest.fixture(scope="session")
def scheduled_doc32() -> dict:
    """examples/scheduled.yaml exported at 1 kHz for float32, predictions left empty."""
    return fast_doc("float32")
