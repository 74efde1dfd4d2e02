"""Batched trie scoring: the trie's layout, and the real model's scores under every batching."""

from __future__ import annotations

import pytest

from t2m_llm_local.trie_scoring import TrieScorer

SUFFIXES = [[7, 1, 2, 3], [7, 1, 2, 4, 5], [7, 1, 6], [7, 1, 2, 3, 9]]
"""Rooted candidates: the prompt's last token (7), then each continuation."""


def test_trie_shares_prefixes_and_orders_parents_first():
    nodes = TrieScorer._trie(SUFFIXES)
    # 7-1-2-3-9, 2-4-5 and 1-6 branch off: 8 distinct nodes for 17 tokens
    assert len(nodes) == 8
    assert nodes[0].token == 7 and nodes[0].depth == 0
    assert [node.depth for node in nodes].count(0) == 1
    assert sorted(nodes[0].sequences) == [1, 2, 3, 4]
    depths = [node.depth for node in nodes]
    assert depths == sorted(depths)
    for index, node in enumerate(nodes):
        for child in node.children.values():
            assert child > index and nodes[child].depth == node.depth + 1
            assert set(nodes[child].sequences) <= set(node.sequences)
    # the node for [7, 1, 2, 3] ends candidate 1 and continues candidate 4
    three = nodes[nodes[nodes[0].children[1]].children[2]].children[3]
    assert sorted(nodes[three].sequences) == [1, 4] and list(nodes[three].children) == [9]


def test_trie_refuses_candidates_with_another_root():
    with pytest.raises(ValueError, match="prompt's last token"):
        TrieScorer._trie([[7, 1], [8, 1]])


CONTEXT = "Objects: table, rack, red_box, blue_box, hook\nExecuted action:"
CANDIDATES = [
    " pick(red_box)",
    " pick(red_box), place(red_box, rack)",  # continues another candidate
    " pick(blue_box)",
    " place(red_box, rack)",
    " place(red_box, table)",
    " pull(blue_box, hook)",
    " push(red_box, hook, rack)",
]


def _tokens(llama, text: str) -> list[int]:
    return llama.tokenize(text.encode(), add_bos=False, special=False)


@pytest.mark.llm
@pytest.mark.slow
def test_groups_and_batch_splits_give_the_same_scores(local_model):
    llama = local_model._llama
    prompt = _tokens(llama, CONTEXT)
    full = [_tokens(llama, CONTEXT + candidate) for candidate in CANDIDATES]
    assert all(tokens[: len(prompt)] == prompt for tokens in full)
    continuations = [tokens[len(prompt) :] for tokens in full]

    one_batch = TrieScorer(llama)
    reference = one_batch.log_probs(prompt, continuations)
    # 2 candidates per group and 3 tokens per decode call: 4 groups, several calls each
    small = TrieScorer(llama, max_sequences=3, max_batch_tokens=3)
    split = small.log_probs(prompt, continuations)
    for continuation, expected, got in zip(continuations, reference, split, strict=True):
        assert expected.shape == got.shape == (len(continuation),)
        assert (expected <= 0).all()
        assert got == pytest.approx(expected, abs=0.3)  # quantised matmuls round by batch size
    # every first token is predicted by the same (kept) logits of the prompt's last token
    assert reference[0][0] == pytest.approx(reference[1][0], abs=1e-9)
    # the candidate that continues another shares its leading tokens' log-probabilities exactly (the
    # last differs: ")" there, ")," here)
    shared = len(reference[0]) - 1
    assert continuations[1][:shared] == continuations[0][:shared]
    assert reference[1][:shared] == pytest.approx(reference[0][:shared], abs=1e-6)
    # the cached prompt is reused: a second call gives the same values, and so does one after a
    # different prompt that evicted it
    again = one_batch.log_probs(prompt, continuations)
    one_batch.log_probs(_tokens(llama, "A different context:"), continuations[:2])
    after = one_batch.log_probs(prompt, continuations)
    for expected, got, later in zip(reference, again, after, strict=True):
        assert got == pytest.approx(expected, abs=1e-6)
        assert later == pytest.approx(expected, abs=0.3)
    one_batch.close()
    small.close()


@pytest.mark.llm
@pytest.mark.slow
def test_prompt_and_candidates_beyond_the_context_are_refused(local_model):
    llama = local_model._llama
    scorer = TrieScorer(llama)
    prompt = _tokens(llama, "word " * (scorer.n_ctx - 3))[: scorer.n_ctx - 3]
    many = [[100 + k, 7] for k in range(10)]  # 20 candidate tokens on top of n_ctx - 3 prompt tokens
    with pytest.raises(ValueError, match="exceed the context"):
        scorer.log_probs(prompt, many)
    with pytest.raises(ValueError, match="non-empty prompt"):
        scorer.log_probs([], many)
    scorer.close()
