"""Training smoke test: PPO on the native batch, with the shield in the loop, saves a model the
benchmark loads and evaluates; one seed gives identical results twice."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

pytest.importorskip("torch")

from shieldnav.exceptions import InvalidArgumentError  # noqa: E402
from shieldnav.registration import ENV_IDS  # noqa: E402
from shieldnav.sb3 import ShieldnavVecEnv  # noqa: E402

from agents import benchmark, train  # noqa: E402

COUNTS = {"timesteps": "--timesteps", "num_envs": "--num-envs", "eval_every": "--eval-every", "eval_episodes": "--eval-episodes",
          "max_episode_steps": "--max-episode-steps"}
CP = "shieldnav/ConstrictedPassage-v0"
ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.expensive
def test_ppo_trains_saves_reloads_and_is_benchmarked_identically_twice(tmp_path):
    rows = []
    for run in ("a", "b"):
        path = train.main([
            "--algo", "ppo", "--env", "shieldnav/ConstrictedPassage-v0", "--shield", "composite", "--timesteps", "2048",
            "--num-envs", "4", "--seed", "3", "--eval-every", "1024", "--eval-episodes", "1", "--max-episode-steps", "200",
            "--out", str(tmp_path / run), "--no-progress", "--no-tensorboard", "--hyperparams", str(small_hyperparams(tmp_path)),
        ])
        assert path.exists() and (tmp_path / run / "checkpoints").is_dir()
        logged = (tmp_path / run / "progress.csv").read_text().splitlines()
        assert "eval/coverage" in logged[0].split(",") and len(logged) > 1, "no log in the run folder"
        meta = json.loads((tmp_path / run / "run.json").read_text())
        assert [e["timesteps"] for e in meta["eval"]] == [1024, 2048]
        # safety over every training step: each of the 2048 steps counted once
        safety = meta["training_safety"]
        assert safety["steps"] == 2048 and "train_safety/contact_steps" in logged[0].split(",")
        assert 0 <= safety["episodes_with_contact"] <= safety["episodes"] >= 4 * (512 // 200)  # 4 envs, 200-step limit
        assert safety["contact_steps"] >= safety["episodes_with_contact"] and 0 < safety["interventions"] <= 2048
        rows.append(benchmark.main([
            "--scenarios", "shieldnav/ConstrictedPassage-v0", "--shields", "composite", "--seeds", "1", "--workers", "1",
            "--policy", str(path), "--max-steps", "200", "--out", str(tmp_path / run / "bench"), "--no-plots",
        ]))
    a, b = (r[("shieldnav/ConstrictedPassage-v0", "composite")] for r in rows)
    timeless = ("shield_us_mean", "shield_us_p99_6", "shield_us_max", "steps_per_s")
    assert {k: v for k, v in a.items() if k not in timeless} == {k: v for k, v in b.items() if k not in timeless}
    ea = json.loads((tmp_path / "a" / "bench" / "benchmark.json").read_text())["episodes"][0]["summary"]
    eb = json.loads((tmp_path / "b" / "bench" / "benchmark.json").read_text())["episodes"][0]["summary"]
    assert ea["path_length"] == eb["path_length"] and ea["total_reward"] == eb["total_reward"]


def test_sb3_adapter_honours_time_limit():
    v = ShieldnavVecEnv("shieldnav/ConstrictedPassage-v0", num_envs=2, time_limit=6)
    v.seed(0)
    v.reset()
    dones = [v.step_wait()[2].all() if v.step_async(np.zeros((2, 3), np.float32)) is None else None for _ in range(6)]
    assert dones == [False] * 5 + [True]
    v.close()


def test_sb3_adapter_answers_as_dummy_vec_env_does():
    from shieldnav.exceptions import InvalidArgumentError

    v = ShieldnavVecEnv("shieldnav/ConstrictedPassage-v0", num_envs=2)
    assert [s.shape for s in v.get_attr("observation_space")] == [(73,), (73,)]
    assert [s.shape for s in v.get_attr("action_space")] == [(3,), (3,)]
    assert v.get_attr("spec")[0].id == "shieldnav/ConstrictedPassage-v0"
    v.seed(4)
    v.reset()
    assert v.reset_infos[1]["seed"] == gym.make("shieldnav/ConstrictedPassage-v0").reset(seed=5)[1]["seed"]
    v.step_async(np.zeros((2, 3), np.float32))
    infos = v.step_wait()[3]
    single = gym.make("shieldnav/ConstrictedPassage-v0")
    single.reset(seed=0)
    assert set(single.step(np.zeros(3, np.float32))[4]) <= set(infos[0])
    # the reset after an ended episode is in reset_infos, as DummyVecEnv keeps it
    short = ShieldnavVecEnv("shieldnav/ConstrictedPassage-v0", num_envs=2, time_limit=2)
    short.seed(0)
    short.reset()
    first = [dict(r) for r in short.reset_infos]
    for _ in range(2):
        short.step_async(np.zeros((2, 3), np.float32))
        ended = short.step_wait()[3]
    assert [r["seed"] for r in short.reset_infos] != [r["seed"] for r in first]
    assert set(short.reset_infos[0]) == {"seed", "coverage", "time", "site"} and ended[0]["time"] > 0.0
    with pytest.raises(InvalidArgumentError, match="actions"):
        short.step_async(np.zeros(6, np.float32))  # a flat array is not reshaped silently
    short.close()
    with pytest.raises(InvalidArgumentError, match="autoreset_mode"):
        ShieldnavVecEnv("shieldnav/ConstrictedPassage-v0", num_envs=2, autoreset_mode="next_step")
    with pytest.raises(InvalidArgumentError, match="not a shieldnav environment"):
        ShieldnavVecEnv("CartPole-v1", num_envs=2)
    v.set_options({"anything": 1})
    with pytest.raises(InvalidArgumentError, match="options"):
        v.reset()
    v.reset()  # (the options are dropped with the error)
    v.close()


def test_sb3_adapter_follows_same_step_autoreset():
    v = ShieldnavVecEnv("shieldnav/ConstrictedPassage-v0", num_envs=2, max_episode_steps=5)
    v.seed(0)
    obs = v.reset()
    assert obs.shape == (2, 73)
    for k in range(5):
        obs, rewards, dones, infos = v.step_wait() if v.step_async(np.zeros((2, 3), np.float32)) is None else None
    assert dones.all() and rewards.dtype == np.float32
    for i in range(2):
        assert infos[i]["TimeLimit.truncated"] is True
        assert infos[i]["terminal_observation"].shape == (73,)
        assert infos[i]["shieldnav_episode"]["steps"] == 5
        assert not np.array_equal(infos[i]["terminal_observation"], obs[i]), "obs is already the next episode's"



def test_the_adapters_step_info_columns_are_the_infos_entries():
    """`step_info` (what `TrainingSafety` reads) holds each environment's per-step entries as
    its info dict does, an ended episode's last step included."""
    v = ShieldnavVecEnv(CP, num_envs=3, max_episode_steps=7, shield="braking")
    v.seed(1)
    v.reset()
    rng = np.random.default_rng(0)
    ended = 0
    for _ in range(20):
        v.step_async(rng.uniform(-1, 1, (3, 3)).astype(np.float32))
        _, _, dones, infos = v.step_wait()
        ended += int(dones.sum())
        assert {"cost", "intervention", "shield_braked", "clearance"} <= set(v.step_info)
        for key, column in v.step_info.items():
            assert len(column) == 3
            for i in range(3):
                np.testing.assert_array_equal(column[i], infos[i][key], err_msg=f"{key}[{i}], done={dones[i]}")
    assert ended >= 6
    v.close()

