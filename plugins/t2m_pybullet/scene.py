"""Builds the PyBullet bodies of a TableEnv scene from the domain's object specifications.

One set of bodies per set of present objects (absent objects are simply not built: not in the
observation, not physical, docs/guide/world.md#absent-objects). Every object follows
:data:`t2m_core.domain.objects.OBJECTS`: the table slab, the rack as one compound of 7 boxes whose
frame is its top surface, the hook as two cylinders and a sphere (the original's shapes), the boxes.

PyBullet combines frictions by product, as in the original: boxes and the hook 0.5, the table and
the rack 1.0, so a box slides on the table with 0.5 (:mod:`t2m_core.simulation.scene`).

A PyBullet base pose is the pose of its centre of mass; :class:`SceneBodies` converts between that
and the object frame of the domain (the rack's top surface, the hook's bounding-box centre).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from t2m_core.domain.geometry import quat_to_matrix
from t2m_core.domain.objects import ObjectKind, object_spec
from t2m_core.simulation.scene import FLOOR_Z, OBJECT_FRICTION, TABLE_FRICTION
from t2m_pybullet.robot_model import OBJECT_GROUP, ROBOT_GROUP, TABLE_GROUP

FLOOR_RGBA = (0.30, 0.33, 0.37, 1.0)
PARKED_Z = -0.5
"""Metres: where objects wait below the table until a reset places them."""
_QUARTER_ABOUT_Y = (0.0, math.sin(math.pi / 4), 0.0, math.cos(math.pi / 4))
"""A cylinder's axis is its local z: this turns it onto x."""
_QUARTER_ABOUT_X = (math.sin(math.pi / 4), 0.0, 0.0, math.cos(math.pi / 4))
"""… and this onto y."""


@dataclass(frozen=True)
class SceneBodies:
    """The bodies of one scene.

    Attributes:
        object_names: present objects in task order (``table`` first when present).
        body: object name -> PyBullet body id (the table's is its static slab).
        com_offset: free object name -> ``(3,)`` centre of mass in the object frame, metres.
        free_names: the objects that are not the static table, in task order.
        floor: the floor's body id.
    """

    object_names: tuple[str, ...]
    body: dict[str, int]
    com_offset: dict[str, np.ndarray]
    free_names: tuple[str, ...]
    floor: int

    def object_pose(self, name: str, com_position, orientation) -> tuple[np.ndarray, np.ndarray]:
        """Object-frame ``((3,) position m, (4,) xyzw quaternion)`` of a body whose centre of mass is at
        ``com_position`` with ``orientation``."""
        quaternion = np.array(orientation, dtype=np.float64)
        return np.array(com_position, dtype=np.float64) - quat_to_matrix(quaternion) @ self.com_offset[name], quaternion

    def com_position(self, name: str, position: np.ndarray, quaternion: np.ndarray) -> np.ndarray:
        """``(3,)`` world centre of mass of ``name`` at the object-frame pose (``position``, ``quaternion``)."""
        return np.asarray(position, dtype=np.float64) + quat_to_matrix(np.asarray(quaternion)) @ self.com_offset[name]


def build_scene(client, object_names: tuple[str, ...]) -> SceneBodies:
    """Create the floor, the table and the present objects in ``client`` (objects parked below the table).

    Raises:
        KeyError: an unknown object name (the message lists the known ones).
        ValueError: duplicated names.
    """
    import pybullet

    if len(set(object_names)) != len(object_names):
        raise ValueError(f"object names repeat: {object_names}")
    specs = [object_spec(name) for name in object_names]
    floor = _static_box(client, pybullet, (3.0, 3.0, 0.01), (0.3, 0.0, FLOOR_Z - 0.01), FLOOR_RGBA)
    client.setCollisionFilterGroupMask(floor, -1, TABLE_GROUP, OBJECT_GROUP)
    bodies: dict[str, int] = {}
    offsets: dict[str, np.ndarray] = {}
    for index, spec in enumerate(specs):
        if spec.kind is ObjectKind.TABLE:
            (slab,) = spec.parts()
            body = _static_box(client, pybullet, tuple(s / 2 for s in slab.size), slab.center, spec.rgba)
            client.changeDynamics(body, -1, lateralFriction=TABLE_FRICTION)
            client.setCollisionFilterGroupMask(body, -1, TABLE_GROUP, OBJECT_GROUP | ROBOT_GROUP)
        else:
            body, offsets[spec.name] = _free_body(client, pybullet, spec, (3.0 * index, 0.0, PARKED_Z))
        bodies[spec.name] = body
    free = tuple(spec.name for spec in specs if spec.kind is not ObjectKind.TABLE)
    return SceneBodies(tuple(object_names), bodies, offsets, free, floor)


def _static_box(client, pybullet, half, center, rgba) -> int:
    collision = client.createCollisionShape(pybullet.GEOM_BOX, halfExtents=list(half))
    visual = client.createVisualShape(pybullet.GEOM_BOX, halfExtents=list(half), rgbaColor=list(rgba))
    return client.createMultiBody(0.0, collision, visual, list(center))


def _free_body(client, pybullet, spec, parked: tuple[float, float, float]) -> tuple[int, np.ndarray]:
    """A movable compound body of ``spec`` (mass split over its parts); returns its id and centre of
    mass in the object frame."""
    if spec.kind is ObjectKind.HOOK:
        parts = []
        for part in spec.hook.cylinders():
            if part.length == 0.0:
                parts.append((pybullet.GEOM_SPHERE, {"radius": part.radius}, part.center, (0, 0, 0, 1)))
            else:
                turn = _QUARTER_ABOUT_Y if part.axis == "x" else _QUARTER_ABOUT_X
                parts.append((pybullet.GEOM_CYLINDER, {"radius": part.radius, "length": part.length}, part.center, turn))
    else:
        parts = [(pybullet.GEOM_BOX, {"halfExtents": [s / 2 for s in box.size]}, box.center, (0, 0, 0, 1)) for box in spec.parts()]
    com = spec.centre_of_mass()  # the mass split over the parts as the domain says (the hook's by length)
    collision = client.createCollisionShapeArray(
        shapeTypes=[p[0] for p in parts],
        radii=[p[1].get("radius", 0.0) for p in parts],
        halfExtents=[p[1].get("halfExtents", [0.0, 0.0, 0.0]) for p in parts],
        lengths=[p[1].get("length", 0.0) for p in parts],
        collisionFramePositions=[list(np.array(p[2]) - com) for p in parts],
        collisionFrameOrientations=[list(p[3]) for p in parts],
    )
    visual = client.createVisualShapeArray(
        shapeTypes=[p[0] for p in parts],
        radii=[p[1].get("radius", 0.0) for p in parts],
        halfExtents=[p[1].get("halfExtents", [0.0, 0.0, 0.0]) for p in parts],
        lengths=[p[1].get("length", 0.0) for p in parts],
        rgbaColors=[list(spec.rgba)] * len(parts),
        visualFramePositions=[list(np.array(p[2]) - com) for p in parts],
        visualFrameOrientations=[list(p[3]) for p in parts],
    )
    body = client.createMultiBody(spec.mass, collision, visual, list(np.array(parked) + com))
    friction = TABLE_FRICTION if spec.kind is ObjectKind.RACK else OBJECT_FRICTION
    client.changeDynamics(body, -1, lateralFriction=friction)
    client.setCollisionFilterGroupMask(body, -1, OBJECT_GROUP, TABLE_GROUP | OBJECT_GROUP | ROBOT_GROUP)
    return body, com
