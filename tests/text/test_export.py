"""exotune.text.export: the one line of ``exotune export`` on a controller file exported here —
the path, the rate and the numbers it states, each with its unit, read back from the document."""

import copy
import re

import pytest

from exotune.text.export import format_export

from paper_design import paper_controller


@pytest.fixture(scope="module")
def doc():
    return paper_controller(1000.0)


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
