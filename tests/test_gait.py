"""The RL gait: trot prior IK, observation, policy inference (numpy vs torch), checkpoints, the env's
reward terms and the controller on the dynamic Go1 (training and obstacles: tests/test_gait_training.py)."""

from __future__ import annotations

import json
import math

import mujoco
import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from robots.gait_policy import (
    ACTION_DIM,
    CONFIG_FILE,
    OBS_DIM,
    GaitController,
    GaitPolicy,
    NumpyActor,
    PolicyConfig,
    TrotConfig,
    TrotPrior,
    actor_weights_from_torch,
    build_observation,
    build_torch_actor,
    load_policy,
    make_gait_controller,
    projected_gravity,
    ramp_command,
    save_policy,
)
from robots.go1 import load_go1_spec
from robots.mujoco_backend import MujocoRobot
from semexp_bt.core.scene import SceneSpec
from semexp_bt.core.types import InvalidInputError, Pose2D, Twist
from sims.gait_env import GaitEnv, GaitEnvConfig, NoiseConfig, RandomizationConfig, reward_terms

SPEC = load_go1_spec()


def _leg_fk(hip: float, thigh: float, knee: float, abduction_offset_m: float) -> np.ndarray:
    """Foot position relative to the hip joint, written from the MJCF's joint axes (x, y, y)."""
    link = SPEC.thigh_length_m
    x = -link * math.sin(thigh) - link * math.sin(thigh + knee)
    z_plane = -link * math.cos(thigh) - link * math.cos(thigh + knee)
    y_plane = abduction_offset_m
    # Rotation about x by the abduction angle.
    y = y_plane * math.cos(hip) - z_plane * math.sin(hip)
    z = y_plane * math.sin(hip) + z_plane * math.cos(hip)
    return np.array([x, y, z])


def test_prior_zero_command_is_the_standing_pose() -> None:
    prior = TrotPrior()
    for phase in (0.0, 0.3, 0.77):
        targets = prior.joint_targets(np.array([phase]), np.zeros((1, 3)))[0]
        np.testing.assert_allclose(targets, SPEC.standing_pose_rad, atol=1e-3)


@settings(max_examples=60, deadline=None)
@given(
    dx=st.floats(-0.12, 0.12),
    dy=st.floats(-0.06, 0.06),
    dz=st.floats(0.0, 0.08),
    leg=st.integers(0, 3),
)
def test_leg_ik_reaches_the_foot_target(dx: float, dy: float, dz: float, leg: int) -> None:
    prior = TrotPrior()
    feet = np.zeros((1, 4, 3))
    feet[0, leg] = [dx, dy, dz]
    joints = prior.leg_ik(feet)[0].reshape(4, 3)[leg]
    offset = SPEC.thigh_offset_y_m * (1.0 if leg in (1, 3) else -1.0)
    expected = np.array([dx, offset + dy, -prior.config.stand_height_m + dz])
    np.testing.assert_allclose(
        _leg_fk(joints[0], joints[1], joints[2], abduction_offset_m=offset), expected, atol=1e-6
    )


def test_prior_trots_diagonal_pairs_and_follows_the_command() -> None:
    prior = TrotPrior(TrotConfig(frequency_hz=2.0, stride_gain=1.0))
    command = np.array([[0.5, 0.0, 0.0]])
    feet = prior.foot_positions(np.array([0.25]), command)[0]
    # Phase 0.25: FR and RL are mid-swing (lifted to the apex), FL and RR mid-stance (on the ground).
    assert feet[0, 2] == pytest.approx(prior.config.foot_lift_m)
    assert feet[3, 2] == pytest.approx(prior.config.foot_lift_m)
    assert feet[1, 2] == 0.0 and feet[2, 2] == 0.0
    # Stance feet sweep backwards by v * stance time: at phase 0 (stance start for FL) x = +v T/4.
    start = prior.foot_positions(np.array([0.0]), command)[0]
    assert start[1, 0] == pytest.approx(0.5 * 0.25 / 2.0)
    assert prior.gate(np.zeros((1, 3)))[0] == 0.0


def test_projected_gravity() -> None:
    np.testing.assert_allclose(projected_gravity(np.array([1.0, 0, 0, 0])), [0, 0, -1], atol=1e-12)
    # Rolled 90 degrees about x (left side up... right side down): gravity points along body -y.
    half = math.sqrt(0.5)
    np.testing.assert_allclose(projected_gravity(np.array([half, half, 0, 0])), [0, -1, 0], atol=1e-12)
    batch = projected_gravity(np.array([[1.0, 0, 0, 0], [half, 0, half, 0]]))
    np.testing.assert_allclose(batch[1], [1, 0, 0], atol=1e-12)


