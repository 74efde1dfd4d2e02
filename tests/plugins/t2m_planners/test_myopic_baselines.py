"""saycan-gs and innermono-gs: one skill at a time by usefulness x current-state value, stop()
handling, scene feedback (docs/guide/planners.md#saycan-gs)."""

from __future__ import annotations

import numpy as np

from t2m_core.domain.goals import parse_goal
from t2m_core.language.scene_description import describe_state
from t2m_core.language.session import LanguageSession
from t2m_core.protocols import PlanningContext
from t2m_core.tasks import load_task
from t2m_planners.myopic import MyopicPlanner
from t2m_planners.options import MyopicOptions
from tests.core.plugin_doubles import ScriptedSimulator
from tests.plugins.t2m_planners.planner_doubles import RuleModel


class ConstantSkill:
    """Every member says ``value``; the policy's action is zeros."""

    action_dim, ood_threshold = 4, 0.1

    def __init__(self, name: str, value: float) -> None:
        self.name, self.value = name, value

    def policy(self, states):
        return np.zeros((len(states), 4), np.float32)

    def q_values(self, states, actions):
        return np.full((len(states), 8), self.value, np.float32)


def episode(model: RuleModel, feedback: bool, values: dict[str, float], skill_type: type = ConstantSkill):
    task = load_task("task0")
    simulator = ScriptedSimulator(success=True)
    reset = simulator.reset(task, seed=0)
    session = LanguageSession(model, describe_state(task.instruction, reset.state, task.objects), constrained=False, grounded=False)
    skills = {name: skill_type(name, value) for name, value in values.items()}
    events: list = []
    context = PlanningContext(task.instruction, parse_goal("[['on(yellow_box, rack)']]"), session, skills, None, task.objects,
                              reset.observation, simulator=simulator, on_event=events.append)
    planner = MyopicPlanner(MyopicOptions(max_depth=3), scene_feedback=feedback)
    return planner.plan(context), model, simulator, events


def test_the_baselines_execute_the_best_scored_skill_until_the_step_budget() -> None:
    model = RuleModel(next_skills=["['pick(yellow_box)', 'pick(cyan_box)']"], scores={"pick(yellow_box)": -1.0, "pick(cyan_box)": -1.5, "stop()": -9.0})
    plan, model, simulator, events = episode(model, False, {"pick": 0.9})
    assert plan.executed and [str(c) for c in plan.skeleton] == ["pick(yellow_box)"] * 3 and simulator.executions == 3
    assert plan.llm_calls == 6 and model.requests == ["next", "score"] * 3
    stop = [c for c in events[0]["candidates"] if c["skill"] == "stop()"][0]
    assert stop["value"] == 0.5  # stop() is not the model's first choice


def test_stop_ends_the_episode_when_the_model_ranks_it_first() -> None:
    model = RuleModel(next_skills=["['pick(yellow_box)']"], scores={"pick(yellow_box)": -3.0, "stop()": -0.5})
    plan, _, simulator, events = episode(model, False, {"pick": 0.99})
    assert plan.skeleton == [] and simulator.executions == 0
    assert [c for c in events[0]["candidates"] if c["chosen"]][0]["skill"] == "stop()"


def test_an_infeasible_skill_loses_to_stop_and_ood_counts_as_infeasible() -> None:
    model = RuleModel(next_skills=["['pick(yellow_box)']"], scores={"pick(yellow_box)": -1.0, "stop()": -1.2})
    plan, _, simulator, _ = episode(model, False, {"pick": 0.05})
    assert simulator.executions == 0  # 0.05 x usefulness < 0.5 x usefulness of stop()


class DetectedSkill(ConstantSkill):
    """Its members agree (variance 0), but its separate OOD detector flags every pair."""

    def ood_variance(self, states, actions, q_members):
        return np.full(len(states), 0.25, np.float32)


def test_a_separate_detector_masks_the_current_state_value() -> None:
    model = RuleModel(next_skills=["['pick(yellow_box)']"], scores={"pick(yellow_box)": -1.0, "stop()": -1.2})
    _, _, simulator, events = episode(model, False, {"pick": 0.9}, DetectedSkill)
    assert simulator.executions == 0  # valued 0.9 by its members, 0 once flagged: stop() wins
    picked = [c for c in events[0]["candidates"] if c["skill"] == "pick(yellow_box)"][0]
    assert picked["value"] == 0.0


def test_innermono_shows_the_observed_relationships_after_each_execution() -> None:
    def prompts(feedback: bool) -> list[str]:
        model = RuleModel(next_skills=["['pick(yellow_box)']"], scores={"pick(yellow_box)": -1.0, "stop()": -9.0})
        captured = []
        original = model.complete
        model.complete = lambda prompt, **kw: (captured.append(prompt), original(prompt, **kw))[1]
        episode(model, feedback, {"pick": 0.9})
        return captured

    assert "New object relationships" in prompts(True)[1].split("Human instruction")[-1]
    assert "New object relationships" not in prompts(False)[1].split("Human instruction")[-1]
