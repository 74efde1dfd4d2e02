"""Rotations and the analytic geometric tests of the TableEnv world (docs/guide/world.md#geometric-tests).

Quaternions are ``(x, y, z, w)``; rotation helpers broadcast over leading axes (``(..., 4)``).
The object tests work on :class:`ObjectGeometry`, the world-frame corners, AABB and xy footprint of
an object's *convex parts* (:meth:`ObjectSpec.convex_parts`: the hook's two footprint boxes, the
rack's full bounding box, a box itself). Engine AABBs, which are padded, are never used.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from t2m_core.domain.constants import (
    DISTURBANCE_ROTATION,
    DISTURBANCE_TRANSLATION,
    EPS_AABB,
    EPS_ALIGN,
    MAX_LIFT_HEIGHT,
    ON_CONTACT_GAP,
)
from t2m_core.domain.objects import ObjectKind, ObjectSpec, object_spec
from t2m_core.domain.state import ObjectPose

IDENTITY_QUAT = np.array([0.0, 0.0, 0.0, 1.0])
"""``(4,)`` the identity rotation, xyzw."""

# --------------------------------------------------------------------------------------------------
# Angles and quaternions
# --------------------------------------------------------------------------------------------------


def wrap_angle(angle: float | np.ndarray) -> float | np.ndarray:
    """Wrap radians to [−π, π)."""
    wrapped = (np.asarray(angle, dtype=np.float64) + np.pi) % (2 * np.pi) - np.pi
    return float(wrapped) if wrapped.ndim == 0 else wrapped


def quat_normalize(q: np.ndarray) -> np.ndarray:
    """``(..., 4)`` unit quaternions; raises ``ValueError`` on a zero quaternion."""
    q = np.asarray(q, dtype=np.float64)
    norm = np.linalg.norm(q, axis=-1, keepdims=True)
    if np.any(norm < 1e-12):
        raise ValueError("cannot normalise a zero quaternion")
    return q / norm


def quat_multiply(q1: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """Hamilton product ``q1 · q2`` (apply q2 first, then q1), ``(..., 4)`` xyzw."""
    q1, q2 = np.asarray(q1, dtype=np.float64), np.asarray(q2, dtype=np.float64)
    x1, y1, z1, w1 = np.moveaxis(q1, -1, 0)
    x2, y2, z2, w2 = np.moveaxis(q2, -1, 0)
    return np.stack(
        (
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        ),
        axis=-1,
    )


def quat_conjugate(q: np.ndarray) -> np.ndarray:
    """``(..., 4)`` conjugate, the inverse of a unit quaternion."""
    q = np.asarray(q, dtype=np.float64)
    return q * np.array([-1.0, -1.0, -1.0, 1.0])


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """``(..., 4)`` xyzw quaternions → ``(..., 3, 3)`` rotation matrices (normalised first)."""
    q = np.asarray(q, dtype=np.float64)
    if q.shape == (4,):
        return _single_quat_to_matrix(q)
    x, y, z, w = np.moveaxis(quat_normalize(q), -1, 0)
    return np.stack(
        (
            np.stack((1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)), axis=-1),
            np.stack((2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)), axis=-1),
            np.stack((2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)), axis=-1),
        ),
        axis=-2,
    )


def _single_quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """:func:`quat_to_matrix` of one ``(4,)`` quaternion in scalar arithmetic: the analytic
    feasibility screens call it hundreds of thousands of times, where array overhead dominated."""
    x, y, z, w = q.tolist()
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    if norm < 1e-12:
        raise ValueError("cannot normalise a zero quaternion")
    x, y, z, w = x / norm, y / norm, z / norm, w / norm
    return np.array(
        (
            (1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)),
            (2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)),
            (2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)),
        )
    )


def matrix_to_quat(matrix: np.ndarray) -> np.ndarray:
    """``(..., 3, 3)`` rotation matrices → ``(..., 4)`` xyzw quaternions with w ≥ 0."""
    m = np.asarray(matrix, dtype=np.float64)
    m00, m11, m22 = m[..., 0, 0], m[..., 1, 1], m[..., 2, 2]
    # Four candidate formulas; each is stable where its pivot (|w|, |x|, |y| or |z|) is largest.
    candidates = np.stack(
        (
            np.stack((m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0], m[..., 1, 0] - m[..., 0, 1],
                      1 + m00 + m11 + m22), axis=-1),
            np.stack((1 + m00 - m11 - m22, m[..., 0, 1] + m[..., 1, 0], m[..., 0, 2] + m[..., 2, 0],
                      m[..., 2, 1] - m[..., 1, 2]), axis=-1),
            np.stack((m[..., 0, 1] + m[..., 1, 0], 1 - m00 + m11 - m22, m[..., 1, 2] + m[..., 2, 1],
                      m[..., 0, 2] - m[..., 2, 0]), axis=-1),
            np.stack((m[..., 0, 2] + m[..., 2, 0], m[..., 1, 2] + m[..., 2, 1], 1 - m00 - m11 + m22,
                      m[..., 1, 0] - m[..., 0, 1]), axis=-1),
        ),
        axis=-2,
    )
    pivots = np.stack((1 + m00 + m11 + m22, 1 + m00 - m11 - m22, 1 - m00 + m11 - m22, 1 - m00 - m11 + m22), axis=-1)
    best = np.argmax(pivots, axis=-1)
    q = np.take_along_axis(candidates, best[..., None, None], axis=-2)[..., 0, :]
    q = quat_normalize(q)
    return np.where(q[..., 3:4] < 0, -q, q)


def axis_angle_to_quat(axis_angle: np.ndarray) -> np.ndarray:
    """``(..., 3)`` rotation vectors (angle·axis, radians) → ``(..., 4)`` xyzw quaternions."""
    aa = np.asarray(axis_angle, dtype=np.float64)
    angle = np.linalg.norm(aa, axis=-1, keepdims=True)
    half = 0.5 * angle
    # sin(θ/2)/θ → 1/2 as θ → 0; the series keeps tiny rotations exact.
    scale = np.where(angle > 1e-8, np.sin(half) / np.where(angle > 1e-8, angle, 1.0), 0.5 - angle**2 / 48)
    return np.concatenate((aa * scale, np.cos(half)), axis=-1)


def quat_to_axis_angle(q: np.ndarray) -> np.ndarray:
    """``(..., 4)`` xyzw quaternions → ``(..., 3)`` rotation vectors angle·axis with angle ∈ [0, π]."""
    q = quat_normalize(q)
    q = np.where(q[..., 3:4] < 0, -q, q)  # the same rotation with angle ≤ π
    vec, w = q[..., :3], q[..., 3:4]
    sin_half = np.linalg.norm(vec, axis=-1, keepdims=True)
    angle = 2 * np.arctan2(sin_half, w)
    scale = np.where(sin_half > 1e-8, angle / np.where(sin_half > 1e-8, sin_half, 1.0), 2.0 + sin_half**2 / 3)
    return vec * scale


def yaw_to_quat(yaw: float | np.ndarray) -> np.ndarray:
    """Rotation Rz(yaw) about the world z axis, ``(..., 4)`` xyzw, yaw in radians."""
    half = 0.5 * np.asarray(yaw, dtype=np.float64)
    zeros = np.zeros_like(half)
    return np.stack((zeros, zeros, np.sin(half), np.cos(half)), axis=-1)


def quat_yaw(q: np.ndarray) -> float | np.ndarray:
    """Heading of the rotated x axis, atan2(R₁₀, R₀₀), radians in [−π, π]."""
    rotation = quat_to_matrix(q)
    yaw = np.arctan2(rotation[..., 1, 0], rotation[..., 0, 0])
    return float(yaw) if np.ndim(yaw) == 0 else yaw


def quat_angle(q1: np.ndarray, q2: np.ndarray) -> float | np.ndarray:
    """Angle of the rotation taking q1 to q2, radians in [0, π]."""
    relative = quat_multiply(quat_conjugate(quat_normalize(q1)), quat_normalize(q2))
    # atan2 keeps small angles exact where arccos of a dot product near 1 loses half the digits.
    angle = 2 * np.arctan2(np.linalg.norm(relative[..., :3], axis=-1), np.abs(relative[..., 3]))
    return float(angle) if np.ndim(angle) == 0 else angle


def rotate(q: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """Rotate ``(..., 3)`` vectors by ``(..., 4)`` quaternions."""
    return np.einsum("...ij,...j->...i", quat_to_matrix(q), np.asarray(vectors, dtype=np.float64))


def compose_poses(
    position_a: np.ndarray, quat_a: np.ndarray, position_b: np.ndarray, quat_b: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``T_a · T_b``: pose b expressed in frame a, mapped to a's parent frame. Returns
    ``((..., 3) position, (..., 4) quaternion)``."""
    position = np.asarray(position_a, dtype=np.float64) + rotate(quat_a, position_b)
    return position, quat_normalize(quat_multiply(quat_a, quat_b))


