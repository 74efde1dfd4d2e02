"""One evaluation of a prompt prefix per model, shared by the generation and scoring contexts.

A loaded model has two llama.cpp contexts over the same weights: llama-cpp-python's own (greedy and
grammar-constrained generation) and the scorer's (:mod:`t2m_llm_local.trie_scoring`). Each keeps
the tokens it last evaluated as sequence 0 and reuses a matching prefix of the next prompt. Before
a context evaluates a prompt, :meth:`PrefixSharing.prepare` gives it the longest prefix of that
prompt that is already paid for:

1. the prompt's in-context part (up to its last blank line: header and examples,
   :func:`in_context_bytes`) from the :class:`~t2m_llm_local.prefix_cache.PrefixCache` (memory,
   then disk), when neither context holds it; a prefix seen for the first time is evaluated alone
   from position 0 and stored, so a stored state is the same whichever query or process made it;
2. otherwise the other context's sequence, when it shares more of the prompt (a next-skill query
   and the scoring that follows share everything but their last line): its state is copied (a
   memory copy of ~12 kB per token) instead of evaluated (~7 ms per token on one core).

The context then evaluates only the tokens after what it holds.
"""

from __future__ import annotations

import ctypes
from collections.abc import Sequence
from typing import Any, Protocol

from t2m_llm_local.prefix_cache import MIN_PREFIX_TOKENS, PrefixCache, PrefixState

MIN_COPIED_TOKENS = 16
"""A shorter gain is evaluated rather than copied (a copy costs a few milliseconds)."""
BLOCK_SEPARATOR = "\n\n"
"""Prompts put a blank line between their header, each example and the current block; the current
block (scene, instruction, history, query line) holds none."""


def in_context_bytes(prompt: str) -> int:
    """UTF-8 length of the prompt's in-context part: everything up to and including its last blank
    line (0 when it has none)."""
    cut = prompt.rfind(BLOCK_SEPARATOR)
    return 0 if cut < 0 else len(prompt[: cut + len(BLOCK_SEPARATOR)].encode("utf-8"))


def common_prefix(first: Sequence[int], second: Sequence[int]) -> int:
    """Number of leading tokens ``first`` and ``second`` share."""
    count = 0
    for a, b in zip(first, second):
        if a != b:
            break
        count += 1
    return count


class SequenceHolder(Protocol):
    """A context's sequence 0, as :class:`PrefixSharing` moves prefixes between contexts."""

    def held_tokens(self) -> Sequence[int]:
        """The tokens sequence 0 holds, in order."""

    def export_state(self) -> bytes:
        """llama.cpp's state of sequence 0."""

    def adopt_state(self, tokens: Sequence[int], data: bytes) -> bool:
        """Replace sequence 0 with ``data`` (a state holding ``tokens``); False if llama.cpp refused it."""

    def truncate(self, count: int) -> None:
        """Keep only the first ``count`` tokens of sequence 0."""

    def evaluate_alone(self, tokens: Sequence[int]) -> None:
        """Make sequence 0 hold exactly ``tokens``, evaluated from position 0 in ``n_batch`` chunks."""


def export_sequence(context: Any, sequence: int = 0) -> bytes:
    """llama.cpp's state of ``sequence`` in the raw context ``context`` (``llama_context_p``)."""
    import llama_cpp

    size = llama_cpp.llama_state_seq_get_size(context, sequence)
    buffer = (ctypes.c_uint8 * size)()
    written = llama_cpp.llama_state_seq_get_data(context, buffer, size, sequence)
    return bytes(buffer)[:written]


def import_sequence(context: Any, data: bytes, sequence: int = 0) -> bool:
    """Load a state made by :func:`export_sequence` into ``sequence``; False if llama.cpp refused it."""
    import llama_cpp

    buffer = (ctypes.c_uint8 * len(data)).from_buffer_copy(data)
    return llama_cpp.llama_state_seq_set_data(context, buffer, len(data), sequence) > 0


class GenerationSequence:
    """Sequence 0 of llama-cpp-python's own context, whose ``generate`` reuses a matching prefix of
    ``input_ids[:n_tokens]`` (the only sequence that context has)."""

    def __init__(self, llama: Any) -> None:
        self._llama = llama

    def held_tokens(self) -> Sequence[int]:
        return self._llama.input_ids[: self._llama.n_tokens].tolist()

    def export_state(self) -> bytes:
        return export_sequence(self._llama._ctx.ctx)

    def adopt_state(self, tokens: Sequence[int], data: bytes) -> bool:
        llama = self._llama
        llama._ctx.kv_cache_seq_rm(-1, 0, -1)
        llama.n_tokens = 0
        if not import_sequence(llama._ctx.ctx, data):
            return False
        llama.input_ids[: len(tokens)] = tokens
        llama.n_tokens = len(tokens)
        llama._requires_eval = True  # no logits were computed for the last token here
        return True

    def truncate(self, count: int) -> None:
        llama = self._llama
        llama._ctx.kv_cache_seq_rm(-1, count, -1)
        llama.n_tokens = min(llama.n_tokens, count)
        llama._requires_eval = True

    def evaluate_alone(self, tokens: Sequence[int]) -> None:
        self._llama.reset()
        self._llama.eval(list(tokens))


class PrefixSharing:
    """Moves paid-for prefixes between a model's contexts and its :class:`PrefixCache`.

    Args:
        holders: the model's context sequences (generation, scoring).
        cache: stored in-context prefixes.
    """

    def __init__(self, holders: Sequence[SequenceHolder], cache: PrefixCache) -> None:
        self.holders = list(holders)
        self.cache = cache
        self.evaluated_prefixes = 0  # in-context prefixes evaluated here (not loaded, not copied)

    def add(self, holder: SequenceHolder) -> None:
        """Share prefixes with another context (the scorer, made on first use)."""
        self.holders.append(holder)

    def prepare(self, target: SequenceHolder, tokens: Sequence[int], in_context: int) -> None:
        """Give ``target`` the longest paid-for prefix of ``tokens`` whose first ``in_context``
        tokens are the prompt's in-context part; ``target`` then evaluates only the rest."""
        held = common_prefix(target.held_tokens(), tokens)
        donor, shared = None, held
        for holder in self.holders:
            if holder is not target and (count := common_prefix(holder.held_tokens(), tokens)) > shared:
                donor, shared = holder, count
        if in_context >= MIN_PREFIX_TOKENS and in_context > shared:
            self._load_in_context(target, tuple(tokens[:in_context]))
        elif donor is not None and shared >= held + MIN_COPIED_TOKENS:
            if target.adopt_state(donor.held_tokens(), donor.export_state()):
                target.truncate(shared)
            else:  # same weights and settings: refusal means a broken context; evaluate instead
                target.truncate(0)

    def _load_in_context(self, target: SequenceHolder, prefix: tuple[int, ...]) -> None:
        state = self.cache.get(prefix)
        if state is not None:
            if target.adopt_state(state.tokens, state.data):
                return
            self.cache.forget(prefix)
        target.evaluate_alone(prefix)
        self.evaluated_prefixes += 1
        self.cache.put(PrefixState(prefix, target.export_state()))
