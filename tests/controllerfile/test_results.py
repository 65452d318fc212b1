"""exotune.controllerfile.results: the typed results of the controller-file layer. An exported
controller's text is its YAML (which reads back to the document) and its rate the file's; a
certificate's verdict and reasons are the report's; the codegen result names its files, counts and
certification in its JSON and its lines."""

from __future__ import annotations

import copy
from pathlib import Path

import yaml

from exotune.controllerfile.results import Certificate, ExportedController, GeneratedC


def test_exported_controller_from_document(scheduled_doc, tmp_path):
    r = ExportedController.from_document(scheduled_doc, tmp_path / "c.yaml")
    assert r.sample_rate_hz == 1000.0
    assert r.path == str(tmp_path / "c.yaml")
    assert r.to_dict() == scheduled_doc
    assert yaml.safe_load(r.to_text()) == scheduled_doc
    assert ExportedController.from_document(scheduled_doc).path is None


def test_exported_controller_summary_names_the_path_rate_and_verdicts(scheduled_doc, tmp_path):
    doc = copy.deepcopy(scheduled_doc)
    doc["predicted"] = {"sampled": {"free_stable": True, "locked_stable": False}}
    s = ExportedController.from_document(doc, tmp_path / "c.yaml").summary()
    assert s.startswith(f"wrote {tmp_path / 'c.yaml'}: 1000 Hz, {len(doc['controller']['filters'])} sos filters")
    assert "free stable" in s and "locked UNSTABLE" in s


def test_certificate_from_report():
    ok = Certificate.from_report({"certified": True, "problems": []})
    assert ok.certified is True and ok.reasons == ()
    bad = Certificate.from_report({"certified": False, "problems": ["free loop unstable", "golden mismatch"]})
    assert bad.certified is False and bad.reasons == ("free loop unstable", "golden mismatch")
    assert bad.to_dict()["problems"] == ["free loop unstable", "golden mismatch"]


def _gen(certified):
    return GeneratedC(Path("/out"), ("exotune_controller.h", "exotune_controller.c", "exotune_golden_test.c"), 6, 31,
                      "-std=c99 -O2", "ab" * 32, certified, () if certified else ("not stable",))


def test_generated_c_json():
    d = _gen(True).to_dict()
    assert d == {"directory": "/out", "files": ["exotune_controller.h", "exotune_controller.c", "exotune_golden_test.c"],
                 "controllers": 6, "sections": 31, "compile_flags": "-std=c99 -O2", "source_sha256": "ab" * 32,
                 "certified": True, "reasons": []}
    assert _gen(False).to_dict()["reasons"] == ["not stable"]


def test_generated_c_text():
    t = _gen(True).to_text()
    assert "6 controllers, 31 sections" in t
    assert "cc -std=c99 -O2 -o exotune_golden_test /out/exotune_controller.c /out/exotune_golden_test.c -lm" in t
    assert "ab" * 32 in t and "certified (exotune certify passed)" in t
    assert "NOT CERTIFIED" in _gen(False).to_text()
    one = GeneratedC(Path("/o"), ("a.h", "a.c", "t.c"), 1, 2, "-O2").to_text()
    assert "(1 controller, 2 sections)" in one
