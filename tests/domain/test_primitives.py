"""Primitive specifications (docs/guide/primitives.md): action ranges, waypoint geometry against hand-computed
poses, contact and disturbance lists, mid-sequence checks, post-conditions and action samplers."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from t2m_core.domain.geometry import axis_angle_to_quat, yaw_to_quat
from t2m_core.domain.objects import OBJECTS
from t2m_core.domain.primitives import (
    FAILURES,
    PRIMITIVES,
    MotionKind,
    MotionStep,
    Outcome,
    StepContext,
    first_disturbed,
    get_primitive,
    is_truncated,
)
from t2m_core.domain.primitives.pull import Pull
from t2m_core.domain.state import GeometricState, ObjectPose
from tests.domain.scenes import RACK_BEYOND, RACK_IN_WORKSPACE, on_table, scene

PICK, PLACE, PULL, PUSH, STOP = (PRIMITIVES[n] for n in ("pick", "place", "pull", "push", "stop"))


def kinds(steps: tuple[MotionStep, ...]) -> list[str]:
    return [step.kind.value for step in steps]


def context(start: GeometricState, now: GeometricState, arguments, distance=lambda a, b: 0.0) -> StepContext:
    return StepContext(start, now, tuple(arguments), distance)


def moved(state: GeometricState, name: str, pose: ObjectPose) -> GeometricState:
    return GeometricState({**state.objects, name: pose}, state.ee_position, state.ee_quaternion, state.held)


# --------------------------------------------------------------------------------------------------
# Action spaces and mapping
# --------------------------------------------------------------------------------------------------


def test_action_ranges_are_the_reference_table() -> None:
    q = math.pi / 4
    expected = {
        "pick": ([-0.2, -0.1, -0.05, -q], [0.2, 0.1, 0.05, 3 * q]),
        "place": ([-1.0, -1.0, 0.0, -q], [1.0, 1.0, 0.1, 3 * q]),
        "pull": ([-0.2, -0.4, -0.05, -2 * q], [0.0, -0.1, 0.05, 2 * q]),
        "push": ([-0.4, 0.1, -0.05, -2 * q], [-0.2, 0.4, 0.05, 2 * q]),
    }
    for name, (low, high) in expected.items():
        np.testing.assert_allclose(PRIMITIVES[name].action_low, low)
        np.testing.assert_allclose(PRIMITIVES[name].action_high, high)
        np.testing.assert_allclose(PRIMITIVES[name].to_physical(-np.ones(4)), low)
        np.testing.assert_allclose(PRIMITIVES[name].to_physical(np.ones(4)), high)


def test_mapping_is_linear_midpoint() -> None:
    np.testing.assert_allclose(PULL.to_physical(np.zeros(4)), [-0.1, -0.25, 0.0, 0.0])
    np.testing.assert_allclose(PICK.to_normalized([0.0, 0.0, 0.0, 0.0]), [0.0, 0.0, 0.0, -0.5])


@given(
    name=st.sampled_from(["pick", "place", "pull", "push", "stop"]),
    action=st.lists(st.floats(-1.0, 1.0, allow_nan=False), min_size=4, max_size=4),
)
def test_mapping_round_trip(name: str, action: list[float]) -> None:
    primitive = PRIMITIVES[name]
    np.testing.assert_allclose(primitive.to_normalized(primitive.to_physical(action)), action, atol=1e-12)


def test_mapping_broadcasts_over_batches() -> None:
    batch = np.linspace(-1, 1, 12).reshape(3, 4)
    assert PLACE.to_physical(batch).shape == (3, 4)
    np.testing.assert_allclose(PLACE.to_normalized(PLACE.to_physical(batch)), batch)


def test_registry_and_unknown_names() -> None:
    assert set(PRIMITIVES) == {"pick", "place", "pull", "push", "stop"}
    assert get_primitive("push") is PUSH
    with pytest.raises(KeyError, match="known primitives: pick, place, pull, push, stop"):
        get_primitive("poke")


def test_argument_validation_names_the_problem() -> None:
    state = scene(rack=RACK_IN_WORKSPACE, red_box=on_table("red_box", 0.5, 0.0))
    with pytest.raises(ValueError, match="takes 1 argument"):
        PICK.motion(state, ["red_box", "rack"], np.zeros(4))
    with pytest.raises(ValueError, match="'rack' is a rack"):
        PICK.motion(state, ["rack"], np.zeros(4))
    with pytest.raises(ValueError, match="'blue_box' is not in the scene"):
        PICK.motion(state, ["blue_box"], np.zeros(4))


# --------------------------------------------------------------------------------------------------
# Failure vocabulary and the disturbance rule
# --------------------------------------------------------------------------------------------------


def test_failure_vocabulary_truncation() -> None:
    control = {"not_in_workspace", "collision", "disturbed", "grasp_failed", "too_high", "below_table", "not_under"}
    post = {"not_upright", "not_on_target", "not_pulled", "outside_workspace"}
    assert all(is_truncated(f) for f in control)
    assert not any(is_truncated(f) for f in post)
    assert control | post <= set(FAILURES)
    assert Outcome.failed("collision").truncated and not Outcome.failed("not_upright").truncated
    assert Outcome.ok().success and not Outcome.ok().truncated
    with pytest.raises(KeyError, match="unknown failure reason 'oops'"):
        Outcome.failed("oops")
    with pytest.raises(ValueError):
        Outcome(True, "collision")


def test_disturbance_threshold_translation_and_rotation() -> None:
    start = scene(red_box=on_table("red_box", 0.5, 0.0), blue_box=on_table("blue_box", 0.6, 0.1))
    nudged = moved(start, "red_box", on_table("red_box", 0.54, 0.0))
    shoved = moved(start, "red_box", on_table("red_box", 0.551, 0.0))
    turned = moved(start, "blue_box", on_table("blue_box", 0.6, 0.1, yaw=math.radians(6)))
    assert first_disturbed(start, nudged, ["red_box", "blue_box"]) is None
    assert first_disturbed(start, shoved, ["red_box"]) == "disturbed"
    assert first_disturbed(start, shoved, ["blue_box"]) is None  # only the listed objects count
    assert first_disturbed(start, turned, ["blue_box"]) == "disturbed"


# --------------------------------------------------------------------------------------------------
# Pick
# --------------------------------------------------------------------------------------------------


@pytest.fixture
def table_scene() -> GeometricState:
    return scene(
        rack=RACK_IN_WORKSPACE,
        hook=on_table("hook", 0.55, 0.25, yaw=math.pi / 2),
        red_box=on_table("red_box", 0.5, 0.0),
        blue_box=on_table("blue_box", 0.6, 0.1, yaw=math.pi / 2),
    )


def test_pick_at_box_centre(table_scene: GeometricState) -> None:
    steps = PICK.motion(table_scene, ["red_box"], PICK.to_normalized([0, 0, 0, 0]))
    assert kinds(steps) == ["move", "descend", "grasp", "lift", "settle"]
    np.testing.assert_allclose(steps[0].ee_position, [0.5, 0.0, 0.40])
    np.testing.assert_allclose(steps[1].ee_position, [0.5, 0.0, 0.059])
    np.testing.assert_allclose(steps[3].ee_position, [0.5, 0.0, 0.40])
    assert steps[1].ee_yaw == pytest.approx(0.0)
    assert steps[2].grasp_object == "red_box"
    assert steps[4].timeout_s == 3.0


def test_pick_offset_is_in_the_object_frame(table_scene: GeometricState) -> None:
    # blue_box is yawed 90°: an offset of +0.1 m along its x axis is +0.1 m along world y.
    steps = PICK.motion(table_scene, ["blue_box"], PICK.to_normalized([0.1, 0.0, 0.02, math.pi / 4]))
    np.testing.assert_allclose(steps[1].ee_position, [0.6, 0.2, 0.053 + 0.02], atol=1e-12)
    np.testing.assert_allclose(steps[0].ee_position, [0.6, 0.2, 0.40], atol=1e-12)
    assert steps[1].ee_yaw == pytest.approx(math.pi / 2 + math.pi / 4)


def test_pick_contacts_and_disturbance(table_scene: GeometricState) -> None:
    steps = PICK.motion(table_scene, ["red_box"], np.zeros(4))
    assert steps[1].contact_objects == ("table", "rack", "hook", "blue_box")
    assert steps[0].disturbance_objects == ("rack", "hook", "blue_box")
    assert steps[3].disturbance_objects == ("rack", "hook", "blue_box")
    assert steps[1].disturbance_objects == ()


def test_pick_refuses_objects_outside_the_workspace() -> None:
    near = scene(red_box=on_table("red_box", 0.35, 0.0))
    far = scene(red_box=on_table("red_box", 0.6, 0.4))  # r = 0.72
    inside = scene(red_box=on_table("red_box", 0.45, 0.3))
    assert PICK.precheck(near, ["red_box"], np.zeros(4)) == "not_in_workspace"
    assert PICK.precheck(far, ["red_box"], np.zeros(4)) == "not_in_workspace"
    assert PICK.precheck(inside, ["red_box"], np.zeros(4)) is None


def test_pick_heuristics(table_scene: GeometricState) -> None:
    rng = np.random.default_rng(0)
    np.testing.assert_allclose(PICK.heuristic_action(table_scene, ["red_box"], rng), [0, 0, 0, -0.5])
    grasps = np.array([PICK.to_physical(PICK.heuristic_action(table_scene, ["hook"], rng)) for _ in range(2000)])
    handle = np.isclose(grasps[:, 3], 0.0)
    assert np.mean(handle) == pytest.approx(0.38 / 0.58, abs=0.04)
    np.testing.assert_allclose(grasps[handle, 1], -0.09)
    assert grasps[handle, 0].min() < -0.15 and grasps[handle, 0].max() > 0.15
    np.testing.assert_allclose(grasps[~handle, 0], 0.18)
    np.testing.assert_allclose(grasps[~handle, 3], math.pi / 2)
    np.testing.assert_allclose(grasps[:, 2], 0.0)


def test_exploration_sampler_mixes_noisy_heuristic_and_uniform(table_scene: GeometricState) -> None:
    rng = np.random.default_rng(1)
    actions = np.array([PICK.exploration_action(table_scene, ["red_box"], rng) for _ in range(4000)])
    assert actions.min() >= -1.0 and actions.max() <= 1.0
    near = np.all(np.abs(actions - [0, 0, 0, -0.5]) < 0.25, axis=1)
    assert np.mean(near) == pytest.approx(0.9, abs=0.02)  # uniform draws land this close ~0.06 % of the time
    assert np.std(actions[near], axis=0) == pytest.approx(np.full(4, 0.05), abs=0.005)


# --------------------------------------------------------------------------------------------------
# Place
# --------------------------------------------------------------------------------------------------


@pytest.fixture
def holding() -> GeometricState:
    box = ObjectPose([0.45, 0.1, 0.37])
    return GeometricState(
        {"table": scene().objects["table"], "rack": RACK_IN_WORKSPACE, "red_box": box, "cyan_box": on_table("cyan_box", 0.6, 0.2)},
        ee_position=np.array([0.45, 0.1, 0.40]),
        held="red_box",
    )


def test_place_on_rack_centre(holding: GeometricState) -> None:
    steps = PLACE.motion(holding, ["red_box", "rack"], PLACE.to_normalized([0, 0, 0.05, 0]))
    assert kinds(steps) == ["move", "descend", "release", "lift", "settle"]
    np.testing.assert_allclose(steps[1].ee_position, [0.44, -0.33, 0.16 + 0.05], atol=1e-12)
    np.testing.assert_allclose(steps[0].ee_position, [0.44, -0.33, 0.40], atol=1e-12)
    assert steps[1].ee_yaw == pytest.approx(math.pi / 2)  # target yaw composed with θ = 0


def test_place_rack_rectangle_in_its_frame(holding: GeometricState) -> None:
    # The rack is yawed 90°: its +x half-width (0.11) points along world +y, its +y half-length
    # (0.16) along world −x.
    steps = PLACE.motion(holding, ["red_box", "rack"], PLACE.to_normalized([1, 1, 0.0, math.pi / 2]))
    np.testing.assert_allclose(steps[1].ee_position, [0.44 - 0.16, -0.33 + 0.11, 0.16], atol=1e-12)
    assert steps[1].ee_yaw == pytest.approx(-math.pi)


def test_place_table_rectangle(holding: GeometricState) -> None:
    corner = PLACE.release_pose(holding, "table", PLACE.to_normalized([-1, -1, 0.02, 0]))[0]
    far = PLACE.release_pose(holding, "table", PLACE.to_normalized([1, 1, 0.02, 0]))[0]
    middle = PLACE.release_pose(holding, "table", PLACE.to_normalized([0, 0, 0.02, 0]))[0]
    np.testing.assert_allclose(corner, [0.28, -0.45, 0.02])
    np.testing.assert_allclose(far, [0.70, 0.45, 0.02])
    np.testing.assert_allclose(middle, [0.49, 0.0, 0.02])
    assert PLACE.precheck(holding, ["red_box", "table"], PLACE.to_normalized([-1, 0, 0.02, 0])) == "not_in_workspace"
    assert PLACE.precheck(holding, ["red_box", "table"], PLACE.to_normalized([1, 1, 0.02, 0])) == "not_in_workspace"
    assert PLACE.precheck(holding, ["red_box", "table"], PLACE.to_normalized([0, 0, 0.02, 0])) is None


def test_place_needs_the_object_in_hand(holding: GeometricState) -> None:
    assert PLACE.precheck(holding, ["cyan_box", "rack"], np.zeros(4)) == "not_held"


def test_place_descent_guards_target_and_drop_height(holding: GeometricState) -> None:
    steps = PLACE.motion(holding, ["red_box", "rack"], np.zeros(4))
    assert steps[1].contact_objects == ("rack", "table", "cyan_box")
    assert steps[0].disturbance_objects == ("cyan_box",)
    assert steps[2].disturbance_objects == ("cyan_box",) and steps[3].disturbance_objects == ("cyan_box",)
    check = steps[1].check
    assert check(context(holding, holding, ["red_box", "rack"], lambda a, b: 0.049)) is None
    assert check(context(holding, holding, ["red_box", "rack"], lambda a, b: 0.051)) == "too_high"


def test_place_post_conditions(holding: GeometricState) -> None:
    on_rack = moved(holding, "red_box", ObjectPose([0.44, -0.33, 0.16 + 0.059]))
    tilted = moved(holding, "red_box", ObjectPose([0.44, -0.33, 0.2], axis_angle_to_quat([0.3, 0.0, 0.0])))
    on_table_instead = moved(holding, "red_box", on_table("red_box", 0.6, 0.0))
    fell = moved(holding, "red_box", ObjectPose([0.95, 0.0, -0.2]))
    args = ["red_box", "rack"]
    assert PLACE.outcome(holding, on_rack, args) == Outcome.ok()
    assert PLACE.outcome(holding, tilted, args) == Outcome.failed("not_upright")
    assert PLACE.outcome(holding, on_table_instead, args) == Outcome.failed("not_on_target")
    assert PLACE.outcome(holding, fell, args) == Outcome.failed("below_table")
    assert PLACE.outcome(holding, fell, args).truncated
    assert PLACE.outcome(holding, on_table_instead, ["red_box", "table"]) == Outcome.ok()


def test_place_heuristic_release_height(holding: GeometricState) -> None:
    rng = np.random.default_rng(2)
    physical = np.array([PLACE.to_physical(PLACE.heuristic_action(holding, ["red_box", "rack"], rng)) for _ in range(50)])
    np.testing.assert_allclose(physical[:, 2], 0.40 - 0.37 + 0.059)  # bottom of the held box at the surface
    assert physical[:, 0].std() > 0.3  # the location stays uniform
    low = moved(holding, "red_box", ObjectPose([0.45, 0.1, 0.2]))  # a height that would exceed 0.1 is clipped
    assert PLACE.to_physical(PLACE.heuristic_action(low, ["red_box", "rack"], rng))[2] == pytest.approx(0.1)


# --------------------------------------------------------------------------------------------------
# Pull and Push: the polar frame at the target
# --------------------------------------------------------------------------------------------------


def hook_in_hand(target_xy, hook_yaw: float = 0.0, ee_offset=(0.0, -0.09, 0.08)) -> GeometricState:
    """The hook at (0.45, 0, 0.02) yawed ``hook_yaw``, held with the EE at ``ee_offset`` in the hook
    frame and the same yaw; a red box at ``target_xy``; the rack beyond the workspace."""
    hook_position = np.array([0.45, 0.0, 0.02])
    c, s = math.cos(hook_yaw), math.sin(hook_yaw)
    offset = np.array([c * ee_offset[0] - s * ee_offset[1], s * ee_offset[0] + c * ee_offset[1], ee_offset[2]])
    return GeometricState(
        {
            "table": scene().objects["table"],
            "rack": RACK_BEYOND,
            "hook": ObjectPose(hook_position, yaw_to_quat(hook_yaw)),
            "red_box": on_table("red_box", *target_xy),
            "blue_box": on_table("blue_box", 0.3, 0.3),
        },
        ee_position=hook_position + offset,
        ee_quaternion=yaw_to_quat(hook_yaw),
        held="hook",
    )


def rotate2(angle: float, x: float, y: float) -> np.ndarray:
    return np.array([math.cos(angle) * x - math.sin(angle) * y, math.sin(angle) * x + math.cos(angle) * y])


def test_pull_polar_frame_straight_ahead() -> None:
    state = hook_in_hand((0.8, 0.0))
    steps = PULL.motion(state, ["red_box", "hook"], PULL.to_normalized([-0.1, -0.3, 0.02, 0.0]))
    assert kinds(steps) == ["move", "descend", "sweep", "lift", "settle"]
    # φ = 0: hook reach (0.7, 0.02, 0.03), pull end (0.4, 0.02, 0.03); the EE sits (0, −0.09, 0.08) off it.
    np.testing.assert_allclose(steps[1].ee_position, [0.7, -0.07, 0.11], atol=1e-12)
    np.testing.assert_allclose(steps[2].ee_position, [0.4, -0.07, 0.11], atol=1e-12)
    np.testing.assert_allclose(steps[0].ee_position, [0.7, -0.07, 0.40], atol=1e-12)
    np.testing.assert_allclose(steps[3].ee_position, [0.4, -0.07, 0.40], atol=1e-12)
    assert steps[2].soft and not steps[1].soft
    assert all(step.ee_yaw == pytest.approx(0.0) for step in steps[:4])


def test_pull_polar_frame_off_axis_with_hook_yaw() -> None:
    target = (0.6, 0.3)
    phi, theta, hook_yaw = math.atan2(0.3, 0.6), math.pi / 8, 0.4
    state = hook_in_hand(target, hook_yaw=hook_yaw)
    steps = PULL.motion(state, ["red_box", "hook"], PULL.to_normalized([-0.15, -0.2, -0.03, theta]))
    hook_reach = np.array(target) + rotate2(phi, -0.15, -0.03)
    hook_end = np.array(target) + rotate2(phi, -0.35, -0.03)
    ee_offset = rotate2(phi + theta, 0.0, -0.09)  # the grasp offset turns with the hook
    np.testing.assert_allclose(steps[1].ee_position, [*(hook_reach + ee_offset), 0.11], atol=1e-9)
    np.testing.assert_allclose(steps[2].ee_position, [*(hook_end + ee_offset), 0.11], atol=1e-9)
    # The EE keeps its yaw relative to the hook (0 here), so it ends at φ + θ.
    assert steps[1].ee_yaw == pytest.approx(phi + theta)


def test_pull_contacts_exclude_the_table_and_check_upright() -> None:
    state = hook_in_hand((0.8, 0.0))
    steps = PULL.motion(state, ["red_box", "hook"], np.zeros(4))
    assert steps[1].contact_objects == ("rack", "blue_box")
    assert steps[0].disturbance_objects == ("rack", "blue_box") == steps[2].disturbance_objects
    tipped = moved(state, "red_box", ObjectPose([0.8, 0.0, 0.03], axis_angle_to_quat([math.pi / 2, 0, 0])))
    assert steps[1].check(context(state, state, ["red_box", "hook"])) is None
    assert steps[1].check(context(state, tipped, ["red_box", "hook"])) == "tipped_over"


def test_pull_prechecks() -> None:
    state = hook_in_hand((0.8, 0.0))
    behind = hook_in_hand((-0.05, 0.3))
    not_held = GeometricState(state.objects, state.ee_position, state.ee_quaternion, held=None)
    assert PULL.precheck(state, ["red_box", "hook"], np.zeros(4)) is None
    assert PULL.precheck(behind, ["red_box", "hook"], np.zeros(4)) == "target_behind_robot"
    assert PULL.precheck(not_held, ["red_box", "hook"], np.zeros(4)) == "not_held"


def test_pull_post_conditions_and_configurable_distance() -> None:
    start = hook_in_hand((0.75, 0.0))
    pulled = moved(start, "red_box", on_table("red_box", 0.62, 0.0))
    short = moved(start, "red_box", on_table("red_box", 0.72, 0.0))
    still_far = moved(start, "red_box", on_table("red_box", 0.70, 0.1))  # r = 0.707: moved, not in reach
    tipped = moved(start, "red_box", ObjectPose([0.6, 0.0, 0.03], axis_angle_to_quat([math.pi / 2, 0, 0])))
    args = ["red_box", "hook"]
    assert PULL.outcome(start, pulled, args) == Outcome.ok()
    assert PULL.outcome(start, short, args) == Outcome.failed("outside_workspace")
    assert PULL.outcome(start, still_far, args) == Outcome.failed("outside_workspace")
    assert PULL.outcome(start, tipped, args) == Outcome.failed("not_upright")
    nudged_start = hook_in_hand((0.66, 0.0))
    nudged = moved(nudged_start, "red_box", on_table("red_box", 0.63, 0.0))
    assert PULL.outcome(nudged_start, nudged, args) == Outcome.failed("not_pulled")
    assert Pull(min_distance=0.01).outcome(nudged_start, nudged, args) == Outcome.ok()  # the original's d_Pull


@pytest.mark.parametrize(("name", "expected"), [("pull", -(0.2 - 0.04 - 0.5 * math.hypot(0.05, 0.05))), ("push", -0.2 - 0.04 - 0.5 * math.hypot(0.05, 0.05))])
def test_hook_heuristic_reach(name: str, expected: float) -> None:
    state = hook_in_hand((0.8, 0.0))
    arguments = ["red_box", "hook"] + (["rack"] if name == "push" else [])
    primitive = PRIMITIVES[name]
    physical = primitive.to_physical(primitive.heuristic_action(state, arguments, np.random.default_rng(3)))
    assert physical[0] == pytest.approx(expected)
    assert physical[0] == pytest.approx(-0.125 if name == "pull" else -0.275, abs=0.001)
    assert physical[3] == pytest.approx(math.pi / 8)


def test_push_sequence_guards_and_checks() -> None:
    start = hook_in_hand((0.55, 0.0))
    args = ["red_box", "hook", "rack"]
    steps = PUSH.motion(start, args, PUSH.to_normalized([-0.3, 0.2, 0.0, 0.0]))
    assert kinds(steps) == ["move", "descend", "sweep", "descend", "lift"]  # no final settle, as in the original
    np.testing.assert_allclose(steps[1].ee_position, [0.25, -0.09, 0.11], atol=1e-12)
    np.testing.assert_allclose(steps[2].ee_position, [0.45, -0.09, 0.11], atol=1e-12)
    np.testing.assert_allclose(steps[3].ee_position, steps[1].ee_position)
    np.testing.assert_allclose(steps[4].ee_position, [0.25, -0.09, 0.40], atol=1e-12)
    assert steps[1].contact_objects == ("table", "blue_box")  # the table is guarded, the rack is an argument
    assert steps[0].disturbance_objects == ("rack", "blue_box") == steps[2].disturbance_objects
    sweep_check = steps[2].check
    under_rack = moved(start, "red_box", on_table("red_box", 0.80, 0.0))
    not_far = moved(start, "red_box", on_table("red_box", 0.58, 0.0))
    beside_rack = moved(start, "red_box", on_table("red_box", 0.62, 0.3))
    assert sweep_check(context(start, under_rack, args)) is None
    assert sweep_check(context(start, not_far, args)) == "not_pushed"
    assert sweep_check(context(start, beside_rack, args)) == "not_under"
    assert is_truncated("not_pushed") and is_truncated("not_under")
    assert PUSH.outcome(start, under_rack, args) == Outcome.ok()


def test_stop_does_nothing_and_succeeds() -> None:
    state = scene()
    assert STOP.motion(state, [], np.zeros(4)) == ()
    assert STOP.precheck(state, [], np.zeros(4)) is None
    assert STOP.outcome(state, state, []) == Outcome.ok()
    with pytest.raises(ValueError, match="takes 0 argument"):
        STOP.motion(state, ["table"], np.zeros(4))


def test_motion_step_validates_its_fields() -> None:
    with pytest.raises(ValueError, match="EE target"):
        MotionStep(MotionKind.MOVE, "pre_pose")
    with pytest.raises(ValueError, match="EE target"):
        MotionStep(MotionKind.RELEASE, "release", ee_position=np.zeros(3))
    with pytest.raises(ValueError, match="grasp_object"):
        MotionStep(MotionKind.GRASP, "grasp")


def _table_action(x: float, y: float, theta: float = 0.0) -> np.ndarray:
    """The physical Place action that releases 5 cm above the table at world (x, y), metres."""
    return np.array([-1.0 + 2.0 * (x - 0.28) / (0.70 - 0.28), -1.0 + 2.0 * (y + 0.45) / 0.90, 0.05, theta])


def test_place_in_the_way_sees_the_held_object_set_down_against_another(holding: GeometricState) -> None:
    # The cyan box stands at (0.6, 0.2); the red box is held centred under the EE.
    half_widths = (OBJECTS["red_box"].size[1] + OBJECTS["cyan_box"].size[1]) / 2
    actions = np.array([
        _table_action(0.6, 0.2),  # on top of it
        _table_action(0.6, 0.2 + half_widths + 0.005),  # 5 mm beside it: within the 1 cm clearance
        _table_action(0.6, 0.2 + half_widths + 0.03, theta=math.pi / 2),  # 3 cm beside it, the jaw across
        _table_action(0.35, 0.35),  # far from it and from the rack
    ])
    assert PLACE.in_the_way(holding, ["red_box", "table"], actions).tolist() == [True, True, False, False]
    # The fingers closed on the 50 mm box reach 26.4 mm beyond its faces along the jaw (world y at
    # θ = 0): 3 cm beside the cyan box along the jaw they come within 5 mm of it, 4.5 cm beside they do not.
    along = np.array([_table_action(0.6, 0.2 + half_widths + gap) for gap in (0.03, 0.045)])
    assert PLACE.in_the_way(holding, ["red_box", "table"], along).tolist() == [True, False]
    # The held object's offset from the EE turns with the release yaw: held 10 cm ahead of the EE
    # along x, released with θ = π/2, it lands 10 cm to the side (+y) of the release point.
    offset = GeometricState(
        {**holding.objects, "red_box": ObjectPose([0.55, 0.1, 0.37])}, ee_position=np.array([0.45, 0.1, 0.40]), held="red_box"
    )
    release = _table_action(0.45, 0.3, theta=math.pi / 2)
    beside = {**offset.objects, "cyan_box": on_table("cyan_box", 0.45, 0.4)}
    ahead = {**offset.objects, "cyan_box": on_table("cyan_box", 0.55, 0.3)}
    assert PLACE.in_the_way(GeometricState(beside, offset.ee_position, held="red_box"), ["red_box", "table"], release[None]).tolist() == [True]
    assert PLACE.in_the_way(GeometricState(ahead, offset.ee_position, held="red_box"), ["red_box", "table"], release[None]).tolist() == [False]
    # Both states in one batch, in any order.
    states = [GeometricState(beside, offset.ee_position, held="red_box"), GeometricState(ahead, offset.ee_position, held="red_box")]
    judged = PLACE.screen_of_states(states, ["red_box", "table"], np.stack([release] * 3), np.array([1, 0, 1]))
    assert judged["in_the_way"].tolist() == [False, True, False]
    # States whose EE, held object and bystanders all differ, in one batch: every prediction is the
    # one of the action's own state judged alone.
    mixed, state_of = [holding, states[1]], np.array([1, 0, 0, 1])
    actions = np.stack([release, _table_action(0.6, 0.2 + half_widths + 0.005), _table_action(0.35, 0.35), _table_action(0.6, 0.2)])
    batch = PLACE.screen_of_states(mixed, ["red_box", "table"], actions, state_of)
    for b, (index, action) in enumerate(zip(state_of, actions, strict=True)):
        alone = PLACE.screen_of_states([mixed[index]], ["red_box", "table"], action[None], np.zeros(1, dtype=int))
        assert {name: values[b] for name, values in batch.items()} == {name: values[0] for name, values in alone.items()}
    assert batch["in_the_way"][:3].tolist() == [False, True, False]  # as judged above
    with pytest.raises(NotImplementedError, match="stop makes no geometric prediction"):
        STOP.in_the_way(holding, [], release[None])


def test_balance_margins_take_the_whole_objects_own_margin_only_where_nothing_is_clipped() -> None:
    from t2m_core.domain.geometry import clip_segments, hull_margins, pad_polygons, yawed_polygons
    from t2m_core.domain.primitives.place import balance_margins

    rng = np.random.default_rng(3)
    table = pad_polygons([np.array([[-0.3, -0.45], [0.9, -0.45], [0.9, 0.45], [-0.3, 0.45]])])[[0] * 400]
    for name in ("hook", "red_box"):
        positions, yaws = rng.uniform([0.3, -0.6, 0.0], [0.8, 0.6, 0.0], (400, 3)), rng.uniform(-np.pi, np.pi, 400)
        centres = yawed_polygons(OBJECTS[name].centre_of_mass()[None, None, :2], positions, yaws)[:, 0, 0]
        clipped, held_up = clip_segments(yawed_polygons(OBJECTS[name].resting_segments(), positions, yaws), table)
        direct = hull_margins(clipped.reshape(400, -1, 2), np.repeat(held_up, 2, axis=-1), centres)
        np.testing.assert_allclose(balance_margins(name, positions, yaws, centres, table), direct, atol=1e-12)
        assert (direct < 0).any() and (direct > 0).any()  # both sides of the edge y = ±0.45 drawn


def test_place_margins_measure_the_drop_to_the_support_and_the_workspace(holding: GeometricState) -> None:
    # The held box's bottom hangs 0.089 m below the EE (0.40 − 0.37 + 0.118 / 2): released with the
    # EE that high above the rack's plate it touches it, 9 mm lower it is pressed 9 mm into it.
    on_rack = np.array([[0.0, 0.0, z, 0.0] for z in (0.089, 0.080, 0.100)])
    judged = PLACE.screen_of_states([holding], ["red_box", "rack"], on_rack, np.zeros(3, dtype=int))
    np.testing.assert_allclose(judged["support_gap"], [0.0, -0.009, 0.011], atol=1e-12)
    # the rack's centre, (0.44, −0.33): 4 cm beyond the workspace's near edge x = 0.40, 0.55 m from the base
    np.testing.assert_allclose(judged["workspace_margin"], 0.04, atol=1e-12)
    # the box's centre there lies half the plate's depth (x) inside its edges
    np.testing.assert_allclose(judged["support_margin"], OBJECTS["rack"].size[0] / 2, atol=1e-12)
    # on the table 5 cm and 2 cm inside its edge y = 0.45, and 3 cm beyond it (it falls: below_table)
    edge = np.array([PLACE.to_physical(_table_action(0.5, y)) for y in (0.40, 0.43, 0.48)])
    np.testing.assert_allclose(PLACE.screen_of_states([holding], ["red_box", "table"], edge, np.zeros(3, dtype=int))["support_margin"], [0.05, 0.02, -0.03], atol=1e-12)
    # The hook's weight lies 5.7 cm towards its handle (−y, yaw 0) from its origin: released 4 cm
    # inside the edge y = −0.45, its origin is inside but its centre of mass 1.7 cm beyond (it falls).
    hook_held = GeometricState({**holding.objects, "hook": ObjectPose([0.45, 0.1, 0.38])}, holding.ee_position, held="hook")
    del hook_held.objects["red_box"]
    centre = OBJECTS["hook"].centre_of_mass()
    at_edge = _table_action(0.5, -0.41)  # physical, θ = 0
    judged = PLACE.screen_of_states([hook_held], ["hook", "table"], at_edge[None], np.zeros(1, dtype=int))
    np.testing.assert_allclose(judged["support_margin"], [0.04 - 0.0567], atol=2e-4)
    np.testing.assert_allclose(judged["support_margin"], [0.04 + centre[1]], atol=1e-12)
    # Turned a quarter (handle along +y, head across it at the far end), released with its origin
    # 17 cm inside the edge y = 0.45: the handle's axis ends 1 cm beyond it, the head lies wholly
    # beyond, and the hook rolls about its handle although its centre of mass lies 11 cm inside the
    # edge. Released 2 cm further in, the head rests on the table too.
    hook_turned = GeometricState({**hook_held.objects, "hook": ObjectPose([0.45, 0.1, 0.38], yaw_to_quat(math.pi / 2))},
                                 holding.ee_position, held="hook")
    judged = PLACE.screen_of_states([hook_turned], ["hook", "table"], np.array([_table_action(0.5, 0.28), _table_action(0.5, 0.26)]),
                                    np.zeros(2, dtype=int))
    np.testing.assert_allclose(judged["support_margin"], [0.45 - 0.28 - centre[0], 0.45 - 0.26 - centre[0]], atol=1e-12)
    np.testing.assert_allclose(judged["balance_margin"], [-(0.09 + centre[1]), 0.09 + centre[1]], atol=1e-12)
    assert judged["balance_margin"][1] == pytest.approx(0.0333, abs=2e-4)
    near = PLACE.to_physical(_table_action(0.35, 0.35))  # 5 cm short of the near edge: the precheck refuses it
    table = PLACE.screen_of_states([holding], ["red_box", "table"], near[None], np.zeros(1, dtype=int))
    assert table["workspace_margin"][0] == pytest.approx(-0.05) and PLACE.precheck(holding, ["red_box", "table"], _table_action(0.35, 0.35)) == "not_in_workspace"
    assert table["support_gap"][0] == pytest.approx(near[2] - 0.089)
    # the held box set down 3 cm and 5 mm beside the cyan box (jaw across): it clears it by 2 cm
    # beyond the 1 cm clearance, or comes 5 mm too near
    half_widths = (OBJECTS["red_box"].size[1] + OBJECTS["cyan_box"].size[1]) / 2
    beside = np.array([[*_table_action(0.6, 0.2 + half_widths + gap)[:2], 0.05, math.pi / 2] for gap in (0.03, 0.005)])  # physical
    judged = PLACE.screen_of_states([holding], ["red_box", "table"], beside, np.zeros(2, dtype=int))
    np.testing.assert_allclose(judged["clearance"], [0.02, -0.005], atol=1e-9)
    assert judged["in_the_way"].tolist() == [False, True]


def test_place_footprint_gap_is_signed_and_ignores_what_stands_below_the_release(holding: GeometricState) -> None:
    # The held red box set down beside the cyan box (jaw across) 3 cm and 5 mm apart, and 4 mm into
    # it: the gap, or minus the depth, where clearance reads -1 cm for any overlap.
    half_widths = (OBJECTS["red_box"].size[1] + OBJECTS["cyan_box"].size[1]) / 2
    beside = np.array([[*_table_action(0.6, 0.2 + half_widths + gap)[:2], 0.05, math.pi / 2] for gap in (0.03, 0.005, -0.004, -0.02)])
    judged = PLACE.screen_of_states([holding], ["red_box", "table"], beside, np.zeros(4, dtype=int))
    np.testing.assert_allclose(judged["footprint_gap"], [0.03, 0.005, -0.004, -0.02], atol=1e-9)
    np.testing.assert_allclose(judged["clearance"], [0.02, -0.005, -0.01, -0.01], atol=1e-9)
    # The cyan box (7 cm tall) under the rack's plate (16 cm up): a box set down on the plate above it
    # comes nowhere near it (nothing else stands within 5 cm), though their footprints overlap.
    under = GeometricState({**holding.objects, "cyan_box": on_table("cyan_box", 0.44, -0.33)}, holding.ee_position, held="red_box")
    on_rack = PLACE.screen_of_states([under], ["red_box", "rack"], np.array([[0.0, 0.0, 0.05, 0.0]]), np.zeros(1, dtype=int))
    assert on_rack["footprint_gap"][0] == pytest.approx(0.05) and on_rack["clearance"][0] == pytest.approx(-0.01)


def _grasp(theta: float = 0.0, z: float = 0.0) -> np.ndarray:
    """The physical Pick action of a grasp at the object's centre, ``z`` metres up, jaw yawed ``theta``."""
    return np.array([0.0, 0.0, z, theta])


