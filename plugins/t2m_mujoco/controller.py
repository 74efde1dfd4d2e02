"""Arm and gripper control: damped-least-squares IK on MuJoCo's Jacobians and per-tick servo targets.

The arm carries joint position servos (:mod:`t2m_mujoco.robot_model`). Every 1/60 s tick the
controller writes 7 joint targets into ``ctrl`` and the simulator advances with one
``mj_step(model, data, nstep)`` call. Targets come from one of two trajectories:

* **free moves** (MOVE) interpolate in joint space, from the current joints to an IK solution of the
  goal pose, at a bounded joint speed;
* **straight moves** (DESCEND, LIFT, SWEEP) interpolate the EE pose on a straight line and run one
  DLS iteration per tick, warm-started from the previous target, so contact-guarded motions stay on
  the segment the domain asked for.

IK runs on a private ``MjData`` (kinematics only), never on the simulated one. The null space pulls
the arm toward q_home with joint 1 facing the goal (atan2(y, x)), as the original's null-space task.
EE orientation targets are top-down with a yaw relative to the home orientation (tableenv.md §3.1):
``R = Rz(yaw) · R_home``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from t2m_mujoco.robot_model import Q_HOME, RobotIndices

TICKS_PER_SECOND = 60
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
IK_POSITION_TOLERANCE = 0.002
"""Metres: an IK solution farther than this from its target means the pose is unreachable."""
IK_ORIENTATION_TOLERANCE = 0.02
"""Radians."""
JOINT_LIMIT_MARGIN = 0.02
"""Radians kept from the joint limits: a target beyond them is a control failure (§3.2 Abort)."""
SOFT_POSITION_GAINS = np.array([49.0, 49.0, 121.0])
"""N/m of the compliant sweep in x, y, z (tableenv.md §3.2 soft gains)."""
SOFT_VELOCITY_GAINS = np.array([14.0, 14.0, 22.0])
"""N·s/m."""
SOFT_ORIENTATION_GAINS = (121.0, 16.0)
"""N·m/rad and N·m·s/rad of the sweep's orientation task."""
SOFT_MAX_FORCE = 6.0
"""N: the most the compliant sweep pushes with, below what slides the 1 kg rack (friction 1.0)."""
SOFT_MAX_TORQUE = 10.0
"""N·m: bound on the sweep's orientation moment (normal sweeps stay below ~3.5 N·m; near a singular
posture the operational-space inertia, and with it the moment, would grow without bound)."""
OPERATIONAL_INERTIA_REGULARISATION = 1e-3
"""Added to J·M⁻¹·Jᵀ (1/kg, 1/(kg·m²)) before inverting it, bounding Λ (≤ 1000) near singular postures."""


