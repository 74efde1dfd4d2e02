"""The litellm backend: option handling, keys, retries, and real requests to a local
OpenAI-compatible server (``python -m llama_cpp.server`` with the embedded model on 127.0.0.1)."""

from __future__ import annotations

import math
import os
import socket
import subprocess
import sys
import time
import urllib.request

import pytest
from pydantic import ValidationError

from t2m_core.errors import T2MError
from t2m_core.language.prompts import scoring_request
from t2m_core.testing import check_import_light, check_language_model
from t2m_litellm.hooks import ALIAS_MODELS, LiteLLMOptions, t2m_register_language_models

SECRET = "sk-test-0123456789abcdefghijklmnop"


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def test_spec_aliases_and_options():
    (spec,) = t2m_register_language_models()
    assert spec.name == "litellm" and {"gpt-4", "gpt-4o", "gpt-3.5-turbo"} <= set(spec.aliases)
    assert spec.alias_options["gpt-4o"] == {"model": "gpt-4o"}
    assert ALIAS_MODELS["claude-3-5-sonnet"].startswith("claude-3-5-sonnet-")
    with pytest.raises(ValidationError):
        LiteLLMOptions(api_key=SECRET)  # keys are never options: they would reach a run directory
    check_import_light("t2m_litellm.hooks")


def test_missing_key_is_reported_before_any_request(monkeypatch):
    from t2m_litellm.backend import LiteLLMLanguageModel

    monkeypatch.delenv("OPENAI_API_KEY", raising=False)
    with pytest.raises(T2MError, match="OPENAI_API_KEY is not set") as raised:
        LiteLLMLanguageModel(LiteLLMOptions(model="gpt-4o"))
    assert "--llm local" in str(raised.value)
    with pytest.raises(T2MError, match="MY_KEY_VARIABLE"):
        LiteLLMLanguageModel(LiteLLMOptions(model="gpt-4o", api_key_env="MY_KEY_VARIABLE"))


def test_unreachable_server_is_retried_then_reported_without_the_key(monkeypatch):
    from t2m_litellm.backend import LiteLLMLanguageModel

    monkeypatch.setenv("T2M_TEST_KEY", SECRET)
    options = LiteLLMOptions(
        model="openai/unreachable", api_base=f"http://127.0.0.1:{free_port()}/v1", api_key_env="T2M_TEST_KEY",
        max_retries=2, backoff_s=0.01, timeout_s=5,
    )
    model = LiteLLMLanguageModel(options)
    with pytest.raises(T2MError, match="failed after 3 attempts") as raised:
        model.complete("hello", max_tokens=2)
    assert SECRET not in str(raised.value)
    with pytest.raises(T2MError, match="grammar"):
        model.complete("hello", grammar='root ::= "a"')


@pytest.fixture(scope="module")
def server():
    """A llama.cpp OpenAI-compatible server with the embedded model; yields its /v1 URL."""
    pytest.importorskip("uvicorn", reason="llama_cpp.server needs the [server] extras (uvicorn, fastapi, sse-starlette, starlette-context)")
    from t2m_llm_local.model_files import embedded_model_path

    port = free_port()
    command = [
        sys.executable, "-m", "llama_cpp.server", "--model", str(embedded_model_path("qwen2.5-coder-0.5b")), "--host", "127.0.0.1",
        "--port", str(port), "--n_ctx", "1024", "--logits_all", "true", "--n_threads", "1", "--verbose", "false",
    ]
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env={**os.environ})
    url = f"http://127.0.0.1:{port}/v1"
    deadline = time.monotonic() + 120
    while True:
        try:
            urllib.request.urlopen(url + "/models", timeout=2)
            break
        except OSError:
            if process.poll() is not None or time.monotonic() > deadline:
                process.kill()
                pytest.fail(f"llama_cpp.server did not start: {process.stderr.read().decode()[-2000:]}")
            time.sleep(0.5)
    yield url
    process.terminate()
    process.wait(timeout=30)


CONTEXT = (
    "Available scene objects: ['table', 'rack', 'red_box']\n"
    "Object relationships: ['on(rack, table)', 'inhand(red_box)']\n"
    "Human instruction: Put the red box on the rack.\n"
)


@pytest.mark.llm
@pytest.mark.slow
def test_chat_model_through_a_local_server_conforms(server):
    from t2m_litellm.backend import LiteLLMLanguageModel

    options = LiteLLMOptions(model="openai/embedded", api_base=server, timeout_s=120, max_retries=1, orderings=1)
    assert not LiteLLMLanguageModel(options).capabilities.exact_scoring
    check_language_model(LiteLLMLanguageModel(options), max_tokens=8)
    # two orderings of three candidates: two requests whose label probabilities are averaged
    model = LiteLLMLanguageModel(options.model_copy(update={"orderings": 2}))
    assert model.scoring == "multiple_choice"
    prompt, continuations = scoring_request(CONTEXT, ["place(red_box, rack)", "pick(red_box)", "pull(red_box, rack)"])
    scores = model.score(prompt, continuations)
    probabilities = [math.exp(value) for value in scores]
    assert all(0 < p <= 1 for p in probabilities)
    assert sum(probabilities) == pytest.approx(1.0, abs=0.35)  # floors and non-label tokens aside


@pytest.mark.llm
@pytest.mark.slow
def test_text_completion_with_echoed_prompt_logprobs(server):
    from t2m_litellm.backend import LiteLLMLanguageModel

    model = LiteLLMLanguageModel(LiteLLMOptions(model="openai/embedded", api_base=server, completion_api="text", timeout_s=120))
    assert model.capabilities.exact_scoring and model.scoring == "prompt_logprobs"
    prompt, continuations = scoring_request(CONTEXT, ["place(red_box, rack)"])
    scores = model.score(prompt, continuations)
    # llama-cpp-python 0.3.36 echoes wrong prompt log-probabilities, so only their form is checked here
    assert len(scores) == 1 and math.isfinite(scores[0]) and scores[0] < 0


def test_multiple_choice_context_drops_the_executed_action_line_and_stops_are_applied():
    from t2m_litellm.backend import _cut_at_stop, without_query_line

    assert without_query_line("a\nb\nExecuted action:") == "a\nb\n"
    assert without_query_line("a\nb: c") == "a\nb: c"  # a full line, not a query label
    assert _cut_at_stop("[1]\nExecuted action: x", ["Executed action:", "\n"]) == "[1]"
    assert _cut_at_stop("[1]", []) == "[1]"
