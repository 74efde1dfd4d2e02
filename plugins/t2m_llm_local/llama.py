"""The embedded language model: a GGUF model run in-process by llama.cpp (llama-cpp-python).

Scoring is exact (text2motion.md §11.3): the shared context is evaluated once, and each candidate's
tokens are decoded on top of that cached prefix with logits for every position; ℓ_k is the sum of
the log-softmax of the candidate's tokens. Tokens are found by byte offsets in the tokenization of
the *full* string (context + candidate), never by tokenizing the candidate alone, because the
tokenizer merges the leading space into the next token. (llama-cpp-python 0.3.36's echoed prompt
log-probabilities are wrong, so they are not used.)

A model file is loaded once per process and shared by every :class:`LocalLanguageModel` that names
the same file and context settings.
"""

from __future__ import annotations

import atexit
import logging
import os
import threading
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from t2m_core.errors import ModelFileError, T2MError
from t2m_core.protocols import LanguageModelCapabilities

from t2m_llm_local.hooks import LocalModelOptions
from t2m_llm_local.model_files import default_model_path

log = logging.getLogger(__name__)

CONTEXT_HINT = "raise the local model's n_ctx option (t2m llm: --set n_ctx=16384; run config: language_model.options.n_ctx)"

_MODELS: dict[tuple[Any, ...], tuple[Any, threading.Lock]] = {}
_MODELS_LOCK = threading.Lock()


@atexit.register
def _close_models() -> None:
    """Free the models before interpreter shutdown: llama-cpp-python's ``__del__`` fails once its
    module globals are gone, printing an "Exception ignored" traceback at every exit."""
    with _MODELS_LOCK:
        for llama, _ in _MODELS.values():
            llama.close()
        _MODELS.clear()


def _load_llama(path: Path, n_ctx: int, n_threads: int, n_threads_batch: int, n_batch: int) -> tuple[Any, threading.Lock]:
    """The process-wide llama.cpp model for these settings (loaded on first use) and the lock that
    serialises its use (its KV cache is one shared state)."""
    key = (str(path), n_ctx, n_threads, n_threads_batch, n_batch)
    with _MODELS_LOCK:
        if key not in _MODELS:
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
            _MODELS[key] = (llama, threading.Lock())
            log.info("loaded %s in %.2f s", path.name, time.perf_counter() - start)
        return _MODELS[key]


def default_threads() -> int:
    """Generation threads when none are configured: all cores but one, at most 8.

    llama.cpp's threads spin at every barrier, once per layer and token; on a small, shared machine a
    thread that loses its core stalls the others (measured on 2 busy cores: 1 thread generates 18
    tokens/s, 2 threads under 1).
    """
    return max(1, min(8, (os.cpu_count() or 2) - 1))


def default_batch_threads() -> int:
    """Threads for prompt and candidate batches when none are configured: the same rule as
    :func:`default_threads`. On an idle 2-core machine 2 batch threads halve the scoring time (96 ms
    instead of 177 ms per candidate), but beside other busy processes they collapse to seconds per
    candidate, so all cores are used only when asked for (``n_threads_batch``)."""
    return default_threads()


def _log_softmax(logits: np.ndarray) -> np.ndarray:
    """Row-wise log-softmax of ``(N, V) float32`` logits, computed in float64."""
    values = logits.astype(np.float64)
    values -= values.max(axis=1, keepdims=True)
    return values - np.log(np.exp(values).sum(axis=1, keepdims=True))


