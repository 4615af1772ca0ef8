"""The braking shield: the standalone `Shield(method="braking")`, the environments' default,
and a short red-team run (the full one is `python -m agents.redteam`)."""

import gymnasium as gym
import numpy as np
import pytest
import shieldnav  # noqa: F401
from shieldnav import InvalidArgumentError, Shield

from agents import redteam


def wall_ahead(distance, n=200):
    y = np.linspace(-2.0, 2.0, n)
    return np.column_stack([np.full(n, distance), y])


def test_full_speed_at_a_wall_brakes_where_the_paper_filter_does_not():
    # 1.2 m to the wall at 1.6 m/s: the body's nose is 0.65 m off, the robot needs 0.66 m to stop
    pts = wall_ahead(1.2)
    braking = Shield(method="braking").filter(pts, [1.6, 0.0], omega=0.0, velocity=[1.6, 0.0, 0.0])
    assert braking.braked and np.all(braking.u == 0.0) and braking.omega == 0.0
    assert braking.sweep_h < 0.0 and abs(braking.clearance - 0.65) < 0.01
    paper = Shield(method="composite", u_max=(1.6, 0.8)).filter(pts, [1.6, 0.0])
    assert paper.u[0] > 0.0, "the single-integrator row still lets it drive on"
    # standing, the same command passes (scaled at most): nothing to brake for
    standing = Shield(method="braking").filter(pts, [1.6, 0.0], omega=0.0, velocity=[0.0, 0.0, 0.0])
    assert not standing.braked and standing.u[0] > 0.0


def test_rotation_is_filtered_and_reported():
    pts = np.array([[0.65, 0.36]])
    out = Shield(method="braking").filter(pts, [0.0, 0.0], omega=1.5, velocity=[0.0, 0.0, 0.0])
    assert out.active and 0.0 <= out.omega < 1.5
    away = Shield(method="braking").filter(pts, [0.0, 0.0], omega=-1.5, velocity=[0.0, 0.0, 0.0])
    assert away.omega == -1.5 and not away.active
    # the paper's filter passes the turn through
    assert Shield().filter(pts, [0.0, 0.0], omega=1.5).omega == 1.5


def test_inside_the_ellipse_it_recovers_away_from_the_point():
    # 0.05 m beside the body (0.25 m half-width): inside the ellipse, outside the margin
    out = Shield(method="braking").filter(np.array([[0.0, 0.3]]), [0.0, 0.0], velocity=[0.0, 0.0, 0.0])
    assert out.recovering and not out.braked and abs(out.clearance - 0.05) < 1e-9
    assert out.u[1] < 0.0, "it moves away from the point on its left"
    # driven toward the point, the body may approach it as far as the check allows
    toward = Shield(method="braking").filter(np.array([[0.0, 0.3]]), [0.0, 0.5], velocity=[0.0, 0.0, 0.0])
    assert toward.tight and toward.u[1] > 0.0 and toward.sweep_h >= 0.0


def test_within_the_margin_no_command_brings_a_point_nearer():
    # 0.02 m beside the body, within the 0.04 m the check keeps; the nominal pushes into it
    pts = np.array([[x, 0.27] for x in np.linspace(-1.0, 1.0, 41)])
    sh = Shield(method="braking")
    for u_nom, omega, v0 in [([0.0, 0.8], 0.0, [0.0, 0.0, 0.0]), ([1.6, 0.8], 1.5, [0.0, 0.1, 0.0]), ([0.0, 0.0], -1.5, [0.0, 0.0, 0.0])]:
        out = sh.filter(pts, u_nom, omega=omega, velocity=v0)
        assert out.clearance == pytest.approx(0.02)
        # replay the command and the brake: no point comes nearer
        assert out.u[1] <= 1e-12, (u_nom, omega, out.u, out.omega)


def test_a_narrow_aisle_is_driven_along_at_the_tight_space_speed():
    # walls 0.4 m either side of the centre: the ellipse (0.45 m) does not fit, the body does
    x = np.linspace(-3.0, 3.0, 241)
    pts = np.concatenate([np.column_stack([x, np.full_like(x, 0.4)]), np.column_stack([x, np.full_like(x, -0.4)])])
    out = Shield(method="braking").filter(pts, [1.6, 0.0], omega=0.0, velocity=[0.3, 0.0, 0.0])
    assert out.recovering and out.tight and not out.braked
    assert 0.0 < out.u[0] <= 0.5 + 1e-12 and abs(out.u[1]) < 1e-9
    slow = Shield(method="braking", tight_speed=0.2).filter(pts, [1.6, 0.0], omega=0.0, velocity=[0.3, 0.0, 0.0])
    assert 0.0 < slow.u[0] <= 0.2 + 1e-12


def test_the_footprint_decides_what_passes():
    # a point 0.3 m beside the centre: clear of the default 0.5 m wide body, inside a 0.7 m wide one
    pts = np.array([[0.0, 0.3]])
    assert Shield(method="braking").filter(pts, [0.0, 0.0], velocity=[0, 0, 0]).clearance == pytest.approx(0.05)
    wide = Shield(method="braking", footprint=(1.1, 0.7)).filter(pts, [0.0, 0.0], velocity=[0, 0, 0])
    assert wide.clearance == pytest.approx(-0.05)
    polygon = [[0.6, 0.0], [0.0, 0.35], [-0.5, 0.25], [-0.5, -0.25], [0.0, -0.35]]
    sh = Shield(method="braking", footprint=polygon)
    assert sh.config["footprint"][0] == [0.6, 0.0]
    assert sh.filter(pts, [0.0, 0.0], velocity=[0, 0, 0]).clearance < 0.0
    assert Shield(method="braking", lidar_noise_std=0.05).filter(pts, [0.0, 0.0], velocity=[0, 0, 0]).clearance == pytest.approx(0.05)


