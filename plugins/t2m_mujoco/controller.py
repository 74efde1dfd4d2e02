"""Arm control in MuJoCo's terms: damped-least-squares IK on MuJoCo's Jacobians and the sweep's
operational-space impedance.

The arm carries joint position servos (:mod:`t2m_mujoco.robot_model`); the core's motion executor
(:mod:`t2m_core.simulation.motion`) writes 7 joint targets into ``ctrl`` every 1/60 s tick, from an
IK solution of a free move's goal or from IK keyframes along a straight move (:meth:`InverseKinematics.track`).

IK runs on a private ``MjData`` (kinematics only), never on the simulated one. The null space pulls
the arm toward q_home with joint 1 facing the goal (atan2(y, x)), as the original's null-space task.
EE orientation targets are top-down with a yaw relative to the home orientation:
``R = Rz(yaw) · R_home``.
"""

from __future__ import annotations

import numpy as np

from t2m_core.simulation import rules
from t2m_core.simulation.backend import IKResult
from t2m_core.simulation.kinematics import relative_yaw, rotation_error, rotation_z, wrist_seeds
from t2m_core.simulation.robot import Q_HOME
from t2m_core.simulation.rules import cap_sweep_wrench, sweep_acceleration
from t2m_mujoco.robot_model import RobotIndices

IK_DAMPING = 0.02
"""DLS damping λ (metres-equivalent): keeps steps bounded near singularities."""
IK_NULL_GAIN = 0.3
IK_POLISH_ITERATIONS = 20
IK_POSTURE_TOLERANCE = 1e-4
"""Radians: the posture phase (with the null-space pull) stops when no joint moves more than this.
The pull converges geometrically (factor 0.7 per iteration), so each tenfold tighter tolerance
costs ~6.5 more iterations, for a posture nobody can tell apart; the polish phase then removes the
task error."""
IK_POLISH_TOLERANCE = 1e-7
"""Radians: the polish phase (no null-space pull) stops when no joint moves more than this."""
IK_TRACK_ITERATIONS = 2
"""DLS iterations per keyframe of a straight motion (warm-started from the previous keyframe)."""
SOFT_POSTURE_SCALE = 0.002
"""During a sweep the joint servos keep only this fraction of their stiffness (a weak posture
task); the Cartesian impedance does the work."""
SOFT_DAMPING_SCALE = 0.01
"""Fraction of the joint servos' damping kept during a sweep: enough to keep the limp posture task
stable, small next to the operational-space damping (a larger one makes the EE crawl behind its
target and a sweep run for hundreds of ticks)."""


