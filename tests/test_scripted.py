"""The scripted inspection agent on whole sites: its view references are ones the robot can
stand at (checked against the Rust shield's own H), and it inspects instead of deadlocking."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
import shieldnav  # noqa: F401
from shieldnav import InvalidArgumentError, Shield
from shieldnav.scripted import InspectionAgent


def corridor_points(width: float, length: float = 12.0, spacing: float = 0.02) -> np.ndarray:
    """World-frame points of two parallel walls at y = ±width/2."""
    x = np.arange(-length / 2, length / 2, spacing)
    return np.concatenate([np.stack([x, np.full_like(x, s * width / 2)], 1) for s in (-1, 1)])


def barrier_at(points: np.ndarray, position: np.ndarray, yaw: float) -> float:
    """H of the paper's composite shield (Rust) for world points seen from a pose."""
    c, s = math.cos(yaw), math.sin(yaw)
    body = (points - position) @ np.array([[c, -s], [s, c]])
    return Shield().filter(np.ascontiguousarray(body), np.zeros(2), yaw=0.0, omega=0.0).H


@pytest.mark.parametrize("width", [1.6, 2.2, 2.8])
def test_view_reference_in_a_narrow_corridor_is_one_the_shield_admits(width):
    env = gym.make("shieldnav/CorridorInspection-v0")
    env.reset(seed=0)
    agent = InspectionAgent(env)
    world = corridor_points(width)
    here = np.zeros(2)
    # the paper's Eq. (flip) reference from the corridor centre: d_view = 1.5 m from a wall
    # about width/2 away, i.e. pressed against the opposite wall, facing across the corridor
    body = np.ascontiguousarray(world)
    raw = agent.planner.plan(body, (0.0, 0.0), 0.0)
    assert raw is not None
    raw_pos, raw_yaw = np.asarray(raw[0][:2]), float(raw[1])
    pos, yaw = agent._fit_goal(world, here, raw_pos, raw_yaw)
    if width >= 2.8:  # wide enough to stand at d_view facing the wall: the reference is the paper's
        assert barrier_at(world, raw_pos, raw_yaw) >= 0.05
        assert np.allclose(pos, raw_pos, atol=1e-12) and yaw == raw_yaw
        return
    assert barrier_at(world, raw_pos, raw_yaw) < 0.0, "the unfitted reference is outside the safe set"
    assert barrier_at(world, pos, yaw) >= 0.05 - 1e-6
    # the along-wall step of Eq. (flip) is kept
    view = np.array((math.cos(raw_yaw), math.sin(raw_yaw)))
    side = raw_pos - view * float(raw_pos @ view)
    assert np.allclose(pos - view * float(pos @ view), side, atol=1e-9)


def test_scripted_agent_inspects_procedural_sites_under_the_composite_shield():
    coverage, contacts = [], 0
    for seed in range(12):
        env = gym.make("shieldnav/CorridorInspection-v0", truncate_on_deadlock=True)
        agent = InspectionAgent(env)
        obs, info = env.reset(seed=seed)
        agent.reset()
        while True:
            obs, _, terminated, truncated, info = env.step(agent.act(obs, info))
            if terminated or truncated:
                break
        s = info["shieldnav_episode"]
        coverage.append(s["coverage"])
        contacts += s["collisions"]
        if s["coverage"] < 0.02:
            # stuck at the start: only where the paper's shield itself refuses every command
            # (a 1.0-1.2 m corridor: H < 0 from the first scan, see the README's sweep; where H
            # hovers at 0 the range noise lets a few steps through)
            assert s["shield_infeasible_steps"] >= 0.8 * s["steps"], (seed, s)
    assert contacts == 0
    # the paper's reference held until reached left the robot at its start (coverage ~1 %)
    assert np.median(coverage) > 0.1, coverage
    assert sum(c > 0.1 for c in coverage) >= 8, coverage


def test_agent_options_are_checked():
    env = gym.make("shieldnav/CorridorInspection-v0")
    with pytest.raises(InvalidArgumentError, match="fit_margin"):
        InspectionAgent(env, fit_margin=-1.0)
    with pytest.raises(InvalidArgumentError, match="stall_time"):
        InspectionAgent(env, stall_time=0.0)
    for key in ("fit_margin", "lookahead", "stall_time"):
        with pytest.raises(InvalidArgumentError, match=key):
            InspectionAgent(env, **{key: "a"})


def test_agent_must_be_reset_with_the_env():
    # without agent.reset() it acted on no goal (the inspection mission) or the last episode's
    env = gym.make("shieldnav/ConstrictedPassage-v0")
    agent = InspectionAgent(env)
    obs, info = env.reset(seed=0)
    with pytest.raises(gym.error.ResetNeeded, match=r"agent.reset\(\)"):
        agent.act(obs, info)
    agent.reset()
    agent.act(obs, info)
    obs, info = env.reset(seed=0)
    with pytest.raises(gym.error.ResetNeeded):
        agent.act(obs, info)
    agent.reset()
    agent.act(obs, info)
