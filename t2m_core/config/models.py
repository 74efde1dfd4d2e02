"""The run configuration: pydantic models that reject unknown keys.

A run is one YAML document::

    task: task0
    seed: 0
    simulator: {name: mujoco, options: {}}
    language_model: {name: local, options: {}}
    scene_parser: {name: ground-truth, options: {}}
    skills: {name: tableenv, options: {}}
    feasibility_planner: {name: policy-cem, options: {}}
    task_planner: {name: hybrid, options: {}}
    prompts: {example_plans: steps}
    run: {closed_loop: true}
    output: {video: true, video_fps: 30}

Each component block names a plugin and its options; the options are validated against that
plugin's own model by :func:`t2m_core.config.resolve.resolve_config` when a registry is given.
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field


class ComponentConfig(BaseModel):
    """Which plugin provides a component, and its options (validated by the plugin's own model)."""

    model_config = ConfigDict(extra="forbid")

    name: str = Field(min_length=1, description="Component name or alias, as listed by `t2m list-plugins`.")
    options: dict[str, Any] = Field(
        default_factory=dict, description="Options of the chosen component; see its options model."
    )


class RunSettings(BaseModel):
    """How an episode is executed."""

    model_config = ConfigDict(extra="forbid")

    closed_loop: bool = Field(
        True,
        description="Re-optimise the remaining skills' parameters from the observed state after every "
        "executed skill (docs/guide/feasibility.md#closed-loop-execution); false executes the open-loop plan.",
    )
    replan_start: Literal["policy", "planned"] = Field(
        "policy",
        description="Where each closed-loop re-plan starts: from scratch (policy, paper) or from the actions "
        "planned before for the same skills, the task planner's accepted plan first (planned; "
        "docs/guide/feasibility.md#closed-loop-execution).",
    )
    retry_below: float | None = Field(
        None,
        ge=0.0,
        le=1.0,
        description="When a closed-loop re-plan values the skill it is about to execute below this, plan once more from "
        "the other start (replan_start's alternative) and execute the plan with the higher p_success; null: never "
        "(docs/guide/feasibility.md#closed-loop-execution).",
    )


class PromptSettings(BaseModel):
    """How the language prompts are written (docs/guide/prompts.md)."""

    model_config = ConfigDict(extra="forbid")

    example_plans: Literal["steps", "sequence"] = Field(
        "steps",
        description="How the next-skill and scoring prompts' in-context examples write their plans: one "
        "'Executed action:' line per skill (steps), or the reference's one 'Top robot action sequence:' list "
        "(sequence); docs/guide/deviations.md#examples-written-as-executed-steps.",
    )


class OutputSettings(BaseModel):
    """What a run writes into its run directory (the directory itself is a machine setting, T2M_RUNS_DIR)."""

    model_config = ConfigDict(extra="forbid")

    video: bool = Field(True, description="Record an MP4 video of the execution.")
    video_fps: int = Field(30, gt=0, le=240, description="Frames per second of the video.")


class RunConfig(BaseModel):
    """Everything that describes one run; written, fully resolved, into the run directory."""

    model_config = ConfigDict(extra="forbid")

    task: str = Field("task0", min_length=1, description="Task name from `t2m tasks` (task0 ... task6).")
    seed: int = Field(0, ge=0, description="Base seed; the accepted seed may be larger (seed, seed + 1, ...).")
    simulator: ComponentConfig = Field(
        default_factory=lambda: ComponentConfig(name="mujoco"), description="Physics backend."
    )
    language_model: ComponentConfig = Field(
        default_factory=lambda: ComponentConfig(name="local"),
        description="Language model backend: the embedded local model by default; any litellm model by name.",
    )
    scene_parser: ComponentConfig = Field(
        default_factory=lambda: ComponentConfig(name="ground-truth"),
        description="Turns the observation into the geometric state.",
    )
    skills: ComponentConfig | None = Field(
        default_factory=lambda: ComponentConfig(name="tableenv"),
        description="Skill library: the learned TableEnv skills with their shipped checkpoints by default.",
    )
    feasibility_planner: ComponentConfig | None = Field(
        default_factory=lambda: ComponentConfig(name="policy-cem"),
        description="Feasibility planner: STAP PolicyCEM by default.",
    )
    task_planner: ComponentConfig | None = Field(
        default_factory=lambda: ComponentConfig(name="hybrid"),
        description="Task planner: Text2Motion's hybrid by default.",
    )
    prompts: PromptSettings = Field(default_factory=PromptSettings)
    run: RunSettings = Field(default_factory=RunSettings)
    output: OutputSettings = Field(default_factory=OutputSettings)


COMPONENT_BLOCKS: dict[str, str] = {
    "simulator": "simulator",
    "language_model": "language_model",
    "scene_parser": "scene_parser",
    "skills": "skill_library",
    "feasibility_planner": "feasibility_planner",
    "task_planner": "task_planner",
}
"""Config block -> registry kind of the component it selects."""
