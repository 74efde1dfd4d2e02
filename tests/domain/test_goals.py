"""Goal parsing, validation and the satisfaction function (docs/guide/world.md#goals)."""

from __future__ import annotations

import itertools
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from t2m_core.domain.geometry import axis_angle_to_quat
from t2m_core.domain.goals import (
    Goal,
    GoalError,
    goal_satisfied,
    goal_satisfied_full,
    grounded_propositions,
    parse_goal,
    validate_goal,
)
from t2m_core.domain.propositions import Proposition
from t2m_core.domain.relations import symbolic_state
from t2m_core.domain.state import ObjectPose
from tests.domain.scenes import RACK_IN_WORKSPACE, SCENE_ORDER, on_table, random_scenes, scene

OBJECTS = ["table", "rack", "hook", "red_box", "blue_box"]
EXPECTED = Goal.from_lists([["on(red_box, rack)", "on(blue_box, rack)"], ["inhand(hook)"]])


@pytest.mark.parametrize(
    "text",
    [
        "[['on(red_box, rack)', 'on(blue_box, rack)'], ['inhand(hook)']]",
        '[["on(red_box,rack)", "on(blue_box , rack)"], ["inhand( hook )"]]',
        "```python\n[['on(red_box, rack)', 'on(blue_box, rack)'],\n ['inhand(hook)'],]\n```",
        "```\n[ [ 'on(red_box, rack)' , \"on(blue_box, rack)\" , ] , [ 'inhand(hook)' ] ]\n```\n",
        "  [['on(red_box, rack)', 'on(blue_box, rack)', 'on(red_box, rack)'], ['inhand(hook)']]  ",
    ],
)
def test_goal_formats(text: str) -> None:
    assert parse_goal(text) == EXPECTED


def test_goal_formatting_round_trips() -> None:
    assert str(EXPECTED) == "[['on(red_box, rack)', 'on(blue_box, rack)'], ['inhand(hook)']]"
    assert EXPECTED.to_lists() == [["on(red_box, rack)", "on(blue_box, rack)"], ["inhand(hook)"]]
    assert parse_goal(str(EXPECTED)) == EXPECTED
    assert len(EXPECTED) == 2
    assert [str(p) for p in EXPECTED.propositions] == ["on(red_box, rack)", "on(blue_box, rack)", "inhand(hook)"]


def test_goal_is_extracted_from_prose_only_when_asked() -> None:
    answer = "Here is the goal: [['on(red_box, rack)']] as requested."
    assert parse_goal(answer, extract=True) == Goal.from_lists([["on(red_box, rack)"]])
    with pytest.raises(GoalError, match="position 0"):
        parse_goal(answer)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("['on(red_box, rack)']", "not a list"),
        ("[]", "empty list"),
        ("[[]]", "alternative 1 is empty"),
        ("[['on(red_box, rack)'], ['on(red_box rack)']]", "alternative 2, entry 1"),
        ("[['on(red_box, rack)']", "expected ']'"),
        ("[[on(red_box, rack)]]", "position 2"),
        ("[['on(red_box, rack)']] and more", "unexpected text"),
        ("[['on(red_box, rack)', ['inhand(hook)']]]", "entry 2 is a list"),
        ("[['on(red_box, rack)\\n']]", "unsupported escape"),
        ("[('on(red_box, rack)',)]", "position 1"),
        ("[['on(red_box, rack)]]", "unterminated string"),
        ("no list here", "no list"),
    ],
)
def test_malformed_goals_are_rejected_with_a_message(text: str, message: str) -> None:
    with pytest.raises(GoalError, match=message.replace("(", r"\(").replace("[", r"\[")):
        parse_goal(text, extract=message == "no list")


@settings(max_examples=200, deadline=None)
@given(st.text(alphabet="[]'\",() onrack_boxinhd\n`", max_size=40))
def test_parser_never_fails_with_anything_but_a_goal_error(text: str) -> None:
    try:
        goal = parse_goal(text)
    except GoalError as error:
        assert str(error)
    else:
        assert parse_goal(str(goal)) == goal


GROUNDED = grounded_propositions(list(SCENE_ORDER))
goals = st.lists(
    st.lists(st.sampled_from(GROUNDED), min_size=1, max_size=4), min_size=1, max_size=4
).map(Goal.from_lists)


