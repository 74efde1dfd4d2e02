"""Prompt-prefix states in memory and on disk: round trip, stale and corrupt files rebuilt, eviction;
the sharing rules between contexts with fake holders (no model)."""

from __future__ import annotations

import pytest

from t2m_llm_local import prefix_cache
from t2m_llm_local.prefix_cache import PrefixCache, PrefixState
from t2m_llm_local.shared_prefix import PrefixSharing, common_prefix, in_context_bytes

SHA = "ab" * 32
TOKENS = tuple(range(200))


def _cache(directory, engine="llama-cpp-python 0.3.36", sha=SHA, **kwargs) -> PrefixCache:
    return PrefixCache(sha, engine, directory, **kwargs)


def test_a_state_written_by_one_process_is_read_by_the_next(tmp_path):
    first = _cache(tmp_path)
    first.put(PrefixState(TOKENS, b"kv" * 1000))
    (path,) = (tmp_path / SHA[:16]).glob("*.kv")
    assert path == first.path(TOKENS) and not list(path.parent.glob("*.tmp"))
    fresh = _cache(tmp_path)  # empty memory: a new process
    state = fresh.get(TOKENS)
    assert state == PrefixState(TOKENS, b"kv" * 1000) and fresh.disk_hits == 1
    assert fresh.get(TOKENS[:-1]) is None  # another prefix is another entry
    assert _cache(None).get(TOKENS) is None  # memory-only caches never touch the disk


@pytest.mark.parametrize(
    "damage",
    [
        lambda raw: raw[:-10],  # truncated
        lambda raw: raw[:-1] + bytes([raw[-1] ^ 1]),  # one flipped bit in the state
        lambda raw: b"junk" + raw,  # not a state file
    ],
)
def test_a_corrupt_file_is_deleted_and_reported_missing(tmp_path, damage):
    _cache(tmp_path).put(PrefixState(TOKENS, b"kv" * 1000))
    path = _cache(tmp_path).path(TOKENS)
    path.write_bytes(damage(path.read_bytes()))
    reader = _cache(tmp_path)
    assert reader.get(TOKENS) is None and not path.exists() and reader.rejected_files == 1


def test_a_stale_file_from_another_engine_is_not_used(tmp_path):
    old = _cache(tmp_path, engine="llama-cpp-python 0.3.1")
    old.put(PrefixState(TOKENS, b"old"))
    new = _cache(tmp_path)
    # another engine names another file; a file renamed over the new name is caught by its header
    old.path(TOKENS).rename(new.path(TOKENS))
    assert new.get(TOKENS) is None and new.rejected_files == 1
    # other weights live in another directory
    assert _cache(tmp_path, sha="cd" * 32).path(TOKENS).parent != new.path(TOKENS).parent


def test_least_recently_used_files_are_evicted(tmp_path):
    cache = _cache(tmp_path, max_disk_entries=2)
    for count in (150, 160, 170):
        cache.put(PrefixState(TOKENS[:count], b"x"))
    assert len(list(cache.directory.glob("*.kv"))) == 2 and not cache.path(TOKENS[:150]).exists()


def test_in_context_part_ends_at_the_last_blank_line():
    assert in_context_bytes("header\n\nexample\n\ncurrent\nquery:") == len("header\n\nexample\n\n")
    assert in_context_bytes("no blank line\nquery:") == 0
    assert in_context_bytes("é\n\nx") == len("é\n\n".encode())
    assert common_prefix([1, 2, 3], [1, 2, 4, 5]) == 2


class FakeHolder:
    """A context's sequence 0 that records how it got its tokens."""

    def __init__(self, tokens=()):
        self.tokens = list(tokens)
        self.evaluated = []

    def held_tokens(self):
        return self.tokens

    def export_state(self):
        return bytes(len(self.tokens))

    def adopt_state(self, tokens, data):
        self.tokens = list(tokens)
        return True

    def truncate(self, count):
        self.tokens = self.tokens[:count]

    def evaluate_alone(self, tokens):
        self.tokens = list(tokens)
        self.evaluated.append(len(tokens))


def test_sharing_evaluates_a_prefix_once_then_loads_or_copies_it(tmp_path):
    prompt = list(range(300))
    generation, scoring = FakeHolder(), FakeHolder()
    sharing = PrefixSharing([generation, scoring], _cache(tmp_path))
    sharing.prepare(generation, prompt, 200)  # first sight: evaluated alone and stored
    assert generation.evaluated == [200] and sharing.evaluated_prefixes == 1
    generation.tokens = prompt + [7, 8]  # generation went on past the prompt
    sharing.prepare(scoring, prompt + [9], 200)  # the other context shares 300 tokens: copied
    assert scoring.tokens == prompt and scoring.evaluated == []
    # a new process: the stored prefix is loaded, not evaluated
    later = FakeHolder()
    PrefixSharing([later], _cache(tmp_path)).prepare(later, prompt, 200)
    assert later.tokens == prompt[:200] and later.evaluated == []
    # short prefixes are neither stored nor loaded
    short = FakeHolder()
    PrefixSharing([short], _cache(tmp_path)).prepare(short, prompt, prefix_cache.MIN_PREFIX_TOKENS - 1)
    assert short.tokens == [] and short.evaluated == []
