"""Registers the ``ground-truth`` scene parser (import-light: the parser is loaded lazily)."""

from __future__ import annotations

from t2m_core.hookspecs import hookimpl
from t2m_core.plugin_specs import NoOptions, SceneParserSpec


@hookimpl
def t2m_register_scene_parsers() -> list[SceneParserSpec]:
    """The ground-truth scene parser."""
    return [
        SceneParserSpec(
            name="ground-truth",
            aliases=("truth",),
            factory="t2m_scene_truth.parser:GroundTruthSceneParser",
            options=NoOptions,
            summary="The simulator's exact object poses (no perception)",
        )
    ]
