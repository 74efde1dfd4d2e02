"""When an instruction has no valid goal, and why (docs/guide/language-models.md#no-valid-goal).

A goal answer passes parsing when its propositions belong to 𝒫 of the scene; that does not make it
a goal the robot can pursue. These checks end a goal query with a clear "no valid goal" instead of
a made-up goal:

- the instruction names a TableEnv object that is not in the scene (``the blue box`` where there
  is none), or uses no word of the world's vocabulary at all (no object, object kind, skill or
  predicate name: "sing me a song"): checked before the model is asked, from the world's own names;
- the model answers ``[]``, the answer the in-context examples give for instructions that no goal
  over the scene's objects expresses (something that is no TableEnv object, a request unrelated to
  arranging objects);
- no alternative of the answer can be reached from the described relationships in at most d_max
  skills under the skills' symbolic rules (a box on a box, the rack moved, two objects in hand).
  Alternatives that cannot be reached are dropped from a goal whose other alternatives can.

Two more steps read the answer as the small models mean it. Alternatives of a lifted goal share
one shape (the same relations to the same places, other objects); an answer whose alternatives
differ in shape lists the parts of one goal, and is merged into one conjunction when that can be
reached (:func:`merge_mixed_alternatives`: ``[['on(red_box, rack)'], ['inhand(hook)']]``). And a
goal keeps to what the instruction names, by name or as the object in hand (:func:`prefer_named_objects`): when
some alternatives move only objects the instruction names and others move objects it does not
name, the latter are dropped (a small model that got "the blue box" right often goes on to list
the other boxes as alternatives).
"""

from __future__ import annotations

import re
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass

from t2m_core.domain.enumeration import candidate_groundings
from t2m_core.domain.goals import Goal
from t2m_core.domain.objects import OBJECTS, ObjectKind
from t2m_core.domain.propositions import GOAL_PREDICATES, Proposition
from t2m_core.domain.skills import SKILLS
from t2m_core.domain.symbolic_effects import apply_effects, precondition_problems
from t2m_core.language.example_retrieval import stem

D_MAX = 10
"""Longest plan considered, in skills (docs/guide/planners.md#constants)."""


@dataclass(frozen=True)
class NoGoal:
    """Why an instruction has no valid goal in its scene.

    Attributes:
        kind: ``"absent"`` (it names an object missing from the scene), ``"none_expresses"`` (the
            model found no goal that expresses it) or ``"unreachable"`` (no plan reaches the goal
            the model wrote).
        reason: one sentence for the user.
    """

    kind: str
    reason: str


def spoken_name(name: str) -> str:
    """The word an instruction uses for an object: the box's colour, else the object's name."""
    return name.removesuffix("_box") if OBJECTS[name].kind is ObjectKind.BOX else name


def named_objects(instruction: str, objects: Sequence[str]) -> tuple[str, ...]:
    """Scene objects the instruction names (``red`` for the red box, ``hook``...)."""
    said = set(re.findall(r"[a-z]+", instruction.lower()))
    return tuple(name for name in objects if name in OBJECTS and spoken_name(name) in said)


def _moved(alternative: Sequence[Proposition]) -> set[str]:
    """The movable objects (boxes, the hook) an alternative is about."""
    return {arg for p in alternative for arg in p.args if OBJECTS[arg].kind in (ObjectKind.BOX, ObjectKind.HOOK)}


HELD_REFERENCES = frozenset(("holding", "carrying", "gripper", "hand"))
"""Words by which an instruction can mean the object in hand ("what you're holding")."""


def held_objects(instruction: str, relationships: Sequence[str]) -> tuple[str, ...]:
    """The objects in hand (``inhand(x)`` among ``relationships``) when the instruction refers to
    what is held (:data:`HELD_REFERENCES`): "put down what you're holding" names the held box."""
    if not HELD_REFERENCES & set(re.findall(r"[a-z]+", instruction.lower())):
        return ()
    return tuple(p.args[0] for p in map(Proposition.coerce, relationships) if p.predicate == "inhand")


def prefer_named_objects(goal: Goal, instruction: str, objects: Sequence[str], relationships: Sequence[str] = ()) -> Goal:
    """``goal`` without the alternatives about movable objects the instruction does not name (by
    name, or as the object in hand: :func:`held_objects`), when others are only about named ones;
    unchanged when the instruction names no movable object or every alternative involves an
    unnamed one ("the cyan box and one other box")."""
    named = {name for name in named_objects(instruction, objects) if OBJECTS[name].kind in (ObjectKind.BOX, ObjectKind.HOOK)}
    named |= set(held_objects(instruction, relationships))
    if not named:
        return goal
    kept = tuple(alternative for alternative in goal if _moved(alternative) <= named)
    return Goal(kept) if kept else goal


