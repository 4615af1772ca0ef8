"""shieldnav.World: LIDAR against an independent numpy ray caster, poses, contacts, errors."""

import json
import re
from pathlib import Path

import numpy as np
import pytest
from shieldnav import World

MAPS = Path(__file__).resolve().parents[1].parent / "shared" / "maps"


def inside_polygon(px, py, vertices):
    """Whether each point `(px, py)` lies inside the polygon `vertices` (even-odd rule)."""
    inside = np.zeros(np.shape(px), dtype=bool)
    for (x1, y1), (x2, y2) in zip(vertices, np.roll(vertices, -1, axis=0)):
        crosses = (y1 > py) != (y2 > py)
        with np.errstate(divide="ignore", invalid="ignore"):
            x_at = x1 + (py - y1) * (x2 - x1) / (y2 - y1)
        inside ^= crosses & (px < x_at)
    return inside


def numpy_ranges(walls, sensor_pose, columns, channels=1, fov=(-np.pi / 4, np.pi / 4), z=0.5, rmin=0.1, rmax=20.0, solids=(), tops_hit=None):
    """Brute-force f64 ray caster: every beam against every wall, (channels, columns); with
    `solids` (outline, height) also against each one's top face, and the beams whose nearest
    hit is solid `i`'s top counted into `tops_hit[i]`."""
    x, y, yaw = sensor_pose
    az = yaw + 2.0 * np.pi * np.arange(columns) / columns
    d = np.stack([np.cos(az), np.sin(az)], axis=1)[:, None, :]  # (N, 1, 2)
    a, b, h = walls[None, :, 0:2], walls[None, :, 2:4], walls[None, :, 4]
    e = b - a
    w = a - np.array([x, y])
    den = d[..., 0] * e[..., 1] - d[..., 1] * e[..., 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (w[..., 0] * e[..., 1] - w[..., 1] * e[..., 0]) / den
        s = (w[..., 0] * d[..., 1] - w[..., 1] * d[..., 0]) / den
    hit = (den != 0) & (t >= 0) & (s >= 0) & (s <= 1)
    t = np.where(hit, t, np.inf)
    # a beam along a wall's line (the sensor on it, e.g. a start on a map's 45° wall) has no
    # well-defined f64 hit: either caster's answer is a quotient of two roundings; NaN there
    length = np.hypot(e[..., 0], e[..., 1])
    along = (np.abs(den) <= 1e-9 * length) & (np.abs(w[..., 0] * e[..., 1] - w[..., 1] * e[..., 0]) <= 1e-6 * length)
    along = along.any(axis=1)
    elev = np.array([0.0]) if channels == 1 else np.linspace(fov[0], fov[1], channels)
    out = np.empty((channels, columns))
    for k, el in enumerate(elev):
        zk = z + np.where(hit, t, 0.0) * np.tan(el)
        ok = hit & (zk >= 0) & (zk <= h)
        r = np.where(ok, t / np.cos(el), np.inf).min(axis=1)
        for i, (outline, height) in enumerate(solids):
            if el < 0 and height < z:
                # the beam meets the top's plane at this range, above this point
                top = (z - height) / np.sin(-el)
                reach = top * np.cos(el)
                over = inside_polygon(x + reach * np.cos(az), y + reach * np.sin(az), np.asarray(outline, dtype=float))
                if tops_hit is not None:
                    tops_hit[i] += int((over & (top < r)).sum())
                r = np.where(over, np.minimum(r, top), r)
        out[k] = np.where(along, np.nan, np.where((r >= rmin) & (r <= rmax), r, np.inf))
    return out


def assert_scan_matches(world, **kw):
    ref = numpy_ranges(world.walls, world.sensor_pose, **kw)
    got = world.ranges
    assert got.shape == ref.shape
    defined = ~np.isnan(ref)
    assert defined.mean() > 0.99, "more than 1 % of the beams run along a wall's line"
    got, ref = got[defined], ref[defined]
    both = np.isfinite(got) | np.isfinite(ref)
    assert both.sum() > 0.5 * got.size
    np.testing.assert_array_equal(np.isfinite(got), np.isfinite(ref))
    np.testing.assert_allclose(got[np.isfinite(got)], ref[np.isfinite(ref)], rtol=0, atol=1e-6)


@pytest.mark.parametrize("name", ["constricted_passage", "odometry_jump", "dynamic_obstacles"])
def test_planar_scan_matches_numpy_on_presets(name):
    w = World(preset=name, range_noise_std=0.0)
    assert w.name == name
    assert_scan_matches(w, columns=1024)
    for _ in range(30):
        if w.step(0.4, 0.0, 0.2)["scanned"]:
            assert_scan_matches(w, columns=1024)


@pytest.mark.parametrize("kind", ["office", "tunnel"])
def test_planar_scan_matches_numpy_on_procedural_sites(kind):
    w = World(procedural=5, kind=kind, range_noise_std=0.0, columns=2048)
    assert_scan_matches(w, columns=2048)


def test_three_d_scan_matches_numpy():
    w = World(preset="dynamic_obstacles", range_noise_std=0.0, channels=16)
    assert_scan_matches(w, columns=1024, channels=16)


def test_three_d_scan_sees_the_tops_of_low_solids_as_numpy_does(tmp_path):
    # low polygons and a low obstacle below a LIDAR mounted at 0.8 m: beams looking down
    # reach their top faces (the numpy caster finds them from the outlines given here; without
    # the tops it differs from the scan at about 130 of 25 000 returns)
    polygons = [
        ([[3.13, 0.42], [3.71, 0.42], [3.71, 1.07], [3.13, 1.07]], 0.31),
        ([[5.21, -1.3], [6.37, -0.62], [5.05, -0.48]], 0.47),
        ([[8.3, 0.2], [9.1, 0.35], [9.4, 1.0], [8.8, 1.3], [8.2, 0.9]], 0.6),
        ([[6.9, -1.1], [7.8, -1.1], [7.8, -0.5], [6.9, -0.5]], 0.1),
    ]
    square = [[-0.2, -0.2], [0.2, -0.2], [0.2, 0.2], [-0.2, 0.2]]
    chair = (2.4, -0.9, 0.3)
    scenario = {
        "name": "low_solids",
        # (a tall closed corridor: most upward beams return too)
        "walls": [{"a": a, "b": b, "height": 10.0} for a, b in [([0, -1.5], [20, -1.5]), ([20, -1.5], [20, 1.5]), ([20, 1.5], [0, 1.5]), ([0, 1.5], [0, -1.5])]],
        "polygons": [{"vertices": v, "height": h} for v, h in polygons],
        "start": {"x": 1.0, "y": 0.05, "yaw": 0.1},
        "obstacles": [{"name": "stool", "shape": {"vertices": square, "height": 0.5}, "trajectory": {"keys": [[0.0, {"x": chair[0], "y": chair[1], "yaw": chair[2]}]]}}],
    }
    path = tmp_path / "low.json"
    path.write_text(json.dumps(scenario))
    w = World(scenario=str(path), range_noise_std=0.0, channels=32, mount=(0.0, 0.0, 0.8, 0.0))
    c, s = np.cos(chair[2]), np.sin(chair[2])
    stool = [[chair[0] + c * px - s * py, chair[1] + s * px + c * py] for px, py in square]
    solids = polygons + [(stool, 0.5)]
    scans, tops = 0, [0] * len(solids)
    for _ in range(60):
        if w.step(0.5, 0.0, 0.15)["scanned"]:
            assert_scan_matches(w, columns=1024, channels=32, z=0.8, solids=solids, tops_hit=tops)
            scans += 1
    # every solid's top seen first by some beams, a thousand in all
    assert scans >= 10 and min(tops) > 10 and sum(tops) > 1000, (scans, tops)


@pytest.mark.skipif(not MAPS.is_dir(), reason=f"{MAPS} absent (shared maps beside the repository)")
@pytest.mark.parametrize("yaml", sorted(str(p) for p in MAPS.glob("*/*.yaml")) if MAPS.is_dir() else [])
def test_real_maps_load_and_scan_matches_numpy(yaml):
    w = World(ros_map=yaml, range_noise_std=0.0, max_range=10.0)
    assert_scan_matches(w, columns=1024, rmax=10.0)


@pytest.mark.skipif(not MAPS.is_dir(), reason=f"{MAPS} absent (shared maps beside the repository)")
def test_unreachable_map_walls_are_dropped_without_changing_the_scan():
    yaml = str(MAPS / "upenn_levine_lobby" / "levinelobby.yaml")
    pruned = World(ros_map=yaml, range_noise_std=0.0, channels=16)
    full = World(ros_map=yaml, range_noise_std=0.0, channels=16, unreachable_walls=True)
    assert len(pruned.walls) < 0.9 * len(full.walls)
    np.testing.assert_array_equal(pruned.ranges, full.ranges)
    for _ in range(20):
        for w in (pruned, full):
            w.step(0.6, 0.0, 0.3)
    np.testing.assert_array_equal(pruned.true_pose, full.true_pose)
    np.testing.assert_array_equal(pruned.ranges, full.ranges)


@pytest.mark.skipif(not MAPS.is_dir(), reason=f"{MAPS} absent (shared maps beside the repository)")
def test_lone_cells_keep_their_thickness():
    # willow_garage has lone occupied cells: simplified along their diagonal they would be walls
    # of zero thickness (a wall and its twin running back over it), which the robot's body hits
    # and a beam seen end-on passes
    walls = World(ros_map=str(MAPS / "willow_garage" / "willow-2010-02-18-0.10.yaml")).walls
    ends = {tuple(w) for w in walls[:, :4].round(9).tolist()}
    assert not [(a, b, c, d) for a, b, c, d in ends if (c, d, a, b) in ends]


@pytest.mark.skipif(not MAPS.is_dir(), reason=f"{MAPS} absent (shared maps beside the repository)")
def test_map_walls_are_simplified_within_the_tolerance():
    yaml = str(MAPS / "g4s_office" / "g4s_y2.yaml")  # drawn at 45°: every wall a staircase
    simple = World(ros_map=yaml, range_noise_std=0.0, max_range=10.0)
    edges = World(ros_map=yaml, range_noise_std=0.0, max_range=10.0, simplify=0)
    loose = World(ros_map=yaml, range_noise_std=0.0, max_range=10.0, simplify=2.5)
    assert len(loose.walls) < len(simple.walls) < 0.5 * len(edges.walls)
    # cell edges are axis-aligned (the map has no yaw); a good share of simplified walls is not
    e = edges.walls
    assert np.all((e[:, 0] == e[:, 2]) | (e[:, 1] == e[:, 3]))
    s = simple.walls
    assert np.mean((s[:, 0] == s[:, 2]) | (s[:, 1] == s[:, 3])) < 0.8
    # the scans differ by at most the tolerance (1 cell, 5 cm) wherever a beam hits the same
    # wall in both: compare the beams whose neighbours agree to within a cell
    a, b = simple.ranges, edges.ranges
    with np.errstate(invalid="ignore"):
        both = np.isfinite(a) & np.isfinite(b) & (np.abs(np.roll(a, 1) - a) < 0.05) & (np.abs(np.roll(b, 1) - b) < 0.05)
    assert both.mean() > 0.5
    assert np.median(np.abs(a[both] - b[both])) < 0.025
    for bad in (-1.0, float("nan")):
        with pytest.raises(ValueError, match="simplify"):
            World(ros_map=yaml, simplify=bad)
    with pytest.raises(ValueError, match="simplify.*ros_map"):
        World(preset="constricted_passage", simplify=1.0)


def test_points_are_ranges_in_the_body_frame():
    w = World(preset="constricted_passage", range_noise_std=0.0, mount=(0.2, 0.0, 0.6, 0.0))
    r = w.ranges[0]
    p = w.points
    assert p.shape == (1024, 3)
    az = 2.0 * np.pi * np.arange(1024) / 1024
    ok = np.isfinite(r)
    np.testing.assert_allclose(p[ok, 0], 0.2 + r[ok] * np.cos(az[ok]), atol=1e-12)
    np.testing.assert_allclose(p[ok, 1], r[ok] * np.sin(az[ok]), atol=1e-12)
    np.testing.assert_allclose(p[ok, 2], 0.6)
    assert np.isnan(p[~ok]).all()


def test_same_seed_same_run_other_seed_differs():
    def run(seed):
        w = World(preset="dynamic_obstacles", seed=seed, dropout=0.05)
        out = []
        for _ in range(60):
            w.step(0.5, 0.0, 0.05)
            out.append(np.concatenate([w.true_pose, w.ranges.ravel()]))
        return np.array(out)

    a, b, c = run(1), run(1), run(2)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)


