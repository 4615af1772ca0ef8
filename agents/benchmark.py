"""The benchmark harness, shieldnav's main job.

With no arguments it runs the scripted inspection agent (the paper's planner and P controller)
under every shield (composite, distance, hard-min, none) on the paper's three scenarios, on
procedural office sites and on the shipped real building map, several seeds each; prints a
table per scenario and shield; writes ``benchmark.json`` (valid JSON: ``null`` for a number
that is undefined, e.g. the ``deadlock_time`` of an episode without a deadlock) and
``benchmark.csv``; and draws the paper's pictures per scenario (u_nom against u*, H and min
h_i over time, shield time over time and against the number of points) plus a short GIF of
the composite run.

    python -m agents.benchmark                       # the default run (a few minutes)
    python -m agents.benchmark --quick               # one seed, the three paper scenarios
    python -m agents.benchmark --quick --seeds 2     # --scenarios and --seeds win over --quick
    python -m agents.benchmark --policy model.zip    # a saved SB3 model instead
    python -m agents.benchmark --policy my.module:make_policy
    python -m agents.benchmark --backend ray [--ray-address auto]

Episodes end at the scenario's goal, at full coverage, at a detected deadlock (benchmark
runs truncate there) or at the time limit. An interrupted run (Ctrl-C) keeps and reports the
episodes that finished. Options are checked before any episode runs (a repeated scenario or
shield, an unknown id, a policy that does not load or does not fit the environments' spaces,
an output folder that cannot be written are usage errors); ``steps_per_s`` times the policy
and the environment's step, not the tracing or the GIF's rendering.
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any, Iterator

from shieldnav.exceptions import InvalidArgumentError
from shieldnav.registration import ENV_IDS
from tqdm import tqdm

from agents import report
from agents.episodes import check_policy, run_episode
from agents.pool import as_finished

SHIELDS = ["braking", "composite", "distance", "hardmin", "none"]
PAPER = ["shieldnav/ConstrictedPassage-v0", "shieldnav/OdometryJump-v0", "shieldnav/DynamicObstacles-v0"]
SITES = ["shieldnav/CorridorInspection-v0", "shieldnav/MapInspection-v0"]
#: Steps kept in the GIF: every n-th at 50 Hz.
VIDEO_EVERY = 5


def positive_int(text: str) -> int:
    """argparse type: an integer of at least 1 (argparse names the option in its error)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def env_id(text: str) -> str:
    """argparse type: one of shieldnav's environment ids."""
    if text not in ENV_IDS:
        raise argparse.ArgumentTypeError(f"unknown environment id {text!r}; known: {', '.join(sorted(ENV_IDS))}")
    return text


def check_options(ap: argparse.ArgumentParser, args: argparse.Namespace, *lists: str) -> None:
    """Usage errors for a repeated value in the list options ``lists`` (it would run the same
    episodes twice and count them twice) and for a Ray address without the Ray backend."""
    for name in lists:
        values = getattr(args, name) or []
        repeated = sorted({v for v in values if values.count(v) > 1})
        if repeated:
            ap.error(f"argument --{name}: {', '.join(repeated)} given more than once")
    if args.ray_address and args.backend != "ray":
        ap.error("argument --ray-address: needs --backend ray")


def output_folder(ap: argparse.ArgumentParser, text: str) -> Path:
    """Creates the ``--out`` folder and checks that a file can be written there, before any
    episode runs: a usage error otherwise."""
    out = Path(text)
    if out.exists() and not out.is_dir():
        ap.error(f"argument --out: {out} is a file, not a folder")
    try:
        out.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=out).close()
    except OSError as err:
        ap.error(f"argument --out: cannot write to the folder {out}: {err.strerror or err}")
    return out


def tasks(env_ids: list[str], shields: list[str], seeds: int, policy: str, video: bool, steps: int | None) -> list[dict[str, Any]]:
    """One task per (scenario, shield, seed); seed 0 records its time series (and the
    composite's seed 0 its video)."""
    out = []
    for env_id in env_ids:
        for shield in shields:
            for seed in range(seeds):
                kwargs: dict[str, Any] = {"truncate_on_deadlock": True}
                if steps is not None:
                    kwargs["max_episode_steps"] = kwargs["time_limit"] = steps
                out.append({
                    "env_id": env_id, "shield": shield, "seed": seed, "policy": policy, "kwargs": kwargs,
                    "trace": seed == 0, "video_every": VIDEO_EVERY if (video and seed == 0 and shield == "composite") else 0,
                })
    return out


def run_local(todo: list[dict[str, Any]], workers: int) -> Iterator[dict[str, Any]]:
    """Runs the tasks on this machine's cores, yielding results as they finish."""
    if workers == 1:
        for t in todo:
            yield run_episode(t)
        return
    # a forked child of a parent that has loaded torch (an SB3 --policy) deadlocks in torch's
    # thread pools: spawn fresh interpreters then, fork (fast, keeps the parent's state) otherwise
    context = multiprocessing.get_context("spawn" if "torch" in sys.modules else None)
    with ProcessPoolExecutor(max_workers=workers, mp_context=context) as pool:
        yield from as_finished(pool, run_episode, todo)


