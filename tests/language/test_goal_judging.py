"""Semantic goal judgement: strict (same reachable states) and plan-level (shortest plans reach the
truth), and the "no valid goal" answer."""

from __future__ import annotations

from t2m_core.domain.goals import parse_goal
from t2m_core.domain.propositions import Proposition
from t2m_core.language.goal_judging import judge_goal, reachable_states

OBJECTS = ("table", "rack", "red_box", "blue_box")
FACTS = frozenset(
    Proposition.parse(text)
    for text in ("on(rack, table)", "on(red_box, table)", "on(blue_box, table)", "inworkspace(table)", "inworkspace(rack)",
                 "inworkspace(red_box)", "inworkspace(blue_box)")
)
STATES = reachable_states(FACTS, OBJECTS)


def judge(predicted, truth):
    return judge_goal(None if predicted is None else parse_goal(predicted), None if truth is None else parse_goal(truth), STATES)


def test_reachable_states_are_breadth_first_distances():
    assert STATES[FACTS] == 0 and max(STATES.values()) == 4  # both boxes moved: pick, place, pick, place
    assert len(STATES) == 4 * 3 - 4  # each box on table/rack/in hand, at most one in hand


def test_a_goal_written_differently_but_meaning_the_same_is_strictly_right():
    truth = "[['on(red_box, rack)']]"
    assert judge("[['on(red_box, rack)', 'on(rack, table)']]", truth).strict  # the rack never moves
    assert judge("[['on(red_box, rack)'], ['on(red_box, rack)', 'on(blue_box, rack)']]", truth).strict  # subsumed
    wrong = judge("[['on(blue_box, rack)']]", truth)
    assert not wrong.strict and not wrong.plan_level and wrong.predicted_distance == wrong.true_distance == 2


def test_plan_level_accepts_what_a_shortest_plan_leaves_true():
    # pinning the other box to the table: shortest plans leave it there, but a state with both on
    # the rack satisfies the truth and not the prediction
    pinned = judge("[['on(red_box, rack)', 'on(blue_box, table)']]", "[['on(red_box, rack)']]")
    assert pinned.plan_level and not pinned.strict
    # one alternative of a lifted goal: its shortest plans reach the truth, the truth accepts more
    one = judge("[['on(red_box, rack)']]", "[['on(red_box, rack)'], ['on(blue_box, rack)']]")
    assert one.plan_level and not one.strict
    # the other way round: a shortest plan to the wider prediction may move the wrong box
    assert not judge("[['on(red_box, rack)'], ['on(blue_box, rack)']]", "[['on(red_box, rack)']]").plan_level
    # a prediction no plan reaches is wrong under both
    unreachable = judge("[['on(red_box, blue_box)']]", "[['on(red_box, rack)']]")
    assert not unreachable.strict and not unreachable.plan_level and unreachable.predicted_distance is None


def test_no_valid_goal_is_right_only_against_no_goal():
    assert judge(None, None).strict and judge(None, None).plan_level
    assert not judge(None, "[['on(red_box, rack)']]").plan_level
    assert not judge("[['on(red_box, rack)']]", None).strict
