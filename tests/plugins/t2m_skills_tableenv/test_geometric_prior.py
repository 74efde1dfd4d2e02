"""The geometric prior of the dynamics and the network that corrects it
(docs/guide/skills.md#geometric-prior): poses worked out by hand, and the prior against MuJoCo's
outcome of the same calls."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from t2m_core.domain.geometry import axis_angle_to_quat, quat_yaw, yaw_to_quat
from t2m_core.domain.observation import argument_first_order, encode_observation, normalize, unnormalize
from t2m_core.domain.primitives import PRIMITIVES
from t2m_core.domain.state import ObjectPose
from t2m_skills_tableenv.checkpoints import load_dynamics, save_weights, update_config
from t2m_skills_tableenv.geometric_prior import prior_next_rows
from t2m_skills_tableenv.networks import build_dynamics, dynamics_architecture
from t2m_skills_tableenv.prior_dynamics import PriorDynamics
from t2m_skills_tableenv.training import WEIGHT_FILES
from tests.domain.scenes import RACK_BEYOND, on_table, scene
from tests.domain.test_sweep_screen import PULL_ARGS, PULL_SCENE, PUSH_ARGS, PUSH_SCENE
from tests.plugins.t2m_skills_tableenv.rows import EMPTY, rows


def raw_rows(state, arguments) -> np.ndarray:
    """``(1, 8, 12)`` raw argument-first rows of ``state`` for a call on ``arguments``."""
    order = argument_first_order(list(state.objects), arguments)
    return encode_observation(state)[order.order][None].astype(np.float64)


def yaw_of(row: np.ndarray) -> float:
    return float(quat_yaw(axis_angle_to_quat(row[3:6])))


def test_a_place_lands_the_carried_box_on_the_rack_where_the_action_says() -> None:
    # The box hangs 1 cm ahead of the EE (its x axis, yaw 0); released at the rack's centre, 2 cm
    # above the plate, gripper turned by π/2: the box ends 1 cm along +y of the centre, resting on the
    # plate (0.16 m) at half its height (0.059 m), turned by π/2.
    state = scene(ee_position=(0.5, 0.0, 0.4), rack=RACK_BEYOND, red_box=ObjectPose([0.51, 0.0, 0.36], yaw_to_quat(0.0)))
    action = PRIMITIVES["place"].to_normalized([0.0, 0.0, 0.02, np.pi / 2])[None]
    after = prior_next_rows("place", raw_rows(state, ["red_box", "rack"]), action)[0]
    np.testing.assert_allclose(after[1, :3], [0.82, 0.01, 0.219], atol=1e-6)
    assert yaw_of(after[1]) == pytest.approx(np.pi / 2)
    np.testing.assert_allclose(after[0, :3], [0.82, 0.0, 0.40], atol=1e-6)  # the EE back at the lift height
    np.testing.assert_allclose(after[2:], raw_rows(state, ["red_box", "rack"])[0, 2:])  # nothing else moves


def test_a_place_on_the_table_uses_the_table_strip() -> None:
    state = scene(ee_position=(0.5, 0.0, 0.4), red_box=ObjectPose([0.5, 0.0, 0.36]))
    # x = −1 is the strip's near edge (0.28 m), y = 1 its left edge (0.45 m)
    action = PRIMITIVES["place"].to_normalized([-1.0, 1.0, 0.0, 0.0])[None]
    after = prior_next_rows("place", raw_rows(state, ["red_box", "table"]), action)[0]
    np.testing.assert_allclose(after[1, :3], [0.28, 0.45, 0.059], atol=1e-6)


def test_a_pick_lifts_the_box_centred_between_the_fingers() -> None:
    # Grasped 1 cm off its centre along x and y of its frame (= the EE's, θ = 0): the fingers close
    # along the EE's y axis, so only the x offset stays; the box rises to the lift height with the EE.
    state = scene(red_box=on_table("red_box", 0.5, 0.02))
    action = PRIMITIVES["pick"].to_normalized([0.01, 0.01, 0.0, 0.0])[None]
    after = prior_next_rows("pick", raw_rows(state, ["red_box"]), action)[0]
    np.testing.assert_allclose(after[0, :3], [0.51, 0.03, 0.40], atol=1e-6)
    np.testing.assert_allclose(after[1, :3], [0.50, 0.03, 0.40], atol=1e-6)


def turned(raw: np.ndarray, angle: float) -> np.ndarray:
    """Raw rows of the same scene turned by ``angle`` about the robot's base (upright rows; an
    all-zero row, the table or an empty slot, stays zero)."""
    out = raw.copy()
    present = np.abs(raw).sum(axis=-1) > 0
    cos, sin = np.cos(angle), np.sin(angle)
    x, y = raw[..., 0], raw[..., 1]
    out[..., 0] = np.where(present, cos * x - sin * y, 0.0)
    out[..., 1] = np.where(present, sin * x + cos * y, 0.0)
    out[..., 5] = np.where(present, np.angle(np.exp(1j * (raw[..., 5] + angle))), 0.0)
    return out


@pytest.mark.parametrize(("skill", "state", "arguments"), [("pull", PULL_SCENE, PULL_ARGS), ("push", PUSH_SCENE, PUSH_ARGS)])
def test_a_sweep_turned_about_the_base_turns_its_prediction(skill, state, arguments) -> None:
    """Pull's and Push's actions live in the polar frame at the box, so the same sweep of a scene
    turned about the base ends turned alike: the prior, and the corrected prediction read in that
    frame, whatever the network's weights."""
    raw = raw_rows(state, list(arguments))
    actions = np.array([[0.3, -0.2, 0.1, 0.4]])
    dynamics = build_dynamics(dynamics_architecture(skill, "prior"))
    torch.manual_seed(0)
    with torch.no_grad():
        dynamics.net[-1].weight.normal_(std=0.01)
    for angle in (0.3, -0.5):
        prior = prior_next_rows(skill, turned(raw, angle), actions)
        np.testing.assert_allclose(prior, turned(prior_next_rows(skill, raw, actions), angle), atol=1e-9)
        encode = lambda rows: torch.from_numpy(normalize(rows).reshape(1, 96))  # noqa: E731
        predicted = unnormalize(dynamics(encode(raw), torch.from_numpy(actions).float()).detach().numpy().reshape(1, 8, 12))
        turned_prediction = unnormalize(dynamics(encode(turned(raw, angle)), torch.from_numpy(actions).float()).detach().numpy().reshape(1, 8, 12))
        assert np.abs(predicted[0, 1, :2] - prior_next_rows(skill, raw, actions)[0, 1, :2]).max() > 1e-3  # it corrects
        np.testing.assert_allclose(turned_prediction, turned(predicted, angle), atol=2e-4)