def run_ray(todo: list[dict[str, Any]], address: str | None, workers: int) -> Iterator[dict[str, Any]]:
    """Runs the tasks as Ray tasks: a local Ray with ``workers`` CPUs, or the cluster at
    ``address``."""
    try:
        import ray
    except ImportError as err:
        raise ImportError('the Ray backend needs Ray: pip install "shieldnav[ray]"') from err
    if not ray.is_initialized():
        root = str(Path(__file__).resolve().parent.parent)
        env = {"working_dir": None, "env_vars": {"PYTHONPATH": root + os.pathsep + os.environ.get("PYTHONPATH", "")}}
        if address:
            ray.init(address=address, runtime_env=env, log_to_driver=False)
        else:
            ray.init(num_cpus=workers, runtime_env=env, log_to_driver=False, include_dashboard=False)
    remote = ray.remote(num_cpus=1)(run_episode)
    pending = [remote.remote(t) for t in todo]
    try:
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            yield ray.get(done[0])
    except BaseException:
        for p in pending:
            ray.cancel(p)
        raise


def run(todo: list[dict[str, Any]], backend: str, workers: int, address: str | None = None) -> list[dict[str, Any]]:
    """Every finished result, with a progress bar; Ctrl-C stops early and keeps what finished."""
    results: list[dict[str, Any]] = []
    source = run_local(todo, workers) if backend == "local" else run_ray(todo, address, workers)
    bar = tqdm(total=len(todo), desc="episodes", unit="ep")
    try:
        for r in source:
            results.append(r)
            bar.update(1)
            bar.set_postfix_str(f"{r['task']['env_id'].split('/')[1]} {r['task']['shield']}")
    except KeyboardInterrupt:
        print(f"\ninterrupted: keeping the {len(results)} finished episodes", file=sys.stderr)
    finally:
        bar.close()
    results.sort(key=lambda r: (r["task"]["env_id"], SHIELDS.index(r["task"]["shield"]) if r["task"]["shield"] in SHIELDS else 9, r["task"]["seed"]))
    return results


def pictures(results: list[dict[str, Any]], out: Path) -> list[Path]:
    """One figure per scenario and one GIF per scenario (composite, seed 0)."""
    from shieldnav.rendering import save_video

    written = []
    for scenario in dict.fromkeys(r["task"]["env_id"] for r in results):
        rs = [r for r in results if r["task"]["env_id"] == scenario]
        traces = {r["task"]["shield"]: r["series"] for r in rs if r["series"] is not None}
        timing = {}
        for shield in dict.fromkeys(r["task"]["shield"] for r in rs):
            first = next(r for r in rs if r["task"]["shield"] == shield)
            timing[shield] = (first["solve_time_ns"] / 1e3, first["num_points"])
        name = scenario.split("/")[1]
        if traces:
            path = out / f"{name}.png"
            report.plot_scenario(scenario, traces, timing, path)
            written.append(path)
        frames = next((r["frames"] for r in rs if r["frames"]), None)
        if frames:
            path = out / f"{name}.gif"
            save_video(frames, path, fps=50 / VIDEO_EVERY)
            written.append(path)
    return written


def main(argv: list[str] | None = None) -> dict[tuple[str, str], dict[str, Any]]:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenarios", nargs="+", type=env_id, default=None, help="environment ids (default: all five; --quick: the paper's three)")
    ap.add_argument("--shields", nargs="+", default=SHIELDS, choices=SHIELDS)
    ap.add_argument("--seeds", type=positive_int, default=None, help="seeds per scenario and shield (default 3; --quick: 1)")
    ap.add_argument("--policy", default="scripted", help="'scripted', 'ppo' (the shipped policy), a saved SB3 model (.zip) or 'module:callable'")
    ap.add_argument("--backend", default="local", choices=["local", "ray"])
    ap.add_argument("--ray-address", default=None, help="Ray cluster address (default: start a local Ray)")
    ap.add_argument("--workers", type=positive_int, default=os.cpu_count() or 1, help="parallel episodes")
    ap.add_argument("--max-steps", type=positive_int, default=None, help="override every scenario's time limit")
    ap.add_argument("--out", default="results/benchmark", help="output folder")
    ap.add_argument("--no-video", action="store_true", help="skip the GIFs")
    ap.add_argument("--no-plots", action="store_true", help="skip the figures and GIFs")
    ap.add_argument("--quick", action="store_true", help="one seed, the three paper scenarios (unless --seeds, --scenarios say otherwise)")
    args = ap.parse_args(argv)
    check_options(ap, args, "scenarios", "shields")
    scenarios = args.scenarios or (PAPER if args.quick else PAPER + SITES)
    seeds = args.seeds or (1 if args.quick else 3)
    todo = tasks(scenarios, args.shields, seeds, args.policy, video=not (args.no_video or args.no_plots), steps=args.max_steps)
    for task in {t["env_id"]: t for t in todo}.values():  # the policy on each scenario, before any episode runs
        try:
            check_policy(task)
        except InvalidArgumentError as err:
            ap.error(f"argument --policy: {err}")
    out = output_folder(ap, args.out)
    results = run(todo, args.backend, args.workers, args.ray_address)
    if not results:
        print("no episode finished", file=sys.stderr)
        return {}
    rows = report.aggregate(results)
    print(report.table(rows))
    report.write_files(results, rows, out)
    written = [out / "benchmark.json", out / "benchmark.csv"]
    if not args.no_plots:
        written += pictures(results, out)
    print("\nwrote " + ", ".join(str(p) for p in written))
    return rows


if __name__ == "__main__":
    main()
