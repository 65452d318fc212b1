"""exotune.config: design and SEA files — reading (:mod:`.yamlio`), validation (:mod:`.validate`,
:mod:`.schema`), the validated configurations (:mod:`.design`) and batches for sweeps
(:mod:`.batch`)."""

from .batch import OVERRIDABLE, batch_config
from .design import (
    DesignConfig,
    SeaConfig,
    design_from_mapping,
    hash_mapping,
    load_design,
    load_sea,
    parse_env,
    parse_human,
    sea_from_mapping,
)
from .schema import ENV_KINDS, HUMAN_KINDS
from .validate import MAX_DELAY_SAMPLES, check_analysis_filters, check_delay_samples
from .yamlio import load_yaml_text, read_yaml

__all__ = [
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
    "read_yaml",
    "load_yaml_text",
    "check_analysis_filters",
    "check_delay_samples",
    "MAX_DELAY_SAMPLES",
    "OVERRIDABLE",
    "HUMAN_KINDS",
    "ENV_KINDS",
]
