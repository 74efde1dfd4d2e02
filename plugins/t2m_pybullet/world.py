"""The simulated world: one PyBullet client holding one scene, and the queries every other module uses.

It owns time (ticks of 1/60 s, each one ``stepSimulation`` call of ``substeps`` internal steps),
the joint motors, object poses and twists, the grasp constraint, contacts and closest distances,
and snapshots. It is PyBullet's :class:`~t2m_core.simulation.backend.PhysicsBackend`; the core's
motion executor drives it.

Each world has its own DIRECT client (and its IK its own), so several live in one process.
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass

import numpy as np

from t2m_core.domain.geometry import matrix_to_quat, quat_conjugate, quat_multiply, quat_to_matrix
from t2m_core.domain.state import GeometricState, ObjectPose
from t2m_core.protocols import Contact
from t2m_core.simulation.backend import IKResult, PhysicsBackend
from t2m_core.simulation.kinematics import rotation_error
from t2m_core.simulation.robot import ARM_TORQUE_LIMITS, FINGER_OPEN, Q_HOME
from t2m_core.simulation.rules import TwistWatch
from t2m_pybullet import contacts
from t2m_pybullet.client import connect
from t2m_pybullet.controller import ARM_POSITION_GAIN, ARM_VELOCITY_GAIN, InverseKinematics, SweepTorques
from t2m_pybullet.robot_model import load_panda
from t2m_pybullet.scene import build_scene

GRAVITY = (0.0, 0.0, -9.8)
GRIP_FORCE = 20.0
"""Newtons per finger motor: the URDF's finger effort. With rigid contacts two motors saturated at
the Franka's 70 N squeeze an object so hard that the solver lets the jaw and the object slide sideways
together (measured: 1 cm in 20 ticks); at 20 N the jaw closes centred and still. (MuJoCo's finger servo
squeezes with about 10 N.)"""
FINGER_SPEED = 0.2
"""m/s: the fastest a finger moves (the URDF's limit); faster, it slams 3 mm into an object in one step."""
FINGER_COUPLING_FORCE = 100.0
"""Newtons the gear constraint may apply to keep the fingers symmetric (more than the grip force)."""
WELD_MAX_FORCE = 1000.0
"""Newtons the grasp constraint may apply (it holds a 0.1 kg object rigidly)."""
IDENTITY_XYZW = np.array([0.0, 0.0, 0.0, 1.0])
APART_Z, APART_SPACING = 100.0, 10.0
"""Metres: where a restore puts the bodies, one above the other, to drop every contact first."""


@dataclass(frozen=True)
class Snapshot:
    """An exact copy of the simulation: PyBullet's in-memory state plus the controller's.

    Attributes:
        scene: the object names of the scene it belongs to.
        state: a ``saveState`` handle (positions, velocities, contact points for warm starting),
            removed from the client when the snapshot is garbage-collected.
        held: the object welded to the hand, or ``None``.
        weld_frame: ``(7,)`` the weld's parent frame in the hand's inertial frame (position, xyzw).
        arm_target: ``(7,)`` joint servo targets, rad. gripper_target: finger target, m.
        ticks: ticks simulated since the reset.
    """

    scene: tuple[str, ...]
    state: _SavedState
    held: str | None
    weld_frame: np.ndarray
    arm_target: np.ndarray
    gripper_target: float
    ticks: int


class _SavedState:
    """A ``saveState`` id that is removed from its client when no snapshot refers to it any more."""

    def __init__(self, client) -> None:
        self.id = client.saveState()
        weakref.finalize(self, _remove_state, weakref.ref(client), self.id)


def _remove_state(client_ref, state_id: int) -> None:
    client = client_ref()
    if client is not None and client.isConnected():
        client.removeState(state_id)


class World(PhysicsBackend):
    """A scene being simulated.

    Args:
        object_names: the present objects, table first.
        substeps: physics steps per 1/60 s tick.
        solver_iterations: PyBullet constraint-solver iterations per step.
    """

    def __init__(self, object_names: tuple[str, ...], substeps: int, solver_iterations: int = 50) -> None:
        self.client = client = connect()
        import pybullet

        self._pybullet = pybullet
        client.setGravity(*GRAVITY)
        client.setPhysicsEngineParameter(
            fixedTimeStep=1.0 / 60.0, numSubSteps=int(substeps), numSolverIterations=int(solver_iterations),
            deterministicOverlappingPairs=1,
            collisionFilterMode=0,  # a pair collides when each one's group is in the other's mask (the default is "either")
        )
        self.substeps = int(substeps)
        self.robot = load_panda(client)
        # PyBullet ignores the URDF's mimic joint: a gear constraint keeps the fingers symmetric,
        # so a closing jaw centres the object
        coupling = client.createConstraint(self.robot.body, self.robot.fingers[0], self.robot.body, self.robot.fingers[1],
                                           pybullet.JOINT_GEAR, [1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
        client.changeConstraint(coupling, gearRatio=-1, erp=0.1, maxForce=FINGER_COUPLING_FORCE)
        self.scene = build_scene(client, tuple(object_names))
        for body in (self.robot.body, *self.scene.body.values()):
            # bodies never sleep: sleep state is not part of a saved state, and with sleeping on (even
            # waking every body on restore) a restored snapshot diverged by 0.1 mm from a straight
            # run (measured); sleeping would halve the cost of a still scene
            client.changeDynamics(body, -1, activationState=pybullet.ACTIVATION_STATE_DISABLE_SLEEPING)
        self.ik = InverseKinematics()
        self.home_rotation = self.ik.home_rotation
        self.object_names = self.scene.object_names
        self.free_names = self.scene.free_names
        self.held: str | None = None
        self.ticks = 0
        self._weld: int | None = None
        self._weld_frame = np.zeros(7)
        self._sweep = SweepTorques(client, self.robot)
        self._compliant = False
        self._arm_target = Q_HOME.copy()
        self._gripper_target = FINGER_OPEN
        self._twist_watch = TwistWatch()
        self._link_names = {j: client.getJointInfo(self.robot.body, j)[12].decode() for j in range(client.getNumJoints(self.robot.body))}
        self._dofs = list(self.robot.dofs)
        self._home_robot()
        self._pristine = _SavedState(client)

    # --- time -------------------------------------------------------------------------------------

    def tick(self, count: int = 1) -> None:
        """Advance ``count`` ticks of 1/60 s (one ``stepSimulation`` of ``substeps`` steps each)."""
        for _ in range(count):
            self.client.stepSimulation()
        self.ticks += count

    # --- robot ------------------------------------------------------------------------------------

    def set_arm_target(self, q: np.ndarray) -> None:
        """Joint servo targets ``(7,)`` rad (the weak posture task's targets during a sweep)."""
        self._arm_target = np.array(q, dtype=np.float64)
        if not self._compliant:
            self._command_arm()

    def _command_arm(self) -> None:
        self.client.setJointMotorControlArray(
            self.robot.body, self.robot.arm, self._pybullet.POSITION_CONTROL, targetPositions=self._arm_target.tolist(),
            forces=ARM_TORQUE_LIMITS, positionGains=[ARM_POSITION_GAIN] * 7, velocityGains=[ARM_VELOCITY_GAIN] * 7,
        )

    def set_gripper(self, opening: float) -> None:
        """Finger target in metres per finger: :data:`FINGER_OPEN` open, 0 closed."""
        self._gripper_target = float(opening)
        for finger in self.robot.fingers:
            self.client.setJointMotorControl2(
                self.robot.body, finger, self._pybullet.POSITION_CONTROL, targetPosition=self._gripper_target,
                force=GRIP_FORCE, positionGain=ARM_POSITION_GAIN, velocityGain=ARM_VELOCITY_GAIN, maxVelocity=FINGER_SPEED,
            )

    def _joint_states(self) -> tuple[np.ndarray, np.ndarray]:
        """``(9,)`` positions and ``(9,)`` velocities of the arm and finger joints."""
        states = self.client.getJointStates(self.robot.body, self._dofs)
        return np.array([s[0] for s in states]), np.array([s[1] for s in states])

    def arm_q(self) -> np.ndarray:
        states = self.client.getJointStates(self.robot.body, self.robot.arm)
        return np.array([s[0] for s in states])

    def finger_q(self) -> float:
        return float(self.client.getJointState(self.robot.body, self.robot.fingers[0])[0])

    def _ee_state(self, velocity: bool = False):
        return self.client.getLinkState(self.robot.body, self.robot.ee, computeLinkVelocity=int(velocity), computeForwardKinematics=1)

    def ee_pose(self) -> tuple[np.ndarray, np.ndarray]:
        state = self._ee_state()
        return np.array(state[4]), quat_to_matrix(np.array(state[5]))

    def ee_velocity(self) -> tuple[float, float]:
        state = self._ee_state(velocity=True)
        return math.hypot(*state[6]), math.hypot(*state[7])

    def ee_distance(self, position: np.ndarray) -> float:
        return float(np.linalg.norm(np.asarray(position) - self._ee_state()[4]))

    def ee_rotation_error(self, rotation: np.ndarray) -> float:
        return float(np.linalg.norm(rotation_error(rotation, self.ee_pose()[1])))

    def solve_ik(self, position: np.ndarray, rotation: np.ndarray, seed: np.ndarray, null_target: np.ndarray) -> IKResult:
        return self.ik.solve(position, rotation, seed, null_target)

    def track_ik(self, q: np.ndarray, position: np.ndarray, rotation: np.ndarray, null_target: np.ndarray) -> np.ndarray:
        return self.ik.track(q, position, rotation)

    def begin_compliance(self) -> None:
        """Switch the arm's motors off (torque control); :meth:`apply_compliance` drives it."""
        self._compliant = True
        self.client.setJointMotorControlArray(self.robot.body, self.robot.arm, self._pybullet.VELOCITY_CONTROL, forces=[0.0] * 7)

    def apply_compliance(self, position_target: np.ndarray, rotation_target: np.ndarray) -> None:
        q, velocity = self._joint_states()
        load = None
        if self.held is not None:
            load = (self._weld_frame[:3], float(self.client.getDynamicsInfo(self.scene.body[self.held], -1)[0]))
        torque = self._sweep.torques(q, velocity, self._arm_target, position_target, rotation_target, load)
        self.client.setJointMotorControlArray(self.robot.body, self.robot.arm, self._pybullet.TORQUE_CONTROL, forces=torque.tolist())

    def end_compliance(self) -> None:
        self._compliant = False
        self._command_arm()

    def reset_robot(self) -> None:
        """Restore the freshly built simulation (no velocities, contacts or weld), set the arm to
        q_home directly (no simulation) and open the gripper (docs/guide/world.md#the-robot)."""
        self.release()
        self._restore_state(self._pristine.id)
        self._home_robot()

    def _home_robot(self) -> None:
        for joint, angle in zip(self.robot.arm, Q_HOME, strict=True):
            self.client.resetJointState(self.robot.body, joint, float(angle), 0.0)
        for joint in self.robot.fingers:
            self.client.resetJointState(self.robot.body, joint, FINGER_OPEN, 0.0)
        self.ticks = 0
        self._twist_watch.forget()
        self._compliant = False
        self.set_arm_target(Q_HOME)
        self.set_gripper(FINGER_OPEN)

    # --- objects ----------------------------------------------------------------------------------

    def object_pose(self, name: str) -> ObjectPose:
        if name == "table":
            return ObjectPose(np.zeros(3), IDENTITY_XYZW.copy())
        com, orientation = self.client.getBasePositionAndOrientation(self.scene.body[name])
        return ObjectPose(*self.scene.object_pose(name, com, orientation))

    def place_objects(self, poses: Mapping[str, ObjectPose]) -> None:
        for name, pose in poses.items():
            body = self.scene.body[name]
            com = self.scene.com_position(name, pose.position, pose.quaternion)
            self.client.resetBasePositionAndOrientation(body, com.tolist(), pose.quaternion.tolist())
            self.client.resetBaseVelocity(body, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0])

    def geometric_state(self) -> GeometricState:
        """Object poses in task order, the EE point and orientation relative to home, the held object."""
        position, rotation = self.ee_pose()
        return GeometricState(
            objects={name: self.object_pose(name) for name in self.scene.object_names},
            ee_position=position,
            ee_quaternion=matrix_to_quat(rotation @ self.home_rotation.T),
            held=self.held,
        )

    def moving_objects(self, names: Iterable[str] | None = None) -> list[str]:
        """Objects with any twist component ≥ ε_twist after averaging with the previous reading
        (docs/guide/world.md#geometric-tests); a held object moves with the hand."""
        free = self.scene.free_names
        if not free:
            return []
        twist = np.array([np.concatenate(self.client.getBaseVelocity(self.scene.body[name])) for name in free])
        if self.held is not None:
            hand = self.client.getLinkState(self.robot.body, self.robot.hand, computeLinkVelocity=1)
            twist[free.index(self.held)] = np.concatenate((hand[6], hand[7]))
        moving = self._twist_watch.moving(twist)
        selected = set(free if names is None else names)
        return [name for name, flag in zip(free, moving, strict=True) if flag and name in selected]

    def forget_twist(self) -> None:
        self._twist_watch.forget()

    # --- grasp weld -------------------------------------------------------------------------------

    def attach(self, name: str) -> None:
        """Weld ``name`` to the hand at its current relative pose (docs/guide/world.md#grasping)."""
        client = self.client
        hand = client.getLinkState(self.robot.body, self.robot.hand, computeForwardKinematics=1)
        hand_position, hand_orientation = np.array(hand[0]), np.array(hand[1])  # inertial frame
        com, orientation = client.getBasePositionAndOrientation(self.scene.body[name])
        relative_position = quat_to_matrix(hand_orientation).T @ (np.array(com) - hand_position)
        relative_orientation = quat_multiply(quat_conjugate(hand_orientation), np.array(orientation))
        self._weld_frame = np.concatenate((relative_position, relative_orientation))
        self._create_weld(name)

    def _create_weld(self, name: str) -> None:
        self._weld = self.client.createConstraint(
            self.robot.body, self.robot.hand, self.scene.body[name], -1, self._pybullet.JOINT_FIXED, [0.0, 0.0, 0.0],
            self._weld_frame[:3].tolist(), [0.0, 0.0, 0.0], self._weld_frame[3:].tolist(), [0.0, 0.0, 0.0, 1.0],
        )
        self.client.changeConstraint(self._weld, maxForce=WELD_MAX_FORCE)
        self.held = name

    def pads_hold(self, name: str) -> bool:
        return contacts.pads_hold(self, name)

    def release(self) -> None:
        """Remove the grasp constraint."""
        if self._weld is not None:
            self.client.removeConstraint(self._weld)
            self._weld = None
        self.held = None

    # --- contacts and distances -------------------------------------------------------------------

    def contact_guard(self, forbidden: tuple[str, ...]) -> Callable[[], list[Contact]]:
        return contacts.contact_guard(self, forbidden)

    def held_touches_robot(self, name: str) -> bool:
        return contacts.held_touches_robot(self, name)

    def objects_touch_base(self) -> bool:
        return contacts.objects_touch_base(self)

    def link_name(self, link: int) -> str:
        """The robot link's URDF name."""
        return self._link_names[link]

    def distance(self, name_a: str, name_b: str, cutoff: float = 0.5) -> float:
        """Closest distance in metres between two objects (negative when penetrating)."""
        points = self.client.getClosestPoints(self.scene.body[name_a], self.scene.body[name_b], cutoff)
        return float(min((point[8] for point in points), default=cutoff))

    # --- snapshots --------------------------------------------------------------------------------

    def canonicalize(self) -> None:
        """Round-trip through a snapshot (the weld recreated, motors re-commanded), so a primitive run
        straight after another one and the same primitive run after :meth:`restore` follow identical
        trajectories."""
        self.restore(self.snapshot())

    def snapshot(self) -> Snapshot:
        return Snapshot(self.scene.object_names, _SavedState(self.client), self.held, self._weld_frame.copy(),
                        self._arm_target.copy(), self._gripper_target, self.ticks)

    def restore(self, snapshot: Snapshot) -> None:
        """Restore a :class:`Snapshot` of this scene exactly."""
        if not isinstance(snapshot, Snapshot):
            raise TypeError(f"set_state expects a snapshot from get_state(), got {type(snapshot).__name__}")
        if snapshot.scene != self.scene.object_names:
            raise ValueError(f"snapshot of scene {snapshot.scene} cannot be restored into scene {self.scene.object_names}")
        self.release()
        self._restore_state(snapshot.state.id)
        self._weld_frame = snapshot.weld_frame.copy()
        if snapshot.held is not None:
            self._create_weld(snapshot.held)
        self._compliant = False
        self._arm_target = snapshot.arm_target.copy()
        self._command_arm()
        self.set_gripper(snapshot.gripper_target)
        self.ticks = snapshot.ticks
        self._twist_watch.forget()

    def _restore_state(self, state_id: int) -> None:
        """``restoreState`` from a clean slate, twice: the bodies are first moved apart and the contacts
        dropped, so the restored contact manifolds (and with them the solver's order) do not depend on
        which contacts the simulation made since the state was saved. A restored manifold saves
        slightly differently from a simulated one (its points rounded, its impulses zero), so one
        restore of a live state and one of a restored state differ by ~1e-8 m; after a second round
        trip the state is a fixed point (measured), and every restore ends there."""
        client = self.client
        self._restore_apart(state_id)
        settled = client.saveState()
        self._restore_apart(settled)
        client.removeState(settled)

    def _restore_apart(self, state_id: int) -> None:
        client = self.client
        for index, body in enumerate((self.robot.body, *self.scene.body.values(), self.scene.floor)):
            client.resetBasePositionAndOrientation(body, [0.0, 0.0, APART_Z + APART_SPACING * index], [0.0, 0.0, 0.0, 1.0])
        client.performCollisionDetection()
        client.restoreState(state_id)

    def close(self) -> None:
        self.ik.close()
        if self.client.isConnected():
            self.client.disconnect()


__all__ = ["Snapshot", "World"]
