"""The embedded language model: a GGUF model run in-process by llama.cpp (llama-cpp-python).

Scoring is exact (docs/guide/prompts.md#scores-from-a-language-model): the shared context is evaluated once, and each candidate's
tokens are decoded on top of that cached prefix with logits for every position; ℓ_k is the sum of
the log-softmax of the candidate's tokens. Tokens are found by byte offsets in the tokenization of
the *full* string (context + candidate), never by tokenizing the candidate alone, because the
tokenizer merges the leading space into the next token. (llama-cpp-python 0.3.36's echoed prompt
log-probabilities are wrong, so they are not used.)

A model file is loaded once per process and shared by every :class:`LocalLanguageModel` that names
the same file and context settings. Its generation and scoring contexts share evaluated prompt
prefixes with each other and with a disk cache (:mod:`t2m_llm_local.shared_prefix`), so the
in-context part of a prompt is evaluated once per model, not once per query, context or process.
"""

from __future__ import annotations

import atexit
import logging
import os
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from t2m_core.errors import ModelFileError, T2MError
from t2m_core.protocols import LanguageModelCapabilities
from t2m_core.settings import cache_dir

from t2m_llm_local.hooks import LocalModelOptions
from t2m_llm_local.model_files import embedded_model_path, model_digest
from t2m_llm_local.prefix_cache import PrefixCache
from t2m_llm_local.shared_prefix import GenerationSequence, PrefixSharing, in_context_bytes
from t2m_llm_local.trie_scoring import TrieScorer

log = logging.getLogger(__name__)

CONTEXT_HINT = "raise the local model's n_ctx option (t2m llm: --set n_ctx=16384; run config: language_model.options.n_ctx)"

WAIT_POLICY = "PASSIVE"
"""OpenMP wait policy set (unless the user set one) before llama.cpp loads. llama.cpp's threads meet
at a barrier after every operation; with the default spinning wait, a thread that loses its core to
another process stalls the others for a scheduler quantum at each barrier (measured on 2 busy
cores: 2 threads took 0.4-1.2 s per scored candidate, 1 thread 0.18 s). Passive waiting yields the
core instead: 2 threads then took 0.07 s on the same busy machine."""


@dataclass
class LoadedModel:
    """A process-wide llama.cpp model, the lock that serialises its use (its KV caches are shared
    state), its generation sequence, the prefix sharing between its contexts and its candidate
    scorer (a second context over the same weights, made on first use)."""

    llama: Any
    lock: threading.Lock
    generation: GenerationSequence
    sharing: PrefixSharing
    scorer: TrieScorer | None = None

    def get_scorer(self) -> TrieScorer:
        """The scorer, made on first use and sharing prefixes with the generation context."""
        if self.scorer is None:
            self.scorer = TrieScorer(self.llama)
            self.sharing.add(self.scorer)
        return self.scorer


_MODELS: dict[tuple[Any, ...], LoadedModel] = {}
_MODELS_LOCK = threading.Lock()


@atexit.register
def _close_models() -> None:
    """Free the models before interpreter shutdown: llama-cpp-python's ``__del__`` fails once its
    module globals are gone, printing an "Exception ignored" traceback at every exit."""
    with _MODELS_LOCK:
        for loaded in _MODELS.values():
            if loaded.scorer is not None:
                loaded.scorer.close()
            loaded.llama.close()
        _MODELS.clear()


def prompt_state_cache(path: Path, on_disk: bool) -> PrefixCache:
    """The prefix-state cache of the model file ``path``: on disk under
    ``<cache_dir>/prompt-states`` (keyed by the file's sha256) or in memory only."""
    import llama_cpp

    engine = f"llama-cpp-python {llama_cpp.__version__}"
    if not on_disk:
        return PrefixCache("memory-only", engine, None)
    return PrefixCache(model_digest(path), engine, cache_dir() / "prompt-states")


