"""Asking a language model for a goal, next skills or skill sequences, with a bounded re-query
while the answer does not parse or validate (docs/guide/prompts.md#parsing-and-validation).

Each ``query_*`` function takes any :class:`~t2m_core.protocols.LanguageModel`; when it declares
``capabilities.grammar`` and ``constrained=True``, decoding is constrained by a GBNF grammar built
from the scene (:mod:`t2m_core.language.grammar`). A rejected answer is asked again with a one-line
note naming the problem inserted before the query line: goals up to ``retries`` times (default 2,
then the episode is a planning failure), skill lists once when no list parses or no entry is valid.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

from t2m_core.domain.goals import Goal, GoalError
from t2m_core.domain.literals import format_string_list
from t2m_core.domain.skills import SkillCall, SkillError
from t2m_core.language import grammar as grammars
from t2m_core.language import instruction_cues as cues
from t2m_core.language.clearing_cue import cleared_support, complete_cleared_goal
from t2m_core.language.goal_checks import (
    NONE_EXPRESSES,
    NoGoal,
    absent_object_reason,
    merge_mixed_alternatives,
    prefer_named_objects,
    reachable_alternatives,
    unreachable_reason,
    unrelated_reason,
)
from t2m_core.language.instruction_checks import two_in_hand_reason, unknown_thing_reason
from t2m_core.language.parsing import SkillCandidates, parse_goal_or_none, parse_skill_candidates, parse_skill_sequences
from t2m_core.language.prompts import GOAL_REQUEST, NEXT_SKILL_REQUEST, SHOOTING_REQUEST, K
from t2m_core.protocols import LanguageModel

T = TypeVar("T")

GOAL_RETRIES = 2
"""Re-queries after an invalid goal, then the episode is a planning failure."""
ALREADY_HOLDS = "already holds in the scene; the instruction asks for a change"
"""The note for a goal with an alternative that is true before the robot moves: asked again, and
kept if the model insists (an instruction may ask for what already holds)."""
LIST_RETRIES = 1
"""Re-queries after an unparseable skill list."""


@dataclass
class Attempt:
    """One model answer in a bounded query loop, and the problem with it (``None`` if it was used)."""

    prompt: str
    answer: str
    problem: str | None


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
    """The outcome of :func:`query_goal`.

    Attributes:
        goal: the goal; ``None`` when the instruction has no valid goal (``no_goal`` says why) or
            every attempt was invalid (a planning failure).
        attempts: every answer, in order (none when the instruction was refused before asking).
        no_goal: why the instruction has no valid goal in this scene.
        unpreferred: the goal before alternatives about objects the instruction does not name
            were dropped (``goal`` when nothing was dropped; for comparisons).
    """

    goal: Goal | None
    attempts: list[Attempt]
    no_goal: NoGoal | None = None
    unpreferred: Goal | None = None


def _ask_until_valid(
    model: LanguageModel,
    prompt: str,
    grammar: str | None,
    request: dict[str, Any],
    read: Callable[[str], tuple[T, str | None]],
    retries: int,
) -> tuple[T, list[Attempt]]:
    """Ask ``model`` until ``read(answer)`` finds no problem, at most ``retries + 1`` times; each
    retry carries a note about the answer before it (:func:`with_error_note`).

    ``read`` returns ``(value, problem)``, ``problem`` ``None`` for a usable answer. Returns the last
    value read and every attempt."""
    attempts: list[Attempt] = []
    current = prompt
    for _ in range(retries + 1):
        answer = model.complete(current, grammar=grammar, **request)[0]
        value, problem = read(answer)
        attempts.append(Attempt(current, answer, problem))
        if problem is None:
            break
        current = with_error_note(prompt, answer, problem)
    return value, attempts


def refusal(instruction: str, objects: Sequence[str]) -> NoGoal | None:
    """Why ``instruction`` has no goal in a scene of ``objects``, read from its words alone: it names
    a world object the scene lacks, nothing of the world, a thing no world object is, or two objects
    to hold at once (:mod:`~t2m_core.language.goal_checks`, :mod:`~t2m_core.language.instruction_checks`)."""
    return (
        absent_object_reason(instruction, objects)
        or unrelated_reason(instruction)
        or unknown_thing_reason(instruction, objects)
        or two_in_hand_reason(instruction)
    )


def query_goal(
    model: LanguageModel,
    prompt: str,
    objects: Sequence[str],
    *,
    retries: int = GOAL_RETRIES,
    constrained: bool = True,
    instruction: str | None = None,
    relationships: Sequence[str] | None = None,
    cues_on: bool = True,
) -> GoalQuery:
    """Ask for the goal; re-query with a note up to ``retries`` times while the answer is invalid.

    With ``instruction``, an instruction that names a TableEnv object missing from the scene,
    nothing of the TableEnv world, a thing no TableEnv object is, or two objects to hold at once, is
    refused before the model is asked (:func:`refusal`), and (``cues_on``) its cues
    (:mod:`t2m_core.language.instruction_cues`) shape the answer: the grammar allows only the goal
    relations its words name and, for a counted box phrase ("three of the boxes"), alternatives of
    exactly that many boxes; a uniform counted answer is completed to every subset of that size, and
    an answer to "clear the rack" is completed from what rests on it (:mod:`~t2m_core.language.clearing_cue`).
    An answer ``[]`` means no goal expresses the instruction. With ``relationships`` (the scene's),
    an answer with an alternative that already holds is asked again with a note (and kept if the
    model repeats it), alternatives of different shapes are merged into one conjunction when it can
    be reached, alternatives no plan of d_max skills reaches are dropped, and a goal left with none is no valid
    goal; alternatives about objects the instruction does not name give way to those about objects
    it names (:mod:`t2m_core.language.goal_checks`).
    """
    if instruction and (refused := refusal(instruction, objects)) is not None:
        return GoalQuery(None, [], refused)
    use_cues = bool(instruction) and cues_on
    relations = cues.named_relations(instruction) if use_cues else cues.GOAL_RELATIONS
    count = cues.count_cue(instruction, objects) if use_cues and relations else None
    grammar = _grammar_for(model, constrained, lambda: grammars.goal_grammar(objects, relations=relations, count=count))

    start = set(relationships or ())

    def read(answer: str) -> tuple[Goal | None, str | None]:
        try:
            goal = parse_goal_or_none(answer, objects)
        except GoalError as error:
            return None, error.message
        held = next((alternative for alternative in goal or () if {str(p) for p in alternative} <= start), None)
        if held is not None:
            return goal, f"{format_string_list([str(p) for p in held])} {ALREADY_HOLDS}"
        return goal, None

    goal, attempts = _ask_until_valid(model, prompt, grammar, GOAL_REQUEST, read, retries)
    problem = attempts[-1].problem
    if problem is not None and not problem.endswith(ALREADY_HOLDS):
        return GoalQuery(None, attempts)
    if goal is None:
        return GoalQuery(None, attempts, NONE_EXPRESSES)
    goal = cues.complete_counted_goal(goal, count)
    if use_cues and relationships is not None:
        goal = complete_cleared_goal(goal, cleared_support(instruction, objects), relationships)
    if relationships is not None:
        goal = merge_mixed_alternatives(goal, objects, relationships)
        reachable = reachable_alternatives(goal, objects, relationships)
        if reachable is None:
            return GoalQuery(None, attempts, unreachable_reason(goal))
        goal = reachable
    preferred = prefer_named_objects(goal, instruction, objects, relationships or ()) if instruction else goal
    return GoalQuery(preferred, attempts, unpreferred=goal)


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
    symbolically valid groundings of the described relationships. The answer is then
    ``min(K, n)`` of them in order, so with ``n <= K`` there is only one answer the grammar admits:
    it is returned without asking the model (one attempt, its prompt never sent).
    """
    grammar = _grammar_for(
        model,
        constrained,
        lambda: grammars.skill_list_grammar(objects, k, typed=check_types, allow_stop=allow_stop, calls=calls),
    )
    admitted = [*(calls or ()), *(["stop()"] if allow_stop else [])]
    if grammar is not None and calls and len(admitted) <= k:
        answer = format_string_list(admitted)
        forced = parse_skill_candidates(answer, objects, k, check_types=check_types, allow_stop=allow_stop)
        return forced, [Attempt(prompt, answer, None)]

    def read(answer: str) -> tuple[SkillCandidates, str | None]:
        try:
            candidates = parse_skill_candidates(answer, objects, k, check_types=check_types, allow_stop=allow_stop)
        except SkillError as error:
            return SkillCandidates(), error.message
        if candidates.calls:
            return candidates, None
        return candidates, "no valid skill call: " + "; ".join(rejected.reason for rejected in candidates.rejected[:2])

    return _ask_until_valid(model, prompt, grammar, NEXT_SKILL_REQUEST, read, retries)


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

    def read(answer: str) -> tuple[list[tuple[SkillCall, ...]], str | None]:
        try:
            sequences, rejected = parse_skill_sequences(answer, objects, k, check_types=check_types)
        except SkillError as error:
            return [], error.message
        if sequences:
            return sequences, None
        return sequences, "no valid skill sequence: " + "; ".join(item.reason for item in rejected[:2])

    return _ask_until_valid(model, prompt, grammar, SHOOTING_REQUEST, read, retries)
