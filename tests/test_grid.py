"""The experiment grid (agents.grid) and PPO-Lagrangian (agents.lagrangian): tiny runs, local and
on Ray, finished runs skipped, Ctrl-C keeping what finished, the multiplier's dual ascent, and one
seed giving the same figures twice."""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

pytest.importorskip("torch")

from stable_baselines3.common.vec_env import DummyVecEnv  # noqa: E402

from agents import grid, train  # noqa: E402
from agents.lagrangian import PPOLagrangian, lagrange_update  # noqa: E402

TINY = """
seeds: [0, 1]
envs:
  cp: {id: shieldnav/ConstrictedPassage-v0}
max_episode_steps: 100
eval: {every: 256, episodes: 1}
algos:
  ppo: {policy: MlpPolicy, n_timesteps: 256, n_envs: 2, n_steps: 64, batch_size: 64, n_epochs: 1}
methods:
  ppo_braking: {algo: ppo, shield: braking}
"""
#: What a run's result is made of (its wall time and steps/s aside).
FIGURES = ("episodes", "eval", "training_safety")


def tiny(tmp_path: Path, text: str = TINY) -> dict:
    path = tmp_path / "tiny.yml"
    path.write_text(text)
    return grid.load(path)


def figures(folder: Path) -> dict:
    meta = json.loads((folder / "run.json").read_text())
    return {k: meta[k] for k in FIGURES}


def test_two_tiny_runs_finish_and_a_second_invocation_skips_them(tmp_path):
    config, out = tiny(tmp_path), tmp_path / "grid"
    lines: list[str] = []
    summary = grid.run_grid(config, out, echo=lines.append)
    assert (summary["total"], summary["skipped"], summary["done"], summary["interrupted"]) == (2, 0, 2, False)
    folders = [out / "cp" / "ppo_braking" / f"seed_{s}" for s in (0, 1)]
    for folder in folders:
        meta = json.loads((folder / "run.json").read_text())
        assert meta["grid"] == {"env": "cp", "method": "ppo_braking"} and meta["shield"] == "braking"
        assert meta["training_safety"]["steps"] == 256 and meta["hyperparams"]["n_steps"] == 64
        assert [e["timesteps"] for e in meta["eval"]] == [256] and meta["steps_per_s"] > 0
        # two environments, 128 steps each, 100-step episodes: one episode each, the run's contact count carried along
        assert [e["length"] for e in meta["episodes"]] == [100] * 2
        assert meta["episodes"][-1]["run_contact_steps"] == sum(e["contact_steps"] for e in meta["episodes"])
        assert (folder / "model.zip").exists()
    assert lines[-1].startswith("[2/2] cp ppo_braking seed 1") and "ETA 0:00:00" in lines[-1]
    assert json.loads((out / "grid.json").read_text())["done"] == 2
    stamps = [(f / "run.json").stat().st_mtime_ns for f in folders]
    again = grid.run_grid(config, out, echo=lines.append)
    assert (again["skipped"], again["done"]) == (2, 0)
    assert [(f / "run.json").stat().st_mtime_ns for f in folders] == stamps


def test_an_unfinished_run_is_trained_again_from_a_clean_folder(tmp_path):
    config, out = tiny(tmp_path), tmp_path / "grid"
    grid.run_grid(config, out, echo=lambda _: None)
    reference = figures(out / "cp" / "ppo_braking" / "seed_1")
    folder = out / "cp" / "ppo_braking" / "seed_1"
    (folder / "run.json").unlink()
    (folder / "leftover.txt").write_text("from a run that was stopped")
    summary = grid.run_grid(config, out, echo=lambda _: None)
    assert (summary["skipped"], summary["done"]) == (1, 1)
    assert not (folder / "leftover.txt").exists() and figures(folder) == reference


