"""The workspace-aware symbolic model and BFS of the subgoal-completion metric (docs/guide/tasks.md#success-and-subgoal-completion)."""

from __future__ import annotations

import pytest

from t2m_core.domain.goals import Goal
from t2m_core.domain.propositions import Proposition
from t2m_core.domain.skills import SkillCall
from t2m_core.tasks import list_tasks, load_task
from t2m_core.tasks.symbolic_model import applicable, apply, groundings, initial_facts, replay, shortest_plan

MINIMAL_PLAN_LENGTH = {"task0": 6, "task1": 6, "task2": 6, "task3": 7, "task4": 5, "task5": 7, "task6": 9}


def call(text: str) -> SkillCall:
    name, rest = text.split("(")
    return SkillCall(name, tuple(a.strip() for a in rest.rstrip(")").split(",")))


def test_initial_facts_drop_sampling_only_predicates() -> None:
    facts = {str(p) for p in initial_facts(load_task("task1"))}
    assert "inworkspace(table)" in facts
    assert {"infront(cyan_box, rack)", "nonblocking(rack, cyan_box)", "beyondworkspace(rack)"} <= facts
    assert not any(f.startswith(("free", "aligned", "poslimit")) for f in facts)


@pytest.mark.parametrize("task", list_tasks(), ids=lambda t: t.id)
def test_reference_skeleton_replays_and_bfs_finds_the_minimal_length(task) -> None:
    facts, applied = replay(task, task.reference_skeleton)
    assert applied == len(task.reference_skeleton)
    assert task.goal.satisfied_by(facts)
    result = shortest_plan(initial_facts(task), task.goal, task.objects)
    assert result.plan is not None and not result.timed_out
    assert len(result.plan) == MINIMAL_PLAN_LENGTH[task.id] == len(task.reference_skeleton)


def test_boxes_beyond_the_workspace_must_be_pulled_first() -> None:
    task = load_task("task4")
    facts = initial_facts(task)
    assert not applicable(call("pick(blue_box)"), facts)
    facts = apply(call("pick(hook)"), facts)
    assert applicable(call("pull(blue_box, hook)"), facts)
    facts = apply(call("pull(blue_box, hook)"), facts)
    assert Proposition("inworkspace", ("blue_box",)) in facts
    assert Proposition("beyondworkspace", ("blue_box",)) not in facts
    assert not applicable(call("pull(blue_box, hook)"), facts)
    facts = apply(call("place(hook, table)"), facts)
    assert applicable(call("pick(blue_box)"), facts)


def test_push_needs_a_clear_obstruction_zone() -> None:
    task = load_task("task1")
    facts = apply(call("pick(hook)"), initial_facts(task))
    assert not applicable(call("push(cyan_box, hook, rack)"), facts)  # yellow and blue obstruct
    # After clearing both boxes to the table (they land in the operational zone, in front of the rack)…
    facts = initial_facts(task)
    for step in ("pick(yellow_box)", "place(yellow_box, table)", "pick(blue_box)", "place(blue_box, table)"):
        assert applicable(call(step), facts), step
        facts = apply(call(step), facts)
    assert Proposition("infront", ("yellow_box", "rack")) in facts
    facts = apply(call("pick(hook)"), facts)
    assert applicable(call("push(cyan_box, hook, rack)"), facts)
    facts = apply(call("push(cyan_box, hook, rack)"), facts)
    assert {Proposition("under", ("cyan_box", "rack")), Proposition("beyondworkspace", ("cyan_box",))} <= facts
    assert Proposition("infront", ("cyan_box", "rack")) not in facts


def test_replay_stops_at_the_first_inapplicable_skill() -> None:
    task = load_task("task0")
    facts, applied = replay(task, [call("pick(blue_box)"), call("pick(cyan_box)"), call("place(blue_box, rack)")])
    assert applied == 1
    assert Proposition("inhand", ("blue_box",)) in facts


def test_search_limits() -> None:
    task = load_task("task6")
    assert shortest_plan(initial_facts(task), task.goal, task.objects, max_depth=8).plan is None
    timed = shortest_plan(initial_facts(task), task.goal, task.objects, timeout_s=0.0)
    assert timed.timed_out and timed.plan is None
    unreachable = Goal.from_lists([["on(rack, hook)"]])
    assert shortest_plan(initial_facts(task), unreachable, task.objects).plan is None
    done = Goal.from_lists([["on(hook, table)"]])
    assert shortest_plan(initial_facts(task), done, task.objects).plan == ()


def test_groundings_are_well_typed() -> None:
    calls = groundings(("table", "rack", "hook", "red_box"))
    assert [str(c) for c in calls if c.name == "pick"] == ["pick(hook)", "pick(red_box)"]
    assert [str(c) for c in calls if c.name == "push"] == ["push(red_box, hook, rack)"]
