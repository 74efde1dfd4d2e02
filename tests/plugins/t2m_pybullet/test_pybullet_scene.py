"""The PyBullet bodies follow the domain's object geometry (docs/guide/world.md#frames-and-objects)."""

import numpy as np
import pytest

from t2m_core.domain.geometry import world_aabb
from t2m_core.tasks import load_task
from t2m_pybullet.simulator import PybulletSimulator


@pytest.fixture(scope="module")
def scene():
    simulator = PybulletSimulator()
    simulator.reset(load_task("task3"), seed=0)  # table, rack, hook and four boxes
    yield simulator.world
    simulator.close()


def test_engine_bounds_match_the_analytic_bounds(scene):
    """Placed unrotated (PyBullet bounds a rotated compound by its rotated local box), each body's
    engine AABB is its analytic one: the rack's top at its origin, the hook's cylinders spanning the
    0.40 × 0.22 × 0.04 box, the boxes' sizes (within PyBullet's AABB padding)."""
    from t2m_core.domain.state import ObjectPose

    poses = {name: ObjectPose(np.array([0.5, 1.0 * index, 0.5])) for index, name in enumerate(scene.free_names)}
    scene.place_objects(poses)
    for name, pose in poses.items():
        low, high = (np.array(corner) for corner in scene.client.getAABB(scene.scene.body[name]))
        np.testing.assert_allclose(np.stack((low, high)), world_aabb(name, pose), atol=2e-3, err_msg=name)
    state = scene.geometric_state()
    for name, pose in poses.items():  # and the reported pose is the object frame, not the centre of mass
        np.testing.assert_allclose(state.objects[name].position, pose.position, atol=1e-12, err_msg=name)


def test_masses_follow_the_specs(scene):
    from t2m_core.domain.objects import object_spec

    for name in scene.free_names:
        assert scene.client.getDynamicsInfo(scene.scene.body[name], -1)[0] == pytest.approx(object_spec(name).mass)
