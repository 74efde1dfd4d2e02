"""The embedded llama.cpp model: exact scoring, generation, grammars, one load per process.

These load the real embedded model (marked ``llm`` and ``slow``); one instance is shared by the session.
"""

from __future__ import annotations

import numpy as np
import pytest

from t2m_core.errors import ModelFileError, T2MError
from t2m_core.language.grammar import goal_grammar
from t2m_core.language.parsing import parse_goal_answer
from t2m_core.testing import check_import_light, check_language_model
from t2m_llm_local.hooks import LocalModelOptions, t2m_register_language_models

CONTEXT = (
    "Available scene objects: ['table', 'rack', 'red_box']\n"
    "Object relationships: ['on(rack, table)', 'inhand(red_box)']\n"
    "Human instruction: Put the red box on the rack.\n"
    "Executed action:"
)
CANDIDATES = [" place(red_box, rack)", " pick(red_box)", " place(red_box, table)"]


def reference_logprob(reference, text: str, boundary: int) -> float:
    """Independent reference: the whole string in one pass with logits for every position."""
    reference.reset()
    tokens = reference.tokenize(text.encode(), add_bos=False)
    reference.eval(tokens)
    logits = reference.scores[: len(tokens)].astype(np.float64)
    logprobs = logits - logits.max(axis=1, keepdims=True)
    logprobs -= np.log(np.exp(logprobs).sum(axis=1, keepdims=True))
    ends = np.cumsum([len(reference.detokenize([token])) for token in tokens])
    return float(sum(logprobs[i - 1, tokens[i]] for i in range(1, len(tokens)) if ends[i] > boundary))


@pytest.mark.llm
@pytest.mark.slow
def test_scores_match_a_full_pass_and_are_stable(local_model):
    import llama_cpp

    scores = local_model.score(CONTEXT, CANDIDATES)
    reference = llama_cpp.Llama(model_path=str(local_model.model_path), n_ctx=256, logits_all=True, verbose=False, n_threads=1)
    for candidate, score in zip(CANDIDATES, scores, strict=True):
        expected = reference_logprob(reference, CONTEXT + candidate, len(CONTEXT))
        # batch splits change quantised matmul rounding by a few hundredths of a nat, no more
        assert score == pytest.approx(expected, abs=0.3)
        assert score < 0
    assert local_model.score(CONTEXT, CANDIDATES) == scores  # the cached prefix gives identical values
    assert local_model.score(CONTEXT, CANDIDATES[::-1]) == scores[::-1]
    # after an unrelated generation the prefix is rebuilt and the scores stay the same
    local_model.complete("Name a colour:", max_tokens=4)
    assert local_model.score(CONTEXT, CANDIDATES) == pytest.approx(scores, abs=1e-3)
    assert local_model.score(CONTEXT, []) == []


@pytest.mark.llm
@pytest.mark.slow
def test_an_in_context_prefix_is_evaluated_once_per_model_and_kept_on_disk(local_model, tmp_path):
    from t2m_llm_local.prefix_cache import PrefixCache

    sharing = local_model._loaded.sharing
    saved = sharing.cache
    holders = [local_model._loaded.generation, local_model._loaded.get_scorer()]

    def new_process_cache() -> PrefixCache:
        for holder in holders:  # forget every evaluated token, as a new process would have none
            holder.truncate(0)
        sharing.cache = PrefixCache(saved.model_sha256, saved.engine, tmp_path)
        return sharing.cache

    examples = "".join(f"Example {index}: the box number {index} goes on the rack.\n\n" for index in range(16))
    try:
        cache = new_process_cache()
        evaluated = sharing.evaluated_prefixes
        local_model.complete(examples + CONTEXT.replace("Executed action:", "Next:"), max_tokens=3)
        assert sharing.evaluated_prefixes == evaluated + 1 and len(list(cache.directory.glob("*.kv"))) == 1
        scores = local_model.score(examples + CONTEXT, CANDIDATES)  # copied from the generation context
        assert sharing.evaluated_prefixes == evaluated + 1
        assert all(score < 0 for score in scores)

        cache = new_process_cache()  # a new process loads the prefix from disk
        loaded = local_model.score(examples + CONTEXT, CANDIDATES)
        # the scoring context evaluated the current block itself this time: rounding as in batch splits
        assert loaded == pytest.approx(scores, abs=0.3)
        assert cache.disk_hits == 1 and sharing.evaluated_prefixes == evaluated + 1

        (path,) = cache.directory.glob("*.kv")
        raw = bytearray(path.read_bytes())
        raw[-100] ^= 0xFF
        path.write_bytes(bytes(raw))
        cache = new_process_cache()  # a corrupt file is detected, evaluated again and rewritten
        assert local_model.score(examples + CONTEXT, CANDIDATES) == pytest.approx(loaded, abs=1e-6)
        assert cache.rejected_files == 1 and sharing.evaluated_prefixes == evaluated + 2 and path.is_file()
    finally:
        sharing.cache = saved