def test_pick_in_the_way_sees_fingers_on_the_rack_plate_a_neighbour_or_the_table() -> None:
    # The rack's plate spans y <= -0.22 at x in [0.28, 0.60]; the red box stands 1.5 cm from its edge.
    # At θ = 0 the jaw opens along world y and the outer finger (y in [-0.246, -0.220]) lands under
    # the plate's edge; at θ = π/2 it opens along x and both fingers stay 3 cm from the plate.
    beside_rack = scene(rack=RACK_IN_WORKSPACE, red_box=on_table("red_box", 0.5, -0.18))
    grasps = np.array([_grasp(0.0), _grasp(math.pi / 2)])
    assert PICK.in_the_way(beside_rack, ["red_box"], grasps).tolist() == [True, False]
    # A neighbour along the jaw: a finger reaches 66.4 mm from the grasp, the blue box's near face
    # stands 25 mm from its centre.
    def neighbour(gap: float) -> GeometricState:
        return scene(red_box=on_table("red_box", 0.5, 0.1), blue_box=on_table("blue_box", 0.5, 0.1 + 0.0664 + 0.025 + gap))

    assert PICK.in_the_way(neighbour(0.003), ["red_box"], grasps).tolist() == [True, False]
    assert PICK.in_the_way(neighbour(0.008), ["red_box"], grasps).tolist() == [False, False]
    # The hook lies 2 cm high: a grasp 1.5 cm below its centre puts the fingertips (8 mm under the EE)
    # into the table; one at its centre does not.
    hook = scene(hook=on_table("hook", 0.5, 0.1))
    assert OBJECTS["hook"].size[2] == pytest.approx(0.04)
    assert PICK.in_the_way(hook, ["hook"], np.array([_grasp(z=-0.015), _grasp(z=0.0)])).tolist() == [True, False]
    # Beyond the workspace every grasp is refused, as the precheck refuses it.
    far = scene(red_box=on_table("red_box", 0.72, 0.0))
    assert PICK.precheck(far, ["red_box"], _grasp()) == "not_in_workspace"
    assert PICK.in_the_way(far, ["red_box"], grasps).tolist() == [True, True]
    # The same facts for grasps in several states at once (a plan step's samples): each its own state's.
    states = [neighbour(0.003), scene(red_box=on_table("red_box", 0.5, 0.1), blue_box=on_table("blue_box", 0.5, 0.1 + 0.0664 + 0.025 + 0.008)),
              scene(red_box=on_table("red_box", 0.72, 0.0), blue_box=on_table("blue_box", 0.3, 0.3))]
    batch = np.array([_grasp(0.0), _grasp(0.0), _grasp(math.pi / 2), _grasp(0.0)])
    judged = PICK.screen_of_states(states, ["red_box"], batch, np.array([0, 1, 0, 2]))["in_the_way"]
    assert judged.tolist() == [True, False, False, True]


