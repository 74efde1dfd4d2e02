"""Registers the ``litellm`` language model and its familiar aliases (``gpt-4``, ``gpt-4o``...).

Import-light: litellm (about 3 s to import) is imported only by the factory.

How a name selects a model (see :func:`t2m_core.language.selection.resolve_language_model`):

- ``--llm gpt-4o`` — a registered alias; ``ALIAS_MODELS`` gives its litellm model name;
- ``--llm litellm/<model>`` — any litellm model name, e.g. ``litellm/claude-3-5-sonnet-20241022``;
- ``--llm ollama/llama3``, ``--llm openai/my-model`` — a name that starts with a litellm provider
  prefix (``PROVIDER_PREFIXES``) is passed to litellm as is;
- ``--llm litellm --set model=...`` (``t2m llm``; ``language_model.options.model`` in a run config) —
  the plain name with the model as an option.
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from t2m_core.hookspecs import hookimpl
from t2m_core.plugin_specs import LanguageModelSpec, NamePrefix

ALIAS_MODELS: dict[str, str] = {
    "gpt-4": "gpt-4",
    "gpt-4o": "gpt-4o",
    "gpt-4o-mini": "gpt-4o-mini",
    "gpt-4-turbo": "gpt-4-turbo",
    "gpt-4.1": "gpt-4.1",
    "gpt-4.1-mini": "gpt-4.1-mini",
    "gpt-3.5-turbo": "gpt-3.5-turbo",
    "claude-3-5-sonnet": "claude-3-5-sonnet-20241022",
    "claude-3-5-haiku": "claude-3-5-haiku-20241022",
    "claude-3-7-sonnet": "claude-3-7-sonnet-20250219",
}
"""Alias -> litellm model name."""

PROVIDER_PREFIXES: tuple[str, ...] = (
    "openai", "azure", "anthropic", "ollama", "ollama_chat", "gemini", "vertex_ai", "bedrock", "groq",
    "mistral", "together_ai", "openrouter", "deepseek", "fireworks_ai", "huggingface", "vllm",
    "hosted_vllm", "text-completion-openai", "cohere", "xai", "perplexity", "deepinfra", "lm_studio",
)
"""litellm provider prefixes that ``--llm <prefix>/<model>`` passes straight to litellm."""


class LiteLLMOptions(BaseModel):
    """Options of the litellm backend. API keys are never options: they stay in the provider's
    environment variable (``OPENAI_API_KEY``, ``ANTHROPIC_API_KEY``...), or the one named here.

    Attributes:
        model: litellm model name (``gpt-4o``, ``claude-3-5-sonnet-20241022``, ``ollama/llama3``,
            ``openai/NAME`` together with ``api_base``).
        api_base: base URL of an OpenAI-compatible or ollama server (``http://127.0.0.1:8000/v1``).
        api_key_env: name of the environment variable holding the key, when it is not the
            provider's usual one.
        timeout_s: per-request timeout in seconds.
        max_retries: retries after a rate limit, timeout, connection or server error.
        backoff_s: first retry delay in seconds; doubles with every retry.
        completion_api: ``chat`` (messages) or ``text`` (legacy completions endpoint).
        scoring: ``multiple_choice`` (labelled options, top-k log-probabilities; approximate),
            ``prompt_logprobs`` (echoed prompt log-probabilities on the text endpoint; exact where
            the server computes them correctly), ``auto`` (``prompt_logprobs`` for the text API,
            else ``multiple_choice``).
        orderings: candidate orderings averaged by multiple-choice scoring (position bias).
        top_logprobs: alternatives requested for the answer token (≥ K + 1; OpenAI allows 20).
        system_prompt: one system line sent with generation requests on the chat API.
    """

    model_config = ConfigDict(extra="forbid")

    model: str = Field(default="gpt-4o", min_length=1, description="litellm model name")
    api_base: str | None = Field(default=None, description="server URL for OpenAI-compatible or ollama servers")
    api_key_env: str | None = Field(default=None, description="environment variable that holds the API key")
    timeout_s: float = Field(default=60.0, gt=0, description="request timeout (seconds)")
    max_retries: int = Field(default=4, ge=0, le=20, description="retries on rate limits and server errors")
    backoff_s: float = Field(default=1.0, ge=0, description="first retry delay (seconds), doubling")
    completion_api: Literal["chat", "text"] = "chat"
    scoring: Literal["auto", "multiple_choice", "prompt_logprobs"] = "auto"
    orderings: int = Field(default=3, ge=1, le=26, description="orderings averaged by multiple-choice scoring")
    top_logprobs: int = Field(default=20, ge=2, le=20, description="top-k alternatives for the answer token")
    system_prompt: str | None = Field(default="Answer with a Python list only.", description="system line for generation")


@hookimpl
def t2m_register_language_models() -> list[LanguageModelSpec]:
    """The litellm backend; each alias implies its model name (``alias_options``)."""
    return [
        LanguageModelSpec(
            name="litellm",
            aliases=tuple(ALIAS_MODELS),
            factory="t2m_litellm.backend:LiteLLMLanguageModel",
            options=LiteLLMOptions,
            summary="Any litellm model (gpt-4o, claude-..., ollama/..., openai/NAME + api_base)",
            alias_options={alias: {"model": model} for alias, model in ALIAS_MODELS.items()},
            # "litellm/NAME" -> model NAME; "<provider>/NAME" -> model "<provider>/NAME" (litellm routes it)
            name_prefixes=(
                NamePrefix("litellm/", "model", strip=True),
                *(NamePrefix(f"{prefix}/", "model") for prefix in PROVIDER_PREFIXES),
            ),
        )
    ]