def test_observation_layout() -> None:
    obs = build_observation(
        command=np.array([[1.0, 0.0, 0.0]]),
        gyro_radps=np.zeros((1, 3)),
        gravity_body=np.array([[0.0, 0.0, -1.0]]),
        joint_position_rel_rad=np.zeros((1, 12)),
        joint_velocity_radps=np.zeros((1, 12)),
        last_action=np.ones((1, 12)),
        phase=np.array([0.25]),
    )
    assert obs.shape == (1, OBS_DIM)
    assert obs[0, 0] == 2.0  # command scale
    assert obs[0, 8] == -1.0
    np.testing.assert_allclose(obs[0, -2:], [1.0, 0.0], atol=1e-12)


def test_numpy_and_torch_actor_agree() -> None:
    torch.manual_seed(0)
    module = build_torch_actor(OBS_DIM, ACTION_DIM, (64, 64))
    rng = np.random.default_rng(0)
    mean, std = rng.normal(size=OBS_DIM), rng.uniform(0.5, 2.0, size=OBS_DIM)
    actor = NumpyActor(actor_weights_from_torch(module), mean, std)
    obs = rng.normal(size=(16, OBS_DIM))
    with torch.no_grad():
        normalised = np.clip((obs - mean) / std, -5.0, 5.0)
        expected = module(torch.as_tensor(normalised, dtype=torch.float32)).numpy()
    got = actor(obs)
    assert got.shape == (16, ACTION_DIM)
    np.testing.assert_allclose(got, np.clip(expected, -1, 1), atol=1e-5)
    assert actor(obs[0]).shape == (ACTION_DIM,)


def test_checkpoint_roundtrip_and_errors(tmp_path) -> None:
    rng = np.random.default_rng(1)
    actor = NumpyActor([(rng.normal(size=(OBS_DIM, 8)), rng.normal(size=8)), (rng.normal(size=(8, 12)), np.zeros(12))],
                       np.zeros(OBS_DIM), np.ones(OBS_DIM))  # fmt: skip
    save_policy(tmp_path, config=PolicyConfig(hidden_sizes=(8,)), actor=actor)
    loaded = load_policy(tmp_path)
    obs = rng.normal(size=(3, OBS_DIM))
    np.testing.assert_allclose(loaded.actor(obs), actor(obs), atol=1e-5)  # float32 storage
    raw = json.loads((tmp_path / CONFIG_FILE).read_text())
    del raw["trot"]
    (tmp_path / CONFIG_FILE).write_text(json.dumps(raw))
    with pytest.raises(InvalidInputError, match="trot"):
        load_policy(tmp_path)
    with pytest.raises(FileNotFoundError, match="policy"):
        load_policy(tmp_path / "missing")


def test_shipped_checkpoint_loads() -> None:
    policy = load_policy()
    assert policy.actor.obs_dim == OBS_DIM
    assert policy.actor(np.zeros(OBS_DIM)).shape == (ACTION_DIM,)
    assert policy.config.info.get("env_steps", 0) > 0


