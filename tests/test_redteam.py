"""The red team's tight-space sites (agents.tight): every one starts the robot contact-free,
with the clearance it names, in an aisle or doorway of the width it names. ``--set`` passes
environment keywords to every cell, checked before any runs."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest
import shieldnav  # noqa: F401

from agents import redteam
from agents.tight import HALF_LENGTH, HALF_WIDTH, scenario_file, tight_sites

SITES = tight_sites(seed=0)


def test_the_families_and_widths_are_all_there():
    names = [s["site"] for s in SITES]
    assert len(names) == len(set(names)) == 27
    assert [s["width"] for s in SITES if s["site"].startswith("aisle-")] == [0.60, 0.65, 0.70, 0.75, 0.80, 0.85, 0.90]
    assert min(s["width"] for s in SITES if s["site"].startswith("L-")) == 0.65
    assert {s["site"] for s in SITES if s["site"].startswith(("beside", "facing", "corner"))} == {
        "beside-0.05", "beside-0.10", "facing-0.10", "facing-0.20", "corner-0.15", "corner-0.20"}
    assert all(0.02 <= s["gap"] <= 0.26 for s in SITES), [(s["site"], s["gap"]) for s in SITES]
    # the jitter follows the seed, the names and geometry stay
    other = tight_sites(seed=1)
    assert [s["site"] for s in other] == names and other[0]["scenario"]["start"] != SITES[0]["scenario"]["start"]
    # the red team's --tight runs exactly these, reported apart
    assert [s["site"] for s in redteam.sites(None) if s["worlds"] == "tight"] == names


def free_width(points: np.ndarray, x0: float, x1: float) -> float:
    """The free width across x in [x0, x1]: the nearest return on the left plus the right."""
    near = points[(points[:, 0] > x0) & (points[:, 0] < x1)]
    return float(near[near[:, 1] > 0, 1].min() - near[near[:, 1] < 0, 1].max())


@pytest.mark.parametrize("site", SITES, ids=[s["site"] for s in SITES])
def test_tight_start_is_contact_free_and_as_named(site, tmp_path):
    start = site["scenario"]["start"]
    env = gym.make(redteam.TIGHT_ID, scenario_path=scenario_file(site["scenario"], tmp_path), observation="dict", lidar_noise_std=0.0)
    for seed in (0, 1):
        obs, info = env.reset(seed=seed)
        assert info["site"] == site["site"]
        # the scan in the start's frame, aligned with the site (its walls along x and y)
        c, s = np.cos(start["yaw"]), np.sin(start["yaw"])
        p = obs["points"][obs["valid"] == 1][:, :2].astype(float) @ np.array([[c, s], [-s, c]])
        name = site["site"]
        if name.startswith(("aisle", "L-")):
            assert free_width(p, -0.4, 0.4) == pytest.approx(site["width"], abs=0.01)
        elif name.startswith("door"):
            jamb = -start["x"]  # the doorway's wall spans x = 0 .. 0.15 in the site
            assert free_width(p, jamb + 0.01, jamb + 0.14) == pytest.approx(site["width"], abs=0.01)
        else:
            if name.startswith(("beside", "corner")):  # the wall y = 0, on the right
                side = p[(np.abs(p[:, 0]) < HALF_LENGTH) & (p[:, 1] < 0)]
                assert -side[:, 1].max() - HALF_WIDTH == pytest.approx(site["gap"], abs=0.01)
            if name.startswith(("facing", "corner")):  # the wall x = 5, ahead
                ahead = p[(np.abs(p[:, 1]) < HALF_WIDTH) & (p[:, 0] > 0)]
                assert ahead[:, 0].min() - HALF_LENGTH == pytest.approx(site["gap"], abs=0.01)
        _, _, _, _, info = env.step(np.zeros(3, np.float32))
        assert info["cost"] == 0 and not info["collision"]
        assert info["clearance"] == pytest.approx(site["gap"], abs=0.01)
    env.close()


def test_red_team_set_reaches_every_cell(tmp_path):
    results = redteam.main(["--quick", "--shields", "braking", "--attackers", "held", "--episodes", "1", "--num-envs", "1",
                            "--steps", "10", "--workers", "1", "--set", "lidar_noise_std=0.03", "--out", str(tmp_path)])
    assert results and all(r["set"] == {"lidar_noise_std": 0.03} for r in results)
    assert all(r["set"] == {"lidar_noise_std": 0.03} for r in json.loads((tmp_path / "redteam.json").read_text()))


@pytest.mark.parametrize("setting, name", [("nonsense=1", "nonsense"), ("lidar_noise_std=fast", "lidar_noise_std"), ("shield=none", "shield")])
def test_red_team_refuses_a_bad_set_before_any_cell(setting, name, tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_:
        redteam.main(["--quick", "--set", setting, "--out", str(tmp_path / "out")])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert f"`{name}`" in err or f"--set: {name}" in err, err
    assert not (tmp_path / "out").exists()


def test_the_node_in_the_loop_keeps_off_the_walls_in_the_tight_spaces(tmp_path):
    """The ROS 2 node's decisions driving the simulated body (its LIDAR as LaserScan at 10 Hz,
    its velocity as Odometry) against two scripted attackers, one episode each per tight site
    (on the scan as it arrived, not moved by the odometry since, they bring it into contact)."""
    results = redteam.main(["--tight", "--shields", "node", "--attackers", "held", "skimmer", "--episodes", "54", "--num-envs", "1",
                            "--steps", "750", "--set", "lidar_noise_std=0.02", "--out", str(tmp_path)])
    assert len(results) == 54 and all(r["shield"] == "node" and r["set"] == {"lidar_noise_std": 0.02} for r in results)
    assert sum(r["contact_steps"] for r in results) == 0
    assert min(r["least_clearance"] for r in results) > 0.0
    # the robot is not frozen: the node lets it move in most of them
    assert sum(r["braked_steps"] for r in results) < sum(r["steps"] for r in results)


def test_the_node_wrapper_names_what_it_cannot_run():
    from shieldnav.exceptions import InvalidArgumentError

    from agents.node_shield import NodeShield

    with pytest.raises(InvalidArgumentError, match="shield='none'"):
        NodeShield(gym.make(redteam.TIGHT_ID))
    with pytest.raises(InvalidArgumentError, match="16 channels"):
        NodeShield(gym.make(redteam.TIGHT_ID, shield="none", lidar_channels=16, lidar_columns=512))
