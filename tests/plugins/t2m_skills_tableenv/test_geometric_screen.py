"""The geometric screen read from skill states, and the Q-ensemble that reads it
(docs/guide/skills.md#geometric-q-ensemble): neighbours placed by hand, rows as the networks see
them, training and checkpoints."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from t2m_skills_tableenv.checkpoints import load_q, save_weights, update_config
from t2m_skills_tableenv.geometric_q import GeometricQEnsemble
from t2m_skills_tableenv.geometric_screen import row_objects, screen_flags
from t2m_skills_tableenv.networks import build_q, q_architecture

from t2m_core.domain.observation import argument_first_order, encode_observation, normalize, unnormalize
from t2m_core.domain.primitives import PRIMITIVES
from tests.domain.scenes import RACK_IN_WORKSPACE, on_table, scene

PICK = PRIMITIVES["pick"]
ACROSS_Y, ACROSS_X = [0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, math.pi / 2]
"""Physical grasps at the box's centre, the jaw opening along world y (θ = 0) or x (θ = π/2)."""


def neighbour_scene(gap: float):
    """The red box at (0.5, 0.1) and the blue box along +y, ``gap`` m beyond the reach of a finger
    opened along y (66.4 mm from the grasp; the blue box's near face 25 mm from its centre), with
    the rack and the hook far from both."""
    return scene(
        rack=RACK_IN_WORKSPACE, hook=on_table("hook", 0.3, -0.1), red_box=on_table("red_box", 0.5, 0.1),
        blue_box=on_table("blue_box", 0.5, 0.1 + 0.0664 + 0.025 + gap),
    )


def skill_rows(state, arguments, permutation=None) -> np.ndarray:
    """``(1, 8, 12)`` raw argument-first rows of ``state`` as a network sees them (normalised and
    back), the non-argument rows optionally permuted."""
    order = argument_first_order(list(state.objects), arguments).order.copy()
    if permutation is not None:
        start = 1 + len(arguments)
        order[start : start + len(permutation)] = order[start:][list(permutation)]
    return unnormalize(normalize(encode_observation(state)[order]))[None].astype(np.float64)


def actions_of(*physical) -> np.ndarray:
    return PICK.to_normalized(np.array(physical, dtype=np.float64))


def test_rows_name_every_object_by_its_shape() -> None:
    state = neighbour_scene(0.05)
    rows = skill_rows(state, ["red_box"])[0]
    # argument first, then the others in task order; the table's all-zero row, then an empty slot
    assert row_objects(rows) == ("red_box", "table", "rack", "hook", "blue_box", None, None)
    # a predicted state: the table's row moved a little, the shapes drifted by half a millimetre
    predicted = rows.copy()
    predicted[2, :3] = [0.001, -0.002, 0.0005]
    predicted[[1, 3, 4, 5], 6:9] += 0.0005
    assert row_objects(predicted) == row_objects(rows)


def test_the_screen_sees_a_neighbour_along_the_jaw_from_the_rows() -> None:
    actions = actions_of(ACROSS_Y, ACROSS_X)
    near, clear = neighbour_scene(0.003), neighbour_scene(0.008)
    assert screen_flags("pick", np.repeat(skill_rows(near, ["red_box"]), 2, axis=0), actions)[:, 0].tolist() == [True, False]
    assert screen_flags("pick", np.repeat(skill_rows(clear, ["red_box"]), 2, axis=0), actions)[:, 0].tolist() == [False, False]
    # the other objects' order does not matter, and distinct states in one batch are screened apart
    shuffled = skill_rows(near, ["red_box"], permutation=(3, 1, 0, 2))
    mixed = np.concatenate((shuffled, skill_rows(clear, ["red_box"]), shuffled))
    assert screen_flags("pick", mixed, actions_of(ACROSS_Y, ACROSS_Y, ACROSS_X))[:, 0].tolist() == [True, False, False]


