"""Grouping a planner's sampled states by the poses of their unmoved objects."""

import numpy as np

from t2m_core.domain.state import GeometricState, ObjectPose, pose_groups


def _state(box_x: float, hook_x: float, ee_x: float = 0.4) -> GeometricState:
    objects = {"table": ObjectPose(np.zeros(3)), "red_box": ObjectPose([box_x, 0.1, 0.059]), "hook": ObjectPose([hook_x, -0.2, 0.02])}
    return GeometricState(objects, ee_position=np.array([ee_x, 0.0, 0.4]))


def test_states_group_by_the_poses_of_the_objects_not_excluded() -> None:
    # the box moved in every sample, the hook in the third only; the EE is not an object
    states = [_state(0.50, 0.6), _state(0.51, 0.6, ee_x=0.45), _state(0.52, 0.7), _state(0.53, 0.6)]
    first, group_of = pose_groups(states, excluded=("red_box",))
    assert first == [0, 2] and group_of.tolist() == [0, 0, 1, 0]
    first, group_of = pose_groups(states)  # nothing excluded: every state its own group
    assert first == [0, 1, 2, 3] and group_of.tolist() == [0, 1, 2, 3]
    # a pose equal only to within rounding is another pose
    nudged = _state(0.50, 0.6 + 1e-12)
    assert pose_groups([states[0], nudged], excluded=("red_box",))[1].tolist() == [0, 1]
    assert pose_groups([], excluded=())[0] == []
