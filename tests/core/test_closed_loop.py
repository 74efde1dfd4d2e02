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
