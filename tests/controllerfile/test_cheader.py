"""exotune.controllerfile.cheader: the header both C ports share and the first lines of their
sources. The header's constants are the file's (rate, delay, controller count, largest cascade,
traceability); every return code is defined with its value; the text is ASCII with extern "C"
guards; the source starts with the file's provenance and the compile-time checks; the tables
(:func:`c_table`, :func:`controller_tables`) hold every row and angle, and the generated source
holds every coefficient of the file as a C literal of the same double."""

from __future__ import annotations

import re

import numpy as np
import pytest

from exotune.controllerfile import c_sources
from exotune.controllerfile.ccode import c_sources as c_sources64
from exotune.controllerfile.cheader import C_FLAGS, c_table, controller_tables, source_head
from exotune.controllerfile.cstep import CHECKS_C, RETURN_CODES, c_double
from exotune.version import __version__

TRACE = {"sha256": "0123abcd" * 8, "certified": True, "verdict": "CERTIFIED", "reasons": []}


@pytest.fixture(scope="module")
def files(scheduled_doc):
    return c_sources64(scheduled_doc, TRACE)


def _define(h: str, name: str) -> str:
    m = re.search(rf"^#define {name} (\S+)", h, re.M)
    assert m, name
    return m.group(1)


def test_header_constants_are_the_files(files, scheduled_doc):
    h = files["exotune_controller.h"]
    assert float(_define(h, "EXOTUNE_SAMPLE_RATE_HZ")) == scheduled_doc["sample_rate_hz"]["value"]
    assert float(_define(h, "EXOTUNE_DELAY_S")) == scheduled_doc["delay_s"]["value"]
    entries = scheduled_doc["gain_schedule"]["entries"]
    assert int(_define(h, "EXOTUNE_N_CONTROLLERS")) == 1 + len(entries)
    sections = [sum(len(f["sos"]) for f in c["filters"])
                for c in [scheduled_doc["controller"]] + [e["controller"] for e in entries]]
    assert int(_define(h, "EXOTUNE_MAX_SECTIONS")) == max(sections)
    assert _define(h, "EXOTUNE_SOURCE_SHA256") == f'"{TRACE["sha256"]}"'
    assert _define(h, "EXOTUNE_VERSION") == f'"{__version__}"'
    assert _define(h, "EXOTUNE_CERTIFIED") == "1"
    assert C_FLAGS in h


def test_every_return_code_is_defined(files):
    h = files["exotune_controller.h"]
    for name, value, _what in RETURN_CODES:
        assert int(_define(h, name)) == value


def test_header_is_ascii_with_c_linkage_guards(files):
    h = files["exotune_controller.h"]
    assert h.isascii()
    assert 'extern "C" {' in h and h.count("#ifdef __cplusplus") == 2
    assert "#ifndef EXOTUNE_CONTROLLER_H" in h and h.rstrip().endswith("#endif")


def test_uncertified_trace_lists_its_reasons(scheduled_doc):
    trace = {**TRACE, "certified": False, "verdict": "UNCERTIFIED", "reasons": ["free loop unstable", "tau·s"]}
    h = c_sources64(scheduled_doc, trace)["exotune_controller.h"]
    assert _define(h, "EXOTUNE_CERTIFIED") == "0"
    assert " *   - free loop unstable" in h and " *   - tau.s" in h


def test_source_head_names_the_provenance(scheduled_doc):
    lines = source_head(scheduled_doc, TRACE, CHECKS_C)
    assert TRACE["sha256"] in lines[1]
    assert scheduled_doc["provenance"]["exotune_version"] in lines[1]
    assert '#include "exotune_controller.h"' in lines and lines[-1] == CHECKS_C


def test_the_source_holds_every_coefficient_of_the_file(files, scheduled_doc):
    c = files["exotune_controller.c"]
    literals = {float(x) for x in re.findall(r"-?\d+\.\d*(?:e[-+]?\d+)?|-?\d+e[-+]?\d+", c)}
    ctrls = [scheduled_doc["controller"]] + [e["controller"] for e in scheduled_doc["gain_schedule"]["entries"]]
    n = 0
    for ctl in ctrls:
        for g in ctl["gains"].values():
            assert g["gain"] in literals
            n += 1
        for f in ctl["filters"]:
            for row in f["sos"]:
                for x in (row[0], row[1], row[2], row[4], row[5]):
                    assert x in literals or x == 0.0, (f["name"], x)
                    n += 1
    assert n > 100
    for e in scheduled_doc["gain_schedule"]["entries"]:
        assert c_double(e["joint_angle_rad"]) in c


def test_c_table():
    assert c_table("double", "T", ["1.0", "2.0"], "0.0") == ["static const double T[2] = {", "    1.0,", "    2.0,", "};"]
    assert c_table("double", "E", [], "0.0") == ["static const double E[1] = {", "    0.0,", "};"]


def test_controller_tables():
    lines = controller_tables([(0, 2, 0.5), (2, 3, -1.25)], ["nominal", "joint angle 0.3 rad"], c_double, [0.3])
    assert lines[0] == "static const exo_controller CONTROLLERS[2] = {"
    assert lines[1] == "    {0, 2, 0.5},  /* nominal */"
    assert lines[2] == "    {2, 3, -1.25},  /* joint angle 0.3 rad */"
    assert lines[-1] == "static const double ANGLES[1] = {0.3};"
    assert controller_tables([(0, 1, 1.0)], ["n"], c_double, [])[-1] == "static const double ANGLES[1] = {0.0};"


def test_the_package_exports_the_same_generator(scheduled_doc):
    assert c_sources(scheduled_doc, TRACE) == c_sources64(scheduled_doc, TRACE)
