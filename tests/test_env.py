"""The Gymnasium environments: API conformance, determinism, the step pipeline's equations,
and the paper's three scenario outcomes with the scripted inspection agent."""

from __future__ import annotations

import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest
import shieldnav
from shieldnav import ENV_IDS, InvalidArgumentError, Shield
from shieldnav.scripted import InspectionAgent

ALL_IDS = sorted(ENV_IDS)


def rollout(env_id: str, seed: int, steps: int | None = None, policy: str = "agent", **kwargs):
    """Runs one episode; returns (observations, rewards, infos, final info + "summary")."""
    env = gym.make(env_id, **kwargs)
    agent = InspectionAgent(env)
    rng = np.random.default_rng(seed)
    obs, info = env.reset(seed=seed)
    agent.reset()
    observations, rewards, infos = [obs], [], []
    k = 0
    while True:
        if policy == "agent":
            action = agent.act(obs, info)
        else:
            action = rng.uniform(-1, 1, 3).astype(np.float32)
        obs, reward, terminated, truncated, info = env.step(action)
        observations.append(obs)
        rewards.append(reward)
        infos.append(info)
        k += 1
        if terminated or truncated or (steps is not None and k >= steps):
            break
    summary = env.unwrapped.episode.summary()
    env.close()
    return observations, rewards, infos, dict(info, summary=summary)


def test_module_colon_id_loads_the_package_first():
    # a fresh interpreter that never imports shieldnav itself
    code = "import gymnasium as gym; e = gym.make('shieldnav:shieldnav/ConstrictedPassage-v0'); print(e.reset(seed=0)[0].shape)"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0 and done.stdout.strip() == "(73,)", done.stderr


@pytest.mark.parametrize("env_id", ALL_IDS)
def test_gymnasium_env_checker_passes(env_id):
    from gymnasium.utils.env_checker import check_env

    # with the defaults (the shield's wall time, the one info entry that is not reproducible,
    # is off by default)
    env = gym.make(env_id, render_mode="rgb_array")
    check_env(env.unwrapped)


@pytest.mark.parametrize("env_id", ALL_IDS)
def test_sb3_env_checker_passes(env_id):
    from stable_baselines3.common.env_checker import check_env

    check_env(gym.make(env_id).unwrapped, warn=True)


def test_dict_observation_passes_the_gymnasium_checker():
    # (SB3's checker rightly warns that an (N, 3) point cloud needs a custom feature extractor:
    # the Dict observation is for scripted agents, the flat one for MlpPolicy)
    from gymnasium.utils.env_checker import check_env

    check_env(gym.make("shieldnav/ConstrictedPassage-v0", observation="dict").unwrapped)


@pytest.mark.parametrize("env_id", ["shieldnav/CorridorInspection-v0", "shieldnav/DynamicObstacles-v0"])
def test_same_seed_same_rollout_bit_for_bit(env_id):
    a = rollout(env_id, seed=3, steps=300, policy="random")
    b = rollout(env_id, seed=3, steps=300, policy="random")
    assert len(a[0]) == len(b[0])
    for x, y in zip(a[0], b[0]):
        assert x.tobytes() == y.tobytes()
    assert a[1] == b[1]
    for x, y in zip(a[2], b[2]):
        assert x["clearance"] == y["clearance"] and x["H"] == y["H"]
        assert x["u_filtered"].tobytes() == y["u_filtered"].tobytes()


def test_another_seed_gives_another_site_and_noise():
    env = gym.make("shieldnav/CorridorInspection-v0")
    o1, _ = env.reset(seed=1)
    name1 = env.unwrapped.episode.name
    o2, _ = env.reset(seed=2)
    assert env.unwrapped.episode.name != name1
    assert o1.tobytes() != o2.tobytes()
    # a preset keeps its site, but the LIDAR noise follows the seed
    env = gym.make("shieldnav/ConstrictedPassage-v0")
    o1, _ = env.reset(seed=1)
    o2, _ = env.reset(seed=2)
    o3, _ = env.reset(seed=1)
    assert o1.tobytes() != o2.tobytes() and o1.tobytes() == o3.tobytes()