def test_an_untrained_network_predicts_the_prior_and_others_never_move() -> None:
    dynamics = PriorDynamics("place", context_rows=3)
    states, actions = rows(16, 0).reshape(16, 96), torch.rand(16, 4) * 2 - 1
    torch.testing.assert_close(dynamics(states, actions), dynamics.prior(states, actions))
    with torch.no_grad():
        dynamics.net[-1].weight.normal_()
    predicted = dynamics(states, actions)
    assert not torch.allclose(predicted[:, :36], dynamics.prior(states, actions)[:, :36])
    torch.testing.assert_close(predicted[:, 36:], states[:, 36:])  # bystanders: the prior's, unchanged
    empty = states.reshape(16, 8, 12).clone()
    empty[:, 3:] = EMPTY
    torch.testing.assert_close(dynamics(empty.reshape(16, 96), actions).reshape(16, 8, 12)[:, 3:], empty[:, 3:])


def test_a_prior_dynamics_checkpoint_round_trips_and_unknown_skills_are_named(tmp_path) -> None:
    architecture = dynamics_architecture("push", "prior")
    assert architecture["context_rows"] == 4 and architecture["skill"] == "push"
    dynamics = build_dynamics(architecture)
    with torch.no_grad():
        dynamics.net[-1].weight.normal_()
    save_weights(tmp_path / WEIGHT_FILES["dynamics"], dynamics)
    update_config(tmp_path, skill="push", models={"dynamics": {"file": WEIGHT_FILES["dynamics"], "architecture": architecture}})
    loaded = load_dynamics(tmp_path)
    states, actions = rows(4, 3).reshape(4, 96), torch.rand(4, 4) * 2 - 1
    torch.testing.assert_close(loaded(states, actions), dynamics(states, actions), rtol=0, atol=0)
    with pytest.raises(ValueError, match="no geometric prior for skill 'stop'"):
        build_dynamics({**architecture, "skill": "stop"})


