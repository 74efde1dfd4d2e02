"""The polar frame shared by the hook primitives Pull and Push (docs/guide/primitives.md#waypoint-geometry).

Both express their action in a frame at the target: φ = atan2(y_t, x_t) points from the robot base
to the target, the base point is the target's xy at the sweep height 0.03 m. The action places the
*hook*; the EE poses follow from the hook-to-EE grasp transform measured when the primitive starts.
"""

from __future__ import annotations

from abc import abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from t2m_core.domain.geometry import (
    ObjectGeometry,
    object_geometry_memo,
    pad_polygons,
    quat_conjugate,
    quat_multiply,
    quat_yaw,
    rotate,
    yaw_to_quat,
)
from t2m_core.domain.objects import object_spec
from t2m_core.domain.primitives.base import Primitive
from t2m_core.domain.primitives.sweep_screen import (
    CLEARANCE_RANGE,
    SweepPrediction,
    Verdicts,
    bystanders,
    lands_on_target,
    obstacle_heights,
    obstacle_footprints,
    predict_sweeps,
    reach_margin,
    sweep_clearance_and_gap,
    unreachable,
)
from t2m_core.domain.state import GeometricState, ObjectPose

SWEEP_HEIGHT = 0.03
"""z of the hook's origin during a reach and a sweep, metres."""

SCREEN_DRAWS = 64
"""Most heuristic draws :meth:`HookSweep.screened_physical` screens before it turns to uniform ones."""

SCREEN_FALLBACK_DRAWS = 256
"""Most uniform draws it then screens before it gives up and returns the last heuristic draw (both
sets judged as batches, about 7 ms of CPU per call in data-generation scenes; in task3's Pull scenes
a passing uniform draw, where one exists, is found within 256 draws in 9 of 10 scenes)."""

OBSTRUCTED_SHARE = 0.5
"""Share of :meth:`HookSweep.obstructed_physical` draws that sweep into a bystander where one can."""


