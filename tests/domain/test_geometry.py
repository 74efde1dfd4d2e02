"""Rotations, polygons and the analytic object geometry (docs/guide/world.md#geometric-tests)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from t2m_core.domain import geometry as g
from t2m_core.domain.objects import object_spec
from t2m_core.domain.state import ObjectPose
from tests.domain.scenes import RACK_BEYOND, RACK_IN_WORKSPACE, finite, on_table, quaternions

unit_quats = st.lists(st.floats(-1, 1, **finite), min_size=4, max_size=4).filter(
    lambda v: np.linalg.norm(v) > 0.1
).map(lambda v: np.asarray(v) / np.linalg.norm(v))


@given(unit_quats)
def test_matrix_quaternion_round_trip(q: np.ndarray) -> None:
    rotation = g.quat_to_matrix(q)
    np.testing.assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(rotation) == pytest.approx(1.0)
    back = g.matrix_to_quat(rotation)
    assert back[3] >= 0
    assert abs(np.dot(back, q)) == pytest.approx(1.0, abs=1e-9)


@given(unit_quats)
def test_axis_angle_round_trip(q: np.ndarray) -> None:
    aa = g.quat_to_axis_angle(q)
    assert np.linalg.norm(aa) <= math.pi + 1e-9
    assert g.quat_angle(g.axis_angle_to_quat(aa), q) < 1e-7


@given(unit_quats, unit_quats, st.lists(st.floats(-1, 1, **finite), min_size=3, max_size=3))
def test_composition_rotates_like_matrices(q1: np.ndarray, q2: np.ndarray, v: list[float]) -> None:
    composed = g.quat_to_matrix(g.quat_multiply(q1, q2))
    np.testing.assert_allclose(composed, g.quat_to_matrix(q1) @ g.quat_to_matrix(q2), atol=1e-12)
    np.testing.assert_allclose(g.rotate(g.quat_conjugate(q1), g.rotate(q1, v)), v, atol=1e-12)


def test_batched_rotations_match_single() -> None:
    rng = np.random.default_rng(3)
    quats = g.quat_normalize(rng.normal(size=(5, 7, 4)))
    batched = g.quat_to_axis_angle(quats)
    assert batched.shape == (5, 7, 3)
    np.testing.assert_allclose(batched[2, 4], g.quat_to_axis_angle(quats[2, 4]))
    single = g.matrix_to_quat(g.quat_to_matrix(quats[1, 1]))
    np.testing.assert_allclose(g.matrix_to_quat(g.quat_to_matrix(quats))[1, 1], single)


def test_small_rotations_stay_exact() -> None:
    aa = np.array([1e-10, -2e-10, 3e-10])
    np.testing.assert_allclose(g.quat_to_axis_angle(g.axis_angle_to_quat(aa)), aa, rtol=1e-6)
    assert g.quat_angle(g.yaw_to_quat(0.0), g.yaw_to_quat(1e-6)) == pytest.approx(1e-6, rel=1e-6)


def test_yaw_and_wrapping() -> None:
    assert g.wrap_angle(math.pi) == pytest.approx(-math.pi)
    assert g.wrap_angle(-math.pi) == pytest.approx(-math.pi)
    assert g.wrap_angle(3 * math.pi / 2) == pytest.approx(-math.pi / 2)
    np.testing.assert_allclose(g.wrap_angle(np.array([0.1, 2 * math.pi + 0.1])), [0.1, 0.1])
    assert g.quat_yaw(g.yaw_to_quat(2.5)) == pytest.approx(2.5)
    np.testing.assert_allclose(g.quat_yaw(g.yaw_to_quat(np.array([0.3, -1.2]))), [0.3, -1.2])
    np.testing.assert_allclose(g.quat_to_axis_angle(g.yaw_to_quat(0.7)), [0, 0, 0.7], atol=1e-12)


def test_compose_poses() -> None:
    position, quat = g.compose_poses([1, 0, 0], g.yaw_to_quat(math.pi / 2), [1, 0, 0], g.yaw_to_quat(0.1))
    np.testing.assert_allclose(position, [1, 1, 0], atol=1e-12)
    assert g.quat_yaw(quat) == pytest.approx(math.pi / 2 + 0.1)


def test_upright_is_a_tilt_test() -> None:
    # an unrotated object is upright (the original's axis test said it was not).
    assert g.is_upright(np.array([0.0, 0.0, 0.0, 1.0]))
    assert g.is_upright(g.yaw_to_quat(2.0))
    assert g.is_upright(g.axis_angle_to_quat([math.radians(8.0), 0, 0]))
    assert not g.is_upright(g.axis_angle_to_quat([0, math.radians(8.2), 0]))
    assert not g.is_upright(g.axis_angle_to_quat([math.pi / 2, 0, 0]))
    batch = np.stack([g.yaw_to_quat(1.0), g.axis_angle_to_quat([1.0, 0, 0])])
    np.testing.assert_array_equal(g.is_upright(batch), [True, False])


@pytest.mark.parametrize(
    ("shift", "angle_deg", "moved"),
    [(0.049, 0.0, False), (0.05, 0.0, True), (0.0, 4.9, False), (0.0, 5.01, True), (0.03, 3.0, False)],
)
def test_did_move_thresholds(shift: float, angle_deg: float, moved: bool) -> None:
    before_q = g.yaw_to_quat(0.3)
    after_q = g.quat_multiply(g.yaw_to_quat(math.radians(angle_deg)), before_q)
    assert g.did_move([0.5, 0, 0], before_q, [0.5, shift, 0], after_q) is moved


def test_convex_hull_drops_interior_points() -> None:
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
    hull = g.convex_hull_2d(np.vstack([square, [[0.5, 0.5], [0.2, 0.7], [0.5, 0.0]]]))
    assert len(hull) == 4
    assert {tuple(p) for p in hull} == {tuple(p) for p in square}
    area = 0.5 * np.sum(hull[:, 0] * np.roll(hull[:, 1], -1) - np.roll(hull[:, 0], -1) * hull[:, 1])
    assert area == pytest.approx(1.0)  # counter-clockwise


def _square(cx: float, cy: float, half: float = 0.5, yaw: float = 0.0) -> np.ndarray:
    corners = np.array([[-half, -half], [half, -half], [half, half], [-half, half]])
    rotation = np.array([[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]])
    return corners @ rotation.T + [cx, cy]


def test_polygon_overlap_and_distance() -> None:
    assert g.polygons_overlap(_square(0, 0), _square(0.9, 0))
    assert g.polygons_overlap(_square(0, 0), _square(1.0, 0))  # touching counts
    assert not g.polygons_overlap(_square(0, 0), _square(1.01, 0))
    # A diamond near the square's corner: separated only along the diamond's own edge normal.
    diamond = _square(1.2, 1.2, half=0.5, yaw=math.pi / 4)
    assert not g.polygons_overlap(_square(0, 0), diamond)
    assert g.polygon_distance(_square(0, 0), _square(1.3, 0)) == pytest.approx(0.3)
    assert g.polygon_distance(_square(0, 0), _square(1.5, 1.5)) == pytest.approx(math.sqrt(0.5))
    assert g.polygon_distance(_square(0, 0), _square(0.2, 0.2)) == 0.0
    # Collinear but disjoint segments do not overlap.
    assert not g.polygons_overlap(np.array([[0, 0], [1, 0]]), np.array([[2, 0], [3, 0]]))
    assert g.segment_intersects_polygon([0, 0], [2, 0], _square(1, 0, half=0.1))
    assert not g.segment_intersects_polygon([0, 0], [2, 0], _square(1, 0.3, half=0.1))


@settings(max_examples=60)
@given(
    st.floats(-2, 2, **finite), st.floats(-2, 2, **finite), st.floats(0, math.pi, **finite),
    st.floats(0.05, 0.8, **finite),
)
def test_polygon_distance_agrees_with_dense_sampling(cx: float, cy: float, yaw: float, half: float) -> None:
    a, b = _square(0, 0), _square(cx, cy, half, yaw)
    distance = g.polygon_distance(a, b)
    assert (distance == 0.0) == g.polygons_overlap(a, b)
    # Sample both boundaries densely: the sampled minimum is an upper bound close to the true one.
    t = np.linspace(0, 1, 200)[:, None]
    boundary = lambda p: np.concatenate([p[i] + t * (p[(i + 1) % 4] - p[i]) for i in range(4)])  # noqa: E731
    sampled = np.min(np.linalg.norm(boundary(a)[:, None] - boundary(b)[None], axis=2))
    if distance > 0:
        assert distance <= sampled + 1e-12
        assert sampled - distance < 0.02


@settings(max_examples=80)
@given(
    st.lists(st.floats(-0.6, 0.6, **finite), min_size=6, max_size=6),
    st.floats(0, math.pi, **finite),
    st.floats(0.02, 0.3, **finite),
    quaternions(),
)
def test_batched_distances_match_the_polygon_distance(shifts: list[float], yaw: float, half: float, q) -> None:
    # A square translated to three places and a (possibly tilted, so 4-8 sided) box footprint, padded.
    square = _square(0, 0, 0.1, yaw)
    shift_rows = np.array(shifts).reshape(3, 2)
    points, edges = g.translation_hull(square, shift_rows)
    box = g.object_geometry("red_box", ObjectPose([0.2, 0.1, 0.3], q)).footprints[0] * half / 0.025
    obstacles = g.pad_polygons([box, _square(0.3, -0.2, half, yaw)])
    distances = g.hull_distances(points, edges, obstacles, g.polygon_edges(obstacles))
    union = g.convex_hull_2d(points)
    expected = [g.polygon_distance(union, box), g.polygon_distance(union, _square(0.3, -0.2, half, yaw))]
    np.testing.assert_allclose(distances, expected, atol=1e-12)


@settings(max_examples=80)
@given(
    st.floats(-0.3, 0.3, **finite), st.floats(-0.3, 0.3, **finite), st.floats(0, 2 * math.pi, **finite), quaternions()
)
def test_penetration_depth_is_the_shortest_separating_move(x: float, y: float, heading: float, q) -> None:
    footprint = g.object_geometry("red_box", ObjectPose([x, y, 0.3], q)).footprints[0]
    region = _square(0.0, 0.0, 0.15, 0.4)
    direction = np.array([math.cos(heading), math.sin(heading)])
    depth = float(g.penetration_depths(footprint, region, direction))
    assert g.polygons_overlap(footprint, region) or depth == 0.0
    assert not g.polygons_overlap(footprint - (depth + 1e-9) * direction, region)
    if depth > 1e-6:
        assert g.polygons_overlap(footprint - (depth - 1e-6) * direction, region)


@settings(max_examples=60)
@given(st.floats(-0.3, 0.3, **finite), st.floats(-0.3, 0.3, **finite), st.floats(0, 2 * math.pi, **finite), quaternions())
def test_signed_distance_is_the_gap_or_minus_the_shortest_separating_move(x: float, y: float, yaw: float, q) -> None:
    footprint = g.object_geometry("red_box", ObjectPose([x, y, 0.3], q)).footprints[0]
    region = g.pad_polygons([_square(0.0, 0.0, 0.15, yaw), footprint])[0]  # padded to the footprint's vertex count
    signed = float(g.signed_hull_distances(footprint, g.polygon_edges(footprint), region, g.polygon_edges(region)))
    if signed >= 0.0:  # apart (or touching): the plain distance
        assert signed == pytest.approx(g.polygon_distance(footprint, region), abs=1e-12)
        return
    # Overlapping: minus the shortest move that separates them, in any direction (the least of the
    # directional depths over 3 600 headings, within the grid's 0.05°)
    headings = np.linspace(0.0, 2 * math.pi, 3600, endpoint=False)
    directions = np.column_stack((np.cos(headings), np.sin(headings)))
    shortest = g.penetration_depths(footprint, region, directions).min()
    assert -signed <= shortest + 1e-12 and shortest <= -signed * (1 + 1e-5) + 1e-12


def test_signed_distance_of_two_squares() -> None:
    a = _square(0.0, 0.0)
    cases = {(1.3, 0.0): 0.3, (0.8, 0.0): -0.2, (0.9, 0.95): -0.05, (0.0, 0.0): -1.0}  # shift of b -> signed distance
    for (dx, dy), expected in cases.items():
        b = _square(dx, dy)
        assert float(g.signed_hull_distances(a, g.polygon_edges(a), b, g.polygon_edges(b))) == pytest.approx(expected, abs=1e-12)


def test_yawed_footprints_are_the_object_footprints() -> None:
    positions, yaws = np.array([[0.5, 0.1, 0.03], [0.2, -0.3, 0.4]]), np.array([0.3, -2.0])
    batch = g.yawed_footprints(object_spec("hook"), positions, yaws)  # (2, 2 parts, 4, 2)
    for position, yaw, parts in zip(positions, yaws, batch, strict=True):
        geometry = g.object_geometry("hook", ObjectPose(position, g.yaw_to_quat(yaw)))
        for part, footprint in zip(parts, geometry.footprints, strict=True):
            np.testing.assert_allclose(g.convex_hull_2d(part), footprint, atol=1e-12)


def test_inside_margins_measure_to_the_nearest_edge_and_go_negative_beyond() -> None:
    square = g.convex_hull_2d(np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]))
    padded = g.pad_polygons([square, np.array([[0.0, 0.0], [2.0, 0.0], [0.0, 2.0]])])  # the square gains no vertex
    points = np.array([[0.5, 0.5], [0.1, 0.7], [1.2, 0.5], [0.5, 0.5]])
    margins = g.inside_margins(points, padded[[0, 0, 0, 1]])
    # the centre 0.5 from every side; 0.1 from the left side; 0.2 beyond the right side; inside the
    # triangle, 0.5 from both legs and (2 − 1) / √2 from the hypotenuse
    np.testing.assert_allclose(margins, [0.5, 0.1, -0.2, 0.5], atol=1e-12)
    moved = g.pad_polygons([square])[0] + [0.0, 0.3]  # a padding-free square shifted up by 0.3 m
    assert g.inside_margins(np.array([0.5, 0.2]), moved) == pytest.approx(-0.1)


def test_clip_segments_keep_the_part_inside_a_convex_polygon() -> None:
    square = g.pad_polygons([np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])])[0]
    segments = np.array([
        [[-1.0, 0.5], [2.0, 0.5]],  # across: cut at both sides
        [[0.2, 0.2], [0.6, 0.7]],  # inside: unchanged
        [[2.0, 2.0], [3.0, 3.0]],  # outside
        [[0.5, 1.5], [0.5, 0.25]],  # entering from above, ending inside
        [[-0.5, 0.5], [0.5, -0.5]],  # touching the corner (0, 0) only
    ])
    clipped, inside = g.clip_segments(segments, square)
    assert inside.tolist() == [True, True, False, True, True]
    np.testing.assert_allclose(clipped[[0, 1, 3, 4]], [[[0.0, 0.5], [1.0, 0.5]], [[0.2, 0.2], [0.6, 0.7]],
                                                      [[0.5, 1.0], [0.5, 0.25]], [[0.0, 0.0], [0.0, 0.0]]], atol=1e-12)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.floats(-1, 1), st.floats(-1, 1)), min_size=3, max_size=8), st.tuples(st.floats(-1.2, 1.2), st.floats(-1.2, 1.2)))
def test_hull_margins_equal_the_margins_inside_the_built_hull(points: list, query: tuple) -> None:
    points, query = np.array(points), np.array(query)
    hull = g.convex_hull_2d(points)
    (ax, ay), (bx, by) = (hull[1] - hull[0], hull[2] - hull[0]) if len(hull) >= 3 else ((0, 0), (0, 0))
    if abs(ax * by - ay * bx) < 1e-6:
        return  # degenerate: measured below
    assert g.hull_margins(points, np.ones(len(points), dtype=bool), query) == pytest.approx(g.inside_margins(query, hull), abs=1e-9)


def test_hull_margins_of_a_line_a_point_or_nothing_have_no_inside() -> None:
    points = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [5.0, 5.0]])
    query = np.array([0.25, 0.1])
    assert g.hull_margins(points, np.array([True, True, True, False]), query) == pytest.approx(0.1)
    assert g.hull_margins(points, np.array([True, True, False, False]), query) == pytest.approx(-0.1)  # the x axis
    assert g.hull_margins(points, np.array([False, False, True, False]), query) == pytest.approx(-math.hypot(0.25, 0.9))
    assert g.hull_margins(points, np.zeros(4, dtype=bool), query) == -np.inf


def test_the_hook_rests_on_its_axes_with_its_weight_a_handle_radius_inside() -> None:
    # handle: x from -0.20 to 0.18 at y = -0.09; head: y from -0.09 to 0.11 at x = 0.18 (cylinders' axes)
    hook = object_spec("hook")
    np.testing.assert_allclose(hook.resting_segments(), [[[-0.20, -0.09], [0.18, -0.09]], [[0.18, -0.09], [0.18, 0.11]]], atol=1e-12)
    # its centre of mass lies 3.3 cm from the handle's axis, the nearest side of the triangle they span
    margin = g.hull_margins(hook.resting_segments().reshape(-1, 2), np.ones(4, dtype=bool), hook.centre_of_mass()[:2])
    assert margin == pytest.approx(-0.0567 + 0.09, abs=2e-4)
    box = object_spec("red_box")  # a box rests on its bottom face: its four edges
    np.testing.assert_allclose(np.sort(box.resting_segments()[:, 0], axis=0), np.sort(g.convex_hull_2d(
        np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * np.array(box.size[:2]) / 2), axis=0), atol=1e-12)


def test_grow_polygon_moves_vertices_outward_per_axis() -> None:
    grown = g.grow_polygon(_square(1, 1, half=0.1), 0.05)
    np.testing.assert_allclose(grown.min(axis=0), [0.85, 0.85])
    np.testing.assert_allclose(grown.max(axis=0), [1.15, 1.15])


def test_table_geometry_spans_the_table() -> None:
    table = g.object_geometry("table", ObjectPose(np.zeros(3)))
    np.testing.assert_allclose(table.aabb, [[-0.3, -0.45, -0.05], [0.9, 0.45, 0.0]])


def test_hook_uses_its_two_footprint_boxes() -> None:
    hook = g.object_geometry("hook", ObjectPose([0.5, 0.0, 0.02]))
    np.testing.assert_allclose(hook.aabb, [[0.3, -0.11, 0.0], [0.7, 0.11, 0.04]], atol=1e-12)
    assert len(hook.footprints) == 2
    handle, head = hook.footprints
    np.testing.assert_allclose([handle.min(axis=0), handle.max(axis=0)], [[0.3, -0.11], [0.7, -0.07]], atol=1e-12)
    np.testing.assert_allclose([head.min(axis=0), head.max(axis=0)], [[0.66, -0.11], [0.70, 0.11]], atol=1e-12)
    # Turned by 90°, the handle lies along y.
    turned = g.object_geometry("hook", ObjectPose([0.5, 0.0, 0.02], g.yaw_to_quat(math.pi / 2)))
    np.testing.assert_allclose(turned.aabb[:, :2], [[0.39, -0.2], [0.61, 0.2]], atol=1e-12)
    # nonblocking's whole-bounding-box hull covers the L's empty corner.
    box_hull = hook.bounding_box_footprint()
    np.testing.assert_allclose([box_hull.min(axis=0), box_hull.max(axis=0)], [[0.3, -0.11], [0.7, 0.11]], atol=1e-12)


def test_rack_uses_its_full_bounding_box() -> None:
    rack = g.object_geometry("rack", RACK_IN_WORKSPACE)  # yaw π/2: x and y extents swap
    np.testing.assert_allclose(rack.aabb, [[0.28, -0.44, 0.0], [0.60, -0.22, 0.16]], atol=1e-12)
    assert len(rack.footprints) == 1
    beyond = g.object_geometry("rack", RACK_BEYOND)
    np.testing.assert_allclose(beyond.aabb, [[0.71, -0.16, 0.0], [0.93, 0.16, 0.16]], atol=1e-12)


def test_tilted_box_aabb_is_exact() -> None:
    pose = ObjectPose([0.5, 0.0, 0.2], g.axis_angle_to_quat([math.pi / 2, 0, 0]))  # red box lying on its side
    box = g.object_geometry("red_box", pose)
    np.testing.assert_allclose(box.aabb, [[0.475, -0.059, 0.175], [0.525, 0.059, 0.225]], atol=1e-12)
    np.testing.assert_allclose(g.world_aabb("red_box", pose), box.aabb)


def test_closest_distance_between_objects() -> None:
    a = g.object_geometry("red_box", on_table("red_box", 0.5, 0.0))
    b = g.object_geometry("blue_box", on_table("blue_box", 0.6, 0.0))
    assert g.closest_distance(a, b) == pytest.approx(0.05)
    touching = g.object_geometry("blue_box", on_table("blue_box", 0.55, 0.0))
    assert g.closest_distance(a, touching) == 0.0
    stacked = g.object_geometry("blue_box", ObjectPose([0.5, 0.0, 0.118 + 0.02 + 0.053]))
    assert g.closest_distance(a, stacked) == pytest.approx(0.02)
    diagonal = g.object_geometry("blue_box", on_table("blue_box", 0.6, 0.1))
    assert g.closest_distance(a, diagonal) == pytest.approx(math.hypot(0.05, 0.05))


@given(quaternions())
def test_footprints_contain_the_projected_corners(q: np.ndarray) -> None:
    box = g.object_geometry("cyan_box", ObjectPose([0.5, 0.1, 0.3], q))
    footprint = box.footprints[0]
    for corner in box.part_corners[0, :, :2]:
        assert g.polygon_distance(footprint, corner[None, :]) == 0.0
    np.testing.assert_allclose(footprint.min(axis=0), box.aabb[0, :2], atol=1e-9)
