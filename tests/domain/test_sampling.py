"""Initial-state sampling (docs/guide/primitives.md#initial-state-sampling): every task's propositions hold on the sampled state,
the samplers' geometry, and determinism per seed."""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
import pytest

from t2m_core.domain.geometry import (
    closest_distance,
    is_upright,
    object_geometry,
    quat_conjugate,
    quat_yaw,
    rotate,
)
from t2m_core.domain.propositions import Proposition, PropositionError, canonical_order
from t2m_core.domain.sampling import (
    DROP_HEIGHT,
    MAX_SEED_ATTEMPTS,
    SampledScene,
    SamplingError,
    _sample_candidate,
    candidate_windows,
    clear_cache,
    random_robot_pose,
    sample_initial_state,
    sample_task,
)
from t2m_core.evaluation import SEED_SPACING
from t2m_core.tasks import list_tasks, load_task
from t2m_core.testing.success_facts import bottom_z, centre_in_support_frame, top_z, world_bounds

TASKS = {task.id: task for task in list_tasks()}
RACK_IN_WORKSPACE = ["aligned(rack)", "poslimit(rack)", "inworkspace(rack)", "on(rack, table)"]
RACK_BEYOND = ["aligned(rack)", "poslimit(rack)", "beyondworkspace(rack)", "on(rack, table)"]


ZONE_TESTS = {
    "inworkspace": lambda x, r: x >= 0.40 and r < 0.70,
    "incollisionzone": lambda x, r: 0.40 <= x < 0.50 and r < 0.70,
    "inoperationalzone": lambda x, r: 0.50 <= x < 0.60 and r < 0.70,
    "inobstructionzone": lambda x, r: x >= 0.575 and r < 0.70,
    "beyondworkspace": lambda x, r: r >= 0.70,
}
"""Zone membership as the world page states it (docs/guide/world.md#constants-and-zones)."""
RACK_POSITIONS = {"inworkspace": (0.44, -0.33), "beyondworkspace": (0.82, 0.0)}


def independent_problems(proposition: str, state) -> list[str]:
    """Why ``state``'s poses contradict ``proposition``, by plain geometry written here rather than
    the predicates the sampler accepted its samples with. ``free``, ``nonblocking`` and the sampling
    markers are judged by their own tests below."""
    prop = Proposition.parse(proposition)
    name, args, poses = prop.predicate, prop.args, state.objects
    a = args[0]
    if name == "on":
        support = args[1]
        centre, low, high = centre_in_support_frame(a, poses[a], support, poses[support])
        if abs(bottom_z(a, poses[a]) - top_z(support, poses[support])) > 1e-6:
            return [f"{prop}: {a} does not rest on {support}'s top"]
        if np.any(centre < low) or np.any(centre > high):
            return [f"{prop}: {a}'s centre is not over {support}"]
    elif name == "inhand" and (state.held != a or bottom_z(a, poses[a]) < 0.1):
        return [f"{prop}: {a} is not held up in the gripper"]
    elif name == "under":
        centre, low, high = centre_in_support_frame(a, poses[a], args[1], poses[args[1]])
        if top_z(a, poses[a]) >= top_z(args[1], poses[args[1]]) or np.any(centre < low) or np.any(centre > high):
            return [f"{prop}: {a} is not below and inside {args[1]}"]
    elif name in ZONE_TESTS and not (a == "rack" and name == "inworkspace"):  # the rack's x is set by poslimit
        x, y = poses[a].position[:2]
        if not ZONE_TESTS[name](x, math.hypot(x, y)):
            return [f"{prop}: {a} at ({x:.3f}, {y:.3f}) is outside the zone"]
    elif name == "poslimit":
        offsets = [np.max(np.abs(poses[a].position[:2] - centre)) for centre in RACK_POSITIONS.values()]
        if min(offsets) > 0.01 + 1e-9:
            return [f"{prop}: {a} is not within 0.01 m of {list(RACK_POSITIONS.values())}"]
    elif name == "infront":
        (x, y), (low, high) = poses[a].position[:2], world_bounds(args[1], poses[args[1]])
        if not (x < low[0] and low[1] < y < high[1]):
            return [f"{prop}: {a} at ({x:.3f}, {y:.3f}) is not in front of {args[1]}"]
    return []


