"""The shield on a robot's own recording: what it would have sent, where and why.

``replay(bag)`` reads a rosbag2 (``.mcap``, ``.db3``, or its folder) or a ROS 1 ``.bag`` with
`rosbags` (no ROS installation) and runs every message through the ROS 2 node's own decisions
(``shieldnav._core.Node``, the node's code without the network): scans and point clouds,
odometry or an IMU, and at each nominal command the command the node would have sent, from the
inputs it holds at that moment. Messages are taken in the order they were recorded, each at its
recording time (the node's arrival time), so timeouts and stale scans count as they would have
live. The node's parameters come from its own command line (``node_args``: ``--params
FILE.yaml``, ``--ros-args -p name:=value -r from:=to``): the same file the node reads.

    from shieldnav.replay import replay

    result = replay("run.mcap", node_args=["--params", "shield.yaml"], topics={"scan": "/front/scan"})
    result.summary["changed"], result.table["command"]
    result.write_mcap("run.shieldnav")        # the filtered command and the state, for Foxglove

The command line: ``shieldnav replay BAG [--params FILE] [--scan TOPIC ...] [--start S --end S]
[--out DIR]``. Needs ``pip install "shieldnav[replay]"``.
"""

from __future__ import annotations

import json
import struct
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from shieldnav._core import Node
from shieldnav.exceptions import InvalidArgumentError, ShieldnavError

#: What each of the node's inputs may be recorded as.
TYPES = {
    "scan": ("sensor_msgs/msg/LaserScan",),
    "cloud": ("sensor_msgs/msg/PointCloud2",),
    "nominal": ("geometry_msgs/msg/Twist", "geometry_msgs/msg/TwistStamped"),
    "odom": ("nav_msgs/msg/Odometry",),
    "imu": ("sensor_msgs/msg/Imu",),
}
#: The topics of the written MCAP (beside the recording's own in a viewer).
OUT_TOPICS = {"cmd": "/shieldnav/replay/cmd_vel", "state": "/shieldnav/replay/state"}
_FLAGS = ("ok", "active", "feasible", "braked", "recovering", "tight")
_NUMBERS = ("H", "h_min", "clearance", "scan_age", "solve_time_us")


class ReplayError(ShieldnavError, ValueError):
    """A recording that cannot be replayed: unreadable, or without the node's inputs."""


