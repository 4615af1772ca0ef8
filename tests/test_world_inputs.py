"""Keywords of `World` and of the environments that do not apply are errors naming them (they
were silently ignored), and scenario files' starts, shapes and faults are checked."""

import json

import gymnasium as gym
import numpy as np
import pytest
import shieldnav  # noqa: F401  (registers the ids)
from shieldnav import InvalidArgumentError, World


@pytest.mark.parametrize(
    "kw, key",
    [
        (dict(preset="constricted_passage", kind="tunnel"), "`kind`"),
        (dict(preset="constricted_passage", unknown_is_wall=False), "`unknown_is_wall`"),
        (dict(procedural=3, unreachable_walls=True), "`unreachable_walls`"),
        (dict(procedural=True), "`procedural`"),
        (dict(procedural=-1), "`procedural`"),
        (dict(preset="constricted_passage", seed=-1), "`seed`"),
        (dict(preset="constricted_passage", vertical_fov=(-0.3, 0.3)), "`vertical_fov`"),
        (dict(procedural=4, robot_length=1.6, robot_width=1.2), "`robot_length/robot_width`"),
    ],
)
def test_world_keywords_that_do_not_apply_are_errors(kw, key):
    with pytest.raises(InvalidArgumentError, match=key):
        World(**kw)


def test_world_procedural_sites_admit_the_robot_given():
    """A generated site is checked for the robot it will carry, not the default one."""
    built = 0
    for site in range(6):
        try:
            w = World(procedural=site, robot_length=1.3, robot_width=0.7)
        except InvalidArgumentError as e:
            assert "`procedural`" in str(e) and f"site {site}" in str(e)
            continue
        built += 1
        assert w.contacts[0] == 0
    assert built >= 2
    World(preset="constricted_passage", channels=16, vertical_fov=(-0.3, 0.3))


@pytest.mark.parametrize(
    "kw, message",
    [
        (dict(preset="constricted_passage", map_path="x.yaml"), "exactly one of preset, procedural=True, map_path, scenario_path \\(got preset, map_path\\)"),
        (dict(procedural=7), "`procedural`: expected True or False, got 7"),
        (dict(lidar_vertical_fov=(-0.3, 0.3)), "`lidar_vertical_fov`"),
    ],
)
def test_env_site_and_lidar_errors_name_the_env_keywords(kw, message):
    with pytest.raises(InvalidArgumentError, match=message):
        gym.make("shieldnav/ConstrictedPassage-v0", **kw)


def _scenario(tmp_path, **changes):
    s = {
        "walls": [{"a": [-5, 1.5], "b": [15, 1.5], "height": 2.0}, {"a": [-5, -1.5], "b": [15, -1.5], "height": 2.0}],
        "polygons": [{"vertices": [[4, -1.5], [6, -1.5], [6, -0.5], [4, -0.5]], "height": 1.0}],
        "start": {"x": 0, "y": 0, "yaw": 0},
    }
    s.update(changes)
    path = tmp_path / "s.json"
    path.write_text(json.dumps(s))
    return str(path)


@pytest.mark.parametrize(
    "start, what",
    [({"x": 0, "y": 1.3, "yaw": 0}, "crosses or touches the wall"), ({"x": 5, "y": -1.0, "yaw": 0}, "inside polygons\\[0\\]")],
)
def test_a_start_where_the_robot_cannot_stand_is_an_error(tmp_path, start, what):
    World(scenario=_scenario(tmp_path))
    with pytest.raises(InvalidArgumentError, match=f"`start`.*{what}"):
        World(scenario=_scenario(tmp_path, start=start))


def test_nested_unknown_keys_and_non_convex_obstacles_are_errors(tmp_path):
    walls = [{"a": [-5, 1.5], "b": [15, 1.5], "height": 2.0, "one_sidd": True}]
    with pytest.raises(shieldnav.MapFileError, match="one_sidd"):
        World(scenario=_scenario(tmp_path, walls=walls))
    notch = {"vertices": [[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [0.0, 0.0], [-0.5, 0.5]], "height": 1.0}
    obstacles = [{"name": "c", "shape": notch, "trajectory": {"keys": [[0.0, {"x": 8, "y": 0, "yaw": 0}]]}}]
    with pytest.raises(shieldnav.MapFileError, match="must be convex"):
        World(scenario=_scenario(tmp_path, obstacles=obstacles))


def test_odometry_faults_at_the_start_apply_from_it(tmp_path):
    odo = {"translation_noise": 0.0, "yaw_noise": 0.0, "yaw_bias": 0.0, "faults": [{"kind": "jump", "time": 0.0, "dx": 2.0, "dy": 0.5}]}
    w = World(scenario=_scenario(tmp_path, odometry=odo))
    np.testing.assert_allclose(np.asarray(w.estimated_pose) - np.asarray(w.true_pose), [2.0, 0.5, 0.0])
