"""Hook specifications of t2m: the whole plugin API.

A plugin is a module with functions decorated by :data:`hookimpl`, exposed through an entry point in
group ``t2m``::

    # pyproject.toml of your package
    [project.entry-points.t2m]
    my_plugin = "my_package.hooks"

Each registration hook returns a list of spec objects (:mod:`t2m_core.plugin_specs`). Keep the hooks
module import-light: point at factories by import path so ``t2m list-plugins`` stays fast.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import pluggy

if TYPE_CHECKING:
    from t2m_core.plugin_specs import (
        FeasibilityPlannerSpec,
        LanguageModelSpec,
        SceneParserSpec,
        SimulatorSpec,
        SkillLibrarySpec,
        TaskPlannerSpec,
    )

PROJECT_NAME = "t2m"
"""pluggy project name and entry-point group."""

hookspec = pluggy.HookspecMarker(PROJECT_NAME)
hookimpl = pluggy.HookimplMarker(PROJECT_NAME)


@hookspec
def t2m_register_simulators() -> list[SimulatorSpec]:
    """Register physics backends.

    Example::

        from t2m_core.hookspecs import hookimpl
        from t2m_core.plugin_specs import SimulatorSpec

        @hookimpl
        def t2m_register_simulators():
            return [SimulatorSpec(name="mysim", factory="my_package.sim:MySimulator",
                                  options=MySimOptions, summary="My physics engine")]
    """


@hookspec
def t2m_register_skills() -> list[SkillLibrarySpec]:
    """Register skill libraries (a factory returns ``{"pick": Skill, "place": Skill, ...}``).

    Example::

        @hookimpl
        def t2m_register_skills():
            return [SkillLibrarySpec(name="my-skills", factory="my_package.skills:load_library",
                                     options=MySkillOptions, summary="Skills trained on my robot")]
    """


@hookspec
def t2m_register_feasibility_planners() -> list[FeasibilityPlannerSpec]:
    """Register feasibility planners.

    Example::

        @hookimpl
        def t2m_register_feasibility_planners():
            return [FeasibilityPlannerSpec(name="mppi", factory="my_package.mppi:MPPIPlanner",
                                           options=MPPIOptions, summary="MPPI over learned dynamics")]
    """


@hookspec
def t2m_register_language_models() -> list[LanguageModelSpec]:
    """Register language model backends; aliases let users type familiar model names.

    Example::

        @hookimpl
        def t2m_register_language_models():
            return [LanguageModelSpec(name="my-llm", aliases=("my-llm-large",),
                                      factory="my_package.llm:MyModel", options=MyLLMOptions,
                                      summary="My hosted model")]
    """


@hookspec
def t2m_register_scene_parsers() -> list[SceneParserSpec]:
    """Register scene parsers.

    Example::

        @hookimpl
        def t2m_register_scene_parsers():
            return [SceneParserSpec(name="scene-file", factory="t2m_scene_file.parser:SceneFileParser",
                                    options=SceneFileOptions, summary="Read a measured scene from YAML")]
    """


@hookspec
def t2m_register_task_planners() -> list[TaskPlannerSpec]:
    """Register task planners.

    Example::

        @hookimpl
        def t2m_register_task_planners():
            return [TaskPlannerSpec(name="beam", factory="my_package.beam:BeamPlanner",
                                    options=BeamOptions, summary="Beam search over skill sequences")]
    """


REGISTRATION_HOOKS: dict[str, str] = {
    "simulator": "t2m_register_simulators",
    "skill_library": "t2m_register_skills",
    "feasibility_planner": "t2m_register_feasibility_planners",
    "language_model": "t2m_register_language_models",
    "scene_parser": "t2m_register_scene_parsers",
    "task_planner": "t2m_register_task_planners",
}
"""Component kind -> the registration hook that provides it."""
