"""Object specifications of the TableEnv world (docs/guide/world.md#frames-and-objects): exact geometry, mass, colour and
the static shape features that enter the observation.

Frames: every object's origin is the centre of its bounding box, except the table and the rack, whose
origins are their top surfaces (z = 0 for the table, z = 0.16 above the table for a standing rack).
The table's pose is the identity (world origin), so its slab is offset to its centre (0.3, 0, −0.025).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import numpy as np

TABLE_CENTER_XY: tuple[float, float] = (0.3, 0.0)
"""The table's top-surface centre in the world (m); its observation row is nevertheless all zeros."""


class ObjectKind(str, Enum):
    """Object types of the symbolic layer."""

    TABLE = "table"  # unmovable support
    RACK = "rack"  # unmovable receptacle
    HOOK = "hook"  # movable tool
    BOX = "box"  # movable


@dataclass(frozen=True)
class BoxPart:
    """One rigid box of a compound object, in the object frame.

    Attributes:
        name: part name (``"top"``, ``"leg_0"``, ``"handle"``...).
        size: ``(3,)`` full extents in metres.
        center: ``(3,)`` centre in the object frame, metres.
    """

    name: str
    size: tuple[float, float, float]
    center: tuple[float, float, float]


@dataclass(frozen=True)
class CylinderPart:
    """A cylinder (``axis`` "x" or "y") or, with ``length == 0``, a sphere of the hook, object frame."""

    name: str
    radius: float
    length: float
    axis: str
    center: tuple[float, float, float]


@dataclass(frozen=True)
class HookGeometry:
    """The L-shaped hook's parameters, metres except ``handle_y`` (a sign/scale)."""

    head_length: float = 0.20
    handle_length: float = 0.38
    handle_y: float = -1.0
    radius: float = 0.02

    @property
    def lateral_offset(self) -> float:
        """Lateral offset ``dy`` of the head: ½·sign(handle_y)·max(0, (|handle_y| − 1)·h/2 + r) (−0.01 for the default)."""
        h, r = self.head_length, self.radius
        return 0.5 * float(np.sign(self.handle_y)) * max(0.0, (abs(self.handle_y) - 1.0) * h / 2 + r)

    def cylinders(self) -> tuple[CylinderPart, ...]:
        """Handle (axis x), head (axis y) and the joint sphere, as built by the simulators."""
        h, l_, r, hy, dy = self.head_length, self.handle_length, self.radius, self.handle_y, self.lateral_offset
        return (
            CylinderPart("handle", r, l_, "x", (-r / 2, hy * h / 2 - dy, 0.0)),
            CylinderPart("head", r, h, "y", ((l_ - r) / 2, -dy, 0.0)),
            CylinderPart("joint", r, 0.0, "x", ((l_ - r) / 2, hy * h / 2 - dy, 0.0)),
        )

    def mass_split(self, mass: float) -> tuple[float, ...]:
        """``mass`` (kg) split over :meth:`cylinders` in proportion to their lengths (the joint
        sphere's to its radius), as the simulators build the hook: its centre of mass lies about 8 cm
        from the bounding box's centre, towards the corner where handle and head meet."""
        total = self.head_length + self.handle_length + self.radius
        return tuple(mass * (part.length if part.length > 0.0 else part.radius) / total for part in self.cylinders())

    def footprint(self) -> tuple[BoxPart, ...]:
        """The two boxes used by the geometric tests: handle 0.40 × 0.04 and head 0.04 × 0.22."""
        h, l_, r = self.head_length, self.handle_length, self.radius
        handle_y_center = self.handle_y * h / 2 - self.lateral_offset + 0.0
        return (
            BoxPart("handle", (l_ + r, 2 * r, 2 * r), (0.0, handle_y_center, 0.0)),
            BoxPart("head", (2 * r, h + 2 * abs(-self.lateral_offset), 2 * r), ((l_ - r) / 2, 0.0, 0.0)),
        )

    @property
    def size(self) -> tuple[float, float, float]:
        """Overall bounding-box size (l + r, h + 2·|head centre y|, 2r) = (0.40, 0.22, 0.04)."""
        return (self.handle_length + self.radius, self.head_length + 2 * abs(self.lateral_offset), 2 * self.radius)


