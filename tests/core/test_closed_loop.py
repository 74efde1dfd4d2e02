"""Closed-loop execution of a fixed skeleton: what is re-planned, from where, and when it stops
(docs/guide/feasibility.md#closed-loop-execution)."""

from __future__ import annotations

import numpy as np
import pytest

from t2m_core.closed_loop import execute_closed_loop
from t2m_core.domain.skills import SkillCall
from t2m_core.protocols import PlanResult
from t2m_core.tasks import load_task
from tests.core.plugin_doubles import ScriptedSimulator

SKELETON = [SkillCall("pick", ("red_box",)), SkillCall("place", ("red_box", "rack")), SkillCall("pick", ("blue_box",))]


class RecordingPlanner:
    """Plans ``k`` skills with actions ``call index + step / 10`` in every component (so each plan
    is told apart), and records the ``initial_actions`` of every call (``None`` when none)."""

    def __init__(self) -> None:
        self.starts: list[np.ndarray | None] = []

    def plan(self, observation, skeleton, skills, object_names, *, initial_actions=None) -> PlanResult:
        self.starts.append(None if initial_actions is None else np.asarray(initial_actions).copy())
        call = len(self.starts)
        actions = np.array([[call + step / 10] * 4 for step in range(len(skeleton))], np.float32) / 10
        states = np.repeat(np.asarray(observation, np.float32)[None], len(skeleton) + 1, axis=0)
        values = np.full(len(skeleton), 0.9, np.float32)
        return PlanResult(actions, states, values, np.zeros(len(skeleton), bool), float(np.prod(values)))


def simulator(success=True) -> ScriptedSimulator:
    sim = ScriptedSimulator(success)
    sim.reset(load_task("task3"), seed=0)
    return sim


def test_every_skill_is_planned_again_from_scratch_by_default() -> None:
    planner = RecordingPlanner()
    sim = simulator()
    result = execute_closed_loop(sim, planner, {}, SKELETON, sim.objects)
    assert result.success and len(result.steps) == 3 and planner.starts == [None, None, None]
    # each executed action is the first of the plan made just before it
    assert [float(s.action[0]) for s in result.steps] == pytest.approx([0.1, 0.2, 0.3])


def test_the_recorded_action_is_the_executed_one_bit_for_bit() -> None:
    executed = []
    sim = simulator(success=lambda action: executed.append(np.array(action)) or True)
    result = execute_closed_loop(sim, RecordingPlanner(), {}, SKELETON, sim.objects)
    recorded = [np.asarray(step.summary()["action"], np.float64) for step in result.steps]
    # the planned actions are float32 (0.1 is 0.10000000149...): more digits than four decimals keep
    assert all(np.array_equal(r, e) for r, e in zip(recorded, executed, strict=True)) and len(recorded) == 3
    assert any(not np.array_equal(r, np.round(r, 4)) for r in recorded)


def test_planned_starts_take_the_accepted_plan_then_each_plans_remaining_actions() -> None:
    planner = RecordingPlanner()
    sim = simulator()
    accepted = PlanResult(np.full((3, 4), -0.7, np.float32), np.zeros((4, 8, 12), np.float32), np.ones(3, np.float32), np.zeros(3, bool), 1.0)
    execute_closed_loop(sim, planner, {}, SKELETON, sim.objects, replan_start="planned", accepted=accepted)
    np.testing.assert_array_equal(planner.starts[0], np.full((3, 4), -0.7, np.float32))
    # the second re-plan starts from the first plan's actions for skills 2 and 3 (0.11, 0.12)
    np.testing.assert_allclose(planner.starts[1][:, 0], [0.11, 0.12], atol=1e-6)
    np.testing.assert_allclose(planner.starts[2][:, 0], [0.21], atol=1e-6)


def test_planned_starts_without_an_accepted_plan_start_the_first_skill_from_scratch() -> None:
    planner = RecordingPlanner()
    sim = simulator()
    execute_closed_loop(sim, planner, {}, SKELETON, sim.objects, replan_start="planned")
    assert planner.starts[0] is None and planner.starts[1].shape == (2, 4)


def test_execution_stops_at_the_first_failure_and_open_loop_plans_once() -> None:
    planner = RecordingPlanner()
    sim = simulator(success=lambda action: action[0] < 0.15)  # the second executed action is 0.2
    result = execute_closed_loop(sim, planner, {}, SKELETON, sim.objects)
    assert not result.success and [s.result.success for s in result.steps] == [True, False]
    planner = RecordingPlanner()
    sim = simulator()
    result = execute_closed_loop(sim, planner, {}, SKELETON, sim.objects, closed_loop=False)
    assert len(planner.starts) == 1 and [float(s.action[0]) for s in result.steps] == pytest.approx([0.1, 0.11, 0.12])


