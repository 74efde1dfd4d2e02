"""Registers the ``replay`` language model (import-light: the factory is loaded lazily)."""

from __future__ import annotations

from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field

from t2m_core.hookspecs import hookimpl
from t2m_core.plugin_specs import LanguageModelSpec


class ReplayOptions(BaseModel):
    """Options of the replay model.

    Attributes:
        transcript: a ``transcript.jsonl`` written by an earlier run (``runs/<id>/transcript.jsonl``).
    """

    model_config = ConfigDict(extra="forbid")

    transcript: Path = Field(description="JSON-lines transcript of an earlier run to answer from")


@hookimpl
def t2m_register_language_models() -> list[LanguageModelSpec]:
    """The replay backend."""
    return [
        LanguageModelSpec(
            name="replay",
            factory="t2m_llm_replay.replay:ReplayLanguageModel",
            options=ReplayOptions,
            summary="Answer from a recorded transcript (offline reproduction, tests)",
        )
    ]
