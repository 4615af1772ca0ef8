"""The shipped policies: numpy only, checked against the environment, and the PPO policy
inspects under the shield without contact."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
import shieldnav  # noqa: F401
from shieldnav.exceptions import InvalidArgumentError
from shieldnav.policies import POLICIES, MlpPolicy, load


def test_the_ppo_policy_inspects_under_the_default_shield_without_contact():
    env = gym.make("shieldnav/CorridorInspection-v0", time_limit=1500)
    policy = load("ppo", env)
    for seed in (0, 1):
        obs, info = env.reset(seed=seed)
        while True:
            obs, _, terminated, truncated, info = env.step(policy.act(obs, info))
            if terminated or truncated:
                break
        episode = info["shieldnav_episode"]
        assert episode["collisions"] == 0 and episode["contact_time"] == 0.0, episode
        assert episode["coverage"] > 0.05, episode


def test_a_batch_is_the_rows_one_by_one_and_actions_stay_in_the_box():
    policy = load("ppo")
    obs = np.random.default_rng(0).uniform(-3, 3, (16, policy.obs_dim)).astype(np.float32)
    batch = policy(obs)
    assert batch.shape == (16, 3) and batch.dtype == np.float32 and np.all(np.abs(batch) <= 1.0)
    np.testing.assert_allclose(batch, np.stack([policy(o) for o in obs]), rtol=1e-6, atol=1e-6)


def test_layers_compute_tanh_then_linear():
    w = {"w0": np.eye(2, dtype=np.float32), "b0": np.zeros(2, np.float32), "w1": 2 * np.eye(2, dtype=np.float32), "b1": np.array([0.1, 0.0], np.float32)}
    out = MlpPolicy(w)(np.array([0.2, -5.0], np.float32))
    np.testing.assert_allclose(out, [2 * np.tanh(0.2) + 0.1, -1.0], rtol=1e-6)


def test_bad_names_and_spaces_are_clear_errors():
    assert set(POLICIES) == {"ppo"}
    with pytest.raises(InvalidArgumentError, match="shipped policies"):
        load("sac")
    with pytest.raises(InvalidArgumentError, match="flat observation of 73 values"):
        load("ppo", gym.make("shieldnav/CorridorInspection-v0", lidar_bins=32))


def test_the_command_line_runs_the_shipped_policy():
    import json
    import subprocess
    import sys

    done = subprocess.run([sys.executable, "-m", "shieldnav", "run", "shieldnav/CorridorInspection-v0", "--policy", "ppo", "--steps", "20"],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["steps"] == 20


def test_an_exported_sb3_model_acts_as_its_deterministic_prediction(tmp_path):
    pytest.importorskip("stable_baselines3")
    import torch
    from stable_baselines3 import PPO

    from agents.export_policy import export

    env = gym.make("shieldnav/ConstrictedPassage-v0")
    model = PPO("MlpPolicy", env, seed=0, device="cpu")
    with torch.no_grad():  # weights away from the initialisation's small action head
        for p in model.policy.parameters():
            p.add_(0.3 * torch.randn_like(p))
    model.save(tmp_path / "m.zip")
    export(tmp_path / "m.zip", tmp_path / "p.npz")
    with np.load(tmp_path / "p.npz") as f:
        policy = MlpPolicy({k: f[k] for k in f.files})
    obs = np.stack([env.observation_space.sample() for _ in range(64)])
    expected, _ = model.predict(obs, deterministic=True)
    np.testing.assert_allclose(policy(obs), expected, atol=1e-5)
    assert np.abs(expected).max() > 0.5
    model = PPO("MlpPolicy", env, seed=0, device="cpu", policy_kwargs={"activation_fn": torch.nn.ReLU})
    model.save(tmp_path / "relu.zip")
    with pytest.raises(InvalidArgumentError, match="not an MlpPolicy with tanh layers"):
        export(tmp_path / "relu.zip", tmp_path / "q.npz")
    env.close()
