"""Key-value states of prompt prefixes, kept in memory and on disk, so that the in-context part of
a prompt (header and examples, ~1,600 tokens) is evaluated once per model and prefix, not once per
query or per process (docs/guide/language-models.md#prompts-paid-for-once).

A state is llama.cpp's copy of one sequence's cache (``llama_state_seq_get_data``) holding exactly
the prefix's tokens. On disk it lives in ``<cache_dir>/prompt-states/<model sha256[:16]>/``, one
file per prefix, named by a hash of the format, the engine, the model's sha256 and the token ids::

    b"T2MKV\\n" | header length (8 bytes, little-endian) | header (JSON) | state bytes

The header repeats everything the name hashes (tokens included) and the state's size and sha256.
A file whose header does not match what was asked for (stale: another engine or format) or whose
bytes do not match their hash (corrupt, truncated) is deleted and reported missing, so the caller
evaluates the prefix again and writes a good file. Files are written atomically (temporary file,
then rename); the least recently used ones beyond :data:`MAX_DISK_ENTRIES` are removed.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import struct
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from t2m_core.atomic_files import write_bytes_atomic

log = logging.getLogger(__name__)

FORMAT = 1
"""Version of the file layout and header."""
MAGIC = b"T2MKV\n"
MAX_DISK_ENTRIES = 24
"""Prefix files kept per model (about 19 MB each for the 0.5B model's 1,500-token prefix, 43 MB
for the 1.5B model's)."""
MEMORY_ENTRIES = 4
"""Prefix states kept in memory per model (a goal prefix and a planning prefix per instruction)."""
MIN_PREFIX_TOKENS = 128
"""Shorter prefixes are cheaper to evaluate than to keep."""


@dataclass(frozen=True)
class PrefixState:
    """The cache of one sequence holding exactly ``tokens``.

    Attributes:
        tokens: the prefix's token ids.
        data: llama.cpp's sequence state (``llama_state_seq_get_data``).
    """

    tokens: tuple[int, ...]
    data: bytes


class PrefixCache:
    """Prefix states of one model, in memory (a few) and, with ``directory``, on disk.

    Args:
        model_sha256: the model file's sha256 (states are only valid for these weights).
        engine: the inference engine and version (``"llama-cpp-python 0.3.36"``); its state layout
            may change between versions.
        directory: the disk cache's root (``<cache_dir>/prompt-states``); ``None`` keeps states
            in memory only.
        max_disk_entries: files kept for this model.
    """

    def __init__(self, model_sha256: str, engine: str, directory: Path | None, max_disk_entries: int = MAX_DISK_ENTRIES) -> None:
        self.model_sha256 = model_sha256
        self.engine = engine
        self.directory = None if directory is None else Path(directory) / model_sha256[:16]
        self.max_disk_entries = max_disk_entries
        self._memory: OrderedDict[tuple[int, ...], PrefixState] = OrderedDict()
        self.disk_hits = 0
        self.rejected_files = 0

    def key(self, tokens: Sequence[int]) -> str:
        """Hex name of the prefix ``tokens`` for this model and engine."""
        digest = hashlib.sha256(f"{FORMAT}|{self.engine}|{self.model_sha256}|".encode())
        digest.update(struct.pack(f"<{len(tokens)}i", *tokens))
        return digest.hexdigest()

    def path(self, tokens: Sequence[int]) -> Path | None:
        """The file that holds (or would hold) the state of ``tokens``."""
        return None if self.directory is None else self.directory / f"{self.key(tokens)[:40]}.kv"

    def get(self, tokens: Sequence[int]) -> PrefixState | None:
        """The state of exactly ``tokens``, from memory or disk, or ``None``."""
        tokens = tuple(tokens)
        if tokens in self._memory:
            self._memory.move_to_end(tokens)
            return self._memory[tokens]
        state = self._read(tokens)
        if state is not None:
            self.disk_hits += 1
            self._remember(state)
        return state

    def put(self, state: PrefixState) -> None:
        """Keep ``state`` in memory and write it to disk (a failed write is logged, not raised: the
        cache only saves time)."""
        self._remember(state)
        path = self.path(state.tokens)
        if path is None:
            return
        header = json.dumps(self._header(state.tokens) | {"data_size": len(state.data), "data_sha256": hashlib.sha256(state.data).hexdigest()})
        encoded = header.encode()
        try:
            write_bytes_atomic(path, MAGIC + struct.pack("<Q", len(encoded)) + encoded + state.data)
            self._evict()
        except OSError as error:
            log.warning("could not write the prompt state %s: %s", path, error)

    def forget(self, tokens: Sequence[int]) -> None:
        """Drop a state that llama.cpp refused to load, from memory and disk."""
        tokens = tuple(tokens)
        self._memory.pop(tokens, None)
        path = self.path(tokens)
        if path is not None:
            path.unlink(missing_ok=True)
        self.rejected_files += 1

    # ------------------------------------------------------------------------------------------

    def _header(self, tokens: Sequence[int]) -> dict[str, object]:
        return {"format": FORMAT, "engine": self.engine, "model_sha256": self.model_sha256, "tokens": list(tokens)}

    def _remember(self, state: PrefixState) -> None:
        self._memory[state.tokens] = state
        self._memory.move_to_end(state.tokens)
        while len(self._memory) > MEMORY_ENTRIES:
            self._memory.popitem(last=False)

    def _read(self, tokens: tuple[int, ...]) -> PrefixState | None:
        path = self.path(tokens)
        if path is None or not path.is_file():
            return None
        try:
            raw = path.read_bytes()
            problem = _problem(raw, self._header(tokens))
        except OSError as error:
            problem = f"unreadable ({error})"
        if problem is not None:
            log.warning("prompt state %s is %s; evaluating the prefix again", path, problem)
            path.unlink(missing_ok=True)
            self.rejected_files += 1
            return None
        try:
            os.utime(path)  # least recently used files are evicted first
        except OSError:
            pass
        (length,) = struct.unpack_from("<Q", raw, len(MAGIC))
        return PrefixState(tokens, raw[len(MAGIC) + 8 + length :])

    def _evict(self) -> None:
        if self.directory is None:
            return
        files = sorted(self.directory.glob("*.kv"), key=lambda path: path.stat().st_mtime_ns)
        for path in files[: max(0, len(files) - self.max_disk_entries)]:
            path.unlink(missing_ok=True)


def _problem(raw: bytes, expected: dict[str, object]) -> str | None:
    """Why ``raw`` is not a good file for ``expected`` (stale or corrupt), or ``None``."""
    start = len(MAGIC) + 8
    if len(raw) < start or not raw.startswith(MAGIC):
        return "not a prompt-state file (corrupt)"
    (length,) = struct.unpack_from("<Q", raw, len(MAGIC))
    try:
        header = json.loads(raw[start : start + length])
    except ValueError:
        return "corrupt (unreadable header)"
    if not isinstance(header, dict):
        return "corrupt (unreadable header)"
    for field, value in expected.items():
        if header.get(field) != value:
            return f"stale ({field} differs)"
    data = raw[start + length :]
    if len(data) != header.get("data_size") or hashlib.sha256(data).hexdigest() != header.get("data_sha256"):
        return "corrupt (its bytes do not match their sha256)"
    return None
