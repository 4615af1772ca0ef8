"""Moving objects: the shield's `movers` argument, the environments' mover tracking, and the
outcome the issue asks for (no contact begins with the robot moving)."""

import json

import gymnasium as gym
import numpy as np
import pytest
import shieldnav  # noqa: F401
from shieldnav import InvalidArgumentError, Shield


def test_a_mover_coming_head_on_stops_the_robot_before_it_arrives():
    # a walker 3 m ahead coming at 1.5 m/s; the robot at 1.6 m/s toward it: 0.8 s of braking
    # and the walker's 1.2 m leave no room to go on
    mover = np.array([[3.0, 0.0, -1.5, 0.0, 0.3, 0.1]])
    empty = np.zeros((0, 2))
    sh = Shield(method="braking")
    blind = sh.filter(empty, [1.6, 0.0], omega=0.0, velocity=[1.6, 0.0, 0.0])
    assert not blind.active and blind.u[0] == pytest.approx(1.6)
    seen = sh.filter(empty, [1.6, 0.0], omega=0.0, velocity=[1.6, 0.0, 0.0], movers=mover)
    assert seen.active and seen.braked and seen.u[0] == 0.0
    # a mover walking away, or one far off the path, does not hold the robot back
    for other in ([3.0, 0.0, 1.5, 0.0, 0.3], [3.0, 4.0, -1.5, 0.0, 0.3]):
        out = sh.filter(empty, [1.6, 0.0], omega=0.0, velocity=[1.6, 0.0, 0.0], movers=np.array([other]))
        assert out.u[0] == pytest.approx(1.6), other


def test_the_composite_row_takes_a_movers_motion_into_dh_dt():
    pts = np.array([[1.0, 0.0]])
    sh = Shield()
    still = sh.filter(pts, [0.0, 0.0])
    coming = sh.filter(pts, [0.0, 0.0], movers=np.array([[1.0, 0.0, -1.5, 0.0, 0.0]]))
    assert still.dH_dt == 0.0 and coming.dH_dt < 0.0
    # the row now asks the standing robot to back away
    assert coming.active and coming.u[0] < 0.0


@pytest.mark.parametrize(
    "movers, match",
    [
        (np.zeros((1, 4)), "5 or 6 columns"),
        (np.array([[1.0, 0.0, np.nan, 0.0, 0.3]]), "finite"),
        (np.array([[1.0, 0.0, 20.0, 0.0, 0.3]]), "at most"),
        (np.array([[1.0, 0.0, 0.0, 0.0, -0.3]]), "radius"),
        ([[1.0, 0.0]], "float64"),
    ],
)
def test_bad_movers_are_named(movers, match):
    with pytest.raises(InvalidArgumentError, match="movers") as e:
        Shield(method="braking").filter(np.zeros((0, 2)), [0.0, 0.0], velocity=[0.0, 0.0, 0.0], movers=movers)
    assert match in str(e.value)
    with pytest.raises(InvalidArgumentError, match="mover_accel"):
        Shield(mover_accel=-1.0)


SQUARE = {"vertices": [[-0.25, -0.25], [0.25, -0.25], [0.25, 0.25], [-0.25, 0.25]], "height": 1.8}


def walker_scenario(tmp_path, waypoints, speed):
    room = [[-20.0, -8.0], [20.0, -8.0], [20.0, 8.0], [-20.0, 8.0]]
    scenario = {
        "name": "walker",
        "walls": [{"a": room[k], "b": room[(k + 1) % 4], "height": 2.0} for k in range(4)],
        "start": {"x": 0.0, "y": 0.0, "yaw": 0.0},
        "obstacles": [{"name": "walker", "shape": SQUARE, "walk": {"waypoints": waypoints, "speed": speed}}],
    }
    path = tmp_path / "walker.json"
    path.write_text(json.dumps(scenario))
    return path


def episode_totals(path, steps=500, **kwargs):
    env = gym.make("shieldnav/CorridorInspection-v0", scenario_path=str(path), **kwargs)
    env.reset(seed=0)
    movers = 0
    for _ in range(steps):
        _, _, terminated, truncated, info = env.step(np.array([1.0, 0.0, 0.0], dtype=np.float32))
        movers = max(movers, info["movers"])
        if terminated or truncated:
            break
    totals = env.unwrapped.episode.summary()
    env.close()
    return totals, movers


def test_a_pedestrian_head_on_is_not_driven_into(tmp_path):
    path = walker_scenario(tmp_path, [[7.0, -0.2], [-19.0, -0.2]], 1.2)
    tracked, movers = episode_totals(path)
    assert movers >= 1 and tracked["mover_steps"] > 0
    assert tracked["moving_collisions"] == 0, tracked
    blind, _ = episode_totals(path, track_movers=False)
    assert blind["moving_collisions"] > 0, "taken as static, the walker was expected to be driven into"
    assert tracked["contact_steps"] < blind["contact_steps"]


def test_an_escape_once_sent_is_kept_until_reset():
    # a walker 4 m ahead coming at 1.5 m/s, a wall 1.5 m behind: the robot steps aside, away
    # from the walker's side. Seen a little to the other side at the next call, the walker
    # would send it the other way; the escape running is kept (near-equal escapes alternated
    # and went nowhere) until reset() forgets it
    wall = np.array([[-1.5, y] for y in np.linspace(-4.0, 4.0, 81)])
    sh = Shield(method="braking")

    def step(side):
        walker = np.array([[4.0, side, -1.5, 0.0, 0.3, 0.1]])
        return sh.filter(wall, [0.0, 0.0], omega=0.0, velocity=[0.0, 0.0, 0.0], movers=walker).u

    first = step(0.1)
    assert first[1] == pytest.approx(-0.8) and first[0] == pytest.approx(0.0, abs=1e-9)
    assert step(-0.1)[1] == pytest.approx(-0.8)
    sh.reset()
    assert step(-0.1)[1] == pytest.approx(0.8)