@dataclass
class Replay:
    """What the shield would have done: ``table`` (one row a nominal command, one array a
    column: ``t`` in s from the recording's start, ``stamp_ns`` its recording time,
    ``nominal`` and ``command`` ``(n, 6)``, ``H``, ``h_min``, ``clearance``, ``scan_age``,
    ``solve_time_us`` (NaN where the node stopped or used no point), the flags ``ok``,
    ``active``, ``feasible``, ``braked``, ``recovering``, ``tight``, ``points_used``,
    ``points_in_scan`` and ``reason``), ``summary`` and the node's ``states`` (the state topic's
    JSON text a command), the ``body`` the node saw (``Node.body()``: frame, mount, footprint,
    ellipse) and, at the footprint's ``closest`` approach, its row ``k`` and the scan's points
    the node held (body frame, ``(n, 3)``; ``None`` when no clearance was measured)."""

    table: dict[str, np.ndarray]
    summary: dict[str, Any]
    states: list[str]
    body: dict[str, Any]
    closest: dict[str, Any] | None = None

    def write_mcap(self, path: str | Path) -> Path:
        """Writes the filtered command (``geometry_msgs/msg/Twist``) and the state
        (``std_msgs/msg/String``, the node's JSON) at each command's recording time to a rosbag2
        folder ``path`` holding one ``.mcap`` (ros2 profile, CDR, ``ros2msg`` schemas); returns
        the ``.mcap`` file."""
        from rosbags.rosbag2 import StoragePlugin, Writer
        from rosbags.typesys import Stores, get_typestore

        path = Path(path)
        if path.exists():
            raise InvalidArgumentError(f"invalid `path`: {path} exists (rosbag2 writes a new folder)")
        store = get_typestore(Stores.ROS2_JAZZY)
        T = store.types
        Twist, Vector3, String = T["geometry_msgs/msg/Twist"], T["geometry_msgs/msg/Vector3"], T["std_msgs/msg/String"]
        cmd_type = "geometry_msgs/msg/TwistStamped" if self.summary.get("cmd_stamped") else "geometry_msgs/msg/Twist"
        with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
            cmd = writer.add_connection(OUT_TOPICS["cmd"], cmd_type, typestore=store)
            state = writer.add_connection(OUT_TOPICS["state"], "std_msgs/msg/String", typestore=store)
            for stamp, c, text in zip(self.table["stamp_ns"].tolist(), self.table["command"], self.states):
                msg = Twist(linear=Vector3(x=float(c[0]), y=float(c[1]), z=float(c[2])), angular=Vector3(x=float(c[3]), y=float(c[4]), z=float(c[5])))
                if cmd_type.endswith("Stamped"):
                    sec, nsec = divmod(int(stamp), 10**9)
                    head = T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nsec), frame_id=self.body["base_frame"])
                    msg = T[cmd_type](header=head, twist=msg)
                writer.write(cmd, int(stamp), store.serialize_cdr(msg, cmd_type))
                writer.write(state, int(stamp), store.serialize_cdr(String(data=text), "std_msgs/msg/String"))
        return next(path.glob("*.mcap"))

    def plot_closest(self, path: str | Path) -> Path | None:
        """Top-down, body frame, at the footprint's closest approach: the scan the node held,
        the footprint and the ellipse, the nominal and the sent velocity; one PNG (``None``
        when no clearance was measured)."""
        if self.closest is None:
            return None
        plt = _pyplot()
        from matplotlib.patches import Ellipse, Polygon

        k, pts = self.closest["k"], self.closest["points"]
        fig, ax = plt.subplots(figsize=(7, 7))
        ax.scatter(pts[:, 0], pts[:, 1], s=3, color="k", label=f"scan ({len(pts)} returns)")
        ax.add_patch(Polygon(self.body["footprint"], closed=True, fill=False, color="C3", lw=1.5, label="footprint"))
        axes = self.body["semi_axes"]
        ax.add_patch(Ellipse((0.0, 0.0), 2 * axes[0], 2 * axes[1], fill=False, color="C0", ls="--", label="ellipse"))
        for row, color, name in ((self.table["nominal"][k], "0.5", "nominal"), (self.table["command"][k], "C2", "sent")):
            if np.isfinite(row[:2]).all():
                ax.arrow(0.0, 0.0, row[0], row[1], width=0.02, color=color, length_includes_head=True, label=f"{name} ({row[0]:.2f}, {row[1]:.2f}) m/s")
        reach = max(1.5, 1.5 * max(axes))
        ax.set_xlim(-reach, reach)
        ax.set_ylim(-reach, reach)
        ax.set_aspect("equal")
        ax.grid(alpha=0.3)
        ax.set_xlabel("x, body frame (m)")
        ax.set_ylabel("y (m)")
        ax.legend(loc="upper right", fontsize=8)
        ax.set_title(f"closest approach: {self.table['clearance'][k]:.3f} m at {self.table['t'][k]:.2f} s ({self.summary['method']})")
        return _save(fig, path)

    def plot(self, path: str | Path) -> Path:
        """Commands (nominal and sent), ``H`` and ``h_min`` and the clearance over time, one PNG."""
        plt = _pyplot()

        t, tab = self.table["t"], self.table
        fig, axes = plt.subplots(4, 1, figsize=(10, 9), sharex=True)
        for ax, k, name in ((axes[0], 0, "vx (m/s)"), (axes[1], 5, "ωz (rad/s)")):
            ax.plot(t, tab["nominal"][:, k], label="nominal", color="0.6")
            ax.plot(t, tab["command"][:, k], label="sent", color="C0")
            ax.set_ylabel(name)
            ax.legend(loc="upper right")
        axes[2].plot(t, tab["H"], label="H")
        axes[2].plot(t, tab["h_min"], label="h_min")
        axes[2].axhline(0.0, color="k", lw=0.5)
        axes[2].legend(loc="upper right")
        axes[3].plot(t, tab["clearance"], color="C3")
        axes[3].set_ylabel("clearance (m)")
        axes[3].set_xlabel("time from the recording's start (s)")
        for k in np.flatnonzero(~tab["ok"]):
            axes[0].axvline(t[k], color="C3", alpha=0.15, lw=1)
        fig.suptitle(f"shieldnav replay: {self.summary['bag']} ({self.summary['method']})")
        return _save(fig, path)


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig: Any, path: str | Path) -> Path:
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=100)
    _pyplot().close(fig)
    return path


def _reader(paths: Sequence[Path]) -> Any:
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError as err:  # pragma: no cover - exercised only without the extra
        raise ImportError('replaying a recording needs rosbags: pip install "shieldnav[replay]"') from err
    return AnyReader(list(paths), default_typestore=get_typestore(Stores.ROS2_JAZZY))