def assert_valid(scene: SampledScene, objects, propositions) -> None:
    """Every proposition's geometry holds (judged independently), objects keep the task order,
    nothing interpenetrates."""
    state = scene.state
    assert tuple(state.objects) == tuple(objects)
    failing = [problem for p in propositions for problem in independent_problems(str(p), state)]
    assert not failing, f"seed {scene.accepted_seed}: {failing}"
    resting = [n for n in objects if n not in ("table", state.held)]
    under = {(p.split("(")[1].split(",")[0], "rack") for p in map(str, propositions) if p.startswith("under(")}
    for i, a in enumerate(resting):
        for b in resting[i + 1 :]:
            if (a, b) in under or (b, a) in under:
                continue
            ga, gb = object_geometry(a, state.objects[a]), object_geometry(b, state.objects[b])
            stacked = abs(ga.min_z - gb.max_z) < 1e-9 or abs(gb.min_z - ga.max_z) < 1e-9
            assert stacked or closest_distance(ga, gb) > 0.0, f"{a} and {b} overlap (seed {scene.accepted_seed})"


# --------------------------------------------------------------------------------------------------
# The task suite
# --------------------------------------------------------------------------------------------------


def check_task_seeds(task_id: str, seeds: range) -> None:
    task = TASKS[task_id]
    for seed in seeds:
        scene = sample_task(task, seed)
        assert scene.accepted_seed == seed + scene.rejections
        assert_valid(scene, task.objects, task.initial_state)


@pytest.mark.parametrize("task_id", sorted(TASKS))
def test_first_seeds_of_every_task_are_valid(task_id: str) -> None:
    check_task_seeds(task_id, range(3))


@pytest.mark.slow
@pytest.mark.parametrize("task_id", sorted(TASKS))
def test_seeds_0_to_99_of_every_task_are_valid(task_id: str) -> None:
    check_task_seeds(task_id, range(100))


def test_determinism_per_seed() -> None:
    task = load_task("task4")
    first = sample_task(task, 5)
    clear_cache()  # recomputed from scratch, not served from the memo
    second = sample_task(task, 5)
    assert first is not second
    assert (first.accepted_seed, first.rejections) == (second.accepted_seed, second.rejections)
    for name in task.objects:
        np.testing.assert_array_equal(first.state.objects[name].position, second.state.objects[name].position)
        np.testing.assert_array_equal(first.state.objects[name].quaternion, second.state.objects[name].quaternion)
    np.testing.assert_array_equal(first.robot_pose.position, second.robot_pose.position)
    other = sample_task(task, first.accepted_seed + 1)
    assert not np.allclose(other.state.objects["red_box"].position, first.state.objects["red_box"].position)


def test_accepted_seed_is_a_fixed_point() -> None:
    task = load_task("task1")
    scene = sample_task(task, 0)
    again = sample_task(task, scene.accepted_seed)
    assert (again.accepted_seed, again.rejections) == (scene.accepted_seed, 0)
    np.testing.assert_array_equal(again.state.objects["hook"].position, scene.state.objects["hook"].position)


def test_sampled_poses_are_read_only() -> None:
    scene = sample_task(load_task("task0"), 0)
    with pytest.raises(ValueError):
        scene.state.objects["blue_box"].position[0] = 1.0


# --------------------------------------------------------------------------------------------------
# The samplers
# --------------------------------------------------------------------------------------------------


def sample_many(objects, propositions, seeds=range(30)) -> list[SampledScene]:
    return [sample_initial_state(objects, propositions, seed) for seed in seeds]


