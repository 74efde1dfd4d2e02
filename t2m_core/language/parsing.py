"""From model answers to validated goals, skill candidates and skill sequences
(docs/guide/prompts.md#parsing-and-validation), with a bounded re-query when an answer does not parse.

Parsing uses the domain's literal grammar (never ``eval``). Validation is against the scene:

- goals: every proposition in 𝒫 of the scene's objects; a goal with any invalid proposition
  is rejected as a whole, then re-queried (at most ``retries`` times, default 2, with a one-line note
  naming the problem inserted before the query line);
- next-skill candidates: each entry is checked by INST (known skill, arity, scene objects, no repeated
  argument; argument types too with ``check_types=True``); invalid entries are dropped and logged,
  duplicates removed, at most K kept; the whole answer is re-queried (once) only when no list parses;
- skill sequences (shooting): a sequence with any invalid entry is dropped.

``query_*`` functions take any :class:`~t2m_core.protocols.LanguageModel`; when it declares
``capabilities.grammar`` and ``constrained=True``, decoding is constrained by a GBNF grammar built
from the scene (:mod:`t2m_core.language.grammar`).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from t2m_core.domain.goals import Goal, GoalError, parse_goal, validate_goal
from t2m_core.domain.literals import LiteralSyntaxError, extract_first_list, parse_string_lists
from t2m_core.domain.skills import SkillCall, SkillError, check_argument_types, parse_skill_call
from t2m_core.language import grammar as grammars
from t2m_core.language import instruction_cues as cues
from t2m_core.language.prompts import GOAL_REQUEST, K, NEXT_SKILL_REQUEST, SHOOTING_REQUEST
from t2m_core.protocols import LanguageModel

log = logging.getLogger(__name__)

GOAL_RETRIES = 2
"""Re-queries after an invalid goal, then the episode is a planning failure."""
LIST_RETRIES = 1
"""Re-queries after an unparseable skill list."""


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


@dataclass
class Attempt:
    """One model answer in a bounded query loop, and the problem with it (``None`` if it was used)."""

    prompt: str
    answer: str
    problem: str | None


# --------------------------------------------------------------------------------------------------
# Parsers (pure functions of the answer text)
# --------------------------------------------------------------------------------------------------


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


# --------------------------------------------------------------------------------------------------
# Bounded queries
# --------------------------------------------------------------------------------------------------


def with_error_note(prompt: str, answer: str, problem: str) -> str:
    """``prompt`` with a one-line note about the rejected ``answer`` inserted before its query line."""
    head, newline, query = prompt.rpartition("\n")
    shown = " ".join(answer.split())[:200]
    reason = " ".join(problem.split("\n")[0].split())[:200]  # the first line: no excerpt with a caret
    note = f"Note: the answer {shown!r} was rejected ({reason}). Use only the listed objects and predicates."
    return f"{head}{newline}{note}\n{query}" if newline else f"{note}\n{prompt}"


def _grammar_for(model: LanguageModel, constrained: bool, build: Callable[[], str]) -> str | None:
    """The grammar ``build`` makes, when decoding is constrained and the model accepts grammars."""
    return build() if constrained and model.capabilities.grammar else None


@dataclass
class GoalQuery:
    """The outcome of :func:`query_goal`: the goal (``None`` after all retries failed) and every attempt."""

    goal: Goal | None
    attempts: list[Attempt]


def query_goal(
    model: LanguageModel,
    prompt: str,
    objects: Sequence[str],
    *,
    retries: int = GOAL_RETRIES,
    constrained: bool = True,
    instruction: str | None = None,
) -> GoalQuery:
    """Ask for the goal; re-query with a note up to ``retries`` times while the answer is invalid.

    With ``instruction``, its cues (:mod:`t2m_core.language.instruction_cues`) shape the answer: the
    grammar allows only the goal relations its words name and, for a counted box phrase ("three of
    the boxes"), alternatives of exactly that many boxes; a uniform counted answer is completed to
    every subset of that size. Without it, the goal is the model's answer as written.
    """
    relations = cues.named_relations(instruction) if instruction else cues.GOAL_RELATIONS
    count = cues.count_cue(instruction, objects) if instruction else None
    grammar = _grammar_for(model, constrained, lambda: grammars.goal_grammar(objects, relations=relations, count=count))
    attempts: list[Attempt] = []
    current = prompt
    for _ in range(retries + 1):
        answer = model.complete(current, grammar=grammar, **GOAL_REQUEST)[0]
        try:
            goal = parse_goal_answer(answer, objects)
        except GoalError as error:
            attempts.append(Attempt(current, answer, error.message))
            current = with_error_note(prompt, answer, error.message)
            continue
        attempts.append(Attempt(current, answer, None))
        return GoalQuery(cues.complete_counted_goal(goal, count), attempts)
    return GoalQuery(None, attempts)


def query_next_skills(
    model: LanguageModel,
    prompt: str,
    objects: Sequence[str],
    k: int = K,
    *,
    retries: int = LIST_RETRIES,
    constrained: bool = True,
    check_types: bool = False,
    allow_stop: bool = False,
    calls: Sequence[str] | None = None,
) -> tuple[SkillCandidates, list[Attempt]]:
    """Ask for K next skills; re-query while no list parses or no entry is valid.

    ``calls`` (constrained decoding only) limits the entries to those call strings, e.g. the
    symbolically valid groundings of the described relationships.
    """
    grammar = _grammar_for(
        model,
        constrained,
        lambda: grammars.skill_list_grammar(objects, k, typed=check_types, allow_stop=allow_stop, calls=calls),
    )
    attempts: list[Attempt] = []
    current = prompt
    candidates = SkillCandidates()
    for _ in range(retries + 1):
        answer = model.complete(current, grammar=grammar, **NEXT_SKILL_REQUEST)[0]
        try:
            candidates = parse_skill_candidates(answer, objects, k, check_types=check_types, allow_stop=allow_stop)
        except SkillError as error:
            problem = error.message
        else:
            if candidates.calls:
                attempts.append(Attempt(current, answer, None))
                return candidates, attempts
            problem = "no valid skill call: " + "; ".join(rejected.reason for rejected in candidates.rejected[:2])
        attempts.append(Attempt(current, answer, problem))
        current = with_error_note(prompt, answer, problem)
    return candidates, attempts


def query_skill_sequences(
    model: LanguageModel,
    prompt: str,
    objects: Sequence[str],
    k: int = K,
    *,
    d_max: int = 10,
    retries: int = LIST_RETRIES,
    constrained: bool = True,
    check_types: bool = False,
) -> tuple[list[tuple[SkillCall, ...]], list[Attempt]]:
    """Ask for K whole skill sequences (shooting); re-query while none is valid."""
    grammar = _grammar_for(model, constrained, lambda: grammars.skill_sequences_grammar(objects, k, d_max, typed=check_types))
    attempts: list[Attempt] = []
    current = prompt
    sequences: list[tuple[SkillCall, ...]] = []
    for _ in range(retries + 1):
        answer = model.complete(current, grammar=grammar, **SHOOTING_REQUEST)[0]
        try:
            sequences, rejected = parse_skill_sequences(answer, objects, k, check_types=check_types)
        except SkillError as error:
            problem = error.message
        else:
            if sequences:
                attempts.append(Attempt(current, answer, None))
                return sequences, attempts
            problem = "no valid skill sequence: " + "; ".join(item.reason for item in rejected[:2])
        attempts.append(Attempt(current, answer, problem))
        current = with_error_note(prompt, answer, problem)
    return sequences, attempts
