"""The small interface a physics engine implements to run the TableEnv world.

A backend owns one simulated scene and answers in world coordinates (metres, radians, seconds;
quaternions ``(x, y, z, w)``). The core drives it: :class:`~t2m_core.simulation.motion.MotionExecutor`
turns the domain's motion steps into servo targets and ticks, :func:`~t2m_core.simulation.execution.execute_primitive`
runs a primitive, :func:`~t2m_core.simulation.reset.reset_to_task` samples, settles and verifies a
task's initial state. Everything geometric comes from :mod:`t2m_core.domain`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from t2m_core.domain.state import GeometricState, ObjectPose
from t2m_core.protocols import Contact
from t2m_core.simulation import rules
from t2m_core.simulation.kinematics import rotation_z


@dataclass
class IKResult:
    """An IK answer: ``q`` ``(7,)`` joints in radians and how far their pose is from the target
    (metres, radians). The pose is reachable when the solution lands within
    :data:`~t2m_core.simulation.rules.IK_POSITION_TOLERANCE` and
    :data:`~t2m_core.simulation.rules.IK_ORIENTATION_TOLERANCE` of it, inside the joint limits less
    :data:`~t2m_core.simulation.rules.JOINT_LIMIT_MARGIN`."""

    q: np.ndarray  # (7,) rad
    position_error: float
    orientation_error: float
    within_limits: bool

    @property
    def reachable(self) -> bool:
        return (
            self.within_limits
            and self.position_error < rules.IK_POSITION_TOLERANCE
            and self.orientation_error < rules.IK_ORIENTATION_TOLERANCE
        )


class PhysicsBackend(ABC):
    """One simulated TableEnv scene: the Panda, the present objects, a grasp weld.

    Attributes:
        ticks: 1/60 s ticks simulated since the last reset.
        held: the object welded to the hand, or ``None``.
        home_rotation: ``(3, 3)`` EE rotation at q_home (top-down, yaw 0).
        object_names: the present objects in task order (``table`` first).
        free_names: the present objects that are not the static table, in task order.
    """

    ticks: int
    held: str | None
    home_rotation: np.ndarray
    object_names: tuple[str, ...]
    free_names: tuple[str, ...]

    # --- time ---------------------------------------------------------------------------------------

    @abstractmethod
    def tick(self, count: int = 1) -> None:
        """Advance ``count`` ticks of 1/60 s with the current servo targets and compliance."""

    @abstractmethod
    def snapshot(self) -> Any:
        """An exact, opaque copy of the physics and the controller (servo targets, weld, ticks)."""

    @abstractmethod
    def restore(self, snapshot: Any) -> None:
        """Restore a :meth:`snapshot` of this scene exactly; ``TypeError`` / ``ValueError`` for a
        snapshot of another kind or scene."""

    @abstractmethod
    def canonicalize(self) -> None:
        """Bring the engine into the state a snapshot restore gives (e.g. every body awake, caches
        as after a restore), so a primitive run straight after another one and the same primitive
        run after a restore follow identical trajectories."""

    # --- arm ----------------------------------------------------------------------------------------

    @abstractmethod
    def arm_q(self) -> np.ndarray:
        """``(7,)`` arm joint positions, radians."""

    @abstractmethod
    def set_arm_target(self, q: np.ndarray) -> None:
        """Joint servo targets ``(7,)`` rad, held until changed."""

    @abstractmethod
    def ee_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """EE operational point ``((3,) position m, (3, 3) rotation)`` in the world."""

    @abstractmethod
    def ee_velocity(self) -> tuple[float, float]:
        """EE linear (m/s) and angular (rad/s) speed."""

    @abstractmethod
    def ee_distance(self, position: np.ndarray) -> float:
        """Metres from the EE point to ``position`` (3,)."""

    @abstractmethod
    def ee_rotation_error(self, rotation: np.ndarray) -> float:
        """Radians between the EE orientation and ``rotation`` (3, 3)."""

    @abstractmethod
    def solve_ik(self, position: np.ndarray, rotation: np.ndarray, seed: np.ndarray, null_target: np.ndarray) -> IKResult:
        """Joints that put the EE at ``position`` (3,) m with ``rotation`` (3, 3), starting from ``seed``
        (7,) rad, the posture pulled toward ``null_target`` (7,) rad. Never moves the simulated arm."""

    @abstractmethod
    def track_ik(self, q: np.ndarray, position: np.ndarray, rotation: np.ndarray, null_target: np.ndarray) -> np.ndarray:
        """A cheap IK refinement from ``q`` (7,) toward a nearby pose: the keyframes of a straight
        motion, each warm-started from the previous one. Returns ``(7,)`` rad within the limits."""

    def target_rotation(self, yaw: float) -> np.ndarray:
        """``(3, 3)`` top-down EE rotation at ``yaw`` radians relative to home."""
        return rotation_z(yaw) @ self.home_rotation

    @abstractmethod
    def begin_compliance(self) -> None:
        """Make the arm compliant for a tool sweep: the joint servos nearly limp, the EE driven by
        :meth:`apply_compliance` (the reference's operational-space sweep)."""

    @abstractmethod
    def apply_compliance(self, position_target: np.ndarray, rotation_target: np.ndarray) -> None:
        """Set the compliant sweep's joint torques toward the EE targets ((3,) m, (3, 3)) for the next tick."""

    @abstractmethod
    def end_compliance(self) -> None:
        """Restore the stiff joint servos and stop the sweep's torques."""

    # --- gripper ------------------------------------------------------------------------------------

    @abstractmethod
    def set_gripper(self, opening: float) -> None:
        """Finger target in metres per finger: ``FINGER_OPEN`` open, 0 closed."""

    @abstractmethod
    def finger_q(self) -> float:
        """Finger position in metres (0 closed)."""

    @abstractmethod
    def pads_hold(self, name: str) -> bool:
        """Whether both pads grip ``name`` validly (:func:`t2m_core.simulation.grasp.pad_grips`)."""

    @abstractmethod
    def attach(self, name: str) -> None:
        """Weld ``name`` rigidly to the hand at its current relative pose, compensating its weight."""

    @abstractmethod
    def release(self) -> None:
        """Drop the grasp weld."""

    # --- objects and contacts -----------------------------------------------------------------------

    @abstractmethod
    def geometric_state(self) -> GeometricState:
        """Object poses in task order, the EE point and orientation relative to home, the held object."""

    @abstractmethod
    def moving_objects(self, names: Iterable[str] | None = None) -> list[str]:
        """The objects (of ``names``; default all free ones) moving by the ε_twist rule
        (:class:`~t2m_core.simulation.rules.TwistWatch`); a held object moves with the hand."""

    @abstractmethod
    def forget_twist(self) -> None:
        """Start a fresh averaging window for :meth:`moving_objects`."""

    @abstractmethod
    def distance(self, name_a: str, name_b: str) -> float:
        """Closest distance in metres between two objects (negative when penetrating)."""

    @abstractmethod
    def contact_guard(self, forbidden: tuple[str, ...]) -> Callable[[], list[Contact]]:
        """A check, called during a guarded motion, returning the contacts with a positive normal
        force between a finger (pads and finger bodies) or the held object and a ``forbidden`` object."""

    # --- reset --------------------------------------------------------------------------------------

    @abstractmethod
    def reset_robot(self) -> None:
        """Clear the simulation (velocities, contacts, time), put the arm at q_home without simulating,
        open the gripper, drop any weld: a reset never depends on what was simulated before."""

    @abstractmethod
    def place_objects(self, poses: Mapping[str, ObjectPose]) -> None:
        """Put the free objects at rest at ``poses``."""

    @abstractmethod
    def held_touches_robot(self, name: str) -> bool:
        """Whether held ``name`` touches a robot part other than the fingers."""

    @abstractmethod
    def objects_touch_base(self) -> bool:
        """Whether any object touches the robot's base link."""

    def close(self) -> None:
        """Release native resources (engine clients)."""
