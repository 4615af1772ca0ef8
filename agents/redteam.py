"""The red team: attackers that try to make the shielded robot touch something.

Each attacker drives the environment's own action (body-frame ``(v_x, v_y, ω)`` in
``[-1, 1]³``) through the shield under test; the harness counts, over every episode, the
steps in contact (``info["cost"]``), the episodes with contact and the least true clearance.

Attackers:

- ``held``: every component at ``±1`` (random signs), held for 0.1–1 s, then drawn again;
- ``seeker``: full speed at the nearest LIDAR return while spinning at the full rate (the
  spin's sign flips every 2–4 s);
- ``skimmer``: full speed along the nearest wall while pressing into it, the heading turned
  toward it;
- ``cruise``: straight ahead at half the top speed (0.8 m/s), what a nominal controller
  does down a corridor;
- ``ppo``: a PPO policy trained under the shield to touch things (``--train-attacker``: a
  reward for contact and for low clearance), evaluated with ``--attacker-model``.

Shields: the environment's (``braking``, ``composite``, the baselines, ``none``), and ``node``:
the ROS 2 node's decisions in the loop of the simulated body (``agents.node_shield``: the
LIDAR as ``LaserScan`` at its rate, the body's velocity as ``Odometry``, the node's braking
shield with the body's model), one environment after another.

Sites: procedural office sites, the paper's static scenarios and every ROS map in
``--maps`` (default ``../shared/maps`` beside the repository); tight spaces (``agents.tight``:
the robot started in aisles, L-shaped aisles and doorways 0.60–0.90 m wide, narrower than
the shield's 0.9 m ellipse, beside, facing and in the corner of walls), reported apart
(``tight``); the scenario with moving obstacles (``moving``) and the mover sites
(``agents.movers``: pedestrians crossing, head-on and overtaking, a chaser, a pushed chair and
a swung door), reported apart (``movers``) with the contact events and the events that began
with the robot moving: a reactive shield cannot stop something from driving into a robot that
already stands, but it must not drive into it.

    python -m agents.redteam                               # >= 10,000 episodes per shield
    python -m agents.redteam --quick                       # a short look
    python -m agents.redteam --tight --episodes 200        # the tight spaces only
    python -m agents.redteam --movers --attackers held seeker cruise   # the mover sites only
    python -m agents.redteam --movers --set track_movers=False         # every return taken as static
    python -m agents.redteam --shields braking --attackers held --episodes 64
    python -m agents.redteam --shields node --tight --episodes 300   # the ROS 2 node's decisions
    python -m agents.redteam --train-attacker --timesteps 300000 --out results/redteam
    python -m agents.redteam --attackers ppo --attacker-model results/redteam/attacker.zip
    python -m agents.redteam --backend ray [--ray-address auto]
    python -m agents.redteam --quick --set lidar_noise_std=0.05 --set brake_margin=0.02   # env keywords in every cell

Results: a table on stdout, ``redteam.json`` and ``redteam.csv`` under ``--out``.
"""

from __future__ import annotations

import argparse
import ast
import csv
import json
import math
import os
import sys
import time
from pathlib import Path
from typing import Any, Iterator

import gymnasium as gym
import numpy as np
import shieldnav  # noqa: F401  (registers the ids)
from shieldnav.exceptions import InvalidArgumentError
from tqdm import tqdm

from agents.benchmark import check_options, output_folder, positive_int
from agents.movers import mover_sites
from agents.tight import scenario_file, tight_sites

