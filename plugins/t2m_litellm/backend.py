"""The litellm backend: generation through any provider, and candidate scoring.

Scoring (docs/guide/prompts.md#scores-from-a-language-model):

- ``multiple_choice`` (chat models, approximate): the scoring context with its ``Executed action:``
  line replaced by a labelled candidate list; one answer token at temperature 0 with top-k
  log-probabilities; floors for labels not returned; probabilities averaged over ``orderings``
  cyclic shifts of the candidates.
- ``prompt_logprobs`` (text-completion servers that echo prompt log-probabilities, e.g. vLLM; exact):
  context + candidate is sent with ``echo``, ``logprobs=1`` and no new tokens, and the log-probs of
  the tokens covering the candidate's characters are summed.

Requests time out after ``timeout_s``; rate limits, timeouts, connection and 5xx errors are retried
``max_retries`` times with exponential backoff. A missing key is reported before the first request.
API keys are read from the environment and passed to litellm per request; they never appear in an
option, a log line, an error message or a transcript (every message goes through
:func:`~t2m_core.language.transcript.redact`).
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Sequence
from typing import Any

from t2m_core.errors import T2MError
from t2m_core.language.scoring import (
    average_choice_logprobs,
    choice_labels,
    continuation_logprob,
    cyclic_orderings,
    label_logprobs,
    multiple_choice_prompt,
)
from t2m_core.language.transcript import redact
from t2m_core.protocols import LanguageModelCapabilities

from t2m_litellm.hooks import LiteLLMOptions

log = logging.getLogger(__name__)

_MAX_STOP_SEQUENCES = 4  # the OpenAI API rejects more


def _import_litellm() -> Any:
    """Import litellm without letting it fetch its model-cost map from the network."""
    os.environ.setdefault("LITELLM_LOCAL_MODEL_COST_MAP", "True")
    import litellm

    litellm.suppress_debug_info = True
    litellm.drop_params = True  # providers without n / top_logprobs get the call without them
    return litellm


def without_query_line(prompt: str) -> str:
    """The scoring prompt without its final query line (``Executed action:``)."""
    head, newline, last = prompt.rpartition("\n")
    return head + newline if newline and last.rstrip().endswith(":") else prompt


class LiteLLMLanguageModel:
    """A litellm-reachable model behind the :class:`~t2m_core.protocols.LanguageModel` protocol."""

    def __init__(self, options: LiteLLMOptions) -> None:
        self.options = options
        self._litellm = _import_litellm()
        self.scoring = options.scoring
        if self.scoring == "auto":
            self.scoring = "prompt_logprobs" if options.completion_api == "text" else "multiple_choice"
        self.capabilities = LanguageModelCapabilities(exact_scoring=self.scoring == "prompt_logprobs", grammar=False)
        self.name = f"litellm:{options.model}"
        self._api_key = self._find_api_key()

    # ------------------------------------------------------------------------------------------
    # keys and requests
    # ------------------------------------------------------------------------------------------

    def _find_api_key(self) -> str | None:
        """The key to send, or ``None`` to let litellm read the provider's own variable.

        Raises:
            T2MError: the provider needs a key and none is set.
        """
        if self.options.api_key_env:
            key = os.environ.get(self.options.api_key_env)
            if not key:
                raise T2MError(
                    f"the environment variable {self.options.api_key_env} (api_key_env) is not set",
                    hint=f"export {self.options.api_key_env}=<your key>",
                )
            return key
        if self.options.api_base:
            # Local OpenAI-compatible servers accept any key; the client library insists on one.
            needed = self._litellm.validate_environment(self.options.model).get("missing_keys", [])
            return "no-key-needed" if needed else None
        report = self._litellm.validate_environment(self.options.model)
        missing = [key for key in report.get("missing_keys", []) if key.endswith(("_KEY", "_TOKEN"))]
        if missing:
            raise T2MError(
                f"no API key for {self.options.model}: {', '.join(missing)} is not set",
                hint=f"export {missing[0]}=<your key>, or run with the embedded model (--llm local)",
            )
        return None

    def _request(self, call: str, **arguments: Any) -> Any:
        """One litellm call with timeout, retries and backoff; errors come back redacted."""
        exceptions = self._litellm.exceptions
        retryable = (
            exceptions.RateLimitError,
            exceptions.Timeout,
            exceptions.APIConnectionError,
            exceptions.InternalServerError,
            exceptions.ServiceUnavailableError,
            exceptions.BadGatewayError,
        )
        if self.options.api_base:
            arguments["api_base"] = self.options.api_base
        if self._api_key:
            arguments["api_key"] = self._api_key
        delay = self.options.backoff_s
        for attempt in range(self.options.max_retries + 1):
            try:
                return getattr(self._litellm, call)(
                    model=self.options.model, timeout=self.options.timeout_s, num_retries=0, **arguments
                )
            except exceptions.AuthenticationError as error:
                raise T2MError(
                    f"{self.options.model} rejected the API key: {redact(str(error))[:300]}",
                    hint="check the key in the provider's environment variable",
                ) from None
            except retryable as error:
                if attempt == self.options.max_retries:
                    raise T2MError(
                        f"{self.options.model} failed after {attempt + 1} attempts: {redact(str(error))[:300]}",
                        hint="check the server (api_base), the network, or raise max_retries / timeout_s",
                    ) from None
                log.warning("%s: %s; retrying in %.1f s", self.options.model, type(error).__name__, delay)
                time.sleep(delay)
                delay *= 2
            except exceptions.APIError as error:
                raise T2MError(f"{self.options.model} request failed: {redact(str(error))[:300]}") from None
        raise AssertionError("unreachable")

    # ------------------------------------------------------------------------------------------
    # generation
    # ------------------------------------------------------------------------------------------

    def complete(
        self,
        prompt: str,
        *,
        max_tokens: int = 256,
        stop: Sequence[str] = (),
        temperature: float = 0.0,
        n: int = 1,
        grammar: str | None = None,
    ) -> list[str]:
        """``n`` completions (``grammar`` is not supported by remote APIs and must be ``None``)."""
        if grammar is not None:
            raise T2MError("the litellm backend cannot do grammar-constrained decoding", hint="pass grammar=None")
        samples = 1 if temperature == 0 else n
        texts: list[str] = []
        while len(texts) < samples:
            wanted = samples - len(texts)
            common = {"max_tokens": max_tokens, "temperature": temperature, "n": wanted}
            if stop:
                common["stop"] = list(stop)[:_MAX_STOP_SEQUENCES]
            if self.options.completion_api == "text":
                response = self._request("text_completion", prompt=prompt, **common)
                texts += [choice.text or "" for choice in response.choices]
            else:
                messages = [{"role": "user", "content": prompt}]
                if self.options.system_prompt:
                    messages.insert(0, {"role": "system", "content": self.options.system_prompt})
                response = self._request("completion", messages=messages, **common)
                texts += [choice.message.content or "" for choice in response.choices]
            if not response.choices:
                raise T2MError(f"{self.options.model} returned no completion")
        texts = [_cut_at_stop(text, stop) for text in texts[:samples]]
        return texts * n if samples == 1 else texts

    # ------------------------------------------------------------------------------------------
    # scoring
    # ------------------------------------------------------------------------------------------

    def score(self, prompt: str, candidates: Sequence[str]) -> list[float]:
        """Log-likelihood of each candidate (exact or multiple-choice, see the module docstring)."""
        if not candidates:
            return []
        if self.scoring == "prompt_logprobs":
            return [self._echo_logprob(prompt, candidate) for candidate in candidates]
        return self._multiple_choice(prompt, candidates)

    def _echo_logprob(self, prompt: str, candidate: str) -> float:
        text = prompt + candidate
        # One new token, not zero: llama.cpp servers read max_tokens=0 as "until the context is full".
        response = self._request("text_completion", prompt=text, max_tokens=1, echo=True, logprobs=1, temperature=0)
        logprobs = response.choices[0].logprobs
        if logprobs is None or not getattr(logprobs, "token_logprobs", None):
            raise T2MError(
                f"{self.options.model} returned no prompt log-probabilities",
                hint="use scoring: multiple_choice for this server",
            )
        return continuation_logprob(
            response.choices[0].text, logprobs.text_offset, logprobs.token_logprobs, len(prompt), end=len(text)
        )

    def _multiple_choice(self, prompt: str, candidates: Sequence[str]) -> list[float]:
        context = without_query_line(prompt)
        options = [candidate.strip() for candidate in candidates]
        labels = choice_labels(len(options))
        per_ordering = []
        for order in cyclic_orderings(len(options), self.options.orderings):
            question = multiple_choice_prompt(context, options, order)
            response = self._request(
                "completion",
                messages=[{"role": "user", "content": question}],
                max_tokens=1,
                temperature=0,
                logprobs=True,
                top_logprobs=self.options.top_logprobs,
            )
            per_ordering.append((order, label_logprobs(_first_token_top_logprobs(response, self.options.model), labels)))
        return average_choice_logprobs(per_ordering, len(options))


def _first_token_top_logprobs(response: Any, model: str) -> dict[str, float]:
    """``{token: logprob}`` of the top-k alternatives at the first generated position."""
    logprobs = getattr(response.choices[0], "logprobs", None)
    content = getattr(logprobs, "content", None) if logprobs is not None else None
    if not content:
        raise T2MError(
            f"{model} returned no log-probabilities, so candidates cannot be scored",
            hint="use a model whose API returns logprobs/top_logprobs (OpenAI chat models, llama.cpp or vLLM servers)",
        )
    first = content[0]
    alternatives = {entry.token: float(entry.logprob) for entry in (first.top_logprobs or [])}
    alternatives.setdefault(first.token, float(first.logprob))
    return alternatives


def _cut_at_stop(text: str, stop: Sequence[str]) -> str:
    """Truncate at the earliest stop sequence (providers honour at most four of them)."""
    cut = min((index for index in (text.find(sequence) for sequence in stop if sequence) if index >= 0), default=len(text))
    return text[:cut]
