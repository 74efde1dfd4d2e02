import mujoco
import numpy as np
import pytest

from t2m_core.simulation.kinematics import null_target_facing
from t2m_core.simulation.robot import EE_OFFSET_FROM_LINK7, Q_HOME
from t2m_mujoco.controller import InverseKinematics
from t2m_mujoco.scene import build_scene


@pytest.fixture(scope="module")
def scene():
    return build_scene(("table", "rack", "hook", "red_box"))


def test_home_pose_matches_reference(scene):
    data = mujoco.MjData(scene.model)
    data.qpos[scene.robot.arm_qpos] = Q_HOME
    mujoco.mj_kinematics(scene.model, data)
    ee = data.site_xpos[scene.robot.ee_site]
    np.testing.assert_allclose(ee, [0.402, 0.0, 0.400], atol=2e-3)
    rotation = data.site_xmat[scene.robot.ee_site].reshape(3, 3)
    np.testing.assert_allclose(rotation[:, 2], [0, 0, -1], atol=1e-6)  # pointing down
    link7 = scene.model.body("panda_link7").id
    offset = rotation.T @ (ee - data.xpos[link7])
    np.testing.assert_allclose(offset, [0, 0, EE_OFFSET_FROM_LINK7], atol=1e-9)


def test_pads_close_along_world_y_at_home(scene):
    data = mujoco.MjData(scene.model)
    data.qpos[scene.robot.arm_qpos] = Q_HOME
    data.qpos[scene.robot.finger_qpos] = 0.02
    mujoco.mj_kinematics(scene.model, data)
    left, right = (data.geom_xpos[g] for g in scene.robot.pad_geoms)
    gap = left - right
    assert abs(gap[0]) < 1e-9 and abs(gap[2]) < 1e-9 and abs(abs(gap[1]) - 0.05) < 1e-9


def test_scene_objects_follow_specs(scene):
    model = scene.model
    assert model.body_mass[scene.body["rack"]] == pytest.approx(1.0)
    assert model.body_mass[scene.body["hook"]] == pytest.approx(0.1)
    assert model.body_mass[scene.body["red_box"]] == pytest.approx(0.1)
    box = model.geom("red_box/body")
    np.testing.assert_allclose(2 * box.size, [0.05, 0.05, 0.118])
    np.testing.assert_allclose(box.rgba, [1, 0, 0, 1])
    assert sum(1 for g in range(model.ngeom) if model.geom_bodyid[g] == scene.body["rack"]) == 7


def _solve_reachable(scene, position, yaw):
    """IK from q_home for ``position`` (m) at ``yaw`` (rad); asserts a reachable solution whose EE
    lands within 0.1 mm, and returns the solver and the reached ``(3, 3)`` rotation."""
    ik = InverseKinematics(scene.model, scene.robot)
    target = np.array(position)
    result = ik.solve(target, ik.target_rotation(yaw), Q_HOME, null_target_facing(target))
    assert result.reachable, result
    reached, rotation = ik.forward(result.q)
    np.testing.assert_allclose(reached, target, atol=1e-4)
    return ik, rotation


@pytest.mark.parametrize("position,yaw", [((0.5, 0.2, 0.03), 0.5), ((0.4, -0.3, 0.4), 1.0), ((0.65, 0.0, 0.05), 3.0)])
def test_ik_reaches_table_poses(scene, position, yaw):
    _solve_reachable(scene, position, yaw)


def test_ik_reports_out_of_reach(scene):
    ik = InverseKinematics(scene.model, scene.robot)
    target = np.array([1.3, 0.0, 0.4])
    assert not ik.solve(target, ik.target_rotation(0.0), Q_HOME, null_target_facing(target)).reachable


@pytest.mark.parametrize("position,yaw", [((0.65, -0.1, 0.4), -2.66), ((0.65, -0.1, 0.4), 2.8), ((0.5, 0.4, 0.4), 2.9)])
def test_ik_turns_the_wrist_the_long_way_for_yaws_near_half_turn(scene, position, yaw):
    """From the home seed DLS turns joint 7 the short way into its limit; the solver must retry
    with the wrist turned the other way (these yaws are within joint 7's ±2.9 rad)."""
    ik, rotation = _solve_reachable(scene, position, yaw)
    np.testing.assert_allclose(rotation, ik.target_rotation(yaw), atol=1e-3)