def tilt_cosine(q: np.ndarray) -> float | np.ndarray:
    """(R·ẑ)·ẑ = 1 − 2(x² + y²) of a unit quaternion: the cosine of the object's tilt."""
    x, y = np.moveaxis(quat_normalize(q), -1, 0)[:2]
    value = 1.0 - 2.0 * (x * x + y * y)
    return float(value) if np.ndim(value) == 0 else value


def is_upright(q: np.ndarray) -> bool | np.ndarray:
    """Tilt test: (R·ẑ)·ẑ ≥ 0.99 (tilt ≤ ≈ 8.1°). Unlike the original's axis test, an unrotated object
    is upright (docs/guide/deviations.md#uprightness-is-a-tilt-test)."""
    value = np.asarray(tilt_cosine(q)) >= EPS_ALIGN
    return bool(value) if value.ndim == 0 else value


def did_move(
    position_before: np.ndarray,
    quat_before: np.ndarray,
    position_after: np.ndarray,
    quat_after: np.ndarray,
) -> bool | np.ndarray:
    """The disturbance test: translation ≥ 0.05 m or rotation ≥ 5°. Broadcasts over ``(..., 3)``
    positions and ``(..., 4)`` quaternions."""
    shift = np.linalg.norm(np.asarray(position_after, float) - np.asarray(position_before, float), axis=-1)
    turn = np.asarray(quat_angle(quat_before, quat_after))
    moved = (shift >= DISTURBANCE_TRANSLATION) | (turn >= DISTURBANCE_ROTATION)
    return bool(moved) if np.ndim(moved) == 0 else moved


