"""shieldnav.testing (episode checks) and its pytest plugin."""

import importlib.metadata
import pickle

import numpy as np
import pytest
from shieldnav import InvalidArgumentError
from shieldnav.testing import (
    EpisodeSummary,
    assert_coverage_at_least,
    assert_no_contact,
    assert_no_deadlock,
    assert_safe_episodes,
    cases,
    run_episodes,
)

pytest_plugins = ["pytester"]

CP = "shieldnav/ConstrictedPassage-v0"


def sideways(obs, info):
    """Straight into the passage's side wall (contact at step 89 without a shield)."""
    return np.array([0.0, 1.0, 0.0], dtype=np.float32)


def zero(obs, info):
    return np.zeros(3, dtype=np.float32)


def test_wall_policy_fails_no_contact_naming_seed_and_step():
    summaries = run_episodes(sideways, CP, seeds=[3], workers=1, max_steps=120, shield="none")
    (row,) = summaries
    assert isinstance(row, EpisodeSummary) and row.first_contact_step is not None and row.contact_steps > 0
    with pytest.raises(AssertionError) as err:
        assert_no_contact(summaries)
    msg = str(err.value)
    assert CP in msg and "seed 3" in msg and f"step {row.first_contact_step}" in msg and f"t = {row.first_contact_time:.2f} s" in msg


def test_zero_policy_fails_the_deadlock_check():
    summaries = run_episodes(zero, CP, seeds=[0], workers=1, max_steps=200, deadlock_window=1.0, truncate_on_deadlock=True)
    (row,) = summaries
    assert row.deadlock and row.first_deadlock_step == row.steps
    assert_no_contact(summaries)
    with pytest.raises(AssertionError, match=r"seed 0: deadlock detected at step \d+ \(t = 1\.00 s\)"):
        assert_no_deadlock(summaries)
    with pytest.raises(AssertionError, match="coverage"):
        assert_coverage_at_least(summaries, 0.5)
    with pytest.raises(AssertionError, match="deadlock detected.*coverage"):
        assert_safe_episodes(summaries, min_coverage=0.5)


def test_scripted_agent_passes_a_short_constricted_passage():
    summaries = run_episodes("scripted", "ConstrictedPassage-v0", seeds=[0, 1], workers=1, max_steps=150)
    assert [r.seed for r in summaries] == [0, 1] and all(r.steps == 150 for r in summaries)
    assert_safe_episodes(summaries, min_coverage=0.01)


def test_one_and_two_workers_give_the_same_summaries():
    ids, seeds = [CP, "shieldnav/DynamicObstacles-v0"], [2, 0]
    one = run_episodes("scripted", ids, seeds, workers=1, max_steps=60)
    two = run_episodes("scripted", ids, seeds, workers=2, max_steps=60)
    assert list(one) == list(two)
    assert [(r.env_id, r.seed) for r in one] == [(CP, 0), (CP, 2), ("shieldnav/DynamicObstacles-v0", 0), ("shieldnav/DynamicObstacles-v0", 2)]


def test_shipped_and_stateful_policies():
    class Counter:
        """A stateful policy: reset per episode, so episodes do not see each other's state."""

        def __init__(self):
            self.n = 0

        def reset(self):
            self.n = 0

        def __call__(self, obs, info):
            self.n += 1
            return np.array([0.0, 1.0 if self.n > 20 else 0.0, 0.0], np.float32)

    a = run_episodes(Counter(), CP, seeds=[0, 1], workers=1, max_steps=130, shield="none")
    assert a[0].first_contact_step == a[1].first_contact_step == 89 + 20
    ppo = run_episodes("ppo", CP, seeds=[0], workers=1, max_steps=30)
    assert ppo[0].steps == 30


def test_lambda_runs_in_process_or_is_a_clear_error():
    table = run_episodes(lambda o, i: np.zeros(3, np.float32), CP, seeds=[0, 1], max_steps=10)
    assert len(table) == 2
    with pytest.raises(InvalidArgumentError, match="cannot be pickled.*workers=1"):
        run_episodes(lambda o, i: np.zeros(3, np.float32), CP, seeds=[0, 1], workers=2, max_steps=10)


@pytest.mark.parametrize(
    "kwargs, name",
    [
        (dict(env_ids="Nowhere-v0"), "env_ids"),
        (dict(env_ids=[]), "env_ids"),
        (dict(seeds=[]), "seeds"),
        (dict(seeds=[-1]), "seeds"),
        (dict(seeds="abc"), "seeds"),
        (dict(workers=-1), "workers"),
        (dict(workers=0), "workers"),
        (dict(policy=42), "policy"),
        (dict(policy="sb3"), "policy"),
        (dict(max_steps=0), "max_steps"),
        (dict(render_mode="rgb_array"), "render_mode"),
        (dict(vectorised="yes"), "vectorised"),
        (dict(policy="scripted", vectorised=True), "vectorised"),
        (dict(vectorised=True, observation="dict"), "vectorised"),
        (dict(env_ids="no_such_map.yaml"), "env_ids"),
        (dict(env_ids="notes.txt"), "env_ids"),
    ],
)
def test_bad_arguments_are_clear_errors(kwargs, name):
    args = dict(policy=zero, env_ids=CP, seeds=[0], max_steps=5)
    args.update(kwargs)
    with pytest.raises(InvalidArgumentError, match=f"invalid `{name}`"):
        run_episodes(args.pop("policy"), args.pop("env_ids"), args.pop("seeds"), **args)


