"""Throwaway plugins for registry and CLI tests (test doubles: never shipped)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from t2m_core.hookspecs import hookimpl
from t2m_core.plugin_specs import (
    FeasibilityPlannerSpec,
    LanguageModelSpec,
    SceneParserSpec,
    SimulatorSpec,
    SkillLibrarySpec,
    TaskPlannerSpec,
)


class ToySimOptions(BaseModel):
    """Options of the toy simulator."""

    model_config = ConfigDict(extra="forbid")

    timestep: float = Field(0.002, gt=0, description="seconds")
    substeps: int = Field(8, ge=1)


@dataclass
class ToySimulator:
    """A component that only remembers its options."""

    options: ToySimOptions


def plugin(**hooks: list[Any]) -> SimpleNamespace:
    """A plugin object whose registration hooks return the given spec lists."""
    namespace = SimpleNamespace()
    for hook_name, specs in hooks.items():

        def implementation(specs: list[Any] = specs) -> list[Any]:
            return list(specs)

        implementation.__name__ = hook_name
        setattr(namespace, hook_name, hookimpl(implementation))
    return namespace


def toy_simulator_spec(name: str = "toysim", aliases: tuple[str, ...] = ()) -> SimulatorSpec:
    return SimulatorSpec(name=name, aliases=aliases, factory=ToySimulator, options=ToySimOptions, summary="Toy physics")


class EveryKind:
    """A plugin providing one component of every kind, each hook written out as a plugin author would."""

    @hookimpl
    def t2m_register_simulators(self) -> list[SimulatorSpec]:
        return [toy_simulator_spec()]

    @hookimpl
    def t2m_register_skills(self) -> list[SkillLibrarySpec]:
        return [SkillLibrarySpec(name="toy-skills", factory=dict, summary="No skills")]

    @hookimpl
    def t2m_register_feasibility_planners(self) -> list[FeasibilityPlannerSpec]:
        return [FeasibilityPlannerSpec(name="toy-cem", factory="builtins:object", summary="Toy planner")]

    @hookimpl
    def t2m_register_language_models(self) -> list[LanguageModelSpec]:
        return [LanguageModelSpec(name="toy-llm", aliases=("gpt-toy",), factory="builtins:object", summary="Toy LM")]

    @hookimpl
    def t2m_register_scene_parsers(self) -> list[SceneParserSpec]:
        return [SceneParserSpec(name="toy-parser", factory="builtins:object", summary="Toy parser")]

    @hookimpl
    def t2m_register_task_planners(self) -> list[TaskPlannerSpec]:
        return [TaskPlannerSpec(name="toy-hybrid", factory="builtins:object", summary="Toy task planner")]


class ScriptedSimulator:
    """A simulator without physics: resets to the sampled scene of a task and seed, and reports every
    primitive with the scripted outcome without moving anything: ``success`` is a bool, or a rule of
    the ``(4,)`` action; a failure is a ``"collision"``. After ``interrupt_after`` executions it raises
    ``KeyboardInterrupt`` (a killed run)."""

    def __init__(self, success: bool | Callable[[Any], bool], interrupt_after: int | None = None) -> None:
        self.success = success
        self.interrupt_after = interrupt_after
        self.executions = 0
        self.state: Any = None
        self.objects: tuple[str, ...] = ()

    def reset(self, task: Any, *, seed: int) -> Any:
        from t2m_core.domain.sampling import sample_task
        from t2m_core.protocols import ResetResult

        sampled = sample_task(task, seed)
        self.state, self.objects = sampled.state, tuple(task.objects)
        return ResetResult(sampled.state, self.observation(), sampled.accepted_seed, sampled.rejections)

    def execute(self, primitive: str, arguments: Any, action: Any) -> Any:
        import numpy as np

        from t2m_core.protocols import PrimitiveResult

        self.executions += 1
        if self.interrupt_after is not None and self.executions > self.interrupt_after:
            raise KeyboardInterrupt
        success = bool(self.success(np.asarray(action))) if callable(self.success) else self.success
        return PrimitiveResult(success, not success, None if success else "collision", self.state, self.observation())

    def get_state(self) -> Any:
        return self.state

    def set_state(self, snapshot: Any) -> None:
        self.state = snapshot

    def geometric_state(self) -> Any:
        return self.state

    def observation(self) -> Any:
        from t2m_core.domain.observation import encode_observation

        return encode_observation(self.state, self.objects)

    def render(self, camera: str | None = None, *, depth: bool = False) -> Any:
        import numpy as np

        return np.zeros((8, 8, 3), dtype=np.uint8)

    def close(self) -> None:
        pass