@pytest.mark.parametrize("value", ["0", "-5"])
@pytest.mark.parametrize("option", COUNTS.values())
def test_command_line_rejects_a_count_below_one_before_training(option, value, tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        train.main([option, value, "--out", str(tmp_path / "run"), "--no-progress", "--no-tensorboard"])
    assert exc.value.code == 2
    assert f"argument {option}: must be at least 1, got {value}" in capsys.readouterr().err
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize("name", COUNTS)
def test_train_names_a_count_below_one(name, tmp_path):
    kwargs = {"timesteps": 64, "num_envs": 1, "eval_every": 64, "eval_episodes": 1, name: 0}
    with pytest.raises(InvalidArgumentError, match=f"invalid `{name}`: must be at least 1, got 0"):
        train.train("ppo", "shieldnav/ConstrictedPassage-v0", "composite", seed=0, out=tmp_path / "run", **kwargs)
    assert not (tmp_path / "run").exists()


@pytest.mark.expensive
def test_a_model_is_benchmarked_on_two_workers(tmp_path):
    """Loading the model imports torch in the benchmark's process: workers forked from it hung
    for ever in torch's thread pools. A hang fails the test at the timeout."""
    path = train.main(["--env", CP, "--timesteps", "256", "--num-envs", "1", "--eval-every", "256", "--eval-episodes", "1",
                       "--max-episode-steps", "20", "--out", str(tmp_path / "run"), "--no-progress", "--no-tensorboard",
                       "--hyperparams", str(small_hyperparams(tmp_path))])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    argv = [sys.executable, "-m", "agents.benchmark", "--scenarios", CP, "--shields", "composite", "none", "--seeds", "1",
            "--workers", "2", "--max-steps", "20", "--policy", str(path), "--out", str(tmp_path / "bench"), "--no-plots"]
    proc = subprocess.Popen(argv, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        _, err = proc.communicate(timeout=180)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)  # the benchmark and its workers
        proc.communicate()
        pytest.fail("the benchmark of a model on two workers hung")
    assert proc.returncode == 0, err
    episodes = json.loads((tmp_path / "bench" / "benchmark.json").read_text())["episodes"]
    assert sorted(e["task"]["shield"] for e in episodes) == ["composite", "none"]
    assert all(e["summary"]["steps"] == 20 for e in episodes)


@pytest.mark.parametrize("option, value, message", [
    ("--env", "shieldnav/Foo-v0", "argument --env: unknown environment id 'shieldnav/Foo-v0'"),
    ("--seed", "-1", "argument --seed: must be in 0 … 2**32 − 1, got -1"),
    ("--seed", "4294967296", "argument --seed: must be in 0 … 2**32 − 1, got 4294967296"),
])
def test_command_line_rejects_an_unknown_env_and_a_bad_seed_before_training(option, value, message, tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        train.main([option, value, "--out", str(tmp_path / "run"), "--no-progress", "--no-tensorboard"])
    assert exc.value.code == 2 and message in capsys.readouterr().err
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize("kwargs, message", [
    ({"env_id": "shieldnav/Foo-v0"}, "invalid `env_id`: expected a shieldnav id"),
    ({"env_id": "CartPole-v1"}, "invalid `env_id`: expected a shieldnav id"),
    ({"shield": "bogus"}, "invalid `shield`: expected one of"),
    ({"seed": -1}, "invalid `seed`: must be in 0 … 2**32 − 1, got -1"),
    ({"max_episode_steps": -5}, "invalid `max_episode_steps`: must be at least 1, got -5"),
    ({"kappa": -1.0}, "invalid `kappa`"),
])
def test_train_refuses_bad_arguments_before_creating_the_run_folder(kwargs, message, tmp_path):
    args = {"algo": "ppo", "env_id": CP, "shield": "composite", "timesteps": 64, "num_envs": 1, "seed": 0,
            "out": tmp_path / "run", "progress": False, "tensorboard": False} | kwargs
    with pytest.raises(InvalidArgumentError, match=re.escape(message)):
        train.train(**args)
    assert not (tmp_path / "run").exists()


def test_a_missing_progress_bar_package_is_reported_before_training(tmp_path, capsys, monkeypatch):
    """SB3's progress bar is tqdm's rich bar: without rich, learn() failed after the run folder
    was made (the README's command did)."""
    monkeypatch.setitem(sys.modules, "tqdm.rich", None)  # import tqdm.rich now raises ImportError
    with pytest.raises(SystemExit) as exc:
        train.main(["--env", CP, "--timesteps", "64", "--out", str(tmp_path / "run"), "--no-tensorboard"])
    err = capsys.readouterr().err
    assert exc.value.code == 2
    assert "error: the progress bar needs tqdm and rich" in err and "or pass --no-progress" in err
    with pytest.raises(ImportError, match="the progress bar needs tqdm and rich"):
        train.train("ppo", CP, "composite", 64, 1, 0, tmp_path / "run", tensorboard=False)
    assert not (tmp_path / "run").exists()


def test_evaluation_on_the_batch_equals_single_environment_episodes():
    """`train.evaluate` runs its episodes side by side on the native batch; each must be the
    episode a single environment reset with the same seed gives under the same policy."""

    class Steer:  # deterministic, state-free, and different per observation
        def predict(self, obs, deterministic=True):
            obs = np.asarray(obs, dtype=float)
            return np.tanh(np.stack([obs[..., 0] - 0.3, obs[..., 1], 0.5 * obs[..., 2]], axis=-1)).astype(np.float32), None

    kwargs = {"shield": "braking", "max_episode_steps": 150, "time_limit": 150}
    batch = train.evaluate(Steer(), CP, 3, 40, **kwargs)
    rows = []
    for k in range(3):
        env = gym.make(CP, **kwargs)
        obs, _ = env.reset(seed=40 + k)
        ret, done = 0.0, False
        while not done:
            obs, reward, terminated, truncated, info = env.step(Steer().predict(obs)[0])
            ret += float(reward)
            done = terminated or truncated
        s = info["shieldnav_episode"]
        rows.append((ret, s["collisions"] > 0, s["deadlock"], s["coverage"], s["contact_time"]))
        env.close()
    r = np.asarray(rows, dtype=float).mean(axis=0)
    assert batch["coverage"] > 0
    np.testing.assert_allclose([batch[k] for k in ("return", "episodes_with_contact", "deadlock_rate", "coverage", "contact_time")], r,
                               rtol=1e-6, atol=1e-9)


def small_hyperparams(tmp_path: Path, **keys: object) -> Path:
    """A hyperparameter file for ConstrictedPassage with rollouts small enough for a smoke test."""
    block = {"policy": "MlpPolicy", "n_envs": 2, "n_timesteps": 128, "n_steps": 32, "batch_size": 32, "n_epochs": 2, **keys}
    path = tmp_path / "ppo.yml"
    path.write_text(yaml.safe_dump({CP: block}))
    return path


@pytest.mark.filterwarnings("ignore:You have specified a mini-batch size")  # two environments, not the block's
def test_the_shipped_hyperparameter_files_hold_every_environment_and_build_their_algorithm():
    for algo, Algo in train.ALGOS.items():
        for env_id in ENV_IDS:
            block = train.hyperparameters(algo, env_id)
            assert block["n_envs"] >= 1 and block["n_timesteps"] >= 1 and block["policy"] == "MlpPolicy"
            venv = ShieldnavVecEnv(env_id, num_envs=2)
            keys = {k: v for k, v in block.items() if k not in train.RUN_KEYS}
            Algo(block["policy"], venv, device="cpu", **keys)  # every key is a constructor keyword
            venv.close()


def test_the_command_line_takes_its_defaults_from_the_hyperparameter_file(tmp_path):
    hp = small_hyperparams(tmp_path, learning_rate=0.001)
    train.main(["--env", CP, "--hyperparams", str(hp), "--eval-every", "64", "--eval-episodes", "1", "--max-episode-steps", "20",
                "--out", str(tmp_path / "run"), "--no-progress", "--no-tensorboard"])
    meta = json.loads((tmp_path / "run" / "run.json").read_text())
    assert (meta["num_envs"], meta["timesteps"], meta["training_safety"]["steps"]) == (2, 128, 128)
    assert meta["hyperparams"] == {"n_steps": 32, "batch_size": 32, "n_epochs": 2, "learning_rate": 0.001}
    train.main(["--env", CP, "--hyperparams", str(hp), "--num-envs", "1", "--timesteps", "64", "--eval-every", "64", "--eval-episodes", "1",
                "--max-episode-steps", "20", "--out", str(tmp_path / "flags"), "--no-progress", "--no-tensorboard"])
    meta = json.loads((tmp_path / "flags" / "run.json").read_text())
    assert (meta["num_envs"], meta["timesteps"]) == (1, 64), "flags override the file"


@pytest.mark.parametrize("content, message", [
    (None, "cannot read"),
    ("a: [", "is not YAML"),
    ("shieldnav/CorridorInspection-v0: {n_envs: 2}", "has no block for 'shieldnav/ConstrictedPassage-v0'"),
    (f"{CP}: {{n_envs: 0}}", "`n_envs` must be a whole number ≥ 1, got 0"),
    (f"{CP}: {{n_timesteps: 1.5}}", "`n_timesteps` must be a whole number ≥ 1, got 1.5"),
    (f"{CP}: {{n_envs: 2, n_stepz: 32}}", "invalid `hyperparams` for ppo on shieldnav/ConstrictedPassage-v0"),
    (f"{CP}: {{n_envs: 2, n_steps: 32, batch_size: 1}}", "invalid `hyperparams` for ppo on shieldnav/ConstrictedPassage-v0"),
])
def test_a_bad_hyperparameter_file_is_named_before_the_run_folder_is_made(content, message, tmp_path):
    path = tmp_path / "hp.yml"
    if content is not None:
        path.write_text(content)
    with pytest.raises(InvalidArgumentError, match=re.escape(message)):
        train.train("ppo", CP, "braking", 64, None, 0, tmp_path / "run", progress=False, tensorboard=False, hyperparams_file=path)
    assert not (tmp_path / "run").exists()