def test_a_grasps_prediction_never_depends_on_the_other_grasps_in_its_batch() -> None:
    # the hook (a few cm tall) beside the red box along y: a grasp at the box's centre passes above
    # it, the same grasp 5 cm deeper strikes it
    state = scene(rack=RACK_IN_WORKSPACE, hook=on_table("hook", 0.5, 0.25), red_box=on_table("red_box", 0.5, 0.1))
    rows = skill_rows(state, ["red_box"])
    high, deep = [0.0, 0.0, 0.0, 0.0], [0.0, 0.0, -0.05, 0.0]
    assert screen_flags("pick", rows, actions_of(high))[:, 0].tolist() == [False]
    assert screen_flags("pick", rows, actions_of(deep))[:, 0].tolist() == [True]
    # ranked together (a planner's samples in one state), each keeps its own prediction
    assert screen_flags("pick", np.repeat(rows, 3, axis=0), actions_of(high, deep, high))[:, 0].tolist() == [False, True, False]


def test_every_action_of_a_call_the_primitive_refuses_is_in_the_way() -> None:
    # the invalid split's pairs: the table's all-zero row or the rack as Pick's argument
    state = neighbour_scene(0.05)
    refused = np.concatenate((skill_rows(state, ["table"]), skill_rows(state, ["rack"])))
    assert screen_flags("pick", refused, actions_of(ACROSS_X, ACROSS_X))[:, 0].tolist() == [True, True]


def test_an_unknown_shape_is_named_and_left_unscreened_and_an_unknown_skill_named() -> None:
    rows = skill_rows(neighbour_scene(0.05), ["red_box"])
    near = skill_rows(neighbour_scene(0.003), ["red_box"])
    assert screen_flags("pick", near, actions_of(ACROSS_Y))[:, 0].tolist() == [True]
    near[0, 5, 8] = 0.09  # the blue box 9 cm tall: no object of the world
    with pytest.raises(ValueError, match="match no object of the world"):
        row_objects(near[0])
    assert screen_flags("pick", near, actions_of(ACROSS_Y))[:, 0].tolist() == [False]  # no prediction for it
    with pytest.raises(ValueError, match="no geometric screen for skill 'stop'"):
        screen_flags("stop", rows, actions_of(ACROSS_Y))
    with pytest.raises(ValueError, match="no geometric screen for skill 'stop'"):
        GeometricQEnsemble("stop")


def states_and_actions(count: int, seed: int) -> tuple[torch.Tensor, torch.Tensor]:
    """Normalised skill states of the neighbour scene at gaps in [0, 1.2 cm] and grasps at θ = 0 or π/2."""
    rng = np.random.default_rng(seed)
    gaps, across_x = rng.uniform(0.0, 0.012, count), rng.random(count) < 0.5
    rows = np.concatenate([normalize(skill_rows(neighbour_scene(g), ["red_box"])) for g in gaps])
    actions = actions_of(*[ACROSS_X if x else ACROSS_Y for x in across_x])
    return torch.from_numpy(rows.reshape(count, 96)).float(), torch.from_numpy(actions).float()


def test_a_geometric_ensemble_reads_the_screen_it_computes_or_is_given() -> None:
    torch.manual_seed(0)
    network = GeometricQEnsemble("pick")
    states, actions = states_and_actions(16, 0)
    computed = network.screen(states, actions)
    assert set(computed.flatten().tolist()) == {-0.5, 0.5}  # a flag: ±0.5
    torch.testing.assert_close(network(states, actions), network(states, actions, computed), rtol=0, atol=0)
    assert not torch.allclose(network(states, actions, computed), network(states, actions, -computed))
    # member-specific inputs (bootstrapped batches) take a screen per member
    members = network(states.expand(8, -1, -1), actions.expand(8, -1, -1), computed.expand(8, -1, -1))
    torch.testing.assert_close(members, network(states, actions, computed))


