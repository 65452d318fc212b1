"""exotune.controllerfile.fileio: reading and writing controller files. write→read round trips
(and a second write is byte-identical); the loader refuses a malformed or out-of-range file naming
the field; the file's controller as one state space (:func:`discrete_from_file`) runs like the
reference runtime (``scipy.signal.dlsim`` of the state space against :class:`Runtime`); the plant
is the plant section; a schedule entry's view carries that entry; position feedback is read from
the controller's own θ_m path."""

from __future__ import annotations

import copy

import numpy as np
import pytest
import scipy.signal
import yaml

from exotune.controllerfile.fileio import (check_file_limits, checked_controller, discrete_from_file, load_controller,
                                           load_controller_file, plant_from_file, position_feedback,
                                           schedule_entry_doc, write_controller)
from exotune.controllerfile.model import ControllerFile
from exotune.controllerfile.runtime import Runtime
from exotune.errors import ConfigError
from exotune.sampled import Measured


def test_write_read_round_trip_is_byte_identical(scheduled_doc, tmp_path):
    a, b = tmp_path / "a.yaml", tmp_path / "b.yaml"
    write_controller(scheduled_doc, a)
    assert a.read_text(encoding="utf-8").startswith("# exotune runtime controller file")
    back = load_controller(a)
    assert back == scheduled_doc
    write_controller(back, b)
    assert a.read_bytes() == b.read_bytes()
    cf = load_controller_file(a)
    assert isinstance(cf, ControllerFile) and cf.to_dict() == scheduled_doc


def test_loader_uses_the_safe_loader(tmp_path):
    p = tmp_path / "evil.yaml"
    p.write_text("!!python/object/apply:os.system ['true']\n", encoding="utf-8")
    with pytest.raises((ConfigError, yaml.YAMLError)):
        load_controller(p)


def test_loader_names_a_schema_error(scheduled_doc, tmp_path):
    doc = copy.deepcopy(scheduled_doc)
    doc["delay_s"]["value"] = "1 ms"
    p = tmp_path / "bad.yaml"
    write_controller(doc, p)
    with pytest.raises(ConfigError, match=r"delay_s\.value"):
        load_controller(p)


def test_checked_controller_refuses_a_changed_golden_vector(scheduled_doc):
    doc = copy.deepcopy(scheduled_doc)
    assert checked_controller(copy.deepcopy(doc)) == doc
    doc["golden"]["tau_cmd"]["values"] = doc["golden"]["tau_cmd"]["values"][:-1]
    with pytest.raises(ConfigError, match="golden"):
        checked_controller(doc)


def test_limits_name_the_field_and_range(scheduled_doc):
    doc = copy.deepcopy(scheduled_doc)
    check_file_limits(doc)  # in range
    doc["plant"]["motor_inertia"]["value"] = 1e12
    with pytest.raises(ConfigError, match=r"plant\.motor_inertia\.value.*range"):
        check_file_limits(doc)


def test_discrete_controller_runs_like_the_runtime(scheduled_doc):
    dc = discrete_from_file(scheduled_doc)
    assert dc.sample_rate_hz == pytest.approx(1000.0) and dc.delay_s == pytest.approx(scheduled_doc["delay_s"]["value"])
    rng = np.random.default_rng(4)
    scale = np.array([0.1, 1.0, 5.0, 100.0, 2.0])
    U = rng.normal(size=(100, 5)) * scale
    _, y, _ = scipy.signal.dlsim((dc.Ac, dc.Bc, dc.Cc, dc.Dc, 1e-3), U)
    ref = Runtime(scheduled_doc).run({s: U[:, i] for i, s in enumerate(Measured)})
    np.testing.assert_allclose(y[:, 0], ref, rtol=1e-7, atol=1e-7 * np.max(np.abs(ref)))


def test_plant_is_the_plant_section(scheduled_doc):
    p = plant_from_file(scheduled_doc)
    sec = scheduled_doc["plant"]
    got = p.__dict__ if hasattr(p, "__dict__") else p._asdict()
    values = sorted(float(v) for v in got.values() if isinstance(v, (int, float)))
    assert values == sorted(float(v["value"]) for v in sec.values())


def test_schedule_entry_view_has_the_entrys_controller(scheduled_doc):
    e = scheduled_doc["gain_schedule"]["entries"][-1]
    view = schedule_entry_doc(scheduled_doc, e)
    assert view["plant"] is e["plant"] and view["gains"] is e["gains"]
    assert view["controller"]["filters"] == e["controller"]["filters"]
    assert view["sample_rate_hz"] == scheduled_doc["sample_rate_hz"]
    assert scheduled_doc["controller"]["filters"] != e["controller"]["filters"]


def _ctrl(gain, sos):
    return {"gains": {"theta_m": {"gain": gain, "unit": "N·m/rad"}},
            "filters": [{"name": "f", "input": "theta_m", "sos": sos}]}


@pytest.mark.parametrize("gain, sos, expected", [
    (0.0, [[1.0, -1.0, 0.0, 1.0, -0.5, 0.0]], False),  # a zero at z = 1: no DC on θ_m
    (0.0, [[1.0, 0.0, 0.0, 1.0, -0.5, 0.0]], True),  # DC gain 2 on θ_m
    (-2.0, [[1.0, 0.0, 0.0, 1.0, -0.5, 0.0]], False),  # the gain cancels the filter's DC
    (0.0, [[1.0, 0.0, 0.0, 1.0, -1.0, 0.0]], True),  # an integrator on θ_m
])
def test_position_feedback_from_the_theta_path(scheduled_doc, gain, sos, expected):
    c = copy.deepcopy(scheduled_doc["controller"])
    c["gains"] = {k: v for k, v in c["gains"].items() if k != "theta_m"}
    c["filters"] = [f for f in c["filters"] if f["input"] != "theta_m"]
    extra = _ctrl(gain, sos)
    if gain:
        c["gains"]["theta_m"] = {"gain": gain, "unit": "N·m/rad"}
    f = copy.deepcopy(c["filters"][0])
    f.update(name="pos", input="theta_m", sos=extra["filters"][0]["sos"], input_unit="rad", unit="N·m/rad")
    c["filters"].append(f)
    assert position_feedback(c) is expected


def test_the_exported_dob_has_no_position_feedback(scheduled_doc):
    assert position_feedback(scheduled_doc["controller"]) is False