def _load_llama(path: Path, n_ctx: int, n_threads: int, n_threads_batch: int, n_batch: int, prompt_cache: bool) -> LoadedModel:
    """The process-wide llama.cpp model for these settings, loaded on first use."""
    key = (str(path), n_ctx, n_threads, n_threads_batch, n_batch, prompt_cache)
    with _MODELS_LOCK:
        if key not in _MODELS:
            os.environ.setdefault("OMP_WAIT_POLICY", WAIT_POLICY)
            from llama_cpp import Llama

            start = time.perf_counter()
            try:
                llama = Llama(
                    model_path=str(path),
                    n_ctx=n_ctx,
                    n_batch=n_batch,
                    n_ubatch=n_batch,
                    n_threads=n_threads,
                    n_threads_batch=n_threads_batch,
                    logits_all=False,
                    verbose=False,
                )
            except ValueError as error:  # llama-cpp-python reports unreadable files as ValueError
                raise ModelFileError(
                    f"llama.cpp could not load {path}: {error}", hint="pass a valid GGUF file as model_path"
                ) from error
            generation = GenerationSequence(llama)
            sharing = PrefixSharing([generation], prompt_state_cache(path, prompt_cache))
            _MODELS[key] = LoadedModel(llama, threading.Lock(), generation, sharing)
            log.info("loaded %s in %.2f s", path.name, time.perf_counter() - start)
        return _MODELS[key]


def default_threads() -> int:
    """Generation threads when none are configured: all cores but one, at most 8.

    Generation decodes one token per call, so its threads meet at a barrier after every small
    operation; beside other busy processes a second thread costs more than it brings (measured on
    2 busy cores: 1 thread 11 tokens/s, 2 threads 9 with passive waits, 1-3 with spinning waits).
    """
    return max(1, min(8, (os.cpu_count() or 2) - 1))


def default_batch_threads() -> int:
    """Threads for prompt and candidate batches when none are configured: all cores, at most 8.

    A batch of tokens is compute-bound, with few barriers per token: with :data:`WAIT_POLICY`
    every core helps even on a busy machine (measured on 2 busy cores, 5 scored candidates: 70 ms
    each with 2 threads, 180 ms with 1)."""
    return max(1, min(8, os.cpu_count() or 2))