def test_reward_terms_on_hand_made_states() -> None:
    n = 3
    command = np.array([[0.5, 0.0, 0.0], [0.5, 0.0, 1.0], [0.0, 0.0, 0.0]])
    lin = np.array([[0.5, 0.0, 0.1], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    ang = np.array([[0.0, 0.0, 0.0], [0.2, 0.0, 1.0], [0.0, 0.0, 0.0]])
    contact = np.array([[1, 0, 0, 1], [1, 1, 1, 1], [1, 1, 1, 1]], dtype=float)
    foot_vel = np.zeros((n, 4, 2))
    foot_vel[0, 0] = [0.3, 0.4]  # in contact: slips 0.25 m^2/s^2
    foot_vel[0, 1] = [1.0, 0.0]  # swinging: not a slip
    first = np.zeros((n, 4))
    first[0, 0] = first[2, 0] = 1.0
    air = np.full((n, 4), 0.3)
    q_rel = np.zeros((n, 12))
    q_rel[2, 0] = 0.2
    terms = reward_terms(
        command=command, base_lin_vel_body=lin, base_ang_vel_body=ang,
        gravity_body=np.array([[0.1, 0.0, -0.99], [0, 0, -1.0], [0, 0, -1.0]]),
        torques_nm=np.array([[1.0] + [0.0] * 11, [0.0] * 12, [2.0] * 12]),
        action=np.ones((n, 12)), last_action=np.zeros((n, 12)), foot_contact=contact,
        foot_velocity_xy=foot_vel, first_contact=first, air_time_s=air, joint_position_rel_rad=q_rel,
        base_height_m=np.array([0.25, 0.2, 0.3]), tracking_sigma=0.25, target_height_m=0.25,
    )  # fmt: skip
    np.testing.assert_allclose(terms["tracking_lin_vel"], [1.0, math.exp(-1.0), 1.0])
    np.testing.assert_allclose(terms["tracking_ang_vel"], [1.0, 1.0, 1.0])
    np.testing.assert_allclose(terms["lin_vel_z"], [0.01, 0.0, 0.0])
    np.testing.assert_allclose(terms["ang_vel_xy"], [0.0, 0.04, 0.0])
    np.testing.assert_allclose(terms["orientation"], [0.01, 0.0, 0.0])
    np.testing.assert_allclose(terms["torques"], [1.0, 0.0, 48.0])
    np.testing.assert_allclose(terms["action_rate"], [12.0, 12.0, 12.0])
    np.testing.assert_allclose(terms["feet_slip"], [0.25, 0.0, 0.0])
    # Air time rewards a 0.3 s step by 0.1 only while moving; standing still penalises joint offsets.
    np.testing.assert_allclose(terms["feet_air_time"], [0.1, 0.0, 0.0])
    np.testing.assert_allclose(terms["stand_still"], [0.0, 0.0, 0.2])
    np.testing.assert_allclose(terms["base_height"], [0.0, 0.0025, 0.0025])
    np.testing.assert_allclose(terms["action_magnitude"], [12.0, 12.0, 12.0])


def test_env_steps_and_detects_falls() -> None:
    config = GaitEnvConfig(
        num_envs=2, randomization=RandomizationConfig(enabled=False), noise=NoiseConfig(enabled=False)
    )
    env = GaitEnv(config, seed=0)
    obs = env.reset()
    assert obs.shape == (2, OBS_DIM)
    obs, reward, done, info = env.step(np.zeros((2, ACTION_DIM)))
    assert reward.shape == (2,) and not done.any() and np.isfinite(reward).all()
    assert info["critic_obs"].shape[0] == 2
    # Tip env 1 upside down: the next step ends its episode as a fall and resets it.
    env.datas[1].qpos[3:7] = [0.0, 1.0, 0.0, 0.0]
    env.datas[1].qpos[2] = 0.3
    _, _, done, info = env.step(np.zeros((2, ACTION_DIM)))
    assert info["terminated"].tolist() == [False, True]
    assert env.episode_step[1] == 0
    with pytest.raises(InvalidInputError, match="actions"):
        env.step(np.zeros((3, ACTION_DIM)))


def _flat_robot() -> MujocoRobot:
    scene = SceneSpec(name="flat", title="Flat", seed=0, bounds_m=(-5.0, -5.0, 5.0, 5.0), objects=(),
                      goal_object_id=0, instruction="")  # fmt: skip
    return MujocoRobot(scene=scene, fidelity="dynamic", start_pose=Pose2D(0.0, 0.0, 0.0), seed=0)


def _drive(robot: MujocoRobot, twist: Twist, seconds: float, checkpoint: str | None = None) -> None:
    controller = make_gait_controller(checkpoint)
    for _ in range(int(round(seconds / 0.02))):
        controller(robot, twist)
        robot.advance(0.02)


def _tick(controller: GaitController, robot: MujocoRobot, twist: Twist, ticks: int) -> None:
    for _ in range(ticks):
        controller(robot, twist)
        robot.advance(0.02)


def _tip_trunk(robot: MujocoRobot, roll_rad: float) -> None:
    """Roll the trunk by ``roll_rad`` about x in place."""
    robot.data.qpos[3:7] = [math.cos(0.5 * roll_rad), math.sin(0.5 * roll_rad), 0.0, 0.0]
    mujoco.mj_forward(robot.model, robot.data)  # the IMU's orientation sensor reads the new pose


def test_controller_stands_on_a_zero_command() -> None:
    robot = _flat_robot()
    try:
        start = robot.base_pose()
        _drive(robot, Twist.zero(), 3.0)
        end = robot.base_pose()
        assert not robot.safety().fallen
        assert math.hypot(end.x_m - start.x_m, end.y_m - start.y_m) < 0.1
        assert robot.data.qpos[2] > 0.2
    finally:
        robot.close()


def test_controller_walks_forward() -> None:
    robot = _flat_robot()
    try:
        _drive(robot, Twist(0.5, 0.0, 0.0), 5.0)
        assert not robot.safety().fallen
        assert robot.base_pose().x_m > 0.5
    finally:
        robot.close()


def test_controller_rejects_a_nan_twist() -> None:
    robot = _flat_robot()
    try:
        with pytest.raises(InvalidInputError, match="twist"):
            make_gait_controller("reference")(robot, Twist(math.nan, 0.0, 0.0))
    finally:
        robot.close()


def test_ramp_command_limits_acceleration() -> None:
    # 2 m/s^2 and 4 rad/s^2 over 20 ms: at most 0.04 m/s and 0.08 rad/s per tick.
    ramped = ramp_command(np.zeros(3), np.array([1.0, 0.01, -1.0]), 0.02)
    np.testing.assert_allclose(ramped, [0.04, 0.01, -0.08])
    command = np.zeros(3)
    for _ in range(25):
        command = ramp_command(command, np.array([1.0, 0.0, 0.0]), 0.02)
    np.testing.assert_allclose(command, [1.0, 0.0, 0.0])


def test_reference_gait_is_a_zero_residual() -> None:
    reference = GaitPolicy.reference()
    assert np.all(reference.actor(np.ones(OBS_DIM)) == 0.0)


@pytest.mark.slow
def test_bench_quick_runs() -> None:
    from sims.gait_bench import format_table, run_gait_bench

    result = run_gait_bench(seeds=1, quick=True)
    assert set(result["gaits"]) == {"policy", "reference"}
    assert "pushes recovered" in format_table(result)


def test_bench_contact_only_runs_the_contact_section_alone_and_tabulates_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import sims.gait_bench as bench

    def not_in_a_contact_only_run(*args: object, **kwargs: object) -> None:
        raise AssertionError("a contact-only run benchmarked open ground")

    cases = {"cases": 2, "fell": 1, "fell_cases": ["wall 1.0 m/s 0 deg"]}
    contact = {
        "run_in": cases, "turn_beside": {"cases": 1, "fell": 0, "fell_cases": []},
        "bump_and_turn": {"cases": 1, "fell": 0, "fell_cases": []},
        "command_steps": {"envs": 1, "steps_per_env": 2, "falls": 0},
        "obstacle_course": {"seeds": 1, "minutes_per_seed": 2.0, "falls": 2, "contact_share": 0.12},
        "run_in_fell": 1, "turn_beside_fell": 0, "bump_and_turn_fell": 0, "command_step_falls": 0,
        "course_falls": 2, "falls": 3,
    }  # fmt: skip
    for name in ("_grid", "_random", "_pushes"):
        monkeypatch.setattr(bench, name, not_in_a_contact_only_run)
    monkeypatch.setattr(bench, "_contact", lambda policy, **kwargs: contact)
    result = bench.run_gait_bench(seeds=1, contact_only=True)
    table = bench.format_table(result)
    print(table)
    assert result["floors_met"] == {"no_contact_falls": False}
    assert result["gaits"]["policy"] == {"contact": contact}
    assert "contact: obstacle-course falls" in table and "wall 1.0 m/s 0 deg" in table
    assert "random commands" not in table


def _gravity_tilted(angle_rad: float) -> np.ndarray:
    """Projected gravity of a trunk rolled by ``angle_rad``."""
    return np.array([[0.0, math.sin(angle_rad), -math.cos(angle_rad)]])


def test_near_fall_recovery_holds_until_level_for_the_hold_time() -> None:
    from robots.gait_policy import (
        NEAR_FALL_TILT_RAD,
        RECOVERED_TILT_RAD,
        RECOVERY_HOLD_S,
        NearFallRecovery,
    )

    recovery = NearFallRecovery(1, control_dt_s=0.02)
    assert not recovery.update(_gravity_tilted(NEAR_FALL_TILT_RAD - 0.05))[0]
    assert recovery.update(_gravity_tilted(NEAR_FALL_TILT_RAD + 0.05))[0]
    assert recovery.near_falls == 1
    # Between the two thresholds the robot is not yet level: the hold does not start.
    for _ in range(200):
        assert recovery.update(_gravity_tilted(0.5 * (NEAR_FALL_TILT_RAD + RECOVERED_TILT_RAD)))[0]
    hold_ticks = int(round(RECOVERY_HOLD_S / 0.02))
    for _ in range(hold_ticks - 1):
        assert recovery.update(_gravity_tilted(0.0))[0]
    assert not recovery.update(_gravity_tilted(0.0))[0]
    assert recovery.near_falls == 1


def test_controller_stops_walking_through_a_near_fall() -> None:
    robot = _flat_robot()
    try:
        controller = GaitController(load_policy())
        _tick(controller, robot, Twist(0.8, 0.0, 0.0), 100)
        assert controller.command[0] == pytest.approx(0.8)
        # Tip the trunk by 0.4 rad about x: the next ticks ramp the command down instead of walking on.
        _tip_trunk(robot, 0.4)
        controller(robot, Twist(0.8, 0.0, 0.0))
        assert controller.recovering and controller.near_falls == 1
        assert controller.command[0] < 0.8
    finally:
        robot.close()


def test_stance_hold_fades_the_residual_out_when_idle_and_back_in_when_not() -> None:
    from robots.gait_policy import STANCE_FADE_S, StanceHold

    stance = StanceHold(2, control_dt_s=0.02)
    fade_ticks = int(round(STANCE_FADE_S / 0.02))
    walking = np.array([False, False])
    for _ in range(fade_ticks):
        share = stance.update(walking)
    np.testing.assert_allclose(share, [1.0, 1.0])
    # The first robot stops: its share falls one step per tick and stays at zero; the second walks on.
    idle = np.array([True, False])
    first = stance.update(idle)
    assert 0.0 < first[0] < 1.0 and first[1] == 1.0
    for _ in range(fade_ticks):
        share = stance.update(idle)
    np.testing.assert_allclose(share, [0.0, 1.0])
    # Asked to walk again, the share climbs back over the same time.
    for _ in range(fade_ticks - 1):
        share = stance.update(walking)
    assert 0.9 < share[0] < 1.0
    np.testing.assert_allclose(stance.update(walking), [1.0, 1.0])


def _standing_speeds(controller: GaitController, robot: MujocoRobot, ticks: int) -> list[float]:
    """The trunk's horizontal speed (m/s) at each of ``ticks`` ticks under a zero command."""
    speeds = []
    previous = robot.base_pose()
    for _ in range(ticks):
        controller(robot, Twist.zero())
        robot.advance(0.02)
        pose = robot.base_pose()
        speeds.append(math.hypot(pose.x_m - previous.x_m, pose.y_m - previous.y_m) / 0.02)
        previous = pose
    return speeds


def test_controller_stands_on_the_prior_alone_after_a_stop() -> None:
    from robots.gait_policy import STANCE_FADE_S

    robot = _flat_robot()
    try:
        controller = GaitController(load_policy())
        _tick(controller, robot, Twist(0.5, 0.0, 0.0), 100)
        # Walking, the residual is applied in full.
        assert np.abs(controller.last_action).max() > 0.0
        assert controller.stance.share[0] == 1.0
        # Stopped: the command ramps down (0.25 s at 2 m/s^2), then the residual fades out.
        _tick(controller, robot, Twist.zero(), int(round((0.25 + STANCE_FADE_S) / 0.02)) + 2)
        assert controller.stance.share[0] == 0.0
        np.testing.assert_array_equal(controller.last_action, np.zeros(12))
        # What the legs are given is the prior's standing target (its IK of the nominal feet), nothing more.
        prior_stand = controller.policy.prior.joint_targets(np.array([controller.phase]), np.zeros((1, 3)))[0]
        np.testing.assert_allclose(robot.data.ctrl, prior_stand, atol=1e-12)
        # Settled, the trunk stands still on the prior's stance.
        _tick(controller, robot, Twist.zero(), 90)
        held = _standing_speeds(controller, robot, 150)
        # The same robot with the residual applied in full at the zero command (no hold) sways and steps.
        controller.stance.update = lambda idle: np.ones(len(idle))  # type: ignore[method-assign]
        _tick(controller, robot, Twist.zero(), 90)
        unheld = _standing_speeds(controller, robot, 150)
        print(
            f"standing trunk speed, median (max): with the hold {np.median(held):.4f} ({max(held):.4f}) m/s, "
            f"residual in full {np.median(unheld):.4f} ({max(unheld):.4f}) m/s"
        )
        assert np.median(held) < 0.005
        assert np.median(held) < 0.2 * np.median(unheld)
        assert not robot.safety().fallen
    finally:
        robot.close()


def test_a_recovering_controller_keeps_the_full_residual_at_a_zero_command() -> None:
    robot = _flat_robot()
    try:
        controller = GaitController(load_policy())
        _tick(controller, robot, Twist(0.8, 0.0, 0.0), 100)
        _tip_trunk(robot, 0.4)
        # 0.8 s at a zero command, twice the fade, without advancing: the trunk stays tipped.
        for _ in range(40):
            controller(robot, Twist.zero())
        assert controller.recovering
        assert controller.stance.share[0] == 1.0
    finally:
        robot.close()


def test_command_tracking_integrates_a_drift_out_while_walking_and_holds_it_while_standing() -> None:
    from robots.gait_policy import COMMAND_HIGH, TRACKING_LIMIT, CommandTracking

    # A plant that walks what it is told plus a constant drift (the shipped policy's is about this).
    drift = np.array([[0.04, 0.0, -0.1], [0.04, 0.0, -0.1]])
    tracking = CommandTracking(2, control_dt_s=0.02)
    asked = np.array([[0.0, 0.0, 0.2], [0.0, 0.0, 0.2]])
    walking = np.array([True, False])
    body = np.zeros((2, 3))
    for _ in range(500):  # 10 s
        told = tracking.update(asked, body, walking)
        body = told + drift
    # The walking robot realises the command; the standing one is told the command unchanged.
    np.testing.assert_allclose(body[0], asked[0], atol=2e-3)
    np.testing.assert_allclose(tracking.correction[0], -drift[0], atol=2e-3)
    np.testing.assert_array_equal(told[1], asked[1])
    np.testing.assert_array_equal(tracking.correction[1], np.zeros(3))
    # Standing, the first robot's correction is held (the drift is the gait's), not applied.
    held = tracking.correction[0].copy()
    for _ in range(100):
        told = tracking.update(np.zeros((2, 3)), np.zeros((2, 3)), np.array([False, False]))
    np.testing.assert_array_equal(tracking.correction[0], held)
    np.testing.assert_array_equal(told, np.zeros((2, 3)))
    # A body that does not move at all (pushing on a wall) winds the correction up to its limit, no further.
    for _ in range(2000):
        tracking.update(np.array([[0.3, 0.1, 0.3]] * 2), np.zeros((2, 3)), np.array([True, True]))
    np.testing.assert_allclose(tracking.correction, np.tile(TRACKING_LIMIT, (2, 1)))
    # At the edge of the command range there is no room: the command passes unchanged, nothing winds up.
    edge = np.tile(COMMAND_HIGH, (2, 1))
    for _ in range(200):
        told = tracking.update(edge, np.zeros((2, 3)), np.array([True, True]))
    np.testing.assert_array_equal(told, edge)
    np.testing.assert_array_equal(tracking.correction, np.zeros((2, 3)))


def _yaw_rate_over(
    controller: GaitController, robot: MujocoRobot, twist: Twist, settle_s: float, measure_s: float
) -> float:
    _tick(controller, robot, twist, int(round(settle_s / 0.02)))
    start = robot.base_pose().yaw_rad
    _tick(controller, robot, twist, int(round(measure_s / 0.02)))
    return math.remainder(robot.base_pose().yaw_rad - start, math.tau) / measure_s


@pytest.mark.parametrize("rate_radps", [0.15, -0.15])
def test_controller_turns_as_slowly_as_asked(rate_radps: float) -> None:
    # 0.15 rad/s is inside the trained prior's deadband (norm 0.045 < 0.05): as trained, the robot stands.
    robot = _flat_robot()
    try:
        controller = GaitController(load_policy())
        realised = _yaw_rate_over(controller, robot, Twist(angular_z_radps=rate_radps), 3.0, 3.0)
        print(f"asked {rate_radps:+.2f} rad/s, realised {realised:+.3f} rad/s")
        assert realised == pytest.approx(rate_radps, rel=0.2)
        assert not robot.safety().fallen
    finally:
        robot.close()