@dataclass(frozen=True)
class ObjectSpec:
    """Everything static about one object.

    Attributes:
        name: the object's name in tasks, prompts and goals (``"red_box"``).
        kind: its symbolic type.
        size: ``(3,)`` bounding-box extents in metres (the table's is its slab).
        mass: kilograms (0 for static bodies).
        rgba: display colour.
        hook: hook parameters, only for the hook.
    """

    name: str
    kind: ObjectKind
    size: tuple[float, float, float]
    mass: float
    rgba: tuple[float, float, float, float]
    hook: HookGeometry | None = None

    @property
    def movable(self) -> bool:
        """Boxes and the hook can be grasped; the table and the rack cannot."""
        return self.kind in (ObjectKind.BOX, ObjectKind.HOOK)

    def shape_features(self) -> np.ndarray:
        """``(6,) float32`` static observation features (indices 6–11 of a row, docs/guide/world.md#observation-encoding):
        box_size xyz for boxes and the rack, head_length, handle_length, handle_y for the hook, zeros
        for the table."""
        features = np.zeros(6, dtype=np.float32)
        if self.kind in (ObjectKind.BOX, ObjectKind.RACK):
            features[:3] = self.size
        elif self.kind is ObjectKind.HOOK and self.hook is not None:
            features[3:] = (self.hook.head_length, self.hook.handle_length, self.hook.handle_y)
        return features

    def parts(self) -> tuple[BoxPart, ...]:
        """Rigid box parts in the object frame (rack: plate, 4 legs, 2 stabilisers; box: itself;
        table: its slab below z = 0). The hook is made of cylinders: see :meth:`HookGeometry.cylinders`."""
        sx, sy, sz = self.size
        if self.kind is ObjectKind.RACK:
            legs = tuple(
                BoxPart(f"leg_{i}", (0.01, 0.01, sz - 0.02), (ix * (sx - 0.01) / 2, iy * (sy - 0.01) / 2, -sz / 2))
                for i, (ix, iy) in enumerate(((1, 1), (1, -1), (-1, 1), (-1, -1)))
            )
            bars = tuple(
                BoxPart(f"bar_{i}", (sx, 0.01, 0.01), (0.0, iy * (sy - 0.01) / 2, -sz + 0.005))
                for i, iy in enumerate((1, -1))
            )
            return (BoxPart("top", (sx, sy, 0.01), (0.0, 0.0, -0.005)), *legs, *bars)
        if self.kind is ObjectKind.TABLE:
            # Offset by the top-surface centre: the table's reported pose is the identity.
            return (BoxPart("slab", self.size, (*TABLE_CENTER_XY, -self.size[2] / 2)),)
        if self.kind is ObjectKind.HOOK and self.hook is not None:
            return self.hook.footprint()
        return (BoxPart("body", self.size, (0.0, 0.0, 0.0)),)

    def centre_of_mass(self) -> np.ndarray:
        """``(3,)`` centre of mass in the object frame, metres, as the simulators build the body: the
        hook's mass split over its cylinders (:meth:`HookGeometry.mass_split`), any other object's
        equally over its :meth:`parts` (a box's is its origin)."""
        if self.kind is ObjectKind.HOOK and self.hook is not None:
            centres, shares = [part.center for part in self.hook.cylinders()], self.hook.mass_split(1.0)
        else:
            parts = self.parts()
            centres, shares = [part.center for part in parts], (1.0 / len(parts),) * len(parts)
        return np.asarray(shares) @ np.asarray(centres, dtype=np.float64)

    def resting_segments(self) -> np.ndarray:
        """``(S, 2, 2)`` xy segments (start, end) in the object frame, metres, whose convex hull is
        where the object touches a flat support it stands on upright: a box's bottom edges; the
        hook's cylinder axes (a cylinder lying down touches along its axis; the joint sphere's
        point is on both; MuJoCo's capsules of the same length touch along all but their 2 cm
        caps). Its centre of mass must lie within the part of that hull that the support holds
        up, or it tips (Place's ``balance_margin``)."""
        if self.kind is ObjectKind.HOOK and self.hook is not None:
            segments = []
            for part in self.hook.cylinders():
                if part.length > 0.0:
                    half = np.array((part.length / 2, 0.0) if part.axis == "x" else (0.0, part.length / 2))
                    segments.append((np.asarray(part.center[:2]) - half, np.asarray(part.center[:2]) + half))
            return np.asarray(segments, dtype=np.float64)
        corners = [np.asarray(p.center[:2]) + 0.5 * np.array(signs) * np.asarray(p.size[:2])
                   for p in self.convex_parts() for signs in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
        corners = np.asarray(corners, dtype=np.float64).reshape(-1, 4, 2)
        return np.stack((corners, np.roll(corners, -1, axis=1)), axis=2).reshape(-1, 2, 2)

    def convex_parts(self) -> tuple[BoxPart, ...]:
        """The convex boxes that the geometric tests use, object frame: the box
        itself, the rack's full bounding box (not its 7 parts), the hook's two footprint boxes, the
        table's slab."""
        if self.kind is ObjectKind.RACK:
            return (BoxPart("bbox", self.size, (0.0, 0.0, -self.size[2] / 2)),)
        return self.parts()

    def local_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """``((3,), (3,))`` min and max corners of the bounding box in the object frame, metres."""
        sx, sy, sz = self.size
        half = np.array([sx / 2, sy / 2, sz / 2])
        if self.kind is ObjectKind.RACK:
            return np.array([-sx / 2, -sy / 2, -sz]), np.array([sx / 2, sy / 2, 0.0])
        if self.kind is ObjectKind.TABLE:
            # The table's pose is the identity (its observation row is zeros), so its slab sits at
            # the world position of its top-surface centre: x ∈ [−0.3, 0.9], y ∈ [−0.45, 0.45].
            cx, cy = TABLE_CENTER_XY
            return np.array([cx - sx / 2, cy - sy / 2, -sz]), np.array([cx + sx / 2, cy + sy / 2, 0.0])
        return -half, half


HOOK_GEOMETRY = HookGeometry()

OBJECTS: dict[str, ObjectSpec] = {
    spec.name: spec
    for spec in (
        ObjectSpec("table", ObjectKind.TABLE, (1.2, 0.9, 0.05), 0.0, (0.82, 0.74, 0.62, 1.0)),
        ObjectSpec("rack", ObjectKind.RACK, (0.22, 0.32, 0.16), 1.0, (0.4, 0.2, 0.0, 1.0)),
        ObjectSpec("hook", ObjectKind.HOOK, HOOK_GEOMETRY.size, 0.1, (0.6, 0.6, 0.6, 1.0), hook=HOOK_GEOMETRY),
        ObjectSpec("red_box", ObjectKind.BOX, (0.050, 0.050, 0.118), 0.1, (1.0, 0.0, 0.0, 1.0)),
        ObjectSpec("blue_box", ObjectKind.BOX, (0.050, 0.050, 0.106), 0.1, (0.0, 0.0, 1.0, 1.0)),
        ObjectSpec("yellow_box", ObjectKind.BOX, (0.057, 0.057, 0.066), 0.1, (1.0, 1.0, 0.0, 1.0)),
        ObjectSpec("cyan_box", ObjectKind.BOX, (0.058, 0.058, 0.070), 0.1, (0.0, 1.0, 1.0, 1.0)),
    )
}
"""Every object of the world, by name."""


def object_spec(name: str) -> ObjectSpec:
    """The specification of ``name``; raises ``KeyError`` naming the known objects."""
    try:
        return OBJECTS[name]
    except KeyError:
        raise KeyError(f"unknown object {name!r}; known objects: {', '.join(OBJECTS)}") from None