def rotation_z(yaw: float) -> np.ndarray:
    """``(3, 3)`` rotation about world z by ``yaw`` radians."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rotation_error(target: np.ndarray, current: np.ndarray) -> np.ndarray:
    """``(3,)`` world-frame rotation vector (axis·angle, radians) taking ``current`` to ``target``."""
    # scalar arithmetic on a flat list: this runs every control tick, where numpy's per-call
    # overhead on 3-vectors costs more than the arithmetic
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = (target @ current.T).ravel().tolist()
    cos_angle = max(-1.0, min(1.0, (r00 + r11 + r22 - 1.0) / 2.0))
    angle = math.acos(cos_angle)
    sin_angle = math.sin(angle)
    if sin_angle < 1e-6:
        if angle < 1e-6:
            return np.array([0.5 * (r21 - r12), 0.5 * (r02 - r20), 0.5 * (r10 - r01)])
        # near π: axis from the diagonal
        return angle * np.sqrt(np.maximum((np.array([r00, r11, r22]) + 1.0) / 2.0, 0.0))
    scale = angle / (2.0 * sin_angle)
    return np.array([scale * (r21 - r12), scale * (r02 - r20), scale * (r10 - r01)])


@dataclass
class IKResult:
    """A joint solution and how far its pose is from the target (metres, radians)."""

    q: np.ndarray  # (7,) rad
    position_error: float
    orientation_error: float
    within_limits: bool

    @property
    def reachable(self) -> bool:
        return (
            self.within_limits
            and self.position_error < IK_POSITION_TOLERANCE
            and self.orientation_error < IK_ORIENTATION_TOLERANCE
        )


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
        self._low = robot.joint_low + JOINT_LIMIT_MARGIN
        self._high = robot.joint_high - JOINT_LIMIT_MARGIN
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
        """``(7,)`` seeds: ``null_target`` with joint 7 at each in-limit angle giving the EE yaw of
        ``rotation`` (top-down, the yaw is q1 − q7 relative to home when the other joints are at home)."""
        relative = rotation @ self.home_rotation.T
        yaw = math.atan2(relative[1, 0], relative[0, 0])
        base = null_target[0] - yaw + Q_HOME[6]
        seeds = []
        for turns in (-1, 0, 1):
            wrist = base + 2.0 * math.pi * turns
            if self._low[6] < wrist < self._high[6]:
                seed = np.array(null_target, dtype=np.float64)
                seed[6] = wrist
                seeds.append(seed)
        return seeds


def null_target_facing(position: np.ndarray) -> np.ndarray:
    """``(7,)`` null-space posture: q_home with joint 1 turned to face ``position`` (x, y)."""
    target = Q_HOME.copy()
    target[0] = math.atan2(position[1], position[0])
    return target


def index_slice(indices: np.ndarray) -> slice | np.ndarray:
    """``indices`` as a slice when they are consecutive (views instead of copies), else unchanged."""
    indices = np.asarray(indices)
    if indices.size and np.array_equal(indices, np.arange(indices[0], indices[0] + indices.size)):
        return slice(int(indices[0]), int(indices[0]) + indices.size)
    return indices


class SweepImpedance:
    """Operational-space impedance of the original's sweep (tableenv.md §3.2 soft gains).

    :meth:`apply` writes joint torques ``Jᵀ·Λ·(K·(x* − x) − D·v)`` into ``qfrc_applied``, held for the
    next tick, with ``Λ = (J·M⁻¹·Jᵀ)⁻¹`` the EE's operational-space inertia, so the EE moves like a
    unit mass on the reference's springs (critically damped at ω = 7 rad/s) instead of dragging the
    arm's inertia. ``M⁻¹·Jᵀ`` comes from ``mj_solveM`` on the factor of M (armature included) that the
    last physics step computed, and ``Λ·a`` from one 6×6 solve: no dense inverse per tick. The force
    is bounded: a blocked tool presses and stalls, ending the motion, instead of ploughing through
    the rack.

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
        self._jacobian = np.zeros((6, model.nv))  # rows: linear (3), angular (3)
        self._inverse_mass_jacobian = np.zeros((6, model.nv))  # rows of (M⁻¹·Jᵀ)ᵀ
        self._acceleration = np.empty(6)
        self._wrench = np.empty(6)

    def apply(self, position_target: np.ndarray, rotation_target: np.ndarray) -> None:
        """Set the arm's applied torques toward ``position_target`` (3,) m and ``rotation_target`` (3, 3)."""
        mujoco, model, data, site = self._mujoco, self.model, self.data, self._site
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        jacobian = self._jacobian
        mujoco.mj_jacSite(model, data, jacobian[:3], jacobian[3:], site)
        arm_jacobian = jacobian[:, self._arm]
        velocity = arm_jacobian @ data.qvel[self._arm]
        acceleration = self._acceleration
        acceleration[:3] = SOFT_POSITION_GAINS * (position_target - data.site_xpos[site]) - SOFT_VELOCITY_GAINS * velocity[:3]
        stiffness, damping = SOFT_ORIENTATION_GAINS
        rotation = data.site_xmat[site].reshape(3, 3)
        acceleration[3:] = stiffness * rotation_error(rotation_target, rotation) - damping * velocity[3:]
        mujoco.mj_solveM(model, data, self._inverse_mass_jacobian, jacobian)
        # Λ·a = (J·M⁻¹·Jᵀ + εI)⁻¹·a; the regularisation bounds Λ near singular postures
        inverse_inertia = jacobian @ self._inverse_mass_jacobian.T
        inverse_inertia.flat[::7] += OPERATIONAL_INERTIA_REGULARISATION
        mujoco.mju_cholFactor(inverse_inertia, 0.0)  # symmetric positive definite
        wrench = self._wrench
        mujoco.mju_cholSolve(wrench, inverse_inertia, acceleration)
        force = math.sqrt(wrench[0] * wrench[0] + wrench[1] * wrench[1] + wrench[2] * wrench[2])
        if force > SOFT_MAX_FORCE:  # a blocked sweep presses, it does not shove (the rack weighs 1 kg)
            wrench[:3] *= SOFT_MAX_FORCE / force
        torque = math.sqrt(wrench[3] * wrench[3] + wrench[4] * wrench[4] + wrench[5] * wrench[5])
        if torque > SOFT_MAX_TORQUE:  # Λ grows without bound near a singular posture
            wrench[3:] *= SOFT_MAX_TORQUE / torque
        data.qfrc_applied[self._arm] = arm_jacobian.T @ wrench

    def release(self) -> None:
        """Stop applying torques."""
        self.data.qfrc_applied[self._arm] = 0.0