def test_bad_assertion_arguments():
    with pytest.raises(InvalidArgumentError, match="summaries"):
        assert_no_contact([{"seed": 0}])
    with pytest.raises(InvalidArgumentError, match="minimum"):
        assert_coverage_at_least([], 1.5)


def test_gif_of_a_failing_episode(tmp_path):
    summaries = run_episodes(sideways, CP, seeds=[0], workers=1, max_steps=100, shield="none", gif_dir=tmp_path / "gifs")
    with pytest.raises(AssertionError, match="GIF of") as err:
        assert_no_contact(summaries)
    (gif,) = (tmp_path / "gifs").glob("*.gif")
    assert gif.name == "ConstrictedPassage-v0-seed0-contact.gif" and str(gif) in str(err.value)


def test_cases_and_pickling():
    params = cases(["ConstrictedPassage-v0", "shieldnav/OdometryJump-v0"], range(2))
    assert [p.id for p in params] == ["ConstrictedPassage-v0-seed0", "ConstrictedPassage-v0-seed1", "OdometryJump-v0-seed0", "OdometryJump-v0-seed1"]
    assert params[0].values == (CP, 0)
    row = run_episodes(zero, CP, [0], workers=1, max_steps=3)[0]
    assert pickle.loads(pickle.dumps(row)) == row


def _plugin_args():
    """``-p shieldnav.pytest_plugin`` unless the installed package's entry point loads it already."""
    names = {ep.value for ep in importlib.metadata.entry_points(group="pytest11")}
    return [] if "shieldnav.pytest_plugin" in names else ["-p", "shieldnav.pytest_plugin"]


USER_TESTS = '''
import numpy as np
import pytest
from shieldnav.testing import assert_no_contact, assert_safe_episodes, cases


def sideways(obs, info):
    return np.array([0.0, 1.0, 0.0], dtype=np.float32)


def test_env_fixture(shieldnav_env):
    env = shieldnav_env("ConstrictedPassage-v0", time_limit=5)
    obs, info = env.reset(seed=0)
    assert env.observation_space.contains(obs)


@pytest.mark.parametrize("env_id, seed", cases(["ConstrictedPassage-v0"], [0]))
def test_scripted(shieldnav_runner, env_id, seed):
    assert_safe_episodes(shieldnav_runner("scripted", env_id, [seed], max_steps=40))


def test_wall(shieldnav_runner):
    assert_no_contact(shieldnav_runner(sideways, "ConstrictedPassage-v0", [1], max_steps=100, shield="none"))
'''


def test_plugin_fixtures_gif_dir_and_summary(pytester):
    pytester.makepyfile(test_user=USER_TESTS)
    gifs = pytester.path / "gifs"
    result = pytester.runpytest_subprocess(*_plugin_args(), f"--shieldnav-gif-dir={gifs}", "--shieldnav-workers=1", "-p", "no:cacheprovider")
    result.assert_outcomes(passed=2, failed=1)
    result.stdout.fnmatch_lines(["*ConstrictedPassage-v0 seed 1: first contact at step 89 (t = 1.78 s)*"])
    result.stdout.fnmatch_lines(["shieldnav: 2 episodes run, 1 with a contact, 0 with a deadlock"])
    assert (gifs / "ConstrictedPassage-v0-seed1-contact.gif").is_file()


def test_plugin_under_pytest_xdist(pytester):
    pytester.makepyfile(test_user=USER_TESTS)
    result = pytester.runpytest_subprocess(*_plugin_args(), "-n", "2", "-p", "no:cacheprovider")
    result.assert_outcomes(passed=2, failed=1)
    result.stdout.fnmatch_lines(["*2 workers*"])
    # the controller adds up the workers' counts
    result.stdout.fnmatch_lines(["shieldnav: 2 episodes run, 1 with a contact, 0 with a deadlock"])


def test_an_sb3_like_model_acts_deterministically():
    class Model:
        """What run_episodes reads of an SB3 model: ``predict(obs, deterministic=True) -> (action, state)``."""

        def predict(self, obs, deterministic=False):
            assert deterministic
            action = np.array([0.0, 1.0, 0.0], np.float32)
            return (np.tile(action, (len(obs), 1)) if np.ndim(obs) == 2 else action), None

    on_batch = run_episodes(Model(), CP, [0], workers=1, max_steps=100, shield="none")
    in_process = run_episodes(Model(), CP, [0], workers=1, max_steps=100, shield="none", vectorised=False)
    assert on_batch.vectorised and list(on_batch) == list(in_process)
    assert on_batch[0].first_contact_step == 89