def test_info_keys_and_cost_convention():
    env = gym.make("shieldnav/DynamicObstacles-v0", shield="none", report_timing=True)
    env.reset(seed=0)
    keys = {"cost", "collision", "clearance", "H", "h_min", "shield_active", "shield_feasible", "intervention",
            "u_nom", "u_filtered", "coverage", "deadlock", "odometry_error", "solve_time_ns"}
    saw_contact = False
    for _ in range(700):
        # drive straight at the clutter on the left
        _, _, _, _, info = env.step(np.array([1.0, 1.0, 0.0], np.float32))
        assert keys <= set(info)
        assert info["cost"] == (1.0 if info["contacts"] > 0 else 0.0)
        assert info["collision"] == (info["cost"] > 0)
        if info["cost"]:
            saw_contact = True
            assert info["clearance"] < 1e-2
        assert info["u_nom"].shape == (3,) and info["u_filtered"].shape == (3,)
    assert saw_contact, "an unshielded robot driven into the wall touches it"


def test_step_applies_the_shield_to_the_current_scan():
    """The env's u* is exactly the standalone braking Shield's on the same body-frame points
    and body velocity."""
    env = gym.make("shieldnav/DynamicObstacles-v0")
    env.reset(seed=0)
    ep = env.unwrapped.episode
    shield = Shield(method="braking", u_max=list(env.unwrapped.config["v_max"]))
    for k in range(400):
        action = np.array([1.0, 0.6 * np.sin(0.05 * k), 0.3], np.float32)
        points = ep.shield_points()
        # the shield's points are the scan's returns that can reach its 3.5 m crop radius, moved
        # into the current body frame in float32 (the valid points are moved in float64); a
        # return within 1e-4 m of the crop circle may fall either side
        every = ep.valid_points()
        clear = lambda p: np.abs(np.hypot(p[:, 0], p[:, 1]) - 3.5) > 1e-4  # noqa: E731
        inside = every[(np.hypot(every[:, 0], every[:, 1]) <= 3.5) & clear(every)]
        mine = points[(np.hypot(points[:, 0], points[:, 1]) <= 3.5) & clear(points)]
        assert len(mine) == len(inside)
        np.testing.assert_allclose(np.sort(mine, axis=0), np.sort(inside, axis=0), rtol=0, atol=2e-5)
        u_nom = np.array([1.6 * float(action[0]), 0.8 * float(action[1])])
        expected = shield.filter(points, u_nom, yaw=0.0, omega=1.5 * float(action[2]), velocity=ep.velocity)
        _, _, _, _, info = env.step(action)
        assert info["H"] == expected.H and info["h_min"] == expected.h_min
        np.testing.assert_array_equal(info["u_filtered"], [*expected.u, expected.omega])
        assert info["shield_braked"] == expected.braked and info["shield_recovering"] == expected.recovering
        assert info["intervention"] == pytest.approx(np.hypot(*(info["u_filtered"][:2] - info["u_nom"][:2])))


def test_map_paths_expand_home_and_an_image_is_named_as_not_the_yaml(tmp_path, monkeypatch):
    from shieldnav.maps import DEFAULT_MAP

    monkeypatch.setenv("HOME", str(DEFAULT_MAP.parent))
    gym.make("shieldnav/MapInspection-v0", map_path=f"~/{DEFAULT_MAP.name}").reset(seed=0)
    image = tmp_path / "map.png"
    image.write_bytes(b"\x89PNG\r\n\x1a\n\xff\xfe")
    with pytest.raises(shieldnav.MapFileError, match="not text: expected the map's map_server YAML"):
        gym.make("shieldnav/MapInspection-v0", map_path=str(image))


