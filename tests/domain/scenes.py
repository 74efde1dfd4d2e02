"""Scene builders and hypothesis strategies shared by the domain tests."""

from __future__ import annotations

import numpy as np
from hypothesis import strategies as st

from t2m_core.domain.geometry import axis_angle_to_quat, quat_multiply, yaw_to_quat
from t2m_core.domain.objects import OBJECTS
from t2m_core.domain.state import GeometricState, ObjectPose

TABLE = ObjectPose(np.zeros(3))
RACK_IN_WORKSPACE = ObjectPose([0.44, -0.33, 0.16], yaw_to_quat(np.pi / 2))
"""The rack standing at its in-workspace poslimit pose (origin = top plate, 0.16 m up)."""
RACK_BEYOND = ObjectPose([0.82, 0.0, 0.16])
"""The rack at its beyond-workspace poslimit pose."""


def on_table(name: str, x: float, y: float, yaw: float = 0.0) -> ObjectPose:
    """A box or the hook resting upright on the table at (x, y), metres."""
    return ObjectPose([x, y, OBJECTS[name].size[2] / 2], yaw_to_quat(yaw))


def scene(ee_position=(0.402, 0.0, 0.4), **poses: ObjectPose) -> GeometricState:
    """A state with the table (identity pose) first, then the given objects in keyword order."""
    return GeometricState({"table": TABLE, **poses}, ee_position=np.asarray(ee_position, dtype=float))


SCENE_ORDER = ("table", "rack", "hook", "red_box", "blue_box", "yellow_box", "cyan_box")

finite = dict(allow_nan=False, allow_infinity=False)


@st.composite
def quaternions(draw, tilt: bool = True) -> np.ndarray:
    """Yaw-only or arbitrary rotations (unit xyzw)."""
    yaw = draw(st.floats(-np.pi, np.pi, **finite))
    q = yaw_to_quat(yaw)
    if tilt and draw(st.booleans()):
        axis_angle = np.array(draw(st.lists(st.floats(-np.pi / 2, np.pi / 2, **finite), min_size=3, max_size=3)))
        axis_angle[2] = 0.0
        q = quat_multiply(axis_angle_to_quat(axis_angle), q)
    return q


@st.composite
def object_poses(draw, name: str, tilt: bool = True) -> ObjectPose:
    """A pose anywhere above the table; z snaps to "resting on the table", "on the rack top" or free."""
    x = draw(st.floats(-0.3, 0.9, **finite))
    y = draw(st.floats(-0.45, 0.45, **finite))
    size_z = OBJECTS[name].size[2]
    resting = {"table": size_z / 2 if name != "rack" else size_z, "rack": 0.16 + size_z / 2}
    mode = draw(st.sampled_from(("table", "rack", "free")))
    z = resting[mode] if mode in resting else draw(st.floats(-0.05, 0.6, **finite))
    return ObjectPose([x, y, z], draw(quaternions(tilt=tilt and name != "rack")))


@st.composite
def random_scenes(draw, tilt: bool = True) -> GeometricState:
    """A table plus a random non-empty subset of the other objects in random poses (task order kept).

    Rack poses cluster near its poslimit centres half of the time so that on/under relations occur.
    """
    names = [n for n in SCENE_ORDER[1:] if draw(st.booleans())] or ["red_box"]
    poses = {"table": TABLE}
    for name in names:
        if name == "rack" and draw(st.booleans()):
            poses[name] = draw(st.sampled_from((RACK_IN_WORKSPACE, RACK_BEYOND)))
        elif name != "rack" and "rack" in poses and draw(st.booleans()):
            # Near the rack so that on(·, rack) / under(·, rack) happen often.
            rack_xy = poses["rack"].position[:2]
            dx, dy = draw(st.floats(-0.15, 0.15, **finite)), draw(st.floats(-0.2, 0.2, **finite))
            z = draw(st.sampled_from((OBJECTS[name].size[2] / 2, 0.16 + OBJECTS[name].size[2] / 2)))
            poses[name] = ObjectPose([rack_xy[0] + dx, rack_xy[1] + dy, z], draw(quaternions(tilt=tilt)))
        else:
            poses[name] = draw(object_poses(name, tilt=tilt))
    ee = np.array(draw(st.lists(st.floats(0.0, 0.7, **finite), min_size=3, max_size=3)))
    return GeometricState(poses, ee_position=ee, ee_quaternion=draw(quaternions()))
