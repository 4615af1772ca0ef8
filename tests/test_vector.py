"""The native vector environment: make_vec returns it, its autoreset mode is declared and
honoured, and a batch of N equals N single environments bit for bit."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import shieldnav  # noqa: F401
from shieldnav import InvalidArgumentError
from shieldnav.vector import CorridorInspectionVectorEnv

ENV = "shieldnav/DynamicObstacles-v0"


def actions(k: int, n: int) -> np.ndarray:
    return np.random.default_rng(k).uniform(-1, 1, (n, 3)).astype(np.float32)


def singles_next_step(env_id: str, n: int, seed: int, steps: int, **kwargs):
    """N single environments driven with Gymnasium's next-step autoreset by hand."""
    envs = [gym.make(env_id, max_episode_steps=kwargs["time_limit"], **kwargs) for _ in range(n)]
    obs = [e.reset(seed=seed + i)[0] for i, e in enumerate(envs)]
    done = [False] * n
    out = []
    for k in range(steps):
        a = actions(k, n)
        row = []
        for i, e in enumerate(envs):
            if done[i]:
                obs[i], _ = e.reset()
                row.append((obs[i], 0.0, False, False))
                done[i] = False
            else:
                obs[i], r, te, tr, _ = e.step(a[i])
                row.append((obs[i], r, te, tr))
                done[i] = te or tr
        out.append(row)
    return out


@pytest.mark.parametrize("env_id", [ENV, "shieldnav/CorridorInspection-v0"])
def test_make_vec_gives_the_native_batch_equal_to_single_envs(env_id):
    n, steps, limit = 3, 130, 60
    v = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", max_episode_steps=limit, time_limit=limit)
    assert isinstance(v, CorridorInspectionVectorEnv)
    assert v.metadata["autoreset_mode"] == gym.vector.AutoresetMode.NEXT_STEP
    obs, _ = v.reset(seed=10)
    ref = singles_next_step(env_id, n, 10, steps, time_limit=limit)
    ends = 0
    for k in range(steps):
        obs, r, te, tr, info = v.step(actions(k, n))
        for i in range(n):
            o, rr, tte, ttr = ref[k][i]
            assert obs[i].tobytes() == o.tobytes(), (k, i)
            assert r[i] == rr and te[i] == tte and tr[i] == ttr, (k, i)
        if "shieldnav_episode" in info:
            ends += int(info["_shieldnav_episode"].sum())
            assert np.all(info["shieldnav_episode"]["steps"][info["_shieldnav_episode"]] == limit)
    assert ends == 2 * n, "every sub-environment hit the 60-step limit twice in 130 steps"


def test_vector_info_holds_the_single_envs_keys_and_values():
    single = gym.make(ENV)
    single.reset(seed=4)
    vec = gym.make_vec(ENV, num_envs=2, vectorization_mode="vector_entry_point")
    vec.reset(seed=4)
    for k in range(3):
        a = actions(k, 2)
        one = single.step(a[0])[4]
        many = vec.step(a)[4]
        keys = set(one) - {"solve_time_ns"}  # (wall time)
        assert keys <= set(many), keys - set(many)
        for key in keys:
            np.testing.assert_array_equal(np.asarray(many[key])[0], np.asarray(one[key]), err_msg=key)
            assert many["_" + key].all()
    vec.close()


def test_time_limit_shortens_vector_episodes_as_it_does_single_ones():
    # make_vec passes the id's max_episode_steps too: the smaller limit ends the episodes
    for kwargs in ({"time_limit": 7}, {"max_episode_steps": 7}):
        v = gym.make_vec(ENV, num_envs=2, vectorization_mode="vector_entry_point", **kwargs)
        v.reset(seed=0)
        ends = [v.step(np.zeros((2, 3), np.float32))[3].all() for _ in range(7)]
        assert ends == [False] * 6 + [True], kwargs
        v.close()


def test_gymnasium_vector_conventions():
    v = gym.make_vec(ENV, num_envs=3, vectorization_mode="vector_entry_point", autoreset_mode=gym.vector.AutoresetMode.SAME_STEP,
                     time_limit=4)
    assert v.metadata["autoreset_mode"] == gym.vector.AutoresetMode.SAME_STEP
    # a list with None: those draw from the vector's generator; the others are as given
    a, _ = v.reset(seed=[5, None, 7])
    b, _ = v.reset(seed=[5, 6, 7])
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[2], b[2])
    for _ in range(4):
        obs, _, _, truncated, info = v.step(np.zeros((3, 3), np.float32))
    assert truncated.all() and info["_final_info"].all()
    final = info["final_info"]
    assert list(final["shieldnav_episode"]["steps"]) == [4, 4, 4] and final["_cost"].all() and "H" in final
    v.close()
    with pytest.raises(gym.error.ClosedEnvironmentError):
        v.step(np.zeros((3, 3), np.float32))


def test_reset_info_is_the_single_envs():
    v = gym.make_vec(ENV, num_envs=2, vectorization_mode="vector_entry_point")
    _, info = v.reset(seed=3)
    for i in range(2):
        single = gym.make(ENV)
        _, one = single.reset(seed=3 + i)
        assert info["seed"][i] == one["seed"] and info["_seed"][i]
        assert info["coverage"][i] == one["coverage"] and info["time"][i] == one["time"]
    v.close()


def test_same_step_mode_returns_the_final_observation():
    v = CorridorInspectionVectorEnv(2, preset="constricted_passage", autoreset_mode="same_step", max_episode_steps=5)
    assert v.metadata["autoreset_mode"] == gym.vector.AutoresetMode.SAME_STEP
    v.reset(seed=0)
    single = gym.make("shieldnav/ConstrictedPassage-v0", max_episode_steps=5, time_limit=5)
    single.reset(seed=0)
    for k in range(5):
        a = actions(k, 2)
        obs, r, te, tr, info = v.step(a)
        so, *_ = single.step(a[0])
    assert tr.all() and "final_obs" in info and info["_final_obs"].all()
    assert info["final_obs"][0].tobytes() == so.tobytes()
    so, _ = single.reset()
    assert obs[0].tobytes() == so.tobytes(), "the same step already starts the next episode"


def test_bad_arguments_raise():
    with pytest.raises(InvalidArgumentError, match="num_envs"):
        CorridorInspectionVectorEnv(0, preset="constricted_passage")
    with pytest.raises(InvalidArgumentError, match="autoreset_mode"):
        CorridorInspectionVectorEnv(2, preset="constricted_passage", autoreset_mode="sometimes")
    v = CorridorInspectionVectorEnv(2, preset="constricted_passage")
    v.reset(seed=0)
    with pytest.raises(InvalidArgumentError, match="actions"):
        v.step(np.zeros((3, 3), np.float32))
    with pytest.raises(InvalidArgumentError, match="action"):
        v.step(np.full((2, 3), 2.0, np.float32))
