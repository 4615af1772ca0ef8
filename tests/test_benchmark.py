"""The benchmark harness: its files hold the paper's outcomes, a policy can be swapped in, an
interrupted run keeps what finished."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from agents import benchmark


@pytest.mark.expensive
def test_benchmark_json_holds_the_papers_outcomes(tmp_path):
    rows = benchmark.main([
        "--scenarios", "shieldnav/ConstrictedPassage-v0", "shieldnav/OdometryJump-v0", "shieldnav/DynamicObstacles-v0",
        "--shields", "composite", "distance", "none", "--seeds", "1", "--workers", "2", "--out", str(tmp_path), "--no-video",
    ])
    data = json.loads((tmp_path / "benchmark.json").read_text())
    agg = {(r["scenario"], r["shield"]): r for r in data["aggregate"]}
    assert agg == {k: {"scenario": k[0], "shield": k[1], **v} for k, v in rows.items()}
    s1, s2, s3 = (f"shieldnav/{n}-v0" for n in ("ConstrictedPassage", "OdometryJump", "DynamicObstacles"))
    # Scenario 1: the composite passes, the distance shield deadlocks
    assert agg[(s1, "composite")]["success_rate"] == 1.0 and agg[(s1, "composite")]["with_contact"] == 0
    assert agg[(s1, "distance")]["deadlock_rate"] == 1.0 and agg[(s1, "distance")]["success_rate"] == 0.0
    # Scenarios 2 and 3: no contact under the composite shield, contacts without one
    for s in (s2, s3):
        assert agg[(s, "composite")]["with_contact"] == 0
        assert agg[(s, "none")]["with_contact"] == 1
    with open(tmp_path / "benchmark.csv") as f:
        assert len(list(csv.DictReader(f))) == 9
    for name in ("ConstrictedPassage-v0", "OdometryJump-v0", "DynamicObstacles-v0"):
        assert (tmp_path / f"{name}.png").stat().st_size > 10_000
    assert len(data["episodes"]) == 9


def always_forward(env):
    return lambda obs, info: np.array([0.5, 0.0, 0.0], np.float32)


def test_a_module_callable_policy_is_benchmarked(tmp_path):
    rows = benchmark.main([
        "--scenarios", "shieldnav/ConstrictedPassage-v0", "--shields", "composite", "--seeds", "1", "--workers", "1",
        "--policy", "tests.test_benchmark:always_forward", "--out", str(tmp_path), "--no-plots",
    ])
    row = rows[("shieldnav/ConstrictedPassage-v0", "composite")]
    # straight ahead at 0.8 m/s along y = 0: the composite steers it through the gap to the goal
    assert row["success_rate"] == 1.0 and row["with_contact"] == 0


CP = "shieldnav/ConstrictedPassage-v0"


def raising_factory(env):
    raise RuntimeError("no weights here")


def no_policy(env):
    return None


def two_numbers(env):
    return lambda obs, info: np.zeros(2, np.float32)


def too_fast(env):
    return lambda obs, info: np.array([2.0, 0.0, 0.0], np.float32)


def failing_act(env):
    def act(obs, info):
        raise KeyError("lidar")
    return act


@pytest.mark.parametrize("args, message", [
    (["--seeds", "0"], "argument --seeds: must be at least 1, got 0"),
    (["--workers", "0"], "argument --workers: must be at least 1, got 0"),
    (["--workers", "-1"], "argument --workers: must be at least 1, got -1"),
    (["--max-steps", "0"], "argument --max-steps: must be at least 1, got 0"),
    (["--max-steps", "-3"], "argument --max-steps: must be at least 1, got -3"),
    (["--scenarios", "bogus"], "argument --scenarios: unknown environment id 'bogus'"),
    (["--scenarios", CP, CP], f"argument --scenarios: {CP} given more than once"),
    (["--shields", "none", "none"], "argument --shields: none given more than once"),
    (["--policy", "nonsense"], "argument --policy: invalid `policy`: expected 'scripted'"),
    (["--policy", "nosuch.mod:f"], "argument --policy: invalid `policy`: cannot import the module 'nosuch.mod'"),
    (["--policy", "shieldnav.scripted:nosuch"], "argument --policy: invalid `policy`: the module 'shieldnav.scripted' has no 'nosuch'"),
    (["--policy", "missing.zip"], "the model file missing.zip does not exist"),
    (["--policy", "os:getcwd"], "argument --policy: invalid `policy`: os:getcwd(env) raised TypeError"),
    (["--policy", "tests.test_benchmark:raising_factory"],
     "argument --policy: invalid `policy`: tests.test_benchmark:raising_factory(env) raised RuntimeError: no weights here"),
    (["--policy", "tests.test_benchmark:no_policy"],
     "argument --policy: invalid `policy`: tests.test_benchmark:no_policy(env) returned NoneType, not a callable act(obs, info)"),
    (["--policy", "tests.test_benchmark:two_numbers"],
     "argument --policy: invalid `policy`: tests.test_benchmark:two_numbers's action does not fit Box(-1.0, 1.0, (3,), float32): "
     "invalid `action`: expected shape (3,)"),
    (["--policy", "tests.test_benchmark:too_fast"], "tests.test_benchmark:too_fast's action does not fit Box(-1.0, 1.0, (3,), float32)"),
    (["--policy", "tests.test_benchmark:failing_act"],
     "argument --policy: invalid `policy`: tests.test_benchmark:failing_act raised KeyError on a reset observation: 'lidar'"),
    (["--out", "/proc/shieldnav"], "argument --out: cannot write to the folder /proc/shieldnav"),
    (["--ray-address", "auto"], "argument --ray-address: needs --backend ray"),
])
def test_user_errors_are_usage_errors_naming_the_option_before_any_episode(args, message, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(benchmark, "run", lambda *a: pytest.fail("episodes ran"))
    with pytest.raises(SystemExit) as exc:
        benchmark.main(["--shields", "none", "--workers", "1", "--max-steps", "50", "--out", str(tmp_path / "out"), *args])
    assert exc.value.code == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("module", ["agents.report", "agents.episodes"])
def test_library_modules_say_which_modules_are_command_lines(module):
    root = Path(__file__).resolve().parents[1]
    done = subprocess.run([sys.executable, "-m", module, "--help"], cwd=root, capture_output=True, text=True, timeout=60)
    assert done.returncode == 2 and not done.stdout
    assert done.stderr.splitlines() == [f"{module} is not a command line; the command lines are python -m agents.train, "
                                        "agents.benchmark and agents.sweep (each with --help)"]


def test_an_out_path_that_is_a_file_is_refused_before_any_episode(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(benchmark, "run", lambda *a: pytest.fail("episodes ran"))
    (tmp_path / "file").write_text("")
    with pytest.raises(SystemExit) as exc:
        benchmark.main(["--quick", "--out", str(tmp_path / "file")])
    assert exc.value.code == 2 and f"argument --out: {tmp_path / 'file'} is a file" in capsys.readouterr().err


def test_scenarios_and_seeds_win_over_quick(tmp_path, monkeypatch):
    ran = []
    monkeypatch.setattr(benchmark, "run", lambda todo, *a: ran.extend(todo) or [])
    benchmark.main(["--quick", "--scenarios", CP, "--seeds", "2", "--shields", "none", "--out", str(tmp_path)])
    assert [(t["env_id"], t["seed"]) for t in ran] == [(CP, 0), (CP, 1)]
    ran.clear()
    benchmark.main(["--quick", "--shields", "none", "--out", str(tmp_path)])
    assert [(t["env_id"], t["seed"]) for t in ran] == [(s, 0) for s in benchmark.PAPER]


def test_a_model_for_other_spaces_is_refused_naming_the_file(tmp_path, capsys):
    pytest.importorskip("torch")
    import gymnasium as gym
    from stable_baselines3 import PPO

    path = tmp_path / "cartpole.zip"
    PPO("MlpPolicy", gym.make("CartPole-v1"), n_steps=64, batch_size=64).save(path)
    with pytest.raises(SystemExit) as exc:
        benchmark.main(["--scenarios", CP, "--shields", "none", "--seeds", "1", "--workers", "1", "--policy", str(path),
                        "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert exc.value.code == 2
    assert f"argument --policy: invalid `policy`: {path} was made for the observation space Box of shape (4,)" in err
    assert f"{CP} has Box of shape (73,)" in err


def strict_json(path):
    """The file as JSON, refusing the NaN and Infinity that json.loads accepts by default."""
    def refuse(name):
        raise ValueError(f"{path} holds {name}: not JSON")

    return json.loads(path.read_text(), parse_constant=refuse)


def test_benchmark_json_is_valid_json_with_null_for_no_deadlock_time(tmp_path):
    benchmark.main(["--scenarios", CP, "--shields", "none", "--seeds", "1", "--workers", "1", "--max-steps", "50",
                    "--out", str(tmp_path), "--no-plots"])
    summary = strict_json(tmp_path / "benchmark.json")["episodes"][0]["summary"]
    assert not summary["deadlock"] and summary["deadlock_time"] is None


def test_to_json_writes_null_for_non_finite_numbers():
    from agents import report

    text = report.to_json({"a": np.float64("nan"), "b": [float("inf"), np.int32(3)], "c": np.array([1.5, -np.inf])})
    assert json.loads(text) == {"a": None, "b": [None, 3], "c": [1.5, None]}


def test_steps_per_s_leaves_out_the_video_frames(monkeypatch):
    """Seed 0 of the composite records the GIF: its steps/s times the stepping only, so it is
    comparable with an episode without frames (timing the rendering made it 20-80 times
    slower). Checked on a fake clock that a step advances by 1 s and drawing a frame by 1000 s:
    exactly 1 step/s means no drawing was timed."""
    from shieldnav.env import CorridorInspectionEnv
    from shieldnav.rendering import TopDownRenderer

    from agents import episodes

    clock = [0.0]

    def ticking(method, seconds):
        def wrapped(*args, **kwargs):
            clock[0] += seconds
            return method(*args, **kwargs)
        return wrapped

    monkeypatch.setattr(episodes.time, "perf_counter", lambda: clock[0])
    monkeypatch.setattr(CorridorInspectionEnv, "step", ticking(CorridorInspectionEnv.step, 1.0))
    monkeypatch.setattr(CorridorInspectionEnv, "render_frame", ticking(CorridorInspectionEnv.render_frame, 1000.0))
    monkeypatch.setattr(TopDownRenderer, "draw", ticking(TopDownRenderer.draw, 1000.0))
    task = benchmark.tasks([CP], ["composite"], 1, "scripted", video=True, steps=100)[0]
    result = benchmark.run_episode(task)
    frames = result["frames"]
    assert len(frames) == 100 // benchmark.VIDEO_EVERY and frames[0].ndim == 3 and frames[0].dtype == np.uint8
    assert clock[0] > 1000.0 * len(frames), "the frames were drawn"
    assert result["steps_per_s"] == 1.0


def test_interrupted_run_keeps_finished_episodes(monkeypatch):
    todo = benchmark.tasks(["shieldnav/ConstrictedPassage-v0"], ["composite", "none"], 1, "scripted", video=False, steps=50)

    def source(_todo, _workers):
        yield benchmark.run_episode(_todo[0])
        raise KeyboardInterrupt

    monkeypatch.setattr(benchmark, "run_local", source)
    results = benchmark.run(todo, "local", 1)
    assert len(results) == 1 and results[0]["task"]["shield"] == "composite"


@pytest.mark.expensive
def test_ray_backend_gives_the_local_numbers(tmp_path, monkeypatch):
    import shutil
    import tempfile

    import ray

    # Ray's session folders (logs, sockets) in a short folder of the test's, not /tmp/ray
    # (a socket path must stay under 108 bytes: pytest's tmp_path is too long)
    ray_tmp = tempfile.mkdtemp(prefix="ray")
    monkeypatch.setenv("RAY_TMPDIR", ray_tmp)
    args = ["--scenarios", "shieldnav/ConstrictedPassage-v0", "shieldnav/DynamicObstacles-v0", "--shields", "composite", "none",
            "--seeds", "1", "--workers", "2", "--max-steps", "300", "--no-plots"]
    local = benchmark.main(args + ["--out", str(tmp_path / "local")])
    try:
        remote = benchmark.main(args + ["--backend", "ray", "--out", str(tmp_path / "ray")])
    finally:
        ray.shutdown()
        shutil.rmtree(ray_tmp, ignore_errors=True)
    timing = ("shield_us_mean", "shield_us_p99_6", "shield_us_max", "steps_per_s")
    assert local.keys() == remote.keys()
    for key in local:
        assert {k: v for k, v in local[key].items() if k not in timing} == {k: v for k, v in remote[key].items() if k not in timing}


def test_figures_skip_the_empty_scan_sentinel_and_zero_times(tmp_path):
    """A scan with no point in the crop gives H = h_min = f64::MAX, and a shield call can time
    at 0 µs: the figure draws neither (no overflow on the axes) and is still written."""
    import warnings

    from agents import report

    big = np.finfo(np.float64).max
    n = 50
    trace = {"t": np.arange(n) * 0.02, "u_nom": np.zeros((n, 3)), "u_star": np.zeros((n, 3)),
             "H": np.r_[np.full(10, big), np.linspace(1.0, 0.2, n - 10)],
             "h_min": np.r_[np.full(10, big), np.linspace(1.5, 0.3, n - 10)]}
    timing = {"composite": (np.r_[np.zeros(5), np.full(n - 5, 2.0)], np.full(n, 100))}
    path = tmp_path / "fig.png"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        report.plot_scenario("test", {"composite": trace}, timing, path)
    assert path.stat().st_size > 10_000
