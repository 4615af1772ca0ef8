"""Episode checks for your own controller, with the shieldnav pytest plugin (installed with
shieldnav). Run with ``pytest examples/test_my_controller.py``; add
``--shieldnav-gif-dir=gifs`` for a GIF of every failing episode.
"""

import numpy as np
import pytest
from shieldnav.testing import assert_coverage_at_least, assert_no_contact, assert_safe_episodes, cases

IDS = ["ConstrictedPassage-v0", "DynamicObstacles-v0"]


def my_controller(obs, info):
    """The nominal command ``(v_x, v_y, ω)`` over the robot's limits, from the flat observation:
    ahead at half speed, turning away from the nearer side (bins 0.. run counter-clockwise)."""
    bins = obs[:64]
    left, right = bins[8:24].min(), bins[40:56].min()
    return np.array([0.5, 0.0, 0.5 * (left - right)], dtype=np.float32)


@pytest.mark.parametrize("env_id, seed", cases(IDS, range(3)))
def test_no_contact_under_the_shield(shieldnav_runner, env_id, seed):
    # one episode per test: pytest-xdist spreads them over its workers
    summaries = shieldnav_runner(my_controller, env_id, [seed], max_steps=500, workers=1)
    assert_no_contact(summaries)


def test_all_seeds_at_once(shieldnav_runner):
    # one call over ids × seeds: the episodes run in parallel processes
    summaries = shieldnav_runner(my_controller, IDS, range(4), max_steps=500)
    assert_safe_episodes(summaries, deadlock=False)


def test_the_scripted_agent_inspects(shieldnav_runner):
    summaries = shieldnav_runner("scripted", "CorridorInspection-v0", [0], max_steps=1000)
    assert_coverage_at_least(summaries, 0.05)


def test_one_environment(shieldnav_env):
    env = shieldnav_env("ConstrictedPassage-v0", time_limit=50)
    obs, info = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(my_controller(obs, info))
    assert not info["collision"]


class MyBatchController:
    """The same controller over a batch of observations ``(n, L)``: ``run_episodes`` then runs
    every seed of an id as one native batch (``act_batch``), one policy call per step."""

    def act_batch(self, obs, info):
        left, right = obs[:, 8:24].min(axis=1), obs[:, 40:56].min(axis=1)
        actions = np.zeros((len(obs), 3), dtype=np.float32)
        actions[:, 0], actions[:, 2] = 0.5, 0.5 * (left - right)
        return actions


def test_a_batch_controller_on_many_seeds(shieldnav_runner):
    summaries = shieldnav_runner(MyBatchController(), IDS, range(8), max_steps=500)
    assert_no_contact(summaries)