def test_ctrl_c_keeps_the_finished_runs_and_leaves_no_run_json_for_the_stopped_one(tmp_path, monkeypatch):
    config, out = tiny(tmp_path), tmp_path / "grid"
    train_run = grid.train_run

    def stopped_at_the_second(run, threads=None):
        if run["seed"] == 1:
            Path(run["folder"]).mkdir(parents=True)
            raise KeyboardInterrupt
        return train_run(run, threads)

    monkeypatch.setattr(grid, "train_run", stopped_at_the_second)
    lines: list[str] = []
    summary = grid.run_grid(config, out, echo=lines.append)
    assert summary["interrupted"] and summary["done"] == 1 and "1 of 2 runs finished and kept" in lines[-1]
    assert (out / "cp" / "ppo_braking" / "seed_0" / "run.json").exists()
    assert not (out / "cp" / "ppo_braking" / "seed_1" / "run.json").exists()
    assert not list(out.rglob("*.tmp")), "a half-written file was left"
    monkeypatch.setattr(grid, "train_run", train_run)
    assert grid.run_grid(config, out, echo=lambda _: None)["done"] == 1


def test_one_seed_gives_the_same_figures_twice_and_another_seed_others(tmp_path):
    config = tiny(tmp_path)
    a, b = (grid.run_grid(config, tmp_path / name, echo=lambda _: None) for name in ("a", "b"))
    assert a["done"] == b["done"] == 2
    seed0 = [figures(tmp_path / name / "cp" / "ppo_braking" / "seed_0") for name in ("a", "b")]
    seed1 = figures(tmp_path / "a" / "cp" / "ppo_braking" / "seed_1")
    assert seed0[0] == seed0[1]
    assert [e["return"] for e in seed0[0]["episodes"]] != [e["return"] for e in seed1["episodes"]]


@pytest.mark.expensive
def test_the_ray_backend_gives_the_local_results(tmp_path):
    ray = pytest.importorskip("ray", reason="the Ray backend needs ray (in the test extra)")
    config = tiny(tmp_path)
    grid.run_grid(config, tmp_path / "local", workers=1, echo=lambda _: None)
    try:
        summary = grid.run_grid(config, tmp_path / "ray", workers=2, backend="ray", echo=lambda _: None)
    finally:
        ray.shutdown()
    assert (summary["done"], summary["backend"]) == (2, "ray")
    for seed in (0, 1):
        rel = Path("cp") / "ppo_braking" / f"seed_{seed}"
        assert figures(tmp_path / "ray" / rel) == figures(tmp_path / "local" / rel)


@pytest.mark.expensive
def test_local_worker_processes_give_the_in_process_results(tmp_path):
    config = tiny(tmp_path)
    grid.run_grid(config, tmp_path / "one", workers=1, echo=lambda _: None)
    summary = grid.run_grid(config, tmp_path / "two", workers=2, echo=lambda _: None)
    assert summary["done"] == 2
    for seed in (0, 1):
        rel = Path("cp") / "ppo_braking" / f"seed_{seed}"
        assert figures(tmp_path / "two" / rel) == figures(tmp_path / "one" / rel)


@pytest.mark.parametrize("key, value, message", [
    ("methods", {"x": {"algo": "a2c"}}, "uses algorithm 'a2c'"),
    ("seeds", [-1], "`seeds` must be"),
    ("envs", {"e": {"id": "CartPole-v1"}}, "env 'e'"),
    ("methods", {"x": {"algo": "ppo", "shield": "magic"}}, "shield must be one of"),
    ("bogus", 1, "unknown keys"),
    ("algos", {"ppo": [2]}, "needs a block of hyperparameters"),
])
def test_a_wrong_experiment_file_is_refused_with_the_reason(tmp_path, key, value, message):
    data = yaml.safe_load(TINY)
    data[key] = value
    with pytest.raises(grid.GridError, match=message):
        tiny(tmp_path, yaml.safe_dump(data))


def test_the_command_line_lists_the_runs_and_refuses_a_ray_address_without_ray(tmp_path, capsys):
    (tmp_path / "tiny.yml").write_text(TINY)
    grid.main([str(tmp_path / "tiny.yml"), "--out", str(tmp_path / "g"), "--list"])
    rows = capsys.readouterr().out.splitlines()
    assert [r.split()[:2] + r.split()[3:5] for r in rows] == [["todo", "cp", "seed", "0"], ["todo", "cp", "seed", "1"]]
    with pytest.raises(SystemExit):
        grid.main([str(tmp_path / "tiny.yml"), "--ray-address", "auto"])
    assert "--ray-address needs --backend ray" in capsys.readouterr().err


