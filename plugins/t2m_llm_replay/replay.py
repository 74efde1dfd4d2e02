"""A language model that answers every request from a transcript (:mod:`t2m_core.language.transcript`).

Requests are matched exactly (prompt, every generation parameter, the candidate list). When the same
request was recorded several times, the recorded answers are returned in order and the last one is
repeated after that, so a deterministic run replays identically. A request that was never recorded
is an error that names the nearest recorded prompt, because a silent fallback would make a replayed
run differ from the original without telling anyone.
"""

from __future__ import annotations

import difflib
from collections import defaultdict
from collections.abc import Sequence
from typing import Any

from t2m_core.errors import T2MError
from t2m_core.language.transcript import completion_request, read_transcript, request_key, score_request
from t2m_core.protocols import LanguageModelCapabilities

from t2m_llm_replay.hooks import ReplayOptions


class ReplayLanguageModel:
    """Serves recorded responses; see the module docstring for the matching rules."""

    def __init__(self, options: ReplayOptions) -> None:
        self.path = options.transcript
        records = read_transcript(self.path)
        self._answers: dict[str, list[Any]] = defaultdict(list)
        self._served: dict[str, int] = defaultdict(int)
        self._requests: list[dict[str, Any]] = []
        scorers = set()
        grammar = False
        for record in records:
            self._answers[request_key(record["kind"], record["request"])].append(record["response"])
            self._requests.append(record["request"])
            if record["kind"] == "score":
                scorers.add(record.get("scorer"))
            grammar = grammar or bool(record["request"].get("grammar"))
        # Replay what the recorded model could do, so callers send the same requests again.
        self.capabilities = LanguageModelCapabilities(exact_scoring=scorers <= {"exact"}, grammar=grammar)

    def _answer(self, kind: str, request: dict[str, Any]) -> Any:
        key = request_key(kind, request)
        answers = self._answers.get(key)
        if not answers:
            raise T2MError(
                f"replay: no recorded {kind!r} answer for this request in {self.path}{self._nearest(request)}",
                hint="replay the transcript with the same task, seed, planner and prompt settings that recorded it",
            )
        index = min(self._served[key], len(answers) - 1)
        self._served[key] += 1
        return answers[index]

    def _nearest(self, request: dict[str, Any]) -> str:
        """A short description of how ``request`` differs from the most similar recorded one."""
        if not self._requests:
            return " (the transcript is empty)"
        prompt = request["prompt"]
        recorded = max(
            self._requests,
            key=lambda old: difflib.SequenceMatcher(None, old.get("prompt", "")[-400:], prompt[-400:]).ratio(),
        )
        nearest = recorded.get("prompt", "")
        if nearest == prompt:
            differing = sorted(key for key in request if recorded.get(key) != request[key])
            return f"; a recorded request has the same prompt but different {', '.join(differing)}"
        for position, (old, new) in enumerate(zip(nearest, prompt, strict=False)):
            if old != new:
                break
        else:
            position = min(len(nearest), len(prompt))
        return (
            f"; the nearest recorded prompt differs at character {position}: "
            f"recorded {nearest[position:position + 60]!r}, requested {prompt[position:position + 60]!r}"
        )

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
        """The recorded completions of this exact request."""
        return list(self._answer("complete", completion_request(prompt, max_tokens, stop, temperature, n, grammar)))

    def score(self, prompt: str, candidates: Sequence[str]) -> list[float]:
        """The recorded log-likelihoods of these exact candidates."""
        return [float(value) for value in self._answer("score", score_request(prompt, candidates))]