def test_odometry_jump_moves_the_estimate_only():
    w = World(preset="odometry_jump", range_noise_std=0.0)
    for _ in range(int(20.5 / 0.02)):
        w.step(0.5, 0.0, 0.0)
    t, e = w.true_pose, w.estimated_pose
    assert e[0] - t[0] == pytest.approx(100.0, abs=1e-6)
    assert e[1] - t[1] == pytest.approx(-1.5, abs=1e-6)
    assert t[0] == pytest.approx(2.0 + 0.5 * 20.5, abs=0.2)
    assert_scan_matches(w, columns=1024)  # the LIDAR still sees from the true pose


def test_contacts_when_driving_into_the_cabinet():
    w = World(preset="constricted_passage")
    counts = [w.step(1.0, 0.2, 0.0)["contact_count"] for _ in range(400)]
    assert counts[0] == 0 and max(counts) > 0
    c = w.contacts
    assert c.shape == (4,) and c[0] == c[1] + c[2]


def test_errors_name_what_is_wrong(tmp_path):
    with pytest.raises(ValueError, match="unknown preset `warehouse`"):
        World(preset="warehouse")
    with pytest.raises(ValueError, match="exactly one"):
        World(preset="odometry_jump", procedural=3)
    with pytest.raises(ValueError, match="columns"):
        World(preset="odometry_jump", columns=1000)
    with pytest.raises(ValueError, match="dropout"):
        World(preset="odometry_jump", dropout=1.5)
    with pytest.raises(ValueError, match="invalid `robot_length`"):
        World(preset="odometry_jump", robot_length=0.0)
    # a value of the wrong type or sign: the exception's note names the argument (PyO3)
    with pytest.raises(ValueError, match="invalid `seed`: expected an integer seed"):
        World(preset="odometry_jump", seed=-1)
    for kwargs, kind, name in [({"dt": "0.1"}, TypeError, "dt"), ({"channels": -1}, ValueError, "channels")]:
        with pytest.raises(kind) as caught:
            World(preset="odometry_jump", **kwargs)
        assert f"'{name}'" in " ".join(getattr(caught.value, "__notes__", [])), caught.value
    bad = tmp_path / "bad.yaml"
    bad.write_text("image: x.pgm\nresolution: fine\norigin: [0, 0, 0]\n")
    with pytest.raises(ValueError, match=r"bad.yaml: line 2, field resolution"):
        World(ros_map=str(bad))
    scen = tmp_path / "s.json"
    scen.write_text('{"walls": [], "start": {"x": 0, "y": 0}}')
    with pytest.raises(ValueError, match=r"s.json: line 1"):
        World(scenario=str(scen))
    yaml_scen = tmp_path / "s.yaml"
    yaml_scen.write_text("walls:\n  - {a: [0, 0], b: [1, 0], height: 1}\n")
    with pytest.raises(ValueError, match=r"s.yaml: line 1: a scenario file is one JSON object"):
        World(scenario=str(yaml_scen))
    w = World(preset="odometry_jump")
    with pytest.raises(ValueError, match="command"):
        w.step(float("nan"), 0.0, 0.0)