def test_rack_in_workspace_is_aligned_and_pos_limited() -> None:
    for scene in sample_many(["table", "rack"], RACK_IN_WORKSPACE):
        rack = scene.state.objects["rack"]
        np.testing.assert_allclose(rack.position[:2], [0.44, -0.33], atol=0.01 + 1e-12)
        assert rack.position[2] == pytest.approx(0.16)
        deviation = quat_yaw(rack.quaternion) - math.pi / 2
        assert 0.002 <= abs(deviation) <= 0.1 + 1e-12


def test_rack_beyond_workspace_and_random_zone_without_one() -> None:
    for scene in sample_many(["table", "rack"], RACK_BEYOND):
        rack = scene.state.objects["rack"]
        np.testing.assert_allclose(rack.position[:2], [0.82, 0.0], atol=0.01 + 1e-12)
        assert abs(quat_yaw(rack.quaternion)) <= 0.1 + 1e-12
    anchors = {
        tuple(np.round(s.state.objects["rack"].position[:2], 1))
        for s in sample_many(["table", "rack"], ["aligned(rack)", "poslimit(rack)", "on(rack, table)"])
    }
    assert anchors == {(0.4, -0.3), (0.8, 0.0)}


@pytest.mark.parametrize(
    ("zone", "test"),
    [
        ("inworkspace", lambda x, r: x >= 0.40 and r < 0.70),
        ("incollisionzone", lambda x, r: 0.40 <= x < 0.50 and r < 0.70),
        ("inoperationalzone", lambda x, r: 0.50 <= x < 0.60 and r < 0.70),
        ("inobstructionzone", lambda x, r: x >= 0.575 and r < 0.70),
        ("beyondworkspace", lambda x, r: r >= 0.70),
    ],
)
def test_zone_samples_land_in_their_zone(zone, test) -> None:
    for scene in sample_many(["table", "cyan_box"], [f"{zone}(cyan_box)", "on(cyan_box, table)"]):
        box = scene.state.objects["cyan_box"]
        x, r = box.position[0], float(np.hypot(*box.position[:2]))
        assert test(x, r)
        assert box.position[2] == pytest.approx(0.035)  # resting on the table
        assert is_upright(box.quaternion)


def test_default_zone_and_yaw_spread() -> None:
    scenes = sample_many(["table", "red_box"], ["on(red_box, table)"], range(200))
    xs = np.array([s.state.objects["red_box"].position[0] for s in scenes])
    yaws = np.array([quat_yaw(s.state.objects["red_box"].quaternion) for s in scenes])
    assert xs.min() >= 0.28 and xs.max() <= 0.90
    assert xs.min() < 0.35 and xs.max() > 0.80  # the default box is x ∈ [0.28, 0.90] minus margins
    assert yaws.min() < -2.5 and yaws.max() > 2.5  # unaligned: uniform yaw


def test_box_on_rack_rests_on_its_top() -> None:
    props = [*RACK_IN_WORKSPACE, "on(red_box, rack)"]
    for scene in sample_many(["table", "rack", "red_box"], props):
        box, rack = scene.state.objects["red_box"], scene.state.objects["rack"]
        assert box.position[2] == pytest.approx(0.16 + 0.059)
        local = rotate(quat_conjugate(rack.quaternion), box.position - rack.position)
        assert abs(local[0]) <= 0.11 and abs(local[1]) <= 0.16


def test_stacked_box_uses_the_fractional_stable_region() -> None:
    # A 0.057 m box on a 0.05 m box: the shrunk top rectangle is empty, so the fractional bounds
    # [min(0.25ρ, 0.45), max(0.55, min(0.75ρ, 0.95))] × 0.05 m, re-centred, apply (ρ ≥ 57/50).
    props = ["on(red_box, table)", "on(yellow_box, red_box)"]
    for scene in sample_many(["table", "red_box", "yellow_box"], props):
        red, yellow = scene.state.objects["red_box"], scene.state.objects["yellow_box"]
        local = rotate(quat_conjugate(red.quaternion), yellow.position - red.position)
        assert np.all(local[:2] >= 0.25 * 0.057 / 0.05 * 0.05 - 0.025 - 1e-9)
        assert np.all(local[:2] <= 0.95 * 0.05 - 0.025 + 1e-9)
        assert yellow.position[2] == pytest.approx(0.118 + 0.033)