def test_training_learns_what_the_screen_predicts(tmp_path) -> None:
    """Labels that follow the hand-placed geometry (a grasp along the jaw fails when the neighbour
    stands within 5 mm of a finger); the ensemble learns them through the precomputed screen."""
    from t2m_skills_tableenv.dataset import SkillTensors
    from t2m_skills_tableenv.training import QStage, StageSettings, q_metrics, run_stage

    def problem(count: int, seed: int) -> SkillTensors:
        states, actions = states_and_actions(count, seed)
        rng = np.random.default_rng(seed)
        gaps, across_x = rng.uniform(0.0, 0.012, count), rng.random(count) < 0.5
        rewards = torch.from_numpy((across_x | (gaps > 0.005)).astype(np.float32))
        return SkillTensors(states.reshape(count, 8, 12), states.reshape(count, 8, 12), torch.tensor([[2, 5]]).expand(count, 2), actions, rewards)

    train, validation = problem(256, 1), problem(128, 2)
    torch.manual_seed(0)
    settings = StageSettings(steps=300, batch_size=64, learning_rate=1e-3, eval_every=100, q_network="geometric")
    stage = QStage(train, validation, settings, GeometricQEnsemble("pick"))
    run_stage(stage, settings, tmp_path)
    metrics = q_metrics(stage.network, validation)
    assert metrics["accuracy"] > 0.95, metrics


def test_a_geometric_checkpoint_round_trips_and_other_skills_are_refused(tmp_path) -> None:
    pull = q_architecture("pull", "geometric")
    assert pull["input"] == 102 and pull["screen"] == ["clearance", "reach_margin"]
    assert build_q(pull).features == ("clearance", "reach_margin")
    assert build_q({**pull, "screen": ["in_the_way", "unreachable"]}).features == ("in_the_way", "unreachable")  # stop-54's Pull
    # the first geometric checkpoints (Pick) name their one prediction as a string
    assert build_q({**q_architecture("pick", "geometric"), "screen": "in_the_way"}).features == ("in_the_way",)
    architecture = q_architecture("pick", "geometric")
    assert architecture["input"] == 101 and architecture["skill"] == "pick"
    torch.manual_seed(1)
    network = build_q(architecture)
    save_weights(tmp_path / "q_ensemble.safetensors", network)
    update_config(tmp_path, skill="pick", models={"q": {"file": "q_ensemble.safetensors", "architecture": architecture}})
    loaded = load_q(tmp_path)
    assert isinstance(loaded, GeometricQEnsemble)
    states, actions = states_and_actions(4, 3)
    torch.testing.assert_close(loaded(states, actions), network(states, actions), rtol=0, atol=0)


FLAGS = ("in_the_way", "unreachable")
"""The hook sweeps' two flags (their default network reads the margins behind them)."""


def test_the_sweep_screen_sees_a_bystander_on_a_pull_from_the_rows() -> None:
    """The hand-placed pulls of the domain's sweep tests: the red box between the blue box and the
    base is in the way of every draw, the red box aside or absent of none."""
    from tests.domain.test_sweep_screen import BLOCKED_PULL, PULL_ARGS, PULL_SCENE, holding_hook, pull

    pull_primitive = PRIMITIVES["pull"]
    draws = pull_primitive.to_normalized(np.array([pull(-0.3, -0.03), pull(-0.2, 0.0), pull(-0.3, 0.05)]))
    aside = holding_hook((0.8, 0.0), grasp_x=-0.1, rack=False, red_box=on_table("red_box", 0.45, -0.35))
    for state, expected in ((BLOCKED_PULL, True), (aside, False), (PULL_SCENE, False)):
        rows = np.repeat(skill_rows(state, list(PULL_ARGS), permutation=None), 3, axis=0)
        assert screen_flags("pull", rows, draws, FLAGS)[:, 0].tolist() == [expected] * 3
    # the pull's second prediction: the box too far for the arm (the domain's sweep test), read from the rows
    far = holding_hook((1.0, 0.3), grasp_x=-0.1, rack=False)
    rows = np.concatenate((skill_rows(far, list(PULL_ARGS)), skill_rows(PULL_SCENE, list(PULL_ARGS))))
    flags = screen_flags("pull", rows, draws[:2], FLAGS)
    assert flags.shape == (2, 2) and flags[:, 1].tolist() == [True, False]
    assert screen_flags("pull", rows, draws[:2], ("in_the_way",)).shape == (2, 1)
    with pytest.raises(ValueError, match="pick's screen predicts in_the_way; asked for unreachable"):
        GeometricQEnsemble("pick", features=("unreachable",))


