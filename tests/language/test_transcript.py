"""Transcripts: JSON lines, redaction, tolerant reading, recording wrapper."""

from __future__ import annotations

import json

import pytest

from t2m_core.errors import T2MError
from t2m_core.language.transcript import (
    REDACTED,
    RecordingLanguageModel,
    TranscriptWriter,
    read_transcript,
    redact,
    request_key,
)
from t2m_core.protocols import LanguageModelCapabilities


class ScriptedModel:
    """Test double: fixed completions and scores."""

    capabilities = LanguageModelCapabilities(exact_scoring=True)

    def complete(self, prompt, *, max_tokens=256, stop=(), temperature=0.0, n=1, grammar=None):
        return [f"answer to {prompt[-5:]}"] * n

    def score(self, prompt, candidates):
        return [-float(len(candidate)) for candidate in candidates]


def test_redact_key_shapes_and_secret_environment_values(monkeypatch):
    monkeypatch.setenv("MY_SERVICE_API_KEY", "plain-secret-value-123")
    text = "key sk-abcdefghijklmnopqrstuvwx and plain-secret-value-123 and Bearer abcdefghijklmnopqrstu"
    cleaned = redact(text)
    assert "sk-abcdefghijklmnopqrstuvwx" not in cleaned
    assert "plain-secret-value-123" not in cleaned
    assert "abcdefghijklmnopqrstu" not in cleaned
    assert cleaned.count(REDACTED) == 3
    assert redact("on(red_box, rack)") == "on(red_box, rack)"


def test_recording_model_writes_one_line_per_call_without_keys(tmp_path, monkeypatch):
    monkeypatch.setenv("OPENAI_API_KEY", "sk-live-0123456789abcdefghij")
    path = tmp_path / "run" / "transcript.jsonl"
    model = RecordingLanguageModel(ScriptedModel(), TranscriptWriter(path), "scripted")
    assert model.complete("prompt sk-live-0123456789abcdefghij", max_tokens=5, stop=["\n"]) == ["answer to fghij"]
    assert model.score("ctx", [" a", " bb"]) == [-2.0, -3.0]
    raw = path.read_text()
    assert "sk-live-0123456789abcdefghij" not in raw
    records = read_transcript(path)
    assert [record["kind"] for record in records] == ["complete", "score"]
    assert records[0]["request"] == {
        "prompt": f"prompt {REDACTED}", "max_tokens": 5, "stop": ["\n"], "temperature": 0.0, "n": 1, "grammar": None
    }
    assert records[1]["response"] == [-2.0, -3.0]
    assert records[1]["scorer"] == "exact"
    assert records[0]["model"] == "scripted"


def test_read_transcript_skips_a_truncated_last_line(tmp_path):
    path = tmp_path / "t.jsonl"
    good = json.dumps({"kind": "score", "request": {"prompt": "p", "candidates": []}, "response": []})
    path.write_text(good + "\n" + '{"kind": "comp')
    assert len(read_transcript(path)) == 1


def test_read_transcript_rejects_corruption_in_the_middle(tmp_path):
    path = tmp_path / "t.jsonl"
    good = json.dumps({"kind": "score", "request": {"prompt": "p", "candidates": []}, "response": []})
    path.write_text("not json\n" + good + "\n")
    with pytest.raises(T2MError, match="line 1"):
        read_transcript(path)
    with pytest.raises(T2MError, match="does not exist"):
        read_transcript(tmp_path / "missing.jsonl")


def test_request_key_depends_on_every_field():
    base = {"prompt": "p", "candidates": ["a"]}
    assert request_key("score", base) == request_key("score", dict(base))
    assert request_key("score", base) != request_key("score", {"prompt": "p", "candidates": ["b"]})
    assert request_key("score", base) != request_key("complete", base)
