"""The simulated world: one compiled scene, its ``MjData`` and the queries every other module uses.

It owns time (ticks of 1/60 s, each one ``mj_step`` call with ``substeps`` physics steps), object
poses and twists, the grasp weld, contacts and closest distances, and snapshots. It is MuJoCo's
:class:`~t2m_core.simulation.backend.PhysicsBackend` and knows nothing about primitives: the core's
motion executor drives it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from t2m_core.domain.state import GeometricState, ObjectPose
from t2m_core.protocols import Contact
from t2m_core.simulation.backend import IKResult, PhysicsBackend
from t2m_core.simulation.kinematics import rotation_error
from t2m_core.simulation.robot import FINGER_OPEN, Q_HOME
from t2m_core.simulation.rules import TwistWatch
from t2m_mujoco import contacts
from t2m_mujoco.controller import InverseKinematics, SweepImpedance, index_slice
from t2m_mujoco.scene import SceneModel

IDENTITY_XYZW = np.array([0.0, 0.0, 0.0, 1.0])


def wxyz_to_xyzw(quat: np.ndarray) -> np.ndarray:
    return np.array([quat[1], quat[2], quat[3], quat[0]])


def matrix_to_xyzw(rotation: np.ndarray) -> np.ndarray:
    import mujoco

    wxyz = np.empty(4)
    mujoco.mju_mat2Quat(wxyz, rotation.reshape(9))
    return wxyz_to_xyzw(wxyz)


@dataclass(frozen=True)
class Snapshot:
    """An exact copy of the simulation: MuJoCo's integration state plus the controller's.

    Attributes:
        scene: the object names of the scene it belongs to.
        physics: ``mj_getState(..., mjSTATE_INTEGRATION)`` (qpos, qvel, act, ctrl, eq_active,
            warm start, time...).
        held: the welded object, or ``None``.
        weld_pose: ``(7,)`` relative pose data of the active weld (position, wxyz quaternion).
        ticks: ticks simulated since the reset.
    """

    scene: tuple[str, ...]
    physics: np.ndarray
    held: str | None
    weld_pose: np.ndarray
    ticks: int


class World(PhysicsBackend):
    """A scene being simulated.

    Args:
        scene: the compiled scene.
        substeps: physics steps per 1/60 s tick (the timestep is ``1/(60·substeps)`` seconds).
    """

    def __init__(self, scene: SceneModel, substeps: int) -> None:
        import mujoco

        self._mujoco = mujoco
        self.scene = scene
        self.model = scene.model
        self.robot = scene.robot
        self.substeps = int(substeps)
        self.data = mujoco.MjData(self.model)
        self.ik = InverseKinematics(self.model, self.robot)
        self.held: str | None = None
        self.ticks = 0
        self._state_spec = mujoco.mjtState.mjSTATE_INTEGRATION
        self._free = scene.free_names
        self._twist_index = np.array(
            [scene.dof_address[n] + k for n in self._free for k in range(6)], dtype=int
        ).reshape(len(self._free), 6)
        self._body_ids = np.array([scene.body[n] for n in scene.object_names], dtype=int)
        self._twist_watch = TwistWatch()
        self._arm_ctrl = index_slice(self.robot.arm_actuators)
        self._site_velocity = np.empty(6)
        self._impedance = SweepImpedance(self.model, self.data, self.robot)
        self._finger_geoms = contacts.finger_geoms(self)
        self.home_rotation = self.ik.home_rotation
        self.object_names = scene.object_names
        self.free_names = scene.free_names

    # --- time -------------------------------------------------------------------------------------

    def tick(self, count: int = 1) -> None:
        """Advance ``count`` ticks of 1/60 s (``substeps`` physics steps each, all in C)."""
        self._mujoco.mj_step(self.model, self.data, nstep=self.substeps * count)
        self.ticks += count

    # --- robot ------------------------------------------------------------------------------------

    def set_arm_target(self, q: np.ndarray) -> None:
        """Joint servo targets ``(7,)`` rad."""
        self.data.ctrl[self._arm_ctrl] = q

    def set_gripper(self, opening: float) -> None:
        """Finger target in metres per finger: :data:`FINGER_OPEN` open, 0 closed."""
        self.data.ctrl[self.robot.gripper_actuator] = opening

    def arm_q(self) -> np.ndarray:
        return self.data.qpos[self.robot.arm_qpos].copy()

    def finger_q(self) -> float:
        return float(self.data.qpos[self.robot.finger_qpos[0]])

    def ee_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """EE site ``((3,) position m, (3, 3) rotation)`` in the world."""
        site = self.robot.ee_site
        return self.data.site_xpos[site].copy(), self.data.site_xmat[site].reshape(3, 3).copy()

    def ee_velocity(self) -> tuple[float, float]:
        """EE linear (m/s) and angular (rad/s) speed."""
        v = self._site_velocity  # (angular, linear)
        self._mujoco.mj_objectVelocity(self.model, self.data, self._mujoco.mjtObj.mjOBJ_SITE, self.robot.ee_site, v, 0)
        return math.sqrt(v[3] * v[3] + v[4] * v[4] + v[5] * v[5]), math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])

    def ee_distance(self, position: np.ndarray) -> float:
        """Metres from the EE site to ``position`` (3,)."""
        offset = position - self.data.site_xpos[self.robot.ee_site]
        return math.sqrt(float(offset @ offset))

    def ee_rotation_error(self, rotation: np.ndarray) -> float:
        """Radians between the EE orientation and ``rotation`` (3, 3)."""
        error = rotation_error(rotation, self.data.site_xmat[self.robot.ee_site].reshape(3, 3))
        return math.sqrt(float(error @ error))

    def solve_ik(self, position: np.ndarray, rotation: np.ndarray, seed: np.ndarray, null_target: np.ndarray) -> IKResult:
        """DLS IK on a private ``MjData`` (:meth:`InverseKinematics.solve`)."""
        return self.ik.solve(position, rotation, seed, null_target)

    def track_ik(self, q: np.ndarray, position: np.ndarray, rotation: np.ndarray, null_target: np.ndarray) -> np.ndarray:
        return self.ik.track(q, position, rotation, null_target)

    def begin_compliance(self) -> None:
        self._impedance.begin()

    def apply_compliance(self, position_target: np.ndarray, rotation_target: np.ndarray) -> None:
        self._impedance.apply(position_target, rotation_target)

    def end_compliance(self) -> None:
        self._impedance.end()

    def reset_robot(self, q: np.ndarray = Q_HOME) -> None:
        """Clear the whole simulation state (velocities, warm start, time, sleep), set the joints
        directly (no simulation) and open the gripper (docs/guide/world.md#the-robot). Clearing
        everything makes a reset independent of what was simulated before it."""
        self._mujoco.mj_resetData(self.model, self.data)
        self.ticks = 0
        self._twist_watch.forget()
        data = self.data
        data.qpos[self.robot.arm_qpos] = q
        data.qvel[self.robot.arm_dof] = 0.0
        data.qpos[self.robot.finger_qpos] = FINGER_OPEN
        data.ctrl[self.robot.arm_actuators] = q
        data.ctrl[self.robot.gripper_actuator] = FINGER_OPEN
        self.release()
        self._mujoco.mj_forward(self.model, data)

    # --- objects ----------------------------------------------------------------------------------

    def object_pose(self, name: str) -> ObjectPose:
        if name == "table":
            return ObjectPose(np.zeros(3), IDENTITY_XYZW.copy())
        body = self.scene.body[name]
        return ObjectPose(self.data.xpos[body].copy(), wxyz_to_xyzw(self.data.xquat[body]))

    def set_object_pose(self, name: str, pose: ObjectPose) -> None:
        """Place a free object (position, xyzw quaternion) at rest; call :meth:`forward` after."""
        address = self.scene.qpos_address[name]
        x, y, z, w = pose.quaternion
        self.data.qpos[address : address + 7] = (*pose.position, w, x, y, z)
        dof = self.scene.dof_address[name]
        self.data.qvel[dof : dof + 6] = 0.0

    def place_objects(self, poses: Mapping[str, ObjectPose]) -> None:
        for name, pose in poses.items():
            self.set_object_pose(name, pose)
        self.forward()

    def forward(self) -> None:
        self._mujoco.mj_forward(self.model, self.data)

    def geometric_state(self) -> GeometricState:
        """Object poses in task order, the EE point and orientation relative to home, the held object."""
        # After mj_step the kinematic fields describe the state before the last substep; recompute
        # them so a state read after stepping equals the same state read after a restore.
        self._mujoco.mj_kinematics(self.model, self.data)
        position, rotation = self.ee_pose()
        relative = rotation @ self.ik.home_rotation.T
        return GeometricState(
            objects={name: self.object_pose(name) for name in self.scene.object_names},
            ee_position=position,
            ee_quaternion=matrix_to_xyzw(relative),
            held=self.held,
        )

    def moving_objects(self, names: Iterable[str] | None = None) -> list[str]:
        """Objects with any twist component ≥ 0.001 after averaging with the previous reading (docs/guide/world.md#geometric-tests).

        A held object is rigidly attached in the reference (docs/guide/world.md#grasping), so it moves when the hand
        does: it is judged by the hand's twist. The weld equality is slightly soft, and a held hook
        keeps rotating in it at a few mrad/s for about a second after the arm has stopped, which
        otherwise made every "wait until stable" after a Pick or a Pull run ~35-55 extra ticks."""
        if not self._free:
            return []
        twist = self.data.qvel[self._twist_index]
        if self.held is not None:
            twist = twist.copy()
            hand_twist = np.empty(6)
            self._mujoco.mj_objectVelocity(self.model, self.data, self._mujoco.mjtObj.mjOBJ_BODY, self.robot.hand_body, hand_twist, 0)
            twist[self._free.index(self.held)] = hand_twist  # (angular, linear); only magnitudes matter
        moving = self._twist_watch.moving(twist)
        selected = set(self._free if names is None else names)
        return [name for name, flag in zip(self._free, moving, strict=True) if flag and name in selected]

    def forget_twist(self) -> None:
        """Start a fresh averaging window for :meth:`moving_objects`."""
        self._twist_watch.forget()

    # --- grasp weld -------------------------------------------------------------------------------

    def attach(self, name: str) -> None:
        """Weld ``name`` to the hand at its current relative pose (docs/guide/world.md#grasping)."""
        mujoco, data = self._mujoco, self.data
        hand, body = self.robot.hand_body, self.scene.body[name]
        relative_position = data.xmat[hand].reshape(3, 3).T @ (data.xpos[body] - data.xpos[hand])
        inverse = np.empty(4)
        mujoco.mju_negQuat(inverse, data.xquat[hand])
        relative_quat = np.empty(4)
        mujoco.mju_mulQuat(relative_quat, inverse, data.xquat[body])
        weld = self.scene.weld[name]
        self.model.eq_data[weld, 0:3] = 0.0
        self.model.eq_data[weld, 3:6] = relative_position
        self.model.eq_data[weld, 6:10] = relative_quat
        self.model.eq_data[weld, 10] = 1.0
        data.eq_active[weld] = 1
        # The original's controller adds the held object to the arm's load model; compensating its
        # weight here keeps a held hook from sagging onto the table under compliant gains.
        self.model.body_gravcomp[self.scene.body[name]] = 1.0
        self.held = name

    def pads_hold(self, name: str) -> bool:
        return contacts.pads_hold(self, name)

    def release(self) -> None:
        """Switch every grasp weld off."""
        for name, weld in self.scene.weld.items():
            self.data.eq_active[weld] = 0
            self.model.body_gravcomp[self.scene.body[name]] = 0.0
        self.held = None

    # --- contacts and distances -------------------------------------------------------------------

    def contacts_between(self, geoms_a: np.ndarray, owners_b: Sequence[int]) -> list[tuple[int, int, float]]:
        """Active contacts between a geom of ``geoms_a`` and a geom owned by ``owners_b``:
        ``(contact index, geom in a, normal force N)``, only those with a positive normal force."""
        data = self.data
        ncon = data.ncon
        if ncon == 0:
            return []
        geom_pairs = data.contact.geom[:ncon]
        owner = self.scene.geom_owner
        in_a = np.isin(geom_pairs, geoms_a)
        in_b = np.isin(owner[geom_pairs], owners_b)
        hits = np.flatnonzero((in_a[:, 0] & in_b[:, 1]) | (in_a[:, 1] & in_b[:, 0]))
        result = []
        force = np.empty(6)
        for index in hits:
            self._mujoco.mj_contactForce(self.model, data, int(index), force)
            if force[0] > 0.0:
                pair = geom_pairs[index]
                result.append((int(index), int(pair[0] if in_a[index, 0] else pair[1]), float(force[0])))
        return result

    def contact_guard(self, forbidden: tuple[str, ...]) -> Callable[[], list[Contact]]:
        return contacts.contact_guard(self, self._finger_geoms, forbidden)

    def held_touches_robot(self, name: str) -> bool:
        return contacts.held_touches_robot(self, name)

    def objects_touch_base(self) -> bool:
        return contacts.objects_touch_base(self)

    def owner_name(self, geom: int) -> str:
        owner = self.scene.geom_owner[geom]
        return self.scene.owners[owner] if owner >= 0 else "world"

    def distance(self, name_a: str, name_b: str, cutoff: float = 0.5) -> float:
        """Closest distance in metres between two objects' geoms (negative when penetrating)."""
        geoms_a = self.geoms_of(name_a)
        geoms_b = self.geoms_of(name_b)
        best = cutoff
        for geom_a in geoms_a:
            for geom_b in geoms_b:
                best = min(best, self._mujoco.mj_geomDistance(self.model, self.data, int(geom_a), int(geom_b), cutoff, None))
        return float(best)

    def geoms_of(self, name: str) -> np.ndarray:
        owner = self.scene.owners.index(name)
        return np.flatnonzero(self.scene.geom_owner == owner)

    # --- snapshots --------------------------------------------------------------------------------

    def canonicalize(self) -> None:
        """Round-trip through a snapshot: every body awake, nothing else changed. The simulator does
        this before each primitive, so a primitive run straight after another one and the same
        primitive run after :meth:`restore` follow bit-identical trajectories."""
        self.restore(self.snapshot())

    def snapshot(self) -> Snapshot:
        mujoco = self._mujoco
        size = mujoco.mj_stateSize(self.model, self._state_spec)
        physics = np.empty(size)
        mujoco.mj_getState(self.model, self.data, physics, self._state_spec)
        weld_pose = self.model.eq_data[self.scene.weld[self.held], 3:10].copy() if self.held else np.zeros(7)
        return Snapshot(self.scene.object_names, physics, self.held, weld_pose, self.ticks)

    def restore(self, snapshot: Snapshot) -> None:
        """Restore a :class:`Snapshot` of this scene exactly."""
        if not isinstance(snapshot, Snapshot):
            raise TypeError(f"set_state expects a snapshot from get_state(), got {type(snapshot).__name__}")
        if snapshot.scene != self.scene.object_names:
            raise ValueError(
                f"snapshot of scene {snapshot.scene} cannot be restored into scene {self.scene.object_names}"
            )
        mujoco = self._mujoco
        # MuJoCo's sleep bookkeeping is not part of any mjSTATE; resetting the data first wakes
        # every body, so a restore always yields the same (all-awake) simulation state.
        mujoco.mj_resetData(self.model, self.data)
        mujoco.mj_setState(self.model, self.data, snapshot.physics, self._state_spec)
        for name in self.scene.weld:
            self.model.body_gravcomp[self.scene.body[name]] = 0.0
        self.held = snapshot.held
        if snapshot.held:
            self.model.body_gravcomp[self.scene.body[snapshot.held]] = 1.0
            weld = self.scene.weld[snapshot.held]
            self.model.eq_data[weld, 0:3] = 0.0
            self.model.eq_data[weld, 3:10] = snapshot.weld_pose
            self.model.eq_data[weld, 10] = 1.0
        self.ticks = snapshot.ticks
        self._twist_watch.forget()
        mujoco.mj_forward(self.model, self.data)


__all__ = ["Snapshot", "World"]
