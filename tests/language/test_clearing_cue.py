"""Clearing a rack: which instructions ask for it, and the goal completed from what rests on it."""

from __future__ import annotations

import pytest

from t2m_core.domain.goals import parse_goal
from t2m_core.language.clearing_cue import cleared_support, complete_cleared_goal

OBJECTS = ("table", "rack", "hook", "red_box", "blue_box", "yellow_box")
LOADED = ("on(rack, table)", "on(hook, rack)", "on(red_box, rack)", "on(blue_box, table)", "on(yellow_box, table)")


@pytest.mark.parametrize(
    "instruction",
    ["Clear off the rack, please.", "Unload the rack.", "Take all the boxes off the rack.", "Nothing may remain on the rack."],
)
def test_clearing_phrases_name_the_rack(instruction):
    assert cleared_support(instruction, OBJECTS) == "rack"


@pytest.mark.parametrize(
    "instruction",
    [
        "Put the red box on the rack.",
        "Clear the table.",  # the table is no rack
        "Move everything onto the rack.",  # filling, not clearing
        "Clear the rack.",  # asked in a scene without a rack: below
    ],
)
def test_other_instructions_clear_nothing(instruction):
    objects = OBJECTS if "Clear the rack" not in instruction else ("table", "red_box")
    assert cleared_support(instruction, objects) is None


def test_the_goal_moves_what_rests_on_the_rack_and_nothing_else():
    wrong_box = parse_goal("[['on(blue_box, table)', 'on(hook, table)']]")  # blue already on the table
    assert complete_cleared_goal(wrong_box, "rack", LOADED).to_lists() == [["on(hook, table)", "on(red_box, table)"]]
    second_half = parse_goal("[['on(yellow_box, rack)']]")  # "empty the rack, then put the yellow box on it"
    assert complete_cleared_goal(second_half, "rack", LOADED).to_lists() == [
        ["on(yellow_box, rack)", "on(hook, table)", "on(red_box, table)"]
    ]
    immovable = parse_goal("[['on(table, rack)']]")
    assert complete_cleared_goal(immovable, "rack", LOADED).to_lists() == [["on(hook, table)", "on(red_box, table)"]]
    assert complete_cleared_goal(wrong_box, None, LOADED) == wrong_box
