"""Inputs of the core's classes (`World`, `Episode`, `Batch`): a refused batch step steps no
episode, bool and complex actions are refused, bad counts, seeds, tuples and bool-valued
numeric keys are errors naming the argument, a scan rate the control period cannot honour is
an error, `Episode.step` and `observe` release the GIL, and a 3D scan looks down on solid
furniture."""

import json
import sys
import threading
import time

import numpy as np
import pytest
from shieldnav import InvalidArgumentError, World
from shieldnav._core import Batch, Episode

PRESET = "constricted_passage"


def steps_of(batch):
    return [batch.summary(i)["steps"] for i in range(len(batch))]


def good_actions(n):
    return np.tile(np.array([0.3, 0.0, 0.1], dtype=np.float32), (n, 1))


# --- 1. a refused batch step steps no episode; bool and complex actions are refused ---


@pytest.mark.parametrize("bad", [np.nan, np.inf, 1.5])
def test_a_bad_row_steps_no_episode_and_is_named(bad):
    b = Batch(4, [1, 2, 3, 4], preset=PRESET, threads=2)
    seeds = np.arange(4, dtype=np.uint64)
    b.reset(seeds)
    b.step(good_actions(4), seeds)
    before = steps_of(b)
    assert before == [1, 1, 1, 1]
    a = good_actions(4)
    a[2, 1] = bad
    for _ in range(5):
        with pytest.raises(InvalidArgumentError, match=r"actions\[2\]"):
            b.step(a, seeds)
        assert steps_of(b) == before
    b.step(good_actions(4), seeds)
    assert steps_of(b) == [2, 2, 2, 2]


@pytest.mark.parametrize(
    "action",
    [
        np.array([True, False, False]),
        np.array([0.5 + 0.5j, 0.0, 0.0]),
        np.array([0.5, 0.0, 0.0], dtype=np.complex64),
        [True, False, False],
        [0.5, 0.0, 0.5j],
        (np.bool_(True), 0.0, 0.0),
    ],
)
def test_episode_refuses_bool_and_complex_actions(action):
    ep = Episode(preset=PRESET, seed=1)
    with pytest.raises(InvalidArgumentError, match=r"`action`.*(bool|complex)"):
        ep.step(action)
    assert ep.summary()["steps"] == 0
    ep.step(np.array([0.5, 0.0, 0.0]))
    assert ep.summary()["steps"] == 1


@pytest.mark.parametrize("dtype", [np.bool_, np.complex128, np.complex64])
def test_batch_refuses_bool_and_complex_actions(dtype):
    b = Batch(2, [1, 2], preset=PRESET)
    seeds = np.zeros(2, dtype=np.uint64)
    with pytest.raises(InvalidArgumentError, match=r"`actions`.*(bool|complex)"):
        b.step(np.ones((2, 3), dtype=dtype), seeds)
    assert steps_of(b) == [0, 0]


# --- 5. Episode.step and observe release the GIL ---


def test_episode_step_releases_the_gil():
    """With a long switch interval, another Python thread only runs while the stepping thread
    releases the GIL; it ran during the steps. (`observe` releases it too, but for too short a
    time for a waiting thread to wake up and take it.)"""
    ep = Episode(preset=PRESET, seed=3)
    count = [0]
    stop = threading.Event()

    def spin():
        while not stop.is_set():
            count[0] += 1
            if count[0] % 200 == 0:
                time.sleep(0)  # hands the GIL back

    old = sys.getswitchinterval()
    sys.setswitchinterval(5.0)
    t = threading.Thread(target=spin)
    try:
        t.start()
        n0 = count[0]
        # (a step is short: the waiting thread may not wake up in time for every one)
        deadline = time.monotonic() + 5.0
        while count[0] == n0 and time.monotonic() < deadline:
            _, _, terminated, truncated, _ = ep.step(np.array([0.2, 0.0, 0.0], dtype=np.float32))
            if terminated or truncated:
                ep.reset(4)
        assert count[0] > n0, "no other thread ran during Episode.step"
    finally:
        stop.set()
        t.join()
        sys.setswitchinterval(old)


# --- 6. a scan rate faster than the control rate is an error naming both ---


