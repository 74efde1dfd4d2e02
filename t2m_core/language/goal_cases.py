"""The language goal evaluation set (docs/guide/language-models.md#the-goal-evaluation-set):
instructions written for t2m, apart from the task suite, each on a scene that the world's sampler
instantiates, with its ground-truth goal or the kind of reason no goal expresses it.

Usage::

    for case in load_goal_cases():
        scene = describe_case(case, seed=0)          # sampled scene, relationships, instruction
        states = reachable_states(initial_facts(case.scene), case.scene.objects)
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from t2m_core.domain.goals import Goal, GoalError, validate_goal
from t2m_core.domain.propositions import Proposition, PropositionError, canonical_order, validate_proposition
from t2m_core.errors import T2MError
from t2m_core.language.scene_description import SceneDescription, describe_state

NO_GOAL_KINDS = ("absent", "unknown", "impossible", "unrelated")
"""Why no goal expresses an instruction: it names a TableEnv object missing from the scene, names
something that is no TableEnv object, asks for what the skills cannot reach, or asks for nothing a
goal can express."""

TAGS = ("explicit", "list", "category", "count", "all", "inhand", "under", "clear", *NO_GOAL_KINDS)
"""What a case exercises."""

DEFAULT_CASES = "goals.yaml"
HELDOUT_CASES = "heldout.yaml"
"""A smaller set written before the prompts were tuned on the main set's failures, kept out of tuning."""


class _SceneFile(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    objects: list[str] = Field(min_length=2, max_length=7)
    initial_state: list[str]


class _CaseFile(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    id: str
    scene: str
    tags: list[Literal[TAGS]] = Field(min_length=1)  # type: ignore[valid-type]
    instruction: str = Field(min_length=1)
    goal: list[list[str]] | None = None
    no_goal: Literal[NO_GOAL_KINDS] | None = None  # type: ignore[valid-type]


class _SetFile(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    version: Literal[1]
    scenes: dict[str, _SceneFile]
    cases: list[_CaseFile] = Field(min_length=1)


@dataclass(frozen=True)
class GoalScene:
    """A scene template: objects in observation order and initial-state propositions (as in a task)."""

    name: str
    objects: tuple[str, ...]
    initial_state: tuple[Proposition, ...]


@dataclass(frozen=True)
class GoalCase:
    """One instruction with its ground truth.

    Attributes:
        id: ``"g01"`` ...
        scene: where it is asked.
        tags: what it exercises (:data:`TAGS`).
        instruction: the words.
        goal: the true goal alternatives, ``None`` when no goal expresses the instruction.
        no_goal: then, the kind of reason (:data:`NO_GOAL_KINDS`).
    """

    id: str
    scene: GoalScene
    tags: tuple[str, ...]
    instruction: str
    goal: Goal | None
    no_goal: str | None


def load_goal_cases(path: str | Path | None = None) -> tuple[GoalCase, ...]:
    """The cases of a goal-set file (the shipped main set by default; :func:`load_heldout_cases`
    for the held-out one).

    Raises:
        T2MError: a schema error, an unknown scene, an invalid proposition or goal, a case with both
            or neither of ``goal`` and ``no_goal``, or a repeated id; each names the case.
    """
    if path is None:
        return _shipped()
    return _parse(Path(path).read_text(encoding="utf-8"), str(path))


def load_heldout_cases() -> tuple[GoalCase, ...]:
    """The shipped held-out cases (:data:`HELDOUT_CASES`)."""
    return _shipped(HELDOUT_CASES)


@functools.cache
def _shipped(name: str = DEFAULT_CASES) -> tuple[GoalCase, ...]:
    text = resources.files("t2m_core.language").joinpath("evaluation", name).read_text(encoding="utf-8")
    return _parse(text, name)


def _parse(text: str, source: str) -> tuple[GoalCase, ...]:
    try:
        data = _SetFile.model_validate(yaml.safe_load(text))
    except ValidationError as error:
        raise T2MError(f"{source}: {error}", hint="see t2m_core/language/evaluation/goals.yaml") from None
    scenes = {}
    for name, scene in data.scenes.items():
        try:
            props = canonical_order(Proposition.parse(text) for text in scene.initial_state)
            for prop in props:
                validate_proposition(prop, scene.objects)
        except (PropositionError, ValueError) as error:
            raise T2MError(f"{source}: scene {name!r}: {error}") from None
        scenes[name] = GoalScene(name, tuple(scene.objects), tuple(props))
    cases, seen = [], set()
    for entry in data.cases:
        where = f"{source}: case {entry.id!r}"
        if entry.id in seen:
            raise T2MError(f"{where} is listed twice", hint="give every case its own id")
        seen.add(entry.id)
        if entry.scene not in scenes:
            raise T2MError(f"{where}: unknown scene {entry.scene!r}", hint=f"scenes: {sorted(scenes)}")
        if (entry.goal is None) == (entry.no_goal is None):
            raise T2MError(f"{where} needs exactly one of goal and no_goal")
        goal = None
        if entry.goal is not None:
            try:
                goal = Goal.from_lists(entry.goal)
                validate_goal(goal, scenes[entry.scene].objects)
            except (GoalError, ValueError) as error:
                raise T2MError(f"{where}: {error}") from None
        cases.append(GoalCase(entry.id, scenes[entry.scene], tuple(entry.tags), entry.instruction.strip(), goal, entry.no_goal))
    return tuple(cases)


def initial_facts(scene: GoalScene) -> frozenset[Proposition]:
    """The scene's symbolic initial state for the workspace-aware model: a task's (on, zone,
    infront and nonblocking facts, ``inworkspace(table)``) plus what starts in hand, which no task has."""
    from t2m_core.tasks.symbolic_model import initial_facts as task_facts

    held = {prop for prop in scene.initial_state if prop.predicate == "inhand"}
    return task_facts(scene) | held  # reads only ``initial_state``, as for a task


def describe_case(case: GoalCase, seed: int) -> SceneDescription:
    """The case's scene sampled for ``seed`` (domain sampler, no physics), described with its instruction."""
    from t2m_core.domain.sampling import sample_initial_state

    state = sample_initial_state(case.scene.objects, case.scene.initial_state, seed).state
    return describe_state(case.instruction, state, case.scene.objects)
