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


def test_an_sb3_like_model_acts_deterministically():
    class Model:
        """What run_episodes reads of an SB3 model: ``predict(obs, deterministic=True) -> (action, state)``."""

        def predict(self, obs, deterministic=False):
            assert deterministic
            return np.array([0.0, 1.0, 0.0], np.float32), None

    (row,) = run_episodes(Model(), CP, [0], workers=1, max_steps=100, shield="none")
    assert row.first_contact_step == 89


def test_an_unguarded_script_with_workers_is_a_clear_error(tmp_path):
    import subprocess
    import sys

    script = "from shieldnav.testing import run_episodes\nrun_episodes('scripted', 'ConstrictedPassage-v0', [0, 1], workers=2, max_steps=3)\n"
    out = subprocess.run([sys.executable, "-"], input=script, capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert out.returncode != 0 and "ShieldnavError" in out.stderr and 'if __name__ == "__main__"' in out.stderr
