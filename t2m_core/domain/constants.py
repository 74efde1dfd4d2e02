"""Workspace constants and zones of the TableEnv world (docs/guide/world.md#constants-and-zones).

Distances in metres, angles in radians. Every number here is the reference's default; a change
alters which scenes are sampled and which skills succeed, so none of them is a tuning knob.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from t2m_core.domain.objects import ObjectKind

# --------------------------------------------------------------------------------------------------
# Table and workspace
# --------------------------------------------------------------------------------------------------

TABLE_Z_MAX = 0.00
"""Table top height; an object whose centre is below it has fallen off ("below the table")."""
TABLE_X_RANGE = (-0.30, 0.90)
"""Full x extent of the table top."""
TABLE_X_MIN = 0.28
"""Near (robot-side) limit of table placements and of the random robot pose."""
TABLE_Y_MIN, TABLE_Y_MAX = -0.45, 0.45
"""Table y extent."""
WORKSPACE_X_MIN = 0.40
"""In the workspace requires x ≥ 0.40."""
OPERATIONAL_X_MIN, OPERATIONAL_X_MAX = 0.50, 0.60
"""The operational zone band."""
OBSTRUCTION_X_MIN = 0.575
"""The obstruction zone requires x ≥ 0.575."""
WORKSPACE_RADIUS = 0.70
"""In the workspace requires ‖(x, y)‖ < 0.70; beyond it requires ‖(x, y)‖ ≥ 0.70."""
MAX_LIFT_HEIGHT = 0.40
"""z of every pre- and post-waypoint of every skill; also the reference of the ``inhand`` test."""
MAX_LIFT_RADIUS = 0.70
"""Far x limit of table placements: the table reaches 0.90, placements stop here, as in the original."""
TABLE_PLACE_X_RANGE = (TABLE_X_MIN, MAX_LIFT_RADIUS)
"""x range of the Place action's table rectangle."""

# --------------------------------------------------------------------------------------------------
# Tolerances
# --------------------------------------------------------------------------------------------------

EPS_AABB = 0.05
"""Tolerance of the ``above`` test: min_z(a) > max_z(b) − 0.05."""
EPS_ALIGN = 0.99
"""Uprightness threshold on (R·ẑ)·ẑ (tilt ≤ ≈ 8.1°; docs/guide/deviations.md#uprightness-is-a-tilt-test)."""
EPS_TWIST = 0.001
"""An object is moving when any twist component is ≥ this (m/s or rad/s)."""
EPS_TIPPING = 0.1
"""Probability of a tipped sample when ``tippable`` is given."""
ON_CONTACT_GAP = 0.04
"""``on(a, b)`` requires |min_z(a) − max_z(b)| < 0.04."""
DISTURBANCE_TRANSLATION = 0.05
"""A non-argument object that moved ≥ 0.05 m was disturbed (``did_move``)."""
DISTURBANCE_ROTATION = math.radians(5.0)
"""… or that rotated ≥ 5° (0.0873 rad)."""

D_PULL = 0.05
"""Minimum decrease of a pulled box's planar distance to the base, metres.

The published 0.05 m is the default; the original used 0.01 m, and primitives take it as a
parameter (docs/guide/deviations.md#pull-and-push-displacement)."""
D_PUSH = 0.05
"""Minimum increase of a pushed box's planar distance to the base, metres (as :data:`D_PULL`)."""

# --------------------------------------------------------------------------------------------------
# Rack placement (``poslimit``, ``aligned``)
# --------------------------------------------------------------------------------------------------

RACK_POSLIMIT_CENTERS: dict[str, tuple[float, float]] = {
    "inworkspace": (0.44, -0.33),
    "beyondworkspace": (0.82, 0.00),
}
"""Rack xy centre per zone; the sampled position stays within ±:data:`RACK_POSLIMIT_HALF_WIDTH`."""
RACK_POSLIMIT_HALF_WIDTH = 0.01
"""Half-width of the rack's position box, metres."""

