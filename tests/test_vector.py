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
    # either limit ends the episodes (the id registers its time_limit, no max_episode_steps)
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


def assert_same_info(native, sync, where):
    """The same keys, masks and values (Gymnasium's sync layout; `final_obs` stacked here)."""
    assert set(native) == set(sync), (where, set(native) ^ set(sync))
    for key, want in sync.items():
        got = native[key]
        if isinstance(want, dict):
            assert_same_info(got, want, f"{where}/{key}")
        elif key == "final_obs":
            mask = sync["_final_obs"]
            assert np.array_equal(got[mask], np.stack(want[mask])), where
        else:
            got, want = np.asarray(got), np.asarray(want)
            kinds = {got.dtype.kind, want.dtype.kind}
            assert len(kinds) == 1 or kinds == {"i", "u"}, (where, key, got.dtype, want.dtype)
            assert np.array_equal(got, want, equal_nan=got.dtype.kind == "f"), (where, key, got, want)


@pytest.mark.parametrize("mode", ["next_step", "same_step"])
def test_vector_info_is_laid_out_as_gymnasiums_own_vector_env(mode):
    # contacts end episodes at different steps: resets at different times, reset infos with
    # the first scan's coverage, the ended episodes' totals and (same step) final infos
    kwargs = dict(num_envs=3, time_limit=300, shield="none", terminate_on_contact=True)
    env_id = "shieldnav/ConstrictedPassage-v0"
    native = gym.make_vec(env_id, vectorization_mode="vector_entry_point", autoreset_mode=mode, **kwargs)
    sync = gym.make_vec(env_id, vectorization_mode="sync", vector_kwargs={"autoreset_mode": gym.vector.AutoresetMode(mode.title().replace("_", ""))}, **kwargs)
    assert_same_info(native.reset(seed=7)[1], sync.reset(seed=7)[1], "reset")
    rng = np.random.default_rng(0)
    seen = {"reset_one": False, "ended": 0}
    for k in range(700):
        a = rng.uniform(-1, 1, (3, 3)).astype(np.float32)
        a[:, 0] = np.abs(a[:, 0])  # on, into the doorway's clutter
        n_obs, n_r, n_te, n_tr, n_info = native.step(a)
        s_obs, s_r, s_te, s_tr, s_info = sync.step(a)
        assert n_obs.tobytes() == s_obs.tobytes() and np.array_equal(n_r, s_r), k
        assert np.array_equal(n_te, s_te) and np.array_equal(n_tr, s_tr), k
        assert_same_info(n_info, s_info, f"step {k}")
        seen["reset_one"] |= 0 < int(n_info.get("_seed", np.zeros(3, bool)).sum()) < 3
        seen["ended"] += int((n_te | n_tr).sum())
    assert seen["reset_one"] and seen["ended"] >= 6, seen
    native.close()
    sync.close()


def test_bad_vector_arguments_name_what_is_wrong():
    make = lambda **kw: CorridorInspectionVectorEnv(kw.pop("n", 2), preset="constricted_passage", **kw)  # noqa: E731
    for kwargs, name in [({"threads": -1}, "threads"), ({"threads": 2.5}, "threads"), ({"max_episode_steps": 0}, "max_episode_steps"),
                         ({"time_limit": True}, "time_limit"), ({"report_timing": "no"}, "report_timing"), ({"seed": 3}, "seed"),
                         ({"n": True}, "num_envs"), ({"autoreset_mode": gym.vector.AutoresetMode.DISABLED}, "autoreset_mode")]:
        with pytest.raises(InvalidArgumentError, match=f"invalid `{name}`"):
            make(**kwargs)
    # numpy integers and Gymnasium's own mode values are what they say
    v = make(n=np.int64(2), autoreset_mode="SameStep", threads=np.int32(1))
    assert v.num_envs == 2 and v.metadata["autoreset_mode"] == gym.vector.AutoresetMode.SAME_STEP
    a, _ = v.reset(seed=np.int64(4))
    b, _ = v.reset(seed=[4, 5])
    assert np.array_equal(a, b)
    for seed, name in [("123", "seed"), ([1.9, 2.2], r"seed\[0\]"), ([True, 2], r"seed\[0\]"), ([3, -1], r"seed\[1\]"), (-1, "seed"), (1.5, "seed")]:
        with pytest.raises(InvalidArgumentError, match=f"invalid `{name}`"):
            v.reset(seed=seed)
    v.close()
    with pytest.raises(gym.error.ClosedEnvironmentError):
        v.summary(0)
