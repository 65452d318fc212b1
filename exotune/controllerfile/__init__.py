"""exotune.controllerfile: the runtime controller file — its format (:mod:`.schema`), its typed model
(:class:`~.model.ControllerFile`, :mod:`.model`), consistency
checks (:mod:`.checks`), reading and writing (:mod:`.fileio`), discretization to second-order
sections (:mod:`.sos`), building it from a design (:mod:`.export`), the reference runtime
(:mod:`.runtime`) and its sampled-data certification (:mod:`.certify`).

(The function ``certify`` is not re-exported here: ``exotune.controllerfile.certify`` is the
module.)"""

from .ccode import c_sources, write_c_sources
from .certify import position_feedback, sampled_analysis
from .continuation import stable_intervals
from .checks import MIN_GOLDEN_SAMPLES, check_controller_file
from .export import build_export, check_sample_rate, design_at_rate, export_design, reflected_mapping
from .fileio import (checked_controller, checked_controller_file, discrete_from_file, load_controller, load_controller_file,
                     plant_from_file, schedule_entry_doc, write_controller)
from .model import ControllerFile, as_controller_file
from .runtime import Runtime, SosFilter
from .schema import SCHEMA_VERSION, SIGNAL_UNITS, ControllerSchema, json_schema, schema_path, validate_controller, write_schema
from .sos import sos_ss, tustin_sos

__all__ = [
    "c_sources",
    "write_c_sources",
    "SCHEMA_VERSION",
    "SIGNAL_UNITS",
    "ControllerFile",
    "as_controller_file",
    "ControllerSchema",
    "validate_controller",
    "json_schema",
    "write_schema",
    "schema_path",
    "check_controller_file",
    "MIN_GOLDEN_SAMPLES",
    "tustin_sos",
    "sos_ss",
    "load_controller",
    "load_controller_file",
    "checked_controller",
    "checked_controller_file",
    "write_controller",
    "discrete_from_file",
    "plant_from_file",
    "schedule_entry_doc",
    "build_export",
    "export_design",
    "design_at_rate",
    "check_sample_rate",
    "reflected_mapping",
    "sampled_analysis",
    "stable_intervals",
    "position_feedback",
    "Runtime",
    "SosFilter",
]
