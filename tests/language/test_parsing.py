"""Parsing and validating model answers (docs/guide/prompts.md#parsing-and-validation)."""

from __future__ import annotations

import pytest

from t2m_core.domain.goals import GoalError
from t2m_core.domain.skills import SkillCall, SkillError
from t2m_core.language.parsing import parse_goal_answer, parse_skill_candidates, parse_skill_sequences

OBJECTS = ("table", "rack", "hook", "red_box", "blue_box")


def test_goal_answer_in_prose_with_loose_spacing():
    goal = parse_goal_answer("Sure! ```[['on(red_box,rack)'], [\"on(blue_box, rack)\"]]``` done", OBJECTS)
    assert goal.to_lists() == [["on(red_box, rack)"], ["on(blue_box, rack)"]]


@pytest.mark.parametrize(
    "answer, problem",
    [
        ("[['on(green_box, rack)']]", "green_box"),
        ("[['near(red_box, rack)']]", "near"),
        ("[['on(red_box, red_box)']]", "itself"),
        ("['on(red_box, rack)']", "not a list"),
        ("no list here", "no list"),
    ],
)
def test_invalid_goal_answers_name_the_problem(answer, problem):
    with pytest.raises(GoalError, match=problem):
        parse_goal_answer(answer, OBJECTS)


def test_candidates_drop_invalid_entries_dedupe_and_cap_at_k():
    answer = "['pick(hook)', 'pick(hook)', 'pick(red_box, table)', 'fly(hook)', 'pick(green_box)', " \
             "'place(hook, table)', 'pull(red_box, hook)', 'pull(blue_box, hook)', 'pick(table)', 'pick(rack)']"
    result = parse_skill_candidates(answer, OBJECTS, k=5)
    assert [str(call) for call in result.calls] == [
        "pick(hook)", "place(hook, table)", "pull(red_box, hook)", "pull(blue_box, hook)", "pick(table)"
    ]
    reasons = " | ".join(rejected.reason for rejected in result.rejected)
    assert "takes 1 argument" in reasons and "unknown skill 'fly'" in reasons and "green_box" in reasons
    assert "more than K = 5" in reasons
    typed = parse_skill_candidates("['pick(table)', 'pick(hook)']", OBJECTS, check_types=True)
    assert typed.calls == [SkillCall("pick", ("hook",))]
    with pytest.raises(SkillError, match="cannot read a list"):
        parse_skill_candidates("pick(hook)", OBJECTS)


def test_sequences_drop_any_sequence_with_an_invalid_entry():
    answer = "[['pick(hook)', 'pull(red_box, hook)'], ['pick(hook)', 'fly(hook)'], [], ['pick(red_box)']]"
    sequences, rejected = parse_skill_sequences(answer, OBJECTS)
    assert [[str(c) for c in sequence] for sequence in sequences] == [["pick(hook)", "pull(red_box, hook)"], ["pick(red_box)"]]
    assert len(rejected) == 2
    flat, _ = parse_skill_sequences("['pick(red_box)', 'place(red_box, rack)']", OBJECTS)
    assert len(flat) == 1 and len(flat[0]) == 2
