"""Goal relations and counted box phrases read from instructions, and the completion of counted
lifted goals (lifted goals enumerate their alternatives)."""

from __future__ import annotations

import pytest

from t2m_core.domain.goals import parse_goal
from t2m_core.language.instruction_cues import category_boxes, complete_counted_goal, count_cue, named_relations

OBJECTS = ("table", "rack", "hook", "red_box", "blue_box", "yellow_box", "cyan_box")


@pytest.mark.parametrize(
    "instruction, relations",
    [
        ("Could you stack a pair of boxes onto the rack?", ("on",)),
        ("Hide the cyan box beneath the rack.", ("under",)),
        ("Place the red box on the table, then push the cyan box under the rack.", ("on", "under")),
        ("Tidy up, please.", ("on", "under")),  # names neither: both stay allowed
        ("Grab the red box.", ()),  # only asks to hold: inhand goals alone
        ("Keep the hook in your gripper.", ()),
        ("Pick up the hook and put it on the rack.", ("on",)),  # holding on the way, then a place
    ],
)
def test_named_relations(instruction, relations):
    assert named_relations(instruction) == relations


@pytest.mark.parametrize(
    "instruction, k, described",
    [
        ("Would you lift a couple of the boxes onto the rack?", 2, False),
        ("Place one box on the rack.", 1, False),
        ("Can you set any three boxes on the rack?", 3, False),
        ("Put two ocean colored boxes on the rack.", 2, True),  # a class only the model can read
        ("Move all of the boxes to the rack.", 4, False),
    ],
)
def test_count_cue_reads_the_count_and_whether_a_class_narrows_it(instruction, k, described):
    cue = count_cue(instruction, OBJECTS)
    assert cue is not None and (cue.k, cue.described) == (k, described)
    assert cue.boxes == ("red_box", "blue_box", "yellow_box", "cyan_box")
    assert cue.destinations == ("rack",) and cue.pins


@pytest.mark.parametrize(
    "instruction",
    [
        "Fetch an odd number greater than one of the boxes.",  # a comparison, not a count
        "Put the red box and the hook on the rack.",  # no count
        "Tuck every ocean colored box under the rack.",  # "every" of a class only the model can size
        "Put five boxes on the rack.",  # not a count word it knows, and more than the scene has
    ],
)
def test_no_count_cue(instruction):
    assert count_cue(instruction, OBJECTS) is None


def test_destinations_are_the_named_supports_never_the_hook():
    cue = count_cue("Put one box on the rack (you may use the hook).", OBJECTS)
    assert cue.destinations == ("rack",)
    assert count_cue("Put two boxes somewhere.", OBJECTS).destinations == ("table", "rack")


def test_plain_count_completes_to_every_subset_of_all_boxes():
    cue = count_cue("Get two boxes onto the rack.", OBJECTS)
    answer = parse_goal("[['on(red_box, rack)', 'on(blue_box, rack)'], ['on(red_box, rack)', 'on(blue_box, rack)']]")
    goal = complete_counted_goal(answer, cue)
    assert len(goal) == 6
    assert {frozenset(map(str, alternative)) for alternative in goal} == {
        frozenset({f"on({a}, rack)", f"on({b}, rack)"})
        for a, b in [("red_box", "blue_box"), ("red_box", "yellow_box"), ("red_box", "cyan_box"),
                     ("blue_box", "yellow_box"), ("blue_box", "cyan_box"), ("yellow_box", "cyan_box")]
    }


def test_described_count_ranges_over_the_boxes_the_model_named_and_keeps_its_relation():
    cue = count_cue("Slide two bright colored boxes under the rack.", OBJECTS)
    answer = parse_goal("[['under(red_box, rack)', 'under(yellow_box, rack)']]")
    goal = complete_counted_goal(answer, cue)
    assert goal.to_lists() == [["under(red_box, rack)", "under(yellow_box, rack)"]]
    answer = parse_goal("[['under(red_box, rack)', 'under(yellow_box, rack)'], ['under(blue_box, rack)', 'under(red_box, rack)']]")
    assert len(complete_counted_goal(answer, cue)) == 3  # red, yellow, blue: three pairs


def test_pinned_answers_pin_every_other_box_in_the_completion():
    cue = count_cue("Put one box on the rack.", OBJECTS)
    answer = parse_goal("[['on(red_box, rack)', 'on(blue_box, table)', 'on(yellow_box, table)', 'on(cyan_box, table)']]")
    goal = complete_counted_goal(answer, cue)
    assert len(goal) == 4
    assert all(len(alternative) == 4 for alternative in goal)
    assert ["on(blue_box, rack)", "on(red_box, table)", "on(yellow_box, table)", "on(cyan_box, table)"] in goal.to_lists()


@pytest.mark.parametrize(
    "answer",
    [
        "[['on(red_box, rack)', 'on(blue_box, rack)'], ['on(red_box, rack)']]",  # not k boxes everywhere
        "[['on(red_box, rack)', 'on(blue_box, rack)'], ['under(red_box, rack)', 'under(cyan_box, rack)']]",  # mixed
        "[['on(red_box, rack)', 'on(hook, rack)']]",  # not only boxes
    ],
)
def test_non_uniform_answers_are_left_as_the_model_wrote_them(answer):
    cue = count_cue("Put two boxes on the rack.", OBJECTS)
    goal = parse_goal(answer)
    assert complete_counted_goal(goal, cue) == goal
    assert complete_counted_goal(goal, None) == goal


@pytest.mark.parametrize(
    "instruction, k, members",
    [
        ("Move the warm-colored boxes to the rack.", 2, ("red_box", "yellow_box")),  # no count: all of them
        ("Put the cool ones on the rack.", 2, ("blue_box", "cyan_box")),
        ("Put two primary colored boxes on the rack.", 2, ("red_box", "blue_box", "yellow_box")),
        ("Tuck every warm colored box under the rack.", 2, ("red_box", "yellow_box")),
    ],
)
def test_a_colour_category_ranges_the_count_over_its_members(instruction, k, members):
    cue = count_cue(instruction, OBJECTS)
    assert (cue.k, cue.described, cue.boxes) == (k, False, members)


def test_a_category_without_members_in_the_scene_gives_no_cue():
    assert category_boxes("Put the warm boxes on the rack.", ("table", "rack", "blue_box", "cyan_box")) is None
    assert count_cue("Put the warm boxes on the rack.", ("table", "rack", "blue_box", "cyan_box")) is None
    assert category_boxes("Put the red box on the rack.", OBJECTS) is None


def test_a_categorised_count_completes_to_the_subsets_of_its_members():
    cue = count_cue("Put two primary colored boxes onto the rack.", OBJECTS)
    goal = complete_counted_goal(parse_goal("[['on(red_box, rack)', 'on(blue_box, rack)']]"), cue)
    assert sorted(sorted(alternative) for alternative in goal.to_lists()) == [
        ["on(blue_box, rack)", "on(red_box, rack)"],
        ["on(blue_box, rack)", "on(yellow_box, rack)"],
        ["on(red_box, rack)", "on(yellow_box, rack)"],
    ]