@pytest.fixture(scope="module")
def simulated() -> dict[str, list[tuple[np.ndarray, np.ndarray, np.ndarray]]]:
    """Per skill, successful calls in evaluation scenes, simulated by MuJoCo with the shipped
    policy's action: (raw argument-first rows before, normalised action, raw rows after)."""
    from t2m_core.registry import get_registry
    from t2m_skills_tableenv.episodes import evaluation_episodes
    from t2m_skills_tableenv.library import load_library
    from t2m_skills_tableenv.options import TableEnvSkillsOptions

    simulator = get_registry().create("simulator", "mujoco")
    library = load_library(TableEnvSkillsOptions())
    outcomes: dict[str, list] = {}
    for skill in ("pick", "place", "pull", "push"):
        outcomes[skill] = []
        for scene_call in evaluation_episodes(skill, simulator, 8, seed=3):
            if scene_call is None:
                continue
            call, state = scene_call
            before = simulator.geometric_state()
            names = list(before.objects)
            order = argument_first_order(names, call.args).order
            with torch.no_grad():
                action = np.asarray(library[skill].policy(state[None]))[0]
            result = simulator.execute(skill, call.args, action)
            if result.success:
                outcomes[skill].append((encode_observation(before, names)[order], action, encode_observation(result.state, names)[order]))
    return outcomes


def prior_errors(skill: str, outcomes, row: int) -> np.ndarray:
    """Position errors (metres) of the prior for ``row`` over simulated successes of ``skill``."""
    before, actions, after = (np.stack(column).astype(np.float64) for column in zip(*outcomes))
    predicted = prior_next_rows(skill, before, actions)
    return np.linalg.norm(predicted[:, row, :3] - after[:, row, :3], axis=-1)


@pytest.mark.parametrize(("skill", "moved_tolerance"), [("place", 0.005), ("pick", 0.02)])
def test_the_prior_matches_the_simulated_carry(simulated, skill, moved_tolerance) -> None:
    outcomes = simulated[skill]
    assert len(outcomes) >= 3, f"too few {skill} successes to compare"
    assert np.median(prior_errors(skill, outcomes, 1)) < moved_tolerance
    assert np.max(prior_errors(skill, outcomes, 0)) < 0.003  # the EE: commanded, so exact


@pytest.mark.parametrize("skill", ["pull", "push"])
def test_the_prior_follows_the_simulated_hook_and_moves_the_box_its_way(simulated, skill) -> None:
    outcomes = simulated[skill]
    assert len(outcomes) >= 3, f"too few {skill} successes to compare"
    assert np.max(prior_errors(skill, outcomes, 2)) < 0.005  # the hook, carried rigidly
    before, _, after = (np.stack(column) for column in zip(*outcomes))
    travelled = np.linalg.norm(after[:, 1, :2] - before[:, 1, :2], axis=-1)
    # the box moves 5-40 cm; the prior gets it to within a fraction of that
    assert np.median(prior_errors(skill, outcomes, 1) / travelled) < 0.3


def test_the_loss_compares_yaws_modulo_a_turn() -> None:
    def yaw_error(predicted_degrees: float, target_degrees: float) -> torch.Tensor:
        predicted, target = torch.zeros(1, 96), torch.zeros(1, 96)
        predicted[0, 12 + 5] = np.radians(predicted_degrees) / (2 * np.pi)  # encoded: a full turn is 1.0
        target[0, 12 + 5] = np.radians(target_degrees) / (2 * np.pi)
        return PriorDynamics.loss(predicted, target)

    torch.testing.assert_close(yaw_error(179.0, -179.0), yaw_error(2.0, 0.0))
    assert yaw_error(90.0, -90.0) > 40 * yaw_error(2.0, 0.0)


def test_training_learns_what_the_prior_misses(tmp_path) -> None:
    """The recorded next states sit 0.02 (encoded) beside the prior's along x for the moved row;
    training the correction removes most of it."""
    from t2m_skills_tableenv.dataset import SkillTensors
    from t2m_skills_tableenv.training import DynamicsStage, StageSettings, run_stage

    dynamics = PriorDynamics("place", context_rows=3)

    def problem(count: int, seed: int) -> SkillTensors:
        states, actions = rows(count, seed), torch.rand(count, 4, generator=torch.Generator().manual_seed(seed)) * 2 - 1
        after = dynamics.prior(states.reshape(count, 96), actions).reshape(count, 8, 12)
        after[:, 1, 0] += 0.02
        return SkillTensors(states, after, torch.tensor([[3, 8]]).expand(count, 2), actions, torch.ones(count))

    train, validation = problem(2048, 0), problem(512, 1)
    torch.manual_seed(0)
    settings = StageSettings(steps=400, batch_size=256, learning_rate=2e-3, eval_every=200, dynamics_network="prior")
    run_stage(DynamicsStage(train, validation, settings, dynamics), settings, tmp_path)
    with torch.no_grad():
        predicted = dynamics(validation.states(), validation.actions).reshape(512, 8, 12)
    error = (predicted[:, 1, 0] - validation.next_rows[:, 1, 0]).abs().median()
    assert error < 0.005, error  # the prior alone misses by 0.02
