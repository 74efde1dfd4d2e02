"""Arm control in PyBullet's terms: its inverse kinematics, its joint motors, and operational-space
torques for the compliant sweep.

* **IK** is ``calculateInverseKinematics`` on a private kinematics-only copy of the robot in a client
  of its own, so solving never touches the simulated arm. A solve has two phases, like the original's
  null-space controller: PyBullet's null-space IK (joint limits, rest pose q_home with joint 1 facing
  the goal) shapes the posture, then its plain DLS IK from that posture removes the task error the
  null-space variant leaves (millimetres). The answer is checked by forward kinematics; a failure is
  retried from wrist seeds (:func:`t2m_core.simulation.kinematics.wrist_seeds`).
* **Servos** are PyBullet's ``POSITION_CONTROL`` motors (velocity constraints toward the target, at
  most :data:`~t2m_core.simulation.robot.ARM_TORQUE_LIMITS`).
* **The sweep** switches the arm to ``TORQUE_CONTROL``: ``τ = Jᵀ·Λ·a + Nᵀ·M·(K_p·(q* − q) − K_d·q̇) + g(q) + Jₒᵀ·mₒ·g``
  with ``a`` the soft springs of :func:`t2m_core.simulation.rules.sweep_acceleration`, ``Λ = (J·M⁻¹·Jᵀ)⁻¹``
  the EE's operational-space inertia from ``calculateMassMatrix`` and ``calculateJacobian``, a
  posture task toward the IK keyframes in the task's null space (``Nᵀ = I − Jᵀ·Λ·J·M⁻¹``, the
  original's null-space task), gravity ``g(q)`` from ``calculateInverseDynamics`` and the held
  object's weight. The torques are computed once per tick and hold for its substeps.
"""

from __future__ import annotations

import numpy as np

from t2m_core.domain.geometry import matrix_to_quat, quat_to_matrix
from t2m_core.simulation import rules
from t2m_core.simulation.backend import IKResult
from t2m_core.simulation.kinematics import relative_yaw, rotation_error, wrist_seeds
from t2m_core.simulation.robot import FINGER_OPEN, Q_HOME
from t2m_pybullet.client import connect
from t2m_pybullet.robot_model import RobotLinks, load_panda

POSTURE_ITERATIONS = 100
"""Iterations of PyBullet's null-space IK (the posture phase)."""
POLISH_ITERATIONS = 1000
"""Most iterations of PyBullet's plain DLS IK from the posture (the polish phase; it stops at
:data:`IK_RESIDUAL`). Near the arm's reach (0.70-0.73 m at the lift height) its damped steps converge
slowly: 100 iterations left 2-5 mm, which read as unreachable, 1000 leave 0.01 mm (measured)."""
TRACK_ITERATIONS = 200
"""Most plain IK iterations per keyframe of a straight motion (warm-started from the previous keyframe;
PyBullet stops at :data:`TRACK_RESIDUAL`). Its damped steps are slow: 3 iterations left centimetres
(a hook withdrawn after a push dipped into the table), 50 left 3 mm on a line that also turns the
gripper; 200 keep every keyframe within 1 mm of the line (tested)."""
IK_RESIDUAL = 1e-7
"""Metres: PyBullet's IK stops iterating below this residual."""
TRACK_RESIDUAL = 1e-5
"""Metres: a keyframe stops iterating below this residual (a hundredth of a millimetre)."""
ARM_POSITION_GAIN = 0.1
"""PyBullet motor position gain (fraction of the position error corrected per physics step)."""
ARM_VELOCITY_GAIN = 1.0
SOFT_POSTURE_GAINS = (16.0, 8.0)
"""1/s² and 1/s of the sweep's posture task (critically damped at 4 rad/s), in joint accelerations
weighted by the mass matrix and projected into the null space of the EE task: joint-space gains in
N·m/rad would make the light wrist links oscillate (their inertia is a few 1e-4 kg·m², and a torque
holds for a whole 1/60 s tick)."""