def _remaps(node_args: list[str], topics: Mapping[str, str] | None) -> list[str]:
    """The node's command line's ``-r`` remaps that read each input from ``topics``."""
    if not topics:
        return []
    unknown = set(topics) - set(TYPES)
    if unknown:
        raise InvalidArgumentError(f"invalid `topics`: unknown inputs {sorted(unknown)} (known: {sorted(TYPES)})")
    current = Node(node_args).topics()
    remaps: list[str] = ["--ros-args"]
    for kind, topic in topics.items():
        if not isinstance(topic, str) or not topic.startswith("/"):
            raise InvalidArgumentError(f"invalid `topics`: {kind} must be a topic name starting with '/', got {topic!r}")
        if current[kind] is None:
            raise InvalidArgumentError(f"invalid `topics`: the node's {kind} input is switched off by its parameters")
        remaps += ["-r", f"{current[kind]}:={topic}"]
    return remaps


def _mounted(reader: Any, node: Node, args: list[str], wanted: dict[str, str]) -> tuple[Node, str]:
    """The node with the recording's ``/tf_static`` mount where its parameters give none, and
    where the mount came from."""
    from shieldnav import tf

    body = node.body()
    tf_conns = [c for c in reader.connections if c.topic == "/tf_static" and c.msgtype == "tf2_msgs/msg/TFMessage"]
    sensors = [c for c in reader.connections if (c.topic, c.msgtype) in {(wanted.get("scan"), TYPES["scan"][0]), (wanted.get("cloud"), TYPES["cloud"][0])}]
    if any(body["mount"]) or not tf_conns or not sensors:
        return node, "parameters"
    frame = None
    for connection, _, raw in reader.messages(connections=sensors):
        try:
            frame = reader.deserialize(raw, connection.msgtype).header.frame_id
        except Exception:  # noqa: BLE001 - an undecodable scan is the run's to count
            continue
        break
    tree = tf.static_tree(reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages(connections=tf_conns))
    try:
        mount = None if frame is None else tf.mount(tree, body["base_frame"], frame)
    except tf.TransformError as err:
        raise ReplayError(f"{err} (set the mount parameters, or replay with tf=False / --no-tf)") from err
    if mount is None:
        return node, "parameters"
    names = ("mount_x", "mount_y", "mount_z", "mount_yaw")
    return Node([*args, "--ros-args", *(a for n, v in zip(names, mount) for a in ("-p", f"{n}:={v!r}"))]), f"/tf_static ({body['base_frame']} → {frame})"


def replay(bag: str | Path, node_args: Sequence[str] = (), topics: Mapping[str, str] | None = None,
           start: float | None = None, end: float | None = None, tf: bool = True) -> Replay:
    """Runs the recording ``bag`` through the node (see the module's text). ``topics``:
    the recording's topic for an input (``scan``, ``cloud``, ``nominal``, ``odom``, ``imu``) where
    it is not the node's. ``start``/``end``: a window in seconds from the recording's start.
    ``tf``: where the parameters give no mount (``mount_*`` all zero), the sensor's mount is
    the recording's ``/tf_static`` chain from ``base_frame`` to the first scan's frame."""
    for name, value in (("start", start), ("end", end)):
        if value is not None and not (isinstance(value, (int, float)) and not isinstance(value, bool) and np.isfinite(value) and value >= 0):
            raise InvalidArgumentError(f"invalid `{name}`: seconds from the recording's start, finite and ≥ 0, got {value!r}")
    if start is not None and end is not None and end <= start:
        raise InvalidArgumentError(f"invalid `end`: must be after `start` ({start} s), got {end} s")
    # the node's command line with the remaps: built once more below only for a /tf_static mount
    args = [str(a) for a in node_args]
    args += _remaps(args, topics)
    node = Node(args)
    wanted = {k: v for k, v in node.topics().items() if k in TYPES and v}
    path = Path(bag)
    if not path.exists():
        raise ReplayError(f"invalid `bag`: {path} does not exist")
    from rosbags.highlevel import AnyReaderError

    try:
        with _reader([path]) as reader:
            node, mount_source = _mounted(reader, node, args, wanted) if tf else (node, "parameters")
            result = _run(reader, node, wanted, path, start, end)
            result.summary["mount"] = {"source": mount_source, "xyz_yaw": list(result.body["mount"])}
            return result
    except ShieldnavError:
        raise
    except (AnyReaderError, OSError, EOFError, ValueError, IndexError, KeyError, struct.error) as err:  # the reader's, on a damaged file
        raise ReplayError(f"cannot read the recording {path}: {type(err).__name__}: {err}") from err


