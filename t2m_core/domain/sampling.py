"""Initial-state sampling: a geometric instance of a task's symbolic initial state (docs/guide/primitives.md#initial-state-sampling).

Given the task's objects and initial-state propositions and a seed, :func:`sample_initial_state`
tries the seed, seed + 1, ... until one candidate passes. For each candidate seed a NumPy generator
seeded with it drives every random draw, so the result is a pure function of (objects,
propositions, seed):

1. process the propositions in canonical order, calling each predicate's sampler: markers
   (``handlegrasp``, ``aligned``, ``tippable``, zones, ``under``, ``infront``) shape the later
   ``on`` samples, ``poslimit`` fixes the rack's position box, ``on`` places an object on its
   support, ``inhand`` puts an object in the gripper at the home pose;
2. draw a random robot pose (the backend moves the arm there);
3. verify every proposition's ``value()`` (including ``free`` and ``nonblocking``) on the resting
   state; accept or move on to the next seed.

Physics is the backend's job: it loads :attr:`SampledScene.drop_state` (objects 5 cm above their
supports, as the reference drops them), moves the robot to :attr:`SampledScene.robot_pose`, settles,
and re-checks the propositions. :attr:`SampledScene.state` is the analytic
prediction of the settled scene (every object resting on its support), on which this module
verifies the propositions.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

import numpy as np

from t2m_core.domain.constants import (
    ALIGNED_YAW_MAX_DEVIATION,
    ALIGNED_YAW_MIN_ABS,
    ALIGNED_YAW_STD,
    DEFAULT_ZONE,
    EPS_TIPPING,
    MAX_LIFT_HEIGHT,
    RACK_ALIGNED_YAW,
    RACK_POSLIMIT_CENTERS,
    RACK_POSLIMIT_HALF_WIDTH,
    TABLE_X_MIN,
    TABLE_Y_MAX,
    TABLE_Y_MIN,
    WORKSPACE_RADIUS,
    WORKSPACE_X_MIN,
    ZONES,
    Zone,
)
from t2m_core.domain.geometry import (
    ObjectGeometry,
    axis_angle_to_quat,
    closest_distance,
    object_geometry,
    quat_multiply,
    quat_yaw,
    rotate,
    wrap_angle,
    yaw_to_quat,
)
from t2m_core.domain.objects import ObjectKind, object_spec
from t2m_core.domain.predicates import Scene, evaluate
from t2m_core.domain.primitives.pick import Pick
from t2m_core.domain.propositions import ZONE_PREDICATES, Proposition, canonical_order, validate_proposition
from t2m_core.domain.state import GeometricState, ObjectPose
from t2m_core.errors import T2MError

DROP_HEIGHT = 0.05
"""Objects are dropped from this far above their support, metres."""
ON_ATTEMPTS = 10
"""Draws of the ``on`` sampler before it fails and the candidate seed is rejected."""
MAX_SEED_ATTEMPTS = 1000
"""Candidate seeds tried in each of a seed's two windows (:func:`candidate_windows`)."""
OVERFLOW_SEED_BASE = 10**9
"""Where the second windows of candidates begin: seed s continues at 10⁹ + 1000·s."""
TIPPED_DROP_SCALE = 0.8
"""A tipped object is dropped from parent_top + 0.8·max(size_x, size_y) (``tippable``)."""
FREE_DISTANCE_HORIZON = 0.15
"""Distances beyond this (metres) need not be exact while sampling: ``free`` thresholds are ≤ 0.10 m."""
HOME_EE_POSITION = np.array([0.402, 0.0, MAX_LIFT_HEIGHT])
"""``(3,)`` the home EE pose (docs/guide/world.md#the-robot), where ``inhand`` puts the grasp, metres."""

