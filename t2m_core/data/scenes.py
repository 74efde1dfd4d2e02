"""What one transition of skill data is drawn from: a symbolic state, a grounding of the skill in
it, and the scene's distractor boxes (docs/guide/skills.md#data-generation).

A :class:`DataTask` quacks like a :class:`t2m_core.tasks.Task` for :meth:`Simulator.reset`: it has
``id``, ``objects`` and ``initial_state``. Its initial state holds only the symbolic state's
propositions (no ``free`` or ``nonblocking`` rejection predicates), so infeasible situations occur
as they would in the world.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from t2m_core.domain.enumeration import DATA_MOVABLES, SymbolicState, enumerate_groundings, enumerate_symbolic_states
from t2m_core.domain.objects import ObjectKind, object_spec
from t2m_core.domain.propositions import Proposition, canonical_order
from t2m_core.domain.skills import SkillCall

DATA_SKILLS: tuple[str, ...] = ("pick", "place", "pull", "push")
"""The learned skills, in the order the prompts list them (index by name, never by position)."""
HOOK_MASS = 0.5
"""Share of the valid Pick / Place draws whose object is the hook (the rest: boxes)."""


@dataclass(frozen=True)
class DataTask:
    """A data-generation scene to reset a simulator to.

    Attributes:
        id: a readable label, ``"pick(red_box) @ state 17"``.
        objects: present objects in observation-row order (table, rack, then movables).
        initial_state: the propositions the reset samples and verifies.
        symbolic_state: index of the scene's symbolic state in :func:`enumerate_symbolic_states`.
        call: the skill call to execute (or, in the invalid split, to encode).
    """

    id: str
    objects: tuple[str, ...]
    initial_state: tuple[Proposition, ...]
    symbolic_state: int
    call: SkillCall


@lru_cache(maxsize=1)
def symbolic_states() -> tuple[SymbolicState, ...]:
    """The 1 296 enumerated symbolic states (cached)."""
    return enumerate_symbolic_states()


@lru_cache(maxsize=1)
def _state_index() -> dict[frozenset[Proposition], int]:
    return {state.facts: index for index, state in enumerate(symbolic_states())}


@lru_cache(maxsize=16)
def groundings(skill: str, valid: bool) -> tuple[tuple[int, SkillCall], ...]:
    """Every ``(state index, call)`` pair of ``skill`` that is symbolically valid (``valid``) or
    invalid, over the enumerated states."""
    pairs = []
    for index, state in enumerate(symbolic_states()):
        good, bad = enumerate_groundings(skill, state)
        pairs.extend((index, call) for call in (good if valid else bad))
    return tuple(pairs)


def draw_grounding(skill: str, valid: bool, rng: np.random.Generator) -> tuple[int, SkillCall]:
    """One ``(state index, call)`` pair. Valid Pick and Place put :data:`HOOK_MASS` of the draws on
    calls whose object is the hook; every other draw is uniform over the pairs."""
    pairs = groundings(skill, valid)
    if valid and skill in ("pick", "place"):
        on_hook = rng.random() < HOOK_MASS
        pairs = _split_by_hook(skill)[0 if on_hook else 1]
    return pairs[int(rng.integers(len(pairs)))]


@lru_cache(maxsize=4)
def _split_by_hook(skill: str) -> tuple[tuple[tuple[int, SkillCall], ...], tuple[tuple[int, SkillCall], ...]]:
    pairs = groundings(skill, True)
    return tuple(p for p in pairs if p[1].args[0] == "hook"), tuple(p for p in pairs if p[1].args[0] != "hook")


def with_distractors(state_index: int, rng: np.random.Generator) -> int:
    """The state with a uniform number (0 .. all) of the absent boxes added on the table, chosen at
    random: the explicit distractor-count sampler."""
    state = symbolic_states()[state_index]
    absent = [m for m in DATA_MOVABLES if m not in state.objects and object_spec(m).kind is ObjectKind.BOX]
    count = int(rng.integers(len(absent) + 1))
    if count == 0:
        return state_index
    added = rng.choice(len(absent), size=count, replace=False)
    facts = state.facts | {Proposition("on", (absent[i], "table")) for i in added}
    return _state_index()[facts]


def data_task(state_index: int, call: SkillCall) -> DataTask:
    """The :class:`DataTask` of a state and a call."""
    state = symbolic_states()[state_index]
    return DataTask(
        id=f"{call} @ state {state_index}",
        objects=state.objects,
        initial_state=canonical_order(state.propositions),
        symbolic_state=state_index,
        call=call,
    )


def draw_data_task(skill: str, valid: bool, rng: np.random.Generator) -> DataTask:
    """A grounding (valid or invalid) of ``skill`` in a state with distractors."""
    state_index, call = draw_grounding(skill, valid, rng)
    return data_task(with_distractors(state_index, rng), call)