def _run(reader: Any, node: Node, wanted: dict[str, str], path: Path, start: float | None, end: float | None) -> Replay:
    by_topic: dict[str, list[Any]] = {}
    for c in reader.connections:
        by_topic.setdefault(c.topic, []).append(c)
    present = sorted(by_topic)
    if wanted["nominal"] not in by_topic:
        raise ReplayError(f"{path} has no nominal command on {wanted['nominal']} (topics: {', '.join(present)}); "
                          "name it with topics={'nominal': ...} or --nominal")
    if not any(wanted.get(k) in by_topic for k in ("scan", "cloud")):
        raise ReplayError(f"{path} has no scan on {wanted.get('scan')} nor cloud on {wanted.get('cloud')} (topics: {', '.join(present)})")
    if not any(c.msgtype in TYPES["nominal"] for c in by_topic[wanted["nominal"]]):
        types = sorted({c.msgtype for c in by_topic[wanted["nominal"]]})
        raise ReplayError(f"{path}: the nominal topic {wanted['nominal']} holds {', '.join(types)}, not geometry_msgs/msg/Twist or TwistStamped")
    skipped: Counter[str] = Counter()
    routes: dict[int, str] = {}
    for kind, topic in wanted.items():
        for c in by_topic.get(topic, []):
            if c.msgtype in TYPES[kind]:
                routes[id(c)] = kind
            else:
                skipped[f"{topic}: type {c.msgtype}, not {' or '.join(TYPES[kind])}"] += c.msgcount
    origin = reader.start_time
    lo = None if start is None else origin + int(start * 1e9)
    hi = None if end is None else origin + int(end * 1e9)
    connections = [c for cs in by_topic.values() for c in cs if id(c) in routes]
    rows: list[tuple[float, int, np.ndarray, list[float], dict[str, Any]]] = []
    states: list[str] = []
    scans: list[float] = []
    closest: dict[str, Any] | None = None
    for connection, stamp, raw in reader.messages(connections=connections, start=lo, stop=hi):
        kind = routes[id(connection)]
        t = (stamp - origin) * 1e-9
        try:
            msg = reader.deserialize(raw, connection.msgtype)
        except Exception as err:  # noqa: BLE001 - any decoding failure is the message's, counted and passed on to the node
            reason = f"{connection.topic}: cannot decode a {connection.msgtype} ({type(err).__name__})"
            skipped[reason] += 1
            if kind == "nominal":
                command, state = node.reject_nominal(t, reason)
                rows.append((t, stamp, np.asarray(command), [np.nan] * 6, json.loads(state)))
                states.append(state)
            elif kind in ("scan", "cloud"):
                node.reject_scan(reason)
            else:
                node.reject_motion(reason)
            continue
        rejected = None
        if kind == "scan":
            scans.append(t)
            rejected = node.on_scan(t, msg.header.frame_id, msg.angle_min, msg.angle_max, msg.angle_increment, msg.range_min, msg.range_max,
                                    np.asarray(msg.ranges, dtype=np.float32), np.asarray(msg.intensities, dtype=np.float32),
                                    msg.time_increment, msg.scan_time)
        elif kind == "cloud":
            scans.append(t)
            fields = [(f.name, int(f.offset), int(f.datatype), int(f.count)) for f in msg.fields]
            rejected = node.on_cloud(t, msg.header.frame_id, int(msg.height), int(msg.width), fields, bool(msg.is_bigendian), int(msg.point_step),
                                     int(msg.row_step), np.asarray(msg.data, dtype=np.uint8).tobytes(), bool(msg.is_dense))
        elif kind == "odom":
            tw = msg.twist.twist
            rejected = node.on_odometry(t, [tw.linear.x, tw.linear.y, tw.linear.z], [tw.angular.x, tw.angular.y, tw.angular.z])
        elif kind == "imu":
            w = msg.angular_velocity
            rejected = node.on_imu(t, [w.x, w.y, w.z])
        else:
            tw = msg.twist if connection.msgtype.endswith("TwistStamped") else msg
            nominal = [tw.linear.x, tw.linear.y, tw.linear.z, tw.angular.x, tw.angular.y, tw.angular.z]
            command, state = node.on_nominal(t, nominal[:3], nominal[3:])
            parsed = json.loads(state)
            if parsed["clearance"] is not None and (closest is None or parsed["clearance"] < closest["clearance"]):
                closest = {"k": len(rows), "clearance": parsed["clearance"], "points": node.points()}
            rows.append((t, stamp, np.asarray(command), nominal, parsed))
            states.append(state)
        if rejected is not None:
            skipped[f"{connection.topic}: rejected by the node: {rejected}"] += 1
    table = _table(rows)
    return Replay(table, _summary(table, path, node, wanted, skipped, scans, origin, reader.end_time), states, node.body(), closest)


