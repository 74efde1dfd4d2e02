"""Executes the domain's :class:`~t2m_core.domain.primitives.MotionStep` s on a :class:`World`.

Everything geometric (waypoints, which bodies a motion may not touch, success tests) comes from the
domain; this module only turns a step into servo targets, ticks, and the control failures of
tableenv.md §3.2: ``"unreachable"`` (IK outside the joint limits, or a motion that neither converges
nor stalls within 10 s), ``"collision"`` (a finger or the held object touching a forbidden body,
checked every 10 ticks and when the motion ends) and ``"grasp_failed"`` (§3.3).

Timing is counted in 1/60 s ticks, as the reference requires: motion timeout 600 ticks, gripper
timeout 60 ticks, settle up to ``timeout_s``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from t2m_core.domain.objects import ObjectKind, object_spec
from t2m_core.domain.primitives import MotionKind, MotionStep
from t2m_core.protocols import Contact
from t2m_mujoco import grasp
from t2m_mujoco.controller import TICKS_PER_SECOND, SweepImpedance, null_target_facing
from t2m_mujoco.robot_model import FINGER_OPEN
from t2m_mujoco.world import World, robot_geoms

MOTION_TIMEOUT_TICKS = 600
"""10 s (§3.2)."""
GRIPPER_TIMEOUT_TICKS = 60
"""1 s (§3.3)."""
CONTACT_CHECK_PERIOD = 10
"""Ticks between collision checks during a guarded motion (§3.2)."""
CONVERGED_POSITION = 0.01
"""m; with speed < 0.01 m/s, orientation error < 0.01 rad and angular speed < 0.01 rad/s (§3.2)."""
CONVERGED_SPEED = 0.01
CONVERGED_ORIENTATION = 0.01
CONVERGED_ANGULAR_SPEED = 0.01
STALLED_SPEED = 0.001
"""m/s of the exponentially averaged (factor 0.5) EE speed below which a motion has stalled."""
STALLED_ANGULAR_SPEED = 0.02
STALLED_SWEEP_SPEED = CONVERGED_SPEED
"""m/s: the stall threshold of a compliant sweep, the slowest speed a converged motion may have (a
documented deviation from §3.2's 0.001 m/s). A blocked sweep presses with at most
:data:`~t2m_mujoco.controller.SOFT_MAX_FORCE`, less than what slides the 1 kg rack (friction 1.0), so
in PyBullet, whose friction is rigid, it stands still and stalls at once. MuJoCo's friction is soft:
a pressed rack, or a box pressed against it, creeps at 1-10 mm/s for as long as the pressure lasts
(measured), so at 0.001 m/s a blocked sweep ran until the 10 s timeout, shoving the rack along. A
sweep still moving freely is much faster than this until it is within millimetres of its goal,
where convergence ends it."""
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
SOFT_POSTURE_SCALE = 0.002
"""During a sweep the joint servos keep only this fraction of their stiffness (a weak posture
task); the Cartesian impedance does the work."""
SOFT_DAMPING_SCALE = 0.01
"""Fraction of the joint servos' damping kept during a sweep: enough to keep the limp posture task
stable, small next to the operational-space damping (a larger one makes the EE crawl behind its
target and a sweep run for hundreds of ticks)."""


@dataclass
class StepReport:
    """What one step did: a failure reason or ``None``, and the contacts it saw."""

    failure: str | None = None
    contacts: list[Contact] = field(default_factory=list)


class Executor:
    """Runs motion steps on one :class:`World`.

    Args:
        world: the simulated world.
        on_tick: called after every tick (the video recorder), or ``None``.
        frame_every: call ``on_tick`` every this many ticks.
    """

    def __init__(self, world: World, on_tick=None, frame_every: int = 2) -> None:
        self.world = world
        self.on_tick = on_tick
        self.frame_every = max(1, int(frame_every))
        self._finger_geoms = robot_geoms(world)
        self._impedance = SweepImpedance(world.model, world.data, world.robot)
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
        world = self.world
        world.forget_twist()
        limit = max(min_ticks, int(round(timeout_s * TICKS_PER_SECOND)))
        for tick in range(1, limit + 1):
            self._tick()
            if tick >= min_ticks and not world.moving_objects():
                return tick
        return limit

    def grasp(self, name: str) -> str | None:
        """Close on ``name``, validate the pads (§3.3), weld it. ``"grasp_failed"`` or ``None``."""
        world = self.world
        world.set_gripper(0.0)
        world.forget_twist()
        previous = world.finger_q()
        for tick in range(GRIPPER_TIMEOUT_TICKS):
            self._tick()
            finger = world.finger_q()
            settled = abs(finger - previous) < 1e-4 and tick >= 3
            previous = finger
            if settled and name not in world.moving_objects([name]):
                break
        if world.finger_q() < grasp.CLOSED_FINGER:
            return "grasp_failed"  # closed on nothing
        if not grasp.pads_hold(world, name):
            return "grasp_failed"
        world.attach(name)
        # The weld holds the object now; keep the fingers where they are instead of squeezing, so
        # pad forces and the weld do not fight (which makes the object creep).
        world.set_gripper(world.finger_q())
        return None

    def release(self) -> None:
        """Drop the weld and open the gripper (up to 1 s)."""
        world = self.world
        world.release()
        world.set_gripper(FINGER_OPEN)
        for _ in range(GRIPPER_TIMEOUT_TICKS):
            self._tick()
            if world.finger_q() > FINGER_OPEN - 0.002:
                break

    # --- motions ----------------------------------------------------------------------------------

    def _move(self, step: MotionStep, *, straight: bool) -> StepReport:
        world, ik = self.world, self.world.ik
        goal = step.ee_position
        start_position, start_rotation = world.ee_pose()
        start_yaw = _relative_yaw(start_rotation, ik.home_rotation)
        yaw = start_yaw if step.ee_yaw is None else float(step.ee_yaw)
        null_target = null_target_facing(goal)
        q_start = world.arm_q()

        if step.ee_yaw is not None:
            yaw = _wrap(yaw + self.yaw_offset)
        solution = ik.solve(goal, ik.target_rotation(yaw), q_start, null_target)
        if not solution.reachable and step.ee_yaw is not None and self._half_turn_allowed():
            # A parallel-jaw gripper holding nothing, or a square box, is symmetric under a half
            # turn about z: use the twin yaw when the commanded one is beyond joint 7's range, and
            # keep that choice for the rest of the primitive.
            twin = _wrap(yaw + math.pi)
            twin_solution = ik.solve(goal, ik.target_rotation(twin), q_start, null_target)
            if twin_solution.reachable:
                yaw, solution = twin, twin_solution
                self.yaw_offset = _wrap(self.yaw_offset + math.pi)
        if not solution.reachable:
            return StepReport("unreachable")
        goal_rotation = ik.target_rotation(yaw)

        report = StepReport()
        forbidden = [world.scene.owners.index(n) for n in step.contact_objects if n in world.scene.owners]
        if world.held in step.contact_objects:
            forbidden.remove(world.scene.owners.index(world.held))
        held_geoms = world.geoms_of(world.held) if world.held else np.empty(0, dtype=int)
        watched = np.concatenate((self._finger_geoms, held_geoms)).astype(int)

        if straight:
            distance = float(np.linalg.norm(goal - start_position))
            yaw_change = abs(_wrap(yaw - start_yaw))
            speed = SWEEP_SPEED if step.kind is MotionKind.SWEEP else STRAIGHT_SPEED
            duration = max(distance / speed, yaw_change / YAW_SPEED)
        else:
            duration = float(np.max(np.abs(solution.q - q_start))) / MOVE_JOINT_SPEED
        ramp_ticks = max(1, int(math.ceil(duration * TICKS_PER_SECOND)))
        # servo targets (and the sweep's EE targets) of every ramp tick, computed at once
        ramp = np.arange(1, ramp_ticks)
        if straight:
            key_ticks, key_q = self._straight_keyframes(start_position, start_yaw, goal, yaw, q_start, solution.q, ramp_ticks, null_target)
            segment = np.minimum(ramp // IK_KEY_PERIOD, len(key_ticks) - 2)
            fraction = (ramp - key_ticks[segment]) / (key_ticks[segment + 1] - key_ticks[segment])
            targets = key_q[segment] + fraction[:, None] * (key_q[segment + 1] - key_q[segment])
        else:  # smoothstep: no velocity jumps
            targets = q_start + self._ramp(ramp / ramp_ticks)[:, None] * (solution.q - q_start)
        if step.soft:
            sweep_targets = start_position + self._ramp(np.append(ramp / ramp_ticks, 1.0))[:, None] * (goal - start_position)

        gains = self._soften() if step.soft else None
        stalled_speed = STALLED_SWEEP_SPEED if step.soft else STALLED_SPEED
        try:
            averaged_speed, averaged_angular = None, None
            for tick in range(1, MOTION_TIMEOUT_TICKS + 1):
                if tick < ramp_ticks:
                    world.set_arm_target(targets[tick - 1])
                elif tick == ramp_ticks:
                    world.set_arm_target(solution.q)
                if gains is not None:
                    self._impedance.apply(sweep_targets[min(tick, ramp_ticks) - 1], goal_rotation)
                self._tick()

                if forbidden and tick % CONTACT_CHECK_PERIOD == 0 and self._collided(watched, forbidden, report):
                    return report
                if tick < ramp_ticks:
                    continue  # the servo follows the ramp; convergence is judged at its end
                speed, angular = world.ee_velocity()
                if averaged_speed is None:
                    averaged_speed, averaged_angular = speed, angular
                else:
                    averaged_speed = 0.5 * averaged_speed + 0.5 * speed
                    averaged_angular = 0.5 * averaged_angular + 0.5 * angular
                stalled = averaged_speed < stalled_speed and averaged_angular < STALLED_ANGULAR_SPEED
                # the cheap speed tests first: the pose error is computed only for a slow EE
                converged = (
                    speed < CONVERGED_SPEED
                    and angular < CONVERGED_ANGULAR_SPEED
                    and world.ee_distance(goal) < CONVERGED_POSITION
                    and world.ee_rotation_error(goal_rotation) < CONVERGED_ORIENTATION
                )
                if converged or stalled:
                    # a last check, so a contact made after the last periodic check is not missed
                    if forbidden and tick % CONTACT_CHECK_PERIOD:
                        self._collided(watched, forbidden, report)
                    return report
            report.failure = "unreachable"  # neither converged nor stalled in 10 s
            return report
        finally:
            if gains is not None:
                self._restore_gains(gains)
                self._impedance.release()

    # --- helpers ----------------------------------------------------------------------------------

    def _collided(self, watched: np.ndarray, forbidden: list[int], report: StepReport) -> bool:
        """Record a ``"collision"`` in ``report`` if a watched geom touches a forbidden body now."""
        hits = self.world.contacts_between(watched, forbidden)
        if hits:
            report.contacts.extend(_contacts(self.world, hits))
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
        """``(K,)`` ticks and ``(K, 7)`` joint keyframes every :data:`IK_KEY_PERIOD` ticks along the straight EE path (smoothstep
        timing), each two warm-started DLS iterations from the previous one; the servo targets
        interpolate between them, which keeps the EE within a fraction of a millimetre of the line
        while running IK on one tick in five."""
        ik = self.world.ik
        key_ticks = list(range(0, ramp_ticks, IK_KEY_PERIOD)) + [ramp_ticks]
        key_q = [q_start]
        q = q_start
        yaw_change = _wrap(yaw - start_yaw)
        for tick in key_ticks[1:-1]:
            progress = tick / ramp_ticks
            blend = progress * progress * (3.0 - 2.0 * progress)
            position = start_position + blend * (goal - start_position)
            rotation = ik.target_rotation(start_yaw + blend * yaw_change)
            for _ in range(2):
                q = ik.step(q, position, rotation, null_target)
            key_q.append(q)
        key_q.append(q_goal)
        return np.array(key_ticks), np.array(key_q)

    def _half_turn_allowed(self) -> bool:
        held = self.world.held
        if held is None:
            return True
        spec = object_spec(held)
        return spec.kind is ObjectKind.BOX and abs(spec.size[0] - spec.size[1]) < 1e-9

    def _tick(self) -> None:
        self.world.tick()
        if self.on_tick is not None and self.world.ticks % self.frame_every == 0:
            self.on_tick(self.world)

    def _soften(self) -> tuple[np.ndarray, np.ndarray]:
        """Make the joint servos nearly limp for a compliant sweep (see :meth:`_apply_impedance`)."""
        model, actuators = self.world.model, self.world.robot.arm_actuators
        saved = (model.actuator_gainprm[actuators].copy(), model.actuator_biasprm[actuators].copy())
        model.actuator_gainprm[actuators, 0] *= SOFT_POSTURE_SCALE
        model.actuator_biasprm[actuators, 1] *= SOFT_POSTURE_SCALE
        model.actuator_biasprm[actuators, 2] *= SOFT_DAMPING_SCALE
        return saved

    @staticmethod
    def _ramp(progress: float) -> float:
        return progress * progress * (3.0 - 2.0 * progress)

    def _restore_gains(self, saved: tuple[np.ndarray, np.ndarray]) -> None:
        model, actuators = self.world.model, self.world.robot.arm_actuators
        model.actuator_gainprm[actuators] = saved[0]
        model.actuator_biasprm[actuators] = saved[1]


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def _relative_yaw(rotation: np.ndarray, home_rotation: np.ndarray) -> float:
    relative = rotation @ home_rotation.T
    return math.atan2(relative[1, 0], relative[0, 0])


def _contacts(world: World, hits: list[tuple[int, int, float]]) -> list[Contact]:
    contacts = []
    pairs = world.data.contact.geom
    for index, geom, force in hits:
        other = pairs[index][1] if pairs[index][0] == geom else pairs[index][0]
        name_a = world.owner_name(geom)
        if name_a == "robot":
            name_a = world.model.geom(geom).name or world.model.body(world.model.geom_bodyid[geom]).name
        contacts.append(Contact(name_a, world.owner_name(int(other)), force))
    return contacts