def test_a_site_keyword_given_replaces_the_ids_own_site(tmp_path):
    # Gymnasium merges an id's registered keywords with the user's: scenario_path= on the
    # procedural id was refused as "got procedural=True, scenario_path"
    import json

    from shieldnav.maps import DEFAULT_MAP

    walls = [{"a": [0, -1], "b": [12, -1], "height": 2.0}, {"a": [0, 1], "b": [12, 1], "height": 2.0}]
    path = tmp_path / "corridor.json"
    path.write_text(json.dumps({"name": "my_corridor", "walls": walls, "start": {"x": 2, "y": 0, "yaw": 0}}))
    env = gym.make("shieldnav/CorridorInspection-v0", scenario_path=str(path))
    for seed in (0, 1):
        _, info = env.reset(seed=seed)
        assert info["site"] == "my_corridor"
        for _ in range(5):
            _, _, terminated, truncated, info = env.step(np.array([1.0, 0.0, 0.0], np.float32))
            assert not (terminated or truncated) and info["cost"] == 0
    assert env.unwrapped.episode.true_pose[0] > 2.0
    env.close()
    vec = gym.make_vec("shieldnav/CorridorInspection-v0", num_envs=2, vectorization_mode="vector_entry_point", scenario_path=str(path))
    assert list(vec.reset(seed=0)[1]["site"]) == ["my_corridor"] * 2
    vec.step(np.zeros((2, 3), np.float32))
    vec.close()
    # a map on a preset id, a preset or a procedural site on the map id
    env = gym.make("shieldnav/ConstrictedPassage-v0", map_path=str(DEFAULT_MAP))
    assert env.reset(seed=0)[1]["site"] == gym.make("shieldnav/MapInspection-v0").reset(seed=0)[1]["site"]
    assert env.unwrapped.preset is None
    assert gym.make("shieldnav/MapInspection-v0", preset="odometry_jump").unwrapped.preset == "odometry_jump"
    gym.make("shieldnav/MapInspection-v0", procedural=True).reset(seed=0)
    # procedural=False chooses no site: the preset id keeps its own, the procedural id has none left
    assert gym.make("shieldnav/ConstrictedPassage-v0", procedural=False).unwrapped.preset == "constricted_passage"
    with pytest.raises(InvalidArgumentError, match=r"exactly one of .* \(got none\)"):
        gym.make("shieldnav/CorridorInspection-v0", procedural=False)
    # two sites given are still refused, both named
    for env_id, kwargs, named in [
        ("shieldnav/CorridorInspection-v0", dict(procedural=True, scenario_path=str(path)), "procedural=True, scenario_path"),
        ("shieldnav/ConstrictedPassage-v0", dict(preset="constricted_passage", map_path=str(DEFAULT_MAP)), "preset, map_path"),
        ("shieldnav/MapInspection-v0", dict(map_path=str(DEFAULT_MAP), scenario_path=str(path)), "map_path, scenario_path"),
    ]:
        with pytest.raises(InvalidArgumentError, match=rf"give exactly one of preset, procedural=True, map_path, scenario_path \(got {named}\)"):
            gym.make(env_id, **kwargs)
        with pytest.raises(InvalidArgumentError, match=rf"\(got {named}\)"):
            gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point", **kwargs)


@pytest.mark.parametrize("kwargs", [{"action_mode": "world", "shield": "none"},
                                    {"action_mode": "waypoint", "shield": "none", "controller_u_max": [2.0, 2.0]}])
def test_unshielded_world_and_waypoint_commands_stay_in_the_space(kwargs):
    # (a world-frame command (1, 1) turned into the body frame left the command's bound)
    env = gym.make("shieldnav/ConstrictedPassage-v0", **kwargs)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    for k in range(200):
        action = np.array([1.0, 1.0, 0.3], np.float32) if k % 2 == 0 else rng.uniform(-1, 1, 3).astype(np.float32)
        obs, *_ = env.step(action)
        assert env.observation_space.contains(obs), (k, obs[-3:], env.observation_space.high[-3:])


def test_dict_observation_stays_in_its_space_with_an_offset_mount():
    # the sensor 0.6 m ahead of the body's centre sees 3 m: body-frame points reach 3.6 m
    env = gym.make("shieldnav/ConstrictedPassage-v0", observation="dict", lidar_mount=(0.6, 0.3, 0.5, 0.0), lidar_max_range=3.0)
    obs, _ = env.reset(seed=0)
    valid = obs["points"][obs["valid"].astype(bool)]
    assert np.abs(valid[:, 0]).max() > 3.0, "a point beyond the range from the body's centre"
    assert env.observation_space.contains(obs)
    for _ in range(20):
        obs, *_ = env.step(np.array([1.0, 0.0, 0.0], np.float32))
        assert env.observation_space.contains(obs)