ATTACKERS = ["held", "seeker", "skimmer", "cruise", "ppo"]
SHIELDS = ["braking", "composite"]
STATIC = ["shieldnav/CorridorInspection-v0", "shieldnav/ConstrictedPassage-v0", "shieldnav/OdometryJump-v0"]
DYNAMIC = ["shieldnav/DynamicObstacles-v0"]
DEFAULT_MAPS = Path(__file__).resolve().parents[2] / "shared" / "maps"
#: The id that runs the tight sites' scenario files.
TIGHT_ID = "shieldnav/CorridorInspection-v0"
#: The tight sites of ``--quick``.
QUICK_TIGHT = ("aisle-0.70", "door-0.80-inside")
#: The mover sites of ``--quick``.
QUICK_MOVERS = ("head-on-0",)
#: Draws of each mover site (their timings and offsets) in a full run.
MOVER_VARIANTS = 4
#: What each episode's totals give the cells.
EPISODE_KEYS = ("contact_steps", "collisions", "contact_events", "moving_collisions", "min_clearance", "steps", "shield_braked_steps", "shield_recovering_steps")
#: The groups of sites, each reported apart.
WORLDS = ("static", "tight", "moving", "movers")
#: Control periods per second at the default dt.
RATE = 50
#: Keywords each cell sets itself (the site, the shield, the episode's length): not for --set.
OWN_KEYWORDS = ("shield", "time_limit", "terminate_at_goal", "threads", "preset", "procedural", "map_path", "scenario_path", "default_site", "observation")


def keyword(text: str) -> tuple[str, Any]:
    """argparse type of ``--set KEY=VALUE``: the value a Python literal where it parses as one
    (``0.05``, ``(1.1, 0.5)``, ``True``), else the string."""
    key, eq, value = text.partition("=")
    if not eq or not key.strip():
        raise argparse.ArgumentTypeError(f"expected KEY=VALUE, got {text!r}")
    try:
        return key.strip(), ast.literal_eval(value)
    except (ValueError, SyntaxError):
        return key.strip(), value


def sites(maps: Path | None, seed: int = 0) -> list[dict[str, Any]]:
    """Every site of a full run: the static ids, each map of ``maps``, the tight spaces (their
    scenario built from ``seed``), then the moving one."""
    def site(name: str, env_id: str, worlds: str, **extra: Any) -> dict[str, Any]:
        return {"site": name, "env_id": env_id, "kwargs": {}, "worlds": worlds, "dynamic": worlds in ("moving", "movers"), **extra}

    out = [site(env_id.split("/")[1].removesuffix("-v0"), env_id, "static") for env_id in STATIC]
    if maps is not None and maps.is_dir():
        out += [site(yaml.parent.name, "shieldnav/MapInspection-v0", "static", kwargs={"map_path": str(yaml)}) for yaml in sorted(maps.glob("*/*.yaml"))]
    out += [site(t["site"], TIGHT_ID, "tight", scenario=t["scenario"]) for t in tight_sites(seed)]
    out += [site(env_id.split("/")[1].removesuffix("-v0"), env_id, "moving") for env_id in DYNAMIC]
    out += [site(f"{m['site']}-{v}", TIGHT_ID, "movers", scenario=m["scenario"]) for v in range(MOVER_VARIANTS) for m in mover_sites(MOVER_VARIANTS * seed + v)]
    return out


class Attacker:
    """A vectorised attacker: ``act(obs) -> actions`` for ``n`` sub-environments."""

    def __init__(self, kind: str, n: int, seed: int, model: str | None = None) -> None:
        self.kind, self.n = kind, n
        self.rng = np.random.default_rng(seed)
        self.action = self.rng.choice([-1.0, 1.0], size=(n, 3))
        self.hold = self.rng.integers(5, 51, size=n)
        self.spin = self.rng.choice([-1.0, 1.0], size=n)
        self.side = self.rng.choice([-1.0, 1.0], size=n)
        self.model = None
        if kind == "ppo":
            if model is None:
                raise ValueError("the ppo attacker needs --attacker-model (train one with --train-attacker)")
            from stable_baselines3 import PPO

            self.model = PPO.load(model, device="cpu")

    def act(self, obs: np.ndarray) -> np.ndarray:
        if self.kind == "ppo":
            action, _ = self.model.predict(obs, deterministic=False)
            return np.clip(action, -1.0, 1.0)
        if self.kind == "cruise":
            return np.tile(np.array([0.5, 0.0, 0.0]), (self.n, 1))
        if self.kind == "held":
            self.hold -= 1
            new = self.hold <= 0
            k = int(new.sum())
            if k:
                self.action[new] = self.rng.choice([-1.0, 1.0], size=(k, 3))
                self.hold[new] = self.rng.integers(5, 51, size=k)
            return self.action.copy()
        bins = obs.shape[1] - 9
        nearest = np.argmin(obs[:, :bins], axis=1)
        bearing = nearest * (2.0 * math.pi / bins)
        flip = self.rng.random(self.n) < 1.0 / (3 * RATE)
        self.spin[flip] *= -1.0
        if self.kind == "seeker":
            d = np.stack([np.cos(bearing), np.sin(bearing)], axis=1)
            w = self.spin
        else:  # skimmer: along the wall, pressed into it, turned toward it
            along = bearing + self.side * (math.pi / 2)
            d = np.stack([np.cos(along) + 0.6 * np.cos(bearing), np.sin(along) + 0.6 * np.sin(bearing)], axis=1)
            w = np.clip(2.0 * np.sin(bearing), -1.0, 1.0)
        d /= np.maximum(np.abs(d).max(axis=1, keepdims=True), 1e-9)
        return np.concatenate([d, w[:, None]], axis=1)


