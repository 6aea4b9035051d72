"""The Go1 MJCF: kinematics, inertia, joint order and limits, gains, sensors, and a stable stand."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from robots.go1 import GO1_XML_PATH, LEG_NAMES, NUM_JOINTS, load_go1_spec
from robots.mjcf_scene import build_mjcf
from semexp_bt.core.scene import SceneSpec
from semexp_bt.core.types import JointState

SPEC = load_go1_spec()
EMPTY_SCENE = SceneSpec(
    name="empty",
    title="Empty",
    seed=0,
    bounds_m=(-2.0, -2.0, 2.0, 2.0),
    objects=(),
    goal_object_id=0,
    instruction="",
)


@pytest.fixture(scope="module")
def robot_only() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(GO1_XML_PATH))


@pytest.fixture()
def on_floor() -> tuple[mujoco.MjModel, mujoco.MjData]:
    model = mujoco.MjModel.from_xml_string(build_mjcf(EMPTY_SCENE, fidelity="dynamic"))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    return model, data


def test_model_loads_with_free_base_and_twelve_actuators(robot_only: mujoco.MjModel) -> None:
    assert robot_only.nq == 7 + NUM_JOINTS
    assert robot_only.nv == 6 + NUM_JOINTS
    assert robot_only.nu == NUM_JOINTS
    assert robot_only.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE
    # Unitree quotes about 12 kg for the Go1 (trunk 5.2 kg + 4 legs of 1.88 kg).
    assert robot_only.body_subtreemass[robot_only.body("trunk").id] == pytest.approx(12.74, abs=0.05)
    assert robot_only.opt.timestep == pytest.approx(0.002)


def test_joint_and_actuator_order_is_fr_fl_rr_rl_hip_thigh_calf(robot_only: mujoco.MjModel) -> None:
    expected = [f"{leg}_{part}_joint" for leg in LEG_NAMES for part in ("hip", "thigh", "calf")]
    assert list(SPEC.joint_names) == expected
    for index, name in enumerate(expected):
        joint = robot_only.joint(name)
        assert joint.qposadr[0] == 7 + index, name
        assert joint.dofadr[0] == 6 + index, name
        assert robot_only.actuator_trnid[index, 0] == joint.id, name
    # JointState documents the same order.
    assert "FR, FL, RR, RL x (hip, thigh, calf)" in (JointState.__doc__ or "")


def test_joint_ranges_gains_and_torque_limits_match_the_yaml(robot_only: mujoco.MjModel) -> None:
    joint_ids = [robot_only.joint(name).id for name in SPEC.joint_names]
    np.testing.assert_allclose(robot_only.jnt_range[joint_ids, 0], SPEC.joint_lower_rad)
    np.testing.assert_allclose(robot_only.jnt_range[joint_ids, 1], SPEC.joint_upper_rad)
    assert all(robot_only.jnt_limited[joint_ids])
    np.testing.assert_allclose(robot_only.actuator_forcerange[:, 1], SPEC.torque_limit_nm)
    np.testing.assert_allclose(robot_only.actuator_forcerange[:, 0], -SPEC.torque_limit_nm)
    assert SPEC.torque_limit_nm[:3] == pytest.approx([23.7, 23.7, 35.55])
    # Position actuator: force = kp * ctrl - kp * q - kv * qdot.
    np.testing.assert_allclose(robot_only.actuator_gainprm[:, 0], SPEC.kp_nm_per_rad)
    np.testing.assert_allclose(robot_only.actuator_biasprm[:, 1], -SPEC.kp_nm_per_rad)
    np.testing.assert_allclose(robot_only.actuator_biasprm[:, 2], -SPEC.kd_nm_s_per_rad)
    np.testing.assert_allclose(robot_only.actuator_ctrlrange, robot_only.jnt_range[joint_ids])


def test_straight_legs_put_each_foot_thigh_plus_calf_below_its_thigh_joint(
    robot_only: mujoco.MjModel,
) -> None:
    data = mujoco.MjData(robot_only)
    data.qpos[:7] = [0, 0, 1, 1, 0, 0, 0]
    mujoco.mj_kinematics(robot_only, data)
    for leg in LEG_NAMES:
        side = 1.0 if leg.endswith("L") else -1.0
        front = 1.0 if leg.startswith("F") else -1.0
        hip = data.xpos[robot_only.body(f"{leg}_hip").id]
        thigh = data.xpos[robot_only.body(f"{leg}_thigh").id]
        foot = data.geom_xpos[robot_only.geom(f"{leg}_foot").id]
        np.testing.assert_allclose(hip, [front * 0.1881, side * 0.04675, 1.0], atol=1e-9)
        np.testing.assert_allclose(thigh - hip, [0.0, side * 0.08, 0.0], atol=1e-9)
        np.testing.assert_allclose(foot - thigh, [0.0, 0.0, -0.426], atol=1e-9)


def test_home_keyframe_puts_the_feet_on_the_floor_under_the_hips(on_floor: tuple) -> None:
    model, data = on_floor
    mujoco.mj_kinematics(model, data)
    # thigh 0.9, calf -1.8: foot 2 * 0.213 * cos(0.9) = 0.2648 m below the hip, straight under it.
    for leg in LEG_NAMES:
        foot = data.geom_xpos[model.geom(f"{leg}_foot").id]
        hip = data.xpos[model.body(f"{leg}_thigh").id]
        assert foot[2] - SPEC.foot_radius_m == pytest.approx(0.0, abs=1e-3)
        assert foot[0] == pytest.approx(hip[0], abs=1e-9)
        assert hip[2] - foot[2] == pytest.approx(2 * 0.213 * math.cos(0.9), abs=1e-6)
    np.testing.assert_allclose(data.ctrl, SPEC.standing_pose_rad)


def test_imu_sensors_read_gravity_at_rest(on_floor: tuple) -> None:
    model, data = on_floor
    assert model.sensor("imu_gyro").type == mujoco.mjtSensor.mjSENS_GYRO
    assert model.sensor("imu_acc").type == mujoco.mjtSensor.mjSENS_ACCELEROMETER
    assert model.sensor("imu_quat").type == mujoco.mjtSensor.mjSENS_FRAMEQUAT
    for _ in range(1000):
        mujoco.mj_step(model, data)
    np.testing.assert_allclose(data.sensor("imu_acc").data, [0, 0, 9.81], atol=0.4)
    np.testing.assert_allclose(data.sensor("imu_gyro").data, 0.0, atol=0.01)


def test_stands_still_for_five_seconds_holding_the_standing_targets(on_floor: tuple) -> None:
    model, data = on_floor
    heights = []
    for _ in range(int(5.0 / model.opt.timestep)):
        mujoco.mj_step(model, data)
        heights.append(float(data.qpos[2]))
    settled = np.array(heights[len(heights) // 5 :])  # after the first second of PD sag
    assert settled.min() > 0.23 and settled.max() < 0.29
    assert settled.max() - settled.min() < 0.01
    assert heights[-1] == pytest.approx(SPEC.standing_trunk_height_m, abs=0.01)
    assert np.linalg.norm(data.qpos[:2]) < 0.08
    w, x, y, z = data.qpos[3:7]
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(2 * (w * y - z * x))
    assert abs(roll) < 0.05 and abs(pitch) < 0.1
    assert np.abs(data.qvel).max() < 0.02
    # Only the four feet touch the floor.
    foot_ids = {model.geom(f"{leg}_foot").id for leg in LEG_NAMES}
    touching = {int(g) for pair in data.contact.geom[: data.ncon] for g in pair} - {model.geom("floor").id}
    assert touching == foot_ids
    assert model.geom_friction[model.geom("FR_foot").id, 0] == pytest.approx(0.8)


def test_motor_torque_saturates_at_the_unitree_limits(on_floor: tuple) -> None:
    model, data = on_floor
    # Joints at one end of their range, targets at the other: kp * error is far beyond every limit.
    data.qpos[7:] = SPEC.joint_lower_rad
    data.ctrl[:] = SPEC.joint_upper_rad
    mujoco.mj_forward(model, data)
    np.testing.assert_allclose(np.abs(data.actuator_force), SPEC.torque_limit_nm, rtol=1e-9)
