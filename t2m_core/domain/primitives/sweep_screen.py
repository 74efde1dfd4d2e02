"""Analytic screen of Pull and Push actions for data generation (no simulation).

The reference heuristic (docs/guide/primitives.md#action-samplers) fixes r_reach and θ = π/8 and draws the sweep
length and the sideways offset y uniformly. Many such draws are doomed before any physics runs: the
handle lands on the box's top (the box tips), the sweep ends with the box outside the workspace or
short of the rack, the tool or the hand sweeps through a bystander, or the EE leaves the arm's reach.
This module predicts those outcomes from the domain's own geometry, so the *screened* sampler
(:meth:`~t2m_core.domain.primitives.hook_sweep.HookSweep.screened_physical`) can redraw them.

The prediction is deliberately simple: once the head has closed the initial gap, the swept box moves
with it and keeps its yaw. Pulled, it follows the sweep, possibly sliding sideways into the hook's
crook against the handle; pushed, it slides along the angled head's normal, as a frictionless
contact would (measured on task1 scenes: a box pushed with θ = π/8 drifts sideways by about 0.4 of
its forward travel). Margins absorb the errors of that model. A screen reason is a prediction
only; the primitive's own tests decide success.

The screen judges a batch of draws at once (:class:`Verdicts`): the sampler screens up to 64 draws
per scene, and array arithmetic over them costs about what one draw did in scalar code.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from t2m_core.domain.constants import TABLE_X_MIN
from t2m_core.domain.geometry import (
    ObjectGeometry,
    convex_hull_2d,
    hull_distances,
    object_geometry,
    pad_polygons,
    penetration_depths,
    polygon_edges,
    quat_to_matrix,
    signed_hull_distances,
    translation_hull,
    yawed_footprints,
)
from t2m_core.domain.objects import BoxPart, ObjectKind, ObjectSpec, object_spec
from t2m_core.domain.state import GeometricState, ObjectPose

EE_MAX_RADIUS = 0.72
"""m: the EE's planar distance from the base must stay below this at the reach and the sweep end.
The Panda's top-down reach at the 0.40 m lift height ends between 0.73 and 0.74 m (measured in
MuJoCo on 1 200 pulls: every pre-pose up to 0.73 m was reached, none from 0.74 m)."""

EE_MIN_RADIUS = TABLE_X_MIN
"""m: the EE must stay at least this far from the base at table height (closer, the arm folds onto
itself; the table's near placement limit)."""

TOOL_CLEARANCE = 0.01
"""m: the swept hook and the swept box must stay this far from bystanders and the rack's legs."""

HAND_CLEARANCE = 0.10
"""m: the EE's straight path must stay this far from the footprint of a bystander (the gripper body
reaches about this far from the EE across its fingers; measured: with 0.06 m it still struck the rack)."""

MAX_FACE_ANGLE = np.pi / 6
"""rad: the largest angle between the head's face normal and the sweep at which the box follows the
head; at steeper angles it slides off the face (the heuristic's θ = π/8 is below it)."""

LANDING_CLEARANCE = 0.005
"""m: at the reach pose the hook must be this far from the target's footprint, or it lands on it."""

HEAD_LANDING_DEPTH = 0.01
"""m: how deep the head's footprint may reach into the target's along the sweep at the reach pose."""

CLEARANCE_RANGE = 0.05
"""m: how far beyond :data:`TOOL_CLEARANCE` and :data:`HAND_CLEARANCE` the screen measures a
sweep's clearance (:func:`sweep_clearance`) for the learned models that read it; farther is far."""

END_MARGIN = 0.03
"""m: how far inside its success region the predicted end of the target must lie."""


HANDLE, HEAD = 0, 1
"""Indices of the hook's convex parts (:meth:`~t2m_core.domain.objects.ObjectSpec.convex_parts`)."""


@dataclass(frozen=True)
class SweepPrediction:
    """The geometry of B hook sweeps, predicted (world frame, metres): from one start state, or each
    from its own (:meth:`~t2m_core.domain.primitives.hook_sweep.HookSweep.screen_of_states`).

    Attributes:
        hook_reach: ``(B, P, 4, 2)`` footprints of the hook's convex parts (handle, head) at the reach pose.
        sweep: ``(B, 2)`` the hook's travel from the reach pose to the sweep end.
        hook_yaw: ``(B,)`` the hook's yaw during the sweep, radians.
        target_start: ``(K, 2)`` the target's footprint now (``(B, K, 2)``: each draw's own; then
            :meth:`take` does not apply).
        target_xy: ``(2,)`` the target's position now (``(B, 2)``: each draw's own).
        target_shift: ``(B, 2)`` the target's predicted displacement.
        drift_shift: ``(B, 2)`` its displacement if it also slides sideways along the head (Pull: into
            the crook against the handle); ``target_shift`` where no drift is predicted.
        ee_path: ``(B, 2, 2)`` xy of the EE at the reach and at the sweep end.
    """

    hook_reach: np.ndarray
    sweep: np.ndarray
    hook_yaw: np.ndarray
    target_start: np.ndarray
    target_xy: np.ndarray
    target_shift: np.ndarray
    drift_shift: np.ndarray
    ee_path: np.ndarray

    def take(self, draws: np.ndarray) -> SweepPrediction:
        """The prediction of the ``(n,)`` indexed draws only."""
        shared = {"target_start": self.target_start, "target_xy": self.target_xy}
        per_draw = ("hook_reach", "sweep", "hook_yaw", "target_shift", "drift_shift", "ee_path")
        return SweepPrediction(**shared, **{name: getattr(self, name)[draws] for name in per_draw})

    @property
    def direction(self) -> np.ndarray:
        """``(B, 2)`` unit direction of the sweep."""
        return unit(self.sweep)

    @property
    def target_end_xy(self) -> np.ndarray:
        """``(B, 2)`` the target's predicted end position, metres."""
        return self.target_xy + self.target_shift


def unit(vectors: np.ndarray) -> np.ndarray:
    """``(..., 2)`` vectors scaled to unit length (a zero one stays zero)."""
    return vectors / np.maximum(np.linalg.norm(vectors, axis=-1), 1e-12)[..., None]


def predict_sweeps(
    target_start: np.ndarray,
    target_xy: np.ndarray,
    hook_spec: ObjectSpec,
    hook_reach: np.ndarray,
    hook_end: np.ndarray,
    hook_yaw: np.ndarray,
    ee_path: np.ndarray,
    *,
    along_head_normal: bool = False,
    into_crook: bool = False,
) -> SweepPrediction:
    """Predict the target's end pose for B sweeps: it moves with the hook once the head closes the gap to it.

    Args:
        target_start: ``(K, 2)`` the target's footprint now, shared by the B sweeps, or ``(B, K, 2)``,
            each sweep's own; target_xy: its ``(2,)`` or ``(B, 2)`` position now, metres.
        hook_spec: the hook's shape.
        hook_reach, hook_end: ``(B, 3)`` the hook's origin at the reach and the sweep end, metres.
        hook_yaw: ``(B,)`` the hook's yaw during the sweep, radians.
        ee_path: ``(B, 2, 2)`` EE xy at the reach and the sweep end.
        along_head_normal: the box slides along the head's normal (Push) instead of following the
            sweep (Pull).
        into_crook: the box may also slide sideways into the crook, up to the handle (Pull).
    """
    hook_yaw = np.asarray(hook_yaw, dtype=np.float64)
    reach = yawed_footprints(hook_spec, hook_reach, hook_yaw)
    target_start = np.asarray(target_start, dtype=np.float64)
    xy = np.asarray(target_xy, dtype=np.float64)
    sweep = (np.asarray(hook_end) - hook_reach)[..., :2]
    direction = unit(sweep)
    shift = target_shifts(reach[..., HEAD, :, :], target_start, sweep, hook_yaw, along_head_normal=along_head_normal)
    drift = shift
    if into_crook:
        handle = reach[..., HANDLE, :, :]
        across = np.stack((-direction[..., 1], direction[..., 0]), axis=-1)
        away = np.sum((handle.mean(axis=-2) - xy) * across, axis=-1) < 0.0
        across = np.where(away[..., None], -across, across)
        drift = shift + _distances_to(handle, target_start)[..., None] * across
    return SweepPrediction(reach, sweep, hook_yaw, target_start, xy, shift, drift, np.asarray(ee_path, dtype=np.float64))


def target_shifts(
    head_reach: np.ndarray, target_footprint: np.ndarray, sweep: np.ndarray, hook_yaw: np.ndarray, *, along_head_normal: bool
) -> np.ndarray:
    """``(..., 2)`` the target's displacement by sweeps, metres: it moves with the hook once the head
    closes the gap to it, along the sweep or (``along_head_normal``, Push) along the head's normal.

    Args:
        head_reach: ``(..., 4, 2)`` the head's footprint at the reach pose.
        target_footprint: ``(..., K, 2)`` the target's footprint now (convex).
        sweep: ``(..., 2)`` the hook's travel; hook_yaw: ``(...)`` its yaw during the sweep, radians.
    """
    direction = unit(sweep)
    gap = _distances_to(head_reach, target_footprint)
    shift = np.maximum(0.0, np.linalg.norm(sweep, axis=-1) - gap)[..., None] * direction
    if along_head_normal:
        # The head's face looks along the hook's x axis.
        normal = np.stack((np.cos(hook_yaw), np.sin(hook_yaw)), axis=-1)
        normal = np.where((np.sum(normal * direction, axis=-1) >= 0.0)[..., None], normal, -normal)
        shift = np.sum(shift * normal, axis=-1)[..., None] * normal
    return shift


def _distances_to(footprints: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """``(B,)`` distances from ``(B, K, 2)`` convex footprints to a convex ``(L, 2)`` polygon (or B of
    them, ``(B, L, 2)``), metres."""
    return hull_distances(footprints, polygon_edges(footprints), polygon, polygon_edges(polygon))


class Verdicts:
    """The first predicted failure of each of B draws. Checks run in order, each on the draws that
    passed every earlier one: the reasons a per-draw screen returning at its first failure gives.

    Attributes:
        prediction: the sweeps of all B draws.
        reasons: per draw, the reason of the first check that failed it, or ``None``.
    """

    def __init__(self, prediction: SweepPrediction) -> None:
        self.prediction = prediction
        self.reasons: list[str | None] = [None] * len(prediction.sweep)
        self._pending = np.arange(len(prediction.sweep))

    def check(self, reason: str, fails: Callable[[SweepPrediction], np.ndarray]) -> None:
        """Give ``reason`` to the pending draws that ``fails`` rejects; it maps the prediction of the n
        draws still pending to ``(n,)`` bool."""
        if self._pending.size == 0:
            return
        failed = np.asarray(fails(self.prediction.take(self._pending)), dtype=bool)
        for draw in self._pending[failed]:
            self.reasons[draw] = reason
        self._pending = self._pending[~failed]


def unreachable(prediction: SweepPrediction) -> np.ndarray:
    """``(B,)`` whether the EE leaves the annulus the arm reaches at table height (``"unreachable"``)."""
    radii = np.linalg.norm(prediction.ee_path, axis=-1)
    return ~np.all((radii >= EE_MIN_RADIUS) & (radii < EE_MAX_RADIUS), axis=-1)


def reach_margin(prediction: SweepPrediction) -> np.ndarray:
    """``(B,)`` metres the EE's path stays inside the annulus the arm reaches at table height (at the
    reach and at the sweep end, the smaller of ``EE_MAX_RADIUS − r`` and ``r − EE_MIN_RADIUS``);
    negative by as much as it leaves it (:func:`unreachable`)."""
    radii = np.linalg.norm(prediction.ee_path, axis=-1)
    return np.minimum(EE_MAX_RADIUS - radii, radii - EE_MIN_RADIUS).min(axis=-1)


def lands_on_target(prediction: SweepPrediction) -> np.ndarray:
    """``(B,)`` whether the hook at the reach pose would come down on the target (``"tipped_over"``):
    its handle within :data:`LANDING_CLEARANCE` of the target's footprint, or its head more than
    :data:`HEAD_LANDING_DEPTH` into it along the sweep. (The heuristic's r_reach leaves the head
    about 0.01 m from a square-on box; a turned box's corner may reach under it by a few mm, which
    the measured sweeps survive.)"""
    target = prediction.target_start
    handle_lands = _distances_to(prediction.hook_reach[:, HANDLE], target) < LANDING_CLEARANCE
    head_depth = penetration_depths(prediction.hook_reach[:, HEAD], target, prediction.direction)
    return handle_lands | (head_depth > HEAD_LANDING_DEPTH)


def face_meets_target(prediction: SweepPrediction) -> np.ndarray:
    """``(B,)`` whether the head's face, not its corner at the joint, meets the target square enough
    to carry it: the target's extent across the sweep lies within the head's (a corner turns the box
    and sends it sideways) and the face is within :data:`MAX_FACE_ANGLE` of the sweep."""
    direction = prediction.direction
    face_normal = np.stack((np.cos(prediction.hook_yaw), np.sin(prediction.hook_yaw)), axis=-1)
    square = np.abs(np.sum(face_normal * direction, axis=-1)) >= np.cos(MAX_FACE_ANGLE)
    across = np.stack((-direction[:, 1], direction[:, 0]), axis=-1)
    head = np.sum(prediction.hook_reach[:, HEAD] * across[:, None], axis=-1)  # (B, 4)
    target = across @ prediction.target_start.T  # (B, K)
    return square & (target.min(axis=-1) >= head.min(axis=-1)) & (target.max(axis=-1) <= head.max(axis=-1))


def sweep_disturbs(
    prediction: SweepPrediction,
    *,
    hook_obstacles: np.ndarray,
    target_obstacles: np.ndarray,
    hand_obstacles: np.ndarray,
) -> np.ndarray:
    """``(B,)`` whether the swept hook or the swept target comes within :data:`TOOL_CLEARANCE` of one
    of its obstacles, or the EE's path within :data:`HAND_CLEARANCE` of a hand obstacle
    (``"disturbed"``). Obstacles are ``(N, K, 2)`` footprints (:func:`obstacle_footprints`), or
    ``(B, N, K, 2)``, each draw's own."""
    return sweep_clearance(prediction, hook_obstacles=hook_obstacles, target_obstacles=target_obstacles, hand_obstacles=hand_obstacles) < 0.0


def sweep_clearance(
    prediction: SweepPrediction,
    *,
    hook_obstacles: np.ndarray,
    target_obstacles: np.ndarray,
    hand_obstacles: np.ndarray,
    within: float = 0.0,
) -> np.ndarray:
    """``(B,)`` metres by which the swept hook and the swept target clear their obstacles beyond
    :data:`TOOL_CLEARANCE`, and the EE's path its hand obstacles beyond :data:`HAND_CLEARANCE` (the
    smallest of the three); negative where :func:`sweep_disturbs`. Measured up to ``within``: a
    draw that clears everything by more reads ``within`` (the larger it is, the more pairs of region
    and obstacle need an exact distance). Obstacles as :func:`sweep_disturbs` takes them."""
    hook, target, hand = swept_regions(prediction)
    regions = ((hook, hook_obstacles, TOOL_CLEARANCE), (target, target_obstacles, TOOL_CLEARANCE), (hand, hand_obstacles, HAND_CLEARANCE))
    return np.min([nearest_gaps(*region, obstacles, clearance + within) - clearance for region, obstacles, clearance in regions], axis=0)


def sweep_clearance_and_gap(
    prediction: SweepPrediction, obstacles: np.ndarray, in_layer: np.ndarray, within: float
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`sweep_clearance` of B sweeps from one set of ``(B, N, K, 2)`` obstacles (for the hook,
    the target and the hand alike), and ``(B,)`` the *signed* gap between the swept hook and target
    and the nearest obstacle in the sweep's layer (``(B, N)`` ``in_layer``: an obstacle whose bottom
    lies below the swept objects' tops), metres, within ±``within``: negative, how deep the sweep
    reaches into one (the shortest move that separates them,
    :func:`~t2m_core.domain.geometry.signed_hull_distances`), where the clearance reads
    ``−TOOL_CLEARANCE`` for any overlap, even with an object raised above the sweep (a box on the
    rack). One exact test per near pair serves both: the signed distance is the plain one apart."""
    hook, target, hand = swept_regions(prediction)
    pairs = [pair_gaps(*region, obstacles, TOOL_CLEARANCE + within, signed=True) for region in (hook, target)]
    draw, obstacle, signed = (np.concatenate(column) for column in zip(*pairs, strict=True))
    tool, gap = clearance_and_gap(len(prediction.sweep), draw, signed, np.asarray(in_layer, dtype=bool)[draw, obstacle], within)
    return np.minimum(tool, nearest_gaps(*hand, obstacles, HAND_CLEARANCE + within) - HAND_CLEARANCE), gap


def clearance_and_gap(count: int, draw: np.ndarray, signed: np.ndarray, eligible: np.ndarray, within: float) -> tuple[np.ndarray, np.ndarray]:
    """From the ``(P,)`` signed distances of near pairs (:func:`pair_gaps` within
    ``TOOL_CLEARANCE + within``) of ``count`` draws: ``(count,)`` how far each draw clears its
    obstacles beyond :data:`TOOL_CLEARANCE` (``−TOOL_CLEARANCE`` for any overlap; up to ``within``),
    and ``(count,)`` the signed gap to the ``eligible`` pairs' obstacles only, within ±``within``,
    metres."""
    clearance = np.full(count, TOOL_CLEARANCE + within)
    np.minimum.at(clearance, draw, np.maximum(signed, 0.0))
    gap = np.full(count, within)
    np.minimum.at(gap, draw[eligible], signed[eligible])
    return clearance - TOOL_CLEARANCE, np.maximum(gap, -within)


def swept_regions(prediction: SweepPrediction) -> tuple[tuple[np.ndarray, np.ndarray], ...]:
    """What B sweeps cover, each as ``(points, edges)`` (:func:`~t2m_core.domain.geometry.hull_distances`
    takes them): the hook's parts swept from the reach pose to the sweep end, the target's footprint
    swept to its predicted ends (with and without drift), and the EE's straight path (one segment)."""
    still = np.zeros_like(prediction.sweep)
    hook = translation_hull(prediction.hook_reach, np.stack((still, prediction.sweep), axis=-2)[:, None])
    target_shifts = np.stack((still, prediction.target_shift, prediction.drift_shift), axis=-2)
    target = translation_hull(prediction.target_start, target_shifts)
    hand = (prediction.ee_path, prediction.ee_path[:, None])  # one segment
    return hook, target, hand


def comes_near(points: np.ndarray, edges: np.ndarray, obstacles: np.ndarray, clearance: float) -> np.ndarray:
    """``(B,)`` whether any region of a draw (``(B, ..., M, 2)`` points, ``(B, ..., S, 2, 2)`` edges, as
    :func:`~t2m_core.domain.geometry.hull_distances` takes them) comes within ``clearance`` metres of
    any ``(N, K, 2)`` obstacle (or of its own: ``(B, N, K, 2)``, each draw's obstacles)."""
    return nearest_gaps(points, edges, obstacles, clearance) < clearance


def near_pairs(points: np.ndarray, obstacles: np.ndarray, within: float) -> tuple[tuple[np.ndarray, ...], np.ndarray, np.ndarray]:
    """The pairs of a draw's region and an obstacle whose bounding boxes come within ``within``
    metres (arguments as :func:`comes_near` takes them): ``(region, obstacle, candidates)``, the
    region's index arrays (the first the draw's), each pair's obstacle index and ``(P, K, 2)``
    polygon. The gap between bounding boxes never exceeds the distance, so no other pair lies
    within ``within``; most regions are far from most obstacles, and only these need an exact test."""
    per_draw = obstacles.ndim == 4
    low, high = points.min(axis=-2)[..., None, :], points.max(axis=-2)[..., None, :]
    obstacle_low, obstacle_high = obstacles.min(axis=-2), obstacles.max(axis=-2)  # ([B,] N, 2)
    if per_draw:  # one axis per region axis of a draw
        region_axes = (slice(None),) + (None,) * (points.ndim - 3)
        obstacle_low, obstacle_high = obstacle_low[region_axes], obstacle_high[region_axes]
    gaps = np.maximum(0.0, np.maximum(obstacle_low - high, low - obstacle_high))  # (B, ..., N, 2)
    *region, obstacle = np.nonzero(np.sum(gaps * gaps, axis=-1) < within**2)
    candidates = obstacles[region[0], obstacle] if per_draw else obstacles[obstacle]
    return tuple(region), obstacle, candidates


def nearest_gaps(points: np.ndarray, edges: np.ndarray, obstacles: np.ndarray, within: float) -> np.ndarray:
    """``(B,)`` the smallest distance from any region of a draw to any obstacle (arguments as
    :func:`comes_near` takes them), metres; ``within`` where every one lies at least that far."""
    draw, _, distances = pair_gaps(points, edges, obstacles, within)
    nearest = np.full(len(points), float(within))
    np.minimum.at(nearest, draw, distances)
    return nearest


def pair_gaps(
    points: np.ndarray, edges: np.ndarray, obstacles: np.ndarray, within: float, *, signed: bool = False
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The distances of the pairs of a draw's region and an obstacle that :func:`near_pairs` finds
    within ``within`` metres (arguments as :func:`comes_near` takes them): each pair's draw, obstacle
    and distance, ``(P,)`` each; ``signed``: minus the penetration depth where they overlap
    (:func:`~t2m_core.domain.geometry.signed_hull_distances`), not 0."""
    region, obstacle, candidates = near_pairs(points, obstacles, within)
    distance = signed_hull_distances if signed else hull_distances
    return region[0], obstacle, distance(points[*region], edges[*region], candidates, polygon_edges(candidates))


def obstacle_heights(geometries: Sequence[ObjectGeometry]) -> np.ndarray:
    """``(N, 2)`` the lowest and the highest z of every convex part of the objects, metres, in the
    order of :func:`obstacle_footprints`."""
    return np.array([(z.min(), z.max()) for geometry in geometries for z in geometry.part_corners[..., 2]], dtype=np.float64).reshape(-1, 2)


def obstacle_footprints(geometries: Sequence[ObjectGeometry]) -> np.ndarray:
    """``(N, K, 2)`` the footprints of every convex part of the objects, padded to one size."""
    return pad_polygons([footprint for geometry in geometries for footprint in geometry.footprints])


def bystanders(
    state: GeometricState, arguments: Sequence[str], geometry: Callable[[str, ObjectPose], ObjectGeometry] = object_geometry
) -> list[ObjectGeometry]:
    """Geometry of the present objects other than the arguments and the table (``geometry``: how to
    compute one, e.g. a memo over many states)."""
    return [
        geometry(name, pose)
        for name, pose in state.objects.items()
        if name not in arguments and object_spec(name).kind is not ObjectKind.TABLE
    ]


def rack_parts(state: GeometricState, rack: str, names: Sequence[str]) -> list[ObjectGeometry]:
    """The named parts of the rack (``"leg_0"``..., ``"bar_0"``...) as one-part
    :class:`ObjectGeometry` s: the space between the legs is open, so Push needs them separately."""
    pose = state.objects[rack]
    spec = object_spec(rack)
    return [_part_geometry(rack, spec, part, pose) for part in spec.parts() if part.name in names]


def _part_geometry(name: str, spec, part: BoxPart, pose: ObjectPose) -> ObjectGeometry:
    rotation = quat_to_matrix(pose.quaternion)
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=np.float64)
    corners = (np.asarray(part.center) + 0.5 * signs * np.asarray(part.size)) @ rotation.T + pose.position
    aabb = np.stack((corners.min(axis=0), corners.max(axis=0)))
    return ObjectGeometry(name, spec, pose.position, pose.quaternion, corners[None], aabb, (convex_hull_2d(corners[:, :2]),))
