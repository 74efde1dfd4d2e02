"""Executes the domain's :class:`~t2m_core.domain.primitives.MotionStep` s on any :class:`PhysicsBackend`.

Everything geometric (waypoints, which bodies a motion may not touch, success tests) comes from the
domain; this module turns a step into servo targets and ticks, with the control failures of the
reference: ``"unreachable"`` (IK outside the joint limits, or a motion that neither converges nor
stalls within 10 s), ``"collision"`` (a finger or the held object touching a forbidden body, checked
every 10 ticks and when the motion ends) and ``"grasp_failed"``.

* **Free moves** (MOVE) interpolate in joint space with a smoothstep, from the current joints to an
  IK solution of the goal pose, at a mean :data:`MOVE_JOINT_SPEED` on the joint that moves most.
* **Straight moves** (DESCEND, LIFT, SWEEP) follow the straight EE line: IK keyframes every
  :data:`IK_KEY_PERIOD` ticks along it, each warm-started from the previous one, the servo targets
  interpolated between them. A compliant sweep (``soft``) also drives the EE along the line with the
  backend's operational-space torques while the joint servos go nearly limp.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from t2m_core.domain.geometry import wrap_angle
from t2m_core.domain.objects import ObjectKind, object_spec
from t2m_core.domain.primitives import MotionKind, MotionStep
from t2m_core.protocols import Contact
from t2m_core.simulation import rules
from t2m_core.simulation.backend import PhysicsBackend
from t2m_core.simulation.grasp import CLOSED_FINGER
from t2m_core.simulation.kinematics import null_target_facing, relative_yaw, smoothstep
from t2m_core.simulation.robot import FINGER_OPEN

MOVE_JOINT_SPEED = 2.0
"""rad/s: mean speed of the joint that moves most in a free move (the Panda allows 2.1-2.6)."""
STRAIGHT_SPEED = 0.8
"""m/s of descents and lifts (mean over the smoothstep ramp)."""
SWEEP_SPEED = 0.4
"""m/s of tool sweeps."""
YAW_SPEED = 2.0
"""rad/s of the gripper yaw on straight moves."""
IK_KEY_PERIOD = 5
"""Ticks between IK keyframes of a straight move."""


@dataclass
class StepReport:
    """What one step did: a failure reason or ``None``, and the contacts it saw."""

    failure: str | None = None
    contacts: list[Contact] = field(default_factory=list)


class MotionExecutor:
    """Runs motion steps on one backend.

    Args:
        backend: the simulated scene.
        on_tick: called every ``frame_every`` ticks of a motion (the video recorder), or ``None``.
        frame_every: see ``on_tick``.
    """

    def __init__(self, backend: PhysicsBackend, on_tick: Callable[[], None] | None = None, frame_every: int = 2) -> None:
        self.backend = backend
        self.on_tick = on_tick
        self.frame_every = max(1, int(frame_every))
        self.yaw_offset = 0.0

    def begin_primitive(self) -> None:
        """Forget the half-turn yaw choice of the previous primitive (see :meth:`_move`)."""
        self.yaw_offset = 0.0

    # --- public -----------------------------------------------------------------------------------

    def run(self, step: MotionStep) -> StepReport:
        """Execute one step; returns its failure reason (``None`` on success) and contacts."""
        kind = step.kind
        if kind is MotionKind.MOVE:
            return self._move(step, straight=False)
        if kind in (MotionKind.DESCEND, MotionKind.LIFT, MotionKind.SWEEP):
            return self._move(step, straight=True)
        if kind is MotionKind.GRASP:
            return StepReport(self.grasp(step.grasp_object))
        if kind is MotionKind.RELEASE:
            self.release()
            return StepReport()
        if kind is MotionKind.SETTLE:
            self.settle(step.timeout_s if step.timeout_s is not None else 3.0)
            return StepReport()
        raise ValueError(f"unknown motion kind {kind!r}")

    def settle(self, timeout_s: float, min_ticks: int = 1) -> int:
        """Tick until no object moves (at least ``min_ticks``, at most ``timeout_s``); returns the ticks used."""
        backend = self.backend
        backend.forget_twist()
        limit = max(min_ticks, int(round(timeout_s * rules.TICKS_PER_SECOND)))
        for tick in range(1, limit + 1):
            self._tick()
            if tick >= min_ticks and not backend.moving_objects():
                return tick
        return limit

    def grasp(self, name: str) -> str | None:
        """Close on ``name`` while it moves, validate the pads, weld it. ``"grasp_failed"`` or ``None``."""
        backend = self.backend
        backend.set_gripper(0.0)
        backend.forget_twist()
        previous = backend.finger_q()
        for tick in range(rules.GRIPPER_TIMEOUT_TICKS):
            self._tick()
            finger = backend.finger_q()
            settled = abs(finger - previous) < 1e-4 and tick >= 3
            previous = finger
            if settled and name not in backend.moving_objects([name]):
                break
        if backend.finger_q() < CLOSED_FINGER:
            return "grasp_failed"  # closed on nothing
        if not backend.pads_hold(name):
            return "grasp_failed"
        backend.attach(name)
        # The weld holds the object now; keep the fingers where they are instead of squeezing, so
        # pad forces and the weld do not fight (which makes the object creep).
        backend.set_gripper(backend.finger_q())
        return None

    def release(self) -> None:
        """Drop the weld and open the gripper (up to 1 s)."""
        backend = self.backend
        backend.release()
        backend.set_gripper(FINGER_OPEN)
        for _ in range(rules.GRIPPER_TIMEOUT_TICKS):
            self._tick()
            if backend.finger_q() > FINGER_OPEN - 0.002:
                break

    # --- motions ----------------------------------------------------------------------------------

    def _move(self, step: MotionStep, *, straight: bool) -> StepReport:
        backend = self.backend
        goal = step.ee_position
        start_position, start_rotation = backend.ee_pose()
        start_yaw = relative_yaw(start_rotation, backend.home_rotation)
        yaw = start_yaw if step.ee_yaw is None else float(step.ee_yaw)
        null_target = null_target_facing(goal)
        q_start = backend.arm_q()

        if step.ee_yaw is not None:
            yaw = wrap_angle(yaw + self.yaw_offset)
        solution = backend.solve_ik(goal, backend.target_rotation(yaw), q_start, null_target)
        if not solution.reachable and step.ee_yaw is not None and self._half_turn_allowed():
            # A parallel-jaw gripper holding nothing, or a square box, is symmetric under a half
            # turn about z: use the twin yaw when the commanded one is beyond joint 7's range, and
            # keep that choice for the rest of the primitive.
            twin = wrap_angle(yaw + math.pi)
            twin_solution = backend.solve_ik(goal, backend.target_rotation(twin), q_start, null_target)
            if twin_solution.reachable:
                yaw, solution = twin, twin_solution
                self.yaw_offset = wrap_angle(self.yaw_offset + math.pi)
        if not solution.reachable:
            return StepReport("unreachable")
        goal_rotation = backend.target_rotation(yaw)

        report = StepReport()
        forbidden = tuple(name for name in step.contact_objects if name != backend.held)
        guard = backend.contact_guard(forbidden) if forbidden else None

        if straight:
            distance = float(np.linalg.norm(goal - start_position))
            yaw_change = abs(wrap_angle(yaw - start_yaw))
            speed = SWEEP_SPEED if step.kind is MotionKind.SWEEP else STRAIGHT_SPEED
            duration = max(distance / speed, yaw_change / YAW_SPEED)
        else:
            duration = float(np.max(np.abs(solution.q - q_start))) / MOVE_JOINT_SPEED
        ramp_ticks = max(1, int(math.ceil(duration * rules.TICKS_PER_SECOND)))
        # servo targets (and the sweep's EE targets) of every ramp tick, computed at once
        ramp = np.arange(1, ramp_ticks)
        if straight:
            key_ticks, key_q = self._straight_keyframes(start_position, start_yaw, goal, yaw, q_start, solution.q, ramp_ticks, null_target)
            segment = np.minimum(ramp // IK_KEY_PERIOD, len(key_ticks) - 2)
            fraction = (ramp - key_ticks[segment]) / (key_ticks[segment + 1] - key_ticks[segment])
            targets = key_q[segment] + fraction[:, None] * (key_q[segment + 1] - key_q[segment])
        else:  # smoothstep: no velocity jumps
            targets = q_start + smoothstep(ramp / ramp_ticks)[:, None] * (solution.q - q_start)
        if step.soft:
            sweep_targets = start_position + smoothstep(np.append(ramp / ramp_ticks, 1.0))[:, None] * (goal - start_position)
            backend.begin_compliance()
        stalled_speed = rules.STALLED_SWEEP_SPEED if step.soft else rules.STALLED_SPEED
        try:
            averaged_speed, averaged_angular = None, None
            for tick in range(1, rules.MOTION_TIMEOUT_TICKS + 1):
                if tick < ramp_ticks:
                    backend.set_arm_target(targets[tick - 1])
                elif tick == ramp_ticks:
                    backend.set_arm_target(solution.q)
                if step.soft:
                    backend.apply_compliance(sweep_targets[min(tick, ramp_ticks) - 1], goal_rotation)
                self._tick()

                if guard is not None and tick % rules.CONTACT_CHECK_PERIOD == 0 and self._collided(guard, report):
                    return report
                if tick < ramp_ticks:
                    continue  # the servo follows the ramp; convergence is judged at its end
                speed, angular = backend.ee_velocity()
                if averaged_speed is None:
                    averaged_speed, averaged_angular = speed, angular
                else:
                    averaged_speed = 0.5 * averaged_speed + 0.5 * speed
                    averaged_angular = 0.5 * averaged_angular + 0.5 * angular
                stalled = averaged_speed < stalled_speed and averaged_angular < rules.STALLED_ANGULAR_SPEED
                # the cheap speed tests first: the pose error is computed only for a slow EE
                converged = (
                    speed < rules.CONVERGED_SPEED
                    and angular < rules.CONVERGED_ANGULAR_SPEED
                    and backend.ee_distance(goal) < rules.CONVERGED_POSITION
                    and backend.ee_rotation_error(goal_rotation) < rules.CONVERGED_ORIENTATION
                )
                if converged or stalled:
                    # a last check, so a contact made after the last periodic check is not missed
                    if guard is not None and tick % rules.CONTACT_CHECK_PERIOD:
                        self._collided(guard, report)
                    return report
            report.failure = "unreachable"  # neither converged nor stalled in 10 s
            return report
        finally:
            if step.soft:
                backend.end_compliance()

    # --- helpers ----------------------------------------------------------------------------------

    @staticmethod
    def _collided(guard: Callable[[], list[Contact]], report: StepReport) -> bool:
        """Record a ``"collision"`` in ``report`` if a watched body touches a forbidden one now."""
        hits = guard()
        if hits:
            report.contacts.extend(hits)
            report.failure = "collision"
        return bool(hits)

    def _straight_keyframes(
        self,
        start_position: np.ndarray,
        start_yaw: float,
        goal: np.ndarray,
        yaw: float,
        q_start: np.ndarray,
        q_goal: np.ndarray,
        ramp_ticks: int,
        null_target: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(K,)`` ticks and ``(K, 7)`` joint keyframes every :data:`IK_KEY_PERIOD` ticks along the
        straight EE path (smoothstep timing), each a :meth:`PhysicsBackend.track_ik` from the previous
        one; the servo targets interpolate between them, which keeps the EE within a fraction of a
        millimetre of the line while running IK on one tick in five."""
        backend = self.backend
        key_ticks = list(range(0, ramp_ticks, IK_KEY_PERIOD)) + [ramp_ticks]
        key_q = [q_start]
        q = q_start
        yaw_change = wrap_angle(yaw - start_yaw)
        for tick in key_ticks[1:-1]:
            blend = smoothstep(tick / ramp_ticks)
            position = start_position + blend * (goal - start_position)
            q = backend.track_ik(q, position, backend.target_rotation(start_yaw + blend * yaw_change), null_target)
            key_q.append(q)
        key_q.append(q_goal)
        return np.array(key_ticks), np.array(key_q)

    def _half_turn_allowed(self) -> bool:
        """A parallel gripper holding nothing, or a square box, looks the same after a half turn."""
        held = self.backend.held
        if held is None:
            return True
        spec = object_spec(held)
        return spec.kind is ObjectKind.BOX and abs(spec.size[0] - spec.size[1]) < 1e-9

    def _tick(self) -> None:
        self.backend.tick()
        if self.on_tick is not None and self.backend.ticks % self.frame_every == 0:
            self.on_tick()
