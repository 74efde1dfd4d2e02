"""The Panda as PyBullet loads it, PyBullet's IK, and the controller choices of t2m_pybullet."""

import numpy as np
import pytest

from t2m_core.domain.primitives import get_primitive
from t2m_core.simulation.kinematics import null_target_facing, rotation_error, rotation_z
from t2m_core.simulation.robot import EE_OFFSET_FROM_LINK7, FINGER_OPEN, Q_HOME
from t2m_core.tasks import load_task
from t2m_pybullet.controller import InverseKinematics
from t2m_pybullet.simulator import PybulletSimulator


@pytest.fixture(scope="module")
def ik():
    solver = InverseKinematics()
    yield solver
    solver.close()


@pytest.fixture(scope="module")
def sim():
    simulator = PybulletSimulator()
    yield simulator
    simulator.close()


def test_home_pose_matches_reference(ik):
    position, rotation = ik.forward(Q_HOME)
    np.testing.assert_allclose(position, [0.402, 0.0, 0.400], atol=2e-3)
    np.testing.assert_allclose(rotation[:, 2], [0, 0, -1], atol=1e-6)  # pointing down
    link7 = ik.client.getLinkState(ik.robot.body, ik.robot.arm[6], computeForwardKinematics=1)
    link7_rotation = np.array(ik.client.getMatrixFromQuaternion(link7[5])).reshape(3, 3)
    np.testing.assert_allclose(link7_rotation.T @ (position - np.array(link7[4])), [0, 0, EE_OFFSET_FROM_LINK7], atol=1e-7)


def test_pads_close_along_world_y_at_home(ik):
    client, robot = ik.client, ik.robot
    ik.forward(Q_HOME)
    for finger in robot.fingers:
        client.resetJointState(robot.body, finger, 0.02)
    left, right = (np.array(client.getLinkState(robot.body, pad, computeForwardKinematics=1)[4]) for pad in robot.pads)
    gap = left - right
    assert abs(gap[0]) < 1e-9 and abs(gap[2]) < 1e-9 and abs(abs(gap[1]) - 0.05) < 1e-9
    for finger in robot.fingers:
        client.resetJointState(robot.body, finger, FINGER_OPEN)


@pytest.mark.parametrize(
    "position,yaw",
    [((0.5, 0.2, 0.03), 0.5), ((0.4, -0.3, 0.4), 1.0), ((0.65, -0.1, 0.4), -2.66),
     ((0.651, -0.272, 0.4), 0.213), ((0.611, -0.375, 0.4), 0.014)],  # the last two near the arm's reach
)
def test_ik_reaches_poses_within_a_tenth_of_a_millimetre(ik, position, yaw):
    target, rotation = np.array(position), rotation_z(yaw) @ ik.home_rotation
    result = ik.solve(target, rotation, Q_HOME, null_target_facing(target))
    assert result.reachable, result
    reached, reached_rotation = ik.forward(result.q)
    np.testing.assert_allclose(reached, target, atol=1e-4)
    assert np.linalg.norm(rotation_error(rotation, reached_rotation)) < 1e-3


def test_ik_reports_out_of_reach(ik):
    target = np.array([0.78, 0.0, 0.4])  # the Panda reaches 0.73 m top-down at the lift height
    assert not ik.solve(target, ik.home_rotation, Q_HOME, null_target_facing(target)).reachable


def test_straight_motion_keyframes_stay_on_the_line(sim):
    """A 0.3 m straight move low over the table: every keyframe of PyBullet's warm-started IK lands
    on the line (a few iterations per keyframe drifted centimetres, into the table)."""
    from t2m_core.domain.primitives import MotionKind, MotionStep

    sim.reset(load_task("task0"), seed=0)
    world, executor = sim.world, sim.executor
    executor.begin_primitive()
    start, goal = np.array([0.62, 0.1, 0.05]), np.array([0.35, -0.05, 0.05])
    assert executor.run(MotionStep(MotionKind.MOVE, "start", np.array([0.62, 0.1, 0.4]), 0.3)).failure is None
    assert executor.run(MotionStep(MotionKind.DESCEND, "down", start, 0.3)).failure is None
    _ticks, keyframes = executor._straight_keyframes(start, 0.3, goal, -0.2, world.arm_q(), world.arm_q(), 30, null_target_facing(goal))
    for q in keyframes[1:-1]:
        position, _ = world.ik.forward(q)
        offset = position - start
        along = offset @ (goal - start) / np.linalg.norm(goal - start)
        assert np.linalg.norm(offset - along * (goal - start) / np.linalg.norm(goal - start)) < 1e-3


def test_closing_jaw_centres_the_box(sim):
    """The finger motors press with 20 N and a gear keeps the fingers symmetric: the box ends
    centred between the pads and where it stood (70 N motors shoved jaw and box sideways)."""
    sim.reset(load_task("task0"), seed=0)
    before = sim.geometric_state()
    pick = sim.execute("pick", ["yellow_box"], get_primitive("pick").to_normalized(np.zeros(4)))
    assert pick.success, pick.failure
    box_xy = pick.state.objects["yellow_box"].position[:2]
    np.testing.assert_allclose(box_xy, pick.state.ee_position[:2], atol=2e-3)
    np.testing.assert_allclose(box_xy, before.objects["yellow_box"].position[:2], atol=2e-3)
    left, right = (sim.world.client.getJointState(sim.world.robot.body, finger)[0] for finger in sim.world.robot.fingers)
    assert abs(left - right) < 1e-3


def test_robot_base_rests_on_the_table_without_contact(sim):
    """PyBullet's default collision filter lets a pair collide when *either* group matches a mask;
    the world uses the "both" rule, so the base (which collides only with objects) never touches the table."""
    sim.reset(load_task("task0"), seed=0)
    world = sim.world
    assert world.client.getContactPoints(world.robot.body, world.scene.body["table"], -1) == ()


def test_connecting_prints_nothing_on_stdout(capfd):
    """``t2m sim demo --json`` writes JSON to stdout: PyBullet's ``argv[0]=`` must not land there."""
    from t2m_pybullet.client import connect

    client = connect()
    try:
        assert capfd.readouterr().out == ""
    finally:
        client.disconnect()
