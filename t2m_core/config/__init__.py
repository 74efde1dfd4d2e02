"""Run configuration: models (:mod:`.models`), resolution from files, flags and overrides
(:mod:`.resolve`), reading and writing files (:mod:`.files`), and the JSON schema (:mod:`.schema`)."""

from t2m_core.config.files import config_to_yaml, load_yaml_file, write_config
from t2m_core.config.models import COMPONENT_BLOCKS, ComponentConfig, OutputSettings, RunConfig, RunSettings
from t2m_core.config.resolve import (
    NAMED_FLAGS,
    ConfigIssue,
    check_config,
    deep_merge,
    parse_override,
    resolve_config,
)
from t2m_core.config.schema import run_config_schema

__all__ = [
    "COMPONENT_BLOCKS",
    "NAMED_FLAGS",
    "ComponentConfig",
    "ConfigIssue",
    "OutputSettings",
    "RunConfig",
    "RunSettings",
    "check_config",
    "config_to_yaml",
    "deep_merge",
    "load_yaml_file",
    "parse_override",
    "resolve_config",
    "run_config_schema",
    "write_config",
]
