"""exotune.config: design and SEA files — reading (:mod:`.yamlio`), validation (:mod:`.validate`,
:mod:`.schema`), the validated configurations (:mod:`.design`) and batches for sweeps
(:mod:`.batch`)."""

from ..lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        "load_design": "design",
        "design_from_mapping": "design",
        "DesignConfig": "design",
        "load_sea": "design",
        "sea_from_mapping": "design",
        "SeaConfig": "design",
        "parse_human": "design",
        "parse_env": "design",
        "batch_config": "batch",
        "design_row": "batch",
        "OVERRIDABLE": "batch",
        "HUMAN_KINDS": "schema",
        "ENV_KINDS": "schema",
        "read_yaml": "yamlio",
        "load_yaml_text": "yamlio",
    },
)
