"""Which in-context examples a prompt shows, and in what order: the ones whose instructions share
the most informative words with the query's instruction, the closest last, next to the query
(docs/guide/deviations.md#examples-chosen-by-relevance).

Small models copy the shape of the example nearest to the query: its relation, its count, whether
it enumerates alternatives. Relevance is the cosine similarity of the instructions' words weighted
by inverse document frequency (words crudely stemmed, function words left out, and every box
colour read as one word, ``<colour>``: which box an instruction names says nothing about the goal's
shape, that it names one does), computed over the examples themselves: words that few examples use ("every", "hold", "beneath", "either") weigh most, and an
example whose instruction says much that the query does not ranks lower. Nothing is specific to
any instruction; the function-word list is the only English in it.
"""

from __future__ import annotations

import math
import re
from collections import Counter
from collections.abc import Sequence
from typing import Protocol

from t2m_core.domain.objects import OBJECTS, ObjectKind

FUNCTION_WORDS = frozenset(
    "a an the of and or to for with in at by from is are be been am do does did can could would will "
    "should shall may might must i me my you your we us our it its they them their this that these those "
    "please thanks now just then so there here what how".split()
)
"""Words that say nothing about a goal's shape."""
COLOUR_WORDS = frozenset(name.removesuffix("_box") for name, spec in OBJECTS.items() if spec.kind is ObjectKind.BOX)
"""The box colours of the world, read as one word."""
COLOUR = "<colour>"


class HasInstruction(Protocol):
    instruction: str


def stem(word: str) -> str:
    """A crude English stem: ``boxes`` -> ``box``, ``colored`` -> ``color``, ``holding`` -> ``hold``."""
    for suffix, keep in (("ing", 5), ("ed", 4), ("es", 4), ("s", 3)):
        if word.endswith(suffix) and len(word) > keep and not word.endswith("ss"):
            return word[: -len(suffix)]
    return word


def content_words(text: str) -> set[str]:
    """Stemmed words of ``text`` without function words, box colours read as :data:`COLOUR`."""
    words = re.findall(r"[a-z]+", text.lower())
    return {COLOUR if word in COLOUR_WORDS else stem(word) for word in words if word not in FUNCTION_WORDS}


def word_weights(examples: Sequence[HasInstruction]) -> dict[str, float]:
    """Inverse document frequency of each content word over the examples' instructions."""
    counts = Counter(word for example in examples for word in content_words(example.instruction))
    total = len(examples)
    return {word: math.log((total + 1) / (count + 1)) + 1.0 for word, count in counts.items()}


def relevance(instruction: str, example: HasInstruction, weights: dict[str, float]) -> float:
    """Cosine similarity of the weighted content words of ``instruction`` and the example's
    instruction (a word no example uses gets the largest weight)."""
    unseen = max(weights.values(), default=1.0)
    query, other = content_words(instruction), content_words(example.instruction)
    shared = sum(weights.get(word, unseen) ** 2 for word in query & other)
    if not shared:
        return 0.0
    norm = math.sqrt(sum(weights.get(word, unseen) ** 2 for word in query) * sum(weights.get(word, unseen) ** 2 for word in other))
    return shared / norm


def most_relevant(instruction: str, examples: Sequence[HasInstruction], count: int | None = None) -> list:
    """The ``count`` examples most relevant to ``instruction`` (all when ``None``), least relevant
    first; ties keep the given order (a seeded shuffle), so the result is deterministic."""
    weights = word_weights(examples)
    scored = sorted(range(len(examples)), key=lambda index: relevance(instruction, examples[index], weights))
    chosen = scored if count is None else scored[len(scored) - min(count, len(scored)) :]
    return [examples[index] for index in chosen]