def test_record_episode_statistics_wraps_the_env_and_the_summary_stays():
    # Gymnasium's wrapper owns info["episode"] (it asserted on ours); time_limit ends the episode itself
    env = gym.wrappers.RecordEpisodeStatistics(gym.make("shieldnav/ConstrictedPassage-v0", time_limit=7))
    env.reset(seed=0)
    for k in range(7):
        _, _, terminated, truncated, info = env.step(np.zeros(3, np.float32))
    assert truncated and not terminated
    assert info["episode"]["l"] == 7 and info["shieldnav_episode"]["steps"] == 7
    vec = gym.wrappers.vector.RecordEpisodeStatistics(
        gym.make_vec("shieldnav/ConstrictedPassage-v0", num_envs=2, vectorization_mode="vector_entry_point", max_episode_steps=5))
    vec.reset(seed=0)
    for k in range(5):
        _, _, _, truncated, info = vec.step(np.zeros((2, 3), np.float32))
    assert truncated.all() and list(info["episode"]["l"]) == [5, 5]
    assert list(info["shieldnav_episode"]["steps"]) == [5, 5] and info["_shieldnav_episode"].all()
    vec.close()


def test_bad_actions_and_arguments_raise_named_errors():
    env = gym.make("shieldnav/ConstrictedPassage-v0")
    env.reset(seed=0)
    with pytest.raises(InvalidArgumentError, match="action"):
        env.step(np.array([1.5, 0.0, 0.0], np.float32))
    with pytest.raises(InvalidArgumentError, match="action"):
        env.step(np.array([np.nan, 0.0, 0.0], np.float32))
    with pytest.raises(InvalidArgumentError, match="action"):
        env.step(np.zeros(4, np.float32))
    with pytest.raises(InvalidArgumentError, match="kapa"):
        gym.make("shieldnav/ConstrictedPassage-v0", kapa=3.0)
    with pytest.raises(InvalidArgumentError, match="shield"):
        gym.make("shieldnav/ConstrictedPassage-v0", shield="magic")
    with pytest.raises(InvalidArgumentError, match="gamma"):
        gym.make("shieldnav/ConstrictedPassage-v0", gamma=-1.0)
    with pytest.raises(InvalidArgumentError, match="lidar_bins"):
        gym.make("shieldnav/ConstrictedPassage-v0", lidar_bins=2)
    with pytest.raises(shieldnav.MapFileError):
        gym.make("shieldnav/MapInspection-v0", map_path="/nonexistent/map.yaml")
    # the keyword the user passed is named, not the core's field behind it
    for key, value in [("robot_length", 0.0), ("lidar_noise_std", -1.0), ("yaw_accel_max", -1.0), ("tracker_tau", -1.0),
                       ("lidar_columns", 3), ("lidar_mount", (0.0, 0.0, float("nan"), 0.0)), ("lidar_max_range", -1.0)]:
        with pytest.raises(InvalidArgumentError, match=f"invalid `{key}`"):
            gym.make("shieldnav/ConstrictedPassage-v0", **{key: value})
    # keywords of another kind of site are errors, not silently ignored
    with pytest.raises(InvalidArgumentError, match="invalid `site_kind`: applies to procedural"):
        gym.make("shieldnav/ConstrictedPassage-v0", site_kind="tunnel")
    for key, value in [("simplify", 2.0), ("unknown_is_wall", False), ("unreachable_walls", True)]:
        with pytest.raises(InvalidArgumentError, match=f"invalid `{key}`: applies to ROS map"):
            gym.make("shieldnav/CorridorInspection-v0", **{key: value})
    gym.make("shieldnav/CorridorInspection-v0", site_kind="tunnel").reset(seed=0)
    # the defaults can be passed back in (site keys at their defaults change nothing)
    for env_id in ("shieldnav/ConstrictedPassage-v0", "shieldnav/CorridorInspection-v0"):
        gym.make(env_id, **shieldnav.ENV_DEFAULTS).reset(seed=0)
    # a core name shared by two keywords is the one given; the generator's robot limits name the robot
    with pytest.raises(InvalidArgumentError, match="invalid `controller_u_max`"):
        gym.make("shieldnav/ConstrictedPassage-v0", controller_u_max=[1.0, -1.0])
    with pytest.raises(InvalidArgumentError, match="invalid `robot_length/robot_width`|invalid `robot_width`"):
        gym.make("shieldnav/CorridorInspection-v0", robot_width=0.9)
    # a strided action of three is read, not refused as "shape (3,), got [3]"
    env = gym.make("shieldnav/ConstrictedPassage-v0")
    env.reset(seed=0)
    env.unwrapped.episode.step(np.zeros(6, np.float32)[::2])
    with pytest.raises(InvalidArgumentError, match="invalid `robot_width`"):
        gym.make_vec("shieldnav/ConstrictedPassage-v0", num_envs=2, vectorization_mode="vector_entry_point", robot_width=-1.0)


