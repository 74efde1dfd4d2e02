"""Build the components a resolved run configuration names, through the plugin registry."""

from __future__ import annotations

from typing import Any

from t2m_core.config.models import COMPONENT_BLOCKS, RunConfig
from t2m_core.errors import ConfigError


def build_component(config: RunConfig, block: str) -> Any:
    """The component of config block ``block`` (``"simulator"``, ``"skills"``, ...).

    Raises:
        ConfigError: the block is null (no component chosen).
        PluginError: its plugin cannot be loaded.
    """
    from t2m_core.registry import get_registry

    component = getattr(config, block)
    if component is None:
        raise ConfigError(f"the run configuration chooses no {block.replace('_', ' ')}", f"set {block}.name (see `t2m list-plugins`)")
    return get_registry().create(COMPONENT_BLOCKS[block], component.name, component.options)
