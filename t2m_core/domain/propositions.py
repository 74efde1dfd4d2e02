"""Propositions of the TableEnv world: the grounded-predicate type and its parser, each predicate's
arity, the canonical order in which initial states are sampled (docs/guide/world.md#canonical-order)
and the check that a proposition fits a scene.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from t2m_core.domain.constants import ZONES
from t2m_core.domain.literals import format_call, parse_call
from t2m_core.errors import T2MError

PREDICATE_ORDER: tuple[str, ...] = (
    "handlegrasp",
    "upperhandlegrasp",
    "free",
    "aligned",
    "tippable",
    "poslimit",
    "inworkspace",
    "incollisionzone",
    "inoperationalzone",
    "inobstructionzone",
    "beyondworkspace",
    "inoodzone",
    "under",
    "infront",
    "nonblocking",
    "on",
    "inhand",
)
"""Canonical predicate order (docs/guide/world.md#canonical-order): initial states are sampled in this order (``on`` before ``inhand``)."""

PREDICATE_ARITY: dict[str, int] = {
    name: (2 if name in ("under", "infront", "nonblocking", "on") else 1) for name in PREDICATE_ORDER
}
"""Number of arguments of every predicate."""

GOAL_PREDICATES: tuple[str, ...] = ("on", "under", "inhand")
"""The only predicates of goals, the language interface and task success."""

ZONE_PREDICATES: tuple[str, ...] = tuple(ZONES)
"""The zone predicates, in canonical order."""



class PropositionError(T2MError, ValueError):
    """A proposition names an unknown predicate or object, or has the wrong number of arguments."""


@dataclass(frozen=True, order=True)
class Proposition:
    """A grounded predicate, e.g. ``on(red_box, rack)``.

    Attributes:
        predicate: the predicate's name (``"on"``).
        args: object names, in order.
    """

    predicate: str
    args: tuple[str, ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "args", tuple(self.args))

    def __str__(self) -> str:
        return format_call(self.predicate, self.args)

    @classmethod
    def parse(cls, text: str) -> Proposition:
        """Parse ``"on(red_box,rack)"`` (any spacing). Syntax only: see :func:`validate_proposition`.

        Raises:
            LiteralSyntaxError: naming the offending position.
        """
        name, args = parse_call(text, "proposition")
        return cls(name, args)

    @classmethod
    def coerce(cls, value: Proposition | str) -> Proposition:
        """``value`` itself, or parsed from a string."""
        return value if isinstance(value, Proposition) else cls.parse(value)

    @property
    def canonical_rank(self) -> int:
        """Index of the predicate in :data:`PREDICATE_ORDER` (unknown predicates sort last)."""
        try:
            return PREDICATE_ORDER.index(self.predicate)
        except ValueError:
            return len(PREDICATE_ORDER)


def canonical_order(propositions: Iterable[Proposition | str]) -> tuple[Proposition, ...]:
    """Sort by :data:`PREDICATE_ORDER`, keeping the given order within one predicate."""
    props = [Proposition.coerce(p) for p in propositions]
    return tuple(sorted(props, key=lambda p: p.canonical_rank))  # sorted() is stable


def validate_proposition(
    proposition: Proposition,
    object_names: Sequence[str],
    predicates: Sequence[str] = PREDICATE_ORDER,
) -> None:
    """Check the predicate is one of ``predicates``, the arity is right and every argument is in
    ``object_names``.

    Raises:
        PropositionError: naming the problem and listing what exists.
    """
    if proposition.predicate not in predicates:
        raise PropositionError(
            f"unknown predicate {proposition.predicate!r} in {proposition}",
            f"use one of: {', '.join(predicates)}",
        )
    arity = PREDICATE_ARITY[proposition.predicate]
    if len(proposition.args) != arity:
        raise PropositionError(
            f"{proposition} has {len(proposition.args)} argument(s); {proposition.predicate} takes {arity}",
            f"write {proposition.predicate}({', '.join('xy'[:arity])})",
        )
    for arg in proposition.args:
        if arg not in object_names:
            raise PropositionError(
                f"unknown object {arg!r} in {proposition}", f"objects in this scene: {', '.join(object_names)}"
            )