def test_reach_at_lift_height_is_the_stretched_arm_not_the_solver(scene):
    """0.73 m is reachable top-down at z = 0.40; just beyond it the best solution has the elbow
    (joint 4) straight (≈ −0.47 rad with the Panda's link offsets), far from its −0.07 rad limit."""
    ik = InverseKinematics(scene.model, scene.robot)
    near, far = np.array([0.73, 0.0, 0.4]), np.array([0.75, 0.0, 0.4])
    assert ik.solve(near, ik.target_rotation(0.0), Q_HOME, null_target_facing(near)).reachable
    beyond = ik.solve(far, ik.target_rotation(0.0), Q_HOME, null_target_facing(far), iterations=400)
    assert not beyond.reachable
    assert -0.7 < beyond.q[3] < -0.3


def test_sweep_impedance_is_the_operational_space_law(scene):
    """SweepImpedance's torques equal Jᵀ·Λ·(K·e − D·v) computed densely from mj_fullM, Λ =
    (J·M⁻¹·Jᵀ + εI)⁻¹, with the force capped at SOFT_MAX_FORCE and the moment at SOFT_MAX_TORQUE."""
    from t2m_core.simulation import rules
    from t2m_core.simulation.kinematics import rotation_error, rotation_z
    from t2m_mujoco.controller import SweepImpedance

    model, robot = scene.model, scene.robot
    data = mujoco.MjData(model)
    data.qpos[robot.arm_qpos] = Q_HOME + np.array([0.2, 0.1, -0.1, 0.15, 0.05, -0.1, 0.3])
    data.qvel[robot.arm_dof] = np.array([0.01, -0.02, 0.005, 0.01, -0.01, 0.02, 0.005])
    mujoco.mj_forward(model, data)  # M and its factor at this posture
    site = robot.ee_site
    position = data.site_xpos[site].copy()
    rotation = data.site_xmat[site].reshape(3, 3).copy()
    target_rotation = rotation_z(0.002) @ rotation

    def dense(position_target):
        jacobian = np.zeros((6, model.nv))
        mujoco.mj_jacSite(model, data, jacobian[:3], jacobian[3:], site)
        full = np.zeros((model.nv, model.nv))
        mujoco.mj_fullM(model, data, full)
        inertia = np.linalg.inv(jacobian @ np.linalg.solve(full, jacobian.T) + rules.OPERATIONAL_INERTIA_REGULARISATION * np.eye(6))
        velocity = jacobian @ data.qvel
        stiffness, damping = rules.SOFT_ORIENTATION_GAINS
        acceleration = np.concatenate((
            rules.SOFT_POSITION_GAINS * (position_target - position) - rules.SOFT_VELOCITY_GAINS * velocity[:3],
            stiffness * rotation_error(target_rotation, rotation) - damping * velocity[3:],
        ))
        wrench = inertia @ acceleration
        force = np.linalg.norm(wrench[:3])
        if force > rules.SOFT_MAX_FORCE:
            wrench[:3] *= rules.SOFT_MAX_FORCE / force
        torque = np.linalg.norm(wrench[3:])
        if torque > rules.SOFT_MAX_TORQUE:
            wrench[3:] *= rules.SOFT_MAX_TORQUE / torque
        return (jacobian.T @ wrench)[robot.arm_dof], force

    impedance = SweepImpedance(model, data, robot)
    for offset, capped in ((np.array([0.002, 0.0, 0.0]), False), (np.array([0.3, -0.2, 0.0]), True)):
        expected, force = dense(position + offset)
        assert bool(force > rules.SOFT_MAX_FORCE) == capped
        impedance.apply(position + offset, target_rotation)
        np.testing.assert_allclose(data.qfrc_applied[robot.arm_dof], expected, rtol=1e-9, atol=1e-9)
    impedance.end()
    assert not np.any(data.qfrc_applied[robot.arm_dof])
