"""The polar frame shared by the hook primitives Pull and Push (docs/guide/primitives.md#waypoint-geometry).

Both express their action in a frame at the target: φ = atan2(y_t, x_t) points from the robot base
to the target, the base point is the target's xy at the sweep height 0.03 m. The action places the
*hook*; the EE poses follow from the hook-to-EE grasp transform measured when the primitive starts.
"""

from __future__ import annotations

from abc import abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from t2m_core.domain.geometry import quat_conjugate, quat_multiply, quat_yaw, rotate, yaw_to_quat
from t2m_core.domain.objects import object_spec
from t2m_core.domain.primitives.base import Primitive
from t2m_core.domain.primitives.sweep_screen import SweepPrediction, landing_failure, predict_sweep, reach_failure
from t2m_core.domain.state import GeometricState

SWEEP_HEIGHT = 0.03
"""z of the hook's origin during a reach and a sweep, metres."""

SCREEN_DRAWS = 64
"""Most heuristic draws :meth:`HookSweep.screened_physical` screens before it turns to uniform ones."""

SCREEN_FALLBACK_DRAWS = 256
"""Most uniform draws it then screens before it gives up and returns the last heuristic draw (about
0.3 s of CPU at most; in task3's Pull scenes a passing uniform draw, where one exists, is found
within 256 draws in 9 of 10 scenes)."""


@dataclass(frozen=True)
class SweepPoses:
    """EE targets of one hook sweep, world frame.

    Attributes:
        reach_position: ``(3,)`` EE position that puts the hook at the reach pose, metres.
        end_position: ``(3,)`` EE position that puts the hook at the end of the sweep, metres.
        yaw: EE yaw relative to home for both, radians.
        hook_reach: ``(3,)`` the hook's origin at the reach pose, metres.
        hook_end: ``(3,)`` the hook's origin at the sweep end, metres.
        hook_yaw: the hook's world yaw φ + θ for both, radians.
    """

    reach_position: np.ndarray
    end_position: np.ndarray
    yaw: float
    hook_reach: np.ndarray
    hook_end: np.ndarray
    hook_yaw: float


def planar_distance(state: GeometricState, name: str) -> float:
    """Distance of ``name`` from the robot base in the table plane, metres."""
    return float(np.linalg.norm(state.objects[name].position[:2]))


def sweep_poses(
    state: GeometricState, target: str, hook: str, r_reach: float, r_sweep: float, y: float, theta: float
) -> SweepPoses:
    """Hook poses ``c + Rz(φ)·(r_reach, y, 0)`` and ``c + Rz(φ)·(r_reach + r_sweep, y, 0)`` with the
    hook yawed ``φ + θ``, converted to EE poses with the current grasp transform (metres, radians)."""
    target_xy = state.objects[target].position[:2]
    phi = float(np.arctan2(target_xy[1], target_xy[0]))
    frame = yaw_to_quat(phi)
    base_point = np.array([target_xy[0], target_xy[1], SWEEP_HEIGHT])
    hook_reach = base_point + rotate(frame, np.array([r_reach, y, 0.0]))
    hook_end = base_point + rotate(frame, np.array([r_reach + r_sweep, y, 0.0]))
    hook_quat = quat_multiply(frame, yaw_to_quat(theta))

    # Grasp transform T_hook⁻¹·T_ee. EE orientations are relative to home on both sides of the
    # composition, so the home orientation cancels.
    hook_pose = state.objects[hook]
    hook_inverse = quat_conjugate(hook_pose.quaternion)
    ee_in_hook = rotate(hook_inverse, state.ee_position - hook_pose.position)
    ee_quat = quat_multiply(hook_quat, quat_multiply(hook_inverse, state.ee_quaternion))
    offset = rotate(hook_quat, ee_in_hook)
    return SweepPoses(
        hook_reach + offset, hook_end + offset, float(quat_yaw(ee_quat)), hook_reach, hook_end, phi + float(theta)
    )


