"""``--llm NAME`` resolution: names, aliases with their options, provider prefixes."""

from __future__ import annotations

import pytest

from t2m_core.errors import PluginError
from t2m_core.language.selection import resolve_language_model
from t2m_core.registry import Registry


@pytest.fixture(scope="module")
def registry():
    return Registry.from_entry_points()


@pytest.mark.parametrize(
    "name, expected",
    [
        ("local", ("local", {})),
        ("gpt-4", ("litellm", {"model": "gpt-4"})),
        ("gpt-4o", ("litellm", {"model": "gpt-4o"})),
        ("claude-3-5-haiku", ("litellm", {"model": "claude-3-5-haiku-20241022"})),
        ("litellm/claude-3-opus-20240229", ("litellm", {"model": "claude-3-opus-20240229"})),
        ("ollama/llama3", ("litellm", {"model": "ollama/llama3"})),
        ("openai/my-model", ("litellm", {"model": "openai/my-model"})),
        ("litellm", ("litellm", {})),
    ],
)
def test_names_resolve(registry, name, expected):
    assert resolve_language_model(name, registry=registry) == expected


def test_explicit_options_win(registry):
    assert resolve_language_model("gpt-4o", {"model": "gpt-4o-mini", "timeout_s": 5}, registry=registry) == (
        "litellm", {"model": "gpt-4o-mini", "timeout_s": 5}
    )


def test_unknown_name_suggests_a_close_one(registry):
    with pytest.raises(PluginError) as raised:
        resolve_language_model("lcal", registry=registry)
    assert "did you mean 'local'" in str(raised.value)