def test_map_walls_are_simplified_by_default_and_on_request():
    walls = {}
    for tol in (None, 0, 2.0):
        env = gym.make("shieldnav/MapInspection-v0", **({} if tol is None else {"simplify": tol}))
        env.reset(seed=0)
        walls[tol] = len(env.unwrapped._episode.render_data()["walls"])
    assert walls[2.0] < walls[None] < 0.5 * walls[0]
    assert shieldnav.ENV_DEFAULTS["simplify"] == 1.0
    for bad in (-1, float("nan"), "x"):
        with pytest.raises(InvalidArgumentError, match="simplify"):
            gym.make("shieldnav/MapInspection-v0", simplify=bad)


def test_defaults_are_the_papers():
    d = shieldnav.ENV_DEFAULTS
    assert d["semi_axes"] == (0.9, 0.45) and d["gamma"] == 0.9 and d["kappa"] == 8.0 and d["alpha"] == 2.0
    assert d["crop_radius"] == 3.5 and d["safety_distance"] == 0.8 and d["kp"] == 4.0
    assert d["d_view"] == 1.5 and d["gamma_h"] == 0.5 and np.degrees(d["fov_h"]) == pytest.approx(69.4)
    assert d["dt"] == 0.02 and d["lidar_rate_hz"] == 10.0 and d["lidar_columns"] == 1024
    assert d["shield"] == "braking" and d["terminate_on_contact"] is False
    # one source of truth: the mirror cannot be changed behind the core's back
    with pytest.raises(TypeError):
        d["kappa"] = 12.0  # type: ignore[index]
    with pytest.raises(TypeError):
        d["v_max"][0] = 0.4  # type: ignore[index]


def test_observation_layout():
    env = gym.make("shieldnav/ConstrictedPassage-v0", lidar_bins=32)
    obs, _ = env.reset(seed=0)
    assert obs.shape == (41,) and obs.dtype == np.float32
    # counter-clockwise from ahead: bin 8 looks left, 16 behind, 24 right, over the 20 m range;
    # the robot starts at (1, 0) in a room spanning y in [-1.5, 1.5] with its back wall at x = 0
    assert obs[8] == pytest.approx(1.5 / 20.0, abs=2e-3)
    assert obs[16] == pytest.approx(1.0 / 20.0, abs=2e-3)
    assert obs[24] == pytest.approx(1.5 / 20.0, abs=2e-3)
    obs, *_ = env.step(np.array([1.0, 0.0, 0.0], np.float32))
    assert obs[32 + 6] == pytest.approx(1.0)  # last command, normalised
    assert 0.0 < obs[32 + 3] < 1.0  # the tracker's lag


def test_coverage_grows_and_reward_counts_it():
    _, rewards, infos, last = rollout("shieldnav/DynamicObstacles-v0", seed=0)
    cov = [i["coverage"] for i in infos]
    assert all(b >= a for a, b in zip(cov, cov[1:]))
    assert cov[-1] > 0.3
    new = sum(i["new_coverage"] for i in infos)
    assert sum(rewards) == pytest.approx(new - 0.05 * sum(i["intervention"] for i in infos) - sum(i["cost"] for i in infos))


def test_dict_observation_drives_the_agent_like_the_flat_one():
    _, _, a, _ = rollout("shieldnav/ConstrictedPassage-v0", seed=0, steps=200, observation="dict")
    _, _, b, _ = rollout("shieldnav/ConstrictedPassage-v0", seed=0, steps=200)
    for x, y in zip(a, b):
        np.testing.assert_allclose(x["u_nom"], y["u_nom"], atol=1e-5)


# --- the paper's outcomes with the scripted agent -------------------------------------------


def test_scenario1_distance_shield_deadlocks_before_the_gap_composite_passes():
    *_, composite = rollout("shieldnav/ConstrictedPassage-v0", seed=0, shield="composite")
    e = composite["shieldnav_episode"]
    assert e["success"] and e["collisions"] == 0 and not e["deadlock"]
    *_, distance = rollout("shieldnav/ConstrictedPassage-v0", seed=0, shield="distance", truncate_on_deadlock=True)
    e = distance["shieldnav_episode"]
    assert e["deadlock"] and not e["success"] and e["collisions"] == 0
    # stuck with its centre before the gap (cabinet and doorway span x 4.2 - 5.1)
    assert distance["time"] < 20.0