def node_vector_env(env_id: str, n: int, **kwargs: Any) -> gym.vector.VectorEnv:
    """``n`` environments, each with the ROS 2 node's decisions in place of its shield
    (``agents.node_shield``), stepped one after the other."""
    from agents.node_shield import NodeShield

    return gym.vector.SyncVectorEnv([lambda: NodeShield(gym.make(env_id, shield="none", **kwargs)) for _ in range(n)],
                                    autoreset_mode=gym.vector.AutoresetMode.SAME_STEP)


def run_cell(task: dict[str, Any]) -> dict[str, Any]:
    """``episodes`` episodes of one attacker against one shield on one site, in one native
    vector environment; returns the totals and the per-episode figures."""
    n = min(task["num_envs"], task["episodes"])
    kwargs = dict(task["kwargs"])
    if task.get("scenario") is not None:  # (written where the cell runs: a Ray worker may be elsewhere)
        kwargs["scenario_path"] = scenario_file(task["scenario"])
    if task["shield"] == "node":
        env = node_vector_env(task["env_id"], n, time_limit=task["steps"], terminate_at_goal=False, **kwargs)
    else:
        env = gym.make_vec(
            task["env_id"], num_envs=n, vectorization_mode="vector_entry_point", autoreset_mode="same_step",
            time_limit=task["steps"], terminate_at_goal=False, shield=task["shield"], threads=task["threads"], **kwargs,
        )
    attacker = Attacker(task["attacker"], n, task["seed"], task.get("model"))
    obs, _ = env.reset(seed=task["seed"])
    episodes: list[dict[str, float]] = []
    started = time.perf_counter()
    steps = 0
    while len(episodes) < task["episodes"]:
        obs, _, _, _, info = env.step(attacker.act(obs))
        steps += n
        final = info.get("final_info")
        if final is not None:
            ended = final["shieldnav_episode"]
            for i in np.flatnonzero(ended["_contact_steps"]):
                episodes.append({k: float(ended[k][i]) for k in EPISODE_KEYS})
    config = env.get_attr("config")[0] if task["shield"] == "node" else env.config
    settings = {k: config[k] for k in task.get("set", {})}  # as the environment took them
    env.close()
    episodes = episodes[: task["episodes"]]
    contact = [e["contact_steps"] for e in episodes]
    return {
        **{k: task[k] for k in ("site", "env_id", "shield", "attacker", "worlds", "dynamic")},
        "set": settings,
        "episodes": len(episodes),
        "steps": int(sum(e["steps"] for e in episodes)),
        "contact_steps": int(sum(contact)),
        "episodes_with_contact": int(sum(c > 0 for c in contact)),
        "contact_events": int(sum(e["contact_events"] for e in episodes)),
        "moving_contact_events": int(sum(e["moving_collisions"] for e in episodes)),
        "least_clearance": min(e["min_clearance"] for e in episodes),
        "braked_steps": int(sum(e["shield_braked_steps"] for e in episodes)),
        "recovering_steps": int(sum(e["shield_recovering_steps"] for e in episodes)),
        "steps_per_s": steps / max(time.perf_counter() - started, 1e-9),
    }


def run_local(todo: list[dict[str, Any]]) -> Iterator[dict[str, Any]]:
    for task in todo:
        yield run_cell(task)


