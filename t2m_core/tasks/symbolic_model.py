"""The workspace-aware symbolic model used for the subgoal-completion metric
(docs/guide/tasks.md#success-and-subgoal-completion).

Unlike the simple rules of :mod:`t2m_core.domain.skills`, this model tracks
workspace zones, ``infront`` and ``nonblocking`` facts, so that e.g. a box beyond the workspace
must be pulled before it can be picked. Subgoal completion replays the executed skills with it and
searches breadth-first for the shortest remaining plan (depth ≤ 20, timeout 10 s).
"""

from __future__ import annotations

import itertools
import time
from collections import deque
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from t2m_core.domain.goals import Goal
from t2m_core.domain.objects import ObjectKind, object_spec
from t2m_core.domain.propositions import Proposition
from t2m_core.domain.skills import MOVABLE, SKILLS, UNMOVABLE, SkillCall, check_argument_types
from t2m_core.tasks.model import Task

Facts = frozenset[Proposition]

SYMBOLIC_ZONES = (
    "inworkspace", "beyondworkspace", "incollisionzone", "inoperationalzone", "inobstructionzone", "inoodzone"
)
"""Zone facts of the model."""
_RELATIONAL = ("infront", "nonblocking")
_KEPT_INITIAL = ("on", "inworkspace", "beyondworkspace", "inoperationalzone", "inobstructionzone", *_RELATIONAL)
"""Initial-state predicates kept by :func:`initial_facts` (free, aligned and poslimit have no symbolic role)."""

MAX_DEPTH = 20
"""Breadth-first search depth limit, in skills."""
TIMEOUT_S = 10.0
"""Breadth-first search time limit, seconds."""


def initial_facts(task: Task) -> Facts:
    """The task's symbolic initial state: its on, zone, infront and nonblocking propositions, plus
    inworkspace(table)."""
    facts = {p for p in task.initial_state if p.predicate in _KEPT_INITIAL}
    facts.add(Proposition("inworkspace", ("table",)))
    return frozenset(facts)


def _kind(name: str) -> ObjectKind:
    return object_spec(name).kind


def _has(facts: Facts, predicate: str, *args: str) -> bool:
    return Proposition(predicate, args) in facts


def _in_any_zone(facts: Facts, obj: str, zones: Iterable[str]) -> bool:
    return any(_has(facts, zone, obj) for zone in zones)


def _under_any(facts: Facts, obj: str) -> bool:
    return any(p.predicate == "under" and p.args[0] == obj for p in facts)


def applicable(call: SkillCall, facts: Facts) -> bool:
    """Whether the preconditions of ``call`` hold in ``facts``."""
    if call.name not in SKILLS or len(call.args) != SKILLS[call.name].arity or check_argument_types(call):
        return False
    if len(set(call.args)) != len(call.args):
        return False
    held = any(p.predicate == "inhand" for p in facts)
    a = call.args[0]
    if call.name == "pick":
        return (
            not held
            and any(
                p.predicate == "on"
                and p.args[0] == a
                and _kind(p.args[1]) in UNMOVABLE
                and _has(facts, "inworkspace", p.args[1])
                for p in facts
            )
            and _in_any_zone(facts, a, ("inworkspace", "incollisionzone", "inoperationalzone", "inobstructionzone"))
            and not _under_any(facts, a)
            and not _in_any_zone(facts, a, ("beyondworkspace", "inoodzone"))
        )
    if call.name == "place":
        return _has(facts, "inhand", a) and _has(facts, "inworkspace", call.args[1])
    tool = call.args[1]
    common = _has(facts, "inhand", tool) and _has(facts, "on", a, "table") and not _under_any(facts, a)
    if call.name == "pull":
        return (
            common
            and _has(facts, "beyondworkspace", a)
            and not _has(facts, "inworkspace", a)
            and not any(p.predicate == "infront" and p.args[1] == a for p in facts)
            and not _in_any_zone(facts, a, ("incollisionzone", "inoperationalzone", "inobstructionzone", "inoodzone"))
        )
    rack = call.args[2]  # push
    return (
        common
        and _has(facts, "inoperationalzone", a)
        and _has(facts, "infront", a, rack)
        and _has(facts, "beyondworkspace", rack)
        and not _in_any_zone(facts, a, ("incollisionzone", "inobstructionzone", "beyondworkspace", "inoodzone"))
        and not any(
            p.predicate == "inobstructionzone" and p.args[0] != a and _kind(p.args[0]) in MOVABLE for p in facts
        )
    )