def test_a_scan_rate_the_control_period_cannot_honour_is_an_error():
    with pytest.raises(InvalidArgumentError, match=r"`rate_hz`.*dt"):
        World(preset=PRESET, dt=0.1, rate_hz=20.0)
    with pytest.raises(InvalidArgumentError, match=r"`lidar_rate_hz`.*dt"):
        Episode(preset=PRESET, dt=0.1, lidar_rate_hz=20.0)
    with pytest.raises(InvalidArgumentError, match=r"`lidar_rate_hz`.*dt"):
        Batch(2, [1, 2], preset=PRESET, dt=0.1, lidar_rate_hz=20.0)
    # a rate the steps can honour: 20 Hz at 0.05 s, one scan every step
    w = World(preset=PRESET, dt=0.05, rate_hz=20.0)
    times = []
    for _ in range(6):
        w.step(0.2, 0.0, 0.0)
        times.append(w.scan_time)
    np.testing.assert_allclose(times, 0.05 * np.arange(1, 7), atol=1e-12)
    World(preset=PRESET, dt=0.1, rate_hz=10.0)


# --- 7. bad inputs name the argument ---


@pytest.mark.parametrize(
    "make, name",
    [
        (lambda: World(preset=PRESET, channels=-1), "channels"),
        (lambda: World(preset=PRESET, columns=-1024), "columns"),
        (lambda: World(preset=PRESET, channels=True), "channels"),
        (lambda: World(preset=PRESET, mount=(0, 0, 0.5)), "mount"),
        (lambda: World(preset=PRESET, mount=(0, 0, True, 0)), "mount"),
        (lambda: World(preset=PRESET, channels=16, vertical_fov=(0.1,)), "vertical_fov"),
        (lambda: Episode(preset=PRESET, seed=-1), "seed"),
        (lambda: Episode(preset=PRESET, seed=2**64), "seed"),
        (lambda: Episode(preset=PRESET, seed=1.5), "seed"),
        (lambda: Episode(preset=PRESET).reset(-1), "seed"),
        (lambda: Batch(-1, [1], preset=PRESET), "num_envs"),
        (lambda: Batch(1, [1], preset=PRESET, threads=-2), "threads"),
        (lambda: Episode(preset=PRESET, gamma=True), "gamma"),
        (lambda: Episode(preset=PRESET, dt=True), "dt"),
        (lambda: Episode(preset=PRESET, time_limit=True), "time_limit"),
        (lambda: Episode(preset=PRESET, lidar_channels=np.bool_(True)), "lidar_channels"),
        (lambda: Episode(preset=PRESET, v_max=[True, 0.4]), "v_max"),
        (lambda: Episode(preset=PRESET, lidar_mount=(0, 0, 0.5, False)), "lidar_mount"),
        (lambda: Batch(2, [1, 2], preset=PRESET, kappa=False), "kappa"),
    ],
)
def test_bad_inputs_are_invalid_argument_errors_naming_the_argument(make, name):
    with pytest.raises(InvalidArgumentError, match=f"`{name}`"):
        make()


def test_bool_keys_take_bools_and_only_bools():
    for flag in (False, True, np.bool_(True)):
        Episode(preset=PRESET, terminate_on_contact=flag, stop_when_infeasible=flag).step(np.zeros(3))
    for number in (0, 1, 1.0):
        with pytest.raises(InvalidArgumentError, match="`terminate_on_contact`: expected True or False"):
            Episode(preset=PRESET, terminate_on_contact=number)


# --- 2. a 3D scan looks down on solid furniture ---


def test_three_d_scan_sees_the_top_of_a_box_not_the_wall_behind(tmp_path):
    """A 0.8 m box at x 3–6, y ±1, a wall at x = 10; 16 channels over ±0.2 rad from z = 1:
    channel 6 (−0.04 rad) passes over the box's front face at z = 0.88 and hits its top
    (5.0 m), not the wall behind (10.008 m)."""
    scen = {
        "name": "box",
        "walls": [
            {"a": [10, -5], "b": [10, 5], "height": 2.0},
            {"a": [-2, -5], "b": [10, -5], "height": 2.0},
            {"a": [10, 5], "b": [-2, 5], "height": 2.0},
            {"a": [-2, 5], "b": [-2, -5], "height": 2.0},
        ],
        "polygons": [{"vertices": [[3, -1], [6, -1], [6, 1], [3, 1]], "height": 0.8}],
        "start": {"x": 0, "y": 0, "yaw": 0},
    }
    path = tmp_path / "box.json"
    path.write_text(json.dumps(scen))
    w = World(scenario=str(path), channels=16, vertical_fov=(-0.2, 0.2), mount=(0.0, 0.0, 1.0, 0.0), range_noise_std=0.0)
    el = -0.2 + 6 * 0.4 / 15
    want = (0.8 - 1.0) / np.tan(el) / np.cos(el)
    assert abs(w.ranges[6, 0] - want) < 1e-9, w.ranges[6, 0]
    # a channel that clears the box's top sees the wall behind it
    up = -0.2 + 8 * 0.4 / 15
    assert abs(w.ranges[8, 0] - 10.0 / np.cos(up)) < 1e-9
