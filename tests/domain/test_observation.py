"""Raw observations, skill states and dynamics states (docs/guide/world.md#observation-encoding, docs/guide/skills.md#state-encodings)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from t2m_core.domain.geometry import axis_angle_to_quat, quat_angle, yaw_to_quat
from t2m_core.domain.observation import (
    FEATURE_HIGH,
    FEATURE_LOW,
    ObservationError,
    argument_first_order,
    decode_dynamics_prediction,
    decode_observation,
    dynamics_state,
    encode_observation,
    normalize,
    skill_state,
    unnormalize,
)
from t2m_core.domain.state import ObjectPose
from tests.domain.scenes import RACK_IN_WORKSPACE, on_table, random_scenes, scene

STATE = scene(
    ee_position=(0.45, 0.1, 0.4),
    rack=RACK_IN_WORKSPACE,
    hook=on_table("hook", 0.5, 0.25, yaw=-0.3),
    red_box=ObjectPose([0.44, -0.33, 0.219]),
)
NAMES = ("table", "rack", "hook", "red_box")


def test_raw_observation_layout() -> None:
    state = scene(ee_position=(0.45, 0.1, 0.4), rack=RACK_IN_WORKSPACE, hook=on_table("hook", 0.5, 0.25, yaw=-0.3),
                  red_box=ObjectPose([0.44, -0.33, 0.219]))
    state = type(state)(state.objects, ee_position=state.ee_position, ee_quaternion=yaw_to_quat(0.7))
    obs = encode_observation(state)
    assert obs.shape == (8, 12) and obs.dtype == np.float32
    np.testing.assert_allclose(obs[0], [0.45, 0.1, 0.4, 0, 0, 0.7, 0, 0, 0, 0, 0, 0], atol=1e-6)
    np.testing.assert_array_equal(obs[1], np.zeros(12))  # the table row is all zeros
    np.testing.assert_allclose(obs[2], [0.44, -0.33, 0.16, 0, 0, np.pi / 2, 0.22, 0.32, 0.16, 0, 0, 0], atol=1e-6)
    np.testing.assert_allclose(obs[3], [0.5, 0.25, 0.02, 0, 0, -0.3, 0, 0, 0, 0.2, 0.38, -1.0], atol=1e-6)
    np.testing.assert_allclose(obs[4], [0.44, -0.33, 0.219, 0, 0, 0, 0.05, 0.05, 0.118, 0, 0, 0], atol=1e-6)
    np.testing.assert_array_equal(obs[5:], np.zeros((3, 12)))


def test_observation_follows_the_given_order_and_skips_absent_objects() -> None:
    obs = encode_observation(STATE, ["table", "red_box", "cyan_box", "hook", "rack"])
    np.testing.assert_allclose(obs[2, :3], [0.44, -0.33, 0.219], atol=1e-6)
    np.testing.assert_allclose(obs[3, 9:], [0.2, 0.38, -1.0])
    np.testing.assert_allclose(obs[4, 6:9], [0.22, 0.32, 0.16])


@settings(max_examples=80, deadline=None)
@given(random_scenes())
def test_observation_round_trip(state) -> None:
    obs = encode_observation(state)
    decoded = decode_observation(obs, state.object_names)
    assert decoded.object_names == state.object_names
    again = encode_observation(decoded)
    not_rotation = [0, 1, 2, 6, 7, 8, 9, 10, 11]
    np.testing.assert_allclose(again[:, not_rotation], obs[:, not_rotation], atol=1e-6)
    # Axis-angle is ambiguous at π (±π·axis); compare the rotations themselves.
    assert np.all(quat_angle(axis_angle_to_quat(again[:, 3:6]), axis_angle_to_quat(obs[:, 3:6])) < 1e-5)
    for name, pose in state.objects.items():
        np.testing.assert_allclose(decoded.objects[name].position, pose.position, atol=1e-6)
        if name != "table":
            assert quat_angle(decoded.objects[name].quaternion, pose.quaternion) < 1e-5
    assert quat_angle(decoded.ee_quaternion, state.ee_quaternion) < 1e-5


def test_observation_errors() -> None:
    with pytest.raises(ObservationError, match=r"expected an \(8, 12\)"):
        decode_observation(np.zeros((7, 12)), NAMES)
    with pytest.raises(ObservationError, match="at most 7"):
        argument_first_order([f"o{i}" for i in range(8)], [])
    with pytest.raises(ObservationError, match="cyan_box not among"):
        argument_first_order(NAMES, ["cyan_box"])


def test_argument_first_order() -> None:
    order = argument_first_order(NAMES, ["red_box", "rack"])
    np.testing.assert_array_equal(order.order, [0, 4, 2, 1, 3, 5, 6, 7])
    assert (order.shuffle_start, order.shuffle_stop, order.num_present) == (3, 5, 4)
    np.testing.assert_array_equal(order.order[order.inverse], np.arange(8))
    pick = argument_first_order(("table", "rack", "hook", "red_box", "blue_box", "yellow_box", "cyan_box"), ["hook"])
    np.testing.assert_array_equal(pick.order, [0, 3, 1, 2, 4, 5, 6, 7])
    assert (pick.shuffle_start, pick.shuffle_stop) == (2, 8)


def test_normalisation() -> None:
    np.testing.assert_allclose(normalize(FEATURE_LOW), -0.5)
    np.testing.assert_allclose(normalize(FEATURE_HIGH), 0.5)
    zero_row = normalize(np.zeros(12))
    assert zero_row[0] == pytest.approx(-0.25)  # an empty row is a constant non-zero vector
    assert zero_row[2] == pytest.approx(-1 / 3)
    assert zero_row[6] == pytest.approx(-0.5) and zero_row[11] == pytest.approx(0.0)
    rng = np.random.default_rng(0)
    values = rng.uniform(FEATURE_LOW, FEATURE_HIGH, size=(10, 12)).astype(np.float32)
    np.testing.assert_allclose(unnormalize(normalize(values)), values, atol=1e-6)


def test_skill_state_layout() -> None:
    obs = encode_observation(STATE)
    order = argument_first_order(NAMES, ["red_box", "rack"])
    state = skill_state(obs, order)
    assert state.shape == (96,) and state.dtype == np.float32
    rows = state.reshape(8, 12)
    np.testing.assert_allclose(rows[1], normalize(obs[4]))  # the first argument comes first
    np.testing.assert_allclose(rows[2], normalize(obs[2]))
    np.testing.assert_allclose(rows[3], normalize(obs[1]))  # then the table, then the hook
    np.testing.assert_allclose(rows[4], normalize(obs[3]))
    np.testing.assert_array_equal(skill_state(obs, order), state)  # no rng: deterministic
    np.testing.assert_array_equal(dynamics_state(obs, order), state)


def test_shuffling_permutes_only_the_shuffle_range() -> None:
    names = ("table", "rack", "hook", "red_box", "blue_box", "yellow_box", "cyan_box")
    obs = np.arange(8 * 12, dtype=np.float32).reshape(8, 12) / 100.0
    order = argument_first_order(names, ["blue_box", "hook"])
    batch = np.broadcast_to(obs, (200, 8, 12))
    states = skill_state(batch, order, rng=np.random.default_rng(1)).reshape(200, 8, 12)
    fixed = skill_state(obs, order).reshape(8, 12)
    np.testing.assert_array_equal(states[:, :3], np.broadcast_to(fixed[:3], (200, 3, 12)))
    permutations = {tuple(np.argsort(s[3:, 0])) for s in states}
    assert len(permutations) > 20  # independent per sample
    for s in states[:10]:
        assert sorted(map(tuple, s[3:])) == sorted(map(tuple, fixed[3:]))


@settings(max_examples=50, deadline=None)
@given(random_scenes(tilt=False), st.data())
def test_dynamics_mapping_inverts_the_encoding(state, data) -> None:
    names = state.object_names
    arguments = data.draw(st.lists(st.sampled_from(names), unique=True, max_size=3))
    order = argument_first_order(names, arguments)
    obs = np.clip(encode_observation(state), FEATURE_LOW, FEATURE_HIGH)
    restored = decode_dynamics_prediction(dynamics_state(obs, order), obs, order)
    np.testing.assert_allclose(restored, obs, atol=2e-6)


def test_dynamics_prediction_is_clamped_and_keeps_static_features() -> None:
    obs = encode_observation(STATE)
    order = argument_first_order(NAMES, ["red_box", "rack"])
    prediction = dynamics_state(obs, order).reshape(8, 12).copy()
    prediction[1, 0] = 3.0  # the red box's x, far out of range: clamped to 0.5 → x = 0.9
    prediction[1, 6:] = 0.1  # garbage static features: replaced by the input's
    prediction[6, :] = 0.3  # a row beyond the present objects: zeroed
    restored = decode_dynamics_prediction(prediction.reshape(96), obs, order)
    assert restored[4, 0] == pytest.approx(0.9)
    np.testing.assert_allclose(restored[4, 6:], obs[4, 6:])
    np.testing.assert_array_equal(restored[5:], 0.0)
    batched = decode_dynamics_prediction(np.stack([prediction.reshape(96)] * 3), np.stack([obs] * 3), order)
    assert batched.shape == (3, 8, 12)
    np.testing.assert_allclose(batched[2], restored)
