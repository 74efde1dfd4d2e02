"""Symbolic validity and effects of a skill call: which groundings are valid in a symbolic state and
the state after a call succeeds (the rules of skill-data generation,
docs/guide/skills.md#data-generation).

Symbolic states here are sets of :class:`Proposition` (on/under/inhand plus, where a rule needs it,
zone propositions such as ``beyondworkspace(rack)``).
"""

from __future__ import annotations

from collections.abc import Iterable

from t2m_core.domain.objects import ObjectKind, object_spec
from t2m_core.domain.propositions import Proposition
from t2m_core.domain.skills import UNMOVABLE, SkillCall, check_argument_types, syntax_problems

SymbolicFacts = frozenset[Proposition]


def _kind(name: str) -> ObjectKind:
    return object_spec(name).kind


def _facts(state: Iterable[Proposition | str]) -> SymbolicFacts:
    return frozenset(Proposition.coerce(p) for p in state)


def precondition_problems(call: SkillCall, state: Iterable[Proposition | str]) -> list[str]:
    """Why ``call`` is not a symbolically valid grounding in ``state``; empty
    when it is valid. Argument types are part of validity."""
    facts = _facts(state)
    problems = syntax_problems(call) or check_argument_types(call)
    if problems:
        return problems
    held = [p.args[0] for p in facts if p.predicate == "inhand"]
    a = call.args[0]
    if call.name == "pick":
        if held:
            problems.append(f"{held[0]} is already in hand")
        if not any(p.predicate == "on" and p.args[0] == a and _kind(p.args[1]) in UNMOVABLE for p in facts):
            problems.append(f"{a} is not on the table or the rack")
    elif call.name == "place":
        if Proposition("inhand", (a,)) not in facts:
            problems.append(f"{a} is not in hand")
    else:  # pull, push
        tool = call.args[1]
        if Proposition("inhand", (tool,)) not in facts:
            problems.append(f"{tool} is not in hand")
        if Proposition("on", (a, "table")) not in facts:
            problems.append(f"{a} is not on the table")
        if call.name == "push":
            rack = call.args[2]
            if Proposition("under", (a, rack)) in facts:
                problems.append(f"{a} is already under {rack}")
            if Proposition("beyondworkspace", (rack,)) not in facts:
                problems.append(f"{rack} is not beyond the workspace")
    return problems


def is_valid_grounding(call: SkillCall, state: Iterable[Proposition | str]) -> bool:
    """Whether ``call`` is a symbolically valid grounding in ``state``."""
    return not precondition_problems(call, state)


def apply_effects(call: SkillCall, state: Iterable[Proposition | str]) -> SymbolicFacts:
    """The symbolic state after ``call`` succeeds: pick → inhand(a) (a leaves its support);
    place → on(a, b); pull keeps on(a, table); push keeps on(a, table) and adds under(a, rack).
    Preconditions are not checked (see :func:`precondition_problems`)."""
    facts = set(_facts(state))
    a = call.args[0] if call.args else None
    if call.name == "pick":
        facts = {p for p in facts if not (p.predicate in ("on", "under") and p.args[0] == a)}
        facts.add(Proposition("inhand", (a,)))
    elif call.name == "place":
        facts.discard(Proposition("inhand", (a,)))
        facts.add(Proposition("on", call.args))
    elif call.name == "push":
        facts.add(Proposition("under", (a, call.args[2])))
    return frozenset(facts)
