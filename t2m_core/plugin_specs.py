"""Spec objects that registration hooks return: one per component a plugin provides.

A spec names a component, its aliases and its options model, and points at its factory by import
path, so that registering a plugin never imports its heavy dependencies. The registry
(:mod:`t2m_core.registry`) owns the policy: unique names, alias resolution, "did you mean".
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

from pydantic import BaseModel, ConfigDict


class NoOptions(BaseModel):
    """Options model of a component that takes none."""

    model_config = ConfigDict(extra="forbid")


@dataclass(frozen=True)
class ComponentSpec:
    """Describes one component a plugin provides.

    Attributes:
        name: the name users select it by (``--sim mujoco``); lowercase, ``-`` or ``_`` separated.
        factory: ``"module.path:attribute"`` of a callable taking the validated options model and
            returning the component, or the callable itself. Import paths are resolved lazily by
            :meth:`load_factory`, so heavy imports happen only when the component is used.
        options: pydantic model of the component's options (reject unknown keys).
        aliases: other names that resolve to this component (``gpt-4`` for the litellm model).
        summary: one line for ``t2m list-plugins``.
    """

    kind: ClassVar[str] = ""

    name: str
    factory: str | Callable[..., Any]
    options: type[BaseModel] = NoOptions
    aliases: tuple[str, ...] = ()
    summary: str = ""

    def load_factory(self) -> Callable[..., Any]:
        """Import and return the factory callable."""
        return load_callable(self.factory, f"factory of {self.kind} {self.name!r}")

    def create(self, options: BaseModel | dict[str, Any] | None = None) -> Any:
        """Validate ``options`` against :attr:`options` and build the component."""
        validated = options if isinstance(options, self.options) else self.options.model_validate(options or {})
        return self.load_factory()(validated)


def load_callable(target: str | Callable[..., Any], what: str) -> Callable[..., Any]:
    """``target`` itself if callable, else the attribute its ``"module:attribute"`` path names
    (imported now). ``what`` names it in the error."""
    if callable(target):
        return target
    module_name, _, attribute = target.partition(":")
    if not attribute:
        raise ValueError(f"{what} must look like 'module:attribute', got {target!r}")
    return getattr(importlib.import_module(module_name), attribute)


@dataclass(frozen=True)
class SimulatorSpec(ComponentSpec):
    """A physics backend (:class:`t2m_core.protocols.Simulator`)."""

    kind: ClassVar[str] = "simulator"


@dataclass(frozen=True)
class SkillLibrarySpec(ComponentSpec):
    """A skill library: its factory returns a mapping of skill name to :class:`~t2m_core.protocols.Skill`.

    A library that can be trained, calibrated and reported on by ``t2m train``, ``t2m calibrate`` and
    ``t2m skills report`` names those entry points (``"module:function"``, imported only when used):

    Attributes:
        trainer: ``train(skill, models, data, checkpoint, overrides, on_progress, simulator, more_train) -> dict``
            (``more_train``: further dataset directories whose train splits are appended; ``init_from``
            and ``anchor`` are passed as keywords only when given).
        calibrator: ``calibrate(skill, data, checkpoint) -> dict``.
        reporter: ``report(checkpoints, data, episodes, out, simulator) -> dict``, and the keywords
            ``ood_detectors`` and ``published_ood`` when ``t2m skills report`` is given them.
    """

    kind: ClassVar[str] = "skill_library"

    trainer: str | Callable[..., Any] | None = None
    calibrator: str | Callable[..., Any] | None = None
    reporter: str | Callable[..., Any] | None = None


@dataclass(frozen=True)
class FeasibilityPlannerSpec(ComponentSpec):
    """A feasibility planner (:class:`t2m_core.protocols.FeasibilityPlanner`)."""

    kind: ClassVar[str] = "feasibility_planner"


@dataclass(frozen=True)
class NamePrefix:
    """A family of names that select a language model with one option taken from the name.

    ``NamePrefix("ollama/", option="model")`` makes ``--llm ollama/llama3`` select the model with
    ``model="ollama/llama3"``; with ``strip=True`` (``NamePrefix("litellm/", "model", strip=True)``)
    ``--llm litellm/claude-3-5-haiku`` gives ``model="claude-3-5-haiku"``.
    """

    prefix: str
    option: str
    strip: bool = False


@dataclass(frozen=True)
class LanguageModelSpec(ComponentSpec):
    """A language model backend (:class:`t2m_core.protocols.LanguageModel`).

    Attributes:
        alias_options: options an alias implies, ``{"gpt-4o": {"model": "gpt-4o"}}``; explicit
            options win. Every key must be one of :attr:`aliases`.
        name_prefixes: name families that select this backend (:class:`NamePrefix`).
    """

    kind: ClassVar[str] = "language_model"

    alias_options: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    name_prefixes: tuple[NamePrefix, ...] = ()

    def __post_init__(self) -> None:
        unknown_aliases = sorted(set(self.alias_options) - set(self.aliases))
        if unknown_aliases:
            raise ValueError(
                f"language model {self.name!r}: alias_options names {unknown_aliases}, which are not among its "
                f"aliases {list(self.aliases)}; add them to aliases or drop them"
            )
        options = set(self.options.model_fields)
        implied = {option for values in self.alias_options.values() for option in values}
        implied |= {prefix.option for prefix in self.name_prefixes}
        if implied - options:
            raise ValueError(
                f"language model {self.name!r}: alias_options / name_prefixes set {sorted(implied - options)}, "
                f"which {self.options.__name__} does not have (its options: {sorted(options)})"
            )


@dataclass(frozen=True)
class SceneParserSpec(ComponentSpec):
    """A scene parser (:class:`t2m_core.protocols.SceneParser`)."""

    kind: ClassVar[str] = "scene_parser"


@dataclass(frozen=True)
class TaskPlannerSpec(ComponentSpec):
    """A task planner (:class:`t2m_core.protocols.TaskPlanner`)."""

    kind: ClassVar[str] = "task_planner"


SPEC_TYPES: dict[str, type[ComponentSpec]] = {
    spec.kind: spec
    for spec in (SimulatorSpec, SkillLibrarySpec, FeasibilityPlannerSpec, LanguageModelSpec, SceneParserSpec, TaskPlannerSpec)
}
"""Component kind -> spec type."""
