"""A plugin of test doubles that worker processes load by name (``T2M_PLUGINS``), so that a Ray
worker, which never sees a test's in-process registry, builds the same components as the test.

The simulator is :class:`MortalSimulator`: it dies mid-task, once, when told to. Never shipped."""

from __future__ import annotations

import os
import signal

from pydantic import BaseModel, ConfigDict

from t2m_core.hookspecs import hookimpl
from t2m_core.plugin_specs import FeasibilityPlannerSpec, LanguageModelSpec, SimulatorSpec, SkillLibrarySpec
from tests.core.plugin_doubles import ScriptedSimulator
from tests.plugins.t2m_planners.planner_doubles import RuleModel, SymbolicFeasibility

MODULE = "tests.executors.cluster_doubles"
"""This module's import name, the value of ``T2M_PLUGINS``."""
KILL_MARKER = "T2M_TEST_KILL_MARKER"
"""Environment variable naming a file: the first worker to delete it kills itself."""
SELECTION = ["--set", "simulator.name=mortal", "--set", "simulator.options.always_succeed=true", "--set", "language_model.name=rule",
             "--set", "skills.name=none", "--set", "feasibility_planner.name=symbolic", "--set", "output.video=false"]
"""``t2m eval`` overrides that run episodes on these doubles."""
GOAL = "[['on(yellow_box, rack)', 'on(cyan_box, rack)', 'on(blue_box, rack)']]"
SOLUTION = ("[['pick(yellow_box)', 'place(yellow_box, rack)', 'pick(cyan_box)', 'place(cyan_box, rack)', 'pick(blue_box)', "
            "'place(blue_box, rack)']]")


class MortalOptions(BaseModel):
    """Options of the mortal simulator."""

    model_config = ConfigDict(extra="forbid")

    always_succeed: bool = False
    """Every primitive succeeds (an episode executes its whole plan); by default, those whose
    action's first coordinate is positive (data with successes and failures)."""


class MortalSimulator(ScriptedSimulator):
    """A :class:`ScriptedSimulator` whose second execution kills its own process with SIGKILL, as an
    out-of-memory killer would, if the file named by ``T2M_TEST_KILL_MARKER`` exists; it deletes
    the file first, so that one worker dies."""

    def __init__(self, options: MortalOptions) -> None:
        super().__init__(True if options.always_succeed else lambda action: action[0] > 0.0)

    def execute(self, primitive, arguments, action):
        marker = os.environ.get(KILL_MARKER)
        if self.executions == 1 and marker:
            try:
                os.unlink(marker)  # whoever deletes it dies: exactly one worker
            except FileNotFoundError:
                pass
            else:
                os.kill(os.getpid(), signal.SIGKILL)
        return super().execute(primitive, arguments, action)


@hookimpl
def t2m_register_simulators():
    return [SimulatorSpec(name="mortal", factory=MortalSimulator, options=MortalOptions, summary="test double that can die")]


@hookimpl
def t2m_register_language_models():
    return [LanguageModelSpec(name="rule", factory=lambda _options: RuleModel(goal=GOAL, sequences=SOLUTION), summary="test double")]


@hookimpl
def t2m_register_skills():
    return [SkillLibrarySpec(name="none", factory=lambda _options: {}, summary="test double")]


@hookimpl
def t2m_register_feasibility_planners():
    return [FeasibilityPlannerSpec(name="symbolic", factory=lambda _options: SymbolicFeasibility(), summary="test double")]