# Box grasps of the inhand sampler (our concrete reading of the original's words): the grasp
# point is within ±0.01 m of the box axis in x and y, at least 0.02 m above the bottom and at least
# 0.04 m below the top (bounded with the z-extent: docs/guide/deviations.md#grasp-height-of-a-box-in-hand).
BOX_GRASP_LATERAL = 0.01
BOX_GRASP_MIN_ABOVE_BOTTOM = 0.02
BOX_GRASP_MIN_BELOW_TOP = 0.04
# Hook grasps: lateral tolerance, and the 0.011 m finger clearance that keeps a grasp off the other
# link (the upperhandlegrasp bound x ≤ head_x − r − 0.011, applied to both links).
HOOK_GRASP_LATERAL = 0.01
HOOK_GRASP_CLEARANCE = 0.011
GRASP_YAW_STD = 0.05
"""Std of the noise added to a sampled grasp yaw, radians (then clipped to the Pick θ range)."""


class SamplingError(T2MError):
    """No candidate seed produced a valid initial state."""


@dataclass(frozen=True)
class RobotPose:
    """A top-down EE target: ``position`` ``(3,)`` metres, ``yaw`` radians relative to home."""

    position: np.ndarray
    yaw: float


@dataclass(frozen=True)
class SampledScene:
    """An accepted initial state.

    Attributes:
        state: the resting geometric state on which every proposition was verified (EE at home;
            ``held`` set by ``inhand``).
        drop_state: the same scene as a backend loads it before settling: every ``on`` sample
            5 cm above its support (tipped ones higher), held objects in the gripper.
        robot_pose: the random EE pose the robot moves to before the scene settles.
        accepted_seed: the seed whose candidate was accepted (record it for reproducibility).
        rejections: how many candidate seeds were rejected before it.
        tipped: objects the ``tippable`` sampler tipped over (their resting pose is approximate).
    """

    state: GeometricState
    drop_state: GeometricState
    robot_pose: RobotPose
    accepted_seed: int
    rejections: int
    tipped: frozenset[str] = field(default_factory=frozenset)


class _Rejected(Exception):
    """A sampler failed for this candidate seed: try the next one."""


# --------------------------------------------------------------------------------------------------
# Public entry points
# --------------------------------------------------------------------------------------------------


def candidate_windows(seed: int, max_attempts: int = MAX_SEED_ATTEMPTS) -> tuple[range, range]:
    """The candidate seeds of ``seed``, in the order they are tried: ``seed, seed + 1, ...`` and, if
    all of those are rejected, ``10⁹ + 1000·seed, ...`` (``max_attempts`` of each).

    Where a task's scenes are rare (task6 accepts about one candidate in 220), a first window of
    1000 is exhausted about once in a hundred seeds. The second windows of seeds below 10⁶ lie
    beyond every first window, and those of distinct seeds do not meet (for ``max_attempts`` up to
    1000), so seeds spaced 1000 apart (an evaluation's) never share a candidate.
    """
    overflow = OVERFLOW_SEED_BASE + MAX_SEED_ATTEMPTS * seed
    return range(seed, seed + max_attempts), range(overflow, overflow + max_attempts)


def sample_task(task: Any, seed: int, *, max_attempts: int = MAX_SEED_ATTEMPTS) -> SampledScene:
    """:func:`sample_initial_state` for a task (anything with ``objects`` and ``initial_state``)."""
    return sample_initial_state(task.objects, task.initial_state, seed, max_attempts=max_attempts)


def sample_initial_state(
    objects: Sequence[str],
    propositions: Iterable[Proposition | str],
    seed: int,
    *,
    max_attempts: int = MAX_SEED_ATTEMPTS,
) -> SampledScene:
    """Sample a geometric state in which every proposition holds.

    Args:
        objects: object names in observation order (``table`` first for every task).
        propositions: the initial-state propositions, any order (they are processed canonically).
        seed: the first candidate seed; ``seed + 1``, ``seed + 2``... follow on rejection, then a
            second window (:func:`candidate_windows`).
        max_attempts: candidate seeds to try in each window.

    Raises:
        PropositionError: a proposition names an unknown predicate or object.
        SamplingError: no candidate of either window was accepted.
    """
    names = tuple(objects)
    for name in names:
        object_spec(name)  # unknown objects fail here, naming the known ones
    props = canonical_order(propositions)
    for prop in props:
        validate_proposition(prop, names)
    if max_attempts < 1:
        raise ValueError(f"max_attempts must be at least 1, got {max_attempts}")
    windows = candidate_windows(seed, max_attempts)
    for attempt, candidate in enumerate(itertools.chain(*windows)):
        scene = _sample_candidate(names, props, candidate)
        if scene is not None:
            return SampledScene(scene.state, scene.drop_state, scene.robot_pose, candidate, attempt, scene.tipped)
    tried = " or ".join(f"{window.start}..{window.stop - 1}" for window in windows)
    raise SamplingError(
        f"no valid initial state in seeds {tried} for {', '.join(map(str, props))}",
        "check that the propositions are satisfiable together (zones, free, infront, nonblocking), "
        "or allow more attempts",
    )


