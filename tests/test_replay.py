"""`shieldnav replay`: a recording runs through the node's own decisions, in every bag format,
the same as feeding the node by hand; damaged recordings end with a clear error or counted
skips; the MCAP written reads back with the `mcap` reader."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

rosbags = pytest.importorskip("rosbags")

from rosbags.rosbag1 import Writer as Writer1  # noqa: E402
from rosbags.rosbag2 import StoragePlugin, Writer  # noqa: E402
from rosbags.typesys import Stores, get_typestore  # noqa: E402
from shieldnav import cli  # noqa: E402
from shieldnav._core import Node  # noqa: E402
from shieldnav.exceptions import InvalidArgumentError  # noqa: E402
from shieldnav.replay import OUT_TOPICS, ReplayError, replay  # noqa: E402

ROS2 = get_typestore(Stores.ROS2_JAZZY)
ROS1 = get_typestore(Stores.ROS1_NOETIC)
BEAMS = 360
ANGLES = -math.pi + np.arange(BEAMS) * (2 * math.pi / BEAMS)


def corridor_ranges(y: float, half_width: float = 0.8) -> np.ndarray:
    """A robot at lateral offset ``y`` in an endless corridor along x, walls at ±half_width."""
    s = np.sin(ANGLES)
    with np.errstate(divide="ignore"):
        r = np.where(s > 0, (half_width - y) / s, np.where(s < 0, (-half_width - y) / s, np.inf))
    return np.minimum(r, 30.0).astype(np.float32)


def recording(seconds: float = 2.0) -> list[tuple[str, int, str, dict]]:
    """(topic, time ns, type, fields): scans at 20 Hz of a robot drifting toward the left wall,
    odometry at 50 Hz, a planner asking for 1 m/s forward and 0.6 m/s left at 50 Hz."""
    out = []
    t0 = 1_700_000_000_000_000_000
    for k in range(int(seconds * 50)):
        t = k * 0.02
        y = min(0.45, 0.3 * t)
        stamp = t0 + int(t * 1e9)
        if k % 2 == 0:  # (scans at 25 Hz)
            out.append(("/scan", stamp, "sensor_msgs/msg/LaserScan", {"ranges": corridor_ranges(y), "t": t}))
        out.append(("/odom", stamp + 1000, "nav_msgs/msg/Odometry", {"v": (1.0, 0.3 if y < 0.45 else 0.0), "t": t}))
        out.append(("/cmd_vel_nominal", stamp + 2000, "geometry_msgs/msg/Twist", {"v": (1.0, 0.6, 0.1), "t": t}))
    return out


def message(store, msgtype: str, fields: dict):
    T = store.types
    sec, nsec = divmod(int(fields["t"] * 1e9), 10**9)
    if msgtype == "sensor_msgs/msg/LaserScan":
        f = {"frame": "base_laser", "angle_min": float(ANGLES[0]), "angle_max": float(ANGLES[-1]), "angle_increment": float(2 * math.pi / BEAMS),
             "range_min": 0.05, "range_max": 30.0, **fields}
        head = header(store, sec, nsec, f["frame"])
        return T[msgtype](header=head, angle_min=f["angle_min"], angle_max=f["angle_max"], angle_increment=f["angle_increment"],
                          time_increment=0.0, scan_time=0.04, range_min=f["range_min"], range_max=f["range_max"], ranges=f["ranges"],
                          intensities=np.zeros(0, np.float32))
    if msgtype == "tf2_msgs/msg/TFMessage":
        transforms = []
        for parent, child, (x, y, z), (qx, qy, qz, qw) in fields["transforms"]:
            transforms.append(T["geometry_msgs/msg/TransformStamped"](header=header(store, sec, nsec, parent), child_frame_id=child, transform=T["geometry_msgs/msg/Transform"](
                translation=T["geometry_msgs/msg/Vector3"](x=x, y=y, z=z), rotation=T["geometry_msgs/msg/Quaternion"](x=qx, y=qy, z=qz, w=qw))))
        return T[msgtype](transforms=transforms)
    v3 = T["geometry_msgs/msg/Vector3"]
    if msgtype == "nav_msgs/msg/Odometry":
        pose = T["geometry_msgs/msg/PoseWithCovariance"](pose=T["geometry_msgs/msg/Pose"](
            position=T["geometry_msgs/msg/Point"](x=0.0, y=0.0, z=0.0), orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)),
            covariance=np.zeros(36))
        twist = T["geometry_msgs/msg/TwistWithCovariance"](twist=T["geometry_msgs/msg/Twist"](
            linear=v3(x=fields["v"][0], y=fields["v"][1], z=0.0), angular=v3(x=0.0, y=0.0, z=fields.get("w", 0.0))), covariance=np.zeros(36))
        return T[msgtype](header=header(store, sec, nsec, "odom"), child_frame_id="base_link", pose=pose, twist=twist)
    vx, vy, wz = fields["v"]
    twist = T["geometry_msgs/msg/Twist"](linear=v3(x=vx, y=vy, z=0.0), angular=v3(x=0.0, y=0.0, z=wz))
    if msgtype == "geometry_msgs/msg/TwistStamped":
        return T[msgtype](header=header(store, sec, nsec, "base_link"), twist=twist)
    return twist


def header(store, sec: int, nsec: int, frame: str):
    T = store.types
    if "seq" in T["std_msgs/msg/Header"].__dataclass_fields__:  # ROS 1
        return T["std_msgs/msg/Header"](seq=0, stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nsec), frame_id=frame)
    return T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nsec), frame_id=frame)


def write_bag(path: Path, messages, fmt: str = "mcap") -> Path:
    if fmt == "bag":
        writer, store, serialize = Writer1(path), ROS1, ROS1.serialize_ros1
    else:
        writer = Writer(path, version=9, storage_plugin=StoragePlugin.MCAP if fmt == "mcap" else StoragePlugin.SQLITE3)
        store, serialize = ROS2, ROS2.serialize_cdr
    with writer as w:
        conns = {}
        for topic, stamp, msgtype, fields in messages:
            if topic not in conns:
                conns[topic] = w.add_connection(topic, msgtype, typestore=store)
            w.write(conns[topic], stamp, serialize(message(store, msgtype, fields), msgtype))
    return path


def by_hand(messages, strict: bool = True) -> list[list[float]]:
    """The commands of the node fed the same messages directly, at the same times (``strict``:
    every input accepted)."""
    node = Node([])
    origin = min(m[1] for m in messages)
    out = []
    for topic, stamp, _, fields in sorted(messages, key=lambda m: m[1]):
        t = (stamp - origin) * 1e-9
        if topic == "/scan":
            rejected = node.on_scan(t, "base_laser", float(np.float32(ANGLES[0])), float(np.float32(ANGLES[-1])), float(np.float32(2 * math.pi / BEAMS)),
                                    float(np.float32(0.05)), 30.0, fields["ranges"], np.zeros(0, np.float32), 0.0, float(np.float32(0.04)))
        elif topic == "/odom":
            rejected = node.on_odometry(t, [fields["v"][0], fields["v"][1], 0.0], [0.0, 0.0, 0.0])
        else:
            rejected = None
            out.append(node.on_nominal(t, [fields["v"][0], fields["v"][1], 0.0], [0.0, 0.0, fields["v"][2]])[0])
        assert rejected is None or not strict, rejected
    return out


@pytest.mark.parametrize("fmt", ["mcap", "db3", "bag"])
def test_a_recording_replays_as_the_node_decides_on_the_same_messages(fmt, tmp_path):
    messages = recording()
    bag = write_bag(tmp_path / ("run.bag" if fmt == "bag" else "run"), messages, fmt)
    result = replay(bag)
    expected = np.asarray(by_hand(messages))
    assert result.table["command"].shape == (100, 6)
    np.testing.assert_array_equal(result.table["command"], expected)  # bit for bit
    s = result.summary
    assert s["commands"] == 100 and s["method"] == "braking" and s["skipped"] == {}
    # the planner pushes toward the wall: the shield changes the command, and never lets the
    # footprint's standing clearance go below its margin
    assert s["changed"] > 10 and result.table["ok"].all()
    assert result.table["command"][:, 1].min() < 0.6 - 1e-6
    assert s["closest_clearance_m"] is not None and s["closest_clearance_m"] > 0.0
    assert s["scans"] == 50 and abs(s["longest_scan_gap_s"] - 0.04) < 1e-6


def test_a_window_and_remapped_topics_are_honoured(tmp_path):
    messages = [(t.replace("/scan", "/front/scan"), *rest) for t, *rest in recording()]
    bag = write_bag(tmp_path / "run", messages)
    with pytest.raises(ReplayError, match=r"no scan on /scan nor cloud.*/front/scan"):
        replay(bag)
    result = replay(bag, topics={"scan": "/front/scan"}, start=0.5, end=1.0)
    assert result.summary["topics"]["scan"] == "/front/scan"
    assert 24 <= result.summary["commands"] <= 26 and result.table["t"].min() >= 0.5 - 1e-9
    with pytest.raises(InvalidArgumentError, match="unknown inputs"):
        replay(bag, topics={"lidar": "/front/scan"})
    with pytest.raises(InvalidArgumentError, match="invalid `end`"):
        replay(bag, start=1.0, end=0.5)


def test_damaged_recordings_end_with_a_clear_error_or_counted_skips(tmp_path):
    messages = recording(1.0)
    # truncated: half the MCAP file
    bag = write_bag(tmp_path / "ok", messages)
    mcap = next(bag.glob("*.mcap"))
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(mcap.read_bytes()[: mcap.stat().st_size // 2])
    with pytest.raises(ReplayError, match="cannot read the recording"):
        replay(cut)
    with pytest.raises(ReplayError, match="does not exist"):
        replay(tmp_path / "nothing.mcap")
    # no nominal command
    no_cmd = write_bag(tmp_path / "nocmd", [m for m in messages if m[0] != "/cmd_vel_nominal"])
    with pytest.raises(ReplayError, match="no nominal command on /cmd_vel_nominal"):
        replay(no_cmd)
    # the nominal topic of another type
    wrong = [("/cmd_vel_nominal", s, "nav_msgs/msg/Odometry", {"v": (1.0, 0.0), "t": f["t"]}) if t == "/cmd_vel_nominal" else (t, s, ty, f)
             for t, s, ty, f in messages]
    with pytest.raises(ReplayError, match="holds nav_msgs/msg/Odometry"):
        replay(write_bag(tmp_path / "wrong", wrong))
    # a scan of the wrong type: every one skipped and counted, the commands stopped
    bad_scan = [("/scan", s, "geometry_msgs/msg/Twist", {"v": (0.0, 0.0, 0.0), "t": f["t"]}) if t == "/scan" else (t, s, ty, f)
                for t, s, ty, f in messages]
    result = replay(write_bag(tmp_path / "badscan", bad_scan))
    assert result.summary["skipped"] == {"/scan: type geometry_msgs/msg/Twist, not sensor_msgs/msg/LaserScan": 25}
    assert not result.table["ok"].any() and (result.table["command"] == 0).all()
    assert result.summary["stop_reasons"] == {"no scan received yet": 50}
    # NaN and inf ranges, an empty scan, header stamps out of order: the node's decisions
    odd = []
    for k, (t, s, ty, f) in enumerate(messages):
        if t == "/scan":
            r = f["ranges"].copy()
            if k % 3 == 0:
                r[:] = np.nan
            elif k % 3 == 1:
                r[::2] = np.inf
            else:
                r = np.zeros(0, np.float32)
            f = {**f, "ranges": r, "t": 5.0 - f["t"]}
        odd.append((t, s, ty, f))
    result = replay(write_bag(tmp_path / "odd", odd))
    assert result.summary["commands"] == 50
    assert any("rejected by the node" in reason and "NaN" in reason for reason in result.summary["skipped"])
    np.testing.assert_array_equal(result.table["command"], np.asarray(by_hand(odd, strict=False)))


def test_the_mcap_written_reads_back_with_the_mcap_reader(tmp_path):
    from mcap.reader import make_reader

    result = replay(write_bag(tmp_path / "run", recording(1.0)))
    path = result.write_mcap(tmp_path / "out")
    with path.open("rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        topics = {c.topic: c for c in summary.channels.values()}
        assert set(topics) == set(OUT_TOPICS.values())
        schemas = {s.name: s for s in summary.schemas.values()}
        assert {"geometry_msgs/msg/Twist", "std_msgs/msg/String"} <= set(schemas)
        assert all(s.encoding == "ros2msg" and s.data for s in schemas.values())
        assert all(c.message_encoding == "cdr" for c in topics.values())
        commands, states = [], []
        for _, channel, msg in reader.iter_messages():
            if channel.topic == OUT_TOPICS["cmd"]:
                tw = ROS2.deserialize_cdr(msg.data, "geometry_msgs/msg/Twist")
                commands.append([tw.linear.x, tw.linear.y, tw.linear.z, tw.angular.x, tw.angular.y, tw.angular.z])
            else:
                states.append(json.loads(ROS2.deserialize_cdr(msg.data, "std_msgs/msg/String").data))
    np.testing.assert_array_equal(np.asarray(commands), result.table["command"])
    assert [s["command"] for s in states] == result.table["command"].tolist()
    with pytest.raises(InvalidArgumentError, match="exists"):
        result.write_mcap(tmp_path / "out")


def test_the_command_line_writes_the_table_summary_picture_and_mcap(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    bag = write_bag(tmp_path / "run", recording(1.0))
    assert cli.main(["replay", str(bag), "-p", "method:=braking", "--out", str(tmp_path / "r")]) == 0
    out = capsys.readouterr().out
    assert "50 commands" in out and "shield braking" in out
    rows = (tmp_path / "r" / "table.csv").read_text().splitlines()
    assert len(rows) == 51 and rows[0].startswith("t,nominal_vx")
    assert json.loads((tmp_path / "r" / "summary.json").read_text())["commands"] == 50
    assert (tmp_path / "r" / "replay.png").stat().st_size > 0 and list((tmp_path / "r" / "mcap").glob("*.mcap"))
    assert (tmp_path / "r" / "closest.png").stat().st_size > 0 and "sensor mount (0.000, 0.000, 0.000) m" in out
    assert cli.main(["replay", str(tmp_path / "missing.mcap")]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert cli.main(["replay", str(bag), "-p", "method:=magic"]) == 2
    assert "method" in capsys.readouterr().err


def test_the_node_binding_names_bad_input_and_reads_unaligned_ranges():
    with pytest.raises(InvalidArgumentError, match="invalid `args`"):
        Node(["--bogus"])
    with pytest.raises(InvalidArgumentError, match="method"):
        Node(["-p", "method:=magic"])
    node = Node(["-p", "method:=braking"])
    assert node.method == "braking" and node.topics()["scan"] == "/scan" and node.topics()["odom"] == "/odom"
    ranges = corridor_ranges(0.2)
    with pytest.raises(InvalidArgumentError, match="invalid `t`"):
        node.on_scan(-1.0, "laser", float(ANGLES[0]), float(ANGLES[-1]), float(2 * math.pi / BEAMS), 0.05, 30.0, ranges)
    with pytest.raises(TypeError):
        node.on_scan(0.0, "laser", float(ANGLES[0]), float(ANGLES[-1]), float(2 * math.pi / BEAMS), 0.05, 30.0, ranges.astype(np.float64))
    # a view at an odd byte offset, as a decoder's buffer may hand it out: read, not refused
    buffer = np.zeros(ranges.nbytes + 1, np.uint8)
    buffer[1:] = np.frombuffer(ranges.tobytes(), np.uint8)
    unaligned = np.frombuffer(buffer, np.float32, count=BEAMS, offset=1)
    assert not unaligned.flags.aligned
    args = ("laser", float(np.float32(ANGLES[0])), float(np.float32(ANGLES[-1])), float(np.float32(2 * math.pi / BEAMS)), 0.05, 30.0)
    a, b = Node([]), Node([])
    for node_, r in ((a, ranges), (b, unaligned)):
        assert node_.on_scan(0.0, *args, r) is None
        assert node_.on_odometry(0.0, [0.5, 0.0, 0.0], [0.0, 0.0, 0.0]) is None
    (ca, sa), (cb, sb) = (n.on_nominal(0.01, [1.0, 0.5, 0.0], [0.0, 0.0, 0.0]) for n in (a, b))
    assert ca == cb and ca[1] < 0.5 and json.loads(sa)["H"] == json.loads(sb)["H"]


def test_the_sensor_mount_is_read_from_tf_static(tmp_path):
    s45 = math.sin(math.pi / 4)
    chain = [("base_link", "mast", (0.2, 0.0, 0.2), (0.0, 0.0, 0.0, 1.0)), ("mast", "base_laser", (0.1, 0.1, 0.0), (0.0, 0.0, s45, s45))]
    messages = recording(1.0)
    static = ("/tf_static", messages[0][1], "tf2_msgs/msg/TFMessage", {"transforms": chain, "t": 0.0})
    bag = write_bag(tmp_path / "tf", [static, *messages])
    result = replay(bag)
    mount = result.summary["mount"]
    assert mount["source"] == "/tf_static (base_link → base_laser)"
    np.testing.assert_allclose(mount["xyz_yaw"], [0.3, 0.1, 0.2, math.pi / 2], atol=1e-12)
    # the same as the mount given as parameters, bit for bit; not the same as no mount
    params = [a for name, v in zip(("mount_x", "mount_y", "mount_z", "mount_yaw"), mount["xyz_yaw"]) for a in ("-p", f"{name}:={v!r}")]
    by_params = replay(bag, node_args=params, tf=False)
    assert by_params.summary["mount"]["source"] == "parameters"
    np.testing.assert_array_equal(result.table["command"], by_params.table["command"])
    unmounted = replay(bag, tf=False)
    assert unmounted.summary["mount"]["xyz_yaw"] == [0.0, 0.0, 0.0, 0.0]
    assert not np.array_equal(result.table["command"], unmounted.table["command"])
    # the node's command line may name its file as a Path
    params = tmp_path / "shield.yaml"
    params.write_text("/**:\n  ros__parameters:\n    method: braking\n")
    assert replay(bag, node_args=["--params", params]).summary["mount"] == mount
    # a mount in the parameters wins over /tf_static
    assert replay(bag, node_args=["-p", "mount_x:=0.5"]).summary["mount"] == {"source": "parameters", "xyz_yaw": [0.5, 0.0, 0.0, 0.0]}
    # an upside-down LIDAR cannot be a planar mount: a clear error, not a silently mirrored scan
    flipped = [chain[0], ("mast", "base_laser", (0.1, 0.1, 0.0), (1.0, 0.0, 0.0, 0.0))]
    bag = write_bag(tmp_path / "flipped", [(*static[:3], {"transforms": flipped, "t": 0.0}), *messages])
    with pytest.raises(ReplayError, match=r"'base_laser' is tilted 180.0° from 'base_link'.*--no-tf"):
        replay(bag)
    assert replay(bag, tf=False).summary["commands"] == 50


def test_a_stamped_command_is_written_stamped_in_the_base_frame(tmp_path):
    from mcap.reader import make_reader

    result = replay(write_bag(tmp_path / "run", recording(0.5)), node_args=["-p", "cmd_stamped:=true", "-p", "base_frame:=chassis"])
    path = result.write_mcap(tmp_path / "out")
    with path.open("rb") as f:
        reader = make_reader(f)
        assert "geometry_msgs/msg/TwistStamped" in {s.name for s in reader.get_summary().schemas.values()}
        stamped = [ROS2.deserialize_cdr(m.data, "geometry_msgs/msg/TwistStamped") for _, c, m in reader.iter_messages() if c.topic == OUT_TOPICS["cmd"]]
    assert [m.header.frame_id for m in stamped] == ["chassis"] * 25
    assert [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in stamped] == result.table["stamp_ns"].tolist()
    np.testing.assert_array_equal([[m.twist.linear.x, m.twist.linear.y, m.twist.angular.z] for m in stamped], result.table["command"][:, [0, 1, 5]])


def test_a_recording_of_a_simulated_episode_replays_to_the_episodes_own_commands(tmp_path):
    """The node in the loop of the simulated body (its LIDAR as LaserScan, its achieved velocity
    as Odometry, a planner pushing sideways and turning at full speed through the constricted
    passage): no contact, and the recording of the episode replays to its commands bit for bit."""
    from shieldnav._core import World

    world = World(preset="constricted_passage", seed=3)
    node = Node(["-p", "method:=braking"])
    beams = world.ranges.shape[1]
    scan = {"frame": "laser", "angle_min": 0.0, "angle_increment": float(np.float32(2 * math.pi / beams)),
            "range_min": float(np.float32(0.1)), "range_max": 20.0}
    scan["angle_max"] = float(np.float32((beams - 1) * scan["angle_increment"]))
    t0 = 1_700_000_000_000_000_000
    messages, sent, velocity, scanned_at, contacts = [], [], [0.0, 0.0, 0.0], None, 0
    for k in range(600):
        stamp = t0 + k * 20_000_000
        if world.scan_time != scanned_at:
            scanned_at = world.scan_time
            ranges = world.ranges[0].astype(np.float32)
            assert node.on_scan((stamp - t0) * 1e-9, "laser", scan["angle_min"], scan["angle_max"], scan["angle_increment"],
                                scan["range_min"], scan["range_max"], ranges) is None
            messages.append(("/scan", stamp, "sensor_msgs/msg/LaserScan", {**scan, "ranges": ranges, "t": k * 0.02}))
        assert node.on_odometry((stamp + 1000 - t0) * 1e-9, [velocity[0], velocity[1], 0.0], [0.0, 0.0, velocity[2]]) is None
        messages.append(("/odom", stamp + 1000, "nav_msgs/msg/Odometry", {"v": velocity[:2], "w": velocity[2], "t": k * 0.02}))
        nominal = (1.5, 0.8 * math.sin(0.9 * k * 0.02), 1.5 * math.sin(0.5 * k * 0.02))
        command, _ = node.on_nominal((stamp + 2000 - t0) * 1e-9, [nominal[0], nominal[1], 0.0], [0.0, 0.0, nominal[2]])
        messages.append(("/cmd_vel_nominal", stamp + 2000, "geometry_msgs/msg/Twist", {"v": nominal, "t": k * 0.02}))
        sent.append(command)
        out = world.step(command[0], command[1], command[5])
        velocity = list(out["velocity"])
        contacts += out["contact_count"]
    sent = np.asarray(sent)
    assert contacts == 0
    assert world.true_pose[0] > 2.5, "the robot moves on"
    assert (np.abs(sent[:, [0, 1, 5]] - 0).sum(axis=1) < 1e-12).any(), "and the shield stops it somewhere"
    result = replay(write_bag(tmp_path / "episode", messages))
    np.testing.assert_array_equal(result.table["command"], sent)  # bit for bit
    assert result.summary["skipped"] == {} and result.summary["scans"] == sum(m[0] == "/scan" for m in messages)
    # the closest approach: its row, and the scan the node held there
    k = result.closest["k"]
    assert k == int(np.nanargmin(result.table["clearance"])) and result.closest["clearance"] == result.table["clearance"][k]
    assert result.closest["points"].shape[1] == 3 and len(result.closest["points"]) > 100