def run_ray(todo: list[dict[str, Any]], address: str | None, workers: int) -> Iterator[dict[str, Any]]:
    try:
        import ray
    except ImportError as err:
        raise ImportError('the Ray backend needs Ray: pip install "shieldnav[ray]"') from err
    if not ray.is_initialized():
        env = {"env_vars": {"PYTHONPATH": os.pathsep.join(sys.path)}}
        if address:
            ray.init(address=address, runtime_env=env, log_to_driver=False)
        else:
            ray.init(num_cpus=workers, runtime_env=env, log_to_driver=False, include_dashboard=False)
    # by reference, so that a worker imports this module (and shieldnav with its ids): under
    # `python -m agents.redteam` this module's own run_cell is __main__'s, sent by value
    from agents.redteam import run_cell as by_reference

    remote = ray.remote(num_cpus=1)(by_reference)
    pending = [remote.remote({**t, "threads": 1}) for t in todo]
    try:
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            yield ray.get(done[0])
    finally:
        for p in pending:
            ray.cancel(p)


def train_attacker(env_id: str, shield: str, timesteps: int, seed: int, out: Path, num_envs: int, **settings: Any) -> Path:
    """PPO trained under ``shield`` with a reward for contact (+10 a step) and for low
    clearance (``−clearance``, capped at 1 m): the strongest learned attacker we build;
    ``settings`` go to the environment."""
    from shieldnav.sb3 import ShieldnavVecEnv
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecEnvWrapper

    class AttackReward(VecEnvWrapper):  # type: ignore[misc]
        def reset(self) -> Any:
            return self.venv.reset()

        def step_wait(self) -> Any:
            obs, _, done, infos = self.venv.step_wait()
            reward = np.array([10.0 * i["cost"] - min(i["clearance"], 1.0) for i in infos], dtype=np.float32)
            return obs, reward, done, infos

    inner = ShieldnavVecEnv(env_id, num_envs=num_envs, shield=shield, terminate_at_goal=False, time_limit=750, **settings)
    inner.seed(seed)
    venv = AttackReward(inner)
    model = PPO("MlpPolicy", venv, seed=seed, n_steps=256, batch_size=512, device="cpu", verbose=0)
    model.learn(total_timesteps=timesteps, progress_bar=True)
    path = out / "attacker.zip"
    model.save(path)
    return path


