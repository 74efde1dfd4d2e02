"""The goal evaluation set: its size and balance, every scene samples, every true goal is reachable
within d_max skills, and "no goal" cases say why."""

from __future__ import annotations

import pytest

from t2m_core.errors import T2MError
from t2m_core.language.goal_cases import (
    NO_GOAL_KINDS,
    describe_case,
    initial_facts,
    load_goal_cases,
    load_heldout_cases,
)
from t2m_core.language.goal_judging import judge_goal, reachable_states
from t2m_core.tasks import list_tasks

CASES = load_goal_cases()
HELDOUT = load_heldout_cases()


def test_the_set_is_large_varied_and_apart_from_the_suite():
    assert len(CASES) >= 40 and len({case.id for case in CASES}) == len(CASES)
    tags = {tag for case in CASES for tag in case.tags}
    assert {"list", "category", "count", "all", "inhand", "under", "clear", *NO_GOAL_KINDS} <= tags
    suite = {task.instruction.lower() for task in list_tasks()}
    assert not suite & {case.instruction.lower() for case in CASES}


def test_the_heldout_set_is_apart_from_the_main_set_and_the_suite():
    assert len(HELDOUT) >= 10 and len({case.id for case in HELDOUT}) == len(HELDOUT)
    seen = {task.instruction.lower() for task in list_tasks()} | {case.instruction.lower() for case in CASES}
    assert not seen & {case.instruction.lower() for case in HELDOUT}
    assert not {case.scene.name for case in CASES} & {case.scene.name for case in HELDOUT}


@pytest.mark.parametrize("cases", [CASES, HELDOUT], ids=["main", "heldout"])
def test_every_scene_samples_and_every_true_goal_is_reachable(cases):
    scenes = {case.scene.name: case for case in cases}
    states = {name: reachable_states(initial_facts(case.scene), case.scene.objects) for name, case in scenes.items()}
    for case in scenes.values():
        described = describe_case(case, seed=0)
        assert described.objects == case.scene.objects and described.relationships
    for case in cases:
        judgement = judge_goal(case.goal, case.goal, states[case.scene.name])
        assert judgement.strict, f"{case.id}: {case.goal} is not reachable within 10 skills"
        assert (case.goal is None) == (case.no_goal is not None)


def test_a_malformed_set_names_the_case(tmp_path):
    bad = tmp_path / "set.yaml"
    bad.write_text(
        "version: 1\nscenes: {s: {objects: [table, rack, red_box], initial_state: ['on(red_box, table)']}}\n"
        "cases: [{id: x, scene: s, tags: [explicit], instruction: hi, goal: [['on(red_box, shelf)']]}]\n"
    )
    with pytest.raises(T2MError, match="case 'x'"):
        load_goal_cases(bad)
