"""Instructions refused from their words: things no world object is, two objects to hold at once;
and the object in hand named as "what you're holding"."""

from __future__ import annotations

import pytest

from t2m_core.domain.goals import parse_goal
from t2m_core.language.goal_checks import held_objects, prefer_named_objects
from t2m_core.language.grammar import goal_grammar
from t2m_core.language.instruction_checks import (
    direct_objects,
    held_together,
    two_in_hand_reason,
    unknown_thing_reason,
    unknown_things,
)
from t2m_core.language.queries import query_goal
from t2m_core.protocols import LanguageModelCapabilities

OBJECTS = ("table", "rack", "hook", "red_box", "blue_box")


@pytest.mark.parametrize(
    "instruction, things",
    [
        ("Put the purple box next to the hook.", ("purple box",)),
        ("Could you move a green one onto the rack?", ("green box",)),
        ("Set the mug on the rack, please.", ("mug",)),
        ("Pick up the wooden spoon and put it on the table.", ("wooden spoon",)),
        ("Place the red box and the orange block on the rack.", ("orange box",)),
    ],
)
def test_things_no_world_object_is(instruction, things):
    assert unknown_things(instruction) == things


@pytest.mark.parametrize(
    "instruction",
    [
        "Put the red one on the rack.",
        "Get a pair of boxes onto the rack.",  # "of" is read through: boxes
        "Move the warm-colored boxes to the rack.",  # a category, not a colour
        "Take the tool off the rack.",
        "Put the rest on the table.",
        "Hold the red box and the blue box at the same time.",  # "the same time" is no direct object
        "Move the red box to the left of the rack.",  # only direct objects are read
        "Clear the rack.",
    ],
)
def test_world_things_are_not_refused(instruction):
    assert unknown_things(instruction) == ()


def test_direct_objects_follow_verbs_and_particles():
    assert direct_objects("Pick up the big red box, then set a mug down.") == [["big", "red", "box"], ["mug"]]


def test_unknown_reason_names_the_thing_and_the_scene():
    reason = unknown_thing_reason("Put the banana on the rack.", OBJECTS)
    assert reason.kind == "unknown" and "the banana" in reason.reason and "red_box" in reason.reason
    assert unknown_thing_reason("Put the blue box on the rack.", OBJECTS) is None


@pytest.mark.parametrize(
    "instruction, held",
    [
        ("Hold the red box and the blue box at the same time.", ("red_box", "blue_box")),
        ("Grab both the hook and the yellow box.", ("hook", "yellow_box")),
        ("Keep the cyan box and the red box in your hand.", ("cyan_box", "red_box")),
    ],
)
def test_two_objects_to_hold_at_once(instruction, held):
    assert held_together(instruction) == held
    reason = two_in_hand_reason(instruction)
    assert reason.kind == "impossible" and "holds one object" in reason.reason


@pytest.mark.parametrize(
    "instruction",
    [
        "Hold the red box.",
        "Put the red box on the rack and hold the hook.",  # a place for one of them
        "Hold the red box, then the blue box.",  # one after the other
        "Pick the red box and the blue box up and put them on the rack.",
    ],
)
def test_one_object_in_hand_is_not_refused(instruction):
    assert two_in_hand_reason(instruction) is None


def test_what_is_held_is_named_by_reference():
    held = ("on(rack, table)", "on(red_box, table)", "inhand(blue_box)")
    assert held_objects("Put down what you're holding on the rack.", held) == ("blue_box",)
    assert held_objects("Put the box on the rack.", held) == ()  # no reference to the hand
    assert held_objects("Put down what you're holding.", ("on(rack, table)",)) == ()  # nothing held
    goal = parse_goal("[['on(hook, table)'], ['on(blue_box, rack)'], ['on(red_box, rack)']]")
    preferred = prefer_named_objects(goal, "Set whatever is in your gripper on the rack.", OBJECTS, held)
    assert preferred.to_lists() == [["on(blue_box, rack)"]]


def test_holding_only_grammar_admits_inhand_of_movable_objects_only():
    grammar = goal_grammar(OBJECTS, relations=())
    assert '"inhand("' in grammar and "on" not in grammar.replace("inhand", "")
    assert '"hook"' in grammar and '"table"' not in grammar and '"rack"' not in grammar


class Refusing:
    capabilities = LanguageModelCapabilities(exact_scoring=True, grammar=True)

    def complete(self, prompt, **_):
        raise AssertionError("a refused instruction must not reach the model")


@pytest.mark.parametrize(
    "instruction, kind",
    [("Put the banana on the rack.", "unknown"), ("Hold the red box and the blue box together.", "impossible")],
)
def test_goal_queries_refuse_before_asking(instruction, kind):
    query = query_goal(Refusing(), "ctx\nQ:", OBJECTS, instruction=instruction, relationships=("on(rack, table)",))
    assert query.goal is None and query.attempts == [] and query.no_goal.kind == kind
