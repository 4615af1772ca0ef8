"""The ``shieldnav`` command line.

    shieldnav info                                   # version, SIMD level, ids and time limits
    shieldnav render shieldnav/MapInspection-v0 --set map_path=my_map.yaml --out site.png
    shieldnav run shieldnav/ConstrictedPassage-v0 --policy scripted --gif run.gif
    shieldnav filter scan.npy --u-nom 1.0 0.2        # the shield on a saved scan (N×2 or N×3)
    shieldnav filter scan.npy --u-nom 1 0 0 --semi-axes 0.9 0.45 0.4   # a 3D shield (N×3 scan)
    shieldnav replay run.mcap --params shield.yaml --scan /front/scan --out run.shieldnav   # a recording

``--set key=value`` passes any environment keyword (``shieldnav.ENV_DEFAULTS``); values are
read as JSON when they parse (numbers, lists, true/false/null), else as strings. Errors name
what was wrong and exit with status 2; output files (``--out``, ``--gif``) and ``--policy
scripted`` are checked before anything runs.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import warnings
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from shieldnav.exceptions import ShieldnavError

POLICIES = ("zero", "random", "scripted", "ppo")


def _settings(pairs: Sequence[str]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for pair in pairs:
        key, sep, raw = pair.partition("=")
        if not sep or not key:
            raise ValueError(f"invalid `--set`: expected key=value, got {pair!r}")
        try:
            out[key] = json.loads(raw)
        except json.JSONDecodeError:
            out[key] = raw
    return out


def _at_least(option: str, value: int | None, low: int) -> None:
    if value is not None and value < low:
        raise ValueError(f"invalid `{option}`: must be at least {low}, got {value}")


def _writable(option: str, path: str) -> None:
    """A usage error unless a file can be written at ``path`` (its folder exists and takes one)."""
    target = Path(path)
    if target.is_dir():
        raise ValueError(f"invalid `{option}`: {target} is a folder, not a file name")
    folder = target.parent
    if not folder.is_dir():
        raise ValueError(f"invalid `{option}`: the folder {folder} does not exist")
    try:
        tempfile.TemporaryFile(dir=folder).close()
    except OSError as err:
        raise ValueError(f"invalid `{option}`: cannot write to the folder {folder}: {err.strerror or err}") from err


def _check_image(path: str) -> None:
    """``render --out``: a file name whose extension Pillow writes, in a writable folder."""
    from PIL import Image

    Image.init()
    ext = Path(path).suffix.lower()
    if Image.registered_extensions().get(ext) not in Image.SAVE:
        raise ValueError(f"invalid `--out`: expected an image file name that Pillow writes (e.g. .png or .jpg), got {path!r}")
    _writable("--out", path)


def _check_video(path: str) -> None:
    """``run --gif``: a .gif (Pillow) or .mp4 (imageio and imageio-ffmpeg) file name in a writable folder."""
    ext = Path(path).suffix.lower()
    if ext not in (".gif", ".mp4"):
        raise ValueError(f"invalid `--gif`: expected a .gif or .mp4 file name, got {path!r}")
    if ext == ".mp4":
        try:
            import imageio.v2  # noqa: F401
            import imageio_ffmpeg  # noqa: F401
        except ImportError as err:
            raise ValueError(f'invalid `--gif`: writing .mp4 needs imageio and imageio-ffmpeg ({err}): pip install "shieldnav[render]"') from err
    _writable("--gif", path)


def _make(env_id: str, settings: dict[str, Any], render: bool, shield: str | None = None) -> Any:
    import gymnasium as gym

    from shieldnav.registration import ENV_IDS

    if env_id not in ENV_IDS:
        raise ValueError(f"invalid environment id {env_id!r}: known ids are {', '.join(sorted(ENV_IDS))}")
    if "render_mode" in settings:
        raise ValueError("invalid `--set render_mode`: the command chooses the render mode itself (rgb_array for `render` and `--gif`)")
    kwargs = dict(settings)
    if shield is not None:
        kwargs["shield"] = shield
    return gym.make(env_id, render_mode="rgb_array" if render else None, **kwargs)


def cmd_info(_: argparse.Namespace) -> None:
    from shieldnav import SHIELD_DEFAULTS, Shield, __version__
    from shieldnav.registration import ENV_IDS

    print(f"shieldnav {__version__}  (shield kernel: {Shield().simd_level})")
    print("\nenvironments (time limit at 50 Hz):")
    for env_id, (_, steps) in sorted(ENV_IDS.items()):
        print(f"  {env_id:36s} {steps:5d} steps ({steps * 0.02:g} s)")
    print("\nshield defaults (the paper's):")
    for key, value in SHIELD_DEFAULTS.items():
        print(f"  {key:16s} {value}")


def cmd_render(args: argparse.Namespace) -> None:
    from PIL import Image

    _at_least("--seed", args.seed, 0)
    _check_image(args.out)
    env = _make(args.env_id, _settings(args.set), render=True)
    env.reset(seed=args.seed)
    frame = env.render()
    env.close()
    Image.fromarray(frame).save(args.out)
    print(f"wrote {args.out} ({frame.shape[1]}×{frame.shape[0]})")


def cmd_run(args: argparse.Namespace) -> None:
    _at_least("--seed", args.seed, 0)
    _at_least("--steps", args.steps, 1)
    if args.gif is not None:
        _check_video(args.gif)
    env = _make(args.env_id, _settings(args.set), render=args.gif is not None, shield=args.shield)
    obs, info = env.reset(seed=args.seed)
    rng = np.random.default_rng(args.seed)
    agent = None
    if args.policy == "scripted":
        from shieldnav.scripted import InspectionAgent

        agent = InspectionAgent(env)
        agent.reset()
    elif args.policy == "ppo":
        from shieldnav.policies import load

        agent = load("ppo", env)
    frames = []
    steps = 0
    while True:
        if agent is not None:
            action = agent.act(obs, info)
        elif args.policy == "random":
            action = rng.uniform(-1.0, 1.0, 3).astype(np.float32)
        else:
            action = np.zeros(3, dtype=np.float32)
        obs, _, terminated, truncated, info = env.step(action)
        steps += 1
        if args.gif is not None and steps % 5 == 1:
            frames.append(env.render())
        if terminated or truncated or (args.steps is not None and steps >= args.steps):
            break
    summary = env.unwrapped.episode.summary()
    env.close()
    if args.gif is not None:
        from shieldnav.rendering import save_video

        save_video(frames, args.gif, fps=10)
    clean = {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in summary.items()}
    print(json.dumps(clean, indent=1))
    if args.gif is not None:
        print(f"wrote {args.gif} ({len(frames)} frames)", file=sys.stderr)


def cmd_filter(args: argparse.Namespace) -> None:
    from shieldnav import Shield

    kwargs: dict[str, Any] = {"method": args.method}
    if args.semi_axes is not None:
        kwargs["semi_axes"] = tuple(args.semi_axes)
    shield = Shield(**kwargs)
    if len(args.u_nom) != shield.dim:
        raise ValueError(f"invalid `--u-nom`: a {shield.dim}D shield ({shield.dim} semi-axes) takes {shield.dim} values, got {len(args.u_nom)}")
    path = Path(args.points)
    if not path.is_file():
        raise ValueError(f"invalid `points`: {path} is not a file")
    try:
        if path.suffix == ".npy":
            points = np.load(path)
        else:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)  # an empty file is an empty scan
                points = np.loadtxt(path, delimiter=",", ndmin=2)
            if points.size == 0:
                points = np.empty((0, shield.dim))
    except (ValueError, OSError, EOFError) as err:
        raise ValueError(f"invalid `points`: cannot read {path}: {err}") from err
    points = np.ascontiguousarray(points)
    # 3D: --yaw is the rotation about z (body to world) and --omega the body yaw rate
    omega = args.omega if shield.dim == 2 else np.array([0.0, 0.0, args.omega])
    out = shield.filter(points, np.asarray(args.u_nom, dtype=np.float64), yaw=args.yaw, omega=omega)
    print(json.dumps({
        "u": [float(v) for v in out.u], "H": out.H, "h_min": out.h_min if math.isfinite(out.h_min) and out.h_min < 1e300 else None,
        "active": out.active, "feasible": out.feasible, "num_points": out.num_points, "solve_time_us": out.solve_time_ns / 1e3,
    }, indent=1))


def cmd_replay(args: argparse.Namespace) -> None:
    from shieldnav.replay import replay, summary_text

    out = Path(args.out) if args.out else None
    if out is not None and out.exists():
        raise ValueError(f"invalid `--out`: {out} exists (the replay writes a new folder)")
    node_args = (["--params", args.params] if args.params else []) + [a for pair in args.param for a in ("-p", pair)]
    topics = {k: getattr(args, k) for k in ("scan", "cloud", "nominal", "odom", "imu") if getattr(args, k)}
    result = replay(args.bag, node_args, topics, args.start, args.end, tf=not args.no_tf)
    print(summary_text(result))
    if out is not None:
        out.mkdir(parents=True)
        columns = ["t", *(f"nominal_{a}" for a in ("vx", "vy", "vz", "wx", "wy", "wz")), *(f"command_{a}" for a in ("vx", "vy", "vz", "wx", "wy", "wz")),
                   "H", "h_min", "clearance", "ok", "active", "feasible", "braked", "recovering", "tight", "points_used", "points_in_scan",
                   "scan_age", "solve_time_us", "reason"]
        tab = result.table
        with (out / "table.csv").open("w") as f:
            f.write(",".join(columns) + "\n")
            for k in range(len(tab["t"])):
                row = [tab["t"][k], *tab["nominal"][k], *tab["command"][k], *(tab[c][k] for c in columns[13:-1])]
                f.write(",".join(f"{v:.9g}" if isinstance(v, (float, np.floating)) else str(int(v)) for v in row) + f",{json.dumps(tab['reason'][k])}\n")
        (out / "summary.json").write_text(json.dumps(result.summary, indent=1))
        mcap = result.write_mcap(out / "mcap")
        written = [out / "table.csv", out / "summary.json", mcap]
        try:
            written.append(result.plot(out / "replay.png"))
            closest = result.plot_closest(out / "closest.png")
            if closest is not None:
                written.append(closest)
        except ImportError:
            print("matplotlib not installed: no replay.png", file=sys.stderr)
        print("wrote " + ", ".join(str(w) for w in written), file=sys.stderr)


def parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="shieldnav", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="command", required=True)
    sub.add_parser("info", help="version, SIMD level, environment ids, shield defaults").set_defaults(func=cmd_info)
    r = sub.add_parser("render", help="save the top-down picture of an environment after reset")
    r.add_argument("env_id")
    r.add_argument("--seed", type=int, default=0)
    r.add_argument("--out", default="shieldnav.png")
    r.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="an environment keyword")
    r.set_defaults(func=cmd_render)
    u = sub.add_parser("run", help="run one episode and print its summary")
    u.add_argument("env_id")
    u.add_argument("--policy", choices=POLICIES, default="zero")
    u.add_argument("--shield", default=None, help="braking, composite, distance, hardmin or none (default: the env's, braking)")
    u.add_argument("--seed", type=int, default=0)
    u.add_argument("--steps", type=int, default=None, help="stop after this many steps")
    u.add_argument("--gif", default=None, help="write a GIF of the episode (every 5th step)")
    u.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="an environment keyword")
    u.set_defaults(func=cmd_run)
    f = sub.add_parser("filter", help="the shield on a saved scan (.npy or .csv, N×2 or N×3, body frame)")
    f.add_argument("points")
    f.add_argument("--u-nom", type=float, nargs="+", required=True, metavar="V", help="VX VY, or VX VY VZ for a 3D shield")
    f.add_argument("--yaw", type=float, default=0.0, help="heading (rad; about z for a 3D shield)")
    f.add_argument("--omega", type=float, default=0.0, help="yaw rate (rad/s; about body z for a 3D shield)")
    f.add_argument("--semi-axes", type=float, nargs="+", default=None)
    f.add_argument("--method", default="composite", choices=["composite", "distance", "hardmin", "none"])
    f.set_defaults(func=cmd_filter)
    y = sub.add_parser("replay", help="the shield on a recording (rosbag2 .mcap or .db3, ROS 1 .bag): what it would have sent")
    y.add_argument("bag")
    y.add_argument("--params", default=None, help="the node's parameter file (ROS 2 layout, as shieldnav-ros2 reads it)")
    y.add_argument("-p", "--param", action="append", default=[], metavar="NAME:=VALUE", help="a node parameter over the file")
    for kind in ("scan", "cloud", "nominal", "odom", "imu"):
        y.add_argument(f"--{kind}", default=None, metavar="TOPIC", help=f"the recording's {kind} topic (default: the node's)")
    y.add_argument("--start", type=float, default=None, help="seconds from the recording's start")
    y.add_argument("--end", type=float, default=None, help="seconds from the recording's start")
    y.add_argument("--no-tf", action="store_true", help="do not take the sensor's mount from the recording's /tf_static")
    y.add_argument("--out", default=None, help="a new folder for table.csv, summary.json, replay.png, closest.png and the MCAP of the filtered command")
    y.set_defaults(func=cmd_replay)
    return ap


def main(argv: Sequence[str] | None = None) -> int:
    args = parser().parse_args(argv)
    try:
        args.func(args)
    except (ValueError, ShieldnavError, OSError, ImportError) as err:
        print(f"shieldnav: error: {err}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
