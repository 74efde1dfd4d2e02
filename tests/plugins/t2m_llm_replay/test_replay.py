"""The replay model answers from a transcript exactly as the recorded run did."""

from __future__ import annotations

import pytest

from t2m_core.errors import T2MError
from t2m_core.language.transcript import RecordingLanguageModel, TranscriptWriter
from t2m_core.protocols import LanguageModelCapabilities
from t2m_core.testing import check_import_light, check_language_model
from t2m_llm_replay.hooks import ReplayOptions, t2m_register_language_models
from t2m_llm_replay.replay import ReplayLanguageModel


class CountingModel:
    """Test double: every completion is numbered, so the order of answers is visible."""

    capabilities = LanguageModelCapabilities(exact_scoring=True, grammar=True)

    def __init__(self):
        self.calls = 0

    def complete(self, prompt, *, max_tokens=256, stop=(), temperature=0.0, n=1, grammar=None):
        self.calls += 1
        if grammar:
            return ["['pick(red_box)']"] * n
        return [f"answer {self.calls}"] * n

    def score(self, prompt, candidates):
        return [-1.0 - index for index, _ in enumerate(candidates)]


def record(tmp_path):
    path = tmp_path / "transcript.jsonl"
    recorder = RecordingLanguageModel(CountingModel(), TranscriptWriter(path), "counting")
    recorder.complete("p1", max_tokens=10, stop=["\n"])
    recorder.complete("p1", max_tokens=10, stop=["\n"])
    recorder.score("ctx", [" a", " b"])
    return path


def test_replay_serves_recorded_answers_in_order(tmp_path):
    replay = ReplayLanguageModel(ReplayOptions(transcript=record(tmp_path)))
    assert replay.complete("p1", max_tokens=10, stop=["\n"]) == ["answer 1"]
    assert replay.complete("p1", max_tokens=10, stop=["\n"]) == ["answer 2"]
    assert replay.complete("p1", max_tokens=10, stop=["\n"]) == ["answer 2"]  # the last one repeats
    assert replay.score("ctx", [" a", " b"]) == [-1.0, -2.0]
    assert replay.capabilities.exact_scoring
    assert not replay.capabilities.grammar  # nothing was recorded with a grammar


def test_a_request_never_recorded_is_an_error_naming_the_difference(tmp_path):
    replay = ReplayLanguageModel(ReplayOptions(transcript=record(tmp_path)))
    with pytest.raises(T2MError, match="no recorded 'complete' answer") as raised:
        replay.complete("p2", max_tokens=10, stop=["\n"])
    assert "differs at character 1" in str(raised.value)
    with pytest.raises(T2MError, match="same prompt but different max_tokens"):
        replay.complete("p1", max_tokens=11, stop=["\n"])  # any parameter counts
    with pytest.raises(T2MError):
        replay.score("ctx", [" b", " a"])


class EchoModel(CountingModel):
    """Deterministic test double: the answer depends on the prompt only."""

    def complete(self, prompt, *, max_tokens=256, stop=(), temperature=0.0, n=1, grammar=None):
        return ["['pick(red_box)']" if grammar else f"echo {len(prompt)}"] * n


def test_replay_conforms_when_the_transcript_covers_the_check(tmp_path):
    path = tmp_path / "conformance.jsonl"
    check_language_model(RecordingLanguageModel(EchoModel(), TranscriptWriter(path), "echo"))
    check_language_model(ReplayLanguageModel(ReplayOptions(transcript=path)))


def test_hooks_register_the_replay_spec_and_stay_light():
    (spec,) = t2m_register_language_models()
    assert spec.name == "replay" and spec.options is ReplayOptions
    check_import_light("t2m_llm_replay.hooks")