def test_pick_grasp_bounds_keep_a_box_grasp_on_the_box() -> None:
    low, high = PICK.grasp_bounds(["cyan_box"])  # 58 mm square: faces 29 mm out, grasp points 1 cm inside them
    np.testing.assert_allclose(high, [0.019, 0.019, PICK.action_high[2], PICK.action_high[3]])
    np.testing.assert_allclose(low, [-0.019, -0.019, PICK.action_low[2], PICK.action_low[3]])
    low, high = PICK.grasp_bounds(["hook"])
    np.testing.assert_allclose(low, PICK.action_low)
    np.testing.assert_allclose(high, PICK.action_high)


def test_finger_footprints_and_the_opening_on_a_held_box(holding: GeometricState) -> None:
    from t2m_core.domain.primitives.fingers import finger_footprints, held_opening

    # Open jaw at yaw 0: the pads' inner faces 40 mm either side along world y, the bodies' outer
    # faces 66.4 mm out, 21 mm wide along x; at yaw π/2 the same along x.
    left, right = finger_footprints(np.array([[0.5, 0.1]]), np.array([0.0]), 0.04)[0]
    np.testing.assert_allclose(left.min(axis=0), [0.4895, 0.14], atol=1e-9)
    np.testing.assert_allclose(left.max(axis=0), [0.5105, 0.1664], atol=1e-9)
    np.testing.assert_allclose(right.min(axis=0), [0.4895, 0.0336], atol=1e-9)
    turned = finger_footprints(np.array([[0.5, 0.1]]), np.array([math.pi / 2]), 0.04)[0]
    np.testing.assert_allclose(turned[0].min(axis=0), [0.5 - 0.0664, 0.0895], atol=1e-9)
    # Closed on the 50 mm red box centred under the EE, the pads stand 25 mm either side.
    assert held_opening(holding, "red_box") == pytest.approx(0.025)


