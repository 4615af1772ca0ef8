"""The benchmark harness: its files hold the paper's outcomes, a policy can be swapped in, an
interrupted run keeps what finished."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from agents import benchmark


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


def test_bad_policy_is_a_clear_error(tmp_path):
    from shieldnav import InvalidArgumentError

    with pytest.raises(InvalidArgumentError, match="policy"):
        benchmark.main(["--quick", "--policy", "nonsense", "--workers", "1", "--out", str(tmp_path)])


def test_interrupted_run_keeps_finished_episodes(monkeypatch):
    todo = benchmark.tasks(["shieldnav/ConstrictedPassage-v0"], ["composite", "none"], 1, "scripted", video=False, steps=50)

    def source(_todo, _workers):
        yield benchmark.run_episode(_todo[0])
        raise KeyboardInterrupt

    monkeypatch.setattr(benchmark, "run_local", source)
    results = benchmark.run(todo, "local", 1)
    assert len(results) == 1 and results[0]["task"]["shield"] == "composite"


def test_ray_backend_gives_the_local_numbers(tmp_path):
    import ray

    args = ["--scenarios", "shieldnav/ConstrictedPassage-v0", "shieldnav/DynamicObstacles-v0", "--shields", "composite", "none",
            "--seeds", "1", "--workers", "2", "--max-steps", "300", "--no-plots"]
    local = benchmark.main(args + ["--out", str(tmp_path / "local")])
    try:
        remote = benchmark.main(args + ["--backend", "ray", "--out", str(tmp_path / "ray")])
    finally:
        ray.shutdown()
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
