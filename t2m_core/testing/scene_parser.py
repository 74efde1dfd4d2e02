"""Conformance check for :class:`~t2m_core.protocols.SceneParser` implementations."""

from __future__ import annotations

import numpy as np

from t2m_core.domain.state import GeometricState, ObjectPose
from t2m_core.protocols import SceneObservation, SceneParser

POSITION_TOLERANCE_M = 1e-6
QUATERNION_NORM_TOLERANCE = 1e-6


def sample_observation(*, with_ground_truth: bool = True) -> SceneObservation:
    """A small TableEnv scene (table, rack, red box, hook) as a parser would receive it.

    Poses are in metres and ``(x, y, z, w)`` quaternions; the rack stands in the workspace and the
    red box rests on the table (its centre at half its 0.118 m height).
    """
    yaw = np.pi / 6  # radians
    ground_truth = GeometricState(
        objects={
            "table": ObjectPose(np.zeros(3)),
            "rack": ObjectPose(np.array([0.44, -0.33, 0.16])),
            "red_box": ObjectPose(np.array([0.5, 0.1, 0.059]), np.array([0.0, 0.0, np.sin(yaw / 2), np.cos(yaw / 2)])),
            "hook": ObjectPose(np.array([0.35, 0.2, 0.02])),
        }
    )
    return SceneObservation(
        object_names=("table", "rack", "red_box", "hook"),
        ground_truth=ground_truth if with_ground_truth else None,
    )


def check_scene_parser(
    parser: SceneParser, observation: SceneObservation, expected: GeometricState | None = None
) -> GeometricState:
    """Assert that ``parser`` turns ``observation`` into a well-formed geometric state; return it.

    Checks: the parser satisfies the protocol; it returns a :class:`GeometricState` whose objects are
    exactly ``observation.object_names`` in that order (when given); every position is a finite
    ``(3,)`` vector in metres and every quaternion a unit ``(4,)``; parsing twice gives the same
    state; and, when ``expected`` is given, poses match it within 1 µm (quaternions up to sign).
    """
    assert isinstance(parser, SceneParser), f"{type(parser).__name__} lacks SceneParser.parse"
    state = parser.parse(observation)
    assert isinstance(state, GeometricState), f"parse returned {type(state).__name__}, not GeometricState"
    if observation.object_names:
        assert state.object_names == tuple(observation.object_names), (
            f"objects {state.object_names} differ from the requested {tuple(observation.object_names)}"
        )
    for name, pose in state.objects.items():
        assert pose.position.shape == (3,) and np.all(np.isfinite(pose.position)), (
            f"{name}: bad position {pose.position}"
        )
        assert pose.quaternion.shape == (4,), f"{name}: quaternion must be (4,), got {pose.quaternion.shape}"
        norm = float(np.linalg.norm(pose.quaternion))
        assert abs(norm - 1.0) < QUATERNION_NORM_TOLERANCE, f"{name}: quaternion norm {norm:.6f} is not 1"
    assert state.ee_position.shape == (3,) and np.all(np.isfinite(state.ee_position)), "bad end-effector position"
    assert state.held is None or state.held in state.objects, f"held object {state.held!r} is not in the scene"
    _assert_same_state(parser.parse(observation), state, "parsing the same observation twice")
    if expected is not None:
        _assert_same_state(state, expected, "the expected state")
    return state


def _assert_same_state(actual: GeometricState, expected: GeometricState, what: str) -> None:
    assert actual.object_names == expected.object_names, f"objects differ from {what}"
    for name, pose in actual.objects.items():
        other = expected.objects[name]
        assert np.allclose(pose.position, other.position, atol=POSITION_TOLERANCE_M), (
            f"{name}: position {pose.position} differs from {what} {other.position}"
        )
        same_rotation = abs(float(np.dot(pose.quaternion, other.quaternion))) > 1 - 1e-9
        assert same_rotation, f"{name}: orientation {pose.quaternion} differs from {what} {other.quaternion}"
    assert actual.held == expected.held, f"held object {actual.held!r} differs from {what} {expected.held!r}"
