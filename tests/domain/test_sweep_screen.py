"""The screened heuristic of Pull and Push: the analytic screen's predictions on hand-built scenes and
the sampler that redraws the reference heuristic until the screen passes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from t2m_core.data.scenes import draw_data_task
from t2m_core.domain.geometry import polygon_edges
from t2m_core.domain.primitives import PRIMITIVES
from t2m_core.domain.primitives.hook_sweep import SCREEN_DRAWS, sweep_poses
from t2m_core.domain.primitives.sweep_screen import (
    CLEARANCE_RANGE,
    EE_MAX_RADIUS,
    EE_MIN_RADIUS,
    TOOL_CLEARANCE,
    nearest_gaps,
)
from t2m_core.domain.sampling import sample_initial_state
from t2m_core.domain.state import GeometricState
from tests.domain.scenes import RACK_BEYOND, on_table, scene
from tests.domain.sweep_screen_reference import reference_screen

PICK, PLACE, PULL, PUSH = (PRIMITIVES[n] for n in ("pick", "place", "pull", "push"))
THETA = math.pi / 8
PULL_ARGS = ("blue_box", "hook")
PUSH_ARGS = ("blue_box", "hook", "rack")


def holding_hook(box_xy, *, grasp_x: float, rack: bool = True, **others) -> GeometricState:
    """The hook in hand at the home pose, yaw 0, grasped on the handle ``grasp_x`` from its centre
    (the EE 0.09 m to the handle's side of the hook's origin, 0.08 m above it); the blue box at
    ``box_xy``; the rack beyond the workspace unless ``rack`` is false."""
    hook = on_table("hook", 0.402 - grasp_x, 0.09)
    hook = type(hook)(hook.position + np.array([0.0, 0.0, 0.4 - 0.08 - hook.position[2]]), hook.quaternion)
    racks = {"rack": RACK_BEYOND} if rack else {}
    state = scene(**racks, hook=hook, blue_box=on_table("blue_box", *box_xy), **others)
    return GeometricState(state.objects, np.array([0.402, 0.0, 0.4]), np.array([0.0, 0.0, 0.0, 1.0]), "hook")


PULL_SCENE = holding_hook((0.8, 0.0), grasp_x=-0.1, rack=False)  # the handle's tail, as for a pull
PUSH_SCENE = holding_hook((0.55, 0.0), grasp_x=0.0)  # the handle's centre, as for a push


def pull(r_pull: float, y: float) -> np.ndarray:
    return np.array([PULL.heuristic_reach(PULL_ARGS), r_pull, y, THETA])


def push(r_push: float, y: float) -> np.ndarray:
    return np.array([PUSH.heuristic_reach(PUSH_ARGS), r_push, y, THETA])


def test_prediction_moves_the_box_with_the_head_after_the_gap() -> None:
    poses = sweep_poses(PULL_SCENE, "blue_box", "hook", *pull(-0.3, -0.03)[:, None])  # a batch of one
    prediction = PULL.predict(PULL_SCENE, PULL_ARGS, pull(-0.3, -0.03)[None])
    (moved,) = prediction.target_shift
    # Straight towards the base, a little less than the 0.3 m sweep (the head first closes its gap).
    assert moved[1] == pytest.approx(0.0, abs=1e-9)
    assert -0.3 < moved[0] < -0.27
    np.testing.assert_allclose(prediction.ee_path[0, 0], poses.reach_position[0, :2])


def test_pull_screen_accepts_a_clean_pull_into_the_workspace() -> None:
    assert PULL.screen(PULL_SCENE, PULL_ARGS, pull(-0.3, -0.03)) is None


def test_pull_screen_predicts_each_failure() -> None:
    # θ = π/8 swings the handle towards the box: with y > 0 it comes down on the box's top.
    assert PULL.screen(PULL_SCENE, PULL_ARGS, pull(-0.3, 0.05)) == "tipped_over"
    # A reach 0.2 m short of the box puts the head itself on top of it.
    assert PULL.screen(PULL_SCENE, PULL_ARGS, np.array([-0.2, -0.3, -0.03, THETA])) == "tipped_over"
    assert PULL.screen(PULL_SCENE, PULL_ARGS, np.array([-0.08, -0.3, -0.03, THETA])) is None
    # Too short: the box stays beyond the workspace's radius.
    assert PULL.screen(PULL_SCENE, PULL_ARGS, pull(-0.12, -0.03)) == "outside_workspace"
    # Too long: the EE would end within the arm's minimum radius.
    assert PULL.screen(PULL_SCENE, PULL_ARGS, pull(-0.4, -0.03)) == "unreachable"
    # A bystander on the box's way to the base.
    blocked = holding_hook((0.8, 0.0), grasp_x=-0.1, rack=False, red_box=on_table("red_box", 0.6, 0.0))
    assert PULL.screen(blocked, PULL_ARGS, pull(-0.3, -0.03)) == "disturbed"
    far = holding_hook((1.0, 0.3), grasp_x=-0.1, rack=False)
    assert PULL.screen(far, PULL_ARGS, pull(-0.3, -0.03)) == "unreachable"
    not_held = GeometricState(PULL_SCENE.objects, PULL_SCENE.ee_position, PULL_SCENE.ee_quaternion, None)
    assert PULL.screen(not_held, PULL_ARGS, pull(-0.3, -0.03)) == "not_held"


def test_push_screen_wants_the_box_just_under_the_rack() -> None:
    # The rack's near edge is at x = 0.71; the box (front face at 0.575) must end 0.02-0.12 m past it.
    for r_push in (0.22, 0.25, 0.3):
        assert PUSH.screen(PUSH_SCENE, PUSH_ARGS, push(r_push, -0.03)) is None
    assert PUSH.screen(PUSH_SCENE, PUSH_ARGS, push(0.15, -0.03)) == "not_under"
    assert PUSH.screen(PUSH_SCENE, PUSH_ARGS, push(0.35, -0.03)) == "disturbed"
    assert PUSH.screen(PUSH_SCENE, PUSH_ARGS, push(0.4, -0.03)) == "disturbed"
    far = holding_hook((0.6, 0.0), grasp_x=0.18)  # a head grasp: the EE ends 0.18 m past the hook's centre
    assert PUSH.screen(far, PUSH_ARGS, push(0.4, -0.03)) == "unreachable"
    # y > 0 puts the corner at the head's joint on the box, which turns it aside.
    assert PUSH.screen(PUSH_SCENE, PUSH_ARGS, push(0.3, 0.05)) == "not_under"
    # Between the legs only: the angled head drifts the box sideways, into a leg from y = 0.08.
    beside = holding_hook((0.55, 0.08), grasp_x=0.0)
    assert PUSH.screen(beside, PUSH_ARGS, push(0.3, -0.03)) == "disturbed"


@pytest.mark.parametrize("name", ["pull", "push"])
def test_batched_screen_gives_the_per_draw_reference_verdicts(name: str) -> None:
    # Data-generation scenes; per scene heuristic and uniform draws and the sampler's pick (which passes).
    primitive, rng = PRIMITIVES[name], np.random.default_rng(17)
    seen: list[str | None] = []
    for seed in range(40):
        task = draw_data_task(name, True, rng)
        state, arguments = sample_initial_state(task.objects, task.initial_state, seed).state, task.call.args
        draws = np.concatenate(
            (
                primitive.heuristic_draws(arguments, rng, 8),
                rng.uniform(primitive.action_low, primitive.action_high, (8, 4)),
                primitive.screened_physical(state, arguments, rng)[None],
            )
        )
        expected = [reference_screen(name, state, arguments, physical) for physical in draws]
        assert primitive.screen_draws(state, arguments, draws) == expected
        assert primitive.screen(state, arguments, draws[-1]) == expected[-1]
        seen += expected
    assert len(seen) == 40 * 17 and seen.count(None) >= 10
    assert {"unreachable", "tipped_over", "disturbed"} < set(seen)


def test_heuristic_draws_are_the_reference_heuristic_in_a_row() -> None:
    rng, twin = np.random.default_rng(4), np.random.default_rng(4)
    draws = PUSH.heuristic_draws(PUSH_ARGS, rng, 5)
    for draw in draws:
        expected = twin.uniform(PUSH.action_low, PUSH.action_high)  # the heuristic as published
        expected[0], expected[3] = PUSH.heuristic_reach(PUSH_ARGS), THETA
        np.testing.assert_array_equal(draw, expected)
    np.testing.assert_array_equal(
        PUSH.heuristic_physical(PUSH_SCENE, PUSH_ARGS, rng), PUSH.heuristic_draws(PUSH_ARGS, twin, 1)[0]
    )


def test_screened_sampler_keeps_the_heuristic_support_and_passes_the_screen() -> None:
    rng = np.random.default_rng(5)
    for _ in range(20):
        physical = PUSH.screened_physical(PUSH_SCENE, PUSH_ARGS, rng)
        assert physical[0] == pytest.approx(PUSH.heuristic_reach(PUSH_ARGS)) and physical[3] == pytest.approx(THETA)
        assert np.all(physical >= PUSH.action_low) and np.all(physical <= PUSH.action_high)
        assert PUSH.screen(PUSH_SCENE, PUSH_ARGS, physical) is None
        action = PULL.screened_action(PULL_SCENE, PULL_ARGS, rng)
        assert PULL.screen(PULL_SCENE, PULL_ARGS, PULL.to_physical(action)) is None
    # Reproducible from the generator's state.
    a = PULL.screened_action(PULL_SCENE, PULL_ARGS, np.random.default_rng(9))
    b = PULL.screened_action(PULL_SCENE, PULL_ARGS, np.random.default_rng(9))
    np.testing.assert_array_equal(a, b)


def test_screened_sampler_tries_the_whole_action_range_where_the_heuristic_cannot_work() -> None:
    # Here no heuristic draw passes (the EE ends beyond 0.72 m or the handle lands on the box); 4 % of
    # uniform draws do.
    far = holding_hook((0.85, 0.3), grasp_x=-0.1, rack=False)
    rng = np.random.default_rng(3)
    assert all(PULL.screen(far, PULL_ARGS, PULL.heuristic_physical(far, PULL_ARGS, rng)) for _ in range(SCREEN_DRAWS))
    physical = PULL.screened_physical(far, PULL_ARGS, rng)
    assert PULL.screen(far, PULL_ARGS, physical) is None
    assert physical[0] != pytest.approx(PULL.heuristic_reach(PULL_ARGS))


def test_screened_sampler_falls_back_to_the_heuristic_when_nothing_passes() -> None:
    beyond_reach = holding_hook((1.0, 0.3), grasp_x=-0.1, rack=False)
    rng, twin = np.random.default_rng(2), np.random.default_rng(2)
    physical = PULL.screened_physical(beyond_reach, PULL_ARGS, rng)
    for _ in range(SCREEN_DRAWS):
        expected = PULL.heuristic_physical(beyond_reach, PULL_ARGS, twin)
    np.testing.assert_array_equal(physical, expected)  # the last heuristic draw (no uniform one passed)


def test_screened_pick_grasps_a_square_box_across_either_face_pair() -> None:
    state = scene(red_box=on_table("red_box", 0.5, 0.0), hook=on_table("hook", 0.4, 0.3))
    rng = np.random.default_rng(1)
    grasps = np.array([PICK.screened_physical(state, ["red_box"], rng) for _ in range(400)])
    np.testing.assert_array_equal(grasps[:, :3], 0.0)  # still the centred grasp
    assert set(np.round(grasps[:, 3], 6)) == {0.0, round(0.5 * math.pi, 6)}
    assert 150 < np.sum(grasps[:, 3] > 0) < 250  # about half across the other faces
    # The hook is not square: its grasps stay the reference heuristic's, draw for draw.
    for seed in range(20):
        np.testing.assert_array_equal(
            PICK.screened_action(state, ["hook"], np.random.default_rng(seed)),
            PICK.heuristic_action(state, ["hook"], np.random.default_rng(seed)),
        )


def test_primitives_without_a_screen_use_the_heuristic() -> None:
    state = scene(red_box=on_table("red_box", 0.5, 0.0))
    for seed in range(20):
        np.testing.assert_array_equal(
            PLACE.screened_action(state, ["red_box", "table"], np.random.default_rng(seed)),
            PLACE.heuristic_action(state, ["red_box", "table"], np.random.default_rng(seed)),
        )
    for _ in range(50):
        action = PUSH.screened_exploration_action(PUSH_SCENE, PUSH_ARGS, np.random.default_rng(_))
        assert action.shape == (4,) and np.all(np.abs(action) <= 1.0)


BLOCKED_PULL = holding_hook((0.8, 0.0), grasp_x=-0.1, rack=False, red_box=on_table("red_box", 0.6, 0.0))
"""A pull whose box's way to the base crosses the red box (task3's pull-first failures)."""


def test_in_the_way_sees_a_bystander_on_the_sweep_and_nothing_else() -> None:
    draws = np.array([pull(-0.3, -0.03), pull(-0.2, 0.0), pull(-0.3, 0.05)])
    assert PULL.in_the_way(BLOCKED_PULL, PULL_ARGS, draws).tolist() == [True, True, True]
    aside = holding_hook((0.8, 0.0), grasp_x=-0.1, rack=False, red_box=on_table("red_box", 0.45, -0.35))
    assert PULL.in_the_way(aside, PULL_ARGS, draws).tolist() == [False, False, False]
    assert PULL.in_the_way(PULL_SCENE, PULL_ARGS, draws).tolist() == [False, False, False]  # no bystander at all
    # Whatever else the screen says: the third draw tips the box first, yet it sweeps through the red box.
    assert PULL.screen(BLOCKED_PULL, PULL_ARGS, draws[2]) == "tipped_over"


def test_the_screen_of_many_states_judges_each_sample_in_its_own_state() -> None:
    """Samples of the blocked and the aside pull mixed in one batch, as a planner's predicted states
    are: each gets the verdict of its own state (the hand-placed facts above)."""
    aside = holding_hook((0.8, 0.0), grasp_x=-0.1, rack=False, red_box=on_table("red_box", 0.45, -0.35))
    draws = np.array([pull(-0.3, -0.03), pull(-0.2, 0.0), pull(-0.3, 0.05), pull(-0.3, -0.03)])
    state_of = np.array([0, 1, 1, 0])
    assert PULL.screen_of_states([BLOCKED_PULL, aside], PULL_ARGS, draws, state_of)["in_the_way"].tolist() == [True, False, False, True]
    assert PULL.screen_of_states([aside, BLOCKED_PULL], PULL_ARGS, draws, state_of)["in_the_way"].tolist() == [False, True, True, False]
    # too long a sweep (the EE ends within the arm's minimum radius) and a box too far (as above)
    far = holding_hook((1.0, 0.3), grasp_x=-0.1, rack=False, red_box=on_table("red_box", 0.45, -0.35))
    reach = PULL.screen_of_states([aside, far], PULL_ARGS, np.array([pull(-0.4, -0.03), pull(-0.3, -0.03), pull(-0.3, -0.03)]), np.array([0, 0, 1]))
    assert reach["unreachable"].tolist() == [True, False, True]


def test_the_margins_behind_the_flags_measure_the_sweep_in_metres() -> None:
    """``clearance``: a bystander moved 1 cm further from the pull's path (its near edge parallel to
    the path) clears it by 1 cm more, up to the range measured; ``reach_margin``: the EE's distance
    inside the arm's annulus at the reach and the sweep end, from the sweep's own poses."""
    draw = pull(-0.3, -0.03)[None]
    clearances = []
    for y in (0.19, 0.20, 0.21, 0.22, 0.30):
        state = holding_hook((0.8, 0.0), grasp_x=-0.1, rack=False, red_box=on_table("red_box", 0.6, y))
        clearances.append(float(PULL.screen_of_states([state], PULL_ARGS, draw, np.zeros(1, dtype=int))["clearance"][0]))
    np.testing.assert_allclose(np.diff(clearances[:4]), 0.01, atol=1e-9)
    assert 0.0 < clearances[0] < 0.01 and clearances[-1] == CLEARANCE_RANGE
    aside = holding_hook((0.8, 0.0), grasp_x=-0.1, rack=False, red_box=on_table("red_box", 0.45, -0.35))
    draws = np.array([pull(-0.3, -0.03), pull(-0.2, 0.0), pull(-0.3, 0.05), pull(-0.4, -0.03)])
    judged = PULL.screen_of_states([BLOCKED_PULL, aside], PULL_ARGS, draws, np.array([0, 0, 1, 1]))
    assert judged["clearance"].tolist()[:2] == [-TOOL_CLEARANCE] * 2  # the swept box runs into the red box
    np.testing.assert_array_equal(judged["in_the_way"], judged["clearance"] < 0.0)
    poses = sweep_poses(aside, "blue_box", "hook", *draws.T)
    radii = np.linalg.norm(np.stack((poses.reach_position[:, :2], poses.end_position[:, :2])), axis=-1)  # (2, B)
    np.testing.assert_allclose(judged["reach_margin"], np.minimum(EE_MAX_RADIUS - radii, radii - EE_MIN_RADIUS).min(axis=0))
    assert judged["reach_margin"][3] < 0.0 and judged["unreachable"].tolist() == [False, False, False, True]


def test_sweep_gap_is_signed_and_sees_only_what_stands_at_the_sweeps_height() -> None:
    """``sweep_gap``: the plain gap of the swept hook and box from a bystander while they lie apart
    (the unsigned ``clearance`` plus the 1 cm it keeps), then minus how deep they reach into it as the
    red box moves 1 cm at a time into the pull's path (its near edge parallel to the path), where
    ``clearance`` reads −1 cm for any overlap; the same box raised above the sweep (standing on a
    rack's plate) is no obstacle to it, though ``clearance`` still counts its footprint."""
    draw = pull(-0.3, -0.03)[None]
    ys = (0.20, 0.19, 0.18, 0.17, 0.16, 0.15)
    states = [holding_hook((0.8, 0.0), grasp_x=-0.1, rack=False, red_box=on_table("red_box", 0.6, y)) for y in ys]
    judged = [PULL.screen_of_states([state], PULL_ARGS, draw, np.zeros(1, dtype=int)) for state in states]
    gap, clearance = (np.array([float(j[name][0]) for j in judged]) for name in ("sweep_gap", "clearance"))
    batch = PULL.screen_of_states(states[::-1], PULL_ARGS, draw.repeat(len(ys), axis=0), np.arange(len(ys))[::-1])
    np.testing.assert_array_equal(batch["sweep_gap"], gap)  # each sample in its own state, as judged alone
    assert 0.0 < clearance[1] < 0.01
    expected = clearance[1] + TOOL_CLEARANCE - (0.19 - np.array(ys))  # the box 1 cm deeper each step
    np.testing.assert_allclose(gap, expected, atol=1e-9)
    assert gap[-1] < -0.02 and np.all(clearance[gap < 0.0] == -TOOL_CLEARANCE)
    np.testing.assert_allclose(clearance[:2], gap[:2] - TOOL_CLEARANCE, atol=1e-12)
    raised = on_table("red_box", 0.6, 0.15)
    raised = type(raised)(raised.position + np.array([0.0, 0.0, 0.2]), raised.quaternion)
    above = PULL.screen_of_states([holding_hook((0.8, 0.0), grasp_x=-0.1, rack=False, red_box=raised)], PULL_ARGS, draw, np.zeros(1, dtype=int))
    assert above["sweep_gap"][0] == CLEARANCE_RANGE and above["clearance"][0] < 0.0
    alone = PULL.screen_of_states([PULL_SCENE], PULL_ARGS, draw, np.zeros(1, dtype=int))
    assert alone["sweep_gap"][0] == alone["clearance"][0] == CLEARANCE_RANGE  # no bystander at all


def test_push_margins_follow_the_box_under_the_rack() -> None:
    """``under_depth`` is below the screen's 2 cm band where it says ``not_under``, inside it where it
    passes, beyond 12 cm where the box is driven into the far legs; once under, it grows with the
    box's predicted travel. ``leg_clearance`` shrinks as the box goes deeper between the legs."""
    lengths = (0.15, 0.2, 0.25, 0.3, 0.35)
    draws = np.array([push(r_push, -0.03) for r_push in lengths])
    judged = PUSH.screen_of_states([PUSH_SCENE], PUSH_ARGS, draws, np.zeros(len(draws), dtype=int))
    verdicts = [PUSH.screen(PUSH_SCENE, PUSH_ARGS, draw) for draw in draws]
    assert verdicts == ["not_under", "not_under", None, None, "disturbed"]
    depth = judged["under_depth"]
    assert depth[0] < 0.02 and depth[1] < 0.02 and 0.02 < depth[2] < depth[3] < 0.12 < depth[4]
    travel = np.linalg.norm(PUSH.predict(PUSH_SCENE, PUSH_ARGS, draws).target_shift, axis=-1)
    np.testing.assert_allclose(np.diff(depth[2:]), np.diff(travel[2:]), atol=1e-9)
    legs = judged["leg_clearance"]
    assert legs[0] == CLEARANCE_RANGE and np.all(np.diff(legs) <= 1e-12) and legs[-1] < CLEARANCE_RANGE
    assert "under_depth" not in PULL.screen_of_states([PULL_SCENE], PULL_ARGS, pull(-0.3, -0.03)[None], np.zeros(1, dtype=int))


def test_nearest_gaps_are_the_distances_to_the_nearest_obstacle_up_to_the_range() -> None:
    square = np.array([[0.0, 0.0], [0.1, 0.0], [0.1, 0.1], [0.0, 0.1]])
    obstacles = np.stack((square + [0.13, 0.0], square + [0.0, 0.12]))  # 3 cm and 2 cm away
    regions = np.stack((square, square + [0.0, -0.5]))  # the second far from both
    gaps = nearest_gaps(regions, polygon_edges(regions), obstacles, 0.05)
    np.testing.assert_allclose(gaps, [0.02, 0.05])
    assert nearest_gaps(regions, polygon_edges(regions), obstacles, 0.015).tolist() == [0.015, 0.015]


def test_obstructed_sampler_sweeps_into_a_bystander_about_half_the_time() -> None:
    rng = np.random.default_rng(6)
    physical = np.array([PULL.obstructed_physical(BLOCKED_PULL, PULL_ARGS, rng) for _ in range(200)])
    assert np.all(physical >= PULL.action_low) and np.all(physical <= PULL.action_high)
    hits = PULL.in_the_way(BLOCKED_PULL, PULL_ARGS, physical).sum()
    rng = np.random.default_rng(6)
    screened = PULL.in_the_way(BLOCKED_PULL, PULL_ARGS, np.array([PULL.screened_physical(BLOCKED_PULL, PULL_ARGS, rng) for _ in range(200)])).sum()
    # Here the screened sampler often finds no passing draw and falls back to a heuristic one through
    # the red box (78 of 200); the obstructed one aims half its draws there: about 78 + (200 - 78) / 2.
    assert 40 < screened < 120 and hits - screened > 40 and hits < 180
    # Without a bystander nothing can be in the way: every draw is the screened sampler's, passing its screen.
    rng = np.random.default_rng(6)
    for _ in range(20):
        assert PULL.screen(PULL_SCENE, PULL_ARGS, PULL.obstructed_physical(PULL_SCENE, PULL_ARGS, rng)) is None
        action = PUSH.obstructed_exploration_action(PUSH_SCENE, PUSH_ARGS, rng)
        assert action.shape == (4,) and np.all(np.abs(action) <= 1.0)