class HookSweep(Primitive):
    """Common parts of Pull and Push: the hook must be held and the target in front of the base."""

    def sweep(self, state: GeometricState, arguments: Sequence[str], action: np.ndarray) -> SweepPoses:
        """The EE poses of the reach and the sweep end for the normalised ``action``."""
        r_reach, r_sweep, y, theta = self.to_physical(action)
        return sweep_poses(state, arguments[0], arguments[1], r_reach, r_sweep, y, theta)

    def precheck(self, state: GeometricState, arguments: Sequence[str], action: np.ndarray) -> str | None:
        arguments = self.check_arguments(state, arguments)
        if state.held != arguments[1]:
            return "not_held"
        # The polar frame points from the base to the target; behind the base it is meaningless.
        return "target_behind_robot" if state.objects[arguments[0]].position[0] < 0.0 else None

    @abstractmethod
    def heuristic_reach(self, arguments: Sequence[str]) -> float:
        """Heuristic r_reach in metres; Pull and Push place the hook differently."""

    def heuristic_physical(self, state: GeometricState, arguments: Sequence[str], rng: np.random.Generator) -> np.ndarray:
        """Uniform, except r_reach from :meth:`heuristic_reach` and θ = π/8."""
        action = rng.uniform(self.action_low, self.action_high)
        action[0] = self.heuristic_reach(arguments)
        action[3] = 0.125 * np.pi
        return action

    # --- screened heuristic (data generation) -----------------------------------------------------

    def screened_physical(self, state: GeometricState, arguments: Sequence[str], rng: np.random.Generator) -> np.ndarray:
        """The reference heuristic's draws (r_reach and θ fixed, the sweep length and y uniform),
        redrawn until :meth:`screen` predicts no failure, at most :data:`SCREEN_DRAWS` times; in a
        scene where none passes (the fixed r_reach and θ cannot work there), up to
        :data:`SCREEN_FALLBACK_DRAWS` uniform draws over the whole action range, screened alike;
        failing those, the last heuristic draw.

        A deviation for data generation only (the reference heuristic stays :meth:`heuristic_physical`):
        it rejects the draws the domain's geometry already dooms."""
        arguments = self.check_arguments(state, arguments)
        fallback = None
        for _ in range(SCREEN_DRAWS):
            physical = self.heuristic_physical(state, arguments, rng)
            if self.screen(state, arguments, physical) is None:
                return physical
            fallback = physical
        for _ in range(SCREEN_FALLBACK_DRAWS):
            physical = rng.uniform(self.action_low, self.action_high)
            if self.screen(state, arguments, physical) is None:
                return physical
        return fallback

    def screen(self, state: GeometricState, arguments: Sequence[str], physical: np.ndarray) -> str | None:
        """The failure reason the domain's geometry predicts for the physical action, or ``None``
        (see :mod:`~t2m_core.domain.primitives.sweep_screen`). A prediction, not a result."""
        reason = self.precheck(state, arguments, self.to_normalized(physical))
        if reason is not None:
            return reason
        target, hook = arguments[0], arguments[1]
        poses = sweep_poses(state, target, hook, *physical)
        prediction = predict_sweep(
            state,
            target,
            hook,
            poses.hook_reach,
            poses.hook_end,
            poses.hook_yaw,
            np.stack((poses.reach_position[:2], poses.end_position[:2])),
            along_head_normal=self.deflects_target,
            into_crook=not self.deflects_target,
        )
        return reach_failure(prediction) or landing_failure(prediction) or self.screen_sweep(state, arguments, prediction)

    deflects_target: bool = False
    """Whether the swept box slides along the head's normal (Push) rather than following the sweep,
    held in the hook's crook (Pull)."""

    @abstractmethod
    def screen_sweep(self, state: GeometricState, arguments: Sequence[str], prediction: SweepPrediction) -> str | None:
        """The primitive's own predicted failure of the sweep: bystanders in the way, the predicted
        end of the target outside the region its success test needs."""


def hook_clearance(target: str, hook: str) -> tuple[float, float]:
    """``(½·hook_size_x, 2r + ½‖target_size_xy‖)`` in metres, the two terms of the heuristic reach."""
    hook_spec, target_spec = object_spec(hook), object_spec(target)
    radius = hook_spec.hook.radius if hook_spec.hook is not None else 0.0
    return 0.5 * hook_spec.size[0], 2.0 * radius + 0.5 * float(np.linalg.norm(target_spec.size[:2]))