# --------------------------------------------------------------------------------------------------
# 2-D convex polygons
# --------------------------------------------------------------------------------------------------


def convex_hull_2d(points: np.ndarray) -> np.ndarray:
    """Counter-clockwise convex hull ``(K, 2)`` of ``(M, 2)`` points (monotone chain; collinear
    points dropped). Degenerate inputs give 1 or 2 vertices."""
    # Plain tuples: for the 8 corners of a part this is several times faster than NumPy set ops.
    pts = sorted(set(map(tuple, np.round(np.asarray(points, dtype=np.float64), 12).tolist())))
    if len(pts) <= 2:
        return np.array(pts, dtype=np.float64).reshape(-1, 2)

    def cross(o: tuple, a: tuple, b: tuple) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[tuple] = []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    upper: list[tuple] = []
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return np.array(lower[:-1] + upper[:-1], dtype=np.float64)


def _edge_normals(polygon: np.ndarray) -> np.ndarray:
    """``(K, 2)`` normals of a polygon's edges (unnormalised; degenerate edges dropped)."""
    edges = np.roll(polygon, -1, axis=0) - polygon
    normals = np.stack((-edges[:, 1], edges[:, 0]), axis=1)
    return normals[np.linalg.norm(normals, axis=1) > 1e-15]


def polygons_overlap(polygon_a: np.ndarray, polygon_b: np.ndarray) -> bool:
    """Separating-axis test for two convex polygons ``(K, 2)`` (a segment is a 2-vertex polygon).
    Touching boundaries count as overlapping, like shapely's ``intersects``."""
    a, b = np.asarray(polygon_a, dtype=np.float64), np.asarray(polygon_b, dtype=np.float64)
    axes = [_edge_normals(a), _edge_normals(b)]
    if len(a) == 2 and len(b) == 2:
        # Two segments: also test the axes along them, or collinear disjoint segments would overlap.
        axes.append(np.stack((a[1] - a[0], b[1] - b[0])))
    normals = np.concatenate(axes)
    if len(normals) == 0:
        return bool(np.allclose(a[0], b[0]))
    return not bool(_separated_along(a, b, normals).any())


