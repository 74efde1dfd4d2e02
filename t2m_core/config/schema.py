"""JSON schema of the run configuration, with each registered component's options schema."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from t2m_core.config.models import COMPONENT_BLOCKS, RunConfig

if TYPE_CHECKING:
    from t2m_core.registry import Registry

SCHEMA_DIALECT = "https://json-schema.org/draft/2020-12/schema"


def run_config_schema(registry: Registry | None = None) -> dict[str, Any]:
    """The JSON schema (draft 2020-12) of :class:`~t2m_core.config.models.RunConfig`.

    With a registry, each component block also gets one ``if name is X then options match X's
    model`` rule per registered component (aliases included), so editors can check options too.
    """
    schema = RunConfig.model_json_schema()
    schema["$schema"] = SCHEMA_DIALECT
    if registry is None:
        return schema
    for block, kind in COMPONENT_BLOCKS.items():
        rules = []
        for entry in registry.components(kind):
            options_schema = entry.spec.options.model_json_schema()
            rules.append(
                {
                    "if": {"properties": {"name": {"enum": [entry.spec.name, *entry.spec.aliases]}}},
                    "then": {"properties": {"options": options_schema}},
                }
            )
        if rules:
            property_schema = schema["properties"][block]
            schema["properties"][block] = {"allOf": [property_schema, {"anyOf": [{"type": "null"}, {"allOf": rules}]}]}
    return schema
