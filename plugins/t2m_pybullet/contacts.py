"""Contact queries on PyBullet's contact points: the guarded-motion check, the grasp's pad test, and
the reset's robot-touch tests.

PyBullet reports the contacts of the last physics step; a point is ``(flag, bodyA, bodyB, linkA,
linkB, positionOnA, positionOnB, normalOnB (B → A), distance, normalForce, ...)``. The grasp test itself
is :func:`t2m_core.simulation.grasp.pad_grips`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from t2m_core.domain.geometry import quat_to_matrix
from t2m_core.protocols import Contact
from t2m_core.simulation.grasp import pad_grips

if TYPE_CHECKING:
    from t2m_pybullet.world import World

_LINK_A, _POSITION_ON_A, _NORMAL_ON_B, _NORMAL_FORCE = 3, 5, 7, 9


def contact_guard(world: World, forbidden: tuple[str, ...]) -> Callable[[], list[Contact]]:
    """A check returning the contacts (positive normal force) between a finger (pads and finger
    bodies) or the held object and the ``forbidden`` objects; bodies resolved when the motion starts."""
    client, robot, bodies = world.client, world.robot, world.scene.body
    watched = {*robot.finger_links, *robot.pads}
    names = {link: world.link_name(link) for link in watched}
    targets = [(name, bodies[name]) for name in forbidden if name in bodies]
    held = world.held
    held_body = bodies[held] if held else None

    def check() -> list[Contact]:
        contacts = []
        for name, body in targets:
            for point in client.getContactPoints(robot.body, body):
                if point[_LINK_A] in watched and point[_NORMAL_FORCE] > 0.0:
                    contacts.append(Contact(names[point[_LINK_A]], name, point[_NORMAL_FORCE]))
            if held_body is not None:
                contacts.extend(
                    Contact(held, name, point[_NORMAL_FORCE])
                    for point in client.getContactPoints(held_body, body)
                    if point[_NORMAL_FORCE] > 0.0
                )
        return contacts

    return check


def pads_hold(world: World, name: str) -> bool:
    """Whether both pads grip ``name`` validly (:func:`~t2m_core.simulation.grasp.pad_grips`)."""
    client, robot = world.client, world.robot
    hand = client.getLinkState(robot.body, robot.hand, computeForwardKinematics=1)
    hand_y = quat_to_matrix(np.array(hand[5]))[:, 1]
    for pad, inward in zip(robot.pads, (-hand_y, hand_y), strict=True):
        pad_center = np.array(client.getLinkState(robot.body, pad, computeForwardKinematics=1)[4])
        contacts = [
            (-np.array(point[_NORMAL_ON_B]), np.array(point[_POSITION_ON_A]))  # from the pad into the object
            for point in client.getContactPoints(robot.body, world.scene.body[name], pad)
            if point[_NORMAL_FORCE] > 0.0
        ]
        if not pad_grips(inward, pad_center, contacts):
            return False
    return True


def held_touches_robot(world: World, held: str) -> bool:
    """Whether ``held`` touches a robot link other than the fingers and pads."""
    fingers = {*world.robot.finger_links, *world.robot.pads}
    points = world.client.getContactPoints(world.robot.body, world.scene.body[held])
    return any(point[_LINK_A] not in fingers for point in points)


def objects_touch_base(world: World) -> bool:
    """Whether any free object touches the robot's base link."""
    client, robot = world.client, world.robot
    return any(client.getContactPoints(robot.body, world.scene.body[name], -1) for name in world.scene.free_names)

