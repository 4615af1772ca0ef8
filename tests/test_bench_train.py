"""The training benchmark runs end to end and reports what it measured."""

import json
import sys
from pathlib import Path

import pytest

pytest.importorskip("stable_baselines3")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks import bench_train  # noqa: E402


@pytest.mark.expensive
def test_bench_train_reports_speed_time_to_the_scripted_coverage_and_no_training_contact(tmp_path):
    out = tmp_path / "bench_train.json"
    rows = bench_train.main(["--timesteps", "2048", "--eval-every", "1024", "--configs", "sb3-8x256", "--env-seconds", "0.2",
                             "--out", str(out)])
    assert [r["config"] for r in rows] == ["env alone, 256 envs", "sb3-8x256"]
    assert all(r["steps_per_s"] > 0 for r in rows)
    run = rows[1]
    # the steps asked for, trained under the braking shield without a contact, evaluated twice
    assert run["steps"] == 2048 and run["training_contact_steps"] == 0 and run["num_envs"] == 8
    assert [step for step, _ in run["curve"]] == [1024, 2048] and run["final_coverage"] == run["curve"][-1][1]
    target = json.loads(out.read_text())["meta"]["scripted_coverage"]["0"]
    assert 0 < target < 1
    reached = [step for step, coverage in run["curve"] if coverage >= target]
    assert run["to_scripted_steps"] == (reached[0] if reached else None)
    assert (run["to_scripted_s"] is None) == (not reached)
    assert run["to_scripted_s"] is None or 0 < run["to_scripted_s"] < run["training_s"] + 60
