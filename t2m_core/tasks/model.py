"""The language task model (docs/guide/tasks.md#task-files): what one evaluation task is."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from t2m_core.domain.goals import Goal
from t2m_core.domain.objects import ObjectKind, object_spec
from t2m_core.domain.propositions import Proposition
from t2m_core.domain.skills import SkillCall

TASK_PROPERTIES: dict[str, str] = {
    "LH": "long-horizon: the solution needs five or more dependent skills",
    "LG": "lifted goal: the instruction names a class or a count, so several goal sets are valid",
    "PAP": "partial affordance perception: a needed precondition shows neither in the instruction nor in the scene",
}
"""Task property tags: long-horizon, lifted goal, partial affordance perception."""


@dataclass(frozen=True)
class Task:
    """One language task.

    Attributes:
        id: ``"task0"`` … ``"task6"``.
        name: the original's internal name (``"lh_lg_po_2"``).
        properties: tags of :data:`TASK_PROPERTIES` (``("LH", "LG", "PAP")``).
        paper_task: the paper's task number this most likely is (inferred), or ``None``.
        instruction: the instruction, verbatim.
        objects: object names in observation-row order (``table`` first).
        rack_zone: ``"inworkspace"`` or ``"beyondworkspace"``.
        initial_state: initial-state propositions in canonical predicate order
            (docs/guide/world.md#canonical-order).
        goal: the ground-truth goal alternatives.
        reference_skeleton: one minimal solution (never shown to the planners).
        source: the file it was loaded from, if any.
    """

    id: str
    name: str
    properties: tuple[str, ...]
    paper_task: int | None
    instruction: str
    objects: tuple[str, ...]
    rack_zone: str
    initial_state: tuple[Proposition, ...]
    goal: Goal
    reference_skeleton: tuple[SkillCall, ...]
    source: Path | None = None

    @property
    def boxes(self) -> tuple[str, ...]:
        """The task's boxes, in object order."""
        return tuple(n for n in self.objects if object_spec(n).kind is ObjectKind.BOX)

    @property
    def has_hook(self) -> bool:
        """Whether the hook is in the scene."""
        return "hook" in self.objects

    @property
    def initial_state_strings(self) -> tuple[str, ...]:
        """The initial state as strings, ``('free(hook)', ...)``."""
        return tuple(str(p) for p in self.initial_state)

    def summary(self) -> dict[str, object]:
        """JSON-ready description (``t2m tasks --json``)."""
        return {
            "id": self.id,
            "name": self.name,
            "properties": list(self.properties),
            "paper_task": self.paper_task,
            "instruction": self.instruction,
            "objects": list(self.objects),
            "rack_zone": self.rack_zone,
            "initial_state": list(self.initial_state_strings),
            "goal": self.goal.to_lists(),
            "reference_skeleton": [str(c) for c in self.reference_skeleton],
        }
