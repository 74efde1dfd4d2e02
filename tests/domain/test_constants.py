"""Workspace constants and zones (docs/guide/world.md#constants-and-zones)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from t2m_core.domain import constants as c
from t2m_core.domain.constants import DEFAULT_ZONE, ZONES, beyond_workspace, in_workspace


def test_reference_values() -> None:
    assert (c.MAX_LIFT_HEIGHT, c.WORKSPACE_RADIUS, c.WORKSPACE_X_MIN) == (0.40, 0.70, 0.40)
    assert (c.OPERATIONAL_X_MIN, c.OPERATIONAL_X_MAX, c.OBSTRUCTION_X_MIN) == (0.50, 0.60, 0.575)
    assert (c.EPS_AABB, c.EPS_ALIGN, c.EPS_TWIST, c.EPS_TIPPING) == (0.05, 0.99, 0.001, 0.1)
    assert (c.D_PULL, c.D_PUSH) == (0.05, 0.05)  # the published value is the default
    assert c.DISTURBANCE_ROTATION == pytest.approx(math.radians(5))
    assert c.TABLE_PLACE_X_RANGE == (0.28, 0.70)


@pytest.mark.parametrize(
    ("zone", "x", "y", "inside"),
    [
        ("inworkspace", 0.40, 0.0, True),
        ("inworkspace", 0.3999, 0.0, False),
        ("inworkspace", 0.69, 0.0, True),
        ("inworkspace", 0.60, 0.40, False),  # r = 0.72
        ("incollisionzone", 0.40, 0.2, True),
        ("incollisionzone", 0.50, 0.0, False),  # upper bound exclusive
        ("inoperationalzone", 0.50, -0.3, True),
        ("inoperationalzone", 0.60, 0.0, False),
        ("inoperationalzone", 0.55, 0.45, False),  # r = 0.71
        ("inobstructionzone", 0.575, 0.0, True),
        ("inobstructionzone", 0.5749, 0.0, False),
        ("inobstructionzone", 0.65, 0.3, False),  # r = 0.716
        ("beyondworkspace", 0.70, 0.0, True),  # r ≥ 0.70 is beyond
        ("beyondworkspace", 0.6999, 0.0, False),
        ("beyondworkspace", 0.55, 0.45, True),
        ("inoodzone", -0.3, 0.0, True),
        ("inoodzone", 0.85, 0.4, True),
    ],
)
def test_zone_membership(zone: str, x: float, y: float, inside: bool) -> None:
    assert ZONES[zone].contains(x, y) is inside


def test_zone_sampling_ranges() -> None:
    ranges = {name: zone.x_range for name, zone in ZONES.items()}
    assert ranges["inworkspace"] == (0.40, 0.70)
    assert ranges["incollisionzone"] == (0.40, 0.50)
    assert ranges["inoperationalzone"] == (0.50, 0.60)
    assert ranges["inobstructionzone"] == (0.575, 0.70)
    assert ranges["beyondworkspace"][0] == pytest.approx(0.536, abs=1e-3)
    assert ranges["beyondworkspace"][1] == 0.90
    assert ranges["inoodzone"] == (-0.30, 0.28)
    assert DEFAULT_ZONE.x_range == (0.28, 0.90)
    assert all(zone.y_range == (-0.45, 0.45) for zone in ZONES.values())
    hook_scaled = {name for name, zone in ZONES.items() if zone.hook_margin_scale == 0.25}
    assert hook_scaled == {"incollisionzone", "inoperationalzone", "inobstructionzone"}


def test_beyond_lower_bound_is_where_the_table_edge_meets_the_radius() -> None:
    x = ZONES["beyondworkspace"].x_range[0]
    assert math.hypot(x, 0.45) == pytest.approx(0.70)
    assert not beyond_workspace(x - 1e-6, 0.45)
    assert beyond_workspace(x + 1e-6, 0.45)


def test_membership_is_vectorised() -> None:
    xs = np.array([0.45, 0.39, 0.69, 0.80])
    ys = np.array([0.0, 0.0, 0.2, 0.0])
    expected = [in_workspace(x, y) for x, y in zip(xs, ys)]
    np.testing.assert_array_equal(in_workspace(xs, ys), expected)
    assert expected == [True, False, False, False]
    np.testing.assert_array_equal(beyond_workspace(xs, ys), [False, False, True, True])
