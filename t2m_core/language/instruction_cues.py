"""What an instruction's words say about the shape of its goal: which goal relations it names
(``onto`` -> on, ``beneath`` -> under) and how many boxes it counts (``three of the boxes``,
``two primary colored boxes``, ``all of the boxes``).

A 0.5B model copies the goal relation of a similar example and does not count: it writes
``under(...)`` for "move three of the boxes to the rack" and pairs for any count. These cues feed
the goal grammar (:func:`t2m_core.language.grammar.goal_grammar`) and the completion of counted,
lifted goals (:func:`complete_counted_goal`): a goal expresses "two of the boxes" by
enumerating the alternatives, so a counted answer is completed to every k-subset of the boxes it
ranges over. The model still chooses the relation, the destination and (for a described class such
as "primary colored") which boxes belong to it.

Written against the task suite's instructions, the cues still help on phrasings they were not
written for (the goal evaluation set: docs/guide/language-models.md#the-embedded-model-local), for
both embedded models, so they stay on by default.

Usage::

    cue = count_cue("How would you move three of the boxes to the rack?", objects)
    grammar = goal_grammar(objects, relations=named_relations(instruction), count=cue)
    goal = complete_counted_goal(parse_goal_answer(answer, objects), cue)
"""

from __future__ import annotations

import itertools
import re
from collections.abc import Sequence
from dataclasses import dataclass

from t2m_core.domain.goals import Goal
from t2m_core.domain.objects import OBJECTS, ObjectKind
from t2m_core.domain.propositions import Proposition

RELATION_WORDS = {
    "on": "on", "onto": "on", "to": "on", "atop": "on",
    "under": "under", "beneath": "under", "underneath": "under", "below": "under", "hidden": "under",
    "tuck": "under", "slide": "under", "push": "under", "shove": "under",
}
"""Words that say which goal relation an instruction asks for."""

GOAL_RELATIONS = ("on", "under")
"""The binary goal predicates, in the order grammars list them."""

_COUNT_WORDS = {
    "one": 1, "single": 1, "two": 2, "couple": 2, "pair": 2, "three": 3, "four": 4,
    "all": None, "every": None, "each": None, "both": None,
}
# "<count> [of] [the] [up to three describing words] box|boxes"; "than one of the boxes" is a
# comparison, not a count.
_COUNT_PHRASE = re.compile(
    r"(?<!than )\b(?P<count>" + "|".join(_COUNT_WORDS) + r")\b(?: of)?(?: the)?(?P<described>(?: [a-z-]+){0,3}?) box(?:es)?\b"
)


def words(text: str) -> list[str]:
    """Lower-case words of ``text``."""
    return re.findall(r"[a-z]+", text.lower())


HOLD_WORDS = frozenset(["hold", "holding", "holds", "grab", "grabbing", "grasp", "grip", "carry", "carrying", "pick", "lift"])
"""Words that ask for an object in hand."""
HAND_WORDS = frozenset(("hand", "gripper"))
"""With ``in``, words that say where an object is held."""


def asks_to_hold(said: Sequence[str]) -> bool:
    """Whether the words ``said`` ask for something in hand: a :data:`HOLD_WORDS` word, or ``in``
    with ``hand`` or ``gripper``."""
    return bool(HOLD_WORDS.intersection(said)) or ("in" in said and bool(HAND_WORDS.intersection(said)))


def named_relations(instruction: str) -> tuple[str, ...]:
    """The binary goal relations the instruction's words name, in :data:`GOAL_RELATIONS` order;
    none when it only asks to hold something (:func:`asks_to_hold`: goals of ``inhand`` alone);
    both when it names neither (nothing to go by). ``inhand`` is always allowed besides."""
    said = words(instruction)
    named = {RELATION_WORDS[word] for word in said if word in RELATION_WORDS}
    if not named and asks_to_hold(said):
        return ()
    return tuple(relation for relation in GOAL_RELATIONS if relation in named) or GOAL_RELATIONS


def boxes(objects: Sequence[str]) -> tuple[str, ...]:
    """The scene's boxes, in scene order."""
    return tuple(name for name in objects if name in OBJECTS and OBJECTS[name].kind is ObjectKind.BOX)


@dataclass(frozen=True)
class CountCue:
    """A counted box phrase of an instruction.

    Attributes:
        k: boxes each goal alternative moves.
        described: True when words between the count and "boxes" narrow the class
            ("two primary colored boxes"); the model's answer then says which boxes belong to it.
        destinations: where the counted boxes go: the scene's supports (table, rack) that the
            instruction names (all of them when it names none).
        boxes: the scene's boxes, in scene order.
        pins: whether an alternative may keep other boxes ``on(box, table)`` (the scene has a table).
    """

    k: int
    described: bool
    destinations: tuple[str, ...]
    boxes: tuple[str, ...]
    pins: bool