def _table(rows: list[tuple[float, int, np.ndarray, list[float], dict[str, Any]]]) -> dict[str, np.ndarray]:
    n = len(rows)
    table: dict[str, np.ndarray] = {
        "t": np.array([r[0] for r in rows], float), "stamp_ns": np.array([r[1] for r in rows], np.int64),
        "nominal": np.array([r[3] for r in rows], float).reshape(n, 6), "command": np.array([r[2] for r in rows], float).reshape(n, 6),
    }
    for key in _NUMBERS:
        table[key] = np.array([np.nan if r[4].get(key) is None else r[4][key] for r in rows], float)
    for key in _FLAGS:
        table[key] = np.array([bool(r[4].get(key)) for r in rows], bool)
    for key in ("points_used", "points_in_scan"):
        table[key] = np.array([int(r[4].get(key) or 0) for r in rows], np.int64)
    table["reason"] = np.array([r[4].get("reason") or "" for r in rows], object)
    return table


def _summary(table: dict[str, np.ndarray], path: Path, node: Node, wanted: dict[str, str], skipped: Counter[str], scans: list[float],
             origin: int, last: int) -> dict[str, Any]:
    ok = table["ok"]
    change = np.abs(table["command"] - np.nan_to_num(table["nominal"])).max(axis=1) if len(ok) else np.zeros(0)
    changed = ok & (change > 1e-9)
    clearance = table["clearance"]
    closest = int(np.nanargmin(clearance)) if np.isfinite(clearance).any() else None
    gaps = np.diff(scans) if len(scans) > 1 else np.zeros(0)
    stale = sum(1 for r in table["reason"] if r.startswith("stale scan"))
    return {
        "bag": path.name, "method": node.method, "topics": wanted, "cmd_stamped": bool(node.topics()["cmd_stamped"]),
        "duration_s": (last - origin) * 1e-9, "commands": int(len(ok)),
        "changed": int(changed.sum()), "stopped": int((~ok).sum()), "braked": int(table["braked"].sum()), "recovering": int(table["recovering"].sum()),
        "largest_change": float(change[changed].max()) if changed.any() else 0.0,
        "stop_reasons": dict(Counter(r.split(":")[0] for r in table["reason"] if r)),
        "closest_clearance_m": None if closest is None else float(clearance[closest]), "closest_at_s": None if closest is None else float(table["t"][closest]),
        "scans": len(scans), "longest_scan_gap_s": float(gaps.max()) if len(gaps) else None, "stale_scan_commands": stale,
        "skipped": dict(skipped), "solve_time_us_median": float(np.nanmedian(table["solve_time_us"])) if ok.any() else None,
    }


def summary_text(result: Replay) -> str:
    """The summary as a few lines for the terminal."""
    s = result.summary
    lines = [f"{s['bag']}: {s['commands']} commands over {s['duration_s']:.1f} s, shield {s['method']}",
             f"  changed {s['changed']} ({s['largest_change']:.3f} at most), stopped {s['stopped']}, braked {s['braked']}, recovering {s['recovering']}"]
    if s["closest_clearance_m"] is not None:
        lines.append(f"  closest approach: {s['closest_clearance_m']:.3f} m at {s['closest_at_s']:.2f} s")
    if "mount" in s:
        x, y, z, yaw = s["mount"]["xyz_yaw"]
        lines.append(f"  sensor mount ({x:.3f}, {y:.3f}, {z:.3f}) m, yaw {yaw:.3f} rad, from {s['mount']['source']}")
    lines.append(f"  scans {s['scans']}, longest gap {s['longest_scan_gap_s'] or 0:.3f} s, commands on a stale scan {s['stale_scan_commands']}")
    for reason, count in s["stop_reasons"].items():
        lines.append(f"  stopped: {reason} ({count})")
    for reason, count in s["skipped"].items():
        lines.append(f"  skipped: {reason} ({count})")
    return "\n".join(lines)
