"""Turning candidate log-likelihoods into usefulness scores, and the labelled multiple-choice
approximation for chat APIs that return only top-k log-probabilities (docs/guide/planners.md#scores,
docs/guide/prompts.md#scores-from-a-language-model).

Exact backends return ℓ_k = Σ log p(token) of each candidate after ``Executed action:``; approximate
ones build a multiple-choice question (:func:`multiple_choice_prompt`), read the label tokens' top-k
log-probabilities (:func:`label_logprobs`), and average over candidate orderings
(:func:`average_choice_logprobs`). Either way planners apply :func:`dampened_softmax` with β = 0.3.
"""

from __future__ import annotations

import math
import string
from collections.abc import Mapping, Sequence

BETA = 0.3
"""Dampening of the usefulness softmax (docs/guide/planners.md#constants)."""

MULTIPLE_CHOICE_ORDERINGS = 3
"""Cyclic shifts of the candidate order averaged to cancel position bias."""

MULTIPLE_CHOICE_QUESTION = "Answer with the single letter of the most useful next action."


def dampened_softmax(logprobs: Sequence[float], beta: float = BETA) -> list[float]:
    """S_llm(c_k) = exp(β ℓ_k) / Σ_j exp(β ℓ_j); ``-inf`` entries get 0. Empty input gives ``[]``."""
    if not logprobs:
        return []
    scaled = [beta * value for value in logprobs]
    top = max(scaled)
    if top == -math.inf:
        return [1.0 / len(scaled)] * len(scaled)
    weights = [math.exp(value - top) for value in scaled]
    total = sum(weights)
    return [weight / total for weight in weights]


def logsumexp(values: Sequence[float]) -> float:
    """log Σ exp(v), stable; ``-inf`` for an empty sequence."""
    if not values:
        return -math.inf
    top = max(values)
    if top == -math.inf:
        return -math.inf
    return top + math.log(sum(math.exp(value - top) for value in values))


def choice_labels(count: int) -> list[str]:
    """``["A", "B", ...]`` for ``count`` options (at most 26)."""
    if not 0 < count <= len(string.ascii_uppercase):
        raise ValueError(f"multiple choice needs 1..26 options, got {count}")
    return list(string.ascii_uppercase[:count])


def cyclic_orderings(count: int, orderings: int = MULTIPLE_CHOICE_ORDERINGS) -> list[list[int]]:
    """Up to ``orderings`` distinct cyclic shifts of ``range(count)``, the identity first."""
    shifts = min(max(orderings, 1), count)
    step = max(count // shifts, 1)
    return [[(index + shift * step) % count for index in range(count)] for shift in range(shifts)]


def multiple_choice_prompt(context: str, candidates: Sequence[str], order: Sequence[int]) -> str:
    """The scoring context with the query line replaced by a labelled list of candidates.

    Args:
        context: the scoring prompt without its ``Executed action:`` line.
        candidates: candidate skill texts.
        order: ``order[i]`` is the candidate shown under the i-th label.
    """
    labels = choice_labels(len(order))
    lines = [f"{label}) {candidates[index]}" for label, index in zip(labels, order, strict=True)]
    separator = "" if context.endswith("\n") or not context else "\n"
    return f"{context}{separator}Candidate next actions:\n" + "\n".join(lines) + f"\n{MULTIPLE_CHOICE_QUESTION}\nAnswer:"


def _label_of(token: str) -> str | None:
    """The option letter a generated token stands for (``"A"``, ``" A"``, ``"A)"``, ``"(A"``), else None."""
    stripped = token.strip().strip("()").strip()
    if len(stripped) == 1 and stripped in string.ascii_uppercase:
        return stripped
    return None


def label_logprobs(top_logprobs: Mapping[str, float], labels: Sequence[str]) -> list[float]:
    """Log-probability of each label at the first generated position, from its top-k alternatives.

    Token variants of one label (``"A"``, ``" A"``, ``"A)"``) are combined with log-sum-exp. A label
    missing from the top-k gets the floor ``min(returned) - ln 2``: less likely than anything listed,
    never impossible.
    """
    if not top_logprobs:
        raise ValueError("the backend returned no top log-probabilities for the answer token")
    variants: dict[str, list[float]] = {label: [] for label in labels}
    for token, logprob in top_logprobs.items():
        label = _label_of(token)
        if label in variants:
            variants[label].append(float(logprob))
    floor = min(float(value) for value in top_logprobs.values()) - math.log(2.0)
    return [logsumexp(values) if values else floor for values in (variants[label] for label in labels)]


def average_choice_logprobs(per_ordering: Sequence[tuple[Sequence[int], Sequence[float]]], count: int) -> list[float]:
    """Average candidate probabilities over orderings, then take the log.

    Args:
        per_ordering: for each ordering, ``(order, label_logprobs)``; ``label_logprobs[i]`` belongs to
            candidate ``order[i]``.
        count: number of candidates.

    Returns:
        ``(count,)`` log of the mean probability of each candidate.
    """
    sums = [0.0] * count
    for order, logprobs in per_ordering:
        for position, candidate in enumerate(order):
            sums[candidate] += math.exp(logprobs[position])
    return [math.log(total / len(per_ordering)) if total > 0 else -math.inf for total in sums]


def continuation_logprob(
    text: str, token_offsets: Sequence[int], token_logprobs: Sequence[float | None], boundary: int, end: int | None = None
) -> float:
    """Sum of the log-probabilities of the tokens that cover characters in ``[boundary, end)``.

    This is the exact score from echoed prompt log-probabilities: tokens are located by their
    character offsets in ``text``, never by looking for a ``:`` token.

    Args:
        text: the echoed prompt (context + label + " " + candidate).
        token_offsets: start character of each token.
        token_logprobs: log-probability of each token (``None`` for the first token).
        boundary: character index where the candidate continuation starts (``len(context)``).
        end: where the scored text ends (default ``len(text)``); tokens starting at or after it
            (e.g. a generated token appended to the echo) are ignored.
    """
    stop = len(text) if end is None else end
    total = 0.0
    for index, start in enumerate(token_offsets):
        token_end = token_offsets[index + 1] if index + 1 < len(token_offsets) else len(text)
        if token_end > boundary and start < stop:
            logprob = token_logprobs[index]
            if logprob is None:
                raise ValueError("the first token of the continuation has no log-probability")
            total += float(logprob)
    return total