@pytest.mark.llm
@pytest.mark.slow
def test_model_prefers_the_sensible_continuation(local_model):
    # holding the red box with the goal on the rack: placing it is far likelier than picking it again
    place, pick, _ = local_model.score(CONTEXT, CANDIDATES)
    assert place > pick


@pytest.mark.llm
@pytest.mark.slow
def test_grammar_constrained_goal_always_parses(local_model):
    objects = ["table", "rack", "red_box"]
    prompt = CONTEXT.replace("Executed action:", "Predicted goal predicate set (python list of lists):")
    answer = local_model.complete(prompt, max_tokens=60, stop=["\n"], grammar=goal_grammar(objects))[0]
    goal = parse_goal_answer(answer, objects)
    assert all(arg in objects for prop in goal.propositions for arg in prop.args)


@pytest.mark.llm
@pytest.mark.slow
def test_conformance_and_single_load_per_process(local_model):
    check_language_model(local_model)
    from t2m_llm_local.llama import LocalLanguageModel

    again = LocalLanguageModel(LocalModelOptions(model="qwen2.5-coder-0.5b", n_ctx=4096))
    assert again._llama is local_model._llama and again._lock is local_model._lock
    assert again.load_time_s < 0.5


@pytest.mark.llm
@pytest.mark.slow
def test_context_overflow_is_a_clear_error(local_model):
    with pytest.raises(T2MError, match="exceeds the context"):
        local_model.complete("word " * 5000, max_tokens=10)
    # scoring refuses before decoding anything, with the same hint
    with pytest.raises(T2MError, match="exceed the context") as refused:
        local_model.score("word " * 5000 + ":", [" pick(red_box)"])
    assert "n_ctx" in refused.value.hint


def test_missing_model_file_is_a_clear_error(tmp_path):
    from t2m_llm_local.llama import LocalLanguageModel

    with pytest.raises(ModelFileError, match="does not exist"):
        LocalLanguageModel(LocalModelOptions(model_path=tmp_path / "missing.gguf"))


def test_hooks_register_local_and_stay_light():
    (spec,) = t2m_register_language_models()
    assert spec.name == "local" and spec.options is LocalModelOptions
    assert LocalModelOptions().model_path is None and LocalModelOptions().n_ctx == 8192
    assert LocalModelOptions().model == "qwen2.5-coder-1.5b" and LocalModelOptions().prompt_cache
    assert spec.alias_options["qwen2.5-coder-1.5b"] == {"model": "qwen2.5-coder-1.5b"}
    with pytest.raises(ValueError, match="unknown embedded model 'qwen-7b'; choose one of"):
        LocalModelOptions(model="qwen-7b")
    check_import_light("t2m_llm_local.hooks")


def test_thread_options_are_bounded_and_default_to_the_cores(monkeypatch):
    import pydantic

    from t2m_llm_local import llama

    assert LocalModelOptions(n_threads=2).n_threads == 2
    for bad in (0, 257):
        with pytest.raises(pydantic.ValidationError):
            LocalModelOptions(n_threads=bad)
    for cores, generation, batch in ((1, 1, 1), (2, 1, 2), (16, 8, 8), (None, 1, 2)):
        monkeypatch.setattr(llama.os, "cpu_count", lambda cores=cores: cores)
        assert (llama.default_threads(), llama.default_batch_threads()) == (generation, batch), cores