COLOUR_CATEGORIES = {
    "warm": frozenset({"red", "orange", "yellow"}),
    "cool": frozenset({"blue", "cyan", "green", "purple", "violet"}),
    "primary": frozenset({"red", "yellow", "blue"}),
    "secondary": frozenset({"green", "orange", "purple"}),
}
"""Colour categories and the colours they hold (general colour knowledge, not the world's)."""
_BOX_WORDS = frozenset(("box", "boxes", "ones"))


def category_boxes(instruction: str, objects: Sequence[str]) -> tuple[str, ...] | None:
    """The scene's boxes of the colour category the instruction names ("the warm-colored boxes",
    "two primary colored boxes"), in scene order; ``None`` when it names none (or the scene has
    none of that category)."""
    said = words(instruction)
    category = next((word for word in said if word in COLOUR_CATEGORIES), None)
    if category is None or not _BOX_WORDS.intersection(said):
        return None
    members = tuple(name for name in boxes(objects) if name.removesuffix("_box") in COLOUR_CATEGORIES[category])
    return members or None


def count_cue(instruction: str, objects: Sequence[str]) -> CountCue | None:
    """The instruction's counted box phrase, or ``None`` when it counts no boxes (or counts more
    boxes than the scene has, or "all" of a described class, whose size only the model knows).

    A colour category (:func:`category_boxes`) is a class whose members are known: the count ranges
    over them, and a category named without a count ("the cool-colored boxes") counts all of them."""
    text = " ".join(words(instruction))
    match = _COUNT_PHRASE.search(text)
    scene_boxes = boxes(objects)
    members = category_boxes(instruction, objects)
    if not scene_boxes or (match is None and members is None):
        return None
    described = match is not None and bool(match.group("described").strip())
    k = _COUNT_WORDS[match.group("count")] if match is not None else None
    if members is not None:
        scene_boxes, described = members, False
    if k is None:
        if described:
            return None
        k = len(scene_boxes)
    if k > len(scene_boxes):
        return None
    said = set(words(instruction))
    supports = [name for name in objects if name in OBJECTS and OBJECTS[name].kind in (ObjectKind.TABLE, ObjectKind.RACK)]
    destinations = tuple(name for name in supports if name in said) or tuple(supports)
    return CountCue(k, described, destinations, scene_boxes, "table" in objects)


def complete_counted_goal(goal: Goal, cue: CountCue | None) -> Goal:
    """Every k-subset of the boxes a counted answer ranges over (lifted goals are enumerated:
    docs/guide/planners.md#goal-prediction).

    The answer must be uniform: every alternative moves k distinct boxes with one relation to one
    destination (plus, optionally, ``on(box, table)`` for the boxes it leaves). The boxes ranged over
    are all the scene's boxes for a plain count ("three of the boxes") and the boxes the answer names
    for a described class ("two primary colored boxes"). Alternatives keep the answer's relation,
    destination and pinning (all the other boxes on the table, when its first alternative does so).
    Any other answer is returned unchanged.
    """
    if cue is None:
        return goal
    shapes, moved_sets, pins = set(), [], []
    for alternative in goal:
        moved = [p for p in alternative if p.predicate in GOAL_RELATIONS and p.args[0] in cue.boxes and p.args[1] != "table"]
        left = [p for p in alternative if p not in moved]
        if len(moved) != cue.k or any(p.predicate != "on" or p.args[1] != "table" for p in left):
            return goal
        shapes |= {(p.predicate, p.args[1]) for p in moved}
        moved_sets.append({p.args[0] for p in moved})
        pins.append({p.args[0] for p in left})
    if len(shapes) != 1 or any(len(moved) != cue.k for moved in moved_sets):
        return goal
    (relation, destination), = shapes
    scene_boxes = cue.boxes
    named = set().union(*moved_sets)
    ranged = [name for name in scene_boxes if name in named] if cue.described else list(scene_boxes)
    pin_others = pins[0] == set(scene_boxes) - moved_sets[0]
    alternatives = []
    for subset in itertools.combinations(ranged, cue.k):
        props = [Proposition(relation, (name, destination)) for name in subset]
        if pin_others:
            props += [Proposition("on", (name, "table")) for name in scene_boxes if name not in subset]
        alternatives.append(tuple(props))
    return Goal(tuple(alternatives))