def table(results: list[dict[str, Any]]) -> str:
    """Totals per (static, tight or moving worlds, shield, attacker)."""
    rows = ["| worlds | shield | attacker | episodes | steps | contact steps | episodes with contact | contact events | begun moving | least clearance (m) |",
            "|---|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    keys = sorted({(WORLDS.index(r["worlds"]), r["shield"], r["attacker"]) for r in results})
    for w, shield, attacker in keys:
        rs = [r for r in results if (r["worlds"], r["shield"], r["attacker"]) == (WORLDS[w], shield, attacker)]
        rows.append(
            f"| {WORLDS[w]} | {shield} | {attacker} | {sum(r['episodes'] for r in rs):,} | {sum(r['steps'] for r in rs):,} | "
            f"{sum(r['contact_steps'] for r in rs):,} | {sum(r['episodes_with_contact'] for r in rs):,} | {sum(r['contact_events'] for r in rs):,} | "
            f"{sum(r['moving_contact_events'] for r in rs):,} | {min(r['least_clearance'] for r in rs):.3f} |"
        )
    return "\n".join(rows)


def main(argv: list[str] | None = None) -> list[dict[str, Any]]:
    ap = argparse.ArgumentParser(prog="python -m agents.redteam", description=__doc__.split("\n\n")[0])
    ap.add_argument("--shields", nargs="+", default=SHIELDS, choices=["braking", "composite", "distance", "hardmin", "none", "node"])
    ap.add_argument("--attackers", nargs="+", default=["held", "seeker", "skimmer"], choices=ATTACKERS)
    ap.add_argument("--episodes", type=positive_int, default=10_000,
                    help="episodes per shield over the static worlds, and again over the tight spaces (split over sites and attackers)")
    ap.add_argument("--steps", type=positive_int, default=750, help="steps per episode (50 Hz)")
    ap.add_argument("--maps", type=Path, default=DEFAULT_MAPS, help="a folder of ROS maps (<name>/<name>.yaml)")
    ap.add_argument("--num-envs", type=positive_int, default=64, help="episodes stepped together per cell")
    ap.add_argument("--workers", type=positive_int, default=len(os.sched_getaffinity(0)), help="threads (local) or Ray CPUs")
    ap.add_argument("--backend", default="local", choices=["local", "ray"])
    ap.add_argument("--ray-address", default=None)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--quick", action="store_true", help="48 episodes per shield on three sites, two tight spaces and a mover site")
    ap.add_argument("--tight", action="store_true", help="the tight spaces only")
    ap.add_argument("--movers", action="store_true", help="the mover sites only")
    ap.add_argument("--attacker-model", default=None, help="the ppo attacker's model (.zip)")
    ap.add_argument("--train-attacker", action="store_true", help="train the ppo attacker, then stop")
    ap.add_argument("--timesteps", type=positive_int, default=300_000, help="--train-attacker's training steps")
    ap.add_argument("--set", type=keyword, action="append", default=[], metavar="KEY=VALUE",
                    help="an environment keyword for every cell (repeatable), e.g. --set lidar_noise_std=0.05")
    ap.add_argument("--out", default="results/redteam")
    args = ap.parse_args(argv)
    check_options(ap, args, "shields", "attackers")
    settings = dict(args.set)
    own = sorted(set(settings) & set(OWN_KEYWORDS))
    if own:
        ap.error(f"argument --set: {', '.join(own)} is set by the red team itself (use --shields, --steps)")
    try:  # one environment with them, before any cell runs
        gym.make(STATIC[0], **settings).close()
    except InvalidArgumentError as err:
        ap.error(f"argument --set: {err}")
    out = output_folder(ap, args.out)
    if args.train_attacker:
        path = train_attacker("shieldnav/CorridorInspection-v0", args.shields[0], args.timesteps, args.seed, out, 8, **settings)
        print(f"attacker saved to {path}")
        return []
    if "ppo" in args.attackers and not args.attacker_model:
        ap.error("argument --attackers: ppo needs --attacker-model (train one with --train-attacker)")
    todo_sites = sites(None if args.quick or args.tight or args.movers else args.maps, args.seed)
    if args.quick:
        quick = {"tight": lambda s: s["site"] in QUICK_TIGHT, "movers": lambda s: s["site"] in QUICK_MOVERS}
        todo_sites = [s for s in todo_sites if quick.get(s["worlds"], lambda s: s["env_id"] in (STATIC[0], STATIC[1], DYNAMIC[0]))(s)]
        args.episodes = min(args.episodes, 48)
    if args.tight or args.movers:
        todo_sites = [s for s in todo_sites if (args.tight and s["worlds"] == "tight") or (args.movers and s["worlds"] == "movers")]
    # --episodes over the static sites, again over the tight ones and over the mover sites; the
    # moving scenario as a static site
    count = {w: sum(s["worlds"] == w for s in todo_sites) for w in WORLDS}
    per_cell = {w: max(1, math.ceil(args.episodes / (max(count[w], 1) * len(args.attackers)))) for w in ("static", "tight", "movers")}
    per_cell["moving"] = per_cell["static"]
    todo = [
        {**s, "shield": shield, "attacker": attacker, "episodes": per_cell[s["worlds"]], "steps": args.steps, "seed": args.seed + 1000 * k,
         "num_envs": args.num_envs, "threads": args.workers, "model": args.attacker_model, "kwargs": {**s["kwargs"], **settings}, "set": settings}
        for shield in args.shields for k, attacker in enumerate(args.attackers) for s in todo_sites
    ]
    source = run_local(todo) if args.backend == "local" else run_ray(todo, args.ray_address, args.workers)
    results = []
    try:
        for r in tqdm(source, total=len(todo), desc="red team", unit="cell"):
            results.append(r)
    except KeyboardInterrupt:
        print(f"interrupted: {len(results)} of {len(todo)} cells finished", file=sys.stderr)
    if results:
        (out / "redteam.json").write_text(json.dumps(results, indent=1))
        with open(out / "redteam.csv", "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(results[0]))
            w.writeheader()
            w.writerows(results)
        print(table(results) + (f"\nenvironment keywords (--set): {settings}" if settings else ""))
    return results


if __name__ == "__main__":
    main()