def test_under_redirects_into_the_rack_footprint() -> None:
    props = [*RACK_BEYOND, "under(cyan_box, rack)", "on(cyan_box, table)"]
    for scene in sample_many(["table", "rack", "cyan_box"], props):
        assert independent_problems("under(cyan_box, rack)", scene.state) == []
        assert scene.state.objects["cyan_box"].position[2] == pytest.approx(0.035)


def test_infront_box_is_between_robot_and_rack() -> None:
    props = [*RACK_BEYOND, "inoperationalzone(cyan_box)", "infront(cyan_box, rack)", "on(cyan_box, table)"]
    for scene in sample_many(["table", "rack", "cyan_box"], props):
        box = scene.state.objects["cyan_box"].position
        rack_box = object_geometry("rack", scene.state.objects["rack"]).aabb
        assert 0.50 <= box[0] < 0.60 and box[0] < rack_box[0, 0]
        assert rack_box[0, 1] < box[1] < rack_box[1, 1]


def test_free_keeps_boxes_apart() -> None:
    props = ["free(red_box)", "free(blue_box)", "incollisionzone(red_box)", "incollisionzone(blue_box)",
             "on(red_box, table)", "on(blue_box, table)"]  # fmt: skip
    for scene in sample_many(["table", "red_box", "blue_box"], props):
        state = scene.state
        gap = closest_distance(*(object_geometry(n, state.objects[n]) for n in ("red_box", "blue_box")))
        assert gap > 0.05


def test_drop_state_is_five_centimetres_up() -> None:
    scene = sample_initial_state(["table", "rack", "red_box"], [*RACK_IN_WORKSPACE, "on(red_box, rack)"], 0)
    rest, drop = scene.state.objects, scene.drop_state.objects
    assert drop["rack"].position[2] == pytest.approx(0.16 + DROP_HEIGHT)
    # The box drops onto the dropped rack: 5 cm above its top, which is itself 5 cm up.
    assert drop["red_box"].position[2] == pytest.approx(rest["red_box"].position[2] + 2 * DROP_HEIGHT)
    np.testing.assert_array_equal(drop["red_box"].position[:2], rest["red_box"].position[:2])


def test_inhand_box_grasp_coincides_with_the_home_pose() -> None:
    for scene in sample_many(["table", "red_box"], ["inhand(red_box)"]):
        state = scene.state
        assert state.held == "red_box"
        assert independent_problems("inhand(red_box)", state) == []
        box = state.objects["red_box"]
        grasp = rotate(quat_conjugate(box.quaternion), np.array([0.402, 0.0, 0.40]) - box.position)
        assert np.all(np.abs(grasp[:2]) <= 0.01 + 1e-12)
        assert -0.059 + 0.02 - 1e-12 <= grasp[2] <= 0.059 - 0.04 + 1e-12
        theta = -quat_yaw(box.quaternion)  # gripper yaw relative to the box
        assert -math.pi / 4 - 1e-9 <= theta <= 3 * math.pi / 4 + 1e-9
        assert min(abs(theta), abs(theta - math.pi / 2)) < 0.25  # {0, π/2} + N(0, 0.05)


@pytest.mark.parametrize(("marker", "x_range"), [("handlegrasp", (-0.2, 0.0)), ("upperhandlegrasp", (0.0, 0.149))])
def test_inhand_hook_grasp_markers(marker: str, x_range: tuple[float, float]) -> None:
    for scene in sample_many(["table", "hook"], [f"{marker}(hook)", "inhand(hook)"], range(20)):
        hook = scene.state.objects["hook"]
        grasp = rotate(quat_conjugate(hook.quaternion), np.array([0.402, 0.0, 0.40]) - hook.position)
        assert x_range[0] - 1e-9 <= grasp[0] <= x_range[1] + 1e-9
        assert grasp[1] == pytest.approx(-0.09, abs=0.01 + 1e-9)
        assert grasp[2] == pytest.approx(0.0, abs=1e-12)