def test_scenario2_odometry_jump_unshielded_hits_the_wall_shielded_goes_on():
    _, _, infos, none = rollout("shieldnav/OdometryJump-v0", seed=0, shield="none")
    first_contact = next(i["time"] for i in infos if i["cost"] > 0)
    assert 20.0 <= first_contact < 23.0, "the jump at 20 s sends the unshielded robot into the wall"
    _, _, infos, comp = rollout("shieldnav/OdometryJump-v0", seed=0, shield="composite")
    assert comp["shieldnav_episode"]["collisions"] == 0
    assert max(i["odometry_error"] for i in infos) > 100.0
    after = [i for i in infos if i["time"] > 20.0]
    assert after[-1]["time"] > 45.0 and comp["shieldnav_episode"]["path_length"] > 30.0


def test_scenario3_moving_chair_and_door_composite_zero_contacts_none_collides():
    _, _, infos, comp = rollout("shieldnav/DynamicObstacles-v0", seed=0, shield="composite")
    e = comp["shieldnav_episode"]
    assert e["collisions"] == 0 and e["success"], e
    assert e["time"] > 22.0, "it met the door swinging open from 20 s to 22 s"
    *_, none = rollout("shieldnav/DynamicObstacles-v0", seed=0, shield="none")
    assert none["shieldnav_episode"]["collisions"] > 0


@pytest.mark.expensive
@pytest.mark.parametrize("policy", ["agent", "random"])
def test_corridor_inspection_shielded_never_touches_a_wall(policy):
    for seed in range(20):
        *_, last = rollout("shieldnav/CorridorInspection-v0", seed=seed, policy=policy, steps=1000)
        assert last["summary"]["contact_steps"] == 0, (seed, last["summary"])


def test_reset_info_coverage_timing_totals_and_keyword_checks():
    env = gym.make("shieldnav/DynamicObstacles-v0")
    _, info = env.reset(seed=0)
    # the first scan, at reset, already inspects walls: the reset info says so
    assert info["coverage"] == env.unwrapped.episode.summary()["coverage"] > 0.0
    _, _, _, _, step = env.step(np.zeros(3, np.float32))
    assert step["coverage"] >= info["coverage"]
    # wall-clock entries only with report_timing: two runs with one seed give equal infos
    totals = []
    for timing in (False, False, True):
        e = gym.make("shieldnav/ConstrictedPassage-v0", time_limit=5, report_timing=timing)
        e.reset(seed=3)
        for _ in range(5):
            *_, last = e.step(np.zeros(3, np.float32))
        totals.append(last["shieldnav_episode"])
    assert repr(totals[0]) == repr(totals[1]) and "solve_time_mean_ns" not in totals[0]  # (repr: NaN entries)
    assert totals[2]["solve_time_max_ns"] > 0 and set(totals[2]) - set(totals[0]) == {"solve_time_mean_ns", "solve_time_max_ns"}
    for kwargs, name in [({"report_timing": "no"}, "report_timing"), ({"seed": 3}, "seed"), ({"preset": 5}, "preset")]:
        with pytest.raises(InvalidArgumentError, match=f"invalid `{name}`"):
            shieldnav.CorridorInspectionEnv(**{"preset": "constricted_passage", **kwargs})
    for name in ("map_path", "scenario_path"):
        with pytest.raises(InvalidArgumentError, match=f"invalid `{name}`: expected a file path"):
            shieldnav.CorridorInspectionEnv(**{name: 123})


def test_the_episode_applies_its_time_limit_once():
    # the id registers its time limit as the episode's `time_limit`, with no TimeLimit wrapper on top
    for env_id, (_, steps) in ENV_IDS.items():
        assert gym.spec(env_id).max_episode_steps is None and gym.spec(env_id).kwargs["time_limit"] == steps, env_id
    env = gym.make("shieldnav/ConstrictedPassage-v0", time_limit=5)
    wrapper = env
    while isinstance(wrapper, gym.Wrapper):
        assert not isinstance(wrapper, gym.wrappers.TimeLimit)
        wrapper = wrapper.env
    env.reset(seed=0)
    ends = [env.step(np.zeros(3, np.float32)) for _ in range(5)]
    assert [truncated for _, _, _, truncated, _ in ends] == [False] * 4 + [True]
    assert "shieldnav_episode" in ends[-1][4] and "shieldnav_episode" not in ends[-2][4]
    env.close()