def test_pull_margins_read_from_the_rows_and_enter_the_network_scaled() -> None:
    """The hand-placed pull (red box 2 cm further than the screen's clearance from the swept box,
    tests/domain), read from its rows; a refused call reads every margin at its worst, a state of
    no known world at its best; the network gets flags as ±0.5 and margins of ±5 cm as ±0.5."""
    from t2m_skills_tableenv.geometric_screen import screen_inputs, screen_values

    from tests.domain.test_sweep_screen import PULL_ARGS, holding_hook, pull

    features = ("in_the_way", "clearance", "reach_margin")
    draws = PRIMITIVES["pull"].to_normalized(np.array([pull(-0.3, -0.03)]))
    beside = holding_hook((0.8, 0.0), grasp_x=-0.1, rack=False, red_box=on_table("red_box", 0.6, 0.2))
    values = screen_values("pull", skill_rows(beside, list(PULL_ARGS)), draws, features)[0]
    assert values[0] == 0.0 and values[1] == pytest.approx(0.0168, abs=1e-3) and 0.0 < values[2] < 0.1
    refused = skill_rows(beside, ["blue_box", "red_box"])
    assert screen_values("pull", refused, draws, features)[0].tolist() == [1.0, -np.inf, -np.inf]
    unknown = skill_rows(beside, list(PULL_ARGS))
    unknown[0, 3, 8] = 0.09  # no object of the world is this tall
    assert screen_values("pull", unknown, draws, features)[0].tolist() == [0.0, np.inf, np.inf]
    np.testing.assert_allclose(screen_inputs(np.array([[1.0, 0.025, -0.2], [0.0, np.inf, -np.inf]]), features), [[0.5, 0.25, -0.5], [-0.5, 0.5, -0.5]])
    with pytest.raises(ValueError, match="clearance are margins"):
        screen_flags("pull", refused, draws, ("in_the_way", "clearance"))


def test_every_margin_place_predicts_enters_the_network_scaled() -> None:
    """A prediction that is not a flag must have a scale (without one it would enter as a flag,
    value − 0.5); Place's ``footprint_gap`` reads ±1 cm as ±0.5."""
    from t2m_skills_tableenv.geometric_screen import MARGIN_SCALES, screen_inputs

    from t2m_core.domain.state import GeometricState, ObjectPose

    table = scene(rack=RACK_IN_WORKSPACE, cyan_box=on_table("cyan_box", 0.6, 0.2))
    holding = GeometricState({**table.objects, "red_box": ObjectPose([0.45, 0.1, 0.37])}, np.array([0.45, 0.1, 0.40]), held="red_box")
    place = PRIMITIVES["place"]
    judged = place.screen_of_states([holding], ["red_box", "table"], np.array([[0.0, 0.0, 0.05, 0.0]]), np.zeros(1, dtype=int))
    assert set(judged) == set(place.screen_predictions)
    for name, values in judged.items():
        assert values.dtype == bool or name in MARGIN_SCALES, f"{name} is a margin without a scale"
    np.testing.assert_allclose(screen_inputs(np.array([[-0.004, 0.03, -np.inf]]), ("footprint_gap",) * 3), [[-0.2, 0.5, -0.5]])