ALIGNED_YAW_STD = 0.05
"""Std of the ``aligned`` yaw noise, radians."""
ALIGNED_YAW_MIN_ABS = 0.002
"""``aligned`` redraws its noise until |noise| ≥ this (kept for sampling parity with the original)."""
ALIGNED_YAW_MAX_DEVIATION = 0.1
"""``aligned`` clips the yaw to mean ± 0.1 rad."""
RACK_ALIGNED_YAW: dict[str, float] = {"inworkspace": 0.5 * math.pi, "beyondworkspace": 0.0}
"""Mean yaw of an aligned rack per zone (0 otherwise)."""

# --------------------------------------------------------------------------------------------------
# Zones
# --------------------------------------------------------------------------------------------------

HOOK_ZONE_MARGIN_SCALE = 0.25
"""Fraction of its half-extent margin applied to the hook in the collision, operational and
obstruction zones."""


@dataclass(frozen=True)
class Zone:
    """A region of the table, with a sampling box and a membership test .

    The sampling x-range is used when *generating* a pose (y is always the table's); the membership
    test is used when *checking* one. They differ on purpose (e.g. ``inworkspace`` samples
    x ∈ [0.40, 0.70] but accepts any x ≥ 0.40 with r < 0.70).

    Attributes:
        name: the predicate name (``"inworkspace"``) or ``"default"``.
        x_range: ``(x_min, x_max)`` sampling range, metres.
        x_min: membership lower x bound (inclusive), or ``None``.
        x_max: membership upper x bound (exclusive), or ``None``.
        radius: ``"inside"`` (r < 0.70), ``"outside"`` (r ≥ 0.70) or ``None`` (no radius test).
        hook_margin_scale: fraction of the half-extent margin applied to the hook when sampling.
        always_true: the membership test accepts every position (``inoodzone``, ``default``).
    """

    name: str
    x_range: tuple[float, float]
    x_min: float | None = None
    x_max: float | None = None
    radius: str | None = None
    hook_margin_scale: float = 1.0
    always_true: bool = False

    @property
    def y_range(self) -> tuple[float, float]:
        """Sampling y range: always the table's, metres."""
        return (TABLE_Y_MIN, TABLE_Y_MAX)

    def contains(self, x: float | np.ndarray, y: float | np.ndarray) -> bool | np.ndarray:
        """Membership of world xy position(s), metres; scalars give a ``bool``, arrays ``(N,) bool``."""
        x_arr, y_arr = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
        inside = np.ones(np.broadcast(x_arr, y_arr).shape, dtype=bool)
        if not self.always_true:
            if self.x_min is not None:
                inside &= x_arr >= self.x_min
            if self.x_max is not None:
                inside &= x_arr < self.x_max
            if self.radius is not None:
                r = np.hypot(x_arr, y_arr)
                inside &= (r < WORKSPACE_RADIUS) if self.radius == "inside" else (r >= WORKSPACE_RADIUS)
        return bool(inside) if inside.ndim == 0 else inside


BEYOND_WORKSPACE_X_MIN = WORKSPACE_RADIUS * math.cos(math.asin(TABLE_Y_MAX / WORKSPACE_RADIUS))
"""≈ 0.536 m: the smallest x at which a point on the table (|y| ≤ 0.45) can be beyond the workspace
radius. Lower bound of the ``beyondworkspace`` sampling box **[INFERRED]**; samples are then rejected
unless r ≥ 0.70."""