class InverseKinematics:
    """DLS inverse kinematics of the EE site on a private kinematics-only ``MjData``."""

    def __init__(self, model, robot: RobotIndices) -> None:
        import mujoco

        self._mujoco = mujoco
        self.model = model
        self.robot = robot
        self.data = mujoco.MjData(model)
        self._jacobian = np.zeros((6, model.nv))
        self._arm = index_slice(robot.arm_dof)
        self._arm_qpos = index_slice(robot.arm_qpos)
        self._weights = np.empty(6)
        self._projected = np.empty(6)
        self._low = robot.joint_low + rules.JOINT_LIMIT_MARGIN
        self._high = robot.joint_high - rules.JOINT_LIMIT_MARGIN
        self.home_rotation = self.forward(Q_HOME)[1]

    def forward(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """EE site ``((3,) position m, (3, 3) rotation)`` for arm joints ``q`` (7,) rad."""
        self.data.qpos[self.robot.arm_qpos] = q
        self._mujoco.mj_kinematics(self.model, self.data)
        site = self.robot.ee_site
        return self.data.site_xpos[site].copy(), self.data.site_xmat[site].reshape(3, 3).copy()

    def target_rotation(self, yaw: float) -> np.ndarray:
        """``(3, 3)`` top-down EE rotation at ``yaw`` radians relative to home."""
        return rotation_z(yaw) @ self.home_rotation

    def step(
        self, q: np.ndarray, position: np.ndarray, rotation: np.ndarray, null_target: np.ndarray | None
    ) -> np.ndarray:
        """One DLS iteration from ``q`` toward the pose, with a null-space pull toward ``null_target``
        (``None``: none); returns the new ``(7,)`` joints, clipped to the limits."""
        mujoco, data, robot = self._mujoco, self.data, self.robot
        data.qpos[self._arm_qpos] = q
        mujoco.mj_kinematics(self.model, data)
        mujoco.mj_comPos(self.model, data)
        site = robot.ee_site
        error = np.empty(6)
        error[:3] = position - data.site_xpos[site]
        error[3:] = rotation_error(rotation, data.site_xmat[site].reshape(3, 3))
        mujoco.mj_jacSite(self.model, data, self._jacobian[:3], self._jacobian[3:], site)
        jac = self._jacobian[:, self._arm]
        # dq = J⁺·e + (I − J⁺·J)·z with the damped pseudo-inverse J⁺ = Jᵀ·(J·Jᵀ + λ²I)⁻¹, (7, 6); the
        # projected pull is z − J⁺·(J·z): one Cholesky factor of J·Jᵀ + λ²I serves both solves
        jjt = jac @ jac.T
        jjt.flat[::7] += IK_DAMPING**2  # the diagonal
        mujoco.mju_cholFactor(jjt, 0.0)  # symmetric positive definite: Cholesky, in place
        weights = self._weights
        mujoco.mju_cholSolve(weights, jjt, error)
        if null_target is None:
            return self._clipped(q + jac.T @ weights)
        pull = IK_NULL_GAIN * (null_target - q)
        projected = self._projected
        mujoco.mju_cholSolve(projected, jjt, jac @ pull)
        return self._clipped(q + jac.T @ (weights - projected) + pull)

    def track(self, q: np.ndarray, position: np.ndarray, rotation: np.ndarray, null_target: np.ndarray) -> np.ndarray:
        """:data:`IK_TRACK_ITERATIONS` :meth:`step` s from ``q`` (7,): a keyframe of a straight motion."""
        for _ in range(IK_TRACK_ITERATIONS):
            q = self.step(q, position, rotation, null_target)
        return q

    def _clipped(self, q: np.ndarray) -> np.ndarray:
        """``q`` (7,) clipped to the joint limits less the margin, in place."""
        np.maximum(q, self._low, out=q)
        return np.minimum(q, self._high, out=q)

    def _iterate(
        self,
        q: np.ndarray,
        position: np.ndarray,
        rotation: np.ndarray,
        null_target: np.ndarray | None,
        iterations: int,
        tolerance: float,
    ) -> np.ndarray:
        """Up to ``iterations`` :meth:`step` s, stopping when no joint moves more than ``tolerance`` rad."""
        for _ in range(iterations):
            q_next = self.step(q, position, rotation, null_target)
            if np.max(np.abs(q_next - q)) < tolerance:
                return q_next
            q = q_next
        return q

    def solve(
        self, position: np.ndarray, rotation: np.ndarray, seed: np.ndarray, null_target: np.ndarray, iterations: int = 60
    ) -> IKResult:
        """Iterate :meth:`step` from ``seed``; reports the residual and whether limits were respected.

        The null-space pull shapes the posture during the first ``iterations``; a few final
        iterations without it remove the small task error the damped projection leaks."""
        result = self._solve_from(np.array(seed, dtype=np.float64), position, rotation, null_target, iterations)
        if result.reachable:
            return result
        # DLS turns the wrist the short way round, which runs joint 7 into its limit for yaws near
        # ±π although the other way round is within the limits: retry from the facing posture with
        # joint 7 already turned to the yaw, both ways round.
        for posture in self._wrist_seeds(null_target, rotation):
            candidate = self._solve_from(posture, position, rotation, null_target, iterations)
            if candidate.reachable:
                return candidate
        return result

    def _solve_from(
        self, seed: np.ndarray, position: np.ndarray, rotation: np.ndarray, null_target: np.ndarray, iterations: int
    ) -> IKResult:
        q = self._iterate(seed, position, rotation, null_target, iterations, IK_POSTURE_TOLERANCE)
        q = self._iterate(q, position, rotation, None, IK_POLISH_ITERATIONS, IK_POLISH_TOLERANCE)
        reached, reached_rotation = self.forward(q)
        position_error = float(np.linalg.norm(position - reached))
        orientation_error = float(np.linalg.norm(rotation_error(rotation, reached_rotation)))
        within = bool(np.all(q > self._low + 1e-6) and np.all(q < self._high - 1e-6))
        return IKResult(q, position_error, orientation_error, within)

    def _wrist_seeds(self, null_target: np.ndarray, rotation: np.ndarray) -> list[np.ndarray]:
        """``(7,)`` seeds with joint 7 turned to the yaw of ``rotation``, both ways round (:func:`wrist_seeds`)."""
        return wrist_seeds(null_target, relative_yaw(rotation, self.home_rotation), self._low[6], self._high[6])


def index_slice(indices: np.ndarray) -> slice | np.ndarray:
    """``indices`` as a slice when they are consecutive (views instead of copies), else unchanged."""
    indices = np.asarray(indices)
    if indices.size and np.array_equal(indices, np.arange(indices[0], indices[0] + indices.size)):
        return slice(int(indices[0]), int(indices[0]) + indices.size)
    return indices


class SweepImpedance:
    """Operational-space impedance of the original's sweep (the reference's soft gains,
    :func:`t2m_core.simulation.rules.sweep_acceleration`).

    :meth:`begin` makes the joint servos nearly limp; :meth:`apply` writes joint torques
    ``Jᵀ·Λ·(K·(x* − x) − D·v)`` into ``qfrc_applied``, held for the next tick, with ``Λ = (J·M⁻¹·Jᵀ)⁻¹``
    the EE's operational-space inertia, so the EE moves like a unit mass on the reference's springs
    (critically damped at ω = 7 rad/s) instead of dragging the arm's inertia. ``M⁻¹·Jᵀ`` comes from
    ``mj_solveM`` on the factor of M (armature included) that the last physics step computed, and
    ``Λ·a`` from one 6×6 solve: no dense inverse per tick. The force is capped
    (:func:`~t2m_core.simulation.rules.cap_sweep_wrench`): a blocked tool presses and stalls, ending
    the motion, instead of ploughing through the rack. :meth:`end` restores the servos.

    Args:
        model, data: the simulated ``MjModel`` / ``MjData``.
        robot: the robot's indices.
    """

    def __init__(self, model, data, robot: RobotIndices) -> None:
        import mujoco

        self._mujoco = mujoco
        self.model, self.data = model, data
        self._site = robot.ee_site
        self._arm = index_slice(robot.arm_dof)
        self._actuators = robot.arm_actuators
        self._jacobian = np.zeros((6, model.nv))  # rows: linear (3), angular (3)
        self._inverse_mass_jacobian = np.zeros((6, model.nv))  # rows of (M⁻¹·Jᵀ)ᵀ
        self._acceleration = np.empty(6)
        self._wrench = np.empty(6)
        self._saved_gains: tuple[np.ndarray, np.ndarray] | None = None

    def begin(self) -> None:
        """Make the joint servos nearly limp (:data:`SOFT_POSTURE_SCALE`, :data:`SOFT_DAMPING_SCALE`)."""
        model, actuators = self.model, self._actuators
        self._saved_gains = (model.actuator_gainprm[actuators].copy(), model.actuator_biasprm[actuators].copy())
        model.actuator_gainprm[actuators, 0] *= SOFT_POSTURE_SCALE
        model.actuator_biasprm[actuators, 1] *= SOFT_POSTURE_SCALE
        model.actuator_biasprm[actuators, 2] *= SOFT_DAMPING_SCALE

    def apply(self, position_target: np.ndarray, rotation_target: np.ndarray) -> None:
        """Set the arm's applied torques toward ``position_target`` (3,) m and ``rotation_target`` (3, 3)."""
        mujoco, model, data, site = self._mujoco, self.model, self.data, self._site
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        jacobian = self._jacobian
        mujoco.mj_jacSite(model, data, jacobian[:3], jacobian[3:], site)
        arm_jacobian = jacobian[:, self._arm]
        velocity = arm_jacobian @ data.qvel[self._arm]
        acceleration = sweep_acceleration(
            position_target, data.site_xpos[site], rotation_target, data.site_xmat[site].reshape(3, 3), velocity, self._acceleration
        )
        mujoco.mj_solveM(model, data, self._inverse_mass_jacobian, jacobian)
        # Λ·a = (J·M⁻¹·Jᵀ + εI)⁻¹·a; the regularisation bounds Λ near singular postures
        inverse_inertia = jacobian @ self._inverse_mass_jacobian.T
        inverse_inertia.flat[::7] += rules.OPERATIONAL_INERTIA_REGULARISATION
        mujoco.mju_cholFactor(inverse_inertia, 0.0)  # symmetric positive definite
        wrench = self._wrench
        mujoco.mju_cholSolve(wrench, inverse_inertia, acceleration)
        data.qfrc_applied[self._arm] = arm_jacobian.T @ cap_sweep_wrench(wrench)

    def end(self) -> None:
        """Restore the servo gains saved by :meth:`begin` and stop applying torques."""
        if self._saved_gains is not None:
            model, actuators = self.model, self._actuators
            model.actuator_gainprm[actuators] = self._saved_gains[0]
            model.actuator_biasprm[actuators] = self._saved_gains[1]
            self._saved_gains = None
        self.data.qfrc_applied[self._arm] = 0.0
