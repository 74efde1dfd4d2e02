"""Usefulness scores and the multiple-choice approximation (docs/guide/planners.md#scores)."""

from __future__ import annotations

import math

import pytest

from t2m_core.language.scoring import (
    BETA,
    MULTIPLE_CHOICE_QUESTION,
    average_choice_logprobs,
    choice_labels,
    continuation_logprob,
    cyclic_orderings,
    dampened_softmax,
    label_logprobs,
    logsumexp,
    multiple_choice_prompt,
)


def test_beta_is_the_published_value():
    assert BETA == 0.3


def test_dampened_softmax_matches_the_formula():
    logprobs = [-1.0, -3.0, -6.0]
    expected = [math.exp(0.3 * value) for value in logprobs]
    total = sum(expected)
    assert dampened_softmax(logprobs) == pytest.approx([value / total for value in expected])
    # beta < 1 flattens: the gap between the best and the worst shrinks compared with beta = 1
    assert dampened_softmax(logprobs)[0] < dampened_softmax(logprobs, beta=1.0)[0]


def test_dampened_softmax_edge_cases():
    assert dampened_softmax([]) == []
    assert dampened_softmax([-math.inf, -2.0]) == pytest.approx([0.0, 1.0])
    assert dampened_softmax([-math.inf, -math.inf]) == pytest.approx([0.5, 0.5])
    # large magnitudes do not overflow
    assert dampened_softmax([-5000.0, -5001.0])[0] == pytest.approx(1 / (1 + math.exp(-0.3)))


def test_logsumexp():
    assert logsumexp([math.log(0.25), math.log(0.5)]) == pytest.approx(math.log(0.75))
    assert logsumexp([]) == -math.inf


def test_choice_labels_and_orderings():
    assert choice_labels(3) == ["A", "B", "C"]
    with pytest.raises(ValueError):
        choice_labels(0)
    orders = cyclic_orderings(6, 3)
    assert orders[0] == [0, 1, 2, 3, 4, 5]
    assert orders[1] == [2, 3, 4, 5, 0, 1]
    assert all(sorted(order) == list(range(6)) for order in orders)
    assert cyclic_orderings(2, 3) == [[0, 1], [1, 0]]


def test_multiple_choice_prompt_replaces_the_query_line():
    text = multiple_choice_prompt("ctx line\n", ["pick(a)", "place(a, b)"], [1, 0])
    assert text == f"ctx line\nCandidate next actions:\nA) place(a, b)\nB) pick(a)\n{MULTIPLE_CHOICE_QUESTION}\nAnswer:"


def test_label_logprobs_merges_variants_and_floors_missing_labels():
    top = {"A": math.log(0.5), " A": math.log(0.1), "B)": math.log(0.2), "hello": math.log(0.05)}
    values = label_logprobs(top, ["A", "B", "C"])
    assert values[0] == pytest.approx(math.log(0.6))
    assert values[1] == pytest.approx(math.log(0.2))
    # C is missing: lowest returned log-prob minus ln 2
    assert values[2] == pytest.approx(math.log(0.05) - math.log(2))
    with pytest.raises(ValueError):
        label_logprobs({}, ["A"])


def test_average_over_orderings_undoes_the_permutation():
    # candidate 0 gets 0.7 under the identity order, 0.5 when shown second
    per_ordering = [([0, 1], [math.log(0.7), math.log(0.3)]), ([1, 0], [math.log(0.5), math.log(0.5)])]
    values = average_choice_logprobs(per_ordering, 2)
    assert values == pytest.approx([math.log(0.6), math.log(0.4)])


def test_continuation_logprob_sums_tokens_after_the_boundary():
    text = "Executed action: pick(a)"
    offsets = [0, 8, 15, 16, 21, 22, 23]  # "Executed", " action", ":", " pick", "(", "a", ")"
    logprobs = [None, -1.0, -0.5, -2.0, -0.25, -0.125, -0.0625]
    boundary = len("Executed action:")
    assert continuation_logprob(text, offsets, logprobs, boundary) == pytest.approx(-2.4375)
    # a generated token beyond the scored text is ignored
    assert continuation_logprob(text + "\n", [*offsets, 24], [*logprobs, -9.0], boundary, end=len(text)) == pytest.approx(-2.4375)
