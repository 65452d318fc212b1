"""exotune.config: design and SEA files — reading (:mod:`.yamlio`), validation (:mod:`.validate`,
:mod:`.schema`), the validated configurations (:mod:`.design`) and batches for sweeps
(:mod:`.batch`)."""

from .batch import OVERRIDABLE, OVERRIDE_LIMITS, batch_config, continuous, design_row
from .design import (
    DesignConfig,
    SeaConfig,
    design_from_mapping,
    hash_mapping,
    load_design,
    load_sea,
    parse_env,
    parse_human,
    refuse_other_kind,
    sea_from_mapping,
)
from .schema import ENV_KINDS, HUMAN_KINDS
from .validate import (LIMITS, MAX_DELAY_SAMPLES, check_analysis_filters, check_delay_samples, check_limit,
                       number_field)
from .yamlio import (MAX_DEPTH, MAX_JSON_BYTES, MAX_YAML_BYTES, MAX_YAML_NODES, load_yaml_text, read_json_guarded,
                     read_yaml, spec_base)

__all__ = [
    "spec_base",
    "number_field",
    "design_row",
    "continuous",
    "DesignConfig",
    "SeaConfig",
    "load_design",
    "design_from_mapping",
    "load_sea",
    "sea_from_mapping",
    "parse_human",
    "parse_env",
    "batch_config",
    "hash_mapping",
    "refuse_other_kind",
    "read_yaml",
    "read_json_guarded",
    "MAX_YAML_BYTES",
    "MAX_JSON_BYTES",
    "MAX_DEPTH",
    "MAX_YAML_NODES",
    "load_yaml_text",
    "check_analysis_filters",
    "check_delay_samples",
    "check_limit",
    "MAX_DELAY_SAMPLES",
    "OVERRIDABLE",
    "OVERRIDE_LIMITS",
    "LIMITS",
    "HUMAN_KINDS",
    "ENV_KINDS",
]
