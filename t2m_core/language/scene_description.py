"""What the language model is told about a scene: its objects and their relationships
(docs/guide/world.md#relations-the-language-model-sees). Workspace membership is never described:
reachability is left to the Q-values."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from t2m_core.domain.literals import format_string_list
from t2m_core.domain.relations import relation_strings
from t2m_core.domain.state import GeometricState


@dataclass(frozen=True)
class SceneDescription:
    """The current block's first lines.

    Attributes:
        objects: object names in task order, ``table`` included.
        relationships: true on/under/inhand relations, e.g. ``('on(rack, table)', 'inhand(hook)')``.
        instruction: the human instruction.
    """

    objects: tuple[str, ...]
    relationships: tuple[str, ...]
    instruction: str

    def lines(self) -> list[str]:
        """``Available scene objects``, ``Object relationships`` and ``Human instruction`` lines."""
        return [
            f"Available scene objects: {format_string_list(self.objects)}",
            f"Object relationships: {format_string_list(self.relationships)}",
            f"Human instruction: {self.instruction}",
        ]


def relationships_of(state: GeometricState, objects: Sequence[str]) -> tuple[str, ...]:
    """The relationship strings of a (real or predicted) state, in the canonical order."""
    return tuple(relation_strings(state, objects))


def describe_state(instruction: str, state: GeometricState, objects: Sequence[str]) -> SceneDescription:
    """The description of ``state`` for ``instruction``."""
    return SceneDescription(tuple(objects), relationships_of(state, objects), instruction.strip())


def describe_task_scene(task: Any, seed: int) -> tuple[SceneDescription, GeometricState]:
    """Sample the task's initial state for ``seed`` (domain sampler, no physics) and describe it.

    Returns:
        the description and the sampled resting state.
    """
    from t2m_core.domain.sampling import sample_task

    state = sample_task(task, seed).state
    return describe_state(task.instruction, state, task.objects), state
