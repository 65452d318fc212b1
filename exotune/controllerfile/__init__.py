"""exotune.controllerfile: the runtime controller file — its format (:mod:`.schema`), its typed model
(:class:`~.model.ControllerFile`, :mod:`.model`), consistency
checks (:mod:`.checks`), reading and writing (:mod:`.fileio`), discretization to second-order
sections (:mod:`.sos`), building it from a design (:mod:`.export`), the reference runtime
(:mod:`.runtime`), its sampled-data certification (:mod:`.certify`) and certify's consistency checks
alone (:mod:`.consistency`, for ``simulate``).

(The function ``certify`` is not re-exported here: ``exotune.controllerfile.certify`` is the
module.)"""

from ..lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        "SCHEMA_VERSION": "schema",
        "ControllerSchema": "schema",
        "validate_controller": "schema",
        "json_schema": "schema",
        "write_schema": "schema",
        "schema_path": "schema",
        "ControllerFile": "model",
        "as_controller_file": "model",
        "check_controller_file": "checks",
        "load_controller": "fileio",
        "load_controller_file": "fileio",
        "checked_controller": "fileio",
        "checked_controller_file": "fileio",
        "write_controller": "fileio",
        "tustin_sos": "sos",
        "build_export": "export",
        "export_design": "export",
        "design_at_rate": "export",
        "Runtime": "runtime",
        "SosFilter": "runtime",
        "c_sources": "ccode",
        "write_c_sources": "ccode",
    },
)
