"""Clearing a rack: what "clear the rack", "take everything off the rack" or "nothing should stay on
the rack" asks of the goal, read from the words and the scene (an instruction cue, like
:mod:`t2m_core.language.instruction_cues`).

Small models write such goals over the wrong objects: a box that is already on the table, or only
the part after "then" ("empty the rack, then put the yellow box on it"). Which objects rest on the
rack is in the scene's relationships, so the goal is completed from them: every object on the
cleared rack that the answer does not place elsewhere goes ``on(object, table)``; table
propositions that already hold for objects not on the rack are dropped (the instruction does not
ask to keep them), and so are propositions about the table or the rack themselves, which never move.

Usage::

    support = cleared_support(instruction, objects)
    goal = complete_cleared_goal(goal, support, relationships)
"""

from __future__ import annotations

import re
from collections.abc import Sequence

from t2m_core.domain.goals import Goal
from t2m_core.domain.objects import OBJECTS, ObjectKind
from t2m_core.domain.propositions import Proposition
from t2m_core.language.instruction_cues import words

_CLEARING = (
    re.compile(r"\b(?:clear|empty|unload)(?: off| out)?(?: the)? (?P<support>[a-z]+)"),
    re.compile(r"\b(?:everything|all|every)(?: [a-z]+){0,3}? (?:off|from)(?: of)?(?: the)? (?P<support>[a-z]+)"),
    re.compile(r"\bnothing(?: [a-z]+){0,4}? on(?: the)? (?P<support>[a-z]+)"),
)
"""Phrases that ask for a support to be cleared: "clear the rack", "everything off the rack",
"all the boxes from the rack", "nothing should stay on the rack"."""


def cleared_support(instruction: str, objects: Sequence[str]) -> str | None:
    """The rack of the scene the instruction asks to clear, or ``None``."""
    text = " ".join(words(instruction))
    for pattern in _CLEARING:
        for match in pattern.finditer(text):
            name = match.group("support")
            if name in objects and name in OBJECTS and OBJECTS[name].kind is ObjectKind.RACK:
                return name
    return None


def complete_cleared_goal(goal: Goal, support: str | None, relationships: Sequence[str]) -> Goal:
    """Each alternative of ``goal`` completed to clear ``support`` (see the module docstring);
    ``goal`` unchanged when ``support`` is ``None``."""
    if support is None:
        return goal
    facts = {Proposition.coerce(text) for text in relationships}
    on_support = [p.args[0] for p in map(Proposition.coerce, relationships) if p.predicate == "on" and p.args[1] == support]
    alternatives = []
    for alternative in goal:
        kept = [
            p for p in alternative
            if OBJECTS[p.args[0]].kind in (ObjectKind.BOX, ObjectKind.HOOK)
            and not (p in facts and p.predicate == "on" and p.args[1] == "table" and p.args[0] not in on_support)
        ]
        placed = {p.args[0] for p in kept}
        kept += [Proposition("on", (name, "table")) for name in on_support if name not in placed]
        alternatives.append(tuple(dict.fromkeys(kept)) or tuple(alternative))
    return Goal(tuple(dict.fromkeys(alternatives)))