class LocalLanguageModel:
    """In-process llama.cpp backend with exact candidate scoring and GBNF-constrained decoding.

    Args:
        options: validated :class:`~t2m_llm_local.hooks.LocalModelOptions`.
    """

    capabilities = LanguageModelCapabilities(exact_scoring=True, grammar=True)

    def __init__(self, options: LocalModelOptions) -> None:
        self.options = options
        if options.model_path is None:
            self.model_path = default_model_path()
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
        self._llama, self._lock = _load_llama(self.model_path, options.n_ctx, threads, batch_threads, options.n_batch)
        self.load_time_s = time.perf_counter() - start
        self._grammars: dict[str, Any] = {}
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
        with self._lock:
            for sample in range(samples):
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
        """Cumulative byte length of the detokenized text after each token."""
        ends, total = [], 0
        for token in tokens:
            total += len(self._llama.detokenize([token]))
            ends.append(total)
        return ends

    def _eval_prefix(self, prefix: Sequence[int]) -> None:
        """Make the KV cache hold exactly ``prefix``, reusing whatever leading part it already holds."""
        llama = self._llama
        cached = llama.n_tokens
        reuse = 0
        held = llama.input_ids
        limit = min(cached, len(prefix))
        while reuse < limit and held[reuse] == prefix[reuse]:
            reuse += 1
        llama.n_tokens = reuse
        if reuse < len(prefix):
            llama.eval(list(prefix[reuse:]))
        else:
            llama._ctx.kv_cache_seq_rm(-1, reuse, -1)

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
        for candidate, tokens in zip(candidates, full, strict=True):
            if len(tokens) + 1 > self.options.n_ctx:
                raise T2MError(
                    f"scoring prompt for {candidate!r} has {len(tokens)} tokens, more than the context of {self.options.n_ctx}",
                    hint=CONTEXT_HINT,
                )
        # Shared prefix: tokens common to every full tokenization that end before the candidate.
        first = full[0]
        common = min(len(tokens) for tokens in full)
        for tokens in full[1:]:
            common = next((index for index in range(common) if tokens[index] != first[index]), common)
        ends = self._token_byte_ends(first[:common])
        shared = next((index for index, end in enumerate(ends) if end > boundary), common)
        if shared == 0:
            raise ValueError("scoring needs a non-empty context before the candidates")
        # Evaluate all but the last shared token once; the candidates' decodes start with that token
        # so its logits predict each candidate's first token.
        base = shared - 1
        boundary_in_suffix = boundary - (ends[base - 1] if base else 0)
        suffixes = [list(tokens[base:]) for tokens in full]
        # Candidates in token order share leading tokens ("place(hook," ...): each is decoded only from
        # where it leaves the previous one, on top of that one's cached keys and values.
        order = sorted(range(len(suffixes)), key=lambda index: suffixes[index])
        scores = [0.0] * len(suffixes)
        with self._lock:
            self._eval_prefix(first[:base])
            previous: list[int] = []
            rows: list[np.ndarray] = []  # rows[i]: log-probabilities after suffix[: i + 1]
            for index in order:
                suffix = suffixes[index]
                common = 0
                # only rows that were decoded (never the last token's) can be reused
                while common < min(len(previous) - 1, len(suffix)) and previous[common] == suffix[common]:
                    common += 1
                rows = rows[:common] + self._decode_rows(suffix, base, common)
                scores[index] = self._sum_candidate(suffix, rows, boundary_in_suffix)
                previous = suffix
            llama.n_tokens = base
            llama._ctx.kv_cache_seq_rm(-1, base, -1)
            # The live logits now belong to a candidate, not to the cached prefix.
            llama._requires_eval = True
        return scores

    def _decode_rows(self, suffix: Sequence[int], base: int, start: int) -> list[np.ndarray]:
        """Log-probability rows ``(V,) float64`` after ``suffix[: i + 1]`` for ``i`` in
        ``start .. len(suffix) - 2``, decoding those tokens at positions ``base + i`` on top of a KV
        cache that holds ``tokens[: base + start]``. The last token predicts nothing scored."""
        llama = self._llama
        pending = list(suffix[start : len(suffix) - 1])
        llama._ctx.kv_cache_seq_rm(-1, base + start, -1)
        if not pending:
            return []
        if len(pending) > llama.n_batch:
            raise ValueError(f"a candidate of {len(suffix)} tokens is longer than the batch ({llama.n_batch})")
        llama._batch.set_batch(batch=pending, n_past=base + start, logits_all=True)
        llama._ctx.decode(llama._batch)
        logits = np.ctypeslib.as_array(llama._ctx.get_logits(), shape=(len(pending), llama.n_vocab()))
        return list(_log_softmax(logits))

    def _sum_candidate(self, suffix: Sequence[int], rows: Sequence[np.ndarray], boundary: int) -> float:
        """Σ log p of the suffix tokens that cover bytes at or after ``boundary`` (counted from the
        start of ``suffix[0]``); ``rows[i]`` predicts ``suffix[i + 1]``."""
        ends = self._token_byte_ends(suffix)
        return float(sum(rows[i][suffix[i + 1]] for i in range(len(suffix) - 1) if ends[i + 1] > boundary))