def test_a_stable_baselines3_model_runs_on_the_batch():
    import gymnasium as gym
    from stable_baselines3 import PPO

    model = PPO("MlpPolicy", gym.make("shieldnav/CorridorInspection-v0"), seed=0, device="cpu")
    table = run_episodes(model, "CorridorInspection-v0", range(3), max_steps=50)
    assert table.vectorised and [r.steps for r in table] == [50, 50, 50]


def test_an_unguarded_script_with_workers_is_a_clear_error(tmp_path):
    import subprocess
    import sys

    script = "from shieldnav.testing import run_episodes\nrun_episodes('scripted', 'ConstrictedPassage-v0', [0, 1], workers=2, max_steps=3)\n"
    out = subprocess.run([sys.executable, "-"], input=script, capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert out.returncode != 0 and "ShieldnavError" in out.stderr and 'if __name__ == "__main__"' in out.stderr


class Steer:
    """Ahead at 0.8 m/s, turning by the difference of two range bins: elementwise, so its actions
    on a batch are its actions one observation at a time, bit for bit."""

    def act_batch(self, obs, info):
        obs = np.atleast_2d(obs)
        a = np.zeros((obs.shape[0], 3), np.float32)
        a[:, 0] = 0.8
        a[:, 2] = obs[:, 16] - obs[:, 48]
        return a


def sideways_batch(obs, info):
    return np.tile(np.array([0.0, 1.0, 0.0], np.float32), (len(obs), 1))


def test_the_native_batch_gives_the_process_path_summaries():
    ids = [CP, "shieldnav/CorridorInspection-v0"]
    batch = run_episodes(Steer(), ids, range(3), max_steps=200, workers=1)
    procs = run_episodes(Steer(), ids, range(3), max_steps=200, workers=2, vectorised=False)
    two_threads = run_episodes(Steer(), ids, range(3), max_steps=200, workers=2)
    assert batch.vectorised and two_threads.vectorised and not procs.vectorised
    assert list(batch) == list(procs) == list(two_threads)
    assert [(r.env_id, r.seed) for r in batch] == [(e, s) for e in sorted(ids) for s in range(3)]


def test_a_forced_batch_policy_fails_naming_seed_step_and_reruns_for_a_gif(tmp_path):
    table = run_episodes(sideways_batch, CP, [0, 1], max_steps=150, shield="none", vectorised=True, gif_dir=tmp_path)
    assert table.vectorised and all(r.first_contact_step for r in table)
    with pytest.raises(AssertionError, match=r"ConstrictedPassage-v0 seed 1: first contact at step \d+") as err:
        assert_no_contact(table)
    assert "GIF of" in str(err.value) and list(tmp_path.glob("*.gif"))
    # the single-environment re-run sees the same episode
    first = table[0]
    assert table.rerun(first).first_contact_step == first.first_contact_step


def test_a_batch_policy_returning_the_wrong_shape_is_a_clear_error():
    with pytest.raises(InvalidArgumentError, match=r"invalid `policy`: on a batch of 2 observations .* shape \(3,\)"):
        run_episodes(zero, CP, [0, 1], max_steps=5, vectorised=True)


def test_the_shipped_policy_runs_on_the_batch():
    table = run_episodes("ppo", "CorridorInspection-v0", range(2), max_steps=100)
    assert table.vectorised and len(table) == 2 and all(r.steps == 100 for r in table)


def test_map_and_scenario_files_as_inputs(tmp_path):
    from shieldnav.maps import DEFAULT_MAP

    scen = tmp_path / "corridor.json"
    scen.write_text(
        '{"name": "mine", "walls": [{"a": [0, -1], "b": [20, -1], "height": 2.0}, {"a": [0, 1], "b": [20, 1], "height": 2.0}],'
        ' "start": {"x": 2, "y": 0, "yaw": 0}}'
    )
    table = run_episodes(sideways, [scen, str(DEFAULT_MAP)], [0], max_steps=60, shield="none", workers=1)
    by_file = {r.env_id: r for r in table}
    assert set(by_file) == {str(scen), str(DEFAULT_MAP)}
    # 1 m from the +y wall, driven at it without a shield
    assert by_file[str(scen)].first_contact_step is not None
    with pytest.raises(AssertionError, match=r"corridor.json seed 0: first contact"):
        assert_no_contact(table)
    assert [p.id for p in cases([scen], [2])] == ["corridor-seed2"]
    # the same file on the native batch: the same episode
    batch = run_episodes(sideways_batch, scen, [0], max_steps=60, shield="none", vectorised=True)
    assert list(batch) == [by_file[str(scen)]]


def test_the_example_test_file_passes(pytester):
    from pathlib import Path

    example = Path(__file__).resolve().parents[1] / "examples" / "test_my_controller.py"
    pytester.makepyfile(test_example=example.read_text())
    result = pytester.runpytest_subprocess(*_plugin_args(), "-p", "no:cacheprovider")
    result.assert_outcomes(passed=10)
    result.stdout.fnmatch_lines(["shieldnav: 31 episodes run, 0 with a contact, 0 with a deadlock"])