@dataclass(frozen=True)
class SweepPoses:
    """EE targets of one hook sweep, world frame; of B sweeps with a leading ``B`` axis on every field.

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
    yaw: float | np.ndarray
    hook_reach: np.ndarray
    hook_end: np.ndarray
    hook_yaw: float | np.ndarray


def planar_distance(state: GeometricState, name: str) -> float:
    """Distance of ``name`` from the robot base in the table plane, metres."""
    return float(np.linalg.norm(state.objects[name].position[:2]))


def sweep_poses(
    state: GeometricState,
    target: str,
    hook: str,
    r_reach: float | np.ndarray,
    r_sweep: float | np.ndarray,
    y: float | np.ndarray,
    theta: float | np.ndarray,
) -> SweepPoses:
    """Hook poses ``c + Rz(φ)·(r_reach, y, 0)`` and ``c + Rz(φ)·(r_reach + r_sweep, y, 0)`` with the
    hook yawed ``φ + θ``, converted to EE poses with the current grasp transform (metres, radians).
    Floats give one sweep; ``(B,)`` arrays give B."""
    hook_pose = state.objects[hook]
    poses = batched_sweep_poses(
        state.objects[target].position[:2], hook_pose.position, hook_pose.quaternion, state.ee_position, state.ee_quaternion,
        r_reach, r_sweep, y, theta,
    )
    if np.ndim(poses.hook_yaw) == 0:
        return SweepPoses(poses.reach_position, poses.end_position, float(poses.yaw), poses.hook_reach, poses.hook_end, float(poses.hook_yaw))
    return poses


def batched_sweep_poses(
    target_xy: np.ndarray,
    hook_position: np.ndarray,
    hook_quaternion: np.ndarray,
    ee_position: np.ndarray,
    ee_quaternion: np.ndarray,
    r_reach: float | np.ndarray,
    r_sweep: float | np.ndarray,
    y: float | np.ndarray,
    theta: float | np.ndarray,
) -> SweepPoses:
    """:func:`sweep_poses` from arrays, broadcast over leading axes: ``(..., 2)`` target xy,
    ``(..., 3)`` positions and ``(..., 4)`` xyzw quaternions of the hook and the EE (relative to
    home), ``(...)`` physical action parameters; every field of the result has the leading axes."""
    target_xy = np.asarray(target_xy, dtype=np.float64)
    phi = np.arctan2(target_xy[..., 1], target_xy[..., 0])
    parameters = (np.asarray(value, dtype=np.float64) for value in (r_reach, r_sweep, y, theta))
    r_reach, r_sweep, y, theta = np.broadcast_arrays(*parameters)
    frame = yaw_to_quat(phi)
    base_point = np.concatenate((target_xy, np.full((*target_xy.shape[:-1], 1), SWEEP_HEIGHT)), axis=-1)
    hook_reach = base_point + rotate(frame, np.stack((r_reach, y, np.zeros_like(y)), axis=-1))
    hook_end = base_point + rotate(frame, np.stack((r_reach + r_sweep, y, np.zeros_like(y)), axis=-1))
    hook_quat = quat_multiply(frame, yaw_to_quat(theta))

    # Grasp transform T_hook⁻¹·T_ee. EE orientations are relative to home on both sides of the
    # composition, so the home orientation cancels.
    hook_inverse = quat_conjugate(hook_quaternion)
    ee_in_hook = rotate(hook_inverse, np.asarray(ee_position, dtype=np.float64) - hook_position)
    ee_quat = quat_multiply(hook_quat, quat_multiply(hook_inverse, ee_quaternion))
    offset = rotate(hook_quat, ee_in_hook)
    return SweepPoses(hook_reach + offset, hook_end + offset, quat_yaw(ee_quat), hook_reach, hook_end, phi + theta)


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
        return self.heuristic_draws(arguments, rng, 1)[0]

    def heuristic_draws(self, arguments: Sequence[str], rng: np.random.Generator, count: int) -> np.ndarray:
        """``(count, 4)`` physical :meth:`heuristic_physical` actions drawn at once: the values ``count``
        calls in a row would give."""
        draws = rng.uniform(self.action_low, self.action_high, (count, len(self.action_low)))
        draws[:, 0] = self.heuristic_reach(arguments)
        draws[:, 3] = 0.125 * np.pi
        return draws

    # --- screened heuristic (data generation) -----------------------------------------------------

    def screened_physical(self, state: GeometricState, arguments: Sequence[str], rng: np.random.Generator) -> np.ndarray:
        """The reference heuristic's draws (r_reach and θ fixed, the sweep length and y uniform): the
        first of :data:`SCREEN_DRAWS` that :meth:`screen` predicts no failure for; in a scene where
        none passes (the fixed r_reach and θ cannot work there), the first of
        :data:`SCREEN_FALLBACK_DRAWS` uniform draws over the whole action range that passes; failing
        those, the last heuristic draw. Each set of draws is drawn and screened at once.

        A deviation for data generation only (the reference heuristic stays :meth:`heuristic_physical`):
        it rejects the draws the domain's geometry already dooms."""
        arguments = self.check_arguments(state, arguments)
        heuristic = self.heuristic_draws(arguments, rng, SCREEN_DRAWS)
        passing = self._first_passing(state, arguments, heuristic)
        if passing is None:
            uniform = rng.uniform(self.action_low, self.action_high, (SCREEN_FALLBACK_DRAWS, len(self.action_low)))
            passing = self._first_passing(state, arguments, uniform)
        return heuristic[-1] if passing is None else passing

    def obstructed_physical(self, state: GeometricState, arguments: Sequence[str], rng: np.random.Generator) -> np.ndarray:
        """With probability :data:`OBSTRUCTED_SHARE`, a sweep into a bystander: the first of
        :data:`SCREEN_DRAWS` heuristic draws, then of :data:`SCREEN_FALLBACK_DRAWS` uniform ones, that
        :meth:`in_the_way` predicts to meet one; otherwise, and in a scene where no draw does, the
        :meth:`screened_physical` action.

        The screened sampler avoids such sweeps, so its data hold almost no failure from them, and an
        ensemble trained there values a planner's sweep through a box as highly as one beside it
        (docs/guide/skills.md#obstructed-sweeps). Here the physics labels both."""
        arguments = self.check_arguments(state, arguments)
        if rng.random() < OBSTRUCTED_SHARE:
            for draws in (self.heuristic_draws(arguments, rng, SCREEN_DRAWS),
                          rng.uniform(self.action_low, self.action_high, (SCREEN_FALLBACK_DRAWS, len(self.action_low)))):
                blocked = np.flatnonzero(self.in_the_way(state, arguments, draws))
                if blocked.size:
                    return draws[blocked[0]]
        return self.screened_physical(state, arguments, rng)

    def obstructed_exploration_action(self, state: GeometricState, arguments: Sequence[str], rng: np.random.Generator) -> np.ndarray:
        """:meth:`~t2m_core.domain.primitives.base.Primitive.exploration_action` around
        :meth:`obstructed_physical` (normalised, ``(4,)``)."""
        return self._explore(lambda *args: np.clip(self.to_normalized(self.obstructed_physical(*args)), -1.0, 1.0), state, arguments, rng)

    def _first_passing(self, state: GeometricState, arguments: Sequence[str], draws: np.ndarray) -> np.ndarray | None:
        """The first row of ``(B, 4)`` physical draws that the screen passes, or ``None``."""
        reasons = self.screen_draws(state, arguments, draws)
        return next((draw for draw, reason in zip(draws, reasons, strict=True) if reason is None), None)

    def screen(self, state: GeometricState, arguments: Sequence[str], physical: np.ndarray) -> str | None:
        """The failure reason the domain's geometry predicts for the ``(4,)`` physical action, or
        ``None`` (see :mod:`~t2m_core.domain.primitives.sweep_screen`). A prediction, not a result."""
        return self.screen_draws(state, arguments, np.asarray(physical, dtype=np.float64)[None])[0]

    def screen_draws(self, state: GeometricState, arguments: Sequence[str], physical: np.ndarray) -> list[str | None]:
        """:meth:`screen` of each row of ``(B, 4)`` physical actions, judged together."""
        arguments = self.check_arguments(state, arguments)
        # The precheck reads the state alone, so its verdict holds for every draw.
        reason = self.precheck(state, arguments, self.to_normalized(physical[0]))
        if reason is not None:
            return [reason] * len(physical)
        verdicts = Verdicts(self.predict(state, arguments, physical))
        verdicts.check("unreachable", unreachable)
        verdicts.check("tipped_over", lands_on_target)
        self.screen_sweep(state, arguments, verdicts)
        return verdicts.reasons

    def predict(self, state: GeometricState, arguments: Sequence[str], physical: np.ndarray) -> SweepPrediction:
        """The predicted sweeps of ``(B, 4)`` physical actions (:func:`~t2m_core.domain.primitives.sweep_screen.predict_sweeps`)."""
        physical = np.asarray(physical, dtype=np.float64)
        return self._predict_of_states([state], arguments, physical, np.zeros(len(physical), dtype=np.int64), object_geometry_memo())

    def _predict_of_states(
        self,
        states: Sequence[GeometricState],
        arguments: Sequence[str],
        physical: np.ndarray,
        state_of: np.ndarray,
        geometry: Callable[[str, ObjectPose], ObjectGeometry],
    ) -> SweepPrediction:
        """The sweeps of ``(B, 4)`` physical actions, action b in ``states[state_of[b]]``: the target's
        footprint and position each draw's own, or shared by all draws of a single state (what
        :class:`~t2m_core.domain.primitives.sweep_screen.Verdicts` take)."""
        target, hook = arguments[0], arguments[1]

        def per_draw(values: Sequence[np.ndarray]) -> np.ndarray:
            return np.asarray(values[0]) if len(states) == 1 else np.asarray(values)[state_of]

        footprints = per_draw(pad_polygons([geometry(target, state.objects[target]).footprints[0] for state in states]))
        poses = [(state.objects[target].position[:2], state.objects[hook].position, state.objects[hook].quaternion,
                  state.ee_position, state.ee_quaternion) for state in states]
        target_xy, hook_position, hook_quaternion, ee_position, ee_quaternion = (per_draw(column) for column in zip(*poses, strict=True))
        sweeps = batched_sweep_poses(target_xy, hook_position, hook_quaternion, ee_position, ee_quaternion, *np.asarray(physical, dtype=np.float64).T)
        return predict_sweeps(
            footprints, target_xy, object_spec(hook), sweeps.hook_reach, sweeps.hook_end, sweeps.hook_yaw,
            np.stack((sweeps.reach_position[:, :2], sweeps.end_position[:, :2]), axis=1),
            along_head_normal=self.deflects_target, into_crook=not self.deflects_target,
        )

    def in_the_way(self, state: GeometricState, arguments: Sequence[str], physical: np.ndarray) -> np.ndarray:
        """``(B,)`` whether each of ``(B, 4)`` physical actions is predicted to sweep the hook, the box
        or the hand into a bystander (an object other than the arguments and the table:
        :func:`~t2m_core.domain.primitives.sweep_screen.sweep_disturbs`), whatever else the screen
        would say of it. A prediction from the domain's geometry, not a result."""
        physical = np.asarray(physical, dtype=np.float64)
        return self.screen_of_states([state], arguments, physical, np.zeros(len(physical), dtype=np.int64))["in_the_way"]

    def screen_of_states(
        self, states: Sequence[GeometricState], arguments: Sequence[str], physical: np.ndarray, state_of: np.ndarray
    ) -> dict[str, np.ndarray]:
        """The predictions (:attr:`screen_predictions`) for ``(B, 4)`` physical actions, action b
        taken in ``states[state_of[b]]``, judged as one batch (a planner's samples, each in its own
        predicted state), each ``(B,)``: ``"in_the_way"`` (:meth:`in_the_way`), ``"unreachable"``
        (the EE leaves the arm's reach: :func:`~t2m_core.domain.primitives.sweep_screen.unreachable`),
        and the margins behind them in metres, ``"clearance"``
        (:func:`~t2m_core.domain.primitives.sweep_screen.sweep_clearance` from the bystanders, up to
        :data:`~t2m_core.domain.primitives.sweep_screen.CLEARANCE_RANGE`; negative where in the way),
        ``"sweep_gap"`` (the signed gap of the swept hook and box from the bystander parts whose
        bottom lies below the top of the target or of the hook at the sweep height, within ±that
        range: :func:`~t2m_core.domain.primitives.sweep_screen.sweep_clearance_and_gap`; negative,
        how deep they reach into one, where ``"clearance"`` reads the same for any overlap, even
        with a box standing on the rack above the sweep)
        and ``"reach_margin"`` (:func:`~t2m_core.domain.primitives.sweep_screen.reach_margin`). The
        states hold the same objects; an object's geometry is computed once per distinct pose."""
        arguments = self.check_arguments(states[0], arguments)
        state_of = np.asarray(state_of, dtype=np.int64)
        geometry = object_geometry_memo()
        prediction = self._predict_of_states(states, arguments, physical, state_of, geometry)
        others = [bystanders(state, arguments, geometry) for state in states]
        obstacles = [obstacle_footprints(shapes) for shapes in others]  # (N, K_s, 2) each
        if obstacles[0].shape[0] == 0:
            clearance = sweep_gap = np.full(len(state_of), CLEARANCE_RANGE)
        else:
            obstacles = pad_polygons(obstacles)[state_of]  # (B, N, K, 2)
            # the sweep's layer: up to the top of the target or of the hook at the sweep height
            hook_top = SWEEP_HEIGHT + 0.5 * object_spec(arguments[1]).size[2]
            tops = np.array([max(hook_top, geometry(arguments[0], state.objects[arguments[0]]).aabb[1][2]) for state in states])
            in_layer = np.array([obstacle_heights(shapes)[:, 0] for shapes in others]) < tops[:, None]  # (S, N)
            clearance, sweep_gap = sweep_clearance_and_gap(prediction, obstacles, in_layer[state_of], CLEARANCE_RANGE)
        predictions = {
            "in_the_way": clearance < 0.0, "unreachable": unreachable(prediction), "clearance": clearance, "sweep_gap": sweep_gap,
            "reach_margin": reach_margin(prediction),
        }
        return predictions | self.sweep_margins(states, arguments, prediction, state_of, geometry)

    screen_predictions: tuple[str, ...] = ("in_the_way", "unreachable", "clearance", "sweep_gap", "reach_margin")
    """The predictions :meth:`screen_of_states` makes."""

    def sweep_margins(
        self, states: Sequence[GeometricState], arguments: Sequence[str], prediction: SweepPrediction, state_of: np.ndarray,
        geometry: Callable[[str, ObjectPose], ObjectGeometry],
    ) -> dict[str, np.ndarray]:
        """The primitive's own margins of the predicted sweeps (:meth:`screen_of_states`), ``(B,)``
        metres each, by name; none by default."""
        return {}

    deflects_target: bool = False
    """Whether the swept box slides along the head's normal (Push) rather than following the sweep,
    held in the hook's crook (Pull)."""

    @abstractmethod
    def screen_sweep(self, state: GeometricState, arguments: Sequence[str], verdicts: Verdicts) -> None:
        """Add the primitive's own checks of the sweep to ``verdicts``, in order: bystanders in the
        way, the predicted end of the target outside the region its success test needs."""


def hook_clearance(target: str, hook: str) -> tuple[float, float]:
    """``(½·hook_size_x, 2r + ½‖target_size_xy‖)`` in metres, the two terms of the heuristic reach."""
    hook_spec, target_spec = object_spec(hook), object_spec(target)
    radius = hook_spec.hook.radius if hook_spec.hook is not None else 0.0
    return 0.5 * hook_spec.size[0], 2.0 * radius + 0.5 * float(np.linalg.norm(target_spec.size[:2]))

