"""Run an experiment grid (methods × environments × seeds) described by one YAML file.

    python -m agents.grid experiments/safe_rl.yml --out results/grid/safe_rl --workers 2
    python -m agents.grid experiments/safe_rl.yml --out results/grid/safe_rl --backend ray [--ray-address auto]

The file follows rl-zoo3's conventions for the hyperparameters: a block per algorithm with
``policy``, ``n_timesteps``, ``n_envs`` and the algorithm's constructor keywords, over the
environment's block of ``agents/hyperparams/<algo>.yml`` (``{}``: those of ``agents.train``);
methods name an algorithm, a shield and any environment keyword, and may override
hyperparameters::

    seeds: [0, 1, 2]
    envs:                       # folder name: {id: registered id, any environment keyword}
      corridor: {id: shieldnav/CorridorInspection-v0}
    eval: {every: 100000, episodes: 2}
    algos:
      ppo: {policy: MlpPolicy, n_timesteps: 500000, n_envs: 8, n_steps: 256, batch_size: 256}
    methods:
      ppo_braking: {algo: ppo, shield: braking}
      ppo_penalty: {algo: ppo, shield: none, env_kwargs: {collision_penalty: 10.0}}

Each run trains with ``agents.train.train`` into ``<out>/<env>/<method>/seed_<k>/``. A run whose
folder holds a ``run.json`` is finished and skipped; ``run.json`` is written last and whole, so
a run stopped by Ctrl-C leaves none and starts again next time, while the finished runs stay.
Progress (runs done / total, env steps/s, ETA) is printed as runs finish. ``--workers N`` runs
N trainings at once, each in its own process with one torch thread and one native thread;
``--backend ray`` runs each training as a Ray task (a local Ray with ``--workers`` CPUs, or the
cluster at ``--ray-address``) with the same code and seeds, hence the same results. With Ray
the driver writes each ``run.json`` from the task's answer, so the grid's figures reach the
driver's folder even when the workers' file system is another.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import shutil
import signal
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any, Iterator

import yaml
from shieldnav.exceptions import InvalidArgumentError

from agents import benchmark, train
from agents.pool import as_finished
from agents.train import ALGOS, RUN_KEYS, SEED_END, write_json_atomically

METHOD_KEYS = {"algo", "shield", "env_kwargs", "hyperparams"}
TOP_KEYS = {"seeds", "envs", "eval", "algos", "methods", "max_episode_steps"}


class GridError(ValueError):
    """An experiment file that cannot be run, with the reason."""


def load(path: Path | str) -> dict[str, Any]:
    """Reads and checks an experiment file."""
    data = yaml.safe_load(Path(path).read_text())
    if not isinstance(data, dict):
        raise GridError(f"{path}: expected a mapping at the top, got {type(data).__name__}")
    unknown = set(data) - TOP_KEYS
    if unknown:
        raise GridError(f"{path}: unknown keys {sorted(unknown)} (known: {sorted(TOP_KEYS)})")
    for key in ("seeds", "envs", "algos", "methods"):
        if not data.get(key):
            raise GridError(f"{path}: `{key}` is missing or empty")
    seeds = data["seeds"]
    if not isinstance(seeds, list) or not all(isinstance(s, int) and not isinstance(s, bool) and 0 <= s < SEED_END for s in seeds):
        raise GridError(f"{path}: `seeds` must be a list of integers in 0 … 2**32 − 1, got {seeds!r}")
    for name, env in data["envs"].items():
        if not isinstance(env, dict) or "id" not in env:
            raise GridError(f"{path}: env {name!r} needs an `id`, got {env!r}")
        try:
            benchmark.env_id(env["id"])
        except argparse.ArgumentTypeError as err:
            raise GridError(f"{path}: env {name!r}: {err}") from None
    for name, block in data["algos"].items():
        if name not in ALGOS:
            raise GridError(f"{path}: unknown algorithm {name!r} (known: {sorted(ALGOS)})")
        if not isinstance(block, dict):
            raise GridError(f"{path}: algorithm {name!r} needs a block of hyperparameters ({{}} for agents/hyperparams/{name}.yml's), got {block!r}")
    for name, method in data["methods"].items():
        if not isinstance(method, dict) or set(method) - METHOD_KEYS or "algo" not in method:
            raise GridError(f"{path}: method {name!r} needs `algo` and takes only {sorted(METHOD_KEYS)}, got {method!r}")
        if method["algo"] not in data["algos"]:
            raise GridError(f"{path}: method {name!r} uses algorithm {method['algo']!r}, which has no block under `algos`")
        if method.get("shield", "braking") not in benchmark.SHIELDS:
            raise GridError(f"{path}: method {name!r}: shield must be one of {benchmark.SHIELDS}, got {method['shield']!r}")
    return data


def runs(config: dict[str, Any], out: Path) -> list[dict[str, Any]]:
    """Every run of the grid, seed-major (every method and environment of the first seed, then
    the next seed), so that a grid stopped early has every method on fewer seeds."""
    evaluation = config.get("eval", {})
    todo = []
    for seed in config["seeds"]:
        for env_name, env in config["envs"].items():
            env_kwargs = {k: v for k, v in env.items() if k != "id"}
            for method, m in config["methods"].items():
                try:
                    defaults = train.hyperparameters(m["algo"], env["id"])
                except InvalidArgumentError as err:
                    raise GridError(str(err)) from None
                block = {**defaults, **config["algos"][m["algo"]]}
                hyper = {k: v for k, v in block.items() if k not in RUN_KEYS}
                hyper.update(m.get("hyperparams", {}))
                n_timesteps = int(float(block["n_timesteps"]))
                todo.append({
                    "env": env_name, "env_id": env["id"], "method": method, "algo": m["algo"], "shield": m.get("shield", "braking"),
                    "seed": seed, "n_timesteps": n_timesteps, "n_envs": int(block.get("n_envs", 8)), "policy": block.get("policy", "MlpPolicy"),
                    "hyperparams": hyper, "env_kwargs": {**env_kwargs, **m.get("env_kwargs", {})},
                    "eval_every": int(float(evaluation.get("every", max(n_timesteps // 5, 1)))), "eval_episodes": int(evaluation.get("episodes", 2)),
                    "max_episode_steps": config.get("max_episode_steps"), "folder": str(out / env_name / method / f"seed_{seed}"),
                })
    return todo


def finished(run: dict[str, Any]) -> bool:
    """A run is finished when its folder holds a readable ``run.json``."""
    try:
        json.loads((Path(run["folder"]) / "run.json").read_text())
    except (OSError, ValueError):
        return False
    return True


def train_run(run: dict[str, Any], threads: int | None = None) -> dict[str, Any]:
    """Trains one run into its folder (any unfinished leftovers are removed first) and returns
    its ``run.json`` with the grid's names added."""
    folder = Path(run["folder"])
    if folder.exists() and not finished(run):
        shutil.rmtree(folder)
    train.train(run["algo"], run["env_id"], run["shield"], run["n_timesteps"], run["n_envs"], run["seed"], folder,
                eval_every=run["eval_every"], eval_episodes=run["eval_episodes"], progress=False, max_episode_steps=run["max_episode_steps"],
                hyperparams=run["hyperparams"], policy=run["policy"], threads=threads, **run["env_kwargs"])
    meta = json.loads((folder / "run.json").read_text())
    meta["grid"] = {k: run[k] for k in ("env", "method")}
    write_json_atomically(folder / "run.json", meta)
    return meta


