"""Hostile input never crashes the process and every refusal names its argument (issue cases
found by fuzzing): Shield keywords of the wrong type or out of range, views of a stepping world
(test_world.py), map images that declare huge sizes or never end (Rust unit tests)."""

from __future__ import annotations

import numpy as np
import pytest
from shieldnav import Shield
from shieldnav.exceptions import InvalidArgumentError


@pytest.mark.parametrize("kwargs, name", [
    ({"angular_bins": -1}, "angular_bins"),
    ({"angular_bins": 2**64}, "angular_bins"),
    ({"crop_radius": 10**400}, "crop_radius"),
    ({"kappa": "8"}, "kappa"),
    ({"gamma": True}, "gamma"),
    ({"alpha": 1 + 2j}, "alpha"),
    ({"semi_axes": (0.9 + 1j, 0.45)}, "semi_axes"),
    ({"semi_axes": "ab"}, "semi_axes"),
    ({"u_max": (True, 1.0)}, "u_max"),
    ({"height_band": (0.1, 0.2, 0.3)}, "height_band"),
    ({"voxel_size": [0.1]}, "voxel_size"),
    ({"a_max": 2.0}, "a_max"),
    ({"rotation_weight": None}, "rotation_weight"),
])
def test_shield_keywords_of_the_wrong_type_name_themselves(kwargs, name):
    with pytest.raises(InvalidArgumentError, match=f"invalid `{name}`"):
        Shield(**kwargs)


def test_a_yaw_no_float_holds_names_yaw():
    with pytest.raises(InvalidArgumentError, match="invalid `yaw`"):
        Shield().filter(np.array([[1.0, 0.5]]), np.array([1.0, 0.0]), yaw=10**400)


@pytest.mark.parametrize("scan", [{"voxel_size": 1.0}, {"angular_bins": 16}])
def test_a_point_at_1e155_m_is_down_sampled_without_a_panic(scan):
    points, u_nom = np.array([[0.0, 1e155], [1.0, 0.0]]), np.array([1.0, 0.0])
    outcomes = []
    for shield in (Shield(crop_radius=None), Shield(crop_radius=None, **scan)):
        try:
            out = shield.filter(points, u_nom)
            outcomes.append(("ok", tuple(out.u), out.num_points))
        except InvalidArgumentError as err:  # a PanicException (a BaseException) would escape
            outcomes.append(("error", str(err)))
    assert outcomes[0] == outcomes[1]


@pytest.mark.parametrize("method", ["none", "composite", "braking", "hardmin", "distance"])
def test_an_angular_velocity_no_robot_has_names_omega(method):
    kwargs = {"velocity": [0.0, 0.0, 0.0]} if method == "braking" else {}
    with pytest.raises(InvalidArgumentError, match="invalid `omega`"):
        Shield(method=method).filter(np.array([[1.0, 0.5]]), np.array([1.0, 0.0]), omega=1e308, **kwargs)
    out = Shield(method=method).filter(np.array([[1.0, 0.5]]), np.array([1.0, 0.0]), omega=1e4, **kwargs)
    assert np.isfinite(out.dH_dt) and np.all(np.isfinite(out.u))


def test_feasible_on_the_clarabel_path_means_the_row_and_the_box_hold():
    # a nominal command of 2e16 m/s: Clarabel stops 6e-4 short of the row
    out = Shield().filter(np.array([[0.0, -0.6]]), np.array([2.2e16, -6.4]), extra_A=np.zeros((0, 2)), extra_b=np.zeros(0))
    b = -2.0 * out.H - out.dH_dt
    assert not out.feasible or float(np.dot(out.grad_p[:2], out.u)) >= b - 1e-9 * max(abs(b), 1.0)
    # a box of 1e-300 m/s on x: the command stays in it
    out = Shield(method="distance", u_max=(1e-300, 1.0)).filter(np.array([[0.5, 0.1], [1.0, -0.3]]), np.array([1.0, 0.2]))
    assert abs(out.u[0]) <= 1e-300 and abs(out.u[1]) <= 1.0