class LocalLanguageModel:
    """In-process llama.cpp backend with exact candidate scoring and GBNF-constrained decoding.

    Args:
        options: validated :class:`~t2m_llm_local.hooks.LocalModelOptions`.
    """

    capabilities = LanguageModelCapabilities(exact_scoring=True, grammar=True)

    def __init__(self, options: LocalModelOptions) -> None:
        self.options = options
        if options.model_path is None:
            self.model_path = embedded_model_path(options.model)
        else:
            self.model_path = Path(options.model_path).expanduser()
            if not self.model_path.is_file():
                raise ModelFileError(
                    f"model file {self.model_path} does not exist",
                    hint="give the path of a GGUF file, or leave model_path unset for the embedded model",
                )
        threads = options.n_threads or default_threads()
        batch_threads = options.n_threads_batch or default_batch_threads()
        start = time.perf_counter()
        self._loaded = _load_llama(self.model_path, options.n_ctx, threads, batch_threads, options.n_batch, options.prompt_cache)
        self._llama, self._lock = self._loaded.llama, self._loaded.lock
        self.load_time_s = time.perf_counter() - start
        self._grammars: dict[str, Any] = {}
        self._piece_bytes: dict[int, int] = {}  # token id -> bytes of its piece
        self.name = f"local:{self.model_path.name}"

    # ------------------------------------------------------------------------------------------
    # generation
    # ------------------------------------------------------------------------------------------

    def _grammar(self, grammar: str | None) -> Any:
        if grammar is None:
            return None
        if grammar not in self._grammars:
            from llama_cpp import LlamaGrammar

            self._grammars[grammar] = LlamaGrammar.from_string(grammar, verbose=False)
        return self._grammars[grammar]

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
        """``n`` completions; at temperature 0 decoding is greedy, so one is computed and repeated."""
        self._check_length(prompt, max_tokens)
        samples = 1 if temperature == 0 else n
        texts = []
        # tokenized as create_completion does, so the prepared prefix is the one it reuses
        tokens = self._llama.tokenize(prompt.encode("utf-8"), add_bos=False, special=True)
        in_context, _ = self._split_at_boundary(tokens, in_context_bytes(prompt))
        with self._lock:
            for sample in range(samples):
                self._loaded.sharing.prepare(self._loaded.generation, tokens, in_context)
                result = self._llama.create_completion(
                    prompt,
                    max_tokens=max_tokens,
                    stop=list(stop) or None,
                    temperature=temperature,
                    top_p=1.0,
                    top_k=0 if temperature > 0 else 40,
                    min_p=0.0,
                    repeat_penalty=1.0,
                    seed=self.options.seed + sample,
                    grammar=self._grammar(grammar),
                )
                texts.append(result["choices"][0]["text"])
        return texts * n if samples == 1 else texts

    def count_tokens(self, text: str) -> int:
        """Number of tokens of ``text`` (for budgets and throughput figures)."""
        return len(self._llama.tokenize(text.encode("utf-8"), add_bos=False, special=False))

    def _check_length(self, prompt: str, max_tokens: int) -> None:
        tokens = self.count_tokens(prompt)
        if tokens + max_tokens > self.options.n_ctx:
            raise T2MError(
                f"prompt of {tokens} tokens + {max_tokens} new tokens exceeds the context of {self.options.n_ctx}",
                hint=CONTEXT_HINT,
            )

    # ------------------------------------------------------------------------------------------
    # exact scoring
    # ------------------------------------------------------------------------------------------

    def _token_byte_ends(self, tokens: Sequence[int]) -> list[int]:
        """Cumulative byte length of the detokenized text after each token (piece lengths are
        remembered per token id: a prompt of 2,000 tokens then costs dictionary lookups, not 2,000
        detokenize calls)."""
        ends, total, pieces = [], 0, self._piece_bytes
        for token in tokens:
            if token not in pieces:
                pieces[token] = len(self._llama.detokenize([token]))
            total += pieces[token]
            ends.append(total)
        return ends

    def score(self, prompt: str, candidates: Sequence[str]) -> list[float]:
        """ℓ_k = Σ log p(token | prompt, earlier tokens) over the tokens of each candidate.

        ``prompt`` ends where the candidate text begins (``...Executed action: ``), so the leading
        space belongs to the prompt's last characters or is merged into the candidate's first token,
        whichever the tokenizer does; only tokens that cover candidate bytes are summed.
        """
        if not candidates:
            return []
        llama = self._llama
        boundary = len(prompt.encode("utf-8"))
        full = [llama.tokenize((prompt + candidate).encode("utf-8"), add_bos=False, special=False) for candidate in candidates]
        # Shared prefix: tokens common to every full tokenization that end before the candidate.
        first = full[0]
        common = min(len(tokens) for tokens in full)
        for tokens in full[1:]:
            common = next((index for index in range(common) if tokens[index] != first[index]), common)
        shared, prompt_bytes = self._split_at_boundary(first[:common], boundary)
        if shared == 0:
            raise ValueError("scoring needs a non-empty context before the candidates")
        # The cached prompt ends before the first token that covers candidate bytes; its last logits
        # predict each candidate's first token.
        boundary_in_suffix = boundary - prompt_bytes
        suffixes = [list(tokens[shared:]) for tokens in full]
        in_context, _ = self._split_at_boundary(first[:shared], in_context_bytes(prompt))
        with self._lock:
            scorer = self._loaded.get_scorer()
            self._loaded.sharing.prepare(scorer, first[:shared], in_context)
            try:
                rows = scorer.log_probs(first[:shared], suffixes)
            except ValueError as error:  # the scorer's only ValueError here: prompt + candidates exceed n_ctx
                raise T2MError(str(error), hint=CONTEXT_HINT) from error
        return [self._sum_candidate(suffix, row, boundary_in_suffix) for suffix, row in zip(suffixes, rows, strict=True)]

    def _split_at_boundary(self, tokens: Sequence[int], boundary: int) -> tuple[int, int]:
        """``(n, bytes)``: the first ``n`` tokens end at or before byte ``boundary`` (the next one
        covers a byte after it) and span ``bytes`` bytes."""
        ends = self._token_byte_ends(tokens)
        count = next((index for index, end in enumerate(ends) if end > boundary), len(tokens))
        return count, ends[count - 1] if count else 0

    def _sum_candidate(self, suffix: Sequence[int], log_probs: np.ndarray, boundary: int) -> float:
        """Σ log p of the suffix tokens that cover bytes at or after ``boundary`` (counted from the
        start of ``suffix[0]``); ``log_probs[i]`` is that of ``suffix[i]``."""
        ends = self._token_byte_ends(suffix)
        return float(sum(log_probs[i] for i in range(len(suffix)) if ends[i] > boundary))