# ---------------------------------------------------------------- PPO-Lagrangian


def test_the_multiplier_rises_above_the_budget_and_falls_to_zero_and_stays_below_it():
    assert lagrange_update(0.0, 30.0, 10.0, 0.1) == pytest.approx(2.0)
    assert lagrange_update(2.0, 30.0, 10.0, 0.1) == pytest.approx(4.0)
    assert lagrange_update(2.0, 10.0, 10.0, 0.1) == 2.0
    lam, path = 1.0, []
    for _ in range(5):
        lam = lagrange_update(lam, 5.0, 10.0, 0.1)  # 5 below the budget: −0.5 a step
        path.append(lam)
    assert path == pytest.approx([0.5, 0.0, 0.0, 0.0, 0.0])


class CostlyEnv(gym.Env):
    """Reward 1 and cost ``cost`` on every step, 10-step episodes."""

    observation_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)
    action_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)

    def __init__(self, cost: float) -> None:
        self.cost, self.t = cost, 0

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.t = 0
        return np.zeros(1, np.float32), {}

    def step(self, action):
        self.t += 1
        return np.zeros(1, np.float32), 1.0, False, self.t >= 10, {"cost": self.cost}


def lagrangian(cost: float, **kwargs) -> PPOLagrangian:
    venv = DummyVecEnv([lambda: CostlyEnv(cost)] * 2)
    model = PPOLagrangian("MlpPolicy", venv, n_steps=16, batch_size=32, n_epochs=1, episode_steps=10, seed=0, device="cpu", **kwargs)
    model.learn(32 * 6)
    return model


def unbootstrapped(model: PPOLagrangian) -> np.ndarray:
    """The last rollout's rewards but the one step where SB3 adds the truncated episode's value:
    the rollout holds env steps 81–96, and the episode ends at step 90 (row 9)."""
    return np.delete(model.rollout_buffer.rewards, 9, axis=0)


def test_ppo_lagrangian_raises_the_multiplier_while_over_budget_and_trains_on_r_minus_lambda_c():
    model = lagrangian(1.0, cost_limit=4.0, lagrangian_lr=0.1)  # every episode costs 10, the budget is 4
    history = model.multiplier_history
    assert [c for _, c, _ in history] == pytest.approx([10.0] * 6)
    assert [lam for _, _, lam in history] == pytest.approx([0.6 * k for k in range(1, 7)])
    # the last rollout was collected with λ = 3.0 (from the update before it): reward 1 − 3.0 · 1
    assert np.allclose(unbootstrapped(model), 1.0 - 3.0)


def test_ppo_lagrangian_drops_the_multiplier_to_zero_and_keeps_it_there_under_budget():
    model = lagrangian(0.5, cost_limit=8.0, lagrangian_lr=0.2, lagrangian_init=1.0)  # episode cost 5, budget 8: −0.6 a rollout
    assert [lam for _, _, lam in model.multiplier_history] == pytest.approx([0.4, 0.0, 0.0, 0.0, 0.0, 0.0])
    assert np.allclose(unbootstrapped(model), 1.0)  # λ = 0: the reward untouched


def test_ppo_lagrangian_refuses_a_negative_budget():
    with pytest.raises(ValueError, match="cost_limit ≥ 0"):
        PPOLagrangian("MlpPolicy", DummyVecEnv([lambda: CostlyEnv(1.0)]), cost_limit=-1.0)


@pytest.mark.parametrize("path", sorted((Path(__file__).resolve().parents[1] / "experiments").glob("*.yml")), ids=lambda p: p.name)
def test_every_shipped_experiment_file_loads_and_names_its_runs(path, tmp_path):
    config = grid.load(path)
    todo = grid.runs(config, tmp_path)
    assert len(todo) == len(config["seeds"]) * len(config["envs"]) * len(config["methods"])
    assert len({r["folder"] for r in todo}) == len(todo)
    assert all(r["n_timesteps"] >= 1 and r["algo"] in config["algos"] for r in todo)


