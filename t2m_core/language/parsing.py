"""From model answers to validated goals, skill candidates and skill sequences
(docs/guide/prompts.md#parsing-and-validation). Pure functions of the answer text; asking the model
(with a bounded re-query) is :mod:`t2m_core.language.queries`.

Parsing uses the domain's literal grammar (never ``eval``). Validation is against the scene:

- goals: every proposition in 𝒫 of the scene's objects; a goal with any invalid proposition is
  rejected as a whole;
- next-skill candidates: each entry is checked by INST (known skill, arity, scene objects, no repeated
  argument; argument types too with ``check_types=True``); invalid entries are dropped and logged,
  duplicates removed, at most K kept;
- skill sequences (shooting): a sequence with any invalid entry is dropped.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, field

from t2m_core.domain.goals import Goal, parse_goal, validate_goal
from t2m_core.domain.literals import LiteralSyntaxError, extract_first_list, parse_string_lists
from t2m_core.domain.skills import SkillCall, SkillError, check_argument_types, parse_skill_call
from t2m_core.language.prompts import K

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Rejected:
    """An answer entry that was dropped, and why."""

    text: str
    reason: str


@dataclass
class SkillCandidates:
    """Validated skill calls from one answer, plus what was dropped."""

    calls: list[SkillCall] = field(default_factory=list)
    rejected: list[Rejected] = field(default_factory=list)


# --------------------------------------------------------------------------------------------------
# Parsers (pure functions of the answer text)
# --------------------------------------------------------------------------------------------------


def parse_goal_or_none(text: str, objects: Sequence[str]) -> Goal | None:
    """:func:`parse_goal_answer`, except that an empty list, the answer for an instruction no goal
    expresses (docs/guide/language-models.md#no-valid-goal), gives ``None``.

    Raises:
        GoalError: naming the unparseable part or the invalid proposition.
    """
    try:
        if parse_string_lists(extract_first_list(text)) == []:
            return None
    except LiteralSyntaxError:
        pass  # parse_goal_answer names the problem
    return parse_goal_answer(text, objects)


def parse_goal_answer(text: str, objects: Sequence[str]) -> Goal:
    """The goal in a model answer, validated against 𝒫 of ``objects``.

    Raises:
        GoalError: naming the unparseable part or the invalid proposition.
    """
    goal = parse_goal(text, extract=True)
    validate_goal(goal, objects)
    return goal


def inst(text: str, objects: Sequence[str], *, check_types: bool = False, allow_stop: bool = False) -> SkillCall:
    """INST (docs/guide/planners.md#shared-steps): the skill call ``text`` names, or :class:`SkillError` naming why it is invalid."""
    call = parse_skill_call(text, objects, allow_stop=allow_stop)
    if check_types and call.name != "stop":
        problems = check_argument_types(call)
        if problems:
            raise SkillError(f"invalid skill call {call}: {'; '.join(problems)}")
    return call


def parse_skill_candidates(
    text: str, objects: Sequence[str], k: int = K, *, check_types: bool = False, allow_stop: bool = False
) -> SkillCandidates:
    """Valid, distinct skill calls of a ``['pick(a)', ...]`` answer (at most ``k``), in answer order.

    Raises:
        SkillError: no list of strings can be read from the answer at all.
    """
    entries = _first_list(text)
    result = SkillCandidates()
    for entry in entries:
        if not isinstance(entry, str):
            result.rejected.append(Rejected(str(entry), "a nested list, expected a skill call"))
            continue
        try:
            call = inst(entry, objects, check_types=check_types, allow_stop=allow_stop)
        except SkillError as error:
            result.rejected.append(Rejected(entry, error.message))
            continue
        if call in result.calls:
            continue
        if len(result.calls) == k:
            result.rejected.append(Rejected(entry, f"more than K = {k} candidates"))
            continue
        result.calls.append(call)
    for rejected in result.rejected:
        log.info("dropped candidate %r: %s", rejected.text, rejected.reason)
    return result


def parse_skill_sequences(
    text: str, objects: Sequence[str], k: int = K, *, check_types: bool = False
) -> tuple[list[tuple[SkillCall, ...]], list[Rejected]]:
    """Valid skill sequences of a ``[['pick(a)', ...], ...]`` answer (at most ``k``).

    A sequence with any invalid entry, or an empty one, is dropped. Duplicates are removed.

    Raises:
        SkillError: no list can be read from the answer at all.
    """
    entries = _first_list(text)
    if entries and all(isinstance(entry, str) for entry in entries):
        entries = [entries]  # a single flat sequence: read it as one proposal
    sequences: list[tuple[SkillCall, ...]] = []
    rejected: list[Rejected] = []
    for entry in entries:
        if not isinstance(entry, list) or not entry or not all(isinstance(item, str) for item in entry):
            rejected.append(Rejected(str(entry), "not a non-empty list of skill-call strings"))
            continue
        try:
            sequence = tuple(inst(item, objects, check_types=check_types) for item in entry)
        except SkillError as error:
            rejected.append(Rejected(str(entry), error.message))
            continue
        if sequence not in sequences and len(sequences) < k:
            sequences.append(sequence)
    return sequences, rejected


def _first_list(text: str) -> list:
    try:
        value = parse_string_lists(extract_first_list(text))
    except LiteralSyntaxError as error:
        raise SkillError(f"cannot read a list from the answer: {error.message}", "answer with a Python list") from None
    return value
