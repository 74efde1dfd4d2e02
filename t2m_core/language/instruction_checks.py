"""Instructions refused before the model is asked, because of what their words name
(docs/guide/language-models.md#no-valid-goal).

Two checks, both read from the world's own names plus a few English word classes, nothing specific
to any instruction:

- *unknown things*: a colour word that no box of the world has, naming a box ("the purple box",
  "a green one"), or a thing to move that no word of the world names (the direct object of a verb
  of moving or holding: "put the banana ...", "grab the cup"). A small model given such an
  instruction writes a goal over other objects.
- *two objects in hand*: a clause that asks to hold (hold, grab, pick, "in hand": ``asks_to_hold``) two or more
  objects and says nowhere to put them ("hold the red box and the yellow box"): the gripper holds one.

Usage::

    refused = unknown_thing_reason(instruction, objects) or two_in_hand_reason(instruction)
"""

from __future__ import annotations

import itertools
import re
from collections.abc import Sequence

from t2m_core.domain.objects import OBJECTS, ObjectKind
from t2m_core.language.example_retrieval import stem
from t2m_core.language.goal_checks import NoGoal, spoken_name
from t2m_core.language.instruction_cues import RELATION_WORDS, asks_to_hold

COLOUR_TERMS = frozenset(
    [
        "black", "white", "red", "green", "yellow", "blue", "brown", "orange", "pink", "purple", "violet",
        "grey", "gray", "cyan", "magenta", "turquoise", "teal", "beige", "gold", "golden", "silver", "navy",
        "maroon", "lime", "indigo", "crimson"
    ]
)
"""English colour words; the ones no world box has name nothing here."""
REFERENT_WORDS = frozenset(
    stem(word) for word in [
        "box", "block", "cube", "one", "thing", "object", "item", "tool", "gripper", "hand", "rest", "other",
        "remaining", "everything", "all", "both", "each", "every", "same", "last", "first", "left", "right"
    ]
)
"""Words that refer to the world's things without naming one (``the red one``, ``the rest``)."""
MOVE_VERBS = frozenset(
    [
        "put", "place", "set", "move", "bring", "take", "grab", "hold", "pick", "lift", "carry", "get", "push",
        "slide", "shove", "tuck", "hide", "drop", "hang", "stack", "fetch", "lay", "keep", "pull", "load",
        "grasp"
    ]
)
"""Verbs whose direct object is a thing to move or hold."""
DETERMINERS = frozenset(["the", "a", "an", "this", "that", "these", "those", "my", "your", "some"])
PARTICLES = frozenset(["up", "down", "back", "over", "away", "out"])
PHRASE_ENDS = frozenset(
    [
        "on", "onto", "in", "into", "under", "beneath", "underneath", "below", "beside", "near", "next", "to",
        "off", "from", "with", "at", "by", "over", "and", "or", "then", "so", "for", "as", "without", "using",
        "please", "too", "again", "there", "here", "up", "down", "back", "away", "out"
    ]
)
"""Words that end a noun phrase."""


def _tokens(text: str) -> list[str]:
    """Lower-case words and clause punctuation."""
    return re.findall(r"[a-z]+|[.,;:!?]", text.lower())


def _world_words() -> frozenset[str]:
    names = {spoken_name(name) for name in OBJECTS} | {kind.name.lower() for kind in ObjectKind}
    return frozenset(stem(word) for word in names) | REFERENT_WORDS


def _box_colours() -> frozenset[str]:
    return frozenset(spoken_name(name) for name, spec in OBJECTS.items() if spec.kind is ObjectKind.BOX)


def direct_objects(instruction: str) -> list[list[str]]:
    """The noun phrases (words after the determiner) that follow a verb of :data:`MOVE_VERBS`,
    ``of`` read through (``a pair of boxes`` -> ``pair boxes``)."""
    tokens, phrases = _tokens(instruction), []
    for index, token in enumerate(tokens):
        if token not in MOVE_VERBS:
            continue
        at = index + 1
        while at < len(tokens) and tokens[at] in PARTICLES:
            at += 1
        if at >= len(tokens) or tokens[at] not in DETERMINERS:
            continue
        phrase, at = [], at + 1
        while at < len(tokens) and tokens[at].isalpha():
            if tokens[at] == "of":
                at += 1 + (at + 1 < len(tokens) and tokens[at + 1] in DETERMINERS)
                continue
            if tokens[at] in PHRASE_ENDS:
                break
            phrase.append(tokens[at])
            at += 1
        if phrase:
            phrases.append(phrase)
    return phrases


def unknown_colours(instruction: str) -> tuple[str, ...]:
    """Colour words that name a box (``purple box``, ``green one``) no box of the world has."""
    tokens = _tokens(instruction)
    box_words = {"box", "block", "cube", "one"}
    return tuple(
        word for word, after in itertools.pairwise(tokens)
        if word in COLOUR_TERMS and word not in _box_colours() and stem(after) in box_words
    )


def unknown_things(instruction: str) -> tuple[str, ...]:
    """Things the instruction asks to move or hold that the world has not: boxes of an
    :func:`unknown_colours` colour, then direct objects no word of the world names."""
    found = [f"{colour} box" for colour in unknown_colours(instruction)]
    world = _world_words()
    for phrase in direct_objects(instruction):
        if not {stem(word) for word in phrase} & world:
            found.append(" ".join(phrase))
    return tuple(dict.fromkeys(found))


def unknown_thing_reason(instruction: str, objects: Sequence[str]) -> NoGoal | None:
    """A :class:`NoGoal` (``"unknown"``) naming what the instruction asks for that no world object is."""
    things = unknown_things(instruction)
    if not things:
        return None
    names = " and ".join(f"the {thing}" for thing in things)
    colours = ", ".join(sorted(_box_colours()))
    return NoGoal(
        "unknown",
        f"the instruction asks for {names}, which {'is no object' if len(things) == 1 else 'are no objects'} "
        f"of this world (boxes are {colours}; "
        f"this scene has: {', '.join(objects)})",
    )


def held_together(instruction: str) -> tuple[str, ...]:
    """The world objects a clause asks to hold at once: two or more movable objects named in a
    clause with a holding word and no word of where to put them; ``()`` when there is none."""
    movable = {spoken_name(name): name for name, spec in OBJECTS.items() if spec.kind in (ObjectKind.BOX, ObjectKind.HOOK)}
    clause: list[str] = []
    for token in [*_tokens(instruction), "."]:
        if token.isalpha() and token != "then":
            clause.append(token)
            continue
        holds = asks_to_hold(clause)
        named = tuple(dict.fromkeys(movable[word] for word in clause if word in movable))
        if holds and len(named) >= 2 and not set(clause) & set(RELATION_WORDS):
            return named
        clause = []
    return ()


def two_in_hand_reason(instruction: str) -> NoGoal | None:
    """A :class:`NoGoal` (``"impossible"``) for an instruction that asks to hold two objects at once."""
    named = held_together(instruction)
    if not named:
        return None
    names = " and ".join(f"the {name.replace('_', ' ')}" for name in named)
    return NoGoal("impossible", f"the instruction asks to hold {names} at once, and the gripper holds one object at a time")
