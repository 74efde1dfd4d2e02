"""Batched trie scoring: the trie's layout, and the real model's scores under every batching."""

from __future__ import annotations

import pytest

from t2m_llm_local.trie_scoring import TrieScorer

SUFFIXES = [[7, 1, 2, 3], [7, 1, 2, 4, 5], [7, 1, 6], [7, 1, 2, 3, 9]]


def test_trie_shares_prefixes_and_orders_parents_first():
    nodes, roots = TrieScorer._trie(SUFFIXES)
    # 7-1-2-3-9, 2-4-5 and 1-6 branch off: 8 distinct nodes for 17 tokens
    assert len(nodes) == 8
    assert list(roots) == [7]
    assert sorted(nodes[roots[7]].sequences) == [1, 2, 3, 4]
    depths = [node.depth for node in nodes]
    assert depths == sorted(depths)
    for index, node in enumerate(nodes):
        for child in node.children.values():
            assert child > index and nodes[child].depth == node.depth + 1
            assert set(nodes[child].sequences) <= set(node.sequences)
    # the node for [7, 1, 2, 3] ends candidate 1 and continues candidate 4
    three = nodes[nodes[nodes[roots[7]].children[1]].children[2]].children[3]
    assert sorted(nodes[three].sequences) == [1, 4] and list(nodes[three].children) == [9]


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
    full = [_tokens(llama, CONTEXT + candidate) for candidate in CANDIDATES]
    base = len(_tokens(llama, CONTEXT)) - 1
    assert all(tokens[: base + 1] == full[0][: base + 1] for tokens in full)
    suffixes = [tokens[base:] for tokens in full]

    one_batch = TrieScorer(llama)
    reference = one_batch.log_probs(full[0][:base], suffixes)
    # 2 candidates per group and 3 tokens per decode call: 4 groups, several calls each
    small = TrieScorer(llama, max_sequences=3, max_batch_tokens=3)
    split = small.log_probs(full[0][:base], suffixes)
    for suffix, expected, got in zip(suffixes, reference, split, strict=True):
        assert expected.shape == got.shape == (len(suffix) - 1,)
        assert (expected <= 0).all()
        assert got == pytest.approx(expected, abs=0.3)  # quantised matmuls round by batch size
    # the candidate that continues another shares its leading tokens' log-probabilities exactly (the
    # last differs: ")" there, ")," here)
    shared = len(reference[0]) - 1
    assert suffixes[1][: shared + 1] == suffixes[0][: shared + 1]
    assert reference[1][:shared] == pytest.approx(reference[0][:shared], abs=1e-6)
    # the cached prompt is reused: a second call gives the same values
    again = one_batch.log_probs(full[0][:base], suffixes)
    for expected, got in zip(reference, again, strict=True):
        assert got == pytest.approx(expected, abs=1e-6)
    one_batch.close()
    small.close()


@pytest.mark.llm
@pytest.mark.slow
def test_prompt_and_candidates_beyond_the_context_are_refused(local_model):
    llama = local_model._llama
    scorer = TrieScorer(llama)
    prompt = _tokens(llama, "word " * (scorer.n_ctx - 3))[: scorer.n_ctx - 3]
    many = [[prompt[-1], 100 + k, 7] for k in range(10)]  # 11 nodes on top of n_ctx - 3 prompt tokens
    with pytest.raises(ValueError, match="exceed the context"):
        scorer.log_probs(prompt[:-1], many)
    scorer.close()
