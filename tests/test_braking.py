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
    # 1.4 m to the wall at 1.6 m/s: the ellipse's nose is 0.5 m off, the robot needs 0.66 m to stop
    pts = wall_ahead(1.4)
    braking = Shield(method="braking").filter(pts, [1.6, 0.0], omega=0.0, velocity=[1.6, 0.0, 0.0])
    assert braking.braked and np.all(braking.u == 0.0) and braking.omega == 0.0
    assert braking.sweep_h < 0.0
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
    out = Shield(method="braking").filter(np.array([[0.0, 0.3]]), [0.0, 0.5], velocity=[0.0, 0.0, 0.0])
    assert out.recovering and not out.braked and np.isnan(out.sweep_h)
    assert out.u[1] < 0.0, "it moves away from the point on its left"


@pytest.mark.parametrize(
    "kwargs, name",
    [({"tracker_tau": -1.0}, "tracker_tau"), ({"dt": 0.0}, "dt"), ({"brake_margin": -0.1}, "brake_margin"),
     ({"yaw_accel_max": 0.0}, "yaw_accel_max"), ({"w_max": float("nan")}, "w_max"), ({"method": "brake"}, "method")],
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
    static = [r for r in results if not r["dynamic"]]
    braking = [r for r in static if r["shield"] == "braking"]
    paper = [r for r in static if r["shield"] == "composite"]
    assert sum(r["episodes"] for r in braking) >= 12
    assert sum(r["contact_steps"] for r in braking) == 0, braking
    assert sum(r["contact_steps"] for r in paper) > 0, "the attackers were expected to beat the paper's filter"
    assert (tmp_path / "redteam.json").exists()
