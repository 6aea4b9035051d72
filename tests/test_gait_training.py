"""The gait's training side: obstacles in the env, the contact force the critic sees, rsl_rl's PPO wired
to the env (warm start, export parity with the numpy actor, resume), and the fall probe's summary."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from robots.gait_policy import ACTION_DIM, OBS_DIM, load_policy
from sims.gait_env import (
    CRITIC_OBS_DIM,
    OBSTACLE_MIN_GAP_M,
    OBSTACLE_SLOTS,
    PARKED_OBSTACLE_POS,
    GaitEnv,
    GaitEnvConfig,
    NoiseConfig,
    ObstacleConfig,
    RandomizationConfig,
)

pytest.importorskip("rsl_rl", reason="the gait-train extra (rsl-rl-lib) is not installed")


def _nominal(num_envs: int, obstacles: ObstacleConfig) -> GaitEnv:
    config = GaitEnvConfig(
        num_envs=num_envs,
        command_resample_s=math.inf,  # the test sets the commands
        randomization=RandomizationConfig(enabled=False),
        noise=NoiseConfig(enabled=False),
        obstacles=obstacles,
    )
    return GaitEnv(config, seed=0)


def _robot_gap(env: GaitEnv, i: int, slot: int) -> float:
    import mujoco

    model, data = env.models[i], env.datas[i]
    geom = int(env._obstacle_geoms[slot])
    return min(mujoco.mj_geomDistance(model, data, int(g), geom, 10.0, None) for g in env._robot_geoms)


def test_obstacles_are_laid_out_near_the_robot_and_never_in_penetration() -> None:
    env = _nominal(24, ObstacleConfig(probability=1.0))
    placed = 0
    for i in range(env.num_envs):
        for slot in range(OBSTACLE_SLOTS):
            centre = env.datas[i].mocap_pos[env._obstacle_mocap[slot]]
            if np.allclose(centre, PARKED_OBSTACLE_POS):
                continue
            placed += 1
            assert np.hypot(*(centre[:2] - env.datas[i].qpos[:2])) < 3.5
            assert _robot_gap(env, i, slot) >= OBSTACLE_MIN_GAP_M
    # Most slots are used (a few layouts are dropped for starting too close).
    assert placed > 0.8 * env.num_envs * OBSTACLE_SLOTS


def test_disabled_obstacles_stay_parked() -> None:
    env = _nominal(4, ObstacleConfig(enabled=False))
    parked = env.datas[0].mocap_pos[env._obstacle_mocap]
    np.testing.assert_allclose(parked, np.tile(PARKED_OBSTACLE_POS, (OBSTACLE_SLOTS, 1)))


def test_walking_into_a_wall_is_felt_as_contact_force_by_the_critic() -> None:
    policy = load_policy()
    env = _nominal(1, ObstacleConfig(enabled=False))
    x, y = env.datas[0].qpos[0:2]
    heading = math.atan2(env.rotation[0, 1, 0], env.rotation[0, 0, 0])
    ahead = np.array([math.cos(heading), math.sin(heading)])
    env.place_obstacle(0, 0, np.array([x, y]) + 0.6 * ahead, heading, (0.1, 1.0, 0.5))
    env.commands[:] = [0.6, 0.0, 0.0]
    forces = []
    obs = env.observe(noisy=False)
    for _ in range(150):
        obs, _, _, info = env.step(policy.actor(obs))
        forces.append(info["contact_force_n"][0])
    assert max(forces[:5]) == 0.0, "no contact before the robot gets there"
    assert max(forces) > 10.0, "the trunk or a leg presses on the wall"
    critic = info["critic_obs"]
    assert critic.shape == (1, CRITIC_OBS_DIM)
    # The last critic input is the contact force / 100 N, capped at 5.
    assert critic[0, -1] == pytest.approx(min(forces[-1] / 100.0, 5.0))


def test_warm_start_reproduces_the_checkpoint_and_torch_matches_numpy(tmp_path: Path) -> None:
    import torch

    from sims.gait_train import PPOConfig, PPOTrainer

    config = PPOConfig(env=GaitEnvConfig(num_envs=2), rollout_steps=4, select_every=0)
    trainer = PPOTrainer(tmp_path, config=config, seed=0, init_from=Path("robots/gait_checkpoints"))
    shipped = load_policy().actor
    rng = np.random.default_rng(0)
    # Within and beyond the 5-sigma clip, so that the clip itself is compared too.
    obs = shipped.obs_mean + shipped.obs_std * rng.normal(0.0, 4.0, size=(64, OBS_DIM))
    np.testing.assert_allclose(trainer.numpy_actor()(obs), shipped(obs), atol=1e-5)
    from tensordict import TensorDict

    batch = TensorDict(
        {
            "policy": torch.as_tensor(obs, dtype=torch.float32),
            "critic": torch.zeros(64, CRITIC_OBS_DIM),
        },
        batch_size=[64],
    )
    with torch.no_grad():
        torch_actions = trainer.alg.actor(batch).numpy()
    np.testing.assert_allclose(np.clip(torch_actions, -1.0, 1.0), shipped(obs), atol=1e-5)


def test_training_runs_freezes_the_actor_while_the_critic_warms_up_and_resumes(tmp_path: Path) -> None:
    from sims.gait_train import LOG_FILE, POLICY_DIR, STATE_FILE, PPOConfig, PPOTrainer

    config = PPOConfig(
        env=GaitEnvConfig(num_envs=2), rollout_steps=4, select_every=0, critic_warmup_iterations=2
    )
    trainer = PPOTrainer(tmp_path, config=config, seed=0, init_from=Path("robots/gait_checkpoints"))
    before = [p.detach().clone() for p in trainer.alg.actor.mlp.parameters()]
    trainer.train(total_steps=2 * 4 * 2, verbose=False)
    after_warmup = list(trainer.alg.actor.mlp.parameters())
    assert all(bool((a == b).all()) for a, b in zip(before, after_warmup, strict=True))
    trainer.train(total_steps=2 * 4 * 4, verbose=False)
    assert any(bool((a != b).any()) for a, b in zip(before, trainer.alg.actor.mlp.parameters(), strict=True))
    for name in (STATE_FILE, LOG_FILE):
        assert (tmp_path / name).is_file()
    exported = load_policy(tmp_path / POLICY_DIR)
    assert exported.config.info["trainer"].startswith("sims/gait_train.py (rsl_rl PPO)")
    assert exported.config.info["env_steps"] == 2 * 4 * 4
    resumed = PPOTrainer(tmp_path, config=config, seed=0, resume=True)
    assert resumed.iteration == 4 and resumed.env_steps == 2 * 4 * 4
    np.testing.assert_allclose(
        resumed.numpy_actor()(np.zeros((1, OBS_DIM))), exported.actor(np.zeros((1, OBS_DIM))), atol=1e-6
    )
    assert resumed.numpy_actor()(np.zeros((1, OBS_DIM))).shape == (1, ACTION_DIM)


def test_fall_probe_summarises_what_preceded_the_fall() -> None:
    from semexp_bt.cli.gait import GaitProbe

    probe = GaitProbe()
    for k in range(300):
        t = k * 0.02
        probe.ticks.append(
            {
                "t": round(t, 2),
                "requested": [0.8, 0.0, 0.0 if t < 5.0 else 1.0],
                "command": [0.8, 0.0, 0.0],
                "body": [0.1, 0.3 if t > 4.0 else 0.0, 0.0],
                "roll": 0.0 if k < 299 else 1.1,
                "pitch": 0.0,
                "height": 0.25,
                "contacts": {"trunk>obj3": 40.0 + k} if t > 4.0 else {},
                "fallen": k == 299,
            }
        )
    summary = probe.fall_summary()
    assert summary is not None
    assert summary["t_fall_s"] == pytest.approx(5.98)
    assert summary["first_contact_in_window_s"] == pytest.approx(4.02)
    assert summary["max_contact_force_n"] == {"trunk>obj3": 40.0 + 299}
    assert summary["requested_wz"] == [0.0, 1.0]
    assert summary["roll_at_fall"] == 1.1
    probe.ticks[-1]["fallen"] = False
    assert probe.fall_summary() is None
