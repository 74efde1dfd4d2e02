"""Enumerations over symbolic states: every grounding of a skill in a scene, and the 1 296 symbolic
states and valid / invalid groundings of skill-data generation (docs/guide/skills.md#data-generation)."""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass

from t2m_core.domain.objects import ObjectKind, object_spec
from t2m_core.domain.propositions import Proposition, canonical_order
from t2m_core.domain.skills import RECEPTACLE, SkillCall, SkillError, signature_hint
from t2m_core.domain.symbolic_effects import SymbolicFacts, precondition_problems


def _kind(name: str) -> ObjectKind:
    return object_spec(name).kind

# --------------------------------------------------------------------------------------------------

DATA_MOVABLES: tuple[str, ...] = ("hook", "red_box", "blue_box", "yellow_box", "cyan_box")
"""The five movable objects of the data-generation scene, in enumeration order."""


@dataclass(frozen=True)
class SymbolicState:
    """One enumerated symbolic state of skill-data generation.

    Attributes:
        objects: present objects in observation order (table, rack, then present movables).
        propositions: its propositions in canonical order (aligned, poslimit, zone, on, inhand).
    """

    objects: tuple[str, ...]
    propositions: tuple[Proposition, ...]

    @property
    def facts(self) -> SymbolicFacts:
        """The propositions as a set."""
        return frozenset(self.propositions)

    @property
    def rack_zone(self) -> str:
        """``"inworkspace"`` or ``"beyondworkspace"``."""
        return next(p.predicate for p in self.propositions if p.args == ("rack",) and p.predicate.endswith("workspace"))


def enumerate_symbolic_states() -> tuple[SymbolicState, ...]:
    """The 1 296 symbolic states of skill-data generation: each movable absent, in hand, on the table or on the rack
    (at most one in hand: 648 assignments), times the rack in or beyond the workspace. The rack is
    always on the table, aligned and poslimit."""
    states = []
    for zone in ("inworkspace", "beyondworkspace"):
        for assignment in itertools.product(("absent", "inhand", "table", "rack"), repeat=len(DATA_MOVABLES)):
            if assignment.count("inhand") > 1:
                continue
            present = [m for m, where in zip(DATA_MOVABLES, assignment) if where != "absent"]
            props = [
                Proposition("aligned", ("rack",)),
                Proposition("poslimit", ("rack",)),
                Proposition(zone, ("rack",)),
                Proposition("on", ("rack", "table")),
            ]
            for movable, where in zip(DATA_MOVABLES, assignment):
                if where == "inhand":
                    props.append(Proposition("inhand", (movable,)))
                elif where != "absent":
                    props.append(Proposition("on", (movable, where)))
            states.append(SymbolicState(("table", "rack", *present), canonical_order(props)))
    return tuple(states)


def candidate_groundings(skill: str, object_names: Sequence[str]) -> tuple[SkillCall, ...]:
    """Every grounding of ``skill`` considered by data generation: pick over every object; place and
    pull over ordered pairs of distinct objects; push over ordered pairs of distinct
    non-receptacles with each receptacle as the third argument. (These reproduce the original's
    task counts, see :func:`enumerate_groundings`.)"""
    if skill == "pick":
        return tuple(SkillCall("pick", (a,)) for a in object_names)
    if skill in ("place", "pull"):
        return tuple(SkillCall(skill, pair) for pair in itertools.permutations(object_names, 2))
    if skill == "push":
        receptacles = [n for n in object_names if _kind(n) in RECEPTACLE]
        others = [n for n in object_names if _kind(n) not in RECEPTACLE]
        return tuple(
            SkillCall("push", (a, b, c)) for c in receptacles for a, b in itertools.permutations(others, 2)
        )
    raise SkillError(f"unknown skill {skill!r}", signature_hint(False))


def enumerate_groundings(
    skill: str, state: SymbolicState
) -> tuple[tuple[SkillCall, ...], tuple[SkillCall, ...]]:
    """``(valid, invalid)`` groundings of ``skill`` in an enumerated state.

    A push whose only failing condition is "the rack is beyond the workspace" is in neither set:
    it is symbolically sensible but not trained. Over the 1 296 states this gives the original's
    counts: pick 1 620 / 5 562, place 1 620 / 32 292, pull 216 / 33 696, push 108 / 21 924.
    """
    valid, invalid = [], []
    rack_only = {f"{c} is not beyond the workspace" for c in state.objects if _kind(c) in RECEPTACLE}
    for call in candidate_groundings(skill, state.objects):
        problems = precondition_problems(call, state.facts)
        if not problems:
            valid.append(call)
        elif not set(problems) <= rack_only:
            invalid.append(call)
    return tuple(valid), tuple(invalid)
