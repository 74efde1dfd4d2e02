"""Goals: disjunctions of conjunctions of on/under/inhand propositions (docs/guide/world.md#goals).

A language model answers ``[['on(red_box, rack)', 'on(blue_box, rack)'], ['on(red_box, rack)']]``;
:func:`parse_goal` turns that into a :class:`Goal`, :func:`validate_goal` checks it against the
grounded proposition set of the scene, and :func:`goal_satisfied` is the satisfaction function
F_sat: any alternative whose every proposition holds.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass

from t2m_core.domain.literals import (
    LiteralSyntaxError,
    extract_first_list,
    format_string_list,
    parse_string_lists,
)
from t2m_core.domain.predicates import Scene, evaluate
from t2m_core.domain.propositions import GOAL_PREDICATES, Proposition, PropositionError, validate_proposition
from t2m_core.domain.relations import symbolic_state
from t2m_core.domain.state import GeometricState
from t2m_core.errors import T2MError


class GoalError(T2MError, ValueError):
    """A goal that cannot be parsed, or that uses something outside the scene's proposition set."""


@dataclass(frozen=True)
class Goal:
    """A goal in disjunctive normal form.

    Attributes:
        alternatives: the disjuncts; each is a conjunction of propositions, in the order given, with
            duplicates removed. Never empty, and no alternative is empty.
    """

    alternatives: tuple[tuple[Proposition, ...], ...]

    def __post_init__(self) -> None:
        alternatives = tuple(
            tuple(dict.fromkeys(Proposition.coerce(p) for p in alternative)) for alternative in self.alternatives
        )
        if not alternatives:
            raise GoalError("a goal needs at least one alternative", "write e.g. [['on(red_box, rack)']]")
        for index, alternative in enumerate(alternatives, start=1):
            if not alternative:
                raise GoalError(f"goal alternative {index} is empty", "every inner list needs a proposition")
        object.__setattr__(self, "alternatives", alternatives)

    @classmethod
    def from_lists(cls, alternatives: Iterable[Iterable[Proposition | str]]) -> Goal:
        """Build from lists of propositions or proposition strings (syntax-checked)."""
        return cls(tuple(tuple(Proposition.coerce(p) for p in alternative) for alternative in alternatives))

    def to_lists(self) -> list[list[str]]:
        """JSON-ready ``[['on(a, b)', ...], ...]``."""
        return [[str(p) for p in alternative] for alternative in self.alternatives]

    def __str__(self) -> str:
        """Python spelling with single quotes, as in prompts: ``[['on(a, b)'], ['inhand(c)']]``."""
        return "[" + ", ".join(format_string_list(alt) for alt in self.to_lists()) + "]"

    def __len__(self) -> int:
        return len(self.alternatives)

    def __iter__(self) -> Iterator[tuple[Proposition, ...]]:
        return iter(self.alternatives)

    @property
    def propositions(self) -> tuple[Proposition, ...]:
        """Every distinct proposition, in first-mention order."""
        return tuple(dict.fromkeys(itertools.chain.from_iterable(self.alternatives)))

    def satisfied_by(self, relations: Iterable[Proposition | str]) -> bool:
        """Symbolic satisfaction: some alternative is a subset of ``relations``."""
        true = {Proposition.coerce(r) for r in relations}
        return any(all(p in true for p in alternative) for alternative in self.alternatives)


def parse_goal(text: str, *, extract: bool = False) -> Goal:
    """Parse a goal written as a Python/JSON list of lists of proposition strings.

    Accepts single or double quotes, any whitespace, trailing commas, one enclosing code fence and
    any spacing inside a proposition (``on(a,b)`` becomes ``on(a, b)``). Syntax only: check the
    names with :func:`validate_goal`.

    Args:
        text: e.g. ``"[['on(red_box, rack)'], ['on(blue_box,rack)']]"``.
        extract: take the first bracketed list out of surrounding prose (language-model answers).

    Raises:
        GoalError: naming the offending position or entry.
    """
    try:
        body = extract_first_list(text) if extract else text
        value = parse_string_lists(body)
    except LiteralSyntaxError as error:
        hint = "write a list of lists, e.g. [['on(a, b)']]"
        raise GoalError(f"cannot parse the goal: {error.message}", hint) from None
    if not value:
        raise GoalError("the goal is an empty list", "write at least one alternative, e.g. [['on(a, b)']]")
    alternatives: list[tuple[Proposition, ...]] = []
    for i, alternative in enumerate(value, start=1):
        if not isinstance(alternative, list):
            raise GoalError(
                f"goal alternative {i} is the string {alternative!r}, not a list",
                "a goal is a list of lists: wrap each alternative in brackets, e.g. [['on(a, b)']]",
            )
        props: list[Proposition] = []
        for j, entry in enumerate(alternative, start=1):
            if not isinstance(entry, str):
                raise GoalError(f"goal alternative {i}, entry {j} is a list; expected a proposition string")
            try:
                props.append(Proposition.parse(entry))
            except LiteralSyntaxError as error:
                raise GoalError(f"goal alternative {i}, entry {j} ({entry!r}): {error.message}", error.hint) from None
        alternatives.append(tuple(props))
    return Goal(tuple(alternatives))


def grounded_propositions(object_names: Sequence[str]) -> tuple[Proposition, ...]:
    """𝒫, the propositions a goal may use: inhand(x) for every object, on(x, y) and under(x, y) for every
    ordered pair of distinct objects, the table included."""
    props = [Proposition("inhand", (x,)) for x in object_names]
    for x, y in itertools.permutations(object_names, 2):
        props += [Proposition("on", (x, y)), Proposition("under", (x, y))]
    return tuple(props)


def validate_goal(goal: Goal, object_names: Sequence[str]) -> None:
    """Check that every proposition of ``goal`` belongs to 𝒫 of this scene.

    Raises:
        GoalError: naming the unknown predicate or object (listing what exists), a wrong arity, or
            an object related to itself.
    """
    for proposition in goal.propositions:
        try:
            validate_proposition(proposition, object_names, GOAL_PREDICATES)
        except PropositionError as error:
            raise GoalError(f"invalid goal proposition: {error.message}", error.hint) from None
        if len(set(proposition.args)) != len(proposition.args):
            raise GoalError(
                f"invalid goal proposition {proposition}: an object cannot be related to itself",
                "on(x, y) and under(x, y) need two different objects",
            )


def goal_satisfied(goal: Goal, state: GeometricState, object_names: Sequence[str] | None = None) -> bool:
    """F_sat: some alternative holds entirely under the geometry-only checks.
    Used on predicted states; ``on`` does not require uprightness."""
    return goal.satisfied_by(symbolic_state(state, object_names))


def goal_satisfied_full(
    goal: Goal, state: GeometricState, context: Iterable[Proposition | str] = ()
) -> bool:
    """Ground-truth task success: some alternative holds under the full checks
    (``on`` requires uprightness unless ``tippable`` is in ``context``)."""
    scene = Scene(state, context)
    return any(all(evaluate(p, scene, full=True) for p in alternative) for alternative in goal.alternatives)
