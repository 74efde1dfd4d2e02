"""The geometric state of a TableEnv scene: object poses (metres, xyzw quaternions) and the end effector.

This is the value every part exchanges: simulators report it, scene parsers produce it, predicates,
the observation encoding and the learned skills consume it. Shapes (sizes, hook dimensions) are not
stored here: they come from the object specifications in :mod:`t2m_core.domain.objects`, looked up by
object name.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class ObjectPose:
    """Pose of one object in the world frame.

    Attributes:
        position: ``(3,) float64`` object-frame origin in metres. For the rack the origin is its top
            plate; for boxes and the hook it is the bounding-box centre; the table's is ``0``.
        quaternion: ``(4,) float64`` world orientation, ``(x, y, z, w)``.
    """

    position: np.ndarray
    quaternion: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 0.0, 1.0]))

    def __post_init__(self) -> None:
        object.__setattr__(self, "position", np.asarray(self.position, dtype=np.float64).reshape(3))
        object.__setattr__(self, "quaternion", np.asarray(self.quaternion, dtype=np.float64).reshape(4))


@dataclass(frozen=True)
class GeometricState:
    """A scene's geometry at one instant.

    Attributes:
        objects: object name -> pose, in the task's object order (``table`` first). Only present
            objects appear; the order is the order of observation rows ``1..N``.
        ee_position: ``(3,) float64`` end-effector operational point in metres (world frame).
        ee_quaternion: ``(4,) float64`` end-effector orientation *relative to the home orientation*,
            ``(x, y, z, w)`` (the identity means top-down at home yaw; docs/guide/world.md#the-robot).
        held: name of the object rigidly grasped, or ``None``.
    """

    objects: Mapping[str, ObjectPose]
    ee_position: np.ndarray = field(default_factory=lambda: np.array([0.402, 0.0, 0.400]))
    ee_quaternion: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 0.0, 1.0]))
    held: str | None = None

    @property
    def object_names(self) -> tuple[str, ...]:
        """Present objects in observation-row order."""
        return tuple(self.objects)


def pose_groups(states: Sequence[GeometricState], excluded: Collection[str] = ()) -> tuple[list[int], np.ndarray]:
    """The states grouped by the exact poses of their objects other than ``excluded`` (a planner's
    samples, whose moved objects differ and whose others stand where they stood):
    ``(the first state of each group, (S,) int64 the group of each state)``."""
    groups: dict[tuple, int] = {}
    first: list[int] = []
    group_of = np.empty(len(states), dtype=np.int64)
    for index, state in enumerate(states):
        key = tuple((name, pose.position.tobytes(), pose.quaternion.tobytes()) for name, pose in state.objects.items() if name not in excluded)
        if key not in groups:
            groups[key] = len(first)
            first.append(index)
        group_of[index] = groups[key]
    return first, group_of