@lru_cache(maxsize=4096)
def _sample_candidate(names: tuple[str, ...], props: tuple[Proposition, ...], candidate: int) -> _Result | None:
    """One candidate seed's scene, or ``None`` if it is rejected. Memoised: neighbouring base seeds
    walk through the same candidates (seed 3 retries 4, 5...), and every planner of an evaluation
    resets the same seeds; a candidate's outcome depends only on these arguments."""
    try:
        return _SceneSampler(names, props, np.random.default_rng(candidate)).run()
    except _Rejected:
        return None


def clear_cache() -> None:
    """Forget memoised candidates (for timing the sampler)."""
    _sample_candidate.cache_clear()


def random_robot_pose(rng: np.random.Generator) -> RobotPose:
    """The random EE pose a reset moves the robot to: xy uniform in [0.28, 0.70] × [−0.45, 0.45] with
    ‖xy‖ < 0.70 (redrawn until it holds), z = 0.40, yaw uniform in [−π, π)."""
    while True:
        xy = rng.uniform((TABLE_X_MIN, TABLE_Y_MIN), (WORKSPACE_RADIUS, TABLE_Y_MAX))
        if np.linalg.norm(xy) < WORKSPACE_RADIUS:
            break
    return RobotPose(np.array([xy[0], xy[1], MAX_LIFT_HEIGHT]), float(rng.uniform(-np.pi, np.pi)))


# --------------------------------------------------------------------------------------------------
# One candidate seed
# --------------------------------------------------------------------------------------------------


@dataclass
class _Placement:
    """Where an object is: resting pose (verified) and drop pose (loaded by the backend), with the
    resting geometry computed once (the hot path of the rejection loops)."""

    rest: ObjectPose
    drop: ObjectPose
    rest_geometry: ObjectGeometry
    drop_top: float
    """max z of the dropped object's AABB, metres."""

    @classmethod
    def of(cls, name: str, rest: ObjectPose, drop: ObjectPose) -> _Placement:
        """Both poses share their orientation, so the drop top is the rest top shifted in z. The
        arrays are made read-only: accepted scenes are memoised and shared between callers."""
        for pose in (rest, drop):
            pose.position.flags.writeable = False
            pose.quaternion.flags.writeable = False
        geometry = object_geometry(name, rest)
        return cls(rest, drop, geometry, geometry.max_z + float(drop.position[2] - rest.position[2]))


class _PlacedScene(Scene):
    """A :class:`Scene` of the objects placed so far that reuses their cached resting geometry."""

    def __init__(self, placed: dict[str, _Placement], state: GeometricState, context: Iterable[Proposition]) -> None:
        super().__init__(state, context)
        self._placed = placed

    def geometry(self, name: str) -> ObjectGeometry:
        placement = self._placed.get(name)
        return placement.rest_geometry if placement is not None else super().geometry(name)

    def distance(self, a: str, b: str) -> float:
        """Exact up to :data:`FREE_DISTANCE_HORIZON`; beyond it the (cheaper) AABB gap, a lower bound.
        Only ``free`` asks for distances, and it compares them with thresholds ≤ 0.10 m."""
        gap = _aabb_gap(self.geometry(a).aabb, self.geometry(b).aabb)
        return gap if gap > FREE_DISTANCE_HORIZON else super().distance(a, b)