def test_a_map_of_open_floor_is_refused_as_a_map_file_error(tmp_path):
    from shieldnav import World
    from shieldnav.exceptions import MapFileError

    w, h = 600, 400
    (tmp_path / "free.pgm").write_bytes(f"P5\n{w} {h}\n255\n".encode() + bytes([254]) * (w * h))
    (tmp_path / "free.yaml").write_text("image: free.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n")
    with pytest.raises(MapFileError, match="no free region inside the building"):
        World(ros_map=str(tmp_path / "free.yaml"))


@pytest.mark.parametrize("yaw", ["", 10**400, True])
def test_filter_world_names_a_yaw_of_the_wrong_type(yaw):
    with pytest.raises(InvalidArgumentError, match="invalid `yaw`"):
        Shield().filter_world(np.array([[1.0, 0.5]]), np.array([1.0, 0.0]), np.zeros(2), yaw=yaw)


def test_a_brake_margin_out_of_range_names_brake_margin():
    with pytest.raises(InvalidArgumentError, match="invalid `brake_margin`"):
        Shield(brake_margin=2.76e16)


@pytest.mark.parametrize("u_nom", [(0.0, 1.04e10), (-3e12, 5e11), (1e16, 0.0)])
def test_extra_rows_with_a_huge_nominal_command_are_solved(u_nom):
    # the braking shield's box against a nominal command of 1e10 m/s and more, by Clarabel
    out = Shield(method="braking").filter(
        np.array([[0.0, 2.0], [1.0, -2.0]]), np.array(u_nom), extra_A=np.array([[0.0, -1.0]]), extra_b=np.array([0.0]), velocity=[0.0, 0.0, 0.0]
    )
    assert np.all(np.abs(out.u) <= [1.6, 0.8])
    assert out.feasible and -out.u[1] >= -1e-9


def test_an_observation_mode_of_no_string_names_observation():
    import gymnasium as gym

    with pytest.raises(InvalidArgumentError, match="invalid `observation`"):
        gym.make("shieldnav/ConstrictedPassage-v0", observation=np.array([True, True]))


def test_a_robot_too_wide_for_the_start_names_robot_width():
    import gymnasium as gym

    with pytest.raises(InvalidArgumentError, match="robot_width"):
        gym.make("shieldnav/OdometryJump-v0", robot_width=6.2e16)


@pytest.mark.parametrize("method", [None, 3, b"composite", ["composite"]])
def test_a_method_of_no_string_names_method(method):
    with pytest.raises(InvalidArgumentError, match="invalid `method`"):
        Shield(method=method)


def test_a_yaw_rate_limit_beyond_the_body_rate_limit_names_w_max():
    import gymnasium as gym

    # (the env's rotation command reaches w_max, which the shield refuses beyond 1e4 rad/s)
    with pytest.raises(InvalidArgumentError, match="invalid `w_max`"):
        gym.make("shieldnav/OdometryJump-v0", w_max=14370)
    with pytest.raises(InvalidArgumentError, match="invalid `w_max`"):
        Shield(method="braking", w_max=2e4)


@pytest.mark.parametrize("name", ["coverage_reward", "collision_penalty", "intervention_penalty"])
def test_a_reward_weight_that_could_make_the_reward_infinite_names_itself(name):
    """Found by fuzzing: `intervention_penalty=1e308` made a step's reward -inf."""
    import gymnasium as gym

    with pytest.raises(InvalidArgumentError, match=f"invalid `{name}`: must be within ±1e6"):
        gym.make("shieldnav/DynamicObstacles-v0", **{name: -1e308})
    env = gym.make("shieldnav/DynamicObstacles-v0", **{name: 1e6})  # the limit itself is accepted
    env.reset(seed=1)
    for _ in range(20):
        obs, reward, *_ = env.step(np.array([1.0, 1.0, 1.0], np.float32))
        assert np.isfinite(reward) and np.all(np.isfinite(obs))