@given(goals, st.sampled_from(["'", '"']), st.sampled_from(["", " ", "\n  "]))
def test_goal_round_trips_through_text(goal: Goal, quote: str, space: str) -> None:
    text = "[" + f",{space}".join(
        "[" + f",{space}".join(f"{quote}{p.predicate}({','.join(p.args)}){quote}" for p in alt) + "]" for alt in goal
    ) + "]"
    assert parse_goal(text) == goal
    assert parse_goal(str(goal)) == goal
    assert Goal.from_lists(goal.to_lists()) == goal
    validate_goal(goal, list(SCENE_ORDER))


def test_grounded_proposition_set() -> None:
    props = grounded_propositions(["table", "rack", "red_box"])
    n = 3
    assert len(props) == n + 2 * n * (n - 1)
    texts = {str(p) for p in props}
    assert {"inhand(table)", "on(rack, table)", "under(red_box, rack)", "on(table, red_box)"} <= texts
    assert not any(p.predicate != "inhand" and p.args[0] == p.args[1] for p in props)
    assert len(texts) == len(props)


def test_validate_goal_names_the_problem() -> None:
    validate_goal(parse_goal("[['on(red_box, rack)'], ['under(blue_box, rack)', 'inhand(hook)']]"), OBJECTS)
    with pytest.raises(GoalError, match="unknown object 'green_box'") as caught:
        validate_goal(parse_goal("[['on(green_box, rack)']]"), OBJECTS)
    assert "table, rack, hook, red_box, blue_box" in str(caught.value)
    with pytest.raises(GoalError, match="unknown predicate 'free'") as caught:
        validate_goal(parse_goal("[['free(red_box)']]"), OBJECTS)
    assert "on, under, inhand" in str(caught.value)
    with pytest.raises(GoalError, match="related to itself"):
        validate_goal(parse_goal("[['on(red_box, red_box)']]"), OBJECTS)
    with pytest.raises(GoalError, match="takes 2"):
        validate_goal(parse_goal("[['on(red_box)']]"), OBJECTS)


def test_goal_satisfaction_on_a_scene() -> None:
    state = scene(
        rack=RACK_IN_WORKSPACE,
        red_box=ObjectPose([0.40, -0.33, 0.16 + 0.059]),
        blue_box=on_table("blue_box", 0.6, 0.2),
    )
    assert goal_satisfied(parse_goal("[['on(red_box, rack)']]"), state)
    assert not goal_satisfied(parse_goal("[['on(red_box, rack)', 'on(blue_box, rack)']]"), state)
    assert goal_satisfied(parse_goal("[['on(red_box, rack)', 'on(blue_box, rack)'], ['on(blue_box, table)']]"), state)
    assert not goal_satisfied(parse_goal("[['inhand(hook)']]"), state)  # absent object
    assert goal_satisfied_full(parse_goal("[['on(red_box, rack)', 'on(blue_box, table)']]"), state)


def test_full_success_needs_upright_objects() -> None:
    lying = ObjectPose([0.44, -0.33, 0.16 + 0.025], axis_angle_to_quat([math.pi / 2, 0, 0]))
    state = scene(rack=RACK_IN_WORKSPACE, red_box=lying)
    goal = parse_goal("[['on(red_box, rack)']]")
    assert goal_satisfied(goal, state)  # geometry-only: the planner's check on predicted states
    assert not goal_satisfied_full(goal, state)  # ground truth
    assert goal_satisfied_full(goal, state, ["tippable(red_box)"])


@settings(max_examples=80, deadline=None)
@given(random_scenes(), goals)
def test_satisfaction_equals_its_definition(state, goal: Goal) -> None:
    relations = set(symbolic_state(state))
    expected = any(all(p in relations for p in alternative) for alternative in goal.alternatives)
    assert goal_satisfied(goal, state) == expected
    # The full check differs only by uprightness, so it can only be stricter.
    if goal_satisfied_full(goal, state):
        assert goal_satisfied(goal, state)


def test_goal_rejects_empty_structures() -> None:
    with pytest.raises(GoalError):
        Goal(())
    with pytest.raises(GoalError):
        Goal(((),))
    assert Goal(((Proposition("inhand", ("hook",)),),)).satisfied_by(["inhand(hook)"])
    assert not any(
        Goal.from_lists([[p]]).satisfied_by([]) for p in itertools.islice(GROUNDED, 5)
    )