def test_scenario_file_round_trip(tmp_path):
    scen = tmp_path / "corridor.json"
    scen.write_text(
        '{"name": "mine", "walls": [{"a": [0, -1], "b": [20, -1], "height": 2.0}, {"a": [0, 1], "b": [20, 1], "height": 2.0}],'
        ' "start": {"x": 2, "y": 0, "yaw": 0}}'
    )
    w = World(scenario=str(scen), range_noise_std=0.0)
    assert w.name == "mine"
    assert w.ranges[0, 256] == pytest.approx(1.0, abs=1e-12)  # +y wall, 1 m away


def test_the_documented_scenario_file_loads_and_runs(tmp_path):
    # the example of docs/world.md, as a user copies it
    doc = (Path(__file__).resolve().parents[1] / "docs" / "world.md").read_text()
    (example,) = re.findall(r"```json\n(.*?)```", doc, flags=re.S)
    scen = tmp_path / "mine.json"
    scen.write_text(example)
    w = World(scenario=str(scen), range_noise_std=0.0)
    assert w.name == "my_corridor"
    while w.time < 20.1:  # standing still: the odometry jumps 120 m at 20 s
        w.step(0.0, 0.0, 0.0)
    assert w.estimated_pose[0] - w.true_pose[0] == pytest.approx(120.0, abs=1e-6)