@pytest.mark.parametrize(
    "kwargs, name",
    [({"tracker_tau": -1.0}, "tracker_tau"), ({"dt": 0.0}, "dt"), ({"brake_margin": -0.1}, "brake_margin"),
     ({"yaw_accel_max": 0.0}, "yaw_accel_max"), ({"w_max": float("nan")}, "w_max"), ({"method": "brake"}, "method"),
     ({"lidar_noise_std": -0.01}, "lidar_noise_std"), ({"lidar_noise_std": "0.1"}, "lidar_noise_std"),
     ({"tight_speed": -1.0}, "tight_speed"), ({"tight_speed": float("inf")}, "tight_speed"),
     ({"footprint": [[1.0, 0.0], [0.0, 1.0]]}, "footprint"), ({"footprint": [[1.0, 1.0], [2.0, 1.0], [2.0, 2.0]]}, "footprint"),
     ({"footprint": "square"}, "footprint"), ({"footprint": (0.0, 0.5)}, "footprint"),
     ({"footprint": [[1, 1], [-1, 1], [0, 0.5], [-1, -1], [1, -1]]}, "footprint")],
)
def test_bad_parameters_name_themselves(kwargs, name):
    with pytest.raises(InvalidArgumentError, match=name):
        Shield(method="braking", **{k: v for k, v in kwargs.items() if k != "method"}) if "method" not in kwargs else Shield(**kwargs)


def test_velocity_is_required_and_checked():
    sh = Shield(method="braking")
    pts = wall_ahead(3.0)
    with pytest.raises(InvalidArgumentError, match="velocity"):
        sh.filter(pts, [1.0, 0.0])
    with pytest.raises(InvalidArgumentError, match="velocity"):
        sh.filter(pts, [1.0, 0.0], velocity=[1.0, 0.0])
    with pytest.raises(InvalidArgumentError, match="velocity"):
        sh.filter(pts, [1.0, 0.0], velocity=[np.nan, 0.0, 0.0])


def test_environments_default_to_the_braking_shield():
    env = gym.make("shieldnav/ConstrictedPassage-v0")
    env.reset(seed=0)
    _, _, _, _, info = env.step(np.array([1.0, 1.0, 1.0], dtype=np.float32))
    assert "shield_braked" in info and "shield_recovering" in info
    assert env.unwrapped.config["shield"] == "braking"
    env.close()


def test_red_team_smoke_no_contact_under_the_braking_shield(tmp_path):
    results = redteam.main(["--quick", "--episodes", "12", "--num-envs", "4", "--steps", "400",
                            "--shields", "braking", "composite", "--out", str(tmp_path)])
    static = [r for r in results if r["worlds"] in ("static", "tight")]
    assert {r["worlds"] for r in results} == {"static", "tight", "moving", "movers"}
    # with movers, no contact event begins with the robot moving
    assert sum(r["moving_contact_events"] for r in results if r["worlds"] == "movers" and r["shield"] == "braking") == 0
    braking = [r for r in static if r["shield"] == "braking"]
    paper = [r for r in static if r["shield"] == "composite"]
    assert sum(r["episodes"] for r in braking) >= 12
    assert sum(r["contact_steps"] for r in braking) == 0, braking
    assert sum(r["contact_steps"] for r in paper) > 0, "the attackers were expected to beat the paper's filter"
    assert (tmp_path / "redteam.json").exists()


@pytest.mark.parametrize(
    "kwargs, name",
    [({"footprint": [[1.0, 0.0], [0.0, 1.0]]}, "footprint"), ({"footprint": "square"}, "footprint"),
     ({"tight_speed": -1.0}, "tight_speed"), ({"lidar_noise_std": 2.0}, "lidar_noise_std")],
)
def test_environment_shield_keywords_name_themselves(kwargs, name):
    with pytest.raises(InvalidArgumentError, match=name):
        gym.make("shieldnav/CorridorInspection-v0", **kwargs)


def test_environment_footprint_defaults_to_the_body_and_takes_a_polygon():
    env = gym.make("shieldnav/CorridorInspection-v0")
    assert env.unwrapped.config["footprint"] is None
    env.reset(seed=0)
    _, _, _, _, info = env.step(np.zeros(3, dtype=np.float32))
    assert info["shield_tight"] is False
    wide = [[0.6, 0.3], [-0.6, 0.3], [-0.6, -0.3], [0.6, -0.3]]
    env = gym.make("shieldnav/CorridorInspection-v0", footprint=wide, time_limit=3)
    assert np.allclose(env.unwrapped.config["footprint"], wide)
    env.reset(seed=0)
    for _ in range(3):
        *_, info = env.step(np.zeros(3, dtype=np.float32))
    assert info["shieldnav_episode"]["shield_tight_steps"] == 0
    env.close()