@pytest.mark.expensive
def test_the_report_draws_each_environment_and_tables_every_method_with_the_scripted_line(tmp_path):
    from agents import report_grid

    out, other = tmp_path / "grid", tmp_path / "other"
    grid.run_grid(tiny(tmp_path), out, echo=lambda _: None)
    # a second grid folder with another method: drawn and tabled with the first
    config = tiny(tmp_path)
    config["methods"] = {"ppo_none": {**config["methods"]["ppo_braking"], "shield": "none"}}
    config["seeds"] = [0]
    grid.run_grid(config, other, echo=lambda _: None)
    text = report_grid.main([str(out), str(other), "--out", str(tmp_path / "docs"), "--scripted-seeds", "1"]).read_text()
    table = text.splitlines()
    assert (tmp_path / "docs" / "cp.png").stat().st_size > 10_000
    rows = [[c.strip() for c in line.strip("|").split("|")] for line in table if line.startswith("| cp")]
    assert [r[1] for r in rows] == ["ppo_braking", "ppo_none", "scripted agent (braking)"]
    assert "The last invocation of the grid `grid`: 2 runs" in text and "The last invocation of the grid `other`: 1 runs" in text
    safety = [json.loads((out / "cp" / "ppo_braking" / f"seed_{s}" / "run.json").read_text())["training_safety"] for s in (0, 1)]
    assert rows[0][2] == "2" and rows[0][8].endswith(f"({safety[0]['contact_steps']}, {safety[1]['contact_steps']})")
    assert json.loads((out / "scripted.json").read_text())  # the scripted agent's episodes, kept for the next report


def test_an_algorithms_block_goes_over_the_training_defaults(tmp_path):
    """`{}` runs `agents.train`'s hyperparameters for each environment; a key of the block
    replaces the file's."""
    data = yaml.safe_load(TINY)
    data["algos"] = {"ppo": {}}
    (tmp_path / "g.yml").write_text(yaml.safe_dump(data))
    run = grid.runs(grid.load(tmp_path / "g.yml"), tmp_path)[0]
    defaults = train.hyperparameters("ppo", run["env_id"])
    assert (run["n_envs"], run["n_timesteps"], run["policy"]) == (defaults["n_envs"], defaults["n_timesteps"], defaults["policy"])
    assert run["hyperparams"] == {k: v for k, v in defaults.items() if k not in train.RUN_KEYS}
    data["algos"] = {"ppo": {"n_envs": 3, "n_epochs": 2}}
    (tmp_path / "h.yml").write_text(yaml.safe_dump(data))
    run = grid.runs(grid.load(tmp_path / "h.yml"), tmp_path)[0]
    assert run["n_envs"] == 3 and run["hyperparams"]["n_epochs"] == 2
    assert run["hyperparams"]["batch_size"] == defaults["batch_size"]


def test_the_cost_penalty_reads_the_native_batchs_cost_column_as_the_infos_give_it():
    from shieldnav.sb3 import ShieldnavVecEnv

    from agents.lagrangian import CostPenalty

    class Owner:
        lagrange_multiplier = 2.0

    # strafing into the corridor's wall without a shield: contact steps, and episodes that end
    make = lambda: ShieldnavVecEnv("shieldnav/CorridorInspection-v0", num_envs=4, max_episode_steps=50, shield="none")  # noqa: E731
    plain, penalised = make(), CostPenalty(make(), Owner())
    for v in (plain, penalised):
        v.seed(5)
        v.reset()
    rng = np.random.default_rng(1)
    total = 0.0
    for _ in range(60):
        action = np.tile([0.3, 1.0, 0.0], (4, 1)) if rng.random() < 0.8 else rng.uniform(-1, 1, (4, 3))
        _, reward, _, infos = plain.step(action.astype(np.float32))
        _, shaped, _, _ = penalised.step(action.astype(np.float32))
        cost = np.array([info["cost"] for info in infos])
        total += cost.sum()
        np.testing.assert_allclose(shaped, reward - np.float32(2.0) * cost.astype(np.float32))
    assert total > 0, "no contact: the test compares nothing"
    assert penalised.take() == (total, 240)
