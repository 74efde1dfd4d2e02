"""Predicates (docs/guide/world.md#predicates): worked examples of the geometric tests and the value()
checks on scenes."""

from __future__ import annotations

import math

import pytest

from t2m_core.domain.geometry import axis_angle_to_quat, quat_multiply, yaw_to_quat
from t2m_core.domain.predicates import Scene, evaluate, holds_all
from t2m_core.domain.propositions import (
    PropositionError,
)
from t2m_core.domain.relations import relation_strings
from t2m_core.domain.state import ObjectPose
from tests.domain.scenes import RACK_BEYOND, RACK_IN_WORKSPACE, on_table, scene

# --------------------------------------------------------------------------------------------------
# Worked examples of the geometric tests
# --------------------------------------------------------------------------------------------------


def test_box_resting_on_the_table() -> None:
    state = scene(rack=RACK_IN_WORKSPACE, red_box=on_table("red_box", 0.6, 0.2))
    assert evaluate("on(red_box, table)", state)
    assert not evaluate("on(red_box, rack)", state)
    assert not evaluate("under(red_box, rack)", state)
    assert not evaluate("inhand(red_box)", state)
    assert evaluate("on(rack, table)", state)


def test_box_on_the_rack_top_is_not_on_the_table() -> None:
    state = scene(rack=RACK_IN_WORKSPACE, blue_box=ObjectPose([0.44, -0.33, 0.16 + 0.053]))
    assert evaluate("on(blue_box, rack)", state)
    assert not evaluate("on(blue_box, table)", state)  # |0.16 − 0| ≥ 0.04
    assert not evaluate("under(blue_box, rack)", state)


def test_box_under_the_rack_is_also_on_the_table() -> None:
    state = scene(rack=RACK_IN_WORKSPACE, yellow_box=on_table("yellow_box", 0.44, -0.33))
    assert evaluate("under(yellow_box, rack)", state)
    assert evaluate("on(yellow_box, table)", state)
    assert not evaluate("on(yellow_box, rack)", state)
    assert relation_strings(state) == ["under(yellow_box, rack)", "on(rack, table)", "on(yellow_box, table)"]


def test_lifted_box_is_in_hand_and_on_nothing() -> None:
    state = scene(rack=RACK_IN_WORKSPACE, red_box=ObjectPose([0.44, -0.33, 0.40]))  # right above the rack
    assert evaluate("inhand(red_box)", state)
    assert relation_strings(state) == ["on(rack, table)", "inhand(red_box)"]


def test_inhand_threshold_uses_half_the_height() -> None:
    # centre z > 0.40 − 0.5·size_z (0.341 for the red box).
    assert evaluate("inhand(red_box)", scene(red_box=ObjectPose([0.5, 0, 0.342])))
    assert not evaluate("inhand(red_box)", scene(red_box=ObjectPose([0.5, 0, 0.340])))


def test_on_requires_contact_and_overlap() -> None:
    hovering = scene(rack=RACK_IN_WORKSPACE, blue_box=ObjectPose([0.44, -0.33, 0.16 + 0.053 + 0.045]))
    assert not evaluate("on(blue_box, rack)", hovering)  # 4.5 cm gap ≥ 0.04
    beside = scene(rack=RACK_IN_WORKSPACE, blue_box=ObjectPose([0.70, -0.33, 0.16 + 0.053]))
    assert not evaluate("on(blue_box, rack)", beside)  # no footprint overlap
    far = scene(cyan_box=on_table("cyan_box", 0.85, 0.0))
    assert evaluate("on(cyan_box, table)", far)  # the table reaches x = 0.9


def test_full_on_requires_uprightness_unless_tippable() -> None:
    tipped = ObjectPose([0.5, 0.1, 0.025], quat_multiply(axis_angle_to_quat([math.pi / 2, 0, 0]), yaw_to_quat(0.2)))
    state = scene(red_box=tipped)
    assert evaluate("on(red_box, table)", state, full=False)
    assert not evaluate("on(red_box, table)", state)
    assert evaluate("on(red_box, table)", state, ["tippable(red_box)"])
    assert "on(red_box, table)" in relation_strings(state)  # the language layer does not check uprightness


# --------------------------------------------------------------------------------------------------
# Sampling-time predicates
# --------------------------------------------------------------------------------------------------


def test_marker_predicates_always_hold() -> None:
    state = scene(hook=ObjectPose([2.0, 2.0, -1.0]), rack=RACK_BEYOND)
    for text in ("handlegrasp(hook)", "upperhandlegrasp(hook)", "aligned(rack)", "tippable(hook)", "poslimit(rack)",
                 "inoodzone(hook)"):
        assert evaluate(text, state)


def test_zone_predicates() -> None:
    state = scene(rack=RACK_BEYOND, red_box=on_table("red_box", 0.55, 0.0), blue_box=on_table("blue_box", 0.75, 0.1))
    assert evaluate("inworkspace(red_box)", state)
    assert evaluate("inoperationalzone(red_box)", state)
    assert not evaluate("incollisionzone(red_box)", state)
    assert not evaluate("inobstructionzone(red_box)", state)
    assert evaluate("beyondworkspace(blue_box)", state)
    assert not evaluate("inworkspace(blue_box)", state)
    assert evaluate("inworkspace(rack)", state)  # the rack is never tested against the workspace
    assert evaluate("beyondworkspace(rack)", state)


def test_absent_objects() -> None:
    state = scene(red_box=on_table("red_box", 0.5, 0.0))
    assert evaluate("inworkspace(hook)", state)
    assert evaluate("free(cyan_box)", state)
    assert evaluate("nonblocking(red_box, cyan_box)", state)
    assert not evaluate("on(cyan_box, table)", state)  # goal predicates about absent objects are false
    assert not evaluate("inhand(hook)", state)