def _aabb_gap(box_a: np.ndarray, box_b: np.ndarray) -> float:
    """Euclidean gap between two ``(2, 3)`` AABBs, metres (0 when they overlap): a lower bound of the
    distance between anything inside them."""
    separation = np.maximum(0.0, np.maximum(box_a[0] - box_b[1], box_b[0] - box_a[1]))
    return float(np.linalg.norm(separation))


@dataclass
class _Result:
    state: GeometricState
    drop_state: GeometricState
    robot_pose: RobotPose
    tipped: frozenset[str]


class _SceneSampler:
    """Samples one candidate: raises :class:`_Rejected` when a sampler or the final check fails."""

    SAMPLERS = {"poslimit": "_sample_poslimit", "on": "_sample_on", "inhand": "_sample_inhand"}
    """Predicates that place objects, and their sampler methods."""

    def __init__(self, names: tuple[str, ...], props: tuple[Proposition, ...], rng: np.random.Generator) -> None:
        self.names = names
        self.props = props
        self.rng = rng
        self.context = frozenset(str(p) for p in props)
        self.placed: dict[str, _Placement] = {}
        self.zone: dict[str, Zone] = {}  # first zone predicate about each object
        self.poslimit_center: dict[str, tuple[float, float]] = {}
        self.held: str | None = None
        self.tipped: set[str] = set()
        for name in names:
            if object_spec(name).kind is ObjectKind.TABLE:
                identity = ObjectPose(np.zeros(3))
                self.placed[name] = _Placement.of(name, identity, identity)

    def has(self, text: str) -> bool:
        return text in self.context

    # --- the loop --------------------------------------------------------------------------------

    def run(self) -> _Result:
        for prop in self.props:
            if prop.predicate in ZONE_PREDICATES:
                self.zone.setdefault(prop.args[0], ZONES[prop.predicate])  # the first zone named wins
            elif prop.predicate in self.SAMPLERS:
                getattr(self, self.SAMPLERS[prop.predicate])(*prop.args)
            # the rest are markers read by the samplers (aligned, tippable, grasp markers, under,
            # infront) or checks of the final verification (free, nonblocking)
        robot_pose = random_robot_pose(self.rng)
        state = self.state(rest=True)
        scene = _PlacedScene(self.placed, state, self.props)
        if not all(evaluate(p, scene) for p in self.props):
            raise _Rejected
        return _Result(state, self.state(rest=False), robot_pose, frozenset(self.tipped))

    def state(self, *, rest: bool) -> GeometricState:
        """The scene so far, in object order; unplaced objects are left out (not yet physical)."""
        objects = {
            name: (self.placed[name].rest if rest else self.placed[name].drop) for name in self.names if name in self.placed
        }
        return GeometricState(objects, held=self.held)

    # --- poslimit and inhand ----------------------------------------------------------------------

    def _sample_poslimit(self, obj: str) -> None:
        """Fix the rack's xy box: ±0.01 around its zone's anchor, a random zone if none is given."""
        if object_spec(obj).kind is not ObjectKind.RACK:
            return
        zones = [z for z in RACK_POSLIMIT_CENTERS if self.has(f"{z}({obj})")]
        zone = zones[0] if zones else str(self.rng.choice(sorted(RACK_POSLIMIT_CENTERS)))
        self.poslimit_center[obj] = RACK_POSLIMIT_CENTERS[zone]
        self.zone.setdefault(obj, ZONES[zone])

    def _sample_inhand(self, obj: str) -> None:
        """Put ``obj`` in the gripper at the home EE pose with a sampled grasp."""
        spec = object_spec(obj)
        if not spec.movable:
            return
        if self.held is not None:
            raise _Rejected  # one gripper
        grasp_position, grasp_yaw = self._grasp_in_object_frame(obj)
        # T_obj = T_ee · T_grasp⁻¹ with the EE top-down at home yaw (relative orientation identity).
        quaternion = yaw_to_quat(-grasp_yaw)
        position = HOME_EE_POSITION - rotate(quaternion, grasp_position)
        pose = ObjectPose(position, quaternion)
        self.placed[obj] = _Placement.of(obj, pose, pose)
        self.held = obj

    def _grasp_in_object_frame(self, obj: str) -> tuple[np.ndarray, float]:
        """``((3,) grasp point in the object frame, gripper yaw relative to the object)``."""
        spec = object_spec(obj)
        rng = self.rng
        if spec.kind is ObjectKind.HOOK and spec.hook is not None:
            hook = spec.hook
            handle, head = hook.footprint()
            handle_x_min = handle.center[0] - 0.5 * handle.size[0]
            near_head_x = head.center[0] - hook.radius - HOOK_GRASP_CLEARANCE
            if self.has(f"handlegrasp({obj})"):
                link, x_range = "handle", (handle_x_min, 0.0)
            elif self.has(f"upperhandlegrasp({obj})"):
                link, x_range = "handle", (0.0, near_head_x)
            elif rng.random() < hook.handle_length / (hook.handle_length + hook.head_length):
                link, x_range = "handle", (handle_x_min, near_head_x)
            else:
                link, x_range = "head", (0.0, 0.0)
            if link == "handle":
                position = np.array(
                    [rng.uniform(*x_range), handle.center[1] + rng.uniform(-HOOK_GRASP_LATERAL, HOOK_GRASP_LATERAL), 0.0]
                )
                yaw = 0.0
            else:
                y_min = handle.center[1] + hook.radius + HOOK_GRASP_CLEARANCE
                y_max = head.center[1] + 0.5 * head.size[1]
                x = head.center[0] + rng.uniform(-HOOK_GRASP_LATERAL, HOOK_GRASP_LATERAL)
                position = np.array([x, rng.uniform(y_min, y_max), 0.0])
                yaw = 0.5 * np.pi
        else:
            half_z = 0.5 * spec.size[2]
            z_min = -half_z + BOX_GRASP_MIN_ABOVE_BOTTOM
            z_max = max(z_min, half_z - BOX_GRASP_MIN_BELOW_TOP)
            lateral = rng.uniform(-BOX_GRASP_LATERAL, BOX_GRASP_LATERAL, size=2)
            position = np.array([lateral[0], lateral[1], rng.uniform(z_min, z_max)])
            yaw = float(rng.choice([0.0, 0.5 * np.pi]))
        theta_low, theta_high = Pick.action_low[3], Pick.action_high[3]
        return position, float(np.clip(yaw + rng.normal(0.0, GRASP_YAW_STD), theta_low, theta_high))

    # --- on -----------------------------------------------------------------------------------------

    def _sample_on(self, child: str, parent: str) -> None:
        spec = object_spec(child)
        if spec.kind is ObjectKind.TABLE:
            return
        if parent not in self.placed:
            raise _Rejected  # the support is not in the scene yet (e.g. it is held)
        for _ in range(ON_ATTEMPTS):
            quaternion = yaw_to_quat(self._yaw(child))
            region = self._region(child, parent, quaternion)
            if region is None:
                continue
            low, high, frame = region
            local_xy = self.rng.uniform(low, high)
            xy = local_xy if frame is None else frame.position[:2] + rotate(frame.quaternion, [*local_xy, 0.0])[:2]
            tipped_quaternion = self._maybe_tip(child, quaternion)
            orientation = quaternion if tipped_quaternion is None else tipped_quaternion
            self.placed[child] = self._rest_and_drop(child, parent, xy, orientation, tipped=tipped_quaternion is not None)
            if self._accepts(child) and not self._interpenetrates(child, parent):
                if tipped_quaternion is not None:
                    self.tipped.add(child)
                return
            del self.placed[child]
        raise _Rejected

    def _yaw(self, obj: str) -> float:
        """``aligned``: N(0, 0.05) redrawn until |·| ≥ 0.002, plus the zone mean, clipped to mean ± 0.1;
        otherwise uniform in [−π, π)."""
        if not self.has(f"aligned({obj})"):
            return float(self.rng.uniform(-np.pi, np.pi))
        mean = 0.0
        if object_spec(obj).kind is ObjectKind.RACK and obj in self.zone:
            mean = RACK_ALIGNED_YAW.get(self.zone[obj].name, 0.0)
        while True:
            noise = float(self.rng.normal(0.0, ALIGNED_YAW_STD))
            if abs(noise) >= ALIGNED_YAW_MIN_ABS:
                break
        yaw = float(np.clip(mean + noise, mean - ALIGNED_YAW_MAX_DEVIATION, mean + ALIGNED_YAW_MAX_DEVIATION))
        return float(wrap_angle(yaw))

    def _region(
        self, child: str, parent: str, quaternion: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, ObjectPose | None] | None:
        """``(low (2,), high (2,), frame)``: the xy box to draw from, in ``frame`` (world when ``None``),
        or ``None`` when it is empty at this orientation."""
        parent_kind = object_spec(parent).kind
        racks_over = [
            p.args[1] for p in self.props if p.predicate == "under" and p.args[0] == child and p.args[1] in self.placed
        ]
        if parent_kind is ObjectKind.TABLE and racks_over:
            return self._footprint_region(child, racks_over[0], quaternion)
        if parent_kind is ObjectKind.TABLE:
            return self._table_region(child, quaternion)
        return self._stable_region(child, parent, quaternion)

    def _table_region(self, child: str, quaternion: np.ndarray) -> tuple[np.ndarray, np.ndarray, None] | None:
        if child in self.poslimit_center:
            center = np.array(self.poslimit_center[child])
            return center - RACK_POSLIMIT_HALF_WIDTH, center + RACK_POSLIMIT_HALF_WIDTH, None
        zone = self.zone.get(child, DEFAULT_ZONE)
        low = np.array([zone.x_range[0], zone.y_range[0]])
        high = np.array([zone.x_range[1], zone.y_range[1]])
        for rack in (p.args[1] for p in self.props if p.predicate == "infront" and p.args[0] == child):
            if rack not in self.placed:
                continue
            rack_box = self.placed[rack].rest_geometry.aabb
            low = np.maximum(low, [WORKSPACE_X_MIN, rack_box[0, 1]])
            high = np.minimum(high, [rack_box[0, 0], rack_box[1, 1]])
        # Shrink by the half extents of the world AABB at this yaw (hook: 25 % in the small zones).
        below, above = _half_extents(child, quaternion)
        scale = zone.hook_margin_scale if object_spec(child).kind is ObjectKind.HOOK else 1.0
        low, high = low + scale * below, high - scale * above
        return (low, high, None) if np.all(low <= high) else None

    def _footprint_region(self, child: str, rack: str, quaternion: np.ndarray) -> tuple[np.ndarray, np.ndarray, ObjectPose] | None:
        """``under(child, rack)``: the rack's footprint (its frame), shrunk so the child stays inside."""
        frame = self.placed[rack].rest
        rack_low, rack_high = object_spec(rack).local_bounds()
        below, above = _half_extents_in_frame(child, quaternion, frame.quaternion)
        low, high = rack_low[:2] + below, rack_high[:2] - above
        return (low, high, frame) if np.all(low <= high) else None

    def _stable_region(self, child: str, parent: str, quaternion: np.ndarray) -> tuple[np.ndarray, np.ndarray, ObjectPose]:
        """The parent's top rectangle shrunk by the child's half extents in the parent frame; if that
        is empty in either axis, the fractional bounds
        [min(0.25ρ, 0.45), max(0.55, min(0.75ρ, 0.95))] of the original for both axes, ρ = child extent /
        parent extent."""
        frame = self.placed[parent].rest
        parent_low, parent_high = object_spec(parent).local_bounds()
        parent_low, parent_high = parent_low[:2], parent_high[:2]
        below, above = _half_extents_in_frame(child, quaternion, frame.quaternion)
        low, high = parent_low + below, parent_high - above
        if np.all(low <= high):
            return low, high, frame
        parent_size = parent_high - parent_low
        ratio = (below + above) / parent_size
        fraction_low = np.minimum(0.25 * ratio, 0.45)
        fraction_high = np.maximum(0.55, np.minimum(0.75 * ratio, 0.95))
        center = 0.5 * (parent_low + parent_high)
        return center + (fraction_low - 0.5) * parent_size, center + (fraction_high - 0.5) * parent_size, frame

    def _maybe_tip(self, child: str, quaternion: np.ndarray) -> np.ndarray | None:
        """``tippable``: with probability 0.1 (not the hook or the rack) a 90° tip about a random
        horizontal axis of the object frame; ``None`` when not tipped."""
        if not self.has(f"tippable({child})") or object_spec(child).kind not in (ObjectKind.BOX,):
            return None
        if self.rng.random() >= EPS_TIPPING:
            return None
        axis = self.rng.uniform(-1.0, 1.0, size=2)
        axis /= max(np.linalg.norm(axis), 1e-12)
        return quat_multiply(quaternion, axis_angle_to_quat(0.5 * np.pi * np.array([axis[0], axis[1], 0.0])))

    def _rest_and_drop(
        self, child: str, parent: str, xy: np.ndarray, quaternion: np.ndarray, *, tipped: bool
    ) -> _Placement:
        """Poses resting on the parent (bottom on its top) and dropped 5 cm above it (tipped:
        from parent_top + 0.8·max(size_x, size_y), the reference's drop height)."""
        bottom_offset = -object_geometry(child, ObjectPose(np.zeros(3), quaternion)).aabb[0, 2]
        rest_top = self.placed[parent].rest_geometry.max_z
        drop_top = self.placed[parent].drop_top
        if not tipped:
            drop_z = drop_top + DROP_HEIGHT + bottom_offset
        else:
            drop_z = drop_top + TIPPED_DROP_SCALE * max(object_spec(child).size[:2])
        rest = ObjectPose(np.array([xy[0], xy[1], rest_top + bottom_offset]), quaternion)
        drop = ObjectPose(np.array([xy[0], xy[1], drop_z]), quaternion)
        return _Placement.of(child, rest, drop)

    def _interpenetrates(self, child: str, parent: str) -> bool:
        """Whether the resting child overlaps a placed object other than its support (or a rack it
        is meant to be under). Settling would push such objects apart, so the attempt is redrawn
        (a deviation from the reference, whose samples only physics separated)."""
        me = self.placed[child].rest_geometry
        allowed = {child, parent, *(p.args[1] for p in self.props if p.predicate == "under" and p.args[0] == child)}
        return any(
            _aabb_gap(me.aabb, placement.rest_geometry.aabb) <= 0.0
            and closest_distance(me, placement.rest_geometry) <= 0.0
            for name, placement in self.placed.items()
            if name not in allowed and name != self.held and object_spec(name).kind is not ObjectKind.TABLE
        )

    def _accepts(self, child: str) -> bool:
        """Every ``free(child)`` and every zone proposition about ``child`` holds so far."""
        scene = _PlacedScene(self.placed, self.state(rest=True), self.props)
        return all(
            evaluate(p, scene)
            for p in self.props
            if p.args[:1] == (child,) and (p.predicate == "free" or p.predicate in ZONE_PREDICATES)
        )


def _half_extents(obj: str, quaternion: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``((2,), (2,))`` distances from the origin to the low and high xy sides of the world AABB at
    this orientation, metres."""
    box = object_geometry(obj, ObjectPose(np.zeros(3), quaternion)).aabb
    return -box[0, :2], box[1, :2]


def _half_extents_in_frame(obj: str, quaternion: np.ndarray, frame_quaternion: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_half_extents` expressed in a frame yawed like ``frame_quaternion`` (a support)."""
    relative_yaw = quat_yaw(quaternion) - quat_yaw(frame_quaternion)
    tilt = quat_multiply(yaw_to_quat(-quat_yaw(quaternion)), quaternion)  # the orientation minus its yaw
    return _half_extents(obj, quat_multiply(yaw_to_quat(relative_yaw), tilt))


__all__ = [
    "DROP_HEIGHT",
    "MAX_SEED_ATTEMPTS",
    "RobotPose",
    "SampledScene",
    "SamplingError",
    "clear_cache",
    "random_robot_pose",
    "sample_initial_state",
    "sample_task",
]