def _one_thread() -> None:
    os.environ["OMP_NUM_THREADS"] = "1"
    import torch

    torch.set_num_threads(1)


def _worker(run: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    _one_thread()
    return run, train_run(run, threads=1)


def run_local(todo: list[dict[str, Any]], workers: int) -> Iterator[tuple[dict[str, Any], dict[str, Any]]]:
    """Trains the runs here: in this process with one worker, else in ``workers`` fresh processes."""
    if workers == 1:
        for run in todo:
            yield run, train_run(run)
        return
    # spawn: a forked child of a parent that has loaded torch can deadlock in torch's thread pools
    with ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn"), initializer=_one_thread) as pool:
        yield from as_finished(pool, _worker, todo)


def run_ray(todo: list[dict[str, Any]], address: str | None, workers: int) -> Iterator[tuple[dict[str, Any], dict[str, Any]]]:
    """Trains each run as a Ray task (one CPU each)."""
    try:
        import ray
    except ImportError as err:
        raise ImportError('the Ray backend needs Ray: pip install "shieldnav[ray]"') from err
    if not ray.is_initialized():
        root = str(Path(__file__).resolve().parent.parent)
        env = {"env_vars": {"PYTHONPATH": root + os.pathsep + os.environ.get("PYTHONPATH", ""), "OMP_NUM_THREADS": "1"}}
        if address:
            ray.init(address=address, runtime_env=env, log_to_driver=False)
        else:
            ray.init(num_cpus=workers, runtime_env=env, log_to_driver=False, include_dashboard=False)
    remote = ray.remote(num_cpus=1, max_retries=0)(_worker)
    pending = {remote.remote(run): run for run in todo}
    try:
        while pending:
            done, _ = ray.wait(list(pending), num_returns=1)
            pending.pop(done[0])
            run, meta = ray.get(done[0])
            if not finished(run):  # the worker's folder is elsewhere: keep the figures here
                Path(run["folder"]).mkdir(parents=True, exist_ok=True)
                write_json_atomically(Path(run["folder"]) / "run.json", meta)
            yield run, meta
    except BaseException:
        for ref in pending:
            ray.cancel(ref, force=True)
        raise


def _clock(seconds: float) -> str:
    seconds = int(round(seconds))
    return f"{seconds // 3600}:{seconds % 3600 // 60:02d}:{seconds % 60:02d}"


def run_grid(config: dict[str, Any], out: Path, workers: int = 1, backend: str = "local", address: str | None = None,
             echo: Any = print) -> dict[str, Any]:
    """Runs what is not finished; returns ``{"total", "skipped", "done", "interrupted", "wall_time_s", "steps_per_s"}``
    and writes it to ``<out>/grid.json`` (the wall time and env steps/s of this invocation)."""
    todo = runs(config, out)
    left = [r for r in todo if not finished(r)]
    total, skipped = len(todo), len(todo) - len(left)
    echo(f"{total} runs, {skipped} finished already, {len(left)} to train ({backend}, {workers} worker{'s' * (workers > 1)})")
    steps_left = sum(r["n_timesteps"] for r in left)
    steps_done, done, interrupted = 0, 0, False
    start = time.perf_counter()
    source = run_local(left, workers) if backend == "local" else run_ray(left, address, workers)
    try:
        for run, meta in source:
            done += 1
            steps_done += run["n_timesteps"]
            elapsed = time.perf_counter() - start
            rate = steps_done / elapsed
            eta = (steps_left - steps_done) / rate if rate > 0 else 0.0
            s = meta["training_safety"]
            last = meta["eval"][-1] if meta["eval"] else {}
            echo(f"[{skipped + done}/{total}] {run['env']} {run['method']} seed {run['seed']}: {meta['wall_time_s']:.0f} s, "
                 f"{meta['steps_per_s']:.0f} steps/s, {s['contact_steps']} training contact steps, eval coverage {last.get('coverage', float('nan')):.3f} "
                 f"| elapsed {_clock(elapsed)}, {rate:.0f} steps/s overall, ETA {_clock(eta)}")
    except KeyboardInterrupt:
        interrupted = True
        echo(f"\ninterrupted: {skipped + done} of {total} runs finished and kept; run the same command again to train the rest")
    wall = time.perf_counter() - start
    summary = {"total": total, "skipped": skipped, "done": done, "interrupted": interrupted, "wall_time_s": wall,
               "steps_per_s": steps_done / wall if wall > 0 else 0.0, "workers": workers, "backend": backend}
    out.mkdir(parents=True, exist_ok=True)
    write_json_atomically(out / "grid.json", summary)
    return summary


def main(argv: list[str] | None = None) -> dict[str, Any]:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("config", help="the experiment's YAML file")
    ap.add_argument("--out", default=None, help="the grid's folder (default results/grid/<config name>)")
    ap.add_argument("--workers", type=benchmark.positive_int, default=1, help="trainings at once (processes, or Ray CPUs)")
    ap.add_argument("--backend", choices=["local", "ray"], default="local")
    ap.add_argument("--ray-address", default=None, help="a Ray cluster's address (with --backend ray); default: a local Ray")
    ap.add_argument("--list", action="store_true", help="print the runs and whether each is finished, and train nothing")
    args = ap.parse_args(argv)
    if args.ray_address and args.backend != "ray":
        ap.error("--ray-address needs --backend ray")
    try:
        config = load(args.config)
    except (OSError, yaml.YAMLError, GridError) as err:
        ap.error(str(err))
    out = Path(args.out or Path("results/grid") / Path(args.config).stem)
    # Ctrl-C also when started in the background (which ignores it), and `kill` stop as Ctrl-C does
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    if args.list:
        for r in runs(config, out):
            print(f"{'done' if finished(r) else 'todo'}  {r['env']:<12} {r['method']:<18} seed {r['seed']}  {r['n_timesteps']} steps  {r['folder']}")
        return {}
    summary = run_grid(config, out, args.workers, args.backend, args.ray_address)
    print(f"{summary['done']} runs trained in {_clock(summary['wall_time_s'])} ({summary['steps_per_s']:.0f} env steps/s); "
          f"{summary['skipped'] + summary['done']} of {summary['total']} finished")
    if summary["interrupted"]:
        sys.exit(130)
    return summary


if __name__ == "__main__":
    main()