ZONES: dict[str, Zone] = {
    zone.name: zone
    for zone in (
        Zone("inworkspace", (WORKSPACE_X_MIN, WORKSPACE_RADIUS), x_min=WORKSPACE_X_MIN, radius="inside"),
        Zone(
            "incollisionzone",
            (WORKSPACE_X_MIN, OPERATIONAL_X_MIN),
            x_min=WORKSPACE_X_MIN,
            x_max=OPERATIONAL_X_MIN,
            radius="inside",
            hook_margin_scale=HOOK_ZONE_MARGIN_SCALE,
        ),
        Zone(
            "inoperationalzone",
            (OPERATIONAL_X_MIN, OPERATIONAL_X_MAX),
            x_min=OPERATIONAL_X_MIN,
            x_max=OPERATIONAL_X_MAX,
            radius="inside",
            hook_margin_scale=HOOK_ZONE_MARGIN_SCALE,
        ),
        Zone(
            "inobstructionzone",
            (OBSTRUCTION_X_MIN, WORKSPACE_RADIUS),
            x_min=OBSTRUCTION_X_MIN,
            radius="inside",
            hook_margin_scale=HOOK_ZONE_MARGIN_SCALE,
        ),
        Zone("beyondworkspace", (BEYOND_WORKSPACE_X_MIN, TABLE_X_RANGE[1]), radius="outside"),
        Zone("inoodzone", (TABLE_X_RANGE[0], TABLE_X_MIN), always_true=True),
    )
}
"""The zone predicates, by name, in canonical predicate order."""

DEFAULT_ZONE = Zone("default", (TABLE_X_MIN, TABLE_X_RANGE[1]), always_true=True)
"""Sampling box of a table placement with no zone predicate: x ∈ [0.28, 0.90]."""


def in_workspace(x: float | np.ndarray, y: float | np.ndarray) -> bool | np.ndarray:
    """x ≥ 0.40 and ‖(x, y)‖ < 0.70 (the Pick/Place reachability test), metres."""
    return ZONES["inworkspace"].contains(x, y)


def workspace_margin(x: float | np.ndarray, y: float | np.ndarray) -> float | np.ndarray:
    """Metres a world xy position lies inside the workspace of :func:`in_workspace` (the smaller of
    x − 0.40 and 0.70 − ‖(x, y)‖), negative by as much as it lies outside."""
    return np.minimum(np.asarray(x) - WORKSPACE_X_MIN, WORKSPACE_RADIUS - np.hypot(x, y))


def beyond_workspace(x: float | np.ndarray, y: float | np.ndarray) -> bool | np.ndarray:
    """‖(x, y)‖ ≥ 0.70, metres."""
    return ZONES["beyondworkspace"].contains(x, y)


def zone_of(x: float, y: float) -> str | None:
    """``"inworkspace"``, ``"beyondworkspace"`` or ``None`` for a world xy position, metres."""
    for name in ("inworkspace", "beyondworkspace"):
        if ZONES[name].contains(x, y):
            return name
    return None


# --------------------------------------------------------------------------------------------------
# Thresholds of the sampling predicates ``free`` and ``nonblocking``
# --------------------------------------------------------------------------------------------------

FREE_MIN_DISTANCE: dict[frozenset[ObjectKind], float] = {
    frozenset({ObjectKind.BOX}): 0.05,
    frozenset({ObjectKind.BOX, ObjectKind.HOOK}): 0.05,
    frozenset({ObjectKind.BOX, ObjectKind.RACK}): 0.10,
    frozenset({ObjectKind.HOOK, ObjectKind.RACK}): 0.10,
}
"""d_min of ``free`` per unordered type pair, metres; unlisted pairs are ignored."""
FREE_REDUCED_MIN_DISTANCE = 0.04
"""d_min when the other object is a rack beyond the workspace, or an ``infront(·, rack)`` is involved."""

NONBLOCKING_GROWTH: dict[tuple[ObjectKind, ObjectKind], dict[str | None, float]] = {
    (ObjectKind.BOX, ObjectKind.RACK): {"inworkspace": 3.0, "beyondworkspace": 1.5, None: 1.0},
    (ObjectKind.BOX, ObjectKind.BOX): {"inworkspace": 3.0, "beyondworkspace": 3.0, None: 3.0},
    (ObjectKind.RACK, ObjectKind.HOOK): {"inworkspace": 0.25, "beyondworkspace": 0.25, None: 0.25},
}
"""``nonblocking(t, o)`` hull growth scale by (t's type, o's type) and o's zone: the hull of o
grows by scale·max(size_x, size_y of t). The original applied 1.0 to every pair whose obstacle is in
neither zone; the reference's table gives Box–Box 3.0 and Rack–Hook 0.25 unconditionally, which we
follow."""