class InverseKinematics:
    """PyBullet's IK of the EE link on a private kinematics-only robot (its own DIRECT client)."""

    def __init__(self) -> None:
        self.client = connect()
        self.robot: RobotLinks = load_panda(self.client)
        self._low = self.robot.joint_low + rules.JOINT_LIMIT_MARGIN
        self._high = self.robot.joint_high - rules.JOINT_LIMIT_MARGIN
        # PyBullet's null-space IK takes limits, ranges and rest poses for every DoF (arm, fingers)
        self._lower = [*self._low, 0.0, 0.0]
        self._upper = [*self._high, FINGER_OPEN, FINGER_OPEN]
        self._ranges = [high - low for low, high in zip(self._lower, self._upper, strict=True)]
        self.home_rotation = self.forward(Q_HOME)[1]

    def forward(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """EE ``((3,) position m, (3, 3) rotation)`` for arm joints ``q`` (7,) rad."""
        client, robot = self.client, self.robot
        for joint, angle in zip(robot.arm, q, strict=True):
            client.resetJointState(robot.body, joint, float(angle))
        state = client.getLinkState(robot.body, robot.ee, computeForwardKinematics=1)
        return np.array(state[4]), quat_to_matrix(np.array(state[5]))

    def _pybullet_ik(
        self, q: np.ndarray, position: np.ndarray, quaternion: list[float], iterations: int, rest: np.ndarray | None,
        residual: float = IK_RESIDUAL,
    ) -> np.ndarray:
        seed = [*map(float, q), FINGER_OPEN, FINGER_OPEN]
        null_space = {} if rest is None else {
            "lowerLimits": self._lower, "upperLimits": self._upper, "jointRanges": self._ranges,
            "restPoses": [*map(float, rest), FINGER_OPEN, FINGER_OPEN],
        }
        solution = self.client.calculateInverseKinematics(
            self.robot.body, self.robot.ee, list(map(float, position)), quaternion, currentPositions=seed,
            maxNumIterations=iterations, residualThreshold=residual, **null_space,
        )
        return np.array(solution[:7])

    def track(self, q: np.ndarray, position: np.ndarray, rotation: np.ndarray) -> np.ndarray:
        """Plain IK warm-started from ``q`` (7,), at most :data:`TRACK_ITERATIONS`: a keyframe of a straight
        motion, clipped to the limits."""
        solution = self._pybullet_ik(q, position, matrix_to_quat(rotation).tolist(), TRACK_ITERATIONS, None, TRACK_RESIDUAL)
        return np.clip(solution, self._low, self._high)

    def solve(self, position: np.ndarray, rotation: np.ndarray, seed: np.ndarray, null_target: np.ndarray) -> IKResult:
        """Posture then polish from ``seed`` (7,) toward the pose; retried from wrist seeds when the
        answer is out of reach or outside the joint limits."""
        result = self._solve_from(np.asarray(seed, dtype=np.float64), position, rotation, null_target)
        if result.reachable:
            return result
        yaw = relative_yaw(rotation, self.home_rotation)
        for posture in wrist_seeds(null_target, yaw, self._low[6], self._high[6]):
            candidate = self._solve_from(posture, position, rotation, null_target)
            if candidate.reachable:
                return candidate
        return result

    def _solve_from(self, seed: np.ndarray, position: np.ndarray, rotation: np.ndarray, null_target: np.ndarray) -> IKResult:
        quaternion = matrix_to_quat(rotation).tolist()
        q = self._pybullet_ik(seed, position, quaternion, POSTURE_ITERATIONS, null_target)
        q = self._pybullet_ik(q, position, quaternion, POLISH_ITERATIONS, None)
        reached, reached_rotation = self.forward(q)
        within = bool(np.all(q > self._low + 1e-6) and np.all(q < self._high - 1e-6))
        return IKResult(q, float(np.linalg.norm(position - reached)), float(np.linalg.norm(rotation_error(rotation, reached_rotation))), within)

    def close(self) -> None:
        self.client.disconnect()


class SweepTorques:
    """The compliant sweep's joint torques (module docstring), computed once per tick.

    Args:
        client: the simulation's PyBullet client.
        robot: the simulated robot's indices.
    """

    def __init__(self, client, robot: RobotLinks) -> None:
        self.client, self.robot = client, robot
        self._acceleration = np.empty(6)
        self._arm = slice(0, 7)

    def torques(
        self,
        q: np.ndarray,
        velocity: np.ndarray,
        posture_target: np.ndarray,
        position_target: np.ndarray,
        rotation_target: np.ndarray,
        held_load: tuple[np.ndarray, float] | None,
    ) -> np.ndarray:
        """``(7,)`` arm torques in N·m for all DoFs ``q`` (9,) and their ``velocity`` (9,), the joint
        ``posture_target`` (7,), the EE targets ((3,) m, (3, 3)), and ``held_load``: a held object's centre
        of mass in the hand link's inertial frame (3,) m and its mass in kg, or ``None``."""
        client, robot = self.client, self.robot
        positions, velocities, zeros = q.tolist(), velocity.tolist(), [0.0] * len(q)
        state = client.getLinkState(robot.body, robot.ee, computeLinkVelocity=1, computeForwardKinematics=1)
        linear, angular = client.calculateJacobian(robot.body, robot.ee, [0.0, 0.0, 0.0], positions, velocities, zeros)
        jacobian = np.vstack((np.array(linear), np.array(angular)))  # (6, 9): linear rows, angular rows
        ee_velocity = np.concatenate((state[6], state[7]))
        acceleration = rules.sweep_acceleration(
            position_target, np.array(state[4]), rotation_target, quat_to_matrix(np.array(state[5])), ee_velocity, self._acceleration
        )
        mass = np.array(client.calculateMassMatrix(robot.body, positions))
        inverse_mass_jacobian = np.linalg.solve(mass, jacobian.T)  # M⁻¹·Jᵀ, (9, 6)
        # Λ·a = (J·M⁻¹·Jᵀ + εI)⁻¹·a; the regularisation bounds Λ near singular postures
        inverse_inertia = jacobian @ inverse_mass_jacobian + rules.OPERATIONAL_INERTIA_REGULARISATION * np.eye(6)
        wrench = rules.cap_sweep_wrench(np.linalg.solve(inverse_inertia, acceleration))
        stiffness, damping = SOFT_POSTURE_GAINS
        posture = np.zeros(len(q))
        posture[self._arm] = stiffness * (posture_target - q[self._arm]) - damping * velocity[self._arm]
        posture = mass @ posture
        # Nᵀ·τ = τ − Jᵀ·Λ·(J·M⁻¹·τ): the posture acts only where it does not move the EE
        posture -= jacobian.T @ np.linalg.solve(inverse_inertia, inverse_mass_jacobian.T @ posture)
        gravity = np.array(client.calculateInverseDynamics(robot.body, positions, zeros, zeros))
        torque = (jacobian.T @ wrench + posture + gravity)[self._arm]
        if held_load is not None:  # the original adds a held object to the arm's load model
            point, load = held_load
            linear, _ = client.calculateJacobian(robot.body, robot.hand, point.tolist(), positions, velocities, zeros)
            torque += (np.array(linear).T @ np.array([0.0, 0.0, load * 9.8]))[self._arm]
        return torque
