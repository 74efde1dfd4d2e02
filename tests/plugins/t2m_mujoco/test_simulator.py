"""MuJoCo-specific simulator behaviour; what every backend must do is in tests/simulators/."""

import numpy as np
import pytest

from t2m_core.domain.primitives import get_primitive
from t2m_core.tasks import load_task
from t2m_mujoco.options import MujocoOptions
from t2m_mujoco.simulator import MujocoSimulator
from tests.simulators.backends import sweep_into_rack


@pytest.fixture(scope="module")
def sim():
    simulator = MujocoSimulator(MujocoOptions(render_width=160, render_height=120))
    yield simulator
    simulator.close()


def test_held_object_moves_only_with_the_hand(sim):
    """A held object is rigidly attached in the reference: its creep inside the soft weld does not
    count as moving (it made every settle after a grasp wait ~1 s), the hand's motion does."""
    sim.reset(load_task("task0"), seed=0)
    rng = np.random.default_rng(0)
    pick = sim.execute("pick", ["yellow_box"], get_primitive("pick").heuristic_action(sim.geometric_state(), ["yellow_box"], rng))
    assert pick.success, pick.failure
    world = sim.world
    box = world.scene.dof_address["yellow_box"]
    world.data.qvel[:] = 0.0
    world.data.qvel[box + 3 : box + 6] = 0.005  # the box turning in the weld, rad/s
    world.forward()
    world.forget_twist()
    assert world.moving_objects() == []
    world.data.qvel[world.robot.arm_dof[0]] = 0.05  # the arm turning, rad/s
    world.forward()  # body velocities from the new qvel
    world.forget_twist()
    assert world.moving_objects() == ["yellow_box"]


def test_blocked_sweep_under_the_reference_threshold_creeps(sim, monkeypatch):
    """The counter-check of tests/simulators' blocked-sweep test: MuJoCo's soft friction lets the
    pressed rack creep at a few mm/s, so with the reference's 0.001 m/s the blocked sweep creeps on."""
    from t2m_core.simulation import rules

    monkeypatch.setattr(rules, "STALLED_SWEEP_SPEED", rules.STALLED_SPEED)
    ticks, _failure, _moved = sweep_into_rack(sim)
    assert ticks > 300


def test_compiled_bodies_put_their_mass_where_the_domain_says():
    """MuJoCo's own inertia of each compiled body (its centre of mass from the geoms' masses and
    shapes) lies where ``ObjectSpec.centre_of_mass`` says: the hook's at (0.060, −0.057) from its
    bounding box's centre, towards the corner of handle and head, by the lengths of its capsules."""
    from t2m_core.domain.objects import object_spec
    from t2m_mujoco.scene import build_scene

    scene = build_scene(("table", "rack", "hook", "red_box"))
    hook = object_spec("hook").hook
    lengths = np.array([hook.handle_length, hook.head_length, hook.radius])  # handle, head, joint
    by_hand = lengths @ np.array([part.center for part in hook.cylinders()]) / lengths.sum()
    np.testing.assert_allclose(by_hand[:2], [0.0597, -0.0567], atol=1e-4)
    for name in ("hook", "red_box", "rack"):
        body = scene.body[name]
        np.testing.assert_allclose(scene.model.body_ipos[body], object_spec(name).centre_of_mass(), atol=1e-9, err_msg=name)
        assert scene.model.body_mass[body] == pytest.approx(object_spec(name).mass)