def test_tippable_tips_about_one_in_ten() -> None:
    props = ["tippable(red_box)", "on(red_box, table)"]
    scenes = sample_many(["table", "red_box"], props, range(300))
    tipped = [s for s in scenes if "red_box" in s.tipped]
    assert 15 <= len(tipped) <= 50
    assert all(not is_upright(s.state.objects["red_box"].quaternion) for s in tipped)
    assert all(abs(bottom_z("red_box", s.state.objects["red_box"])) < 1e-6 for s in tipped)  # resting, tipped


def test_random_robot_pose_range() -> None:
    rng = np.random.default_rng(0)
    poses = [random_robot_pose(rng) for _ in range(500)]
    xy = np.array([p.position[:2] for p in poses])
    assert xy[:, 0].min() >= 0.28 and xy[:, 0].max() <= 0.70
    assert np.abs(xy[:, 1]).max() <= 0.45 and np.hypot(xy[:, 0], xy[:, 1]).max() < 0.70
    assert all(p.position[2] == 0.40 and -math.pi <= p.yaw < math.pi for p in poses)


def test_unsatisfiable_and_invalid_inputs_fail_clearly() -> None:
    with pytest.raises(SamplingError, match=r"no valid initial state in seeds 0\.\.4 or 1000000000\.\.1000000004 "):
        sample_initial_state(["table", "red_box"], ["inworkspace(red_box)", "beyondworkspace(red_box)",
                                                     "on(red_box, table)"], 0, max_attempts=5)  # fmt: skip
    with pytest.raises(PropositionError, match="unknown object 'green_box'"):
        sample_initial_state(["table", "red_box"], ["on(green_box, table)"], 0)
    with pytest.raises(KeyError, match="unknown object 'green_box'"):
        sample_initial_state(["table", "green_box"], [], 0)


def test_a_seed_whose_first_window_is_exhausted_continues_in_its_second() -> None:
    # task6 of an evaluation's seed index 24: none of 24000..24999 is accepted (task6 takes about
    # one candidate in 220), so the scene comes from the second window, 10^9 + 1000 x 24000 on
    task = load_task("task6")
    names, props = tuple(task.objects), canonical_order(task.initial_state)
    assert all(_sample_candidate(names, props, candidate) is None for candidate in range(24000, 25000))
    scene = sample_task(task, 24000)
    assert 1_024_000_000 <= scene.accepted_seed < 1_024_001_000
    assert scene.rejections == 1000 + scene.accepted_seed - 1_024_000_000
    again = sample_task(task, scene.accepted_seed)
    assert (again.accepted_seed, again.rejections) == (scene.accepted_seed, 0)


def test_the_candidate_windows_of_seeds_spaced_1000_apart_never_meet() -> None:
    windows = [set(itertools.chain(*candidate_windows(index * SEED_SPACING))) for index in range(40)]
    assert all(len(window) == 2 * MAX_SEED_ATTEMPTS for window in windows)
    assert len(set().union(*windows)) == 40 * 2 * MAX_SEED_ATTEMPTS


def test_the_independent_checks_catch_a_wrong_sample() -> None:
    task = load_task("task0")
    state = sample_task(task, 0).state
    box = "yellow_box"
    moved = {**state.objects, box: dataclasses.replace(state.objects[box], position=state.objects[box].position + [0.0, 0.0, 0.05])}
    floating = dataclasses.replace(state, objects=moved)
    assert independent_problems(f"on({box}, table)", state) == []
    assert independent_problems(f"on({box}, table)", floating) != []
    assert independent_problems(f"on({box}, rack)", state) != []
    assert independent_problems(f"inhand({box})", state) != []
    assert independent_problems("beyondworkspace(rack)", state) != []
