"""Exact log-probabilities of many candidate continuations in one batched llama.cpp decode.

The candidates' tokens form a trie rooted at the cached prompt. Every trie node is decoded once, as
one token that belongs to *every* candidate sequence passing through it (llama.cpp tokens may carry
several sequence ids); candidates share the prompt's keys and values through ``seq_cp`` on a unified
KV cache, so the prompt is evaluated once and never copied. All nodes of a group of candidates go
into as few ``llama_decode`` calls as the batch size allows: on a CPU a batch of 100 tokens costs far
less than 30 calls of 3-4 tokens, which re-read all weights each time (measured 2x faster than
decoding each candidate on its own, with the same exact scores up to float rounding).

The scorer owns a second llama.cpp context over the same loaded weights, so scoring never
disturbs the generation context's cache, and keeps the last prompt's tokens cached as sequence 0;
that sequence is shared with the generation context and the prompt-state cache through the
:class:`~t2m_llm_local.shared_prefix.SequenceHolder` methods (:mod:`t2m_llm_local.shared_prefix`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from t2m_llm_local.shared_prefix import export_sequence, import_sequence

MAX_SEQUENCES = 64
"""Sequences of the scoring context: sequence 0 holds the prompt, each other one a candidate."""


@dataclass
class _TrieNode:
    """One decoded token: its id, its position after the prompt, the candidate sequences through it
    and the tokens that follow it in some candidate (whose log-probabilities this node predicts)."""

    token: int
    depth: int
    sequences: list[int] = field(default_factory=list)
    children: dict[int, int] = field(default_factory=dict)  # next token -> node index


class TrieScorer:
    """Batched exact scoring of candidate token sequences on top of a cached prompt.

    Args:
        llama: a loaded ``llama_cpp.Llama``; its weights and context settings are reused.
        max_sequences: sequences of the scoring context (the prompt plus candidates per group).
        max_batch_tokens: tokens per decode call; ``None`` = the model's ``n_batch``.
    """

    def __init__(self, llama, max_sequences: int = MAX_SEQUENCES, max_batch_tokens: int | None = None) -> None:
        import llama_cpp
        from llama_cpp import _internals

        self._llama_cpp = llama_cpp
        settings = llama_cpp.llama_context_params.from_buffer_copy(llama.context_params)
        settings.n_seq_max = min(max_sequences, llama_cpp.llama_max_parallel_sequences())
        settings.kv_unified = True  # every sequence sees the whole cache: the prompt is shared, not split
        settings.no_perf = True
        self.n_ctx = int(settings.n_ctx)
        self.n_batch = int(settings.n_batch) if max_batch_tokens is None else min(int(settings.n_batch), max_batch_tokens)
        self.n_vocab = llama.n_vocab()
        self._group = int(settings.n_seq_max) - 1
        self._context = _internals.LlamaContext(model=llama._model, params=settings, verbose=False)
        self._batch = _internals.LlamaBatch(n_tokens=self.n_batch, embd=0, n_seq_max=int(settings.n_seq_max), verbose=False)
        self._cached: list[int] = []  # tokens held by sequence 0
        self._last_logits: np.ndarray | None = None  # (V,) float32 logits after all of ``_cached``

    def close(self) -> None:
        """Free the context and batch (before the model they belong to)."""
        self._batch.close()
        self._context.close()

    # ------------------------------------------------------------------------------------------
    # sequence 0 as a SequenceHolder (t2m_llm_local.shared_prefix)
    # ------------------------------------------------------------------------------------------

    def held_tokens(self) -> Sequence[int]:
        """The prompt tokens sequence 0 holds."""
        return self._cached

    def export_state(self) -> bytes:
        """llama.cpp's state of sequence 0."""
        return export_sequence(self._context.ctx)

    def adopt_state(self, tokens: Sequence[int], data: bytes) -> bool:
        """Replace sequence 0 with a state holding ``tokens``; False if llama.cpp refused it."""
        self._context.kv_cache_seq_rm(-1, 0, -1)  # between calls only sequence 0 is in use
        self._cached, self._last_logits = [], None
        if not import_sequence(self._context.ctx, data):
            return False
        self._cached = list(tokens)
        return True

    def truncate(self, count: int) -> None:
        """Keep the first ``count`` tokens of sequence 0."""
        if count < len(self._cached):
            self._context.kv_cache_seq_rm(0, count, -1)
            self._cached, self._last_logits = self._cached[:count], None

    def evaluate_alone(self, tokens: Sequence[int]) -> None:
        """Evaluate ``tokens`` into an empty sequence 0 from position 0."""
        self._context.kv_cache_seq_rm(-1, 0, -1)
        self._cached, self._last_logits = [], None
        self._hold_prompt(list(tokens))

    # ------------------------------------------------------------------------------------------

    def log_probs(self, prompt: Sequence[int], continuations: Sequence[Sequence[int]]) -> list[np.ndarray]:
        """Per continuation, ``(len(continuation),) float64`` log-probabilities: entry ``i`` is
        log p(continuation[i] | prompt + continuation[:i]). ``prompt`` must not be empty; a repeated
        prompt is neither decoded again nor are its last logits recomputed."""
        if not prompt:
            raise ValueError("scoring needs a non-empty prompt")
        # The trie's root is the prompt's last token (cached, never decoded here); its logits predict
        # every continuation's first token. Candidates go in token order, so a set of candidates is
        # decoded in the same batch layout (and rounded alike) whatever order it comes in.
        order = sorted(range(len(continuations)), key=lambda index: list(continuations[index]))
        rooted = [[prompt[-1], *continuations[index]] for index in order]
        groups = [rooted[start : start + self._group] for start in range(0, len(rooted), self._group)]
        tries = [self._trie(group) for group in groups]
        largest = max((len(nodes) for nodes in tries), default=0)
        if len(prompt) + largest > self.n_ctx:
            raise ValueError(
                f"a prompt of {len(prompt)} tokens and {largest} candidate tokens exceed the context of {self.n_ctx}"
            )
        self._hold_prompt(list(prompt))
        ordered: list[np.ndarray] = []
        for group, trie in zip(groups, tries, strict=True):
            ordered.extend(self._score_group(len(prompt) - 1, group, trie))
        results: list[np.ndarray] = [np.empty(0)] * len(order)
        for rank, index in enumerate(order):
            results[index] = ordered[rank]
        return results

    # ------------------------------------------------------------------------------------------

    def _hold_prompt(self, prompt: list[int]) -> None:
        """Make sequence 0 hold exactly ``prompt`` and keep its last logits, decoding only what the
        cache does not share (the last token again when its logits are not kept)."""
        if self._cached == prompt and self._last_logits is not None:
            return
        reuse = 0
        limit = min(len(self._cached), len(prompt) - 1)
        while reuse < limit and self._cached[reuse] == prompt[reuse]:
            reuse += 1
        self._context.kv_cache_seq_rm(0, reuse, -1)
        self._cached, self._last_logits = prompt[:reuse], None
        for start in range(reuse, len(prompt), self.n_batch):
            chunk = prompt[start : start + self.n_batch]
            last = start + len(chunk) == len(prompt)
            self._fill(((token, start + offset, (0,), last and offset == len(chunk) - 1) for offset, token in enumerate(chunk)))
            self._context.decode(self._batch)
            self._cached = prompt[: start + len(chunk)]
        self._last_logits = np.ctypeslib.as_array(self._context.get_logits(), shape=(1, self.n_vocab))[0].copy()

    def _score_group(self, base: int, suffixes: Sequence[Sequence[int]], nodes: list[_TrieNode]) -> list[np.ndarray]:
        """Score up to ``max_sequences - 1`` rooted candidates (the prompt's last token, then the
        continuation) as sequences 1..n; the root sits at position ``base``; ``nodes`` is
        :meth:`_trie` of ``suffixes``, node 0 the root."""
        # log p(child | node) for every node that has children: the root's from the kept logits,
        # the others' filled batch by batch
        child_log_probs: list[dict[int, float]] = [{} for _ in nodes]
        self._collect(self._last_logits[None, :], [0], nodes, child_log_probs)
        context = self._context
        for sequence in range(1, len(suffixes) + 1):
            context.kv_cache_seq_cp(0, sequence, 0, base + 1)
        try:
            decoded = [index for index, node in enumerate(nodes) if node.children and node.depth > 0]
            for start in range(0, len(decoded), self.n_batch):
                chunk = decoded[start : start + self.n_batch]
                self._fill((nodes[i].token, base + nodes[i].depth, nodes[i].sequences, True) for i in chunk)
                context.decode(self._batch)
                logits = np.ctypeslib.as_array(context.get_logits(), shape=(len(chunk), self.n_vocab))
                self._collect(logits, chunk, nodes, child_log_probs)
        finally:
            for sequence in range(1, len(suffixes) + 1):
                context.kv_cache_seq_rm(sequence, -1, -1)
        results = []
        for suffix in suffixes:
            values, node = np.empty(len(suffix) - 1), 0
            for i in range(len(suffix) - 1):
                if i:
                    node = nodes[node].children[suffix[i]]
                values[i] = child_log_probs[node][suffix[i + 1]]
            results.append(values)
        return results

    @staticmethod
    def _collect(logits: np.ndarray, rows: Sequence[int], nodes: list[_TrieNode], child_log_probs: list[dict[int, float]]) -> None:
        """Store log p(child | node) for the nodes ``rows`` from their ``(len(rows), V) float32`` logits."""
        top = logits.max(axis=1)
        # float32 exponentials summed in float64: 5x faster than exponentials in float64, and equal
        # to 1e-8 nats (every term is at most 1 after the shift)
        normaliser = top + np.log(np.exp(logits - top[:, None]).sum(axis=1, dtype=np.float64))
        for row, index in enumerate(rows):
            for token in nodes[index].children:
                child_log_probs[index][token] = float(logits[row, token]) - float(normaliser[row])

    @staticmethod
    def _trie(suffixes: Sequence[Sequence[int]]) -> list[_TrieNode]:
        """Trie nodes in breadth-first order (a node after its parent, so a batch split keeps the
        causal order); every suffix starts with the same root token, node 0. Candidate ``k`` is
        sequence ``k + 1``."""
        nodes = [_TrieNode(suffixes[0][0], 0)]
        for sequence, suffix in enumerate(suffixes, start=1):
            if suffix[0] != nodes[0].token:
                raise ValueError("every rooted candidate must start with the prompt's last token")
            node = 0
            nodes[0].sequences.append(sequence)
            for depth, token in enumerate(suffix[1:], start=1):
                children = nodes[node].children
                if token not in children:
                    children[token] = len(nodes)
                    nodes.append(_TrieNode(token, depth))
                node = children[token]
                nodes[node].sequences.append(sequence)
        order = sorted(range(len(nodes)), key=lambda index: nodes[index].depth)  # stable: the root stays 0
        renumber = {old: new for new, old in enumerate(order)}
        ordered = [nodes[old] for old in order]
        for node in ordered:
            node.children = {token: renumber[child] for token, child in node.children.items()}
        return ordered

    def _fill(self, tokens) -> None:
        """Write ``(token, position, sequence ids, wants logits)`` rows into the batch."""
        batch = self._batch.batch
        count = 0
        for token, position, sequences, logits in tokens:
            batch.token[count] = token
            batch.pos[count] = position
            batch.n_seq_id[count] = len(sequences)
            for slot, sequence in enumerate(sequences):
                batch.seq_id[count][slot] = sequence
            batch.logits[count] = logits
            count += 1
        batch.n_tokens = count