def test_an_unknown_replan_start_is_refused() -> None:
    with pytest.raises(ValueError, match="replan_start must be 'policy' or 'planned'"):
        execute_closed_loop(simulator(), RecordingPlanner(), {}, SKELETON, (), replan_start="warm")


class StartDependentPlanner(RecordingPlanner):
    """A RecordingPlanner whose plans value their first skill ``from_policy`` without
    ``initial_actions`` and ``from_planned`` with them."""

    def __init__(self, from_policy: float, from_planned: float) -> None:
        super().__init__()
        self.first_values = {False: from_policy, True: from_planned}

    def plan(self, observation, skeleton, skills, object_names, *, initial_actions=None) -> PlanResult:
        plan = super().plan(observation, skeleton, skills, object_names, initial_actions=initial_actions)
        values = plan.values.copy()
        values[0] = self.first_values[initial_actions is not None]
        return PlanResult(plan.actions, plan.states, values, plan.ood, float(np.prod(values)))


ACCEPTED = PlanResult(np.full((3, 4), -0.7, np.float32), np.zeros((4, 8, 12), np.float32), np.ones(3, np.float32), np.zeros(3, bool), 1.0)


def test_a_low_valued_replan_is_planned_again_from_the_planned_actions_and_the_better_one_executed() -> None:
    planner = StartDependentPlanner(from_policy=0.05, from_planned=0.8)
    sim = simulator()
    result = execute_closed_loop(sim, planner, {}, SKELETON, sim.objects, accepted=ACCEPTED, retry_below=0.1)
    # each skill: the policy start (0.05 < 0.1), then the planned one; 6 plans for 3 skills
    assert len(planner.starts) == 6 and [s is None for s in planner.starts] == [True, False] * 3
    np.testing.assert_array_equal(planner.starts[1], ACCEPTED.actions)
    assert [s.retry["chosen"] for s in result.steps] == ["second"] * 3
    assert result.steps[0].retry["first_p_success"] == pytest.approx(0.05 * 0.81) and result.steps[0].plan.values[0] == pytest.approx(0.8)
    # the executed action is the second plan's (call 2: 0.2), and the next re-plan starts from its remaining actions
    assert float(result.steps[0].action[0]) == pytest.approx(0.2)
    np.testing.assert_allclose(planner.starts[3][:, 0], [0.21, 0.22], atol=1e-6)
    assert result.steps[0].summary()["retry"]["chosen"] == "second"


def test_a_retry_keeps_the_first_plan_when_the_second_is_no_better_and_needs_planned_actions() -> None:
    planner = StartDependentPlanner(from_policy=0.05, from_planned=0.01)
    sim = simulator()
    result = execute_closed_loop(sim, planner, {}, SKELETON, sim.objects, accepted=ACCEPTED, retry_below=0.1)
    assert [s.retry["chosen"] for s in result.steps] == ["first"] * 3 and float(result.steps[0].action[0]) == pytest.approx(0.1)
    # without an accepted plan the first skill has no planned actions to start from: no second plan for it
    planner = StartDependentPlanner(from_policy=0.05, from_planned=0.8)
    sim = simulator()
    result = execute_closed_loop(sim, planner, {}, SKELETON, sim.objects, retry_below=0.1)
    assert result.steps[0].retry is None and "retry" not in result.steps[0].summary() and len(planner.starts) == 5


def test_a_retry_from_planned_starts_plans_again_from_scratch_and_none_above_the_floor() -> None:
    planner = StartDependentPlanner(from_policy=0.8, from_planned=0.05)
    sim = simulator()
    result = execute_closed_loop(sim, planner, {}, SKELETON, sim.objects, accepted=ACCEPTED, replan_start="planned", retry_below=0.1)
    assert [s is None for s in planner.starts] == [False, True] * 3 and [s.retry["chosen"] for s in result.steps] == ["second"] * 3
    planner = StartDependentPlanner(from_policy=0.5, from_planned=0.8)
    sim = simulator()
    result = execute_closed_loop(sim, planner, {}, SKELETON, sim.objects, accepted=ACCEPTED, retry_below=0.1)
    assert len(planner.starts) == 3 and all(s.retry is None for s in result.steps)