def absent_objects(instruction: str, objects: Sequence[str]) -> tuple[str, ...]:
    """TableEnv objects the instruction names (``red`` for the red box, ``hook``...) that the scene lacks."""
    said = set(re.findall(r"[a-z]+", instruction.lower()))
    return tuple(name for name in OBJECTS if name not in objects and spoken_name(name) in said)


def absent_object_reason(instruction: str, objects: Sequence[str]) -> NoGoal | None:
    """A :class:`NoGoal` naming the objects the instruction asks for that are not in the scene."""
    missing = absent_objects(instruction, objects)
    if not missing:
        return None
    names = " and ".join(f"the {name.replace('_', ' ')}" for name in missing)
    verb = "is" if len(missing) == 1 else "are"
    return NoGoal("absent", f"the instruction names {names}, which {verb} not in this scene (its objects: {', '.join(objects)})")


def world_vocabulary() -> frozenset[str]:
    """Words that name something of the TableEnv world: objects (``red`` for the red box, ``hook``),
    object kinds (``box``), skills (``pick``...) and goal predicates (``on``, ``under``)."""
    names = {spoken_name(name) for name in OBJECTS} | {kind.name.lower() for kind in ObjectKind}
    return frozenset(stem(word) for word in names | set(SKILLS) | set(GOAL_PREDICATES))


def unrelated_reason(instruction: str) -> NoGoal | None:
    """A :class:`NoGoal` for an instruction that uses no word of :func:`world_vocabulary`."""
    said = {stem(word) for word in re.findall(r"[a-z]+", instruction.lower())}
    if said & world_vocabulary():
        return None
    return NoGoal(
        "unrelated",
        "the instruction names none of the world's objects (boxes, the hook, the rack, the table) and none of "
        "what the robot can do (pick, place, pull, push; on, under, in hand)",
    )


def _shape(alternative: Sequence[Proposition]) -> tuple[tuple[str, str], ...]:
    """The relations of an alternative, without the objects they move: ``(("on", "rack"), ...)``."""
    return tuple(sorted((p.predicate, p.args[1] if len(p.args) > 1 else "") for p in alternative))


def merge_mixed_alternatives(goal: Goal, objects: Sequence[str], relationships: Sequence[str]) -> Goal:
    """One conjunction of every alternative's propositions when the alternatives differ in shape
    and that conjunction can be reached; ``goal`` otherwise."""
    if len(goal) < 2 or len({_shape(alternative) for alternative in goal}) == 1:
        return goal
    merged = Goal((tuple(p for alternative in goal for p in alternative),))
    return merged if reachable_alternatives(merged, objects, relationships) is not None else goal


NONE_EXPRESSES = NoGoal(
    "none_expresses",
    "the language model found no goal over this scene's objects with on, under and inhand that expresses the instruction",
)


def _described_facts(relationships: Sequence[str]) -> frozenset[Proposition]:
    return frozenset(p for p in map(Proposition.coerce, relationships) if p.predicate in GOAL_PREDICATES)


def reachable_alternatives(goal: Goal, objects: Sequence[str], relationships: Sequence[str], d_max: int = D_MAX) -> Goal | None:
    """The alternatives of ``goal`` that some plan of at most ``d_max`` skills makes true from the
    described relationships (breadth-first over the skills' symbolic rules; workspace facts are not
    described, so reachability with the hook is assumed), or ``None`` when there is none."""
    start = _described_facts(relationships)
    pending = [alternative for alternative in goal if not set(alternative) <= start]
    reached = [alternative for alternative in goal if set(alternative) <= start]
    calls = [call for skill in SKILLS for call in candidate_groundings(skill, objects)]
    seen, frontier = {start}, deque([(start, 0)])
    while frontier and pending:
        facts, depth = frontier.popleft()
        if depth >= d_max:
            continue
        for call in calls:
            if any(not problem.endswith("is not beyond the workspace") for problem in precondition_problems(call, facts)):
                continue
            successor = apply_effects(call, facts)
            if successor in seen:
                continue
            seen.add(successor)
            frontier.append((successor, depth + 1))
            for alternative in [alt for alt in pending if set(alt) <= successor]:
                pending.remove(alternative)
                reached.append(alternative)
    kept = tuple(alternative for alternative in goal if alternative in reached)
    return Goal(kept) if kept else None


def unreachable_reason(goal: Goal, d_max: int = D_MAX) -> NoGoal:
    """The :class:`NoGoal` for a goal none of whose alternatives can be reached."""
    return NoGoal(
        "unreachable",
        f"no sequence of at most {d_max} skills makes {goal} true: objects rest only on the table or the "
        "rack, only boxes go under the rack, the table and the rack stay put, and the gripper holds one object",
    )
