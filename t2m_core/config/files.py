"""Config files on disk: reading one as a mapping, writing a resolved configuration safely."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from t2m_core.atomic_files import write_text_atomic
from t2m_core.config.models import RunConfig
from t2m_core.errors import ConfigError


def load_yaml_file(path: Path) -> dict[str, Any]:
    """Read one config file (YAML or JSON) as a mapping.

    Raises:
        ConfigError: missing file, YAML syntax error (with line and column), or not a mapping.
    """
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as error:
        raise ConfigError(f"cannot read config file {path}: {error.strerror}", hint="check the path") from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        where = f":{mark.line + 1}:{mark.column + 1}" if mark is not None else ""
        problem = getattr(error, "problem", None) or str(error)
        raise ConfigError(f"{path}{where}: invalid YAML: {problem}", hint="fix the syntax at that position") from None
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise ConfigError(
            f"{path}: a config file must be a mapping of keys, got {type(data).__name__}",
            hint="start the file with keys such as `task:` or `simulator:`",
        )
    return data


def config_to_yaml(config: RunConfig) -> str:
    """The configuration as YAML, keys in model order (what ``t2m config show`` prints)."""
    return yaml.safe_dump(config.model_dump(mode="json"), sort_keys=False, default_flow_style=False)


def write_config(config: RunConfig, path: Path) -> None:
    """Write ``config`` as YAML to ``path`` atomically: a crash never leaves a partial file there."""
    write_text_atomic(path, config_to_yaml(config))