def test_scan_poses_and_contacts_are_live_read_only_views_without_copies():
    w = World(preset="constricted_passage", range_noise_std=0.0)
    ranges, points, pose = w.ranges, w.points, w.true_pose
    for a in (ranges, points, pose, w.estimated_pose, w.sensor_pose, w.contacts):
        assert a.base is w, "a view of the world's own buffer"
        assert not a.flags.writeable
    assert np.shares_memory(ranges, w.ranges) and np.shares_memory(points, w.points)
    first = ranges.copy()
    for _ in range(10):  # 0.2 s: two new scans
        w.step(0.5, 0.0, 0.0)
    assert not np.array_equal(first, ranges), "the view follows the world"
    np.testing.assert_array_equal(pose, w.true_pose)
    assert pose[0] > 1.0
    assert_scan_matches(w, columns=1024)
    with pytest.raises(ValueError, match="read-only"):
        ranges[0, 0] = 1.0
    del w  # the views keep the world alive
    assert np.isfinite(ranges).any()


def test_ros_map_border_is_a_wall_and_a_framed_yard_is_outside(tmp_path):
    """ROS maps: the space beyond the image is unknown, so (with unknown_is_wall, the default)
    the image's border is a wall where free cells meet it; free space framed by unknown cells
    is outside, never the start; a misspelt YAML key is an error naming it."""

    def write(name, cells, res):
        """`cells`: rows from the top, 254 free, 0 occupied, 128 unknown."""
        h, w = cells.shape
        (tmp_path / f"{name}.pgm").write_bytes(f"P5\n{w} {h}\n255\n".encode() + cells.astype(np.uint8).tobytes())
        (tmp_path / f"{name}.yaml").write_text(f"image: {name}.pgm\nresolution: {res}\norigin: [0.0, 0.0, 0.0]\n")
        return str(tmp_path / f"{name}.yaml")

    # 8 x 6 m of free cells, a room from 1 to 7 m by 1 to 5 m with a 1 m door west
    img = np.full((60, 80), 254)
    img[10:50, 10:70] = 0
    img[11:49, 11:69] = 254
    img[25:35, 10] = 254
    w = World(ros_map=write("room", img, 0.1), range_noise_std=0.0)
    x = w.walls[:, [0, 2]]
    assert x.min() == 0.0 and x.max() == 8.0
    assert 1.0 < w.true_pose[0] < 7.0 and 1.0 < w.true_pose[1] < 5.0
    contact = False
    for _ in range(400):  # backwards (west), out of the door, to the image's border
        w.step(-1.0, 0.0, 0.0)
        contact |= len(w.contacts) > 0
    assert contact and 0.5 < w.true_pose[0] < 1.0
    # a closed 6 x 4 m building in a larger yard framed by one row of unknown cells
    img = np.full((160, 200), 254)
    img[[0, -1], :] = 128
    img[:, [0, -1]] = 128
    img[38:122, 38:162] = 0
    img[40:120, 40:160] = 254
    w = World(ros_map=write("yard", img, 0.05), range_noise_std=0.0)
    assert 2.0 < w.true_pose[0] < 8.0 and 2.0 < w.true_pose[1] < 6.0
    (tmp_path / "typo.yaml").write_text("image: yard.pgm\nresolution: 0.05\norigin: [0, 0, 0]\noccupied_tresh: 0.99\n")
    with pytest.raises(ValueError, match=r"typo\.yaml: line 4: unknown key `occupied_tresh`; the keys are image, resolution"):
        World(ros_map=str(tmp_path / "typo.yaml"))


def test_views_read_while_another_thread_steps_raise_a_clear_error_not_a_panic():
    import threading

    world = World(preset="constricted_passage", seed=0)
    stop = threading.Event()

    def step():
        while not stop.is_set():
            world.step(0.3, 0.0, 0.2)

    stepper = threading.Thread(target=step)
    stepper.start()
    refused = 0
    try:
        for _ in range(3000):
            for name in ("ranges", "points", "true_pose", "estimated_pose", "sensor_pose", "contacts"):
                try:
                    getattr(world, name)
                except RuntimeError as err:  # a PanicException is a BaseException and would escape
                    assert "being stepped by another thread" in str(err)
                    refused += 1
    finally:
        stop.set()
        stepper.join()
    assert refused > 0, "the stepping thread never held the world while it was read"
    assert world.true_pose.shape == (3,)
