"""Resolving ``--llm NAME`` to a language-model component and its options.

On top of the registry's names and aliases, a :class:`~t2m_core.plugin_specs.LanguageModelSpec`
may declare:

- ``alias_options``: ``{alias: {option: value}}`` applied when the alias is used
  (``gpt-4o`` -> the litellm spec with ``model="gpt-4o"``);
- ``name_prefixes``: :class:`~t2m_core.plugin_specs.NamePrefix` es, so that
  ``litellm/claude-3-5-haiku-20241022`` and ``ollama/llama3`` select that spec with the remainder
  (``strip=True``) or the whole name as the prefix's option.

Explicit options always win over what the name implies.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from t2m_core.errors import PluginError

KIND = "language_model"


def resolve_language_model(name: str, options: Mapping[str, Any] | None = None, registry: Any = None) -> tuple[str, dict[str, Any]]:
    """The canonical component name and merged options that ``name`` selects.

    Raises:
        PluginError: no registered name, alias or prefix matches; the hint lists the choices.
    """
    from t2m_core.registry import get_registry

    registry = registry or get_registry()
    explicit = dict(options or {})
    try:
        spec = registry.get(KIND, name)
    except PluginError as unknown:
        for candidate in registry.specs(KIND):
            for family in candidate.name_prefixes:
                if name.startswith(family.prefix) and len(name) > len(family.prefix):
                    value = name[len(family.prefix) :] if family.strip else name
                    return candidate.name, {family.option: value, **explicit}
        raise unknown
    implied = dict(spec.alias_options.get(name, {})) if name != spec.name else {}
    return spec.name, {**implied, **explicit}


def create_language_model(
    name: str,
    options: Mapping[str, Any] | None = None,
    *,
    transcript: str | Path | None = None,
    registry: Any = None,
) -> Any:
    """Build the language model ``name`` selects; with ``transcript``, record every call there."""
    from t2m_core.language.transcript import RecordingLanguageModel, TranscriptWriter
    from t2m_core.registry import get_registry

    registry = registry or get_registry()
    canonical, merged = resolve_language_model(name, options, registry)
    model = registry.create(KIND, canonical, merged)
    if transcript is None:
        return model
    label = getattr(model, "name", None) or f"{canonical}:{merged.get('model', '')}".rstrip(":")
    return RecordingLanguageModel(model, TranscriptWriter(transcript), label)