def test_free_distance_table() -> None:
    near_boxes = scene(red_box=on_table("red_box", 0.5, 0.0), blue_box=on_table("blue_box", 0.59, 0.0))  # 4 cm
    assert not evaluate("free(red_box)", near_boxes)
    apart_boxes = scene(red_box=on_table("red_box", 0.5, 0.0), blue_box=on_table("blue_box", 0.61, 0.0))  # 6 cm
    assert evaluate("free(red_box)", apart_boxes)
    # Box–rack needs 0.10 m, unless the rack is beyond the workspace (then 0.04 m).
    rack_x_min = 0.71
    box_near_rack = {"rack": RACK_BEYOND, "red_box": on_table("red_box", rack_x_min - 0.025 - 0.07, 0.0)}  # 7 cm
    assert not evaluate("free(red_box)", scene(**box_near_rack))
    assert evaluate("free(red_box)", scene(**box_near_rack), ["beyondworkspace(rack)"])
    assert evaluate("free(red_box)", scene(**box_near_rack), ["infront(red_box, rack)"])
    # Other objects in hand, and unlisted pairs (box–table), are ignored.
    held = scene(red_box=on_table("red_box", 0.5, 0.0), blue_box=on_table("blue_box", 0.59, 0.0))
    assert evaluate("free(red_box)", held, ["inhand(blue_box)"])


def test_free_fails_under_the_rack_and_passes_when_stacked() -> None:
    under = scene(rack=RACK_IN_WORKSPACE, red_box=on_table("red_box", 0.44, -0.33))
    assert not evaluate("free(red_box)", under)
    stacked = scene(rack=RACK_IN_WORKSPACE, red_box=ObjectPose([0.44, -0.33, 0.16 + 0.059]))
    assert evaluate("free(red_box)", stacked)  # within d_min of the rack but above it


def test_free_uses_an_injected_distance_query() -> None:
    state = scene(red_box=on_table("red_box", 0.5, 0.0), blue_box=on_table("blue_box", 0.8, 0.0))
    assert evaluate("free(red_box)", Scene(state))
    assert not evaluate("free(red_box)", Scene(state, distance=lambda a, b: 0.01))


def test_infront_of_the_rack() -> None:
    context = {"rack": RACK_BEYOND}  # footprint x ∈ [0.71, 0.93], y ∈ [−0.16, 0.16]
    assert evaluate("infront(red_box, rack)", scene(**context, red_box=on_table("red_box", 0.55, 0.1)))
    assert not evaluate("infront(red_box, rack)", scene(**context, red_box=on_table("red_box", 0.55, 0.2)))
    assert not evaluate("infront(red_box, rack)", scene(**context, red_box=on_table("red_box", 0.75, 0.0)))


def test_nonblocking_line_of_sight() -> None:
    target = on_table("cyan_box", 0.8, 0.0)
    blocked = scene(red_box=on_table("red_box", 0.6, 0.0), cyan_box=target)
    assert not evaluate("nonblocking(cyan_box, red_box)", blocked)
    clear = scene(red_box=on_table("red_box", 0.6, 0.3), cyan_box=target)
    assert evaluate("nonblocking(cyan_box, red_box)", clear)
    # Box–box hulls grow by 3 × 0.058 = 0.174 m: a box 0.15 m off the line still blocks it.
    near_miss = scene(red_box=on_table("red_box", 0.6, 0.15), cyan_box=target)
    assert not evaluate("nonblocking(cyan_box, red_box)", near_miss)


def test_nonblocking_growth_depends_on_the_racks_zone() -> None:
    # Rack beyond the workspace grows by 1.5 × 0.058 = 0.087 m; in the workspace it would be 3×.
    rack_at = ObjectPose([0.62, 0.30, 0.16])  # footprint y ∈ [0.14, 0.46]; r = 0.69 → in the workspace
    line_target = on_table("cyan_box", 0.85, 0.0)
    assert not evaluate("nonblocking(cyan_box, rack)", scene(rack=rack_at, cyan_box=line_target))
    rack_far = ObjectPose([0.72, 0.30, 0.16])  # r = 0.78 → beyond: 0.087 growth does not reach y ≈ 0.04
    assert evaluate("nonblocking(cyan_box, rack)", scene(rack=rack_far, cyan_box=line_target))


def test_nonblocking_treats_the_hook_as_its_bounding_box() -> None:
    # The L's empty corner (−x, +y in the hook frame) lies on the line: its footprint boxes miss the
    # line, its bounding box does not.
    hook = ObjectPose([0.55, -0.08, 0.02])  # handle y ∈ [−0.19, −0.15], head x ∈ [0.71, 0.75]
    state = scene(hook=hook, red_box=on_table("red_box", 0.65, 0.0))
    assert not evaluate("nonblocking(red_box, hook)", state)


def test_holds_all_uses_the_list_as_its_own_context() -> None:
    tipped = ObjectPose([0.5, 0.1, 0.025], axis_angle_to_quat([math.pi / 2, 0, 0]))
    state = scene(red_box=tipped)
    assert not holds_all(["on(red_box, table)"], state)
    assert holds_all(["tippable(red_box)", "on(red_box, table)"], state)


def test_unknown_predicate_or_arity_is_an_error() -> None:
    with pytest.raises(PropositionError, match="unknown predicate"):
        evaluate("near(red_box, table)", scene())
    with pytest.raises(PropositionError, match="takes 2"):
        evaluate("on(red_box)", scene())