def _separated_along(points_a: np.ndarray, points_b: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """``(..., S)`` whether the projections of the point sets ``(..., M, 2)`` on each of the ``(..., S, 2)``
    axes are disjoint (touching, within 1e-12 of an axis' length, is not disjoint)."""
    to_axes = np.swapaxes(axes, -1, -2)
    proj_a, proj_b = points_a @ to_axes, points_b @ to_axes
    tol = 1e-12 * np.linalg.norm(axes, axis=-1)
    return (proj_a.max(axis=-2) < proj_b.min(axis=-2) - tol) | (proj_b.max(axis=-2) < proj_a.min(axis=-2) - tol)


def _closest_squared_distance(points: np.ndarray, segments: np.ndarray) -> np.ndarray:
    """``(...)`` the smallest squared distance from ``(..., P, 2)`` points to ``(..., S, 2, 2)`` segments
    (start, end), metres². Coordinates are kept apart: reductions over an axis of 2 cost more than
    the arithmetic."""
    start_x, start_y = segments[..., None, :, 0, 0], segments[..., None, :, 0, 1]  # (..., 1, S)
    along_x, along_y = segments[..., None, :, 1, 0] - start_x, segments[..., None, :, 1, 1] - start_y
    rel_x, rel_y = points[..., :, None, 0] - start_x, points[..., :, None, 1] - start_y  # (..., P, S)
    length2 = np.maximum(along_x * along_x + along_y * along_y, 1e-30)
    t = np.clip((rel_x * along_x + rel_y * along_y) / length2, 0.0, 1.0)
    off_x, off_y = rel_x - t * along_x, rel_y - t * along_y
    return (off_x * off_x + off_y * off_y).min(axis=(-2, -1))


def polygon_distance(polygon_a: np.ndarray, polygon_b: np.ndarray) -> float:
    """Closest distance between two convex polygons ``(K, 2)``, metres; 0 when they overlap."""
    a, b = np.asarray(polygon_a, dtype=np.float64), np.asarray(polygon_b, dtype=np.float64)
    if polygons_overlap(a, b):
        return 0.0
    # Disjoint convex sets: the closest pair has a vertex of one on an edge of the other.
    squared = min(_closest_squared_distance(a, polygon_edges(b)), _closest_squared_distance(b, polygon_edges(a)))
    return math.sqrt(squared)


def polygon_edges(polygons: np.ndarray) -> np.ndarray:
    """``(..., K, 2, 2)`` edges (start, end) of ``(..., K, 2)`` polygons in cyclic order, the closing one last."""
    return np.stack((polygons, np.roll(polygons, -1, axis=-2)), axis=-2)


def inside_margins(points: np.ndarray, polygons: np.ndarray) -> np.ndarray:
    """``(...)`` how far ``(..., 2)`` points lie inside ``(..., K, 2)`` counter-clockwise convex
    polygons, metres: the distance to the nearest edge's line, negative beyond an edge (by at least
    the distance to the polygon there). Zero-length edges (a :func:`pad_polygons` padding) are skipped."""
    start, end = polygons, np.roll(polygons, -1, axis=-2)
    along = end - start
    length = np.linalg.norm(along, axis=-1)  # (..., K)
    inward = np.stack((-along[..., 1], along[..., 0]), axis=-1) / np.where(length > 0, length, 1.0)[..., None]
    margins = np.sum(inward * (np.asarray(points)[..., None, :] - start), axis=-1)
    return np.min(np.where(length > 0, margins, np.inf), axis=-1)


def clip_segments(segments: np.ndarray, polygons: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The parts of ``(..., S, 2, 2)`` segments (start, end; metres) inside ``(..., K, 2)``
    counter-clockwise convex polygons (Cyrus-Beck; zero-length edges, a :func:`pad_polygons`
    padding, are skipped): ``((..., S, 2, 2) clipped segments, (..., S) whether any part is inside)``;
    a segment wholly outside keeps its ends and reads ``False``."""
    segments, polygons = np.asarray(segments, dtype=np.float64), np.asarray(polygons, dtype=np.float64)
    start, along = segments[..., 0, :], segments[..., 1, :] - segments[..., 0, :]  # (..., S, 2)
    edge_start = polygons[..., None, :, :]  # (..., 1, K, 2)
    edge = np.roll(polygons, -1, axis=-2)[..., None, :, :] - edge_start
    inward = np.stack((-edge[..., 1], edge[..., 0]), axis=-1)  # (..., 1, K, 2), unnormalised
    real = np.sum(edge * edge, axis=-1) > 0.0
    # inside edge k where inward_k . (start + t along - edge_start_k) >= 0, i.e. offset + t rate >= 0
    offset = np.sum(inward * (start[..., :, None, :] - edge_start), axis=-1)  # (..., S, K)
    rate = np.sum(inward * along[..., :, None, :], axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        bound = -offset / rate
    entering, leaving = real & (rate > 0.0), real & (rate < 0.0)
    low = np.max(np.where(entering, bound, 0.0), axis=-1, initial=0.0)
    high = np.min(np.where(leaving, bound, 1.0), axis=-1, initial=1.0)
    parallel_outside = np.any(real & (rate == 0.0) & (offset < 0.0), axis=-1)
    inside = (low <= high) & ~parallel_outside
    ends = start[..., None, :] + np.stack((low, high), axis=-1)[..., None] * along[..., None, :]
    return np.where(inside[..., None, None], ends, segments), inside


def hull_margins(points: np.ndarray, valid: np.ndarray, queries: np.ndarray) -> np.ndarray:
    """``(...)`` how far ``(..., 2)`` queries lie inside the convex hull of the ``valid`` ``(..., M)``
    of ``(..., M, 2)`` points, metres, without building the hull: the nearest hull edge's line
    (negative beyond it); a hull of collinear points or of one point has no inside, and reads minus
    the query's distance from its line or point; no valid point reads ``-inf``. For a few points
    (every ordered pair is tried as an edge)."""
    points, valid = np.asarray(points, dtype=np.float64), np.asarray(valid, dtype=bool)
    queries = np.asarray(queries, dtype=np.float64)
    x, y = np.ascontiguousarray(points[..., 0]), np.ascontiguousarray(points[..., 1])  # (..., M)
    dx, dy = x[..., None, :] - x[..., :, None], y[..., None, :] - y[..., :, None]  # (..., M, M): from i to j
    length = np.hypot(dx, dy)
    scale = 1.0 / np.where(length > 1e-12, length, 1.0)
    left_x, left_y = -dy * scale, dx * scale  # unit normal to the left of i -> j
    offset = left_x * x[..., :, None] + left_y * y[..., :, None]  # the line through i and j: left . p = offset
    # side of every point k of the line through i and j: (..., M, M, M)
    sides = left_x[..., None] * x[..., None, None, :] + left_y[..., None] * y[..., None, None, :] - offset[..., None]
    pair = valid[..., :, None] & valid[..., None, :] & (length > 1e-9)
    edge = pair & np.all((sides >= -1e-9) | ~valid[..., None, None, :], axis=-1)
    distance = left_x * queries[..., None, None, 0] + left_y * queries[..., None, None, 1] - offset  # (..., M, M)
    margins = np.min(np.where(edge, distance, np.inf), axis=(-2, -1))
    to_points = np.min(np.where(valid, np.hypot(queries[..., None, 0] - x, queries[..., None, 1] - y), np.inf), axis=-1)
    return np.where(np.isfinite(margins), margins, -to_points)


def hull_distances(points_a: np.ndarray, edges_a: np.ndarray, points_b: np.ndarray, edges_b: np.ndarray) -> np.ndarray:
    """Closest distances between the convex hulls of two point sets, broadcast over the leading axes,
    metres; 0 where they overlap: :func:`polygon_distance` for batches.

    Each hull is given by ``(..., M, 2)`` points within it that include its vertices and
    ``(..., S, 2, 2)`` segments within it that include its edges (a convex polygon: its vertices and
    :func:`polygon_edges`; a translated one: :func:`translation_hull`), so that no hull has to be
    built. The separating-axis test then sees every edge normal of both hulls, and the closest
    vertex-edge pair is among the candidates. Not for two segments (:func:`polygons_overlap` tests
    the axes along them too); padded vertices (:func:`pad_polygons`) are harmless."""
    overlap = ~(
        _separated_along(points_a, points_b, _segment_normals(edges_a)).any(axis=-1)
        | _separated_along(points_a, points_b, _segment_normals(edges_b)).any(axis=-1)
    )
    distance2 = np.minimum(_closest_squared_distance(points_a, edges_b), _closest_squared_distance(points_b, edges_a))
    return np.where(overlap, 0.0, np.sqrt(distance2))


def signed_hull_distances(points_a: np.ndarray, edges_a: np.ndarray, points_b: np.ndarray, edges_b: np.ndarray) -> np.ndarray:
    """:func:`hull_distances` where the hulls lie apart, minus the penetration depth where they
    overlap (the shortest translation that separates them: along the unit normals of both hulls'
    segments, the least move that clears one's projection past the other's), metres; arguments as :func:`hull_distances` takes them."""
    distances = np.asarray(hull_distances(points_a, edges_a, points_b, edges_b))
    touching = distances == 0.0  # only these need a depth
    if not touching.any():
        return distances

    def of_touching(array: np.ndarray, tail: int) -> np.ndarray:
        """The touching pairs' entries of an array with ``tail`` trailing axes: ``(T, ...)``."""
        return np.broadcast_to(array, (*distances.shape, *array.shape[array.ndim - tail:]))[touching]

    points_a, points_b, edges_a, edges_b = of_touching(points_a, 2), of_touching(points_b, 2), of_touching(edges_a, 3), of_touching(edges_b, 3)
    normals = np.concatenate((_segment_normals(edges_a), _segment_normals(edges_b)), axis=-2)  # (T, S, 2)
    length = np.linalg.norm(normals, axis=-1)
    axes = np.swapaxes(normals / np.maximum(length, 1e-30)[..., None], -1, -2)
    proj_a, proj_b = points_a @ axes, points_b @ axes  # (T, M, S)
    # the shorter of the two moves along an axis that clear one projection past the other (one hull
    # inside the other needs more than their overlap)
    overlap = np.minimum(proj_a.max(axis=-2) - proj_b.min(axis=-2), proj_b.max(axis=-2) - proj_a.min(axis=-2))
    depth = np.where(length > 1e-12, overlap, np.inf).min(axis=-1)  # a zero-length segment separates nothing
    signed = distances.astype(np.float64, copy=True)
    signed[touching] = np.where(depth > 0.0, -depth, 0.0)
    return signed


def _segment_normals(segments: np.ndarray) -> np.ndarray:
    """``(..., S, 2)`` unnormalised normals of ``(..., S, 2, 2)`` segments; zero for a zero-length one,
    which separates nothing."""
    d = segments[..., 1, :] - segments[..., 0, :]
    return np.stack((-d[..., 1], d[..., 0]), axis=-1)


def translation_hull(polygons: np.ndarray, shifts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The convex hull of ``(..., K, 2)`` convex polygons translated by each of ``(..., T, 2)`` shifts
    (the footprint a polygon sweeps, a box's start and predicted ends), as :func:`hull_distances`
    takes it: ``(..., T·K, 2)`` points and ``(..., (T + T(T−1)/2)·K, 2, 2)`` edges, those of every copy
    and the path of every vertex between two copies. The hull is the polygon's Minkowski sum with the
    shifts' hull, so each of its edges is an edge of a copy or such a path."""
    copies = np.asarray(polygons)[..., None, :, :] + np.asarray(shifts)[..., :, None, :]  # (..., T, K, 2)
    count, corners = copies.shape[-3:-1]
    edges = [polygon_edges(copies).reshape(*copies.shape[:-3], count * corners, 2, 2)]
    pairs = itertools.combinations(range(count), 2)
    edges += [np.stack((copies[..., i, :, :], copies[..., j, :, :]), axis=-2) for i, j in pairs]
    return copies.reshape(*copies.shape[:-3], count * corners, 2), np.concatenate(edges, axis=-3)


def pad_polygons(polygons: Sequence[np.ndarray]) -> np.ndarray:
    """``(N, ..., K, 2)`` the ``(..., K_i, 2)`` polygons stacked, each padded to the most vertices by
    repeating its last one (a zero-length edge); ``(0, 1, 2)`` for none."""
    if len(polygons) == 0:
        return np.zeros((0, 1, 2), dtype=np.float64)
    polygons = [np.asarray(p, dtype=np.float64) for p in polygons]
    size = max(p.shape[-2] for p in polygons)
    return np.stack([np.concatenate((p, np.repeat(p[..., -1:, :], size - p.shape[-2], axis=-2)), axis=-2) for p in polygons])


def penetration_depths(footprints: np.ndarray, regions: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """How far ``(..., K, 2)`` convex footprints reach into ``(..., R, 2)`` convex regions along
    ``(..., 2)`` unit directions: the shortest move back against the direction that separates them,
    metres, 0 where they do not overlap. Broadcast over the leading axes.

    Moving back by t shifts every projection on an axis n by −t·(d·n); the footprint leaves the
    region at the first t where some edge normal separates them."""
    footprints, regions = np.asarray(footprints, dtype=np.float64), np.asarray(regions, dtype=np.float64)
    normals = [_segment_normals(polygon_edges(polygons)) for polygons in (footprints, regions)]
    batch = np.broadcast_shapes(footprints.shape[:-2], regions.shape[:-2], np.shape(directions)[:-1])
    axes = np.concatenate([np.broadcast_to(n, (*batch, *n.shape[-2:])) for n in normals], axis=-2)  # (..., S, 2)
    along = np.sum(axes * np.asarray(directions)[..., None, :], axis=-1)
    axes = np.where(along[..., None] < 0.0, -axes, axes)  # each axis faces the move, so that −t·|d·n| shifts it
    to_axes = np.swapaxes(axes, -1, -2)
    footprint_high, region_low = (footprints @ to_axes).max(axis=-2), (regions @ to_axes).min(axis=-2)
    # An axis square to the move never separates them, and a nearly square one only at t = ∞.
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        exits = np.where(np.abs(along) > 0.0, (footprint_high - region_low) / np.abs(along), np.inf)
    overlap = ~(_separated_along(footprints, regions, axes).any(axis=-1))
    return np.where(overlap, np.maximum(exits.min(axis=-1), 0.0), 0.0)


def grow_polygon(polygon: np.ndarray, margin: float) -> np.ndarray:
    """Push every vertex ``margin`` metres away from the vertex centroid along each axis separately
    (the original's ``nonblocking`` hull growth: v + sign(v − centre)·margin). ``(K, 2)``."""
    poly = np.asarray(polygon, dtype=np.float64)
    return poly + np.sign(poly - poly.mean(axis=0)) * margin


def segment_intersects_polygon(start: np.ndarray, end: np.ndarray, polygon: np.ndarray) -> bool:
    """Whether the segment ``start``–``end`` (``(2,)`` each) touches the convex ``(K, 2)`` polygon."""
    segment = np.stack((np.asarray(start, dtype=np.float64), np.asarray(end, dtype=np.float64)))
    return polygons_overlap(segment, polygon)


# --------------------------------------------------------------------------------------------------
# Objects in the world
# --------------------------------------------------------------------------------------------------

_BOX_SIGNS = np.array(list(itertools.product((-1.0, 1.0), repeat=3)))  # (8, 3)


@lru_cache(maxsize=64)
def _local_part_corners(spec: ObjectSpec) -> np.ndarray:
    """``(P, 8, 3)`` corners of the convex parts in the object frame, metres."""
    return np.stack(
        [np.asarray(part.center) + 0.5 * _BOX_SIGNS * np.asarray(part.size) for part in spec.convex_parts()]
    )


@dataclass(frozen=True)
class ObjectGeometry:
    """An object's analytic geometry in a pose (world frame, metres).

    Attributes:
        name: object name.
        spec: its specification.
        position: ``(3,)`` origin.
        quaternion: ``(4,)`` orientation, xyzw.
        part_corners: ``(P, 8, 3)`` corners of each convex part.
        aabb: ``(2, 3)`` exact world AABB ``[min, max]`` of the convex parts.
        footprints: one counter-clockwise ``(K, 2)`` xy polygon per convex part (the projection).
    """

    name: str
    spec: ObjectSpec
    position: np.ndarray
    quaternion: np.ndarray
    part_corners: np.ndarray
    aabb: np.ndarray
    footprints: tuple[np.ndarray, ...]

    @property
    def min_z(self) -> float:
        """Lowest point, metres."""
        return float(self.aabb[0, 2])

    @property
    def max_z(self) -> float:
        """Highest point, metres."""
        return float(self.aabb[1, 2])

    def bounding_box_footprint(self) -> np.ndarray:
        """``(K, 2)`` xy projection of the object's whole rotated bounding box. For a box and the
        rack it equals their single convex part; ``nonblocking`` also treats the hook as this one
        hull, as the original did."""
        low, high = self.spec.local_bounds()
        corners = (low + (high - low) * (_BOX_SIGNS + 1) / 2) @ quat_to_matrix(self.quaternion).T + self.position
        return convex_hull_2d(corners[:, :2])


def object_geometry(name: str, pose: ObjectPose, spec: ObjectSpec | None = None) -> ObjectGeometry:
    """Analytic world geometry of ``name`` in ``pose``; ``spec`` defaults to ``OBJECTS[name]``."""
    spec = spec if spec is not None else object_spec(name)
    rotation = quat_to_matrix(pose.quaternion)
    corners = _local_part_corners(spec) @ rotation.T + pose.position
    flat = corners.reshape(-1, 3)
    aabb = np.stack((flat.min(axis=0), flat.max(axis=0)))
    footprints = tuple(convex_hull_2d(part[:, :2]) for part in corners)
    return ObjectGeometry(name, spec, pose.position, pose.quaternion, corners, aabb, footprints)


def object_geometry_memo() -> Callable[[str, ObjectPose], ObjectGeometry]:
    """:func:`object_geometry`, computed once per name and exact pose (for one batch of many states,
    most of whose objects stand where they stood)."""
    memo: dict[tuple[str, bytes, bytes], ObjectGeometry] = {}

    def geometry(name: str, pose: ObjectPose) -> ObjectGeometry:
        key = (name, np.asarray(pose.position, dtype=np.float64).tobytes(), np.asarray(pose.quaternion, dtype=np.float64).tobytes())
        if key not in memo:
            memo[key] = object_geometry(name, pose)
        return memo[key]

    return geometry


def yawed_footprints(spec: ObjectSpec, positions: np.ndarray, yaws: np.ndarray) -> np.ndarray:
    """``(..., P, 4, 2)`` counter-clockwise xy footprints of the convex parts of an object turned only
    about z, at ``(..., 3)`` positions (metres) with ``(...)`` yaws (radians): the footprints of
    :func:`object_geometry` for a batch of upright poses, without a hull per pose."""
    return yawed_polygons(_local_part_footprints(spec), positions, yaws)


def yawed_polygons(local: np.ndarray, positions: np.ndarray, yaws: np.ndarray) -> np.ndarray:
    """``(..., P, K, 2)`` world xy of ``(P, K, 2)`` or ``(..., P, K, 2)`` polygons given in a frame at
    ``(..., 2+)`` positions (metres, xy used) turned by ``(...)`` yaws (radians) about z."""
    cos, sin = np.cos(yaws)[..., None, None], np.sin(yaws)[..., None, None]
    x, y = local[..., 0], local[..., 1]
    return np.stack((cos * x - sin * y, sin * x + cos * y), axis=-1) + np.asarray(positions)[..., None, None, :2]


@lru_cache(maxsize=64)
def _local_part_footprints(spec: ObjectSpec) -> np.ndarray:
    """``(P, 4, 2)`` counter-clockwise xy corners of the convex parts in the object frame, metres."""
    signs = np.array([(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)])
    return np.stack([np.asarray(p.center[:2]) + 0.5 * signs * np.asarray(p.size[:2]) for p in spec.convex_parts()])


def world_aabb(name: str, pose: ObjectPose, spec: ObjectSpec | None = None) -> np.ndarray:
    """``(2, 3)`` exact world AABB ``[min, max]`` of the object's convex parts in ``pose``, metres."""
    return object_geometry(name, pose, spec).aabb


def is_above(a: ObjectGeometry, b: ObjectGeometry) -> bool:
    """above(a, b): min_z(aabb(a)) > max_z(aabb(b)) − 0.05."""
    return a.min_z > b.max_z - EPS_AABB


def is_intersecting(a: ObjectGeometry, b: ObjectGeometry) -> bool:
    """intersecting(a, b): some xy projection of a convex part of a overlaps one of b."""
    if np.any(a.aabb[0, :2] > b.aabb[1, :2]) or np.any(b.aabb[0, :2] > a.aabb[1, :2]):
        return False  # the xy AABBs bound the footprints: cheap early reject
    return any(polygons_overlap(pa, pb) for pa in a.footprints for pb in b.footprints)


def closest_distance(a: ObjectGeometry, b: ObjectGeometry) -> float:
    """Closest distance between two objects' convex parts, metres (0 when they overlap).

    Each part is treated as the vertical prism footprint × [part min z, part max z]. For upright
    parts that is the part itself and the distance is exact; for tilted parts the prism contains the
    part, so the distance is a lower bound (``free`` then errs on the side of rejecting a sample).
    Simulators may answer ``free`` with engine closest-point queries instead.
    """
    best = math.inf
    z_a = np.stack((a.part_corners[..., 2].min(axis=1), a.part_corners[..., 2].max(axis=1)), axis=1)
    z_b = np.stack((b.part_corners[..., 2].min(axis=1), b.part_corners[..., 2].max(axis=1)), axis=1)
    for (za, pa), (zb, pb) in itertools.product(zip(z_a, a.footprints), zip(z_b, b.footprints)):
        gap_z = max(0.0, za[0] - zb[1], zb[0] - za[1])
        best = min(best, math.hypot(polygon_distance(pa, pb), gap_z))
    return best


# --------------------------------------------------------------------------------------------------
# The three relations of goals and prompts (geometry only)
# --------------------------------------------------------------------------------------------------


def is_inhand(obj: ObjectGeometry) -> bool:
    """inhand(o): origin z > 0.40 − 0.5·size_z (the original's live test; the rack's origin is its top plate)."""
    return float(obj.position[2]) > MAX_LIFT_HEIGHT - 0.5 * obj.spec.size[2]


def is_on(a: ObjectGeometry, b: ObjectGeometry) -> bool:
    """Geometry-only on(a, b): above, footprints intersect, a not in hand, |min_z(a) − max_z(b)| < 0.04."""
    return (
        a.name != b.name
        and is_above(a, b)
        and abs(a.min_z - b.max_z) < ON_CONTACT_GAP
        and not is_inhand(a)
        and is_intersecting(a, b)
    )


def is_under(a: ObjectGeometry, b: ObjectGeometry) -> bool:
    """under(a, b): b is a receptacle (the original required the name "rack"), neither is the table, a is not above b, and the
    footprints intersect. Never true together with on(a, b), which requires above."""
    return (
        a.name != b.name
        and b.spec.kind is ObjectKind.RACK
        and a.spec.kind is not ObjectKind.TABLE
        and not is_above(a, b)
        and is_intersecting(a, b)
    )
