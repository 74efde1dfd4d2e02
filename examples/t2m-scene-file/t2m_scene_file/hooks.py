"""Registers the ``scene-file`` scene parser (import-light: the parser module is loaded on use)."""

from __future__ import annotations

from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field

from t2m_core.hookspecs import hookimpl
from t2m_core.plugin_specs import SceneParserSpec


class SceneFileOptions(BaseModel):
    """Options of the ``scene-file`` parser.

    Attributes:
        path: the scene file (YAML or JSON; see ``scenes/example.yaml``).
        size_tolerance: metres a measured size may differ from the TableEnv object's size.
    """

    model_config = ConfigDict(extra="forbid")

    path: Path = Field(description="Hand-measured scene file, YAML or JSON")
    size_tolerance: float = Field(
        0.01, gt=0, description="Metres a measured object size may differ from the TableEnv object's size"
    )


@hookimpl
def t2m_register_scene_parsers() -> list[SceneParserSpec]:
    """The scene-file parser."""
    return [
        SceneParserSpec(
            name="scene-file",
            aliases=("measured",),
            factory="t2m_scene_file.parser:SceneFileParser",
            options=SceneFileOptions,
            summary="Object poses measured by hand, read from a YAML/JSON scene file",
        )
    ]
