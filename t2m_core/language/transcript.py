"""Transcripts: every language-model request and response as JSON lines.

One record per call::

    {"kind": "complete", "model": "local:qwen2.5-coder-0.5b-instruct-q4_k_m",
     "request": {"prompt": "...", "max_tokens": 200, "stop": ["\\n"], "temperature": 0.0, "n": 1,
                 "grammar": null},
     "response": ["[['on(red_box, rack)']]"], "elapsed_s": 1.92, "scorer": null}

    {"kind": "score", "model": "...", "request": {"prompt": "...", "candidates": ["pick(a)", ...]},
     "response": [-3.1, -7.4], "elapsed_s": 0.41, "scorer": "exact"}

A record is written with one ``write`` of a whole line to a file opened in append mode and flushed
at once, so a crash leaves at most a truncated last line, which :func:`read_transcript` skips with a
warning; a complete earlier record is never rewritten. Anything that looks like an API key (the
value of any ``*_API_KEY``/``*_TOKEN``-style environment variable, or a well-known key shape) is
redacted before it reaches the file.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import re
import threading
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from t2m_core.errors import T2MError
from t2m_core.protocols import LanguageModel, LanguageModelCapabilities

log = logging.getLogger(__name__)

REDACTED = "[REDACTED]"

# Shapes of provider keys (OpenAI/Anthropic "sk-...", Google "AIza...", HF "hf_...", bearer tokens).
_KEY_PATTERNS = (
    re.compile(r"\bsk-[A-Za-z0-9_\-]{16,}"),
    re.compile(r"\bAIza[0-9A-Za-z_\-]{30,}"),
    re.compile(r"\bhf_[A-Za-z0-9]{20,}"),
    re.compile(r"\b(?:gh[pousr]|xox[baprs])_?-?[A-Za-z0-9\-]{20,}"),
    re.compile(r"(?i)\bbearer\s+[A-Za-z0-9._\-]{16,}"),
)
_SECRET_ENV_NAME = re.compile(r"(?i)(API_?KEY|_KEY|TOKEN|SECRET|PASSWORD)$")


def _secret_env_values() -> list[str]:
    """Values of environment variables whose names say they hold a secret (longest first)."""
    values = {
        value for name, value in os.environ.items() if _SECRET_ENV_NAME.search(name) and len(value) >= 8
    }
    return sorted(values, key=len, reverse=True)


def redact(text: str, secrets: Sequence[str] | None = None) -> str:
    """``text`` with every API-key-looking substring replaced by ``[REDACTED]``.

    Args:
        text: any string about to be logged or written.
        secrets: literal values to remove as well (default: secret-looking environment variables).
    """
    for secret in _secret_env_values() if secrets is None else secrets:
        if secret:
            text = text.replace(secret, REDACTED)
    for pattern in _KEY_PATTERNS:
        text = pattern.sub(REDACTED, text)
    return text


def redact_value(value: Any, secrets: Sequence[str] | None = None) -> Any:
    """:func:`redact` applied to every string inside a JSON-like value."""
    if secrets is None:
        secrets = _secret_env_values()
    if isinstance(value, str):
        return redact(value, secrets)
    if isinstance(value, dict):
        return {key: redact_value(item, secrets) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [redact_value(item, secrets) for item in value]
    return value


def request_key(kind: str, request: dict[str, Any]) -> str:
    """A stable identity of a request (sha256 of its canonical JSON), used to replay it."""
    canonical = json.dumps({"kind": kind, "request": request}, sort_keys=True, ensure_ascii=False)
    return hashlib.sha256(canonical.encode("utf-8")).hexdigest()


class TranscriptWriter:
    """Appends transcript records to a JSON-lines file (created with its parent directory)."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._lock = threading.Lock()

    def write(self, record: dict[str, Any]) -> None:
        """Append one record as a single line (redacted, then flushed and fsynced)."""
        line = json.dumps(redact_value(record), ensure_ascii=False, sort_keys=True) + "\n"
        data = line.encode("utf-8")
        with self._lock:
            fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
            try:
                os.write(fd, data)
                os.fsync(fd)
            finally:
                os.close(fd)


def read_transcript(path: str | Path) -> list[dict[str, Any]]:
    """All complete records of a transcript file, in order.

    A truncated last line (a run killed mid-write) is skipped with a warning; a corrupt line anywhere
    else is an error naming the line.
    """
    path = Path(path)
    if not path.is_file():
        raise T2MError(f"transcript {path} does not exist", hint="pass the transcript.jsonl of an earlier run")
    lines = path.read_text(encoding="utf-8").splitlines(keepends=True)
    records: list[dict[str, Any]] = []
    for number, line in enumerate(lines, start=1):
        if not line.strip():
            continue
        try:
            record = json.loads(line)
        except json.JSONDecodeError as error:
            if number == len(lines) and not line.endswith("\n"):
                log.warning("transcript %s: skipping truncated last line %d", path, number)
                break
            raise T2MError(f"transcript {path}, line {number} is not valid JSON: {error}") from error
        if not isinstance(record, dict) or record.get("kind") not in {"complete", "score"}:
            raise T2MError(f"transcript {path}, line {number} is not a transcript record (kind complete|score)")
        records.append(record)
    return records


class RecordingLanguageModel:
    """Wraps a :class:`~t2m_core.protocols.LanguageModel` and records every call to a transcript.

    Args:
        model: the backend doing the work.
        writer: where records go.
        model_name: how the backend is named in the records (``"local:<file>"``, ``"litellm:gpt-4o"``).
    """

    def __init__(self, model: LanguageModel, writer: TranscriptWriter, model_name: str) -> None:
        self.model = model
        self.writer = writer
        self.model_name = model_name
        self.capabilities: LanguageModelCapabilities = model.capabilities

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
        """Delegate to the wrapped model and record the request and its completions."""
        start = time.perf_counter()
        texts = self.model.complete(
            prompt, max_tokens=max_tokens, stop=stop, temperature=temperature, n=n, grammar=grammar
        )
        self.writer.write(
            {
                "kind": "complete",
                "model": self.model_name,
                "request": completion_request(prompt, max_tokens, stop, temperature, n, grammar),
                "response": list(texts),
                "elapsed_s": round(time.perf_counter() - start, 4),
                "scorer": None,
            }
        )
        return texts

    def score(self, prompt: str, candidates: Sequence[str]) -> list[float]:
        """Delegate to the wrapped model and record the candidates and their log-likelihoods."""
        start = time.perf_counter()
        scores = self.model.score(prompt, candidates)
        self.writer.write(
            {
                "kind": "score",
                "model": self.model_name,
                "request": score_request(prompt, candidates),
                "response": [float(value) for value in scores],
                "elapsed_s": round(time.perf_counter() - start, 4),
                "scorer": "exact" if self.capabilities.exact_scoring else "approximate",
            }
        )
        return scores


def completion_request(
    prompt: str, max_tokens: int, stop: Sequence[str], temperature: float, n: int, grammar: str | None
) -> dict[str, Any]:
    """The request part of a ``complete`` record (also the replay key)."""
    return {
        "prompt": prompt,
        "max_tokens": int(max_tokens),
        "stop": list(stop),
        "temperature": float(temperature),
        "n": int(n),
        "grammar": grammar,
    }


def score_request(prompt: str, candidates: Sequence[str]) -> dict[str, Any]:
    """The request part of a ``score`` record (also the replay key)."""
    return {"prompt": prompt, "candidates": list(candidates)}
