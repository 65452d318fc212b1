"""exotune.text.export: the one line of ``exotune export`` on a controller file exported here —
the path, the rate and the numbers it states, each with its unit, read back from the document."""

import copy
import re
from pathlib import Path

import pytest

from exotune.config import design_from_mapping, load_design
from exotune.controllerfile import build_export
from exotune.text.export import format_export

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def doc():
    raw = copy.deepcopy(load_design(ROOT / "examples" / "paper.yaml").raw)
    raw["implementation"].update(sample_rate_hz=1000.0)
    return build_export(design_from_mapping(raw), 1000.0)


def test_the_export_line(doc):
    doc = copy.deepcopy(doc)
    doc["provenance"]["uncertified"] = []  # (the paper design at 1 kHz is not robust for the lightest masses)
    doc.pop("requirements", None)
    line = format_export(doc, "out/ctrl.yaml")
    assert "\n" not in line
    n = len(doc["controller"]["filters"])
    assert line.startswith(f"wrote out/ctrl.yaml: 1000 Hz, {n} sos filters, sampled-data loop free stable, locked stable")
    assert line.endswith("; run `exotune certify out/ctrl.yaml`")
    slm = doc["predicted"]["sampled_latency_margin"]
    assert f"; sampled-data latency margin {slm['extra_delay_s'] * 1e3:.4g} ms ({slm['extra_delay_samples']:.4g} samples)" in line
    lm = doc["predicted"]["latency_margin"]
    assert f"; continuous {lm['extra_delay_s'] * 1e3:.4g} ms" in line
    for number in re.findall(r"(?<![\w.])-?\d+(?:\.\d+)?(?:e[-+]?\d+)?(?![\w.])", line.split(":", 1)[1]):
        # every number is followed by its unit (Hz, ms, samples) or counts filters
        assert re.search(re.escape(number) + r" (Hz|ms|samples|sos filters)", line), number


def test_uncertified_and_required_margin(doc):
    d = copy.deepcopy(doc)
    d["provenance"]["uncertified"] = ["locked joint unstable", "margin below requirement"]
    d["requirements"] = {"latency_margin_s": 0.002, "source": "design file"}
    line = format_export(d, "c.yaml")
    assert line.endswith("; WRITTEN UNCERTIFIED (--allow-uncertified): locked joint unstable; margin below requirement")
    assert " (required 2 ms)" in line and "run `exotune certify" not in line