def test_place_predicts_too_high_where_the_held_object_would_drop_more_than_5_cm(holding: GeometricState) -> None:
    # The hook (4 cm thick) held flat with its origin 2 cm below the EE: its lowest point hangs 4 cm
    # below the EE, so an EE released 6, 8.5 and 10 cm above the table leaves it 2, 4.5 and 6 cm up;
    # the descent's check fails a drop of more than 5 cm (too_high). The held box hangs 8.9 cm
    # below the EE: no release height of the action's range (z ≤ 0.1 m) drops it too far.
    hook_held = GeometricState({**holding.objects, "hook": ObjectPose([0.45, 0.1, 0.38])}, holding.ee_position, held="hook")
    del hook_held.objects["red_box"]
    heights = np.array([[*_table_action(0.5, 0.0)[:2], z, 0.0] for z in (0.06, 0.085, 0.1)])
    judged = PLACE.screen_of_states([hook_held], ["hook", "table"], heights, np.zeros(3, dtype=int))
    np.testing.assert_allclose(judged["support_gap"], [0.02, 0.045, 0.06], atol=1e-9)
    assert judged["too_high"].tolist() == [False, False, True]
    box = PLACE.screen_of_states([holding], ["red_box", "rack"], heights, np.zeros(3, dtype=int))
    assert not box["too_high"].any() and box["support_gap"].max() == pytest.approx(0.011)