def apply(call: SkillCall, facts: Facts) -> Facts:
    """The facts after ``call`` (its effects; preconditions are not checked, see :func:`applicable`)."""
    new = set(facts)
    a = call.args[0]
    if call.name == "pick":
        new = {
            p
            for p in new
            if not (p.predicate == "on" and p.args[0] == a)
            and not (p.predicate in SYMBOLIC_ZONES and p.args[0] == a)
            and not (p.predicate in _RELATIONAL and a in p.args)
        }
        new.add(Proposition("inhand", (a,)))
    elif call.name == "place":
        support = call.args[1]
        new.discard(Proposition("inhand", (a,)))
        new |= {Proposition("on", (a, support)), Proposition("inworkspace", (a,))}
        if support == "table":
            for p in facts:
                if p.predicate == "beyondworkspace" and _kind(p.args[0]) is ObjectKind.RACK:
                    new |= {Proposition("inoperationalzone", (a,)), Proposition("infront", (a, p.args[0]))}
    elif call.name == "pull":
        new.discard(Proposition("beyondworkspace", (a,)))
        new.add(Proposition("inworkspace", (a,)))
    elif call.name == "push":
        rack = call.args[2]
        new -= {
            Proposition("infront", (a, rack)),
            Proposition("inworkspace", (a,)),
            Proposition("inoperationalzone", (a,)),
        }
        new |= {Proposition("under", (a, rack)), Proposition("beyondworkspace", (a,))}
    return frozenset(new)


def groundings(object_names: Sequence[str]) -> tuple[SkillCall, ...]:
    """Every well-typed grounding of the four skills over the objects, in skill then object order."""
    calls = []
    for signature in SKILLS.values():
        for args in itertools.permutations(object_names, signature.arity):
            call = SkillCall(signature.name, args)
            if not check_argument_types(call):
                calls.append(call)
    return tuple(calls)


@dataclass(frozen=True)
class SearchResult:
    """Outcome of :func:`shortest_plan`.

    Attributes:
        plan: the shortest skill sequence reaching the goal, or ``None`` when none was found.
        expanded: number of states expanded.
        timed_out: the time limit ended the search.
    """

    plan: tuple[SkillCall, ...] | None
    expanded: int
    timed_out: bool = False


def shortest_plan(
    facts: Facts,
    goal: Goal,
    object_names: Sequence[str],
    *,
    max_depth: int = MAX_DEPTH,
    timeout_s: float = TIMEOUT_S,
) -> SearchResult:
    """Breadth-first search for the shortest plan from ``facts`` to any goal alternative."""
    if goal.satisfied_by(facts):
        return SearchResult((), 0)
    calls = groundings(object_names)
    deadline = time.monotonic() + timeout_s
    frontier: deque[tuple[Facts, tuple[SkillCall, ...]]] = deque([(facts, ())])
    seen = {facts}
    expanded = 0
    while frontier:
        if time.monotonic() > deadline:
            return SearchResult(None, expanded, timed_out=True)
        state, plan = frontier.popleft()
        expanded += 1
        if len(plan) >= max_depth:
            continue
        for call in calls:
            if not applicable(call, state):
                continue
            successor = apply(call, state)
            if successor in seen:
                continue
            if goal.satisfied_by(successor):
                return SearchResult((*plan, call), expanded)
            seen.add(successor)
            frontier.append((successor, (*plan, call)))
    return SearchResult(None, expanded)


def replay(task: Task, executed: Iterable[SkillCall]) -> tuple[Facts, int]:
    """Replay executed (successful) skills from the task's initial facts.

    Returns:
        ``(facts, applied)``: the facts after the longest prefix whose preconditions held, and the
        length of that prefix.
    """
    facts = initial_facts(task)
    applied = 0
    for call in executed:
        if not applicable(call, facts):
            break
        facts = apply(call, facts)
        applied += 1
    return facts, applied
